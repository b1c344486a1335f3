"""Auto-reset step that keeps the true final observation of a finished episode."""

from __future__ import annotations

from typing import Tuple

import jax
import jax.numpy as jnp

from envs.base import LocomotionEnv, State


def step_autoreset(env: LocomotionEnv, state: State, action: jax.Array,
                   reset_key: jax.Array) -> Tuple[State, jax.Array]:
    """Step ``env``; if that step ended the episode, continue from ``env.reset(reset_key)``.

    Returns ``(next_state, final_obs)``. ``final_obs`` is always the observation the step reached
    (the true terminal/truncated observation when the episode ended). ``next_state`` is the
    stepped state, or a freshly reset one where ``done``; in both cases its ``reward``, ``done``,
    ``metrics`` and ``info['truncation']`` describe the step just taken, while its obs, physics
    and ``info['steps']`` are those to continue from. A learner stores
    ``(obs, action, reward, final_obs, terminated = done * (1 - truncation))``.
    Pure; works under jit and vmap (the reset is computed every call and selected by ``done``).
    """
    stepped = env.step(state, action)
    fresh = env.reset(reset_key)
    done = stepped.done > 0
    pick = lambda a, b: jnp.where(done, a, b)
    info = dict(stepped.info)
    info["steps"] = pick(fresh.info["steps"], stepped.info["steps"])
    next_state = stepped.replace(
        pipeline_state=jax.tree_util.tree_map(pick, fresh.pipeline_state,
                                              stepped.pipeline_state),
        obs=pick(fresh.obs, stepped.obs),
        info=info,
    )
    return next_state, stepped.obs
