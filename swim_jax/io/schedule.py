"""When a run evaluates, where its chunks end and when it checkpoints: one place for the schedule.

A run of ``total_steps`` env steps (per lane) with ``eval_freq`` F trains in chunks of F steps
(one jitted program call per chunk, or ``progress_steps`` calls inside one); after every chunk it
evaluates, logs the chunk's learning metrics and writes a checkpoint (the last ``keep_checkpoints``
kept). It also evaluates the initial policies, so evaluation i is at step i · F, i = 0 … total/F,
and chunk c (0-based) covers steps c · F … (c + 1) · F. Every module that turns an index into a
step asks :class:`Schedule`; run folders write the steps of their evaluations beside them
(``evaluation_steps.npy``, ``evaluations.csv``'s ``step`` column) so readers need not rebuild them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STEPS_FILE = "evaluation_steps.npy"  # [n_evals] int64, beside evaluations.npy (written since 2026-12-06)


@dataclass(frozen=True)
class Schedule:
    """The schedule of a run of ``total_steps`` with ``eval_freq`` (a divisor of it, > 0)."""

    total_steps: int
    eval_freq: int

    @property
    def chunk_steps(self) -> int:
        """Env steps per chunk (between two evaluations)."""
        return self.eval_freq

    @property
    def checkpoint_every(self) -> int:
        """Env steps between two checkpoints (one after every chunk)."""
        return self.eval_freq

    @property
    def n_chunks(self) -> int:
        return self.total_steps // self.eval_freq

    @property
    def n_evals(self) -> int:
        """Evaluations of a finished run: the initial one and one after every chunk."""
        return self.n_chunks + 1

    def eval_step(self, i: int) -> int:
        """The env step of evaluation ``i`` (also the end of chunk ``i - 1``)."""
        return int(i) * self.eval_freq

    def eval_steps(self, n: int | None = None) -> np.ndarray:
        """The steps of the first ``n`` evaluations (default all), int64."""
        return np.arange(self.n_evals if n is None else n, dtype=np.int64) * self.eval_freq

    def chunk_ends(self, n: int | None = None) -> np.ndarray:
        """The end steps of the first ``n`` chunks (default all), int64: the metrics' steps."""
        return np.arange(1, (self.n_chunks if n is None else n) + 1, dtype=np.int64) * self.eval_freq

    def eval_index(self, step: int) -> int:
        """The index of the evaluation at ``step``; ValueError when none is there."""
        if step < 0 or step % self.eval_freq or step > self.total_steps:
            raise ValueError(f"step {step} is not an evaluation step (a multiple of eval_freq={self.eval_freq} "
                             f"in 0..total_steps={self.total_steps})")
        return step // self.eval_freq

    def chunk_of_step(self, step: int) -> int:
        """The chunk a checkpoint at ``step`` (a chunk's end) resumes after: the chunks done."""
        return int(step) // self.eval_freq
