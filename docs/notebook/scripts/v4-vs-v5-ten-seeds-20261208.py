# Issue 48 item 5: Walker2d-v4 against -v5, float32 ReLU at 300k, ten seeds a side (each pooled from two
# curated folders, seeds 0-4 and 5-9): Welch on the per-seed final, max and time-averaged return (AUC).
# Run from the repository root: python docs/notebook/scripts/v4-vs-v5-ten-seeds-20261208.py
import numpy as np

from swim_jax.analysis import runs_io, stats

CELLS = {
    "v5": ["runs/curated/study-f32/walker_relu", "runs/curated/study-f32-seeds5-9/walker_relu"],
    "v4": ["runs/curated/study-f32-walker-v4/walker_relu", "runs/curated/study-f32-walker-v4-seeds5-9/walker_relu"],
}


def per_seed(folders: list[str], step: int = 300_000) -> dict[str, np.ndarray]:
    """The folders' per-seed scores at ``step``, seeds concatenated in folder order."""
    scores = [stats.per_seed_scores(*_curve(f, step)) for f in folders]
    return {k: np.concatenate([s[k] for s in scores]) for k in scores[0]}


def _curve(folder: str, step: int) -> tuple[np.ndarray, np.ndarray]:
    run = runs_io.load_run(folder, at_step=step)
    return run.steps, run.returns


scores = {version: per_seed(folders) for version, folders in CELLS.items()}
for score in ("final", "max", "auc"):
    v4, v5 = scores["v4"][score], scores["v5"][score]
    welch = stats.welch_t_test(v4, v5)
    lo, hi = stats.welch_diff_ci(v4, v5)
    print(f"{score:5s} v4 ({len(v4)}) {v4.mean():.0f} ± {v4.std(ddof=1):.0f}   v5 ({len(v5)}) {v5.mean():.0f} ± "
          f"{v5.std(ddof=1):.0f}   v4 − v5 {v4.mean() - v5.mean():+.0f} [{lo:+.0f}, {hi:+.0f}], Welch p {welch.p_two_sided:.3f}")
    print(f"      the true difference Welch finds 80 % of the time at p < 0.05 with these samples: "
          f"{stats.detectable_difference(v4.std(ddof=1), len(v4), v5.std(ddof=1), len(v5)):.0f}")
