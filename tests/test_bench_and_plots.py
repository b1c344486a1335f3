"""The benchmark and figure CLIs: real runs on tiny settings, output files checked, bad input."""

import glob
import json
import math
import os
import subprocess
import sys

import pytest

from swim_jax import bench
from swim_jax.analysis import plots
from swim_jax.bench.activations import main as bench_activations_main
from swim_jax.bench.activations import main_rsqrt


def test_unknown_benchmark_exits_2_with_valid_choices(capsys):
    assert bench.main(["bogus"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["swim_jax.bench: unknown benchmark 'bogus'; valid: activations, rsqrt, envs, train, roofline, sgemm, processes, study, profile, checkpoint, startup"]


@pytest.mark.parametrize(
    "args,needle",
    [(["--dtypes", "float16"], "valid: float32, float64"), (["--sections", "z"], "valid: a, b, c"), (["--repeats", "0"], ">= 1")],
)
def test_bad_options_exit_2_and_write_nothing(tmp_path, args, needle):
    proc = subprocess.run(
        [sys.executable, "-m", "swim_jax.bench", "activations", "--out", str(tmp_path / "o"), *args],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    assert needle in proc.stderr
    assert not (tmp_path / "o").exists()


def test_rsqrt_benchmark_measures_the_documented_accuracy(tmp_path):
    assert main_rsqrt(["--quick", "--repeats", "1", "--out", str(tmp_path)]) == 0
    (path,) = tmp_path.glob("rsqrt-*.json")
    rows = json.loads(path.read_text())["rows"]
    err = {r["variant"]: r["max_rel_error_f32"] for r in rows}
    assert err["newton2"] < 1e-6 < err["newton1"]
    assert err["lax.rsqrt"] < 2e-7


def test_elementwise_benchmark_writes_every_candidate(tmp_path):
    assert bench_activations_main(["--quick", "--sections", "a", "--dtypes", "float32", "--repeats", "1", "--out", str(tmp_path)]) == 0
    (path,) = tmp_path.glob("activations-*.json")
    result = json.loads(path.read_text())
    names = {(r["activation"], r["pass"]) for r in result["elementwise"]}
    for act in ("swim", "swim[plain autodiff]", "jax.nn.swish", "relu", "hard_swish", "mish"):
        assert (act, "fwd") in names and (act, "fwd+bwd") in names
    assert all(r["median_us"] > 0 for r in result["elementwise"])
    assert result["machine"]["cores"] >= 1


@pytest.mark.slow
def test_actor_and_update_benchmarks_run(tmp_path):
    assert bench_activations_main(["--quick", "--sections", "b,c", "--repeats", "2", "--out", str(tmp_path)]) == 0
    result = json.loads(next(tmp_path.glob("activations-*.json")).read_text())
    assert {r["activation"] for r in result["td3_update"]} == {"relu", "swish", "swim"}
    assert any(r["activation"] == "swim_vs_swish" for r in result["actor_inference"])


def test_activation_figures_are_written(tmp_path):
    paths = plots.plot_activations(tmp_path / "figs")
    assert [p.name for p in paths] == ["fig1_activations.png", "fig2_derivatives.png"]
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 10_000


def test_plots_cli_refuses_a_file_as_output_folder(tmp_path):
    target = tmp_path / "file.txt"
    target.write_text("keep me")
    proc = subprocess.run(
        [sys.executable, "-m", "swim_jax.plots", "activations", "--out", str(target)], capture_output=True, text=True
    )
    assert proc.returncode == 2 and "is not a folder" in proc.stderr
    assert target.read_text() == "keep me"


def test_env_benchmark_rejects_an_unknown_env_with_exit_2(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "swim_jax.bench", "envs", "--envs", "Bogus-v0", "--out-dir", str(tmp_path / "o")],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    assert "unknown env id 'Bogus-v0'; valid ids: " in proc.stderr and "Hopper-v5" in proc.stderr
    assert not (tmp_path / "o").exists()


def test_env_benchmark_rejects_an_unknown_solver_with_exit_2(tmp_path, capsys):
    from swim_jax.bench.envs import main as bench_envs_main

    with pytest.raises(SystemExit) as e:
        bench_envs_main(["--envs", "Hopper-v5", "--solver-impl", "c,cg", "--out-dir", str(tmp_path / "o")])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "solver_impl must be one of c, mjx, got 'cg'" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_env_benchmark_runs_through_the_bench_cli(tmp_path):
    args = ["envs", "--envs", "Hopper-v5", "--batches", "2", "--scan-len", "2", "--repeats", "1"]
    assert bench.main([*args, "--native-steps", "20", "--solver-impl", "c,mjx", "--backends", "mjx,mujoco",
                       "--out-dir", str(tmp_path)]) == 0
    (path,) = tmp_path.glob("envs-*.json")
    rows = json.loads(path.read_text())["rows"]
    assert [(r["env"], r["physics"]) for r in rows] == [("Hopper-v5", "mjx/c"), ("Hopper-v5", "mjx/mjx"),
                                                        ("Hopper-v5", "mujoco")]
    assert all(len(r["steps_all"]) == len(r["native_all"]) == 1 and r["steps_per_s"] > 0 for r in rows)


def test_env_benchmark_rejects_an_unknown_backend_with_exit_2(tmp_path, capsys):
    from swim_jax.bench.envs import main as bench_envs_main

    with pytest.raises(SystemExit) as e:
        bench_envs_main(["--envs", "Hopper-v5", "--backends", "mjx,bullet", "--out-dir", str(tmp_path / "o")])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown backend 'bullet'; valid backends: mjx, mujoco" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("module,args,needle", [
    ("bench.train", ["--lanes", "0,2"], "positive integers"), ("bench.train", ["--lanes", "x"], "positive integers"),
    ("bench.train", ["--config", "nope"], "valid configs"), ("bench.train", ["--repeats", "0"], ">= 1"),
    ("bench.train", ["--variant", "matmul_dtype=float16"], "valid: full, bfloat16"),
    ("bench.profile", ["--lanes", "0"], ">= 1"), ("bench.profile", ["--steps", "0"], ">= 1"),
    ("bench.profile", ["--config", "nope"], "valid configs")])
def test_train_and_profile_benchmarks_bad_input_exit_2_nothing_written(tmp_path, capsys, module, args, needle):
    import importlib

    main = importlib.import_module(f"swim_jax.{module}").main
    assert main([*args, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_train_benchmark_times_real_programs_without_recompiling(tmp_path, monkeypatch):
    from swim_jax.bench.train import main as bench_train_main

    monkeypatch.setenv("XLA_FLAGS", os.environ.get("XLA_FLAGS", ""))  # undo --host-devices' flag afterwards
    tiny = ["--set", "agent.hidden=[16]", "--set", "agent.batch_size=16", "--host-devices", "1"]  # one program
    assert bench_train_main(["--config", "hopper_relu", "--lanes", "1,2", "--chunk-steps", "50",
                             "--repeats", "2", *tiny, "--variant", "matmul_dtype=bfloat16",
                             "--out", str(tmp_path)]) == 0
    (path,) = tmp_path.glob("train-*.json")
    rows = json.loads(path.read_text())["rows"]
    assert [(r["lanes"], r["variant"]) for r in rows] == [(1, ""), (1, "matmul_dtype=bfloat16"),
                                                         (2, ""), (2, "matmul_dtype=bfloat16")]
    for r in rows:
        # one executable per lane count of each variant's program, none added while timing
        assert r["chunk_executables"] == 2 and r["compiles_while_timing"] == 0 and r["devices"] == 1 and r["min_s"] <= r["median_s"] <= r["max_s"]
        assert r["env_steps_per_s"] == pytest.approx(50 * r["lanes"] / r["median_s"])
        assert r["fraction_of_per_core_roofline"] > 0
    assert rows[0]["cost_ratio_vs_1"] == pytest.approx(1.0) and rows[1]["cost_ratio_vs_1"] == pytest.approx(1.0)


def test_update_flops_matches_hand_count_of_the_matmuls():
    """XLA's count of one TD3 update (policy delay averaged) vs 2·MACs of its dense layers.

    Hand count per sample, layer sizes o→h1→h2→out: forward = Σ in·out MACs; a backward pass for
    weight gradients costs in·out per layer plus in·out for the input gradient of every layer that
    needs one. Critic-only update: target actor + two target critics forward, then two online critics
    forward + backward (no input gradient at the first layer). Actor step (every ``policy_freq``):
    actor forward, Q1 forward, Q1 backward to its input, actor backward (no first-layer input grad).
    ReLU and Adam add a few element-wise flops per unit/parameter, hence the 10 % allowance above.
    """
    from swim_jax.agents.td3 import TD3, ActivationConfig, TD3Config
    from swim_jax.bench.train import update_flops

    o, a, h, b = 5, 2, 64, 64
    agent = TD3(TD3Config(hidden=(h, h), batch_size=b, activation=ActivationConfig(name="relu")),
                obs_dim=o, action_low=(-1.0,) * a, action_high=(1.0,) * a)
    actor = [o * h, h * h, h * a]
    critic = [(o + a) * h, h * h, h * 1]
    fwd = sum
    critic_only = fwd(actor) + 2 * fwd(critic) + 2 * (fwd(critic) + 2 * fwd(critic) - critic[0])
    actor_step = fwd(actor) + fwd(critic) + fwd(critic) + (2 * fwd(actor) - actor[0])
    hand = 2 * b * (critic_only + actor_step / agent.config.policy_freq)
    assert hand <= update_flops(agent) <= 1.10 * hand


def test_roofline_lists_the_update_products_with_their_hand_counted_flops():
    """swim_jax.bench.roofline: a critic-only update of a 16-16 ReLU TD3 (obs 11, act 3, batch 8)
    has, per twin critic pass, products whose FLOPs sum to the hand count; the actor-step update
    adds the actor's; each product timed standalone gives a positive rate."""
    import jax.numpy as jnp

    from swim_jax.agents.td3 import TD3, TD3Config
    from swim_jax.bench import roofline

    agent = TD3(TD3Config(hidden=(16, 16), batch_size=8), 11, (-1.0,) * 3, (1.0,) * 3, dtype=jnp.float32)
    dots = roofline.update_dots(agent)
    assert len(dots[True]) > len(dots[False]) > 0
    b, o, a, h = 8, 11, 3, 16
    # forward MACs of one critic (o+a -> h -> h -> 1) and of the actor (o -> h -> h -> a)
    critic_fwd = (o + a) * h + h * h + h
    actor_fwd = o * h + h * h + h * a
    # critic-only: target actor fwd, 2 target critics fwd, 2 critics fwd + bwd (weights: 1x, inputs:
    # 1x except the first layer) -> 2·b·MACs
    critic_only = actor_fwd + 2 * critic_fwd + 2 * (critic_fwd + critic_fwd + (critic_fwd - (o + a) * h))
    assert sum(d.flops for d in dots[False]) == 2 * b * critic_only
    times = roofline.time_dots(dots[True], repeats=1, loop=2)
    assert all(t > 0 for t in times.values())


HLO_SNIPPET = """HloModule m

%fused_computation.1 (param_0.1: f32[4,8], param_1.1: f32[8,16]) -> f32[4,16] {
  %param_0.1 = f32[4,8]{1,0} parameter(0)
  %param_1.1 = f32[8,16]{1,0} parameter(1)
  ROOT %dot.9 = f32[4,16]{1,0} dot(%param_0.1, %param_1.1), lhs_contracting_dims={1}, rhs_contracting_dims={0}
}

ENTRY %main.2 (p0: f32[2,4,8], p1: f32[2,8,16], p2: f32[2,4,16], p3: f32[4,8], p4: f32[8,16]) -> f32[4,16] {
  %p0 = f32[2,4,8]{2,1,0} parameter(0)
  %p1 = f32[2,8,16]{2,1,0} parameter(1)
  %p2 = f32[2,4,16]{2,1,0} parameter(2)
  %p3 = f32[4,8]{1,0} parameter(3)
  %p4 = f32[8,16]{1,0} parameter(4)
  %dot.1 = f32[2,4,16]{2,1,0} dot(%p0, %p1), lhs_batch_dims={0}, lhs_contracting_dims={2}, rhs_batch_dims={0}, rhs_contracting_dims={1}
  %dot.2 = f32[2,4,8]{2,1,0} dot(%p2, %p1), lhs_batch_dims={0}, lhs_contracting_dims={2}, rhs_batch_dims={0}, rhs_contracting_dims={2}
  %dot.3 = f32[2,8,16]{2,1,0} dot(%p0, %p2), lhs_batch_dims={0}, lhs_contracting_dims={1}, rhs_batch_dims={0}, rhs_contracting_dims={1}
  ROOT %ynn_fusion.4 = f32[4,16]{1,0} fusion(%p3, %p4), kind=kCustom, calls=%fused_computation.1
}
"""


def test_profile_reads_each_products_layout_and_flops_from_hlo():
    """bench_profile.products on a hand-written module: x@W (NN), g·Wᵀ (NT), xᵀ·g (TN), batched,
    and a fusion that contains a dot (as XLA's YNNPACK fusions do), with FLOPs 2·|out|·K."""
    from swim_jax.bench import profile as bp

    p = bp.products(HLO_SNIPPET)
    assert {n: (q.layout, q.contracted, q.flops) for n, q in p.items() if n != "dot.9"} == {
        "dot.1": ("NN", 8, 2 * 2 * 4 * 16 * 8), "dot.2": ("NT", 16, 2 * 2 * 4 * 8 * 16),
        "dot.3": ("TN", 4, 2 * 2 * 8 * 16 * 4), "ynn_fusion.4": ("NN", 8, 2 * 4 * 16 * 8)}
    assert {"p0", "dot.1", "ynn_fusion.4", "dot.9"} <= bp.instruction_names(HLO_SNIPPET)


def test_interleave_rotates_each_round_and_drops_the_warmup_calls():
    """swim_jax.bench.timing.interleave: warm-up calls first (each candidate back to back, round
    indices -warmup … -1, not returned), then rounds × candidates calls, the order rotated by one
    place per round; each candidate's measurements in round order, after_round seeing each round."""
    from swim_jax.bench import timing

    calls, rounds_seen = [], []

    def candidate(name, base):
        def run(r):
            calls.append((name, r))
            return base + r
        return run

    out = timing.interleave({"a": candidate("a", 100), "b": candidate("b", 200), "c": candidate("c", 300)}, rounds=4,
                            warmup=2, after_round=lambda r, measured: rounds_seen.append((r, list(measured.items()))))
    assert calls[:6] == [("a", -2), ("a", -1), ("b", -2), ("b", -1), ("c", -2), ("c", -1)]
    assert [n for n, _ in calls[6:]] == list("abc" "bca" "cab" "abc") and len(calls) == 6 + 4 * 3
    assert [r for _, r in calls[6:]] == [0] * 3 + [1] * 3 + [2] * 3 + [3] * 3
    assert list(out) == ["a", "b", "c"] and out == {"a": [100, 101, 102, 103], "b": [200, 201, 202, 203],
                                                    "c": [300, 301, 302, 303]}
    assert rounds_seen[1] == (1, [("b", 201), ("c", 301), ("a", 101)]) and len(rounds_seen) == 4
    # without rotation every round runs the mapping's order; no warm-up by default
    calls.clear()
    timing.interleave({"a": candidate("a", 0), "b": candidate("b", 0)}, rounds=3, rotate=False)
    assert calls == [("a", 0), ("b", 0), ("a", 1), ("b", 1), ("a", 2), ("b", 2)]
    assert timing.order(["x", "y", "z"], 5) == ["z", "x", "y"] and timing.order(["x", "y"], 5, rotate=False) == ["x", "y"]


def test_timed_reads_the_clock_around_the_calls_and_waits_on_the_last_result():
    """timing.timed with a fake clock that each call of the work advances by 0.5 s: seconds per call
    is exactly 0.5 for any calls_per_sample; wait gets the last call's result once per sample; work
    outside the timed function (a round's set-up) is not counted."""
    from swim_jax.bench import timing

    now, waited = [10.0], []

    def work(r):
        now[0] += 0.5
        return ("result", r)

    sample = timing.timed(work, calls_per_sample=4, wait=waited.append, clock=lambda: now[0])
    assert sample(7) == 0.5 and now[0] == 12.0 and waited == [("result", 7)]
    set_up_then_timed = lambda r: (now.__setitem__(0, now[0] + 100.0), sample(r))[1]
    assert timing.interleave({"w": set_up_then_timed}, rounds=2) == {"w": [0.5, 0.5]}
    assert timing.timed(work, wait=None, clock=lambda: now[0])(0) == 0.5  # nothing to wait for


def test_summarise_and_ratios_compare_candidates_round_by_round():
    """timing.summarise: median, min, max, mean, population std; timing.ratios: each round's
    measurement over the reference's of the same round, summarised (not the ratio of medians)."""
    from swim_jax.bench import timing

    t = timing.summarise([3.0, 1.0, 2.0, 10.0])
    assert (t.median, t.min, t.max, t.mean) == (2.5, 1.0, 10.0, 4.0) and t.std == pytest.approx(math.sqrt(12.5))
    assert t.samples == (3.0, 1.0, 2.0, 10.0) and t.as_dict(10) == {"median": 25.0, "min": 10.0, "max": 100.0,
                                                                   "mean": 40.0, "std": pytest.approx(10 * math.sqrt(12.5))}
    assert timing.summarise([4.0]).std == 0.0
    rel = timing.ratios({"a": [1.0, 4.0, 3.0], "ref": [2.0, 2.0, 6.0]}, "ref")
    assert rel["a"].samples == (0.5, 2.0, 0.5) and rel["a"].median == 0.5  # the ratio of medians would be 1.5
    assert rel["ref"].samples == (1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="2 samples"):
        timing.ratios({"a": [1.0, 2.0], "ref": [1.0, 2.0, 3.0]}, "ref")


def test_time_interleaved_is_interleave_of_timed_with_untimed_warmups(monkeypatch):
    """time_interleaved: max(warmup, 1) untimed calls of each candidate alone, then rotating rounds
    of calls_per_sample calls; on a fake wall clock that a's calls advance by 1 s and b's by 3 s, the
    medians are exactly 1 and 3 seconds per call."""
    import jax.numpy as jnp

    from swim_jax.bench import timing

    now, calls = [0.0], []
    monkeypatch.setitem(timing.CLOCKS, "wall", lambda: now[0])

    def candidate(name, seconds):
        def run():
            calls.append(name)
            now[0] += seconds
            return jnp.zeros(())
        return run

    out = timing.time_interleaved({"a": candidate("a", 1.0), "b": candidate("b", 3.0)}, repeats=2,
                                  calls_per_sample=3, warmup=2)
    assert calls == ["a"] * 2 + ["b"] * 2 + ["a"] * 3 + ["b"] * 3 + ["b"] * 3 + ["a"] * 3
    assert out["a"].samples == (1.0, 1.0) and out["b"].median == 3.0
    calls.clear()
    timing.time_interleaved({"a": candidate("a", 1.0)}, repeats=1, warmup=0)
    assert calls == ["a", "a"]  # at least one warm-up call
    with pytest.raises(ValueError, match="valid: wall, cpu"):
        timing.time_interleaved({"a": candidate("a", 1.0)}, clock="gpu")


def test_process_benchmarks_interleave_their_runs_and_report_rates(monkeypatch):
    """bench processes and bench study on the harness, each run replaced by a known rate: placements
    (cells at once) in a fixed order every round, one folder per round, medians and ratios as in
    their JSON."""
    from swim_jax.bench import processes, study

    ran = []

    def train_rate(args, out_dir, placement, cores):
        ran.append(os.path.basename(out_dir))
        r = int(out_dir.rsplit("-", 1)[1])
        return {"one-process": 100.0, "host-devices": 110.0, "processes": 120.0}[placement] + 10 * r

    monkeypatch.setattr(processes, "train_rate", train_rate)
    monkeypatch.setattr(processes.os, "sched_getaffinity", lambda _pid: {0, 1})
    res = processes.measure("cheetah_relu", 4, 10, 1, 3, log=lambda _: None)
    assert ran == [f"{p}-{r}" for r in range(3) for p in processes.PLACEMENTS]
    assert res["env_steps_per_s"] == {"one-process": [100.0, 110.0, 120.0], "host-devices": [110.0, 120.0, 130.0],
                                      "processes": [120.0, 130.0, 140.0]}
    assert res["median"] == {"one-process": 110.0, "host-devices": 120.0, "processes": 130.0}
    assert res["ratio_vs_one_process"]["processes"] == pytest.approx(130 / 110)

    monkeypatch.setattr(study, "study_rate", lambda path, out_dir, p: (
        ran.append(os.path.basename(out_dir)), {"wall_s": 60.0 / p, "env_steps_per_s": 200.0 * p + int(out_dir[-1])})[1])
    ran.clear()
    res = study.measure(["walker_relu", "walker_swim"], 2, [1, 2], 10, 1, 2, [], log=lambda _: None)
    assert ran == ["p1-0", "p2-0", "p1-1", "p2-1"]
    assert res["env_steps_per_s"] == {"1": [200.0, 201.0], "2": [400.0, 401.0]} and res["wall_s"]["2"] == [30.0, 30.0]
    assert res["median"] == {"1": 200.5, "2": 400.5} and res["ratio_vs_parallel_1"]["2"] == pytest.approx(400.5 / 200.5)


def test_process_benchmark_commands_write_a_result_or_one_error_line(monkeypatch, tmp_path, capsys):
    """bench processes / bench study's command lines: a result is printed as its table and written as
    JSON (exit 0); a bad option is one line, exit 2, a failed run one line, exit 1, nothing written."""
    from swim_jax.bench import processes, study

    res = {"config": "cheetah_relu", "overrides": [], "seeds": 4, "cores": 2, "chunks": 2, "chunk_steps": 10, "rounds": 2,
           "machine": {"cpu": "test"}, "env_steps_per_s": {p: [100.0, 120.0] for p in processes.PLACEMENTS},
           "median": {p: 110.0 for p in processes.PLACEMENTS}, "ratio_vs_one_process": {p: 1.0 for p in processes.PLACEMENTS}}
    monkeypatch.setattr(processes, "measure", lambda *a, **k: res)
    out = tmp_path / "bench"
    assert processes.main(["--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert processes.markdown(res) in printed and len(list(out.glob("processes-*.json"))) == 1
    assert json.loads(next(out.glob("processes-*.json")).read_text()) == res

    def fails(*a, **k):
        raise RuntimeError("cell walker_relu: training exited with status 1")

    monkeypatch.setattr(study, "measure", fails)
    for command, args, status, message in [
            (processes, ["--seeds", "0"], 2, "--seeds, --chunk-steps, --chunks and --rounds must be >= 1"),
            (study, ["--parallel", "3", "--configs", "a,b"], 2, "--parallel 3 needs at least that many --configs, got 2"),
            (study, ["--parallel", "1", "--configs", "a"], 1, "training exited with status 1")]:
        assert command.main([*args, "--out", str(tmp_path / "none")]) == status
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("error: ") and message in err[0], err
    assert not (tmp_path / "none").exists()


def test_interleaved_chunk_ratios_advance_each_state_and_compare_within_rounds():
    """swim_jax.bench.train.interleaved_chunk_ratios (on the harness): every executable runs once per round with its own
    state and the round's first step (steps · round), states are advanced in place, and the
    reference's ratio to itself is exactly 1."""
    import jax.numpy as jnp

    from swim_jax.bench.train import interleaved_chunk_ratios

    calls = []
    def chunk(tag):
        def run(state, first_step, _):
            calls.append((tag, int(first_step)))
            return (state + 1,)
        return run

    states = {"a": jnp.asarray(0), "b": jnp.asarray(10)}
    out = interleaved_chunk_ratios({"a": chunk("a"), "b": chunk("b")}, states, rounds=3, steps=20, reference="a")
    assert calls == [("a", 20), ("b", 20), ("a", 40), ("b", 40), ("a", 60), ("b", 60)]
    assert int(states["a"]) == 3 and int(states["b"]) == 13
    assert out["a"][1] == 1.0 and out["a"][0] > 0 and out["b"][1] > 0


def test_profile_self_times_subtract_nested_operations_only():
    """A while (0–100 µs) holding a dot (10–40) and a fusion (50–70) whose Python frame (55–60) is
    not an operation; another thread's dot (0–25): self times 50, 30+25, 20; calls counted."""
    from swim_jax.bench import profile as bp

    ev = lambda name, ts, dur, tid=1: {"ph": "X", "name": name, "ts": ts, "dur": dur, "pid": 1, "tid": tid}
    events = [ev("while.1", 0, 100), ev("dot.2", 10, 30), ev("fusion.3", 50, 20), ev("$x.py:1 f", 55, 5),
              ev("dot.2", 0, 25, tid=2), {"ph": "M", "name": "thread_name"}]
    total, calls = bp.self_times(events, {"while.1", "dot.2", "fusion.3"})
    assert dict(total) == {"while.1": 50, "dot.2": 55, "fusion.3": 20}
    assert dict(calls) == {"while.1": 1, "dot.2": 2, "fusion.3": 1}
    assert bp.kind("multiply_add_fusion.38") == "multiply_add_fusion" and bp.kind("dot") == "dot"


def test_profile_of_a_compiled_loop_times_its_products():
    """A jitted loop of 8 iterations with three 64×32×48 products: the profile finds the three,
    8 calls each, their FLOPs summing to 3 · 2·64·32·48 per iteration, with positive times."""
    import jax
    import jax.numpy as jnp
    from jax import lax

    from swim_jax.bench import profile as bp

    def f(x, w, g):
        def body(c, _):
            xc = x + c  # not loop-invariant: the products stay in the loop
            y = lax.dot_general(xc, w, (((1,), (0,)), ((), ())))
            dx = lax.dot_general(g + c, w, (((1,), (1,)), ((), ())))
            dw = lax.dot_general(xc, g, (((0,), (0,)), ((), ())))
            return c + 1e-6 * (y.sum() + dx.sum() + dw.sum()), None
        return lax.scan(body, jnp.float32(0), None, length=8)[0]

    args = (jnp.ones((64, 32)), jnp.ones((32, 48)), jnp.ones((64, 48)))
    compiled = jax.jit(f).lower(*args).compile()
    text = compiled.as_text()
    jax.block_until_ready(compiled(*args))
    res = bp.summarise(bp.profile_call(lambda: jax.block_until_ready(compiled(*args)), text), text, steps=8)
    assert len(res["products"]) == 3 and all(r["calls_per_step"] == 1 and r["us_per_call"] > 0 for r in res["products"])
    assert res["products_gflop_per_step"] * 1e9 == pytest.approx(3 * 2 * 64 * 32 * 48)
    assert 0 < res["products_ms_per_step"] <= res["busy_ms_per_step"]


def _sizes(d) -> tuple[int, int, int]:
    """(M, N, K) of a roofline.Dot: the sizes of its left and right operands' free (non-contracted,
    non-batch) axes and of the contracted ones."""
    (lc, rc), (lb, rb) = d.dimension_numbers
    m = math.prod(x for i, x in enumerate(d.lhs) if i not in lc and i not in lb)
    n = math.prod(x for i, x in enumerate(d.rhs) if i not in rc and i not in rb)
    return m, n, math.prod(d.lhs[i] for i in lc)


@pytest.mark.slow
def test_profile_benchmark_counts_the_training_steps_products(tmp_path):
    """``bench profile`` on a 2-lane 16-unit Hopper program (native physics, every step learning):
    the products it finds add up, per step, to at most the products of acting (actor on one row per
    lane) and of the TD3 update averaged over the policy delay, as the update's jaxpr lists them
    (swim_jax.bench.roofline), and to at least the matrix-matrix products (M, N, K > 1) of the critic
    update, which every step runs and needs in full (XLA may run a matrix-vector or outer product,
    e.g. through a critic's 1-unit head, as a multiply and a reduction, and drops the actor step's
    unused second-critic products)."""
    from swim_jax.bench import profile as bp
    from swim_jax import config as cfgmod
    from swim_jax.run import programs
    from swim_jax.bench import roofline

    tiny = ["agent.hidden=[16]", "agent.batch_size=16", "env.backend=mujoco"]
    assert bp.main(["--config", "hopper_relu", "--lanes", "2", "--steps", "20", *[a for t in tiny for a in ("--set", t)],
                    "--out", str(tmp_path)]) == 0
    (path,) = tmp_path.glob("profile-*.json")
    res = json.loads(path.read_text())
    agent = programs.build(cfgmod.resolve("hopper_relu", tiny))[2]
    dots = roofline.update_dots(agent)
    d = agent.config.policy_freq

    def per_step(keep):
        return ((d - 1) * sum(x.flops for x in dots[False] if keep(x)) + sum(x.flops for x in dots[True] if keep(x))) / d

    acting = 2 * (agent.obs_dim * 16 + 16 * agent.action_dim)
    found = res["products_gflop_per_step"] * 1e9
    critic_update = sum(x.flops for x in dots[False] if min(_sizes(x)) > 1)
    assert 2 * critic_update <= found <= 2 * (per_step(lambda x: True) + acting)
    assert res["lanes"] == 2 and res["kinds"] and res["timed_ms_per_step"] > 0


def test_startup_bench_times_the_lines_of_a_real_process_and_stops_at_the_step():
    """bench startup's clock on a real process printing a line, a progress line after a pause, and
    more steps: the times from its start, the longest silence, and the process stopped at the step."""
    from swim_jax.bench.startup import timed_lines

    code = ("import time, sys\nprint('run dir: x', flush=True)\ntime.sleep(0.6)\n"
            "print('step     5000/10000 | ...', flush=True)\nprint('step    10000/10000 | ...', flush=True)\n"
            "time.sleep(30)\nprint('never', flush=True)")
    r = timed_lines([sys.executable, "-c", code], dict(os.environ), until_step=10000, timeout=20)
    assert r["first_line_s"] < r["first_progress_line_s"] <= r["until_step_s"] < 10
    assert 0.5 < r["longest_silence_s"] < 10 and r["first_progress_line_s"] - r["first_line_s"] > 0.5
    assert r["lines"][-1].lstrip().split("  ", 1)[1].startswith("step    10000/")
    assert timed_lines([sys.executable, "-c", code], dict(os.environ), until_step=20000, timeout=2)["until_step_s"] is None


@pytest.mark.parametrize("bad", [["--warm-runs", "0"], ["--until-step", "0"], ["--backends", "gpu"]])
def test_startup_bench_bad_input_is_one_line_exit_2_and_runs_nothing(bad, tmp_path, capsys):
    from swim_jax.bench import startup

    with pytest.raises(SystemExit) as e:
        startup.main([*bad, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert e.value.code == 2 and len(err) == 1 and bad[0] in err[0], err
    assert not (tmp_path / "out").exists()


def test_checkpoint_bench_writes_both_kinds_and_restores(tmp_path, capsys):
    """bench checkpoint on a tiny buffer: both kinds timed per round, disk and restore times in the JSON."""
    from swim_jax import bench

    assert bench.main(["checkpoint", "--config", "hopper_relu", "--seeds", "2", "--replay-size", "2000",
                       "--fill", "2000", "--chunk", "500", "--rounds", "2", "--keep", "2", "--out", str(tmp_path)]) == 0
    res = json.load(open(glob.glob(str(tmp_path / "checkpoint-*.json"))[0]))
    assert [len(res["seconds"][k]) for k in ("whole", "appended")] == [2, 2]
    assert [len(res["restore_seconds"][k]) for k in ("whole", "appended")] == [2, 2]  # restores timed per round too
    assert res["restore_s"]["whole"] == __import__("statistics").median(res["restore_seconds"]["whole"])
    assert res["disk_bytes"]["one_whole_state"] > 0 and res["lanes"] == 2
    assert "| appended |" in capsys.readouterr().out
