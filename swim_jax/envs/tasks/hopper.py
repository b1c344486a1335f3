"""Hopper-v5 and Hopper-v4 (Gymnasium semantics) on MJX or MuJoCo C physics: only what differs from the base."""

from __future__ import annotations

import jax.numpy as jnp

from swim_jax.envs.tasks.planar_walker import PlanarWalker
from swim_jax.envs.terms import in_open_range


class HopperV5(PlanarWalker):
    """Hopper-v5: obs qpos[1:], clip(qvel, ±10) (11); reward healthy(1) + vx - 1e-3|a|^2.

    Terminates unless qpos[2:], qvel all in (-100, 100), z = qpos[1] > 0.7 and
    angle = qpos[2] in (-0.2, 0.2). Reset: qpos0 + U(±5e-3), qvel U(±5e-3).
    """

    env_id = "Hopper-v5"
    xml_file = "hopper.xml"

    def is_healthy(self, data):
        """Strict ranges: state[2:] in (-100, 100), z in (0.7, inf), angle in (-0.2, 0.2)."""
        state = jnp.concatenate([data.qpos, data.qvel])[2:]
        return (jnp.all(in_open_range(state, -100.0, 100.0))
                & in_open_range(data.qpos[1], 0.7, jnp.inf)
                & in_open_range(data.qpos[2], -0.2, 0.2))


class HopperV4(HopperV5):
    """Hopper-v4: as v5 but the healthy reward is also paid on the terminal step."""

    env_id = "Hopper-v4"
    healthy_reward_on_terminal_step = True
