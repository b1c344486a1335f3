"""A trained actor as a plain NumPy function, without JAX (:class:`Policy`), and its export file.

    from swim_jax.policy import load_policy   # a run folder's policy: swim_jax.policy.run_folder
    policy = load_policy("runs/cheetah_swim-20260101-120000", seed=0)   # or step=100000
    action = policy(obs)              # obs [obs_size] or [..., obs_size], float64 or float32
    policy.export("cheetah_swim.npz") # self-contained: weights + a JSON header (see below)

:class:`Policy` is the deterministic policy of a run's actor (``swim_jax/agents/networks.py``),
a = tanh(h) · (high − low)/2 + (high + low)/2 with h the actor's head: for TD3 (``head``
``deterministic``) all of W_n σ(… σ(W_1 s + b_1) …) + b_n, for SAC (``gaussian``) its first half,
the mean of the Gaussian (the second half is its log-std, unused: the mean action). Computed with
NumPy in the run's precision (float32 or float64, ``dtype=`` to change it): σ is the NumPy twin of
the run's activation (``swim_jax.policy.activations``, the registry's ``numpy`` entries) with its
parameters per hidden layer: the config's values, a sweep point's own value (a point folder's
config.yaml), or the learned k/β/α of a learnable run (the ``act_<i>/<param>`` leaves of the actor).
Runs whose Dense layers multiplied in bfloat16 (``matmul_dtype=bfloat16``, or an old folder's
``auto`` that chose it) get the same rounding: inputs, kernels and biases rounded to bfloat16,
products summed in float32.

An exported file (:meth:`Policy.export`, :func:`load_exported`) is an ``.npz`` with the arrays
``W0 … Wn`` (kernels ``[in, out]``), ``b0 … bn`` and ``header``, a JSON string: ``format``
(``"swim-jax-policy"``), ``version``, ``env_id``, ``obs_size``, ``action_size``, ``hidden``,
``activation``, ``layer_params`` (one ``{param: value}`` per hidden layer), ``dtype``,
``matmul_dtype`` (``"full"`` or ``"bfloat16"``; files written before 2026-12-06 call it ``matmul``),
``action_low``, ``action_high``, ``source`` (run, seed, step), ``head`` (``deterministic`` or
``gaussian``: the action is tanh of the first ``action_size`` outputs; version 3; older files are
``deterministic``). README (Usage, "Trained policies outside the project") shows the NumPy lines
that run it without this project.

Every problem raises :class:`PolicyError` with one line naming what is wrong and what is valid.
"""

from __future__ import annotations

import functools
import inspect
import json
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from swim_jax.io.cli_parser import one_line
from swim_jax.policy import activations as activations_np

EXPORT_FORMAT = "swim-jax-policy"
EXPORT_VERSION = 3  # 2: the header key "matmul" became "matmul_dtype"; 3: "head" (older files still load)
MATMUL_DTYPES = ("full", "bfloat16")
# how the actor's head gives the action: outputs per action dimension (the action is tanh of the
# first action_size outputs, scaled): TD3's tanh head, SAC's Gaussian [mean; log-std]
HEADS = {"deterministic": 1, "gaussian": 2}


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
                          f"({one_line(e)})") from None
