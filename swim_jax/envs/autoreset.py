"""Auto-reset steps that keep the true final observation of a finished episode."""

from __future__ import annotations

from typing import Tuple

import jax
import jax.numpy as jnp

from swim_jax.envs.base import LocomotionEnv, State


def _continue_from(done: jax.Array, fresh: State, stepped: State) -> State:
    """``stepped`` with its obs, physics and step counter replaced by ``fresh``'s where ``done``."""
    pick = lambda a, b: jnp.where(done, a, b)
    info = dict(stepped.info)
    info["steps"] = pick(fresh.info["steps"], stepped.info["steps"])
    return stepped.replace(
        pipeline_state=jax.tree_util.tree_map(pick, fresh.pipeline_state, stepped.pipeline_state),
        obs=pick(fresh.obs, stepped.obs),
        info=info,
    )


def step_autoreset(env: LocomotionEnv, state: State, action: jax.Array,
                   reset_key: jax.Array) -> Tuple[State, jax.Array]:
    """Step ``env``; if that step ended the episode, continue from ``env.reset(reset_key)``.

    Returns ``(next_state, final_obs)``. ``final_obs`` is always the observation the step reached
    (the true terminal/truncated observation when the episode ended). ``next_state`` is the
    stepped state, or a freshly reset one where ``done``; in both cases its ``reward``, ``done``,
    ``metrics`` and ``info['truncation']`` describe the step just taken, while its obs, physics
    and ``info['steps']`` are those to continue from. A learner stores
    ``(obs, action, reward, final_obs, terminated = done * (1 - truncation))``.
    Pure; works under jit and vmap (under vmap the reset is computed every call and selected by
    ``done``; :func:`step_autoreset_lanes` resets only on steps where some lane finished).
    """
    stepped = env.step(state, action)
    return _continue_from(stepped.done > 0, env.reset(reset_key), stepped), stepped.obs


def step_autoreset_lanes(env: LocomotionEnv, states: State, actions: jax.Array,
                         reset_keys: jax.Array) -> Tuple[State, jax.Array]:
    """:func:`step_autoreset` for lanes stacked on axis 0, with the same results lane by lane,
    but the resets are computed only on steps where at least one lane's episode ended
    (``lax.cond`` on ``any(done)``): the other steps cost one batched ``env.step``."""
    stepped = jax.vmap(env.step)(states, actions)
    done = stepped.done > 0

    def with_resets():
        return jax.vmap(_continue_from)(done, jax.vmap(env.reset)(reset_keys), stepped)

    return jax.lax.cond(jnp.any(done), with_resets, lambda: stepped), stepped.obs
