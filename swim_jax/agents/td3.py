"""TD3 (Fujimoto et al. 2018) as pure functions over pytrees.

Per update, on a batch (s, a, r, s', d) with d = terminated (truncation is NOT termination):

    ε      = clip(N(0, (σ̃·m)²), −c·m, c·m)               σ̃ = policy_noise, c = noise_clip
    a'     = clip(μ_φ'(s') + ε, low, high)                  m = max_action = (high − low)/2
    y      = r + γ (1 − d) · min(Q_θ'1(s', a'), Q_θ'2(s', a'))          (no gradient through y)
    L_Q    = mean((Q_θ1(s, a) − y)²) + mean((Q_θ2(s, a) − y)²)         → one Adam step on θ
    every ``policy_freq``-th update (``update_actor`` true), after the critic step:
    L_μ    = −mean(Q_θ1(s, μ_φ(s)))                        (θ the freshly updated critic) → Adam on φ
    θ' ← τθ + (1 − τ)θ',   φ' ← τφ + (1 − τ)φ'

The actor's delay is TD3's own: ``update(state, batch, key, iteration)`` steps the actor (and the
targets) on the iterations divisible by ``policy_freq`` (the original's ``total_it``), through
``update_delayed(..., update_actor)``.

Acting: ``act`` = μ_φ(s); ``explore`` = clip(μ_φ(s) + N(0, (expl_noise·m)²), low, high);
``random_action`` = U(low, high). Defaults are the original TD3 code's (``TD3Config``). The
shared parts (critic loss, Polyak averaging, Adam step, action range) are
``swim_jax/agents/base.py``'s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
from swim_jax.agents.base import (ActivationConfig, AgentBase, activation_fields, adam_step, all_finite,
                                  kind_field, polyak, replace_fields)
from swim_jax.agents.metrics import CORE_COUNTERS, CORE_METRICS, MetricSpec
from swim_jax.agents.networks import Actor, TwinCritic
from swim_jax.agents.replay import Transition

Array = jax.Array

__all__ = ["ActivationConfig", "TD3", "TD3Config", "TD3State", "UpdateMetrics", "replace_fields", "sweepable_fields"]


@dataclass(frozen=True)
class TD3Config:
    """TD3 hyperparameters; defaults = the original TD3 code (github.com/sfujim/TD3, main.py / TD3.py)."""

    kind: str = kind_field("td3")
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


# critic loss L_Q and mean Q₁ over every update; actor loss L_μ over the updates that stepped the actor
METRICS = MetricSpec(CORE_COUNTERS, CORE_METRICS)
UpdateMetrics = METRICS.update_type  # (critic_loss, actor_loss, q_mean, actor_updated); actor_loss 0 without actor step


def sweepable_fields(activation: str) -> tuple[str, ...]:
    """Float fields of :class:`TD3Config` that may differ between the lanes of one compiled program
    (sweep axes), as paths relative to the agent config: learning rates, γ, τ, the three noise
    scales and the activation's own parameters (``activation.k`` for swim, ``activation.beta`` for
    swish: its registry spec's parameters). Integer/structural fields (widths, batch size,
    policy_freq) change shapes or control flow and cannot be swept."""
    return TD3.SWEEPABLE + activation_fields(activation)


@dataclass(frozen=True)
class TD3(AgentBase):
    """TD3 for one environment: static config (a :class:`TD3Config`) + networks; all methods are
    pure and jittable."""

    kind = "td3"
    Config = TD3Config
    SWEEPABLE = ("actor_lr", "critic_lr", "discount", "tau", "policy_noise", "noise_clip", "expl_noise")
    METRICS = METRICS
    CHECKED = ("critic_loss", "actor_loss", "actor_params", "critic_params")

    # ---- derived static objects -------------------------------------------------------------
    @property
    def actor_net(self) -> Actor:
        """The policy network μ over this agent's action range."""
        return Actor(self.action_low, self.action_high, self.network_options)

    @property
    def q1_net(self) -> TwinCritic:
        """Q₁ alone: applied to the first slice of the twin critics' stacked parameters."""
        return TwinCritic(self.network_options, num_critics=1)

    # ---- pure functions ---------------------------------------------------------------------
    def init(self, key: Array) -> TD3State:
        """Fresh parameters (actor and critic from independent keys), targets = copies, Adam states."""
        actor, critic = self.init_networks(key)
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

    def actor_loss(self, actor_params, critic_params, obs: Array) -> Array:
        """L_μ = −mean(Q_θ1(s, μ_φ(s))), evaluating Q₁ only (as the original TD3's ``critic.Q1``):
        Q₂ would cost a critic forward and backward pass and contribute nothing."""
        q1_params = jax.tree.map(lambda p: p[:1], critic_params)
        q = self.q1_net.apply(q1_params, obs, self.act(actor_params, obs))
        return -jnp.mean(q[0])

    def update(self, state: TD3State, batch: Transition, key: Array, iteration) -> tuple[TD3State, UpdateMetrics]:
        """One TD3 iteration at 1-based update ``iteration`` (an int32 scalar, unbatched under vmap):
        the actor and the targets step when ``iteration`` is divisible by ``policy_freq``."""
        return self.update_delayed(state, batch, key, (iteration % self.config.policy_freq) == 0)

    def update_delayed(self, state: TD3State, batch: Transition, key: Array,
                       update_actor) -> tuple[TD3State, UpdateMetrics]:
        """One TD3 iteration (see module docstring). ``update_actor`` (bool scalar) selects the
        delayed actor + Polyak step; keep it unbatched under vmap so ``lax.cond`` stays a branch."""
        c = self.config
        y = self.td_target(state, batch, key)
        (l_q, q_mean), grads = jax.value_and_grad(self.critic_loss, has_aux=True)(state.critic, batch, y)
        critic, critic_opt = adam_step(self.critic_tx, grads, state.critic_opt, state.critic)

        def actor_step(operand):
            actor, actor_opt, actor_target, critic_target = operand
            l_mu, g = jax.value_and_grad(self.actor_loss)(actor, critic, batch.obs)
            actor, actor_opt = adam_step(self.actor_tx, g, actor_opt, actor)
            actor_target = polyak(actor_target, actor, c.tau)
            critic_target = polyak(critic_target, critic, c.tau)
            return (actor, actor_opt, actor_target, critic_target), l_mu.astype(l_q.dtype)

        def skip(operand):
            return operand, jnp.zeros((), l_q.dtype)

        operand = (state.actor, state.actor_opt, state.actor_target, state.critic_target)
        (actor, actor_opt, actor_target, critic_target), l_mu = jax.lax.cond(
            update_actor, actor_step, skip, operand
        )
        new = TD3State(actor, critic, actor_target, critic_target, actor_opt, critic_opt)
        return new, UpdateMetrics(l_q, l_mu, q_mean, jnp.asarray(update_actor, jnp.bool_))

    def finite(self, state: TD3State, metrics: UpdateMetrics) -> Array:
        """[L_Q, L_μ, actor parameters, critic parameters] finite (:attr:`CHECKED`)."""
        return jnp.stack([jnp.isfinite(metrics.critic_loss), jnp.isfinite(metrics.actor_loss),
                          all_finite(state.actor), all_finite(state.critic)])
