"""Run configuration: typed dataclasses, YAML files with ``inherit``, dotted ``key=value`` overrides.

Resolution order (later wins): the dataclass defaults (= the TD3 reference protocol) → the chain
of YAML files (``configs/<name>.yaml``, or one's own file, ``config=path/to/my.yaml``; a file's
``inherit: <other>`` is loaded first and deep-merged under it) → command-line overrides
``a.b.c=value`` (values parsed as YAML scalars/lists).
Every problem (unknown key, wrong type, unknown env/activation/precision, inconsistent numbers)
raises ``ConfigError`` with ONE line naming the valid choices.
"""

from __future__ import annotations

import collections.abc
import dataclasses
import itertools
import math
import os
import typing
from dataclasses import dataclass, field
from typing import Any, Mapping

import yaml

from swim_jax import envs
from swim_jax.agents import registry
from swim_jax.agents.base import replace_fields
from swim_jax.agents.td3 import TD3Config
from swim_jax.activations import ACTIVATIONS, learnable_activations, validate_params
from swim_jax.io import provenance, tensorboard_log
from swim_jax.io.cli_parser import dotted_keys
from swim_jax.io.schedule import Schedule


def locate_config_dir() -> str:
    """The folder of the run recipes (``<name>.yaml``, ``studies/``): the checkout's top-level
    ``configs/`` when it exists beside the package (a checkout or an editable install, marked by the
    ``pyproject.toml`` beside it, so edits to configs/ count at once), else the copy that a built
    wheel carries inside the package, ``swim_jax/_configs/`` (put there by setup.py's ``build_py``)."""
    package = os.path.dirname(os.path.abspath(__file__))
    checkout = os.path.dirname(package)
    if os.path.isdir(os.path.join(checkout, "configs")) and os.path.isfile(os.path.join(checkout, "pyproject.toml")):
        return os.path.join(checkout, "configs")
    return os.path.join(package, "_configs")


CONFIG_DIR = locate_config_dir()
PRECISIONS = ("float32", "float64")
MATMUL_PRECISIONS = ("highest", "high", "default")
MATMUL_DTYPES = ("full", "bfloat16")
NATIVE_CALLS = envs.NATIVE_CALLS
# env.backend: "auto" (MuJoCo C on a CPU, MJX on an accelerator) or one of the envs' backends
PHYSICS_BACKENDS = ("auto", *envs.BACKENDS)


class ConfigError(ValueError):
    """A configuration problem, phrased as one line for the user."""


@dataclass(frozen=True)
class EnvConfig:
    """Environment id (``envs.ENV_IDS``), its time limit and physics backend (``auto``, the
    default: ``mujoco`` when JAX runs on a CPU, ``mjx`` on a GPU/TPU, resolved when a run starts
    and recorded so in its config.yaml, swim_jax/run/programs.py ``physics_backend``; ``mjx``: MJX in
    JAX, batched on any device; ``mujoco``: MuJoCo C on the host from inside the jitted program,
    bit for bit Gymnasium's physics and the faster one on a CPU, see swim_jax/envs/physics/native.py). With
    ``mujoco``, ``native_call`` chooses how the program reaches MuJoCo C: ``auto`` (an XLA FFI call
    into C++ on a CPU when it builds, else a Python callback), ``ffi`` or ``callback``."""

    id: str = "Walker2d-v5"
    max_episode_steps: int = 1000
    backend: str = "auto"
    native_call: str = "auto"


@dataclass(frozen=True)
class Config:
    """One training run (all seeds). Defaults = the paper's protocol with the TD3 reference."""

    env: EnvConfig = field(default_factory=EnvConfig)
    # the algorithm: agent.kind (td3, the default, or sac: swim_jax/agents/registry.py) picks the
    # dataclass the rest of agent: is read into (TD3Config, SACConfig: their fields are its keys)
    agent: TD3Config = field(default_factory=TD3Config, metadata={"by_kind": registry.config_class})
    seeds: int = 5  # number of seeds, a vmapped axis
    first_seed: int = 0  # seed indices are first_seed .. first_seed + seeds - 1
    seed: int = 0  # base seed; seed i's keys are fold_in(PRNGKey(seed), i)
    total_steps: int = 1_000_000
    learning_starts: int = 25_000  # uniform-random steps before the first update
    eval_freq: int = 5000  # env steps per chunk; one evaluation after each chunk (+ one at step 0)
    eval_episodes: int = 10
    replay_size: int = 1_000_000
    precision: str = "float32"
    out_dir: str = "runs"
    keep_checkpoints: int = 3
    name: str = ""  # run name (defaults to the config file name)
    # seeds=1 runs a duplicate second lane so the seed is bit-identical to the same seed in a
    # multi-seed run (see swim_jax.placement.layout.LaneLayout.of); false: half the work, float-rounding drift
    pad_single_seed: bool = True
    # float32 matmul precision (jax.default_matmul_precision): "highest" = true float32 everywhere;
    # "default" lets NVIDIA GPUs use TF32 (~1e-3 relative; faster for big matmuls, not comparable with CPU)
    matmul_precision: str = "highest"
    # the dtype of the networks' matrix products: "full" = the run's precision (float32 products in a
    # float32 run, as the TD3 reference) on every machine; "bfloat16" = inputs, weights, biases and
    # the products' derivatives rounded to bfloat16, sums in float32 (parameters, Adam state and
    # activations stay in precision): faster on CPUs with bfloat16 dot instructions, and it changes
    # what TD3 learns (docs/PERFORMANCE.md: bf16-learning-parity). Old run folders may say "auto"
    # (bfloat16 on such CPUs): they resume as they ran (swim_jax.io.provenance.config_matmul_dtype)
    matmul_dtype: str = "full"
    # lanes (seeds × sweep points) split over devices when several exist and lanes divide evenly
    shard_lanes: bool = True
    # > 0: ask XLA for this many host CPU devices (sets XLA_FLAGS before JAX starts; CPU only)
    host_devices: int = 0
    # true: on a CPU, in one process, the lanes are stepped as one group per core, each group its own
    # program on its own host CPU device, all running at once (swim_jax/placement/lane_groups.py); swim_jax.run.train
    # then asks for one host device per core (at most one per seed) unless host_devices is set.
    # What it gains: docs/PERFORMANCE.md: lane-groups-vs-one-program.
    # Not where it cannot apply (GPU, several processes, one seed: one program). false: one program
    lane_groups: bool = True
    # > 1: run as this many jax.distributed processes on this machine, each pinned to its share of
    # the cores (swim_jax/placement/local_processes.py): each steps its own lanes with single-threaded products
    # (docs/PERFORMANCE.md: local-processes-vs-one-process). CPU; lanes must divide
    local_processes: int = 0
    # env steps per call of the compiled program; a progress line (env-steps/s, ETA) is printed
    # between calls at most every ~30 s. Must divide eval_freq (else one call per evaluation).
    progress_steps: int = 1000
    # JAX's persistent compilation cache in ~/.cache/swim-jax/xla ($XDG_CACHE_HOME respected), so a
    # second run of the same program starts in seconds; false (or SWIM_JAX_NO_COMPILATION_CACHE=1) = off
    compilation_cache: bool = True
    # XLA CPU's YNNPACK library fusions in the training program (XLA's default is on); off for
    # float32 (docs/PERFORMANCE.md: ynn-fusions-off), on for bfloat16 products. No effect on GPUs.
    xla_cpu_ynn_fusions: bool = False
    # also write metrics.csv's scalars and the evaluation returns as TensorBoard event files, one
    # run per seed: <run>/tensorboard/seed_<i>/ (swim_jax/io/tensorboard_log.py); needs tensorboardX,
    # the optional extra: pip install -c requirements.lock -e '.[tensorboard]'
    tensorboard: bool = False
    # hyperparameter sweep: {"agent.activation.k": (0.25, 0.5, 1.0), ...}; the grid (cartesian
    # product) × seeds trains as lanes of one program (python -m swim_jax.sweep); empty = no sweep
    sweep: Mapping[str, tuple[float, ...]] = field(default_factory=dict)


# ------------------------------------------------------------------------------------------------
# dict <-> dataclass with type checking
# ------------------------------------------------------------------------------------------------

def to_dict(cfg) -> dict:
    """Plain nested dict (tuples become lists) for YAML; a field whose metadata names an ``omit_if``
    value is left out when it has that value (``agent.kind`` of TD3, the default: TD3 run folders
    read as before)."""
    out = {}
    for f in dataclasses.fields(cfg):
        v = getattr(cfg, f.name)
        if "omit_if" in f.metadata and v == f.metadata["omit_if"]:
            continue
        if dataclasses.is_dataclass(v):
            v = to_dict(v)
        elif isinstance(v, Mapping):
            v = {k: list(x) for k, x in v.items()}
        elif isinstance(v, tuple):
            v = list(v)
        out[f.name] = v
    return out


def _type_name(tp) -> str:
    return getattr(tp, "__name__", str(tp)).replace("typing.", "")


def _number(value):
    """YAML 1.1 reads ``1e30`` / ``3e-4`` (no dot) as strings; accept them as numbers."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def _coerce(value, tp, path: str):
    origin = typing.get_origin(tp)
    if tp in (int, float):
        value = _number(value)
    if tp is bool:
        if isinstance(value, bool):
            return value
    elif tp is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        if isinstance(value, float) and value.is_integer():  # 1e6 written in YAML
            return int(value)
    elif tp is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
    elif tp is str:
        if isinstance(value, str):
            return value
    elif origin is tuple:
        (elem, _ell) = typing.get_args(tp)
        if isinstance(value, (list, tuple)):
            return tuple(_coerce(v, elem, f"{path}[{i}]") for i, v in enumerate(value))
        if isinstance(value, int) and not isinstance(value, bool):
            return (value,)
        raise ConfigError(f"{path}: expected a list of {_type_name(elem)}, got {value!r}")
    raise ConfigError(f"{path}: expected {_type_name(tp)}, got {value!r} ({type(value).__name__})")


def _coerce_sweep(value, path: str) -> dict[str, tuple[float, ...]]:
    """``{"agent": {"tau": [..]}}`` or ``{"agent.tau": [..]}`` → ``{"agent.tau": (floats)}``."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ConfigError(f"{path}: expected a mapping of config keys to value lists, e.g. "
                          f"{path}.agent.activation.k=[0.25,0.5,1], got {value!r}")
    out = {}
    for key, values in dotted_keys(value).items():
        if not isinstance(values, (list, tuple)) or not values:
            raise ConfigError(f"{path}.{key}: expected a non-empty list of numbers such as [0.25,0.5,1], got {values!r}")
        out[key] = tuple(_coerce(v, float, f"{path}.{key}[{i}]") for i, v in enumerate(values))
    return out


def _by_kind(pick, data, path: str) -> type:
    """The dataclass ``pick(kind)`` names for the mapping ``data`` at ``path`` by its ``kind`` key
    (the default kind when it has none); ConfigError naming the valid kinds."""
    kind = data.get("kind", registry.DEFAULT_KIND) if isinstance(data, Mapping) else registry.DEFAULT_KIND
    try:
        return pick(kind if isinstance(kind, str) else repr(kind))
    except ValueError as e:
        raise ConfigError(str(e).replace("agent.kind", f"{path}.kind")) from None


def _other_kinds_key(path: str, key: str, kind: str) -> str:
    """`` (a key of agent.kind=sac, not of agent.kind=td3)`` when ``key`` belongs to another
    registered agent's config than ``kind``'s; "" otherwise."""
    owners = [k for k in registry.kinds() if k != kind
              and key in {f.name for f in dataclasses.fields(registry.config_class(k))}]
    return f" (a key of {path}.kind={owners[0]}, not of {path}.kind={kind})" if owners else ""


def from_dict(cls, data: Mapping[str, Any], prefix: str = ""):
    """Build dataclass ``cls`` from a nested dict; unknown keys and wrong types raise ConfigError.
    A field whose metadata has ``by_kind`` is built into the dataclass its ``kind`` key names (the
    agent: ``agent.kind``); a field the class fixes (``init=False``, such as ``kind``) may be given
    only with its value."""
    hints = typing.get_type_hints(cls)
    fields = dataclasses.fields(cls)
    names = [f.name for f in fields]
    if not isinstance(data, Mapping):
        raise ConfigError(f"{prefix.rstrip('.') or 'config'}: expected a mapping, got {data!r}")
    unknown = [k for k in data if k not in names]
    if unknown:
        kind = getattr(cls, "kind", None) if "kind" in names else None
        other = _other_kinds_key(prefix.rstrip("."), str(unknown[0]), kind) if isinstance(kind, str) else ""
        raise ConfigError(
            f"unknown key {prefix + str(unknown[0])!r}{other}; valid keys{' under ' + prefix.rstrip('.') if prefix else ''}: "
            f"{', '.join(names)}"
        )
    kwargs = {}
    for f in fields:
        name = f.name
        if name not in data:
            continue
        if not f.init:
            if data[name] != f.default:
                raise ConfigError(f"{prefix}{name}: expected {f.default!r}, got {data[name]!r}")
            continue
        tp = hints[name]
        if "by_kind" in f.metadata:
            sub = data[name] if data[name] is not None else {}
            kwargs[name] = from_dict(_by_kind(f.metadata["by_kind"], sub, prefix + name), sub, f"{prefix}{name}.")
        elif dataclasses.is_dataclass(tp):
            kwargs[name] = from_dict(tp, data[name] if data[name] is not None else {}, f"{prefix}{name}.")
        elif typing.get_origin(tp) in (collections.abc.Mapping, dict):
            kwargs[name] = _coerce_sweep(data[name], prefix + name)
        else:
            kwargs[name] = _coerce(data[name], tp, prefix + name)
    return cls(**kwargs)


def deep_merge(base: dict, over: Mapping) -> dict:
    """Recursive dict merge: values of ``over`` win; nested mappings merge key by key."""
    out = dict(base)
    for k, v in over.items():
        if isinstance(v, Mapping) and isinstance(out.get(k), Mapping):
            out[k] = deep_merge(out[k], v)
        else:
            out[k] = v
    return out


def available_configs(config_dir: str = CONFIG_DIR) -> list[str]:
    """Names of the YAML configs (without extension), excluding ``_``-prefixed shared bases."""
    if not os.path.isdir(config_dir):
        return []
    return sorted(f[:-5] for f in os.listdir(config_dir) if f.endswith(".yaml") and not f.startswith("_"))


def _config_file(name: str, config_dir: str, inheriting: str | None) -> str:
    """The file of config ``name``. On the command line: a name ending in ``.yaml`` is a file's path,
    any other a config of ``config_dir``. In an ``inherit:``: the file beside the inheriting one
    first (``name`` relative to its folder), then ``config_dir``'s; never the inheriting file itself."""
    file = name if name.endswith(".yaml") else f"{name}.yaml"
    if inheriting is None:
        path = os.path.abspath(name if name.endswith(".yaml") else os.path.join(config_dir, file))
        if os.path.isfile(path):
            return path
        if name.endswith(".yaml"):
            where = "" if path == name else f" ({path})"
            raise ConfigError(f"config file {name} not found{where}; config= takes a YAML file's path or one "
                              f"of the shipped configs: {', '.join(available_configs(config_dir))}")
        raise ConfigError(f"unknown config {name!r}; valid configs: {', '.join(available_configs(config_dir))}")
    here = os.path.dirname(inheriting)
    for path in (os.path.abspath(os.path.join(here, file)), os.path.abspath(os.path.join(config_dir, file))):
        if os.path.isfile(path) and path != inheriting:
            return path
    if os.path.abspath(os.path.join(here, file)) == inheriting:
        raise ConfigError(f"config {inheriting}: circular inherit (it inherits itself)")
    raise ConfigError(f"config {inheriting}: inherit {name!r} found neither in {here} nor among the shipped "
                      f"configs ({', '.join(available_configs(config_dir))}, and their _<env> bases)")


def load_yaml_mapping(path: str, name: str, expected: str) -> dict:
    """The mapping in the YAML file ``path`` (empty file: ``{}``); :class:`ConfigError` naming
    ``name`` when it is not valid YAML or not a mapping (``expected`` says what it should be)."""
    with open(path) as f:
        try:
            data = yaml.safe_load(f) or {}
        except yaml.YAMLError as e:
            raise ConfigError(f"{name}: invalid YAML ({str(e).splitlines()[0]})") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{name}: expected {expected}")
    return data


def load_yaml_chain(name: str, config_dir: str = CONFIG_DIR, _seen=()) -> dict:
    """Load config ``name`` with its ``inherit`` chain merged (parents first): ``walker_swim`` is
    ``<config_dir>/walker_swim.yaml``, ``path/to/my.yaml`` a file of one's own, whose ``inherit:``
    may name a file beside it or a shipped config (``walker_swim``, ``_walker``); see ``_config_file``."""
    path = _config_file(name, config_dir, _seen[-1] if _seen else None)
    if path in _seen:
        raise ConfigError(f"config {name!r}: circular inherit")
    data = load_yaml_mapping(path, f"config {name!r}", "a mapping at top level")
    parent = data.pop("inherit", None)
    if parent is not None:
        data = deep_merge(load_yaml_chain(str(parent), config_dir, _seen + (path,)), data)
    return data


def available_studies(config_dir: str = CONFIG_DIR) -> list[str]:
    """Names of the shipped study files, ``<config_dir>/studies/<name>.yaml``."""
    folder = os.path.join(config_dir, "studies")
    return sorted(f[:-5] for f in os.listdir(folder) if f.endswith(".yaml")) if os.path.isdir(folder) else []


def shipped_study(name: str, config_dir: str = CONFIG_DIR) -> str | None:
    """The shipped study file of a bare study name (``table2`` or ``table2.yaml``, no folder):
    ``<config_dir>/studies/table2.yaml``; None for a path or a name that is not shipped."""
    if not name or os.path.dirname(name):
        return None
    path = os.path.join(config_dir, "studies", name if name.endswith(".yaml") else f"{name}.yaml")
    return path if os.path.isfile(path) else None


def parse_override(item: str) -> tuple[list[str], Any]:
    """``"a.b=3"`` → (["a", "b"], 3); the value is parsed as YAML (int/float/bool/str/list)."""
    if "=" not in item:
        raise ConfigError(f"expected key=value, got {item!r}")
    key, raw = item.split("=", 1)
    if not key or any(not p for p in key.split(".")):
        raise ConfigError(f"bad key in {item!r}")
    try:
        value = yaml.safe_load(raw) if raw != "" else ""
    except yaml.YAMLError:
        value = raw
    return key.split("."), value


def apply_overrides(data: dict, overrides: list[str]) -> dict:
    """Set each dotted key (creating nested dicts); validation happens in ``from_dict``."""
    data = dict(data)
    for item in overrides:
        path, value = parse_override(item)
        node = data
        for p in path[:-1]:
            child = node.get(p)
            child = dict(child) if isinstance(child, Mapping) else {}
            node[p] = child
            node = child
        node[path[-1]] = value
    return data


def validate(cfg: Config) -> Config:
    """Semantic checks (env id, activation, precision, step arithmetic); returns cfg."""
    if cfg.env.id not in envs.ENV_IDS:
        raise ConfigError(f"unknown env.id {cfg.env.id!r}; valid: {', '.join(envs.ENV_IDS)}")
    if cfg.env.backend not in PHYSICS_BACKENDS:
        raise ConfigError(f"unknown env.backend {cfg.env.backend!r}; valid: {', '.join(PHYSICS_BACKENDS)}")
    if cfg.env.native_call not in NATIVE_CALLS:
        raise ConfigError(f"unknown env.native_call {cfg.env.native_call!r}; valid: {', '.join(NATIVE_CALLS)}")
    act = cfg.agent.activation
    if act.name not in ACTIVATIONS:
        raise ConfigError(f"unknown agent.activation.name {act.name!r}; valid: {', '.join(sorted(ACTIVATIONS))}")
    try:
        validate_params(act.name, act.params())
    except ValueError as e:
        raise ConfigError(str(e)) from None
    if act.learnable and not act.params():
        raise ConfigError("agent.activation.learnable=true needs an activation with a parameter; "
                          f"valid: {', '.join(learnable_activations())}")
    if cfg.matmul_precision not in MATMUL_PRECISIONS:
        raise ConfigError(f"unknown matmul_precision {cfg.matmul_precision!r}; valid: {', '.join(MATMUL_PRECISIONS)}")
    if cfg.matmul_dtype == "auto":
        raise ConfigError("matmul_dtype=auto is no longer offered (it multiplied in bfloat16 on some CPUs only); "
                          "valid: full (the run's precision, the default), bfloat16")
    if cfg.matmul_dtype not in MATMUL_DTYPES:
        raise ConfigError(f"unknown matmul_dtype {cfg.matmul_dtype!r}; valid: {', '.join(MATMUL_DTYPES)}")
    if cfg.precision not in PRECISIONS:
        raise ConfigError(f"unknown precision {cfg.precision!r}; valid: {', '.join(PRECISIONS)}")
    positive = {
        "seeds": cfg.seeds, "total_steps": cfg.total_steps, "eval_freq": cfg.eval_freq,
        "eval_episodes": cfg.eval_episodes, "replay_size": cfg.replay_size,
        "keep_checkpoints": cfg.keep_checkpoints, "env.max_episode_steps": cfg.env.max_episode_steps,
        # every integer of the agent's config (batch size, delays) counts something
        **{f"agent.{f.name}": getattr(cfg.agent, f.name) for f in dataclasses.fields(cfg.agent)
           if isinstance(getattr(cfg.agent, f.name), int) and not isinstance(getattr(cfg.agent, f.name), bool)},
        "progress_steps": cfg.progress_steps,
    }
    for k, v in positive.items():
        if v < 1:
            raise ConfigError(f"{k} must be >= 1, got {v}")
    for k in ("seed", "first_seed", "learning_starts", "host_devices", "local_processes"):
        if getattr(cfg, k) < 0:
            raise ConfigError(f"{k} must be >= 0, got {getattr(cfg, k)}")
    if cfg.seed >= 2**32 or cfg.first_seed + cfg.seeds >= 2**31:
        raise ConfigError("seed must be < 2**32 and first_seed + seeds < 2**31")
    if cfg.total_steps % cfg.eval_freq:
        raise ConfigError(f"total_steps ({cfg.total_steps}) must be a multiple of eval_freq ({cfg.eval_freq})")
    if not cfg.agent.hidden or any(h < 1 for h in cfg.agent.hidden):
        raise ConfigError(f"agent.hidden must be a non-empty list of positive widths, got {list(cfg.agent.hidden)}")
    if hasattr(cfg.agent, "check"):  # the agent's own rules (SAC: log_std_min < log_std_max)
        try:
            cfg.agent.check()
        except ValueError as e:
            raise ConfigError(str(e)) from None
    _validate_sweep(cfg)
    if cfg.tensorboard:
        problem = tensorboard_log.missing_package()
        if problem:
            raise ConfigError(problem)
    return cfg


def sweepable_keys(cfg: Config) -> tuple[str, ...]:
    """Config keys that can be sweep axes for this config (``agent.`` + its agent's ``sweepable_fields``)."""
    return tuple(f"agent.{f}" for f in registry.of_config(cfg.agent).sweepable_fields(cfg.agent.activation.name))


def _validate_sweep(cfg: Config) -> None:
    valid = sweepable_keys(cfg)
    for key, values in cfg.sweep.items():
        if key not in valid:
            raise ConfigError(f"sweep.{key} cannot be swept (activation {cfg.agent.activation.name}); "
                              f"valid sweep keys: {', '.join(valid)}")
        if len(set(values)) != len(values):
            raise ConfigError(f"sweep.{key}: values must be distinct, got {list(values)}")
    for point in sweep_points(cfg):
        pc = point_config(cfg, point)
        try:
            validate_params(pc.agent.activation.name, pc.agent.activation.params())
        except ValueError as e:
            raise ConfigError(f"sweep point {point_label(point)}: {e}") from None
        bad = [k for k, v in point.items() if not math.isfinite(v) or (v < 0 if k != "agent.discount" else not 0 <= v <= 1)]
        if bad:
            raise ConfigError(f"sweep point {point_label(point)}: {bad[0]} must be finite and >= 0 (discount in [0, 1])")


def sweep_points(cfg: Config) -> list[dict[str, float]]:
    """The sweep grid in lane order: the cartesian product of ``cfg.sweep``'s value lists, the
    first key varying slowest; ``[{}]`` (one point, no changes) when there is no sweep."""
    keys = list(cfg.sweep)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(cfg.sweep[k] for k in keys))]


def point_label(point: Mapping[str, float]) -> str:
    """``{"agent.activation.k": 0.25, "agent.tau": 0.01}`` → ``"k=0.25,tau=0.01"`` (folder-safe)."""
    return ",".join(f"{k.rsplit('.', 1)[-1]}={v:g}" for k, v in point.items()) or "default"


def point_config(cfg: Config, point: Mapping[str, float]) -> Config:
    """``cfg`` with the point's values set and no sweep: what a plain run of that point would use."""
    agent = replace_fields(cfg.agent, {key.split(".", 1)[1]: value for key, value in point.items()})  # drop "agent."
    return dataclasses.replace(cfg, agent=agent, sweep={})


def resolve(config: str | None, overrides: list[str], config_dir: str = CONFIG_DIR) -> Config:
    """Defaults ← YAML chain of ``config`` (if given) ← overrides, type-checked and validated."""
    data = load_yaml_chain(config, config_dir) if config else {}
    data = apply_overrides(data, overrides)
    cfg = from_dict(Config, data)
    if not cfg.name:
        cfg = dataclasses.replace(cfg, name=os.path.basename(config)[:-5] if config and config.endswith(".yaml") else (config or "run"))
    return validate(cfg)


def schedule(cfg: Config) -> "Schedule":
    """The run's schedule of evaluations, chunks and checkpoints (swim_jax/io/schedule.py)."""
    return Schedule(cfg.total_steps, cfg.eval_freq)


# config keys a run folder's config.yaml may differ in from the config that continues it (where and
# how the run is placed, not what it computes)
PLACEMENT_KEYS = frozenset({"out_dir", "keep_checkpoints", "shard_lanes", "host_devices", "lane_groups",
                            "compilation_cache", "progress_steps"})


def first_difference(want: Config, run_dir: str, ignored: frozenset = PLACEMENT_KEYS) -> tuple[str, Any, Any] | None:
    """``(key, recorded, wanted)`` of the first dotted key (sorted) in which ``want`` differs from the
    config.yaml of the run folder ``run_dir``, or None when ``want`` continues that run. Not a
    difference: the top-level keys in ``ignored``; ``env.backend=auto`` in ``want`` (the folder
    recorded what auto chose); an old folder's ``matmul_dtype: auto`` (read as what its run
    multiplied in, :func:`read_run_config`); a ``total_steps`` above the folder's (the budget grows)."""
    path = os.path.join(run_dir, "config.yaml")
    recorded = load_yaml_mapping(path, path, "a config mapping")
    recorded = {**recorded, "matmul_dtype": provenance.config_matmul_dtype(run_dir, recorded)}
    wanted = to_dict(want)
    if wanted["env"]["backend"] == "auto":
        wanted["env"]["backend"] = (recorded.get("env") or {}).get("backend", "auto")
    if isinstance(recorded.get("total_steps"), int) and wanted["total_steps"] > recorded["total_steps"]:
        wanted["total_steps"] = recorded["total_steps"]  # a grown budget: a resume continues to it
    flat_want, flat_recorded = (dotted_keys({k: v for k, v in d.items() if k not in ignored})
                                for d in (wanted, recorded))
    diff = sorted(k for k in flat_want.keys() | flat_recorded.keys() if flat_want.get(k) != flat_recorded.get(k))
    return (diff[0], flat_recorded.get(diff[0]), flat_want.get(diff[0])) if diff else None


def read_run_config(run_dir: str, overrides: list[str] = ()) -> tuple[dict, Config]:
    """(the mapping in ``run_dir``'s config.yaml, the validated config a run of it builds with
    ``overrides`` applied). An old folder's ``matmul_dtype: auto`` reads as what that run multiplied in
    (``swim_jax.io.provenance.config_matmul_dtype``), so it resumes, evaluates and exports as it ran.
    :class:`ConfigError` (one line) when the file is missing or invalid."""
    path = os.path.join(run_dir, "config.yaml")
    if not os.path.isfile(path):
        raise ConfigError(f"{path} not found")
    raw = load_yaml_mapping(path, path, "a config mapping")
    data = {**raw, "matmul_dtype": provenance.config_matmul_dtype(run_dir, raw)}
    return raw, validate(from_dict(Config, apply_overrides(data, list(overrides))))


def dump(cfg: Config) -> str:
    """The resolved config as YAML (round-trips through ``from_dict``)."""
    return yaml.safe_dump(to_dict(cfg), sort_keys=False)


def steps_per_call(cfg: Config) -> int:
    """Env steps per call of the compiled chunk: ``progress_steps`` when it divides ``eval_freq``,
    else ``eval_freq`` (one call per evaluation)."""
    return cfg.progress_steps if cfg.eval_freq % cfg.progress_steps == 0 else cfg.eval_freq
