"""A whole study, resumable: ``python -m swim_jax.study STUDY.yaml [--parallel N | --status | --report DIR | --curate DIR | --adopt DIR | --slurm]``.

A study file names a grid of runs ("cells"): configs (``envs`` × ``activations``, i.e.
``configs/<env>_<activation>.yaml``, or an explicit ``configs`` list), optional further ``grid``
axes (config keys with value lists, every combination a cell), and what every cell shares (``seeds``,
``total_steps``, ``overrides``). ``configs/studies/table2.yaml`` is the paper's Table II::

    name: table2                                  # default: the file's name
    out_dir: ~/swim-runs/study-table2             # default: runs/study-<name>; --out-dir overrides
    envs: [walker, swimmer, hopper, cheetah]      # cell configs <env>_<activation>, in this order
    activations: [swim, swish, relu]
    seeds: 5
    total_steps: 300000
    overrides: {env.backend: mujoco}              # dotted config keys, applied to every cell
    grid: {}                                      # e.g. {agent.activation.k: [0.25, 0.5, 1]}

Every cell is an ordinary run folder (swim_jax/run/train.py's files, ``provenance.json`` included) with a
stable name, ``<out_dir>/<config>[-<grid point>]``, and its output in ``train.log`` there. Running the
command again skips finished cells, resumes unfinished ones from their newest checkpoint and starts
the rest, in the file's order, ``--parallel N`` at a time, each pinned to its own share of the cores
(swim_jax/placement/local_processes.py's split). A cell is run by ``python -m swim_jax.study STUDY.yaml --cell
NAME|INDEX`` (the same command from any session, any machine sharing the folder, or a SLURM array
task: ``--slurm`` prints that script). A cell being trained holds an exclusive lock on its
``study.lock`` (released when its process ends, however it ends), so no cell runs twice at once.

The code in three parts: the study file read into cells (swim_jax/run/study_file.py); where each cell
stands, its lock and training it (swim_jax/run/study_cells.py); and here the command, the report's
study section, ``--curate``, ``--adopt`` and ``--slurm``.

Exit status: 0 every cell asked for is done; 1 a cell's training failed (its line names the cell, its
exit status and log); 2 bad study file, option or cell, or a cell folder that was started with a
different config (nothing started).
"""

from __future__ import annotations

import dataclasses
import datetime
import itertools
import json
import os
import shlex
import sys
from typing import Callable

from swim_jax import config as cfgmod
from swim_jax.io import cli_parser, output_folder, provenance
from swim_jax.run.heartbeat import fmt_duration
from swim_jax.run.study_cells import (DEFAULT_PARALLEL, LOCK_FILE, CellState, cell_command, cell_state, is_done,
                                      last_evaluation, reached, run_cell, run_study, shown_path, status_table)
from swim_jax.run.study_file import Study, StudyError, load, started


# ------------------------------------------------------------------------------------------------
# report, curate, adopt and SLURM
# ------------------------------------------------------------------------------------------------

def _git_commits(states: list[CellState]) -> list[str]:
    out = []
    for s in states:
        for e in provenance.read(s.cell.run_dir):
            g = e.get("git") or {}
            label = f"{g.get('commit', '?')[:12]}{' (dirty)' if g.get('dirty') else ''}"
            if label not in out:
                out.append(label)
    return out


def study_section(study: Study, states: list[CellState], trained: Study | None = None) -> str:
    """The report's study section: which cells are in it (partial studies marked), their wall
    times, machines and matmul products (provenance, timing.json), code, and the exact commands
    that train them into ``trained.out_dir`` (``trained``: the study as run, when ``study`` reads
    curated copies of its cells elsewhere; default ``study``)."""
    from swim_jax.analysis.runs_io import read_matmul_dtype

    trained = trained or study
    done = [s for s in states if s.state == "done"]
    # a cell not (yet) among the copies: how it stands where the study trains it
    states = [s if s.state == "done" or trained is study else cell_state(trained.cell(s.cell.name)) for s in states]
    lines = ["## The study", "",
             f"Study file `{shown_path(study.path)}` (`{study.name}`), {len(study.cells)} cells; "
             f"this report pools the **{len(done)} finished**."]
    if len(done) < len(states):
        where = "" if trained is study else f" (their state in {trained.out_dir})"
        lines += ["", f"**Partial study**: {len(states) - len(done)} cell(s) not finished and left out{where}: "
                  + ", ".join(f"{s.cell.name} ({s.state}, step {s.step})" for s in states if s.state != "done") + "."]
    lines += ["", "| cell | state | steps | wall time (last stretch) | CPU | matmul_dtype | code |",
              "|---|---|---|---|---|---|---|"]
    for s in states:
        prov = provenance.read(s.cell.run_dir)
        cpus = sorted({e.get("cpu", "?") for e in prov})
        commits = sorted({(e.get("git") or {}).get("commit", "?")[:12] for e in prov})
        lines.append(f"| {s.cell.name} | {s.state} | {s.step} | {fmt_duration(s.wall_s) if s.wall_s else ''} | "
                     f"{'; '.join(cpus)} | {read_matmul_dtype(s.cell.run_dir, cfgmod.to_dict(s.cell.cfg)) if started(s.cell) else ''} | {', '.join(commits)} |")
    lines += ["", f"Code: {', '.join(_git_commits(done)) or 'unknown'} (git commit of every start or resume, "
              "provenance.json in each cell).", "",
              "Commands (each cell is resumable; the first runs them all):", "", "```",
              shlex.join(["python", "-m", "swim_jax.study", shown_path(trained.path), "--out-dir", trained.out_dir])]
    lines += [shlex.join(["python", *cell_command(dataclasses.replace(trained, path=shown_path(trained.path)), c.name)[1:]])
              for c in trained.cells]
    lines += ["```", ""]
    return "\n".join(lines)


def write_report(study: Study, out: str, bench: list[str], force: bool, log: Callable[[str], None] = print,
                 trained: Study | None = None, command: list[str] | None = None, at_step: int | None = None,
                 mixed_precision: bool = False) -> int:
    """``--report``: swim_jax.analysis.report over the finished cells into ``out``, with :func:`study_section`
    (``trained``: see there). ``command``: the command line the report names as its origin (default:
    the ``--report`` command that writes it). ``at_step``: every cell that has reached that step, read
    at that budget (the report's ``--at-step``); ``mixed_precision``: the report's ``--mixed-precision``."""
    from swim_jax.analysis import report

    owned = report.OUTPUT_FILES + ("study.json",)  # what --report writes into out (and --force replaces)
    states = [cell_state(c) for c in study.cells]
    if at_step is not None:  # a cell that reached the step counts as done at that budget
        states = [dataclasses.replace(s, state="done") if reached(s.cell, at_step) else s for s in states]
    done = [shown_path(s.cell.run_dir) for s in states if s.state == "done"]
    if not done:
        raise StudyError(f"no finished cell in {study.out_dir} yet"
                         f"{f' (none has reached step {at_step})' if at_step else ''}; --status shows where the cells stand")
    argv = [*done, "--out", out, *itertools.chain.from_iterable(("--bench", b) for b in bench)]
    argv += (["--at-step", str(at_step)] if at_step is not None else []) + (["--mixed-precision"] if mixed_precision else [])
    args = report.parse_args(argv + (["--force"] if force else []))
    extra = (["--at-step", str(at_step)] if at_step is not None else []) + (["--mixed-precision"] if mixed_precision else [])
    command = shlex.join(command or ["python", "-m", "swim_jax.study", shown_path(study.path),
                                     "--out-dir", study.out_dir, "--report", out, *extra])
    try:
        output_folder.check(out, force, owned)
        files = report.build(args, command)
    except (report.ReportError, output_folder.OutputFolderError) as e:
        raise StudyError(str(e)) from None
    text = files["REPORT.md"]
    head, sep, rest = text.partition("\n## ")
    section = study_section(study, states, trained)
    files["REPORT.md"] = head + "\n" + section + sep + rest if sep else text + "\n" + section
    files["study.json"] = json.dumps({
        "study": study.path, "name": study.name, "out_dir": study.out_dir,
        "cells": [{"name": s.cell.name, "state": s.state, "step": s.step, "wall_s": s.wall_s,
                   "run_dir": s.cell.run_dir, "provenance": provenance.read(s.cell.run_dir)} for s in states],
    }, indent=1) + "\n"
    try:
        output_folder.write(out, files, force, owned)
    except output_folder.OutputFolderError as e:
        raise StudyError(str(e)) from None
    for line in report.summary_lines(json.loads(files["results.json"])):
        log(line)
    log(f"study report ({len(done)}/{len(states)} cells): wrote {', '.join(sorted(files))} to {out}")
    return 0


CURATE_SKIPS = ("checkpoints", LOCK_FILE)  # what a curated cell leaves out (resumable state, the lock)


def _copy_cell(src: str, dst: str, skips: tuple[str, ...]) -> None:
    """Copy the run folder ``src`` to ``dst`` (which must not exist) whole or not at all: into
    ``dst.partial`` first, then one ``os.replace``, so a copy cut short never leaves a ``dst`` that the
    study would read as a cell. A ``dst.partial`` left by such a copy is removed first."""
    import shutil

    partial = dst + ".partial"
    shutil.rmtree(partial, ignore_errors=True)
    shutil.copytree(src, partial, ignore=shutil.ignore_patterns(*skips))
    os.replace(partial, dst)


def curate(study: Study, out: str, bench: list[str], log: Callable[[str], None] = print,
           mixed_precision: bool = False) -> int:
    """``--curate DIR``: copy every finished cell not yet in ``DIR`` to ``DIR/<cell>/`` without its
    checkpoints (evaluations, metrics, final policies, config, timing, provenance, train.log stay),
    then write the report over all cells in ``DIR`` to ``DIR/report/`` (rewritten each time: it is
    this command's own output). Cells already in ``DIR`` are left as they are."""
    done = [s.cell for s in (cell_state(c) for c in study.cells) if s.state == "done"]
    if not done:
        raise StudyError(f"no finished cell in {study.out_dir} yet; --status shows where the cells stand")
    os.makedirs(out, exist_ok=True)
    for c in done:
        dst = os.path.join(out, c.name)
        if os.path.exists(dst):
            log(f"{c.name}: already in {out}; left as it is")
            continue
        _copy_cell(c.run_dir, dst, CURATE_SKIPS)
        log(f"{c.name}: copied to {dst} (without {', '.join(CURATE_SKIPS)})")
    curated = load(study.path, out)
    command = ["python", "-m", "swim_jax.study", shown_path(study.path), "--out-dir", study.out_dir,
               "--curate", out]
    return write_report(curated, os.path.join(out, "report"), bench, force=True, log=log, trained=study,
                        command=command + (["--mixed-precision"] if mixed_precision else []),
                        mixed_precision=mixed_precision)


def adopt(study: Study, src: str, log: Callable[[str], None] = print) -> int:
    """``--adopt DIR``: the way back from ``--curate DIR`` (a new machine, a wiped scratch folder):
    copy every cell that ``DIR`` holds finished at this study's budget into the study's folder, so the
    study skips it instead of training it again. A cell already in the study's folder is left as it
    is. A copy that stopped short of the budget is not copied, in one line each (a curated cell has no
    checkpoints to grow from, so the study trains that cell from step 0). Refused before anything is
    copied (:class:`StudyError`): ``DIR`` holds none of the study's cells, or a copy's config.yaml is
    not its cell's (the rule of a resume, :func:`swim_jax.config.first_difference`)."""
    found = [c for c in study.cells if os.path.isfile(os.path.join(src, c.name, "config.yaml"))]
    if not found:
        raise StudyError(f"--adopt {src}: holds none of study {study.name}'s cells "
                         f"({', '.join(c.name for c in study.cells)}), each a folder with its config.yaml")
    copies = [dataclasses.replace(c, run_dir=os.path.join(src, c.name)) for c in found]
    for copy in copies:
        diff = cfgmod.first_difference(copy.cfg, copy.run_dir)
        if diff:
            k, recorded, wanted = diff
            raise StudyError(f"--adopt {src}: {copy.run_dir} was run with {k}={recorded!r}, cell {copy.name} of "
                             f"study {study.name} gives {k}={wanted!r}; nothing adopted")
    for c, copy in zip(found, copies):
        if os.path.exists(c.run_dir):
            log(f"{c.name}: already in {study.out_dir}; left as it is")
            continue
        if not is_done(copy):
            last = last_evaluation(copy.run_dir)
            log(f"{c.name}: {copy.run_dir} stopped at step {last[0] if last else 0} of {c.cfg.total_steps} and has no "
                "checkpoints to grow from; not adopted (the study trains it from step 0)")
            continue
        os.makedirs(study.out_dir, exist_ok=True)
        _copy_cell(copy.run_dir, c.run_dir, (LOCK_FILE,))
        log(f"{c.name}: adopted from {copy.run_dir} (done at step {c.cfg.total_steps}; the study skips it)")
    return 0


def slurm_script(study: Study, cpus: int, hours: int, python: str = sys.executable) -> str:
    """A SLURM job-array script, one task per cell, each task the cell's resumable command."""
    repo = provenance.SOURCE_DIR
    cmd = shlex.join(cell_command(study, "INDEX", python)).replace("INDEX", "$SLURM_ARRAY_TASK_ID")
    return "\n".join([
        "#!/bin/bash",
        f"# {len(study.cells)} cells of study {study.name} ({study.path}): one array task per cell.",
        "# Each task trains, resumes or skips its cell; resubmit the same script after a timeout.",
        f"#SBATCH --job-name=swim-{study.name}",
        f"#SBATCH --array=0-{len(study.cells) - 1}",
        "#SBATCH --ntasks=1",
        f"#SBATCH --cpus-per-task={cpus}",
        f"#SBATCH --time={hours}:00:00",
        f"#SBATCH --output={study.out_dir}/slurm-%A_%a.out",
        "# cells: " + " ".join(f"{c.index}={c.name}" for c in study.cells),
        "set -euo pipefail",
        f"cd {shlex.quote(repo)}",
        f"mkdir -p {shlex.quote(study.out_dir)}",
        cmd,
        "",
    ])


# ------------------------------------------------------------------------------------------------
# command line
# ------------------------------------------------------------------------------------------------

def _parser():
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.study", description=__doc__.split("\n")[0])
    p.add_argument("study", metavar="STUDY.yaml", help="study file (the paper's: configs/studies/table2.yaml)")
    p.add_argument("--out-dir", help="the study's folder (default: the file's out_dir)")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--status", action="store_true", help="print where every cell stands and the ETA")
    what.add_argument("--report", metavar="DIR", help="write the report over the finished cells to DIR")
    what.add_argument("--curate", metavar="DIR", help="copy finished cells (no checkpoints) to DIR and report them in DIR/report")
    what.add_argument("--adopt", metavar="DIR",
                      help="copy the cells DIR (a --curate folder) holds finished at this budget into the study's "
                           "folder, so the study skips them (a new machine)")
    what.add_argument("--slurm", action="store_true", help="print a SLURM job-array script (one task per cell)")
    what.add_argument("--cell", metavar="NAME|INDEX", help="train (resume, skip) this one cell in this process")
    p.add_argument("--parallel", type=int, default=None,
                   help=f"cells at once, each pinned to its share of the cores (default {DEFAULT_PARALLEL}, "
                        "measured fastest: docs/PERFORMANCE.md: study-cells-at-once)")
    p.add_argument("--bench", action="append", default=[], metavar="FILE",
                   help="with --report: activation benchmark JSON for Table III (repeatable)")
    p.add_argument("--force", action="store_true", help="with --report: write into a non-empty DIR")
    p.add_argument("--at-step", type=int, default=None, metavar="N",
                   help="with --report: every cell that has reached step N, read at that budget (e.g. Table II "
                        "at 300000 from 1M cells)")
    p.add_argument("--mixed-precision", action="store_true",
                   help="with --report/--curate: compare cells that differ in precision or matmul_dtype "
                        "(refused without it; their rows are marked)")
    p.add_argument("--cpus-per-task", type=int, default=2, help="with --slurm: cores per cell (default 2)")
    p.add_argument("--hours", type=int, default=24, help="with --slurm: time limit per task in hours (default 24)")
    return p


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module docstring)."""
    args = _parser().parse_args(sys.argv[1:] if argv is None else argv)
    cores = len(os.sched_getaffinity(0))
    try:
        if args.parallel is not None and not 1 <= args.parallel <= cores:
            raise StudyError(f"--parallel {args.parallel}: must be between 1 and the {cores} cores this process may use")
        if args.force and not args.report or args.bench and not (args.report or args.curate):
            raise StudyError("--bench goes with --report DIR or --curate DIR, --force with --report DIR")
        if args.at_step is not None and not args.report or args.mixed_precision and not (args.report or args.curate):
            raise StudyError("--at-step goes with --report DIR, --mixed-precision with --report DIR or --curate DIR")
        if args.at_step is not None and args.at_step < 1:
            raise StudyError(f"--at-step must be >= 1 (an evaluation step of every cell), got {args.at_step}")
        if args.cpus_per_task < 1 or args.hours < 1:
            raise StudyError("--cpus-per-task and --hours must be >= 1")
        study = load(args.study, args.out_dir)
        parallel = args.parallel or min(DEFAULT_PARALLEL, cores)
        if args.status:
            print(status_table(study, parallel))
            return 0
        if args.slurm:
            print(slurm_script(study, args.cpus_per_task, args.hours), end="")
            return 0
        if args.report:
            return write_report(study, args.report, args.bench, args.force, at_step=args.at_step,
                                mixed_precision=args.mixed_precision)
        if args.curate:
            return curate(study, args.curate, args.bench, mixed_precision=args.mixed_precision)
        if args.adopt:
            return adopt(study, args.adopt)
        if args.cell is not None:
            cell = study.cell(args.cell)
            return run_cell(cell, log=lambda s: print(s, flush=True))
    except StudyError as e:
        print(f"study: error: {e}", file=sys.stderr)
        return 2
    say = lambda s: print(f"[{datetime.datetime.now():%H:%M:%S}] {s}", flush=True)  # noqa: E731
    say(f"study {study.name}: {len(study.cells)} cells in {study.out_dir}, {parallel} at once")
    return run_study(study, parallel, log=say)


if __name__ == "__main__":
    sys.exit(main())
