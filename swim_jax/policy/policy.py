"""Trained policies as plain NumPy functions, without JAX: ``load_policy(run_dir, seed=0)``.

    from swim_jax.policy import load_policy
    policy = load_policy("runs/cheetah_swim-20260101-120000", seed=0)   # or step=100000
    action = policy(obs)              # obs [obs_size] or [..., obs_size], float64 or float32
    policy.export("cheetah_swim.npz") # self-contained: weights + a JSON header (see below)

:class:`Policy` is the deterministic policy of a run's actor (``swim_jax/agents/networks.py``),
a = tanh(h) · (high − low)/2 + (high + low)/2 with h the actor's head: for TD3 (``head``
``deterministic``) all of W_n σ(… σ(W_1 s + b_1) …) + b_n, for SAC (``gaussian``) its first half, the
mean of the Gaussian (the second half is its log-std, unused: the mean action). Computed with NumPy in the run's precision (float32 or float64,
``dtype=`` to change it): σ is the NumPy twin of the run's activation (``swim_jax.policy.activations``,
the registry's ``numpy`` entries) with its parameters per hidden layer: the config's values, a
sweep point's own value (a point folder's config.yaml), or the learned k/β/α of a learnable run
(the ``act_<i>/<param>`` leaves of the actor). Runs whose Dense layers multiplied in bfloat16
(``matmul_dtype=bfloat16``, or an old folder's ``auto`` that chose it) get the same rounding:
inputs, kernels and biases rounded to bfloat16, products summed in float32.

Where the parameters come from: ``final_policy.npz`` (the actor at ``total_steps``, leading axis =
seed), or with ``step=S`` the orbax checkpoint at step S (``checkpoints/<S>/``; reading one needs
orbax, i.e. the project's JAX stack: ``swim_jax.policy.checkpoint``). A sweep point's checkpoints are
the sweep's (``<sweep>/checkpoints``), its lanes ``point·seeds … point·seeds + seeds − 1``. The action
bounds are the actuators' ``ctrlrange`` of the env's MuJoCo model, read from Gymnasium's env (the
XML the project's envs load too).

An exported file (:meth:`Policy.export`, :func:`load_exported`) is an ``.npz`` with the arrays
``W0 … Wn`` (kernels ``[in, out]``), ``b0 … bn`` and ``header``, a JSON string: ``format``
(``"swim-jax-policy"``), ``version``, ``env_id``, ``obs_size``, ``action_size``, ``hidden``,
``activation``, ``layer_params`` (one ``{param: value}`` per hidden layer), ``dtype``, ``matmul_dtype``
(``"full"`` or ``"bfloat16"``; files written before 2026-12-06 call it ``matmul``), ``action_low``, ``action_high``, ``source`` (run, seed, step),
``head`` (``deterministic`` or ``gaussian``: the action is tanh of the first ``action_size`` outputs;
version 3; older files are ``deterministic``). README
(Usage, "Trained policies outside the project") shows the NumPy lines that run it without this
project.

Every problem raises :class:`PolicyError` with one line naming what is wrong and what is valid.
"""

from __future__ import annotations

import functools
import inspect
import itertools
import json
import os
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np
import yaml

from swim_jax.policy import activations as activations_np
from swim_jax.io import provenance
from swim_jax.io.cli_parser import dotted_keys

FINAL = "final_policy.npz"
CHECKPOINTS = "checkpoints"
EXPORT_FORMAT = "swim-jax-policy"
EXPORT_VERSION = 3  # 2: the header key "matmul" became "matmul_dtype"; 3: "head" (older files still load)
MATMUL_DTYPES = ("full", "bfloat16")
# how the actor's head gives the action: outputs per action dimension (the action is tanh of the
# first action_size outputs, scaled): TD3's tanh head, SAC's Gaussian [mean; log-std]
HEADS = {"deterministic": 1, "gaussian": 2}
# the head of each agent.kind (swim_jax.agents.registry: each agent's POLICY_HEAD; a test checks they agree)
AGENT_HEADS = {"td3": "deterministic", "sac": "gaussian"}


class PolicyError(ValueError):
    """A missing or inconsistent run folder, seed, step or policy file; ``str(e)`` is one line."""


def round_bfloat16(x: np.ndarray) -> np.ndarray:
    """``x`` rounded to the nearest bfloat16 (ties to even, as XLA converts), in ``x``'s dtype:
    the float32 bits with the low 16 rounded off (NaN kept; values past bfloat16's range → ±inf)."""
    x = np.asarray(x)
    bits = np.ascontiguousarray(x, np.float32).view(np.uint32)
    rounded = ((bits + np.uint32(0x7FFF) + ((bits >> 16) & np.uint32(1))) & np.uint32(0xFFFF0000)).view(np.float32)
    return np.where(np.isnan(x), x, rounded.astype(x.dtype))


# ------------------------------------------------------------------------------------------------
# the policy
# ------------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Policy:
    """A run's deterministic policy in NumPy: ``policy(obs) -> action`` (see the module docstring).

    ``kernels[i]`` is ``[in, out]`` (hidden layers, then the head), ``layer_params[i]`` the
    activation's parameters in hidden layer ``i``; ``matmul_dtype`` is ``"full"`` or ``"bfloat16"``;
    ``head`` one of :data:`HEADS` (the head has ``HEADS[head]`` outputs per action dimension)."""

    env_id: str
    kernels: tuple[np.ndarray, ...]
    biases: tuple[np.ndarray, ...]
    activation: str
    layer_params: tuple[Mapping[str, float], ...]
    action_low: np.ndarray
    action_high: np.ndarray
    dtype: np.dtype = np.dtype(np.float32)
    matmul_dtype: str = "full"
    source: Mapping = field(default_factory=dict)
    head: str = "deterministic"

    def __post_init__(self):
        dt = np.dtype(self.dtype)
        if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
            raise PolicyError(f"dtype {dt} is not supported; valid: float32, float64")
        if self.matmul_dtype not in MATMUL_DTYPES:
            raise PolicyError(f"unknown matmul_dtype {self.matmul_dtype!r}; valid: {', '.join(MATMUL_DTYPES)}")
        if self.head not in HEADS:
            raise PolicyError(f"unknown head {self.head!r}; valid: {', '.join(HEADS)}")
        try:
            fn = activations_np.get(self.activation)
        except ValueError as e:
            raise PolicyError(str(e)) from None
        kernels = tuple(np.asarray(w, dt) for w in self.kernels)
        biases = tuple(np.asarray(b, dt) for b in self.biases)
        if not kernels or len(biases) != len(kernels) or len(self.layer_params) != len(kernels) - 1:
            raise PolicyError(f"{len(kernels)} kernels, {len(biases)} biases and {len(self.layer_params)} hidden "
                              f"layers' activation parameters: expected n, n and n - 1 (n >= 1)")
        for i, (w, b) in enumerate(zip(kernels, biases)):
            fan_in = kernels[0].shape[0] if i == 0 else kernels[i - 1].shape[1]
            if w.ndim != 2 or w.shape[0] != fan_in or b.shape != (w.shape[1],):
                raise PolicyError(f"layer {i}: kernel {w.shape} and bias {b.shape} do not chain (expected "
                                  f"[{fan_in}, out] and [out])")
        names = list(inspect.signature(fn).parameters)[1:]
        params = tuple({p: float(v[p]) for p in names} if set(v) == set(names) else None for v in self.layer_params)
        if None in params:
            bad = self.layer_params[params.index(None)]
            raise PolicyError(f"activation {self.activation!r} takes {', '.join(names) or 'no parameters'}, "
                              f"got {', '.join(bad) or 'none'}")
        low, high = (np.asarray(v, np.float64).reshape(-1) for v in (self.action_low, self.action_high))
        outputs = kernels[-1].shape[1]
        if low.shape != (outputs // HEADS[self.head],) or high.shape != low.shape or outputs % HEADS[self.head]:
            raise PolicyError(f"action bounds {low.shape}/{high.shape} do not match the {self.head} head's "
                              f"{outputs} outputs ({HEADS[self.head]} per action)")
        set_ = functools.partial(object.__setattr__, self)
        set_("dtype", dt)
        set_("kernels", kernels)
        set_("biases", biases)
        set_("layer_params", params)
        set_("action_low", low)
        set_("action_high", high)
        set_("source", dict(self.source))
        if self.matmul_dtype == "bfloat16":  # the rounded operands, once
            set_("_operands", tuple((round_bfloat16(w), round_bfloat16(b)) for w, b in zip(kernels, biases)))
        else:
            set_("_operands", tuple(zip(kernels, biases)))
        set_("_fn", fn)

    @property
    def obs_size(self) -> int:
        return int(self.kernels[0].shape[0])

    @property
    def action_size(self) -> int:
        return int(self.kernels[-1].shape[1]) // HEADS[self.head]

    @property
    def hidden(self) -> tuple[int, ...]:
        return tuple(int(w.shape[1]) for w in self.kernels[:-1])

    def __call__(self, obs) -> np.ndarray:
        """The deterministic action of ``obs`` (``[obs_size]`` or ``[..., obs_size]``, any real dtype,
        cast to the policy's), in the policy's dtype, of shape ``[..., action_size]``."""
        x = np.asarray(obs)
        if x.ndim < 1 or x.shape[-1] != self.obs_size:
            raise ValueError(f"obs of shape {x.shape}: expected [..., {self.obs_size}] ({self.env_id})")
        x = x.astype(self.dtype)
        last = len(self._operands) - 1
        for i, (w, b) in enumerate(self._operands):
            if self.matmul_dtype == "bfloat16":
                x = round_bfloat16(x)
            x = x @ w + b
            if i < last:
                x = self._fn(x, **self.layer_params[i])
        x = x[..., : self.action_size]  # a Gaussian head's mean (its log-std half unused)
        low, high = self.action_low.astype(self.dtype), self.action_high.astype(self.dtype)
        return np.tanh(x) * (high - low) / 2 + (high + low) / 2  # as the agents' act (TD3's Actor, SAC's mean)

    # --------------------------------------------------------------------------------- export

    def header(self) -> dict:
        """The exported file's JSON header (see the module docstring)."""
        return {
            "format": EXPORT_FORMAT, "version": EXPORT_VERSION, "env_id": self.env_id,
            "obs_size": self.obs_size, "action_size": self.action_size, "hidden": list(self.hidden),
            "activation": self.activation, "layer_params": [dict(p) for p in self.layer_params],
            "dtype": self.dtype.name, "matmul_dtype": self.matmul_dtype,
            "action_low": self.action_low.tolist(), "action_high": self.action_high.tolist(),
            "source": dict(self.source), "head": self.head,
        }

    def export(self, path: str) -> None:
        """Write the self-contained policy file ``path`` (``.npz``; weights in the policy's dtype)."""
        arrays = {f"W{i}": w for i, w in enumerate(self.kernels)}
        arrays.update({f"b{i}": b for i, b in enumerate(self.biases)})
        with open(path, "wb") as f:
            np.savez(f, header=np.asarray(json.dumps(self.header())), **arrays)


def load_exported(path: str) -> Policy:
    """The :class:`Policy` of a file written by :meth:`Policy.export`."""
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        head = json.loads(str(arrays.pop("header")))
        if head.get("format") != EXPORT_FORMAT:
            raise ValueError(f"format {head.get('format')!r}, expected {EXPORT_FORMAT!r}")
        n = len(head["hidden"]) + 1
        return Policy(head["env_id"], tuple(arrays[f"W{i}"] for i in range(n)), tuple(arrays[f"b{i}"] for i in range(n)),
                      head["activation"], tuple(head["layer_params"]), np.asarray(head["action_low"]),
                      np.asarray(head["action_high"]), np.dtype(head["dtype"]), head.get("matmul_dtype", head.get("matmul")),
                      head.get("source", {}), head.get("head", "deterministic"))
    except PolicyError as e:
        raise PolicyError(f"{path}: {e}") from None
    except (OSError, ValueError, KeyError, TypeError, EOFError) as e:
        raise PolicyError(f"{path}: not a policy file written by python -m swim_jax.evaluate --export "
                          f"({_one_line(e)})") from None


# ------------------------------------------------------------------------------------------------
# run folders
# ------------------------------------------------------------------------------------------------


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
        raise PolicyError(f"{run_dir}/config.yaml: missing or invalid key {_one_line(e)}") from None
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
            raise PolicyError(f"{run.checkpoints}/{step}: {_one_line(e)}") from None
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


# MuJoCo's notices about Gymnasium's own XML files, dropped when Gymnasium makes an env (as
# swim_jax.envs.base.KNOWN_XML_NOTICES drops them for our envs; tests/test_policy.py checks they agree)
KNOWN_XML_NOTICES = ("compiler attribute 'settotalmass' is deprecated",)


def make_gymnasium(env_id: str, **kwargs):
    """``gymnasium.make(env_id, **kwargs)`` with the known MuJoCo notices about Gymnasium's XML
    dropped (printed and appended to ./MUJOCO_LOG.TXT otherwise); other MuJoCo warnings become
    Python warnings."""
    import warnings

    import gymnasium as gym
    import mujoco

    previous = mujoco.get_mju_user_warning()
    messages: list[str] = []
    mujoco.set_mju_user_warning(messages.append)
    try:
        return gym.make(env_id, **kwargs)
    finally:
        mujoco.set_mju_user_warning(previous)
        for message in messages:
            if not any(notice in message for notice in KNOWN_XML_NOTICES):
                warnings.warn(f"MuJoCo: {message}", stacklevel=3)


@functools.cache
def env_spec(env_id: str) -> tuple[int, np.ndarray, np.ndarray]:
    """(observation size, action low, action high) of Gymnasium's ``env_id``; the bounds (float64)
    are the ``ctrlrange`` of its MuJoCo model's actuators, which ``envs`` reads from the same XML for
    the actor's tanh scaling."""
    try:
        env = make_gymnasium(env_id)
    except Exception as e:  # gymnasium raises several types for unknown or broken ids
        raise PolicyError(f"env {env_id!r}: Gymnasium cannot make it ({_one_line(e)})") from None
    try:
        ctrl = np.array(env.unwrapped.model.actuator_ctrlrange, np.float64)
        obs_size = int(np.prod(env.observation_space.shape))
    finally:
        env.close()
    return obs_size, ctrl[:, 0].copy(), ctrl[:, 1].copy()


# ------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------


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
        raise PolicyError(f"{path}: unreadable YAML ({_one_line(e)})") from None
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
        raise PolicyError(f"{where}/config.yaml: missing or invalid agent settings ({_one_line(e)})") from None


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
        raise PolicyError(f"{path}: unreadable ({_one_line(e)})") from None
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
        raise PolicyError(f"{where}/config.yaml: invalid sweep ({_one_line(e)})") from None
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


def _one_line(e: BaseException) -> str:
    s = str(e) or type(e).__name__
    return " ".join(s.split())[:300]
