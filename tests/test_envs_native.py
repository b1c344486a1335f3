"""The native backend (``envs.make(..., backend="mujoco")``: MuJoCo C inside the jitted program)
against Gymnasium's own env, bit for bit in float64.

Teacher forcing: every recorded Gymnasium pre-step state (1000 random + 1000 sine-controller
steps) is stepped by our env with the recorded action, all at once (the lanes split over the
thread pool): obs, reward and terminated equal Gymnasium's exactly. Closed loop: from
Gymnasium's reset state, the same 1000 actions (resetting both where Gymnasium terminates) give
Gymnasium's trajectory exactly. In float32 JAX the physics stays float64 (carried as raw bits),
so observations are exactly Gymnasium's rounded to float32. The default call into MuJoCo is the
XLA FFI handler (swim_jax/envs/physics/native_ffi.cc) where it builds; the Python callback is checked against
Gymnasium too, and against the FFI call bit for bit.
"""

import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from swim_jax import envs
from swim_jax.envs import gym_reference as gr
from swim_jax.envs.physics import native_ffi
from envcases import N_STEPS, env_params

ALL = ("Hopper-v5", "Walker2d-v5", "HalfCheetah-v5", "Swimmer-v5", "Ant-v5", "Hopper-v4",
       "Walker2d-v4")
FAST = ("Hopper-v5", "HalfCheetah-v5")



@pytest.fixture(scope="module")
def recordings():
    cache = {}

    def get(env_id):
        if env_id not in cache:
            cache[env_id] = gr.record_random_and_sine(env_id, N_STEPS, seed=7)
        return cache[env_id]

    return get


@pytest.mark.parametrize("call", ["auto", "callback"])
@pytest.mark.parametrize("env_id", env_params(ALL, fast=FAST))
def test_teacher_forced_float64_is_bit_identical(env_id, call, x64, recordings):
    rec = recordings(env_id)
    st = gr.run_teacher_forced(envs.make(env_id, backend="mujoco", native_call=call), rec)
    assert st.obs.dtype == jnp.float64
    np.testing.assert_array_equal(np.asarray(st.obs), rec["obs"])
    np.testing.assert_array_equal(np.asarray(st.reward), rec["reward"])
    np.testing.assert_array_equal(np.asarray(st.done) > 0, rec["terminated"])


@pytest.mark.parametrize("env_id", env_params(ALL, fast=("HalfCheetah-v5",)))
def test_teacher_forced_float32_obs_are_gymnasiums_rounded(env_id, recordings):
    """float32 JAX: the physics is still float64, so obs = float32(Gymnasium's obs) exactly; the
    reward (computed from float32 positions) within 1e-4, terminations identical."""
    assert not jax.config.jax_enable_x64
    rec = recordings(env_id)
    st = gr.run_teacher_forced(envs.make(env_id, backend="mujoco"), rec)
    assert st.obs.dtype == jnp.float32
    np.testing.assert_array_equal(np.asarray(st.obs), rec["obs"].astype(np.float32))
    assert np.abs(np.asarray(st.reward, np.float64) - rec["reward"]).max() <= 1e-4
    np.testing.assert_array_equal(np.asarray(st.done) > 0, rec["terminated"])


def closed_loop(env_id, n_steps=1000, seed=3):
    """Run Gymnasium and our native env side by side from Gymnasium's reset state with the same
    random actions (both reset to Gymnasium's next reset state when it terminates); returns the
    stacked (ours, theirs) obs, rewards and terminated flags."""
    import gymnasium as gym

    env = envs.make(env_id, backend="mujoco")
    genv = gym.make(env_id).unwrapped
    rng = np.random.default_rng(seed)
    reset = jax.jit(lambda q, v: env.reset(jax.random.PRNGKey(0)).replace(
        pipeline_state=env.physics_reset(q, v)))
    observe = jax.jit(lambda st: st.replace(obs=env.observation(st.pipeline_state)))
    step = jax.jit(env.step)
    ours, theirs = {"obs": [], "reward": [], "term": []}, {"obs": [], "reward": [], "term": []}

    def restart():
        obs, _ = genv.reset(seed=int(rng.integers(2**31)))
        st = observe(reset(jnp.asarray(genv.data.qpos), jnp.asarray(genv.data.qvel)))
        ours["obs"].append(np.asarray(st.obs))
        theirs["obs"].append(obs)
        return st

    st = restart()
    for _ in range(n_steps):
        a = rng.uniform(-1.0, 1.0, env.action_size).astype(np.float32).astype(np.float64)
        obs, reward, term, _, _ = genv.step(a)
        st = step(st, jnp.asarray(a))
        terminated = (st.done > 0) & (st.info["truncation"] == 0)
        for d, o, r, t in ((ours, st.obs, st.reward, terminated), (theirs, obs, reward, term)):
            d["obs"].append(np.asarray(o))
            d["reward"].append(float(r))
            d["term"].append(bool(t))
        if term:
            st = restart()
    genv.close()
    return ({k: np.asarray(v) for k, v in ours.items()}, {k: np.asarray(v) for k, v in theirs.items()})


@pytest.mark.parametrize("env_id", env_params(ALL, fast=("Hopper-v5",)))
def test_closed_loop_1000_steps_is_gymnasiums_trajectory(env_id, x64):
    ours, theirs = closed_loop(env_id)
    if env_id.startswith("Hopper"):
        assert theirs["term"].sum() >= 5  # several episodes, resets included
    for k in ("obs", "reward", "term"):
        np.testing.assert_array_equal(ours[k], theirs[k], err_msg=k)


def test_nested_vmap_reaches_the_host_once_with_every_lane():
    """A [2, 3] batch of resets and steps (nested vmap, broadcast_all) equals each lane alone."""
    env = envs.make("Hopper-v5", backend="mujoco")
    keys = jax.random.split(jax.random.PRNGKey(1), 6).reshape(2, 3, 2)
    actions = jax.random.uniform(jax.random.PRNGKey(2), (2, 3, env.action_size), minval=-1, maxval=1)
    batched = jax.jit(jax.vmap(jax.vmap(lambda k, a: env.step(env.reset(k), a))))(keys, actions)
    one = jax.jit(lambda k, a: env.step(env.reset(k), a))
    for i in range(2):
        for j in range(3):
            single = one(keys[i, j], actions[i, j])
            np.testing.assert_array_equal(np.asarray(single.pipeline_state.exact),
                                          np.asarray(batched.pipeline_state.exact[i, j]))
            np.testing.assert_array_equal(np.asarray(single.obs), np.asarray(batched.obs[i, j]))


def test_unknown_backend_is_one_line_naming_the_valid_ones():
    with pytest.raises(ValueError, match=r"^unknown backend 'bullet'; valid backends: mjx, mujoco$"):
        envs.make("Hopper-v5", backend="bullet")


@pytest.mark.parametrize("shape", [(1,), (3,), (6,), (8,), (17,), (14, 6), (300,)])
def test_reward_arithmetic_rounds_as_numpy(shape, x64):
    """swim_jax.envs.terms: sum_of_squares == np.sum(np.square(x)), w * sum_of_squares - f rounds like
    NumPy (no fused multiply-add), true_divide == x / dt, bit for bit on 200 random vectors."""
    from swim_jax.envs.terms import rounded, sum_of_squares, true_divide

    rng = np.random.default_rng(len(shape) * 100 + shape[0])
    x = rng.normal(size=(200, *shape)) * 10.0 ** rng.integers(-3, 3, size=(200, *shape))
    f = rng.normal(size=200)
    ours = jax.jit(jax.vmap(lambda v, g: (sum_of_squares(v), g - rounded(0.1 * sum_of_squares(v)),
                                          true_divide(g, 0.008))))(x, f)
    ss = np.array([np.sum(np.square(v)) for v in x])
    np.testing.assert_array_equal(np.asarray(ours[0]), ss)
    np.testing.assert_array_equal(np.asarray(ours[1]), f - 0.1 * ss)
    np.testing.assert_array_equal(np.asarray(ours[2]), f / 0.008)


def test_a_one_lane_program_with_other_outputs_runs_repeatedly():
    """One vmapped lane plus another output (as the training program's init has), called
    repeatedly: the host-side MuJoCo objects live with the env, never on XLA's callback threads
    (an MjData freed there, without a Python thread state, crashed the process)."""
    env = envs.make("Hopper-v5", backend="mujoco")
    f = jax.jit(jax.vmap(lambda k: (env.step(env.reset(k), jnp.zeros(env.action_size)), jnp.zeros((100, 11)))))
    for seed in range(3):
        st, _ = f(jax.random.split(jax.random.PRNGKey(seed), 1))
        assert st.obs.shape == (1, 11) and np.all(np.isfinite(np.asarray(st.obs)))


def test_lanes_on_mujocos_thread_pool_equal_lanes_stepped_serially():
    """8 lanes × 30 steps of HalfCheetah on 2 threads and on one: the same bits, resets included."""
    def run(threads: int, pool_min_seconds: float):
        env = envs.make("HalfCheetah-v5", backend="mujoco", native_call="callback")
        native = env.native_physics
        native.threads, native.POOL_MIN_SECONDS = threads, pool_min_seconds
        keys = jax.random.split(jax.random.PRNGKey(3), 8)
        actions = jax.random.uniform(jax.random.PRNGKey(4), (30, 8, env.action_size), minval=-1, maxval=1)
        step = jax.vmap(env.step)
        f = jax.jit(lambda k, a: jax.lax.scan(lambda s, x: (step(s, x), s.pipeline_state.exact),
                                              jax.vmap(env.reset)(k), a)[1])
        out = np.asarray(f(keys, actions))
        assert native._batches[8].sims.nthread == threads
        return out

    np.testing.assert_array_equal(run(2, 0.0), run(1, 1.0))


needs_ffi = pytest.mark.skipif(native_ffi.library() is None,
                               reason=f"native physics FFI unavailable: {native_ffi.unavailable_reason()}")


def _rollout_bits(env_id: str, call: str, lanes: int = 3, steps: int = 300):
    """obs, reward, done and state bits of ``steps`` random-action steps of ``lanes`` vmapped
    lanes with auto-reset (one jitted scan)."""
    env = envs.make(env_id, backend="mujoco", native_call=call)
    assert env.native_physics.call == call, env.native_physics.call_reason

    def rollout(key):
        state = jax.vmap(env.reset)(jax.random.split(key, lanes))

        def body(st, k):
            a = jax.random.uniform(k, (lanes, env.action_size), minval=-1, maxval=1)
            st, _ = envs.step_autoreset_lanes(env, st, a, jax.random.split(jax.random.fold_in(k, 1), lanes))
            return st, (st.obs, st.reward, st.done, st.pipeline_state.exact)

        return jax.lax.scan(body, state, jax.random.split(key, steps))[1]

    return [np.asarray(x) for x in jax.jit(rollout)(jax.random.PRNGKey(0))]


@needs_ffi
@pytest.mark.parametrize("env_id", ["Hopper-v5", "Ant-v5"])
def test_ffi_call_and_python_callback_give_the_same_bits(env_id):
    """300 steps × 3 lanes of random actions with auto-reset (Hopper falls and resets often; Ant's
    observation reads contact forces): obs, rewards, dones and the float64 state bits of the XLA
    FFI call equal the Python callback's exactly."""
    ffi, callback = _rollout_bits(env_id, "ffi"), _rollout_bits(env_id, "callback")
    if env_id == "Hopper-v5":
        assert callback[2].sum() >= 3  # resets happened
    for name, a, b in zip(("obs", "reward", "done", "exact"), ffi, callback):
        np.testing.assert_array_equal(a, b, err_msg=name)


@needs_ffi
def test_ffi_models_are_keyed_by_content_and_an_unknown_key_is_a_clear_error():
    hopper, again = envs.make("Hopper-v5", backend="mujoco"), envs.make("Hopper-v5", backend="mujoco")
    walker = envs.make("Walker2d-v5", backend="mujoco")
    assert hopper.native_physics.call == "ffi"
    assert hopper.native_physics.ffi_key == again.native_physics.ffi_key != walker.native_physics.ffi_key
    hopper.native_physics.ffi_key += 1  # a key no model was registered under
    with pytest.raises(Exception, match="is not registered in this process"):
        jax.block_until_ready(jax.jit(hopper.reset)(jax.random.PRNGKey(0)))


def test_native_call_choices_and_the_fallback_when_the_ffi_is_unavailable(monkeypatch):
    with pytest.raises(ValueError, match=r"^unknown native call 'python'; valid: auto, ffi, callback$"):
        envs.make("Hopper-v5", backend="mujoco", native_call="python")
    assert envs.make("Hopper-v5", backend="mujoco", native_call="callback").native_physics.call == "callback"
    monkeypatch.setattr(native_ffi, "library", lambda: None)
    monkeypatch.setattr(native_ffi, "_REASON", ["no C++ compiler (c++, g++ or clang++; or set CXX)"])
    auto = envs.make("Hopper-v5", backend="mujoco").native_physics
    assert auto.call == "callback" and "no C++ compiler" in auto.call_reason
    with pytest.raises(ValueError, match=r"^native_call=ffi: the native physics FFI is unavailable \(no C\+\+ compiler"):
        envs.make("Hopper-v5", backend="mujoco", native_call="ffi")


def test_a_failed_build_names_the_compiler_and_leaves_no_library(tmp_path, monkeypatch):
    monkeypatch.setenv("CXX", "false")  # a "compiler" that always fails
    with pytest.raises(RuntimeError, match=r"^false failed"):
        native_ffi._build(str(tmp_path / "native.so"))
    assert list(tmp_path.iterdir()) == []


def test_cache_pruning_deletes_only_stale_libraries_and_old_build_leftovers(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    folder = native_ffi.cache_dir()
    os.makedirs(folder)
    now = 1_000_000_000.0
    day = 86400.0
    ages = {"native_ffi-current.so": 400 * day, "native_ffi-recent.so": (native_ffi.STALE_DAYS - 1) * day,
            "native_ffi-stale.so": (native_ffi.STALE_DAYS + 1) * day, "tmpfresh.so": 0.5 * day,
            "tmpold.so": 2 * day, "notes.txt": 400 * day}
    for name, age in ages.items():
        path = os.path.join(folder, name)
        with open(path, "wb") as f:
            f.write(b"x")
        os.utime(path, (now - age, now - age))
    removed = native_ffi.prune_cache(keep=os.path.join(folder, "native_ffi-current.so"), now=now)
    assert sorted(os.path.basename(p) for p in removed) == ["native_ffi-stale.so", "tmpold.so"]
    assert sorted(os.listdir(folder)) == ["native_ffi-current.so", "native_ffi-recent.so", "notes.txt", "tmpfresh.so"]
