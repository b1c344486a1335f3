"""Ant-v5 (Gymnasium semantics) on MJX or MuJoCo C physics: only what differs from the base."""

from __future__ import annotations

import jax.numpy as jnp

from swim_jax.envs.base import LocomotionEnv
from swim_jax.envs.terms import in_closed_range, qpos_qvel_obs, sum_of_squares

CONTACT_FORCE_RANGE = (-1.0, 1.0)
CONTACT_COST_WEIGHT = 5e-4
HEALTHY_Z_RANGE = (0.2, 1.0)
MAIN_BODY = 1  # the torso


class AntV5(LocomotionEnv):
    """Ant-v5: obs qpos[2:], qvel, clip(cfrc_ext[1:], ±1).flat (13 + 14 + 78 = 105).

    Reward healthy(1) + vx - 0.5|a|^2 - 5e-4 |clip(cfrc_ext, ±1)|^2, with vx from the torso's
    ``xpos`` (which, as in MuJoCo C after ``mj_step``, lags qpos by one substep). Terminates
    unless the state is finite and z = qpos[2] in [0.2, 1.0] (inclusive). frame_skip 5.
    Reset: qpos0 + U(±0.1), qvel 0.1 * N(0, 1).
    """

    env_id = "Ant-v5"
    xml_file = "ant.xml"
    frame_skip = 5
    ctrl_cost_weight = 0.5
    healthy_reward = 1.0
    reset_noise_scale = 0.1
    reset_qvel_noise = "normal"
    needs_post_constraint = True

    def _contact_forces(self, data):
        # MJX 3.17+ keeps cfrc_ext in the JAX implementation fields (public access is deprecated)
        impl = getattr(data, "_impl", None)
        cfrc = getattr(impl, "cfrc_ext", None) if impl is not None else None
        return jnp.clip(data.cfrc_ext if cfrc is None else cfrc, *CONTACT_FORCE_RANGE)

    def observation(self, data):
        """Gymnasium Ant ``_get_obs``: qpos[2:], qvel, clipped cfrc_ext[1:] flattened."""
        return jnp.concatenate([qpos_qvel_obs(data, skip_qpos=2),
                                self._contact_forces(data)[1:].ravel()])

    def is_healthy(self, data):
        """All of (qpos, qvel) finite and z = qpos[2] in [0.2, 1.0]."""
        state = jnp.concatenate([data.qpos, data.qvel])
        return jnp.all(jnp.isfinite(state)) & in_closed_range(data.qpos[2], *HEALTHY_Z_RANGE)

    def extra_cost(self, data):
        """Contact cost 5e-4 * sum(clip(cfrc_ext, -1, 1)^2) over all bodies."""
        cost = CONTACT_COST_WEIGHT * sum_of_squares(self._contact_forces(data))
        return cost, {"reward_contact": -cost}

    def x_position(self, data):
        """Torso body x from ``xpos`` (Gymnasium Ant uses the main body's xpos, not qpos)."""
        return data.xpos[MAIN_BODY, 0]
