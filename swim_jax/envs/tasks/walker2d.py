"""Walker2d-v5 and Walker2d-v4 (Gymnasium semantics) on MJX or MuJoCo C physics: only what differs from the base."""

from __future__ import annotations

from swim_jax.envs.tasks.planar_walker import PlanarWalker
from swim_jax.envs.terms import in_open_range


class Walker2dV5(PlanarWalker):
    """Walker2d-v5 (walker2d_v5.xml, both feet friction 1.9): obs qpos[1:], clip(qvel, ±10) (17).

    Reward healthy(1) + vx - 1e-3|a|^2; terminates unless z = qpos[1] in (0.8, 2.0) and
    angle = qpos[2] in (-1, 1). Reset: qpos0 + U(±5e-3), qvel U(±5e-3).
    """

    env_id = "Walker2d-v5"
    xml_file = "walker2d_v5.xml"

    def is_healthy(self, data):
        """Strict ranges: z in (0.8, 2.0) and angle in (-1, 1)."""
        return in_open_range(data.qpos[1], 0.8, 2.0) & in_open_range(data.qpos[2], -1.0, 1.0)


class Walker2dV4(Walker2dV5):
    """Walker2d-v4: walker2d.xml (foot frictions 0.9 right / 1.9 left), healthy reward also
    paid on the terminal step."""

    env_id = "Walker2d-v4"
    xml_file = "walker2d.xml"
    healthy_reward_on_terminal_step = True
