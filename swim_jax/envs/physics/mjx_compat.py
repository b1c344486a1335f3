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

2. RK4 for quaternions (Ant-v5 is the only env with ``integrator="RK4"`` and a free joint).
MJX 3.17 forms each stage's quaternion as ``q_0 * exp(a_i h w_{i-1})`` and the final one from the
averaged angular velocity. MuJoCo 4.0 C runs Runge-Kutta-Munthe-Kaas: the same stages, but each
stage's angular velocity w_i enters as the rate of the rotation vector theta_i of its stage,
``dexp^-1_{theta_i}(w_i)`` (:func:`dexp_inv`). Found by recording ``mj_step``'s stage states
through ``mjcb_control``; a NumPy replica of this scheme equals ``mj_step`` bit for bit (with and
without contacts). :func:`rungekutta4_c` implements it; MJX's scheme is ~1e-6 off per substep.

3. Constraint solver: MuJoCo C's Newton method and line search (:mod:`swim_jax.envs.physics.mjx_solver`) in place
of MJX's ``solver.solve``, which takes another path to the same minimum.

4. Dense factorisation of M (``smooth.factor_m`` / ``solve_m``) in plain JAX ops instead of
jaxlib's LAPACK kernels, which deadlocked when two ran at once (:mod:`swim_jax.envs.physics.small_linalg`).

5. qpos as given: MJX's ``smooth.kinematics`` writes the normalised quaternions of free and ball
joints back into qpos, MuJoCo C's ``mj_kinematics`` normalises copies. Gymnasium's Ant reset leaves
its root quaternion noised off unit length, and its observation shows it; :func:`kinematics_c`
keeps qpos, so every ``forward`` (reset, step, RK4 stage) starts from the qpos C would.

:func:`install` applies all five; it is idempotent and called when ``envs`` is imported.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from mujoco.mjx._src import collision_driver, collision_primitive, forward, math, scan, smooth, solver, support
from mujoco.mjx._src.types import GeomType, JointType

from swim_jax.envs.physics import mjx_solver, small_linalg

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

# |theta| below which dexp_inv's coefficient c(|theta|) is taken from its series (cancellation)
_SERIES_BELOW = 1e-2


def dexp_inv(theta, w):
    """Rate of the rotation vector ``theta`` of ``q0 * exp(theta)`` for body angular velocity w:

    ``dexp^-1_theta(w) = w + theta x w / 2 + c(t) theta x (theta x w)``, ``t = |theta|``,
    ``c(t) = (1 - (t/2) cot(t/2)) / t^2`` (series ``1/12 + t^2/720 + t^4/30240`` for t < 1e-2).
    """
    t2 = jnp.dot(theta, theta)
    t = jnp.sqrt(t2)
    closed_form = t >= _SERIES_BELOW
    t_safe = jnp.where(closed_form, t, 1.0)
    closed = (1.0 - 0.5 * t_safe / jnp.tan(0.5 * t_safe)) / (t_safe * t_safe)
    series = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
    cross = jnp.cross(theta, w)
    return w + 0.5 * cross + jnp.where(closed_form, closed, series) * jnp.cross(theta, cross)


def _tangent_rate(jnt_types, theta, qvel):
    """``scan.flat`` body: d(theta)/dt dof by dof, ``dexp_inv(theta, w)`` for a ball/free
    joint's rotation, qvel itself for every other dof (free-joint position, hinge, slide)."""
    out, vi = [], 0
    for jnt_type in jnt_types:
        if jnt_type == JointType.FREE:
            out += [qvel[vi:vi + 3], dexp_inv(theta[vi + 3:vi + 6], qvel[vi + 3:vi + 6])]
            vi += 6
        elif jnt_type == JointType.BALL:
            out.append(dexp_inv(theta[vi:vi + 3], qvel[vi:vi + 3]))
            vi += 3
        else:
            out.append(qvel[vi:vi + 1])
            vi += 1
    return jnp.concatenate(out) if out else jnp.empty((0,))


def rungekutta4_c(m, d):
    """Classic RK4 step as MuJoCo 4.0 C takes it: Runge-Kutta-Munthe-Kaas on each quaternion.

    Positions are carried as a tangent vector theta from ``qpos_0`` (``qpos(theta) = qpos_0 +
    theta`` for linear coordinates, ``q_0 * exp(theta)`` for quaternions). With h the timestep and
    k_i = (dexp_inv(theta_i, qvel_i), qacc_i, act_dot_i) from ``forward`` at stage i:
    theta_i = a_i h k_{i-1}[0], qvel_i = qvel_0 + a_i h qacc_{i-1}; the step ends at
    theta = h sum_i b_i k_i[0], qvel_0 + h sum_i b_i qacc_i. The warm start (and ``qacc``) is the
    last stage's qacc. Activations are clamped as in MJX's own integrators. (module docstring,
    point 2)

    Stages 1-3 run as a ``lax.scan`` over (a_i, b_i), so ``forward`` is traced once for them, not
    three times: the step traces and compiles in about half the time, at the same step time
    (docs/PERFORMANCE.md: mjx-rk4-scan). The arithmetic is the same; XLA compiles the loop body
    apart from its surroundings, so results differ from unrolled stages at float rounding
    (docs/ENVS.md, "RK4 stages as a scan").
    """
    h = m.opt.timestep
    d0 = d
    rate = lambda theta, qvel: scan.flat(m, _tangent_rate, "jvv", "v", m.jnt_type, theta, qvel)
    integrate = lambda *args: forward._integrate_pos(*args, dt=1.0)
    position = lambda theta: scan.flat(m, integrate, "jqv", "q", m.jnt_type, d0.qpos, theta)
    k = (d0.qvel, d0.qacc, d0.act_dot)  # theta_0 = 0: dexp_inv(0, w) = w
    total = jax.tree_util.tree_map(lambda x: _RK4_B[0] * x, k)

    def stage(carry, ab):
        """Stage i (one ``forward``, traced once for the three stages): its k_i, added to the sum."""
        d, k, total = carry
        a, b = ab
        theta = a * h * k[0]
        d = forward.forward(m, d.replace(qpos=position(theta), qvel=d0.qvel + a * h * k[1],
                                         act=d0.act + a * h * k[2], time=d0.time + a * h))
        k = (rate(theta, d.qvel), d.qacc, d.act_dot)
        return (d, k, jax.tree_util.tree_map(lambda s, x: s + b * x, total, k)), None

    stages = (jnp.asarray(_RK4_A, h.dtype), jnp.asarray(_RK4_B[1:], h.dtype))
    (d, _, total), _ = jax.lax.scan(stage, (d, k, total), stages)
    act = forward._next_activation(m, d0, total[2])
    return d.replace(qpos=position(h * total[0]), qvel=d0.qvel + h * total[1], act=act,
                     time=d0.time + h, qacc_warmstart=d.qacc)


_MJX_FACTOR_M, _MJX_SOLVE_M = smooth.factor_m, smooth.solve_m
_MJX_KINEMATICS = smooth.kinematics
_MJX_RUNGEKUTTA4 = forward.rungekutta4  # MJX's own scheme, kept for comparison (tests)


def factor_m_plain(m, d):
    """MJX's ``smooth.factor_m`` for a dense M without LAPACK (:mod:`swim_jax.envs.physics.small_linalg`)."""
    if support.is_sparse(m):
        return _MJX_FACTOR_M(m, d)
    return d.tree_replace({"_impl.qLD": small_linalg.cholesky_upper(d._impl.M)})


def solve_m_plain(m, d, x):
    """MJX's ``smooth.solve_m`` (x = M^-1 x) for a dense M without LAPACK."""
    if support.is_sparse(m):
        return _MJX_SOLVE_M(m, d, x)
    return small_linalg.cho_solve_upper(d._impl.qLD, x)


def kinematics_c(m, d):
    """MJX's ``smooth.kinematics`` with qpos left as given, as MuJoCo C's (module docstring, point 5)."""
    return _MJX_KINEMATICS(m, d).replace(qpos=d.qpos)


def install() -> None:
    """Register the C-consistent plane-capsule frame, RK4 step, Newton solver and kinematics (qpos
    kept), and LAPACK-free factorisation of M, in MJX (idempotent)."""
    solver.solve = mjx_solver.solve
    smooth.factor_m, smooth.solve_m = factor_m_plain, solve_m_plain
    collision_driver._COLLISION_FUNC[(GeomType.PLANE, GeomType.CAPSULE)] = plane_capsule_c_frame
    forward.rungekutta4 = rungekutta4_c
    smooth.kinematics = kinematics_c
