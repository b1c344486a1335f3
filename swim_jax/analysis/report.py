"""The paper's Tables II/III and Figure 4 from our runs, with the statistics the paper lacks.

    python -m swim_jax.report RUN_DIR... --out DIR [--bench FILE ...] [--score max|final|auc]
                              [--n-boot 10000] [--boot-seed 0] [--allow-incomplete] [--force]

RUN_DIR: run folders written by ``python -m swim_jax.train`` (config.yaml + evaluations.npy).
Several folders of one (env, activation) are pooled as more seeds; all runs of one env must share
``total_steps`` and ``eval_freq`` (see ``swim_jax/analysis/runs_io.py`` for the full grouping policy).
``--bench FILE``: JSON from ``python -m swim_jax.bench activations`` with an ``actor_inference``
section (Table III). At least one RUN_DIR or one ``--bench`` is required.

Writes into DIR: ``REPORT.md`` (tables, figure, statistics, verdicts, budgets), ``results.json``
(every number in full precision), ``figure4.png`` and ``figure4.svg`` (when there are runs),
``learning.png`` and ``learning.svg`` (critic loss, actor loss and Q estimate per chunk, when runs
have a ``metrics.csv``; older run folders without one report as before),
``sweep.png`` and ``sweep.svg`` (when a parameter was swept). DIR must not exist or be empty unless
``--force``: then only those files are replaced, and those of them this report does not write (a
sweep figure of an earlier report) are removed; other files stay. Everything is computed before
anything is written, and the output appears all or nothing (swim_jax/io/output_folder.py, the rule
every ``--out DIR`` of the tool follows).

Exit status: 0 done; 2 bad input (missing/corrupt run folder or bench file, incompatible runs, bad
arguments, unusable --out, non-empty --out without --force): one line on stderr, nothing written.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import sys
import tempfile
from dataclasses import dataclass, field

import numpy as np
import yaml

from swim_jax.io import cli_parser, output_folder
from swim_jax.analysis import aggregate, paper_ref, stats, tidy
from swim_jax.io.bench_results import BenchError, load_bench, speedup_pct
from swim_jax.analysis.report_figure import LEARNING_PANELS, display_name, figure4, group_colors, learning_figure, parameter_series, sweep_figure
from swim_jax.analysis.aggregate_figure import profile_figure
from swim_jax.analysis.runs_io import EnvGroup, RunError, load_and_group, numerics

OUTPUT_FILES = ("REPORT.md", "results.json", "results.csv", "figure4.png", "figure4.svg", "learning.png", "learning.svg",
                "profile.png", "profile.svg",
                "sweep.png", "sweep.svg")  # all it may write
SCORES = ("max", "final", "auc")
SCORE_WORDS = {
    "max": "max over evaluations of the seed's return",
    "final": "the seed's return at the last evaluation",
    "auc": "the seed's time-averaged return (trapezoid AUC / step span)",
}


class ReportError(ValueError):
    """Bad input for the report; ``str(e)`` is one line."""


# ------------------------------------------------------------------------------------------------
# numbers
# ------------------------------------------------------------------------------------------------


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


def learning_table(groups: dict[str, EnvGroup]) -> dict:
    """``{env: {label: row}}`` for the curve sets with learning metrics (metrics.csv) in at least one
    chunk; envs without any are left out. row = ``{"steps": [chunk end steps], "seeds": n,
    "runs_without_metrics": [paths], metric: {"mean", "min", "max": [per chunk]}}`` for each metric
    of :data:`swim_jax.analysis.report_figure.LEARNING_PANELS`: the mean, min and max over the seeds with a
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
            rows[label].update({metric: _over_seeds(m.values[metric]) for metric, _ in LEARNING_PANELS})
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


# ------------------------------------------------------------------------------------------------
# markdown
# ------------------------------------------------------------------------------------------------


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


def _pm(m: float, s: float, nd: int = 2) -> str:
    return f"{m:.{nd}f} ± {s:.{nd}f}"


def _pct(p) -> str:
    if p is None or not math.isfinite(p):
        return "—"
    return f"{p:+.1f}%"


def _name(label: str) -> str:
    return display_name(label)


def _md_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def render_markdown(nums: Numbers, score: str, n_boot: int, boot_seed: int, command: str) -> str:
    """The whole REPORT.md as a string: a pure function of the computed numbers, the verdict's
    score, the bootstrap settings and the command line it names; one section builder per heading."""
    L = ["# Swim vs Swish vs ReLU for TD3: report", "", f"Generated by `{command}`.", ""]
    if nums.groups:
        L += _budget_section(nums.groups, nums.configs)
        L += _table2_section(nums.t2, nums.groups)
        L += _paper_comparison_section(nums.t2, nums.imp)
        L += _figure4_section()
        if nums.learning:
            L += _learning_section(nums.groups, nums.learning)
        L += _statistics_section(nums.comps, n_boot, boot_seed)
        L += _verdict_section(nums.comps, score, nums.groups)
    if nums.agg is not None:
        L += _aggregate_section(nums.agg, n_boot, boot_seed, nums.numerics)
    elif nums.agg_refused:
        L += ["## Across envs: normalized scores (rliable's aggregates)", "", f"Not computed: {nums.agg_refused}.", ""]
    if nums.t3:
        L += _table3_section(nums.t3, nums.bench_meta)
    if nums.groups:
        L += _inputs_section(nums.groups)
    return "\n".join(L) + _sweep_section(nums.series)


def _precision_cell(g: EnvGroup, precision: str) -> str:
    """The env's precision, and its runs' matmul products (as recorded) where they are not that
    precision: ``"float32, bfloat16 products"`` when all runs agree, else (runs of different numerics
    compared on request) per activation (``"float32; products: Swim float32, Swish bfloat16 ‡"``)."""
    per_act = {a: c.matmul_dtypes for a, c in g.curves.items() if c.matmul_dtypes}
    if all(ds == [precision] for ds in per_act.values()):
        return precision
    shown = {a: "+".join(ds) for a, ds in per_act.items()}
    if len(set(shown.values())) == 1 and len(shown) == len(g.curves):
        return f"{precision}, {next(iter(shown.values()))} products"
    return f"{precision}; products: " + ", ".join(f"{_name(a)} {d}" for a, d in shown.items()) + " " + MIXED_MARK


def _budget_section(groups: dict[str, EnvGroup], configs: dict[str, dict]) -> list[str]:
    """Our budget per env next to the paper's, and warnings where they differ or activations' configs do."""
    pb = paper_ref.PAPER_BUDGET
    L = ["## Budget", "",
         f"The paper: {pb['total_steps']:,} steps per run, evaluation every {pb['eval_freq']} steps, "
         f"{pb['seeds']} seeds, {pb['precision']}, gym MuJoCo -v2 envs. Ours:", ""]
    rows = []
    for env, g in groups.items():
        cfg = configs[env]
        seeds = ", ".join(f"{_name(a)} {c.n_seeds}" for a, c in g.curves.items())
        steps = f"{g.total_steps:,}"
        if g.truncated_to_step is not None:
            steps += f" (truncated to {g.truncated_to_step:,}: incomplete runs)"
        rows.append([env, steps, str(g.eval_freq), str(cfg.get("eval_episodes", "?")), seeds,
                     _precision_cell(g, str(cfg.get("precision", "?")))])
    L += [_md_table(["env", "steps per run", "eval every", "episodes per eval", "seeds", "precision"], rows), ""]
    small = [env for env, g in groups.items() if g.total_steps < pb["total_steps"]
             or min(c.n_seeds for c in g.curves.values()) < pb["seeds"]]
    if small:
        L += [f"**Smaller budget than the paper** for {', '.join(small)}: returns are not comparable "
              f"with the paper's in absolute terms.", ""]
    warns = [f"- {env}: {w}" for env, g in groups.items() for w in g.warnings]
    if warns:
        L += ["**Config differences between activations** (beyond the activation itself):", ""] + warns + [""]
    return L


MIXED_MARK = "‡"  # an env whose runs differ in precision or matmul products, compared on request


def _marked(env: str, groups: dict[str, EnvGroup]) -> str:
    """``env``, with :data:`MIXED_MARK` and what differs when its runs' numerics differ."""
    g = groups.get(env)
    return f"{env} {MIXED_MARK} ({g.mixed_precision})" if g is not None and g.mixed_precision else env


def _table2_section(t2: dict, groups: dict[str, EnvGroup]) -> list[str]:
    """Table II: max of mean, final and AUC returns per env and activation, with their definitions."""
    L = ["## Table II: returns", "",
         "Definitions. *Max*: the maximum over evaluations of the mean-over-seeds return (the paper's "
         "metric), ± the standard deviation over seeds at that same evaluation. *Final*: mean ± std "
         "over seeds at the last evaluation. *AUC*: per seed, the trapezoid area under the return curve "
         "divided by the step span (= time-averaged return, same units as a return); mean ± std over "
         "seeds. All std are population std over seeds (ddof = 0, as `numpy.std`). Each evaluation is "
         "the mean return of the run's evaluation episodes without exploration noise.", ""]
    for env, rows_ in t2.items():
        L += [f"### {_marked(env, groups)}", ""]
        rows = [[_name(a), str(r["seeds"]), _pm(r["max_mean"], r["max_std"]), f"{r['max_step']:,}",
                 _pm(r["final_mean"], r["final_std"]), _pm(r["auc_mean"], r["auc_std"])]
                for a, r in rows_.items()]
        L += [_md_table(["activation", "seeds", "max of mean return ± std", "at step",
                         "final return ± std", "AUC / steps ± std"], rows), ""]
    return L


def _paper_comparison_section(t2: dict, imp: dict) -> list[str]:
    """Swim's improvement over Swish per env, next to the paper's Table II row for that env."""
    L = ["### Swim vs Swish, next to the paper", "",
         "Improvement = (Swim − Swish) / |Swish| of the means. The paper's columns are its Table II "
         "(gym -v2 envs, 1M steps, 5 seeds, float64): **a different env version and budget**, shown "
         "for orientation only.", ""]
    rows = []
    for env, r in t2.items():
        if "swim" not in r or "swish" not in r:
            continue
        penv = paper_ref.paper_env(env)
        if penv:
            ps, pw = paper_ref.TABLE_II[penv]["swish"], paper_ref.TABLE_II[penv]["swim"]
            paper_cells = [f"{penv} (1M steps, 5 seeds)", _pm(*ps, nd=1), _pm(*pw, nd=1),
                           f"{paper_ref.TABLE_II_IMPROVEMENT_PCT[penv]}%"]
        else:
            paper_cells = ["— (not in the paper)", "—", "—", "—"]
        rows.append([env, _pm(r["swish"]["max_mean"], r["swish"]["max_std"], 1),
                     _pm(r["swim"]["max_mean"], r["swim"]["max_std"], 1), _pct(imp[env]["max"]),
                     _pct(imp[env]["final"]), _pct(imp[env]["auc"])] + paper_cells)
    if not rows:
        return L + ["(No env has both Swim and Swish runs.)", ""]
    return L + [_md_table(["env", "Swish max", "Swim max", "impr. max", "impr. final", "impr. AUC",
                           "paper env", "paper Swish", "paper Swim", "paper impr."], rows), ""]


def _figure4_section() -> list[str]:
    return ["## Figure 4: learning curves", "",
            "Mean over seeds; shaded: ± half a standard deviation over seeds (as in the paper).", "",
            "![Figure 4: learning curves](figure4.png)", "", "Vector version: [figure4.svg](figure4.svg)", ""]


def _learning_section(groups, learning: dict) -> list[str]:
    """REPORT.md lines of the learning-metrics figure (``learning.png``): what it shows, and the
    runs left out of it for want of a metrics.csv."""
    L = ["## Learning metrics between evaluations", "",
         "Per chunk of `eval_freq` env steps, from each run's `metrics.csv`: the critic loss (mean TD3 "
         "critic loss over the chunk's updates), the actor loss (mean over its actor updates) and the Q "
         "estimate (mean Q₁ over the sampled batches). Line: mean over seeds; shaded: min–max over seeds; "
         "no point before the first update (`learning_starts`). A panel whose values are all positive has "
         "a log axis.", "",
         "![Learning metrics](learning.png)", "", "Vector version: [learning.svg](learning.svg)", ""]
    missing = [p for rows in learning.values() for row in rows.values() for p in row["runs_without_metrics"]]
    missing += [p for env, g in groups.items() for label, c in g.curves.items()
                if label not in learning.get(env, {}) for p in c.runs]
    if missing:
        L += ["Left out (no `metrics.csv` or no row in it; run folders written before it existed have none): "
              + ", ".join(f"`{p}`" for p in missing) + ".", ""]
    return L


def by_numerics_of(groups: dict[str, EnvGroup]) -> dict[str, list[str]]:
    """``{numerics: [envs]}`` of the runs of ``groups`` (``runs_io.numerics``: precision and products)."""
    out: dict[str, list[str]] = {}
    for env, g in groups.items():
        for n in sorted({numerics(r) for c in g.curves.values() for r in c.run_objects}):
            out.setdefault(n, []).append(env)
    return out


def _aggregate_section(agg: aggregate.Aggregates, n_boot: int, boot_seed: int, numerics: dict) -> list[str]:
    """Aggregates across envs on normalized scores: IQM, mean, median, optimality gap with CIs,
    probability of improvement between every pair of labels, the normalization and the figure;
    marked when ``numerics`` (``{numerics: [envs]}``) has more than one entry."""
    L = ["## Across envs: normalized scores (rliable's aggregates)", "",
         f"Per-seed **{agg.score}** scores normalized per env, (score − random) / (reference − random): 0 is a "
         "uniform random policy, 1 published TD3 at 1M steps (swim_jax/analysis/aggregate.py). 95 % CIs: "
         f"stratified bootstrap over each env's seeds, {n_boot} resamples, numpy RandomState({boot_seed}) (the "
         "draws rliable makes after `np.random.seed` of the same seed).", "",
         _md_table(["env", "random policy", "reference", "reference source"],
                   [[e, f"{aggregate.NORMALIZATION[e][0]:g}", f"{aggregate.NORMALIZATION[e][1]:g}",
                     aggregate.NORMALIZATION[e][2]] for e in agg.envs]), ""]
    if len(numerics) > 1:
        L += [f"{MIXED_MARK} Runs of different precision or matmul products are aggregated here (--mixed-precision): "
              + "; ".join(f"{n}: {', '.join(envs)}" for n, envs in numerics.items()) + ".", ""]
    rows = [[_name(a)] + [f"{p:.3f} [{lo:.3f}, {hi:.3f}]" for p, lo, hi in (agg.metrics[a][m] for m in aggregate.METRICS)]
            for a in agg.metrics]
    L += [_md_table(["label", "IQM", "mean", "median", "optimality gap"], rows), ""]
    rows = [[f"{_name(k.split('_vs_')[0])} > {_name(k.split('_vs_')[1])}", f"{p:.2f} [{lo:.2f}, {hi:.2f}]"]
            for k, (p, lo, hi) in agg.improvement.items()]
    L += [_md_table(["probability of improvement", "P [95 % CI]"], rows), "",
          "![performance profiles](profile.png)", ""]
    return L


def _statistics_section(comps: dict, n_boot: int, boot_seed: int) -> list[str]:
    """Every pairwise comparison per env and score: bootstrap CIs, IQM, P(X > Y), Welch's test."""
    L = ["## Beyond the paper: statistics per env", "",
         f"Per-seed scores: *max* = {SCORE_WORDS['max']}; *final* = {SCORE_WORDS['final']}; *auc* = "
         f"{SCORE_WORDS['auc']}. CI: 95% percentile bootstrap of the mean over seeds ({n_boot} resamples, "
         f"numpy default_rng with seed {boot_seed} for X's CI, {boot_seed + 1} for Y's CI and "
         f"{boot_seed + 2} for the difference's, so deterministic); the difference's CI resamples both "
         "samples independently. IQM: interquartile mean over seeds (drop ⌊n/4⌋ from each end). "
         "P(X > Y): over all seed pairs, ties count ½. Welch: unequal-variance t-test, "
         "Welch–Satterthwaite df, two-sided p. The per-seed *max* is biased upwards by evaluation noise "
         "(a max over noisy evaluations); *auc* is the least noisy score. These rows are exploratory: "
         f"with 3 scores × {max((len(per) for per in comps.values()), default=0) or 3} pairs per env some "
         "small p-values are expected by chance (no multiple-"
         "comparison correction); the verdict below uses one score fixed in advance (`--score`).", ""]
    rows = [[env, f"{_name(x)} vs {_name(y)}", s] + _comparison_cells(c)
            for env, per in comps.items() for pair, by_score in per.items()
            for x, y in [pair.split("_vs_")] for s, c in by_score.items()]
    if not rows:
        return L + ["(No env has two of Swim, Swish, ReLU to compare.)", ""]
    return L + [_md_table(["env", "X vs Y", "score", "seeds X/Y", "X mean [95% CI]", "Y mean [95% CI]",
                           "IQM X / Y", "X − Y [95% CI]", "P(X > Y)", "Welch t (df)", "p"], rows), ""]


def _comparison_cells(c: stats.Comparison) -> list[str]:
    """The statistics table's cells of one comparison, from "seeds X/Y" to "p"."""
    w = c.welch
    return [f"{c.n_x}/{c.n_y}",
            f"{c.mean_x:.1f} [{c.ci_x[0]:.1f}, {c.ci_x[1]:.1f}]",
            f"{c.mean_y:.1f} [{c.ci_y[0]:.1f}, {c.ci_y[1]:.1f}]",
            f"{c.iqm_x:.1f} / {c.iqm_y:.1f}",
            f"{c.diff:+.1f} [{c.diff_ci[0]:+.1f}, {c.diff_ci[1]:+.1f}]",
            f"{c.prob_improvement:.2f}",
            _welch_cell(w),
            "—" if w is None else stats.fmt_p(w.p_two_sided)]


def _welch_cell(w) -> str:
    """``t (df)``; '—' without a test (a sample has < 2 seeds); 'n/a (zero variance)' when both
    samples are constant (t undefined)."""
    if w is None:
        return "—"
    if not (math.isfinite(w.t) and math.isfinite(w.df)):
        return "n/a (zero variance)"
    return f"{w.t:.2f} ({w.df:.1f})"


def _verdict_section(comps: dict, score: str, groups: dict[str, EnvGroup]) -> list[str]:
    """One verdict per env on Swim vs Swish, on the score fixed by ``--score``."""
    L = ["## Verdict: Swim vs Swish", "",
         f"On the per-seed **{score}** score ({SCORE_WORDS[score]}). The evidence counts as sufficient "
         f"only with ≥ {stats.MIN_SEEDS} seeds per activation, Welch p < {stats.ALPHA} and a 95% CI of "
         "the difference that excludes 0.", ""]
    for env, per in comps.items():
        if "swim_vs_swish" in per:
            L.append(f"- **{_marked(env, groups)}**: {stats.verdict(per['swim_vs_swish'][score])}")
        else:
            L.append(f"- **{_marked(env, groups)}**: no verdict (needs both Swim and Swish runs).")
    return L + [""] if comps else L


def _table3_section(t3: list[dict], bench_meta: dict) -> list[str]:
    """Table III: actor inference time per activation, next to the paper's, and the bench files' machines."""
    L = ["## Table III: actor inference time", "",
         "Actor forward pass on a batch of 256 states, mean ± std in ms over the timed calls. "
         "Improvement = (Swish − Swim) / Swim, the paper's definition (time saved by Swim). The paper's "
         "columns: its Table III (first 100 training iterations, ARM CPU, float64) — a different "
         "machine.", ""]
    acts = [a for a in ("swish", "swim", "relu") if any(a in r["ms"] for r in t3)]  # the paper's order
    rows = []
    for r in t3:
        cells = [r["env"], r["dtype"]]
        cells += [_pm(r["ms"][a]["mean"], r["ms"][a]["std"], 3) if a in r["ms"] else "—" for a in acts]
        cells.append(_pct(r["improvement_pct"]))
        if r.get("paper"):
            cells += [f"{r['paper_env']} (float64, ARM)", _pm(r["paper"]["swish"]["mean"], r["paper"]["swish"]["std"], 3),
                      _pm(r["paper"]["swim"]["mean"], r["paper"]["swim"]["std"], 3),
                      f"{r['paper_improvement_pct']}%"]
        else:
            cells += ["—"] * 4
        cells.append(r["source"])
        rows.append(cells)
    L += [_md_table(["env", "dtype"] + [f"{_name(a)} ms" for a in acts] +
                    ["Swim impr.", "paper env", "paper Swish ms", "paper Swim ms", "paper impr.", "source"], rows), ""]
    for src, meta in bench_meta.items():
        desc = ", ".join(f"{k}: {meta[k]}" for k in ("cpu", "cores", "jax", "clock", "repeats", "time", "command")
                         if k in meta)
        L.append(f"- `{src}`: {desc}")
    return L + [""]


def _inputs_section(groups: dict[str, EnvGroup]) -> list[str]:
    """The run folders behind every curve."""
    L = ["## Inputs", ""]
    for env, g in groups.items():
        for a, c in g.curves.items():
            L.append(f"- {env} / {_name(a)}: " + ", ".join(f"`{p}`" for p in c.runs))
    return L + [""]


def _sweep_section(series: dict) -> str:
    """Return-vs-parameter table and figure (``sweep.png``) for every activation run with ≥ 2 values
    of its parameter in one env (:func:`swim_jax.analysis.report_figure.parameter_series`); '' when none."""
    if not series:
        return ""
    rows = [[env, _name(act), f"{v:g}", _pm(float(final.mean()), float(final.std(ddof=0))), f"{best:.2f}", str(final.size)]
            for (env, act, key), pts in series.items() for v, final, best in pts]
    return ("\n## Return vs activation parameter (sweeps)\n\n"
            "Final = last evaluation, mean ± std over seeds; best = maximum of the mean-over-seeds curve.\n\n"
            + _md_table(["env", "activation", "parameter", "final return", "best mean", "seeds"], rows)
            + "\n\n![return vs parameter](sweep.png)\n")


# ------------------------------------------------------------------------------------------------
# results.json
# ------------------------------------------------------------------------------------------------


def results_dict(nums: Numbers, score: str, n_boot: int, boot_seed: int) -> dict:
    """Every number of the report, JSON-serialisable; an env of ``nums.learning``
    (:func:`learning_table`) gets its rows as ``learning_metrics``."""
    t2, comps = nums.t2, nums.comps
    def comp(c: stats.Comparison) -> dict:
        w = c.welch
        return {"n_x": c.n_x, "n_y": c.n_y, "mean_x": c.mean_x, "mean_y": c.mean_y, "diff": c.diff,
                "diff_ci95": list(c.diff_ci), "ci95_x": list(c.ci_x), "ci95_y": list(c.ci_y),
                "iqm_x": c.iqm_x, "iqm_y": c.iqm_y, "prob_improvement": c.prob_improvement,
                "welch": None if w is None else {"t": w.t, "df": w.df, "p_two_sided": w.p_two_sided}}

    out = {
        "definitions": {
            "max": "max over evaluations of the mean-over-seeds return; std = population std over seeds at that evaluation",
            "final": "mean / population std over seeds at the last evaluation",
            "auc": "per-seed trapezoid AUC over steps divided by the step span; mean / population std over seeds",
            "improvement_pct": "100*(swim-swish)/|swish| of the means",
            "table3_improvement_pct": "100*(swish-swim)/swim of the mean ms (the paper's definition)",
            "bootstrap": (f"percentile, {n_boot} resamples, 95%; numpy default_rng seeds {boot_seed} (x), "
                          f"{boot_seed + 1} (y), {boot_seed + 2} (difference)"),
        },
        "paper_budget": paper_ref.PAPER_BUDGET,
        "envs": {
            env: {
                "total_steps": g.total_steps, "eval_freq": g.eval_freq, "truncated_to_step": g.truncated_to_step,
                "steps": [int(s) for s in g.steps], "warnings": g.warnings,
                # (only where runs of different numerics were compared on request: older reports stay byte for byte)
                **({"mixed_precision": g.mixed_precision} if g.mixed_precision else {}),
                "curves": {a: {"mean": c.returns.mean(axis=1).tolist(), "std": c.returns.std(axis=1).tolist(),
                               # the runs' matmul products, where they are not the env's precision
                               **({"matmul_dtypes": c.matmul_dtypes}
                                  if c.matmul_dtypes and c.matmul_dtypes != [str(nums.configs[env].get("precision"))] else {})}
                           for a, c in g.curves.items()},
                "table2": t2[env], "improvement_pct": nums.imp.get(env),
                "comparisons": {pair: {s: comp(c) for s, c in by.items()} for pair, by in comps[env].items()},
                "verdict": (stats.verdict(comps[env]["swim_vs_swish"][score])
                            if "swim_vs_swish" in comps[env] else None),
            }
            for env, g in nums.groups.items()
        },
        "verdict_score": score,
        "table3": nums.t3,
    }
    for env, rows in nums.learning.items():
        out["envs"][env]["learning_metrics"] = rows
    if nums.agg is not None:  # (absent with fewer than 2 envs: older reports stay byte for byte)
        out["aggregate"] = nums.agg.to_json()
    return out


def _json_safe(obj):
    """NaN/inf → None (strict JSON), recursively; numpy scalars → Python numbers."""
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def summary_lines(res: dict) -> list[str]:
    """Short stdout summary: per env, Swim vs Swish max-of-mean returns and the verdict."""
    out = []
    for env, e in res["envs"].items():
        t2 = e["table2"]
        if "swim" in t2 and "swish" in t2:
            imp = e["improvement_pct"]["max"]
            out.append(f"{env}: Swim {t2['swim']['max_mean']:.1f} ± {t2['swim']['max_std']:.1f} vs Swish "
                       f"{t2['swish']['max_mean']:.1f} ± {t2['swish']['max_std']:.1f} (max of mean return, "
                       f"{'n/a' if imp is None else f'{imp:+.1f}%'}) — {e['verdict']}")
        else:
            out.append(f"{env}: {', '.join(t2)} only; no Swim vs Swish comparison")
    return out


# ------------------------------------------------------------------------------------------------
# CLI
# ------------------------------------------------------------------------------------------------


def parse_args(argv):
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.report", description=__doc__,
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="*", metavar="RUN_DIR", help="run folders from python -m swim_jax.train")
    p.add_argument("--out", required=True, help="output folder (must not exist or be empty, unless --force)")
    p.add_argument("--bench", action="append", default=[], metavar="FILE",
                   help="activation benchmark JSON for Table III (repeatable)")
    p.add_argument("--score", choices=SCORES, default="max",
                   help="per-seed score the verdict uses (default max, the paper's Table II metric)")
    p.add_argument("--n-boot", type=int, default=10_000, help="bootstrap resamples (default 10000)")
    p.add_argument("--boot-seed", type=int, default=0, help="bootstrap RNG seed (default 0)")
    p.add_argument("--allow-incomplete", action="store_true",
                   help="truncate every run of an env to the evaluations all of them have")
    p.add_argument("--baseline", metavar="LABEL", default=None,
                   help="compare every other label against LABEL (e.g. relu, swim(k=0.75)); default: every pair "
                        "of labels. The Swim vs Swish verdict is the paper's either way")
    p.add_argument("--at-step", type=int, default=None, metavar="N",
                   help="report every run at the budget of N steps (its evaluations up to step N; each run "
                        "must have reached it), e.g. Table II at 300000 from 1M runs")
    p.add_argument("--mixed-precision", action="store_true",
                   help="compare runs of one env that differ in precision or matmul_dtype (refused without "
                        "it); their rows are marked " + MIXED_MARK)
    p.add_argument("--force", action="store_true",
                   help="write into a non-empty --out, replacing only the report's own files")
    a = p.parse_args(argv)
    if not a.runs and not a.bench:
        p.error("give at least one RUN_DIR or --bench FILE")
    if a.n_boot < 100:
        p.error("--n-boot must be >= 100")
    if a.at_step is not None and a.at_step < 1:
        p.error(f"--at-step must be >= 1 (an evaluation step of every run), got {a.at_step}")
    if a.boot_seed < 0:
        p.error(f"--boot-seed must be >= 0 (numpy's default_rng), got {a.boot_seed}")
    return a


def load_inputs(args) -> tuple[dict[str, EnvGroup], list, dict]:
    """(run groups, benchmark rows, ``{bench file name: metadata}``) from ``args``' run folders
    and ``--bench`` files; :class:`ReportError` (one line) on bad input."""
    try:
        groups = (load_and_group(args.runs, allow_incomplete=args.allow_incomplete, at_step=args.at_step,
                                 mixed_precision=args.mixed_precision) if args.runs else {})
    except RunError as e:
        raise ReportError(str(e)) from None
    bench_rows, bench_meta = [], {}
    for path in args.bench:
        try:
            rows, meta = load_bench(path)
        except BenchError as e:
            raise ReportError(str(e)) from None
        src = os.path.basename(path)
        if src in bench_meta:
            raise ReportError(f"{path}: two --bench files share the name {src}")
        bench_rows += rows
        bench_meta[src] = meta
    return groups, bench_rows, bench_meta


def compute(args) -> Numbers:
    """Every number of the report from ``args`` (reads the inputs; :class:`ReportError` on bad ones)."""
    groups, bench_rows, bench_meta = load_inputs(args)
    labels = sorted({a for g in groups.values() for a in g.curves})
    if args.baseline is not None and args.baseline not in labels:
        raise ReportError(f"--baseline {args.baseline!r} is not a label of these runs; valid: {', '.join(labels)}")
    t2 = table2(groups)
    per_env = {env: {a: stats.per_seed_scores(c.steps, c.returns)[args.score] for a, c in g.curves.items()}
               for env, g in groups.items()}
    by_numerics = by_numerics_of(groups)
    agg_refused = None
    if len(by_numerics) > 1 and not args.mixed_precision:  # an aggregate across envs is one comparison too
        agg_refused = ("envs differ in precision or matmul_dtype (" + "; ".join(
            f"{n}: {', '.join(envs)}" for n, envs in by_numerics.items()) + "); --mixed-precision aggregates them, marked")
    return Numbers(groups=groups, configs={env: _first_config(g) for env, g in groups.items()}, t2=t2,
                   imp=improvements(t2), comps=comparisons(groups, args.n_boot, args.boot_seed, args.baseline),
                   t3=table3(bench_rows), bench_meta=bench_meta, learning=learning_table(groups),
                   series=parameter_series(groups),
                   agg=None if agg_refused else aggregate.aggregate(per_env, args.score, reps=args.n_boot,
                                                                    seed=args.boot_seed),
                   agg_refused=agg_refused if len(groups) > 1 else None, numerics=by_numerics)


def _first_config(g: EnvGroup) -> dict:
    c = next(iter(g.curves.values()))
    with open(os.path.join(c.runs[0], "config.yaml")) as f:
        return yaml.safe_load(f)


def build(args, command: str) -> dict[str, bytes | str]:
    """Compute everything from ``args``; return ``{file name: content}`` (figures as bytes).

    Raises :class:`ReportError` (one line) on bad input. Writes nothing.
    """
    nums = compute(args)
    files: dict[str, bytes | str] = {}
    if nums.groups:
        files.update(_figure_bytes("figure4", lambda paths: figure4(nums.groups, paths)))
    if nums.learning:
        files.update(_figure_bytes("learning", lambda paths: learning_figure(nums.learning, group_colors(nums.groups),
                                                                             paths)))
    files["REPORT.md"] = render_markdown(nums, args.score, args.n_boot, args.boot_seed, command)
    if nums.series:
        files.update(_figure_bytes("sweep", lambda paths: sweep_figure(nums.series, paths)))
    if nums.agg is not None:
        files.update(_figure_bytes("profile", lambda paths: profile_figure(nums.agg, paths)))
    res = results_dict(nums, args.score, args.n_boot, args.boot_seed)
    files["results.json"] = json.dumps(_json_safe(res), indent=1, allow_nan=False) + "\n"
    if nums.groups:  # per seed and evaluation, for other tools (swim_jax/analysis/tidy.py)
        files["results.csv"] = tidy.to_csv(tidy.tidy_rows(
            [r for g in nums.groups.values() for c in g.curves.values() for r in c.run_objects]))
    return files


def _figure_bytes(stem: str, draw) -> dict[str, bytes]:
    """``{stem.png: bytes, stem.svg: bytes}`` from ``draw(paths)`` writing into a temporary folder."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        paths = [os.path.join(tmp, f"{stem}.png"), os.path.join(tmp, f"{stem}.svg")]
        draw(paths)
        for p in paths:
            with open(p, "rb") as f:
                out[os.path.basename(p)] = f.read()
    return out


def main(argv=None) -> int:
    """CLI entry point; returns the exit status (0 ok, 2 bad input with one line on stderr)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv)
    command = "python -m swim_jax.report " + " ".join(argv)
    try:
        # refuse an unusable --out before the (slower) computation, and again when writing
        output_folder.check(args.out, args.force, OUTPUT_FILES)
        files = build(args, command)
        output_folder.write(args.out, files, args.force, OUTPUT_FILES)
    except (ReportError, output_folder.OutputFolderError) as e:
        print(f"report: error: {e}", file=sys.stderr)
        return 2
    for line in summary_lines(json.loads(files["results.json"])):
        print(line)
    print(f"report: wrote {', '.join(sorted(files))} to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
