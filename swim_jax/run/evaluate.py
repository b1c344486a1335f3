"""``python -m swim_jax.evaluate``: the Gymnasium comparison of swim_jax/analysis/evaluate.py (its
code and documentation), with ``--ours-episodes``' side plugged in: our own evaluation program
(swim_jax/run/our_evaluation.py, which imports JAX only when it runs)."""

from __future__ import annotations

from swim_jax.analysis import evaluate
from swim_jax.run.our_evaluation import our_episodes


def main(argv=None) -> int:
    """``swim_jax.analysis.evaluate.main`` with :func:`~swim_jax.run.our_evaluation.our_episodes`."""
    return evaluate.main(argv, our_episodes=our_episodes)
