"""``metrics.csv``: what learning looks like between evaluations, per chunk and seed.

One row per evaluation chunk and lane of a run folder (a sweep point's folder holds its own
lanes): ``step`` (env steps done), ``seed``, then the agent's counts and metrics (what its update
reports, declared once in its module: ``swim_jax.agents.metrics.MetricSpec``), then ``episodes``
(training episodes finished so far) and ``last_episode_return`` (return of the last finished
training episode, nan before the first). Every agent reports at least :data:`COLUMNS`' counts and
metrics (all TD3 has): ``updates`` (updates in the chunk), ``critic_loss`` and ``q_mean`` (means
over those updates of L_Q and of Q₁ on the sampled batches), ``actor_updates`` (the updates that
stepped the actor) and ``actor_loss`` (its mean over them); SAC adds ``alpha_loss``, ``alpha`` and
``entropy`` after ``actor_loss``. Count columns (``updates``, ``*_updates``) are integers. Written as the run goes; a resumed run drops the rows after its
checkpoint first (:func:`swim_jax.run.learned_params.truncate_after`). With ``tensorboard=true`` the
same rows also go to TensorBoard event files (:mod:`swim_jax.io.tensorboard_log`);
``python -m swim_jax.report`` plots them (``learning.png``, via :mod:`swim_jax.analysis.runs_io`).
"""

from __future__ import annotations

import csv
import os

import numpy as np

FILENAME = "metrics.csv"
BASE_COLUMNS = ("step", "seed")  # before the agent's counts and metrics
TAIL_COLUMNS = ("episodes", "last_episode_return")  # after them
# the columns every metrics.csv has (every agent reports at least these counts and metrics: TD3's)
COLUMNS = ("step", "seed", "updates", "critic_loss", "q_mean", "actor_updates", "actor_loss",
           "episodes", "last_episode_return")


def columns(chunk_fields) -> tuple[str, ...]:
    """metrics.csv's columns for an agent whose chunk summary has ``chunk_fields`` (its counts and
    metrics, ``swim_jax.agents.metrics.MetricSpec.chunk_fields``)."""
    return (*BASE_COLUMNS, *chunk_fields, *TAIL_COLUMNS)


def is_count(column: str) -> bool:
    """Whether a column holds integers: step, seed, episodes and the counts (``updates``, ``*_updates``)."""
    return column in ("step", "seed", "episodes", "updates") or column.endswith("_updates")


def combine(calls: list) -> dict[str, np.ndarray]:
    """Merge the chunk summaries of the calls making one chunk (``ChunkMetrics`` of the run's agent,
    ``swim_jax.agents.metrics.MetricSpec.chunk_type``: its fields, and ``counter_of`` naming each
    metric's count) into per-lane chunk values, in the summary's field order: counts summed, metrics
    count-weighted means (nan where no update of that kind ran)."""
    kind = type(calls[0])
    total = {f: sum(np.asarray(getattr(c, f), np.int64) for c in calls)
             for f in kind._fields if f not in kind.counter_of}

    def mean(field, counts):
        s = sum(np.where(np.asarray(getattr(c, counts)) > 0,
                         np.asarray(getattr(c, field), np.float64) * np.asarray(getattr(c, counts)), 0.0)
                for c in calls)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(total[counts] > 0, s / np.maximum(total[counts], 1), np.nan)

    return {f: total[f] if f in total else mean(f, kind.counter_of[f]) for f in kind._fields}


def chunk_rows(step: int, seed_ids, chunk: dict[str, np.ndarray], episodes, last_return) -> list[dict]:
    """One row per lane, ``{column: Python number}`` in :func:`columns` order: ``step``,
    ``seed_ids[i]``, each ``chunk[field][i]`` (counts as int), ``episodes[i]``, ``last_return[i]``.
    What :func:`append` writes and :mod:`swim_jax.io.tensorboard_log` logs."""
    def number(field, v):
        return int(v) if is_count(field) else float(v)

    return [{"step": int(step), "seed": int(seed), **{f: number(f, v[i]) for f, v in chunk.items()},
             "episodes": int(episodes[i]), "last_episode_return": float(last_return[i])}
            for i, seed in enumerate(seed_ids)]


def append(path: str, rows: list[dict]) -> None:
    """Append :func:`chunk_rows` to the metrics.csv at ``path`` (header, the rows' columns, first
    when it is new); floats are written with ``repr``, so :func:`read` gives them back exactly."""
    new = not os.path.exists(path)
    with open(path, "a", newline="") as f:
        w = csv.writer(f)
        if new and rows:
            w.writerow(list(rows[0]))
        w.writerows([repr(v) if isinstance(v, float) else v for v in row.values()] for row in rows)


def read(path: str) -> dict[str, np.ndarray]:
    """``{column: array[rows]}`` of every column of a metrics.csv (step, seed, episodes and counts
    as int, the rest float). Raises ValueError naming a missing column of :data:`COLUMNS`, a row of
    another width or a cell that is not a number."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        header = tuple(reader.fieldnames or ())
        missing = [c for c in COLUMNS if c not in header]
        if missing:
            raise ValueError(f"missing column {missing[0]!r}")
        table = list(reader)
    for line, r in enumerate(table, 2):
        if None in r or None in r.values():
            raise ValueError(f"line {line} does not have the header's {len(reader.fieldnames)} fields "
                             f"(truncated file?)")
    return {c: np.asarray([(int if is_count(c) else float)(r[c]) for r in table]) for c in header}
