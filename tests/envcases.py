"""Cases shared by the env tests: which env ids run by default, and teacher forcing against
Gymnasium's recorded trajectories (swim_jax.envs.gym_reference)."""

import numpy as np
import pytest

from swim_jax import envs
from swim_jax.envs import gym_reference as gr

N_STEPS = 1000  # steps of each recorded Gymnasium trajectory (random, then sine controller)
FAST = ("Hopper-v5", "HalfCheetah-v5")


def env_params(ids, fast=FAST):
    """pytest params: ``fast`` ids in the default run, the rest marked slow."""
    return [pytest.param(e, marks=[] if e in fast else [pytest.mark.slow]) for e in ids]


def teacher_forced_errors(env_id, **options):
    """Max abs obs / reward errors and terminated mismatches over both recorded trajectories."""
    env = envs.make(env_id, **options)
    rec = gr.record_random_and_sine(env_id, N_STEPS, seed=7)
    st = gr.run_teacher_forced(env, rec)
    obs = np.asarray(st.obs, np.float64)
    scale = np.maximum(1.0, np.abs(rec["obs"]))
    err = np.abs(obs - rec["obs"])
    return {
        "obs": float(err.max()),
        "obs_p99": float(np.percentile(err.max(axis=1), 99)),
        "obs_rel": float((np.abs(obs - rec["obs"]) / scale).max()),
        "reward": float(np.abs(np.asarray(st.reward, np.float64) - rec["reward"]).max()),
        "term_mismatch": int(((np.asarray(st.done) > 0) != rec["terminated"]).sum()),
        "n_terminated": int(rec["terminated"].sum()),
        "dtype": str(env.dtype),
    }
