"""``metrics.csv``: what learning looks like between evaluations, per chunk and seed.

One row per evaluation chunk and lane of a run folder (a sweep point's folder holds its own
lanes): ``step`` (env steps done), ``seed``, ``updates`` (TD3 updates in the chunk),
``critic_loss`` and ``q_mean`` (means over those updates of L_Q and of Q₁ on the sampled
batches), ``actor_updates`` and ``actor_loss`` (mean L_μ over them), ``episodes`` (training
episodes finished so far) and ``last_episode_return`` (return of the last finished training
episode, nan before the first). Written as the run goes; a resumed run drops the rows after its
checkpoint first (:func:`swim_jax.learned_params.truncate_after`).
"""

from __future__ import annotations

import csv
import os

import numpy as np

FILENAME = "metrics.csv"
COLUMNS = ("step", "seed", "updates", "critic_loss", "q_mean", "actor_updates", "actor_loss",
           "episodes", "last_episode_return")


def combine(calls: list) -> dict[str, np.ndarray]:
    """Merge the :class:`agents.loop.ChunkMetrics` of the calls making one chunk into per-lane
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


def append(path: str, step: int, seed_ids, chunk: dict[str, np.ndarray], episodes, last_return) -> None:
    """Append one row per lane (``seed_ids[i]``, ``chunk[...][i]``, ...) for ``step``."""
    new = not os.path.exists(path)
    with open(path, "a", newline="") as f:
        w = csv.writer(f)
        if new:
            w.writerow(COLUMNS)
        for i, seed in enumerate(seed_ids):
            w.writerow([step, int(seed), int(chunk["updates"][i]), repr(float(chunk["critic_loss"][i])),
                        repr(float(chunk["q_mean"][i])), int(chunk["actor_updates"][i]),
                        repr(float(chunk["actor_loss"][i])), int(episodes[i]), repr(float(last_return[i]))])


def read(path: str) -> dict[str, np.ndarray]:
    """``{column: array[rows]}`` of a metrics.csv (step, seed and counts as int, the rest float)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    ints = {"step", "seed", "updates", "actor_updates", "episodes"}
    return {c: np.asarray([(int if c in ints else float)(r[c]) for r in rows]) for c in COLUMNS}
