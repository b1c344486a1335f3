"""Interleaved wall-clock timing of compiled JAX callables, robust to a noisy machine.

Every candidate is compiled and warmed first; then each repeat times every candidate once, in a
rotating order, so that slow phases of the machine hit all candidates alike. Results are medians
with min and max; compare candidates as ratios of medians measured in the same call.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import jax


CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


@dataclass(frozen=True)
class Timing:
    """Seconds per call of one candidate: median, min, max, mean and std over repeats."""

    median: float
    min: float
    max: float
    mean: float
    std: float
    samples: tuple[float, ...]

    def as_dict(self, scale: float = 1e3) -> dict:
        """The statistics multiplied by ``scale`` (default: milliseconds), samples left out."""
        return {k: getattr(self, k) * scale for k in ("median", "min", "max", "mean", "std")}


def _summarise(samples: Sequence[float]) -> Timing:
    return Timing(
        median=statistics.median(samples),
        min=min(samples),
        max=max(samples),
        mean=statistics.fmean(samples),
        std=statistics.pstdev(samples) if len(samples) > 1 else 0.0,
        samples=tuple(samples),
    )


def time_interleaved(
    candidates: Mapping[str, Callable[[], object]],
    repeats: int = 15,
    calls_per_sample: int = 1,
    warmup: int = 2,
    clock: str = "wall",
) -> dict[str, Timing]:
    """Time zero-argument callables (each returning JAX arrays) interleaved; seconds per call.

    ``clock="wall"`` (default) measures elapsed time; ``clock="cpu"`` measures this process's CPU
    time (all threads), which is what to compare when other processes compete for the cores.

    Each sample runs the callable ``calls_per_sample`` times back to back (letting JAX's async
    dispatch pipeline them) and blocks on the last result; the sample is the elapsed time divided
    by ``calls_per_sample``. The first ``warmup`` calls of every candidate are not timed.
    """
    if clock not in CLOCKS:
        raise ValueError(f"unknown clock {clock!r}; valid: {', '.join(CLOCKS)}")
    now = CLOCKS[clock]
    names = list(candidates)
    for name in names:
        for _ in range(max(warmup, 1)):
            jax.block_until_ready(candidates[name]())
    samples: dict[str, list[float]] = {name: [] for name in names}
    for rep in range(repeats):
        order = names[rep % len(names):] + names[: rep % len(names)]
        for name in order:
            fn = candidates[name]
            start = now()
            out = None
            for _ in range(calls_per_sample):
                out = fn()
            jax.block_until_ready(out)
            samples[name].append((now() - start) / calls_per_sample)
    return {name: _summarise(s) for name, s in samples.items()}


def calls_for(fn: Callable[[], object], target_seconds: float = 0.02, max_calls: int = 1000) -> int:
    """How many back-to-back calls of ``fn`` take about ``target_seconds`` (at least 1)."""
    jax.block_until_ready(fn())
    start = time.perf_counter()
    jax.block_until_ready(fn())
    once = max(time.perf_counter() - start, 1e-7)
    return int(max(1, min(max_calls, target_seconds / once)))
