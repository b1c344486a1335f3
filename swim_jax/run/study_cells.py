"""A study's cells as they run: where each stands (:func:`cell_state`, ``--status``), the lock that
keeps a cell from being trained twice at once (:func:`cell_lock`), training one cell in this
process (:func:`run_cell`, ``--cell``) and all of them, each in its own pinned process
(:func:`run_study`), every cell's output in its ``train.log``.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import fcntl
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable

import yaml

from swim_jax.config import Config
from swim_jax.run.heartbeat import fmt_duration
from swim_jax.run.study_file import Cell, Study, started

LOCK_FILE = "study.lock"
LOG_FILE = "train.log"
# cells run at once when --parallel is not given: one cell on every core was measured fastest in the
# learning phase on this project's 2-core machine (docs/PERFORMANCE.md: study-cells-at-once)
DEFAULT_PARALLEL = 1


@dataclass(frozen=True)
class CellState:
    """Where a cell stands: ``state`` is ``done``, ``running`` (its lock is held), ``started`` (a
    folder, not running) or ``left`` (no folder); ``step`` the newest checkpoint's; ``last_eval``
    (mean, std over seeds) of its newest evaluation; ``seconds_per_step`` its measured wall time
    per env step (all seeds), None until known."""

    cell: Cell
    state: str
    step: int
    last_eval: tuple[float, float] | None
    seconds_per_step: float | None
    wall_s: float | None


def is_locked(run_dir: str) -> bool:
    """Whether a process holds the cell's lock now (i.e. is training it)."""
    path = os.path.join(run_dir, LOCK_FILE)
    if not os.path.isfile(path):
        return False
    with open(path) as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        fcntl.flock(f, fcntl.LOCK_UN)
    return False


@contextlib.contextmanager
def cell_lock(run_dir: str):
    """Hold the cell's exclusive lock for the block; yields False (not held) when another process has it."""
    os.makedirs(run_dir, exist_ok=True)
    with open(os.path.join(run_dir, LOCK_FILE), "a+") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            yield False
            return
        f.seek(0)
        f.truncate()
        f.write(f"{os.getpid()} {os.uname().nodename}\n")
        f.flush()
        try:
            yield True
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def last_evaluation(run_dir: str) -> tuple[int, float, float] | None:
    path = os.path.join(run_dir, "evaluations.csv")
    if not os.path.isfile(path):
        return None
    with open(path) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return None
    r = rows[-1]
    return int(r["step"]), float(r["mean"]), float(r["std"])


def is_done(c: Cell) -> bool:
    last = last_evaluation(c.run_dir)
    return (os.path.isfile(os.path.join(c.run_dir, "timing.json"))
            and os.path.isfile(os.path.join(c.run_dir, "final_policy.npz"))
            and last is not None and last[0] == c.cfg.total_steps)


def _seconds_per_step(c: Cell, done: bool) -> tuple[float | None, float | None]:
    """(measured wall seconds per env step, wall seconds of the last stretch): from timing.json of a
    finished cell (the stretch since its last resume), else from the times of its two newest
    checkpoints, counted only when both lie in the learning phase (the random warm-up before
    ``learning_starts`` is several times faster per step and would make the ETA far too short)."""
    if done:
        with open(os.path.join(c.run_dir, "timing.json")) as f:
            t = json.load(f)
        first = (t.get("resumed_from_chunk") or 0) * c.cfg.eval_freq
        steps = c.cfg.total_steps - first
        return (t["wall_time_s"] / steps if steps > 0 else None), t["wall_time_s"]
    ckpt = os.path.join(c.run_dir, "checkpoints")
    steps = sorted(int(n) for n in os.listdir(ckpt) if n.isdigit()) if os.path.isdir(ckpt) else []
    steps = [s for s in steps if s >= c.cfg.learning_starts]
    if len(steps) < 2:
        return None, None
    a, b = steps[-2], steps[-1]
    dt = os.path.getmtime(os.path.join(ckpt, str(b))) - os.path.getmtime(os.path.join(ckpt, str(a)))
    return (dt / (b - a) if dt > 0 else None), None


def cell_state(c: Cell) -> CellState:
    """The :class:`CellState` of ``c`` read from its folder (nothing is written)."""
    from swim_jax.io.checkpoint import latest_complete_step

    if not started(c):
        return CellState(c, "running" if is_locked(c.run_dir) else "left", 0, None, None, None)
    done = is_done(c)
    last = last_evaluation(c.run_dir)
    step = c.cfg.total_steps if done else (latest_complete_step(os.path.join(c.run_dir, "checkpoints")) or 0)
    rate, wall = _seconds_per_step(c, done)
    state = "done" if done else "running" if is_locked(c.run_dir) else "started"
    return CellState(c, state, step, None if last is None else (last[1], last[2]), rate, wall)


def status_table(study: Study, parallel: int) -> str:
    """The ``--status`` text: one row per cell, then the study's totals and ETA (cells left ×
    their steps at the measured seconds per step, ``parallel`` cells at a time)."""
    states = [cell_state(c) for c in study.cells]
    width = max(len(c.name) for c in study.cells)
    lines = [f"{'cell':<{width}}  {'state':<8} {'steps':>16}  {'last eval (mean ± std over seeds)':>34}  wall"]
    for s in states:
        ev = "" if s.last_eval is None else f"{s.last_eval[0]:.1f} ± {s.last_eval[1]:.1f}"
        lines.append(f"{s.cell.name:<{width}}  {s.state:<8} {s.step:>8}/{s.cell.cfg.total_steps:<7}  {ev:>34}  "
                     f"{fmt_duration(s.wall_s) if s.wall_s else ''}")
    counts = {k: sum(s.state == k for s in states) for k in ("done", "running", "started", "left")}
    left_steps = sum(s.cell.cfg.total_steps - s.step for s in states)
    rates = [s.seconds_per_step for s in states if s.seconds_per_step]
    if rates and left_steps:
        per_step = sum(rates) / len(rates)
        eta = f"ETA {fmt_duration(left_steps * per_step / parallel)} at {parallel} cell(s) at once " \
              f"({per_step * 1000:.1f} ms per step measured over {len(rates)} cell(s))"
    else:
        eta = "done" if not left_steps else "ETA ? (no cell has two checkpoints in its learning phase yet)"
    lines.append(f"study {study.name}: {counts['done']}/{len(states)} done, {counts['running']} running, "
                 f"{counts['started']} started, {counts['left']} not started; {left_steps} steps left; {eta}")
    lines.append(f"out_dir: {study.out_dir}")
    return "\n".join(lines)


def reached(c: Cell, step: int) -> bool:
    """Whether cell ``c`` has evaluated at ``step`` (or beyond)."""
    last = last_evaluation(c.run_dir)
    return last is not None and last[0] >= step


# ------------------------------------------------------------------------------------------------
# running cells
# ------------------------------------------------------------------------------------------------

def shown_path(path: str) -> str:
    """``path`` as a report shows it: relative to the working directory when it lies inside it (a
    curated report in the repository then names its inputs by repository paths, not this
    machine's), else as given."""
    rel = os.path.relpath(path)
    return path if rel == os.pardir or rel.startswith(os.pardir + os.sep) else rel


def cell_command(study: Study, key: str, python: str = sys.executable) -> list[str]:
    """The command that trains (or resumes, or skips when done) one cell of ``study``."""
    return [python, "-m", "swim_jax.study", study.path, "--out-dir", study.out_dir, "--cell", key]


def recorded_backend(c: Cell) -> Config:
    """The cell's config with ``env.backend=auto`` replaced by the backend its run folder recorded
    (a resumed cell keeps the physics it started with, whichever machine resumes it)."""
    if c.cfg.env.backend != "auto":
        return c.cfg
    with open(os.path.join(c.run_dir, "config.yaml")) as f:
        recorded = ((yaml.safe_load(f) or {}).get("env") or {}).get("backend", "auto")
    return dataclasses.replace(c.cfg, env=dataclasses.replace(c.cfg.env, backend=recorded))


@contextlib.contextmanager
def logged_to_file(run_dir: str, log: Callable[[str], None], stream=None):
    """Yield ``log`` extended to append each line to the cell's ``train.log`` too, unless ``stream``
    (default ``sys.stdout``) already writes into that file, as it does for a cell the study's
    runner started (:func:`run_study` redirects its output there): each line lands in the file once."""
    path = os.path.join(run_dir, LOG_FILE)
    stream = sys.stdout if stream is None else stream
    try:
        same = os.path.exists(path) and os.path.samestat(os.fstat(stream.fileno()), os.stat(path))
    except (AttributeError, OSError, ValueError):  # a stream without a file (a pipe is a file; StringIO is not)
        same = False
    if same:
        yield log
        return
    with open(path, "a") as f:
        def log_and_append(line: str) -> None:
            log(line)
            f.write(line + "\n")
            f.flush()
        yield log_and_append


def run_cell(c: Cell, log: Callable[[str], None] = print) -> int:
    """Train cell ``c`` in this process: skip it when done or running elsewhere, resume it from its
    newest checkpoint when started, else start it. Returns the exit status (0, or 3 on NaN/inf).
    Once it trains, every line also goes to the cell's ``train.log`` (:func:`logged_to_file`), so a
    cell run by hand (``--cell``, a SLURM task) keeps its log where the study's runner keeps it."""
    with cell_lock(c.run_dir) as held:
        if not held:
            log(f"{c.name}: already being trained by another process ({os.path.join(c.run_dir, LOCK_FILE)}); skipped")
            return 0
        if is_done(c):
            log(f"{c.name}: done; skipped")
            return 0
        with logged_to_file(c.run_dir, log) as log_both:
            return _train_cell(c, log_both)


def _train_cell(c: Cell, log: Callable[[str], None]) -> int:
    """:func:`run_cell`'s training, the lock held: resume ``c`` when started, else start it."""
    from swim_jax.run import train

    resume = started(c)
    log(f"{c.name}: {'resuming' if resume else 'starting'} in {c.run_dir}")
    cfg = recorded_backend(c) if resume else c.cfg
    try:
        res = train.run(cfg, c.run_dir, resume=resume, log=log, status=log)
    except train.NonFiniteError as e:
        log(f"error: {e}")
        return 3
    log(f"{c.name}: done in {fmt_duration(res.timing['wall_time_s'])}")
    return 0


def run_study(study: Study, parallel: int, log: Callable[[str], None] = print, poll_s: float = 2.0) -> int:
    """Run every cell that is not done, ``parallel`` at a time in the study's order, each as
    :func:`cell_command` in its own process pinned to its share of the cores, its output appended
    to its ``train.log``. Returns 0 when all are done, 1 when a cell failed (named in a line)."""
    from swim_jax.placement.local_processes import core_shares

    shares = core_shares(parallel)
    queue = []
    for c in study.cells:
        s = cell_state(c)
        if s.state == "done":
            log(f"{c.name}: done; skipped")
        elif s.state == "running":
            log(f"{c.name}: being trained by another process; skipped")
        else:
            queue.append(c)
    running: dict[int, tuple[Cell, subprocess.Popen, float, Any]] = {}  # slot -> (cell, process, start, log file)
    failed = []
    try:
        while queue or running:
            for slot in range(parallel):
                if slot not in running and queue:
                    c = queue.pop(0)
                    os.makedirs(c.run_dir, exist_ok=True)
                    out = open(os.path.join(c.run_dir, LOG_FILE), "a")
                    pin = shares[slot] if parallel > 1 else None
                    proc = subprocess.Popen(cell_command(study, c.name), stdout=out, stderr=subprocess.STDOUT,
                                            preexec_fn=(lambda p=pin: os.sched_setaffinity(0, p)) if pin else None)
                    running[slot] = (c, proc, time.time(), out)
                    log(f"{c.name}: started (cores {','.join(map(str, pin)) if pin else 'all'}; "
                        f"log {os.path.join(c.run_dir, LOG_FILE)})")
            time.sleep(poll_s)
            for slot, (c, proc, t0, out) in list(running.items()):
                code = proc.poll()
                if code is None:
                    continue
                out.close()
                del running[slot]
                if code == 0:
                    log(f"{c.name}: finished after {fmt_duration(time.time() - t0)}")
                else:
                    failed.append(c.name)
                    log(f"{c.name}: failed with exit status {code}; see {os.path.join(c.run_dir, LOG_FILE)}")
    finally:
        for c, proc, _, out in running.values():  # interrupted: the cells stop, their checkpoints stay
            proc.terminate()
            proc.wait()
            out.close()
    done = sum(cell_state(c).state == "done" for c in study.cells)
    log(f"study {study.name}: {done}/{len(study.cells)} cells done"
        + (f"; failed: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0
