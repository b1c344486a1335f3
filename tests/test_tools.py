"""The small tools under tools/: tools/compare_runs.py on synthetic run folders with known curves
(expectations by hand, Welch's p against scipy's own test), tools/bench_peers.py's ``--ours`` row
selection (command line, bad input, row mapping; the benchmark itself runs the peers for minutes with
a second Python that has torch and is run by hand, docs/PERFORMANCE.md: td3-vs-peers), the bad-input line of
tools/f32_input_floor.py, and tools/cross_env_table.py on hand-written evaluate tables."""

import os
import subprocess
import sys

import numpy as np
import pytest
from scipy import stats as scipy_stats

from test_report import SWIM, SWISH, write_run

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import bench_peers  # noqa: E402


def run_tool(name, *args):
    return subprocess.run([sys.executable, os.path.join(ROOT, "tools", name), *map(str, args)],
                          capture_output=True, text=True, cwd=ROOT)


def test_table_gives_the_scores_their_difference_and_welch_p(tmp_path):
    # A = SWIM, B = SWISH at steps 0, 100, 200 (2 seeds). By hand: max 55 vs 35, final 45 vs 35,
    # AUC (trapezoid / 200 steps) (40 + 35)/2 = 37.5 vs (17.5 + 25)/2 = 21.25.
    a, b = write_run(tmp_path, "a", returns=SWIM), write_run(tmp_path, "b", act="swish", returns=SWISH)
    done = run_tool("compare_runs.py", a, b)
    assert done.returncode == 0, done.stderr
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
            for line in done.stdout.splitlines()[2:]}
    assert set(rows) == {"max", "final", "auc"}
    expected = {"max": (55, 35, -20, ([60, 50], [30, 40])), "final": (45, 35, -10, ([40, 50], [30, 40])),
                "auc": (37.5, 21.25, -16.25, ([40, 35], [17.5, 25]))}
    for score, (mean_a, mean_b, diff, (per_seed_a, per_seed_b)) in expected.items():
        cells = rows[score]
        assert cells[0].startswith(f"{mean_a:.0f} [") and cells[1].startswith(f"{mean_b:.0f} [")
        assert cells[2].startswith(f"{diff:+.0f} [")
        p = scipy_stats.ttest_ind(per_seed_b, per_seed_a, equal_var=False).pvalue
        assert cells[3] == f"{p:.2f}"


@pytest.mark.parametrize("case", ["missing", "other_env", "other_grid", "one_arg"])
def test_bad_input_is_one_line_and_exit_2(tmp_path, case):
    a = write_run(tmp_path, "a")
    if case == "missing":
        args, needle = (a, tmp_path / "nope"), "nope: not a directory"
    elif case == "other_env":
        args, needle = (a, write_run(tmp_path, "b", env="Hopper-v5")), "env Hopper-v5 differs"
    elif case == "other_grid":
        longer = np.vstack([SWIM, SWIM[-1:]])  # 4 evaluations every 100 steps (total_steps 300)
        args, needle = (a, write_run(tmp_path, "b", returns=longer, total_steps=300)), "the scores need the same grid"
    else:
        args, needle = (a,), "expected two run folders"
    done = run_tool("compare_runs.py", *args)
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], done.stderr


def test_ours_command_puts_the_first_row_in_the_base_config_and_the_rest_in_variants():
    s = {"ours": ["native", "mjx", "native-bf16"], "lanes": 5, "steps": 300}
    cmd = bench_peers.ours_command("Walker2d-v5", s)
    assert cmd[1:4] == ["-m", "swim_jax.bench", "train"]
    text = " ".join(cmd)
    assert "--config walker_relu --lanes 5 --chunk-steps 300 --repeats 1" in text
    assert "--set env.backend=mujoco --set matmul_dtype=full" in text
    assert "--variant env.backend=mjx,matmul_dtype=full --variant env.backend=mujoco,matmul_dtype=bfloat16" in text
    assert cmd[-1] == "--no-roofline"
    only = bench_peers.ours_command("Walker2d-v5", {**s, "ours": ["native"]})
    assert "--variant" not in only


def test_our_rows_names_each_row_by_the_entry_that_produced_it():
    s = {"ours": ["native", "mjx", "native-bf16", "native-one-program"], "lanes": 5}
    groups = "5 lanes as 2 groups of 2, one per cpu device, 1 more in 2 pieces per call over them"
    res = {"rows": [
        {"lanes": 5, "devices": 2, "lane_groups": groups, "variant": "", "env_steps_per_s": 300.0},
        {"lanes": 5, "devices": 1, "variant": "env.backend=mjx,matmul_dtype=full", "env_steps_per_s": 200.0},
        {"lanes": 5, "devices": 1, "variant": "env.backend=mujoco,matmul_dtype=bfloat16", "env_steps_per_s": 350.0},
        {"lanes": 5, "devices": 1, "lane_groups": None, "variant": "env.backend=mujoco,matmul_dtype=full,lane_groups=false",
         "env_steps_per_s": 250.0},
        {"lanes": 1, "devices": 1, "variant": "", "env_steps_per_s": 90.0},
    ]}
    rows = bench_peers.our_rows(res, s)
    assert {k: v["env_steps_per_s"] for k, v in rows.items()} == {
        "ours-mujoco-groups": 300.0, "ours-mjx": 200.0, "ours-mujoco-bf16": 350.0, "ours-mujoco": 250.0}
    assert rows["ours-mujoco-groups"]["label"] == "swim-jax, 5 lanes, native MuJoCo, float32, lane groups (2 devices)"
    assert rows["ours-mujoco"]["label"] == "swim-jax, 5 lanes, native MuJoCo, float32, one program"
    assert rows["ours-mjx"]["label"] == "swim-jax, 5 lanes, MJX, float32, one program"
    assert rows["ours-mujoco-bf16"]["label"] == "swim-jax, 5 lanes, native MuJoCo, bfloat16 matmuls, one program"


@pytest.mark.parametrize("ours", ["gpu", "native,native", ",", "native,fast"])
def test_bad_ours_is_one_line_exit_2_and_nothing_written(ours, tmp_path, capsys):
    out = tmp_path / "bench"
    assert bench_peers.main(["--ours", ours, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--ours" in err[0] and "mjx, native, native-bf16, native-one-program" in err[0]
    assert not out.exists()


@pytest.mark.parametrize("args", [("Nope-v5",), ("Hopper-v5", "Walker2d-v5")])
def test_f32_input_floor_bad_env_is_one_line_exit_2(args):
    done = run_tool("f32_input_floor.py", *args)
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "valid: Hopper-v5, Walker2d-v5, HalfCheetah-v5" in lines[0], done.stderr


@pytest.mark.parametrize("command", [
    ["-m", "swim_jax.bench", "activations"], ["-m", "swim_jax.bench", "rsqrt"], ["-m", "swim_jax.bench", "envs"],
    ["-m", "swim_jax.bench", "train"], ["-m", "swim_jax.bench", "processes"], ["-m", "swim_jax.bench", "profile"],
    ["-m", "swim_jax.plots"], ["-m", "swim_jax.bench", "roofline"], ["-m", "swim_jax.report"], ["-m", "swim_jax.render"],
    ["-m", "swim_jax.evaluate"], ["-m", "swim_jax.study"], ["-m", "swim_jax.bench", "checkpoint"], ["-m", "swim_jax.bench", "startup"],
    ["tools/bench_program_variants.py"], ["tools/bench_compiler_options.py"], ["tools/bench_native_host.py"],
    ["tools/bench_peers.py"], ["tools/cross_env_table.py"],
], ids=lambda c: " ".join(c).replace("-m ", ""))
def test_every_command_lines_usage_error_is_one_line_and_exit_2(command):
    done = subprocess.run([sys.executable, *command, "--no-such-option"], capture_output=True, text=True, cwd=ROOT)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert ": error: " in lines[0]  # the unknown option, or the required arguments it lacks


def test_peer_summary_pairs_each_round_with_that_rounds_best_peer():
    rates = {"pytorch": [100.0, 180.0, 150.0], "cleanrl": [120.0, 150.0, 200.0], "ours-mujoco": [150.0, 200.0, 210.0]}
    labels = {k: k for k in rates}
    summary, best = bench_peers.summarize(rates, labels)
    assert best == 150.0  # max of the medians: pytorch 150, cleanrl 150
    ours = summary["ours-mujoco"]
    assert ours["median"] == 200.0 and ours["ratio_vs_best_peer"] == pytest.approx(200 / 150)
    assert ours["round_ratios"] == pytest.approx([150 / 120, 200 / 180, 210 / 200])
    assert ours["median_round_ratio"] == pytest.approx(200 / 180)
    assert summary["cleanrl"]["round_ratios"] is None and summary["cleanrl"]["ratio_vs_best_peer"] is None
    table = bench_peers.markdown("Hopper-v5", {"summary": summary}, {"steps": 10, "rounds": 3})
    assert "| ours-mujoco | 200 (150–210) | 1.33× | 1.25, 1.11, 1.05 (1.11×) |" in table


def test_peer_rounds_rotate_the_programs_and_keep_every_raw_result(monkeypatch):
    """bench_peers.bench_env on swim_jax.bench.timing.interleave, each run replaced by a known rate:
    the program order rotates per round (recorded in the round's "order"), each round keeps every
    program's raw result, rates and labels come in the first round's order, and ours' per-round
    ratios pair it with the best peer of the same round."""
    ran = []

    def run_peer(impl, env_id, s):
        r = sum(1 for p in ran if p == impl)
        ran.append(impl)
        rate = {"pytorch": [100.0, 180.0, 150.0], "cleanrl": [120.0, 150.0, 200.0]}[impl][r]
        return {"program": impl, "procs": 2, "env_steps_per_s": rate, "wall_env_steps_per_s": rate,
                "overlap_fraction": 1.0, "cpu_per_wall": [1.0, 1.0]}

    def run_ours(env_id, s):
        r = sum(1 for p in ran if p == "ours")
        ran.append("ours")
        return {"program": "ours", "rows": {"ours-mujoco-groups": {"env_steps_per_s": [150.0, 200.0, 210.0][r],
                                                                    "label": "ours"}}}

    monkeypatch.setattr(bench_peers, "run_peer", run_peer)
    monkeypatch.setattr(bench_peers, "run_ours", run_ours)
    logged = []
    res = bench_peers.bench_env("Hopper-v5", {"rounds": 3, "procs": 2, "lanes": 5}, log=logged.append)
    assert ran == ["pytorch", "cleanrl", "ours", "cleanrl", "ours", "pytorch", "ours", "pytorch", "cleanrl"]
    assert [r["order"] for r in res["rounds"]] == [ran[0:3], ran[3:6], ran[6:9]]
    assert [r["round"] for r in res["rounds"]] == [0, 1, 2] and list(res["rounds"][1]) == ["round", "order", "cleanrl", "ours", "pytorch"]
    assert res["rounds"][2]["ours"]["rows"]["ours-mujoco-groups"]["env_steps_per_s"] == 210.0
    assert list(res["summary"]) == ["pytorch", "cleanrl", "ours-mujoco-groups"] and res["best_peer_median"] == 150.0
    assert res["summary"]["pytorch"]["label"] == "PyTorch TD3 (Fujimoto, original), 2 procs × 1 thread"
    assert res["summary"]["ours-mujoco-groups"]["round_ratios"] == pytest.approx([150 / 120, 200 / 180, 210 / 200])
    assert len(logged) == 9 and logged[0].startswith("[Hopper-v5 round 1/3] pytorch: 100.0 env-steps/s")


def write_eval_table(path, env, means, run="runs/x"):
    """A minimal ``evaluate --json`` table: one row per seed with Gymnasium mean ``means[seed]``."""
    import json

    rows = [{"run": run, "seed": s, "step": 1000, "env_id": env, "gymnasium": {"mean": m}} for s, m in enumerate(means)]
    path.write_text(json.dumps({"rows": rows}))
    return path


def test_cross_env_table_pairs_seeds_and_gives_the_paired_t_test(tmp_path):
    a = write_eval_table(tmp_path / "a.json", "Walker2d-v5", [100.0, 200.0, 300.0, 400.0])
    b = write_eval_table(tmp_path / "b.json", "Walker2d-v4", [110.0, 190.0, 330.0, 420.0])
    done = run_tool("cross_env_table.py", a, b)
    assert done.returncode == 0, done.stderr
    row = done.stdout.splitlines()[2]
    # by hand: differences 10, -10, 30, 20: mean 12.5, sd 17.08, se 8.539, t 1.464
    ref = scipy_stats.ttest_rel([110, 190, 330, 420], [100, 200, 300, 400])
    ci = ref.confidence_interval(0.95)
    assert ref.statistic == pytest.approx(12.5 / (np.std([10, -10, 30, 20], ddof=1) / 2))
    assert row == (f"| runs/x: Walker2d-v5 → Walker2d-v4 | 100, 200, 300, 400 (250) | 110, 190, 330, 420 (262) | "
                   f"+12 [{ci.low:+.0f}, {ci.high:+.0f}] ({ref.pvalue:.2g}) |")


def test_cross_env_table_lengths_split_return_into_length_and_return_per_step(tmp_path):
    """--lengths: per seed the mean episode length, the episodes at the time limit and Σ returns / Σ lengths."""
    import json

    episodes = {0: ([100.0, 300.0], [50, 1000]), 1: ([2000.0, 1000.0], [1000, 400])}
    tables = []
    for name, env in (("a.json", "Walker2d-v5"), ("b.json", "Walker2d-v4")):
        rows = [{"run": "runs/x", "seed": s, "step": 1000, "env_id": env,
                 "gymnasium": {"mean": float(np.mean(r)), "returns": r, "lengths": n, "time_limit": 1000,
                               "at_time_limit": sum(k >= 1000 for k in n)}} for s, (r, n) in episodes.items()]
        (tmp_path / name).write_text(json.dumps({"rows": rows}))
        tables.append(tmp_path / name)
    done = run_tool("cross_env_table.py", "--lengths", *tables)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    # seed 0: lengths 50 and 1000 (mean 525, one at the limit), 400 / 1050 per step; seed 1: 700, 1, 3000 / 1400
    assert lines[-4:-2] == [f"| runs/x: {env} | 525 (1/2), 700 (1/2) | {400 / 1050:.2f}, {3000 / 1400:.2f} |"
                            for env in ("Walker2d-v5", "Walker2d-v4")]
    # the share of var(log return) from the length is the slope-like ratio cov(log R, log L) / var(log R)
    log_ret, log_len = np.log([200.0, 1500.0] * 2), np.log([525.0, 700.0] * 2)
    share = np.cov(log_ret, log_len)[0, 1] / np.var(log_ret, ddof=1)
    assert lines[-1] == (f"over 4 seeds, share of var(log return) from the episode length {share:.0%}, from the "
                         f"return per step {1 - share:.0%}; Pearson r(return, length) 1.00")
    done = run_tool("cross_env_table.py", "--lengths-only", tables[1])
    assert done.returncode == 0 and done.stdout.splitlines() == [
        "| run: env | seeds' mean episode length (episodes at the time limit / episodes) | seeds' return per step |",
        "|---|---|---|", lines[-3], "",
        "length share: needs at least 3 seeds with positive mean returns, got 2"], done.stderr
    old = write_eval_table(tmp_path / "old.json", "Walker2d-v5", [1.0, 2.0])
    done = run_tool("cross_env_table.py", "--lengths", old, tables[1])
    assert done.returncode == 2 and "with episode lengths" in done.stderr and done.stdout == ""


@pytest.mark.parametrize("files,message", [
    (["a"], "1 files: give pairs"),
    (["a", "c"], "the same (run, seed, step) rows"),
    (["a", "bad"], "not a table of python -m swim_jax.evaluate --json"),
])
def test_cross_env_table_bad_input_is_one_line_exit_2(files, message, tmp_path):
    write_eval_table(tmp_path / "a", "Walker2d-v5", [1.0, 2.0])
    write_eval_table(tmp_path / "c", "Walker2d-v4", [1.0, 2.0, 3.0])
    (tmp_path / "bad").write_text("{}")
    done = run_tool("cross_env_table.py", *[tmp_path / f for f in files])
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and done.stdout == "" and len(lines) == 1 and message in lines[0], done.stderr
