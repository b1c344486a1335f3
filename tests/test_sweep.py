"""Hyperparameter sweeps as lanes of one program (`python -m swim_jax.sweep`) and learnable k.

One tiny real sweep (Swimmer-v5 on MJX, Swim with learnable k, k ∈ {0.5, 1}, 2 seeds → 4 lanes) serves
the run-level tests; the per-lane hyperparameter mechanism (``TD3.with_hparams``) is checked on
single TD3 updates against agents built from the corresponding plain configs.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from swim_jax.agents.replay import Transition
from swim_jax.agents.td3 import TD3, ActivationConfig, TD3Config
from swim_jax import config as cfgmod
from swim_jax.placement.layout import LaneLayout
from swim_jax.run import learned_params, outputs, programs, train
from swim_jax.analysis import report, runs_io
from swim_jax import sweep
from swim_jax.run.render import RenderError, load_policy

TINY = ["seeds=2", "total_steps=3000", "eval_freq=1000", "learning_starts=1000", "eval_episodes=3",
        "replay_size=5000", "agent.hidden=[16,16]", "agent.batch_size=32", "agent.activation.learnable=true",
        "env.backend=mjx", "env.max_episode_steps=200"]
# the MJX backend's training program, end to end (tests/test_train.py: MuJoCo C): Swimmer's, whose MJX
# programs compile fastest, with 200-step episodes (evaluations run each to its end); the fixture's
# cold time for each env: docs/notebook/tests-2026-12-06.md
KS = (0.5, 1.0)


# ------------------------------------------------------------------------------------------------
# configuration
# ------------------------------------------------------------------------------------------------

def test_sweep_grid_points_and_point_configs():
    cfg = cfgmod.resolve("hopper_swim", ["sweep.agent.activation.k=[0.25,0.5,1]", "sweep.agent.tau=[0.005,0.01]"])
    pts = cfgmod.sweep_points(cfg)
    assert len(pts) == 6 and pts[0] == {"agent.activation.k": 0.25, "agent.tau": 0.005}
    assert pts[1] == {"agent.activation.k": 0.25, "agent.tau": 0.01}  # first key varies slowest
    assert cfgmod.point_label(pts[1]) == "k=0.25,tau=0.01"
    pc = cfgmod.point_config(cfg, pts[1])
    assert pc.agent.activation.k == 0.25 and pc.agent.tau == 0.01 and pc.sweep == {}
    seed_ids, hp = programs.lane_inputs(dataclasses.replace(cfg, seeds=2), np.float32)
    np.testing.assert_array_equal(seed_ids, [0, 1] * 6)
    np.testing.assert_allclose(hp["activation.k"], np.repeat([0.25, 0.25, 0.5, 0.5, 1, 1], 2))
    np.testing.assert_allclose(hp["tau"], np.repeat([0.005, 0.01] * 3, 2), rtol=1e-7)
    layout = LaneLayout.of(dataclasses.replace(cfg, seeds=2, first_seed=3))
    assert layout.count == layout.real == 12 and layout.swept
    assert layout.point_lanes()[1] == slice(2, 4) and layout.where(3) == "seed 4 of sweep point k=0.25,tau=0.01"
    np.testing.assert_array_equal(layout.point_means(np.arange(12.0)), np.arange(6) * 2 + 0.5)
    one = LaneLayout.of(cfgmod.resolve("hopper_swim", ["seeds=1", "first_seed=7"]))  # padded to two lanes
    assert (one.count, one.real, one.swept, one.where(0)) == (2, 1, False, "seed 7")
    np.testing.assert_array_equal(one.seed_ids(), [7, 7])
    assert LaneLayout.of(cfgmod.resolve("hopper_swim", ["seeds=1", "pad_single_seed=false"])).count == 1
    # the sweep round-trips through config.yaml
    assert cfgmod.from_dict(cfgmod.Config, __import__("yaml").safe_load(cfgmod.dump(cfg))) == cfg
    assert cfgmod.sweep_points(cfgmod.resolve("hopper_swim", [])) == [{}]


def test_elu_alpha_is_a_config_key_a_sweep_axis_a_learnable_parameter_and_a_label():
    """ELU(α), one registry entry: agent.activation.alpha sets, sweeps, learns and labels it."""
    cfg = cfgmod.resolve("hopper_swim", ["agent.activation.name=elu", "agent.activation.alpha=0.5"])
    assert cfg.agent.activation.params() == {"alpha": 0.5}
    assert "agent.activation.alpha" in cfgmod.sweepable_keys(cfg) and "agent.activation.k" not in cfgmod.sweepable_keys(cfg)
    dumped = __import__("yaml").safe_load(cfgmod.dump(cfg))
    assert cfgmod.from_dict(cfgmod.Config, dumped) == cfg
    assert runs_io.activation_label(dumped["agent"]["activation"]) == "elu(alpha=0.5)"
    with pytest.raises(cfgmod.ConfigError, match="alpha=-1.0 is invalid; it must be finite and > 0"):
        cfgmod.resolve("hopper_swim", ["agent.activation.name=elu", "agent.activation.alpha=-1"])
    sw = cfgmod.resolve("hopper_swim", ["agent.activation.name=elu", "agent.activation.learnable=true",
                                        "sweep.agent.activation.alpha=[0.5,2]"])
    pts = cfgmod.sweep_points(sw)
    assert [cfgmod.point_label(p) for p in pts] == ["alpha=0.5", "alpha=2"]
    assert cfgmod.point_config(sw, pts[1]).agent.activation.params() == {"alpha": 2.0}
    agent = TD3(sw.agent, 3, (-1.0,), (1.0,)).with_hparams({"activation.alpha": jnp.asarray(2.0)})
    assert dict(agent.network_options.activation_params) == {"alpha": 2.0} and agent.network_options.learnable
    st = TD3(dataclasses.replace(sw.agent, hidden=(4,)), 3, (-1.0,), (1.0,)).init(jax.random.PRNGKey(0))
    lanes = jax.tree.map(lambda x: x[None], (st.actor, st.critic))  # one lane
    assert sorted(learned_params.activation_params(*lanes)) == ["actor/act_0/alpha", "critic_1/act_0/alpha",
                                                                "critic_2/act_0/alpha"]


@pytest.mark.parametrize("argv, needle", [
    (["config=hopper_swim"], "no sweep axis given; add e.g. sweep.agent.activation.k="),
    (["config=hopper_swim", "sweep.agent.batch_size=[64,128]"], "valid sweep keys: agent.actor_lr"),
    (["config=hopper_relu", "sweep.agent.activation.k=[1,2]"], "cannot be swept (activation relu)"),
    (["config=hopper_swish", "sweep.agent.activation.k=[1,2]"], "agent.activation.beta"),
    (["config=hopper_swim", "agent.activation.name=elu", "sweep.agent.activation.k=[1,2]"], "agent.activation.alpha"),
    (["config=hopper_swim", "agent.activation.name=elu", "sweep.agent.activation.alpha=[0.5,0]"], "sweep point alpha=0"),
    (["config=hopper_swim", "sweep.agent.activation.k=[0.5,-1]"], "sweep point k=-1"),
    (["config=hopper_swim", "sweep.agent.tau=0.01"], "expected a non-empty list of numbers"),
    (["config=hopper_swim", "sweep.agent.tau=[0.01,0.01]"], "values must be distinct"),
    (["config=hopper_swim", "sweep.agent.discount=[0.9,1.5]"], "discount in [0, 1]"),
])
def test_sweep_cli_errors_one_line_exit_2_nothing_written(argv, needle, tmp_path, capsys):
    rc = sweep.main(argv + [f"out_dir={tmp_path}"])
    err = capsys.readouterr().err
    assert rc == 2 and needle in err and err.count("\n") == 1, err
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------------------------------------
# per-lane hyperparameters in one update
# ------------------------------------------------------------------------------------------------

def _batch(key, n, obs_dim, act_dim):
    ks = jax.random.split(key, 5)
    return Transition(
        jax.random.normal(ks[0], (n, obs_dim)), jax.random.uniform(ks[1], (n, act_dim), minval=-1, maxval=1),
        jax.random.normal(ks[2], (n,)), jax.random.normal(ks[3], (n, obs_dim)),
        (jax.random.uniform(ks[4], (n,)) < 0.2).astype(jnp.float32))


@pytest.mark.parametrize("learnable", [False, True])
def test_with_hparams_update_matches_agent_built_from_the_plain_config(learnable):
    """Two lanes with different (k, tau, lrs, noises, discount) in one vmapped update equal two
    agents whose configs hold those values as constants (float32 rounding of the constants apart).
    Full-precision matmuls: on NVIDIA GPUs JAX's default f32 matmul uses TF32 (~1e-3 relative), and
    the batched and unbatched programs pick different kernels."""
    with jax.default_matmul_precision("highest"):
        _check_with_hparams(learnable)


def _check_with_hparams(learnable):
    base = TD3Config(hidden=(8,), activation=ActivationConfig("swim", 0.5, learnable=learnable), batch_size=4)
    values = [dict(tau=0.005, actor_lr=3e-4, critic_lr=3e-4, discount=0.99, policy_noise=0.2, noise_clip=0.5, k=0.5),
              dict(tau=0.05, actor_lr=1e-2, critic_lr=2e-2, discount=0.9, policy_noise=0.4, noise_clip=0.3, k=2.0)]
    mk = lambda c: TD3(c, 3, (-1.0, -1.0), (1.0, 1.0))
    batch = _batch(jax.random.PRNGKey(1), 4, 3, 2)
    hp = {("activation.k" if k == "k" else k): jnp.asarray([v[k] for v in values], jnp.float32) for k in values[0]}
    agent = mk(base)

    @jax.jit
    def swept(h):
        def one(h):
            a = agent.with_hparams(h)
            s = a.init(jax.random.PRNGKey(0))
            s, _ = a.update_delayed(s, batch, jax.random.PRNGKey(2), True)
            s, m = a.update_delayed(s, batch, jax.random.PRNGKey(3), True)
            return s, m
        return jax.vmap(one)(h)

    states, metrics = swept(hp)
    for lane, v in enumerate(values):
        cfg = dataclasses.replace(base, activation=dataclasses.replace(base.activation, k=v["k"]),
                                  **{k: x for k, x in v.items() if k != "k"})
        a = mk(cfg)
        s = a.init(jax.random.PRNGKey(0))
        s, _ = a.update_delayed(s, batch, jax.random.PRNGKey(2), True)
        s, m = a.update_delayed(s, batch, jax.random.PRNGKey(3), True)
        np.testing.assert_allclose(metrics.critic_loss[lane], m.critic_loss, rtol=2e-5)
        for got, want in zip(jax.tree.leaves(states), jax.tree.leaves(s)):
            np.testing.assert_allclose(np.asarray(got)[lane], np.asarray(want), rtol=2e-5, atol=1e-6)
    # the lanes really differ (the swept values reached the update)
    assert not np.allclose(metrics.critic_loss[0], metrics.critic_loss[1])


# ------------------------------------------------------------------------------------------------
# one real sweep run
# ------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    lines: list[str] = []
    cfg = cfgmod.resolve("swimmer_swim", TINY + [f"sweep.agent.activation.k=[{KS[0]},{KS[1]}]"])
    res = train.run(cfg, str(tmp_path_factory.mktemp("sweep") / "run"), log=lines.append)
    res.lines = lines
    res.cfg = cfg
    return res


def test_sweep_outputs_one_folder_per_point(swept):
    d = swept.run_dir
    with open(os.path.join(d, "sweep.csv")) as f:
        rows = list(csv.DictReader(f))
    assert [r["point"] for r in rows] == ["k=0.5", "k=1"]
    for p, (row, k) in enumerate(zip(rows, KS)):
        pd = os.path.join(d, "points", row["point"])
        run = runs_io.load_run(pd)  # an ordinary run folder
        assert run.activation == ("swim" if k == 0.5 else f"swim(k={k:g})") + "+learnable"
        np.testing.assert_array_equal(run.returns, swept.evaluations[:, 2 * p:2 * p + 2].mean(axis=2))
        assert float(row["final_mean"]) == pytest.approx(run.returns[-1].mean())
        assert json.load(open(os.path.join(pd, "point.json")))["values"] == {"agent.activation.k": k}
        with np.load(os.path.join(pd, "final_policy.npz")) as z:
            assert z["params/body/head/bias"].shape[0] == 2
    assert len(swept.lines) == 3 and "over 2 points × 2 seeds [k=0.5:" in swept.lines[0]
    assert swept.chunk_fn._cache_size() == 1 and swept.eval_fn._cache_size() == 1  # no recompilation
    assert swept.timing["lanes"] == 4 and swept.timing["sweep_points"] == 2


def test_points_differ_and_seeds_are_shared(swept):
    ev = swept.evaluations.mean(axis=2)  # [n, 4 lanes]
    assert not np.array_equal(ev[:, 0], ev[:, 2])  # k differs
    assert not np.array_equal(ev[:, 0], ev[:, 1])  # seed differs
    # the same seed at both points starts from the same keys: identical initial weights and the same
    # uniform-random warm-up transitions in the replay buffer
    buf = np.asarray(swept.states.buffer.data.obs)
    np.testing.assert_array_equal(buf[0, :1000], buf[2, :1000])
    assert not np.array_equal(buf[0, :1000], buf[1, :1000])


def test_learnable_k_trajectory_logged_per_layer_and_seed(swept):
    for p, k in enumerate(KS):
        log = learned_params.read(os.path.join(swept.run_dir, "points", f"k={k:g}", learned_params.FILENAME))
        np.testing.assert_array_equal(log["step"], [0, 1000, 2000, 3000])
        np.testing.assert_array_equal(log["seed"], [0, 1])
        names = sorted(n for n in log if "/" in n)
        assert names == ["actor/act_0/k", "actor/act_1/k", "critic_1/act_0/k", "critic_1/act_1/k",
                         "critic_2/act_0/k", "critic_2/act_1/k"]
        for n in names:
            np.testing.assert_allclose(log[n][0], k, rtol=1e-7)  # starts at the point's k
            np.testing.assert_array_equal(log[n][1], log[n][0])  # chunk 1 is uniform-random play: no update
            assert not np.allclose(log[n][-1], k, rtol=0, atol=1e-7), n  # k was learned
        # the last row equals the final parameters
        critic = np.asarray(swept.states.agent.critic["params"]["critics"]["body"]["act_1"]["k"])
        np.testing.assert_array_equal(log["critic_2/act_1/k"][-1], critic[2 * p:2 * p + 2, 1].astype(np.float64))


def test_report_expands_a_sweep_and_plots_return_vs_k(swept, tmp_path):
    out = str(tmp_path / "report")
    assert report.main([swept.run_dir, "--out", out]) == 0
    files = os.listdir(out)
    assert {"REPORT.md", "figure4.png", "sweep.png", "sweep.svg", "results.json"} <= set(files)
    md = open(os.path.join(out, "REPORT.md")).read()
    assert "Return vs activation parameter" in md and "| Swimmer-v5 | Swim+learnable | 0.5 |" in md
    assert os.path.getsize(os.path.join(out, "sweep.png")) > 1000


def test_render_refuses_the_sweep_folder_with_a_hint(swept):
    with pytest.raises(RenderError, match="is a sweep; render one of its points"):
        load_policy(swept.run_dir, 0)


# ------------------------------------------------------------------------------------------------
# multi-axis sweeps: sweep.csv labels with commas (quoted), read back by the report
# ------------------------------------------------------------------------------------------------

MULTI = ["sweep.agent.activation.beta=[0.5,2]", "sweep.agent.tau=[0.005,0.01]"]
MULTI_LABELS = ["beta=0.5,tau=0.005", "beta=0.5,tau=0.01", "beta=2,tau=0.005", "beta=2,tau=0.01"]


def test_write_sweep_table_quotes_labels_with_commas(tmp_path):
    cfg = cfgmod.resolve("hopper_swish", ["seeds=2", "eval_freq=100", "total_steps=200", *MULTI])
    points = cfgmod.sweep_points(cfg)
    rng = np.random.default_rng(0)
    evals = rng.normal(size=(3, 8, 2))  # [evaluations, points × seeds, episodes]
    outputs.write_sweep_table(str(tmp_path), cfg, points, evals)
    with open(tmp_path / "sweep.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["point"] for r in rows] == MULTI_LABELS
    for p, r in enumerate(rows):
        assert float(r["agent.activation.beta"]) == (0.5, 0.5, 2.0, 2.0)[p]
        assert float(r["agent.tau"]) == (0.005, 0.01, 0.005, 0.01)[p]
        seeds = [[np.mean(evals[i, 2 * p + s]) for s in range(2)] for i in range(3)]  # [n, seeds]
        curve = [np.mean(v) for v in seeds]
        assert float(r["final_mean"]) == pytest.approx(curve[-1], rel=1e-12)
        assert float(r["final_std"]) == pytest.approx(abs(seeds[-1][0] - seeds[-1][1]) / 2, rel=1e-12)
        assert float(r["best_mean"]) == pytest.approx(max(curve), rel=1e-12)
        assert int(r["best_step"]) == 100 * curve.index(max(curve))
    # labels without commas are written as before (no quotes): old readers keep working
    one = cfgmod.resolve("hopper_swim", ["seeds=2", "sweep.agent.activation.k=[0.5,1]"])
    outputs.write_sweep_table(str(tmp_path), one, cfgmod.sweep_points(one), evals[:, :4])
    lines = (tmp_path / "sweep.csv").read_text().splitlines()
    assert lines[0] == "point,agent.activation.k,final_mean,final_std,best_mean,best_step"
    assert lines[1].startswith("k=0.5,0.5,") and '"' not in "".join(lines)


def _sweep_folder(root, labels, table: str):
    os.makedirs(root, exist_ok=True)
    for label in labels:
        os.makedirs(os.path.join(root, "points", label))
    with open(os.path.join(root, "sweep.csv"), "w", newline="") as f:
        f.write(table)
    return str(root)


@pytest.mark.parametrize("kind", ["legacy_one_axis", "quoted_multi_axis", "legacy_unquoted_multi_axis", "crlf"])
def test_expand_sweeps_reads_quoted_and_old_sweep_tables(tmp_path, kind):
    if kind == "legacy_one_axis":  # written before quoting; labels without commas
        labels = ["k=0.5", "k=1"]
        table = ("point,agent.activation.k,final_mean,final_std,best_mean,best_step\n"
                 "k=0.5,0.5,10.0,1.0,12.0,100\nk=1,1.0,11.0,2.0,13.0,200\n")
    else:
        labels = MULTI_LABELS
        header = "point,agent.activation.beta,agent.tau,final_mean,final_std,best_mean,best_step"
        vals = [("0.5", "0.005"), ("0.5", "0.01"), ("2.0", "0.005"), ("2.0", "0.01")]
        quote = '"' if kind != "legacy_unquoted_multi_axis" else ""
        end = "\r\n" if kind == "crlf" else "\n"
        table = end.join([header] + [f"{quote}{lab}{quote},{b},{t},1.0,0.0,2.0,100"
                                     for lab, (b, t) in zip(labels, vals)]) + end
    d = _sweep_folder(tmp_path / "sw", labels, table)
    other = str(tmp_path / "plain")
    assert runs_io.expand_sweeps([d, other]) == [os.path.join(d, "points", lab) for lab in labels] + [other]


def test_expand_sweeps_bad_table_one_line(tmp_path):
    d = _sweep_folder(tmp_path / "a", [], "point,agent.tau,final_mean\n")
    with pytest.raises(runs_io.RunError, match="no sweep points"):
        runs_io.expand_sweeps([d])
    d = _sweep_folder(tmp_path / "b", [], "label,agent.tau\nx,1\n")
    with pytest.raises(runs_io.RunError, match="not a sweep table"):
        runs_io.expand_sweeps([d])
    d = _sweep_folder(tmp_path / "c", [], "point,agent.tau,final_mean\ntau=1\n")
    with pytest.raises(runs_io.RunError, match="line 2"):
        runs_io.expand_sweeps([d])


def test_multi_axis_sweep_trains_and_reports(tmp_path, capsys):
    """python -m swim_jax.sweep over beta × tau (4 points), then python -m swim_jax.report on it."""
    argv = ["config=hopper_swish", "seeds=1", "pad_single_seed=false", "total_steps=200", "eval_freq=100",
            "learning_starts=100", "eval_episodes=1", "replay_size=500", "agent.hidden=[8]",
            "agent.batch_size=8", "env.backend=mujoco", "progress_steps=100", *MULTI,
            f"out_dir={tmp_path / 'runs'}"]
    assert sweep.main(argv) == 0, capsys.readouterr().err
    (run_dir,) = [str(p) for p in (tmp_path / "runs").iterdir()]
    with open(os.path.join(run_dir, "sweep.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["point"] for r in rows] == MULTI_LABELS
    finals = {}
    for r in rows:
        pd = os.path.join(run_dir, "points", r["point"])
        values = json.load(open(os.path.join(pd, "point.json")))["values"]
        assert values == {"agent.activation.beta": float(r["agent.activation.beta"]),
                          "agent.tau": float(r["agent.tau"])}
        ev = np.load(os.path.join(pd, "evaluations.npy"))
        assert ev.shape == (3, 1)
        assert float(r["final_mean"]) == pytest.approx(ev[-1, 0])
        finals[r["point"]] = ev
    capsys.readouterr()

    out = tmp_path / "report"
    rc = report.main([run_dir, "--out", str(out), "--n-boot", "200"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    res = json.loads((out / "results.json").read_text())
    t2 = res["envs"]["Hopper-v5"]["table2"]
    expect = {f"swish(beta={lab.split(',')[0][5:]})[{lab.split(',')[1]}]": lab for lab in MULTI_LABELS}
    assert sorted(t2) == sorted(expect)  # four experiments, not pooled as seeds
    for act, lab in expect.items():
        ev = finals[lab]
        assert t2[act]["seeds"] == 1 and t2[act]["runs"] == [os.path.join(run_dir, "points", lab)]
        assert t2[act]["final_mean"] == pytest.approx(ev[-1, 0], rel=1e-12)
        assert t2[act]["max_mean"] == pytest.approx(ev[:, 0].max(), rel=1e-12)
    md = (out / "REPORT.md").read_text()
    assert "| Swish(beta=0.5)[tau=0.005] | 1 |" in md and "| Swish(beta=2)[tau=0.01] | 1 |" in md
    import re

    strokes = re.findall(r'clip-path="url\(#\w+\)" style="fill: none; stroke: (#[0-9a-f]{6}); stroke-width: 1\.6;',
                         (out / "figure4.svg").read_text())
    assert len(strokes) == 4 and len(set(strokes)) == 4
