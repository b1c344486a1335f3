"""The replay buffer on disk, each transition written once: ``<run>/checkpoints/replay/``.

Every lane inserts one transition per env step (swim_jax/agents/loop.py), transition ``n`` (0-based, the
env step it was taken at) into slot ``n mod capacity`` (swim_jax/agents/replay.py). A checkpoint at step
``S`` therefore needs, besides its small state (networks, optimisers, env states, keys: the orbax
checkpoint), the transitions ``max(0, S - capacity) <= n < S``. Instead of rewriting the whole
buffer with every checkpoint (its cost growing with the buffer; docs/PERFORMANCE.md:
checkpoint-cost-1M), each chunk's new transitions are appended as one segment file

    replay/<n0:010d>-<n1:010d>.npz     arrays obs, action, reward, next_obs, terminated, each
                                       [lanes, n1 - n0, ...] in the buffer's dtype (uncompressed)

written before that chunk's checkpoint (temporary file, then rename: a killed process leaves no
partial segment), and the buffer of any kept checkpoint is rebuilt from the segments, slot by slot,
the newest transition last: the same arrays, bit for bit, as the buffer that was saved (unfilled
slots stay the zeros they were initialised with). Segments no kept checkpoint needs are deleted.
"""

from __future__ import annotations

import os
import re

import numpy as np

DIRNAME = "replay"
FIELDS = ("obs", "action", "reward", "next_obs", "terminated")  # swim_jax.agents.replay.Transition's
_NAME = re.compile(r"^(\d{10})-(\d{10})\.npz$")


class ReplayStore:
    """Append-only segments of a replay buffer of ``capacity`` slots under ``directory``."""

    def __init__(self, directory: str, capacity: int):
        self.directory, self.capacity = os.path.abspath(directory), int(capacity)

    def new_range(self, n0: int, n1: int) -> tuple[int, int]:
        """The transitions ``[n0, n1)`` a segment must hold to keep every one that is still in the
        buffer after step ``n1`` (older ones were overwritten before they could be needed)."""
        return max(n0, n1 - self.capacity), n1

    def slots(self, n0: int, n1: int) -> np.ndarray:
        """The buffer slots of transitions ``n0 .. n1 - 1`` (int32)."""
        return (np.arange(n0, n1, dtype=np.int64) % self.capacity).astype(np.int32)

    def append(self, n0: int, n1: int, transitions: dict[str, np.ndarray]) -> str:
        """Write transitions ``[n0, n1)`` (``FIELDS`` -> ``[lanes, n1 - n0, ...]``) as one
        segment, replacing one of the same range (a rerun after a resume writes the same bytes)."""
        if set(transitions) != set(FIELDS):
            raise ValueError(f"a segment holds {', '.join(FIELDS)}; got {', '.join(sorted(transitions))}")
        if any(np.shape(v)[1] != n1 - n0 for v in transitions.values()):
            raise ValueError(f"a segment of transitions [{n0}, {n1}) holds {n1 - n0} per lane")
        os.makedirs(self.directory, exist_ok=True)
        path = os.path.join(self.directory, f"{n0:010d}-{n1:010d}.npz")
        tmp = path + ".tmp"
        with open(tmp, "wb") as f:
            np.savez(f, **{k: np.asarray(transitions[k]) for k in FIELDS})
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
        return path

    def segments(self) -> list[tuple[int, int, str]]:
        """``(n0, n1, path)`` of every segment, in the order of ``n0``."""
        if not os.path.isdir(self.directory):
            return []
        found = []
        for name in os.listdir(self.directory):
            m = _NAME.match(name)
            if m:
                found.append((int(m.group(1)), int(m.group(2)), os.path.join(self.directory, name)))
        return sorted(found)

    def rebuild(self, step: int, like: dict[str, tuple[tuple[int, ...], np.dtype]]) -> dict[str, np.ndarray]:
        """The buffer's arrays after step ``step``: ``like`` maps every field to the full buffer's
        ``(shape [lanes, capacity, ...], dtype)``; slot ``n mod capacity`` holds transition ``n``
        for ``max(0, step - capacity) <= n < step``, every other slot zeros. Raises ValueError
        naming the first missing transition when the segments do not cover them."""
        lo = max(0, step - self.capacity)
        out = {k: np.zeros(shape, dtype) for k, (shape, dtype) in like.items()}
        at = lo
        for n0, n1, path in self.segments():
            if n1 <= lo or n0 >= step:
                continue
            if n0 > at:
                break
            a, b = max(n0, at), min(n1, step)  # new transitions of this segment
            with np.load(path) as seg:
                for k in FIELDS:
                    out[k][:, self.slots(a, b)] = seg[k][:, a - n0:b - n0]
            at = b
        if at < step:
            raise ValueError(f"the replay segments in {self.directory} miss transition {at} "
                             f"(the checkpoint at step {step} needs {lo}..{step - 1})")
        return out

    def prune(self, kept_steps: list[int]) -> list[str]:
        """Delete the segments no checkpoint of ``kept_steps`` needs (all of theirs lie at or
        after ``min(kept) - capacity``), and leftover temporary files; the deleted paths."""
        if not kept_steps:
            return []
        oldest_needed = max(0, min(kept_steps) - self.capacity)
        gone = []
        for n0, n1, path in self.segments():
            if n1 <= oldest_needed:
                os.remove(path)
                gone.append(path)
        if os.path.isdir(self.directory):
            for name in os.listdir(self.directory):
                if name.endswith(".tmp"):
                    os.remove(os.path.join(self.directory, name))
                    gone.append(os.path.join(self.directory, name))
        return gone
