"""MJX locomotion environments with Gymnasium v4/v5 semantics and the brax ``Env`` API.

Public contract: ``make(env_id, **options)``, ``ENV_IDS``, ``step_autoreset(env, state, action,
reset_key) -> (next_state, final_obs)`` and its batched ``step_autoreset_lanes``. See docs/ENVS.md.
"""

from swim_jax.envs import deps

deps.import_mjx_quietly()  # before anything else imports mujoco.mjx (or brax, which does)
deps.check_versions()

from swim_jax.envs.physics import mjx_compat  # noqa: E402
from swim_jax.envs.autoreset import step_autoreset, step_autoreset_lanes
from swim_jax.envs.base import BACKENDS, LocomotionEnv, State
from swim_jax.envs.physics.native import CALLS as NATIVE_CALLS
from swim_jax.envs.registry import ENV_IDS, make

mjx_compat.install()

__all__ = ["BACKENDS", "ENV_IDS", "NATIVE_CALLS", "LocomotionEnv", "State", "make", "step_autoreset", "step_autoreset_lanes"]
