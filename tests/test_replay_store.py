"""The replay buffer's append-only segments (swim_jax/io/replay_store.py) against a plain ring buffer
written transition by transition, with wrap-around, kept checkpoints and pruning."""

from __future__ import annotations

import os

import numpy as np
import pytest

from swim_jax.io.replay_store import FIELDS, ReplayStore

LANES, OBS, ACT = 3, 4, 2


def transitions(n0: int, n1: int) -> dict[str, np.ndarray]:
    """Transitions n0..n1-1 of every lane, each value naming its lane and n (so a misplaced one shows)."""
    n = np.arange(n0, n1, dtype=np.float64)[None, :] + 1000.0 * np.arange(LANES)[:, None]  # [lanes, m]
    return {"obs": n[..., None] + np.arange(OBS) / 10, "action": -n[..., None] - np.arange(ACT) / 10,
            "reward": n + 0.5, "next_obs": n[..., None] + 0.25, "terminated": (n % 7 == 0).astype(np.float64)}


def ring_buffer(capacity: int, step: int) -> dict[str, np.ndarray]:
    """The reference: a zero-initialised ring of ``capacity`` slots after inserting 0..step-1 one at a time."""
    like = transitions(0, 1)
    buf = {k: np.zeros((LANES, capacity, *v.shape[2:])) for k, v in like.items()}
    for n in range(step):
        one = transitions(n, n + 1)
        for k in FIELDS:
            buf[k][:, n % capacity] = one[k][:, 0]
    return buf


def like(capacity: int) -> dict:
    return {k: ((LANES, capacity, *v.shape[2:]), np.float64) for k, v in transitions(0, 1).items()}


@pytest.mark.parametrize("capacity,chunk", [(50, 10), (25, 10), (7, 10), (100, 10)])
def test_rebuilt_buffer_equals_the_ring_buffer_at_every_kept_checkpoint(tmp_path, capacity, chunk):
    """Chunks of 10 steps into buffers that never fill (100), fill exactly (50 after 5 chunks), wrap
    mid-chunk (25) and are smaller than a chunk (7); 3 checkpoints kept, the rest pruned."""
    store, kept = ReplayStore(str(tmp_path / "replay"), capacity), []
    for step in range(chunk, 12 * chunk + 1, chunk):
        n0, n1 = store.new_range(step - chunk, step)
        store.append(n0, n1, transitions(n0, n1))
        kept = (kept + [step])[-3:]
        store.prune(kept)
        for s in kept:  # every kept checkpoint can still be rebuilt, bit for bit
            got, want = store.rebuild(s, like(capacity)), ring_buffer(capacity, s)
            for k in FIELDS:
                np.testing.assert_array_equal(got[k], want[k])
    # the segments left hold each transition once (disjoint ranges), and only what the kept
    # checkpoints need: transitions from step 100 - capacity on, give or take one chunk
    ranges = [(a, b) for a, b, _ in store.segments()]
    assert all(b1 <= a2 for (_, b1), (a2, _) in zip(ranges, ranges[1:]))
    needed_from = max(0, 100 - capacity)
    assert ranges[0][1] > needed_from and ranges[0][0] <= needed_from and ranges[-1][1] == 120


def test_segments_hold_each_transition_once_and_are_replaced_by_a_rerun(tmp_path):
    store = ReplayStore(str(tmp_path / "replay"), 1000)
    for step in (10, 20, 30):
        store.append(step - 10, step, transitions(step - 10, step))
    assert [(a, b) for a, b, _ in store.segments()] == [(0, 10), (10, 20), (20, 30)]
    store.append(20, 30, transitions(20, 30))  # after a resume at 20: the same range again
    assert len(store.segments()) == 3 and not any(n.endswith(".tmp") for n in os.listdir(store.directory))
    np.testing.assert_array_equal(store.rebuild(30, like(1000))["reward"], ring_buffer(1000, 30)["reward"])


def test_a_missing_segment_is_named(tmp_path):
    store = ReplayStore(str(tmp_path / "replay"), 1000)
    for step in (10, 20, 30):
        store.append(step - 10, step, transitions(step - 10, step))
    os.remove(store.segments()[1][2])
    with pytest.raises(ValueError, match=r"miss transition 10 \(the checkpoint at step 30 needs 0\.\.29\)"):
        store.rebuild(30, like(1000))
    np.testing.assert_array_equal(store.rebuild(10, like(1000))["obs"], ring_buffer(1000, 10)["obs"])


def test_bad_segments_are_refused(tmp_path):
    store = ReplayStore(str(tmp_path / "replay"), 100)
    with pytest.raises(ValueError, match="holds 10 per lane"):
        store.append(0, 10, transitions(0, 9))
    bad = transitions(0, 10)
    del bad["reward"]
    with pytest.raises(ValueError, match="a segment holds obs, action, reward"):
        store.append(0, 10, bad)
    assert store.segments() == []
