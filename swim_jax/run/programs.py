"""The training program of a config: env, agent and the jitted functions, built once per process.

``placement(cfg)`` decides how the lanes spread over the devices (of every process: a sharding of one
program, or on a CPU one program per group of lanes, swim_jax/placement/lane_groups.py), ``programs(cfg,
sharding)`` builds (or reuses) the env, eval env, agent (``agent.kind``'s) and the three jitted functions of
swim_jax/agents/loop.py for that placement, and ``lanes(cfg, prog, sharding)`` gives their per-lane inputs
(seed ids, sweep values). ``swim_jax.run.train`` runs them; ``swim_jax.run.render``/``roofline`` use
:func:`build` and ``swim_jax.bench.train`` times :func:`programs`' chunk.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax._src import xla_bridge

from swim_jax import envs
from swim_jax.agents import loop
from swim_jax.agents import registry
from swim_jax import config as cfgmod
from swim_jax.placement import lane_groups, stepping
from swim_jax.placement.layout import LaneLayout
from swim_jax.config import Config
from swim_jax.placement.sharding import lane_sharding, over_lanes, place


def _setup_precision(cfg: Config) -> None:
    jax.config.update("jax_enable_x64", cfg.precision == "float64")


def physics_backend(cfg: Config) -> tuple[str, str]:
    """(the physics backend ``cfg`` runs, why, in words for the start-up line). ``env.backend=auto``
    is ``mujoco`` (MuJoCo C inside the jitted program, faster on a CPU: docs/PERFORMANCE.md: native-vs-mjx-learning) when
    JAX's default backend is the CPU, else ``mjx``; asking for it starts JAX's backends."""
    if cfg.env.backend != "auto":
        return cfg.env.backend, f"env.backend={cfg.env.backend}"
    platform = jax.default_backend()
    if platform == "cpu":
        return "mujoco", "env.backend=auto on a CPU: MuJoCo C, the faster there; env.backend=mjx for MJX"
    return "mjx", f"env.backend=auto on {platform}: MJX; env.backend=mujoco for MuJoCo C on the host"


def with_physics_backend(cfg: Config) -> Config:
    """``cfg`` with ``env.backend=auto`` replaced by what :func:`physics_backend` chooses here."""
    backend, _ = physics_backend(cfg)
    return cfg if backend == cfg.env.backend else dataclasses.replace(
        cfg, env=dataclasses.replace(cfg.env, backend=backend))


def build(cfg: Config):
    """(env, eval env, agent) for a validated config, in the configured precision; the agent is the
    registry's class of ``cfg.agent.kind`` (swim_jax/agents/registry.py)."""
    _setup_precision(cfg)
    backend, _ = physics_backend(cfg)
    options = dict(max_episode_steps=cfg.env.max_episode_steps, backend=backend)
    if backend == "mujoco":
        options["native_call"] = cfg.env.native_call
    try:
        env, eval_env = envs.make(cfg.env.id, **options), envs.make(cfg.env.id, **options)
    except ValueError as e:  # e.g. native_call=ffi where the FFI is unavailable
        raise cfgmod.ConfigError(str(e)) from None
    dtype = jnp.float64 if cfg.precision == "float64" else jnp.float32
    agent = registry.of_config(cfg.agent)(
        cfg.agent,
        env.observation_size,
        tuple(float(x) for x in np.asarray(env.action_low)),
        tuple(float(x) for x in np.asarray(env.action_high)),
        dtype=dtype,
        matmul_dtype=matmul_dtype(cfg)[0],
    )
    return env, eval_env, agent


def matmul_dtype(cfg: Config) -> tuple[object, str]:
    """The Dense layers' product dtype (None = the run's precision, or ``jnp.bfloat16``) and, in
    words for the start-up line, what it is: ``matmul_dtype=full`` (the default) multiplies in the
    run's precision on every machine, ``bfloat16`` rounds the products' operands to bfloat16 (sums
    in float32). An old folder's ``auto`` is resolved before a run is built
    (``swim_jax.io.provenance.config_matmul_dtype``)."""
    if cfg.matmul_dtype == "bfloat16":
        return jnp.bfloat16, "bfloat16 matmuls (matmul_dtype=bfloat16)"
    if cfg.matmul_dtype != "full":
        raise cfgmod.ConfigError(f"matmul_dtype={cfg.matmul_dtype!r} cannot be built; valid: full, bfloat16")
    return None, f"{cfg.precision} matmuls (matmul_dtype=full)"


@dataclass
class Programs:
    """The jitted functions of one training program (see swim_jax/agents/loop.py)."""

    env: object
    eval_env: object
    agent: object
    init_fn: object  # (base_seed uint32, seed_ids int32[L][, hparams {path: [L]}]) -> TrainState[L]
    chunk_fn: object  # (TrainState[L], t0 int32[, hparams]) -> TrainState[L] after steps_per_call(cfg) steps; donated
    eval_fn: object  # (actor[L], eval_keys[L], eval_index int32[, hparams]) -> returns[L, E]


_PROGRAMS: dict = {}


def lane_inputs(cfg: Config, dtype) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(seed index per lane int32[L], sweep values per lane ``{agent path: [L]}``) of ``cfg``'s
    :class:`~swim_jax.placement.layout.LaneLayout`. Paths drop the ``agent.`` prefix
    (``activation.k``), as the agent's ``with_hparams`` takes them."""
    layout = LaneLayout.of(cfg)
    return layout.seed_ids(), {key.split(".", 1)[1]: layout.per_lane(key, dtype) for key in cfg.sweep}


def chunk_compiler_options(cfg: Config) -> dict:
    """XLA options of the training chunk: on a CPU backend, XLA's YNNPACK library fusions are
    switched off unless ``cfg.xla_cpu_ynn_fusions`` (within noise for float32; config.py) or the
    matmuls are bfloat16 (XLA's CPU backend multiplies bfloat16 natively only inside those fusions;
    elsewhere it converts the operands to float32 first)."""
    if cfg.xla_cpu_ynn_fusions or matmul_dtype(cfg)[0] is not None or jax.default_backend() != "cpu":
        return {}
    return {"xla_cpu_experimental_ynn_fusion_type": ""}


def programs(cfg: Config, sharding=None) -> Programs:
    """Build (or reuse, within this process) the env, agent and jitted functions for ``cfg``, with
    the lanes split over ``sharding``'s devices (``swim_jax.placement.sharding.over_lanes``) unless None.

    The compiled program depends only on the fields in the cache key, not on seeds' identities,
    total_steps or outputs, so e.g. a resumed or re-run config in the same process compiles nothing."""
    _setup_precision(cfg)
    # every config field that changes the built program (seeds only change the lane shapes)
    key = (cfg.env, cfg.agent, cfg.learning_starts, cfgmod.steps_per_call(cfg), cfg.eval_episodes,
           cfg.replay_size, cfg.precision, cfg.matmul_dtype, cfg.matmul_precision, cfg.xla_cpu_ynn_fusions,
           sharding)
    if key not in _PROGRAMS:
        env, eval_env, agent = build(cfg)
        def init_lanes(base, seed_ids, hparams=None):
            return jax.vmap(lambda i, h: loop.init_state(agent, env, cfg.replay_size, base, i, h))(seed_ids, hparams)

        chunk = loop.make_chunk_fn(agent, env, cfg.learning_starts, cfgmod.steps_per_call(cfg))
        evaluate = loop.make_eval_fn(agent, eval_env, cfg.eval_episodes, cfg.env.max_episode_steps)
        # the replicated arguments: the base seed, the chunk's first step, the evaluation index
        init_fn = jax.jit(over_lanes(init_lanes, sharding, replicated=(0,)))
        chunk_fn = jax.jit(over_lanes(chunk, sharding, replicated=(1,)), donate_argnums=0,
                           compiler_options=chunk_compiler_options(cfg))
        eval_fn = jax.jit(over_lanes(evaluate, sharding, replicated=(2,)))
        _PROGRAMS[key] = Programs(env, eval_env, agent, init_fn, chunk_fn, eval_fn)
    return _PROGRAMS[key]


@dataclass
class Lanes:
    """The per-lane inputs of a run's programs, placed on the devices."""

    layout: LaneLayout  # which lane trains which seed of which sweep point
    init_args: tuple  # (base_seed, seed_ids[, hparams]): ``init_fn``'s arguments
    sweep_args: tuple  # (hparams,) with a sweep, () without: the extra argument of chunk_fn/eval_fn
    sharding: object  # the lane axis' sharding over devices, or None (one device)
    groups: lane_groups.LaneGroups | None = None  # one program per group of lanes (CPU), or None

    @property
    def count(self) -> int:
        """The lane axis' width."""
        return self.layout.count


def auto_host_devices(cfg: Config) -> int:
    """Host CPU devices to ask for when ``host_devices`` is 0: with ``lane_groups=true`` and one
    process on this machine, one per usable core and at most one per real lane (0: leave JAX's
    default of one, i.e. with one core or one seed, or when ``XLA_FLAGS`` already sets a count).
    Harmless on a GPU machine (it only shapes the CPU platform)."""
    if cfg.host_devices or not cfg.lane_groups or cfg.local_processes > 1:
        return 0
    if "--xla_force_host_platform_device_count=" in os.environ.get("XLA_FLAGS", ""):
        return 0
    n = min(len(os.sched_getaffinity(0)), LaneLayout.of(cfg).real)
    return n if n >= 2 else 0


def groups_for(cfg: Config, count: int) -> tuple[lane_groups.LaneGroups | None, str]:
    """The lane groups of ``count`` lanes of ``cfg`` (swim_jax/placement/lane_groups.py), or None and, when
    only the steps per call stand in the way, why in words. Groups need ``lane_groups=true``, a CPU
    backend, one process, at least two host devices and two real lanes (a padded single seed stays
    one program, so that it equals the same seed of a multi-seed run), and, with leftover lanes,
    steps per call that cut into one equal piece per device."""
    if not cfg.lane_groups or jax.process_count() > 1 or jax.default_backend() != "cpu" or LaneLayout.of(cfg).real < 2:
        return None, ""
    try:
        return lane_groups.plan(count, jax.local_devices(), cfgmod.steps_per_call(cfg)), ""
    except lane_groups.StepsError as e:
        return None, f"{e}; set progress_steps (dividing eval_freq={cfg.eval_freq}) to such a multiple"


def stepper(cfg: Config, prog: Programs, sharding, groups: lane_groups.LaneGroups | None):
    """How ``prog``'s training calls run (swim_jax/placement/stepping.py), chosen once from
    :func:`placement`'s ``(sharding, groups)``: as the lane ``groups`` (swim_jax/placement/lane_groups.py;
    a leftover lane's pieces run the same program built for 1/D of the steps per call, D devices),
    or as one program over every lane, placed by ``sharding``."""
    if groups is None:
        return stepping.OneProgram(prog.chunk_fn, sharding)
    per_call = cfgmod.steps_per_call(cfg)
    piece_steps = per_call // len(groups.devices)
    pieces = programs(dataclasses.replace(cfg, progress_steps=piece_steps)).chunk_fn if groups.leftover else None
    return lane_groups.GroupedChunks(groups, prog.chunk_fn, pieces, per_call)


def placement(cfg: Config, log: Callable[[str], None]):
    """How ``cfg``'s lanes spread over the devices: ``(sharding, groups)``. On a CPU backend in one
    process with several host devices and ``lane_groups=true``, ``groups`` (swim_jax/placement/lane_groups.py:
    one program per group of lanes, one group per device) and no sharding; otherwise no groups and
    the sharding of the lane axis over the devices of every process, or None (all lanes on one
    device). ``log`` gets how (when there are several devices; why there are no lane groups when
    only the steps per call stand in the way) and a warning when ``host_devices`` asks for more
    than JAX started with. ConfigError when several processes run and the lanes cannot be split
    over all their devices."""
    count = LaneLayout.of(cfg).count
    if cfg.host_devices and jax.devices()[0].platform == "cpu" and jax.local_device_count() != cfg.host_devices:
        log(f"warning: host_devices={cfg.host_devices} but JAX started with {jax.local_device_count()} devices; "
            f"set XLA_FLAGS=--xla_force_host_platform_device_count={cfg.host_devices} before Python starts")
    groups, why_not = groups_for(cfg, count)
    if groups is not None:
        log(f"lanes: {groups.describe()}")
        return None, groups
    if why_not:
        log(f"lanes: no lane groups ({why_not})")
    sharding, how = lane_sharding(count) if cfg.shard_lanes else (None, "shard_lanes=false")
    if jax.process_count() > 1:
        if sharding is None:
            raise cfgmod.ConfigError(
                f"{count} lanes cannot run on {jax.process_count()} processes with {jax.device_count()} devices "
                f"({how}); use a multiple of {jax.device_count()} lanes (seeds × sweep points) and shard_lanes=true")
        how += f" in {jax.process_count()} processes"
    if jax.device_count() > 1:
        log(f"lanes: {how}")
    return sharding, None


def lanes(cfg: Config, prog: Programs, sharding, groups: lane_groups.LaneGroups | None = None) -> Lanes:
    """The lanes of ``cfg`` for ``prog`` (built for ``sharding``; both from :func:`placement`)."""
    layout = LaneLayout.of(cfg)
    seed_ids, hparams_np = lane_inputs(cfg, prog.agent.dtype)
    on_lanes = jnp.asarray if sharding is None else (lambda x: place(x, sharding))  # NumPy → device arrays
    hparams = {k: on_lanes(v) for k, v in hparams_np.items()}
    sweep_args = (hparams,) if hparams else ()  # no sweep: the functions' 2-/3-argument signatures
    init_args = (jnp.asarray(cfg.seed, jnp.uint32), on_lanes(seed_ids), *sweep_args)
    return Lanes(layout, init_args, sweep_args, sharding, groups)


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


def backends_started() -> bool:
    """Whether JAX has started its backends (after which ``XLA_FLAGS`` is no longer read)."""
    return bool(xla_bridge._backends)
