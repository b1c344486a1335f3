"""Make MJX match MuJoCo C (what Gymnasium runs) where the two differ for our envs.

1. Plane-capsule contact frame. MuJoCo C (``mjc_PlaneCapsule`` + ``mju_makeFrame``) sets the first contact tangent to the capsule
axis orthogonalised against the plane normal, whatever its length; only a zero projection falls
back. MJX's JAX ``plane_capsule`` falls back to the world y (or z) axis as soon as the projected
axis is shorter than 0.5, i.e. for any capsule steeper than 60 degrees. With the pyramidal
friction cone of the Gymnasium XMLs the friction pyramid is then rotated, which changes the
physics (Ant-v5, legs near vertical: qacc off by ~100, qpos by 1e-2 per step). Planar robots are
unaffected (a 90-degree rotation maps the pyramid onto itself).

:func:`install` replaces the (PLANE, CAPSULE) entry of MJX's collision table with the C-consistent
frame. It changes only the tangent frame.

2. RK4 for quaternions (Ant-v5 is the only env with ``integrator="RK4"``). MJX 3.17 forms each
stage's position on the manifold, ``q_i = q_0 * exp(a_i h w_{i-1})``, and the final one with the
averaged angular velocity. MuJoCo 4.0 C, measured against ``mj_step`` with constraints disabled,
integrates a quaternion as a plain vector with derivative ``dq/dt = q * (0, w) / 2`` (w in the
local frame), stage by stage, and normalises it: ``q_i = normalize(q_0 + a_i h dq_{i-1})``,
``q_1 = normalize(q_0 + h sum_i b_i dq_i)``. On a random Ant state the two differ by ~1e-6 in the
quaternion per substep; the plain-vector scheme (:func:`rungekutta4_c`) agrees with MuJoCo C to
~1e-11 in float64.

3. Constraint solver: MuJoCo C's Newton method and line search (:mod:`envs.mjx_solver`) in place
of MJX's ``solver.solve``, which takes another path to the same minimum.

4. Dense factorisation of M (``smooth.factor_m`` / ``solve_m``) in plain JAX ops instead of
jaxlib's LAPACK kernels, which deadlocked when two ran at once (:mod:`envs.small_linalg`).

:func:`install` applies all four; it is idempotent and called when ``envs`` is imported.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from mujoco.mjx._src import collision_driver, collision_primitive, forward, math, scan, smooth, support
from mujoco.mjx._src.types import GeomType, JointType

from envs import small_linalg

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


# MJX's own classic RK4 tableau (diagonal A: stage i uses stage i-1 only)
_RK4_A = tuple(float(a) for a in np.diag(forward._RK4_A))
_RK4_B = tuple(float(b) for b in forward._RK4_B)


def _joint_wise(rot, lin):
    """A ``scan.flat`` body mapping (jnt_types, qpos, qvel) to a qpos-sized vector joint by joint:
    ``rot(q, w)`` for a ball/free quaternion and its angular velocity, ``lin(p, v)`` for every
    other coordinate (free-joint position, hinge, slide) and its velocity."""
    def body(jnt_types, qpos, qvel):
        out, qi, vi = [], 0, 0
        for jnt_type in jnt_types:
            if jnt_type == JointType.FREE:
                out += [lin(qpos[qi:qi + 3], qvel[vi:vi + 3]), rot(qpos[qi + 3:qi + 7], qvel[vi + 3:vi + 6])]
                qi, vi = qi + 7, vi + 6
            elif jnt_type == JointType.BALL:
                out.append(rot(qpos[qi:qi + 4], qvel[vi:vi + 3]))
                qi, vi = qi + 4, vi + 3
            else:
                out.append(lin(qpos[qi:qi + 1], qvel[vi:vi + 1]))
                qi, vi = qi + 1, vi + 1
        return jnp.concatenate(out) if out else jnp.empty((0,))
    return body


# dqpos/dt: qvel for linear coordinates, q * (0, w) / 2 (w local) for quaternions
_qpos_rate = _joint_wise(rot=lambda q, w: 0.5 * math.quat_mul_axis(q, w), lin=lambda p, v: v)
# qpos with every quaternion scaled to unit norm
_normalize_quats = _joint_wise(rot=lambda q, w: math.normalize(q), lin=lambda p, v: p)


def rungekutta4_c(m, d):
    """Classic RK4 step as MuJoCo 4.0 C takes it (module docstring, point 2).

    With h the timestep, x = (qpos, qvel, act) and f(x) = (dqpos/dt, qacc, act_dot) from
    ``forward``: x_i = x_0 + a_i h f(x_{i-1}) (quaternions normalised), x_1 = x_0 + h sum_i b_i
    f(x_i); activations are clamped as in MJX's own integrators.
    """
    h = m.opt.timestep
    rate = lambda qpos, qvel: scan.flat(m, _qpos_rate, "jqv", "q", m.jnt_type, qpos, qvel)
    unit = lambda qpos: scan.flat(m, _normalize_quats, "jqv", "q", m.jnt_type, qpos, d0.qvel)
    d0 = d
    k = (rate(d0.qpos, d0.qvel), d0.qacc, d0.act_dot)
    total = jax.tree_util.tree_map(lambda x: _RK4_B[0] * x, k)
    for a, b in zip(_RK4_A, _RK4_B[1:]):
        d = forward.forward(m, d.replace(qpos=unit(d0.qpos + a * h * k[0]), qvel=d0.qvel + a * h * k[1],
                                         act=d0.act + a * h * k[2], time=d0.time + a * h))
        k = (rate(d.qpos, d.qvel), d.qacc, d.act_dot)
        total = jax.tree_util.tree_map(lambda s, x: s + b * x, total, k)
    act = forward._next_activation(m, d0, total[2])
    return d.replace(qpos=unit(d0.qpos + h * total[0]), qvel=d0.qvel + h * total[1], act=act,
                     time=d0.time + h, qacc_warmstart=d.qacc)


_MJX_FACTOR_M, _MJX_SOLVE_M = smooth.factor_m, smooth.solve_m


def factor_m_plain(m, d):
    """MJX's ``smooth.factor_m`` for a dense M without LAPACK (:mod:`envs.small_linalg`)."""
    if support.is_sparse(m):
        return _MJX_FACTOR_M(m, d)
    return d.tree_replace({"_impl.qLD": small_linalg.cholesky_upper(d._impl.M)})


def solve_m_plain(m, d, x):
    """MJX's ``smooth.solve_m`` (x = M^-1 x) for a dense M without LAPACK."""
    if support.is_sparse(m):
        return _MJX_SOLVE_M(m, d, x)
    return small_linalg.cho_solve_upper(d._impl.qLD, x)


def install() -> None:
    """Register the C-consistent plane-capsule frame, RK4 step and Newton solver, and LAPACK-free
    factorisation of M, in MJX (idempotent)."""
    from envs import mjx_solver
    from mujoco.mjx._src import solver

    solver.solve = mjx_solver.solve
    smooth.factor_m, smooth.solve_m = factor_m_plain, solve_m_plain
    collision_driver._COLLISION_FUNC[(GeomType.PLANE, GeomType.CAPSULE)] = plane_capsule_c_frame
    forward.rungekutta4 = rungekutta4_c
