"""Read the actor-inference rows (Table III) from ``python -m swim_jax.bench activations`` JSON files.

Each file's ``actor_inference`` list holds rows ``{dtype, env, activation, mean_ms, std_ms,
median_ms, ...}`` (plus ``swim_vs_swish`` summary rows, which are ignored here: the improvement is
recomputed from the means with the paper's definition, see :func:`speedup_pct`).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass


class BenchError(ValueError):
    """A missing or malformed benchmark file; ``str(e)`` is one line."""


@dataclass(frozen=True)
class InferenceTiming:
    """Actor inference time of one activation in one (source, env, dtype) cell, in ms."""

    source: str  # file name
    env: str
    dtype: str
    activation: str
    mean_ms: float
    std_ms: float
    median_ms: float | None


def speedup_pct(swim_ms: float, swish_ms: float) -> float:
    """The paper's Table III improvement: ``100 · (swish − swim) / swim`` (time saved relative to Swim;
    e.g. 0.810 vs 0.687 ms → 17.9%)."""
    return 100.0 * (swish_ms - swim_ms) / swim_ms


def load_bench(path: str) -> tuple[list[InferenceTiming], dict]:
    """Rows of ``actor_inference`` and the file's ``machine`` dict (plus ``clock``/``repeats``).

    Raises :class:`BenchError` with one line if the file is missing, not JSON, has no
    ``actor_inference`` section or a row lacks ``mean_ms``/``std_ms``.
    """
    try:
        with open(path) as f:
            data = json.load(f)
    except FileNotFoundError:
        raise BenchError(f"{path}: no such benchmark file") from None
    except (OSError, ValueError) as e:
        raise BenchError(f"{path}: unreadable JSON ({' '.join(str(e).split())[:200]})") from None
    if not isinstance(data, dict) or not isinstance(data.get("actor_inference"), list):
        raise BenchError(f"{path}: no actor_inference section (run `python -m swim_jax.bench "
                         f"activations --sections b` to produce one)")
    src = os.path.basename(path)
    rows = []
    for i, r in enumerate(data["actor_inference"]):
        if not isinstance(r, dict) or r.get("activation") == "swim_vs_swish":
            continue
        try:
            row = InferenceTiming(src, str(r["env"]), str(r["dtype"]), str(r["activation"]),
                                  float(r["mean_ms"]), float(r["std_ms"]),
                                  None if r.get("median_ms") is None else float(r["median_ms"]))
        except (KeyError, TypeError, ValueError):
            raise BenchError(f"{path}: actor_inference row {i} lacks env/dtype/activation/mean_ms/std_ms") from None
        if not (math.isfinite(row.mean_ms) and math.isfinite(row.std_ms)):
            raise BenchError(f"{path}: actor_inference row {i} has non-finite timings")
        rows.append(row)
    if not rows:
        raise BenchError(f"{path}: actor_inference section is empty")
    meta = dict(data.get("machine") or {})
    meta.update({k: data[k] for k in ("clock", "repeats", "quick") if k in data})
    return rows, meta
