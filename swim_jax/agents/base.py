"""What every agent shares: the interface (:class:`Agent`), the activation config, the action range,
the twin critics' loss, Polyak averaging and the Adam step.

An agent (``swim_jax/agents/td3.py``, ``swim_jax/agents/sac.py``) is one module holding a frozen
config dataclass (its ``kind`` the registry key, ``swim_jax/agents/registry.py``) and an agent class
derived from :class:`AgentBase` that implements :class:`Agent`. The training loop
(``swim_jax/agents/loop.py``), the run (``swim_jax/run/``) and the outputs only use that interface.

Shared formulas (used by every agent, so no agent copies them):

    L_Q(θ)       = Σ_j mean_batch((Q_θj(s, a) − y)²)                 (twin critics, j = 1, 2)
    polyak(θ', θ) = τ θ + (1 − τ) θ'                                   (per leaf, in θ''s dtype)
    adam_step    = one optax Adam update of the parameters with its gradients
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar, Mapping, Protocol, Sequence

import jax
import jax.numpy as jnp
import optax

from swim_jax.activations import param_names, parameter_defaults
from swim_jax.agents.metrics import MetricSpec
from swim_jax.agents.networks import NetworkOptions, TwinCritic
from swim_jax.agents.replay import Transition

Array = jax.Array
DEFAULT_KIND = "td3"  # the agent of a config (or an old run folder) that names none


def _activation_params(self) -> dict[str, Any]:
    """The registry parameters this activation takes (e.g. {"k": 0.5} for swim, {} for relu).
    A value set by :meth:`AgentBase.with_hparams` stays a (traced) array; config values are floats."""
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


def kind_field(kind: str):
    """The ``kind`` field of an agent config: the registry key, fixed by the class (not an
    ``__init__`` argument); config.yaml writes it unless it is :data:`DEFAULT_KIND`, so TD3 run
    folders read as they always did (``swim_jax.config.to_dict``)."""
    return field(default=kind, init=False, metadata={"omit_if": DEFAULT_KIND})


def activation_fields(activation: str) -> tuple[str, ...]:
    """The sweepable activation parameters of ``activation`` as config paths (``activation.k``)."""
    return tuple(f"activation.{f}" for f in param_names(activation))


def replace_fields(config, changes: Mapping[str, Any]):
    """``config`` (any agent config) with fields set by path relative to it: ``{"tau": 0.01,
    "activation.k": 2.0}`` (values may be traced arrays inside a vmapped program)."""
    act_changes, top_changes = {}, {}
    for path, value in changes.items():
        if path.startswith("activation."):
            act_changes[path.split(".", 1)[1]] = value
        else:
            top_changes[path] = value
    activation = dataclasses.replace(config.activation, **act_changes)
    return dataclasses.replace(config, activation=activation, **top_changes)


class Agent(Protocol):
    """The interface of an algorithm (what the loop, the run and the outputs use).

    Class attributes: ``kind`` (registry key), ``Config`` (its frozen config dataclass, with
    ``hidden``, ``activation``, ``batch_size`` and a ``kind`` field), ``SWEEPABLE`` (float config
    fields that may differ between the lanes of one program), ``METRICS`` (a
    :class:`~swim_jax.agents.metrics.MetricSpec`: what ``update`` reports, hence the columns of
    metrics.csv, the TensorBoard scalars and the report's panels), ``CHECKED`` (the quantities
    watched for NaN/inf, in the order of ``finite``), ``POLICY_HEAD`` (how the NumPy policy reads the
    actor's output: ``swim_jax.policy.policy.HEADS``).

    The state is a pytree (NamedTuple) whose ``actor`` field holds the parameters of the
    deterministic policy (evaluation, final_policy.npz, export) and whose ``critic`` field holds the
    twin critics (both may hold learnable activation parameters); its first field is ``actor``."""

    kind: str
    config: Any
    dtype: Any

    def init(self, key: Array) -> Any:
        """A fresh state from ``key``."""

    def act(self, actor_params, obs: Array) -> Array:
        """The deterministic action of ``obs`` (evaluation and export)."""

    def explore(self, actor_params, obs: Array, key: Array) -> Array:
        """The exploration action of ``obs`` during training."""

    def random_action(self, key: Array, shape: Sequence[int] = ()) -> Array:
        """U(low, high): the warm-up's actions."""

    def update(self, state, batch: Transition, key: Array, iteration: Array) -> tuple[Any, Any]:
        """One update on ``batch`` at 1-based update ``iteration`` (an int32 scalar shared by the
        lanes; delays such as the actor's every ``policy_freq`` are the agent's own):
        (new state, ``METRICS.update_type``)."""

    def finite(self, state, metrics) -> Array:
        """bool[len(CHECKED)]: whether each watched quantity is finite after an update."""

    def with_hparams(self, hparams: Mapping[str, Array] | None) -> "Agent":
        """This agent with sweepable fields replaced by per-lane (traced) values."""


def all_finite(tree) -> Array:
    """Whether every element of every leaf of ``tree`` is finite (a bool scalar)."""
    leaves = jax.tree.leaves(tree)
    return jnp.all(jnp.stack([jnp.all(jnp.isfinite(x)) for x in leaves]))


def polyak(target, online, tau):
    """τ·online + (1 − τ)·target, leaf by leaf, in the target's dtype."""
    return jax.tree.map(lambda t, p: (tau * p + (1 - tau) * t).astype(t.dtype), target, online)


def adam_step(tx: optax.GradientTransformation, grads, opt_state, params):
    """(params after one step of ``tx`` with ``grads``, the new optimiser state)."""
    updates, opt_state = tx.update(grads, opt_state, params)
    return optax.apply_updates(params, updates), opt_state


@dataclass(frozen=True)
class AgentBase:
    """The static part every agent has: its config, the observation size, the action range
    [low, high] (tuples, static), the parameter dtype and the optional ``matmul_dtype`` (e.g.
    ``jnp.bfloat16``: Dense inputs/weights rounded, float32 accumulation); the networks' options,
    the twin critics and their loss, uniform random actions and per-lane hyperparameters."""

    config: Any
    obs_dim: int
    action_low: tuple[float, ...]
    action_high: tuple[float, ...]
    dtype: Any = jnp.float32
    matmul_dtype: Any = None

    kind: ClassVar[str] = ""  # set by each agent class (the registry key)
    SWEEPABLE: ClassVar[tuple[str, ...]] = ()  # sweepable float fields besides the activation's parameters
    METRICS: ClassVar[MetricSpec | None] = None
    CHECKED: ClassVar[tuple[str, ...]] = ()
    POLICY_HEAD: ClassVar[str] = "deterministic"

    @classmethod
    def sweepable_fields(cls, activation: str) -> tuple[str, ...]:
        """Float config fields that may differ between the lanes of one compiled program (sweep
        axes), as paths relative to the agent config: ``SWEEPABLE`` and the activation's own
        parameters (``activation.k`` for swim). Integer/structural fields (widths, batch size,
        delays) change shapes or control flow and cannot be swept."""
        return cls.SWEEPABLE + activation_fields(activation)

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
    def critic_net(self) -> TwinCritic:
        """The twin critics (Q₁, Q₂)."""
        return TwinCritic(self.network_options)

    @property
    def actor_tx(self) -> optax.GradientTransformation:
        """Adam on the actor (``actor_lr``)."""
        return optax.adam(self.config.actor_lr)

    @property
    def critic_tx(self) -> optax.GradientTransformation:
        """Adam on the twin critics (``critic_lr``)."""
        return optax.adam(self.config.critic_lr)

    def init_networks(self, key: Array):
        """(actor parameters, twin critic parameters) from independent halves of ``key``
        (``split(key)``), initialised on a batch of one zero observation (and action); the agent's
        ``actor_net`` is its own."""
        k_actor, k_critic = jax.random.split(key)
        obs = jnp.zeros((1, self.obs_dim), self.dtype)
        act = jnp.zeros((1, self.action_dim), self.dtype)
        return self.actor_net.init(k_actor, obs), self.critic_net.init(k_critic, obs, act)

    def with_hparams(self, hparams: Mapping[str, Array] | None):
        """This agent with config fields replaced by per-lane values, e.g. ``{"tau": t,
        "activation.k": k}`` (paths from :meth:`sweepable_fields`; values may be traced scalars).
        Inside a vmapped program each lane builds its own agent this way, so one compiled program
        trains every point of a hyperparameter sweep. None or an empty mapping returns ``self``."""
        if not hparams:
            return self
        return dataclasses.replace(self, config=replace_fields(self.config, hparams))

    def _low_high(self):
        return jnp.asarray(self.action_low, self.dtype), jnp.asarray(self.action_high, self.dtype)

    def max_action(self) -> Array:
        """m = (high − low)/2 per action dimension (the action scale of the tanh heads)."""
        low, high = self._low_high()
        return (high - low) / 2

    def random_action(self, key: Array, shape: Sequence[int] = ()) -> Array:
        """U(low, high) of shape ``(*shape, action_dim)``."""
        low, high = self._low_high()
        return jax.random.uniform(key, (*shape, self.action_dim), self.dtype, low, high)

    def critic_loss(self, critic_params, batch: Transition, y: Array):
        """L_Q = Σ_j mean((Q_θj(s, a) − y)²); returns (loss, mean Q₁)."""
        q = self.critic_net.apply(critic_params, batch.obs, batch.action)
        return jnp.sum(jnp.mean((q - y[None]) ** 2, axis=1)), jnp.mean(q[0])

    def zero_metrics(self):
        """The metrics of a step without an update: zeros in the agent's dtype, flags false."""
        return self.METRICS.zeros(self.dtype)
