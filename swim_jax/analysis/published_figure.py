"""The figure of ``python -m swim_jax.published --figure FILE``: our runs' learning curves over the
published curve of the same task, one panel per (published env, algorithm).

Each curve is the mean over seeds of the evaluation return against env steps, shaded mean ± std
over seeds (population std, as the published curves record theirs); the published curve is black
with a grey band, drawn up to the last step of the panel's runs (or ``up_to``)."""

from __future__ import annotations

import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FuncFormatter  # noqa: E402

from swim_jax.analysis import runs_io  # noqa: E402
from swim_jax.analysis.published_curves import SOURCE, WARMUP_STEPS, curve_points, published_env  # noqa: E402
from swim_jax.analysis.report_figure import _save, _steps_label, extra_colors  # noqa: E402


GREYS = ("#7f7f7f", "#c7c7c7")


def run_label(run: runs_io.Run) -> str:
    """A curve's legend: the folder (with its parent, so two studies' ``walker_relu`` differ; pooled
    folders joined by +), env, activation, products and seeds."""
    folder = " + ".join(os.path.join(os.path.basename(os.path.dirname(os.path.abspath(p))), os.path.basename(p))
                        for p in run.path.split(" + "))
    return f"{folder}: {run.env} {run.activation}, {runs_io.numerics(run)}, {run.returns.shape[1]} seeds"


def figure(runs: list[runs_io.Run], paths: list[str], up_to: int | None = None) -> None:
    """Draw ``runs`` over their published curves (:func:`curve_points`; panels in the runs' order of
    tasks) and save the figure to each of ``paths``; ``up_to``: the last step drawn (default: each
    panel's runs' last evaluation)."""
    panels: dict[tuple[str, str], list[runs_io.Run]] = {}
    for run in runs:
        panels.setdefault((published_env(run.env), run.algorithm), []).append(run)
    most = max(len(g) for g in panels.values())
    colors = [c for c in extra_colors(most + len(GREYS)) if c not in GREYS][:most]  # grey is the published band's
    n = len(panels)
    ncols = min(n, 2)
    nrows = math.ceil(n / ncols)
    with plt.rc_context({"svg.hashsalt": "swim-jax-report"}):
        fig, axes = plt.subplots(nrows, ncols, figsize=(6.5 * ncols, 4.2 * nrows), squeeze=False)
        for ax, ((env, algorithm), group) in zip(axes.flat, panels.items()):
            last = up_to if up_to is not None else max(int(r.steps[-1]) for r in group)
            ref = np.asarray(curve_points(group[0].env, algorithm), np.float64)
            ref = ref[ref[:, 0] <= last]
            ax.plot(ref[:, 0], ref[:, 1], color="black", lw=1.8, label=f"published {algorithm.upper()} ({env}; its "
                    f"{WARMUP_STEPS[algorithm.upper()] // 1000}k random steps counted)")
            ax.fill_between(ref[:, 0], ref[:, 1] - ref[:, 2], ref[:, 1] + ref[:, 2], color="0.5", alpha=0.25, lw=0)
            for i, run in enumerate(group):
                keep = run.steps <= last
                steps, returns = run.steps[keep], run.returns[keep]
                mean, sd = returns.mean(axis=1), returns.std(axis=1, ddof=0)
                ax.plot(steps, mean, color=colors[i], lw=1.4, label=run_label(run))
                ax.fill_between(steps, mean - sd, mean + sd, color=colors[i], alpha=0.15, lw=0)
            ax.set_title(f"{env.split('-')[0]}, {algorithm.upper()}")
            ax.set_xlabel("environment steps")
            ax.xaxis.set_major_formatter(FuncFormatter(_steps_label))
            ax.set_ylabel("average return")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="upper left")
        for ax in list(axes.flat)[n:]:
            ax.set_visible(False)
        fig.suptitle(f"Ours over the published curves: {SOURCE}\nmean over seeds, shaded ± std", fontsize=9)
        fig.tight_layout()
        _save(fig, paths)
