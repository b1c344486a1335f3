"""TD3 (Fujimoto et al. 2018) as pure functions over pytrees.

Per update, on a batch (s, a, r, s', d) with d = terminated (truncation is NOT termination):

    ε      = clip(N(0, (σ̃·m)²), −c·m, c·m)               σ̃ = policy_noise, c = noise_clip
    a'     = clip(μ_φ'(s') + ε, low, high)                  m = max_action = (high − low)/2
    y      = r + γ (1 − d) · min(Q_θ'1(s', a'), Q_θ'2(s', a'))          (no gradient through y)
    L_Q    = mean((Q_θ1(s, a) − y)²) + mean((Q_θ2(s, a) − y)²)         → one Adam step on θ
    every ``policy_freq``-th update (``update_actor`` true), after the critic step:
    L_μ    = −mean(Q_θ1(s, μ_φ(s)))                        (θ the freshly updated critic) → Adam on φ
    θ' ← τθ + (1 − τ)θ',   φ' ← τφ + (1 − τ)φ'

Acting: ``act`` = μ_φ(s); ``explore`` = clip(μ_φ(s) + N(0, (expl_noise·m)²), low, high);
``random_action`` = U(low, high). Defaults are the original TD3 code's (``TD3Config``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Mapping, NamedTuple, Sequence

import jax
import jax.numpy as jnp
import optax

from swim_jax.agents.networks import Actor, NetworkOptions, TwinCritic
from swim_jax.agents.replay import Transition
from swim_jax.activations import param_names, parameter_defaults

Array = jax.Array


def _activation_params(self) -> dict[str, Any]:
    """The registry parameters this activation takes (e.g. {"k": 0.5} for swim, {} for relu).
    A value set by :meth:`TD3.with_hparams` stays a (traced) array; config values are floats."""
    return {f: _as_param(getattr(self, f)) for f in param_names(self.name)}


def _as_param(v):
    return v if isinstance(v, jax.Array) else float(v)


# One float field per parameter of the activation registry (k, beta, alpha, ...), so adding an
# activation to swim_jax.activations.ACTIVATIONS adds its config key agent.activation.<param>.
ActivationConfig = dataclasses.make_dataclass(
    "ActivationConfig",
    [("name", str, field(default="relu"))]
    + [(p, float, field(default=d)) for p, d in parameter_defaults().items()]
    + [("learnable", bool, field(default=False))],
    frozen=True,
    namespace={
        "__module__": __name__,
        "__doc__": "Activation in every hidden layer: registry ``name``, one float field per "
                   "parameter of the registry (each activation uses its own: ``k`` swim, ``beta`` "
                   "swish, ``alpha`` elu; defaults from the registry); ``learnable`` makes them "
                   "per-layer trainable weights.",
        "params": _activation_params,
    },
)


def sweepable_fields(activation: str) -> tuple[str, ...]:
    """Float fields of :class:`TD3Config` that may differ between the lanes of one compiled program
    (sweep axes), as paths relative to the agent config: learning rates, γ, τ, the three noise
    scales and the activation's own parameters (``activation.k`` for swim, ``activation.beta`` for
    swish: its registry spec's parameters). Integer/structural fields (widths, batch size,
    policy_freq) change shapes or control flow and cannot be swept."""
    own = tuple(f"activation.{f}" for f in param_names(activation))
    return ("actor_lr", "critic_lr", "discount", "tau", "policy_noise", "noise_clip", "expl_noise") + own


def replace_fields(config: "TD3Config", changes: Mapping[str, Any]) -> "TD3Config":
    """``config`` with fields set by path relative to it: ``{"tau": 0.01, "activation.k": 2.0}``
    (values may be traced arrays inside a vmapped program)."""
    act_changes, top_changes = {}, {}
    for path, value in changes.items():
        if path.startswith("activation."):
            act_changes[path.split(".", 1)[1]] = value
        else:
            top_changes[path] = value
    activation = dataclasses.replace(config.activation, **act_changes)
    return dataclasses.replace(config, activation=activation, **top_changes)


@dataclass(frozen=True)
class TD3Config:
    """TD3 hyperparameters; defaults = the original TD3 code (github.com/sfujim/TD3, main.py / TD3.py)."""

    hidden: tuple[int, ...] = (256, 256)
    activation: ActivationConfig = field(default_factory=ActivationConfig)
    actor_lr: float = 3e-4
    critic_lr: float = 3e-4
    batch_size: int = 256
    discount: float = 0.99
    tau: float = 0.005
    policy_noise: float = 0.2
    noise_clip: float = 0.5
    expl_noise: float = 0.1
    policy_freq: int = 2


class TD3State(NamedTuple):
    """Online and target parameters and both Adam states (a pytree; vmap for many seeds)."""

    actor: Any
    critic: Any
    actor_target: Any
    critic_target: Any
    actor_opt: Any
    critic_opt: Any


class UpdateMetrics(NamedTuple):
    """Scalars from one update: critic loss L_Q, actor loss L_μ (0 when the actor did not update),
    mean of Q₁ on the batch, and whether the actor updated."""

    critic_loss: Array
    actor_loss: Array
    q_mean: Array
    actor_updated: Array


@dataclass(frozen=True)
class TD3:
    """TD3 for one environment: static config + networks; all methods are pure and jittable."""

    config: TD3Config
    obs_dim: int
    action_low: tuple[float, ...]
    action_high: tuple[float, ...]
    dtype: Any = jnp.float32
    matmul_dtype: Any = None  # e.g. jnp.bfloat16: Dense inputs/weights rounded, float32 accumulation

    # ---- derived static objects -------------------------------------------------------------
    @property
    def action_dim(self) -> int:
        return len(self.action_low)

    @property
    def network_options(self) -> NetworkOptions:
        """Options shared by the actor and the critics: widths, activation, precision."""
        a = self.config.activation
        return NetworkOptions(
            hidden=tuple(self.config.hidden),
            activation=a.name,
            activation_params=a.params(),
            learnable=a.learnable,
            dtype=self.dtype,
            matmul_dtype=self.matmul_dtype,
        )

    @property
    def actor_net(self) -> Actor:
        """The policy network μ over this agent's action range."""
        return Actor(self.action_low, self.action_high, self.network_options)

    @property
    def critic_net(self) -> TwinCritic:
        """The twin critics (Q₁, Q₂)."""
        return TwinCritic(self.network_options)

    @property
    def q1_net(self) -> TwinCritic:
        """Q₁ alone: applied to the first slice of the twin critics' stacked parameters."""
        return TwinCritic(self.network_options, num_critics=1)

    @property
    def actor_tx(self) -> optax.GradientTransformation:
        return optax.adam(self.config.actor_lr)

    @property
    def critic_tx(self) -> optax.GradientTransformation:
        return optax.adam(self.config.critic_lr)

    def with_hparams(self, hparams: Mapping[str, Array] | None) -> "TD3":
        """This agent with config fields replaced by per-lane values, e.g. ``{"tau": t,
        "activation.k": k}`` (paths from :func:`sweepable_fields`; values may be traced scalars).
        Inside a vmapped program each lane builds its own agent this way, so one compiled program
        trains every point of a hyperparameter sweep. None or an empty mapping returns ``self``."""
        if not hparams:
            return self
        return dataclasses.replace(self, config=replace_fields(self.config, hparams))

    def _low_high(self):
        return jnp.asarray(self.action_low, self.dtype), jnp.asarray(self.action_high, self.dtype)

    def max_action(self) -> Array:
        """m = (high − low)/2 per action dimension (the original's ``max_action`` for ±m ranges)."""
        low, high = self._low_high()
        return (high - low) / 2

    # ---- pure functions ---------------------------------------------------------------------
    def init(self, key: Array) -> TD3State:
        """Fresh parameters (actor and critic from independent keys), targets = copies, Adam states."""
        k_actor, k_critic = jax.random.split(key)
        obs = jnp.zeros((1, self.obs_dim), self.dtype)
        act = jnp.zeros((1, self.action_dim), self.dtype)
        actor = self.actor_net.init(k_actor, obs)
        critic = self.critic_net.init(k_critic, obs, act)
        return TD3State(
            actor=actor,
            critic=critic,
            actor_target=jax.tree.map(jnp.copy, actor),
            critic_target=jax.tree.map(jnp.copy, critic),
            actor_opt=self.actor_tx.init(actor),
            critic_opt=self.critic_tx.init(critic),
        )

    def act(self, actor_params, obs: Array) -> Array:
        """Deterministic action μ_φ(obs) ∈ [low, high] (any leading batch shape)."""
        return self.actor_net.apply(actor_params, obs)

    def explore(self, actor_params, obs: Array, key: Array) -> Array:
        """clip(μ_φ(obs) + N(0, (expl_noise·m)²), low, high)."""
        low, high = self._low_high()
        mu = self.act(actor_params, obs)
        noise = jax.random.normal(key, mu.shape, self.dtype) * (self.config.expl_noise * self.max_action())
        return jnp.clip(mu + noise, low, high)

    def random_action(self, key: Array, shape: Sequence[int] = ()) -> Array:
        """U(low, high) of shape ``(*shape, action_dim)``."""
        low, high = self._low_high()
        return jax.random.uniform(key, (*shape, self.action_dim), self.dtype, low, high)

    def td_target(self, state: TD3State, batch: Transition, key: Array) -> Array:
        """y = r + γ(1 − terminated)·min_j Q_θ'j(s', clip(μ_φ'(s') + clipped noise, low, high))."""
        c = self.config
        low, high = self._low_high()
        m = self.max_action()
        mu_next = self.act(state.actor_target, batch.next_obs)
        noise = jax.random.normal(key, mu_next.shape, self.dtype) * (c.policy_noise * m)
        noise = jnp.clip(noise, -c.noise_clip * m, c.noise_clip * m)
        next_action = jnp.clip(mu_next + noise, low, high)
        q_next = self.critic_net.apply(state.critic_target, batch.next_obs, next_action)
        min_q = jnp.min(q_next, axis=0)
        y = batch.reward + c.discount * (1 - batch.terminated) * min_q
        return jax.lax.stop_gradient(y)

    def critic_loss(self, critic_params, batch: Transition, y: Array):
        """L_Q = Σ_j mean((Q_θj(s, a) − y)²); returns (loss, mean Q₁)."""
        q = self.critic_net.apply(critic_params, batch.obs, batch.action)
        return jnp.sum(jnp.mean((q - y[None]) ** 2, axis=1)), jnp.mean(q[0])

    def actor_loss(self, actor_params, critic_params, obs: Array) -> Array:
        """L_μ = −mean(Q_θ1(s, μ_φ(s))), evaluating Q₁ only (as the original TD3's ``critic.Q1``):
        Q₂ would cost a critic forward and backward pass and contribute nothing."""
        q1_params = jax.tree.map(lambda p: p[:1], critic_params)
        q = self.q1_net.apply(q1_params, obs, self.act(actor_params, obs))
        return -jnp.mean(q[0])

    def update(self, state: TD3State, batch: Transition, key: Array, update_actor) -> tuple[TD3State, UpdateMetrics]:
        """One TD3 iteration (see module docstring). ``update_actor`` (bool scalar) selects the
        delayed actor + Polyak step; keep it unbatched under vmap so ``lax.cond`` stays a branch."""
        c = self.config
        y = self.td_target(state, batch, key)
        (l_q, q_mean), grads = jax.value_and_grad(self.critic_loss, has_aux=True)(state.critic, batch, y)
        updates, critic_opt = self.critic_tx.update(grads, state.critic_opt, state.critic)
        critic = optax.apply_updates(state.critic, updates)

        def actor_step(operand):
            actor, actor_opt, actor_target, critic_target = operand
            l_mu, g = jax.value_and_grad(self.actor_loss)(actor, critic, batch.obs)
            upd, actor_opt = self.actor_tx.update(g, actor_opt, actor)
            actor = optax.apply_updates(actor, upd)
            polyak = lambda t, p: (c.tau * p + (1 - c.tau) * t).astype(t.dtype)
            actor_target = jax.tree.map(polyak, actor_target, actor)
            critic_target = jax.tree.map(polyak, critic_target, critic)
            return (actor, actor_opt, actor_target, critic_target), l_mu.astype(l_q.dtype)

        def skip(operand):
            return operand, jnp.zeros((), l_q.dtype)

        operand = (state.actor, state.actor_opt, state.actor_target, state.critic_target)
        (actor, actor_opt, actor_target, critic_target), l_mu = jax.lax.cond(
            update_actor, actor_step, skip, operand
        )
        new = TD3State(actor, critic, actor_target, critic_target, actor_opt, critic_opt)
        return new, UpdateMetrics(l_q, l_mu, q_mean, jnp.asarray(update_actor, jnp.bool_))
