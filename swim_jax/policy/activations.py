"""The registry's activations in NumPy, importable without JAX (``swim_jax.policy.policy`` runs trained
policies with them).

Each function here is the ``numpy`` implementation of the registry entry of the same name in
``swim_jax.activations.ACTIVATIONS`` (the registry check insists on that name and on the same
parameters with the same defaults, so code without JAX finds an activation's NumPy twin by its
registry name: :func:`get`). Same calling convention as the JAX side, ``fn(x, **params)``; the
input's float dtype is kept (parameters are cast to it; non-float input becomes float64).

Numerics follow the JAX functions: Swim selects its limits (x or 0) where |kx| ≥ 4/√eps, so an
overflowing k²x² never reaches the result and f(±inf) = +inf/0; Swish's sigmoid never evaluates
exp of a positive number; ELU's exponential sees 0 where x > 0. NaN in gives NaN out.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

def _floating(x) -> np.ndarray:
    x = np.asarray(x)
    return x if np.issubdtype(x.dtype, np.floating) else x.astype(np.float64)


def swim(x, k=0.5) -> np.ndarray:
    """Swim: f(x) = x/2 · (kx/√(1+k²x²) + 1), limits selected where |kx| ≥ 4/√eps(dtype)."""
    x = _floating(x)
    k = np.asarray(k, x.dtype)
    c = 4.0 / math.sqrt(float(np.finfo(x.dtype).eps))
    with np.errstate(over="ignore", invalid="ignore"):
        u = k * x
        s = u / np.sqrt(1 + u * u)
        y = x * np.maximum(0.5 + 0.5 * s, 0)
        return np.where(u <= -c, np.zeros_like(y), np.where(u >= c, x, y))


def swish(x, beta=1.0) -> np.ndarray:
    """Swish / SiLU: f(x) = x·σ(βx), σ(z) = 1/(1 + e⁻ᶻ) for z ≥ 0 and eᶻ/(1 + eᶻ) below."""
    x = _floating(x)
    with np.errstate(over="ignore", invalid="ignore"):  # β·x past the float range: ±inf, as in JAX
        z = np.asarray(beta, x.dtype) * x
        e = np.exp(-np.abs(z))
        return x * np.where(z >= 0, 1 / (1 + e), e / (1 + e))


def relu(x) -> np.ndarray:
    """ReLU: f(x) = max(0, x)."""
    x = _floating(x)
    return np.maximum(x, np.zeros_like(x))


def hard_swish(x) -> np.ndarray:
    """Hard-Swish: f(x) = x·(relu6(x + 3)/6) (that order: no overflow for huge x)."""
    x = _floating(x)
    with np.errstate(invalid="ignore"):  # −inf·0 = NaN, as in JAX
        return x * (np.clip(x + 3, 0, 6) / 6)


def mish(x) -> np.ndarray:
    """Mish: f(x) = x·tanh(softplus(x)), softplus(x) = log(1 + eˣ) = logaddexp(x, 0)."""
    x = _floating(x)
    with np.errstate(invalid="ignore"):  # −inf·0 = NaN, as in JAX
        return x * np.tanh(np.logaddexp(x, np.zeros_like(x)))


def elu(x, alpha=1.0) -> np.ndarray:
    """ELU: f(x) = x for x > 0, α·(eˣ − 1) otherwise."""
    x = _floating(x)
    alpha = np.asarray(alpha, x.dtype)
    return np.where(x > 0, x, alpha * np.expm1(np.where(x > 0, np.zeros_like(x), x)))


def names() -> tuple[str, ...]:
    """The activations defined in this module (the registry's names), in definition order."""
    return tuple(n for n, f in globals().items()
                 if callable(f) and not n.startswith("_") and getattr(f, "__module__", None) == __name__
                 and n not in ("get", "names"))


def get(name: str) -> Callable[..., np.ndarray]:
    """The NumPy activation of registry name ``name``; ValueError naming the valid ones."""
    if name not in names():
        raise ValueError(f"unknown activation {name!r}; valid: {', '.join(sorted(names()))}")
    return globals()[name]
