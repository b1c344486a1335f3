"""Activation functions: Swim and its rivals, one calling convention, one registry.

Swim (Abdool & Dear) with slope parameter k > 0::

    u = k·x,  r = rsqrt(1 + u²),  s = u·r = kx/√(1+k²x²)  ∈ (−1, 1)
    f(x)   = x/2 · (1 + s)
    f'(x)  = ½ (1 + s·(1 + r²))          (= paper eq. 1: ½(kx(k²x²+2)·r³ + 1))
    ∂f/∂k  = ½ x²·r³ = ½ (s/k)²·r

``swim`` is a ``jax.custom_jvp``: the tangent reuses r and s from the primal, so reverse mode stores
one array (f'(x)) per call and the backward pass is a single multiply. ``k`` may be a Python float
or a traced array (jit, vmap over k and differentiation with respect to k all work).

Numerical safety, every float dtype: where |kx| ≥ c(dtype) = 4/√eps, f is already x or 0 to
within rounding, and those lanes are selected to their limits, so an overflowing k²x² never reaches
the result; f(+inf) = +inf, f(−inf) = 0, f'(+inf) = 1, f'(−inf) = 0 exactly; no NaN from a finite
input; NaN in gives NaN out; the input dtype is kept.

Rivals share the calling convention ``fn(x, **params)``: ``swish(x, beta=1)``, ``relu(x)``,
``hard_swish(x)``, ``mish(x)``. ``get_activation(name, **params)`` returns ``x -> y``;
``Activation`` is a flax.linen module that can hold the parameter (k, beta) as a learnable
per-layer weight.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import Callable, Mapping

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

Array = jax.Array

__all__ = [
    "swim",
    "swim_reference",
    "make_swim",
    "rsqrt_newton",
    "rsqrt_default",
    "SWIM_VARIANTS",
    "swish",
    "relu",
    "hard_swish",
    "mish",
    "ACTIVATIONS",
    "ActivationSpec",
    "get_activation",
    "validate_params",
    "Activation",
]


# ---------------------------------------------------------------------------------------------
# Inverse square roots
# ---------------------------------------------------------------------------------------------

# Magic constants for the bit-level first guess of 1/sqrt(y) ("fast inverse square root").
# (int dtype, magic, Newton coefficients (a, b) of the first step y·(a − b·v·y²)).
# f32 uses Moroz et al. (2018)'s constant and modified first step, whose first iterate has
# a 6.5e-4 relative error (vs 1.75e-3 for Lomont/Carmack's 0x5f3759df with the plain step).
_FAST_RSQRT = {
    np.dtype(np.float32): (jnp.int32, 0x5F1FFFF9, (0.703952253 * 2.38924456, 0.703952253)),
    np.dtype(np.float64): (jnp.int64, 0x5FE6EB50C7B537A9, (1.5, 0.5)),
}


@partial(jax.custom_jvp, nondiff_argnums=(1,))
def rsqrt_newton(v: Array, steps: int = 2) -> Array:
    """1/sqrt(v) for v > 0 from a bit-level first guess refined by ``steps`` Newton steps.

    First guess: reinterpret v's bits as an integer i, take ``magic − (i >> 1)`` and reinterpret
    back. Each Newton step is y ← y·(3/2 − v/2·y²) (the f32 first step uses Moroz et al.'s tuned
    coefficients). The relative error roughly squares with each step; measure it with
    ``python -m swim_jax.bench rsqrt``. float16/bfloat16 inputs are computed in float32.
    The derivative is d/dv v^(−1/2) = −y³/2 from the computed y (not the derivative of the
    iteration, which is off by a factor ~ the first guess's error), so higher orders stay accurate.
    """
    dtype = v.dtype
    if np.dtype(dtype) not in _FAST_RSQRT:
        return rsqrt_newton(v.astype(jnp.float32), steps).astype(dtype)
    int_dtype, magic, (a, b) = _FAST_RSQRT[np.dtype(dtype)]
    bits = lax.bitcast_convert_type(v, int_dtype)
    y = lax.bitcast_convert_type(jnp.asarray(magic, int_dtype) - (bits >> 1), dtype)
    for i in range(steps):
        ai, bi = (a, b) if i == 0 else (1.5, 0.5)
        y = y * (ai - bi * v * y * y)
    return y


@rsqrt_newton.defjvp
def _rsqrt_newton_jvp(steps, primals, tangents):
    (v,), (v_dot,) = primals, tangents
    y = rsqrt_newton(v, steps)
    return y, -0.5 * y * y * y * v_dot


# ---------------------------------------------------------------------------------------------
# Swim
# ---------------------------------------------------------------------------------------------


def _saturation_bound(dtype) -> float:
    """c = 4/√eps(dtype): for |u| ≥ c, Swim equals its limits (x or 0) to within rounding.

    Exactly, 1 − s = 1 − u/√(1+u²) < 1/(2u²) ≤ eps/32 there, so f(x) = x·(1+s)/2 rounds to x for
    u ≥ c, and f(x) = x·(1+s)/2 ≈ 1/(4k²x) is below eps·|x|/32 for u ≤ −c. c² = 16/eps is far below
    the largest finite value of every IEEE/bfloat16 type.
    """
    return 4.0 / math.sqrt(float(jnp.finfo(dtype).eps))


def _swim_parts(x: Array, k: Array, rsqrt: Callable[[Array], Array]):
    """Shared intermediates of Swim's value and derivatives: u = kx, s = u·r, r = rsqrt(1 + u²).

    Returns (u, s, r, y, negative_tail, positive_tail) with y = f(x). Lanes with |u| ≥ c are
    selected to their exact limits (f = 0 and f = x), so k²x² overflowing there is harmless: those
    lanes' s and r are discarded by the selects, and inf/NaN inputs come out as f(±inf) = +inf/0,
    f(NaN) = NaN. In the middle, (1 + s)/2 is clamped at 0 so an approximate rsqrt can never flip
    the sign of f for large negative x.
    """
    c = _saturation_bound(x.dtype)
    u = k * x
    r = rsqrt(1 + u * u)
    s = u * r
    negative_tail, positive_tail = u <= -c, u >= c
    y_mid = x * jnp.maximum(0.5 + 0.5 * s, 0)
    y = jnp.where(negative_tail, jnp.zeros_like(y_mid), jnp.where(positive_tail, x, y_mid))
    return u, s, r, y, negative_tail, positive_tail


def make_swim(
    rsqrt: Callable[[Array], Array] = lax.rsqrt, name: str = "swim", share_s: bool = False
) -> Callable:
    """Build a Swim ``f(x, k)`` as a ``jax.custom_jvp`` around the given inverse square root.

    The returned function computes f(x) = x/2·(1 + s) with s = kx·r, r = rsqrt(1 + k²x²), and its
    JVP f'(x)·ẋ + ∂f/∂k·k̇ with f'(x) = ½(1 + s(1 + r²)) and ∂f/∂k = ½(s/k)²·r, all sharing r and s.
    In the tails |kx| ≥ c the derivatives take their limits exactly: f' = 0 or 1, ∂f/∂k = 0.
    Zero tangents (e.g. k a constant) are skipped, so no ∂f/∂k work is done when k is fixed.

    ``share_s``: under differentiation, materialise s once (``lax.optimization_barrier``) and derive
    r² = 1 − s² from it, instead of letting XLA recompute the rsqrt in both the value's and the
    derivative's fusion (XLA's CPU backend does not fuse siblings into one multi-output loop).
    """

    @jax.custom_jvp
    def swim_fn(x, k):
        return _swim_parts(x, k, rsqrt)[3]

    def swim_jvp(primals, tangents):
        x, k = primals
        x_dot, k_dot = tangents
        _, s, r, y, negative_tail, positive_tail = _swim_parts(x, k, rsqrt)
        if share_s:
            s = lax.optimization_barrier(s)
            r2 = jnp.maximum(1 - s * s, 0)  # r² = 1/(1 + u²) = 1 − s²
        else:
            r2 = r * r
        tails = negative_tail | positive_tail
        tangent_out = None
        if not isinstance(x_dot, jax.custom_derivatives.SymbolicZero):
            slope = 0.5 * (1 + s * (1 + r2))
            slope = jnp.where(negative_tail, jnp.zeros_like(slope), jnp.where(positive_tail, 1, slope))
            tangent_out = slope * x_dot
        if not isinstance(k_dot, jax.custom_derivatives.SymbolicZero):
            s_over_k = s / k
            r = jnp.sqrt(r2) if share_s else r
            dk = jnp.where(tails, jnp.zeros_like(s), 0.5 * s_over_k * s_over_k * r)
            tangent_out = dk * k_dot if tangent_out is None else tangent_out + dk * k_dot
        if tangent_out is None:  # both tangents zero: JAX never asks, but stay total
            tangent_out = jnp.zeros_like(y)
        return y, jnp.broadcast_to(tangent_out, y.shape).astype(y.dtype)

    swim_fn.defjvp(swim_jvp, symbolic_zeros=True)
    swim_fn.__name__ = name
    return swim_fn


def rsqrt_default(v: Array) -> Array:
    """The inverse square root Swim uses by default, chosen by measurement (docs/BENCHMARKS.md).

    float32 (and float16/bfloat16, computed in float32): the bit-level guess + 2 Newton steps,
    max relative error 7.5e-7 over every float32 (``python -m swim_jax.bench rsqrt``), the fastest
    variant within 1e-6. float64: ``lax.rsqrt`` (correctly rounded to ~1 ulp; the Newton variant
    needs 4 steps there and is no faster).
    """
    if v.dtype == jnp.float64:
        return lax.rsqrt(v)
    return rsqrt_newton(v, 2)


# Every Swim kernel the benchmark compares; ``swim`` uses "default".
SWIM_VARIANTS: dict[str, Callable] = {
    "default": make_swim(rsqrt_default, "swim_default"),
    "rsqrt": make_swim(lax.rsqrt, "swim_rsqrt"),
    "newton2": make_swim(lambda v: rsqrt_newton(v, 2), "swim_newton2"),
    "newton3": make_swim(lambda v: rsqrt_newton(v, 3), "swim_newton3"),
    "newton4": make_swim(lambda v: rsqrt_newton(v, 4), "swim_newton4"),
    "newton2+shared-s": make_swim(lambda v: rsqrt_newton(v, 2), "swim_newton2_shared_s", share_s=True),
}
def swim(x: Array, k=0.5, variant: str = "default") -> Array:
    """Swim: f(x) = x/2 · (kx/√(1+k²x²) + 1), with a custom rsqrt-based derivative.

    ``k`` > 0 is a Python float or an array broadcastable against x (traced values allowed).
    The result has x's dtype (k is cast to it). See the module docstring for the math.
    ``variant`` names the inverse-square-root kernel (``SWIM_VARIANTS``; benchmarks compare
    them); it is an explicit argument, so a program traced for one kernel is never reused for
    another (networks select one with the activation name ``swim[<variant>]``).
    """
    if variant not in SWIM_VARIANTS:
        raise ValueError(f"unknown Swim variant {variant!r}; valid: {', '.join(SWIM_VARIANTS)}")
    x = jnp.asarray(x)
    if not jnp.issubdtype(x.dtype, jnp.floating):
        x = x.astype(jnp.result_type(float))
    if not isinstance(k, jax.core.Tracer):
        validate_params("swim", {"k": k})
    return SWIM_VARIANTS[variant](x, jnp.asarray(k, x.dtype))


def swim_reference(x: Array, k=0.5) -> Array:
    """Swim as the paper writes it, x/2·(kx/√(1+k²x²) + 1), differentiated by plain autodiff.

    Not overflow-safe (k²x² overflows for huge |x|); kept as the naive baseline for benchmarks
    and as an independent autodiff reference in tests.
    """
    x = jnp.asarray(x)
    return x / 2 * (k * x / jnp.sqrt(1 + k * k * x * x) + 1)


# ---------------------------------------------------------------------------------------------
# Rivals
# ---------------------------------------------------------------------------------------------


def swish(x: Array, beta=1.0) -> Array:
    """Swish / SiLU: f(x) = x·σ(βx), σ the logistic sigmoid (numerically stable in JAX)."""
    x = jnp.asarray(x)
    if not isinstance(beta, jax.core.Tracer):
        validate_params("swish", {"beta": beta})
    return x * jax.nn.sigmoid(jnp.asarray(beta, x.dtype) * x)


def relu(x: Array) -> Array:
    """ReLU: f(x) = max(0, x)."""
    return jax.nn.relu(x)


def hard_swish(x: Array) -> Array:
    """Hard-Swish (Howard et al. 2019): f(x) = x·relu6(x + 3)/6."""
    return jax.nn.hard_swish(x)


def mish(x: Array) -> Array:
    """Mish (Misra 2019): f(x) = x·tanh(softplus(x))."""
    x = jnp.asarray(x)
    return x * jnp.tanh(jax.nn.softplus(x))


# ---------------------------------------------------------------------------------------------
# Registry
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ActivationSpec:
    """A registered activation: its function ``fn(x, **params)`` and default parameters."""

    fn: Callable[..., Array]
    defaults: Mapping[str, float]


ACTIVATIONS: dict[str, ActivationSpec] = {
    "swim": ActivationSpec(swim, {"k": 0.5}),
    "swish": ActivationSpec(swish, {"beta": 1.0}),
    "relu": ActivationSpec(relu, {}),
    "hard_swish": ActivationSpec(hard_swish, {}),
    "mish": ActivationSpec(mish, {}),
}


def _spec(name: str) -> ActivationSpec:
    """The spec of a registry name, or of ``swim[<variant>]`` (Swim with that kernel; benchmarks)."""
    base, _, rest = name.partition("[")
    if base == "swim" and rest.endswith("]") and rest[:-1] in SWIM_VARIANTS:
        variant = rest[:-1]
        return ActivationSpec(lambda x, k=0.5: swim(x, k, variant), ACTIVATIONS["swim"].defaults)
    if name not in ACTIVATIONS:
        raise ValueError(
            f"unknown activation {name!r}; valid: {', '.join(sorted(ACTIVATIONS))}"
        )
    return ACTIVATIONS[name]


def validate_params(name: str, params: Mapping[str, object]) -> dict[str, float]:
    """Check ``params`` for activation ``name``; return them merged over the defaults.

    Raises ValueError naming the valid parameter names, or the valid range (finite and > 0) for a
    bad value. Traced values are accepted unchecked.
    """
    spec = _spec(name)
    unknown = set(params) - set(spec.defaults)
    if unknown:
        valid = ", ".join(sorted(spec.defaults)) or "none"
        raise ValueError(
            f"unknown parameter(s) {', '.join(sorted(unknown))} for activation {name!r}; valid: {valid}"
        )
    merged = {**spec.defaults, **params}
    for key, value in merged.items():
        if isinstance(value, jax.core.Tracer):
            continue
        arr = np.asarray(value)
        if not np.issubdtype(arr.dtype, np.number) or not (np.all(np.isfinite(arr)) and np.all(arr > 0)):
            raise ValueError(
                f"activation {name!r}: parameter {key}={value!r} is invalid; it must be finite and > 0"
            )
    return merged


def get_activation(name: str, **params) -> Callable[[Array], Array]:
    """Return ``x -> activation(x, **params)`` for a registered name, parameters validated.

    ``get_activation("swim", k=0.75)``; unknown names or parameters raise ValueError that lists
    the valid choices.
    """
    spec = _spec(name)
    merged = validate_params(name, params)

    def activation(x: Array) -> Array:
        return spec.fn(x, **merged)

    activation.__name__ = f"{name}({', '.join(f'{k}={v}' for k, v in merged.items())})"
    return activation


class Activation(nn.Module):
    """A registered activation as a flax.linen layer.

    ``Activation(kind="swim", params={"k": 0.5}, learnable=False)``. With ``learnable=False`` (default) the parameters are constants. With ``learnable=True`` each
    parameter (k for Swim, beta for Swish) becomes a scalar flax param of this layer, initialised to
    its configured value, so every layer learns its own k (the paper's proposed future work).
    """

    kind: str | None = None
    params: Mapping[str, float] | None = None
    learnable: bool = False

    @nn.compact
    def __call__(self, x: Array) -> Array:
        if self.kind is None:
            raise ValueError(f"Activation needs kind=<name>; valid: {', '.join(sorted(ACTIVATIONS))}")
        spec = _spec(self.kind)
        values = validate_params(self.kind, dict(self.params or {}))
        if self.learnable:
            if not values:
                raise ValueError(f"activation {self.kind!r} has no parameter to learn")
            values = {
                key: self.param(key, lambda _rng, v=v: jnp.asarray(v, x.dtype))
                for key, v in values.items()
            }
        return spec.fn(x, **values)
