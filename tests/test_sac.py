"""SAC (``agent.kind=sac``) against independent references, and behind the same interface as TD3.

- one SAC update vs a float64 NumPy hand reference: the critic target with its entropy term, the
  tanh log-prob correction, the critic, actor and temperature losses, their gradients (central
  finite differences of the NumPy losses), the Adam steps and the target update;
- the squashed-Gaussian log-density vs scipy (the change of variables) and a numerical integral;
- a tiny SAC run (one compiled program for both seeds, module fixture): metrics.csv and TensorBoard
  carry SAC's metrics, a resume from a checkpoint equals the uninterrupted run bit for bit, the
  NumPy policy (final file, checkpoint and export) is the JAX mean action; a sweep of a SAC float;
- SAC-only keys given to TD3 and the reverse: one line, exit status 2;
- what derives from the registry: metrics.csv's core columns, the report's panels, the NumPy heads.
"""

from __future__ import annotations

import math
import os
import shutil

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.flatten_util import ravel_pytree
from scipy import integrate, stats

from swim_jax import config as cfgmod
from swim_jax.agents import registry, replay
from swim_jax.agents.base import ActivationConfig
from swim_jax.agents.sac import SAC, SACConfig, squashed_gaussian
from swim_jax.agents.td3 import TD3
from swim_jax.io import learning_log, tensorboard_log
from swim_jax.policy import load_exported, load_policy
from swim_jax.policy.run_folder import AGENT_HEADS
from swim_jax.run import train

OBS, ACT, B = 3, 2, 6
LOW, HIGH = (-1.0, -2.0), (1.0, 0.5)


# ------------------------------------------------------------------------------------------------
# the float64 NumPy hand reference
# ------------------------------------------------------------------------------------------------

def np_act(name: str, x: np.ndarray, k: float) -> np.ndarray:
    if name == "relu":
        return np.maximum(x, 0.0)
    if name == "swim":
        return x / 2 * (k * x / np.sqrt(1 + k * k * x * x) + 1)
    raise AssertionError(name)


def np_body(p: dict, x: np.ndarray, name: str, k: float) -> np.ndarray:
    """x @ W + b per layer (flax's dense_<i>, head), the activation after every hidden layer."""
    n = len([key for key in p if key.startswith("dense_")])
    for i in range(n):
        x = np_act(name, x @ p[f"dense_{i}"]["kernel"] + p[f"dense_{i}"]["bias"], k)
    return x @ p["head"]["kernel"] + p["head"]["bias"]


def np_q(critic: dict, s: np.ndarray, a: np.ndarray, name: str, k: float) -> np.ndarray:
    """[2, batch]: Q_j(s, a) of the twin critics (parameters stacked on the leading critic axis)."""
    body = critic["params"]["critics"]["body"]
    x = np.concatenate([s, a], -1)
    return np.stack([np_body(jax.tree.map(lambda w: w[j], body), x, name, k)[:, 0] for j in range(2)])


def np_policy(actor: dict, s: np.ndarray, noise: np.ndarray, cfg: SACConfig):
    """(a, log π(a|s)) by the SAC paper's change of variables (appendix C) with cleanrl's log-std
    squashing and its +1e-6 inside the correction's log."""
    out = np_body(actor["params"]["body"], s, cfg.activation.name, cfg.activation.k)
    mean, raw = out[:, :ACT], out[:, ACT:]
    log_std = cfg.log_std_min + 0.5 * (cfg.log_std_max - cfg.log_std_min) * (np.tanh(raw) + 1)
    std = np.exp(log_std)
    u = mean + std * noise
    m, c = (np.array(HIGH) - np.array(LOW)) / 2, (np.array(HIGH) + np.array(LOW)) / 2
    log_gauss = -((u - mean) ** 2) / (2 * std**2) - np.log(std) - 0.5 * np.log(2 * np.pi)
    log_prob = (log_gauss - np.log(m * (1 - np.tanh(u) ** 2) + 1e-6)).sum(-1)
    return np.tanh(u) * m + c, log_prob


def np_adam_first_step(p: np.ndarray, g: np.ndarray, lr: float) -> np.ndarray:
    """Adam's first step from zero moments: m̂ = g, v̂ = g², p − lr·g/(|g| + 1e-8)."""
    return p - lr * g / (np.sqrt(g * g) + 1e-8)


def fd_grad(f, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central finite differences of scalar ``f`` at the flat vector ``x``."""
    g = np.empty_like(x)
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        g[i] = (f(x + e) - f(x - e)) / (2 * h)
    return g


def flat(tree):
    """(flat float64 NumPy vector, vector -> NumPy pytree) of a JAX pytree."""
    v, unravel = ravel_pytree(tree)
    return np.asarray(v, np.float64), lambda x: jax.tree.map(np.asarray, unravel(jnp.asarray(x)))


@pytest.mark.parametrize("act_name", ["swim", "relu"])
def test_one_sac_update_matches_a_float64_numpy_hand_reference(act_name):
    """iteration 1 with policy_freq = target_freq = 1: critic step, one actor step, one temperature
    step, the target update; every loss, gradient and new parameter against NumPy."""
    with jax.enable_x64(True):
        cfg = SACConfig(hidden=(5,), activation=ActivationConfig(name=act_name, k=0.75), actor_lr=1e-2,
                        critic_lr=2e-2, alpha_lr=3e-2, discount=0.9, tau=0.05, policy_freq=1, target_freq=1,
                        batch_size=B)
        agent = SAC(cfg, OBS, LOW, HIGH, dtype=jnp.float64)
        state = agent.init(jax.random.PRNGKey(3))
        kp = jax.random.PRNGKey(11)  # targets unlike the online critics; α = 0.3 (not 1)
        state = state._replace(
            critic_target=jax.tree.map(lambda x: x - 0.1 * jax.random.normal(kp, x.shape, x.dtype), state.critic_target),
            log_alpha=jnp.asarray(math.log(0.3)))
        rng = np.random.default_rng(0)
        batch = replay.Transition(
            obs=jnp.asarray(rng.normal(size=(B, OBS))), action=jnp.asarray(rng.uniform(LOW, HIGH, size=(B, ACT))),
            reward=jnp.asarray(rng.normal(size=B)), next_obs=jnp.asarray(rng.normal(size=(B, OBS))),
            terminated=jnp.asarray([0.0, 1.0, 0.0, 0.0, 1.0, 0.0]))
        key = jax.random.PRNGKey(5)
        new, m = jax.jit(agent.update)(state, batch, key, jnp.int32(1))
        # the noise of each sample, from the keys as the module docstring splits them
        k_next, k_actor = jax.random.split(key)
        k_pi, k_alpha = jax.random.split(jax.random.split(k_actor, 1)[0])
        eps_next, eps_pi, eps_alpha = (np.asarray(jax.random.normal(k, (B, ACT), jnp.float64))
                                       for k in (k_next, k_pi, k_alpha))
        s, a, r, s2, d = (np.asarray(x, np.float64) for x in batch)
        name, k = act_name, 0.75
        alpha0 = 0.3

        # critic: target with the entropy term, loss, gradient, Adam step
        actor0 = jax.tree.map(np.asarray, state.actor)
        a2, logp2 = np_policy(actor0, s2, eps_next, cfg)
        y = r + 0.9 * (1 - d) * (np_q(jax.tree.map(np.asarray, state.critic_target), s2, a2, name, k).min(0) - alpha0 * logp2)
        np.testing.assert_allclose(agent.td_target(state.actor, state.critic_target, alpha0, batch, k_next), y,
                                   rtol=1e-12, atol=1e-12)
        th0, un_th = flat(state.critic)
        loss_q = lambda v: ((np_q(un_th(v), s, a, name, k) - y[None]) ** 2).mean(1).sum()
        np.testing.assert_allclose(float(m.critic_loss), loss_q(th0), rtol=1e-12)
        np.testing.assert_allclose(float(m.q_mean), np_q(un_th(th0), s, a, name, k)[0].mean(), rtol=1e-12)
        g_th = fd_grad(loss_q, th0)
        g_jax = ravel_pytree(jax.grad(lambda c: agent.critic_loss(c, batch, jnp.asarray(y))[0])(state.critic))[0]
        np.testing.assert_allclose(g_jax, g_th, rtol=1e-6, atol=1e-8)
        th1 = np_adam_first_step(th0, g_th, 2e-2)
        np.testing.assert_allclose(flat(new.critic)[0], th1, rtol=0, atol=1e-7)

        # actor: L_π = mean(α log π − min Q) on the new critics
        ph0, un_ph = flat(state.actor)
        critic1 = jax.tree.map(np.asarray, new.critic)

        def loss_pi(v):
            act, logp = np_policy(un_ph(v), s, eps_pi, cfg)
            return np.mean(alpha0 * logp - np_q(critic1, s, act, name, k).min(0))

        np.testing.assert_allclose(float(m.actor_loss), loss_pi(ph0), rtol=1e-10)
        g_ph = fd_grad(loss_pi, ph0)
        g_jax = ravel_pytree(jax.grad(lambda p: agent.actor_loss(p, new.critic, alpha0, batch.obs, k_pi)[0])(state.actor))[0]
        np.testing.assert_allclose(g_jax, g_ph, rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose(flat(new.actor)[0], np_adam_first_step(ph0, g_ph, 1e-2), rtol=0, atol=1e-7)

        # temperature: L_α = mean(−α (log π + H̄)) with H̄ = −|A|, a fresh sample of the new actor
        _, logp_new = np_policy(jax.tree.map(np.asarray, new.actor), s, eps_alpha, cfg)
        la0 = math.log(alpha0)
        loss_a = lambda la: np.mean(-np.exp(la) * (logp_new - ACT))
        g_la = -np.exp(la0) * np.mean(logp_new - ACT)  # d/d log α, by hand
        np.testing.assert_allclose(fd_grad(lambda v: loss_a(v[0]), np.array([la0]))[0], g_la, rtol=1e-7)
        np.testing.assert_allclose(float(m.alpha_loss), loss_a(la0), rtol=1e-10)
        la1 = np_adam_first_step(np.array(la0), g_la, 3e-2)
        np.testing.assert_allclose(float(new.log_alpha), la1, rtol=1e-12)
        np.testing.assert_allclose(float(m.alpha), np.exp(la1), rtol=1e-12)
        np.testing.assert_allclose(float(m.entropy), -logp_new.mean(), rtol=1e-10)
        assert bool(m.actor_updated)

        # target critics: τθ₁ + (1 − τ)θ'
        np.testing.assert_allclose(flat(new.critic_target)[0], 0.05 * flat(new.critic)[0] + 0.95 * flat(state.critic_target)[0],
                                   rtol=1e-12)


def test_the_actor_and_temperature_wait_for_policy_freq_and_step_policy_freq_times():
    """cleanrl's delayed loop: with policy_freq 2 nothing but the critics changes at iteration 1;
    at iteration 2 the actor and log α take two Adam steps each (their step counts say so)."""
    agent = SAC(SACConfig(hidden=(8,), batch_size=B), OBS, LOW, HIGH)
    state = agent.init(jax.random.PRNGKey(0))
    rng = np.random.default_rng(1)
    batch = replay.Transition(*(jnp.asarray(rng.normal(size=sh), jnp.float32)
                                for sh in ((B, OBS), (B, ACT), (B,), (B, OBS), (B,))))
    update = jax.jit(agent.update)
    s1, m1 = update(state, batch, jax.random.PRNGKey(1), jnp.int32(1))
    assert not bool(m1.actor_updated) and float(m1.actor_loss) == 0.0
    for a, b in zip(jax.tree.leaves((s1.actor, s1.log_alpha)), jax.tree.leaves((state.actor, state.log_alpha))):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(ravel_pytree(s1.critic_target)[0], ravel_pytree(state.critic_target)[0])
    s2, m2 = update(s1, batch, jax.random.PRNGKey(2), jnp.int32(2))
    assert bool(m2.actor_updated) and np.isfinite(float(m2.actor_loss))
    counts = [int(x) for x in jax.tree.leaves((s2.actor_opt, s2.alpha_opt)) if np.asarray(x).dtype == np.int32]
    assert counts == [2, 2]


# ------------------------------------------------------------------------------------------------
# the squashed Gaussian
# ------------------------------------------------------------------------------------------------

def test_squashed_gaussian_log_density_is_the_change_of_variables_and_integrates_to_one():
    """log π(a) with eps = 0 is log N(u; μ, σ) − log(m (1 − tanh² u)), u = atanh((a − c)/m) (scipy),
    and exp(log π) integrates to 1 over (low, high); cleanrl's +1e-6 changes that by < 1e-3."""
    mean, log_std, scale, offset = 0.4, -0.3, 2.0, 0.5

    def density(a, eps):
        lp = float(_log_prob_of_action(a, mean, log_std, scale, offset, eps)[0])
        return math.exp(lp) if math.isfinite(lp) else 0.0  # at the bounds, where tanh saturates

    for a in (-1.2, 0.1, 1.9, 2.45):
        u = math.atanh((a - offset) / scale)
        want = stats.norm.logpdf(u, mean, math.exp(log_std)) - math.log(scale * (1 - math.tanh(u) ** 2))
        lp, action = _log_prob_of_action(a, mean, log_std, scale, offset, 0.0)
        assert action == pytest.approx(a, abs=1e-12)
        np.testing.assert_allclose(lp, want, rtol=1e-10)
    lo, hi = offset - scale, offset + scale
    total, _ = integrate.quad(lambda a: density(a, 0.0), lo, hi, limit=200, points=[offset + scale * math.tanh(mean)])
    assert total == pytest.approx(1.0, abs=1e-7)
    total_eps, _ = integrate.quad(lambda a: density(a, 1e-6), lo, hi, limit=200)
    assert abs(total_eps - 1.0) < 1e-3


def _log_prob_of_action(a, mean, log_std, scale, offset, eps) -> tuple[float, float]:
    """(log π, the action) at action ``a`` through :func:`squashed_gaussian` with noise = (u − μ)/σ,
    float64."""
    with jax.enable_x64(True):
        with np.errstate(divide="ignore"):
            u = float(np.arctanh(np.clip((a - offset) / scale, -1.0, 1.0)))
        noise = (u - mean) / math.exp(log_std)
        f64 = lambda x: jnp.asarray([x], jnp.float64)
        action, log_prob = squashed_gaussian(f64(mean), f64(log_std), f64(noise), f64(scale), f64(offset), eps)
        return float(log_prob), float(action[0])


# ------------------------------------------------------------------------------------------------
# a tiny SAC run
# ------------------------------------------------------------------------------------------------

TINY = ["agent.kind=sac", "seeds=2", "total_steps=3000", "eval_freq=1000", "learning_starts=1000",
        "eval_episodes=3", "replay_size=3000", "agent.hidden=[32,32]", "agent.batch_size=32",
        "agent.activation.learnable=true", "tensorboard=true"]


def tiny(*extra: str) -> cfgmod.Config:
    return cfgmod.resolve("hopper_swim", TINY + list(extra))


@pytest.fixture(scope="module")
def sac_run(tmp_path_factory):
    return train.run(tiny(), str(tmp_path_factory.mktemp("sac") / "run"), log=lambda s: None)


def test_a_sac_run_trains_every_seed_in_one_program_and_logs_its_metrics(sac_run):
    d = sac_run.run_dir
    assert sac_run.evaluations.shape == (4, 2, 3) and np.all(np.isfinite(sac_run.evaluations))
    assert sac_run.chunk_fn._cache_size() == 1 and sac_run.timing["chunk_compiles"] == 1
    assert "kind: sac" in open(os.path.join(d, "config.yaml")).read()
    with open(os.path.join(d, learning_log.FILENAME)) as f:
        assert tuple(f.readline().strip().split(",")) == SAC.METRICS.columns
    m = learning_log.read(os.path.join(d, learning_log.FILENAME))
    np.testing.assert_array_equal(m["updates"], [0, 0, 1000, 1000, 1000, 1000])
    np.testing.assert_array_equal(m["actor_updates"], [0, 0, 500, 500, 500, 500])  # policy_freq 2
    for c in ("critic_loss", "actor_loss", "alpha_loss", "alpha", "entropy"):
        assert np.all(np.isnan(m[c][:2])) and np.all(np.isfinite(m[c][2:])), c
    assert np.all((m["alpha"][2:] > 0) & (m["alpha"][2:] < 1))  # log α starts at 0 and falls
    tags = {}
    for name in os.listdir(tensorboard_log.seed_folder(d, 0)):
        tags[name] = open(os.path.join(tensorboard_log.seed_folder(d, 0), name), "rb").read()
    assert all(f"train/{c}".encode() in b"".join(tags.values()) for c in ("alpha", "entropy", "critic_loss"))
    assert os.path.isfile(os.path.join(d, "activation_params.csv"))  # learnable k in actor and critics


def test_a_sac_run_resumes_bit_for_bit(sac_run, tmp_path):
    dst = str(tmp_path / "resumed")
    shutil.copytree(sac_run.run_dir, dst)
    shutil.rmtree(os.path.join(dst, "checkpoints", "3000"))
    res = train.run(tiny(), dst, resume=True, log=lambda s: None)
    np.testing.assert_array_equal(res.evaluations, sac_run.evaluations)
    for k, v in res.final_actor.items():
        np.testing.assert_array_equal(v, sac_run.final_actor[k], err_msg=k)
    for a, b in zip(jax.tree.leaves(res.states.agent), jax.tree.leaves(sac_run.states.agent)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    for name in ("metrics.csv", "evaluations.csv", "activation_params.csv"):
        assert open(os.path.join(dst, name)).read() == open(os.path.join(sac_run.run_dir, name)).read(), name
    assert res.chunk_fn is sac_run.chunk_fn


def test_the_numpy_policy_of_a_sac_run_is_the_jax_mean_action(sac_run, tmp_path):
    """final_policy.npz, the checkpoint at 3000 and an exported file: NumPy's tanh(mean)·m + c of the
    Gaussian head equals the agent's ``act`` (JAX, learned k per layer)."""
    prog = train.programs(tiny())
    obs = np.random.default_rng(0).normal(size=(7, prog.agent.obs_dim)).astype(np.float32)
    for seed in (0, 1):
        params = jax.tree.map(lambda x: x[seed], sac_run.states.agent.actor)
        want = np.asarray(prog.agent.act(params, jnp.asarray(obs)))
        final, at = load_policy(sac_run.run_dir, seed=seed), load_policy(sac_run.run_dir, seed=seed, step=3000)
        assert final.head == "gaussian" and final.action_size == prog.agent.action_dim
        np.testing.assert_allclose(final(obs), want, rtol=2e-5, atol=2e-6)
        np.testing.assert_array_equal(at(obs), final(obs))
        final.export(str(tmp_path / f"p{seed}.npz"))
        np.testing.assert_array_equal(load_exported(str(tmp_path / f"p{seed}.npz"))(obs), final(obs))


def test_a_sweep_of_a_sac_float_trains_its_points_in_one_program(tmp_path):
    """sweep.agent.alpha_lr: both points as lanes of one program; their temperatures differ."""
    cfg = cfgmod.resolve("hopper_relu", ["agent.kind=sac", "seeds=1", "pad_single_seed=false", "total_steps=2000",
                                         "eval_freq=1000", "learning_starts=1000", "eval_episodes=2",
                                         "replay_size=2000", "agent.hidden=[16]", "agent.batch_size=16",
                                         "sweep.agent.alpha_lr=[0.001,0.01]"])
    res = train.run(cfg, str(tmp_path / "sweep"), log=lambda s: None)
    assert sorted(os.listdir(tmp_path / "sweep" / "points")) == ["alpha_lr=0.001", "alpha_lr=0.01"]
    alphas = [learning_log.read(str(tmp_path / "sweep" / "points" / p / "metrics.csv"))["alpha"][-1]
              for p in ("alpha_lr=0.001", "alpha_lr=0.01")]
    assert alphas[1] < alphas[0] < 1
    assert res.chunk_fn._cache_size() == 1


# ------------------------------------------------------------------------------------------------
# config errors and what derives from the registry
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("argv, needle", [
    (["config=hopper_relu", "agent.alpha_lr=0.1"],
     "unknown key 'agent.alpha_lr' (a key of agent.kind=sac, not of agent.kind=td3); valid keys under agent:"),
    (["config=hopper_relu", "agent.kind=sac", "agent.policy_noise=0.1"],
     "unknown key 'agent.policy_noise' (a key of agent.kind=td3, not of agent.kind=sac); valid keys under agent:"),
    (["config=hopper_relu", "agent.kind=ppo"], "unknown agent.kind 'ppo'; valid: td3, sac"),
    (["config=hopper_relu", "agent.kind=sac", "agent.log_std_min=3"], "must be below agent.log_std_max"),
    (["config=hopper_relu", "agent.kind=sac", "agent.target_freq=0"], "agent.target_freq must be >= 1"),
    (["config=hopper_relu", "agent.kind=sac", "sweep.agent.policy_noise=[0.1,0.2]"], "cannot be swept"),
])
def test_keys_of_the_other_agent_one_line_exit_2_nothing_written(argv, needle, tmp_path, capsys):
    assert train.main(argv + [f"out_dir={tmp_path}/out"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0], err
    assert not os.path.exists(tmp_path / "out")


def test_the_shipped_sac_configs_are_cleanrls():
    for name in ("walker_swim_sac", "cheetah_swim_sac"):
        cfg = cfgmod.resolve(name, [])
        assert isinstance(cfg.agent, SACConfig) and cfg.learning_starts == 5000
        assert (cfg.agent.actor_lr, cfg.agent.critic_lr, cfg.agent.alpha_lr, cfg.agent.batch_size) == (3e-4, 1e-3, 1e-3, 256)
        assert (cfg.agent.tau, cfg.agent.discount, cfg.agent.policy_freq, cfg.agent.target_freq) == (0.005, 0.99, 2, 1)
    assert isinstance(cfgmod.resolve("cheetah_swim", ["agent.kind=sac"]).agent, SACConfig)


def test_what_derives_from_the_registry():
    """metrics.csv's core columns are TD3's and a subset of every agent's; the report's panels are
    the titled metrics all agents share; the NumPy policy knows each agent's head."""
    assert registry.kinds()[0] == "td3" and set(registry.kinds()) == {"td3", "sac"}
    assert TD3.METRICS.columns == learning_log.COLUMNS
    for cls in registry.AGENTS.values():
        assert set(learning_log.COLUMNS) <= set(cls.METRICS.columns)
        assert AGENT_HEADS[cls.kind] == cls.POLICY_HEAD
    assert registry.learning_panels() == (("critic_loss", "critic loss"), ("actor_loss", "actor loss"),
                                          ("q_mean", "Q estimate"))
    assert "kind:" not in cfgmod.dump(cfgmod.resolve("hopper_relu", []))  # TD3 run folders read as before


def test_a_report_refuses_to_pool_sac_and_td3_runs_in_one_line(sac_run, tmp_path):
    """A TD3 run of the same env, activation and budget (the SAC folder with a TD3 config.yaml) is
    another experiment: pooling them as seeds is refused naming agent.kind."""
    import yaml

    from swim_jax.analysis import runs_io

    td3 = str(tmp_path / "td3")
    shutil.copytree(sac_run.run_dir, td3, ignore=shutil.ignore_patterns("checkpoints", "tensorboard"))
    cfg = yaml.safe_load(open(os.path.join(td3, "config.yaml")))
    cfg["agent"] = cfgmod.to_dict(cfgmod.resolve("hopper_swim", ["agent.hidden=[32,32]", "agent.activation.learnable=true"]))["agent"]
    cfg["seed"] = 1  # other seeds: only the algorithm stands in the way
    with open(os.path.join(td3, "config.yaml"), "w") as f:
        yaml.safe_dump(cfg, f)
    with pytest.raises(runs_io.RunError, match=r"differ in agent\.kind \('sac' vs 'td3'\)"):
        runs_io.load_and_group([sac_run.run_dir, td3], allow_incomplete=True)
