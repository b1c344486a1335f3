"""Teacher-forced equivalence with Gymnasium in float64 (JAX x64 mode): bound 1e-8 absolute.

x64 mode is switched on only inside this module's fixture and restored afterwards, so the rest
of the session keeps float32. The envs are built while x64 is on (the physics dtype follows x64).
"""

import jax
import pytest

from test_envs_equivalence import env_params, teacher_forced_errors

ATOL_F64 = 1e-8
# Measured (docs/ENVS.md): rewards meet 1e-8; observations do not at every step, because C's and
# MJX's Newton solvers both stop at MuJoCo's 1e-8 cost tolerance along different paths, leaving
# joint velocities ~1e-6 apart at stiff contact states (unchanged with the uncapped 100/50
# solver). Max obs ceilings: about 3x the measured maxima (Hopper 3.6e-8, HalfCheetah 2.5e-6);
# envs not yet measured in float64 get 1e-5.
MAX_OBS_F64 = {"Hopper-v5": 1e-7, "Hopper-v4": 1e-7, "HalfCheetah-v5": 1e-5}
# the default run checks Hopper-v5 (HalfCheetah-v5 and the rest are marked slow)
ALL = ("Hopper-v5", "Walker2d-v5", "HalfCheetah-v5", "Swimmer-v5", "Ant-v5", "Hopper-v4",
       "Walker2d-v4")


@pytest.fixture(scope="module")
def x64():
    prev = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", prev)


@pytest.mark.parametrize("env_id", env_params(ALL, fast=("Hopper-v5",)))
def test_teacher_forced_float64(env_id, x64, record_property):
    err = teacher_forced_errors(env_id)
    record_property("errors", err)
    print(env_id, err)
    assert err["dtype"] == "float64"
    assert err["term_mismatch"] == 0, err
    assert err["reward"] <= ATOL_F64, err
    assert err["obs"] <= MAX_OBS_F64.get(env_id, 1e-5), err
