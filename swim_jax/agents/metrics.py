"""What an agent's update reports, declared once (:class:`MetricSpec`); everything else derives from it.

An agent declares its metrics (name, the count they are a mean over, a report panel title) and
its counts (``updates``: every update; ``actor_updates``: the updates whose metrics flag says the
actor stepped). From that declaration come:

* ``update_type``: the NamedTuple ``update`` returns per update (the metrics, then the flags);
* ``chunk_type``: the per-lane summary of one call of the training chunk (each count, then the
  means over those updates of its metrics), :meth:`MetricSpec.summarize`;
* the columns of metrics.csv and the TensorBoard scalars (``swim_jax.io.learning_log``: ``step``,
  ``seed``, the chunk fields, ``episodes``, ``last_episode_return``), every agent's a superset of
  ``learning_log.COLUMNS`` (checked here);
* the report's learning panels: the titled metrics every registered agent reports
  (``swim_jax.agents.registry.learning_panels``).

For a count c with mask w_t (update t ran and, for a flagged count, its flag is set) and a metric x
of that count, over the steps t of a call:  c = Σ_t w_t,  mean x = Σ_t w_t x_t / c  (nan when c = 0).
"""

from __future__ import annotations

import collections
import functools
from dataclasses import dataclass

import jax
import jax.numpy as jnp

from swim_jax.io import learning_log

Array = jax.Array


@dataclass(frozen=True)
class Metric:
    """One reported quantity: ``name`` (its column), ``counter`` (the count whose updates it is a
    mean over) and ``title`` (its panel in the report's learning figure; "" for none)."""

    name: str
    counter: str
    title: str = ""


@dataclass(frozen=True)
class MetricSpec:
    """An agent's metrics: ``counters`` are ``(count column, flag)`` pairs, the flag naming a bool
    field of the update metrics that marks the updates of that count (None: every update; count
    columns are ``updates`` or end in ``_updates``, so metrics.csv reads them as integers);
    ``metrics`` in the order of the update metrics' fields (and of the report's panels)."""

    counters: tuple[tuple[str, str | None], ...]
    metrics: tuple[Metric, ...]

    def __post_init__(self):
        counts = [c for c, _ in self.counters]
        if any(c != "updates" and not c.endswith("_updates") for c in counts):
            raise ValueError(f"count columns must be 'updates' or end in '_updates': {counts}")
        if any(m.counter not in counts for m in self.metrics):
            raise ValueError(f"every metric's counter must be one of {counts}")
        names = [*counts, *(m.name for m in self.metrics), *self.flags]
        if len(set(names)) != len(names):
            raise ValueError(f"metric, count and flag names must be distinct: {names}")
        missing = [c for c in learning_log.COLUMNS if c not in (*learning_log.BASE_COLUMNS, *learning_log.TAIL_COLUMNS,
                                                                 *self.chunk_fields)]
        if missing:
            raise ValueError(f"an agent must report every column of metrics.csv's core; missing {missing}")

    @property
    def flags(self) -> tuple[str, ...]:
        """The bool fields of the update metrics (one per flagged count)."""
        return tuple(f for _, f in self.counters if f is not None)

    @property
    def chunk_fields(self) -> tuple[str, ...]:
        """Each count followed by its metrics: the fields of :attr:`chunk_type`, metrics.csv's
        columns between ``seed`` and ``episodes``."""
        return tuple(f for c, _ in self.counters for f in (c, *(m.name for m in self.metrics if m.counter == c)))

    @property
    def columns(self) -> tuple[str, ...]:
        """metrics.csv's columns for this agent."""
        return learning_log.columns(self.chunk_fields)

    @property
    def panels(self) -> tuple[tuple[str, str], ...]:
        """``(metric, title)`` of the metrics with a report panel, in declaration order."""
        return tuple((m.name, m.title) for m in self.metrics if m.title)

    @functools.cached_property
    def update_type(self) -> type:
        """NamedTuple of one update's scalars: the metrics, then the flags; its ``spec`` is this."""
        cls = collections.namedtuple("UpdateMetrics", [m.name for m in self.metrics] + list(self.flags))
        cls.spec = self
        return cls

    @functools.cached_property
    def chunk_type(self) -> type:
        """NamedTuple of one call's per-lane summary (:attr:`chunk_fields`); its ``counter_of``
        (metric → count) lets ``swim_jax.io.learning_log.combine`` merge calls."""
        cls = collections.namedtuple("ChunkMetrics", self.chunk_fields)
        cls.counter_of = {m.name: m.counter for m in self.metrics}
        return cls

    def zeros(self, dtype):
        """The update metrics of a step without an update: zeros in ``dtype``, flags false."""
        z = jnp.zeros((), dtype)
        return self.update_type(*([z] * len(self.metrics)), *([jnp.zeros((), jnp.bool_)] * len(self.flags)))

    def summarize(self, m, updated: Array):
        """:attr:`chunk_type` from per-step update metrics stacked on axis 0 (``[T, L]``) and the
        per-step "an update ran" flags (``[T]``): each count and its metrics' means (see the
        module docstring), counts as int32."""
        every = updated[:, None] & jnp.ones_like(getattr(m, self.metrics[0].name), jnp.bool_)
        masks = {c: every if flag is None else every & getattr(m, flag) for c, flag in self.counters}
        counts = {c: w.sum(0) for c, w in masks.items()}
        mean = lambda x, w, k: jnp.where(k > 0, jnp.where(w, x, 0).sum(0) / jnp.maximum(k, 1), jnp.nan)
        out = {c: counts[c].astype(jnp.int32) for c in masks}
        out.update({x.name: mean(getattr(m, x.name), masks[x.counter], counts[x.counter]) for x in self.metrics})
        return self.chunk_type(**out)


# the counts and metrics every actor-critic agent reports (learning_log.COLUMNS' core; the report's
# panels): L_Q and mean Q₁ over every update, the actor's loss over the updates that stepped it
CORE_COUNTERS = (("updates", None), ("actor_updates", "actor_updated"))
CORE_METRICS = (Metric("critic_loss", "updates", "critic loss"), Metric("actor_loss", "actor_updates", "actor loss"),
                Metric("q_mean", "updates", "Q estimate"))
