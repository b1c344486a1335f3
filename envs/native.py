"""Native MuJoCo C physics inside a jitted JAX program (``envs.make(..., backend="mujoco")``).

The physics of every lane runs in MuJoCo C, the library Gymnasium itself runs, through one
``jax.pure_callback`` per env step (``vmap_method="broadcast_all"``: a vmapped or nested-vmapped
call reaches the host once, with every lane's arrays stacked along leading axes). Everything
else (observation, reward, termination, time limit, auto-reset) stays the task's JAX code, shared
with the MJX backend: :class:`NativeData` exposes the fields the tasks read (``qpos``, ``qvel``,
``xpos``, ``cfrc_ext``) in the env dtype.

Exactness: the physics state that continues an episode (qpos, qvel and the solver's warm start
``qacc_warmstart``) is carried as the raw bits of float64 numbers (``uint32[2 n]``), so physics is
float64 and continues bit for bit even when JAX runs in float32 (then only what the task reads is
rounded to float32). One step is Gymnasium's ``do_simulation``: ``ctrl = action``,
``mj_step(nstep=frame_skip)``, then ``mj_rnePostConstraint`` where the task reads contact forces;
a reset is Gymnasium's ``mj_resetData`` + ``set_state`` (``mj_forward``). In float64 this gives
Gymnasium's observations, rewards and terminations bit for bit (tests/test_envs_native.py).

Lanes are stepped serially, or, when a call carries enough work (many lanes, e.g. the evaluation's
seeds × episodes), in at most ``threads`` blocks on a thread pool (MuJoCo releases the GIL inside
``mj_step``); ``threads`` defaults to the number of CPUs this process may use.
On a GPU the same code runs, but every step copies the lanes to the host and back (slow there:
use the MJX backend on accelerators).
"""

from __future__ import annotations

import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Optional

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct


@struct.dataclass
class NativeData:
    """Per-lane physics of the native backend (the ``pipeline_state`` of its ``State``).

    ``exact``: float64 bits of concat(qpos, qvel, qacc_warmstart) as uint32 (what continues the
    episode); ``qpos``, ``qvel``, ``xpos`` [nbody, 3] and ``cfrc_ext`` [nbody, 6] (zeros unless
    the task needs contact forces): the same numbers in the env dtype, for the task's terms.
    These are read-only views: replacing ``qpos`` does not move the physics (``exact`` does);
    set a state with ``env.physics_reset(qpos, qvel)`` or :meth:`NativePhysics.exact_state`."""

    exact: jax.Array
    qpos: jax.Array
    qvel: jax.Array
    xpos: jax.Array
    cfrc_ext: jax.Array


def _float64_bits(x: np.ndarray) -> np.ndarray:
    """float64[..., n] -> uint32[..., 2n] (the same bytes)."""
    return np.ascontiguousarray(x, dtype=np.float64).view(np.uint32)


def _from_bits(bits: np.ndarray) -> np.ndarray:
    """uint32[..., 2n] -> float64[..., n] (the same bytes)."""
    return np.ascontiguousarray(bits, dtype=np.uint32).view(np.float64)


class NativePhysics:
    """MuJoCo C stepping of ``mj_model`` for jitted code: :meth:`reset` and :meth:`step` are
    pure from JAX's point of view (outputs depend only on inputs) and accept any vmap nesting."""

    def __init__(self, mj_model: mujoco.MjModel, frame_skip: int, post_constraint: bool,
                 dtype, threads: Optional[int] = None):
        self.model = mj_model
        self.frame_skip = int(frame_skip)
        self.post_constraint = bool(post_constraint)
        self.dtype = jnp.dtype(dtype)
        self.nq, self.nv, self.nbody = mj_model.nq, mj_model.nv, mj_model.nbody
        self.threads = max(1, int(threads or len(os.sched_getaffinity(0))))
        self._pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None
        # one scratch MjData per block of lanes, owned here (not thread-local: XLA runs callbacks
        # on threads whose Python state is torn down after each call, and freeing an MjData there
        # crashed); the lock serialises concurrent callbacks (two programs running at once)
        self._data = [mujoco.MjData(mj_model) for _ in range(self.threads)]
        self._lock = threading.Lock()
        self._lane_seconds = None  # running estimate of one lane's serial step/reset time

    # ---------------------------------------------------------------- host side (NumPy, MuJoCo C)

    def _outputs(self, d: mujoco.MjData, out: dict, i: int) -> None:
        out["exact"][i] = np.concatenate([d.qpos, d.qvel, d.qacc_warmstart])
        out["xpos"][i] = d.xpos
        out["cfrc_ext"][i] = d.cfrc_ext

    def _new_outputs(self, n: int) -> dict:
        return {"exact": np.empty((n, self.nq + 2 * self.nv)),
                "xpos": np.empty((n, self.nbody, 3)),
                "cfrc_ext": np.zeros((n, self.nbody, 6))}

    def _reset_lanes(self, qpos, qvel, out, lanes, d: mujoco.MjData) -> None:
        m = self.model
        for i in lanes:
            mujoco.mj_resetData(m, d)
            d.qpos[:] = qpos[i]
            d.qvel[:] = qvel[i]
            mujoco.mj_forward(m, d)
            self._outputs(d, out, i)

    def _step_lanes(self, exact, ctrl, out, lanes, d: mujoco.MjData) -> None:
        m = self.model
        nq, nv = self.nq, self.nv
        for i in lanes:
            d.qpos[:] = exact[i, :nq]
            d.qvel[:] = exact[i, nq:nq + nv]
            d.qacc_warmstart[:] = exact[i, nq + nv:]
            d.ctrl[:] = ctrl[i]
            mujoco.mj_step(m, d, nstep=self.frame_skip)
            if self.post_constraint:
                mujoco.mj_rnePostConstraint(m, d)
            self._outputs(d, out, i)

    # the pool pays only for enough work per call (measured on a 2-core Zen 4: 5 lanes of
    # HalfCheetah, ~0.2 ms of MuJoCo, 0.39 ms serial vs 0.60 ms pooled; 16 lanes of Walker2d,
    # ~2 ms, 2.0 vs 1.7 ms; docs/BENCHMARKS.md §4)
    POOL_MIN_SECONDS = 1.5e-3

    def _run(self, fn, n: int, *args) -> dict:
        """``fn(*args, out, lanes, mjdata)`` over lanes 0..n-1: serially, or in blocks on the
        thread pool when the serial estimate (``n`` × the measured seconds per lane) is at least
        ``POOL_MIN_SECONDS``."""
        out = self._new_outputs(n)
        with self._lock:
            serial = (self._pool is None or n < 2 or self._lane_seconds is None
                      or n * self._lane_seconds < self.POOL_MIN_SECONDS)
            if serial:
                t0 = time.perf_counter()
                fn(*args, out, range(n), self._data[0])
                per_lane = (time.perf_counter() - t0) / n
                self._lane_seconds = per_lane if self._lane_seconds is None else 0.9 * self._lane_seconds + 0.1 * per_lane
            else:
                blocks = [range(b, n, self.threads) for b in range(min(self.threads, n))]
                futures = [self._pool.submit(fn, *args, out, lanes, self._data[b]) for b, lanes in enumerate(blocks)]
                for f in futures:
                    f.result()
        return out

    def _host(self, kind: str, a: np.ndarray, b: np.ndarray):
        batch = a.shape[:-1]
        a2 = a.reshape(-1, a.shape[-1])
        b2 = b.reshape(-1, b.shape[-1])
        if kind == "reset":
            out = self._run(self._reset_lanes, a2.shape[0], a2.astype(np.float64), b2.astype(np.float64))
        else:
            out = self._run(self._step_lanes, a2.shape[0], _from_bits(a2), b2.astype(np.float64))
        exact = out["exact"]
        n = exact.shape[0]
        view = np.concatenate([exact[:, :self.nq + self.nv], out["xpos"].reshape(n, -1),
                               out["cfrc_ext"].reshape(n, -1)], axis=1)
        return _float64_bits(exact).reshape(*batch, -1), view.astype(self.dtype).reshape(*batch, -1)

    # ---------------------------------------------------------------- JAX side
    def _call(self, kind: str, a: jax.Array, b: jax.Array) -> NativeData:
        # two results per call (each costs a conversion): the exact state's bits, and one vector
        # of what the task reads: qpos, qvel, xpos (flat), cfrc_ext (flat), in the env dtype
        nq, nv, nb = self.nq, self.nv, self.nbody
        shapes = (jax.ShapeDtypeStruct((2 * (nq + 2 * nv),), jnp.uint32),
                  jax.ShapeDtypeStruct((nq + nv + 9 * nb,), self.dtype))
        exact, view = jax.pure_callback(
            lambda x, y: self._host(kind, np.asarray(x), np.asarray(y)), shapes, a, b,
            vmap_method="broadcast_all")
        return NativeData(exact=exact, qpos=view[:nq], qvel=view[nq:nq + nv],
                          xpos=view[nq + nv:nq + nv + 3 * nb].reshape(nb, 3),
                          cfrc_ext=view[nq + nv + 3 * nb:].reshape(nb, 6))

    def reset(self, qpos: jax.Array, qvel: jax.Array) -> NativeData:
        """Gymnasium's reset physics: ``mj_resetData``, ``qpos``/``qvel`` set, ``mj_forward``."""
        return self._call("reset", qpos, qvel)

    def step(self, data: NativeData, action: jax.Array) -> NativeData:
        """Gymnasium's ``do_simulation``: ``ctrl = action``, ``frame_skip`` ``mj_step``s (then
        ``mj_rnePostConstraint`` if the task reads contact forces), from ``data``'s exact state."""
        return self._call("step", data.exact, action)

    def exact_state(self, qpos: np.ndarray, qvel: np.ndarray, qacc_warmstart: np.ndarray) -> np.ndarray:
        """Host float64 arrays [..., nq], [..., nv], [..., nv] -> the ``exact`` field (uint32 bits)."""
        return _float64_bits(np.concatenate([qpos, qvel, qacc_warmstart], axis=-1))

    def initial_data(self) -> NativeData:
        """Zero physics of the right shapes (for sizes; not a valid state to step)."""
        n = self.nq + 2 * self.nv
        z = lambda *s: jnp.zeros(s, self.dtype)
        return NativeData(exact=jnp.zeros((2 * n,), jnp.uint32), qpos=z(self.nq), qvel=z(self.nv),
                          xpos=z(self.nbody, 3), cfrc_ext=z(self.nbody, 6))
