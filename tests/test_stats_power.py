"""The power of the Swim vs Swish verdict (swim_jax/analysis/stats.py: detectable_difference,
seeds_to_detect; the report's "Power" line): against scipy's noncentral t, a simulation of Welch's
test, and the report's own per-seed scores recomputed with scipy."""

import json
import math

import numpy as np
import pytest

from swim_jax.analysis import stats
from tests.test_report import run_report, write_run

sps = pytest.importorskip("scipy.stats")

CASES = [(710.9, 5, 507.9, 5), (100.0, 5, 100.0, 5), (300.0, 5, 50.0, 5), (50.0, 10, 80.0, 10),
         (1.0, 3, 1.0, 3), (5.0, 20, 9.0, 7)]


def _welch_df(sx, nx, sy, ny):
    ax, ay = sx ** 2 / nx, sy ** 2 / ny
    return (ax + ay) ** 2 / (ax ** 2 / (nx - 1) + ay ** 2 / (ny - 1)), math.sqrt(ax + ay)


@pytest.mark.parametrize("sx,nx,sy,ny", CASES)
def test_the_detectable_difference_has_the_power_it_claims(sx, nx, sy, ny):
    """Exact power of the two-sided test at that difference: the noncentral t at Welch's df."""
    d = stats.detectable_difference(sx, nx, sy, ny)
    df, se = _welch_df(sx, nx, sy, ny)
    t = sps.t.ppf(0.975, df)
    power = sps.nct.sf(t, df, d / se) + sps.nct.cdf(-t, df, d / se)
    assert power == pytest.approx(0.8, abs=0.01)
    # and the formula itself, with scipy's quantiles
    assert d == pytest.approx((t + sps.t.ppf(0.8, df)) * se, rel=1e-9)


def test_welchs_test_finds_the_detectable_difference_as_often_as_claimed():
    """20000 simulated experiments of 5 seeds a side (normal scores, the spreads of Walker2d at 1M)."""
    sx, sy, n = 710.9, 507.9, 5
    d = stats.detectable_difference(sx, n, sy, n)
    rng = np.random.default_rng(0)
    x = rng.normal(d, sx, size=(20000, n))
    y = rng.normal(0.0, sy, size=(20000, n))
    found = sps.ttest_ind(x, y, axis=1, equal_var=False).pvalue < 0.05
    assert found.mean() == pytest.approx(0.8, abs=0.025)  # Welch's estimated df varies per experiment


def test_seeds_to_detect_is_the_fewest_that_suffice():
    n = stats.seeds_to_detect(712.0, 710.9, 507.9)
    assert n == 13
    assert stats.detectable_difference(710.9, n, 507.9, n) <= 712.0 < stats.detectable_difference(710.9, n - 1, 507.9, n - 1)
    assert stats.seeds_to_detect(-712.0, 710.9, 507.9) == n  # the sign does not matter
    assert stats.seeds_to_detect(0.0, 1.0, 1.0) is None
    assert stats.seeds_to_detect(1e-3, 1.0, 1.0, most=50) is None


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="at least 2 values"):
        stats.detectable_difference(1.0, 1, 1.0, 5)
    with pytest.raises(ValueError, match="power"):
        stats.detectable_difference(1.0, 5, 1.0, 5, power=1.0)
    assert stats.detectable_difference(0.0, 5, 0.0, 5) == 0.0


def _five_seed_runs(tmp_path, shift):
    """Walker2d-v5 Swim and Swish, 5 seeds, 3 evaluations; Swim's scores ``shift`` above Swish's."""
    rng = np.random.default_rng(3)
    runs = tmp_path / "runs"
    runs.mkdir()
    swish = rng.normal(100.0, 20.0, size=(3, 5))
    swim = rng.normal(100.0 + shift, 30.0, size=(3, 5))
    return swim, swish, [write_run(runs, "a", act="swim", returns=swim), write_run(runs, "b", act="swish", returns=swish)]


def test_the_report_says_what_a_too_weak_verdict_could_have_found(tmp_path, capsys):
    swim, swish, paths = _five_seed_runs(tmp_path, shift=5.0)
    out = tmp_path / "out"
    assert run_report(paths + ["--out", out], capsys)[0] == 0
    x, y = swim.max(axis=0), swish.max(axis=0)  # the verdict's score: the per-seed max
    df, se = _welch_df(x.std(ddof=1), 5, y.std(ddof=1), 5)
    want = (sps.t.ppf(0.975, df) + sps.t.ppf(0.8, df)) * se
    paper = 0.16 * abs(y.mean())
    need = next(n for n in range(2, 1001)
                if (sps.t.ppf(0.975, _welch_df(x.std(ddof=1), n, y.std(ddof=1), n)[0])
                    + sps.t.ppf(0.8, _welch_df(x.std(ddof=1), n, y.std(ddof=1), n)[0]))
                * _welch_df(x.std(ddof=1), n, y.std(ddof=1), n)[1] <= paper)
    pw = json.loads((out / "results.json").read_text())["envs"]["Walker2d-v5"]["verdict_power"]
    assert pw["detectable_difference"] == pytest.approx(want, rel=1e-9)
    assert pw["detectable_pct_of_swish"] == pytest.approx(100 * want / y.mean(), rel=1e-9)
    assert (pw["paper_env"], pw["paper_improvement_pct"]) == ("Walker2d-v2", 16)
    assert pw["paper_difference"] == pytest.approx(paper, rel=1e-12)
    assert pw["seeds_for_paper_difference"] == need
    text = (out / "REPORT.md").read_text()
    verdict = text[text.index("## Verdict"):]
    assert "Evidence too weak" in verdict
    assert (f"finds a true difference of {want:.1f} ({100 * want / y.mean():.0f} % of Swish's mean) or more "
            "80% of the time") in verdict
    assert f"The paper's +16 % (Walker2d-v2; {paper:.1f} on this score) would need {need} seeds a side." in verdict


def test_no_power_line_under_a_sufficient_verdict(tmp_path, capsys):
    _, _, paths = _five_seed_runs(tmp_path, shift=300.0)
    out = tmp_path / "out"
    assert run_report(paths + ["--out", out], capsys)[0] == 0
    text = (out / "REPORT.md").read_text()
    assert "Swim is better than Swish" in text and "Power:" not in text
    assert "verdict_power" in json.loads((out / "results.json").read_text())["envs"]["Walker2d-v5"]
