"""``swim_jax.policy`` (policy, run_folder, gymnasium_env): trained actors as NumPy functions, checked against the JAX actor and Gymnasium.

References: the registry's JAX activations (every entry's NumPy twin), the flax actor of
swim_jax/agents/networks.py (random parameters for every activation, learnable or not, float32/float64 and
bfloat16 matmuls; the actors of two tiny trained runs, a sweep's points included, as our
evaluation calls them), the training state's own tree structure (which checkpoint leaves are the
actor), and Gymnasium's env (float64, MuJoCo C: our env's rewards for the same state and actions).
The tiny runs are trained once per session (tests/conftest.py ``policy_runs``).
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from swim_jax import envs
from swim_jax.agents.td3 import TD3, ActivationConfig, TD3Config
from swim_jax.policy import activations as activations_np
from swim_jax.run import outputs, programs
from swim_jax.policy import policy as pol
from swim_jax.policy import gymnasium_env
from swim_jax.policy import run_folder
from swim_jax.activations import ACTIVATIONS, _check_registry
from swim_jax.run.render import unflatten

LOW, HIGH = (-1.0, -0.5, -2.0), (1.0, 2.0, 0.5)  # asymmetric: the tanh scaling is tested too
OBS_SIZE = 11


def within(got, ref, scale, tol):
    """|got − ref| <= tol·(|ref| + scale) everywhere (NaN where both are NaN)."""
    got, ref = np.asarray(got, np.float64), np.asarray(ref, np.float64)
    both_nan = np.isnan(got) & np.isnan(ref)
    same = (got == ref) | both_nan  # equal infinities
    with np.errstate(invalid="ignore"):
        err = np.where(same, 0.0, np.abs(got - ref))
    bound = tol * (np.abs(np.where(same, 0.0, ref)) + np.abs(scale))
    return bool(np.all(err <= bound)), float(np.nanmax(np.where(same, 0.0, err / np.maximum(bound / tol, 1e-300))))


# --------------------------------------------------------------------------- NumPy activations


def special_inputs(dtype) -> np.ndarray:
    big = float(np.finfo(dtype).max)
    c = 4.0 / np.sqrt(float(np.finfo(dtype).eps))  # Swim's saturation bound |kx|
    x = np.concatenate([np.linspace(-30, 30, 601), [1e3, -1e3, 1e10, -1e10, c, -c, 2 * c, -2 * c, c / 2, -c / 2,
                                                      big, -big, np.inf, -np.inf, np.nan, 0.0, -0.0, 1e-30]])
    with np.errstate(over="ignore"):
        return x.astype(dtype)


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize("name", sorted(ACTIVATIONS))
def test_numpy_twin_equals_the_jax_activation(name, dtype):
    """Every registry entry's NumPy implementation against its JAX function, at the defaults and at
    other parameter values, over ordinary, huge, infinite and NaN inputs: float64 within 1e-12 of
    max(|f|, |x|), float32 within 2e-6 (JAX's float32 Swim uses a Newton rsqrt, 7.5e-7 relative)."""
    spec = ACTIVATIONS[name]
    x = special_inputs(dtype)
    settings = [spec.defaults] + ([{p: v * 2.5 for p, v in spec.defaults.items()}] if spec.params else [])
    for params in settings:
        with jax.enable_x64(dtype == "float64"):
            ref = np.asarray(spec.fn(jnp.asarray(x), **params))
        got = spec.numpy(x, **params)
        assert got.dtype == np.dtype(dtype) and got.shape == x.shape
        ok, worst = within(got, ref, np.where(np.isfinite(x), x, 0), 1e-12 if dtype == "float64" else 2e-6)
        assert ok, f"{name}{params} {dtype}: worst error {worst:.3g} of the tolerance's scale"
        np.testing.assert_array_equal(np.isnan(got), np.isnan(ref))


def test_every_numpy_twin_is_registered_and_the_registry_refuses_a_wrong_one():
    assert set(activations_np.names()) == set(ACTIVATIONS)
    assert all(spec.numpy is activations_np.get(name) for name, spec in ACTIVATIONS.items())
    swim = ACTIVATIONS["swim"]
    with pytest.raises(ValueError, match="numpy= must be its NumPy implementation swim_jax.policy.activations.swim"):
        _check_registry({"swim": dataclasses.replace(swim, numpy=None)})
    with pytest.raises(ValueError, match="numpy= must be"):
        _check_registry({"swim": dataclasses.replace(swim, numpy=activations_np.swish)})
    with pytest.raises(ValueError, match=r"NumPy implementation takes \{'k': 0.5\}, the registry entry \{'k': 0.75\}"):
        _check_registry({"swim": dataclasses.replace(swim, params=(dataclasses.replace(swim.params[0], default=0.75),))})
    with pytest.raises(ValueError, match="unknown activation 'nope'; valid: elu, hard_swish, mish, relu, swim, swish"):
        activations_np.get("nope")


def test_round_bfloat16_is_jax_conversion():
    rng = np.random.default_rng(0)
    bits = rng.integers(0, 2**32, 20000, dtype=np.uint64).astype(np.uint32)
    x = np.concatenate([bits.view(np.float32), np.float32([0, -0, np.inf, -np.inf, np.nan, 3.4e38, -3.4e38,
                                                            1 + 2**-8, 1 + 3 * 2**-8, 1e-40])])  # ties, subnormal
    ref = np.asarray(jnp.asarray(x).astype(jnp.bfloat16).astype(jnp.float32))
    got = pol.round_bfloat16(x)
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, ref)


def test_known_xml_notices_are_the_envs():
    from swim_jax.envs.base import KNOWN_XML_NOTICES

    assert gymnasium_env.KNOWN_XML_NOTICES == KNOWN_XML_NOTICES


# --------------------------------------------------------------------------- the actor


def random_actor(name: str, learnable: bool, dtype, matmul_dtype=None, seed: int = 1):
    """(JAX agent, its actor parameters, the NumPy Policy of the same leaves): parameters off their
    defaults, learnable ones moved away from their initial values."""
    values = {p.name: p.default * 1.3 for p in ACTIVATIONS[name].params}
    agent = TD3(TD3Config(hidden=(16, 12), activation=ActivationConfig(name=name, learnable=learnable, **values)),
                OBS_SIZE, LOW, HIGH, dtype=dtype, matmul_dtype=matmul_dtype)
    actor = agent.actor_net.init(jax.random.PRNGKey(seed), jnp.zeros((1, OBS_SIZE), dtype))
    flat = outputs.flat_params(actor)
    flat = {k: v * (0.6 + 0.2 * i) if "/act_" in k else v for i, (k, v) in enumerate(sorted(flat.items()))}
    cfg = {"env": {"id": "Hopper-v5"}, "agent": {"hidden": [16, 12], "activation": {"name": name, "learnable": learnable,
                                                                                    **values}}}
    policy = run_folder.policy_from_leaves(flat, cfg, "test", np.dtype(dtype), "full" if matmul_dtype is None else "bfloat16",
                                    spec=(OBS_SIZE, np.asarray(LOW), np.asarray(HIGH)))
    return agent, jax.tree.map(jnp.asarray, unflatten(flat)), policy


CASES = [(name, learnable) for name, spec in ACTIVATIONS.items() for learnable in ((False, True) if spec.params else (False,))]


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize("name,learnable", CASES, ids=[f"{n}{'+learnable' if l else ''}" for n, l in CASES])
def test_numpy_policy_equals_the_jax_actor(name, learnable, dtype):
    """float64: within 1e-12; float32: within 1e-6 (actions in [low, high], a few float32 ulps)."""
    obs = np.random.default_rng(2).normal(size=(64, OBS_SIZE)) * 3
    with jax.enable_x64(dtype == "float64"):
        agent, params, policy = random_actor(name, learnable, jnp.dtype(dtype))
        ref = np.asarray(jax.jit(agent.act)(params, jnp.asarray(obs, dtype)))
    got = policy(obs)
    assert got.dtype == np.dtype(dtype) and got.shape == (64, 3)
    if learnable:  # each layer its own (moved) values
        assert policy.layer_params[0] != policy.layer_params[1]
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 if dtype == "float64" else 1e-6)
    np.testing.assert_allclose(policy(obs[5]), ref[5], rtol=0, atol=1e-12 if dtype == "float64" else 1e-6)  # one obs
    np.testing.assert_array_equal(policy(obs.astype(np.float32)), policy(obs.astype(np.float32).astype(np.float64)))
    assert np.all(got >= np.asarray(LOW, dtype)) and np.all(got <= np.asarray(HIGH, dtype))


@pytest.mark.parametrize("name,learnable", [("swim", False), ("swish", True), ("relu", False)])
def test_numpy_policy_with_bfloat16_matmuls_equals_the_jax_actor(name, learnable):
    """matmul_dtype=bfloat16 (inputs, kernels, biases rounded, float32 sums): equal to the float32
    rounding except where a float32 sum lands the next layer's input on the other side of a
    bfloat16 rounding boundary (one bfloat16 ulp there, 2⁻⁸ relative)."""
    obs = np.random.default_rng(3).normal(size=(256, OBS_SIZE)) * 3
    agent, params, policy = random_actor(name, learnable, jnp.float32, jnp.bfloat16)
    ref = np.asarray(jax.jit(agent.act)(params, jnp.asarray(obs, jnp.float32)))
    got = policy(obs)
    err = np.abs(got - ref)
    assert np.mean(err <= 1e-6) >= 0.95 and err.max() <= 2e-2, (np.mean(err <= 1e-6), err.max())
    full = run_folder._with(policy, None, "full")(obs)  # the rounding matters: without it most actions differ
    assert np.mean(np.abs(full - ref) <= 1e-6) < 0.5


def test_policy_input_checks_and_export_round_trip(tmp_path):
    _, _, policy = random_actor("swim", True, jnp.float32)
    with pytest.raises(ValueError, match=r"obs of shape \(10,\): expected \[\.\.\., 11\]"):
        policy(np.zeros(10))
    assert policy(np.zeros((2, 5, OBS_SIZE))).shape == (2, 5, 3) and policy(np.zeros(OBS_SIZE)).shape == (3,)
    path = str(tmp_path / "p.npz")
    policy.export(path)
    again = pol.load_exported(path)
    obs = np.random.default_rng(4).normal(size=(8, OBS_SIZE))
    np.testing.assert_array_equal(again(obs), policy(obs))
    assert again.header() == policy.header() and again.header()["layer_params"][1]["k"] == policy.layer_params[1]["k"]
    np.save(tmp_path / "x.npy", np.zeros(3))
    with pytest.raises(pol.PolicyError, match="not a policy file written by python -m swim_jax.evaluate --export"):
        pol.load_exported(str(tmp_path / "x.npy"))


# --------------------------------------------------------------------------- trained runs


def jax_actor(res, lane: int, point: dict | None = None, params=None):
    """``obs -> action`` of lane ``lane`` as our evaluation computes it (the run's own agent, the
    lane's sweep values through ``with_hparams``); parameters: the final actor, or ``params``."""
    prog = programs.programs(res.cfg)  # the run's (cached) program: also sets the run's x64 mode
    hp = {k.split(".", 1)[1]: jnp.asarray(v, prog.agent.dtype) for k, v in (point or {}).items()}
    if params is None:
        params = unflatten({k: v[lane] for k, v in res.final_actor.items()})
    params = jax.tree.map(jnp.asarray, params)
    return lambda obs: np.asarray(prog.agent.with_hparams(hp).act(params, jnp.asarray(obs, prog.agent.dtype)))


def observations(n=50, seed=5):
    return np.random.default_rng(seed).normal(size=(n, OBS_SIZE)) * 2


def test_load_policy_of_a_learnable_float64_run_equals_its_jax_actor(policy_runs):
    res = policy_runs["f64"]
    obs = observations()
    for pos, seed in enumerate((0, 1)):
        policy = run_folder.load_policy(res.run_dir, seed=seed)
        assert policy.dtype == np.float64 and policy.matmul_dtype == "full" and policy.env_id == "Hopper-v5"
        learned = [layer["k"] for layer in policy.layer_params]
        np.testing.assert_array_equal(learned, [float(res.final_actor[f"params/body/act_{i}/k"][pos]) for i in (0, 1)])
        assert all(k != 0.5 for k in learned)  # learned, not the config's k
        np.testing.assert_allclose(policy(obs), jax_actor(res, pos)(obs), rtol=0, atol=1e-12)
        assert policy.source == {"run": os.path.abspath(res.run_dir), "seed": seed, "step": 2000}


def test_load_policy_of_sweep_points_uses_each_points_value(policy_runs):
    """The sweep's points (float32, bfloat16 matmuls): each point's beta from its config.yaml, as the
    lane's swept value in our evaluation; the sweep folder itself is refused with its points."""
    res = policy_runs["sweep"]
    obs = observations()
    with pytest.raises(pol.PolicyError, match=r"is a sweep of 2 points; pass one of its point folders: "
                                              r"points/beta=0.5, points/beta=2"):
        run_folder.load_policy(res.run_dir)
    points = run_folder.run_folders(res.run_dir)
    assert [os.path.basename(p) for p in points] == ["beta=0.5", "beta=2"]
    for lane, (folder, beta) in enumerate(zip(points, (0.5, 2.0))):
        policy = run_folder.load_policy(folder, seed=0)
        assert policy.matmul_dtype == "bfloat16" and policy.dtype == np.float32
        assert policy.layer_params == ({"beta": beta}, {"beta": beta})
        ref = jax_actor(res, lane, {"agent.activation.beta": beta})(obs)
        err = np.abs(policy(obs) - ref)
        assert np.mean(err <= 1e-6) >= 0.95 and err.max() <= 2e-2
    assert run_folder.run_policies(points[1]).lane_offset == 1


def checkpoint_actor_by_structure(res, step: int, lane: int):
    """Lane ``lane``'s actor at checkpoint ``step``, its leaves found from the training state's own
    tree structure (the paths ``.agent.actor…`` of ``init_fn``'s output, as train.py saves it: the
    tuple (state, evaluations), each leaf under its path's names, orbax's nested mapping)."""
    import orbax.checkpoint as ocp

    prog = programs.programs(res.cfg)
    template = jax.eval_shape(prog.init_fn, *programs.lanes(res.cfg, prog, None).init_args)
    paths = []
    for path, _ in jax.tree_util.tree_flatten_with_path(template)[0]:
        if getattr(path[0], "name", None) == "agent" and getattr(path[1], "name", None) == "actor":
            paths.append(["0", "agent", "actor", *(str(p.key) for p in path[2:])])
    item = os.path.join(res.run_dir, "checkpoints", str(step), "default")
    meta = ocp.StandardCheckpointer().metadata(item).item_metadata.tree

    def nested(leaf):
        out = {}
        for parts in paths:
            node, m = out, meta
            for part in parts[:-1]:
                node, m = node.setdefault(part, {}), m[part]
            node[parts[-1]] = leaf(m[parts[-1]])
        return out

    out = ocp.PyTreeCheckpointer().restore(item, args=ocp.args.PyTreeRestore(
        item=nested(lambda m: np.zeros(m.shape, m.dtype)),
        restore_args=nested(lambda m: ocp.RestoreArgs(restore_type=np.ndarray)), partial_restore=True))

    leaves = {}
    for parts in paths:
        node = out
        for part in parts:
            node = node[part]
        leaves["/".join(parts[3:])] = np.asarray(node)[lane]
    return unflatten(leaves)


def test_load_policy_at_a_checkpoint_step(policy_runs):
    res = policy_runs["f64"]
    obs = observations()
    run = run_folder.run_policies(res.run_dir)
    assert run.steps == (1000, 2000) and run.checkpoint_steps == (1000, 2000)
    early = run_folder.load_policy(res.run_dir, seed=1, step=1000)
    assert early.source["step"] == 1000
    ref = jax_actor(res, 1, params=checkpoint_actor_by_structure(res, 1000, 1))(obs)
    np.testing.assert_allclose(early(obs), ref, rtol=0, atol=1e-12)
    assert np.abs(early(obs) - run_folder.load_policy(res.run_dir, seed=1)(obs)).max() > 1e-6  # another policy
    # the final checkpoint read through the checkpoint path equals final_policy.npz exactly
    from swim_jax.policy import checkpoint as policy_checkpoint

    names = run_folder.actor_leaf_names(run.config)
    leaves = policy_checkpoint.actor_leaves(run.checkpoints, 2000, 1, names, run_folder.actor_leaf_shapes(run.config, 11, 3))
    for name in names:
        np.testing.assert_array_equal(leaves[name], res.final_actor[name][1])
    # a sweep point's lanes in the sweep's checkpoints
    sweep = policy_runs["sweep"]
    point = run_folder.run_folders(sweep.run_dir)[1]
    ref = jax_actor(sweep, 1, {"agent.activation.beta": 2.0}, checkpoint_actor_by_structure(sweep, 1000, 1))(obs)
    err = np.abs(run_folder.load_policy(point, seed=0, step=1000)(obs) - ref)
    assert np.mean(err <= 1e-6) >= 0.95 and err.max() <= 2e-2


def test_load_policy_errors(policy_runs, tmp_path):
    run = policy_runs["f64"].run_dir
    for call, message in [
        (lambda: run_folder.load_policy(str(tmp_path / "nope")), r"nope: no such run folder"),
        (lambda: run_folder.load_policy(str(tmp_path)), r"no config.yaml \(not a run folder of python -m swim_jax.train\)"),
        (lambda: run_folder.load_policy(run, seed=2), r"seed 2 is not in .*: its seeds are 0..1"),
        (lambda: run_folder.load_policy(run, step=1500), r"no policy at step 1500; valid steps: checkpoints at 1000, 2000; "
                                                  r"final_policy.npz at 2000"),
    ]:
        with pytest.raises(pol.PolicyError, match=message):
            call()


# --------------------------------------------------------------------------- no JAX, Gymnasium


def test_policy_runs_without_jax(policy_runs, no_jax_env, tmp_path):
    """In a process where importing jax fails: load_policy (a run, a sweep point), the forward
    pass, export and load_exported; the actions equal this process's."""
    run, point = policy_runs["f64"].run_dir, run_folder.run_folders(policy_runs["sweep"].run_dir)[0]
    obs = observations(4)
    np.save(tmp_path / "obs.npy", obs)
    code = f"""
import sys
import numpy as np
try:
    import jax
except ImportError:
    pass
else:
    raise SystemExit("jax imported")
from swim_jax.policy import load_exported, load_policy
obs = np.load({str(tmp_path / 'obs.npy')!r})
a = load_policy({run!r}, seed=1)
b = load_policy({point!r}, seed=0)
a.export({str(tmp_path / 'a.npz')!r})
np.save({str(tmp_path / 'out.npy')!r}, np.stack([a(obs), b(obs).astype(np.float64), load_exported({str(tmp_path / 'a.npz')!r})(obs)]))
assert not any(m.split(".")[0] in ("jax", "jaxlib", "flax", "orbax") for m in sys.modules), sorted(sys.modules)
"""
    p = subprocess.run([sys.executable, "-c", code], env=no_jax_env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    out = np.load(tmp_path / "out.npy")
    np.testing.assert_array_equal(out[0], run_folder.load_policy(run, seed=1)(obs))
    np.testing.assert_array_equal(out[1], run_folder.load_policy(point, seed=0)(obs))
    np.testing.assert_array_equal(out[2], out[0])


def test_gymnasium_return_equals_our_envs_for_the_same_state_and_actions(policy_runs, x64):
    """float64, MuJoCo C: episodes of the trained tiny policy in Gymnasium's Hopper-v5 from its reset
    states; our env (env.backend=mujoco) put in each reset state and given the same actions
    returns the same rewards, step for step, and terminates at the same step; our env driven by
    the JAX actor on its own observations gives the same return to 1e-9."""
    res = policy_runs["f64"]
    policy = run_folder.load_policy(res.run_dir, seed=1)
    env = envs.make("Hopper-v5", backend="mujoco")
    assert env.dtype == jnp.float64
    reset = jax.jit(lambda q, v: env.reset(jax.random.PRNGKey(0)).replace(pipeline_state=env.physics_reset(q, v)))
    observe = jax.jit(lambda st: st.replace(obs=env.observation(st.pipeline_state)))
    step = jax.jit(env.step)
    act = jax_actor(res, 1)
    genv = gymnasium_env.make_gymnasium("Hopper-v5")
    lengths = []
    for reset_seed in (0, 1, 2):
        obs, _ = genv.reset(seed=reset_seed)
        q, v = np.array(genv.unwrapped.data.qpos), np.array(genv.unwrapped.data.qvel)
        actions, rewards, done = [], [], False
        while not done:
            a = policy(obs)
            obs, r, term, trunc, _ = genv.step(a)
            actions.append(a)
            rewards.append(r)
            done = term or trunc
        lengths.append(len(rewards))
        st = observe(reset(jnp.asarray(q), jnp.asarray(v)))
        ours, ours_done = [], []
        for a in actions:
            st = step(st, jnp.asarray(a))
            ours.append(float(st.reward))
            ours_done.append(bool(st.done > 0))
        np.testing.assert_array_equal(ours, rewards)
        assert ours_done == [False] * (len(rewards) - 1) + [True]
        assert sum(ours) == sum(rewards)
        st, total = observe(reset(jnp.asarray(q), jnp.asarray(v))), 0.0
        for _ in range(1000):
            st = step(st, act(st.obs))
            total += float(st.reward)
            if st.done > 0:
                break
        assert total == pytest.approx(sum(rewards), rel=1e-9)
    genv.close()
    assert all(1 < n < 1000 for n in lengths)  # real episodes, ended by termination
