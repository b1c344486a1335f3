"""``python -m swim_jax.evaluate``: trained policies in Gymnasium itself, the table, --json, --export,
the README's standalone NumPy lines, and bad input (one line, exit 2, nothing written).

The runs are tests/conftest.py's ``policy_runs`` (trained once per session); episodes are few.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest
import scipy.stats

from swim_jax.analysis import evaluate
from swim_jax.policy import policy as pol
from swim_jax.policy import run_folder

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_main(capsys, *argv):
    rc = evaluate.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def direct_gymnasium_episodes(policy, env_id: str, seeds) -> tuple[list[float], list[int]]:
    """Episode returns and lengths of ``policy`` in Gymnasium from ``reset(seed=s)``, written out here."""
    import gymnasium as gym

    env = gym.make(env_id)
    returns, lengths = [], []
    for s in seeds:
        obs, _ = env.reset(seed=s)
        total, t = 0.0, 0
        while True:
            obs, r, term, trunc, _ = env.step(policy(obs))
            total, t = total + r, t + 1
            if term or trunc:
                break
        returns.append(total)
        lengths.append(t)
    env.close()
    return returns, lengths


def direct_gymnasium_returns(policy, env_id: str, seeds) -> list[float]:
    return direct_gymnasium_episodes(policy, env_id, seeds)[0]


def test_table_and_json_of_a_short_run(policy_runs, capsys, tmp_path):
    res = policy_runs["f64"]
    table = tmp_path / "table.json"
    rc, out, err = run_main(capsys, res.run_dir, "--episodes", 4, "--env-seed", 10, "--json", table)
    assert rc == 0, err
    lines = out.splitlines()
    assert lines[0].startswith("Gymnasium ") and "4 episodes per seed, reset seeds 10..13" in lines[0]
    assert lines[1] == evaluate.HEADER
    rows = [l for l in lines if l.startswith(f"| {res.run_dir} |")]
    assert len(rows) == 2 and all("| Hopper-v5 | swim+learnable |" in r and "| 2000 |" in r for r in rows)
    assert lines[-1] == f"evaluate: wrote {table}"
    data = json.loads(table.read_text())
    assert data["episodes"] == 4 and data["env_seed"] == 10 and len(data["rows"]) == 2
    episodes = np.load(os.path.join(res.run_dir, "evaluations_episodes.npy"))
    for pos, row in enumerate(data["rows"]):
        assert row["seed"] == pos and row["step"] == 2000 and row["policy"]["source"] == "final_policy.npz"
        # ours: the run's own evaluation at the final step (its eval_episodes episodes)
        np.testing.assert_array_equal(row["ours"]["episodes"], episodes[-1, pos])
        assert row["ours"]["mean"] == pytest.approx(episodes[-1, pos].mean(), rel=1e-15)
        np.testing.assert_allclose(row["ours"]["mean"], res.evaluations[-1, pos].mean(), rtol=1e-12)
        # Gymnasium: the policy's returns from reset seeds 10..13, and a t-based 95 % CI
        g = row["gymnasium"]
        policy = run_folder.load_policy(res.run_dir, seed=pos)
        returns, lengths = direct_gymnasium_episodes(policy, "Hopper-v5", range(10, 14))
        np.testing.assert_array_equal(g["returns"], returns)
        assert g["lengths"] == lengths and g["time_limit"] == 1000
        assert g["at_time_limit"] == sum(n == 1000 for n in lengths)
        assert f"| {np.mean(lengths):.0f} ({g['at_time_limit']}/4) |" in rows[pos]
        x = np.asarray(g["returns"])
        half = scipy.stats.t.ppf(0.975, x.size - 1) * x.std(ddof=1) / np.sqrt(x.size)
        np.testing.assert_allclose(g["ci95"], [x.mean() - half, x.mean() + half], rtol=1e-9)
        assert row["ours_in_ci"] == bool(g["ci95"][0] <= row["ours"]["mean"] <= g["ci95"][1])
        welch = scipy.stats.ttest_ind(row["ours"]["episodes"], x, equal_var=False)
        assert row["welch_p"] == pytest.approx(welch.pvalue, rel=1e-6)
        np.testing.assert_allclose(row["difference_ci95"], welch.confidence_interval(0.95), rtol=1e-8)
        assert evaluate.differs(row) == (not row["difference_ci95"][0] <= 0 <= row["difference_ci95"][1])
        assert f"| {row['seed']} | 2000 | {row['ours']['mean']:.2f} (3) | {g['mean']:.2f} [" in rows[pos]


def test_a_checkpoint_step_and_a_sweeps_points(policy_runs, capsys):
    res, sweep = policy_runs["f64"], policy_runs["sweep"]
    rc, out, err = run_main(capsys, res.run_dir, sweep.run_dir, "--seed", 0, "--step", 1000, "--episodes", 2)
    assert rc == 0, err
    rows = [l for l in out.splitlines() if l.startswith("| /")]
    assert len(rows) == 3
    ours = np.load(os.path.join(res.run_dir, "evaluations_episodes.npy"))[1, 0].mean()
    assert "| swim+learnable | 0 | 1000 |" in rows[0] and f"| {ours:.2f} (3) |" in rows[0]
    assert "points/beta=0.5 | Hopper-v5 | swish[beta=0.5] | 0 | 1000 |" in rows[1]
    assert "points/beta=2 | Hopper-v5 | swish[beta=2] | 0 | 1000 |" in rows[2]


def test_our_evaluation_lies_in_gymnasiums_ci_for_a_float64_run(policy_runs, capsys):
    """The float64 run on MuJoCo C: our evaluation's episodes and Gymnasium's come from the same
    distribution of reset states, so over 30 Gymnasium episodes a Welch test does not reject."""
    rc, out, err = run_main(capsys, policy_runs["f64"].run_dir, "--episodes", 30, "--json", os.devnull, "--force")
    assert rc == 0, err
    # the rows' Welch p (last column) above 0.001 for every seed
    ps = [float(re.sub(r"[<>]", "", l.rsplit("|", 2)[-2].strip())) for l in out.splitlines() if l.startswith("| /")]
    assert len(ps) == 2 and min(ps) > 1e-3, out


def test_export_and_the_readme_numpy_lines(policy_runs, capsys, tmp_path, no_jax_env):
    """--export writes one seed's policy; the README's standalone NumPy lines, run in a process
    without JAX, give load_policy's actions (a learnable Swim float64 run and a bfloat16 Swish point)."""
    readme = open(os.path.join(REPO, "README.md")).read()
    blocks = [b for b in re.findall(r"```python\n(.*?)```", readme, re.S) if 'np.load("policy.npz")' in b]
    assert len(blocks) == 1
    snippet = blocks[0]
    assert "swim_jax" not in snippet and len(snippet.strip().splitlines()) <= 30
    obs = np.random.default_rng(0).normal(size=(20, 11)) * 2
    point = run_folder.run_folders(policy_runs["sweep"].run_dir)[1]
    for i, (run, seed) in enumerate(((policy_runs["f64"].run_dir, 1), (point, 0))):
        work = tmp_path / f"w{i}"
        work.mkdir()
        rc, out, err = run_main(capsys, run, "--seed", seed, "--export", work / "policy.npz")
        assert rc == 0 and err == "" and out.startswith(f"evaluate: wrote {work / 'policy.npz'}: Hopper-v5")
        np.save(work / "obs.npy", obs)
        code = snippet + "\nnp.save('actions.npy', policy(np.load('obs.npy')))\n"
        p = subprocess.run([sys.executable, "-c", code], cwd=work, env=no_jax_env, capture_output=True, text=True,
                           timeout=120)
        assert p.returncode == 0, p.stderr[-2000:]
        ref = run_folder.load_policy(run, seed=seed)
        got = np.load(work / "actions.npy")
        assert got.dtype == ref.dtype
        np.testing.assert_allclose(got, ref(obs), rtol=0, atol=1e-12 if ref.dtype == np.float64 else 2e-6)
        np.testing.assert_array_equal(pol.load_exported(str(work / "policy.npz"))(obs), ref(obs))
        assert json.loads(str(np.load(work / "policy.npz")["header"]))["source"]["seed"] == seed


def test_evaluate_runs_without_jax(policy_runs, no_jax_env, tmp_path):
    p = subprocess.run([sys.executable, "-m", "swim_jax.evaluate", policy_runs["f64"].run_dir, "--seed", "1",
                        "--episodes", "2", "--json", str(tmp_path / "t.json")],
                       env=no_jax_env, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    assert json.loads((tmp_path / "t.json").read_text())["rows"][0]["seed"] == 1


@pytest.fixture(scope="module")
def unfinished(policy_runs, tmp_path_factory):
    """A copy of the float64 run without final_policy.npz (as while it trains)."""
    path = tmp_path_factory.mktemp("unfinished") / "run"
    shutil.copytree(policy_runs["f64"].run_dir, path)
    os.remove(path / "final_policy.npz")
    return str(path)


BAD = [
    ("missing run", lambda r, u, t: [t / "nope"], r"nope: no such run folder"),
    ("not a run", lambda r, u, t: [t], r": no config.yaml \(not a run folder of python -m swim_jax.train\)"),
    ("seed out of range", lambda r, u, t: [r, "--seed", "5"], r"seed 5 is not in .*: its seeds are 0..1"),
    ("unknown step", lambda r, u, t: [r, "--step", "1234"],
     r"no policy at step 1234; valid steps: checkpoints at 1000, 2000; final_policy.npz at 2000"),
    ("no final policy", lambda r, u, t: [u], r"run: no final_policy.npz \(the run has not finished\); policies there: "
                                             r"checkpoints at 1000, 2000"),
    ("bad seed", lambda r, u, t: [r, "--seed", "first"], r"--seed must be a seed id \(an integer\) or all, got 'first' \(see --help\)"),
    ("one episode", lambda r, u, t: [r, "--episodes", "1"], r"--episodes must be >= 2"),
    ("export several", lambda r, u, t: [r, "--export", t / "p.npz"], r"--export writes one policy; 2 match .* give one run folder and --seed N"),
    ("export suffix", lambda r, u, t: [r, "--seed", "0", "--export", t / "p.pkl"], r"--export must end in \.npz"),
    ("json exists", lambda r, u, t: [r, "--json", t / "exists.json"], r"--json .*exists.json exists; refusing to overwrite \(use --force\)"),
    ("json folder", lambda r, u, t: [r, "--json", t / "no" / "t.json"], r"--json .*: folder .* does not exist"),
]


@pytest.mark.parametrize("make_args,message", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_input_is_one_line_exit_2_nothing_written(make_args, message, policy_runs, unfinished, tmp_path, capsys):
    (tmp_path / "exists.json").write_text("{}")
    before = sorted(os.listdir(tmp_path))
    args = [str(a) for a in make_args(policy_runs["f64"].run_dir, unfinished, tmp_path)]
    if "--json" not in args and "--export" not in args:
        args += ["--json", str(tmp_path / "t.json")]
    try:
        rc = evaluate.main(args)
    except SystemExit as e:  # the argument parser's errors
        rc = e.code
    out, err = capsys.readouterr()
    assert rc == 2 and out == ""
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert re.search(message, err), err
    assert err.startswith(("evaluate: error: ", "python -m swim_jax.evaluate: error: "))
    assert sorted(os.listdir(tmp_path)) == before
    assert (tmp_path / "exists.json").read_text() == "{}"



def test_ours_episodes_reruns_our_evaluation_program(policy_runs, capsys):
    """--ours-episodes N: our side is N episodes of the run's own evaluation program on its final
    policies: the recorded final evaluation's episodes first (the same reset keys, float64, MuJoCo
    C), then more draws; in the table N per seed."""
    from swim_jax.run.our_evaluation import our_episodes

    run = policy_runs["f64"]
    recorded = np.load(os.path.join(run.run_dir, "evaluations_episodes.npy"))[-1]  # [seeds, episodes]
    n = run.cfg.eval_episodes
    again = our_episodes(run.run_dir, n)
    assert again.shape == recorded.shape == (run.cfg.seeds, n)
    np.testing.assert_allclose(again, recorded, rtol=1e-12, atol=1e-9)
    more = our_episodes(run.run_dir, n + 3)
    assert more.shape == (run.cfg.seeds, n + 3) and np.all(np.isfinite(more))
    # split(key, N)[e] does not depend on N (jax_threefry_partitionable): the recorded ones, extended
    np.testing.assert_allclose(more[:, :n], recorded, rtol=1e-12, atol=1e-9)
    assert not np.allclose(more[:, n:], more[:, :3])

    rc = evaluate.main([run.run_dir, "--episodes", "3", "--ours-episodes", str(n + 3), "--json", os.devnull,
                        "--force"], our_episodes=our_episodes)
    out, err = capsys.readouterr()
    assert rc == 0, err
    rows = [line for line in out.splitlines() if line.startswith("| /")]
    assert len(rows) == 2 and all(f"({n + 3}) |" in r for r in rows)
    assert f"{more[0].mean():.2f} ({n + 3})" in rows[0] and f"{more[1].mean():.2f} ({n + 3})" in rows[1]


@pytest.mark.parametrize("extra,message", [
    (["--ours-episodes", "1"], "--ours-episodes must be >= 2"),
    (["--ours-episodes", "5", "--step", "1000"], "--ours-episodes evaluates the final policies; drop --step and --export"),
])
def test_ours_episodes_bad_input_is_one_line_exit_2(extra, message, policy_runs, capsys):
    with pytest.raises(SystemExit) as e:
        evaluate.main([policy_runs["f64"].run_dir, *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert e.value.code == 2 and len(err) == 1 and message in err[0], err


def test_ours_episodes_refuses_sweep_points_and_needs_the_jax_side(policy_runs, capsys, tmp_path):
    from swim_jax.run.our_evaluation import our_episodes

    point = run_folder.run_folders(policy_runs["sweep"].run_dir)[0]
    for argv, kwargs, message in (
            ([point, "--ours-episodes", "4"], {"our_episodes": our_episodes}, "evaluates plain runs only"),
            ([policy_runs["f64"].run_dir, "--ours-episodes", "4"], {}, "needs the JAX side")):
        rc = evaluate.main([*argv, "--json", str(tmp_path / "t.json")], **kwargs)
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1 and message in err[0], err
        assert not (tmp_path / "t.json").exists()


def test_in_env_runs_the_policy_in_another_version(policy_runs, capsys, tmp_path):
    """--in-env Hopper-v4: a Hopper-v5 policy's episodes in Gymnasium's Hopper-v4 (same observation
    size and action bounds), equal to the episodes written out here; our side n/a; both envs named."""
    run = policy_runs["f64"].run_dir
    table = tmp_path / "t.json"
    rc, out, err = run_main(capsys, run, "--seed", 1, "--episodes", 3, "--env-seed", 5, "--in-env", "Hopper-v4",
                            "--json", table)
    assert rc == 0, err
    assert out.splitlines()[0].endswith("deterministic actions, in Hopper-v4")
    rows = [line for line in out.splitlines() if line.startswith("| /")]
    assert len(rows) == 1 and "| Hopper-v4 (trained in Hopper-v5) | swim+learnable | 1 | 2000 | n/a |" in rows[0]
    data = json.loads(table.read_text())
    row = data["rows"][0]
    assert data["in_env"] == "Hopper-v4" and row["env_id"] == "Hopper-v4" and row["trained_env_id"] == "Hopper-v5"
    assert row["ours"] is None and row["difference_ci95"] is None and row["welch_p"] is None
    policy = run_folder.load_policy(run, seed=1)
    v4 = direct_gymnasium_returns(policy, "Hopper-v4", range(5, 8))
    np.testing.assert_array_equal(row["gymnasium"]["returns"], v4)
    # the versions' models differ, so the same policy and reset seeds give other returns in v5
    assert not np.array_equal(v4, direct_gymnasium_returns(policy, "Hopper-v5", range(5, 8)))


@pytest.mark.parametrize("extra,message", [
    (["--in-env", "HalfCheetah-v5"], r"--in-env HalfCheetah-v5: observations of size 17, 6 actions in \[-1, 1\]; the "
                                     r"policy of .* \(Hopper-v5\) takes 11 and acts in 3 dims"),
    (["--in-env", "NoSuchEnv-v0"], r"env 'NoSuchEnv-v0': Gymnasium cannot make it"),
])
def test_in_env_bad_env_is_one_line_exit_2(extra, message, policy_runs, capsys, tmp_path):
    rc = evaluate.main([policy_runs["f64"].run_dir, *extra, "--json", str(tmp_path / "t.json")])
    out, err = capsys.readouterr()
    assert rc == 2 and out == "" and err.count("\n") == 1 and re.search(message, err), err
    assert not (tmp_path / "t.json").exists()


def test_in_env_refuses_our_side_and_export(policy_runs, capsys):
    for extra in (["--ours-episodes", "4"], ["--seed", "0", "--export", "p.npz"]):
        with pytest.raises(SystemExit) as e:
            evaluate.main([policy_runs["f64"].run_dir, "--in-env", "Hopper-v4", *extra])
        err = capsys.readouterr().err.strip().splitlines()
        assert e.value.code == 2 and len(err) == 1 and "drop --ours-episodes and --export" in err[0], err
