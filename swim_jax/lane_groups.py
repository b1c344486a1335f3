"""Step a CPU run's lanes as one group per core: one program per group, all running at once.

XLA's CPU backend runs a program's operations one after another, each spread over every core. At
TD3's sizes (256-wide products, elementwise passes over a few MB) that scales poorly: on 2 cores
the products run 1.86× faster than on one, the rest 1.3× (docs/BENCHMARKS.md §8). Host CPU devices
(``XLA_FLAGS=--xla_force_host_platform_device_count=N``, one per core) run their programs at the
same time, each on its own thread, so the lanes can be split into one group per device. Measured
(docs/BENCHMARKS.md §11, 5 lanes on 2 cores): hand-placed groups 0.85× one program's step time, this
module's form (which also splits and joins the whole state at every chunk, for the evaluation and
the checkpoint) 0.90–0.99×, within the machine's noise; so ``lane_groups`` is off by default.

The split (:func:`plan`), L lanes over D = min(L, devices) devices, q = L // D, r = L mod D:

* group g (g < D) holds lanes [g·q, (g+1)·q) and always runs on device g, vmapped over its q lanes;
* each of the r leftover lanes L−r … L−1 runs on its own (one lane), leftover lane i on device
  (i + call) mod D in call number ``call``, so over D calls every device carries q + r/D lanes' work.
  Its state moves with it: a copy between host devices (memory, no arithmetic), and the results
  cannot depend on the device: every device is the same CPU running the same compiled code.

Every lane computes what it computes in one program over all lanes (same seeds, keys, updates);
only float rounding may differ (products batched over q lanes instead of L): a float64 run's final
actors agree to 3e-16 (tests/test_lane_groups.py).

:class:`GroupedChunks` runs a training chunk that way: :meth:`~GroupedChunks.split` the whole-lane
state into parts at the start of a chunk, :meth:`~GroupedChunks.step` every call (asynchronously:
each device works through its own calls; nothing waits between calls), :meth:`~GroupedChunks.join`
the parts back into one whole-lane state (on the first device) at its end, where the evaluation,
the NaN check and the checkpoint read it. The executables (one per lane count and device) are
compiled before the first call, concurrently, so none is compiled while training.
"""

from __future__ import annotations

import concurrent.futures
from dataclasses import dataclass
from typing import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np


@dataclass(frozen=True)
class LaneGroups:
    """Which lanes run where: ``devices[g]`` steps group g = lanes ``[g·per_group, (g+1)·per_group)``;
    the ``leftover`` lanes run one at a time, rotating over the devices call by call."""

    devices: tuple
    per_group: int
    leftover: tuple[int, ...]

    @property
    def lanes(self) -> int:
        return len(self.devices) * self.per_group + len(self.leftover)

    def parts(self) -> list[tuple[int, int]]:
        """[start, stop) of every part's lanes: the groups in device order, then each leftover lane."""
        q = self.per_group
        return [(g * q, (g + 1) * q) for g in range(len(self.devices))] + [(i, i + 1) for i in self.leftover]

    def device_index(self, part: int, call: int) -> int:
        """The device (index into :attr:`devices`) that runs ``part`` in call number ``call``."""
        D = len(self.devices)
        return part if part < D else (part - D + call) % D

    def describe(self) -> str:
        text = f"{self.lanes} lanes as {len(self.devices)} groups of {self.per_group}, one per {self.devices[0].platform} device"
        if self.leftover:
            text += f", {len(self.leftover)} more rotating over them"
        return text


def plan(lanes: int, devices: Sequence) -> LaneGroups | None:
    """The groups of ``lanes`` lanes over ``devices`` (at most one group per lane), or None when
    fewer than two devices would be used (one program is then all there is)."""
    devices = tuple(devices)[:lanes]
    if len(devices) < 2:
        return None
    q, r = divmod(lanes, len(devices))
    return LaneGroups(devices, q, tuple(range(lanes - r, lanes)))


def _specs(device):
    """A function giving a pytree's shapes and dtypes placed on ``device`` (to lower a program for it)."""
    sharding = jax.sharding.SingleDeviceSharding(device)
    return lambda tree: jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype, sharding=sharding), tree)


def _take(tree, start: int, stop: int):
    return jax.tree.map(lambda x: x[start:stop], tree)


@jax.jit
def _concatenate(parts: list):
    """The parts' lanes in order, as one program (op-by-op concatenation costs ~0.3 s per chunk)."""
    return jax.tree.map(lambda *xs: jnp.concatenate(xs), *parts)


def _slices(bounds: tuple):
    """A jitted function giving ``tree``'s lanes ``[a, b)`` for every ``(a, b)`` in ``bounds``."""
    return jax.jit(lambda tree: [_take(tree, a, b) for a, b in bounds])


class GroupedChunks:
    """A chunk function ``fn(states, t, *args) -> (states, metrics)`` (every array with the lanes
    first; ``args``: per-lane arrays such as a sweep's values) run as the parts of ``groups``."""

    def __init__(self, groups: LaneGroups, fn: Callable):
        self.groups = groups
        self._fn = fn
        self._compiled: dict[tuple[int, int], object] = {}  # (lanes, device index) -> executable
        self._split = _slices(tuple(groups.parts()))

    @property
    def executables(self) -> int:
        """Compiled executables: one per (lane count, device) in use."""
        return len(self._compiled)

    def split(self, states, args: tuple, call: int) -> tuple[list, list]:
        """(state parts, argument parts): each part's lanes on the device that runs it in ``call``.
        Compiles, on first use, every executable the rotation will need."""
        # committed to the first device, as join leaves it: one compiled split for every chunk
        pieces = self._split(jax.device_put((states, args), self.groups.devices[0]))
        parts = [self._put(part, p, call) for p, (part, _) in enumerate(pieces)]
        arg_parts = [self._put(a, p, call) for p, (_, a) in enumerate(pieces)]
        self._compile_all(parts, arg_parts, call)
        return parts, arg_parts

    def step(self, parts: list, arg_parts: list, t: int, call: int) -> tuple[list, list]:
        """Call number ``call`` (its first env step ``t``) of every part, on its device; returns the
        new parts and every part's metrics. Nothing waits for the devices."""
        new_parts, metrics = [], []
        for p, (part, args) in enumerate(zip(parts, arg_parts)):
            part, args = self._put(part, p, call), self._put(args, p, call)
            exe = self._compiled[(self._width(p), self.groups.device_index(p, call))]
            part, m = exe(part, self._put(jnp.asarray(t, jnp.int32), p, call), *args)
            new_parts.append(part)
            metrics.append(m)
        return new_parts, metrics

    def join(self, parts: list):
        """The whole-lane state (lanes in order) on the first device."""
        first = self.groups.devices[0]
        return _concatenate([jax.device_put(p, first) for p in parts])

    @staticmethod
    def join_host(metrics: list):
        """Every part's metrics of one call (host arrays) as one pytree with the lanes in order."""
        return jax.tree.map(lambda *xs: np.concatenate(xs), *metrics)

    def _width(self, part: int) -> int:
        return self.groups.per_group if part < len(self.groups.devices) else 1

    def _put(self, tree, part: int, call: int):
        return jax.device_put(tree, self.groups.devices[self.groups.device_index(part, call)])

    def _compile_all(self, parts: list, arg_parts: list, call: int) -> None:
        """Lower (here) and compile (in threads: XLA compiles without the GIL) every missing
        executable: each group's on its device, the one-lane program on every device."""
        todo = {}
        D = len(self.groups.devices)
        for p, (part, args) in enumerate(zip(parts, arg_parts)):
            devices = [self.groups.device_index(p, call)] if p < D else range(D)
            for d in devices:
                key = (self._width(p), d)
                if key not in self._compiled and key not in todo:
                    spec = _specs(self.groups.devices[d])
                    todo[key] = self._fn.lower(spec(part), spec(jnp.asarray(0, jnp.int32)), *spec(args))
        if not todo:
            return
        with concurrent.futures.ThreadPoolExecutor(max_workers=D) as pool:
            done = {key: pool.submit(lowered.compile) for key, lowered in todo.items()}
            self._compiled.update({key: f.result() for key, f in done.items()})
