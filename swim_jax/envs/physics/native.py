"""Native MuJoCo C physics inside a jitted JAX program (``envs.make(..., backend="mujoco")``).

The physics of every lane runs in MuJoCo C, the library Gymnasium itself runs, through one call
per env step, an XLA FFI call into C++ or a ``jax.pure_callback`` (see ``call`` below; both with
``vmap_method="broadcast_all"``: a vmapped or nested-vmapped call reaches MuJoCo once, with every
lane's arrays stacked along leading axes). Everything
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

With the callback, all lanes of a call are one :class:`mujoco.batch.Batch` (MuJoCo's own C++ loop
over simulations, bit-identical to one MjData per lane at any thread count), so a call costs one
Python round trip, not one per lane. The lanes go to ``threads`` threads (default: the CPUs this
process may use) when a call carries at least ``POOL_MIN_SECONDS`` of physics, else one.
On a GPU the same code runs, but every step copies the lanes to the host and back (slow there:
use the MJX backend on accelerators).

``call`` chooses how the jitted program reaches MuJoCo: ``"ffi"``, an XLA FFI custom call into C++
(swim_jax/envs/physics/native_ffi.cc, built on first use by swim_jax/envs/physics/native_ffi.py; CPU only), which does per lane what
the Python path does, serially on XLA's thread, without a Python round trip; ``"callback"``, the
``jax.pure_callback`` above; ``"auto"`` (default), the FFI call on a CPU backend when it builds,
else the callback. Both give the same bits (tests/test_envs_native.py).
"""

from __future__ import annotations

import os
import threading
import time
from typing import Dict, Optional

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import batch as mujoco_batch
from flax import struct

from swim_jax.envs.physics import native_ffi

CALLS = ("auto", "ffi", "callback")


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
                 dtype, threads: Optional[int] = None, call: str = "auto"):
        self.model = mj_model
        self.frame_skip = int(frame_skip)
        self.post_constraint = bool(post_constraint)
        self.dtype = jnp.dtype(dtype)
        self.nq, self.nv, self.nbody = mj_model.nq, mj_model.nv, mj_model.nbody
        self.threads = max(1, int(threads or len(os.sched_getaffinity(0))))
        # one mujoco.batch.Batch per lane count, owned here (freed with the env, never on XLA's
        # callback threads, whose Python state is torn down after each call); the lock
        # serialises concurrent callbacks (two programs running at once share a Batch)
        self._batches: Dict[int, _LaneBatch] = {}
        self._lock = threading.Lock()
        self.ffi_key, self.call, self.call_reason = _choose_call(mj_model, call)
        # the physics per lane decides whether a callback's lanes go to MuJoCo's thread pool; the
        # FFI handler steps its lanes serially and never needs it
        self.step_seconds = _time_one_step(mj_model, self.frame_skip) if self.call == "callback" else None

    # MuJoCo's thread pool pays only for enough work per call: HalfCheetah's 5 lanes ran slower on 2
    # threads than on one, Swimmer's and Walker2d's faster (docs/PERFORMANCE.md: native-thread-pool)
    POOL_MIN_SECONDS = 0.2e-3

    # ---------------------------------------------------------------- host side (NumPy, MuJoCo C)
    def _batch(self, n: int) -> "_LaneBatch":
        if n not in self._batches:
            pooled = n * self.step_seconds >= self.POOL_MIN_SECONDS
            nthread = min(self.threads, n) if pooled else 1
            self._batches[n] = _LaneBatch(self.model, n, nthread, self.post_constraint)
        return self._batches[n]

    def _host(self, kind: str, a: np.ndarray, b: np.ndarray):
        """Host half of one call: ``kind`` "reset" (a = qpos, b = qvel) or "step" (a = exact
        bits, b = ctrl), every lane at once; returns (exact bits, the task's view), batched."""
        batch = a.shape[:-1]
        a2 = a.reshape(-1, a.shape[-1])
        b2 = b.reshape(-1, b.shape[-1])
        n = a2.shape[0]
        with self._lock:
            lanes = self._batch(n)
            if kind == "reset":
                lanes.reset(a2, b2)
            else:
                lanes.step(_from_bits(a2), b2, self.frame_skip)
            exact = np.concatenate([lanes.qpos, lanes.qvel, lanes.qacc_warmstart], axis=1)
            view = np.concatenate([lanes.qpos, lanes.qvel, lanes.xpos.reshape(n, -1),
                                   lanes.cfrc_ext.reshape(n, -1)], axis=1)
        return _float64_bits(exact).reshape(*batch, -1), view.astype(self.dtype).reshape(*batch, -1)

    # ---------------------------------------------------------------- JAX side
    def _call(self, kind: str, a: jax.Array, b: jax.Array) -> NativeData:
        # two results per call (each costs a conversion): the exact state's bits, and one vector
        # of what the task reads: qpos, qvel, xpos (flat), cfrc_ext (flat), in the env dtype
        nq, nv, nb = self.nq, self.nv, self.nbody
        shapes = (jax.ShapeDtypeStruct((2 * (nq + 2 * nv),), jnp.uint32),
                  jax.ShapeDtypeStruct((nq + nv + 9 * nb,), self.dtype))
        if self.ffi_key is not None:  # MuJoCo C on XLA's thread (swim_jax/envs/physics/native_ffi.cc)
            attrs = dict(key=np.int64(self.ffi_key), contact_forces=np.int64(self.post_constraint))
            if kind == "step":
                attrs["frame_skip"] = np.int64(self.frame_skip)
            target = native_ffi.STEP_TARGET if kind == "step" else native_ffi.RESET_TARGET
            exact, view = jax.ffi.ffi_call(target, shapes, vmap_method="broadcast_all")(a, b, **attrs)
        else:
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


def _choose_call(model: mujoco.MjModel, call: str) -> tuple[Optional[int], str, str]:
    """(FFI model key or None, "ffi" or "callback", why) for the requested ``call`` (``CALLS``).
    ValueError for an unknown value, or for "ffi" when the FFI library is unavailable."""
    if call not in CALLS:
        raise ValueError(f"unknown native call {call!r}; valid: {', '.join(CALLS)}")
    if call == "callback":
        return None, "callback", "native_call=callback"
    if jax.default_backend() != "cpu":
        if call == "ffi":
            raise ValueError(f"native_call=ffi: the FFI handlers are CPU-only, JAX runs on {jax.default_backend()}; "
                             f"valid: {', '.join(CALLS)}")
        return None, "callback", f"the FFI handlers are CPU-only, JAX runs on {jax.default_backend()}"
    if native_ffi.library() is None:
        if call == "ffi":
            raise ValueError(f"native_call=ffi: the native physics FFI is unavailable ({native_ffi.unavailable_reason()}); "
                             f"valid: {', '.join(CALLS)}")
        return None, "callback", f"the FFI is unavailable: {native_ffi.unavailable_reason()}"
    return native_ffi.model_key(model), "ffi", f"native_call={call}"


def _time_one_step(model: mujoco.MjModel, frame_skip: int, repeats: int = 30) -> float:
    """Fastest of ``repeats`` env steps (``frame_skip`` mj_steps from the model's reference pose,
    after as many warm-up steps), in seconds: the work per lane that decides whether a call's
    lanes go to MuJoCo's thread pool."""
    d = mujoco.MjData(model)
    mujoco.mj_step(model, d, nstep=repeats * frame_skip)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        mujoco.mj_step(model, d, nstep=frame_skip)
        times.append(time.perf_counter() - t0)
    return min(times)


class _LaneBatch:
    """``n`` lanes of one model in a :class:`mujoco.batch.Batch` (MuJoCo's C++ thread pool over
    simulations; bit-identical to stepping one MjData per lane at any thread count), with live
    (n, ...) views of what a call writes (qpos, qvel, ctrl, qacc_warmstart) and reads (the same,
    xpos, cfrc_ext). Models that need contact forces keep one MjData per lane (persistent) and
    run ``mj_rnePostConstraint`` on each after a step, as Gymnasium does; for the others
    ``cfrc_ext`` stays zero."""

    def __init__(self, model: mujoco.MjModel, n: int, nthread: int, post_constraint: bool):
        self.model = model
        self.sims = mujoco_batch.Batch(model, nsim=n, nthread=nthread, persistent=post_constraint)
        for name in ("qpos", "qvel", "qacc_warmstart", "ctrl", "xpos"):
            setattr(self, name, self.sims.bind(name))
        self.post_constraint = post_constraint
        self.cfrc_ext = np.zeros((n, model.nbody, 6))
        self._scratch = mujoco.MjData(model) if post_constraint else None

    def reset(self, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Gymnasium's reset physics per lane: ``mj_resetData``, set qpos/qvel, ``mj_forward``."""
        self.sims.reset(stage=mujoco.mjtStage.mjSTAGE_NONE)
        self.qpos[:] = qpos
        self.qvel[:] = qvel
        self.sims.forward()
        self._contact_forces(after_step=False)

    def step(self, exact: np.ndarray, ctrl: np.ndarray, frame_skip: int) -> None:
        """Gymnasium's ``do_simulation`` per lane from the float64 state rows ``exact``."""
        nq, nv = self.qpos.shape[1], self.qvel.shape[1]
        self.qpos[:] = exact[:, :nq]
        self.qvel[:] = exact[:, nq:nq + nv]
        self.qacc_warmstart[:] = exact[:, nq + nv:]
        self.ctrl[:] = ctrl
        self.sims.step(nstep=frame_skip)
        self._contact_forces(after_step=True)

    def _contact_forces(self, after_step: bool) -> None:
        # contact forces exist only where a task reads them: Gymnasium runs mj_rnePostConstraint
        # after mj_step (a reset shows what mj_forward left); done on a copy of each lane's
        # persistent MjData
        if not self.post_constraint:
            return
        d = self._scratch
        for i in range(self.cfrc_ext.shape[0]):
            self.sims.get_data(i, d)
            if after_step:
                mujoco.mj_rnePostConstraint(self.model, d)
            self.cfrc_ext[i] = d.cfrc_ext
