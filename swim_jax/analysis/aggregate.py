"""Aggregates across envs, as rliable computes them (Agarwal et al., NeurIPS 2021, "Deep RL at the
Edge of the Statistical Precipice"): normalized scores, IQM, mean, median and optimality gap with
stratified bootstrap CIs, the probability of improvement between every pair of labels, and
performance profiles. Our own code, tested equal to rliable's (tests/test_aggregate.py).

**Normalized score** of a per-seed score s on env e: (s − random_e) / (reference_e − random_e), with
:data:`NORMALIZATION`: random_e the mean return of uniform random actions in Gymnasium's own env
(100 episodes, docs/notebook/scripts/random-policy-returns-20261206.py), reference_e published TD3
at 1M steps (sfujim's TD3 curves on gym v1 for Walker2d, Hopper, HalfCheetah, Ant; Tianshou's TD3 on
v3 for Swimmer; ../shared/paper/REFERENCE.md). 1 = published TD3 at 1M, 0 = random.

**Scores**: a matrix ``[runs, tasks]`` per label (every label must have the same seed count in
every env it is aggregated over). IQM = the 25 % trimmed mean of all entries
(``scipy.stats.trim_mean``); mean = the mean over tasks of the per-task mean; median = the median
over tasks of the per-task mean; optimality gap = γ − mean(min(score, γ)) with γ = 1. The stratified
bootstrap resamples the runs of each task with replacement, independently per task (rliable's
``StratifiedBootstrap``: ``np.random.RandomState(seed).choice(runs, (runs, tasks))`` per
replicate, the same draws as rliable after ``np.random.seed(seed)``); CIs are the 2.5 and 97.5
percentiles. Probability of improvement P(X > Y) = the mean over tasks of the Mann–Whitney U of
X's runs against Y's over runs_x · runs_y (ties count ½), its CI from resampling X's and Y's runs
independently within each task. A performance profile is, per threshold τ, the fraction of all
runs and tasks with a normalized score above τ.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy import stats as sps

# env id -> (random-policy return, reference return, where the reference comes from)
NORMALIZATION = {
    "Walker2d-v5": (1.77, 4413.0, "TD3 1M, sfujim (gym v1)"),
    "Walker2d-v4": (2.61, 4413.0, "TD3 1M, sfujim (gym v1)"),
    "Hopper-v5": (16.67, 3391.0, "TD3 1M, sfujim (gym v1)"),
    "Hopper-v4": (17.67, 3391.0, "TD3 1M, sfujim (gym v1)"),
    "HalfCheetah-v5": (-282.49, 9567.0, "TD3 1M, sfujim (gym v1)"),
    "Ant-v5": (-48.05, 4243.0, "TD3 1M, sfujim (gym v1)"),
    "Swimmer-v5": (0.80, 104.0, "TD3 1M, Tianshou (gym v3)"),
}
METRICS = ("iqm", "mean", "median", "optimality_gap")
GAMMA = 1.0


def normalize(env: str, scores: np.ndarray) -> np.ndarray:
    """``scores`` of env ``env`` normalized with :data:`NORMALIZATION` (KeyError for an env without one)."""
    random, reference, _ = NORMALIZATION[env]
    return (np.asarray(scores, np.float64) - random) / (reference - random)


def iqm(s: np.ndarray) -> float:
    """The interquartile mean of every entry of ``s[runs, tasks]`` (25 % trimmed each side)."""
    return float(sps.trim_mean(s, proportiontocut=0.25, axis=None))


def mean(s: np.ndarray) -> float:
    """The mean over tasks of the per-task mean of ``s[runs, tasks]``."""
    return float(np.mean(np.mean(s, axis=0)))


def median(s: np.ndarray) -> float:
    """The median over tasks of the per-task mean of ``s[runs, tasks]``."""
    return float(np.median(np.mean(s, axis=0)))


def optimality_gap(s: np.ndarray, gamma: float = GAMMA) -> float:
    """γ − the mean of min(s, γ) over every entry of ``s[runs, tasks]``."""
    return float(gamma - np.mean(np.minimum(s, gamma)))


FUNCTIONS = {"iqm": iqm, "mean": mean, "median": median, "optimality_gap": optimality_gap}


def probability_of_improvement(x: np.ndarray, y: np.ndarray) -> float:
    """P(X > Y): per task the Mann–Whitney U of ``x[:, task]`` over ``y[:, task]`` divided by
    runs_x · runs_y (ties ½; ½ when the two columns are equal), averaged over tasks."""
    out = []
    for t in range(x.shape[1]):
        a, b = x[:, t], y[:, t]
        greater = (a[:, None] > b[None, :]).sum() + 0.5 * (a[:, None] == b[None, :]).sum()
        out.append(0.5 if np.array_equal(a, b) else greater / (a.size * b.size))
    return float(np.mean(out))


def _resample(rng: np.random.RandomState, s: np.ndarray) -> np.ndarray:
    """One stratified resample: every task's runs drawn with replacement (rliable's draws)."""
    idx = rng.choice(s.shape[0], s.shape, replace=True)
    return s[idx, np.arange(s.shape[1])[None, :]]


def stratified_ci(s: np.ndarray, fn, reps: int, seed: int) -> tuple[float, float]:
    """The 95 % percentile CI of ``fn(s)`` over ``reps`` stratified resamples of ``s[runs, tasks]``."""
    rng = np.random.RandomState(seed)
    values = np.array([fn(_resample(rng, s)) for _ in range(reps)])
    lo, hi = np.percentile(values, [2.5, 97.5])
    return float(lo), float(hi)


def poi_ci(x: np.ndarray, y: np.ndarray, reps: int, seed: int) -> tuple[float, float]:
    """The 95 % percentile CI of :func:`probability_of_improvement`, X's and Y's runs resampled
    independently within each task."""
    rng = np.random.RandomState(seed)
    values = np.array([probability_of_improvement(_resample(rng, x), _resample(rng, y)) for _ in range(reps)])
    lo, hi = np.percentile(values, [2.5, 97.5])
    return float(lo), float(hi)


def performance_profile(s: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """The fraction of all entries of ``s[runs, tasks]`` above each τ of ``taus``."""
    return np.array([np.mean(s > t) for t in taus])


@dataclass
class Aggregates:
    """The aggregates of one set of labels over the same envs."""

    envs: list[str]
    score: str  # the per-seed score normalized (max, final, auc)
    scores: dict  # label -> normalized [runs, tasks]
    metrics: dict  # label -> {metric: (point, lo, hi)}
    improvement: dict  # "x_vs_y" -> (point, lo, hi)
    taus: np.ndarray
    profiles: dict  # label -> [len(taus)]

    def to_json(self) -> dict:
        return {"envs": self.envs, "score": self.score, "normalization": {e: NORMALIZATION[e] for e in self.envs},
                "metrics": {a: {m: list(v) for m, v in ms.items()} for a, ms in self.metrics.items()},
                "probability_of_improvement": {k: list(v) for k, v in self.improvement.items()},
                "performance_profile": {"tau": self.taus.tolist(), **{a: p.tolist() for a, p in self.profiles.items()}}}


def aggregate(per_env: dict[str, dict[str, np.ndarray]], score: str, reps: int = 2000, seed: int = 0,
              taus: np.ndarray | None = None) -> Aggregates | None:
    """Aggregates over the envs of ``per_env`` (``{env: {label: per-seed scores}}``) for the labels
    present in every env with the same seed count in each; None when fewer than two envs have a
    normalization, or no label qualifies. Bootstrap seeds: ``seed`` for every metric's CI, ``seed``
    for every probability of improvement's."""
    envs = [e for e in per_env if e in NORMALIZATION]
    if len(envs) < 2:
        return None
    labels = [a for a in per_env[envs[0]] if all(a in per_env[e] and len(per_env[e][a]) == len(per_env[envs[0]][a])
                                                for e in envs)]
    if not labels:
        return None
    scores = {a: np.stack([normalize(e, per_env[e][a]) for e in envs], axis=1) for a in labels}
    metrics = {a: {m: (FUNCTIONS[m](s), *stratified_ci(s, FUNCTIONS[m], reps, seed)) for m in METRICS}
               for a, s in scores.items()}
    improvement = {f"{x}_vs_{y}": (probability_of_improvement(scores[x], scores[y]),
                                   *poi_ci(scores[x], scores[y], reps, seed))
                   for x, y in itertools.permutations(labels, 2)}
    taus = np.linspace(0.0, 2.0, 41) if taus is None else taus
    return Aggregates(envs, score, scores, metrics, improvement, taus,
                      {a: performance_profile(s, taus) for a, s in scores.items()})
