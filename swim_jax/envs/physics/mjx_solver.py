"""MuJoCo C's Newton constraint solver (``mj_solPrimal`` + ``PrimalSearch``) written for MJX.

MJX 3.17's ``solver.solve`` minimises the same convex cost as MuJoCo C but along a different
path, so where both stop at ``opt.tolerance`` their answers differ by about the tolerance
(joint velocities ~1e-6 apart in float64 at stiff contacts, docs/ENVS.md). The differences
(read from MuJoCo's ``engine_solver.c`` and MJX's ``solver.py``):

* line search: C takes one-sided Newton steps from the first Newton point (one cost evaluation
  each) and brackets only once the slope changes sign, then evaluates the midpoint and the two
  ends' Newton points; ``ls_iterations`` bounds *evaluations* (the one at alpha = 0 included).
  MJX evaluates three points per iteration from the start, accepts at a looser tolerance
  (``max(gtol, 8 eps |slope|)``) and never takes a non-improving step, which C may;
* costs along the line: C uses ``cost(alpha) - cost(0)`` row by row (exact zeros for rows whose
  state does not change); MJX subtracts absolute costs;
* outer loop: C also stops on the Newton decrement ``0.5 scale g'H^-1 g < tol``, stops on the
  improvement only when it is positive, can finish with zero iterations (small gradient and
  gap), and breaks when a line search returns alpha = 0; warm-start ties go to the warm start.

:func:`solve` reproduces C's branch decisions exactly (rounding aside: sums are reduced in a
different order), for what Gymnasium's locomotion XMLs use: the Newton solver, the pyramidal
cone, no friction loss. Anything else is passed to MJX's own solver. Under ``vmap`` the loops
run until the slowest element is done (MJX's line search always runs all its iterations).

One addition for float32: the line search's slope tolerance (``tolerance * ls_tolerance *
|search| / scale``, about 1e-10 relative for Gymnasium's XMLs) is below what float32 can resolve,
so C's rule alone ran nearly every search to its cap (``ls_iterations``) on steps with contacts,
changing nothing. A slope smaller than 8 ulps of the magnitude of its terms counts as zero (the
same idea as MJX's own acceptance tolerance, ``8 eps |slope terms|``). In float64 that floor lies
far below C's tolerance, which then decides as before (the float64 equivalence tests, 1e-8, are
the proof); in float32 it shortens the MJX step (docs/PERFORMANCE.md: mjx-slope-floor).
The solve also records its Newton iteration count in ``d._impl.solver_niter``, as MuJoCo C does.
Installed by :mod:`swim_jax.envs.physics.mjx_compat`.

Scale: ``1 / trace(M)`` as in MuJoCo 3.17+ (and MJX's ``_trace_m``). Islands: C solves each
constraint island separately; a single kinematic tree with constraints forms one island with all
its dofs, which is the monolithic solve done here.
"""

from __future__ import annotations

import contextlib
from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
from mujoco.mjx._src import smooth, support
from mujoco.mjx._src import solver as mjx_solver
from mujoco.mjx._src.types import ConeType, DisableBit, SolverType

from swim_jax.envs.physics import small_linalg

_MINVAL = mujoco.mjMINVAL
MJX_SOLVE = mjx_solver.solve  # MJX's own solver, kept before swim_jax.envs.physics.mjx_compat replaces it
IMPLEMENTATIONS = ("c", "mjx")
_active = ["c"]


def check_implementation(name: str) -> str:
    """``name`` if it is one of :data:`IMPLEMENTATIONS`, else ValueError in one line naming them."""
    if name not in IMPLEMENTATIONS:
        raise ValueError(f"solver_impl must be one of {', '.join(IMPLEMENTATIONS)}, got {name!r}")
    return name


@contextlib.contextmanager
def _implementation(name: str):
    """Within the block, traced MJX steps solve constraints with ``name``: "c" (:func:`solve`, the
    default) or "mjx" (MJX's own solver). Read at trace time. Private on purpose: only
    ``LocomotionEnv.physics_reset`` / ``physics_step`` use it, around the code they trace, so the
    choice is the env's own option (``solver_impl``) and every jitted function that steps an env
    closes over that env; there is no process-wide switch that a compiled program could miss."""
    check_implementation(name)
    previous, _active[0] = _active[0], name
    try:
        yield
    finally:
        _active[0] = previous


class _Point(NamedTuple):
    """A line-search point: step ``alpha``, ``cost(alpha) - cost(0)``, 1st and 2nd derivative."""
    alpha: jax.Array
    cost: jax.Array
    d0: jax.Array
    d1: jax.Array


def _select(pred, a, b):
    return jax.tree_util.tree_map(lambda x, y: jnp.where(pred, x, y), a, b)


def supported(m) -> bool:
    """True when :func:`solve` reproduces C for model ``m`` (Newton, pyramidal, no friction loss)."""
    has_frictionloss = bool(m._impl.dof_hasfrictionloss.any() or m._impl.tendon_hasfrictionloss.any())
    return (m.opt.solver == SolverType.NEWTON and m.opt.cone == ConeType.PYRAMIDAL
            and (not has_frictionloss or bool(m.opt.disableflags & DisableBit.FRICTIONLOSS)))


def _point_fn(d, ctx, jv, mv):
    """C's ``PrimalPrepare`` + ``PrimalEval`` for equality and inequality rows: returns
    ``alpha -> _Point`` with costs shifted by cost(0), row by row."""
    D, jaref, ne = d._impl.efc_D, ctx.Jaref, d._impl.ne
    dj = D * jaref
    q0, q1, q2 = 0.5 * (jaref * dj), jv * dj, 0.5 * (jv * D * jv)
    g1 = jnp.dot(ctx.search, ctx.Ma) - jnp.dot(d.qfrc_smooth, ctx.search)
    g2 = 0.5 * jnp.dot(ctx.search, mv)
    is_eq = jnp.arange(jaref.shape[0]) < ne
    cost0 = jnp.where(jaref < 0, q0, 0.0)  # inequality row's cost at alpha = 0

    def point(alpha):
        active = is_eq | (jaref + alpha * jv < 0)
        t0 = jnp.sum(jnp.where(active & ~is_eq, q0 - cost0, 0.0))
        t1 = g1 + jnp.sum(jnp.where(active, q1, 0.0))
        t2 = g2 + jnp.sum(jnp.where(active, q2, 0.0))
        cost = -jnp.sum(jnp.where(active, 0.0, cost0)) + (alpha * alpha * t2 + alpha * t1 + t0)
        d1 = 2 * t2
        return _Point(alpha, cost, 2 * alpha * t2 + t1, jnp.where(d1 <= 0, _MINVAL, d1))

    return point


_SLOPE_NOISE = 8.0  # slopes below this many ulps of their terms' magnitude count as zero


def _slope_magnitude(d, ctx, jv):
    """Sum of the magnitudes of the terms of the line's slope at alpha = 0 (search·Ma,
    qfrc_smooth·search and every row's D·jv·Jaref): the scale of its rounding error."""
    gauss = jnp.dot(jnp.abs(ctx.search), jnp.abs(ctx.Ma) + jnp.abs(d.qfrc_smooth))
    return gauss + jnp.sum(jnp.abs(jv * d._impl.efc_D * ctx.Jaref))


def _newton(p: _Point) -> jax.Array:
    return p.alpha - p.d0 / p.d1


def _update_bracket(p: _Point, cands: list[_Point]):
    """C's ``updateBracket``: p takes each candidate of its slope's sign with a smaller |slope|."""
    flag = jnp.asarray(False)
    for c in cands:
        upd = (((p.d0 < 0) & (c.d0 < 0) & (p.d0 < c.d0))
               | ((p.d0 > 0) & (c.d0 > 0) & (p.d0 > c.d0)))
        p, flag = _select(upd, c, p), flag | upd
    return p, flag


def _update_gradient(m, d, ctx):
    """grad = M qacc - qfrc_smooth - qfrc_constraint and Mgrad = H^-1 grad, with the Newton Hessian
    H = M + J' diag(D [active]) J (pyramidal cone), factorised without LAPACK (swim_jax.envs.physics.small_linalg)."""
    grad = ctx.Ma - d.qfrc_smooth - ctx.qfrc_constraint
    J = d._impl.efc_J
    h = support.full_m(m, d) + (J.T * (d._impl.efc_D * ctx.active)) @ J
    u = small_linalg.cholesky_upper(0.5 * (h + h.T))
    return ctx.replace(grad=grad, Mgrad=small_linalg.cho_solve_upper(u, grad))


def _bracket_step(point, gtol, s):
    """One iteration of the bracketed phase of :func:`linesearch`: evaluate the bracket's midpoint,
    move each end to the best candidate that keeps the bracket, take the Newton points of the
    moved ends; ``s`` = (p1, p2, p1next, p2next, n, done, result)."""
    p1, p2, p1next, p2next, n, _done, res = s
    pmid = point(0.5 * (p1.alpha + p2.alpha))
    cands = [p1next, p2next, pmid]
    stacked = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *cands)
    ok = jnp.abs(stacked.d0) < gtol
    best = jax.tree_util.tree_map(lambda x: x[jnp.argmin(jnp.where(ok, stacked.cost, jnp.inf))],
                                  stacked)
    p1u, f1 = _update_bracket(p1, cands)
    p2u, f2 = _update_bracket(p2, cands)
    p1next = _select(f1, point(_newton(p1u)), p1next)
    p2next = _select(f2, point(_newton(p2u)), p2next)
    conv, stuck = ok.any(), ~f1 & ~f2
    res = _select(conv, best, _select(stuck, pmid, res))
    n = n + 1 + f1.astype(n.dtype) + f2.astype(n.dtype)
    return p1u, p2u, p1next, p2next, n, conv | stuck, res


def linesearch(m, d, ctx, scale):
    """C's ``PrimalSearch`` along ``ctx.search``: returns (alpha, improvement = -(cost(alpha) -
    cost(0)), M·search, J·search). alpha = 0 means no step (the outer loop then stops). The slope
    tolerance is C's, or the slope's rounding floor where that is larger (module docstring)."""
    n_max = m.opt.ls_iterations
    snorm = jnp.linalg.norm(ctx.search)
    mv = support.mul_m(m, d, ctx.search)
    jv = d._impl.efc_J @ ctx.search
    point = _point_fn(d, ctx, jv, mv)
    gtol = jnp.maximum(m.opt.tolerance * m.opt.ls_tolerance * snorm / scale,
                       _SLOPE_NOISE * jnp.finfo(snorm.dtype).eps * _slope_magnitude(d, ctx, jv))

    zero = jnp.zeros_like(snorm)
    p0 = point(zero)
    p1 = point(_newton(p0))
    converged = (jnp.abs(p1.d0) < gtol) & ((p1.alpha == 0) | (p1.cost < 0))
    direction = jnp.where(p1.d0 < 0, 1.0, -1.0)

    # one-sided phase: Newton steps from p1 until the slope is small or changes sign
    def one_sided_cond(s):
        p1, _p2, n, conv = s
        return ~conv & (p1.d0 * direction <= -gtol) & (n < n_max)

    def one_sided_body(s):
        p1, _p2, n, _conv = s
        p_new = point(_newton(p1))
        return p_new, p1, n + 1, (jnp.abs(p_new.d0) < gtol) & (p_new.cost < 0)

    p1, p2, n, converged = jax.lax.while_loop(one_sided_cond, one_sided_body,
                                              (p1, p0, jnp.asarray(2), converged))
    take_p1 = converged | (n >= n_max)

    # bracketed phase: midpoint and the two ends' Newton points
    p1next = point(_newton(p1))
    n = n + 1

    def bracket_cond(s):
        _p1, _p2, _p1n, _p2n, n, done, _res = s
        return ~done & (n < n_max)

    p1b, p2b, _, _, _, done, res = jax.lax.while_loop(
        bracket_cond, lambda s: _bracket_step(point, gtol, s), (p1, p2, p1next, p1, n, take_p1, p1))
    # budget used up while bracketing: the better end if it improves, else no step
    no_step = _Point(zero, zero, zero, zero)
    best_end = _select((p1b.cost <= p2b.cost) & (p1b.cost < 0), p1b,
                       _select((p2b.cost <= p1b.cost) & (p2b.cost < 0), p2b, no_step))
    res = _select(take_p1, p1, _select(done, res, best_end))
    alpha = jnp.where(snorm < _MINVAL, zero, res.alpha)
    improvement = jnp.where(snorm < _MINVAL, zero, -res.cost)
    return alpha, improvement, mv, jv


def solve(m, d):
    """Constraint forces by MuJoCo C's Newton method (``mj_solPrimal``), see the module docstring.

    Same contract as ``mujoco.mjx._src.solver.solve``: returns ``d`` with qacc, qfrc_constraint and
    efc_force set. Models :func:`supported` does not cover, and code traced inside
    ``_implementation("mjx")`` (an env with ``solver_impl="mjx"``), use MJX's own solver.
    """
    if _active[0] == "mjx" or not supported(m):
        return MJX_SOLVE(m, d)
    tol = m.opt.tolerance
    Context = mjx_solver.Context
    ctx = Context.create(m, d.replace(qacc=d.qacc_smooth), grad=False)
    if not m.opt.disableflags & DisableBit.WARMSTART:
        warm = Context.create(m, d.replace(qacc=d.qacc_warmstart), grad=False)
        ctx = _select(warm.cost > ctx.cost, ctx, warm)  # tie: warm start
    d = d.replace(qacc=ctx.qacc)
    ctx = _update_gradient(m, d, ctx)
    ctx = ctx.replace(search=-ctx.Mgrad)
    scale = 1.0 / mjx_solver._trace_m(m, d)

    def decrement(c):
        return jnp.maximum(0.0, 0.5 * scale * jnp.dot(c.grad, c.Mgrad))

    gap = jnp.maximum(0.0, 0.5 * scale * jnp.dot(ctx.grad, smooth.solve_m(m, d, ctx.grad)))
    small_grad = scale * jnp.linalg.norm(ctx.grad) < tol
    done = small_grad & ((gap < tol) | (decrement(ctx) < tol))

    def cond(s):
        ctx, done = s
        return ~done & (ctx.solver_niter < m.opt.iterations)

    def body(s):
        ctx, _ = s
        alpha, improvement, mv, jv = linesearch(m, d, ctx, scale)
        new = ctx.replace(qacc=ctx.qacc + alpha * ctx.search, Ma=ctx.Ma + alpha * mv,
                          Jaref=ctx.Jaref + alpha * jv)
        new = _update_gradient(m, d, mjx_solver._update_constraint(m, d, new))
        improvement = scale * improvement
        stop = (((improvement > 0) & (improvement < tol))
                | (scale * jnp.linalg.norm(new.grad) < tol) | (decrement(new) < tol))
        new = new.replace(search=-new.Mgrad, solver_niter=ctx.solver_niter + 1)
        no_step = alpha == 0
        return _select(no_step, ctx, new), no_step | stop

    ctx, _ = jax.lax.while_loop(cond, body, (ctx, done))
    return d.tree_replace({
        "qfrc_constraint": ctx.qfrc_constraint,
        "qacc": ctx.qacc,
        "_impl.efc_force": ctx.efc_force,
        "_impl.solver_niter": ctx.solver_niter,
    })
