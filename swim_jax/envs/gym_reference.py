"""Gymnasium reference recordings and batched teacher forcing (test and benchmark support).

``record(env_id, n_steps, policy, seed)`` runs Gymnasium's own env (MuJoCo C) and records, for
every step, the physics state *before* the step (qpos, qvel, qacc_warmstart, xpos), the action and
Gymnasium's outputs (obs, reward, terminated), resetting Gymnasium when an episode terminates.
``teacher_forced_step(env)`` returns one jitted function that puts every recorded pre-step state
into our MJX env at once (vmap) and steps it with the recorded actions.
"""

from __future__ import annotations

from typing import Callable, Dict, Optional

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np

from swim_jax.envs.base import LocomotionEnv, State

Policy = Callable[[np.ndarray, int, np.random.Generator], np.ndarray]


def random_policy(obs: np.ndarray, t: int, rng: np.random.Generator, nu: int) -> np.ndarray:
    """Uniform random action in [-1, 1]^nu."""
    return rng.uniform(-1.0, 1.0, size=nu)


def sine_policy(obs: np.ndarray, t: int, rng: np.random.Generator, nu: int) -> np.ndarray:
    """Deterministic open-loop gait: a_j = 0.9 sin(2 pi t / 25 + j)."""
    return 0.9 * np.sin(2.0 * np.pi * t / 25.0 + np.arange(nu))


def record(env_id: str, n_steps: int, policy: str = "random", seed: int = 0,
           max_episode_steps: int = 1000, solver_opt: Optional[Dict[str, float]] = None
           ) -> Dict[str, np.ndarray]:
    """Record ``n_steps`` Gymnasium steps of ``env_id`` under ``policy`` ('random' | 'sine').

    ``solver_opt`` (e.g. ``{"tolerance": 0.0}``) overrides fields of Gymnasium's ``model.opt``
    before the first reset: a diagnostic, the equivalence tests record Gymnasium as shipped.

    Returns float64 arrays keyed qpos, qvel, qacc_warmstart, xpos (state before each step),
    action, obs, reward, terminated (Gymnasium's outputs of each step) and t (step in episode).
    All arrays are copies (never views of MjData memory).
    """
    pol = {"random": random_policy, "sine": sine_policy}[policy]
    genv = gym.make(env_id).unwrapped
    valid = sorted(n for n in dir(genv.model.opt) if not n.startswith("_"))
    for name, value in (solver_opt or {}).items():
        if name not in valid:
            genv.close()
            raise ValueError(f"solver_opt: unknown MjOption field {name!r}; valid: {', '.join(valid)}")
        setattr(genv.model.opt, name, value)
    rng = np.random.default_rng(seed)
    genv.reset(seed=seed)
    nu = genv.model.nu
    keys = ("qpos", "qvel", "qacc_warmstart", "xpos", "action", "obs", "reward", "terminated",
            "t")
    out = {k: [] for k in keys}
    t = 0
    obs = None
    for _ in range(n_steps):
        d = genv.data
        out["qpos"].append(np.array(d.qpos, dtype=np.float64, copy=True))
        out["qvel"].append(np.array(d.qvel, dtype=np.float64, copy=True))
        out["qacc_warmstart"].append(np.array(d.qacc_warmstart, dtype=np.float64, copy=True))
        out["xpos"].append(np.array(d.xpos, dtype=np.float64, copy=True))
        # f32-representable values passed as float64: Gymnasium would otherwise compute the
        # control cost in float32 (np.square of a float32 action), a 1e-8-level difference
        action = np.asarray(pol(obs, t, rng, nu), dtype=np.float32).astype(np.float64)
        obs, reward, terminated, _, _ = genv.step(action)
        out["action"].append(action)
        out["obs"].append(np.array(obs, dtype=np.float64, copy=True))
        out["reward"].append(float(reward))
        out["terminated"].append(bool(terminated))
        out["t"].append(t)
        t += 1
        if terminated or t >= max_episode_steps:
            genv.reset(seed=int(rng.integers(2**31)))
            t = 0
    genv.close()
    return {k: np.asarray(v) for k, v in out.items()}


def record_random_and_sine(env_id: str, n_steps: int, seed: int) -> Dict[str, np.ndarray]:
    """The equivalence tests' reference: ``n_steps`` of :func:`record` under the random policy,
    then ``n_steps`` under the sine controller (same seed), concatenated along the step axis."""
    recs = [record(env_id, n_steps, pol, seed=seed) for pol in ("random", "sine")]
    return {k: np.concatenate([r[k] for r in recs]) for k in recs[0]}


def _template(env: LocomotionEnv) -> State:
    """The State each recorded step is put into. MJX: the model's initial data (``mjx.make_data``)
    in the dtypes of a reset state (x64 mode: a forward pass returns int64 counters) and zero
    outputs. A step reads only the fields replaced from the recording and inputs that no forward
    pass changes (qfrc_applied, xfrc_applied: zero in both), so this steps exactly like a reset
    state, without running ``env.reset`` outside jit (op by op: about a minute of small compiles
    per env and precision). Native: the env's own reset (one MuJoCo C call)."""
    key = jax.random.PRNGKey(0)
    if env.backend == "mujoco":
        return env.reset(key)
    like = jax.eval_shape(env.reset, key)  # traced, not run
    zeros = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), like)
    data = jax.tree_util.tree_map(lambda x, s: jnp.asarray(x, s.dtype), env._data0, like.pipeline_state)
    return zeros.replace(pipeline_state=data)


def teacher_forced_step(env: LocomotionEnv) -> Callable[..., State]:
    """Jitted ``f(exact, qpos, qvel, qacc_warmstart, xpos, action) -> State`` batched over axis 0.

    Each element starts from a reset state whose physics is replaced by the recorded Gymnasium
    pre-step state, then takes one ``env.step`` with the recorded action. ``exact`` is the native
    backend's float64 state (``NativePhysics.exact_state``; ignored, may be None, for MJX).
    """
    template = _template(env)

    def one(exact, qpos, qvel, warm, xpos, action):
        if env.backend == "mujoco":
            data = template.pipeline_state.replace(exact=exact, qpos=qpos, qvel=qvel, xpos=xpos)
        else:
            data = template.pipeline_state.replace(qpos=qpos, qvel=qvel, qacc_warmstart=warm,
                                                   xpos=xpos)
        return env.step(template.replace(pipeline_state=data), action)

    return jax.jit(jax.vmap(one))


def run_teacher_forced(env: LocomotionEnv, rec: Dict[str, np.ndarray], fn=None) -> State:
    """Apply :func:`teacher_forced_step` to every recorded step of ``rec``; returns batched State."""
    fn = fn or teacher_forced_step(env)
    cast = lambda k: jnp.asarray(np.array(rec[k]), dtype=env.dtype)
    exact = None
    if env.backend == "mujoco":  # the recorded float64 state, exactly, whatever JAX's precision
        exact = jnp.asarray(env.native_physics.exact_state(rec["qpos"], rec["qvel"], rec["qacc_warmstart"]))
    return fn(exact, cast("qpos"), cast("qvel"), cast("qacc_warmstart"), cast("xpos"), cast("action"))
