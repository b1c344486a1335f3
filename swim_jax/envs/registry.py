"""Registry of environment ids and the ``make`` factory."""

from __future__ import annotations

from typing import Dict, Type

from swim_jax.envs.tasks.ant import AntV5
from swim_jax.envs.base import OPTION_NAMES, LocomotionEnv
from swim_jax.envs.tasks.half_cheetah import HalfCheetahV5
from swim_jax.envs.tasks.hopper import HopperV4, HopperV5
from swim_jax.envs.tasks.swimmer import SwimmerV5
from swim_jax.envs.tasks.walker2d import Walker2dV4, Walker2dV5

_REGISTRY: Dict[str, Type[LocomotionEnv]] = {
    cls.env_id: cls
    for cls in (HopperV5, Walker2dV5, HalfCheetahV5, SwimmerV5, AntV5, HopperV4, Walker2dV4)
}

ENV_IDS = tuple(_REGISTRY)


def make(env_id: str, **options) -> LocomotionEnv:
    """Build the env ``env_id`` (one of ``ENV_IDS``) with Gymnasium semantics.

    Options (all optional): ``max_episode_steps`` (default 1000; ``None`` = never truncate),
    ``solver_iterations`` (default 8; ``None`` = the XML's 100), ``ls_iterations`` (default 16;
    ``None`` = the XML's 50), ``solver_tolerance`` (default ``None`` = the XML's 1e-8), ``solver_impl`` ("c", default:
    MuJoCo C's Newton solver, swim_jax/envs/physics/mjx_solver.py; "mjx": MJX's own), ``dtype`` (must match JAX x64 mode: float64 iff x64 is enabled),
    ``backend`` ("mjx", default: MJX physics in JAX; "mujoco": MuJoCo C on the host from inside the
    jitted program, swim_jax/envs/physics/native.py), ``native_call`` (with "mujoco": "auto", default; "ffi": an XLA FFI
    call into C++; "callback": a Python callback; swim_jax/envs/physics/native.py).
    An unknown id or option raises ``ValueError`` with one line naming the valid ones.
    """
    if env_id not in _REGISTRY:
        raise ValueError(f"unknown env id {env_id!r}; valid ids: {', '.join(ENV_IDS)}")
    unknown = sorted(set(options) - set(OPTION_NAMES))
    if unknown:
        raise ValueError(f"unknown option(s) {', '.join(unknown)} for {env_id}; "
                         f"valid options: {', '.join(OPTION_NAMES)}")
    return _REGISTRY[env_id](**options)
