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

The numbers are computed in swim_jax/analysis/report_numbers.py, REPORT.md is written by
swim_jax/analysis/report_markdown.py and the figures by report_figure.py; this module reads the
inputs, writes results.json and the folder, and is the command.

Exit status: 0 done; 2 bad input (missing/corrupt run folder or bench file, incompatible runs, bad
arguments, unusable --out, non-empty --out without --force): one line on stderr, nothing written.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile

import numpy as np
import yaml

from swim_jax.io import cli_parser, output_folder
from swim_jax.analysis import aggregate, gymnasium_check, paper_ref, stats, tidy
from swim_jax.io.bench_results import BenchError, load_bench
from swim_jax.analysis.report_figure import figure4, group_colors, learning_figure, parameter_series, sweep_figure
from swim_jax.analysis.aggregate_figure import profile_figure
from swim_jax.analysis.report_markdown import MIXED_MARK, render_markdown
from swim_jax.analysis.report_numbers import (SCORES, Numbers, by_numerics_of, comparisons, improvements, learning_table,
                                              table2, table3, verdict_powers)
from swim_jax.analysis.runs_io import EnvGroup, RunError, load_and_group

OUTPUT_FILES = ("REPORT.md", "results.json", "results.csv", "figure4.png", "figure4.svg", "learning.png", "learning.svg",
                "profile.png", "profile.svg",
                "sweep.png", "sweep.svg")  # all it may write


class ReportError(ValueError):
    """Bad input for the report; ``str(e)`` is one line."""


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
                # (only with Swim and Swish, 2 seeds or more each: older reports stay byte for byte)
                **({"verdict_power": nums.power[env]} if env in nums.power else {}),
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
    if nums.gymnasium:  # (absent without gymnasium-evaluation.json files: older reports stay byte for byte)
        out["gymnasium_check"] = {env: {a: {**row, **gymnasium_check.summary(row)} for a, row in by.items()}
                                  for env, by in nums.gymnasium.items()}
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
    try:
        checks = gymnasium_check.table(groups)
    except RunError as e:
        raise ReportError(str(e)) from None
    comps = comparisons(groups, args.n_boot, args.boot_seed, args.baseline)
    return Numbers(groups=groups, configs={env: _first_config(g) for env, g in groups.items()}, t2=t2,
                   imp=improvements(t2), comps=comps, power=verdict_powers(comps, args.score),
                   t3=table3(bench_rows), bench_meta=bench_meta, learning=learning_table(groups),
                   series=parameter_series(groups),
                   agg=None if agg_refused else aggregate.aggregate(per_env, args.score, reps=args.n_boot,
                                                                    seed=args.boot_seed),
                   agg_refused=agg_refused if len(groups) > 1 else None, numerics=by_numerics, gymnasium=checks)


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
