"""The report's Gymnasium check: the final policies of a run, played in Gymnasium's own env by
``python -m swim_jax.evaluate RUN --json RUN/gymnasium-evaluation.json`` (swim_jax/analysis/evaluate.py),
read back and set next to the run's own evaluation at the same step.

Per (env, activation) of a report: over the seeds whose file has a row at the curve's last step, in
the env the run trained in, with our side as the run recorded it (not ``--ours-episodes``; it must equal
the run's evaluation there), the mean ± sample std over seeds of our evaluation and of Gymnasium's, and
the mean over seeds of Gymnasium − ours.
Curves without such a row are left out; a report without any has no such section.
"""

from __future__ import annotations

import json
import os

import numpy as np

from swim_jax.analysis.runs_io import EnvGroup, RunError

FILE = "gymnasium-evaluation.json"


def read(run_path: str, step: int) -> dict[int, tuple[float, float, int]]:
    """``{seed: (ours, Gymnasium mean, Gymnasium episodes)}`` from ``run_path``'s :data:`FILE`: its rows
    at ``step``, played in the env the run trained in, with our recorded evaluation (files written before
    ``--in-env`` and ``--ours-episodes`` existed have only such rows); ``{}`` without the file.
    :class:`RunError` (one line) when the file is not ``swim_jax.evaluate``'s JSON."""
    path = os.path.join(run_path, FILE)
    if not os.path.exists(path):
        return {}
    try:
        with open(path) as f:
            rows = json.load(f)["rows"]
        return {int(r["seed"]): (float(r["ours"]["mean"]), float(r["gymnasium"]["mean"]), int(r["gymnasium"]["n"]))
                for r in rows if int(r["step"]) == step and r.get("trained_env_id", r["env_id"]) == r["env_id"]
                and r["ours"].get("source", "recorded") == "recorded"}
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise RunError(f"{path}: not a `python -m swim_jax.evaluate --json` file ({type(e).__name__}: {e})") from None


def table(groups: dict[str, EnvGroup]) -> dict:
    """``{env: {label: row}}`` for every curve with a check at its last step; a row has ``step``,
    ``seeds`` (the curve's), ``checked`` (seed ids), ``ours`` (the run's evaluation there, per checked
    seed), ``gymnasium`` (Gymnasium's mean, per checked seed) and ``episodes`` (Gymnasium's per seed:
    the sorted distinct counts). :class:`RunError` when a file's record of our return differs from the
    run's own evaluation (the file belongs to another run, or to the run before it was resumed)."""
    out: dict = {}
    for env, g in groups.items():
        for label, c in g.curves.items():
            step = int(c.steps[-1])
            found = {}
            for run in c.run_objects:
                column = {seed: i for i, (_, seed) in enumerate(run.seed_ids)}
                for seed, (recorded, gym, episodes) in read(run.path, step).items():
                    if seed not in column:
                        raise RunError(f"{os.path.join(run.path, FILE)} has seed {seed}; the run's seeds are "
                                       f"{', '.join(map(str, column))}")
                    ours = float(run.returns[-1, column[seed]])
                    if not np.isclose(recorded, ours, rtol=1e-5, atol=1e-3):
                        raise RunError(f"{os.path.join(run.path, FILE)} records seed {seed}'s return at step "
                                       f"{step:,} as {recorded:.2f}, the run's evaluation is {ours:.2f}: the file "
                                       f"is another run's (evaluate the run again to replace it)")
                    found[seed] = (ours, gym, episodes)
            if found:
                seeds = sorted(found)
                out.setdefault(env, {})[label] = {
                    "step": step, "seeds": c.n_seeds, "checked": seeds,
                    "ours": [found[s][0] for s in seeds], "gymnasium": [found[s][1] for s in seeds],
                    "episodes": sorted({found[s][2] for s in seeds})}
    return out


def summary(row: dict) -> dict:
    """Mean ± sample std over the checked seeds of ours and Gymnasium's, and the mean of Gymnasium − ours
    (the std is NaN with one seed)."""
    ours, gym = np.asarray(row["ours"]), np.asarray(row["gymnasium"])
    sd = (lambda x: float(x.std(ddof=1)) if x.size > 1 else float("nan"))
    return {"ours_mean": float(ours.mean()), "ours_sd": sd(ours), "gymnasium_mean": float(gym.mean()),
            "gymnasium_sd": sd(gym), "gymnasium_minus_ours": float((gym - ours).mean())}
