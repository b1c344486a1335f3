"""Train an agent (TD3, or ``agent.kind=sac``) on every seed at once: ``python -m swim_jax.train config=walker_swim [key=value ...]``.

    python -m swim_jax.train config=cheetah_swim seeds=5 total_steps=200000 precision=float64
    python -m swim_jax.train --resume runs/cheetah_swim-20260101-120000     (or resume=<dir>)

The jitted program (swim_jax/agents/loop.py) runs ``eval_freq`` env steps (with their updates) for all seeds
per call; this module only loops over those chunks: evaluation (step 0 and after every chunk, so
1 + total_steps/eval_freq evaluations, like the original TD3 code), progress line, checkpoint.

Outputs in ``<out_dir>/<name>-<UTC timestamp>/``:
  config.yaml                  the resolved config (what ``--resume`` reloads)
  evaluations.csv              step, seed_<i> (mean return of the eval episodes), mean, std
  evaluations.npy              [n_evals, seeds] mean returns; evaluations_seed<i>.npy: [n_evals];
                               evaluation_steps.npy: [n_evals] their steps (swim_jax/io/schedule.py)
  evaluations_episodes.npy     [n_evals, seeds, eval_episodes] every episode's return
  timing.json                  wall time, env-steps/s (aggregate and per seed), compile counts
  checkpoints/<step>/          orbax: the whole training state (last ``keep_checkpoints``)
  final_policy.npz             actor parameters, leading axis = seed
  metrics.csv                  per chunk and seed: updates, critic/actor loss, mean Q, episodes, last
                               training episode's return (swim_jax/io/learning_log.py)
  tensorboard/seed_<i>/        with ``tensorboard=true``: metrics.csv's scalars and the evaluation
                               returns as TensorBoard event files (swim_jax/io/tensorboard_log.py)
  activation_params.csv        learnable k/beta per layer, seed and evaluation (learnable runs)
  point.json                   sweep points only: the point's label and swept values
  provenance.json              one entry per start/resume: git commit and dirty flag, package
                               versions, CPU model, command line (swim_jax/io/provenance.py)

A sweep (``python -m swim_jax.sweep``, config key ``sweep``) trains every grid point × seed as a
lane of the same program; the run folder then holds ``sweep.csv`` (one row per point) and, per
point, ``points/<label>/`` with the files above (its config.yaml is the point's plain config, so
``swim_jax.analysis.report`` and ``swim_jax.run.render`` read a point like any run). Checkpoints stay at the top.

Modules: swim_jax/run/programs.py builds the jitted program and its per-lane inputs (cached per
process), swim_jax/run/outputs.py writes the run folder's files, swim_jax/run/progress.py keeps
the clock and writes the progress line, and this module runs the loop (:func:`run`) and the
command line.

Several processes or hosts (``--coordinator host:port --num-processes N --process-id i``, or the
``JAX_*``/SLURM environment; swim_jax/placement/distributed.py, docs/DISTRIBUTED.md) split the lanes over all
their devices; process 0 prints and writes the run folder, every process writes its checkpoint part.

Exit status: 0 done; 2 bad command line/config (one line on stderr, nothing written);
3 NaN/inf detected (message names seed, step and quantity; last good checkpoint kept);
4 several processes: another process was lost (one line; resume from the checkpoint it names).
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from dataclasses import dataclass
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from swim_jax.agents import registry
from swim_jax import config as cfgmod
from swim_jax.placement import distributed, local_processes
from swim_jax.io import learning_log, provenance
from swim_jax.run import outputs
from swim_jax.io.checkpoint import Checkpointer, latest_complete_step
from swim_jax.io.cli_parser import counted
from swim_jax.config import Config, ConfigError
from swim_jax.placement.distributed import to_host
from swim_jax.run.heartbeat import Heartbeat, fmt_duration
from swim_jax.run.progress import Clock, chunks_left, progress_line
from swim_jax.io.replay_store import DIRNAME as REPLAY_DIR
from swim_jax.io.replay_store import ReplayStore
from swim_jax.run.programs import Lanes, Programs, auto_host_devices, backends_started, lanes as program_lanes, matmul_dtype, physics_backend, placement, programs, stepper as program_stepper, use_compilation_cache, with_physics_backend
from swim_jax.placement.layout import LaneLayout
from swim_jax.placement.sharding import place, set_host_devices

USAGE = (
    "usage: python -m swim_jax.train config=<name> [key=value ...]   (sweeps: python -m swim_jax.sweep)\n"
    "       python -m swim_jax.train --resume <run dir>\n"
    "several processes (every one runs the same command; docs/DISTRIBUTED.md):\n"
    "       ... --coordinator <host:port> --num-processes <N> --process-id <0..N-1>"
)


class NonFiniteError(RuntimeError):
    """Training produced NaN/inf; the message names seed, step and quantity."""


@dataclass
class RunResult:
    """What a finished (or resumed) run produced, for callers and tests."""

    run_dir: str
    evaluations: np.ndarray  # [n_evals, seeds, episodes]
    final_actor: dict  # actor params, leading lane axis: sweep points × seeds (numpy)
    states: object  # final TrainState (device arrays)
    chunk_fn: object  # the jitted chunk (inspect ``_cache_size()``)
    eval_fn: object
    timing: dict


# ------------------------------------------------------------------------------------------------
# the run
# ------------------------------------------------------------------------------------------------

def run(cfg: Config, run_dir: str, resume: bool = False, log: Callable[[str], None] = print,
        status: Callable[[str], None] | None = None) -> RunResult:
    """Train all seeds of ``cfg`` writing into ``run_dir`` (created); continue from the newest
    checkpoint there when ``resume``. Raises NonFiniteError on NaN/inf (no checkpoint written).
    ``log`` gets one line per evaluation chunk; ``status`` (if given) what happens before and
    between them (building, compiling, in-chunk progress), each with the elapsed time.

    Sets ``jax_enable_x64`` for the run (float64 iff ``precision=float64``) and restores the
    previous value when it returns, so in-process callers (tests) keep their own setting.

    In a process whose JAX has not started yet, asks for ``host_devices`` host CPU devices, or with
    ``lane_groups=true`` for one per core (``programs.auto_host_devices``)."""
    host_devices = cfg.host_devices or auto_host_devices(cfg)
    if host_devices and not backends_started():
        set_host_devices(host_devices)  # read when JAX starts its backends (importing it does not)
    if cfg.compilation_cache:
        use_compilation_cache()
    previous_x64 = bool(jax.config.jax_enable_x64)
    t_start = time.time()
    stamped = (lambda m: status(f"[{_fmt_time(time.time() - t_start)}] {m}")) if status else (lambda m: None)
    # every line goes through the heartbeat, which prints one itself after PROGRESS_EVERY_S of silence
    # (its thread looks once a second: speaking after 29 s of silence keeps lines <= 30 s apart)
    beat = Heartbeat(stamped, PROGRESS_EVERY_S - 1.0 if status else 0.0)
    physics_why = physics_backend(cfg)[1]
    cfg = with_physics_backend(cfg)  # env.backend=auto chosen now; config.yaml records the choice
    try:
        # traced (compiled) under the matmul precision; ``closing`` closes the run's open files
        with jax.default_matmul_precision(cfg.matmul_precision), contextlib.ExitStack() as closing, beat:
            return _run(cfg, run_dir, resume, lambda line: beat.say(line, out=log), beat, closing, physics_why)
    finally:
        jax.config.update("jax_enable_x64", previous_x64)


def resolved_matmul_dtype(prog) -> str:
    """The dtype the program's Dense products run in ("bfloat16", or the run's precision): the
    config's ``matmul_dtype`` as a dtype name; recorded in timing.json and each stretch's
    provenance entry (``swim_jax.io.provenance.recorded_matmul_dtypes``)."""
    return jnp.dtype(prog.agent.matmul_dtype or prog.agent.dtype).name


def _run(cfg: Config, run_dir: str, resume: bool, log: Callable[[str], None],
         say: Heartbeat, closing: contextlib.ExitStack, physics_why: str = "") -> RunResult:
    """The training loop: build the program, start (from the newest checkpoint when resuming),
    then per chunk of ``eval_freq`` steps: train, stop on NaN/inf, evaluate, log, checkpoint,
    write the evaluations and ``log`` a progress line; finally the final policy and timing."""
    clock = Clock(time.time())
    say(f"building {cfg.env.id} ({cfg.env.backend} physics: {physics_why}; {cfg.precision}) and the "
        f"{cfg.agent.kind.upper()} program for "
        f"{LaneLayout.of(cfg).count} lanes; {matmul_dtype(cfg)[1]}")
    sharding, groups = placement(cfg, log)
    prog = programs(cfg, sharding)
    native = prog.env.native_physics
    if native is not None:
        say(f"native physics: MuJoCo C through {'an XLA FFI call' if native.call == 'ffi' else 'Python callbacks'} "
            f"({native.call_reason})")
    lanes = program_lanes(cfg, prog, sharding, groups)
    stepper = program_stepper(cfg, prog, sharding, groups)  # one program or lane groups, chosen once
    folder = outputs.RunFolder(cfg, run_dir, lanes.layout, writes=distributed.is_writer())
    layout = lanes.layout
    folder.create(fresh=not resume)
    if resume:
        grown_from = folder.grow_budget()  # a larger total_steps than the folder's: config.yaml says so now
        if grown_from is not None:
            log(f"budget grown: total_steps {grown_from} -> {cfg.total_steps} (config.yaml rewritten; "
                "the run continues as one started with the larger budget)")
    ckpt = Checkpointer(os.path.join(run_dir, "checkpoints"), keep=cfg.keep_checkpoints)
    store = ReplayStore(os.path.join(run_dir, "checkpoints", REPLAY_DIR), cfg.replay_size)
    evals = _Evaluations(cfg, prog, lanes)
    restored = ckpt.latest_step() if resume else None  # continue after the newest checkpoint, if any
    if restored is not None:
        states = _restore(ckpt, store, restored, prog, lanes, evals)
        log(f"resumed {run_dir} at step {restored}")
    folder.start_logs(restored, closing)  # cut after that checkpoint, or (none) started afresh
    if folder.writes:
        products = resolved_matmul_dtype(prog)
        before = provenance.recorded_matmul_dtypes(run_dir)
        if before and before[-1] != products:  # (not since matmul_dtype=auto went: resume_config reads it)
            log(f"warning: this stretch multiplies in {products}, the run's last one in {before[-1]} "
                "(provenance.json records each stretch)")
        provenance.record(run_dir, restored or 0, facts={"matmul_dtype": products})  # code, packages, CPU, command
    if restored is None:
        states = _initial_states(cfg, prog, lanes, folder, evals, say)
        if resume:
            log(f"no checkpoint in {run_dir}; starting from step 0")
    plan = cfgmod.schedule(cfg)
    start = 0 if restored is None else plan.chunk_of_step(restored)
    folder.evaluations(evals.returns, start + 1)
    n_chunks = plan.n_chunks
    if start < n_chunks:  # (said before the split: with lane groups, splitting compiles their executables)
        say(f"compiling the training program and running its first {cfg.eval_freq} steps "
            f"(compiles take seconds to minutes on a CPU; cached for the next run)")
    # training goes on from the stepper's parts; ``states`` is their joined copy after each chunk
    # (with lane groups splitting compiles the groups' executables)
    parts = stepper.split(states, lanes.sweep_args) if start < n_chunks else None
    for c in range(start, n_chunks):
        t0 = time.time()
        states = None  # (with lane groups, the previous chunk's joined copy goes before the next is made)
        parts, metrics = train_chunk(cfg, stepper, parts, c, say, beat=say)
        states = stepper.join(parts)
        bad = to_host(states.bad_step)  # waits for the chunk
        dt = clock.trained(time.time() - t0, cfg.eval_freq)
        step = plan.eval_step(c + 1)
        _stop_if_non_finite(layout, bad[: layout.real], ckpt, run_dir, prog.agent.CHECKED)
        say.doing(f"evaluating at step {step} ({cfg.eval_episodes} episodes per lane)")
        folder.evaluation(c + 1, evals.run(states, c + 1), states.agent)
        folder.chunk(step, metrics, to_host(states.episodes), to_host(states.last_return))
        say.doing(f"writing the checkpoint at step {step}")
        _save(ckpt, store, step, cfg.eval_freq, states, evals)
        folder.evaluations(evals.returns, c + 2)
        clock.iteration_done(time.time() - t0, learning=step > cfg.learning_starts, first=c == start)
        log(progress_line(cfg, layout, step, evals.returns[c + 1, : layout.real], dt, c == start,
                          clock.elapsed(), clock.eta(*chunks_left(cfg, c + 1)), metrics,
                          prog.agent.matmul_dtype is not None))
    final_actor = outputs.flat_params(jax.tree.map(lambda x: x[: layout.real], to_host(states.agent.actor)))
    folder.final_policy(final_actor)
    timing = _timing(cfg, prog, lanes, evals, clock, start if resume else None, stepper)
    folder.timing(timing)
    ckpt.close()
    return RunResult(run_dir, evals.returns[:, : layout.real], final_actor, states, prog.chunk_fn,
                     prog.eval_fn, timing)


def _without_replay(states):
    """``states`` with the replay buffer's arrays replaced by zero-size ones (not checkpointed by
    orbax: swim_jax/io/replay_store.py keeps them); works on arrays and ShapeDtypeStructs."""
    empty = jax.tree.map(lambda a: np.zeros((0,), a.dtype), states.buffer.data)
    return states._replace(buffer=states.buffer._replace(data=empty))


def _save(ckpt: Checkpointer, store: ReplayStore, step: int, eval_freq: int, states, evals: _Evaluations) -> None:
    """Checkpoint ``step``: the chunk's new transitions appended to the replay store (each written
    once), then the rest of the training state and the evaluations as an orbax checkpoint, then
    the segments no kept checkpoint needs deleted."""
    n0, n1 = store.new_range(step - eval_freq, step)
    slots = jnp.asarray(store.slots(n0, n1))
    new = to_host(jax.tree.map(lambda a: a[:, slots], states.buffer.data))  # (a collective)
    if distributed.is_writer():
        store.append(n0, n1, new._asdict())
    ckpt.save(step, (_without_replay(states), evals.saved()))
    if distributed.is_writer():
        store.prune(ckpt.all_steps())


def _restore(ckpt: Checkpointer, store: ReplayStore, step: int, prog: Programs, lanes: Lanes, evals: _Evaluations):
    """The training state of the checkpoint at ``step``; its evaluations go into ``evals``. The
    replay buffer comes from the replay store, or, for a checkpoint written before it existed
    (the whole buffer inside), from the checkpoint itself."""
    full = jax.eval_shape(prog.init_fn, *lanes.init_args)
    # the evaluations as saved: a run whose budget grew since has fewer rows than ``evals`` now
    saved_shape = ckpt.stored_shapes(step, (full, evals.saved()))[-1]
    saved_evals = np.zeros(saved_shape, evals.saved().dtype)
    if saved_shape[0] > evals.returns.shape[0] or saved_shape[1:] != evals.returns.shape[1:]:
        raise ConfigError(f"checkpoint {step} holds evaluations {saved_shape}, this run's budget "
                          f"{evals.returns.shape}: a budget can only grow")
    whole = ckpt.holds(step, (full, saved_evals))
    template = ((full if whole else _without_replay(full)), saved_evals)
    shardings = None
    if lanes.sharding is not None:  # the lanes straight onto their devices; the evaluations whole on each
        everywhere = jax.sharding.NamedSharding(lanes.sharding.mesh, jax.sharding.PartitionSpec())
        shardings = (jax.tree.map(lambda _: lanes.sharding, template[0]), everywhere)
    states, saved_evals = ckpt.restore(step, template, shardings)
    evals.returns[: saved_shape[0]] = to_host(saved_evals)
    if not whole:
        like = {k: (a.shape, a.dtype) for k, a in full.buffer.data._asdict().items()}
        host = store.rebuild(step, like)

        def put(x):
            if lanes.sharding is None:
                return jnp.asarray(x)
            return jax.make_array_from_callback(x.shape, lanes.sharding, lambda index: x[index])

        data = type(full.buffer.data)(**{k: put(v) for k, v in host.items()})
        states = states._replace(buffer=states.buffer._replace(data=data))
    return place(states, lanes.sharding)


def _initial_states(cfg: Config, prog: Programs, lanes: Lanes, folder: outputs.RunFolder,
                    evals: _Evaluations, say: Callable[[str], None]):
    """A fresh training state, its evaluation 0 computed and logged."""
    states = place(prog.init_fn(*lanes.init_args), lanes.sharding)
    say(f"compiling the evaluation program; evaluating the initial policies ({cfg.eval_episodes} episodes per lane)")
    folder.evaluation(0, evals.run(states, 0), states.agent)
    return states


class _Evaluations:
    """Every evaluation's returns ``[n_evals, lanes, episodes]`` (float64, nan until computed) and
    the seconds spent computing them."""

    def __init__(self, cfg: Config, prog: Programs, lanes: Lanes):
        n_evals = cfgmod.schedule(cfg).n_evals  # step 0 and after every chunk
        self.returns = np.full((n_evals, lanes.count, cfg.eval_episodes), np.nan)
        self.seconds = 0.0
        self._eval_fn, self._sweep_args = prog.eval_fn, lanes.sweep_args
        self._dtype = prog.agent.dtype

    def run(self, states, j: int) -> np.ndarray:
        """Evaluation ``j`` of ``states``' actors: its row of :attr:`returns`."""
        t0 = time.time()
        r = self._eval_fn(states.agent.actor, states.eval_key, jnp.asarray(j, jnp.int32), *self._sweep_args)
        self.returns[j] = to_host(r)
        self.seconds += time.time() - t0
        return self.returns[j]

    def saved(self) -> np.ndarray:
        """:attr:`returns` as checkpointed: in the compute dtype (exact: every return was computed
        in it), the same on every process."""
        return self.returns.astype(self._dtype)


def _timing(cfg: Config, prog: Programs, lanes: Lanes, evals: _Evaluations, clock: Clock,
            resumed_from_chunk: int | None, stepper) -> dict:
    """``timing.json``: wall time, throughput (aggregate and per lane), compile counts
    (``chunk_compiles``: the stepper's executables; lane groups make all of theirs before the first
    call, ``chunk_executables_copied`` of them as copies of another device's instead of compiling)."""
    P, S = len(lanes.layout.points), lanes.layout.seeds
    train_s = clock.train_s
    return {
        "wall_time_s": clock.elapsed(),
        "train_time_s_excluding_first_chunk": train_s,
        "first_chunk_s_including_compile": clock.first_chunk_s,
        "eval_time_s": evals.seconds,
        "env_steps_per_s": (clock.steps_timed * P * S / train_s) if train_s > 0 else None,
        "env_steps_per_s_per_seed": (clock.steps_timed / train_s) if train_s > 0 else None,
        "seeds": S,
        "sweep_points": P,
        "lanes": lanes.count,
        "total_steps": cfg.total_steps,
        "resumed_from_chunk": resumed_from_chunk,
        "chunk_compiles": stepper.executables,
        "chunk_executables_copied": stepper.copied,
        "eval_compiles": prog.eval_fn._cache_size(),
        "platform": jax.devices()[0].platform,
        "devices": stepper.devices,
        "lane_groups": stepper.lane_groups,
        "processes": jax.process_count(),
        "matmul_dtype": resolved_matmul_dtype(prog),
        "native_call": prog.env.native_physics.call if prog.env.native_physics is not None else None,
    }


def _stop_if_non_finite(layout: LaneLayout, bad_step: np.ndarray, ckpt: Checkpointer, run_dir: str,
                        checked: tuple[str, ...]) -> None:
    """Raise :class:`NonFiniteError` naming the earliest NaN/inf in ``bad_step[real lanes, checked]``
    (``checked``: the agent's ``CHECKED``)."""
    hit = _first_bad(bad_step, checked)
    if hit is None:
        return
    lane, st, q = hit
    where = layout.where(lane)
    last = ckpt.latest_step()
    raise NonFiniteError(
        f"non-finite {q} in {where} at step {st}; stopped "
        f"(last good checkpoint: {'none' if last is None else f'step {last}'} in {run_dir}/checkpoints)"
    )


def _first_bad(bad_step: np.ndarray, checked: tuple[str, ...] = registry.get(registry.DEFAULT_KIND).CHECKED):
    """(seed position, step, quantity of ``checked``, the agent's ``CHECKED``) of the earliest
    non-finite event, or None."""
    bad = np.where(bad_step < 0, np.iinfo(np.int64).max, bad_step.astype(np.int64))
    if bad.min() == np.iinfo(np.int64).max:
        return None
    s, q = np.unravel_index(np.argmin(bad), bad.shape)
    return int(s), int(bad[s, q]), checked[q]


PROGRESS_EVERY_S = 30.0


def train_chunk(cfg: Config, stepper, parts, c: int, say, beat: Heartbeat | None = None):
    """Chunk ``c`` (``eval_freq`` steps) of ``parts`` (from ``stepper.split``) as calls of
    ``steps_per_call(cfg)`` steps each, made by ``stepper`` (swim_jax/placement/stepping.py).
    With ``beat`` (the run's :class:`~swim_jax.run.heartbeat.Heartbeat`) each call is waited for and
    named as the run's activity, and after a call, once ``PROGRESS_EVERY_S`` seconds passed since
    the run's last line, ``say`` gets the step, env-steps/s and the time to the chunk's evaluation
    (the heartbeat speaks while a call runs longer than that).
    Returns (parts, the chunk's per-lane learning metrics, ``learning_log.combine``)."""
    per_call = cfgmod.steps_per_call(cfg)
    calls = cfg.eval_freq // per_call
    t0 = time.time()
    metrics = []
    so_far = ""
    for j in range(calls):
        t = c * cfg.eval_freq + j * per_call
        if beat is not None:
            beat.doing(f"training steps {t}-{t + per_call} of {cfg.total_steps}{so_far}")
        parts, m = stepper.step(parts, t)
        metrics.append(m)
        if beat is None or j + 1 == calls:
            continue
        # wait for the call (cheap: a few ints), so the step and the rate are the real ones
        stepper.ready(parts)
        done = (j + 1) * per_call
        rate = done / (time.time() - t0)
        progress = (f"{rate * LaneLayout.of(cfg).real:.0f} env-steps/s in this chunk, "
                    f"evaluation in {_fmt_time((cfg.eval_freq - done) / rate)}")
        so_far = f" ({progress} at step {t + per_call})"  # what a heartbeat line during the next call says
        if time.monotonic() - beat.last_line >= PROGRESS_EVERY_S:
            say(f"step {t + per_call}/{cfg.total_steps}: {progress}")
    metrics = [stepper.join_metrics(to_host(m), _merge_pieces) for m in metrics]
    return parts, learning_log.combine(to_host(metrics))


def _merge_pieces(pieces: list):
    """The metrics of one call made of consecutive ``pieces`` (host ``ChunkMetrics`` of the agent)."""
    return type(pieces[0])(**learning_log.combine(pieces))


_fmt_time = fmt_duration  # h:mm:ss, "?" when not finite (swim_jax/run/heartbeat.py)


# ------------------------------------------------------------------------------------------------
# command line
# ------------------------------------------------------------------------------------------------

def parse_args(argv: list[str]) -> tuple[Config, str | None]:
    """(config, resume dir or None) from the command line; ConfigError on any problem."""
    config_name, resume, overrides = None, None, []
    it = iter(argv)
    for tok in it:
        if tok in ("-h", "--help"):  # usage on stdout, exit status 0, as argparse does
            print(USAGE)
            raise SystemExit(0)
        if tok == "--resume":
            resume = next(it, None)
            if resume is None:
                raise ConfigError("--resume needs a run directory")
        elif tok.startswith("--resume="):
            resume = tok.split("=", 1)[1]
        elif tok.startswith("config="):
            config_name = tok.split("=", 1)[1]
        elif tok.startswith("resume="):
            resume = tok.split("=", 1)[1]
        elif tok.startswith("-") or "=" not in tok:
            raise ConfigError(f"unexpected argument {tok!r}; expected config=<name>, key=value or --resume <dir>")
        else:
            overrides.append(tok)
    if resume is not None:
        if config_name is not None:
            raise ConfigError("--resume takes no config= (the run's config.yaml is used; the one override it "
                              "takes is total_steps=N, a larger budget)")
        return resume_config(resume, overrides), resume
    if config_name is None:
        raise ConfigError(f"missing config=<name>; valid configs: {', '.join(cfgmod.available_configs())}")
    return cfgmod.resolve(config_name, overrides), None


def resume_config(run_dir: str, overrides: list[str] = ()) -> Config:
    """The config a resume of ``run_dir`` trains with: its config.yaml, where an old ``matmul_dtype:
    auto`` reads as what the run multiplied in (``provenance.config_matmul_dtype``), and
    ``overrides``, which may only be ``total_steps=N`` with N at least the run's budget (the run
    continues to N, as a run started with N would have: :func:`run` grows the folder's budget).
    Anything else: :class:`ConfigError` (one line)."""
    path = os.path.join(run_dir, "config.yaml")
    if not os.path.isfile(path):
        raise ConfigError(f"cannot resume: {path} not found")
    other = [o for o in overrides if o.split("=", 1)[0] != "total_steps"]
    if other:
        raise ConfigError(f"--resume takes only total_steps=N (a larger budget), not {other[0]!r}: a run "
                          f"continues with the config it started with ({path})")
    _, recorded = cfgmod.read_run_config(run_dir)
    _, cfg = cfgmod.read_run_config(run_dir, overrides)
    if cfg.total_steps < recorded.total_steps:
        raise ConfigError(f"total_steps={cfg.total_steps} is below the run's total_steps={recorded.total_steps} "
                          f"({path}); a resume can only keep or grow the budget")
    return cfg


def main(argv: list[str] | None = None, require_sweep: bool = False) -> int:
    """The command line of ``swim_jax.run.train`` (and, with ``require_sweep``, of ``swim_jax.sweep``);
    with several processes (swim_jax/placement/distributed.py) every process runs it, process 0 prints."""
    command = sys.argv[1:] if argv is None else argv
    try:
        flags, argv = distributed.pop_flags(command)
        launch = distributed.launch_from(flags)
        cfg, resume = parse_args(argv)
        if require_sweep and not cfg.sweep:
            raise ConfigError("no sweep axis given; add e.g. sweep.agent.activation.k=[0.25,0.5,1,2] "
                              f"(sweepable keys: {', '.join(cfgmod.sweepable_keys(cfg))})")
        spawn = cfg.local_processes > 1 and not launch.multi  # (the spawned processes are launch.multi)
        if spawn:
            local_processes.check(cfg, LaneLayout.of(cfg).count)
    except ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if spawn:
        return local_processes.spawn("swim_jax.sweep" if require_sweep else "swim_jax.train", command,
                                     cfg.local_processes)
    host_devices = cfg.host_devices or (0 if launch.multi else auto_host_devices(cfg))
    if host_devices and not backends_started():
        set_host_devices(host_devices)  # before the backends start (joining the processes starts them)
    try:
        distributed.start(launch)
    except RuntimeError as e:
        print(f"error: {e}", file=sys.stderr, flush=True)
        return distributed.EXIT_LOST_PROCESS
    run_dir = resume if resume else distributed.broadcast_text(outputs.new_run_dir(cfg))
    say = (lambda s: print(s, flush=True)) if distributed.is_writer() else (lambda s: None)
    say(f"run dir: {run_dir}")
    if launch.multi and not distributed.is_writer():
        print(f"process {launch.index} of {launch.count} ({launch.source}): stepping its lanes; "
              f"process 0 prints the progress and writes {run_dir}", flush=True)
    try:
        res = run(cfg, run_dir, resume=resume is not None, log=say, status=say)
    except NonFiniteError as e:
        print(f"error: {e}", file=sys.stderr, flush=True)
        return 3
    except ConfigError as e:  # what needs the devices to check (lanes over several processes)
        print(f"error: {e}", file=sys.stderr, flush=True)
        return 2
    except Exception as e:  # noqa: BLE001 - a lost process, or this one failing: stop them all
        if launch.multi:
            distributed.stop(e, run_dir, latest_complete_step(os.path.join(run_dir, "checkpoints")))
        raise
    t = res.timing
    rate = t["env_steps_per_s"]
    over = f"{t['lanes']} lanes (points × seeds)" if cfg.sweep else counted(cfg.seeds, "seed")
    say(f"done in {_fmt_time(t['wall_time_s'])}; {'%.0f' % rate if rate else '?'} env-steps/s over {over}; "
        f"outputs in {run_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
