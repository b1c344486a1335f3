"""Teacher-forced equivalence with Gymnasium in float64 (JAX x64 mode): bound 1e-8 absolute.

x64 mode is switched on only inside this module's fixture and restored afterwards, so the rest
of the session keeps float32. The envs are built while x64 is on (the physics dtype follows x64).
"""

import jax
import numpy as np
import pytest

from test_envs_equivalence import env_params, teacher_forced_errors

ATOL_F64 = 1e-8
# Measured (docs/ENVS.md) with MuJoCo C's Newton solver (envs/mjx_solver.py): obs <= 6.3e-13 and
# rewards <= 4.5e-14 for every env but Ant (with MJX's own solver: up to 2.5e-6, HalfCheetah).
ANT = ("Ant's multi-contact steps still differ from MuJoCo C in float64 (state 7.7e-5, cfrc_ext "
       "1.0e-3 at a few steps; p99 3e-5); lead: RK4 quaternion stages, see docs/ENVS.md")
# The default run checks Hopper-v5 (terminations) and HalfCheetah-v5 (most contact events).
ALL = ("Hopper-v5", "Walker2d-v5", "HalfCheetah-v5", "Swimmer-v5", "Ant-v5", "Hopper-v4",
       "Walker2d-v4")


@pytest.fixture(scope="module")
def x64():
    prev = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", prev)


@pytest.mark.parametrize("env_id", env_params(ALL, fast=("Hopper-v5", "HalfCheetah-v5"),
                                                  xfail={"Ant-v5": ANT}))
def test_teacher_forced_float64(env_id, x64, record_property):
    err = teacher_forced_errors(env_id)
    record_property("errors", err)
    print(env_id, err)
    assert err["dtype"] == "float64"
    assert err["term_mismatch"] == 0, err
    assert err["reward"] <= ATOL_F64, err
    assert err["obs"] <= ATOL_F64, err


def test_rk4_step_matches_mujoco_c_for_a_free_joint(x64):
    """envs.mjx_compat.rungekutta4_c: one MJX RK4 step of Ant (free root joint, constraints off so
    only the integrator is compared) equals MuJoCo C's mj_step to 1e-9; MJX's own RK4 is ~1e-6 off."""
    import mujoco
    import numpy as np
    from mujoco import mjx

    from envs.base import gymnasium_asset_path

    m = mujoco.MjModel.from_xml_path(gymnasium_asset_path("ant.xml"))
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    rng = np.random.default_rng(0)
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0 + rng.uniform(-0.3, 0.3, m.nq)
    d.qpos[3:7] /= np.linalg.norm(d.qpos[3:7])
    d.qvel[:] = rng.normal(0.0, 2.0, m.nv)
    d.ctrl[:] = rng.uniform(-1.0, 1.0, m.nu)
    mujoco.mj_forward(m, d)
    dx = jax.jit(mjx.step)(mjx.put_model(m), mjx.put_data(m, d))
    mujoco.mj_step(m, d)
    assert np.abs(np.asarray(dx.qpos) - d.qpos).max() <= 1e-9
    assert np.abs(np.asarray(dx.qvel) - d.qvel).max() <= 1e-9


def test_c_solver_path_is_what_closes_the_float64_gap(x64):
    """The float64 bound is met because of envs/mjx_solver.py: on the first 100 steps of the
    HalfCheetah sine recording, MJX's own solver (``solver_impl="mjx"``, same tolerance 1e-8)
    misses Gymnasium by > 1e-7 (2.5e-6 measured, step 43), MuJoCo C's path (default) by <= 1e-8."""
    import envs
    from envs import gym_reference as gr

    rec = gr.record("HalfCheetah-v5", 100, "sine", seed=7)
    err = {}
    for impl in ("c", "mjx"):
        st = gr.run_teacher_forced(envs.make("HalfCheetah-v5", solver_impl=impl), rec)
        err[impl] = float(np.abs(np.asarray(st.obs) - rec["obs"]).max())
    assert err["c"] <= ATOL_F64 and err["mjx"] > 1e-7, err
