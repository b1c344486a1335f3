"""Small pure helpers shared by the task files (observation pieces and health-range tests)."""

from __future__ import annotations

from typing import Optional

import jax
import jax.numpy as jnp
from jax import lax
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


def opaque(x: jax.Array, witness: jax.Array) -> jax.Array:
    """``x`` unchanged, through an integer XOR of its bits with ``isnan(witness)`` that the compiler
    cannot see through (0 unless ``witness`` is NaN; then the lowest payload bit, and a NaN in
    ``witness`` makes the result NaN anyway). See :func:`rounded` and :func:`true_divide`."""
    x = jnp.asarray(x)
    ints = {2: jnp.int16, 4: jnp.int32, 8: jnp.int64}[jnp.dtype(x.dtype).itemsize]
    flip = jnp.any(jnp.isnan(witness)).astype(ints)
    return lax.bitcast_convert_type(lax.bitcast_convert_type(x, ints) ^ flip, x.dtype)


def rounded(x: jax.Array) -> jax.Array:
    """``x`` as a value rounded on its own, so a later sum cannot absorb the product behind it.

    XLA's CPU backend contracts ``a - b * c`` inside one fused kernel into a fused multiply-add
    (one rounding instead of two; 1 ulp off NumPy in about a quarter of cases), and neither
    ``optimization_barrier`` nor a bit cast stops it; :func:`opaque` does. With it the reward
    terms round exactly as Gymnasium's NumPy code.
    """
    return opaque(x, x)


def true_divide(x: jax.Array, divisor: float) -> jax.Array:
    """``x / divisor`` as an IEEE division, as NumPy computes it (XLA rewrites division by a
    constant into multiplication by its rounded reciprocal, 1 ulp off in some cases)."""
    return x / opaque(jnp.asarray(divisor, x.dtype), x)


def _pairwise_sum(items: list) -> jax.Array:
    """NumPy's pairwise summation order (``pairwise_sum`` in numpy/_core/src/umath/loops_utils.h):
    below 8 items a running sum; up to 128, eight interleaved partial sums combined as a tree,
    then the remainder; above, the two halves (cut at a multiple of 8) summed recursively."""
    n = len(items)
    if n < 8:
        total = items[0]
        for x in items[1:]:
            total = total + x
        return total
    if n <= 128:
        partial = list(items[:8])
        end = n - n % 8
        for i in range(8, end, 8):
            partial = [p + x for p, x in zip(partial, items[i:i + 8])]
        p = partial
        total = ((p[0] + p[1]) + (p[2] + p[3])) + ((p[4] + p[5]) + (p[6] + p[7]))
        for x in items[end:]:
            total = total + x
        return total
    half = n // 2
    half -= half % 8
    return _pairwise_sum(items[:half]) + _pairwise_sum(items[half:])


def sum_of_squares(x: jax.Array) -> jax.Array:
    """``np.sum(np.square(x))`` bit for bit: every square rounded on its own (:func:`rounded`),
    summed over all entries (row-major) in NumPy's pairwise order. ``x`` has a static shape."""
    squares = rounded(jnp.square(x)).reshape(-1)
    return _pairwise_sum([squares[i] for i in range(squares.shape[0])])
