"""How a run's training calls run, chosen once per run: :class:`OneProgram` (every lane in one
jitted program, its lane axis sharded over the devices or on one) or lane groups
(:class:`~swim_jax.placement.lane_groups.GroupedChunks`: one program per group of lanes, one group
per core). Both are steppers with the same five methods, so the run loop, the chunk call and
``bench train`` have one path:

* ``split(states, args) -> parts``: a whole-lane training state (and the per-lane arguments, e.g.
  a sweep's values) as the stepper steps it; compiles what the calls need;
* ``step(parts, t) -> (parts, metrics)``: one call of ``steps_per_call`` env steps from step ``t``
  (asynchronous: nothing waits for the devices);
* ``ready(parts)``: wait for the last call (reads a few ints);
* ``join(parts) -> states``: the whole-lane state where the evaluation, the NaN check and the
  checkpoint read it (training goes on from ``parts``);
* ``join_metrics(metrics, merge)``: one call's metrics (host arrays) as one pytree, lanes in order.

and two facts for the run's ``timing.json`` and the benchmarks: ``devices`` (how many devices the
lanes run on) and ``lane_groups`` (the groups in words, None for one program).
"""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp

from swim_jax.placement.sharding import place


class OneProgram:
    """Every lane in one program: ``fn(states, t, *args) -> (states, metrics)`` (the state donated),
    the lanes placed by ``sharding`` (None: one device). ``parts`` is the whole-lane state itself."""

    def __init__(self, fn: Callable, sharding=None):
        self.fn, self.sharding = fn, sharding
        self._args: tuple = ()
        self.copied = 0  # executables loaded as copies instead of compiled: none (see lane_groups)

    @property
    def executables(self) -> int:
        """Compiled executables of ``fn`` (one, after the first call, for every call that follows)."""
        return self.fn._cache_size()

    @property
    def devices(self) -> int:
        """Devices the lanes run on: every device of the sharding's mesh, or one."""
        return len(self.sharding.mesh.devices.flat) if self.sharding is not None else 1

    lane_groups = None  # one program: no groups

    def split(self, states, args: tuple):
        self._args = tuple(args)
        return states

    def step(self, states, t: int):
        states, metrics = self.fn(states, jnp.asarray(t, jnp.int32), *self._args)
        return place(states, self.sharding), metrics  # the same input sharding every call: no recompile

    def ready(self, states) -> None:
        jax.block_until_ready(states.bad_step)

    def join(self, states):
        return states

    def join_metrics(self, metrics, merge: Callable):
        return metrics
