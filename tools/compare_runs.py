"""Two run folders side by side: per-seed max / final / AUC scores with bootstrap 95 % CIs, and the
difference B - A (bootstrap CI, Welch p).

    python tools/compare_runs.py RUN_A RUN_B

Used for the learning checks of the benchmark notebook (docs/notebook/BENCHMARKS-2026-11-22-to-12-04.md
§4: the same TD3 config trained on MJX (A) and on MuJoCo C (B) must land inside each other's
confidence intervals; §6: float32 against bfloat16 products, docs/PERFORMANCE.md: bf16-learning-parity). The runs may differ in anything but the env and the evaluation grid (``eval_freq`` and
the number of evaluations), which both scores need to be comparable. A folder that is missing,
corrupt, or incomparable with the other: one line on stderr naming it, exit status 2.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from swim_jax.analysis import runs_io, stats  # noqa: E402


def scores(run: runs_io.Run) -> dict:
    """Per-seed scores (``stats.per_seed_scores``) of a run's evaluations."""
    return stats.per_seed_scores(np.arange(run.returns.shape[0]) * run.eval_freq, run.returns)


def load_pair(path_a: str, path_b: str) -> tuple[runs_io.Run, runs_io.Run]:
    """Both runs, checked to share the env and the evaluation grid; :class:`runs_io.RunError` (one
    line) otherwise."""
    a, b = runs_io.load_run(path_a), runs_io.load_run(path_b)
    if a.env != b.env:
        raise runs_io.RunError(f"{path_b}: env {b.env} differs from {path_a}'s {a.env}")
    grid = lambda r: (r.eval_freq, r.returns.shape[0])
    if grid(a) != grid(b):
        raise runs_io.RunError(f"{path_b}: {b.returns.shape[0]} evaluations every {b.eval_freq} steps differ from "
                               f"{path_a}'s {a.returns.shape[0]} every {a.eval_freq}; the scores need the same grid")
    return a, b


def table(a: runs_io.Run, b: runs_io.Run) -> str:
    """The Markdown comparison table: per score, A's and B's means with bootstrap 95 % CIs, the
    difference B - A with its bootstrap CI, and Welch's two-sided p."""
    sa, sb = scores(a), scores(b)
    lines = ["| score | A: mean [95% CI] | B: mean [95% CI] | B - A [95% CI] | Welch p |", "|---|---|---|---|---|"]
    for k in sa:
        ca, cb = stats.bootstrap_ci(sa[k]), stats.bootstrap_ci(sb[k])
        d = stats.bootstrap_diff_ci(sb[k], sa[k])
        p = stats.welch_t_test(sb[k], sa[k]).p_two_sided
        lines.append(f"| {k} | {np.mean(sa[k]):.0f} [{ca[0]:.0f}, {ca[1]:.0f}] | {np.mean(sb[k]):.0f} [{cb[0]:.0f}, {cb[1]:.0f}] "
                     f"| {np.mean(sb[k]) - np.mean(sa[k]):+.0f} [{d[0]:+.0f}, {d[1]:+.0f}] | {p:.2f} |")
    return "\n".join(lines)


def main(argv) -> int:
    if len(argv) != 2:
        print("compare_runs.py: error: expected two run folders: python tools/compare_runs.py RUN_A RUN_B", file=sys.stderr)
        return 2
    try:
        a, b = load_pair(*argv)
    except runs_io.RunError as e:
        print(f"compare_runs.py: error: {e}", file=sys.stderr)
        return 2
    print(table(a, b))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
