"""Train TD3 on every seed at once: ``python -m swim_jax.train config=walker_swim [key=value ...]``.

    python -m swim_jax.train config=cheetah_swim seeds=5 total_steps=200000 precision=float64
    python -m swim_jax.train --resume runs/cheetah_swim-20260101-120000     (or resume=<dir>)

The jitted program (agents/loop.py) runs ``eval_freq`` env steps (with their updates) for all seeds
per call; this module only loops over those chunks: evaluation (step 0 and after every chunk, so
1 + total_steps/eval_freq evaluations, like the original TD3 code), progress line, checkpoint.

Outputs in ``<out_dir>/<name>-<UTC timestamp>/``:
  config.yaml                  the resolved config (what ``--resume`` reloads)
  evaluations.csv              step, seed_<i> (mean return of the eval episodes), mean, std
  evaluations.npy              [n_evals, seeds] mean returns; evaluations_seed<i>.npy: [n_evals]
  evaluations_episodes.npy     [n_evals, seeds, eval_episodes] every episode's return
  timing.json                  wall time, env-steps/s (aggregate and per seed), compile counts
  checkpoints/<step>/          orbax: the whole training state (last ``keep_checkpoints``)
  final_policy.npz             actor parameters, leading axis = seed
  metrics.csv                  per chunk and seed: updates, critic/actor loss, mean Q, episodes, last
                               training episode's return (swim_jax/learning_log.py)
  tensorboard/seed_<i>/        with ``tensorboard=true``: metrics.csv's scalars and the evaluation
                               returns as TensorBoard event files (swim_jax/tensorboard_log.py)
  activation_params.csv        learnable k/beta per layer, seed and evaluation (learnable runs)
  point.json                   sweep points only: the point's label and swept values

A sweep (``python -m swim_jax.sweep``, config key ``sweep``) trains every grid point × seed as a
lane of the same program; the run folder then holds ``sweep.csv`` (one row per point) and, per
point, ``points/<label>/`` with the files above (its config.yaml is the point's plain config, so
``swim_jax.report`` and ``swim_jax.render`` read a point like any run). Checkpoints stay at the top.

Exit status: 0 done; 2 bad command line/config (one line on stderr, nothing written);
3 NaN/inf detected (message names seed, step and quantity; last good checkpoint kept).
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np
import yaml
from jax._src import xla_bridge

import envs
from agents import loop
from agents.loop import CHECKED
from agents.td3 import TD3
from swim_jax import config as cfgmod
from swim_jax import learned_params, learning_log, tensorboard_log
from swim_jax.checkpoint import Checkpointer
from swim_jax.config import Config, ConfigError
from swim_jax.sharding import lane_sharding, place, set_host_devices

USAGE = (
    "usage: python -m swim_jax.train config=<name> [key=value ...]   (sweeps: python -m swim_jax.sweep)\n"
    "       python -m swim_jax.train --resume <run dir>"
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
# setup
# ------------------------------------------------------------------------------------------------

def _setup_precision(cfg: Config) -> None:
    jax.config.update("jax_enable_x64", cfg.precision == "float64")


def build(cfg: Config):
    """(env, eval env, agent) for a validated config, in the configured precision."""
    _setup_precision(cfg)
    env = envs.make(cfg.env.id, max_episode_steps=cfg.env.max_episode_steps, backend=cfg.env.backend)
    eval_env = envs.make(cfg.env.id, max_episode_steps=cfg.env.max_episode_steps, backend=cfg.env.backend)
    dtype = jnp.float64 if cfg.precision == "float64" else jnp.float32
    agent = TD3(
        cfg.agent,
        env.observation_size,
        tuple(float(x) for x in np.asarray(env.action_low)),
        tuple(float(x) for x in np.asarray(env.action_high)),
        dtype=dtype,
        matmul_dtype=jnp.bfloat16 if cfg.matmul_dtype == "bfloat16" else None,
    )
    return env, eval_env, agent


@dataclass
class Programs:
    """The jitted functions of one training program (see agents/loop.py)."""

    env: object
    eval_env: object
    agent: object
    init_fn: object  # (base_seed uint32, seed_ids int32[L][, hparams {path: [L]}]) -> TrainState[L]
    chunk_fn: object  # (TrainState[L], t0 int32[, hparams]) -> TrainState[L] after steps_per_call(cfg) steps; donated
    eval_fn: object  # (actor[L], eval_keys[L], eval_index int32[, hparams]) -> returns[L, E]


_PROGRAMS: dict = {}


def num_lanes(cfg: Config) -> int:
    """Width of the vmapped lane axis: sweep points × ``seeds``, or 2 for a padded single-lane run.

    Why pad: with a unit vmap axis XLA CPU simplifies the batched MJX physics differently, which
    changes float rounding (~1e-5 after ~10 steps), so seed i alone would drift from seed i in a
    multi-seed run. Lanes ≥ 2 compute each seed bit-identically (tests/test_train.py)."""
    real = len(cfgmod.sweep_points(cfg)) * cfg.seeds
    return 2 if real == 1 and cfg.pad_single_seed else real


def lane_inputs(cfg: Config, dtype) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(seed index per lane int32[L], sweep values per lane ``{agent path: [L]}``).

    Lane ``p·seeds + s`` is seed ``first_seed + s`` of sweep point ``p`` (every point sees the
    same seeds); a padded lane repeats lane 0. Paths drop the ``agent.`` prefix
    (``activation.k``), as ``TD3.with_hparams`` takes them."""
    lanes = num_lanes(cfg)
    points = cfgmod.sweep_points(cfg)
    seeds = np.arange(cfg.first_seed, cfg.first_seed + cfg.seeds)
    seed_ids = np.resize(np.tile(seeds, len(points)), lanes).astype(np.int32)
    hparams = {
        key.split(".", 1)[1]: np.resize(np.repeat([p[key] for p in points], cfg.seeds), lanes).astype(dtype)
        for key in cfg.sweep
    }
    return seed_ids, hparams


def chunk_compiler_options(cfg: Config) -> dict:
    """XLA options of the training chunk: on a CPU backend, XLA's YNNPACK library fusions are
    switched off unless ``cfg.xla_cpu_ynn_fusions`` (measured faster without them; config.py)."""
    if cfg.xla_cpu_ynn_fusions or jax.default_backend() != "cpu":
        return {}
    return {"xla_cpu_experimental_ynn_fusion_type": ""}


def programs(cfg: Config) -> Programs:
    """Build (or reuse, within this process) the env, agent and jitted functions for ``cfg``.

    The compiled program depends only on the fields in the cache key, not on seeds' identities,
    total_steps or outputs, so e.g. a resumed or re-run config in the same process compiles nothing."""
    _setup_precision(cfg)
    # every config field that changes the built program (seeds only change the lane shapes)
    key = (cfg.env, cfg.agent, cfg.learning_starts, cfgmod.steps_per_call(cfg), cfg.eval_episodes,
           cfg.replay_size, cfg.precision, cfg.matmul_dtype, cfg.matmul_precision, cfg.xla_cpu_ynn_fusions)
    if key not in _PROGRAMS:
        env, eval_env, agent = build(cfg)
        def init_lanes(base, seed_ids, hparams=None):
            return jax.vmap(lambda i, h: loop.init_state(agent, env, cfg.replay_size, base, i, h))(seed_ids, hparams)

        init_fn = jax.jit(init_lanes)
        chunk_fn = jax.jit(loop.make_chunk_fn(agent, env, cfg.learning_starts, cfgmod.steps_per_call(cfg)),
                           donate_argnums=0, compiler_options=chunk_compiler_options(cfg))
        eval_fn = jax.jit(loop.make_eval_fn(agent, eval_env, cfg.eval_episodes, cfg.env.max_episode_steps))
        _PROGRAMS[key] = Programs(env, eval_env, agent, init_fn, chunk_fn, eval_fn)
    return _PROGRAMS[key]


def new_run_dir(cfg: Config) -> str:
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
    base = os.path.join(cfg.out_dir, f"{cfg.name}-{stamp}")
    path, n = base, 1
    while os.path.exists(path):
        n += 1
        path = f"{base}-{n}"
    return path


def _fmt_time(sec: float) -> str:
    if not math.isfinite(sec):
        return "?"
    sec = int(round(sec))
    return f"{sec // 3600}:{sec % 3600 // 60:02d}:{sec % 60:02d}"


# ------------------------------------------------------------------------------------------------
# outputs
# ------------------------------------------------------------------------------------------------

def write_evaluations(run_dir: str, cfg: Config, evals: np.ndarray, n_done: int) -> None:
    """Write the first ``n_done`` evaluations of the real seeds (CSV + .npy), overwriting."""
    ev = evals[:n_done, : cfg.seeds]
    means = ev.mean(axis=2)  # [n, seeds]
    np.save(os.path.join(run_dir, "evaluations.npy"), means)
    np.save(os.path.join(run_dir, "evaluations_episodes.npy"), ev)
    for i in range(cfg.seeds):
        np.save(os.path.join(run_dir, f"evaluations_seed{cfg.first_seed + i}.npy"), means[:, i])
    with open(os.path.join(run_dir, "evaluations.csv"), "w") as f:
        cols = [f"seed_{cfg.first_seed + i}" for i in range(cfg.seeds)]
        f.write(",".join(["step", *cols, "mean", "std"]) + "\n")
        for j in range(n_done):
            row = [str(j * cfg.eval_freq), *(repr(float(x)) for x in means[j]),
                   repr(float(means[j].mean())), repr(float(means[j].std()))]
            f.write(",".join(row) + "\n")


def _flat_params(params) -> dict[str, np.ndarray]:
    """``{"params/body/dense_0/kernel": array, ...}``: the layout of ``final_policy.npz``."""
    return {
        "/".join(str(getattr(k, "key", k)) for k in kp): np.asarray(v)
        for kp, v in jax.tree_util.tree_flatten_with_path(params)[0]
    }


def _first_bad(bad_step: np.ndarray):
    """(seed position, step, quantity) of the earliest non-finite event, or None."""
    bad = np.where(bad_step < 0, np.iinfo(np.int64).max, bad_step.astype(np.int64))
    if bad.min() == np.iinfo(np.int64).max:
        return None
    s, q = np.unravel_index(np.argmin(bad), bad.shape)
    return int(s), int(bad[s, q]), CHECKED[q]


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
    previous value when it returns, so in-process callers (tests) keep their own setting."""
    if cfg.host_devices and not _backends_started():
        set_host_devices(cfg.host_devices)  # read when JAX starts its backends (importing it does not)
    if cfg.compilation_cache:
        use_compilation_cache()
    previous_x64 = bool(jax.config.jax_enable_x64)
    t_start = time.time()
    say = (lambda m: status(f"[{_fmt_time(time.time() - t_start)}] {m}")) if status else (lambda m: None)
    try:
        # traced (compiled) under the matmul precision; ``closing`` closes the run's open files
        with jax.default_matmul_precision(cfg.matmul_precision), contextlib.ExitStack() as closing:
            return _run(cfg, run_dir, resume, log, say, closing)
    finally:
        jax.config.update("jax_enable_x64", previous_x64)


def compilation_cache_dir() -> str:
    """``$XDG_CACHE_HOME/swim-jax/xla`` (default ``~/.cache/swim-jax/xla``)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "swim-jax", "xla")


def use_compilation_cache() -> str | None:
    """Turn on JAX's persistent compilation cache in :func:`compilation_cache_dir` unless
    ``SWIM_JAX_NO_COMPILATION_CACHE`` is set or a cache folder is already configured (e.g. by
    ``JAX_COMPILATION_CACHE_DIR``); returns the folder in use. Programs with host callbacks (the
    native physics backend) are not cached by JAX; they compile in seconds."""
    if os.environ.get("SWIM_JAX_NO_COMPILATION_CACHE"):
        return None
    if not jax.config.jax_compilation_cache_dir:
        jax.config.update("jax_compilation_cache_dir", compilation_cache_dir())
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
    return jax.config.jax_compilation_cache_dir


def _backends_started() -> bool:
    return bool(xla_bridge._backends)


def _run(cfg: Config, run_dir: str, resume: bool, log: Callable[[str], None],
         say: Callable[[str], None], closing: contextlib.ExitStack) -> RunResult:
    t_start = time.time()
    say(f"building {cfg.env.id} ({cfg.env.backend} physics, {cfg.precision}) and the TD3 program for "
        f"{num_lanes(cfg)} lanes")
    prog = programs(cfg)
    os.makedirs(run_dir, exist_ok=True)
    points = cfgmod.sweep_points(cfg)
    S, P = cfg.seeds, len(points)
    outputs = _point_outputs(cfg, run_dir, points)
    point_lanes = [slice(p * S, (p + 1) * S) for p in range(P)]  # lanes of point p
    if not resume:
        with open(os.path.join(run_dir, "config.yaml"), "w") as f:
            f.write(cfgmod.dump(cfg))
        for point, (out_dir, point_cfg) in zip(points, outputs):
            os.makedirs(out_dir, exist_ok=True)
            if out_dir != run_dir:
                with open(os.path.join(out_dir, "config.yaml"), "w") as f:
                    f.write(cfgmod.dump(point_cfg))
                with open(os.path.join(out_dir, "point.json"), "w") as f:
                    json.dump({"label": cfgmod.point_label(point), "values": point}, f, indent=1)

    n_chunks = cfg.total_steps // cfg.eval_freq
    n_evals = n_chunks + 1
    lanes = num_lanes(cfg)
    seed_ids_np, hparams_np = lane_inputs(cfg, prog.agent.dtype)
    seed_ids = jnp.asarray(seed_ids_np)
    hparams = {k: jnp.asarray(v) for k, v in hparams_np.items()}
    base_seed = jnp.asarray(cfg.seed, jnp.uint32)
    init_fn, chunk_fn, eval_fn = prog.init_fn, prog.chunk_fn, prog.eval_fn
    ckpt = Checkpointer(os.path.join(run_dir, "checkpoints"), keep=cfg.keep_checkpoints)
    logs_params = cfg.agent.activation.learnable
    if cfg.host_devices and jax.devices()[0].platform == "cpu" and jax.device_count() != cfg.host_devices:
        log(f"warning: host_devices={cfg.host_devices} but JAX started with {jax.device_count()} devices; "
            f"set XLA_FLAGS=--xla_force_host_platform_device_count={cfg.host_devices} before Python starts")
    sharding, how = lane_sharding(lanes) if cfg.shard_lanes else (None, "shard_lanes=false")
    if sharding is not None and cfg.env.backend == "mujoco":
        # XLA's SPMD partitioner places host callbacks on device 0 (gather, step, scatter every
        # step); the native physics already spreads lanes over cores in its own thread pool
        sharding, how = None, "env.backend=mujoco: lanes on one device (its thread pool spreads the physics)"
    if jax.device_count() > 1:
        log(f"lanes: {how}")
    hparams = place(hparams, sharding)
    sweep_args = (hparams,) if hparams else ()  # no sweep: the functions' 2-/4-argument signatures

    evals = np.full((n_evals, lanes, cfg.eval_episodes), np.nan)  # lanes >= points × seeds
    eval_time = 0.0

    def evaluate(states, j):
        nonlocal eval_time
        t0 = time.time()
        r = np.asarray(eval_fn(states.agent.actor, states.eval_key, jnp.asarray(j, jnp.int32), *sweep_args))
        eval_time += time.time() - t0
        evals[j] = r
        if tb is not None:
            for lanes_p, (out_dir, _) in zip(point_lanes, outputs):
                tb.evaluation(out_dir, j * cfg.eval_freq, seed_ids_np[lanes_p], r[lanes_p].mean(axis=1))
        if logs_params:
            values = learned_params.activation_params(states.agent.actor, states.agent.critic)
            for lanes_p, (out_dir, _) in zip(point_lanes, outputs):
                learned_params.append(os.path.join(out_dir, learned_params.FILENAME), j * cfg.eval_freq,
                                      seed_ids_np[lanes_p], {k: v[lanes_p] for k, v in values.items()})

    def write_all(n_done):
        for lanes_p, (out_dir, point_cfg) in zip(point_lanes, outputs):
            write_evaluations(out_dir, point_cfg, evals[:, lanes_p], n_done)
        if cfg.sweep:
            write_sweep_table(run_dir, cfg, points, evals[:n_done, : P * S])

    start_chunk = 0
    restored = resume and ckpt.latest_step() is not None
    if restored:
        step = ckpt.latest_step()
        # evals are stored in the compute dtype (exact: every return was computed in it)
        template = (jax.eval_shape(init_fn, base_seed, seed_ids, *sweep_args),
                    jax.ShapeDtypeStruct(evals.shape, jnp.asarray(evals).dtype))
        states, saved_evals = ckpt.restore(step, template)
        states = place(states, sharding)
        start_chunk = step // cfg.eval_freq
        evals[:] = np.asarray(saved_evals)
        for out_dir, _ in outputs:
            for name in (learned_params.FILENAME, learning_log.FILENAME):
                learned_params.truncate_after(os.path.join(out_dir, name), step)
        log(f"resumed {run_dir} at step {step}")
    else:
        for out_dir, _ in outputs:  # a resume without checkpoints restarts the logs too
            for name in (learned_params.FILENAME, learning_log.FILENAME):
                if os.path.exists(os.path.join(out_dir, name)):
                    os.remove(os.path.join(out_dir, name))
            if cfg.tensorboard:
                tensorboard_log.remove(out_dir)
    first_step = (start_chunk + 1) * cfg.eval_freq if restored else 0  # the first step logged below
    tb = _open_tensorboard(cfg, outputs, point_lanes, seed_ids_np, first_step, closing)
    if not restored:
        states = place(init_fn(base_seed, seed_ids, *sweep_args), sharding)
        say(f"compiling the evaluation program; evaluating the initial policies ({cfg.eval_episodes} episodes per lane)")
        evaluate(states, 0)
        if resume:
            log(f"no checkpoint in {run_dir}; starting from step 0")
    write_all(start_chunk + 1)

    train_time, steps_timed, first_chunk_time = 0.0, 0, None
    loop_walls: list[float] = []  # whole chunk iterations (train + eval + checkpoint) for the ETA
    for c in range(start_chunk, n_chunks):
        t0 = time.time()
        if c == start_chunk:
            say(f"compiling the training program and running its first {cfg.eval_freq} steps "
                f"(compiles take seconds to minutes on a CPU; cached for the next run)")
        states, chunk_metrics = train_chunk(cfg, chunk_fn, states, c, sweep_args, sharding, say)
        bad = np.asarray(states.bad_step)
        dt = time.time() - t0
        if first_chunk_time is None:
            first_chunk_time = dt  # includes compilation
        else:
            train_time += dt
            steps_timed += cfg.eval_freq
        step = (c + 1) * cfg.eval_freq
        hit = _first_bad(bad[: P * S])
        if hit is not None:
            lane, st, q = hit
            where = f"seed {cfg.first_seed + lane % S}"
            if cfg.sweep:
                where += f" of sweep point {cfgmod.point_label(points[lane // S])}"
            last = ckpt.latest_step()
            raise NonFiniteError(
                f"non-finite {q} in {where} at step {st}; stopped "
                f"(last good checkpoint: {'none' if last is None else f'step {last}'} in {run_dir}/checkpoints)"
            )
        evaluate(states, c + 1)
        episodes, last_return = np.asarray(states.episodes), np.asarray(states.last_return)
        for lanes_p, (out_dir, _) in zip(point_lanes, outputs):
            rows = learning_log.chunk_rows(step, seed_ids_np[lanes_p],
                                           {k: v[lanes_p] for k, v in chunk_metrics.items()},
                                           episodes[lanes_p], last_return[lanes_p])
            learning_log.append(os.path.join(out_dir, learning_log.FILENAME), rows)
            if tb is not None:
                tb.chunk(out_dir, rows)
        ckpt.save(step, (states, jnp.asarray(evals)))
        write_all(c + 2)
        loop_walls.append(time.time() - t0)
        # recent iterations: the learning phase is much slower than the uniform-random warm-up
        typical = np.mean(loop_walls[1:][-3:]) if len(loop_walls) > 1 else loop_walls[0]
        log(_progress_line(cfg, points, step, evals[c + 1, : P * S], dt, c == start_chunk,
                           time.time() - t_start, typical * (n_chunks - c - 1), chunk_metrics))

    final_actor = _flat_params(jax.tree.map(lambda x: x[: P * S], states.agent.actor))
    for lanes_p, (out_dir, _) in zip(point_lanes, outputs):
        np.savez(os.path.join(out_dir, "final_policy.npz"), **{k: v[lanes_p] for k, v in final_actor.items()})
    wall = time.time() - t_start
    timing = {
        "wall_time_s": wall,
        "train_time_s_excluding_first_chunk": train_time,
        "first_chunk_s_including_compile": first_chunk_time,
        "eval_time_s": eval_time,
        "env_steps_per_s": (steps_timed * P * S / train_time) if train_time > 0 else None,
        "env_steps_per_s_per_seed": (steps_timed / train_time) if train_time > 0 else None,
        "seeds": S,
        "sweep_points": P,
        "lanes": lanes,
        "total_steps": cfg.total_steps,
        "resumed_from_chunk": start_chunk if resume else None,
        "chunk_compiles": chunk_fn._cache_size(),
        "eval_compiles": eval_fn._cache_size(),
        "platform": jax.devices()[0].platform,
        "devices": jax.device_count() if sharding is not None else 1,
    }
    for out_dir in {run_dir, *(d for d, _ in outputs)}:
        with open(os.path.join(out_dir, "timing.json"), "w") as f:
            json.dump(timing, f, indent=2)
    ckpt.close()
    return RunResult(run_dir, evals[:, : P * S], final_actor, states, chunk_fn, eval_fn, timing)


def _open_tensorboard(cfg: Config, outputs, point_lanes, seed_ids: np.ndarray, first_step: int,
                      closing: contextlib.ExitStack):
    """The run's :class:`swim_jax.tensorboard_log.TensorBoardLog` (one writer per seed of every
    output folder, closed by ``closing``), or None when ``cfg.tensorboard`` is off."""
    if not cfg.tensorboard:
        return None
    tb = tensorboard_log.TensorBoardLog(
        [(out_dir, seed_ids[lanes_p]) for lanes_p, (out_dir, _) in zip(point_lanes, outputs)], first_step)
    closing.callback(tb.close)
    return tb


PROGRESS_EVERY_S = 30.0


def train_chunk(cfg: Config, chunk_fn, states, c: int, sweep_args, sharding, say):
    """Chunk ``c`` (``eval_freq`` steps) as calls of ``steps_per_call(cfg)`` steps each; between
    calls, at most every ``PROGRESS_EVERY_S`` seconds, ``say`` gets the step, env-steps/s and the
    chunk's ETA. Re-placing keeps the input sharding identical every call (no recompilation).
    Returns (states, the chunk's per-lane learning metrics, ``learning_log.combine``)."""
    per_call = cfgmod.steps_per_call(cfg)
    calls = cfg.eval_freq // per_call
    t0 = last = time.time()
    metrics = []
    for j in range(calls):
        t = c * cfg.eval_freq + j * per_call
        states, m = chunk_fn(states, jnp.asarray(t, jnp.int32), *sweep_args)
        states = place(states, sharding)
        metrics.append(m)
        if j + 1 < calls and time.time() - last >= PROGRESS_EVERY_S:
            np.asarray(states.bad_step)  # wait for the call (cheap: a few ints)
            now = time.time()
            done = (j + 1) * per_call
            rate = done / (now - t0)
            say(f"step {t + per_call}/{cfg.total_steps}: {rate * cfg.seeds * len(cfgmod.sweep_points(cfg)):.0f} env-steps/s in this chunk, "
                f"evaluation in {_fmt_time((cfg.eval_freq - done) / rate)}")
            last = now
    return states, learning_log.combine(metrics)


def _point_outputs(cfg: Config, run_dir: str, points) -> list[tuple[str, Config]]:
    """(output folder, plain config) per sweep point; ``[(run_dir, cfg)]`` without a sweep."""
    if not cfg.sweep:
        return [(run_dir, cfg)]
    out = []
    for point in points:
        label = cfgmod.point_label(point)
        pc = dataclasses.replace(cfgmod.point_config(cfg, point), name=f"{cfg.name}-{label}")
        out.append((os.path.join(run_dir, "points", label), pc))
    return out


def write_sweep_table(run_dir: str, cfg: Config, points, evals: np.ndarray) -> None:
    """``sweep.csv``: per point its values, the final and the best evaluation (mean over seeds of
    each seed's mean episode return; std over seeds), from ``evals[n_done, P·seeds, episodes]``."""
    keys = list(cfg.sweep)
    per_point = evals.mean(axis=2).reshape(evals.shape[0], len(points), cfg.seeds)  # [n, P, seeds]
    # csv quoting: multi-axis labels contain commas ("beta=0.5,tau=0.01") and are written quoted;
    # labels without commas are written bare, as before (swim_jax.runs_io.expand_sweeps reads both)
    with open(os.path.join(run_dir, "sweep.csv"), "w", newline="") as f:
        w = csv.writer(f, quoting=csv.QUOTE_MINIMAL, lineterminator="\n")
        w.writerow(["point", *keys, "final_mean", "final_std", "best_mean", "best_step"])
        for p, point in enumerate(points):
            m = per_point[:, p]  # [n, seeds]
            curve = m.mean(axis=1)
            best = int(np.argmax(curve))
            w.writerow([cfgmod.point_label(point), *(repr(point[k]) for k in keys),
                        repr(float(curve[-1])), repr(float(m[-1].std())), repr(float(curve[best])),
                        str(best * cfg.eval_freq)])


def _progress_line(cfg: Config, points, step: int, ev: np.ndarray, dt: float, first: bool,
                   elapsed: float, eta: float, chunk_metrics: dict | None = None) -> str:
    """One line per chunk: step, throughput, eval mean ± std over seeds (per point for sweeps),
    and, once updates run, the chunk's critic loss and Q₁ averaged over the lanes."""
    S, P = cfg.seeds, len(points)
    means = ev.mean(axis=1)  # [P·S] each lane's mean episode return
    rate = cfg.eval_freq * P * S / dt
    unit = "lane" if cfg.sweep else "seed"
    over = f"{P} points × {S} seeds" if cfg.sweep else f"{S} seeds"
    line = (f"step {step:>8d}/{cfg.total_steps} | {rate:8.0f} env-steps/s ({rate / (P * S):.0f}/{unit}"
            f"{', incl. compile' if first else ''}) | eval {means.mean():9.2f} ± {means.std():7.2f} over {over}")
    if cfg.sweep and P <= 8:
        point_means = means.reshape(P, S).mean(axis=1)
        line += " [" + ", ".join(f"{cfgmod.point_label(pt)}: {m:.0f}" for pt, m in zip(points, point_means)) + "]"
    if chunk_metrics is not None and np.any(chunk_metrics["updates"][: P * S] > 0):
        line += (f" | critic loss {np.nanmean(chunk_metrics['critic_loss'][: P * S]):.3g}"
                 f", Q {np.nanmean(chunk_metrics['q_mean'][: P * S]):.3g}")
    return line + f" | elapsed {_fmt_time(elapsed)} | ETA {_fmt_time(eta)}"


# ------------------------------------------------------------------------------------------------
# command line
# ------------------------------------------------------------------------------------------------

def parse_args(argv: list[str]) -> tuple[Config, str | None]:
    """(config, resume dir or None) from the command line; ConfigError on any problem."""
    config_name, resume, overrides = None, None, []
    it = iter(argv)
    for tok in it:
        if tok in ("-h", "--help"):
            raise SystemExit(USAGE)
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
        if config_name is not None or overrides:
            raise ConfigError("--resume takes no config= or overrides (the run's config.yaml is used)")
        path = os.path.join(resume, "config.yaml")
        if not os.path.isfile(path):
            raise ConfigError(f"cannot resume: {path} not found")
        with open(path) as f:
            cfg = cfgmod.from_dict(Config, yaml.safe_load(f) or {})
        return cfgmod.validate(cfg), resume
    if config_name is None:
        raise ConfigError(f"missing config=<name>; valid configs: {', '.join(cfgmod.available_configs())}")
    return cfgmod.resolve(config_name, overrides), None


def main(argv: list[str] | None = None, require_sweep: bool = False) -> int:
    """The command line of ``swim_jax.train`` (and, with ``require_sweep``, of ``swim_jax.sweep``)."""
    argv = sys.argv[1:] if argv is None else argv
    try:
        cfg, resume = parse_args(argv)
        if require_sweep and not cfg.sweep:
            raise ConfigError("no sweep axis given; add e.g. sweep.agent.activation.k=[0.25,0.5,1,2] "
                              f"(sweepable keys: {', '.join(cfgmod.sweepable_keys(cfg))})")
    except ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    run_dir = resume if resume else new_run_dir(cfg)
    print(f"run dir: {run_dir}", flush=True)
    try:
        res = run(cfg, run_dir, resume=resume is not None, log=lambda s: print(s, flush=True),
                  status=lambda s: print(s, flush=True))
    except NonFiniteError as e:
        print(f"error: {e}", file=sys.stderr, flush=True)
        return 3
    t = res.timing
    rate = t["env_steps_per_s"]
    print(
        f"done in {_fmt_time(t['wall_time_s'])}; "
        f"{'%.0f' % rate if rate else '?'} env-steps/s over {t['lanes'] if cfg.sweep else cfg.seeds} "
        f"{'lanes (points × seeds)' if cfg.sweep else 'seeds'}; outputs in {run_dir}",
        flush=True,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
