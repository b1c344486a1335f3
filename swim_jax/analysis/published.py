"""Our runs next to published curves at the same step: ``python -m swim_jax.published RUN_DIR ...
[--at-step N[,N2,...]]`` (docs/PUBLISHED.md says where each figure comes from and how it was measured).

The curves and how their steps line up with ours: swim_jax/analysis/published_curves.py.

For every run (a sweep folder stands for its points): our seeds' evaluations at step N (mean, sample
std, n), the published mean at N with its sample std (population std · √(n/(n−1))), the difference
ours − published with Welch's 95 % CI and two-sided p from those summary statistics
(:func:`swim_jax.analysis.stats.welch_from_stats`), and the published mean over N ± 50k (the single
points are noisy). N defaults to each run's last evaluation; several steps (``--at-step
300000,500000,1000000``) give one row per run and step, in that order, in one table. A run whose env
or algorithm has no published curve, or a step it has not reached or the curve lacks: one line, exit 2.

``--pool`` pools run folders of one (env, activation) as more seeds, as the report does
(``swim_jax.analysis.runs_io``'s grouping policy: the same config but for the seeds, no seed twice,
one numerics per env), e.g. seeds 0–4 and 5–9 of one cell as one row of 10 seeds.

``--reach R[,R2,...]`` gives another table instead: for each run and return R, the first env step at
which the mean over its seeds is ≥ R and the first at which the published mean curve is, up to the
run's last evaluation (so both sides had the same steps), and how much later ours gets there: when a
run learns, not only where it ends (e.g. Walker2d-v5 ReLU reaches 1000 90k steps after Tianshou's).

``--figure FILE`` (.png or .svg) also draws the runs' learning curves over the published curves up
to N (the largest N given; swim_jax/analysis/published_figure.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

import numpy as np

from swim_jax.analysis import runs_io, stats
from swim_jax.analysis.published_curves import SOURCE, WARMUP_STEPS, PublishedError, anchor, curve_points
from swim_jax.io import cli_parser


def ours_at(run: runs_io.Run, step: int) -> np.ndarray:
    """The run's seeds' evaluation returns at ``step`` (:class:`PublishedError` if it has none there)."""
    hit = np.flatnonzero(run.steps == step)
    if hit.size == 0:
        raise PublishedError(f"{run.path} has no evaluation at step {step:,} (its last is at {int(run.steps[-1]):,})")
    return run.returns[hit[0]]


def compare(run: runs_io.Run, step: int | None = None) -> dict:
    """One row: the run at ``step`` (default: its last evaluation) next to the published curve."""
    step = int(run.steps[-1]) if step is None else step
    ref = anchor(run.env, run.algorithm, step)
    x = ours_at(run, step)
    if x.size < 2:
        raise PublishedError(f"{run.path} has {x.size} seed; a comparison needs at least 2")
    w = stats.welch_from_stats(float(x.mean()), float(x.std(ddof=1)), int(x.size), ref.mean, ref.sd, ref.n)
    return {"run": run.path, "env": run.env, "algorithm": run.algorithm, "activation": run.activation,
            "step": step, "ours_mean": float(x.mean()), "ours_sd": float(x.std(ddof=1)), "ours_n": int(x.size),
            "published": ref.__dict__, "diff": w.diff, "diff_ci": [w.low, w.high], "welch_p": w.test.p_two_sided}


def first_reach(steps, curve, level: float) -> int | None:
    """The first of ``steps`` at which ``curve`` is ≥ ``level`` (None when it never is)."""
    hit = np.flatnonzero(np.asarray(curve) >= level)
    return int(steps[hit[0]]) if hit.size else None


def reach(run: runs_io.Run, level: float) -> dict:
    """One row: the first env step at which the run's mean return over its seeds is ≥ ``level``, the
    first at which the published mean curve is (its points up to the run's last evaluation), and
    ``later_by`` = ours − published in env steps (None where either side never gets there)."""
    last = int(run.steps[-1])
    points = [p for p in curve_points(run.env, run.algorithm) if p[0] <= last]
    ours = first_reach(run.steps, run.returns.mean(axis=1), level)
    theirs = first_reach([p[0] for p in points], [p[1] for p in points], level)
    return {"run": run.path, "env": run.env, "algorithm": run.algorithm, "activation": run.activation,
            "return": level, "ours_n": int(run.returns.shape[1]), "up_to": last, "ours_step": ours,
            "published_step": theirs, "later_by": None if ours is None or theirs is None else ours - theirs}


def pooled(runs: list[runs_io.Run]) -> list[runs_io.Run]:
    """The runs pooled by (env, activation) as the report pools them (:func:`runs_io.group_runs`;
    :class:`runs_io.RunError` when they cannot be): one Run per curve set, its ``path`` the folders
    joined by `` + ``, its returns every folder's seeds side by side."""
    out = []
    for group in runs_io.group_runs(runs).values():
        for c in group.curves.values():
            first = c.run_objects[0]
            out.append(dataclasses.replace(first, path=" + ".join(c.runs), returns=c.returns,
                                           seed_ids=[s for r in c.run_objects for s in r.seed_ids]))
    return out


def sentence(row: dict) -> str:
    """The row in words: inside or outside what the published curve's spread allows."""
    lo, hi = row["diff_ci"]
    if lo > 0 or hi < 0:
        side = "above" if lo > 0 else "below"
        return f"{side} the published curve (the difference's 95 % CI excludes 0)"
    return "no difference from the published curve detected (the difference's 95 % CI contains 0)"


def render(rows: list[dict]) -> str:
    """The rows as a markdown table and one sentence each."""
    warmup = ", ".join(f"{n // 1000}k {alg}" for alg, n in WARMUP_STEPS.items())
    L = [f"Ours next to {SOURCE} at the same number of env steps (its env_step + its random warm-up: "
         f"{warmup}); mean ± sample std over seeds; difference ours − published with Welch's 95 % "
         "CI and p:", "",
         "| run | env | algorithm | activation | step | ours | published | published, mean over ±50k | "
         "ours − published [95 % CI] (p) |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        p = r["published"]
        L.append(f"| {r['run']} | {r['env']} | {r['algorithm']} | {r['activation']} | {r['step']:,} | "
                 f"{r['ours_mean']:.1f} ± {r['ours_sd']:.1f} (n {r['ours_n']}) | {p['mean']:.1f} ± {p['sd']:.1f} "
                 f"(n {p['n']}, {p['env']}) | {p['window_mean']:.1f} | {r['diff']:+.1f} [{r['diff_ci'][0]:+.1f}, "
                 f"{r['diff_ci'][1]:+.1f}] ({stats.fmt_p(r['welch_p'])}) |")
    L += [""] + [f"- {r['run']} at {r['step']:,}: {sentence(r)}." for r in rows]
    return "\n".join(L)


def render_reach(rows: list[dict]) -> str:
    """The ``--reach`` rows as a markdown table."""
    def at(step, row):
        return f"{step:,}" if step is not None else f"not by {row['up_to']:,}"

    L = [f"The first env step at which the mean return over seeds reaches each level: ours, and the published "
         f"mean curve of {SOURCE} (its env_step + its random warm-up), both up to the run's last evaluation:", "",
         "| run | env | algorithm | activation | return | ours reaches it at | published reaches it at | "
         "ours later by |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        later = f"{r['later_by']:+,}" if r["later_by"] is not None else "n/a"
        L.append(f"| {r['run']} | {r['env']} | {r['algorithm']} | {r['activation']} | {r['return']:g} | "
                 f"{at(r['ours_step'], r)} (n {r['ours_n']}) | {at(r['published_step'], r)} | {later} |")
    return "\n".join(L)


def parse_args(argv):
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.published", description=__doc__.split("\n")[0],
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="+", metavar="RUN_DIR", help="run folders (a sweep folder stands for its points)")
    p.add_argument("--at-step", type=_steps, default=None, metavar="N[,N2,...]",
                   help="compare at step N, or at each of several steps (multiples of 5000; default: each "
                        "run's last evaluation)")
    p.add_argument("--reach", type=_levels, default=None, metavar="R[,R2,...]",
                   help="instead: the first step at which ours and the published mean curve reach each return")
    p.add_argument("--json", default=None, metavar="FILE", help="also write the rows as JSON to FILE (must not exist)")
    p.add_argument("--pool", action="store_true",
                   help="pool run folders of one (env, activation) as more seeds, as the report does")
    p.add_argument("--figure", default=None, metavar="FILE",
                   help="also draw the runs' curves over the published ones to FILE (.png or .svg; must not exist)")
    a = p.parse_args(argv)
    if a.figure is not None:
        if not a.figure.endswith((".png", ".svg")):
            p.error(f"--figure must end in .png or .svg, got {a.figure!r}")
        problem = cli_parser.output_file_problem("--figure", a.figure)
        if problem:
            p.error(problem)
    if a.reach is not None and a.at_step is not None:
        p.error("--reach and --at-step give two different tables: give one of them")
    bad = [n for n in a.at_step or () if n < 0 or n % 5000]
    if bad:
        p.error(f"--at-step takes non-negative multiples of 5000 (the published curves' spacing), got {bad[0]}")
    if a.json is not None:
        problem = cli_parser.output_file_problem("--json", a.json)
        if problem:
            p.error(problem)
    return a


def _steps(text: str) -> list[int]:
    """``--at-step``'s value: one step or several, comma-separated, each once."""
    try:
        steps = [int(t) for t in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a step or comma-separated steps, got {text!r}") from None
    if len(set(steps)) != len(steps):
        raise argparse.ArgumentTypeError(f"a step is named twice in {text!r}")
    return steps


def _levels(text: str) -> list[float]:
    try:
        levels = [float(t) for t in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a return or comma-separated returns, got {text!r}") from None
    if not all(np.isfinite(levels)):
        raise argparse.ArgumentTypeError(f"expected finite returns, got {text!r}")
    return levels


def main(argv=None) -> int:
    """CLI entry point; returns the exit status (0 printed, 2 bad input with one line on stderr).

    stdout carries the table only (so `> PUBLISHED.md` is the table); notes go to stderr."""
    args = parse_args(sys.argv[1:] if argv is None else list(argv))
    try:
        last = max(args.at_step) if args.at_step else None
        runs = runs_io.load_runs(args.runs, last)
        if args.pool:
            runs = pooled(runs)
        if args.reach:
            rows = [reach(r, level) for r in runs for level in args.reach]
        else:
            rows = [compare(r, step) for r in runs for step in (args.at_step or [None])]
    except (PublishedError, runs_io.RunError) as e:
        print(f"published: error: {e}", file=sys.stderr)
        return 2
    print(render_reach(rows) if args.reach else render(rows))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
            f.write("\n")
    if args.figure:
        from swim_jax.analysis import published_figure  # matplotlib only when asked

        published_figure.figure(runs, [args.figure], up_to=last)
        print(f"published: wrote {args.figure}", file=sys.stderr)  # stdout is the table
    return 0
