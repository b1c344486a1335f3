"""Optional TensorBoard event files (config key ``tensorboard: true``): metrics.csv and the evaluations.

Each run folder (each sweep point's folder) gets ``tensorboard/seed_<i>/events.out.tfevents.*``,
one TensorBoard run per seed, so ``tensorboard --logdir <run folder>`` (or ``--logdir runs``) shows
every seed as its own curve. Tags, with the env steps done as the step:

* ``train/<column>`` for every column of ``metrics.csv`` except step and seed (the agent's counts
  and metrics, at least :data:`TRAIN_COLUMNS`, and the episode columns), at the end of each chunk: the same numbers as the csv
  (:func:`swim_jax.io.learning_log.chunk_rows`), stored as float32 (TensorBoard's scalar format);
  nan cells (no update in the chunk yet, no training episode finished yet) are left out;
* ``eval/return``: the seed's mean evaluation return (a cell of ``evaluations.npy``) at every
  evaluation, step 0 included.

A resumed run writes a new event file in the same folders that starts with a purge marker at the
first step after its checkpoint: TensorBoard hides the events an interrupted run wrote past the
checkpoint (as ``metrics.csv`` drops those rows). Event files are flushed every 30 s and when
the run ends. The writer is tensorboardX (no TensorFlow), the
optional extra ``tensorboard``; :func:`missing_package` says when it cannot be imported.
"""

from __future__ import annotations

import math
import os
import shutil

import numpy as np

from swim_jax.io import learning_log

DIRNAME = "tensorboard"
EVAL_TAG = "eval/return"
# the train/ tags of every run (an agent may log more: all of its metrics.csv columns)
TRAIN_COLUMNS = tuple(c for c in learning_log.COLUMNS if c not in learning_log.BASE_COLUMNS)
INSTALL = "pip install -c requirements.lock -e '.[tensorboard]'"


def train_tag(column: str) -> str:
    """The tag of a metrics.csv column: ``train/<column>``."""
    return f"train/{column}"


def seed_folder(out_dir: str, seed: int) -> str:
    """``<out_dir>/tensorboard/seed_<seed>``: the event files of one seed."""
    return os.path.join(out_dir, DIRNAME, f"seed_{int(seed)}")


def missing_package() -> str | None:
    """None when tensorboardX can be imported; else one line naming the problem and the install
    command (for ``tensorboard=true`` configs)."""
    try:
        import tensorboardX  # noqa: F401  (optional dependency: only needed with tensorboard=true)
    except ImportError as e:
        return (f"tensorboard=true needs the optional package tensorboardX, which cannot be imported "
                f"({e}); install it with: {INSTALL} (or set tensorboard=false)")
    return None


def remove(out_dir: str) -> None:
    """Delete ``<out_dir>/tensorboard`` (a run that restarts from step 0 starts its logs anew)."""
    shutil.rmtree(os.path.join(out_dir, DIRNAME), ignore_errors=True)


class TensorBoardLog:
    """One tensorboardX ``SummaryWriter`` per seed of each output folder.

    ``folders``: ``[(out_dir, seed ids)]``, as the run's output folders and their lanes.
    ``first_step``: the first env step this process logs (0, or the first step after the resumed
    checkpoint); events an earlier process wrote at or after it are purged (hidden) when > 0."""

    def __init__(self, folders: list[tuple[str, np.ndarray]], first_step: int = 0):
        from tensorboardX import SummaryWriter  # optional dependency: only needed with tensorboard=true

        purge = first_step if first_step > 0 else None
        self._writers = {
            (out_dir, int(seed)): SummaryWriter(seed_folder(out_dir, seed), purge_step=purge, flush_secs=30,
                                                filename_suffix=f".from{first_step:012d}")
            for out_dir, seeds in folders for seed in seeds
        }

    def evaluation(self, out_dir: str, step: int, seed_ids, returns) -> None:
        """``eval/return`` = ``returns[i]`` (mean return of the evaluation episodes) for each seed."""
        for seed, r in zip(seed_ids, returns):
            self._add(out_dir, int(seed), EVAL_TAG, float(r), step)

    def chunk(self, out_dir: str, rows: list[dict]) -> None:
        """The ``train/<column>`` scalars of :func:`swim_jax.io.learning_log.chunk_rows`' rows: every
        column but step and seed."""
        for row in rows:
            for column, value in row.items():
                if column not in learning_log.BASE_COLUMNS:
                    self._add(out_dir, row["seed"], train_tag(column), value, row["step"])

    def _add(self, out_dir: str, seed: int, tag: str, value: float, step: int) -> None:
        if math.isfinite(value):
            self._writers[(out_dir, seed)].add_scalar(tag, value, int(step))

    def close(self) -> None:
        """Flush and close every event file (idempotent)."""
        for w in self._writers.values():
            w.close()
        self._writers = {}
