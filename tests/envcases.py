"""Cases shared by the env tests: which env ids run by default, and teacher forcing against
Gymnasium's recorded trajectories (swim_jax.envs.gym_reference)."""

import functools

import jax
import numpy as np
import pytest

from swim_jax import envs
from swim_jax.envs import gym_reference as gr
from swim_jax.envs.physics import mjx_solver

N_STEPS = 1000  # steps of each recorded Gymnasium trajectory (random, then sine controller)
FAST = ("Hopper-v5", "HalfCheetah-v5")


def env_params(ids, fast=FAST):
    """pytest params: ``fast`` ids in the default run, the rest marked slow."""
    return [pytest.param(e, marks=[] if e in fast else [pytest.mark.slow]) for e in ids]


@functools.cache
def recording(env_id):
    """:func:`gym_reference.record_random_and_sine` of ``env_id`` (``N_STEPS`` of each policy, seed 7),
    recorded once per session: the random trajectory's first steps are ``record(env_id, n, "random",
    seed=7)``, the sine trajectory's are rows ``N_STEPS:`` (each a prefix: the same seed, the same
    draws)."""
    return gr.record_random_and_sine(env_id, N_STEPS, seed=7)


_TEACHER_FORCED = {}


def teacher_forced(env_id, **options):
    """``(recording, outputs)``: our ``envs.make(env_id, **options)`` teacher-forced on every step of
    :func:`recording`; ``outputs`` holds obs, reward, done (NumPy) and dtype. Computed once per
    session for each env, option set, precision (x64 mode) and line-search slope floor
    (``mjx_solver._SLOPE_NOISE``, read when the step is traced): an MJX step program takes minutes
    to compile on 2 cores, so the tests that need the same one share it."""
    key = (env_id, bool(jax.config.jax_enable_x64), float(mjx_solver._SLOPE_NOISE), tuple(sorted(options.items())))
    if key not in _TEACHER_FORCED:
        env = envs.make(env_id, **options)
        rec = recording(env_id)
        st = gr.run_teacher_forced(env, rec)
        _TEACHER_FORCED[key] = {"obs": np.asarray(st.obs), "reward": np.asarray(st.reward),
                                "done": np.asarray(st.done), "dtype": str(env.dtype)}
    return recording(env_id), _TEACHER_FORCED[key]


def teacher_forced_errors(env_id, **options):
    """Max abs obs / reward errors and terminated mismatches over both recorded trajectories."""
    rec, st = teacher_forced(env_id, **options)
    obs = np.asarray(st["obs"], np.float64)
    scale = np.maximum(1.0, np.abs(rec["obs"]))
    err = np.abs(obs - rec["obs"])
    return {
        "obs": float(err.max()),
        "obs_p99": float(np.percentile(err.max(axis=1), 99)),
        "obs_rel": float((np.abs(obs - rec["obs"]) / scale).max()),
        "reward": float(np.abs(np.asarray(st["reward"], np.float64) - rec["reward"]).max()),
        "term_mismatch": int(((st["done"] > 0) != rec["terminated"]).sum()),
        "n_terminated": int(rec["terminated"].sum()),
        "dtype": st["dtype"],
    }
