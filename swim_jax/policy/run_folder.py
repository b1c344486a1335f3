"""A run folder's policies as :class:`~swim_jax.policy.policy.Policy` objects: ``load_policy(run_dir, seed=0)``.

Where the parameters come from: ``final_policy.npz`` (the actor at ``total_steps``, leading axis =
seed), or with ``step=S`` the orbax checkpoint at step S (``checkpoints/<S>/``; reading one needs
orbax, i.e. the project's JAX stack: ``swim_jax.policy.checkpoint``). A sweep point's checkpoints are
the sweep's (``<sweep>/checkpoints``), its lanes ``point·seeds … point·seeds + seeds − 1``. The action
bounds are the actuators' ``ctrlrange`` of the env's MuJoCo model, read from Gymnasium's env (the
XML the project's envs load too).

The actor's layout in ``final_policy.npz`` and in a checkpoint (:func:`actor_leaf_names`,
:func:`actor_leaf_shapes`) is swim_jax/agents/networks.py's, read here without JAX.

Every problem raises :class:`~swim_jax.policy.policy.PolicyError` with one line naming what is wrong
and what is valid.
"""

from __future__ import annotations

import inspect
import itertools
import json
import os
from dataclasses import dataclass
from typing import Mapping

import numpy as np
import yaml

from swim_jax.io import provenance
from swim_jax.io.cli_parser import dotted_keys, one_line
from swim_jax.policy import activations as activations_np
from swim_jax.policy.gymnasium_env import env_spec
from swim_jax.policy.policy import HEADS, Policy, PolicyError, load_exported

FINAL = "final_policy.npz"
CHECKPOINTS = "checkpoints"
# the head of each agent.kind (swim_jax.agents.registry: each agent's POLICY_HEAD; a test checks they agree)
AGENT_HEADS = {"td3": "deterministic", "sac": "gaussian"}


@dataclass
class RunPolicies:
    """What a run folder (or one sweep point's folder) holds of its policies."""

    path: str
    config: dict
    env_id: str
    seeds: tuple[int, ...]  # the seed ids, first_seed … first_seed + seeds − 1
    total_steps: int
    eval_freq: int
    final: str | None  # final_policy.npz, None when the run has not written it
    checkpoints: str | None  # the folder holding checkpoints/<step>/ of these lanes
    lane_offset: int  # lane of the first seed in those checkpoints (sweep point · seeds)

    @property
    def checkpoint_steps(self) -> tuple[int, ...]:
        """The complete checkpoints' steps (orbax renames a checkpoint to its bare step once done)."""
        if self.checkpoints is None or not os.path.isdir(self.checkpoints):
            return ()
        return tuple(sorted(int(n) for n in os.listdir(self.checkpoints)
                            if n.isdigit() and os.path.isdir(os.path.join(self.checkpoints, n))))

    @property
    def steps(self) -> tuple[int, ...]:
        """Every step with a policy: the checkpoints' and, with final_policy.npz, ``total_steps``."""
        return tuple(sorted(set(self.checkpoint_steps) | ({self.total_steps} if self.final else set())))

    def seed_position(self, seed) -> int:
        """Position of seed id ``seed`` in the run's seeds; PolicyError naming the valid ones."""
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or int(seed) not in self.seeds:
            raise PolicyError(f"seed {seed!r} is not in {self.path}: its seeds are {_seed_range(self.seeds)}")
        return self.seeds.index(int(seed))

    def describe_steps(self) -> str:
        parts = []
        if self.checkpoint_steps:
            parts.append(f"checkpoints at {', '.join(map(str, self.checkpoint_steps))}")
        if self.final:
            parts.append(f"{FINAL} at {self.total_steps}")
        return "; ".join(parts) or "none (no checkpoint and no final policy)"


def run_policies(run_dir: str) -> RunPolicies:
    """Read ``run_dir``'s config.yaml and find its policies; PolicyError when it is not a run
    folder or is a whole sweep (:func:`run_folders` lists a sweep's points)."""
    if not os.path.isdir(run_dir):
        raise PolicyError(f"{run_dir}: no such run folder")
    cfg = _read_config(run_dir)
    if cfg.get("sweep"):
        points = run_folders(run_dir)
        raise PolicyError(f"{run_dir} is a sweep of {len(points)} points; pass one of its point folders: "
                          f"{', '.join(os.path.relpath(p, run_dir) for p in points)}")
    try:
        env_id = cfg["env"]["id"]
        n, first = int(cfg["seeds"]), int(cfg.get("first_seed", 0))
        total_steps, eval_freq = int(cfg["total_steps"]), int(cfg["eval_freq"])
        if not isinstance(env_id, str) or n < 1 or total_steps < 1 or eval_freq < 1:
            raise ValueError("env.id, seeds, total_steps or eval_freq")
    except (KeyError, TypeError, ValueError) as e:
        raise PolicyError(f"{run_dir}/config.yaml: missing or invalid key {one_line(e)}") from None
    final = os.path.join(run_dir, FINAL)
    checkpoints, offset = os.path.join(run_dir, CHECKPOINTS), 0
    point = os.path.join(run_dir, "point.json")
    if os.path.isfile(point):  # a sweep point: the sweep's checkpoints, this point's lanes
        checkpoints, offset = _point_lanes(run_dir, point, n)
    return RunPolicies(run_dir, cfg, env_id, tuple(range(first, first + n)), total_steps, eval_freq,
                       final if os.path.isfile(final) else None, checkpoints, offset)


def run_folders(path: str) -> list[str]:
    """``[path]`` for a run folder; a sweep's point folders (``points/<label>/``) in grid order."""
    cfg = _read_config(path)
    if not cfg.get("sweep"):
        return [path]
    grid = _grid(cfg, path)
    found = {}
    root = os.path.join(path, "points")
    for name in sorted(os.listdir(root)) if os.path.isdir(root) else ():
        values = _point_values(os.path.join(root, name, "point.json"))
        if values is not None and values in grid:
            found[grid.index(values)] = os.path.join(root, name)
    if not found:
        raise PolicyError(f"{path}: a sweep without point folders (points/<label>/point.json)")
    return [found[i] for i in sorted(found)]


def load_policy(run_dir: str, seed: int = 0, step: int | None = None, dtype=None,
                matmul_dtype: str | None = None) -> Policy:
    """The :class:`Policy` of seed id ``seed`` of ``run_dir`` (a run folder or a sweep point's
    folder; an exported ``.npz`` file is read with :func:`load_exported`): from final_policy.npz, or
    at ``step`` (final_policy.npz at ``total_steps``, else the checkpoint at that step). ``dtype``
    (default: the run's precision) and ``matmul_dtype`` (default: what the run multiplied in) override."""
    if os.path.isfile(run_dir):
        policy = load_exported(run_dir)
        return policy if dtype is None and matmul_dtype is None else _with(policy, dtype, matmul_dtype)
    run = run_policies(run_dir)
    pos = run.seed_position(seed)
    if step is None:
        if run.final is None:
            raise PolicyError(f"{run_dir}: no {FINAL} (the run has not finished); policies there: "
                              f"{run.describe_steps()}")
        step = run.total_steps
    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or int(step) not in run.steps:
        raise PolicyError(f"{run_dir}: no policy at step {step!r}; valid steps: {run.describe_steps()}")
    step = int(step)
    names = actor_leaf_names(run.config, run_dir)
    if run.final is not None and step == run.total_steps:
        flat = _read_final(run.final, names, len(run.seeds), pos)
    else:
        from swim_jax.policy import checkpoint as policy_checkpoint  # orbax (JAX) only for checkpoints

        obs_size, low, _high = env_spec(run.env_id)
        shapes = actor_leaf_shapes(run.config, obs_size, low.size, run_dir)
        try:
            flat = policy_checkpoint.actor_leaves(run.checkpoints, step, run.lane_offset + pos, names, shapes)
        except ValueError as e:
            raise PolicyError(f"{run.checkpoints}/{step}: {one_line(e)}") from None
    return policy_from_leaves(flat, run.config, run_dir, _run_dtype(run.config) if dtype is None else dtype,
                              provenance.config_matmul_dtype(run_dir, run.config) if matmul_dtype is None else matmul_dtype,
                              {"run": os.path.abspath(run_dir), "seed": int(seed), "step": step})


def actor_leaf_names(cfg: Mapping, where: str = "config") -> tuple[str, ...]:
    """The actor's flat parameter names for ``cfg`` (swim_jax/agents/networks.py's layout, as in
    final_policy.npz), sorted as JAX flattens them: ``params/body/act_<i>/<param>`` (learnable
    runs), ``params/body/dense_<i>/{bias,kernel}``, ``params/body/head/{bias,kernel}``."""
    hidden, name, _values, learnable = _network(cfg, where)
    params = _activation_params(name, where)
    names = [f"params/body/dense_{i}/{leaf}" for i in range(len(hidden)) for leaf in ("bias", "kernel")]
    names += ["params/body/head/bias", "params/body/head/kernel"]
    if learnable:
        names += [f"params/body/act_{i}/{p}" for i in range(len(hidden)) for p in params]
    return tuple(sorted(names))


def actor_leaf_shapes(cfg: Mapping, obs_size: int, action_size: int, where: str = "config") -> tuple[tuple[int, ...], ...]:
    """The shapes of :func:`actor_leaf_names`' leaves (one seed's) for the env's sizes (the head
    ``HEADS[head]`` outputs per action dimension, :func:`policy_head`)."""
    hidden = _network(cfg, where)[0]
    widths = (obs_size, *hidden, action_size * HEADS[policy_head(cfg, where)])
    shape = {f"{'head' if i == len(hidden) else f'dense_{i}'}/{leaf}": (widths[i + 1],) if leaf == "bias"
             else (widths[i], widths[i + 1]) for i in range(len(hidden) + 1) for leaf in ("bias", "kernel")}
    return tuple(shape.get(n.split("/", 2)[2], ()) for n in actor_leaf_names(cfg, where))


def policy_from_leaves(flat: Mapping[str, np.ndarray], cfg: Mapping, where: str, dtype, matmul_dtype: str,
                       source: Mapping | None = None, spec: tuple | None = None) -> Policy:
    """The :class:`Policy` of one seed's actor leaves (``{name: array}``, no seed axis) under the
    run config ``cfg`` (hidden widths, activation and its parameters, env id); ``spec``: the env's
    (obs size, action low, action high), default :func:`env_spec` of the config's env."""
    hidden, name, values, learnable = _network(cfg, where)
    names = _activation_params(name, where)
    defaults = {p: q.default for p, q in inspect.signature(activations_np.get(name)).parameters.items()}
    layer = lambda i: f"params/body/{'head' if i == len(hidden) else f'dense_{i}'}"
    kernels = tuple(flat[f"{layer(i)}/kernel"] for i in range(len(hidden) + 1))
    biases = tuple(flat[f"{layer(i)}/bias"] for i in range(len(hidden) + 1))
    got = [int(w.shape[1]) for w in kernels[:-1]]
    if got != list(hidden):
        raise PolicyError(f"{where}: actor parameters of widths {got} do not match config.yaml's "
                          f"agent.hidden {list(hidden)}")
    if learnable:
        params = tuple({p: float(np.asarray(flat[f"params/body/act_{i}/{p}"])) for p in names} for i in range(len(hidden)))
    else:
        params = tuple({p: values.get(p, defaults[p]) for p in names} for _ in hidden)  # missing: older config
    obs_size, low, high = env_spec(cfg["env"]["id"]) if spec is None else spec
    head = policy_head(cfg, where)
    if (kernels[0].shape[0], kernels[-1].shape[1]) != (obs_size, low.size * HEADS[head]):
        raise PolicyError(f"{where}: the actor maps {kernels[0].shape[0]} observations to {kernels[-1].shape[1]} "
                          f"outputs, {cfg['env']['id']} has {obs_size} and {low.size} actions ({head} head: "
                          f"{HEADS[head]} outputs per action)")
    try:
        return Policy(cfg["env"]["id"], kernels, biases, name, params, low, high, np.dtype(dtype), matmul_dtype,
                      source or {}, head)
    except PolicyError as e:
        raise PolicyError(f"{where}: {e}") from None


def _with(policy: Policy, dtype, matmul_dtype) -> Policy:
    return Policy(policy.env_id, policy.kernels, policy.biases, policy.activation, policy.layer_params,
                  policy.action_low, policy.action_high, policy.dtype if dtype is None else np.dtype(dtype),
                  policy.matmul_dtype if matmul_dtype is None else matmul_dtype, policy.source, policy.head)


def policy_head(cfg: Mapping, where: str = "config") -> str:
    """The actor head (:data:`HEADS`) of the run config's ``agent.kind`` (td3 when it names none)."""
    kind = (cfg.get("agent") or {}).get("kind", "td3") if isinstance(cfg.get("agent"), Mapping) else "td3"
    if kind not in AGENT_HEADS:
        raise PolicyError(f"{where}/config.yaml: unknown agent.kind {kind!r}; valid: {', '.join(AGENT_HEADS)}")
    return AGENT_HEADS[kind]


def _read_config(run_dir: str) -> dict:
    path = os.path.join(run_dir, "config.yaml")
    if not os.path.isfile(path):
        raise PolicyError(f"{run_dir}: no config.yaml (not a run folder of python -m swim_jax.train)")
    try:
        with open(path) as f:
            cfg = yaml.safe_load(f)
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as e:
        raise PolicyError(f"{path}: unreadable YAML ({one_line(e)})") from None
    if not isinstance(cfg, dict):
        raise PolicyError(f"{path}: expected a mapping")
    return cfg


def _run_dtype(cfg: Mapping) -> np.dtype:
    return np.dtype(np.float64 if cfg.get("precision") == "float64" else np.float32)


def _network(cfg: Mapping, where: str):
    """(hidden widths, activation name, its config values {param: float}, learnable)."""
    try:
        agent = cfg["agent"]
        act = agent["activation"]
        hidden = tuple(int(h) for h in agent.get("hidden", (256, 256)))
        values = {k: float(v) for k, v in act.items() if k not in ("name", "learnable") and v is not None}
        return hidden, str(act["name"]), values, bool(act.get("learnable", False))
    except (KeyError, TypeError, ValueError, AttributeError) as e:
        raise PolicyError(f"{where}/config.yaml: missing or invalid agent settings ({one_line(e)})") from None


def _activation_params(name: str, where: str) -> tuple[str, ...]:
    """The parameters activation ``name`` takes (its NumPy twin's keywords)."""
    try:
        return tuple(list(inspect.signature(activations_np.get(name)).parameters)[1:])
    except ValueError as e:
        raise PolicyError(f"{where}/config.yaml: {e}") from None


def _read_final(path: str, names: tuple[str, ...], seeds: int, pos: int) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as z:
            flat = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError) as e:
        raise PolicyError(f"{path}: unreadable ({one_line(e)})") from None
    if sorted(flat) != sorted(names):
        raise PolicyError(f"{path}: arrays {', '.join(sorted(flat))} do not match config.yaml's actor "
                          f"({', '.join(names)})")
    if any(v.ndim < 1 or v.shape[0] != seeds for v in flat.values()):
        raise PolicyError(f"{path}: arrays must have a leading axis of {seeds} seeds")
    return {k: v[pos] for k, v in flat.items()}


def _grid(cfg: Mapping, where: str) -> list[dict[str, float]]:
    """The sweep's points in lane order (the first key varying slowest), as swim_jax.config makes them."""
    try:
        sweep = {k: [float(v) for v in vs] for k, vs in dotted_keys(cfg["sweep"]).items()}
    except (TypeError, ValueError, AttributeError) as e:
        raise PolicyError(f"{where}/config.yaml: invalid sweep ({one_line(e)})") from None
    return [dict(zip(sweep, combo)) for combo in itertools.product(*sweep.values())]


def _point_values(path: str) -> dict[str, float] | None:
    try:
        with open(path) as f:
            return {k: float(v) for k, v in json.load(f)["values"].items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def _point_lanes(point_dir: str, point_json: str, seeds: int) -> tuple[str | None, int]:
    """(the sweep's checkpoints folder, this point's first lane) for a point folder; (None, 0) when
    the sweep folder above it cannot say which point it is."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(point_dir)))
    values = _point_values(point_json)
    try:
        grid = _grid(_read_config(root), root)
    except PolicyError:
        return None, 0
    if values is None or values not in grid:
        return None, 0
    return os.path.join(root, CHECKPOINTS), grid.index(values) * seeds


def _seed_range(seeds: tuple[int, ...]) -> str:
    return str(seeds[0]) if len(seeds) == 1 else f"{seeds[0]}..{seeds[-1]}"
