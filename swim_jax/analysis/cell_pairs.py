"""Two sets of runs compared cell by cell: ``python -m swim_jax.compare A_DIR B_DIR [--at-step N] --out DIR``.

A and B are folders of run folders (a study's ``out_dir`` or its curated copy): the cells are their
sub-folders with a ``config.yaml``, paired by name (``walker_swim`` in A with ``walker_swim`` in B).
Each pair must be the same experiment but for the compared keys (``--differ``, default
``matmul_dtype`` and ``precision``: what the one-precision issue measures) and the budget: same env,
activation, seeds and every other config key; a pair that differs elsewhere is refused with one
line naming it. ``--at-step N`` reads both at the budget of N steps (each must have reached it).

Per pair and per-seed score (*max*, *final*, *auc*: ``swim_jax.analysis.stats.per_seed_scores``, as
the report's) the difference of means A − B with its 95 % bootstrap CI and Welch's test
(``stats.compare``), and one plain sentence: whether B's setting changes what TD3 learns in that
cell, which it does when any score's difference passes the report's evidence rule (≥ 5 seeds each,
Welch p < 0.05 and a CI that excludes 0). Writes ``COMPARE.md`` and ``compare.json`` into ``--out``,
all or nothing, by the rule of every ``--out`` (swim_jax/io/output_folder.py): a new or empty folder,
or with ``--force`` any folder, where those two files are replaced (a comparison rerun as a study's
cells finish) and other files stay; nothing is written on bad input.

Exit status: 0 written; 2 bad input (one line on stderr).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from dataclasses import dataclass

from swim_jax.analysis import stats
from swim_jax.analysis.runs_io import POOL_IGNORED_KEYS, Run, RunError, flat_config, load_run, numerics
from swim_jax.io import cli_parser, output_folder

SCORES = ("max", "final", "auc")
DIFFER = ("matmul_dtype", "precision")
IGNORED = POOL_IGNORED_KEYS | {"total_steps", "keep_checkpoints", "compilation_cache", "progress_steps"}


class CompareError(ValueError):
    """Bad input; ``str(e)`` is one line."""


@dataclass
class Pair:
    """One cell in both sets: its name, the two runs, and per score the comparison A vs B."""

    name: str
    a: Run
    b: Run
    comparisons: dict  # score -> stats.Comparison (x = A, y = B)

    def changed(self) -> list[str]:
        """The scores whose difference passes the evidence rule (stats.sufficient, the verdict's)."""
        return [s for s, c in self.comparisons.items() if stats.sufficient(c)]


def cells(folder: str) -> dict[str, str]:
    """``{name: path}`` of the run folders directly inside ``folder`` (those with a config.yaml)."""
    if not os.path.isdir(folder):
        raise CompareError(f"{folder}: not a folder of run folders")
    return {n: os.path.join(folder, n) for n in sorted(os.listdir(folder))
            if os.path.isfile(os.path.join(folder, n, "config.yaml"))}


def pair(name: str, a_path: str, b_path: str, at_step: int | None, differ: tuple[str, ...],
         n_boot: int, seed: int) -> Pair:
    """The :class:`Pair` of cell ``name``; :class:`CompareError` when the runs are not one experiment
    but for ``differ`` (and the budget), or either cannot be read at ``at_step``."""
    try:
        a, b = load_run(a_path, at_step), load_run(b_path, at_step)
    except RunError as e:
        raise CompareError(str(e)) from None
    if (a.total_steps, a.eval_freq) != (b.total_steps, b.eval_freq):
        raise CompareError(f"{name}: budgets differ ({a.path}: {a.total_steps} steps, {b.path}: {b.total_steps}); "
                           "give --at-step N to read both at N steps")
    if a.seed_ids != b.seed_ids:
        raise CompareError(f"{name}: the runs have different seeds ({a.seed_ids} vs {b.seed_ids})")
    ignored = IGNORED | set(differ)
    fa, fb = flat_config(a.config, ignored), flat_config(b.config, ignored)
    diff = sorted(k for k in fa.keys() | fb.keys() if fa.get(k) != fb.get(k))
    if diff:
        k = diff[0]
        raise CompareError(f"{name}: {a.path} and {b.path} differ in {k} ({fa.get(k)!r} vs {fb.get(k)!r}), "
                           f"not only in the compared keys ({', '.join(differ)})")
    sa, sb = (stats.per_seed_scores(r.steps, r.returns) for r in (a, b))
    return Pair(name, a, b, {s: stats.compare(sa[s], sb[s], s, n_boot, seed) for s in SCORES})


def sentence(p: Pair, b_label: str) -> str:
    """Whether B's setting changes what TD3 learns in this cell, in one plain sentence."""
    def fmt(c) -> str:
        lo, hi = c.diff_ci
        pv = c.welch.p_two_sided if c.welch is not None else math.nan
        return f"{c.score} {c.diff:+.1f} [{lo:+.1f}, {hi:+.1f}], p = {stats.fmt_p(pv)}"
    changed = p.changed()
    if changed:
        return (f"Yes: with {b_label} TD3 learns differently here (A − B: "
                + "; ".join(fmt(p.comparisons[s]) for s in changed) + ").")
    n = min(c.n_x for c in p.comparisons.values())
    return (f"No difference detected with {cli_parser.counted(n, 'seed')} (A − B: "
            + "; ".join(fmt(c) for c in p.comparisons.values()) + "); a smaller effect is not ruled out.")


def compare_sets(a_dir: str, b_dir: str, at_step: int | None = None, differ: tuple[str, ...] = DIFFER,
                 n_boot: int = 10_000, seed: int = 0) -> tuple[list[Pair], list[str], list[str]]:
    """(pairs in name order, cells only in A, cells only in B); with ``at_step``, a cell that has not
    evaluated at that step in both sets (a study in progress) is left out and listed with A's.
    :class:`CompareError` on bad input."""
    ca, cb = cells(a_dir), cells(b_dir)
    names = [n for n in ca if n in cb]
    if not names:
        raise CompareError(f"no cell name is in both {a_dir} ({', '.join(ca) or 'none'}) and {b_dir} "
                           f"({', '.join(cb) or 'none'})")
    pairs, short = [], []
    for n in names:
        if at_step is not None and not all(_reached(p, at_step) for p in (ca[n], cb[n])):
            short.append(n)  # (a study in progress: the cell has not evaluated at that step yet)
            continue
        pairs.append(pair(n, ca[n], cb[n], at_step, differ, n_boot, seed))
    if not pairs:
        raise CompareError(f"no cell of both sets has reached step {at_step} ({', '.join(short)} have not)")
    return pairs, [n for n in ca if n not in cb] + [f"{n} (not at step {at_step} yet)" for n in short], \
        [n for n in cb if n not in ca]


def _reached(path: str, step: int) -> bool:
    """Whether the run folder at ``path`` has evaluated at ``step`` (its evaluations.npy is long enough)."""
    try:
        run = load_run(path)
    except RunError:
        return False
    return run.returns.shape[0] > step // run.eval_freq


def render(pairs: list[Pair], only_a: list[str], only_b: list[str], command: str) -> tuple[str, dict]:
    """(COMPARE.md, compare.json's content) of the pairs."""
    L = ["# Cell by cell: A against B", "", f"Generated by `{command}`.", "",
         "Per cell, the difference of the per-seed scores' means A − B (*max*: max over evaluations of the "
         "seed's return; *final*: its last evaluation; *auc*: its time-averaged return), with the 95 % "
         "bootstrap CI of the difference and Welch's p. A cell counts as changed when a score has ≥ "
         f"{stats.MIN_SEEDS} seeds each, p < {stats.ALPHA} and a CI that excludes 0.", "",
         "| cell | env | A | B | steps | seeds | max A − B [95 % CI] (p) | final A − B [95 % CI] (p) | "
         "auc A − B [95 % CI] (p) | changed |", "|---|---|---|---|---|---|---|---|---|---|"]
    rows = {}
    for p in pairs:
        cols = []
        for s in SCORES:
            c = p.comparisons[s]
            pv = c.welch.p_two_sided if c.welch is not None else math.nan
            cols.append(f"{c.diff:+.1f} [{c.diff_ci[0]:+.1f}, {c.diff_ci[1]:+.1f}] ({stats.fmt_p(pv)})")
        changed = p.changed()
        L.append(f"| {p.name} | {p.a.env} | {numerics(p.a)} | {numerics(p.b)} | {p.a.total_steps:,} | "
                 f"{p.a.returns.shape[1]} | " + " | ".join(cols) + f" | {', '.join(changed) or 'no'} |")
        rows[p.name] = {
            "env": p.a.env, "a": {"path": p.a.path, "numerics": numerics(p.a)},
            "b": {"path": p.b.path, "numerics": numerics(p.b)}, "steps": p.a.total_steps,
            "seeds": int(p.a.returns.shape[1]), "changed": changed, "sentence": sentence(p, numerics(p.b)),
            "scores": {s: {"mean_a": c.mean_x, "mean_b": c.mean_y, "diff": c.diff, "diff_ci": list(c.diff_ci),
                           "welch_p": c.welch.p_two_sided if c.welch is not None else None}
                       for s, c in p.comparisons.items()},
        }
    L += ["", "## In words", ""] + [f"- **{n}**: {r['sentence']}" for n, r in rows.items()]
    if only_a or only_b:
        L += ["", f"Not paired: only in A: {', '.join(only_a) or 'none'}; only in B: {', '.join(only_b) or 'none'}."]
    changed = [n for n, r in rows.items() if r["changed"]]
    L += ["", f"**{len(changed)} of {len(rows)} cells changed**" + (f": {', '.join(changed)}." if changed else "."), ""]
    return "\n".join(L), {"command": command, "cells": rows, "only_a": only_a, "only_b": only_b}


def parse_args(argv):
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.compare", description=__doc__.split("\n")[0],
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("a", metavar="A_DIR", help="a folder of run folders (e.g. a study's out_dir)")
    p.add_argument("b", metavar="B_DIR", help="another, whose cells of the same names are compared with A's")
    p.add_argument("--out", required=True, help="output folder (new or empty, unless --force)")
    p.add_argument("--at-step", type=int, default=None, metavar="N", help="read every run at the budget of N steps")
    p.add_argument("--differ", action="append", default=None, metavar="KEY",
                   help=f"a config key the pairs may differ in (repeatable; default {', '.join(DIFFER)})")
    p.add_argument("--n-boot", type=int, default=10_000, help="bootstrap resamples (default 10000)")
    p.add_argument("--boot-seed", type=int, default=0, help="bootstrap RNG seed (default 0)")
    p.add_argument("--force", action="store_true",
                   help=f"rewrite a comparison: {' and '.join(OUT_FILES)} in --out are replaced, other files stay")
    a = p.parse_args(argv)
    if a.n_boot < 100:
        p.error("--n-boot must be >= 100")
    if a.at_step is not None and a.at_step < 1:
        p.error(f"--at-step must be >= 1, got {a.at_step}")
    return a


OUT_FILES = ("COMPARE.md", "compare.json")  # all that compare writes


def main(argv=None) -> int:
    """CLI entry point; returns the exit status (0 written, 2 bad input with one line on stderr)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv)
    try:
        output_folder.check(args.out, args.force, OUT_FILES)  # before the (slower) bootstrap, and again when writing
        pairs, only_a, only_b = compare_sets(args.a, args.b, args.at_step, tuple(args.differ or DIFFER),
                                             args.n_boot, args.boot_seed)
        md, data = render(pairs, only_a, only_b, "python -m swim_jax.compare " + " ".join(argv))
        output_folder.write(args.out, {"COMPARE.md": md, "compare.json": json.dumps(data, indent=1) + "\n"},
                            args.force, OUT_FILES)
    except (CompareError, output_folder.OutputFolderError) as e:
        print(f"compare: error: {e}", file=sys.stderr)
        return 2
    print(md.rsplit("\n\n", 2)[-2] if "\n\n" in md else md)
    print(f"compare: wrote COMPARE.md, compare.json to {args.out}")
    return 0
