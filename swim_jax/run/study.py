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

Exit status: 0 every cell asked for is done; 1 a cell's training failed (its line names the cell, its
exit status and log); 2 bad study file, option or cell, or a cell folder that was started with a
different config (nothing started).
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import datetime
import fcntl
import itertools
import json
import os
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import yaml

from swim_jax.io import cli_parser
from swim_jax import config as cfgmod
from swim_jax.io import output_folder, provenance
from swim_jax.run.heartbeat import fmt_duration
from swim_jax.config import Config, ConfigError

STUDY_KEYS = ("name", "out_dir", "envs", "activations", "configs", "seeds", "total_steps", "overrides", "grid")
SET_BY_STUDY = ("name", "out_dir", "sweep", "local_processes", "seeds", "total_steps")  # not in overrides/grid
LOCK_FILE = "study.lock"
LOG_FILE = "train.log"
# cells run at once when --parallel is not given: one cell on every core was measured fastest in the
# learning phase on this project's 2-core machine (docs/PERFORMANCE.md: study-cells-at-once)
DEFAULT_PARALLEL = 1


class StudyError(ValueError):
    """A bad study file, option or cell folder; ``str(e)`` is one line."""


@dataclass(frozen=True)
class Cell:
    """One run of the study: its stable name, position, config and run folder."""

    index: int
    name: str
    cfg: Config
    run_dir: str


@dataclass(frozen=True)
class Study:
    """A loaded, validated study file: its path, name, out_dir and cells in order."""

    path: str
    name: str
    out_dir: str
    cells: tuple[Cell, ...]

    def cell(self, key: str) -> Cell:
        """The cell named ``key``, or at position ``key`` (0-based, e.g. ``$SLURM_ARRAY_TASK_ID``)."""
        if key.isdigit():
            if int(key) < len(self.cells):
                return self.cells[int(key)]
            raise StudyError(f"--cell {key}: the study has {len(self.cells)} cells (0..{len(self.cells) - 1})")
        for c in self.cells:
            if c.name == key:
                return c
        raise StudyError(f"--cell {key!r}: no such cell; valid: {', '.join(c.name for c in self.cells)}")


# ------------------------------------------------------------------------------------------------
# the study file
# ------------------------------------------------------------------------------------------------

def load(path: str, out_dir: str | None = None) -> Study:
    """Read and validate the study file at ``path`` (``out_dir`` overrides its own); every cell's
    config is resolved and validated, cells that would pool as one (env, activation) are refused,
    and so is an existing cell folder whose config.yaml differs from the cell's. :class:`StudyError`."""
    if not os.path.isfile(path):  # a bare name (table2) is a shipped study, configs/studies/<name>.yaml
        shipped = cfgmod.shipped_study(path)
        if shipped is None:
            raise StudyError(f"study file {path} not found; or a shipped study by name: "
                             f"{', '.join(cfgmod.available_studies())} (table2: the paper's)")
        path = shipped
    try:
        data = cfgmod.load_yaml_mapping(path, path, f"a mapping with keys {', '.join(STUDY_KEYS)}")
    except ConfigError as e:
        raise StudyError(str(e)) from None
    unknown = [k for k in data if k not in STUDY_KEYS]
    if unknown:
        raise StudyError(f"{path}: unknown key {unknown[0]!r}; valid keys: {', '.join(STUDY_KEYS)}")
    name = str(data.get("name") or os.path.splitext(os.path.basename(path))[0])
    out = os.path.abspath(os.path.expanduser(os.path.expandvars(
        out_dir or str(data.get("out_dir") or os.path.join("runs", f"study-{name}")))))
    configs = _config_names(path, data)
    shared = _overrides(path, data.get("overrides"), "overrides")
    for key in ("seeds", "total_steps"):
        if key in data:
            shared[key] = data[key]
    grid = _grid(path, data.get("grid"))
    points = [dict(zip(grid, combo)) for combo in itertools.product(*grid.values())] or [{}]
    cells = []
    for config in configs:
        for point in points:
            cell_name = config + (f"-{_point_label(point)}" if point else "")
            cfg = _cell_config(path, config, {**shared, **point}, cell_name, out)
            cells.append(Cell(len(cells), cell_name, cfg, os.path.join(out, cell_name)))
    _check_poolable(path, cells)
    for c in cells:
        _check_existing(c)
    return Study(os.path.abspath(path), name, out, tuple(cells))


def _string_list(path: str, data: dict, key: str) -> list[str]:
    value = data.get(key)
    if not isinstance(value, list) or not value or not all(isinstance(v, str) and v for v in value):
        raise StudyError(f"{path}: {key} must be a non-empty list of names, got {value!r}")
    if len(set(value)) != len(value):
        raise StudyError(f"{path}: {key} lists a name twice: {value}")
    return value


def _config_names(path: str, data: dict) -> list[str]:
    """The cells' config names: ``configs``, or ``<env>_<activation>`` over ``envs`` × ``activations``."""
    if "configs" in data:
        if "envs" in data or "activations" in data:
            raise StudyError(f"{path}: give either configs or envs with activations, not both")
        names = _string_list(path, data, "configs")
    elif "envs" in data or "activations" in data:
        names = [f"{e}_{a}" for e in _string_list(path, data, "envs") for a in _string_list(path, data, "activations")]
    else:
        raise StudyError(f"{path}: name the cells' configs: envs and activations (configs/<env>_<activation>.yaml) "
                         "or a configs list")
    valid = cfgmod.available_configs()
    for n in names:
        if n not in valid:
            raise StudyError(f"{path}: no config {n!r} (configs/{n}.yaml); valid configs: {', '.join(valid)}")
    return names


def _overrides(path: str, value, key: str) -> dict[str, Any]:
    """``{dotted key: value}`` from a (possibly nested) mapping; keys the study sets itself refused."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise StudyError(f"{path}: {key} must be a mapping of config keys to values, e.g. {{env.backend: mujoco}}")
    flat = cli_parser.dotted_keys(value)
    for k in flat:
        if k.split(".")[0] in SET_BY_STUDY:
            raise StudyError(f"{path}: {key}.{k} is set by the study itself (top-level seeds/total_steps/out_dir; "
                             f"a cell is one plain run); valid here: other config keys")
    return flat


def _grid(path: str, value) -> dict[str, list]:
    grid = _overrides(path, value, "grid")
    for k, values in grid.items():
        if not isinstance(values, list) or not values:
            raise StudyError(f"{path}: grid.{k} must be a non-empty list of values, got {values!r}")
        if len(set(map(repr, values))) != len(values):
            raise StudyError(f"{path}: grid.{k} lists a value twice: {values}")
    return grid


def _point_label(point: Mapping[str, Any]) -> str:
    return ",".join(f"{k.rsplit('.', 1)[-1]}={v:g}" if isinstance(v, float) else f"{k.rsplit('.', 1)[-1]}={v}"
                    for k, v in point.items())


def _set_dotted(data: dict, key: str, value) -> dict:
    data = dict(data)
    node = data
    parts = key.split(".")
    for p in parts[:-1]:
        node[p] = dict(node[p]) if isinstance(node.get(p), Mapping) else {}
        node = node[p]
    node[parts[-1]] = value
    return data


def _cell_config(path: str, config: str, values: dict[str, Any], name: str, out_dir: str) -> Config:
    """The validated config of one cell: ``configs/<config>.yaml`` with ``values`` set."""
    data = cfgmod.load_yaml_chain(config)
    for k, v in values.items():
        data = _set_dotted(data, k, v)
    data = {**data, "name": name, "out_dir": out_dir}
    try:
        return cfgmod.validate(cfgmod.from_dict(Config, data))
    except ConfigError as e:
        raise StudyError(f"{path}: cell {name}: {e}") from None


def _check_poolable(path: str, cells: list[Cell]) -> None:
    """Refuse two cells the report would pool as the same (env, activation) with the same seeds."""
    from swim_jax.analysis.runs_io import activation_label  # (imports the activation registry only)

    seen: dict[tuple, str] = {}
    for c in cells:
        key = (c.cfg.env.id, activation_label(cfgmod.to_dict(c.cfg.agent.activation)), c.cfg.seed, c.cfg.first_seed)
        if key in seen:
            raise StudyError(f"{path}: cells {seen[key]} and {c.name} cannot be pooled: both are {key[0]} with "
                             f"{key[1]} and the same seeds; a grid axis must change the activation (e.g. "
                             "agent.activation.k), or make it a separate study")
        seen[key] = c.name


def _check_existing(c: Cell) -> None:
    """Refuse a cell folder whose config.yaml is not this cell's (the study file or out_dir changed);
    what does not count as a change: :func:`swim_jax.config.first_difference` (a raised total_steps
    among them: the cell resumes to it)."""
    if not started(c):
        return
    diff = cfgmod.first_difference(c.cfg, c.run_dir)
    if diff:
        k, recorded, wanted = diff
        hint = ("; a budget can only grow" if k == "total_steps" else "")
        raise StudyError(f"cell {c.name}: {os.path.join(c.run_dir, 'config.yaml')} was started with {k}={recorded!r}, "
                         f"the study now gives {k}={wanted!r}{hint}; restore the study file or use another --out-dir")


# ------------------------------------------------------------------------------------------------
# the state of a cell
# ------------------------------------------------------------------------------------------------

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


def _last_evaluation(run_dir: str) -> tuple[int, float, float] | None:
    path = os.path.join(run_dir, "evaluations.csv")
    if not os.path.isfile(path):
        return None
    with open(path) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return None
    r = rows[-1]
    return int(r["step"]), float(r["mean"]), float(r["std"])


def _is_done(c: Cell) -> bool:
    last = _last_evaluation(c.run_dir)
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
    done = _is_done(c)
    last = _last_evaluation(c.run_dir)
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


def _recorded_backend(c: Cell) -> Config:
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
        if _is_done(c):
            log(f"{c.name}: done; skipped")
            return 0
        with logged_to_file(c.run_dir, log) as log_both:
            return _train_cell(c, log_both)


def _train_cell(c: Cell, log: Callable[[str], None]) -> int:
    """:func:`run_cell`'s training, the lock held: resume ``c`` when started, else start it."""
    from swim_jax.run import train

    resume = started(c)
    log(f"{c.name}: {'resuming' if resume else 'starting'} in {c.run_dir}")
    cfg = _recorded_backend(c) if resume else c.cfg
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


# ------------------------------------------------------------------------------------------------
# report and SLURM
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


def started(c: Cell) -> bool:
    """Whether cell ``c`` has a run folder with its config.yaml (its run has started)."""
    return os.path.isfile(os.path.join(c.run_dir, "config.yaml"))


def _reached(c: Cell, step: int) -> bool:
    """Whether cell ``c`` has evaluated at ``step`` (or beyond)."""
    last = _last_evaluation(c.run_dir)
    return last is not None and last[0] >= step


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
        states = [dataclasses.replace(s, state="done") if _reached(s.cell, at_step) else s for s in states]
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
        if not _is_done(copy):
            last = _last_evaluation(copy.run_dir)
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
