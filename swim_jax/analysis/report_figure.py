"""The report's figures: Figure 4 of the paper from our runs (learning curves, mean ± half a std
over seeds, one panel per env), the learning metrics between evaluations (metrics.csv) and the
return-vs-parameter figure of sweeps.

Headless (matplotlib Agg). The SVG is written with a fixed hash salt and no date so that the same
inputs give the same bytes.
"""

from __future__ import annotations

import colorsys
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import to_hex, to_rgb  # noqa: E402
from matplotlib.ticker import FuncFormatter, NullFormatter  # noqa: E402

from swim_jax.activations import ACTIVATIONS, display_name  # noqa: E402
from swim_jax.agents.registry import learning_panels  # noqa: E402
from swim_jax.io.cli_parser import counted  # noqa: E402

# the reserved colours of the registry (Swim tab:red, Swish tab:blue, ReLU tab:green)
COLORS = {name: spec.color for name, spec in ACTIVATIONS.items() if spec.color}
# other labels (parameter variants, sweep points): tab10 without the three above, then the light
# tab20 shades except light red/blue/green; beyond those 14, generated hues (extra_colors)
_EXTRA_PALETTE = ("#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
                  "#ffbb78", "#c5b0d5", "#c49c94", "#f7b6d2", "#c7c7c7", "#dbdb8d", "#9edae5")


def extra_colors(n: int) -> list[str]:
    """``n`` distinct hex colours, none of them a reserved Swim/Swish/ReLU colour: the fixed palette
    first, then hues spaced by the golden angle (not within 0.04 of a reserved hue), saturation and
    value also spread (low discrepancy)."""
    used = set(COLORS.values())
    reserved_hues = [colorsys.rgb_to_hsv(*to_rgb(c))[0] for c in COLORS.values()]
    out = []
    for c in _EXTRA_PALETTE:
        if len(out) == n:
            return out
        if c not in used:
            out.append(c)
            used.add(c)
    i = 0
    while len(out) < n:
        h = (0.13 + i * 0.6180339887498949) % 1.0
        s = 0.45 + 0.5 * ((i * 0.41421356237309515) % 1.0)  # low-discrepancy in s and v too, so the
        v = 0.45 + 0.5 * ((i * 0.7320508075688772) % 1.0)  # candidates never run out
        i += 1
        if min(min(abs(h - r), 1 - abs(h - r)) for r in reserved_hues) < 0.04:
            continue  # keep generated colours away from Swim's red, Swish's blue and ReLU's green
        c = to_hex(colorsys.hsv_to_rgb(h, s, v))
        if c not in used:
            out.append(c)
            used.add(c)
    return out


def curve_colors(labels) -> dict[str, str]:
    """``{label: hex colour}``: Swim red, Swish blue, ReLU green (the plain labels only); every other
    label its own colour, distinct from those and from each other, for any number of labels."""
    labels = list(dict.fromkeys(labels))
    others = [lab for lab in labels if lab not in COLORS]
    out = {lab: COLORS[lab] for lab in labels if lab in COLORS}
    out.update(zip(others, extra_colors(len(others))))
    return {lab: out[lab] for lab in labels}


def _steps_label(x, _pos=None) -> str:
    if abs(x) >= 1e6:
        return f"{x / 1e6:g}M"
    if abs(x) >= 1e3:
        return f"{x / 1e3:g}k"
    return f"{x:g}"


def group_colors(groups: dict) -> dict[str, str]:
    """:func:`curve_colors` of every label of ``groups`` ({env: EnvGroup}) in panel order: the
    colours of Figure 4, which the other figures reuse so that a label keeps its colour."""
    return curve_colors(label for env in groups for label in groups[env].curves)


def _save(fig, paths: list[str]) -> None:
    """Save ``fig`` to each path (SVG without a date, PNG at 120 dpi) and close it."""
    for p in paths:
        kw = {"metadata": {"Date": None}} if str(p).endswith(".svg") else {"dpi": 120}
        fig.savefig(p, **kw)
    plt.close(fig)


def figure4(groups: dict, paths: list[str]) -> None:
    """Draw one panel per env of ``groups`` ({env: EnvGroup}) and save it to each of ``paths``.

    Each activation's curve is the mean over seeds of the evaluation return against env steps, with
    the band mean ± 0.5 · (population) std over seeds shaded, as in the paper. Colours: see
    :func:`curve_colors` (a label keeps its colour in every panel).
    """
    envs = list(groups)
    n = max(1, len(envs))
    ncols = min(n, 3)
    nrows = math.ceil(n / ncols)
    with plt.rc_context({"svg.hashsalt": "swim-jax-report"}):
        fig, axes = plt.subplots(nrows, ncols, figsize=(5.0 * ncols, 3.8 * nrows), squeeze=False)
        colors = group_colors(groups)  # same across panels
        for ax, env in zip(axes.flat, envs):
            g = groups[env]
            for label, c in g.curves.items():
                color = colors[label]
                mean = c.returns.mean(axis=1)
                half = 0.5 * c.returns.std(axis=1, ddof=0)
                ax.plot(c.steps, mean, color=color, lw=1.6, label=f"{display_name(label)} ({counted(c.n_seeds, 'seed')})")
                ax.fill_between(c.steps, mean - half, mean + half, color=color, alpha=0.2, lw=0)
            title = env
            if g.truncated_to_step is not None:
                title += f" (truncated at {g.truncated_to_step} steps)"
            ax.set_title(title)
            ax.set_xlabel("environment steps")
            ax.xaxis.set_major_formatter(FuncFormatter(_steps_label))
            ax.set_ylabel("average return")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8, loc="best")
        for ax in list(axes.flat)[len(envs):]:
            ax.set_visible(False)
        fig.suptitle("Learning curves: mean over seeds, shaded ± ½ std", fontsize=11)
        fig.tight_layout()
        _save(fig, paths)


# (metric, panel title): the titled metrics every agent's update reports (swim_jax/agents/registry.py)
LEARNING_PANELS = learning_panels()


def learning_figure(table: dict, colors: dict[str, str], paths: list[str]) -> None:
    """Draw the learning metrics and save the figure to each of ``paths``: one row per env of
    ``table`` (:func:`swim_jax.analysis.report_numbers.learning_table`), one panel per metric of
    :data:`LEARNING_PANELS` against env steps; per label the mean over seeds as a line (colour from
    ``colors``, a dot per chunk), the min–max over seeds shaded. A panel's y axis is logarithmic
    when every value in it is > 0 (the critic loss spans decades)."""
    envs = list(table)
    ncols = len(LEARNING_PANELS)
    with plt.rc_context({"svg.hashsalt": "swim-jax-report"}):
        fig, axes = plt.subplots(len(envs), ncols, figsize=(5.0 * ncols, 3.6 * len(envs)), squeeze=False)
        for row, env in zip(axes, envs):
            for ax, (metric, title) in zip(row, LEARNING_PANELS):
                for label, t in table[env].items():
                    s = t[metric]
                    ax.plot(t["steps"], s["mean"], color=colors[label], lw=1.6, marker="o", ms=2.5,
                            label=f"{display_name(label)} ({counted(t['seeds'], 'seed')})")  # a marker: one chunk shows
                    ax.fill_between(t["steps"], s["min"], s["max"], color=colors[label], alpha=0.2, lw=0)
                values = np.array([v for t in table[env].values() for k in ("min", "max") for v in t[metric][k]])
                values = values[np.isfinite(values)]
                if values.size and values.min() > 0:
                    ax.set_yscale("log")
                ax.set_title(f"{env}: {title}")
                ax.set_xlabel("environment steps")
                ax.xaxis.set_major_formatter(FuncFormatter(_steps_label))
                ax.grid(alpha=0.3)
            row[0].legend(fontsize=8, loc="best")
        fig.suptitle("Learning metrics per chunk (metrics.csv): mean over seeds, shaded min–max", fontsize=11)
        fig.tight_layout()
        _save(fig, paths)


def parameter_series(groups: dict) -> dict:
    """``{(env, activation, param): [(value, final returns[seeds], best-curve mean), ...]}`` for every
    activation parameter that takes ≥ 2 values in one env (a k or beta sweep) among the curves of
    that activation whose other parameters are at their defaults. With ``+learnable`` the value is
    the initial one (series key ``"swim+learnable"``). Curves of sweep points with other swept
    values (``swim(k=1)[tau=0.01]``) are left out. Read from each curve's activation setting."""
    out = {}
    for env, g in groups.items():
        by_act: dict = {}
        for c in g.curves.values():
            s = c.setting
            if s is None or c.sweep_suffix or s.name not in ACTIVATIONS:
                continue
            values, defaults = dict(s.params), ACTIVATIONS[s.name].defaults
            for key in values:
                if all(values[o] == defaults[o] for o in values if o != key):
                    by_act.setdefault((env, s.name + ("+learnable" if s.learnable else ""), key), []).append(
                        (values[key], c.returns[-1], float(c.returns.mean(axis=1).max())))
        out.update({k: sorted(v, key=lambda t: t[0]) for k, v in by_act.items() if len(v) >= 2})
    return out


def sweep_figure(series: dict, paths: list[str]) -> None:
    """Return vs activation parameter (log x): final evaluation return (mean ± std over seeds) and
    the best evaluation of the mean curve, one panel per (env, activation)."""
    n = len(series)
    ncols = min(n, 3)
    nrows = math.ceil(n / ncols)
    with plt.rc_context({"svg.hashsalt": "swim-jax-report"}):
        fig, axes = plt.subplots(nrows, ncols, figsize=(5.0 * ncols, 3.6 * nrows), squeeze=False)
        for ax, ((env, act, key), pts) in zip(axes.flat, series.items()):
            x = np.array([p[0] for p in pts])
            final = np.array([p[1].mean() for p in pts])
            std = np.array([p[1].std(ddof=0) for p in pts])
            best = np.array([p[2] for p in pts])
            base = act.split("+")[0]
            color = COLORS.get(base, "0.3")
            ax.errorbar(x, final, yerr=std, color=color, marker="o", capsize=3, label="final (mean ± std over seeds)")
            ax.plot(x, best, color=color, ls="--", marker="x", label="best of mean curve")
            ax.set_xscale("log")
            ax.set_xticks(x, [f"{v:g}" for v in x])
            ax.xaxis.set_minor_formatter(NullFormatter())
            learn = act.endswith("+learnable")
            ax.set_xlabel(f"initial {key} (learned per layer)" if learn else key)
            ax.set_ylabel("average return")
            ax.set_title(f"{env}: {display_name(act)} vs {key}")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8, loc="best")
        for ax in list(axes.flat)[n:]:
            ax.set_visible(False)
        fig.tight_layout()
        _save(fig, paths)
