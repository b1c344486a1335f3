"""Log the trajectory of learnable activation parameters (``agent.activation.learnable=true``).

With a learnable activation every hidden layer of the actor and of each critic owns a scalar per
activation parameter (``k`` for Swim, ``beta`` for Swish, ``alpha`` for ELU: the parameters in
``swim_jax.activations.ACTIVATIONS``; see ``swim_jax.activations.Activation``). This module reads
them out of a batched training state and appends them to ``activation_params.csv``:

    step,seed,param,value          param = actor/act_0/k, critic_1/act_1/k, critic_2/act_0/k, ...

one row per evaluation, seed and parameter. The file is append-only during a run; on resume,
rows after the resumed step are dropped (:func:`truncate_after`) so the log matches the evaluations.
"""

from __future__ import annotations

import csv
import os

import jax
import numpy as np

from swim_jax.activations import parameter_defaults

FILENAME = "activation_params.csv"
LEARNABLE_NAMES = tuple(parameter_defaults())  # leaf names of learnable activation parameters


def _path_str(path) -> list[str]:
    return [str(getattr(p, "key", getattr(p, "idx", p))) for p in path]


def activation_params(actor, critic) -> dict[str, np.ndarray]:
    """``{"actor/act_0/k": [L], "critic_1/act_0/k": [L], ...}`` from lane-batched parameters.

    Leaves named after an activation parameter (:data:`LEARNABLE_NAMES`: ``k``, ``beta``, ...) are
    the learnable activation parameters; the twin critics' leaves carry a critic axis after the
    lane axis, split into ``critic_1`` and ``critic_2``.
    Empty when the activation has no learnable parameter."""
    out: dict[str, np.ndarray] = {}
    for net, tree in (("actor", actor), ("critic", critic)):
        for path, leaf in jax.tree_util.tree_flatten_with_path(tree)[0]:
            keys = _path_str(path)
            if keys[-1] not in LEARNABLE_NAMES:
                continue
            layer = keys[-2]
            value = np.asarray(leaf)
            if net == "actor":
                out[f"actor/{layer}/{keys[-1]}"] = value.reshape(value.shape[0])
            else:
                for j in range(value.shape[1]):
                    out[f"critic_{j + 1}/{layer}/{keys[-1]}"] = value[:, j]
    return out


def append(path: str, step: int, seed_ids, params: dict[str, np.ndarray]) -> None:
    """Append one evaluation's rows (``params[name][i]`` belongs to seed ``seed_ids[i]``)."""
    if not params:
        return
    new = not os.path.exists(path)
    with open(path, "a", newline="") as f:
        w = csv.writer(f)
        if new:
            w.writerow(["step", "seed", "param", "value"])
        for i, seed in enumerate(seed_ids):
            for name in sorted(params):
                w.writerow([step, int(seed), name, repr(float(params[name][i]))])


def truncate_after(path: str, step: int) -> None:
    """Drop the rows logged after ``step`` (a resumed run repeats those evaluations)."""
    if not os.path.exists(path):
        return
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    keep = [rows[0]] + [r for r in rows[1:] if int(r[0]) <= step]
    with open(path, "w", newline="") as f:
        csv.writer(f).writerows(keep)


def read(path: str) -> dict[str, np.ndarray]:
    """``{param: array[n_evals, seeds]}`` plus ``"step"`` [n_evals] and ``"seed"`` [seeds]."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    steps = sorted({int(r["step"]) for r in rows})
    seeds = sorted({int(r["seed"]) for r in rows})
    names = sorted({r["param"] for r in rows})
    out = {n: np.full((len(steps), len(seeds)), np.nan) for n in names}
    si, ki = {s: i for i, s in enumerate(steps)}, {s: i for i, s in enumerate(seeds)}
    for r in rows:
        out[r["param"]][si[int(r["step"])], ki[int(r["seed"])]] = float(r["value"])
    out["step"], out["seed"] = np.asarray(steps), np.asarray(seeds)
    return out
