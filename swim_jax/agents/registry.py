"""The algorithms, by config key ``agent.kind``: one entry per agent module (``td3`` the default).

Each entry is an agent class implementing ``swim_jax.agents.base.Agent``; its ``Config`` is the
dataclass ``swim_jax.config`` builds ``agent:`` into, its ``METRICS`` what metrics.csv, TensorBoard
and the report show. Adding an algorithm is one module (``swim_jax/agents/<kind>.py``) plus its
line in :data:`AGENTS` (docs/ARCHITECTURE.md: "A third algorithm").
"""

from __future__ import annotations

from swim_jax.agents.base import DEFAULT_KIND
from swim_jax.agents.sac import SAC
from swim_jax.agents.td3 import TD3

AGENTS = {cls.kind: cls for cls in (TD3, SAC)}
assert DEFAULT_KIND in AGENTS


def kinds() -> tuple[str, ...]:
    """The registered ``agent.kind`` values, the default first."""
    return tuple(AGENTS)


def get(kind: str):
    """The agent class of ``kind``; ValueError (one line, naming the valid kinds) for another."""
    if kind not in AGENTS:
        raise ValueError(f"unknown agent.kind {kind!r}; valid: {', '.join(AGENTS)}")
    return AGENTS[kind]


def config_class(kind: str) -> type:
    """The config dataclass of ``kind`` (what ``agent:`` of a config with that kind is built into)."""
    return get(kind).Config


def of_config(agent_config):
    """The agent class an agent config belongs to (by its ``kind``)."""
    return get(agent_config.kind)


def learning_panels() -> tuple[tuple[str, str], ...]:
    """``(metric, title)`` of the report's learning figure: the titled metrics every registered agent
    reports (so runs of any agents share the panels), in the default agent's order."""
    first, *others = (cls.METRICS.panels for cls in AGENTS.values())
    return tuple(p for p in first if all(p[0] in dict(o) for o in others))
