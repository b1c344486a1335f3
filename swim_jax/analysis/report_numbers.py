"""The report's numbers from pooled runs (swim_jax/analysis/runs_io.py's groups): Table II, Swim's
improvements, every pairwise comparison with its bootstrap CI and tests, the learning table, Table III
from benchmark files, gathered in :class:`Numbers`; no file is read or written here.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from swim_jax.analysis import aggregate, paper_ref, stats
from swim_jax.agents.registry import learning_panels
from swim_jax.analysis.runs_io import EnvGroup, numerics
from swim_jax.io.bench_results import speedup_pct

SCORES = ("max", "final", "auc")
SCORE_WORDS = {
    "max": "max over evaluations of the seed's return",
    "final": "the seed's return at the last evaluation",
    "auc": "the seed's time-averaged return (trapezoid AUC / step span)",
}


def table2(groups: dict[str, EnvGroup]) -> dict:
    """``{env: {activation: row}}`` with the Table II numbers of each pooled curve set.

    row = ``{seeds, max_mean, max_std, max_step, final_mean, final_std, auc_mean, auc_std, runs}``:
    ``max_mean`` is the max over evaluations of the mean-over-seeds return, ``max_std`` the
    population std over seeds at that evaluation (``max_step``); ``final_*`` the mean/std over seeds
    at the last evaluation; ``auc_*`` the mean/std over seeds of the per-seed trapezoid AUC divided
    by the step span (time-averaged return).
    """
    out = {}
    for env, g in groups.items():
        out[env] = {}
        for act, c in g.curves.items():
            mx = stats.max_of_mean_curve(c.steps, c.returns)
            fin = stats.final_return(c.steps, c.returns)
            auc = stats.normalized_auc_per_seed(c.steps, c.returns)
            out[env][act] = {
                "seeds": c.n_seeds, "max_mean": mx.mean, "max_std": mx.std, "max_step": mx.step,
                "final_mean": fin.mean, "final_std": fin.std, "final_step": fin.step,
                "auc_mean": float(auc.mean()), "auc_std": float(auc.std(ddof=0)), "runs": list(c.runs),
            }
    return out


def improvements(t2: dict) -> dict:
    """``{env: {"max", "final", "auc": % improvement of Swim over Swish}}`` where both exist:
    ``100 · (swim − swish) / |swish|`` on the Table II means."""
    out = {}
    for env, rows in t2.items():
        if "swim" in rows and "swish" in rows:
            out[env] = {m: stats.improvement_pct(rows["swim"][f"{m}_mean"], rows["swish"][f"{m}_mean"])
                        for m in SCORES}
    return out


def label_pairs(labels: list[str], baseline: str | None = None) -> list[tuple[str, str]]:
    """The (X, Y) pairs compared among ``labels`` (in the report's label order): every pair, X before
    Y (Swim vs Swish, Swim vs ReLU, Swish vs ReLU, then the others), or with ``baseline`` every other
    label against it, and Swim vs Swish (the paper's verdict) whenever both are there."""
    if baseline is None:
        return list(itertools.combinations(labels, 2))
    pairs = [(a, baseline) for a in labels if a != baseline] if baseline in labels else []
    paper = ("swim", "swish")
    return pairs + ([paper] if set(paper) <= set(labels) and paper not in pairs and paper[::-1] not in pairs else [])


def comparisons(groups: dict[str, EnvGroup], n_boot: int, seed: int, baseline: str | None = None) -> dict:
    """``{env: {"swim_vs_swish": {score: Comparison}, ...}}`` for every pair of :func:`label_pairs`."""
    out = {}
    for env, g in groups.items():
        scores = {a: stats.per_seed_scores(c.steps, c.returns) for a, c in g.curves.items()}
        out[env] = {f"{x}_vs_{y}": {s: stats.compare(scores[x][s], scores[y][s], s, n_boot, seed) for s in SCORES}
                    for x, y in label_pairs(list(g.curves), baseline)}
    return out


def verdict_power(env: str, c: stats.Comparison) -> dict | None:
    """How large a Swim vs Swish difference the verdict's seeds could detect (``c``: the verdict's
    :class:`stats.Comparison`); None with fewer than 2 seeds on a side.

    ``{"power", "alpha", "detectable_difference"}``: the smallest true difference of mean per-seed
    scores Welch's test at p < alpha detects with that power at these seeds' sample std
    (:func:`stats.detectable_difference`), and ``"detectable_pct_of_swish"``: it as % of |Swish's
    mean|. Where the paper has the env and a nonzero Table II improvement: ``"paper_improvement_pct"``,
    ``"paper_difference"`` (that % of |Swish's mean| on this score) and ``"seeds_for_paper_difference"``
    (:func:`stats.seeds_to_detect` at these std; None beyond 1000).
    """
    if min(c.n_x, c.n_y) < 2:
        return None
    d = stats.detectable_difference(c.sd_x, c.n_x, c.sd_y, c.n_y)
    out = {"power": stats.POWER, "alpha": stats.ALPHA, "detectable_difference": d,
           "detectable_pct_of_swish": 100.0 * d / abs(c.mean_y) if c.mean_y else None}
    penv = paper_ref.paper_env(env)
    pct = paper_ref.TABLE_II_IMPROVEMENT_PCT.get(penv) if penv else None
    if pct:
        diff = pct / 100.0 * abs(c.mean_y)
        out.update(paper_env=penv, paper_improvement_pct=pct, paper_difference=diff,
                   seeds_for_paper_difference=stats.seeds_to_detect(diff, c.sd_x, c.sd_y))
    return out


def verdict_powers(comps: dict, score: str) -> dict:
    """``{env: verdict_power}`` of each env's Swim vs Swish comparison on the verdict's ``score``
    (envs without that comparison, or with one seed on a side, left out)."""
    out = {}
    for env, per in comps.items():
        if "swim_vs_swish" in per and (pw := verdict_power(env, per["swim_vs_swish"][score])) is not None:
            out[env] = pw
    return out


def learning_table(groups: dict[str, EnvGroup]) -> dict:
    """``{env: {label: row}}`` for the curve sets with learning metrics (metrics.csv) in at least one
    chunk; envs without any are left out. row = ``{"steps": [chunk end steps], "seeds": n,
    "runs_without_metrics": [paths], metric: {"mean", "min", "max": [per chunk]}}`` for each metric
    of :func:`swim_jax.agents.registry.learning_panels` (the figure's panels): the mean, min and max over the seeds with a
    number in that chunk (nan where none has one, e.g. before the first update)."""
    out = {}
    for env, g in groups.items():
        rows = {}
        for label, c in g.curves.items():
            m = c.metrics
            if m is None or m.steps.size == 0:
                continue
            rows[label] = {"steps": m.steps.tolist(), "seeds": m.n_seeds,
                           "runs_without_metrics": list(c.runs_without_metrics)}
            rows[label].update({metric: _over_seeds(m.values[metric]) for metric, _ in learning_panels()})
        if rows:
            out[env] = rows
    return out


def _over_seeds(v: np.ndarray) -> dict[str, list[float]]:
    """Mean, min and max of each row of ``v[chunks, seeds]`` over its finite entries (nan if none)."""
    ok = np.isfinite(v)
    n = ok.sum(axis=1)
    mean = np.where(ok, v, 0.0).sum(axis=1) / np.maximum(n, 1)
    lo, hi = np.where(ok, v, np.inf).min(axis=1), np.where(ok, v, -np.inf).max(axis=1)
    return {k: np.where(n > 0, x, np.nan).tolist() for k, x in (("mean", mean), ("min", lo), ("max", hi))}


def table3(bench_rows) -> list[dict]:
    """Table III rows, one per (source, env, dtype): per-activation mean/std ms and Swim's speed-up
    over Swish (``100 · (swish − swim) / swim``, the paper's definition), with the paper's row."""
    cells: dict[tuple, dict] = {}
    for r in bench_rows:
        cells.setdefault((r.source, r.env, r.dtype), {})[r.activation] = r
    out = []
    for (src, env, dtype), acts in cells.items():
        row = {"source": src, "env": env, "dtype": dtype,
               "ms": {a: {"mean": t.mean_ms, "std": t.std_ms} for a, t in acts.items()}}
        row["improvement_pct"] = (speedup_pct(acts["swim"].mean_ms, acts["swish"].mean_ms)
                                  if "swim" in acts and "swish" in acts else None)
        penv = paper_ref.paper_env(env)
        row["paper_env"] = penv
        if penv is not None:
            row["paper"] = {a: {"mean": m, "std": s} for a, (m, s) in paper_ref.TABLE_III[penv].items()}
            row["paper_improvement_pct"] = paper_ref.TABLE_III_IMPROVEMENT_PCT[penv]
        out.append(row)
    return out


@dataclass
class Numbers:
    """Everything REPORT.md and results.json show, computed by :func:`compute` (no file access after)."""

    groups: dict[str, EnvGroup]  # env -> its pooled runs (swim_jax.analysis.runs_io)
    configs: dict[str, dict]  # env -> the config.yaml of its first run (the budget table's settings)
    t2: dict  # :func:`table2`
    imp: dict  # :func:`improvements`
    comps: dict  # :func:`comparisons`
    t3: list[dict]  # :func:`table3`
    bench_meta: dict  # --bench file name -> its metadata
    learning: dict  # :func:`learning_table`
    series: dict  # swim_jax.analysis.report_figure.parameter_series: return vs activation parameter
    agg: aggregate.Aggregates | None = None  # across envs (rliable's metrics); None with fewer than 2 envs
    agg_refused: str | None = None  # why the envs were not aggregated (their runs' numerics differ)
    numerics: dict = field(default_factory=dict)  # :func:`by_numerics_of` the groups: {numerics: [envs]}
    gymnasium: dict = field(default_factory=dict)  # swim_jax.analysis.gymnasium_check.table of the groups
    power: dict = field(default_factory=dict)  # :func:`verdict_powers` of ``comps``


def by_numerics_of(groups: dict[str, EnvGroup]) -> dict[str, list[str]]:
    """``{numerics: [envs]}`` of the runs of ``groups`` (``runs_io.numerics``: precision and products)."""
    out: dict[str, list[str]] = {}
    for env, g in groups.items():
        for n in sorted({numerics(r) for c in g.curves.values() for r in c.run_objects}):
            out.setdefault(n, []).append(env)
    return out
