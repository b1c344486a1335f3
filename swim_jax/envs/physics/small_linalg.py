"""Cholesky factorisation and solves of small dense SPD matrices in plain JAX (no LAPACK calls).

MJX factors the joint-space inertia M (and its Newton solver the Hessian H) with
``jax.scipy.linalg.cho_factor`` / ``cho_solve``, which on CPU become jaxlib's batched LAPACK
kernels. Each of those splits its batch over XLA's CPU thread pool from inside a pool thread; two
running at once (e.g. an RK4 stage's solve next to the next stage's factorisation) deadlocked on
this 2-core machine (Ant-v5, 2000 states per call: every thread parked, nothing computing). The
matrices here are tiny (nv <= 14 for our envs), so an unrolled factorisation of static size in
ordinary JAX ops is just as fast and cannot deadlock. :mod:`swim_jax.envs.physics.mjx_compat` installs it.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def cholesky_upper(a: jax.Array) -> jax.Array:
    """Upper-triangular U with ``a = U^T U`` (zeros below the diagonal), for SPD ``a`` [n, n].

    Row j: ``U[j,j] = sqrt(a[j,j] - sum_i<j U[i,j]^2)``,
    ``U[j,k] = (a[j,k] - sum_i<j U[i,j] U[i,k]) / U[j,j]`` for k > j.
    """
    n = a.shape[-1]
    u = jnp.zeros_like(a)
    for j in range(n):
        pivot = jnp.sqrt(a[j, j] - jnp.dot(u[:j, j], u[:j, j]))
        u = u.at[j, j].set(pivot)
        if j + 1 < n:
            u = u.at[j, j + 1:].set((a[j, j + 1:] - u[:j, j] @ u[:j, j + 1:]) / pivot)
    return u


def cho_solve_upper(u: jax.Array, b: jax.Array) -> jax.Array:
    """x with ``U^T U x = b`` for U from :func:`cholesky_upper`; ``b`` is [n] or [n, k]."""
    n = u.shape[-1]
    y = jnp.zeros_like(b)
    for j in range(n):  # U^T y = b, forward substitution
        y = y.at[j].set((b[j] - jnp.tensordot(u[:j, j], y[:j], axes=1)) / u[j, j])
    x = jnp.zeros_like(b)
    for j in reversed(range(n)):  # U x = y, back substitution
        x = x.at[j].set((y[j] - jnp.tensordot(u[j, j + 1:], x[j + 1:], axes=1)) / u[j, j])
    return x
