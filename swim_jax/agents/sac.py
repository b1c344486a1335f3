"""SAC (Haarnoja et al. 2018, "Soft Actor-Critic Algorithms and Applications") as pure functions over pytrees.

Twin critics with target networks, a tanh-squashed Gaussian actor with state-dependent log-std,
and an automatically tuned temperature α with target entropy H̄ = −|A|. The algorithm and its
defaults (``SACConfig``) follow ONE reference implementation: cleanrl's
``cleanrl/sac_continuous_action.py`` (github.com/vwxyzjn/cleanrl, commit 004f8a0), including its
delayed actor loop, its log-std squashing and its log-prob correction.

Squashed Gaussian (``squashed_gaussian``), with m = (high − low)/2, c = (high + low)/2:

    [μ, log σ] = GaussianActor_φ(s)        log σ ∈ [log_std_min, log_std_max] (tanh-squashed)
    u = μ + σ·ε,  ε ~ N(0, I);   a = tanh(u)·m + c
    log π(a|s) = Σ_i [ −ε_i²/2 − log σ_i − ½ log 2π − log(m_i (1 − tanh² u_i) + 10⁻⁶) ]

Per update on a batch (s, a, r, s', d) with d = terminated, at 1-based update ``iteration``:

    α      = exp(log α)
    y      = r + γ (1 − d) · (min_j Q_θ'j(s', a') − α log π(a'|s')),   a' ~ π_φ(·|s')   (no gradient)
    L_Q    = Σ_j mean((Q_θj(s, a) − y)²)                                 → Adam on θ (critic_lr)
    when iteration mod policy_freq = 0: policy_freq times (cleanrl's delayed loop), same batch:
        L_π = mean(α log π(ã|s) − min_j Q_θj(s, ã)),  ã ~ π_φ(·|s)       → Adam on φ (actor_lr)
        L_α = mean(−exp(log α)·(log π(ã'|s) + H̄)),  ã' ~ π_φ(·|s) (the new φ, no gradient)
                                                                        → Adam on log α (alpha_lr)
        α ← exp(log α)
    when iteration mod target_freq = 0:  θ' ← τθ + (1 − τ)θ'

Keys: ``k_next, k_actor = split(key)``; the j-th actor step uses ``split(split(k_actor,
policy_freq)[j])`` = (ã's key, ã''s key). Acting: ``explore`` samples a ~ π_φ(·|s); ``act`` (evaluation,
export) is the mean action tanh(μ)·m + c; ``random_action`` = U(low, high).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import optax

from swim_jax.agents.base import ActivationConfig, AgentBase, adam_step, all_finite, kind_field, polyak
from swim_jax.agents.metrics import CORE_COUNTERS, CORE_METRICS, Metric, MetricSpec
from swim_jax.agents.networks import GaussianActor
from swim_jax.agents.replay import Transition

Array = jax.Array

LOG_PROB_EPS = 1e-6  # cleanrl's ε inside log(m (1 − tanh² u) + ε)


@dataclass(frozen=True)
class SACConfig:
    """SAC hyperparameters; defaults = cleanrl's ``sac_continuous_action.py`` (``Args``, commit
    004f8a0): policy_lr 3e-4 (``actor_lr``), q_lr 1e-3 (``critic_lr``, and the temperature's Adam,
    ``alpha_lr``), batch_size 256, gamma 0.99, tau 0.005, policy_frequency 2, target_network_frequency
    1, LOG_STD_MIN −5, LOG_STD_MAX 2, autotune with log α = 0 at the start. Its learning_starts 5e3 is
    the run config's ``learning_starts`` (configs/*_sac.yaml set it)."""

    kind: str = kind_field("sac")
    hidden: tuple[int, ...] = (256, 256)
    activation: ActivationConfig = field(default_factory=ActivationConfig)
    actor_lr: float = 3e-4
    critic_lr: float = 1e-3
    alpha_lr: float = 1e-3
    batch_size: int = 256
    discount: float = 0.99
    tau: float = 0.005
    policy_freq: int = 2
    target_freq: int = 1
    log_std_min: float = -5.0
    log_std_max: float = 2.0

    def check(self) -> None:
        """ValueError (one line) unless log_std_min < log_std_max."""
        if not self.log_std_min < self.log_std_max:
            raise ValueError(f"agent.log_std_min ({self.log_std_min}) must be below agent.log_std_max ({self.log_std_max})")


class SACState(NamedTuple):
    """Actor, twin critics and their targets, the temperature's log α, the three Adam states."""

    actor: Any
    critic: Any
    critic_target: Any
    actor_opt: Any
    critic_opt: Any
    log_alpha: Array
    alpha_opt: Any


# per update: L_Q and mean Q₁; on the updates that stepped the actor, the means over its
# policy_freq steps of L_π, L_α and the entropy estimate −mean log π, and α after them
METRICS = MetricSpec(CORE_COUNTERS, CORE_METRICS + (
    Metric("alpha_loss", "actor_updates", "temperature loss"), Metric("alpha", "actor_updates", "temperature α"),
    Metric("entropy", "actor_updates", "entropy −log π")))
UpdateMetrics = METRICS.update_type


def squashed_gaussian(mean: Array, log_std: Array, noise: Array, scale: Array, offset: Array,
                      eps: float = LOG_PROB_EPS) -> tuple[Array, Array]:
    """(a, log π(a)) of u = mean + exp(log_std)·noise, a = tanh(u)·scale + offset, summed over the
    last axis (see the module docstring; ``eps`` = 0 gives the exact density of a)."""
    u = mean + jnp.exp(log_std) * noise
    y = jnp.tanh(u)
    log_normal = -0.5 * noise**2 - log_std - 0.5 * math.log(2 * math.pi)
    log_prob = jnp.sum(log_normal - jnp.log(scale * (1 - y**2) + eps), axis=-1)
    return y * scale + offset, log_prob


@dataclass(frozen=True)
class SAC(AgentBase):
    """SAC for one environment: static config (a :class:`SACConfig`) + networks; pure, jittable."""

    kind = "sac"
    Config = SACConfig
    SWEEPABLE = ("actor_lr", "critic_lr", "alpha_lr", "discount", "tau")
    METRICS = METRICS
    CHECKED = ("critic_loss", "actor_loss", "alpha_loss", "actor_params", "critic_params", "log_alpha")
    POLICY_HEAD = "gaussian"

    @property
    def actor_net(self) -> GaussianActor:
        """π_φ: (mean, log σ) of the pre-squash Gaussian."""
        c = self.config
        return GaussianActor(self.action_dim, c.log_std_min, c.log_std_max, self.network_options)

    @property
    def alpha_tx(self) -> optax.GradientTransformation:
        return optax.adam(self.config.alpha_lr)

    @property
    def target_entropy(self) -> float:
        """H̄ = −|A|."""
        return -float(self.action_dim)

    def _offset(self) -> Array:
        low, high = self._low_high()
        return (high + low) / 2

    # ---- pure functions ---------------------------------------------------------------------
    def init(self, key: Array) -> SACState:
        """Fresh actor and critics (independent keys), target critics = copies, log α = 0, Adam states."""
        actor, critic = self.init_networks(key)
        log_alpha = jnp.zeros((), self.dtype)
        return SACState(actor, critic, jax.tree.map(jnp.copy, critic), self.actor_tx.init(actor),
                        self.critic_tx.init(critic), log_alpha, self.alpha_tx.init(log_alpha))

    def sample(self, actor_params, obs: Array, key: Array) -> tuple[Array, Array]:
        """(a, log π(a|obs)) with a ~ π_φ(·|obs) reparameterised by ε = N(0, I) from ``key``."""
        mean, log_std = self.actor_net.apply(actor_params, obs)
        noise = jax.random.normal(key, mean.shape, self.dtype)
        return squashed_gaussian(mean, log_std, noise, self.max_action(), self._offset())

    def act(self, actor_params, obs: Array) -> Array:
        """The mean action tanh(μ_φ(obs))·m + c ∈ [low, high] (evaluation and export)."""
        mean, _ = self.actor_net.apply(actor_params, obs)
        return jnp.tanh(mean) * self.max_action() + self._offset()

    def explore(self, actor_params, obs: Array, key: Array) -> Array:
        """a ~ π_φ(·|obs)."""
        return self.sample(actor_params, obs, key)[0]

    def td_target(self, actor_params, critic_target, alpha: Array, batch: Transition, key: Array) -> Array:
        """y = r + γ(1 − terminated)·(min_j Q_θ'j(s', a') − α log π(a'|s')), a' ~ π_φ(·|s')."""
        next_action, next_log_prob = self.sample(actor_params, batch.next_obs, key)
        q_next = self.critic_net.apply(critic_target, batch.next_obs, next_action)
        v = jnp.min(q_next, axis=0) - alpha * next_log_prob
        return jax.lax.stop_gradient(batch.reward + self.config.discount * (1 - batch.terminated) * v)

    def actor_loss(self, actor_params, critic_params, alpha: Array, obs: Array, key: Array) -> tuple[Array, Array]:
        """L_π = mean(α log π(ã|s) − min_j Q_θj(s, ã)), ã ~ π_φ(·|s); returns (L_π, log π)."""
        action, log_prob = self.sample(actor_params, obs, key)
        q = self.critic_net.apply(critic_params, obs, action)
        return jnp.mean(alpha * log_prob - jnp.min(q, axis=0)), log_prob

    def alpha_loss(self, log_alpha: Array, log_prob: Array) -> Array:
        """L_α = mean(−exp(log α)·(log π + H̄)) (cleanrl's form: the gradient is taken in log α)."""
        return jnp.mean(-jnp.exp(log_alpha) * (log_prob + self.target_entropy))

    def _actor_steps(self, critic, obs: Array, key: Array, operand):
        """``policy_freq`` actor + temperature steps (module docstring) from ``operand`` = (actor,
        actor_opt, log_alpha, alpha_opt); returns it and (mean L_π, mean L_α, α, mean entropy)."""
        def one(carry, k):
            actor, actor_opt, log_alpha, alpha_opt = carry
            k_pi, k_alpha = jax.random.split(k)
            (l_pi, _), g = jax.value_and_grad(self.actor_loss, has_aux=True)(
                actor, critic, jnp.exp(log_alpha), obs, k_pi)
            actor, actor_opt = adam_step(self.actor_tx, g, actor_opt, actor)
            log_prob = jax.lax.stop_gradient(self.sample(actor, obs, k_alpha)[1])
            l_alpha, g_alpha = jax.value_and_grad(self.alpha_loss)(log_alpha, log_prob)
            log_alpha, alpha_opt = adam_step(self.alpha_tx, g_alpha, alpha_opt, log_alpha)
            return (actor, actor_opt, log_alpha, alpha_opt), (l_pi, l_alpha, -jnp.mean(log_prob))

        carry, (l_pi, l_alpha, entropy) = jax.lax.scan(one, operand, jax.random.split(key, self.config.policy_freq))
        return carry, (jnp.mean(l_pi), jnp.mean(l_alpha), jnp.exp(carry[2]), jnp.mean(entropy))

    def update(self, state: SACState, batch: Transition, key: Array, iteration) -> tuple[SACState, Any]:
        """One SAC iteration at 1-based update ``iteration`` (an int32 scalar, unbatched under vmap):
        critic step, the delayed actor/temperature steps, the target update (module docstring)."""
        c = self.config
        k_next, k_actor = jax.random.split(key)
        y = self.td_target(state.actor, state.critic_target, jnp.exp(state.log_alpha), batch, k_next)
        (l_q, q_mean), grads = jax.value_and_grad(self.critic_loss, has_aux=True)(state.critic, batch, y)
        critic, critic_opt = adam_step(self.critic_tx, grads, state.critic_opt, state.critic)

        update_actor = (iteration % c.policy_freq) == 0
        operand = (state.actor, state.actor_opt, state.log_alpha, state.alpha_opt)
        zero = jnp.zeros((), l_q.dtype)
        (actor, actor_opt, log_alpha, alpha_opt), (l_pi, l_alpha, alpha, entropy) = jax.lax.cond(
            update_actor, lambda o: self._actor_steps(critic, batch.obs, k_actor, o),
            lambda o: (o, (zero, zero, zero, zero)), operand)
        critic_target = jax.lax.cond((iteration % c.target_freq) == 0, lambda t: polyak(t, critic, c.tau),
                                     lambda t: t, state.critic_target)
        new = SACState(actor, critic, critic_target, actor_opt, critic_opt, log_alpha, alpha_opt)
        return new, UpdateMetrics(l_q, l_pi, q_mean, l_alpha, alpha, entropy, jnp.asarray(update_actor, jnp.bool_))

    def finite(self, state: SACState, metrics) -> Array:
        """[L_Q, L_π, L_α, actor parameters, critic parameters, log α] finite (:attr:`CHECKED`)."""
        return jnp.stack([jnp.isfinite(metrics.critic_loss), jnp.isfinite(metrics.actor_loss),
                          jnp.isfinite(metrics.alpha_loss), all_finite(state.actor), all_finite(state.critic),
                          jnp.isfinite(state.log_alpha)])
