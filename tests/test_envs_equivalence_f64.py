"""Teacher-forced equivalence with Gymnasium in float64 (JAX x64 mode): bound 1e-8 absolute.

x64 mode is switched on only inside this module's fixture and restored afterwards, so the rest
of the session keeps float32. The envs are built while x64 is on (the physics dtype follows x64).
"""

import jax
import pytest

from test_envs_equivalence import env_params, teacher_forced_errors

ATOL_F64 = 1e-8
# the default run checks the two tasks the TD3 work starts with; the rest are marked slow
ALL = ("Hopper-v5", "Walker2d-v5", "HalfCheetah-v5", "Swimmer-v5", "Ant-v5", "Hopper-v4",
       "Walker2d-v4")


@pytest.fixture(scope="module")
def x64():
    prev = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", prev)


@pytest.mark.parametrize("env_id", env_params(ALL))
def test_teacher_forced_float64(env_id, x64, record_property):
    err = teacher_forced_errors(env_id)
    record_property("errors", err)
    print(env_id, err)
    assert err["dtype"] == "float64"
    assert err["term_mismatch"] == 0, err
    assert err["reward"] <= ATOL_F64, err
    assert err["obs"] <= ATOL_F64, err
