"""The figure of the aggregates across envs (swim_jax/analysis/aggregate.py): performance profiles
(the fraction of runs above each normalized score τ, one line per label) beside each label's IQM
with its stratified-bootstrap 95 % CI, as rliable draws them."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from swim_jax.activations import display_name  # noqa: E402
from swim_jax.analysis.aggregate import Aggregates  # noqa: E402
from swim_jax.analysis.report_figure import _save, curve_colors  # noqa: E402


def profile_figure(agg: Aggregates, paths: list[str]) -> None:
    """Draw the performance profiles and the IQMs of ``agg`` and save the figure to each of ``paths``."""
    colors = curve_colors(agg.profiles)
    with plt.rc_context({"svg.hashsalt": "swim-jax-report"}):
        fig, (left, right) = plt.subplots(1, 2, figsize=(10.0, 3.8), gridspec_kw={"width_ratios": [3, 2]})
        for label, profile in agg.profiles.items():
            left.plot(agg.taus, profile, color=colors[label], label=display_name(label))
        left.set_xlabel("normalized score τ (0 random, 1 published TD3 at 1M)")
        left.set_ylabel("fraction of runs with score > τ")
        left.set_title(f"Performance profiles ({agg.score}, {len(agg.envs)} envs)")
        left.grid(alpha=0.3)
        left.legend(fontsize=8)
        labels = list(agg.metrics)
        for i, label in enumerate(labels):
            point, lo, hi = agg.metrics[label]["iqm"]
            right.errorbar([point], [i], xerr=[[point - lo], [hi - point]], fmt="o", color=colors[label], capsize=4)
        right.set_yticks(range(len(labels)), [display_name(a) for a in labels])
        right.set_xlabel("IQM of normalized scores (95 % stratified bootstrap CI)")
        right.grid(alpha=0.3, axis="x")
        fig.tight_layout()
        _save(fig, paths)
