"""HalfCheetah-v5 (Gymnasium semantics) on MJX or MuJoCo C physics: only what differs from the base."""

from __future__ import annotations

from swim_jax.envs.base import LocomotionEnv
from swim_jax.envs.terms import qpos_qvel_obs


class HalfCheetahV5(LocomotionEnv):
    """HalfCheetah-v5: obs qpos[1:], qvel (17); reward vx - 0.1|a|^2; never terminates.

    frame_skip 5 (dt 0.05). Reset: qpos0 + U(±0.1), qvel 0.1 * N(0, 1).
    """

    env_id = "HalfCheetah-v5"
    xml_file = "half_cheetah.xml"
    frame_skip = 5
    ctrl_cost_weight = 0.1
    reset_noise_scale = 0.1
    reset_qvel_noise = "normal"

    def observation(self, data):
        """Gymnasium HalfCheetah ``_get_obs``: qpos[1:], qvel (unclipped)."""
        return qpos_qvel_obs(data, skip_qpos=1)
