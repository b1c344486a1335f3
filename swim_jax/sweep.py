"""Train a hyperparameter grid × seeds as ONE vmapped program: ``python -m swim_jax.sweep``.

    python -m swim_jax.sweep config=hopper_swim sweep.agent.activation.k=[0.25,0.5,1,2] seeds=5
    python -m swim_jax.sweep config=cheetah_swish sweep.agent.activation.beta=[0.5,1,2] seeds=3
    python -m swim_jax.sweep config=walker_swim sweep.agent.tau=[0.002,0.005,0.01] sweep.agent.actor_lr=[1e-4,3e-4]
    python -m swim_jax.sweep --resume runs/hopper_swim-20261122-100000

Every ``sweep.<key>=[v1,v2,...]`` is an axis; the grid is their cartesian product. Sweepable keys
are the float hyperparameters of the agent (learning rates, discount, tau, the noise scales and the
activation's own parameter: ``agent.activation.k`` for swim, ``agent.activation.beta`` for swish,
``agent.activation.alpha`` for elu); they enter the compiled program as per-lane inputs
(``TD3.with_hparams``), so points × seeds lanes train together and each point sees the same seeds. Everything else is ``swim_jax.run.train``: the same
options, checkpoints, ``--resume`` and exit statuses. Outputs: ``sweep.csv`` (one row per point)
and ``points/<label>/`` per point, each readable by ``swim_jax.analysis.report`` and ``swim_jax.run.render``::

    python -m swim_jax.report runs/hopper_swim-20261122-100000 --out runs/hopper_k_report
"""

from __future__ import annotations

import sys

from swim_jax.run.train import main as train_main


def main(argv: list[str] | None = None) -> int:
    """Like ``swim_jax.run.train``'s command line, but at least one ``sweep.<key>=[...]`` is required."""
    return train_main(argv, require_sweep=True)


if __name__ == "__main__":
    sys.exit(main())
