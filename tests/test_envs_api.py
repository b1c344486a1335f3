"""Contract tests for envs.make / ENV_IDS / step_autoreset / time limit (real MJX physics)."""

import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from swim_jax import envs

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_registry_ids():
    assert envs.ENV_IDS == ("Hopper-v5", "Walker2d-v5", "HalfCheetah-v5", "Swimmer-v5", "Ant-v5",
                            "Hopper-v4", "Walker2d-v4")


def test_unknown_id_and_option_raise_one_line():
    with pytest.raises(ValueError) as e:
        envs.make("Hopper-v2")
    msg = str(e.value)
    assert "\n" not in msg and all(i in msg for i in envs.ENV_IDS)
    with pytest.raises(ValueError) as e:
        envs.make("Hopper-v5", frame_skip=3)
    msg = str(e.value)
    assert "\n" not in msg and "frame_skip" in msg and "max_episode_steps" in msg


def test_solver_options_reach_the_model_and_bad_values_raise_one_line():
    env = envs.make("Hopper-v5", solver_tolerance=0.0, solver_iterations=3, ls_iterations=5)
    assert (env.mj_model.opt.tolerance, env.mj_model.opt.iterations, env.mj_model.opt.ls_iterations) == (0.0, 3, 5)
    assert envs.make("Hopper-v5").mj_model.opt.tolerance == pytest.approx(1e-8)  # the XML's value
    for bad in (-1e-3, float("nan")):
        with pytest.raises(ValueError) as e:
            envs.make("Hopper-v5", solver_tolerance=bad)
        assert "\n" not in str(e.value) and "solver_tolerance must be >= 0" in str(e.value)
    assert envs.make("Hopper-v5").solver_impl == "c" and envs.make("Hopper-v5", solver_impl="mjx").solver_impl == "mjx"
    with pytest.raises(ValueError) as e:
        envs.make("Hopper-v5", solver_impl="cg")
    assert "\n" not in str(e.value) and "solver_impl must be one of c, mjx, got 'cg'" in str(e.value)


def test_dtype_option_checked_against_x64():
    with pytest.raises(ValueError):
        envs.make("Hopper-v5", dtype=jnp.float64)  # default run is float32


@pytest.mark.parametrize("env_id,obs_size,act_size,dt", [
    ("Hopper-v5", 11, 3, 0.008), ("Walker2d-v5", 17, 6, 0.008), ("HalfCheetah-v5", 17, 6, 0.05),
    ("Swimmer-v5", 8, 2, 0.04), ("Ant-v5", 105, 8, 0.05), ("Hopper-v4", 11, 3, 0.008),
    ("Walker2d-v4", 17, 6, 0.008)])
def test_sizes_bounds_and_gymnasium_spaces(env_id, obs_size, act_size, dt):
    import gymnasium as gym
    env = envs.make(env_id)
    genv = gym.make(env_id)
    assert env.observation_size == obs_size == genv.observation_space.shape[0]
    assert env.action_size == act_size == genv.action_space.shape[0]
    assert env.dt == pytest.approx(dt) and env.dt == pytest.approx(genv.unwrapped.dt)
    np.testing.assert_array_equal(np.asarray(env.action_low), genv.action_space.low)
    np.testing.assert_array_equal(np.asarray(env.action_high), genv.action_space.high)
    assert env.backend == "mjx"
    genv.close()


@pytest.fixture(scope="module", params=["mujoco", pytest.param("mjx", marks=pytest.mark.slow)])
def short_hopper(request):
    """Hopper-v5 with a 3-step time limit and a jitted, vmapped step_autoreset (compiled once per
    module), on each physics backend: the time limit and the auto-reset are the backends' shared
    JAX code (swim_jax/envs/base.py, autoreset.py), so the default run takes MuJoCo C (compiles in
    seconds); MJX (minutes) runs with -m slow, and trains end to end in tests/test_sweep.py."""
    env = envs.make("Hopper-v5", max_episode_steps=3, backend=request.param)
    reset = jax.jit(jax.vmap(env.reset))
    step = jax.jit(jax.vmap(lambda s, a, k: envs.step_autoreset(env, s, a, k)))
    return env, reset, step


def test_truncation_and_autoreset_keep_final_obs(short_hopper):
    env, reset, step = short_hopper
    n = 2
    state = reset(jax.random.split(jax.random.PRNGKey(0), n))
    assert state.obs.dtype == jnp.float32 and state.done.dtype == jnp.float32
    zero_a = jnp.zeros((n, env.action_size))
    keys = jax.random.split(jax.random.PRNGKey(1), 3 * n).reshape(3, n, 2)
    prev_obs = state.obs
    for t in range(3):
        state, final_obs = step(state, zero_a, keys[t])
        # the true reached obs is continuous with the previous one (one 8 ms step)
        assert np.abs(np.asarray(final_obs - prev_obs))[:, :5].max() < 0.05
        if t < 2:
            assert np.all(np.asarray(state.done) == 0)
            np.testing.assert_array_equal(state.obs, final_obs)
            assert np.all(np.asarray(state.info["steps"]) == t + 1)
        prev_obs = final_obs
    assert np.all(np.abs(np.asarray(state.reward) - 1.0) < 0.5)  # healthy reward of the step
    # third step hit the limit without terminating (zero action: hopper stands at t=3)
    np.testing.assert_array_equal(np.asarray(state.done), 1.0)
    np.testing.assert_array_equal(np.asarray(state.info["truncation"]), 1.0)
    np.testing.assert_array_equal(np.asarray(state.info["steps"]), 0.0)
    fresh = reset(keys[2])
    np.testing.assert_allclose(state.obs, fresh.obs, atol=1e-7)
    assert not np.allclose(np.asarray(state.obs), np.asarray(final_obs))


def test_termination_is_not_truncation(short_hopper):
    """Lane 0 pushed past the angle limit terminates (not truncated) and restarts; lane 1 goes on.
    Batch 2, as the truncation test: the same compiled step serves both."""
    env, reset, step = short_hopper
    state = reset(jax.random.split(jax.random.PRNGKey(2), 2))
    # push lane 0's angle out of (-0.2, 0.2): its next step terminates (set through physics_reset:
    # the native backend steps from its exact state, not from the qpos view)
    data = state.pipeline_state
    state = state.replace(pipeline_state=jax.jit(jax.vmap(env.physics_reset))(data.qpos.at[0, 2].set(0.5), data.qvel))
    state, final_obs = step(state, jnp.zeros((2, env.action_size)),
                            jax.random.split(jax.random.PRNGKey(3), 2))
    assert float(state.done[0]) == 1.0 and float(state.info["truncation"][0]) == 0.0
    assert float(final_obs[0, 1]) > 0.2  # the true terminal observation (angle) is kept
    assert abs(float(state.obs[0, 1])) <= 5e-3  # continued from a fresh reset
    assert float(state.done[1]) == 0.0 and float(state.info["steps"][1]) == 1.0


def test_step_autoreset_lanes_equals_step_autoreset_lane_by_lane():
    """envs.step_autoreset_lanes (resets computed only when some lane finished) gives exactly the
    vmapped step_autoreset over 8 steps of 3 lanes with a 3-step limit and one lane terminating;
    native backend (compiles in seconds; the auto-reset logic is backend-independent)."""
    env = envs.make("Hopper-v5", max_episode_steps=3, backend="mujoco")
    state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), 3))
    lanes = jax.jit(lambda s, a, k: envs.step_autoreset_lanes(env, s, a, k))
    one_by_one = jax.jit(jax.vmap(lambda s, a, k: envs.step_autoreset(env, s, a, k)))
    a_keys = jax.random.split(jax.random.PRNGKey(1), 8)
    r_keys = jax.random.split(jax.random.PRNGKey(2), 24).reshape(8, 3, 2)
    ours, ref = state, state
    dones = []
    for t in range(8):
        actions = jax.random.uniform(a_keys[t], (3, env.action_size), minval=-1.0, maxval=1.0)
        if t == 0:  # lane 2 falls at once: a termination before the time limit
            push = lambda s: s.replace(pipeline_state=jax.vmap(env.physics_reset)(
                s.pipeline_state.qpos.at[2, 2].set(0.5), s.pipeline_state.qvel))
            ours, ref = push(ours), push(ref)
        ours, fo = lanes(ours, actions, r_keys[t])
        ref, fr = one_by_one(ref, actions, r_keys[t])
        for x, y in zip(jax.tree.leaves((ours, fo)), jax.tree.leaves((ref, fr))):
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
        dones.append(np.asarray(ours.done))
    dones = np.array(dones)
    assert dones[0, 2] == 1 and dones[0, :2].sum() == 0  # steps with and without resets were taken
    assert (dones.sum(axis=1) == 0).any() and dones[2].sum() >= 2


def test_making_an_env_prints_nothing_and_writes_no_mujoco_log(tmp_path):
    """Gymnasium's half_cheetah.xml draws MuJoCo's settotalmass deprecation notice on every load
    (printed, and appended to ./MUJOCO_LOG.TXT): building the env shows neither."""
    code = "from swim_jax import envs; envs.make('HalfCheetah-v5', backend='mujoco'); print('made')"
    env = {**os.environ, "PYTHONPATH": REPO}
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout == "made\n"
    assert "settotalmass" not in out.stderr
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
