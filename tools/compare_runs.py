"""Two run folders of the same config side by side: per-seed max / final / AUC scores with
bootstrap 95 % CIs, and the difference B - A (bootstrap CI, Welch p).

    python tools/compare_runs.py RUN_A RUN_B

Used for the native-backend learning check (docs/BENCHMARKS.md §4): the same TD3 config trained on
MJX (A) and on MuJoCo C (B) must land inside each other's confidence intervals.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from swim_jax import stats  # noqa: E402


def scores(run_dir: str) -> dict:
    """Per-seed scores (``stats.per_seed_scores``) of a run folder's evaluations.npy."""
    import yaml

    ev = np.load(os.path.join(run_dir, "evaluations.npy"))  # [n_evals, seeds]
    with open(os.path.join(run_dir, "config.yaml")) as f:
        eval_freq = yaml.safe_load(f)["eval_freq"]
    return stats.per_seed_scores(np.arange(ev.shape[0]) * eval_freq, ev)


def main(argv) -> int:
    if len(argv) != 2:
        print("usage: python tools/compare_runs.py RUN_A RUN_B", file=sys.stderr)
        return 2
    a, b = (scores(d) for d in argv)
    print("| score | A: mean [95% CI] | B: mean [95% CI] | B - A [95% CI] | Welch p |")
    print("|---|---|---|---|---|")
    for k in a:
        ca, cb = stats.bootstrap_ci(a[k]), stats.bootstrap_ci(b[k])
        d = stats.bootstrap_diff_ci(b[k], a[k])
        p = stats.welch_t_test(b[k], a[k]).p_two_sided
        print(f"| {k} | {np.mean(a[k]):.0f} [{ca[0]:.0f}, {ca[1]:.0f}] | {np.mean(b[k]):.0f} [{cb[0]:.0f}, {cb[1]:.0f}] "
              f"| {np.mean(b[k]) - np.mean(a[k]):+.0f} [{d[0]:+.0f}, {d[1]:+.0f}] | {p:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
