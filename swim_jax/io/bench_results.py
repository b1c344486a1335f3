"""Benchmark result files: :func:`write_result` (the JSON every ``swim_jax.bench`` command writes, with
:func:`cpu_model` naming the machine) and the actor-inference rows (Table III) read back from
``python -m swim_jax.bench activations`` JSON files.

Each file's ``actor_inference`` list holds rows ``{dtype, env, activation, mean_ms, std_ms,
median_ms, ...}`` (plus ``swim_vs_swish`` summary rows, which are ignored here: the improvement is
recomputed from the means with the paper's definition, see :func:`speedup_pct`).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from typing import Callable

from swim_jax.io import hardware


def cpu_model() -> str:
    """The CPU's model name as lscpu reports it (falling back to /proc/cpuinfo), with its family
    and model numbers when /proc/cpuinfo has them (e.g. ``AMD EPYC (family 25, model 17)``: the
    name alone does not tell Zen generations apart)."""
    name, info = "unknown", hardware.cpuinfo()
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        name = next((line.split(":", 1)[1].strip() for line in out.splitlines() if line.startswith("Model name:")),
                    info.get("model name", name))
    except OSError:
        name = info.get("model name", name)
    if "cpu family" in info and "model" in info:
        name += f" (family {info['cpu family']}, model {info['model']})"
    return name


def write_result(out_dir: str, prefix: str, result: dict, stamp: time.struct_time | None = None) -> str:
    """``result`` as ``<out_dir>/<prefix>-<UTC stamp>.json`` (``stamp``: default now); prints and
    returns the path."""
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, f"{prefix}-{time.strftime('%Y%m%d-%H%M%S', stamp or time.gmtime())}.json")
    with open(path, "w") as f:
        json.dump(result, f, indent=1)
    print(f"wrote {path}")
    return path


def measure_and_write(measure: Callable[[], dict], markdown: Callable[[dict], str], out_dir: str, prefix: str) -> int:
    """The end of a benchmark command line: ``result = measure()``, then its markdown on stdout and its
    JSON (:func:`write_result`); returns 0. ``measure`` raising ValueError (a bad option) or
    RuntimeError (a timed run failed) prints ``error: <message>`` on stderr, writes nothing and
    returns 2 or 1."""
    try:
        res = measure()
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except RuntimeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(markdown(res))
    write_result(out_dir, prefix, res)
    return 0


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
