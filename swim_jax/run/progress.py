"""A run's clock and its progress line: the first chunk (with its compilation) timed apart from
the others, the ETA per phase (random warm-up, learning), and the one line per chunk that training
prints (step, env-steps/s, evaluation mean ± std over seeds, critic loss and Q, elapsed, ETA)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from swim_jax import config as cfgmod
from swim_jax.config import Config
from swim_jax.io.cli_parser import counted
from swim_jax.placement.layout import LaneLayout
from swim_jax.run.heartbeat import fmt_duration


@dataclass
class Clock:
    """Wall-clock accounting of a run: the first chunk (with its compilation) apart from the others,
    whose env steps give the throughput, and whole chunk iterations per phase (random warm-up,
    learning) for the ETA."""

    start: float
    train_s: float = 0.0  # chunks after the first
    steps_timed: int = 0  # their env steps per lane
    first_chunk_s: float | None = None
    walls: dict = field(default_factory=lambda: {False: [], True: []})  # iterations by phase (learning?)
    first_wall: dict = field(default_factory=dict)  # phase -> the run's first iteration (with its compile)

    def trained(self, dt: float, steps: int) -> float:
        if self.first_chunk_s is None:
            self.first_chunk_s = dt  # includes compilation
        else:
            self.train_s += dt
            self.steps_timed += steps
        return dt

    def iteration_done(self, wall: float, learning: bool, first: bool = False) -> None:
        """One chunk iteration (train + evaluation + checkpoint) of ``wall`` seconds in the
        learning phase or the warm-up; the run's ``first`` (its compilation inside) is kept apart."""
        if first:
            self.first_wall[learning] = wall
        else:
            self.walls[learning].append(wall)

    def elapsed(self) -> float:
        return time.time() - self.start

    def eta(self, warmup_left: int, learning_left: int) -> ETA:
        """Seconds for the chunks left: each phase's at its recent iterations' mean (the learning
        phase is several times slower per step than the warm-up); a lower bound (``ETA.known``
        false) while learning chunks are left and none was timed yet."""
        def typical(learning: bool) -> float | None:
            w = self.walls[learning]
            return float(np.mean(w[-3:])) if w else self.first_wall.get(learning)

        warm, learn = typical(False), typical(True)
        known = learn is not None or learning_left == 0
        seconds = warmup_left * (warm or 0.0) + learning_left * (learn if learn is not None else (warm or 0.0))
        return ETA(seconds, known)


@dataclass(frozen=True)
class ETA:
    """Seconds left; ``known`` false: a lower bound (the learning phase is not timed yet)."""

    seconds: float
    known: bool = True

    def __str__(self) -> str:
        return fmt_duration(self.seconds) if self.known else f">{fmt_duration(self.seconds)} (learning phase not timed yet)"


def chunks_left(cfg: Config, done: int) -> tuple[int, int]:
    """(warm-up chunks, learning chunks) after the first ``done`` chunks; a chunk is learning when
    any of its steps is (its end step > ``learning_starts``)."""
    n = cfgmod.schedule(cfg).n_chunks
    warm = min(n, cfg.learning_starts // cfg.eval_freq)
    return max(0, warm - done), n - max(done, warm)


def progress_line(cfg: Config, layout: LaneLayout, step: int, ev: np.ndarray, dt: float, first: bool,
                   elapsed: float, eta: ETA | float, chunk_metrics: dict | None = None, bf16: bool = False) -> str:
    """One line per chunk: step, throughput (", bf16 matmuls" when ``bf16``), eval mean ± std over
    seeds (per point for sweeps), and, once updates run, the chunk's critic loss and Q₁ averaged
    over the lanes."""
    S, P, points = layout.seeds, len(layout.points), layout.points
    means = ev.mean(axis=1)  # [P·S] each lane's mean episode return
    rate = cfg.eval_freq * P * S / dt
    unit = "lane" if layout.swept else "seed"
    over = f"{P} points × {counted(S, 'seed')}" if layout.swept else counted(S, "seed")
    line = (f"step {step:>8d}/{cfg.total_steps} | {rate:8.0f} env-steps/s ({rate / (P * S):.0f}/{unit}"
            f"{', incl. compile' if first else ''}{', bf16 matmuls' if bf16 else ''}) | eval {means.mean():9.2f} ± {means.std():7.2f} over {over}")
    if layout.swept and P <= 8:
        point_means = layout.point_means(means)
        line += " [" + ", ".join(f"{cfgmod.point_label(pt)}: {m:.0f}" for pt, m in zip(points, point_means)) + "]"
    if chunk_metrics is not None and np.any(chunk_metrics["updates"][: P * S] > 0):
        line += (f" | critic loss {np.nanmean(chunk_metrics['critic_loss'][: P * S]):.3g}"
                 f", Q {np.nanmean(chunk_metrics['q_mean'][: P * S]):.3g}")
    return line + f" | elapsed {fmt_duration(elapsed)} | ETA {eta if isinstance(eta, ETA) else fmt_duration(eta)}"
