"""Swimmer-v5 (Gymnasium semantics) on MJX or MuJoCo C physics: only what differs from the base."""

from __future__ import annotations

from swim_jax.envs.base import LocomotionEnv
from swim_jax.envs.terms import qpos_qvel_obs


class SwimmerV5(LocomotionEnv):
    """Swimmer-v5: obs qpos[2:], qvel (8); reward vx - 1e-4|a|^2; never terminates.

    frame_skip 4 (dt 0.04), viscous fluid from swimmer.xml. Reset: qpos0 + U(±0.1), qvel U(±0.1).
    """

    env_id = "Swimmer-v5"
    xml_file = "swimmer.xml"
    frame_skip = 4
    ctrl_cost_weight = 1e-4
    reset_noise_scale = 0.1

    def observation(self, data):
        """Gymnasium Swimmer ``_get_obs``: qpos[2:], qvel."""
        return qpos_qvel_obs(data, skip_qpos=2)
