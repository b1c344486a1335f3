"""Shared locomotion base with Gymnasium MuJoCo (v4/v5) semantics, on MJX or MuJoCo C physics (``backend``).

One class, :class:`LocomotionEnv`, owns everything the tasks share: loading Gymnasium's own XML
from the installed ``gymnasium`` package, the solver caps, frame skip, reset noise, the
x-velocity ``(x_after - x_before) / dt``, the reward skeleton
``forward_w * vx + healthy_reward - ctrl_w * |a|^2 - extra_cost``, termination from a health
rule, and the built-in 1000-step time limit (brax ``EpisodeWrapper`` conventions for
``info['steps']`` / ``info['truncation']``). A task file only sets class attributes and overrides
:meth:`observation`, :meth:`is_healthy` and (Ant) :meth:`extra_cost` / :meth:`x_position`.

Precision: the physics dtype follows JAX's x64 mode at construction time (float64 when
``jax.config.update("jax_enable_x64", True)`` is on, else float32). The ``dtype`` option only
checks that expectation (asking for float64 without x64 mode is a ``ValueError``).
"""

from __future__ import annotations

import os
import warnings
from typing import Any, ClassVar, Dict, Optional, Tuple

import gymnasium.envs.mujoco as gym_mujoco
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from brax.envs import base as brax_base
from mujoco import mjx

from swim_jax.envs.physics import mjx_solver
from swim_jax.envs.physics.native import NativePhysics
from swim_jax.envs.terms import rounded, sum_of_squares, true_divide

State = brax_base.State

# Defaults chosen from the measured trade-off (docs/PERFORMANCE.md: solver-caps; docs/ENVS.md): 8
# Newton iterations / 16 line-search iterations change nothing versus Gymnasium's 100 / 50 (MuJoCo C
# and MJX teacher-forced tests); fewer move the trajectory.
DEFAULT_SOLVER_ITERATIONS = 8
DEFAULT_LS_ITERATIONS = 16
DEFAULT_MAX_EPISODE_STEPS = 1000

OPTION_NAMES = ("max_episode_steps", "solver_iterations", "ls_iterations", "solver_tolerance",
                "solver_impl", "dtype", "backend", "native_call")
# physics backends: "mjx" (JAX, batched on any device; the default) or "mujoco" (MuJoCo C on the
# host through one callback per step, swim_jax/envs/physics/native.py; fastest on a CPU at few lanes)
BACKENDS = ("mjx", "mujoco")


def gymnasium_asset_path(xml_file: str) -> str:
    """Return the absolute path of ``xml_file`` inside the installed gymnasium's MuJoCo assets.

    Raises FileNotFoundError if the file is not there.
    """
    path = os.path.join(os.path.dirname(gym_mujoco.__file__), "assets", xml_file)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"Gymnasium MuJoCo asset not found: {path}")
    return path


# Gymnasium's half_cheetah.xml sets the compiler attribute settotalmass, which MuJoCo 4 still
# applies but reports as deprecated on every load (printed, and appended to ./MUJOCO_LOG.TXT)
KNOWN_XML_NOTICES = ("compiler attribute 'settotalmass' is deprecated",)


def _compile_quietly(path: str) -> mujoco.MjModel:
    """``MjModel.from_xml_path(path)`` with MuJoCo's warnings caught: the known notices of
    Gymnasium's own files are dropped, any other warning becomes a Python ``UserWarning``."""
    previous = mujoco.get_mju_user_warning()
    messages: list[str] = []
    mujoco.set_mju_user_warning(messages.append)
    try:
        model = mujoco.MjModel.from_xml_path(path)
    finally:
        mujoco.set_mju_user_warning(previous)
    for message in messages:
        if not any(notice in message for notice in KNOWN_XML_NOTICES):
            warnings.warn(f"MuJoCo: {message}", stacklevel=3)
    return model


def load_mj_model(xml_file: str, solver_iterations: Optional[int] = None,
                  ls_iterations: Optional[int] = None,
                  solver_tolerance: Optional[float] = None) -> mujoco.MjModel:
    """Load Gymnasium's XML ``xml_file`` as an MjModel, optionally overriding solver settings.

    ``None`` keeps the XML's value (Gymnasium: 100 Newton iterations, 50 line-search iterations,
    tolerance 1e-8 on the relative cost improvement). ``solver_tolerance=0`` makes the solver run
    every allowed iteration (a diagnostic: both MuJoCo C and MJX then converge as far as they can).
    """
    model = _compile_quietly(gymnasium_asset_path(xml_file))
    if solver_iterations is not None:
        model.opt.iterations = int(solver_iterations)
    if ls_iterations is not None:
        model.opt.ls_iterations = int(ls_iterations)
    if solver_tolerance is not None:
        if not float(solver_tolerance) >= 0:
            raise ValueError(f"solver_tolerance must be >= 0 or None, got {solver_tolerance}")
        model.opt.tolerance = float(solver_tolerance)
    return model


def float_dtype() -> jnp.dtype:
    """The float dtype the physics uses now: float64 in JAX x64 mode, else float32."""
    return jnp.dtype(jnp.float64 if jax.config.jax_enable_x64 else jnp.float32)


class LocomotionEnv(brax_base.Env):
    """Gymnasium-equivalent MuJoCo locomotion task on MJX or MuJoCo C physics (brax ``Env`` API).

    Subclasses set the class attributes below and override :meth:`observation` and, if the task
    can fall, :meth:`is_healthy`. ``reset(rng)`` and ``step(state, action)`` are pure, jit- and
    vmap-compatible; randomness comes only from the key passed to ``reset``.

    State contract: ``obs``, ``reward``, ``done`` (1.0 if terminated or truncated) in the physics
    float dtype; ``metrics`` (reward terms, x position/velocity); ``info['steps']`` (steps taken in
    this episode) and ``info['truncation']`` (1.0 when the time limit ended a non-terminated
    episode). With ``max_episode_steps=None`` the env never truncates (use this under brax's own
    ``EpisodeWrapper``, which keeps the same two info keys itself).
    """

    # --- task description (class attributes, overridden per task) ---
    env_id: ClassVar[str] = ""
    xml_file: ClassVar[str] = ""
    frame_skip: ClassVar[int] = 1
    forward_reward_weight: ClassVar[float] = 1.0
    ctrl_cost_weight: ClassVar[float] = 0.0
    healthy_reward: ClassVar[float] = 0.0
    # v5: the healthy reward is is_healthy * healthy_reward; v4 paid it on the terminal step too.
    healthy_reward_on_terminal_step: ClassVar[bool] = False
    reset_noise_scale: ClassVar[float] = 0.0
    # 'uniform': qvel0 + U(-s, s); 'normal': qvel0 + s * N(0, 1)
    reset_qvel_noise: ClassVar[str] = "uniform"
    # compute cfrc_ext (mj_rnePostConstraint) after each step; only Ant's observation needs it
    needs_post_constraint: ClassVar[bool] = False

    def __init__(self, max_episode_steps: Optional[int] = DEFAULT_MAX_EPISODE_STEPS,
                 solver_iterations: Optional[int] = DEFAULT_SOLVER_ITERATIONS,
                 ls_iterations: Optional[int] = DEFAULT_LS_ITERATIONS,
                 solver_tolerance: Optional[float] = None,
                 solver_impl: str = "c",
                 dtype: Any = None,
                 backend: str = "mjx",
                 native_call: str = "auto"):
        dt_now = float_dtype()
        if dtype is not None and jnp.dtype(dtype) != dt_now:
            raise ValueError(
                f"dtype={jnp.dtype(dtype).name} requested but JAX x64 mode gives {dt_now.name}; "
                "the physics dtype follows jax_enable_x64 (set it before envs.make)")
        if max_episode_steps is not None and int(max_episode_steps) < 1:
            raise ValueError(f"max_episode_steps must be >= 1 or None, got {max_episode_steps}")
        if backend not in BACKENDS:
            raise ValueError(f"unknown backend {backend!r}; valid backends: {', '.join(BACKENDS)}")
        self.physics_backend = backend
        self.solver_impl = mjx_solver.check_implementation(solver_impl)
        self.dtype = dt_now
        self.max_episode_steps = None if max_episode_steps is None else int(max_episode_steps)
        self.mj_model = load_mj_model(self.xml_file, solver_iterations, ls_iterations, solver_tolerance)
        self.solver_iterations = int(self.mj_model.opt.iterations)
        self.ls_iterations = int(self.mj_model.opt.ls_iterations)
        self.sys = mjx.put_model(self.mj_model)
        self._native = None
        if backend == "mujoco":
            self._native = NativePhysics(self.mj_model, self.frame_skip, self.needs_post_constraint, dt_now,
                                         call=native_call)
            self._data0 = self._native.initial_data()
        else:
            self._data0 = mjx.make_data(self.sys)
        self.dt = float(self.mj_model.opt.timestep) * self.frame_skip
        self.init_qpos = jnp.asarray(np.array(self.mj_model.qpos0), dtype=dt_now)
        self.init_qvel = jnp.zeros((self.mj_model.nv,), dtype=dt_now)
        ctrlrange = np.array(self.mj_model.actuator_ctrlrange, dtype=np.float64)
        self.action_low = jnp.asarray(ctrlrange[:, 0], dtype=dt_now)
        self.action_high = jnp.asarray(ctrlrange[:, 1], dtype=dt_now)
        self._obs_size = int(self.observation(self._data0).shape[-1])

    # ------------------------------------------------------------------ task hooks
    def observation(self, data: mjx.Data) -> jax.Array:
        """Observation vector of ``data`` (Gymnasium's ``_get_obs``). Overridden per task."""
        raise NotImplementedError

    def is_healthy(self, data: mjx.Data) -> jax.Array:
        """Boolean health rule (Gymnasium's ``is_healthy``); ``None`` means the task never ends."""
        return None

    def extra_cost(self, data: mjx.Data) -> Tuple[jax.Array, Dict[str, jax.Array]]:
        """Additional cost subtracted from the reward and its metrics (default: none)."""
        return jnp.zeros((), self.dtype), {}

    def x_position(self, data: mjx.Data) -> jax.Array:
        """The x coordinate whose finite difference is the forward velocity (qpos[0] here)."""
        return data.qpos[0]

    # ------------------------------------------------------------------ physics
    def physics_reset(self, qpos: jax.Array, qvel: jax.Array) -> mjx.Data:
        """Physics at ``(qpos, qvel)`` after ``mj_forward``, like Gymnasium's ``set_state``
        (MJX data, or :class:`swim_jax.envs.physics.native.NativeData` with ``backend="mujoco"``)."""
        if self._native is not None:
            return self._native.reset(qpos, qvel)
        data = self._data0.replace(qpos=qpos.astype(self.dtype), qvel=qvel.astype(self.dtype))
        with mjx_solver._implementation(self.solver_impl):
            return mjx.forward(self.sys, data)

    def physics_step(self, data: mjx.Data, action: jax.Array) -> mjx.Data:
        """``frame_skip`` physics steps with ``ctrl = action`` (then cfrc_ext if the task needs it)."""
        if self._native is not None:
            return self._native.step(data, action)
        data = data.replace(ctrl=action.astype(self.dtype))
        with mjx_solver._implementation(self.solver_impl):
            data = jax.lax.fori_loop(0, self.frame_skip, lambda _, d: mjx.step(self.sys, d), data)
        if self.needs_post_constraint:
            data = mjx.rne_postconstraint(self.sys, data)
        return data

    # ------------------------------------------------------------------ brax Env API
    def reset(self, rng: jax.Array) -> State:
        """Fresh episode from key ``rng``: Gymnasium's reset noise around qpos0 / zero qvel.

        Returns a State with reward = done = 0, ``info['steps'] = 0``, ``info['truncation'] = 0``.
        """
        k_pos, k_vel = jax.random.split(rng)
        s = self.reset_noise_scale
        qpos = self.init_qpos + jax.random.uniform(
            k_pos, self.init_qpos.shape, self.dtype, minval=-s, maxval=s)
        if self.reset_qvel_noise == "normal":
            qvel = self.init_qvel + s * jax.random.normal(k_vel, self.init_qvel.shape, self.dtype)
        else:
            qvel = self.init_qvel + jax.random.uniform(
                k_vel, self.init_qvel.shape, self.dtype, minval=-s, maxval=s)
        data = self.physics_reset(qpos, qvel)
        zero = jnp.zeros((), self.dtype)
        metrics = {k: zero for k in self._metric_names()}
        info = {"steps": zero, "truncation": zero}
        return State(pipeline_state=data, obs=self.observation(data), reward=zero, done=zero,
                     metrics=metrics, info=info)

    def step(self, state: State, action: jax.Array) -> State:
        """One Gymnasium step: ``frame_skip`` physics steps, reward, termination, time limit.

        ``done`` = terminated or truncated; ``info['truncation']`` = 1.0 only when the step count
        reached ``max_episode_steps`` and the step did not terminate. Stepping a done state keeps
        simulating (use :func:`envs.step_autoreset` or brax's AutoResetWrapper to reset).
        """
        action = jnp.asarray(action, self.dtype)
        data0 = state.pipeline_state
        x_before = self.x_position(data0)
        data = self.physics_step(data0, action)
        x_velocity = true_divide(self.x_position(data) - x_before, self.dt)
        forward_reward = self.forward_reward_weight * x_velocity
        ctrl_cost = self.ctrl_cost_weight * sum_of_squares(action)
        extra, extra_metrics = self.extra_cost(data)
        healthy = self.is_healthy(data)
        if healthy is None:
            terminated = jnp.zeros((), self.dtype)
            survive = jnp.zeros((), self.dtype)
        else:
            terminated = 1.0 - healthy.astype(self.dtype)
            paid = 1.0 if self.healthy_reward_on_terminal_step else healthy.astype(self.dtype)
            survive = jnp.asarray(self.healthy_reward * paid, self.dtype)
        # Gymnasium's order, (forward + healthy) - (ctrl + contact), each product rounded on its
        # own as in NumPy (terms.rounded: no fused multiply-add across the sum)
        forward_reward, ctrl_cost, extra = (rounded(x) for x in (forward_reward, ctrl_cost, extra))
        reward = (forward_reward + survive) - (ctrl_cost + extra)
        metrics = {
            "x_position": self.x_position(data).astype(self.dtype),
            "x_velocity": x_velocity,
            "reward_forward": forward_reward,
            "reward_ctrl": -ctrl_cost,
            "reward_survive": survive,
            **extra_metrics,
        }
        info = dict(state.info)
        steps = state.info["steps"] + 1
        done = terminated
        if self.max_episode_steps is not None:
            hit_limit = (steps >= self.max_episode_steps).astype(self.dtype)
            truncation = hit_limit * (1.0 - terminated)
            done = jnp.maximum(terminated, hit_limit)
            info["truncation"] = truncation.astype(self.dtype)
            info["steps"] = steps
        return state.replace(pipeline_state=data, obs=self.observation(data),
                             reward=reward.astype(self.dtype), done=done.astype(self.dtype),
                             metrics={k: v.astype(self.dtype) for k, v in metrics.items()},
                             info=info)

    def _metric_names(self):
        names = ["x_position", "x_velocity", "reward_forward", "reward_ctrl", "reward_survive"]
        return names + list(self.extra_cost(self._data0)[1].keys())

    @property
    def observation_size(self) -> int:
        """Length of the observation vector."""
        return self._obs_size

    @property
    def action_size(self) -> int:
        """Number of actuators (action vector length); every action lies in [-1, 1]."""
        return int(self.mj_model.nu)

    @property
    def native_physics(self) -> Optional[NativePhysics]:
        """The MuJoCo C stepper of ``backend="mujoco"`` (None for MJX)."""
        return self._native

    @property
    def backend(self) -> str:
        """Physics backend name (brax API): ``'mjx'`` or ``'mujoco'`` (MuJoCo C, swim_jax/envs/physics/native.py)."""
        return self.physics_backend
