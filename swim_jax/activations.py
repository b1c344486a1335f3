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
``hard_swish(x)``, ``mish(x)``, ``elu(x, alpha=1)``. ``get_activation(name, **params)`` returns
``x -> y``; ``Activation`` is a flax.linen module that can hold the parameters (k, beta, alpha) as
learnable per-layer weights.

``ACTIVATIONS`` is the one description of every activation that the rest of the code derives
from: its function, its NumPy twin (``swim_jax.policy.activations``, same name and parameters: trained
policies run without JAX, ``swim_jax.policy.policy``), its parameters (name, default, valid range, legend
symbol), its display name, its reserved figure colour. From it come the config fields ``agent.activation.<param>``
(``swim_jax.agents.td3.ActivationConfig``), config validation, the sweepable and learnable parameters, the
report's run labels (:class:`ActivationSetting`: ``swim(k=0.75)+learnable``), their display names
(``Swim(k=0.75)``), the figures' colours and legends. Adding an activation is one entry there.
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, replace
from functools import partial
from typing import Callable, Mapping

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from swim_jax.policy import activations as activations_np

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
    "elu",
    "ACTIVATIONS",
    "ActivationParam",
    "ActivationSpec",
    "ActivationSetting",
    "get_spec",
    "param_names",
    "parameter_defaults",
    "learnable_activations",
    "label_activation",
    "display_name",
    "legend_name",
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
    """The inverse square root Swim uses by default, chosen by measurement (docs/PERFORMANCE.md: rsqrt-newton2).

    float32 (and float16/bfloat16, computed in float32): the bit-level guess + 2 Newton steps,
    within 1e-6 relative error over every float32 (``python -m swim_jax.bench rsqrt``) and the
    fastest variant that is. float64: ``lax.rsqrt`` (correctly rounded to ~1 ulp; the Newton variant
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


def elu(x: Array, alpha=1.0) -> Array:
    """ELU (Clevert et al. 2016): f(x) = x for x > 0, α·(eˣ − 1) otherwise, α > 0.

    f'(x) = 1 for x > 0, α·eˣ otherwise (α at the kink x = 0, the left derivative); ∂f/∂α = eˣ − 1
    for x ≤ 0, 0 otherwise. Plain autodiff: JAX differentiates expm1 as expm1(x) + 1, so f' is exact
    to an absolute ~eps·α (far left, α·eˣ < eps·α, it rounds to 0). The exponential sees 0 where
    x > 0, so a large positive x cannot overflow it (nor make the unselected branch's derivative
    inf·0 = NaN). ``alpha`` (a float, or an array broadcastable against x, traced when swept or
    learned) is cast to x's dtype.
    """
    x = jnp.asarray(x)
    if not isinstance(alpha, jax.core.Tracer):
        validate_params("elu", {"alpha": alpha})
    alpha = jnp.asarray(alpha, x.dtype)
    return jnp.where(x > 0, x, alpha * jnp.expm1(jnp.where(x > 0, 0, x)))


# ---------------------------------------------------------------------------------------------
# Registry
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ActivationParam:
    """One parameter of an activation: its ``name`` (also the config key ``agent.activation.<name>``),
    its ``default``, the open interval ``(low, high)`` of valid values (which must also be finite)
    and the ``symbol`` legends write (the name when empty)."""

    name: str
    default: float
    low: float = 0.0
    high: float = math.inf
    symbol: str = ""

    def problem(self, value) -> str | None:
        """Why ``value`` (a number or an array, every element checked) is not a valid value of this
        parameter, as ``"it must be finite and > 0"``; None when it is valid."""
        arr = np.asarray(value)
        if np.issubdtype(arr.dtype, np.number) and np.all(np.isfinite(arr)) and np.all((arr > self.low) & (arr < self.high)):
            return None
        bound = f"> {self.low:g}" if self.high == math.inf else f"in ({self.low:g}, {self.high:g})"
        return f"it must be finite and {bound}"


@dataclass(frozen=True)
class ActivationSpec:
    """A registered activation: ``fn(x, **params)``; its ``params`` (:class:`ActivationParam`, each
    a keyword of ``fn``); ``display``, its name in tables and legends (the registry name when
    empty); ``color``, the hex colour reserved for its plain label in the report's figures (None:
    it gets a generated colour like any other label); ``paper``: one of the paper's activations
    (Figures 1 and 2, and listed first, in registry order, in the report); ``numpy``: the same
    function in NumPy, ``swim_jax.policy.activations.<registry name>`` with the same parameters and
    defaults (required in the registry: ``swim_jax.policy.policy`` runs trained policies without JAX)."""

    fn: Callable[..., Array]
    params: tuple[ActivationParam, ...] = ()
    display: str = ""
    color: str | None = None
    paper: bool = False
    numpy: Callable[..., np.ndarray] | None = None

    @property
    def defaults(self) -> dict[str, float]:
        """``{param: default}``: ``{"k": 0.5}`` for Swim, ``{}`` for ReLU."""
        return {p.name: p.default for p in self.params}


ACTIVATIONS: dict[str, ActivationSpec] = {
    "swim": ActivationSpec(swim, (ActivationParam("k", 0.5),), "Swim", "#d62728", paper=True,  # tab:red
                           numpy=activations_np.swim),
    "swish": ActivationSpec(swish, (ActivationParam("beta", 1.0, symbol="β"),), "Swish", "#1f77b4", paper=True,  # tab:blue
                            numpy=activations_np.swish),
    "relu": ActivationSpec(relu, (), "ReLU", "#2ca02c", paper=True, numpy=activations_np.relu),  # tab:green
    "hard_swish": ActivationSpec(hard_swish, numpy=activations_np.hard_swish),
    "mish": ActivationSpec(mish, numpy=activations_np.mish),
    "elu": ActivationSpec(elu, (ActivationParam("alpha", 1.0, symbol="α"),), "ELU", numpy=activations_np.elu),
}


def _check_registry(registry: Mapping[str, ActivationSpec]) -> None:
    """Each parameter name is ONE config field (``agent.activation.<name>``) shared by every
    activation that takes it, so those must agree on its default, and it cannot be another member
    of the activation config (``name``, ``learnable``, ``params``); each default must be valid; its
    ``numpy`` twin must be ``swim_jax.policy.activations.<name>`` (code without JAX finds it by name)
    taking the same parameters with the same defaults. Raises ValueError naming the offending entry."""
    defaults: dict[str, float] = {}
    for act, spec in registry.items():
        for p in spec.params:
            if p.name in ("name", "learnable", "params") or not p.name.isidentifier():
                raise ValueError(f"activation {act!r}: parameter name {p.name!r} is reserved or not an identifier")
            if defaults.setdefault(p.name, p.default) != p.default:
                raise ValueError(f"activation {act!r}: parameter {p.name} defaults to {p.default}, another "
                                 f"activation's {p.name} to {defaults[p.name]} (one config field, one default)")
            if p.problem(p.default):
                raise ValueError(f"activation {act!r}: default {p.name}={p.default} is invalid; {p.problem(p.default)}")
        if spec.numpy is None or getattr(activations_np, act, None) is not spec.numpy:
            raise ValueError(f"activation {act!r}: numpy= must be its NumPy implementation "
                             f"swim_jax.policy.activations.{act} (policies run without JAX look it up by name)")
        keywords = {n: q.default for n, q in list(inspect.signature(spec.numpy).parameters.items())[1:]}
        if keywords != spec.defaults:
            raise ValueError(f"activation {act!r}: its NumPy implementation takes {keywords or 'no parameters'}, "
                             f"the registry entry {spec.defaults or 'no parameters'}")


_check_registry(ACTIVATIONS)


def get_spec(name: str) -> ActivationSpec:
    """The spec of a registry name, or of ``swim[<variant>]`` (Swim with that kernel; benchmarks).
    Unknown names raise ValueError listing the valid ones."""
    base, _, rest = name.partition("[")
    if base == "swim" and rest.endswith("]") and rest[:-1] in SWIM_VARIANTS:
        return replace(ACTIVATIONS["swim"], fn=partial(swim, variant=rest[:-1]))
    if name not in ACTIVATIONS:
        raise ValueError(
            f"unknown activation {name!r}; valid: {', '.join(sorted(ACTIVATIONS))}"
        )
    return ACTIVATIONS[name]


def param_names(name: str) -> tuple[str, ...]:
    """The parameters activation ``name`` takes, in spec order: ``("k",)`` for swim (and its kernel
    variants), ``()`` for relu and for unknown names (which :func:`get_spec` refuses)."""
    try:
        return tuple(p.name for p in get_spec(name).params)
    except ValueError:
        return ()


def parameter_defaults() -> dict[str, float]:
    """Every parameter name of the registry with its default, in registry order
    (``{"k": 0.5, "beta": 1.0, "alpha": 1.0}``): the parameter fields of the activation config."""
    return {p.name: p.default for spec in ACTIVATIONS.values() for p in spec.params}


def learnable_activations() -> tuple[str, ...]:
    """Registry names with at least one parameter, in registry order: those that can learn them."""
    return tuple(name for name, spec in ACTIVATIONS.items() if spec.params)


def validate_params(name: str, params: Mapping[str, object]) -> dict[str, float]:
    """Check ``params`` for activation ``name``; return them merged over the defaults.

    Raises ValueError naming the valid parameter names, or a bad value's valid range from its
    :class:`ActivationParam` ("it must be finite and > 0"). Traced values are accepted unchecked.
    """
    spec = get_spec(name)
    unknown = set(params) - set(spec.defaults)
    if unknown:
        valid = ", ".join(sorted(spec.defaults)) or "none"
        raise ValueError(
            f"unknown parameter(s) {', '.join(sorted(unknown))} for activation {name!r}; valid: {valid}"
        )
    merged = {**spec.defaults, **params}
    for p in spec.params:
        value = merged[p.name]
        problem = None if isinstance(value, jax.core.Tracer) else p.problem(value)
        if problem:
            raise ValueError(f"activation {name!r}: parameter {p.name}={value!r} is invalid; {problem}")
    return merged


def get_activation(name: str, **params) -> Callable[[Array], Array]:
    """Return ``x -> activation(x, **params)`` for a registered name, parameters validated.

    ``get_activation("swim", k=0.75)``; unknown names or parameters raise ValueError that lists
    the valid choices.
    """
    spec = get_spec(name)
    merged = validate_params(name, params)

    def activation(x: Array) -> Array:
        return spec.fn(x, **merged)

    activation.__name__ = f"{name}({', '.join(f'{k}={v}' for k, v in merged.items())})"
    return activation


class Activation(nn.Module):
    """A registered activation as a flax.linen layer.

    ``Activation(kind="swim", params={"k": 0.5}, learnable=False)``. With ``learnable=False``
    (default) the parameters are constants. With ``learnable=True`` each parameter of the spec (k
    for Swim, beta for Swish, alpha for ELU) becomes a scalar flax param of this layer named after
    it, initialised to its configured value, so every layer learns its own k (the paper's proposed
    future work).
    """

    kind: str | None = None
    params: Mapping[str, float] | None = None
    learnable: bool = False

    @nn.compact
    def __call__(self, x: Array) -> Array:
        if self.kind is None:
            raise ValueError(f"Activation needs kind=<name>; valid: {', '.join(sorted(ACTIVATIONS))}")
        spec = get_spec(self.kind)
        values = validate_params(self.kind, dict(self.params or {}))
        if self.learnable:
            if not values:
                raise ValueError(f"activation {self.kind!r} has no parameter to learn")
            values = {
                key: self.param(key, lambda _rng, v=v: jnp.asarray(v, x.dtype))
                for key, v in values.items()
            }
        return spec.fn(x, **values)


# ---------------------------------------------------------------------------------------------
# Labels: how runs name their activation in the report
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ActivationSetting:
    """What a run's hidden layers used: the registry ``name``, the value of every parameter of its
    spec (``(("k", 0.75),)``) and whether those were ``learnable``."""

    name: str
    params: tuple[tuple[str, float], ...] = ()
    learnable: bool = False

    @classmethod
    def from_config(cls, act: Mapping) -> "ActivationSetting":
        """From a config's ``agent.activation`` mapping (a run's config.yaml): ``name``, the values
        of the parameters that activation takes (missing or null ones at their defaults, others
        ignored; an unknown name takes none) and ``learnable``. A non-number raises ValueError."""
        name = str(act.get("name"))
        spec = ACTIVATIONS.get(name)
        params = tuple((p.name, p.default if act.get(p.name) is None else float(act[p.name]))
                       for p in (spec.params if spec else ()))
        return cls(name, params, bool(act.get("learnable")))

    @property
    def label(self) -> str:
        """``name``, then the parameters that differ from their defaults (``swim(k=0.75)``, values
        ``:g``-formatted), then ``+learnable`` for learnable parameters (``swim+learnable``)."""
        defaults = ACTIVATIONS[self.name].defaults if self.name in ACTIVATIONS else {}
        changed = [f"{key}={value:g}" for key, value in self.params if value != defaults.get(key)]
        label = f"{self.name}({','.join(changed)})" if changed else self.name
        return label + ("+learnable" if self.learnable else "")


def label_activation(label: str) -> str | None:
    """The registry name a run label is made of: the label itself, or followed by its parameters or
    ``+learnable`` (``swim(k=1)+learnable[tau=0.01]`` → swim). None for any other label, including
    a default-parameter point of a sweep over other values (``swim[tau=0.01]``)."""
    base = label.split("(")[0].split("+")[0]
    return base if base in ACTIVATIONS else None


def display_name(label: str) -> str:
    """A run label for tables and legends: the activation's display name, the rest kept
    (``swim(k=0.75)`` → ``Swim(k=0.75)``); labels without one unchanged (``mish``)."""
    name = label_activation(label)
    if name is None or not ACTIVATIONS[name].display:
        return label
    return ACTIVATIONS[name].display + label[len(name):]


def legend_name(name: str) -> str:
    """An activation at its default parameters, for figure legends: ``Swim (k=0.5)``,
    ``Swish (β=1)``, ``ReLU``."""
    spec = get_spec(name)
    title = spec.display or name
    if not spec.params:
        return title
    return f"{title} ({', '.join(f'{p.symbol or p.name}={p.default:g}' for p in spec.params)})"
