"""swim_jax.analysis.stats against independent computations (hand values, loops, scipy where installed)."""

import math

import numpy as np
import pytest

from swim_jax.analysis import stats


def test_max_of_mean_curve_uses_std_at_the_argmax_evaluation():
    steps = np.array([0, 10, 20])
    r = np.array([[0.0, 10.0], [60.0, 40.0], [40.0, 50.0]])  # means 5, 50, 45
    m = stats.max_of_mean_curve(steps, r)
    assert (m.mean, m.std, m.index, m.step) == (50.0, 10.0, 1, 10)
    f = stats.final_return(steps, r)
    assert (f.mean, f.std, f.step) == (45.0, 5.0, 20)


def test_normalized_auc_matches_trapezoid_by_hand_and_numpy():
    steps = np.array([0, 100, 300])  # uneven spacing on purpose
    r = np.array([[0.0, 2.0], [10.0, 4.0], [20.0, 4.0]])
    # seed 0: (0+10)/2*100 + (10+20)/2*200 = 500 + 3000 = 3500 over 300
    # seed 1: (2+4)/2*100 + (4+4)/2*200 = 300 + 800 = 1100 over 300
    np.testing.assert_allclose(stats.normalized_auc_per_seed(steps, r), [3500 / 300, 1100 / 300], rtol=1e-15)
    trap = getattr(np, "trapezoid", None) or np.trapz
    np.testing.assert_allclose(stats.normalized_auc_per_seed(steps, r), trap(r, steps, axis=0) / 300)
    np.testing.assert_array_equal(stats.normalized_auc_per_seed([0], r[:1]), r[0])
    with pytest.raises(ValueError):
        stats.normalized_auc_per_seed([0, 0, 1], r)


def test_iqm_drops_a_quarter_each_end():
    assert stats.iqm([1, 2, 3, 4, 100, -100, 5, 6]) == np.mean([2, 3, 4, 5])  # n=8: drop 2 each end
    assert stats.iqm([3.0, 1.0, 2.0]) == 2.0  # n=3: nothing dropped
    assert stats.iqm([10, 0, 1, 2, 3]) == 2.0  # n=5: drop 1 each end -> mean(1,2,3)
    sps = pytest.importorskip("scipy.stats")
    x = np.random.default_rng(3).normal(size=13)
    assert stats.iqm(x) == pytest.approx(sps.trim_mean(x, 0.25), rel=1e-12)


def test_probability_of_improvement_counts_ties_half():
    x, y = [1.0, 2.0, 3.0], [2.0, 0.0]
    # pairs: (1,2)<, (1,0)>, (2,2)=, (2,0)>, (3,2)>, (3,0)>  -> (4 + 0.5)/6
    assert stats.prob_improvement(x, y) == pytest.approx(4.5 / 6)
    rng = np.random.default_rng(0)
    a, b = rng.integers(0, 4, 7).astype(float), rng.integers(0, 4, 5).astype(float)
    loop = sum(1.0 if ai > bi else 0.5 if ai == bi else 0.0 for ai in a for bi in b) / (len(a) * len(b))
    assert stats.prob_improvement(a, b) == pytest.approx(loop)


def test_bootstrap_ci_matches_a_plain_loop_with_the_same_draws_and_scipy_within_tolerance():
    x = np.array([3.0, 7.0, 1.0, 9.0, 4.0])
    lo, hi = stats.bootstrap_ci(x, n_boot=4000, seed=11)
    assert (lo, hi) == stats.bootstrap_ci(x, n_boot=4000, seed=11)  # deterministic
    rng = np.random.default_rng(11)
    idx = rng.integers(0, x.size, size=(4000, x.size))
    means = [np.mean([x[j] for j in row]) for row in idx]
    assert (lo, hi) == pytest.approx(tuple(np.quantile(means, [0.025, 0.975])))
    # independent RNG stream: a different random loop bootstrap agrees within Monte-Carlo error
    rng2 = np.random.default_rng(12345)
    m2 = [x[rng2.integers(0, 5, 5)].mean() for _ in range(20000)]
    assert lo == pytest.approx(np.quantile(m2, 0.025), abs=0.25)
    assert hi == pytest.approx(np.quantile(m2, 0.975), abs=0.25)
    sps = pytest.importorskip("scipy.stats")
    import inspect

    seed_kw = "rng" if "rng" in inspect.signature(sps.bootstrap).parameters else "random_state"
    res = sps.bootstrap((x,), np.mean, n_resamples=20000, method="percentile", **{seed_kw: np.random.default_rng(1)})
    assert lo == pytest.approx(res.confidence_interval.low, abs=0.25)
    assert hi == pytest.approx(res.confidence_interval.high, abs=0.25)


def test_bootstrap_diff_ci_against_a_loop():
    x, y = np.array([10.0, 12.0, 15.0, 11.0]), np.array([8.0, 9.0, 13.0])
    lo, hi = stats.bootstrap_diff_ci(x, y, n_boot=3000, seed=5)
    rng = np.random.default_rng(99)
    d = [x[rng.integers(0, 4, 4)].mean() - y[rng.integers(0, 3, 3)].mean() for _ in range(30000)]
    assert lo == pytest.approx(np.quantile(d, 0.025), abs=0.3)
    assert hi == pytest.approx(np.quantile(d, 0.975), abs=0.3)
    assert lo < x.mean() - y.mean() < hi


def test_welch_by_hand():
    x, y = np.array([1.0, 2.0, 3.0, 4.0]), np.array([2.0, 4.0, 9.0])
    vx, vy = np.var(x, ddof=1) / 4, np.var(y, ddof=1) / 3  # 5/12, 13/3
    t = (2.5 - 5.0) / math.sqrt(vx + vy)
    df = (vx + vy) ** 2 / (vx ** 2 / 3 + vy ** 2 / 2)
    w = stats.welch_t_test(x, y)
    assert w.t == pytest.approx(t, rel=1e-13) and w.df == pytest.approx(df, rel=1e-13)
    assert 0 < w.p_two_sided < 1


@pytest.mark.parametrize("seed", range(6))
def test_welch_against_scipy(seed):
    sps = pytest.importorskip("scipy.stats")
    rng = np.random.default_rng(seed)
    x = rng.normal(1.0, 1.0 + seed, size=3 + seed)
    y = rng.normal(0.0, 0.5, size=2 + 2 * seed)
    w = stats.welch_t_test(x, y)
    ref = sps.ttest_ind(x, y, equal_var=False)
    assert w.t == pytest.approx(ref.statistic, rel=1e-10)
    assert w.p_two_sided == pytest.approx(ref.pvalue, rel=1e-8, abs=1e-15)
    if hasattr(ref, "df"):
        assert w.df == pytest.approx(ref.df, rel=1e-10)


def test_t_p_values_and_incomplete_beta_against_known_values():
    # t = 2.776 with df = 4 is the textbook two-sided 5% critical value; t=0 gives p=1
    assert stats.student_t_two_sided_p(2.7764451051977987, 4) == pytest.approx(0.05, rel=1e-9)
    assert stats.student_t_two_sided_p(0.0, 3.5) == 1.0
    # df = 1 is Cauchy: p = 1 - 2/pi * atan|t|
    for t in (0.3, 1.0, 7.0):
        assert stats.student_t_two_sided_p(t, 1.0) == pytest.approx(1 - 2 / math.pi * math.atan(t), rel=1e-12)
    # I_x(1, 1) = x; I_x(a, 1) = x^a
    assert stats.betainc_regularized(1, 1, 0.37) == pytest.approx(0.37, rel=1e-14)
    assert stats.betainc_regularized(2.5, 1, 0.6) == pytest.approx(0.6 ** 2.5, rel=1e-13)


def test_incomplete_beta_against_scipy_on_a_grid():
    sp = pytest.importorskip("scipy.special")
    for a in (0.5, 1.0, 2.3, 7.0, 40.0):
        for b in (0.5, 1.0, 3.0):
            for x in (1e-6, 0.01, 0.3, 0.5, 0.77, 0.999):
                assert stats.betainc_regularized(a, b, x) == pytest.approx(sp.betainc(a, b, x), rel=1e-10, abs=1e-300)


def test_welch_degenerate_cases():
    with pytest.raises(ValueError):
        stats.welch_t_test([1.0], [1.0, 2.0])
    w = stats.welch_t_test([1.0, 1.0], [1.0, 1.0])
    assert math.isnan(w.t) and math.isnan(w.p_two_sided)
    w = stats.welch_t_test([1.0, 1.0, 1.0], [2.0, 3.0])  # one sample constant: still defined
    assert math.isfinite(w.t) and w.df == pytest.approx(1.0)


def test_improvement_pct():
    assert stats.improvement_pct(4387.442, 3774.668) == pytest.approx(16.234, abs=1e-3)  # paper Walker2d
    assert stats.improvement_pct(-5.0, -10.0) == pytest.approx(50.0)  # relative to |base|
    assert math.isnan(stats.improvement_pct(1.0, 0.0))


def test_verdict_wording():
    strong = stats.compare([10, 11, 12, 10.5, 11.5], [1, 2, 1.5, 2.5, 1], "max", n_boot=2000)
    v = stats.verdict(strong)
    assert v.startswith("Swim is better than Swish") and "too weak" not in v
    worse = stats.compare([1, 2, 1.5, 2.5, 1], [10, 11, 12, 10.5, 11.5], "max", n_boot=2000)
    assert stats.verdict(worse).startswith("Swim is worse than Swish")
    few = stats.compare([10, 11, 12], [1, 2, 1.5], "max", n_boot=2000)
    v = stats.verdict(few)
    assert v.startswith("Evidence too weak") and "Swim has 3 seeds and Swish 3 seeds (at least 5 each" in v
    overlap = stats.compare([1, 5, 2, 6, 3], [2, 4, 3, 5, 1], "final", n_boot=2000)
    v = stats.verdict(overlap)
    assert v.startswith("Evidence too weak") and "p ≥ 0.05" in v and "includes 0" in v
    single = stats.compare([1.0], [2.0], "final", n_boot=500)
    v = stats.verdict(single)
    assert single.welch is None and "no t-test possible" in v and "Swim has 1 seed and Swish 1 seed" in v
    # one seed a side: the bootstrap "interval" is the point -1.0; the verdict gives no CI and no CI reason
    assert single.diff_ci == (-1.0, -1.0) and "CI of the difference n/a" in v and "includes 0" not in v


def test_verdict_wording_when_the_means_are_equal():
    c = stats.compare([1.0, 2.0, 3.0], [3.0, 2.0, 1.0], "auc", n_boot=500)
    assert c.diff == 0.0
    v = stats.verdict(c)
    assert "equal than" not in v
    assert "Swim's mean per-seed auc score equals Swish's (95% bootstrap CI" in v
    assert v.startswith("Evidence too weak")


def test_t_quantile_mean_ci_and_welch_difference_ci_match_scipy():
    import scipy.stats

    for q, df in [(0.975, 1), (0.975, 2.5), (0.975, 9), (0.975, 99), (0.995, 30), (0.75, 4), (0.5, 7)]:
        assert stats.student_t_quantile(q, df) == pytest.approx(scipy.stats.t.ppf(q, df), rel=1e-9, abs=1e-9)
    rng = np.random.default_rng(0)
    x, y = rng.normal(5, 2, 12), rng.normal(4, 7, 40)
    ci = stats.mean_ci(x)
    assert (ci.low, ci.high) == pytest.approx(scipy.stats.t.interval(0.95, 11, x.mean(), scipy.stats.sem(x)), rel=1e-10)
    assert x.mean() in ci and ci.high + 1 not in ci
    ref = scipy.stats.ttest_ind(x, y, equal_var=False).confidence_interval(0.95)
    assert stats.welch_diff_ci(x, y) == pytest.approx((ref.low, ref.high), rel=1e-9)
    with pytest.raises(ValueError):
        stats.mean_ci([1.0])
