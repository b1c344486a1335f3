"""``metrics.csv``: what learning looks like between evaluations, per chunk and seed.

One row per evaluation chunk and lane of a run folder (a sweep point's folder holds its own
lanes): ``step`` (env steps done), ``seed``, ``updates`` (TD3 updates in the chunk),
``critic_loss`` and ``q_mean`` (means over those updates of L_Q and of Q₁ on the sampled
batches), ``actor_updates`` and ``actor_loss`` (mean L_μ over them), ``episodes`` (training
episodes finished so far) and ``last_episode_return`` (return of the last finished training
episode, nan before the first). Written as the run goes; a resumed run drops the rows after its
checkpoint first (:func:`swim_jax.run.learned_params.truncate_after`). With ``tensorboard=true`` the
same rows also go to TensorBoard event files (:mod:`swim_jax.io.tensorboard_log`);
``python -m swim_jax.report`` plots them (``learning.png``, via :mod:`swim_jax.analysis.runs_io`).
"""

from __future__ import annotations

import csv
import os

import numpy as np

FILENAME = "metrics.csv"
COLUMNS = ("step", "seed", "updates", "critic_loss", "q_mean", "actor_updates", "actor_loss",
           "episodes", "last_episode_return")
INT_COLUMNS = frozenset({"step", "seed", "updates", "actor_updates", "episodes"})


def combine(calls: list) -> dict[str, np.ndarray]:
    """Merge the :class:`swim_jax.agents.loop.ChunkMetrics` of the calls making one chunk into per-lane
    chunk values (count-weighted means; nan where no update of that kind ran)."""
    n = sum(np.asarray(c.updates, np.int64) for c in calls)
    na = sum(np.asarray(c.actor_updates, np.int64) for c in calls)

    def mean(field, counts, total):
        s = sum(np.where(np.asarray(getattr(c, counts)) > 0,
                         np.asarray(getattr(c, field), np.float64) * np.asarray(getattr(c, counts)), 0.0)
                for c in calls)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(total > 0, s / np.maximum(total, 1), np.nan)

    return {"updates": n, "critic_loss": mean("critic_loss", "updates", n),
            "q_mean": mean("q_mean", "updates", n), "actor_updates": na,
            "actor_loss": mean("actor_loss", "actor_updates", na)}


def chunk_rows(step: int, seed_ids, chunk: dict[str, np.ndarray], episodes, last_return) -> list[tuple]:
    """One row per lane, in :data:`COLUMNS` order, as Python numbers: ``(step, seed_ids[i],
    chunk["updates"][i], ..., episodes[i], last_return[i])``. What :func:`append` writes and
    :mod:`swim_jax.io.tensorboard_log` logs."""
    return [(int(step), int(seed), int(chunk["updates"][i]), float(chunk["critic_loss"][i]),
             float(chunk["q_mean"][i]), int(chunk["actor_updates"][i]), float(chunk["actor_loss"][i]),
             int(episodes[i]), float(last_return[i]))
            for i, seed in enumerate(seed_ids)]


def append(path: str, rows: list[tuple]) -> None:
    """Append :func:`chunk_rows` to the metrics.csv at ``path`` (header first when it is new); floats
    are written with ``repr``, so :func:`read` gives them back exactly."""
    new = not os.path.exists(path)
    with open(path, "a", newline="") as f:
        w = csv.writer(f)
        if new:
            w.writerow(COLUMNS)
        w.writerows([repr(v) if isinstance(v, float) else v for v in row] for row in rows)


def read(path: str) -> dict[str, np.ndarray]:
    """``{column: array[rows]}`` of a metrics.csv (step, seed and counts as int, the rest float).
    Raises ValueError naming a missing column, a row of another width or a cell that is not a number."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in COLUMNS if c not in (reader.fieldnames or ())]
        if missing:
            raise ValueError(f"missing column {missing[0]!r}")
        table = list(reader)
    for line, r in enumerate(table, 2):
        if None in r or None in r.values():
            raise ValueError(f"line {line} does not have the header's {len(reader.fieldnames)} fields "
                             f"(truncated file?)")
    return {c: np.asarray([(int if c in INT_COLUMNS else float)(r[c]) for r in table]) for c in COLUMNS}
