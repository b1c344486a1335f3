"""Step a CPU run's lanes as one group per core: one program per group, all running at once.

XLA's CPU backend runs a program's operations one after another, each spread over every core. At
TD3's sizes (256-wide products, elementwise passes over a few MB) that scales poorly: on 2 cores
the products run much faster than on one, the rest barely (docs/PERFORMANCE.md: two-cores-vs-one). Host CPU devices
(``XLA_FLAGS=--xla_force_host_platform_device_count=N``, one per core) run their programs at the
same time, each on its own thread, so the lanes can be split into one group per device
(docs/PERFORMANCE.md: lane-groups-vs-one-program).

The split (:func:`plan`), L lanes over D = min(L, devices) devices, q = L // D, r = L mod D:

* group g (g < D) holds lanes [g·q, (g+1)·q) and always runs on device g, vmapped over its q lanes;
* each of the r leftover lanes L−r … L−1 runs on its own (one lane) in D pieces per call, each of
  1/D of the call's steps, piece k of leftover lane j on device (j + k) mod D, one after another.
  So in every call every device carries q + r/D lanes' work. The lane's state moves from piece to
  piece (a copy between host devices: memory, no arithmetic), and the results cannot depend on the
  device: every device is the same CPU running the same compiled code.

Every lane computes what it computes in one program over all lanes (same seeds, keys, updates; a
chunk of n steps is the same as two chunks of n/2); only float rounding may differ (products
batched over q lanes instead of L): a float64 run's final actors agree to 3e-16
(tests/test_lane_groups.py).

:class:`GroupedChunks` runs the training calls that way: :meth:`~GroupedChunks.split` a whole-lane
state into :class:`Parts` once, :meth:`~GroupedChunks.step` them call after call (asynchronously:
each device works through its own queue; nothing waits between calls), and
:meth:`~GroupedChunks.join` a whole-lane copy (on the first device) where the evaluation, the NaN
check and the checkpoint read one; training goes on from the parts. The executables (each program
on each device) are ready before the first call, so none is compiled while training: each program
is compiled once, for the first device, and loaded as a copy for the others.
"""

from __future__ import annotations

import concurrent.futures
from dataclasses import dataclass
from typing import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from swim_jax.placement import executable_copies


@dataclass(frozen=True)
class LaneGroups:
    """Which lanes run where: ``devices[g]`` steps group g = lanes ``[g·per_group, (g+1)·per_group)``;
    the ``leftover`` lanes run one at a time, in one piece per device every call."""

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

    def piece_devices(self, j: int) -> list[int]:
        """The devices (indices into :attr:`devices`) of leftover lane number ``j``'s pieces, in order."""
        D = len(self.devices)
        return [(j + k) % D for k in range(D)]

    def describe(self) -> str:
        D = len(self.devices)
        text = f"{self.lanes} lanes as {D} groups of {self.per_group}, one per {self.devices[0].platform} device"
        if self.leftover:
            text += f", {len(self.leftover)} more in {D} pieces per call over them"
        return text


class StepsError(ValueError):
    """The steps per call cannot be cut into one equal piece per device."""


def plan(lanes: int, devices: Sequence, steps_per_call: int) -> LaneGroups | None:
    """The groups of ``lanes`` lanes over ``devices`` (at most one group per lane), or None when
    fewer than two devices would be used (one program is then all there is). :class:`StepsError`
    when there are leftover lanes and ``steps_per_call`` is not a multiple of the devices used."""
    devices = tuple(devices)[:lanes]
    if len(devices) < 2:
        return None
    q, r = divmod(lanes, len(devices))
    if r and steps_per_call % len(devices):
        raise StepsError(f"{lanes} lanes on {len(devices)} devices leave {r} lane(s) to run in {len(devices)} "
                         f"equal pieces per call, but {steps_per_call} steps per call is not a multiple of "
                         f"{len(devices)}")
    return LaneGroups(devices, q, tuple(range(lanes - r, lanes)))


@dataclass
class Parts:
    """A whole-lane training state as :class:`GroupedChunks` steps it: ``states[g]`` group g's lanes
    on device g, then every leftover lane's state (on the device of its first piece); ``args`` their
    per-lane arguments (a group's on its device; a leftover lane's as one copy per device)."""

    states: list
    args: list

    def ready(self) -> None:
        """Wait until every part's last call has finished (reads a few ints)."""
        jax.block_until_ready([s.bad_step for s in self.states])


def _specs(device):
    """A function giving a pytree's shapes and dtypes placed on ``device`` (to lower a program for it)."""
    sharding = jax.sharding.SingleDeviceSharding(device)
    return lambda tree: jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype, sharding=sharding), tree)


@jax.jit
def _concatenate(parts: list):
    """The parts' lanes in order, as one program (op by op it costs more: docs/PERFORMANCE.md: lane-groups-join)."""
    return jax.tree.map(lambda *xs: jnp.concatenate(xs), *parts)


def _slices(bounds: tuple):
    """A jitted function giving ``tree``'s lanes ``[a, b)`` for every ``(a, b)`` in ``bounds``."""
    return jax.jit(lambda tree: [jax.tree.map(lambda x: x[a:b], tree) for a, b in bounds])


class GroupedChunks:
    """Training calls ``fn(states, t, *args) -> (states, metrics)`` (every array with the lanes
    first; ``args``: per-lane arrays such as a sweep's values) run as the parts of ``groups``; a
    leftover lane's call as ``piece_fn`` (the same program for 1/D of the steps) once per device.
    A stepper (swim_jax/placement/stepping.py), as :class:`~swim_jax.placement.stepping.OneProgram` is."""

    def __init__(self, groups: LaneGroups, fn: Callable, piece_fn: Callable, steps_per_call: int):
        self.groups = groups
        self._fn, self._piece_fn = fn, piece_fn
        self._piece_steps = steps_per_call // len(groups.devices)
        self._compiled: dict[tuple[str, int], object] = {}  # ("group" | "piece", device index) -> executable
        self.copied = 0  # of those, loaded as a copy of the first device's (compiled once)
        self._split = _slices(tuple(groups.parts()))

    @property
    def executables(self) -> int:
        """Compiled executables: each group's on its device, the piece program on every device (and
        any that calling ``fn`` itself compiled: none, when the groups alone call it)."""
        return len(self._compiled) + self._fn._cache_size()

    @property
    def devices(self) -> int:
        """Devices the lanes run on: one per group."""
        return len(self.groups.devices)

    @property
    def lane_groups(self) -> str:
        """The groups in words (:meth:`LaneGroups.describe`)."""
        return self.groups.describe()

    def split(self, states, args: tuple) -> Parts:
        """``states`` (whole-lane) and ``args`` as :class:`Parts`, each on the device that runs it
        first. Compiles, on first use, every executable the parts need."""
        # committed to the first device, as join leaves it: one compiled split for every state
        pieces = self._split(jax.device_put((states, args), self.groups.devices[0]))
        D = len(self.groups.devices)
        states = [self._on(part, self._first_device(p)) for p, (part, _) in enumerate(pieces)]
        arg_parts = [self._on(a, p) if p < D else [self._on(a, d) for d in range(D)]
                     for p, (_, a) in enumerate(pieces)]
        parts = Parts(states, arg_parts)
        self._compile_all(parts)
        return parts

    def step(self, parts: Parts, t: int) -> tuple[Parts, list]:
        """One call (its first env step ``t``) of every part; returns the new parts and every part's
        metrics (a leftover lane's as the list of its pieces'). Nothing waits for the devices.

        Order matters, because a copy out of a device waits for the work queued there before it: a
        leftover lane's first pieces go first, each followed at once by the copy of its state to the
        next piece's device, then the groups; the step numbers go straight from the host to each device."""
        D = len(self.groups.devices)
        states, metrics = list(parts.states), [None] * D + [[] for _ in self.groups.leftover]

        def piece(j: int, k: int):
            devices = self.groups.piece_devices(j)
            d = devices[k]
            states[D + j], m = self._compiled[("piece", d)](states[D + j], self._step(t + k * self._piece_steps, d),
                                                           *parts.args[D + j][d])
            metrics[D + j].append(m)
            states[D + j] = self._on(states[D + j], devices[(k + 1) % D])  # where its next piece runs

        for j in range(len(self.groups.leftover)):
            piece(j, 0)
        for g in range(D):
            states[g], metrics[g] = self._compiled[("group", g)](states[g], self._step(t, g), *parts.args[g])
        for k in range(1, D):
            for j in range(len(self.groups.leftover)):
                piece(j, k)
        return Parts(states, parts.args), metrics

    def ready(self, parts: Parts) -> None:
        """Wait until every part's last call has finished."""
        parts.ready()

    def join(self, parts: Parts):
        """A whole-lane copy of ``parts``' states (lanes in order) on the first device."""
        first = self.groups.devices[0]
        return _concatenate([jax.device_put(s, first) for s in parts.states])

    def join_metrics(self, metrics: list, merge: Callable):
        """One call's metrics from :meth:`step` (host arrays) as one pytree with the lanes in order;
        ``merge`` turns a leftover lane's pieces' metrics into that call's."""
        D = len(self.groups.devices)
        whole = metrics[:D] + [merge(pieces) for pieces in metrics[D:]]
        return jax.tree.map(lambda *xs: np.concatenate(xs), *whole)

    def _first_device(self, part: int) -> int:
        D = len(self.groups.devices)
        return part if part < D else self.groups.piece_devices(part - D)[0]

    def _on(self, tree, device: int):
        return jax.device_put(tree, self.groups.devices[device])

    def _step(self, t: int, device: int):
        """Step number ``t`` on ``device``, from the host (made on another device, it would wait there)."""
        return jax.device_put(np.int32(t), self.groups.devices[device])

    def _compile_all(self, parts: Parts) -> None:
        """Compile every missing executable: each group's on its device, the one-lane piece program
        on every device. Each program is lowered (here) and compiled (in threads: XLA compiles
        without the GIL) for the first device only, and loaded for the others as a copy of that
        machine code (swim_jax/placement/executable_copies.py); where a copy cannot be made (or
        device 0's came from the persistent compilation cache), it is compiled for that device too."""
        D = len(self.groups.devices)
        t = np.int32(0)

        def lowered(key: tuple[str, int]):
            kind, d = key
            spec = _specs(self.groups.devices[d])
            if kind == "group":
                return self._fn.lower(spec(parts.states[d]), spec(t), *spec(parts.args[d]))
            return self._piece_fn.lower(spec(parts.states[D]), spec(t), *spec(parts.args[D][d]))

        kinds = ["group"] + (["piece"] if self.groups.leftover else [])
        missing = [(k, d) for k in kinds for d in range(D) if (k, d) not in self._compiled]
        if not missing:
            return
        with concurrent.futures.ThreadPoolExecutor(max_workers=D) as pool:
            def compile_each(keys) -> dict:
                done = {key: pool.submit(executable_copies.compile_noting_cache, lowered(key)) for key in keys}
                results = {key: f.result() for key, f in done.items()}
                self._compiled.update({key: compiled for key, (compiled, _) in results.items()})
                return {key: from_cache for key, (_, from_cache) in results.items()}

            from_cache = compile_each([(k, 0) for k in kinds if (k, 0) in missing])
            uncopied = []
            for kind, d in missing:
                if d > 0:  # a copy of device 0's, unless that came from the persistent cache (a read then)
                    copy = (None if from_cache.get((kind, 0), True) else
                            executable_copies.copy_to_device(self._compiled[(kind, 0)], self.groups.devices[d]))
                    if copy is None:
                        uncopied.append((kind, d))
                    else:
                        self._compiled[(kind, d)] = copy
                        self.copied += 1
            compile_each(uncopied)
