"""The agents' networks (flax.linen): actors and twin critics, activation injected by name.

Actor:   a = tanh(W₃ σ(W₂ σ(W₁ s + b₁) + b₂) + b₃) · scale + offset,
         scale = (high − low)/2, offset = (high + low)/2, so a ∈ [low, high]    (TD3)
Gaussian actor (SAC): the same hidden stack with a head of 2·|A| outputs [μ; ρ], the mean μ and
         log σ = lo + (hi − lo)·(tanh ρ + 1)/2 ∈ [lo, hi] (the log-std squashed into its range as
         cleanrl / SpinUp do); the policy's action is tanh(μ + σ·ε)·scale + offset.
Critics: Q_j(s, a) = W₃ʲ σ(W₂ʲ σ(W₁ʲ [s; a] + b₁ʲ) + b₂ʲ) + b₃ʲ for j = 1, 2, computed by ONE module
         vmapped over a leading critic axis of its parameters; output shape (2, batch).

σ is ``swim_jax.activations.Activation(kind, params, learnable)`` in every hidden layer (a fresh
layer each time, so a learnable k/beta/alpha is per layer). Dense layers use PyTorch's ``nn.Linear``
default initialisation (weights and biases U(±1/√fan_in)), as in the original TD3 code.

``matmul_dtype`` (e.g. ``jnp.bfloat16``): every Dense layer rounds its input, kernel and bias to that
type and accumulates the products in the network dtype,
y = Σᵢ bf16(xᵢ)·bf16(Wᵢⱼ) (summed in float32) + bf16(bⱼ), and its derivatives are such products too
(:func:`dense_dot_general`); parameters, optimiser state and the activations stay in the
network dtype. None (default): plain matmuls in the network dtype. Either way the derivative
products are laid out for XLA's CPU dot (:func:`dense_dot_general`).
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, Mapping, Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp
from jax import lax

from swim_jax.activations import Activation

Array = jax.Array


def torch_linear_kernel_init():
    """U(±1/√fan_in) for a (fan_in, fan_out) kernel: variance scaling 1/3, fan_in, uniform."""
    return nn.initializers.variance_scaling(1.0 / 3.0, "fan_in", "uniform")


def torch_linear_bias_init(fan_in: int):
    """U(±1/√fan_in) for a bias vector (PyTorch ``nn.Linear`` default)."""
    bound = 1.0 / float(fan_in) ** 0.5

    def init(key, shape, dtype=jnp.float32):
        return jax.random.uniform(key, shape, dtype, -bound, bound)

    return init


def dense_precision_options(dtype: Any, matmul_dtype: Any = None) -> dict:
    """``nn.Dense`` keyword options: parameters in ``dtype`` and :func:`dense_dot_general` as the
    product; with ``matmul_dtype`` the layer's inputs, kernel and bias are rounded to it and the
    matmul accumulates in ``dtype`` (``accumulate``), so the output is back in ``dtype``."""
    if matmul_dtype is None or jnp.dtype(matmul_dtype) == jnp.dtype(dtype):
        return dict(dtype=dtype, param_dtype=dtype, dot_general=dense_dot_general)
    return dict(dtype=matmul_dtype, param_dtype=dtype,
                dot_general=functools.partial(dense_dot_general, accumulate=jnp.dtype(dtype)))


def dense_dot_general(lhs, rhs, dimension_numbers, precision=None, preferred_element_type=None, *,
                      accumulate=None):
    """``y = x @ W`` for a Dense layer (the last axis of ``x`` with the first of ``W``, no batch axes;
    anything else is refused), with derivatives dx = g·Wᵀ and dW = xᵀ·g written for XLA's CPU dot.

    Without ``accumulate`` (products in the network dtype), dx is a plain product with an explicitly
    transposed kernel, g·(Wᵀ): XLA folds a transpose into the dot as an "NT" product, which its CPU
    (Eigen) kernel runs slower than the plain "NN" form, while Wᵀ is a kernel-sized copy
    (docs/PERFORMANCE.md: dense-transposed-kernel). dW stays the folded xᵀ·g: there the copy would
    be batch-sized and costs more than it saves.

    ``accumulate`` (float32) with low-precision ``x`` and ``W`` (bfloat16): products summed in
    ``accumulate``, output in ``accumulate``; the derivatives are low-precision products too (as
    PyTorch's autocast computes them): the output cotangent g is rounded to the operands' type, dx
    and dW are summed in ``accumulate`` and returned in the operands' type. dx is the folded g·Wᵀ
    (a bf16 Wᵀ copy made the TD3 step slower, same figure) and dW is xᵀ·g on an explicitly
    transposed x (XLA's CPU backend has no bf16 kernel for the folded form outside its YNNPACK fusions).
    ``precision`` and ``preferred_element_type`` from flax are ignored: the product is in the
    operands' type, or summed in ``accumulate``."""
    dense = (((lhs.ndim - 1,), (0,)), ((), ()))
    if tuple(map(tuple, dimension_numbers[0])) != dense[0] or any(dimension_numbers[1]):
        raise ValueError(f"dense_dot_general: only x @ W, got dimension_numbers {dimension_numbers}")
    return _dense_matmul(lhs, rhs, accumulate)


def _matmul(a, b, accumulate):
    """a @ b over a's last axis and b's first (no batch axes), summed in ``accumulate`` if given."""
    return lax.dot_general(a, b, (((a.ndim - 1,), (0,)), ((), ())), preferred_element_type=accumulate)


@functools.partial(jax.custom_vjp, nondiff_argnums=(2,))
def _dense_matmul(x, w, accumulate):
    return _matmul(x, w, accumulate)


def _dense_matmul_fwd(x, w, accumulate):
    return _matmul(x, w, accumulate), (x, w)


def _dense_matmul_bwd(accumulate, residuals, g):
    x, w = residuals
    g = g.astype(x.dtype)
    rows_x, rows_g = x.reshape(-1, x.shape[-1]), g.reshape(-1, g.shape[-1])
    # the barriers keep XLA from folding the transposes back into the dots (see dense_dot_general)
    if accumulate is None:
        dx = _matmul(g, lax.optimization_barrier(w.T), None)
        dw = lax.dot_general(rows_x, rows_g, (((0,), (0,)), ((), ())))
    else:
        dx = lax.dot_general(g, w, (((g.ndim - 1,), (1,)), ((), ())), preferred_element_type=accumulate)
        dw = _matmul(lax.optimization_barrier(rows_x.T), rows_g, accumulate)
    return dx.astype(x.dtype), dw.astype(w.dtype)


_dense_matmul.defvjp(_dense_matmul_fwd, _dense_matmul_bwd)


@dataclasses.dataclass(frozen=True)
class NetworkOptions:
    """What the actor and the critics share: hidden ``widths``, the ``activation`` registry name,
    its parameters (e.g. ``{"k": 0.5}``, stored as sorted ``(name, value)`` pairs so the options
    hash and compare by value; a value may be a traced array inside a sweep, which does not hash),
    ``learnable`` (each hidden layer learns its own activation parameters), the parameter ``dtype``
    and the optional ``matmul_dtype`` (see the module docstring)."""

    hidden: tuple[int, ...] = (256, 256)
    activation: str = "relu"
    activation_params: Mapping[str, Any] | tuple[tuple[str, Any], ...] = ()
    learnable: bool = False
    dtype: Any = jnp.float32
    matmul_dtype: Any = None

    @property
    def casts_to_matmul_dtype(self) -> bool:
        """Whether the Dense products round to ``matmul_dtype`` (set and not ``dtype``)."""
        return self.matmul_dtype is not None and jnp.dtype(self.matmul_dtype) != jnp.dtype(self.dtype)

    def __post_init__(self):
        # normalise the mutable, unordered forms callers pass (list widths, dict parameters)
        object.__setattr__(self, "hidden", tuple(self.hidden))
        object.__setattr__(self, "activation_params", tuple(sorted(dict(self.activation_params or {}).items())))


class _Body(nn.Module):
    """Hidden stack + linear head; the activation module is created fresh in every hidden layer."""

    options: NetworkOptions
    out_dim: int

    @nn.compact
    def __call__(self, x: Array) -> Array:
        o = self.options
        x = x.astype(o.dtype)
        precision = dense_precision_options(o.dtype, o.matmul_dtype)
        for i, width in enumerate(o.hidden):
            x = nn.Dense(
                width,
                **precision,
                kernel_init=torch_linear_kernel_init(),
                bias_init=torch_linear_bias_init(x.shape[-1]),
                name=f"dense_{i}",
            )(x)
            x = Activation(
                kind=o.activation,
                params=dict(o.activation_params),
                learnable=o.learnable,
                name=f"act_{i}",
            )(x)
        return nn.Dense(
            self.out_dim,
            **precision,
            kernel_init=torch_linear_kernel_init(),
            bias_init=torch_linear_bias_init(x.shape[-1]),
            name="head",
        )(x)


class Actor(nn.Module):
    """Deterministic policy μ(s) ∈ [low, high]: tanh head scaled to the action range.

    ``action_low``/``action_high`` are tuples (static); ``__call__(obs[..., obs_dim]) -> [..., act_dim]``.
    """

    action_low: Sequence[float]
    action_high: Sequence[float]
    options: NetworkOptions = NetworkOptions()

    @nn.compact
    def __call__(self, obs: Array) -> Array:
        dtype = self.options.dtype
        low = jnp.asarray(self.action_low, dtype)
        high = jnp.asarray(self.action_high, dtype)
        out = _Body(self.options, len(self.action_low), name="body")(obs)
        return jnp.tanh(out) * (high - low) / 2 + (high + low) / 2


class GaussianActor(nn.Module):
    """State-dependent Gaussian over pre-squash actions: ``__call__(obs[..., obs_dim]) -> (mean,
    log_std)``, each ``[..., act_dim]``: the first half of the head's outputs is the mean, the second
    the log-std squashed into [``log_std_min``, ``log_std_max``] (see the module docstring). Its
    parameters have :class:`Actor`'s layout (``body/dense_<i>``, ``body/head``), the head twice as
    wide."""

    action_dim: int
    log_std_min: float = -5.0
    log_std_max: float = 2.0
    options: NetworkOptions = NetworkOptions()

    @nn.compact
    def __call__(self, obs: Array) -> tuple[Array, Array]:
        out = _Body(self.options, 2 * self.action_dim, name="body")(obs)
        mean, raw = out[..., : self.action_dim], out[..., self.action_dim:]
        lo, hi = self.log_std_min, self.log_std_max
        return mean, lo + 0.5 * (hi - lo) * (jnp.tanh(raw) + 1)


class _Critic(nn.Module):
    """One Q network: Q(s, a) = MLP([s; a]) → scalar per row."""

    options: NetworkOptions

    @nn.compact
    def __call__(self, obs: Array, action: Array) -> Array:
        dtype = self.options.dtype
        x = jnp.concatenate([obs.astype(dtype), action.astype(dtype)], axis=-1)
        return _Body(self.options, 1, name="body")(x)[..., 0]


class TwinCritic(nn.Module):
    """Twin critics (Q₁, Q₂) as one module: parameters stacked on a leading axis of size
    ``num_critics`` (default 2), independently initialised; ``__call__(obs, action) -> (2, ...)``.

    With products in the network dtype each critic is handed its own (broadcast) copy of
    ``(obs, action)``: with one shared input XLA merges the critics' first layers into one wider
    product whose output and derivative it must then transpose into per-critic order; with a copy
    each, the layers stay one batched product (the same values up to float rounding; less time per
    TD3 step on a CPU, docs/PERFORMANCE.md: critic-input-copies). With bfloat16 products
    (``matmul_dtype``) the shared input is the faster form (same figure) and is kept."""

    options: NetworkOptions = NetworkOptions()
    num_critics: int = 2

    @nn.compact
    def __call__(self, obs: Array, action: Array) -> Array:
        vmapped = nn.vmap(
            _Critic,
            variable_axes={"params": 0},
            split_rngs={"params": True},
            in_axes=None if self.options.casts_to_matmul_dtype else 0,
            out_axes=0,
            axis_size=self.num_critics,
        )
        if not self.options.casts_to_matmul_dtype:  # a broadcast copy per critic (see above)
            obs, action = (jnp.broadcast_to(x, (self.num_critics, *x.shape)) for x in (obs, action))
        return vmapped(self.options, name="critics")(obs, action)
