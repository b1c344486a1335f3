"""Statistics for comparing learning curves across seeds (numpy and ``math`` only, no scipy).

Conventions used throughout (and stated in the generated report):

* A *curve* array is ``returns[n_evals, n_seeds]``: the mean evaluation return of each seed at each
  evaluation step ``steps[n_evals]``.
* "std over seeds" in the paper-style tables is the population standard deviation (``ddof=0``, as
  ``numpy.std`` and the ``evaluations.csv`` written by ``swim_jax.run.train``). Welch's t-test uses the
  unbiased sample variance (``ddof=1``), as the test requires.
* The normalised area under the curve is the trapezoid integral of the return over steps divided by
  the step span, i.e. the time-averaged return (same units as a return).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from swim_jax.io.cli_parser import counted

# ------------------------------------------------------------------------------------------------
# curve summaries (the paper's Table II)
# ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MeanStd:
    """A mean ± population std over seeds, optionally at one evaluation index/step."""

    mean: float
    std: float
    index: int | None = None
    step: int | None = None


def max_of_mean_curve(steps: np.ndarray, returns: np.ndarray) -> MeanStd:
    """The paper's Table II metric: max over evaluations of the mean-over-seeds return.

    Returns that maximum, the population std over seeds *at that same evaluation*, and the index and
    step of the evaluation (the first one if several tie). ``returns`` is ``[n_evals, n_seeds]``.
    """
    returns = _curve(returns)
    mean = returns.mean(axis=1)
    i = int(np.argmax(mean))
    return MeanStd(float(mean[i]), float(returns[i].std(ddof=0)), i, int(np.asarray(steps)[i]))


def final_return(steps: np.ndarray, returns: np.ndarray) -> MeanStd:
    """Mean ± population std over seeds of the return at the last evaluation."""
    returns = _curve(returns)
    return MeanStd(float(returns[-1].mean()), float(returns[-1].std(ddof=0)), returns.shape[0] - 1,
                   int(np.asarray(steps)[-1]))


def normalized_auc_per_seed(steps: np.ndarray, returns: np.ndarray) -> np.ndarray:
    """Per-seed trapezoid area under the return curve divided by the step span: ``[n_seeds]``.

    This is the time-averaged return over the training horizon. With a single evaluation it is that
    evaluation's return. ``steps`` must be strictly increasing.
    """
    returns = _curve(returns)
    steps = np.asarray(steps, dtype=np.float64)
    if steps.shape != (returns.shape[0],):
        raise ValueError(f"steps has shape {steps.shape}, expected ({returns.shape[0]},)")
    if returns.shape[0] == 1:
        return returns[0].copy()
    if np.any(np.diff(steps) <= 0):
        raise ValueError("steps must be strictly increasing")
    widths = np.diff(steps)[:, None]
    area = (0.5 * (returns[1:] + returns[:-1]) * widths).sum(axis=0)
    return area / (steps[-1] - steps[0])


def per_seed_scores(steps: np.ndarray, returns: np.ndarray) -> dict[str, np.ndarray]:
    """Per-seed scalar scores ``{"max", "final", "auc"}``, each ``[n_seeds]``.

    ``max``: max over evaluations of that seed's return; ``final``: return at the last evaluation;
    ``auc``: :func:`normalized_auc_per_seed`.
    """
    returns = _curve(returns)
    return {
        "max": returns.max(axis=0),
        "final": returns[-1].copy(),
        "auc": normalized_auc_per_seed(steps, returns),
    }


def _curve(returns) -> np.ndarray:
    r = np.asarray(returns, dtype=np.float64)
    if r.ndim != 2 or r.shape[0] < 1 or r.shape[1] < 1:
        raise ValueError(f"returns must be [n_evals>=1, n_seeds>=1], got shape {r.shape}")
    return r


def improvement_pct(new: float, base: float) -> float:
    """``100 · (new − base) / |base|`` (NaN when base is 0): Table II's improvement of Swim over Swish."""
    if base == 0:
        return float("nan")
    return 100.0 * (new - base) / abs(base)


# ------------------------------------------------------------------------------------------------
# beyond the paper
# ------------------------------------------------------------------------------------------------


def iqm(x) -> float:
    """Interquartile mean: the mean of the sorted values after dropping ``floor(n/4)`` from each end.

    This equals ``scipy.stats.trim_mean(x, 0.25)``. With fewer than 4 values nothing is dropped.
    """
    x = np.sort(np.asarray(x, dtype=np.float64).ravel())
    if x.size == 0:
        raise ValueError("iqm of an empty sample")
    k = x.size // 4
    return float(x[k:x.size - k].mean())


def bootstrap_ci(x, n_boot: int = 10_000, alpha: float = 0.05, seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap ``(lo, hi)`` CI at level ``1 − alpha`` of the mean of ``x``.

    Resamples ``x`` with replacement ``n_boot`` times with ``numpy.random.default_rng(seed)``, so the
    result is deterministic for a given seed. A single value gives the degenerate CI ``(x, x)``.
    """
    x = np.asarray(x, dtype=np.float64).ravel()
    if x.size == 0:
        raise ValueError("bootstrap of an empty sample")
    rng = np.random.default_rng(seed)
    means = x[rng.integers(0, x.size, size=(n_boot, x.size))].mean(axis=1)
    lo, hi = np.quantile(means, [alpha / 2, 1 - alpha / 2])
    return float(lo), float(hi)


def bootstrap_diff_ci(x, y, n_boot: int = 10_000, alpha: float = 0.05, seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap CI of ``mean(x) − mean(y)``, resampling each sample independently.

    Deterministic for a given ``seed`` (``x`` indices drawn first, then ``y`` indices, from one
    ``numpy.random.default_rng(seed)``).
    """
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    if x.size == 0 or y.size == 0:
        raise ValueError("bootstrap of an empty sample")
    rng = np.random.default_rng(seed)
    mx = x[rng.integers(0, x.size, size=(n_boot, x.size))].mean(axis=1)
    my = y[rng.integers(0, y.size, size=(n_boot, y.size))].mean(axis=1)
    lo, hi = np.quantile(mx - my, [alpha / 2, 1 - alpha / 2])
    return float(lo), float(hi)


def prob_improvement(x, y) -> float:
    """P(X > Y) over all ``len(x) · len(y)`` pairs, ties counting 1/2 (the Mann–Whitney U / (n·m))."""
    x = np.asarray(x, dtype=np.float64).ravel()[:, None]
    y = np.asarray(y, dtype=np.float64).ravel()[None, :]
    if x.size == 0 or y.size == 0:
        raise ValueError("probability of improvement of an empty sample")
    return float(((x > y) + 0.5 * (x == y)).mean())


@dataclass(frozen=True)
class WelchResult:
    """Welch's unequal-variance t-test of mean(x) − mean(y): statistic, Welch–Satterthwaite df, p."""

    t: float
    df: float
    p_two_sided: float


def welch_t_test(x, y) -> WelchResult:
    """Welch's t-test (two-sided) of ``mean(x) = mean(y)`` with sample variances (``ddof=1``).

    ``t = (mx − my) / sqrt(vx/nx + vy/ny)``, ``df = (vx/nx + vy/ny)² / ((vx/nx)²/(nx−1) +
    (vy/ny)²/(ny−1))``, ``p = 2·P(T_df > |t|) = I_{df/(df+t²)}(df/2, 1/2)``. Needs at least 2 values
    per sample (else ``ValueError``). If both samples have zero variance the result is NaN throughout.
    """
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    if x.size < 2 or y.size < 2:
        raise ValueError("Welch's t-test needs at least 2 values per sample")
    return _welch(x.mean() - y.mean(), x.var(ddof=1) / x.size, y.var(ddof=1) / y.size, x.size, y.size)


def _welch(d, ax, ay, nx, ny) -> WelchResult:
    """Welch's t-test of a difference ``d`` of means whose squared standard errors are ``ax``, ``ay``
    (variance / n) over ``nx``, ``ny`` values (:func:`welch_t_test`)."""
    se2 = ax + ay
    if se2 == 0:
        nan = float("nan")
        return WelchResult(nan, nan, nan)
    t = float(d / math.sqrt(se2))
    df = float(se2 ** 2 / (ax ** 2 / (nx - 1) + ay ** 2 / (ny - 1)))
    return WelchResult(t, df, student_t_two_sided_p(t, df))


@dataclass(frozen=True)
class WelchFromStats:
    """mean_x − mean_y, its Welch confidence interval ``[low, high]`` and the test (:class:`WelchResult`)."""

    diff: float
    low: float
    high: float
    test: WelchResult


def welch_from_stats(mean_x: float, sd_x: float, n_x: int, mean_y: float, sd_y: float, n_y: int,
                     level: float = 0.95) -> WelchFromStats:
    """Welch's test and ``level`` confidence interval of mean_x − mean_y from summary statistics
    (sample standard deviations, ``ddof=1``; at least 2 values per sample), e.g. our seeds against a
    published mean ± std over its seeds: the same formulas as :func:`welch_t_test` and
    :func:`welch_diff_ci` with ``v/n = sd²/n``."""
    if n_x < 2 or n_y < 2:
        raise ValueError("Welch's t-test needs at least 2 values per sample")
    d, ax, ay = float(mean_x - mean_y), sd_x ** 2 / n_x, sd_y ** 2 / n_y
    test = _welch(d, ax, ay, n_x, n_y)
    return WelchFromStats(d, *_welch_ci(d, ax, ay, test, level), test)


def _welch_ci(d, ax, ay, test: WelchResult, level: float) -> tuple[float, float]:
    """``d`` ± t_{(1+level)/2, df} · √(ax + ay), df that of ``test`` (:func:`_welch` of the same
    numbers); both squared standard errors zero: ``d`` twice."""
    if ax + ay == 0:
        return d, d
    half = student_t_quantile(0.5 + level / 2, test.df) * math.sqrt(ax + ay)
    return d - half, d + half


def student_t_two_sided_p(t: float, df: float) -> float:
    """Two-sided p-value ``P(|T| ≥ |t|)`` of Student's t with (real) ``df > 0`` degrees of freedom."""
    if not df > 0:
        raise ValueError(f"df must be > 0, got {df}")
    if math.isinf(t):
        return 0.0
    return min(1.0, betainc_regularized(df / 2.0, 0.5, df / (df + t * t)))


def student_t_quantile(q: float, df: float) -> float:
    """The ``q``-quantile (``0.5 <= q < 1``) of Student's t with ``df > 0`` degrees of freedom:
    the ``t >= 0`` with ``P(T <= t) = q``, by bisection on :func:`student_t_two_sided_p`
    (``P(|T| >= t) = 2(1 − q)``) to ~1e-12. ``student_t_quantile(0.975, 9)`` = 2.2622."""
    if not 0.5 <= q < 1:
        raise ValueError(f"q must be in [0.5, 1), got {q}")
    target = 2.0 * (1.0 - q)
    lo, hi = 0.0, 1.0
    while student_t_two_sided_p(hi, df) > target:
        lo, hi = hi, 2.0 * hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if student_t_two_sided_p(mid, df) > target:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12 * max(1.0, hi):
            break
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class MeanCI:
    """A sample's mean, sample std (``ddof=1``), size and t-based confidence interval of the mean."""

    mean: float
    sd: float
    n: int
    low: float
    high: float

    def __contains__(self, value: float) -> bool:
        return self.low <= value <= self.high


def mean_ci(x, level: float = 0.95) -> MeanCI:
    """mean ± t_{(1+level)/2, n−1} · sd/√n of ``x`` (at least 2 values, else ``ValueError``)."""
    x = np.asarray(x, dtype=np.float64).ravel()
    if x.size < 2:
        raise ValueError("a confidence interval needs at least 2 values")
    m, sd = float(x.mean()), float(x.std(ddof=1))
    half = student_t_quantile(0.5 + level / 2, x.size - 1) * sd / math.sqrt(x.size)
    return MeanCI(m, sd, int(x.size), m - half, m + half)


def welch_diff_ci(x, y, level: float = 0.95) -> tuple[float, float]:
    """Welch's confidence interval of mean(x) − mean(y): the difference ± t_{(1+level)/2, df} times
    its standard error, df the Welch–Satterthwaite degrees of freedom (:func:`welch_t_test`); at
    least 2 values per sample. Both variances zero: the difference itself, twice."""
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    if x.size < 2 or y.size < 2:
        raise ValueError("a difference CI needs at least 2 values per sample")
    ax, ay = x.var(ddof=1) / x.size, y.var(ddof=1) / y.size
    d = float(x.mean() - y.mean())
    return _welch_ci(d, ax, ay, _welch(d, ax, ay, x.size, y.size), level)


def betainc_regularized(a: float, b: float, x: float) -> float:
    """Regularised incomplete beta ``I_x(a, b)`` for ``a, b > 0``, ``0 ≤ x ≤ 1``.

    Continued fraction (modified Lentz) with the symmetry ``I_x(a,b) = 1 − I_{1−x}(b,a)``; relative
    accuracy ~1e-14 for the moderate ``a, b`` of t-tests.
    """
    if not (a > 0 and b > 0):
        raise ValueError("a and b must be > 0")
    if not 0.0 <= x <= 1.0:
        raise ValueError("x must be in [0, 1]")
    if x == 0.0 or x == 1.0:
        return x
    log_front = (math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
                 + a * math.log(x) + b * math.log1p(-x))
    if x < (a + 1.0) / (a + b + 2.0):
        return math.exp(log_front) * _betacf(a, b, x) / a
    return 1.0 - math.exp(log_front) * _betacf(b, a, 1.0 - x) / b


def _betacf(a: float, b: float, x: float) -> float:
    tiny, eps = 1e-300, 1e-16
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 10_000):
        m2 = 2 * m
        aa = m * (b - m) * x / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c
        c = c if abs(c) > tiny else tiny
        h *= d * c
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c
        c = c if abs(c) > tiny else tiny
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < eps:
            return h
    raise ArithmeticError("incomplete beta continued fraction did not converge")


# ------------------------------------------------------------------------------------------------
# verdict
# ------------------------------------------------------------------------------------------------

MIN_SEEDS = 5
ALPHA = 0.05


@dataclass(frozen=True)
class Comparison:
    """Swim (x) vs Swish (y) on one per-seed score."""

    score: str
    n_x: int
    n_y: int
    mean_x: float
    mean_y: float
    diff: float
    diff_ci: tuple[float, float]
    ci_x: tuple[float, float]
    ci_y: tuple[float, float]
    iqm_x: float
    iqm_y: float
    prob_improvement: float
    welch: WelchResult | None
    sd_x: float = float("nan")  # sample std (ddof = 1) of the per-seed scores; nan with one seed
    sd_y: float = float("nan")


def compare(x, y, score: str, n_boot: int = 10_000, seed: int = 0) -> Comparison:
    """All beyond-the-paper statistics of per-seed scores ``x`` (Swim) vs ``y`` (Swish).

    Bootstrap CIs use ``seed`` (x's CI), ``seed + 1`` (y's) and ``seed + 2`` (the difference).
    Welch's test is ``None`` when a sample has fewer than 2 seeds.
    """
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    welch = welch_t_test(x, y) if min(x.size, y.size) >= 2 else None
    return Comparison(
        score=score, n_x=int(x.size), n_y=int(y.size), mean_x=float(x.mean()), mean_y=float(y.mean()),
        diff=float(x.mean() - y.mean()), diff_ci=bootstrap_diff_ci(x, y, n_boot, seed=seed + 2),
        ci_x=bootstrap_ci(x, n_boot, seed=seed), ci_y=bootstrap_ci(y, n_boot, seed=seed + 1),
        iqm_x=iqm(x), iqm_y=iqm(y), prob_improvement=prob_improvement(x, y), welch=welch,
        sd_x=float(x.std(ddof=1)) if x.size >= 2 else float("nan"),
        sd_y=float(y.std(ddof=1)) if y.size >= 2 else float("nan"),
    )


POWER = 0.8


def detectable_difference(sd_x: float, n_x: int, sd_y: float, n_y: int,
                          power: float = POWER, alpha: float = ALPHA) -> float:
    """The smallest true difference of means that Welch's two-sided test at level ``alpha`` detects
    with probability ``power``, for samples of ``n_x``, ``n_y`` values whose standard deviations are
    ``sd_x``, ``sd_y`` (sample std, ``ddof=1``; at least 2 values per sample, else ``ValueError``).

    ``(t_{1−α/2, df} + t_{power, df}) · √(sd_x²/n_x + sd_y²/n_y)``, df the Welch–Satterthwaite degrees
    of freedom: the usual t approximation of the noncentral t (the far tail neglected), within 0.01
    of the exact power for df ≥ 4 (tests/test_stats_power.py checks it against scipy's noncentral t
    and a simulation). Both std zero: 0.
    """
    if n_x < 2 or n_y < 2:
        raise ValueError("a power calculation needs at least 2 values per sample")
    if not 0.5 <= power < 1:
        raise ValueError(f"power must be in [0.5, 1), got {power}")
    ax, ay = sd_x ** 2 / n_x, sd_y ** 2 / n_y
    if ax + ay == 0:
        return 0.0
    df = (ax + ay) ** 2 / (ax ** 2 / (n_x - 1) + ay ** 2 / (n_y - 1))
    return (student_t_quantile(1 - alpha / 2, df) + student_t_quantile(power, df)) * math.sqrt(ax + ay)


def seeds_to_detect(difference: float, sd_x: float, sd_y: float, power: float = POWER,
                    alpha: float = ALPHA, most: int = 1000) -> int | None:
    """The fewest seeds per side (the same on both) whose :func:`detectable_difference` at these
    standard deviations is at most ``|difference|``; None if more than ``most`` would be needed or
    ``difference`` is 0. By bisection: the detectable difference falls as n grows (a smaller standard
    error, a larger df, smaller t quantiles)."""
    def enough(n: int) -> bool:
        return detectable_difference(sd_x, n, sd_y, n, power, alpha) <= abs(difference)

    if difference == 0 or not enough(most):
        return None
    lo, hi = 1, most  # not enough(lo) (n = 1 has no test), enough(hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if enough(mid) else (mid, hi)
    return hi


def verdict(c: Comparison, x_name: str = "Swim", y_name: str = "Swish") -> str:
    """A plain-words conclusion for one comparison; says when the evidence is too weak.

    The evidence counts as sufficient only if both samples have at least ``MIN_SEEDS`` seeds, Welch's
    p < ``ALPHA`` and the bootstrap 95% CI of the difference excludes 0 (all three; :func:`sufficient`).
    """
    if c.diff == 0:
        relation = f"equals {y_name}'s"
    else:
        relation = f"is {'higher' if c.diff > 0 else 'lower'} than {y_name}'s by {_fmt_num(abs(c.diff))}"
    lo, hi = c.diff_ci
    ci = f"[{_fmt_num(lo)}, {_fmt_num(hi)}]" if _spread(c) else "n/a (one seed on a side)"
    observed = (f"{x_name}'s mean per-seed {c.score} score {relation} "
                f"(95% bootstrap CI of the difference {ci}, Welch p = {fmt_p(_p(c))}, "
                f"P({x_name} > {y_name}) = {c.prob_improvement:.2f})")
    reasons = _too_weak_because(c, x_name, y_name)
    if reasons:
        return f"Evidence too weak to conclude: {observed}; " + ", ".join(reasons) + "."
    better = "better" if c.diff > 0 else "worse"
    return f"{x_name} is {better} than {y_name} on this budget: {observed}."


def sufficient(c: Comparison) -> bool:
    """Whether :func:`verdict` counts the evidence as sufficient (no reason to call it too weak)."""
    return not _too_weak_because(c)


def _p(c: Comparison) -> float:
    return c.welch.p_two_sided if c.welch is not None else float("nan")


def _spread(c: Comparison) -> bool:
    """At least 2 seeds a side (with one, the bootstrap CI is a single point, not an interval)."""
    return min(c.n_x, c.n_y) >= 2


def _too_weak_because(c: Comparison, x_name: str = "Swim", y_name: str = "Swish") -> list[str]:
    """Why the evidence is too weak (:func:`verdict`'s rule); empty when it is sufficient."""
    reasons = []
    if min(c.n_x, c.n_y) < MIN_SEEDS:
        reasons.append(f"{x_name} has {counted(c.n_x, 'seed')} and {y_name} {counted(c.n_y, 'seed')} "
                       f"(at least {MIN_SEEDS} each are needed)")
    p = _p(c)
    if not (p < ALPHA):
        reasons.append(f"p ≥ {ALPHA}" if math.isfinite(p) else "no t-test possible")
    lo, hi = c.diff_ci
    if _spread(c) and lo <= 0.0 <= hi:
        reasons.append("the CI of the difference includes 0")
    return reasons


def _fmt_num(v: float) -> str:
    return f"{v:.1f}" if abs(v) >= 10 else f"{v:.3g}"


def fmt_p(p: float) -> str:
    """A p-value as the report prints it: 3 significant digits, scientific below 1e-4, 'n/a' if undefined."""
    if not math.isfinite(p):
        return "n/a"
    return f"{p:.3g}" if p >= 1e-4 else f"{p:.1e}"
