"""Small pure helpers shared by the task files (observation pieces and health-range tests)."""

from __future__ import annotations

from typing import Optional

import jax
import jax.numpy as jnp
from mujoco import mjx


def qpos_qvel_obs(data: mjx.Data, skip_qpos: int, qvel_clip: Optional[float] = None) -> jax.Array:
    """``concat(qpos[skip_qpos:], qvel)`` with qvel optionally clipped to ``±qvel_clip``.

    This is Gymnasium's ``_get_obs`` for Hopper/Walker2d (skip 1, clip 10), HalfCheetah (skip 1),
    Swimmer and Ant (skip 2, no clip).
    """
    qvel = data.qvel if qvel_clip is None else jnp.clip(data.qvel, -qvel_clip, qvel_clip)
    return jnp.concatenate([data.qpos[skip_qpos:], qvel])


def in_open_range(x: jax.Array, low: float, high: float) -> jax.Array:
    """Elementwise ``low < x < high`` (Gymnasium's strict health checks)."""
    return jnp.logical_and(x > low, x < high)


def in_closed_range(x: jax.Array, low: float, high: float) -> jax.Array:
    """Elementwise ``low <= x <= high`` (Ant's inclusive z range)."""
    return jnp.logical_and(x >= low, x <= high)
