"""Make MJX's plane-capsule contact frame match MuJoCo C (what Gymnasium runs).

MuJoCo C (``mjc_PlaneCapsule`` + ``mju_makeFrame``) sets the first contact tangent to the capsule
axis orthogonalised against the plane normal, whatever its length; only a zero projection falls
back. MJX's JAX ``plane_capsule`` falls back to the world y (or z) axis as soon as the projected
axis is shorter than 0.5, i.e. for any capsule steeper than 60 degrees. With the pyramidal
friction cone of the Gymnasium XMLs the friction pyramid is then rotated, which changes the
physics (Ant-v5, legs near vertical: qacc off by ~100, qpos by 1e-2 per step). Planar robots are
unaffected (a 90-degree rotation maps the pyramid onto itself).

:func:`install` replaces the (PLANE, CAPSULE) entry of MJX's collision table with the C-consistent
frame; it is idempotent and called when ``envs`` is imported. It changes only the tangent frame.
"""

from __future__ import annotations

import jax.numpy as jnp
from mujoco.mjx._src import collision_driver, collision_primitive, math
from mujoco.mjx._src.types import GeomType

_MINVAL = 1e-15


@collision_primitive.collider(ncon=2)
def plane_capsule_c_frame(plane, cap):
    """Two plane-capsule contacts (capsule end spheres), frame tangent = projected capsule axis."""
    n, axis = plane.mat[:, 2], cap.mat[:, 2]
    b, b_norm = math.normalize_with_norm(axis - n * jnp.dot(n, axis))
    b = jnp.where(b_norm < _MINVAL, jnp.array([1.0, 0.0, 0.0], b.dtype), b)
    frame = jnp.array([[n, b, jnp.cross(n, b)]])
    segment = axis * cap.size[1]
    out = []
    for offset in (segment, -segment):
        dist, pos = collision_primitive._plane_sphere(n, plane.pos, cap.pos + offset,
                                                      cap.size[0])
        out.append((dist[None], pos[None], frame))
    return tuple(jnp.concatenate(x) for x in zip(*out))


def install() -> None:
    """Register :func:`plane_capsule_c_frame` for (PLANE, CAPSULE) pairs in MJX (idempotent)."""
    collision_driver._COLLISION_FUNC[(GeomType.PLANE, GeomType.CAPSULE)] = plane_capsule_c_frame
