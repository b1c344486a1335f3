"""Per-seed results as tidy rows, the form other tools read (pandas, rliable, R): one row per run,
seed and evaluation step. A report writes them as ``results.csv``; ``swim_jax.results`` returns them.

Columns (:data:`COLUMNS`): ``env`` (``Walker2d``), ``env_version`` (``v5``), ``algorithm`` (the
config's ``agent.kind``, ``td3`` before it existed), ``activation`` (the registry name),
``activation_params`` (every parameter's value, ``k=0.5``; ``+learnable`` when learned),
``label`` (the report's label of the run's curve), ``precision`` (``float32``, or ``float32,
bfloat16 products``), ``seed`` (the seed index), ``step``, ``return`` (the mean return of that
evaluation's episodes).
"""

from __future__ import annotations

import csv
import io

from swim_jax.analysis.runs_io import Run, numerics

COLUMNS = ("env", "env_version", "algorithm", "activation", "activation_params", "label", "precision",
           "seed", "step", "return")


def tidy_rows(runs: list[Run]) -> list[dict]:
    """Every evaluation of every seed of ``runs`` as a row with :data:`COLUMNS` (runs in order,
    then seeds, then steps)."""
    rows = []
    for r in runs:
        name, _, version = r.env.rpartition("-")
        setting = r.setting
        params = ",".join(f"{k}={v:g}" for k, v in setting.params) + ("+learnable" if setting.learnable else "")
        fixed = {"env": name or r.env, "env_version": version if name else "", "algorithm":
                 r.algorithm, "activation": setting.name,
                 "activation_params": params, "label": r.activation, "precision": numerics(r)}
        for j, (_, seed) in enumerate(r.seed_ids):
            for i in range(r.returns.shape[0]):
                rows.append({**fixed, "seed": int(seed), "step": int(r.steps[i]), "return": float(r.returns[i, j])})
    return rows


def to_csv(rows: list[dict]) -> str:
    """``rows`` as CSV text with a header of :data:`COLUMNS` (returns written with repr's precision)."""
    out = io.StringIO()
    w = csv.DictWriter(out, fieldnames=COLUMNS, lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({**row, "return": repr(row["return"])})
    return out.getvalue()
