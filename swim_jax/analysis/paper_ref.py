"""The paper's published numbers (Tables II and III) and the mapping of our env ids onto its envs.

Source: the Swim paper (Abdool & Dear), Tables II and III (TD3, 1M steps, 5 seeds, gym -v2 MuJoCo envs,
float64; Table III on an ARM CPU). Our runs use Gymnasium v4/v5 envs and usually smaller budgets, so
these are side-by-side references, not like-for-like targets.
"""

from __future__ import annotations

PAPER_BUDGET = {"total_steps": 1_000_000, "seeds": 5, "eval_freq": 5000, "precision": "float64"}

# env -> activation -> (mean, std) of the max over time of the average return (5 trials, 1M steps)
TABLE_II = {
    "Walker2d-v2": {"swish": (3774.668, 149.779), "swim": (4387.442, 453.526)},
    "Hopper-v2": {"swish": (3450.055, 129.203), "swim": (3431.081, 110.394)},
    "HalfCheetah-v2": {"swish": (10519.091, 872.693), "swim": (11130.364, 652.716)},
    "Swimmer-v2": {"swish": (132.838, 8.146), "swim": (134.503, 6.806)},
}
TABLE_II_IMPROVEMENT_PCT = {"Walker2d-v2": 16, "Hopper-v2": 0, "HalfCheetah-v2": 5, "Swimmer-v2": 1}

# env -> activation -> (mean, std) ms of actor inference (first 100 iterations, ARM CPU, float64)
TABLE_III = {
    "Walker2d-v2": {"swish": (0.810, 0.066), "swim": (0.687, 0.077)},
    "Hopper-v2": {"swish": (0.720, 0.055), "swim": (0.666, 0.056)},
    "HalfCheetah-v2": {"swish": (0.826, 0.057), "swim": (0.733, 0.064)},
    "Swimmer-v2": {"swish": (0.737, 0.060), "swim": (0.644, 0.045)},
}
TABLE_III_IMPROVEMENT_PCT = {"Walker2d-v2": 17.9, "Hopper-v2": 8.1, "HalfCheetah-v2": 12.7, "Swimmer-v2": 14.4}


def paper_env(env: str) -> str | None:
    """The paper's env id for one of ours (``Walker2d-v5``, ``Walker2d-v4`` or ``Walker2d`` →
    ``Walker2d-v2``), or ``None`` when the paper has no such env (e.g. Ant)."""
    base = env.split("-")[0]
    key = f"{base}-v2"
    return key if key in TABLE_II else None
