"""Which lane trains what: the lane layout of a run, :class:`LaneLayout`.

All of a run's lanes (every seed of every sweep point) train in one lane axis of the program's
arrays. Lane ``p·S + s`` (S = ``seeds``) trains seed ``first_seed + s`` of sweep point ``p`` (every
point sees the same seeds); these ``P·S`` lanes are the *real* lanes. A run of one seed and no
sweep has one more lane, repeating lane 0 (``pad_single_seed``, see :meth:`LaneLayout.of`), so
that its lane axis is never 1 wide. Everything that maps lanes to seeds, points or outputs asks
this object.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swim_jax import config as cfgmod
from swim_jax.config import Config


@dataclass(frozen=True)
class LaneLayout:
    """The lanes of a run: ``points`` (its sweep points; one ``{}`` without a sweep) × ``seeds``
    seeds from ``first_seed``, in a lane axis ``count`` wide (≥ the real lanes)."""

    points: tuple[dict, ...]
    seeds: int
    first_seed: int
    count: int
    swept: bool

    @classmethod
    def of(cls, cfg: Config) -> LaneLayout:
        """The layout of ``cfg``. Why a single lane is padded to two: with a unit vmap axis XLA CPU
        simplifies the batched physics differently, which changes float rounding (~1e-5 after ~10
        steps), so seed i alone would drift from seed i in a multi-seed run. Lanes ≥ 2 compute each
        seed bit-identically at the same lane count per device (tests/test_train.py); another lane
        count rounds the updates differently (XLA compiles the batched bias-gradient reductions per
        shape; ~1e-8 after one update, docs/DISTRIBUTED.md)."""
        points = tuple(cfgmod.sweep_points(cfg))
        real = len(points) * cfg.seeds
        return cls(points, cfg.seeds, cfg.first_seed, 2 if real == 1 and cfg.pad_single_seed else real,
                   bool(cfg.sweep))

    @property
    def real(self) -> int:
        """The lanes that train a seed of a sweep point: points × seeds (no padding lane)."""
        return len(self.points) * self.seeds

    def seed_ids(self) -> np.ndarray:
        """int32[count]: the seed every lane trains (a padded lane repeats lane 0's)."""
        seeds = np.arange(self.first_seed, self.first_seed + self.seeds)
        return np.resize(np.tile(seeds, len(self.points)), self.count).astype(np.int32)

    def per_lane(self, key: str, dtype) -> np.ndarray:
        """[count]: every lane's value of the swept config key ``key`` (its point's)."""
        return np.resize(np.repeat([p[key] for p in self.points], self.seeds), self.count).astype(dtype)

    def point_lanes(self) -> list[slice]:
        """The lanes of every point, in point order."""
        return [slice(p * self.seeds, (p + 1) * self.seeds) for p in range(len(self.points))]

    def where(self, lane: int) -> str:
        """What real lane ``lane`` trains, in words: ``seed 3`` or ``seed 3 of sweep point k=0.5``."""
        text = f"seed {self.first_seed + lane % self.seeds}"
        if self.swept:
            text += f" of sweep point {cfgmod.point_label(self.points[lane // self.seeds])}"
        return text

    def point_means(self, per_lane: np.ndarray) -> np.ndarray:
        """[points]: the mean over each point's seeds of a per-real-lane value."""
        return np.asarray(per_lane)[: self.real].reshape(len(self.points), self.seeds).mean(axis=1)
