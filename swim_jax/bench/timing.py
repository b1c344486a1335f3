"""The one timing harness of every benchmark: interleaved rounds of candidates, a timer, summaries.

How this project compares candidates (docs/PERFORMANCE.md, "How to measure"): build and warm every
candidate first, then run rounds, each running every candidate once, so that slow phases of the
machine hit all of them alike; report each one's median (min–max) over the rounds, or the median of
its per-round ratios to a reference measured in the same rounds.

- A **candidate** is a callable ``fn(r)`` of the round index ``r`` returning its measurement of
  that round: seconds (the work wrapped in :func:`timed`), the rate a whole process reported, or
  any value the caller reads afterwards. It may keep state between rounds (a training chunk
  advancing its own state; a checkpoint written at the round's step).
- :func:`interleave` runs the rounds and returns every candidate's measurements, round by round.
- :func:`timed` makes a candidate of some work: seconds per call on a given clock, waiting for
  JAX's asynchronous results.
- :func:`summarise` gives a :class:`Timing` (median, min, max, mean, std) of one candidate's
  measurements; :func:`ratios` the summary of each one's per-round ratio to a reference.
- :func:`time_interleaved` times zero-argument JAX callables: :func:`interleave` of :func:`timed`.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from collections.abc import Callable, Hashable, Mapping, Sequence
from typing import TypeVar

K = TypeVar("K", bound=Hashable)
T = TypeVar("T")

CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def block_until_ready(x):
    """``jax.block_until_ready(x)``, importing JAX only when a timed candidate first waits (the
    benchmarks of whole processes need no JAX)."""
    import jax

    return jax.block_until_ready(x)


@dataclass(frozen=True)
class Timing:
    """Median, min, max, mean and (population) std of one candidate's samples over the rounds: of
    seconds per call for a timed candidate, or of whatever it measured (a rate, a ratio)."""

    median: float
    min: float
    max: float
    mean: float
    std: float
    samples: tuple[float, ...]

    def as_dict(self, scale: float = 1e3) -> dict:
        """The statistics multiplied by ``scale`` (default: milliseconds), samples left out."""
        return {k: getattr(self, k) * scale for k in ("median", "min", "max", "mean", "std")}


def summarise(samples: Sequence[float]) -> Timing:
    """The :class:`Timing` of ``samples`` (at least one; std 0 for a single sample)."""
    return Timing(
        median=statistics.median(samples),
        min=min(samples),
        max=max(samples),
        mean=statistics.fmean(samples),
        std=statistics.pstdev(samples) if len(samples) > 1 else 0.0,
        samples=tuple(samples),
    )


def ratios(samples: Mapping[K, Sequence[float]], reference: K) -> dict[K, Timing]:
    """Every candidate's ratio to ``reference`` round by round (its sample of round r / the
    reference's of round r), summarised per candidate; the reference's own ratios are exactly 1.
    A reference that is no candidate (the best of several in each round) is added as one more
    key. Raises ValueError when a candidate has not as many samples as the reference."""
    base = samples[reference]
    out = {}
    for name, values in samples.items():
        if len(values) != len(base):
            raise ValueError(f"{name!r} has {len(values)} samples, the reference {reference!r} {len(base)}")
        out[name] = summarise([a / b for a, b in zip(values, base)])
    return out


def order(names: Sequence[K], r: int, rotate: bool = True) -> list[K]:
    """The order in which round ``r`` runs ``names``: rotated left by ``r`` (modulo their number)
    with ``rotate``, else as given."""
    names = list(names)
    k = r % len(names) if rotate and names else 0
    return names[k:] + names[:k]


def interleave(candidates: Mapping[K, Callable[[int], T]], rounds: int, warmup: int = 0, rotate: bool = True,
               after_round: Callable[[int, dict[K, T]], None] | None = None) -> dict[K, list[T]]:
    """Run every candidate once per round for ``rounds`` rounds; their measurements, round by round.

    First each candidate, in the mapping's order, is called ``warmup`` times back to back with the
    round indices −warmup … −1; those measurements are dropped. Then round r = 0 … rounds−1 calls
    ``fn(r)`` of every candidate in :func:`order` (rotated by one more place each round with
    ``rotate``, the default; always the mapping's order without) and, if given,
    ``after_round(r, measured)`` with that round's measurements in the order they ran (e.g. to log
    it). Returns name → [measurement of round 0, 1, …], names in the mapping's order.
    """
    names = list(candidates)
    for name in names:
        for w in range(warmup):
            candidates[name](w - warmup)
    samples: dict[K, list[T]] = {name: [] for name in names}
    for r in range(rounds):
        measured = {}
        for name in order(names, r, rotate):
            measured[name] = candidates[name](r)
            samples[name].append(measured[name])
        if after_round is not None:
            after_round(r, measured)
    return samples


def timed(fn: Callable[[int], object], calls_per_sample: int = 1,
          wait: Callable[[object], object] | None = block_until_ready,
          clock: Callable[[], float] = time.perf_counter) -> Callable[[int], float]:
    """A candidate that times ``fn``: called with the round index r, it reads ``clock``, calls
    ``fn(r)`` ``calls_per_sample`` times back to back (letting JAX's asynchronous dispatch pipeline
    them), calls ``wait`` on the last result (default: ``jax.block_until_ready``; None when ``fn``
    returns only once its work is done), reads ``clock`` again and returns the difference divided by
    ``calls_per_sample``: seconds per call. Only that is timed; whatever a round needs set up
    untimed goes in a candidate around it (``lambda r: (set_up(r), sample(r))[1]``).
    ``clock``: ``time.perf_counter`` (wall, the default), ``time.process_time`` (this process's CPU
    time, all threads: :data:`CLOCKS`), or any callable returning seconds."""

    def sample(r: int) -> float:
        start = clock()
        out = None
        for _ in range(calls_per_sample):
            out = fn(r)
        if wait is not None:
            wait(out)
        return (clock() - start) / calls_per_sample

    return sample


def time_interleaved(
    candidates: Mapping[K, Callable[[], object]],
    repeats: int = 15,
    calls_per_sample: int = 1,
    warmup: int = 2,
    clock: str = "wall",
) -> dict[K, Timing]:
    """Time zero-argument callables (each returning JAX arrays) interleaved; seconds per call.

    Each candidate is first called ``max(warmup, 1)`` times alone, each call waited for and not
    timed; then ``repeats`` rounds of :func:`interleave` (rotating order) take one :func:`timed`
    sample of each: ``calls_per_sample`` calls back to back, blocking on the last, the elapsed time
    divided by ``calls_per_sample``. ``clock="wall"`` (default) measures elapsed time;
    ``clock="cpu"`` this process's CPU time (all threads), which is what to compare when other
    processes compete for the cores.
    """
    if clock not in CLOCKS:
        raise ValueError(f"unknown clock {clock!r}; valid: {', '.join(CLOCKS)}")
    for fn in candidates.values():
        for _ in range(max(warmup, 1)):
            block_until_ready(fn())
    samples = interleave({name: timed(lambda _r, f=fn: f(), calls_per_sample, clock=CLOCKS[clock])
                          for name, fn in candidates.items()}, repeats)
    return {name: summarise(s) for name, s in samples.items()}


def calls_for(fn: Callable[[], object], target_seconds: float = 0.02, max_calls: int = 1000) -> int:
    """How many back-to-back calls of ``fn`` take about ``target_seconds`` (at least 1): one
    call waited for, then one timed wall-clock call."""
    sample = timed(lambda _r: fn())
    sample(-1)
    once = max(sample(0), 1e-7)
    return int(max(1, min(max_calls, target_seconds / once)))
