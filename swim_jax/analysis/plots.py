"""``python -m swim_jax.plots activations --out DIR``: the paper's Figures 1 and 2.

Figure 1: the paper's activations (``paper=True`` in ``swim_jax.activations.ACTIVATIONS``: Swim
(k = 0.5), Swish (β = 1) and ReLU) at their default parameters over [−6, 6], and zoomed on the
negative region. Figure 2: their first derivatives (computed by jax.grad through each function's
own derivative rule, i.e. Swim's custom rsqrt JVP), likewise. Written as PNG files; headless
(matplotlib Agg).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from swim_jax.io import cli_parser  # noqa: E402
from swim_jax.activations import ACTIVATIONS, get_activation, legend_name  # noqa: E402

PAPER = tuple(name for name, spec in ACTIVATIONS.items() if spec.paper)  # swim, swish, relu
FULL_RANGE, NEGATIVE_RANGE = (-6.0, 6.0), (-10.0, 0.5)


def curves(x: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """legend label (``Swim (k=0.5)``) -> (f(x), f'(x)) for each of :data:`PAPER` at its default
    parameters, evaluated in float32 with JAX."""
    xs = jnp.asarray(x, jnp.float32)
    out = {}
    for name in PAPER:
        fn = get_activation(name)
        out[legend_name(name)] = (np.asarray(fn(xs)), np.asarray(jax.vmap(jax.grad(fn))(xs)))
    return out


def _figure(which: int, path: Path, title: str) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, (lo, hi), sub in zip(axes, (FULL_RANGE, NEGATIVE_RANGE), ("(a)", "(b) negative inputs")):
        x = np.linspace(lo, hi, 2001)
        for label, values in curves(x).items():
            ax.plot(x, values[which], label=label)
        ax.axhline(0, color="0.7", lw=0.8)
        ax.axvline(0, color="0.7", lw=0.8)
        ax.set_xlabel("x")
        ax.set_title(f"{sub}")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("f(x)" if which == 0 else "f'(x)")
    axes[0].legend()
    if which == 0:
        axes[1].set_ylim(-0.35, 0.1)
    else:
        axes[1].set_ylim(-0.15, 0.6)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_activations(out_dir: Path) -> list[Path]:
    """Write fig1_activations.png and fig2_derivatives.png to ``out_dir``; return their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [out_dir / "fig1_activations.png", out_dir / "fig2_derivatives.png"]
    names = [ACTIVATIONS[name].display or name for name in PAPER]
    listed = f"{', '.join(names[:-1])} and {names[-1]}"
    _figure(0, paths[0], f"Figure 1: {listed}")
    _figure(1, paths[1], f"Figure 2: first derivatives of {listed}")
    return paths


def main(argv: list[str] | None = None) -> int:
    """CLI entry: ``activations --out DIR``. Bad input: one line on stderr, exit status 2."""
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.plots", description=__doc__.split("\n")[0])
    p.add_argument("figure", choices=["activations"], help="which figures to draw")
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    args = p.parse_args(argv)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        print(f"swim_jax.plots: --out {out} exists and is not a folder", file=sys.stderr)
        return 2
    for path in plot_activations(out):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
