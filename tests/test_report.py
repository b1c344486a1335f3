"""python -m swim_jax.report on synthetic run folders with known curves (expectations by hand)."""

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

from swim_jax.analysis import report, runs_io
from swim_jax.analysis.report_figure import parameter_series

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Walker2d-v5, total_steps 200, eval_freq 100 -> evaluations at steps 0, 100, 200
SWIM = np.array([[0.0, 10.0], [60.0, 40.0], [40.0, 50.0]])  # mean 5, 50, 45
SWISH = np.array([[0.0, 0.0], [20.0, 30.0], [30.0, 40.0]])  # mean 0, 25, 35


def write_run(root, name, env="Walker2d-v5", act="swim", returns=SWIM, total_steps=200, eval_freq=100,
              first_seed=0, seed=0, k=0.5, beta=1.0, hidden=(8, 8), precision="float32", activation=None, **extra):
    """A minimal run folder in the format of swim_jax.run.train (config.yaml + evaluations.npy); the
    activation section has k and beta only (as before alpha existed) unless ``activation`` gives
    extra keys."""
    d = os.path.join(str(root), name)
    os.makedirs(d)
    returns = np.asarray(returns, dtype=np.float64)
    cfg = {
        "env": {"id": env, "max_episode_steps": 1000},
        "agent": {"hidden": list(hidden),
                  "activation": {"name": act, "k": k, "beta": beta, "learnable": False, **(activation or {})},
                  "batch_size": 64},
        "seeds": returns.shape[1], "first_seed": first_seed, "seed": seed, "total_steps": total_steps,
        "eval_freq": eval_freq, "eval_episodes": 5, "precision": precision, "out_dir": str(root), "name": name,
    }
    cfg.update(extra)
    with open(os.path.join(d, "config.yaml"), "w") as f:
        yaml.safe_dump(cfg, f)
    np.save(os.path.join(d, "evaluations.npy"), returns)
    return d


def run_report(args, capsys):
    rc = report.main([str(a) for a in args])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


@pytest.fixture
def walker(tmp_path):
    runs = tmp_path / "runs"
    runs.mkdir()
    return [write_run(runs, "swim", act="swim", returns=SWIM), write_run(runs, "swish", act="swish", returns=SWISH)]


def test_table2_values_by_hand(tmp_path, walker, capsys):
    out = tmp_path / "out"
    rc, _, err = run_report(walker + ["--out", out, "--n-boot", "500"], capsys)
    assert rc == 0, err
    res = json.loads((out / "results.json").read_text())
    t2 = res["envs"]["Walker2d-v5"]["table2"]
    # swim: mean curve 5, 50, 45 -> max 50 at step 100, std over seeds there = |60-40|/2 = 10
    # final 45 +- 5; AUC: seed0 (0+60)/2*100+(60+40)/2*100 = 8000 -> /200 = 40; seed1 7000/200 = 35
    expect_swim = dict(seeds=2, max_mean=50.0, max_std=10.0, max_step=100, final_mean=45.0, final_std=5.0,
                       auc_mean=37.5, auc_std=2.5)
    # swish: mean 0, 25, 35 -> max 35 at 200 (std 5) = final; AUC seed0 3500/200, seed1 5000/200
    expect_swish = dict(seeds=2, max_mean=35.0, max_std=5.0, max_step=200, final_mean=35.0, final_std=5.0,
                        auc_mean=21.25, auc_std=3.75)
    for act, exp in (("swim", expect_swim), ("swish", expect_swish)):
        for key, val in exp.items():
            assert t2[act][key] == pytest.approx(val, abs=1e-12), (act, key)
    imp = res["envs"]["Walker2d-v5"]["improvement_pct"]
    assert imp["max"] == pytest.approx(100 * 15 / 35)
    assert imp["final"] == pytest.approx(100 * 10 / 35)
    assert imp["auc"] == pytest.approx(100 * 16.25 / 21.25)
    md = (out / "REPORT.md").read_text()
    assert "| Swim | 2 | 50.00 ± 10.00 | 100 | 45.00 ± 5.00 | 37.50 ± 2.50 |" in md
    assert "| Swish | 2 | 35.00 ± 5.00 | 200 | 35.00 ± 5.00 | 21.25 ± 3.75 |" in md
    # side by side with the paper's Walker2d-v2 row, labelled as another env version (budget and precision: the Budget section)
    assert ("| Walker2d-v5 | 35.0 ± 5.0 | 50.0 ± 10.0 | +42.9% | +28.6% | +76.5% | Walker2d-v2 (1M steps, 5 seeds) "
            "| 3774.7 ± 149.8 | 4387.4 ± 453.5 | 16% |") in md
    assert "**another env version** (the Budget section says where steps, seeds and precision differ too)" in md
    assert "standard deviation over seeds at that same evaluation" in md
    assert "1,000,000 steps per run" in md and "| Walker2d-v5 | 200 | 100 | 5 | Swim 2, Swish 2 | float32 |" in md
    assert "Evidence too weak" in md and "at least 5 each are needed" in md  # 2 seeds
    # 200 steps and 2 seeds against the paper's 1M and 5: two warnings, each naming its own shortfall
    assert "**Fewer steps than the paper** for Walker2d-v5: returns are not comparable" in md
    assert "**Fewer seeds than the paper's 5** for Walker2d-v5: the max of the mean" in md


def test_a_paper_length_run_with_fewer_seeds_warns_of_the_seeds_only(tmp_path, capsys):
    """1M steps (the paper's) on one seed a side: the seeds warning, not the steps one; the verdict
    gives no bootstrap CI (one seed makes it a single point) and names both seed counts."""
    runs = tmp_path / "runs"
    runs.mkdir()
    curve = np.linspace(0.0, 3000.0, 201)[:, None]
    args = [write_run(runs, a, act=a, returns=curve + off, total_steps=1_000_000, eval_freq=5000)
            for a, off in (("swim", 100.0), ("swish", 0.0))]
    rc, _, err = run_report(args + ["--out", tmp_path / "out", "--n-boot", "200"], capsys)
    assert rc == 0, err
    md = (tmp_path / "out" / "REPORT.md").read_text()
    assert "Fewer steps than the paper" not in md
    assert "**Fewer seeds than the paper's 5** for Walker2d-v5" in md
    assert "CI of the difference n/a (one seed on a side)" in md and "Swim has 1 seed and Swish 1 seed" in md


def test_figures_written_and_non_empty(tmp_path, walker, capsys):
    out = tmp_path / "out"
    assert run_report(walker + ["--out", out, "--n-boot", "200"], capsys)[0] == 0
    png = (out / "figure4.png").read_bytes()
    svg = (out / "figure4.svg").read_text()
    assert png.startswith(b"\x89PNG") and len(png) > 5000
    assert "<svg" in svg and len(svg) > 5000
    md = (out / "REPORT.md").read_text()
    assert "![Figure 4: learning curves](figure4.png)" in md


def test_deterministic_output(tmp_path, walker, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    assert run_report(walker + ["--out", a, "--n-boot", "300"], capsys)[0] == 0
    assert run_report(walker + ["--out", b, "--n-boot", "300"], capsys)[0] == 0
    assert (a / "results.json").read_text() == (b / "results.json").read_text()
    assert (a / "figure4.svg").read_bytes() == (b / "figure4.svg").read_bytes()


def test_statistics_against_independent_computation(tmp_path, capsys):
    rng = np.random.default_rng(0)
    runs = tmp_path / "runs"
    runs.mkdir()
    base = np.linspace(0, 100, 5)[:, None]
    swim = base + rng.normal(0, 5, size=(5, 6)) + np.linspace(0, 30, 5)[:, None]
    swish = base + rng.normal(0, 5, size=(5, 5))
    paths = [write_run(runs, "a", act="swim", returns=swim, total_steps=400),
             write_run(runs, "b", act="swish", returns=swish, total_steps=400)]
    out = tmp_path / "out"
    assert run_report(paths + ["--out", out, "--n-boot", "4000", "--score", "final"], capsys)[0] == 0
    res = json.loads((out / "results.json").read_text())
    c = res["envs"]["Walker2d-v5"]["comparisons"]["swim_vs_swish"]["final"]
    x, y = swim[-1], swish[-1]
    assert c["mean_x"] == pytest.approx(x.mean()) and c["mean_y"] == pytest.approx(y.mean())
    assert c["iqm_x"] == pytest.approx(np.sort(x)[1:5].mean())  # n=6: drop 1 each end
    assert c["prob_improvement"] == pytest.approx(np.mean([[xi > yi for yi in y] for xi in x]))
    # bootstrap CI of the mean: an independent loop bootstrap with another RNG stream
    r2 = np.random.default_rng(777)
    boots = [x[r2.integers(0, 6, 6)].mean() for _ in range(20000)]
    lo, hi = np.quantile(boots, [0.025, 0.975])
    half = (hi - lo) / 2
    assert c["ci95_x"][0] == pytest.approx(lo, abs=0.1 * half)
    assert c["ci95_x"][1] == pytest.approx(hi, abs=0.1 * half)
    # Welch by hand
    vx, vy = x.var(ddof=1) / 6, y.var(ddof=1) / 5
    assert c["welch"]["t"] == pytest.approx((x.mean() - y.mean()) / math.sqrt(vx + vy), rel=1e-12)
    assert c["welch"]["df"] == pytest.approx((vx + vy) ** 2 / (vx ** 2 / 5 + vy ** 2 / 4), rel=1e-12)
    sps = pytest.importorskip("scipy.stats")
    ref = sps.ttest_ind(x, y, equal_var=False)
    assert c["welch"]["p_two_sided"] == pytest.approx(ref.pvalue, rel=1e-8)
    assert res["verdict_score"] == "final"


def test_pooling_more_seeds_and_grouping_by_env(tmp_path, capsys):
    runs = tmp_path / "runs"
    runs.mkdir()
    extra = np.array([[5.0], [70.0], [20.0]])
    hop = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0], [7.0, 8.0], [9.0, 10.0]])
    paths = [
        write_run(runs, "swim_a", act="swim", returns=SWIM),
        write_run(runs, "swim_b", act="swim", returns=extra, first_seed=2),  # seed index 2: new seed
        write_run(runs, "swish", act="swish", returns=SWISH),
        write_run(runs, "relu", act="relu", returns=SWISH + 1),
        write_run(runs, "hop", env="Hopper-v5", act="swim", returns=hop, total_steps=4000, eval_freq=1000),
        write_run(runs, "swim_k", act="swim", k=0.75, returns=SWISH),  # a different activation label
    ]
    out = tmp_path / "out"
    rc, _, err = run_report(paths + ["--out", out, "--n-boot", "200"], capsys)
    assert rc == 0, err
    res = json.loads((out / "results.json").read_text())
    assert sorted(res["envs"]) == ["Hopper-v5", "Walker2d-v5"]
    w = res["envs"]["Walker2d-v5"]
    assert list(w["table2"]) == ["swim", "swim(k=0.75)", "swish", "relu"]
    pooled = np.concatenate([SWIM, extra], axis=1)  # means 5, 56.67, 36.67
    assert w["table2"]["swim"]["seeds"] == 3
    assert w["table2"]["swim"]["max_mean"] == pytest.approx(170 / 3)
    assert w["table2"]["swim"]["max_std"] == pytest.approx(np.std([60.0, 40.0, 70.0]))
    np.testing.assert_allclose(w["curves"]["swim"]["mean"], pooled.mean(axis=1))
    assert set(w["comparisons"]) == {"swim_vs_swish", "swim_vs_relu", "swish_vs_relu", "swim_vs_swim(k=0.75)",
                                     "swim(k=0.75)_vs_swish", "swim(k=0.75)_vs_relu"}  # every pair of labels
    h = res["envs"]["Hopper-v5"]
    assert h["steps"] == [0, 1000, 2000, 3000, 4000] and h["table2"]["swim"]["max_mean"] == 9.5
    assert h["verdict"] is None
    md = (out / "REPORT.md").read_text()
    assert "Swim(k=0.75)" in md and "Hopper-v5**: no verdict" in md


def test_single_seed_and_zero_baseline_edge_cases(tmp_path, capsys):
    paths = [write_run(tmp_path, "a", act="swim", returns=np.array([[0.0], [2.0], [1.0]])),
             write_run(tmp_path, "b", act="swish", returns=np.zeros((3, 1)))]
    out = tmp_path / "out"
    rc, stdout, err = run_report(paths + ["--out", out, "--n-boot", "200"], capsys)
    assert rc == 0, err
    res = json.loads((out / "results.json").read_text())  # strict JSON: NaN written as null
    w = res["envs"]["Walker2d-v5"]
    assert w["table2"]["swim"]["max_mean"] == 2.0 and w["table2"]["swim"]["max_std"] == 0.0
    assert w["improvement_pct"]["max"] is None  # Swish mean 0: improvement undefined
    assert w["comparisons"]["swim_vs_swish"]["max"]["welch"] is None
    assert "Evidence too weak" in w["verdict"] and "no t-test possible" in w["verdict"]
    assert "Walker2d-v5: Swim 2.0 ± 0.0 vs Swish 0.0 ± 0.0" in stdout


def test_table3_from_bench_json(tmp_path, capsys):
    rows = [
        {"dtype": "float64", "env": "Walker2d", "activation": "swish", "mean_ms": 0.9, "std_ms": 0.1, "median_ms": 0.85},
        {"dtype": "float64", "env": "Walker2d", "activation": "swim", "mean_ms": 0.75, "std_ms": 0.05, "median_ms": 0.7},
        {"dtype": "float64", "env": "Walker2d", "activation": "relu", "mean_ms": 0.5, "std_ms": 0.02, "median_ms": 0.5},
        {"dtype": "float64", "env": "Walker2d", "activation": "swim_vs_swish", "improvement_pct_mean": 20.0},
        {"dtype": "float32", "env": "Ant", "activation": "swish", "mean_ms": 1.0, "std_ms": 0.1},
        {"dtype": "float32", "env": "Ant", "activation": "swim", "mean_ms": 1.25, "std_ms": 0.1},
    ]
    bench = tmp_path / "activations-x.json"
    bench.write_text(json.dumps({"machine": {"cpu": "test cpu"}, "actor_inference": rows}))
    out = tmp_path / "out"
    rc, _, err = run_report(["--bench", bench, "--out", out], capsys)
    assert rc == 0, err
    res = json.loads((out / "results.json").read_text())
    t3 = {(r["env"], r["dtype"]): r for r in res["table3"]}
    assert t3[("Walker2d", "float64")]["improvement_pct"] == pytest.approx(100 * 0.15 / 0.75)  # 20%
    assert t3[("Ant", "float32")]["improvement_pct"] == pytest.approx(-20.0)
    md = (out / "REPORT.md").read_text()
    assert ("| Walker2d | float64 | 0.900 ± 0.100 | 0.750 ± 0.050 | 0.500 ± 0.020 | +20.0% | Walker2d-v2 (float64, ARM) "
            "| 0.810 ± 0.066 | 0.687 ± 0.077 | 17.9% | activations-x.json |") in md
    assert "| Ant | float32 | 1.000 ± 0.100 | 1.250 ± 0.100 | — | -20.0% | — | — | — | — |" in md
    assert not (out / "figure4.png").exists()  # no runs, no figure


# ------------------------------------------------------------------------------------------------
# errors: one line on stderr, exit 2, nothing written
# ------------------------------------------------------------------------------------------------


def _corrupt(kind, root):
    if kind == "nonexistent":
        return os.path.join(str(root), "nope")
    d = write_run(root, "bad", act="swish", returns=SWISH)
    if kind == "no_config":
        os.remove(os.path.join(d, "config.yaml"))
    elif kind == "no_evals":
        os.remove(os.path.join(d, "evaluations.npy"))
    elif kind == "bad_yaml":
        with open(os.path.join(d, "config.yaml"), "w") as f:
            f.write("env: {id: [unclosed\n  :: -\n")
    elif kind == "yaml_not_mapping":
        with open(os.path.join(d, "config.yaml"), "w") as f:
            f.write("- 1\n- 2\n")
    elif kind == "no_env_key":
        with open(os.path.join(d, "config.yaml"), "w") as f:
            yaml.safe_dump({"total_steps": 200, "eval_freq": 100, "seeds": 2}, f)
    elif kind == "bad_npy":
        with open(os.path.join(d, "evaluations.npy"), "wb") as f:
            f.write(b"not a numpy file")
    elif kind == "shape_seeds":
        np.save(os.path.join(d, "evaluations.npy"), np.zeros((3, 3)))
    elif kind == "shape_too_many_evals":
        np.save(os.path.join(d, "evaluations.npy"), np.zeros((4, 2)))
    elif kind == "nan":
        np.save(os.path.join(d, "evaluations.npy"), np.full((3, 2), np.nan))
    return d


@pytest.mark.parametrize("kind", ["nonexistent", "no_config", "no_evals", "bad_yaml", "yaml_not_mapping",
                                  "no_env_key", "bad_npy", "shape_seeds", "shape_too_many_evals", "nan"])
def test_corrupt_run_folder_exit_2_one_line_nothing_written(tmp_path, walker, capsys, kind):
    bad = _corrupt(kind, tmp_path)
    out = tmp_path / "out"
    rc, stdout, err = run_report(walker + [bad, "--out", out], capsys)
    assert rc == 2
    assert len(err.strip().splitlines()) == 1 and err.startswith("report: error: ")
    assert ("bad" in err) or ("nope" in err)
    assert not out.exists()
    assert [p for p in os.listdir(tmp_path) if p.startswith(".")] == []  # no temporary folder left


def test_parent_folder_of_runs_gets_a_hint(tmp_path, walker, capsys):
    parent = os.path.dirname(walker[0])
    rc, _, err = run_report([parent, "--out", tmp_path / "out"], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert "missing config.yaml; it contains 2 run folder(s)" in err and "pass those instead" in err


def test_budget_conflict_in_one_env_is_refused_naming_both_runs(tmp_path, walker, capsys):
    other = write_run(tmp_path, "long", act="relu", returns=np.zeros((5, 2)), total_steps=400)
    rc, _, err = run_report(walker + [other, "--out", tmp_path / "out"], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert walker[0] in err and other in err and "total_steps=400" in err
    freq = write_run(tmp_path, "freq", act="relu", returns=np.zeros((5, 2)), eval_freq=50)
    rc, _, err = run_report(walker + [freq, "--out", tmp_path / "out"], capsys)
    assert rc == 2 and "eval_freq=50" in err and freq in err


def test_pooling_refuses_overlapping_seeds_and_different_hyperparameters(tmp_path, walker, capsys):
    dup = write_run(tmp_path, "dup", act="swim", returns=SWIM[:, :1], first_seed=1)  # seed index 1 again
    rc, _, err = run_report(walker + [dup, "--out", tmp_path / "o1"], capsys)
    assert rc == 2 and "seed index 1" in err and dup in err and len(err.strip().splitlines()) == 1
    ok = write_run(tmp_path, "other_base", act="swim", returns=SWIM[:, :1], first_seed=1, seed=7)
    assert run_report(walker + [ok, "--out", tmp_path / "o2", "--n-boot", "200"], capsys)[0] == 0
    # one seed trained alone without its padding lane (pad_single_seed: false, e.g. a 1M cell's last
    # piece): placement, like lane_groups; pooled as a seed of the same experiment
    alone = write_run(tmp_path, "alone", act="swim", returns=SWIM[:, :1], first_seed=6, pad_single_seed=False)
    assert run_report(walker + [alone, "--out", tmp_path / "o5", "--n-boot", "200"], capsys)[0] == 0
    big = write_run(tmp_path, "big", act="swim", returns=SWIM[:, :1], first_seed=5, hidden=(256, 256))
    rc, _, err = run_report(walker + [big, "--out", tmp_path / "o3"], capsys)
    assert rc == 2 and "agent.hidden" in err and big in err
    rc, _, err = run_report(walker + [walker[0], "--out", tmp_path / "o4"], capsys)
    assert rc == 2 and "given twice" in err


def test_runs_of_different_precision_are_refused_unless_asked_and_then_marked(tmp_path, capsys):
    """float32 against float64 runs of one env: one line naming both, exit 2, nothing written;
    with --mixed-precision the report is written and the env's rows and verdict carry the mark."""
    paths = [write_run(tmp_path, "a", act="swim"), write_run(tmp_path, "b", act="swish", returns=SWISH,
                                                               precision="float64")]
    out = tmp_path / "out"
    rc, _, err = run_report(paths + ["--out", out, "--n-boot", "200"], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1 and not out.exists()
    assert "runs differ in precision or matmul_dtype: float32: a; float64: b" in err and "--mixed-precision" in err
    assert run_report(paths + ["--out", out, "--n-boot", "200", "--mixed-precision"], capsys)[0] == 0
    md = (out / "REPORT.md").read_text()
    assert "### Walker2d-v5 ‡ (runs differ in precision or matmul_dtype: float32: a; float64: b)" in md
    assert "- **Walker2d-v5 ‡ (runs differ" in md
    assert json.loads((out / "results.json").read_text())["envs"]["Walker2d-v5"]["mixed_precision"].startswith("runs differ")


def _write_matmul_dtype(run_dir, dtype):
    """The key swim_jax.run.train writes into a finished run's timing.json: the dtype its products ran in."""
    with open(os.path.join(run_dir, "timing.json"), "w") as f:
        json.dump({"wall_time_s": 1.0, "matmul_dtype": dtype}, f)


def test_matmul_products_differing_between_machines_are_refused_unless_asked(tmp_path, capsys):
    """Same config (the old matmul_dtype: auto) resolved to bfloat16 on one machine and float32 on
    another: refused with one line naming the runs, compared with --mixed-precision (the budget table
    names each activation's products, the rows are marked); agreeing runs get one dtype and no mark;
    runs that multiplied in their precision (or record nothing) keep the plain precision."""
    runs = tmp_path / "runs"
    runs.mkdir()
    swim = write_run(runs, "swim", act="swim", matmul_dtype="auto")
    swish = write_run(runs, "swish", act="swish", returns=SWISH, matmul_dtype="auto")
    out = tmp_path / "none"
    assert run_report([swim, swish, "--out", out, "--n-boot", "200"], capsys)[0] == 0
    md = (out / "REPORT.md").read_text()
    assert "| 5 | Swim 2, Swish 2 | float32 |" in md and "‡" not in md
    _write_matmul_dtype(swim, "float32")
    _write_matmul_dtype(swish, "bfloat16")
    out = tmp_path / "mixed"
    rc, _, err = run_report([swim, swish, "--out", out, "--n-boot", "200"], capsys)
    assert rc == 2 and "float32: swim; float32, bfloat16 products: swish" in err and not out.exists()
    assert run_report([swim, swish, "--out", out, "--n-boot", "200", "--mixed-precision"], capsys)[0] == 0
    md = (out / "REPORT.md").read_text()
    assert "| float32; products: Swim float32, Swish bfloat16 ‡ |" in md
    walker_json = json.loads((out / "results.json").read_text())["envs"]["Walker2d-v5"]
    assert any("--mixed-precision" in w for w in walker_json["warnings"])
    assert {a: c.get("matmul_dtypes") for a, c in walker_json["curves"].items()} == {"swim": None,
                                                                                     "swish": ["bfloat16"]}
    _write_matmul_dtype(swim, "bfloat16")
    out = tmp_path / "same"
    assert run_report([swim, swish, "--out", out, "--n-boot", "200"], capsys)[0] == 0
    md = (out / "REPORT.md").read_text()
    assert "| float32, bfloat16 products |" in md and "‡" not in md


def test_report_at_a_budget_the_runs_have_reached(tmp_path, capsys):
    """--at-step N reads every run at the budget N (Table II at 300k from 1M runs): equal to a report of
    the same runs cut at N, a run still training counts once it has passed N, and a step the runs
    have not reached or that is not an evaluation step is one line, exit 2."""
    long_swim = np.concatenate([SWIM, SWIM[-1:] + 50.0, SWIM[-1:] + 90.0])  # 5 evaluations: 0..400
    long_swish = np.concatenate([SWISH, SWISH[-1:] - 20.0])  # 4 of 5: still training
    full = [write_run(tmp_path / "full", "swim", act="swim", returns=long_swim, total_steps=400),
            write_run(tmp_path / "full", "swish", act="swish", returns=long_swish, total_steps=400)]
    cut = [write_run(tmp_path / "cut", "swim", act="swim"), write_run(tmp_path / "cut", "swish", act="swish", returns=SWISH)]
    assert run_report(cut + ["--out", tmp_path / "r_cut", "--n-boot", "200"], capsys)[0] == 0
    assert run_report(full + ["--out", tmp_path / "r_at", "--n-boot", "200", "--at-step", "200"], capsys)[0] == 0
    at = json.loads((tmp_path / "r_at" / "results.json").read_text())["envs"]["Walker2d-v5"]
    ref = json.loads((tmp_path / "r_cut" / "results.json").read_text())["envs"]["Walker2d-v5"]
    without_paths = lambda t2: {a: {k: v for k, v in row.items() if k != "runs"} for a, row in t2.items()}
    assert without_paths(at["table2"]) == without_paths(ref["table2"])
    assert at["steps"] == [0, 100, 200] and at["total_steps"] == 200
    rc, _, err = run_report(full + ["--out", tmp_path / "r_far", "--at-step", "400"], capsys)
    assert rc == 2 and "has reached step 300, not --at-step 400" in err
    rc, _, err = run_report(full + ["--out", tmp_path / "r_odd", "--at-step", "150"], capsys)
    assert rc == 2 and "not an evaluation step" in err and len(err.strip().splitlines()) == 1


def test_incomplete_runs_refused_or_truncated(tmp_path, walker, capsys):
    part = write_run(tmp_path, "partial", act="relu", returns=SWISH[:2])  # 2 of 3 evaluations
    rc, _, err = run_report(walker + [part, "--out", tmp_path / "o1"], capsys)
    assert rc == 2 and "incomplete run (2 of 3 evaluations)" in err and "--allow-incomplete" in err
    out = tmp_path / "o2"
    rc, _, err = run_report(walker + [part, "--out", out, "--allow-incomplete", "--n-boot", "200"], capsys)
    assert rc == 0, err
    res = json.loads((out / "results.json").read_text())
    w = res["envs"]["Walker2d-v5"]
    assert w["steps"] == [0, 100] and w["truncated_to_step"] == 100
    assert w["table2"]["swim"]["max_mean"] == 50.0 and w["table2"]["swim"]["final_mean"] == 50.0
    assert "truncated to 100" in (out / "REPORT.md").read_text()


def test_non_empty_out_refused_unless_force(tmp_path, walker, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "REPORT.md").write_text("precious")
    (out / "keep.txt").write_text("mine")
    rc, _, err = run_report(walker + ["--out", out], capsys)
    assert rc == 2 and "not empty" in err and "--force" in err and len(err.strip().splitlines()) == 1
    assert (out / "REPORT.md").read_text() == "precious" and sorted(os.listdir(out)) == ["REPORT.md", "keep.txt"]
    rc, _, err = run_report(walker + ["--out", out, "--force", "--n-boot", "200"], capsys)
    assert rc == 0, err
    assert (out / "REPORT.md").read_text().startswith("# Swim vs Swish") and (out / "keep.txt").read_text() == "mine"
    # an empty existing folder is fine without --force
    empty = tmp_path / "empty"
    empty.mkdir()
    assert run_report(walker + ["--out", empty, "--n-boot", "200"], capsys)[0] == 0


def test_bad_bench_and_bad_arguments(tmp_path, walker, capsys):
    bench = tmp_path / "b.json"
    bench.write_text(json.dumps({"machine": {}, "elementwise": []}))
    rc, _, err = run_report(walker + ["--bench", bench, "--out", tmp_path / "o"], capsys)
    assert rc == 2 and "no actor_inference section" in err and not (tmp_path / "o").exists()
    (tmp_path / "c.json").write_text("{not json")
    rc, _, err = run_report(["--bench", tmp_path / "c.json", "--out", tmp_path / "o"], capsys)
    assert rc == 2 and "unreadable JSON" in err and len(err.strip().splitlines()) == 1
    with pytest.raises(SystemExit) as e:
        report.main(["--out", str(tmp_path / "o")])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "at least one RUN_DIR" in err


def test_module_cli_exit_status(tmp_path, walker):
    out = tmp_path / "out"
    bad = os.path.join(str(tmp_path), "missing")
    p = subprocess.run([sys.executable, "-m", "swim_jax.report", *walker, bad, "--out", str(out)],
                       cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and p.stderr.strip() == f"report: error: {bad}: not a directory"
    assert not out.exists()
    p = subprocess.run([sys.executable, "-m", "swim_jax.report", *walker, "--out", str(out), "--n-boot", "200"],
                       cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert sorted(os.listdir(out)) == ["REPORT.md", "figure4.png", "figure4.svg", "results.csv", "results.json"]


# ------------------------------------------------------------------------------------------------
# defects: figure colours, --out edge cases, atomic --force, input validation, wording
# ------------------------------------------------------------------------------------------------

RESERVED = {"#d62728": "swim", "#1f77b4": "swish", "#2ca02c": "relu"}  # matplotlib tab:red/blue/green


def _curve_stroke_colours(svg: str) -> list[str]:
    """Stroke colours of the plotted curves (clipped to the axes, line width 1.6), in drawing order."""
    import re

    return re.findall(r'clip-path="url\(#\w+\)" style="fill: none; stroke: (#[0-9a-f]{6}); stroke-width: 1\.6;', svg)


def test_figure4_colours_distinct_for_any_number_of_curves(tmp_path, capsys):
    runs = tmp_path / "runs"
    runs.mkdir()
    paths = [write_run(runs, "swim", act="swim"), write_run(runs, "swish", act="swish", returns=SWISH),
             write_run(runs, "relu", act="relu", returns=SWISH + 1)]
    for i, k in enumerate((0.25, 0.75, 1.0, 1.5, 2.0, 3.0)):
        paths.append(write_run(runs, f"swim_k{i}", act="swim", k=k, returns=SWIM + i))
    for i, b in enumerate((0.5, 1.5, 2.0, 3.0, 4.0, 5.0)):
        paths.append(write_run(runs, f"swish_b{i}", act="swish", beta=b, returns=SWISH + i))
    out = tmp_path / "out"
    rc, _, err = run_report(paths + ["--out", out, "--n-boot", "200"], capsys)
    assert rc == 0, err
    colours = _curve_stroke_colours((out / "figure4.svg").read_text())
    assert len(colours) == 15  # 3 paper activations + 12 parameter variants
    assert len(set(colours)) == 15, colours  # every curve its own colour
    for reserved in RESERVED:  # tab:red/blue/green only for Swim, Swish and ReLU themselves
        assert colours.count(reserved) == 1, (reserved, colours)


def test_figure4_legend_counts_seeds_in_words(tmp_path, capsys, monkeypatch):
    """A curve's legend label says how many seeds it averages: "1 seed", "2 seeds"."""
    from swim_jax.analysis import report_figure

    labels, save = [], report_figure._save

    def save_and_read_legends(fig, paths):
        labels.extend(t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts())
        save(fig, paths)

    monkeypatch.setattr(report_figure, "_save", save_and_read_legends)
    runs = tmp_path / "runs"
    runs.mkdir()
    paths = [write_run(runs, "swim", act="swim", returns=SWIM[:, :1]), write_run(runs, "swish", act="swish")]
    rc, _, err = run_report(paths + ["--out", tmp_path / "out", "--n-boot", "200"], capsys)
    assert rc == 0, err
    assert labels[:2] == ["Swim (1 seed)", "Swish (2 seeds)"], labels


def test_figure_curve_colours_function():
    from swim_jax.analysis.report_figure import COLORS, curve_colors

    labels = ["swim", "swish", "relu"] + [f"swim(k={i})" for i in range(40)]
    cols = curve_colors(labels)
    assert cols["swim"] == "#d62728" and cols["swish"] == "#1f77b4" and cols["relu"] == "#2ca02c"
    assert len(set(cols.values())) == len(labels)
    assert cols["swim(k=0)"] not in RESERVED  # the first extra label is not Swim's red
    assert curve_colors(["swim(k=2)"])["swim(k=2)"] not in RESERVED
    assert set(COLORS) == {"swim", "swish", "relu"}


def _one_error_line(err: str) -> bool:
    return len(err.strip().splitlines()) == 1 and err.startswith("report: error: ")


def test_out_empty_string_is_refused(tmp_path, walker, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    before = sorted(os.listdir(tmp_path.parent))
    rc, _, err = run_report(walker + ["--out", "", "--n-boot", "200"], capsys)
    assert rc == 2 and _one_error_line(err), err
    assert "--out is empty" in err
    assert sorted(os.listdir(tmp_path.parent)) == before  # no temporary (.out-*) folder next to the cwd
    assert sorted(os.listdir(tmp_path)) == ["runs"]


def test_out_dangling_symlink_is_refused(tmp_path, walker, capsys):
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "gone")
    rc, _, err = run_report(walker + ["--out", link, "--n-boot", "200"], capsys)
    assert rc == 2 and _one_error_line(err), err
    assert "dangling symbolic link" in err and str(link) in err
    assert link.is_symlink() and not (tmp_path / "gone").exists()
    assert [p for p in os.listdir(tmp_path) if p.startswith(".")] == []  # no temporary folder left
    # a link to an existing empty folder is a valid --out
    (tmp_path / "real").mkdir()
    ok = tmp_path / "ok"
    ok.symlink_to(tmp_path / "real")
    assert run_report(walker + ["--out", ok, "--n-boot", "200"], capsys)[0] == 0
    assert (tmp_path / "real" / "REPORT.md").is_file()


def _old_report(out):
    out.mkdir()
    for name in ("figure4.png", "figure4.svg", "results.json", "sweep.png", "sweep.svg"):
        (out / name).write_text(f"old {name}")
    (out / "keep.txt").write_text("mine")


def _snapshot(d):
    return {p: (open(os.path.join(d, p), "rb").read() if os.path.isfile(os.path.join(d, p)) else "dir")
            for p in sorted(os.listdir(d))}


def test_force_refuses_a_directory_named_report_md_and_changes_nothing(tmp_path, walker, capsys):
    out = tmp_path / "out"
    _old_report(out)
    (out / "REPORT.md").mkdir()
    (out / "REPORT.md" / "notes.txt").write_text("precious")
    before = _snapshot(out)
    rc, _, err = run_report(walker + ["--out", out, "--force", "--n-boot", "200"], capsys)
    assert rc == 2 and _one_error_line(err), err
    assert "REPORT.md" in err and "directory" in err
    assert _snapshot(out) == before  # the figures were not replaced
    assert (out / "REPORT.md" / "notes.txt").read_text() == "precious"
    assert [p for p in os.listdir(tmp_path) if p.startswith(".")] == []  # no temporary folder left


def test_force_is_all_or_nothing_when_a_replacement_fails(tmp_path, walker, capsys, monkeypatch):
    out = tmp_path / "out"
    _old_report(out)
    (out / "REPORT.md").write_text("old report")
    before = _snapshot(out)
    real_replace = os.replace

    def flaky(src, dst, *a, **kw):  # the 3rd file moved into out fails
        if os.path.dirname(os.path.abspath(dst)) == str(out):
            flaky.n += 1
            if flaky.n == 3:
                raise OSError(28, "No space left on device")
        return real_replace(src, dst, *a, **kw)

    flaky.n = 0
    monkeypatch.setattr(os, "replace", flaky)
    rc, _, err = run_report(walker + ["--out", out, "--force", "--n-boot", "200"], capsys)
    monkeypatch.undo()
    assert flaky.n >= 3
    assert rc == 2 and _one_error_line(err), err
    assert "No space left on device" in err
    assert _snapshot(out) == before  # everything restored, the stale sweep figures too
    assert [p for p in os.listdir(tmp_path) if p.startswith(".")] == []  # no temporary folder left


def test_force_removes_stale_sweep_figures(tmp_path, walker, capsys):
    runs = tmp_path / "k"
    runs.mkdir()
    ks = [write_run(runs, "k1", act="swim", k=1.0), write_run(runs, "k2", act="swim", k=2.0)]
    out = tmp_path / "out"
    assert run_report(walker + ks + ["--out", out, "--n-boot", "200"], capsys)[0] == 0
    assert (out / "sweep.png").is_file() and (out / "sweep.svg").is_file()
    (out / "keep.txt").write_text("mine")
    rc, _, err = run_report(walker + ["--out", out, "--force", "--n-boot", "200"], capsys)
    assert rc == 0, err
    assert sorted(os.listdir(out)) == ["REPORT.md", "figure4.png", "figure4.svg", "keep.txt", "results.csv", "results.json"]
    assert "sweep.png" not in (out / "REPORT.md").read_text()


def test_complex_evaluations_are_refused(tmp_path, walker, capsys):
    bad = write_run(tmp_path, "cplx", act="relu", returns=SWISH)
    np.save(os.path.join(bad, "evaluations.npy"), SWISH + 1j)
    out = tmp_path / "out"
    rc, _, err = run_report(walker + [bad, "--out", out], capsys)
    assert rc == 2 and _one_error_line(err), err
    assert bad in err and "complex128" in err and "real" in err
    assert not out.exists()


def test_total_steps_not_a_multiple_of_eval_freq_is_refused(tmp_path, capsys):
    # 250 steps, evaluations every 100: steps 0, 100, 200 -- the last 50 steps were never evaluated
    paths = [write_run(tmp_path, "a", act="swim", total_steps=250), write_run(tmp_path, "b", act="swish",
                                                                               returns=SWISH, total_steps=250)]
    out = tmp_path / "out"
    rc, _, err = run_report(paths + ["--out", out], capsys)
    assert rc == 2 and _one_error_line(err), err
    assert "total_steps=250" in err and "multiple of eval_freq=100" in err and paths[0] in err
    assert not out.exists()


def test_report_states_the_bootstrap_seed_of_each_sample(tmp_path, capsys):
    x = np.array([[0.0, 0.0, 0.0, 0.0], [3.0, 7.0, 1.0, 9.0], [4.0, 2.0, 8.0, 5.0]])
    y = np.array([[0.0, 0.0, 0.0], [2.0, 6.0, 1.0], [5.0, 3.0, 4.0]])
    paths = [write_run(tmp_path, "a", act="swim", returns=x), write_run(tmp_path, "b", act="swish", returns=y)]
    out = tmp_path / "out"
    rc, _, err = run_report(paths + ["--out", out, "--n-boot", "500", "--boot-seed", "5", "--score", "final"], capsys)
    assert rc == 0, err
    md = (out / "REPORT.md").read_text()
    assert "seed 5 for X's CI, 6 for Y's CI and 7 for the difference's" in md
    assert "seed 5, so deterministic" not in md
    res = json.loads((out / "results.json").read_text())
    assert "5 (x), 6 (y), 7 (difference)" in res["definitions"]["bootstrap"]
    c = res["envs"]["Walker2d-v5"]["comparisons"]["swim_vs_swish"]["final"]

    def loop_ci(*samples, seed):  # the draws the text promises, as a plain loop
        rng = np.random.default_rng(seed)
        idx = [rng.integers(0, s.size, size=(500, s.size)) for s in samples]
        stat = [sum((1 if j == 0 else -1) * np.mean([s[i] for i in idx[j][b]]) for j, s in enumerate(samples))
                for b in range(500)]
        return list(np.quantile(stat, [0.025, 0.975]))

    assert c["ci95_x"] == pytest.approx(loop_ci(x[-1], seed=5), rel=1e-12)
    assert c["ci95_y"] == pytest.approx(loop_ci(y[-1], seed=6), rel=1e-12)
    assert c["diff_ci95"] == pytest.approx(loop_ci(x[-1], y[-1], seed=7), rel=1e-12)


def test_welch_cell_when_both_samples_have_zero_variance(tmp_path, capsys):
    # every seed has the same curve: per-seed scores constant, Welch's t undefined
    paths = [write_run(tmp_path, "a", act="swim", returns=np.array([[0.0, 0.0], [5.0, 5.0], [6.0, 6.0]])),
             write_run(tmp_path, "b", act="swish", returns=np.array([[0.0, 0.0], [4.0, 4.0], [4.0, 4.0]]))]
    out = tmp_path / "out"
    rc, _, err = run_report(paths + ["--out", out, "--n-boot", "200"], capsys)
    assert rc == 0, err
    md = (out / "REPORT.md").read_text()
    assert "nan (nan)" not in md
    row = [line for line in md.splitlines() if line.startswith("| Walker2d-v5 | Swim vs Swish | max |")]
    assert len(row) == 1 and row[0].endswith("| 6.0 [6.0, 6.0] | 4.0 [4.0, 4.0] | 6.0 / 4.0 | +2.0 [+2.0, +2.0] "
                                             "| 1.00 | n/a (zero variance) | n/a |"), row
    res = json.loads((out / "results.json").read_text())
    w = res["envs"]["Walker2d-v5"]["comparisons"]["swim_vs_swish"]["max"]["welch"]
    assert w == {"t": None, "df": None, "p_two_sided": None}


def test_negative_boot_seed_is_refused(tmp_path, walker, capsys):
    with pytest.raises(SystemExit) as e:
        report.main(walker + ["--out", str(tmp_path / "o"), "--boot-seed", "-1"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--boot-seed must be >= 0" in err
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------------------------------------------------
# learning metrics between evaluations (metrics.csv)
# ------------------------------------------------------------------------------------------------

METRICS_HEADER = "step,seed,updates,critic_loss,q_mean,actor_updates,actor_loss,episodes,last_episode_return"


def write_metrics(run_dir, rows):
    """metrics.csv as swim_jax.run.train writes it, from (step, seed, critic loss, actor loss, Q) rows."""
    lines = [METRICS_HEADER] + [f"{st},{seed},100,{c!r},{q!r},50,{a!r},3,12.5" for st, seed, c, a, q in rows]
    with open(os.path.join(run_dir, "metrics.csv"), "w") as f:
        f.write("\n".join(lines) + "\n")


NAN = float("nan")
# Walker2d-v5, eval_freq 100: chunks end at steps 100 and 200. (step, seed, critic, actor, Q)
SWIM_A = [(100, 0, NAN, NAN, NAN), (100, 1, NAN, NAN, NAN), (200, 0, 4.0, 1.0, -2.0), (200, 1, 1.0, 3.0, -6.0)]
SWIM_B = [(100, 2, 2.0, 5.0, 0.5), (200, 2, 7.0, 2.0, -1.0)]  # a second swim run: seed 2, pooled
SWISH_M = [(100, 0, 10.0, -1.0, 1.0), (100, 1, 30.0, 1.0, 3.0), (200, 0, 5.0, 2.0, 10.0), (200, 1, 5.0, 4.0, 20.0)]


def _learning_runs(root):
    runs = os.path.join(str(root), "runs")
    os.makedirs(runs)
    paths = [write_run(runs, "swim_a", act="swim"),
             write_run(runs, "swim_b", act="swim", returns=SWIM[:, :1], first_seed=2),
             write_run(runs, "swish", act="swish", returns=SWISH),
             write_run(runs, "relu", act="relu", returns=SWISH + 1)]
    for path, rows in zip(paths, (SWIM_A, SWIM_B, SWISH_M)):
        write_metrics(path, rows)
    return paths  # relu: an old run folder without metrics.csv


def test_learning_metrics_figure_and_numbers_by_hand(tmp_path, capsys):
    """Per chunk mean/min/max over the pooled seeds that have a number (swim: seeds 0, 1 of one run
    and seed 2 of another), drawn in Figure 4's colours; the run without metrics.csv is named."""
    paths = _learning_runs(tmp_path)
    out = tmp_path / "out"
    rc, stdout, err = run_report(paths + ["--out", out, "--n-boot", "200"], capsys)
    assert rc == 0, err
    assert sorted(os.listdir(out)) == ["REPORT.md", "figure4.png", "figure4.svg", "learning.png", "learning.svg",
                                       "results.csv", "results.json"]
    assert "learning.png" in stdout and (out / "learning.png").read_bytes().startswith(b"\x89PNG")
    lm = json.loads((out / "results.json").read_text())["envs"]["Walker2d-v5"]["learning_metrics"]
    assert list(lm) == ["swim", "swish"]  # relu has no metrics.csv
    # swim, chunk 100: only seed 2 updated; chunk 200: seeds 0, 1, 2
    assert lm["swim"]["steps"] == [100, 200] and lm["swim"]["seeds"] == 3
    assert lm["swim"]["critic_loss"] == {"mean": [2.0, 4.0], "min": [2.0, 1.0], "max": [2.0, 7.0]}
    assert lm["swim"]["actor_loss"] == {"mean": [5.0, 2.0], "min": [5.0, 1.0], "max": [5.0, 3.0]}
    assert lm["swim"]["q_mean"] == {"mean": [0.5, -3.0], "min": [0.5, -6.0], "max": [0.5, -1.0]}
    assert lm["swish"]["critic_loss"] == {"mean": [20.0, 5.0], "min": [10.0, 5.0], "max": [30.0, 5.0]}
    assert lm["swish"]["actor_loss"] == {"mean": [0.0, 3.0], "min": [-1.0, 2.0], "max": [1.0, 4.0]}
    assert lm["swish"]["q_mean"] == {"mean": [2.0, 15.0], "min": [1.0, 10.0], "max": [3.0, 20.0]}
    # three panels (critic loss, actor loss, Q), each with Swim's red then Swish's blue
    colours = _curve_stroke_colours((out / "learning.svg").read_text())
    assert colours == ["#d62728", "#1f77b4"] * 3, colours
    md = (out / "REPORT.md").read_text()
    assert "## Learning metrics between evaluations" in md and "![Learning metrics](learning.png)" in md
    assert md.index("## Figure 4") < md.index("## Learning metrics") < md.index("## Beyond the paper")
    assert "Left out (no `metrics.csv`" in md and f"`{paths[3]}`." in md


def test_runs_without_metrics_csv_report_as_before(tmp_path, capsys):
    """The same runs without their metrics.csv: no learning figure, and REPORT.md and results.json
    are those of the report with metrics less its learning section and numbers. --force over a
    report with the figure removes it."""
    paths = _learning_runs(tmp_path)
    with_m, without = tmp_path / "with", tmp_path / "without"
    assert run_report(paths + ["--out", with_m, "--n-boot", "200"], capsys)[0] == 0
    for p in paths[:3]:
        os.remove(os.path.join(p, "metrics.csv"))
    assert run_report(paths + ["--out", without, "--n-boot", "200"], capsys)[0] == 0
    assert sorted(os.listdir(without)) == ["REPORT.md", "figure4.png", "figure4.svg", "results.csv", "results.json"]
    for name in ("figure4.png", "figure4.svg"):
        assert (with_m / name).read_bytes() == (without / name).read_bytes()
    res_with, res_without = (json.loads((d / "results.json").read_text()) for d in (with_m, without))
    del res_with["envs"]["Walker2d-v5"]["learning_metrics"]
    assert res_with == res_without
    md_with = (with_m / "REPORT.md").read_text().replace(str(with_m), "OUT")
    start, end = md_with.index("## Learning metrics"), md_with.index("## Beyond the paper")
    assert md_with[:start] + md_with[end:] == (without / "REPORT.md").read_text().replace(str(without), "OUT")
    rc, _, err = run_report(paths + ["--out", with_m, "--force", "--n-boot", "200"], capsys)
    assert rc == 0, err
    assert sorted(os.listdir(with_m)) == ["REPORT.md", "figure4.png", "figure4.svg", "results.csv", "results.json"]


@pytest.mark.parametrize("rows, needle", [
    ([(100, 5, 1.0, 1.0, 1.0)], "row 2 has seed 5, not one of the run's seeds [0, 1]"),
    ([(150, 0, 1.0, 1.0, 1.0)], "row 2 has step 150, not a chunk end"),
    ([(300, 0, 1.0, 1.0, 1.0)], "row 2 has step 300, not a chunk end"),
    ([(100, 0, 1.0, 1.0, 1.0), (100, 0, 2.0, 1.0, 1.0)], "step 100 of seed 0 appears twice"),
    (None, "unreadable (missing column 'updates'"),
])
def test_bad_metrics_csv_exit_2_one_line_nothing_written(tmp_path, walker, capsys, rows, needle):
    if rows is None:
        with open(os.path.join(walker[0], "metrics.csv"), "w") as f:
            f.write("step,seed,critic_loss\n100,0,1.0\n")  # columns missing
    else:
        write_metrics(walker[0], rows)
    out = tmp_path / "out"
    rc, _, err = run_report(walker + ["--out", out], capsys)
    assert rc == 2 and _one_error_line(err), err
    assert os.path.join(walker[0], "metrics.csv") in err and needle in err, err
    assert not out.exists()


def test_learning_metrics_of_incomplete_runs_cover_the_common_evaluations(tmp_path, walker, capsys):
    """--allow-incomplete truncates the metrics to the chunks before the last common evaluation;
    chunks a run has no row for are gaps (no number)."""
    part = write_run(tmp_path, "partial", act="relu", returns=SWISH[:2])  # evaluations at 0 and 100
    write_metrics(part, [(100, 0, 1.0, 2.0, 3.0), (200, 0, 9.0, 9.0, 9.0)])  # chunk 200 logged, not evaluated
    write_metrics(walker[1], [(200, 0, 4.0, 5.0, 6.0)])
    out = tmp_path / "out"
    rc, _, err = run_report(walker + [part, "--out", out, "--allow-incomplete", "--n-boot", "200"], capsys)
    assert rc == 0, err
    lm = json.loads((out / "results.json").read_text())["envs"]["Walker2d-v5"]["learning_metrics"]
    assert lm["relu"]["steps"] == [100] and lm["relu"]["critic_loss"]["mean"] == [1.0]
    assert lm["relu"]["actor_loss"]["max"] == [2.0] and lm["relu"]["q_mean"]["min"] == [3.0]
    assert lm["swish"]["steps"] == [100]
    assert lm["swish"]["critic_loss"] == {"mean": [None], "min": [None], "max": [None]}  # no row for 100


def test_elu_labels_old_and_new_run_folders_and_alpha_series(tmp_path, capsys):
    """ELU(α) reaches the report from the registry alone: labels elu / elu(alpha=0.5) /
    elu+learnable, display name ELU, a return-vs-alpha series; a run folder written before alpha
    existed (no alpha key) pools with a new one at the default alpha."""
    runs = tmp_path / "runs"
    runs.mkdir()
    paths = [write_run(runs, "swim", act="swim"),
             write_run(runs, "elu_old", act="elu", returns=SWISH),  # no alpha key: alpha = 1
             write_run(runs, "elu_new", act="elu", returns=SWISH + 1, first_seed=2, activation={"alpha": 1.0}),
             write_run(runs, "elu_a", act="elu", returns=SWISH + 2, activation={"alpha": 0.5}),
             write_run(runs, "elu_l", act="elu", returns=SWISH + 3, activation={"alpha": 1.0, "learnable": True})]
    groups = runs_io.load_and_group(paths)
    curves = groups["Walker2d-v5"].curves
    assert list(curves) == ["swim", "elu", "elu(alpha=0.5)", "elu+learnable"]
    assert curves["elu"].n_seeds == 4 and curves["elu"].setting.params == (("alpha", 1.0),)
    series = parameter_series(groups)
    assert list(series) == [("Walker2d-v5", "elu", "alpha")]
    assert [v for v, _, _ in series[("Walker2d-v5", "elu", "alpha")]] == [0.5, 1.0]
    out = tmp_path / "out"
    rc, _, err = run_report(paths + ["--out", out, "--n-boot", "200"], capsys)
    assert rc == 0, err
    md = (out / "REPORT.md").read_text()
    assert "| ELU(alpha=0.5) |" in md and "| ELU+learnable |" in md and "| Walker2d-v5 | ELU | 0.5 |" in md
    assert (out / "sweep.svg").is_file()


def test_every_pair_of_labels_is_compared_or_each_against_a_baseline(tmp_path, capsys):
    """Any activation gets comparisons: every pair of the labels present (Swim, Swish, ReLU first), or
    with --baseline LABEL every other label against it; the paper's Swim vs Swish verdict stays."""
    mish = SWISH + 5.0
    paths = [write_run(tmp_path, "a", act="swim"), write_run(tmp_path, "b", act="swish", returns=SWISH),
             write_run(tmp_path, "c", act="relu", returns=SWISH - 3.0), write_run(tmp_path, "d", act="mish", returns=mish)]
    assert run_report(paths + ["--out", tmp_path / "all", "--n-boot", "200"], capsys)[0] == 0
    res = json.loads((tmp_path / "all" / "results.json").read_text())["envs"]["Walker2d-v5"]
    assert list(res["comparisons"]) == ["swim_vs_swish", "swim_vs_relu", "swim_vs_mish", "swish_vs_relu",
                                        "swish_vs_mish", "relu_vs_mish"]
    c = res["comparisons"]["relu_vs_mish"]["final"]
    assert c["diff"] == pytest.approx((SWISH[-1] - 3.0).mean() - mish[-1].mean())
    assert res["verdict"] is not None and "with 3 scores × 6 pairs per env" in (tmp_path / "all" / "REPORT.md").read_text()
    assert run_report(paths + ["--out", tmp_path / "base", "--n-boot", "200", "--baseline", "relu"], capsys)[0] == 0
    res = json.loads((tmp_path / "base" / "results.json").read_text())["envs"]["Walker2d-v5"]
    assert list(res["comparisons"]) == ["swim_vs_relu", "swish_vs_relu", "mish_vs_relu", "swim_vs_swish"]
    assert res["verdict"] is not None
    rc, _, err = run_report(paths + ["--out", tmp_path / "bad", "--baseline", "gelu"], capsys)
    assert rc == 2 and "--baseline 'gelu' is not a label of these runs; valid: mish, relu, swim, swish" in err
    assert not (tmp_path / "bad").exists()
