"""Aggregates across envs (swim_jax/analysis/aggregate.py) equal rliable's on the curated Table II
study (12 cells × 5 seeds): IQM, mean, median and optimality gap with their stratified bootstrap CIs
(same draws: rliable after np.random.seed(s)), the probability of improvement with its CI, and the
performance profiles; and the report writes them with its figure."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from swim_jax.analysis import aggregate as ag, report, runs_io, stats

rly = pytest.importorskip("rliable.library")  # part of the test extra (pyproject.toml)
from rliable import metrics  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CELLS = [os.path.join(REPO, "runs", "curated", "study-table2", f"{e}_{a}")
         for e in ("walker", "hopper", "cheetah", "swimmer") for a in ("swim", "swish", "relu")]
REPS, SEED = 300, 3


@pytest.fixture(scope="module")
def curated():
    # (its Walker2d cells mix float32 and bfloat16 products: compared here as data, on request)
    groups = runs_io.load_and_group(CELLS, mixed_precision=True)
    per_env = {env: {a: stats.per_seed_scores(c.steps, c.returns)["max"] for a, c in g.curves.items()}
               for env, g in groups.items()}
    return per_env, ag.aggregate(per_env, "max", reps=REPS, seed=SEED)


def test_normalized_scores_are_the_formula(curated):
    per_env, agg = curated
    assert agg.envs == ["HalfCheetah-v5", "Hopper-v5", "Swimmer-v5", "Walker2d-v5"]
    for j, env in enumerate(agg.envs):
        random, reference, _ = ag.NORMALIZATION[env]
        np.testing.assert_allclose(agg.scores["swim"][:, j], (per_env[env]["swim"] - random) / (reference - random))


def test_metrics_and_their_cis_equal_rliables(curated):
    _, agg = curated
    fn = lambda s: np.array([metrics.aggregate_iqm(s), metrics.aggregate_mean(s), metrics.aggregate_median(s),
                             metrics.aggregate_optimality_gap(s)])
    for label, scores in agg.scores.items():
        np.random.seed(SEED)
        point, ci = rly.get_interval_estimates({label: scores}, fn, reps=REPS)
        ours = np.array([agg.metrics[label][m] for m in ag.METRICS])  # [metric, (point, lo, hi)]
        np.testing.assert_allclose(ours[:, 0], point[label], rtol=1e-12)
        np.testing.assert_allclose(ours[:, 1:], ci[label].T, rtol=1e-12)


def test_probability_of_improvement_and_profiles_equal_rliables(curated):
    _, agg = curated
    for key, (p, lo, hi) in agg.improvement.items():
        x, y = (agg.scores[a] for a in key.split("_vs_"))
        np.random.seed(SEED)
        point, ci = rly.get_interval_estimates({key: [x, y]}, lambda a, b: np.array([metrics.probability_of_improvement(a, b)]),
                                               reps=REPS)
        assert p == pytest.approx(point[key][0], abs=1e-12)
        np.testing.assert_allclose([lo, hi], ci[key][:, 0], atol=1e-12)
    profiles, _ = rly.create_performance_profile(agg.scores, agg.taus)
    for label in agg.scores:
        np.testing.assert_array_equal(agg.profiles[label], profiles[label])


def test_the_report_writes_the_aggregates_and_their_figure(tmp_path):
    out = tmp_path / "rep"
    assert report.main([*CELLS, "--out", str(out), "--n-boot", str(REPS), "--boot-seed", str(SEED),
                        "--mixed-precision"]) == 0
    res = json.loads((out / "results.json").read_text())["aggregate"]
    agg = ag.aggregate({env: {a: stats.per_seed_scores(c.steps, c.returns)["max"] for a, c in g.curves.items()}
                        for env, g in runs_io.load_and_group(CELLS, mixed_precision=True).items()},
                       "max", reps=REPS, seed=SEED)
    assert res["metrics"]["swim"]["iqm"] == pytest.approx(list(agg.metrics["swim"]["iqm"]))
    md = (out / "REPORT.md").read_text()
    assert "## Across envs: normalized scores" in md and "| Swim > Swish |" in md
    assert (out / "profile.png").read_bytes().startswith(b"\x89PNG")
    assert report.main([CELLS[3], CELLS[4], "--out", str(tmp_path / "one"), "--n-boot", "200"]) == 0
    assert not (tmp_path / "one" / "profile.png").exists()  # one env: nothing to aggregate


def test_envs_of_different_numerics_are_aggregated_only_on_request(tmp_path):
    """Hopper's curated cells multiplied in bfloat16; copies of HalfCheetah's that say float32 make the
    aggregate across envs a mixed one: not computed (the per-env tables stay), unless --mixed-precision."""
    import shutil

    hopper = CELLS[3:6]
    cheetah = []
    for src in CELLS[6:9]:
        dst = tmp_path / "f32" / os.path.basename(src)
        shutil.copytree(src, dst)
        for name in ("provenance.json", "timing.json"):
            path = dst / name
            path.write_text(path.read_text().replace('"bfloat16"', '"float32"'))
        cheetah.append(str(dst))
    out = tmp_path / "refused"
    assert report.main([*hopper, *cheetah, "--out", str(out), "--n-boot", "200"]) == 0
    md = (out / "REPORT.md").read_text()
    assert "Not computed: envs differ in precision or matmul_dtype (float32: HalfCheetah-v5; float32, bfloat16 " \
           "products: Hopper-v5); --mixed-precision aggregates them, marked." in md
    assert "aggregate" not in json.loads((out / "results.json").read_text()) and not (out / "profile.png").exists()
    out = tmp_path / "asked"
    assert report.main([*hopper, *cheetah, "--out", str(out), "--n-boot", "200", "--mixed-precision"]) == 0
    md = (out / "REPORT.md").read_text()
    assert "‡ Runs of different precision or matmul products are aggregated here" in md and (out / "profile.png").exists()
    assert report.main([*hopper, *CELLS[6:9], "--out", str(tmp_path / "same"), "--n-boot", "200"]) == 0
    assert "‡" not in (tmp_path / "same" / "REPORT.md").read_text()
