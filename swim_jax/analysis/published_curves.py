"""The published learning curves our runs are held against, and reading them at a step.

The curves are Tianshou's MuJoCo benchmark: thu-ml/tianshou ``examples/mujoco/benchmark/<Env>-v3/
result.json`` at commit 63f0e9a0fb5b30ee15635b9ad41400111a187a37, TD3 and SAC, one point every 5,000
steps: the mean over 10 seeds of each seed's mean return over 10 deterministic test episodes, and the
population std over the seeds. Its TD3 runs the TD3 reference code's current defaults, which are
ours; its SAC differs from ours (fixed α = 0.2, learning rate 1e-3, 10k random steps). Envs are gym v3
(mujoco-py), ours Gymnasium v4/v5: the same tasks, not the same files.

Steps are env steps, as ours count them: a run's random start steps included. Tianshou's
``env_step`` starts at 0 after its random warm-up (``train_collector.collect(n_step=start_timesteps,
random=True)`` before the trainer, whose ``env_step`` counts from 0: examples/mujoco/mujoco_td3.py
and tianshou/trainer/offpolicy.py at e605bdea, the commit its README names; start_timesteps 25,000
for TD3, 10,000 for SAC). So its point at ``env_step`` x is at x + 25,000 env steps (TD3) or x +
10,000 (SAC) here: our TD3 at 300k (275k updates) sits beside its point at 275k (275k updates).
"""

from __future__ import annotations

import functools
import json
import math
import os
from dataclasses import dataclass

import numpy as np

DATA = os.path.join(os.path.dirname(__file__), "published_tianshou.json")
# Tianshou's random warm-up steps, not counted in its env_step (see the module docstring)
WARMUP_STEPS = {"TD3": 25_000, "SAC": 10_000}
SOURCE = "Tianshou (thu-ml/tianshou 63f0e9a, gym v3)"
SEEDS = 10  # Tianshou's benchmark runs 10 seeds per curve
WINDOW = 50_000  # the published mean over N ± WINDOW steps


class PublishedError(ValueError):
    """No published curve for a run, or not at the asked step; ``str(e)`` is one line."""


@dataclass(frozen=True)
class Anchor:
    """A published curve's value at ``step``: mean and sample std over ``n`` seeds; ``window_mean``:
    the mean of the curve's points within ``step ± WINDOW``."""

    env: str
    algorithm: str
    step: int
    mean: float
    sd: float
    n: int
    window_mean: float


@functools.lru_cache(maxsize=1)
def _curves() -> dict:
    with open(DATA) as f:
        return json.load(f)["envs"]


def published_env(env: str) -> str:
    """The published curve's env id for one of ours (``Walker2d-v5`` → ``Walker2d-v3``)."""
    return env.split("-")[0] + "-v3"


def curve_points(env: str, algorithm: str) -> list:
    """The published ``algorithm`` (``td3`` or ``sac``) curve of our ``env``: ``[[step, mean,
    population std], ...]`` every 5,000 steps, ``step`` in env steps (Tianshou's ``env_step`` +
    :data:`WARMUP_STEPS`; :class:`PublishedError` naming what exists when there is none)."""
    curves = _curves()
    key = published_env(env)
    if key not in curves:
        raise PublishedError(f"no published curve for {env}: published envs are {', '.join(sorted(curves))}")
    points = curves[key].get(algorithm.upper())
    if not points:
        raise PublishedError(f"no published {algorithm} curve for {env}: published algorithms are "
                             f"{', '.join(a.lower() for a in curves[key])}")
    warmup = WARMUP_STEPS[algorithm.upper()]
    return [[s + warmup, m, sd] for s, m, sd in points]


def anchor(env: str, algorithm: str, step: int) -> Anchor:
    """The published ``algorithm`` (``td3`` or ``sac``) curve of ``env`` at ``step``
    (:class:`PublishedError` naming what exists when there is none)."""
    key = published_env(env)
    at = {int(s): (m, sd) for s, m, sd in curve_points(env, algorithm)}
    if step not in at:
        raise PublishedError(f"the published {algorithm} curve of {key} has no point at step {step:,}: "
                             f"it has every 5,000 env steps from {min(at):,} to {max(at):,} (its "
                             f"{WARMUP_STEPS[algorithm.upper()]:,} random warm-up steps counted)")
    mean, pop_sd = at[step]
    window = [m for s, (m, _) in at.items() if abs(s - step) <= WINDOW]
    return Anchor(key, algorithm, step, float(mean), float(pop_sd) * math.sqrt(SEEDS / (SEEDS - 1)), SEEDS,
                  float(np.mean(window)))
