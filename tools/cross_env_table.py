"""Two Gymnasium evaluations of the same policies, one per env, side by side: how a learned gait scores
in another version of its env.

    python -m swim_jax.evaluate RUN --json in-v5.json                       # the training env
    python -m swim_jax.evaluate RUN --in-env Walker2d-v4 --json in-v4.json  # the other version
    python tools/cross_env_table.py in-v5.json in-v4.json [A2.json B2.json ...]
    python tools/cross_env_table.py --lengths in-v5.json in-v4.json       # also: falls or speed?
    python tools/cross_env_table.py --lengths-only T1.json [T2.json ...]   # that table alone, any files

Each pair of ``python -m swim_jax.evaluate --json`` files must hold the same (run, seed, step) rows
evaluated in two envs. One markdown row per pair: each seed's Gymnasium mean in A and in B (their
mean over seeds in brackets), and B − A over seeds, paired by seed: the mean difference d̄ with its
95 % CI d̄ ± t₀.₉₇₅,ₙ₋₁ · sd(d)/√n (``stats.mean_ci`` of the differences) and the paired t-test's
two-sided p of t = d̄ / (sd(d)/√n) with n − 1 degrees of freedom (n = seeds, at least 2).
``--lengths`` adds a table of every file: per seed, the mean episode length, the episodes that
reached the time limit, and the return per step (Σ returns / Σ lengths). Return = length × return
per step, so it tells a low return from falls (short episodes) from one of a slow gait;
``--lengths-only`` prints that table alone, for any number of files (one env each, no pairs).
Under it, one line over all the seeds: since a seed's mean return is its mean length × its return
per step, var(log return) splits into the length's share and the rate's (each with half the
covariance), and Pearson's r of return and length.
Bad input (an odd number of files, a file that is not such a table, rows that do not match): one
line on stderr, exit status 2.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import NamedTuple

import numpy as np

from swim_jax.analysis import stats
from swim_jax.io import cli_parser

HEADER = "| run | seeds' means in A (mean) | in B (mean) | B − A, paired by seed [95 % CI] (p) |"
LENGTHS_HEADER = ("| run: env | seeds' mean episode length (episodes at the time limit / episodes) | "
                  "seeds' return per step |")


def read_table(path: str) -> tuple[str, dict[tuple, float]]:
    """(env, {(run, seed, step): Gymnasium mean}) of one ``evaluate --json`` file (one env)."""
    try:
        with open(path) as f:
            rows = json.load(f)["rows"]
        means = {(r["run"], r["seed"], r["step"]): float(r["gymnasium"]["mean"]) for r in rows}
        envs = {r["env_id"] for r in rows}
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ValueError(f"{path}: not a table of python -m swim_jax.evaluate --json ({e})") from None
    if len(envs) != 1 or not means:
        raise ValueError(f"{path}: expected rows of one env, got {sorted(envs) or 'no rows'}")
    return envs.pop(), means


class SeedLengths(NamedTuple):
    """One seed's episodes in one ``evaluate --json`` row."""

    mean_length: float
    at_time_limit: int | None  # episodes that reached the time limit (None: the limit is unknown)
    episodes: int
    per_step: float  # return per step: Σ returns / Σ lengths


def seed_lengths(path: str) -> tuple[str, list[SeedLengths]]:
    """("run: env" label, each seed's :class:`SeedLengths`) of one ``evaluate --json`` file."""
    try:
        with open(path) as f:
            rows = sorted(json.load(f)["rows"], key=lambda r: (r["run"], r["seed"], r["step"]))
        seeds = []
        for r in rows:
            g = r["gymnasium"]
            lengths, returns = np.asarray(g["lengths"], float), np.asarray(g["returns"], float)
            seeds.append(SeedLengths(lengths.mean(), g["at_time_limit"], lengths.size, returns.sum() / lengths.sum()))
        runs, envs = sorted({r["run"] for r in rows}), sorted({r["env_id"] for r in rows})
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ValueError(f"{path}: not a table of python -m swim_jax.evaluate --json with episode lengths "
                         f"(written since 2026-12-07) ({e})") from None
    return f"{', '.join(runs)}: {', '.join(envs)}", seeds


def lengths_row(label: str, seeds: list[SeedLengths]) -> str:
    """The ``--lengths`` row of one file's :func:`seed_lengths`."""
    at_limit = lambda s: "?" if s.at_time_limit is None else str(s.at_time_limit)  # noqa: E731
    return (f"| {label} | " + ", ".join(f"{s.mean_length:.0f} ({at_limit(s)}/{s.episodes})" for s in seeds)
            + " | " + ", ".join(f"{s.per_step:.2f}" for s in seeds) + " |")


def length_share(seeds: list[SeedLengths]) -> str:
    """One line over all seeds given: mean return = mean length × return per step, so over seeds
    var(log return) = var(log length) + var(log rate) + 2 cov; the share of each is its variance plus
    half the covariance, over var(log return) (population moments). With Pearson's r of return and
    mean length."""
    length = np.array([s.mean_length for s in seeds])
    rate = np.array([s.per_step for s in seeds])
    ret = length * rate
    if ret.size < 3 or np.any(ret <= 0):
        return f"length share: needs at least 3 seeds with positive mean returns, got {ret.size}"
    ll, lr = np.log(length), np.log(rate)
    cov = float(np.mean((ll - ll.mean()) * (lr - lr.mean())))
    total = ll.var() + lr.var() + 2 * cov
    r = float(np.corrcoef(ret, length)[0, 1])
    return (f"over {ret.size} seeds, share of var(log return) from the episode length "
            f"{(ll.var() + cov) / total:.0%}, from the return per step {(lr.var() + cov) / total:.0%}; "
            f"Pearson r(return, length) {r:.2f}")


def paired_row(path_a: str, path_b: str) -> str:
    """The markdown row of one pair of files (see the module docstring)."""
    env_a, a = read_table(path_a)
    env_b, b = read_table(path_b)
    if set(a) != set(b) or len(a) < 2:
        raise ValueError(f"{path_a} and {path_b}: the same (run, seed, step) rows, at least 2, are needed; "
                         f"got {len(a)} and {len(b)} rows, {len(set(a) & set(b))} shared")
    keys = sorted(a)
    x, y = np.array([a[k] for k in keys]), np.array([b[k] for k in keys])
    ci = stats.mean_ci(y - x)
    p = stats.student_t_two_sided_p(ci.mean / (ci.sd / math.sqrt(ci.n)), ci.n - 1) if ci.sd > 0 else float("nan")
    runs = sorted({k[0] for k in keys})
    fmt = lambda v: ", ".join(f"{m:.0f}" for m in v) + f" ({v.mean():.0f})"  # noqa: E731
    return (f"| {', '.join(runs)}: {env_a} → {env_b} | {fmt(x)} | {fmt(y)} | "
            f"{ci.mean:+.0f} [{ci.low:+.0f}, {ci.high:+.0f}] ({p:.2g}) |")


def main(argv=None) -> int:
    p = cli_parser.ArgumentParser(prog="python tools/cross_env_table.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("tables", nargs="+", metavar="TABLE.json", help="pairs of evaluate --json files")
    p.add_argument("--lengths", action="store_true",
                   help="also a table of episode lengths and return per step of every file")
    p.add_argument("--lengths-only", action="store_true",
                   help="only that table, for any number of files (not paired)")
    args = p.parse_args(argv)
    if len(args.tables) % 2 and not args.lengths_only:
        p.error(f"{len(args.tables)} files: give pairs (A B), one per set of policies (or --lengths-only)")
    try:
        rows = [] if args.lengths_only else [paired_row(a, b) for a, b in zip(args.tables[::2], args.tables[1::2])]
        lengths = [seed_lengths(t) for t in args.tables] if args.lengths or args.lengths_only else []
    except ValueError as e:
        print(f"cross_env_table: error: {e}", file=sys.stderr)
        return 2
    if rows:
        print(HEADER)
        print("|---|---|---|---|")
        print("\n".join(rows))
    if lengths:
        if rows:
            print()
        print(LENGTHS_HEADER)
        print("|---|---|---|")
        print("\n".join(lengths_row(label, seeds) for label, seeds in lengths))
        print()
        print(length_share([s for _, seeds in lengths for s in seeds]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
