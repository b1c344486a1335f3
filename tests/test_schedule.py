"""The schedule (swim_jax/io/schedule.py): evaluation i at step i · eval_freq, chunk c ending at
(c + 1) · eval_freq, one checkpoint per chunk; run folders write their evaluations' steps
(evaluation_steps.npy) and readers check them against the schedule."""

from __future__ import annotations

import os

import numpy as np
import pytest
import yaml

from swim_jax.analysis import runs_io
from swim_jax.io.schedule import STEPS_FILE, Schedule


def test_steps_by_hand():
    s = Schedule(total_steps=20_000, eval_freq=5_000)
    assert (s.n_chunks, s.n_evals, s.chunk_steps, s.checkpoint_every) == (4, 5, 5_000, 5_000)
    assert s.eval_steps().tolist() == [0, 5_000, 10_000, 15_000, 20_000] and s.eval_steps(2).tolist() == [0, 5_000]
    assert s.chunk_ends().tolist() == [5_000, 10_000, 15_000, 20_000]
    assert s.eval_index(15_000) == 3 and s.eval_step(3) == 15_000 and s.chunk_of_step(10_000) == 2
    for bad in (-5_000, 12_345, 25_000):
        with pytest.raises(ValueError, match="not an evaluation step"):
            s.eval_index(bad)


def _folder(root, steps=None):
    d = os.path.join(str(root), "run")
    os.makedirs(d)
    cfg = {"env": {"id": "Hopper-v5"}, "agent": {"activation": {"name": "relu"}}, "seeds": 2, "total_steps": 300,
           "eval_freq": 100, "precision": "float32"}
    with open(os.path.join(d, "config.yaml"), "w") as f:
        yaml.safe_dump(cfg, f)
    np.save(os.path.join(d, "evaluations.npy"), np.zeros((3, 2)))
    if steps is not None:
        np.save(os.path.join(d, STEPS_FILE), np.asarray(steps, np.int64))
    return d


def test_readers_check_the_written_steps(tmp_path):
    assert runs_io.load_run(_folder(tmp_path / "old")).steps.tolist() == [0, 100, 200]  # no file: the schedule
    assert runs_io.load_run(_folder(tmp_path / "new", [0, 100, 200])).steps.tolist() == [0, 100, 200]
    with pytest.raises(runs_io.RunError, match="do not match config.yaml's schedule"):
        runs_io.load_run(_folder(tmp_path / "bad", [0, 50, 100]))
