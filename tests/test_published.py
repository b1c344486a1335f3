"""``python -m swim_jax.published``: the published curves' extract against the figures Tianshou's README
publishes, Welch from summary statistics against SciPy, and the command on curated runs."""

import json
import math
import os

import numpy as np
import pytest
from scipy import stats as sps

from swim_jax.analysis import published, published_curves, stats

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WALKER_RELU = os.path.join(REPO, "runs", "curated", "study-table2", "walker_relu")

# Tianshou's README (examples/mujoco/README.md at 63f0e9a): max over the first 1M steps, mean ± std
README_1M = {("Walker2d-v3", "TD3"): (3982.4, 274.5), ("Hopper-v3", "TD3"): (3472.2, 116.8),
             ("HalfCheetah-v3", "TD3"): (10201.2, 772.8), ("Swimmer-v3", "TD3"): (104.2, 34.2),
             ("Walker2d-v3", "SAC"): (5007.0, 251.5), ("Hopper-v3", "SAC"): (3542.2, 51.5),
             ("HalfCheetah-v3", "SAC"): (12138.8, 1049.3), ("Swimmer-v3", "SAC"): (44.4, 0.5)}


@pytest.mark.parametrize("env,agent", sorted(README_1M))
def test_extract_reproduces_the_readme_1m_table(env, agent):
    points = json.load(open(published_curves.DATA))["envs"][env][agent]
    best = max((p for p in points if p[0] <= 1_000_000), key=lambda p: p[1])
    assert (round(best[1], 1), round(best[2], 1)) == README_1M[env, agent]


def test_anchor_at_300k_and_its_sample_std():
    """300k env steps of ours are Tianshou's env_step 275k: its trainer counts from 0 after 25k random
    steps (10k for SAC), so both sides have taken the same env steps and updates there."""
    a = published_curves.anchor("Walker2d-v5", "td3", 300_000)
    raw = {p[0]: p[1:] for p in json.load(open(published_curves.DATA))["envs"]["Walker2d-v3"]["TD3"]}
    assert (a.env, a.n, a.step, a.mean) == ("Walker2d-v3", 10, 300_000, raw[275_000][0])
    assert a.sd == pytest.approx(raw[275_000][1] * math.sqrt(10 / 9), rel=1e-12)
    assert a.window_mean == pytest.approx(np.mean([raw[s][0] for s in range(225_000, 325_001, 5000)]), rel=1e-12)
    sac = {p[0]: p[1] for p in json.load(open(published_curves.DATA))["envs"]["Hopper-v3"]["SAC"]}
    assert published_curves.anchor("Hopper-v5", "sac", 300_000).mean == sac[290_000]
    assert published_curves.curve_points("Walker2d-v5", "td3")[0] == [25_000, *raw[0]]


@pytest.mark.parametrize("env,algorithm,step,fragment", [
    ("Ant-v5", "td3", 300_000, "no published curve for Ant-v5"),
    ("Walker2d-v5", "ppo2", 300_000, "no published ppo2 curve"),
    ("Walker2d-v5", "td3", 300_001, "no point at step 300,001"),
    ("Walker2d-v5", "td3", 20_000, r"every 5,000 env steps from 25,000 to 1,275,000 \(its 25,000 random"),
])
def test_anchor_refuses_what_is_not_published(env, algorithm, step, fragment):
    with pytest.raises(published_curves.PublishedError, match=fragment):
        published_curves.anchor(env, algorithm, step)


@pytest.mark.parametrize("mx,sx,nx,my,sy,ny", [(1390.6, 1121.3, 5, 1663.5, 469.0, 10), (46.5, 0.4, 5, 59.3, 18.2, 10),
                                               (10.0, 3.0, 3, 1.0, 0.5, 7)])
def test_welch_from_stats_against_scipy(mx, sx, nx, my, sy, ny):
    w = stats.welch_from_stats(mx, sx, nx, my, sy, ny)
    ref = sps.ttest_ind_from_stats(mx, sx, nx, my, sy, ny, equal_var=False)
    assert w.test.t == pytest.approx(ref.statistic, rel=1e-12)
    assert w.test.p_two_sided == pytest.approx(ref.pvalue, rel=1e-9)
    se = math.sqrt(sx ** 2 / nx + sy ** 2 / ny)
    half = sps.t.ppf(0.975, w.test.df) * se
    assert (w.low, w.high) == pytest.approx((mx - my - half, mx - my + half), rel=1e-9)


def test_welch_from_stats_equals_the_sample_forms():
    rng = np.random.default_rng(0)
    x, y = rng.normal(3, 2, 5), rng.normal(1, 1, 8)
    w = stats.welch_from_stats(x.mean(), x.std(ddof=1), 5, y.mean(), y.std(ddof=1), 8)
    assert w.test.p_two_sided == pytest.approx(stats.welch_t_test(x, y).p_two_sided, rel=1e-12)
    assert (w.low, w.high) == pytest.approx(stats.welch_diff_ci(x, y), rel=1e-12)


def test_command_on_a_curated_cell(capsys, tmp_path):
    out = tmp_path / "rows.json"
    assert published.main([WALKER_RELU, "--at-step", "300000", "--json", str(out)]) == 0
    row, = json.load(open(out))
    evals = np.load(os.path.join(WALKER_RELU, "evaluations.npy"))  # [evaluations, seeds]
    x = evals[300_000 // 5000]
    assert row["ours_mean"] == pytest.approx(x.mean(), rel=1e-12) and row["ours_n"] == x.size
    assert row["ours_sd"] == pytest.approx(x.std(ddof=1), rel=1e-12)
    raw = {p[0]: p[1] for p in json.load(open(published_curves.DATA))["envs"]["Walker2d-v3"]["TD3"]}
    assert row["published"]["mean"] == raw[275_000] and "Walker2d-v5 | td3 | relu | 300,000" in capsys.readouterr().out


def test_several_steps_give_one_row_per_run_and_step_each_the_single_steps_row(tmp_path, capsys):
    """``--at-step 100000,300000``: the rows of ``--at-step 100000`` and ``--at-step 300000``, in
    that order, in one table and one JSON list."""
    rows = []
    for steps in ("100000", "300000", "100000,300000"):
        out = tmp_path / f"{steps}.json"
        assert published.main([WALKER_RELU, "--at-step", steps, "--json", str(out)]) == 0
        rows.append(json.load(open(out)))
    assert rows[2] == rows[0] + rows[1] and [r["step"] for r in rows[2]] == [100_000, 300_000]
    out = capsys.readouterr().out
    assert out.count("| Walker2d-v5 | td3 | relu |") == 4  # 1 + 1 + 2
    assert out.count(f"- {WALKER_RELU} at 100,000: ") == 2 and out.count(f"- {WALKER_RELU} at 300,000: ") == 2


def test_reach_gives_the_first_step_at_each_return_on_both_sides(tmp_path, capsys):
    """``--reach``: the first evaluation at which the seeds' mean is ≥ R, against the first point of
    Tianshou's raw mean curve (its env_step + 25k) ≥ R, both up to the run's last step (300k here)."""
    out = tmp_path / "reach.json"
    assert published.main([WALKER_RELU, "--reach", "500,1000,99999", "--json", str(out)]) == 0
    rows = json.load(open(out))
    mean = np.load(os.path.join(WALKER_RELU, "evaluations.npy")).mean(axis=1)  # [evaluations]
    raw = [(p[0] + 25_000, p[1]) for p in json.load(open(published_curves.DATA))["envs"]["Walker2d-v3"]["TD3"]
           if p[0] + 25_000 <= 300_000]
    for row, level in zip(rows, (500, 1000)):
        ours = 5000 * next(i for i, m in enumerate(mean) if m >= level)
        theirs = next(s for s, m in raw if m >= level)
        assert (row["return"], row["ours_step"], row["published_step"]) == (level, ours, theirs)
        assert row["later_by"] == ours - theirs and row["ours_n"] == 5
    assert (rows[2]["ours_step"], rows[2]["published_step"], rows[2]["later_by"]) == (None, None, None)
    assert "| 99999 | not by 300,000 (n 5) | not by 300,000 | n/a |" in capsys.readouterr().out


def _exit_status(argv) -> int:
    """``published.main``'s status, argparse's refusals (SystemExit) included."""
    try:
        return published.main(argv)
    except SystemExit as e:
        return e.code


@pytest.mark.parametrize("argv,fragment", [
    ([WALKER_RELU, "--at-step", "12345"], "multiples of 5000"),
    ([WALKER_RELU, "--at-step", "400000"], "400000"),
    ([WALKER_RELU, "--at-step", "100000,12345"], "got 12345"),
    ([WALKER_RELU, "--at-step", "100000,100000"], "named twice"),
    ([WALKER_RELU, "--at-step", "3e5"], "comma-separated steps"),
    ([WALKER_RELU, "--reach", "1000,lots"], "comma-separated returns"),
    ([WALKER_RELU, "--reach", "nan"], "finite returns"),
    ([WALKER_RELU, "--reach", "1000", "--at-step", "300000"], "give one of them"),
    ([os.path.join(REPO, "runs", "no-such-run")], "no-such-run"),
])
def test_bad_input_is_one_line_and_exit_2(argv, fragment, capsys):
    assert _exit_status(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and fragment in err


def test_existing_json_is_not_overwritten(tmp_path, capsys):
    out = tmp_path / "rows.json"
    out.write_text("keep")
    assert _exit_status([WALKER_RELU, "--json", str(out)]) == 2 and out.read_text() == "keep"



def test_figure_draws_each_run_over_its_published_curve(tmp_path, capsys):
    """--figure: one panel per task, each run's curve named by its folder, env, activation and
    products, the published curve under it, drawn up to --at-step."""
    sac = os.path.join(REPO, "runs", "curated", "sac-check", "hopper_relu")
    out = tmp_path / "curves.svg"
    assert published.main([WALKER_RELU, sac, "--at-step", "100000", "--figure", str(out)]) == 0
    printed = capsys.readouterr()
    assert printed.err == f"published: wrote {out}\n" and "published: wrote" not in printed.out
    svg = out.read_text()
    for text in ("study-table2/walker_relu: Walker2d-v5 relu, float32, bfloat16 products, 5 seeds",
                 "sac-check/hopper_relu: Hopper-v5 relu, float32, 3 seeds",
                 "published TD3 (Walker2d-v3; its 25k random steps counted)",
                 "published SAC (Hopper-v3; its 10k random steps counted)", "Walker2d, TD3", "Hopper, SAC"):
        assert text in svg, text
    assert "300k" not in svg and "100k" in svg  # the x axis ends at --at-step


@pytest.mark.parametrize("name,fragment", [("f.pdf", "must end in .png or .svg"), ("exists.png", "exists; nothing written"),
                                           ("no/f.png", "does not exist")])
def test_figure_bad_path_is_one_line_exit_2_nothing_written(name, fragment, tmp_path, capsys):
    (tmp_path / "exists.png").write_text("keep")
    before = sorted(os.listdir(tmp_path))
    assert _exit_status([WALKER_RELU, "--figure", str(tmp_path / name)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and fragment in err
    assert sorted(os.listdir(tmp_path)) == before and (tmp_path / "exists.png").read_text() == "keep"


@pytest.fixture
def seeds_5_to_9(tmp_path):
    """A copy of WALKER_RELU whose config says its seeds are 5-9 (as configs/studies/*-seeds5-9.yaml
    writes them): the same experiment, other seeds, so the report's policy pools it with the original."""
    import shutil

    import yaml

    other = tmp_path / "more" / "walker_relu"
    shutil.copytree(WALKER_RELU, other)
    cfg = yaml.safe_load((other / "config.yaml").read_text())
    cfg["first_seed"] = 5
    (other / "config.yaml").write_text(yaml.safe_dump(cfg))
    os.remove(other / "metrics.csv")  # its rows name seeds 0-4 (metrics.csv is optional)
    return str(other)


def test_pool_gives_one_row_of_every_folders_seeds(seeds_5_to_9, tmp_path, capsys):
    out = tmp_path / "rows.json"
    fig = tmp_path / "pooled.svg"
    assert published.main([WALKER_RELU, seeds_5_to_9, "--pool", "--at-step", "300000", "--json", str(out),
                           "--figure", str(fig)]) == 0
    row, = json.load(open(out))
    x = np.load(os.path.join(WALKER_RELU, "evaluations.npy"))[60]
    both = np.concatenate([x, x])
    assert row["run"] == f"{WALKER_RELU} + {seeds_5_to_9}" and row["ours_n"] == 10
    assert row["ours_mean"] == pytest.approx(both.mean(), rel=1e-12)
    assert row["ours_sd"] == pytest.approx(both.std(ddof=1), rel=1e-12)
    assert "study-table2/walker_relu + more/walker_relu: Walker2d-v5 relu" in fig.read_text()
    capsys.readouterr()
    # without --pool: two rows of 5
    assert published.main([WALKER_RELU, seeds_5_to_9, "--at-step", "300000"]) == 0
    assert capsys.readouterr().out.count("(n 5)") == 2


def test_pool_refuses_a_seed_twice(capsys):
    assert _exit_status([WALKER_RELU, os.path.join(REPO, "runs", "curated", "study-table2", "walker_relu"), "--pool"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "seed" in err
