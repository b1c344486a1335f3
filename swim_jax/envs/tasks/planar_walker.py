"""What Gymnasium's two planar walkers (Hopper and Walker2d) share; each task file adds its model,
id and health rule."""

from __future__ import annotations

from swim_jax.envs.base import LocomotionEnv
from swim_jax.envs.terms import qpos_qvel_obs


class PlanarWalker(LocomotionEnv):
    """Hopper/Walker2d: frame skip 4; reward healthy(1) + vx − 1e-3·|a|²; reset qpos0 + U(±5e-3),
    qvel U(±5e-3); observation qpos[1:] (the x position left out), clip(qvel, −10, 10)."""

    frame_skip = 4
    ctrl_cost_weight = 1e-3
    healthy_reward = 1.0
    reset_noise_scale = 5e-3

    def observation(self, data):
        """Gymnasium's Hopper/Walker2d ``_get_obs``: qpos[1:], clip(qvel, -10, 10)."""
        return qpos_qvel_obs(data, skip_qpos=1, qvel_clip=10.0)
