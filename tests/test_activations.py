"""Swim and its rivals against independent references: the float64 formula, mpmath, eq. (1),
finite differences and autodiff of the plain formula."""

import flax.linen as nn
import jax
import jax.numpy as jnp
import mpmath
import numpy as np
import pytest
from jax.test_util import check_grads

from swim_jax.policy import activations as activations_np
from swim_jax.activations import (
    ACTIVATIONS,
    SWIM_VARIANTS,
    Activation,
    ActivationParam,
    ActivationSetting,
    ActivationSpec,
    _check_registry,
    display_name,
    elu,
    get_activation,
    hard_swish,
    learnable_activations,
    legend_name,
    mish,
    param_names,
    parameter_defaults,
    relu,
    rsqrt_newton,
    swim,
    swim_reference,
    swish,
)

K = 0.5


def swim_f64(x, k=K):
    """The paper's formula in numpy float64."""
    x = np.asarray(x, np.float64)
    return x / 2 * (k * x / np.sqrt(1 + k * k * x * x) + 1)


def swim_prime_f64(x, k=K):
    """Eq. (1): f'(x) = ½(kx(k²x² + 2)/(1 + k²x²)^{3/2} + 1), numpy float64."""
    x = np.asarray(x, np.float64)
    return 0.5 * (k * x * (k * k * x * x + 2) / (1 + k * k * x * x) ** 1.5 + 1)


def swim_dk_f64(x, k=K):
    """∂f/∂k = x²/2 · (1 + k²x²)^{-3/2}, numpy float64."""
    x = np.asarray(x, np.float64)
    return 0.5 * x * x / (1 + k * k * x * x) ** 1.5


def swim_prime_mp(x, k=K):
    """Eq. (1) in mpmath arithmetic."""
    x, k = mpmath.mpf(x), mpmath.mpf(k)
    return (k * x * (k * k * x * x + 2) / (1 + k * k * x * x) ** 1.5 + 1) / 2


def swim_mp(x, k=K):
    """Swim in 60-digit arithmetic."""
    mpmath.mp.dps = 60
    x, k = mpmath.mpf(x), mpmath.mpf(k)
    return x / 2 * (k * x / mpmath.sqrt(1 + k * k * x * x) + 1)


GRID = np.concatenate(
    [np.linspace(-50, 50, 20001), -np.logspace(-8, 3, 2000), np.logspace(-8, 3, 2000)]
).astype(np.float32)

swim_f32 = jax.jit(lambda x: swim(x, K))
swim_grad_f32 = jax.jit(jax.vmap(jax.grad(lambda x: swim(x, K))))


# --------------------------------------------------------------------------- values


def test_values_f32_against_float64_formula():
    y = np.asarray(swim_f32(GRID), np.float64)
    ref = swim_f64(GRID)
    x = GRID.astype(np.float64)
    pos = x >= 0
    # x ≥ 0: 1 + s ≥ 1, no cancellation: relative error (measured 4.3e-7 with the default rsqrt).
    rel = np.abs(y - ref)[pos] / np.maximum(np.abs(ref[pos]), np.finfo(np.float32).tiny)
    assert rel.max() < 1e-6
    # x < 0: 1 + s cancels as s → −1; the error is absolute, ≤ 1e-6·max(1, |x|) (measured 3.8e-7).
    err = np.abs(y - ref)[~pos] / np.maximum(1.0, np.abs(x[~pos]))
    assert err.max() < 1e-6


def test_values_f64_against_float64_formula():
    x = GRID.astype(np.float64)
    with jax.enable_x64(True):
        y = np.asarray(jax.jit(lambda x: swim(x, K))(jnp.asarray(x)))
    assert y.dtype == np.float64
    np.testing.assert_allclose(y, swim_f64(x), rtol=1e-13, atol=1e-14 * np.maximum(1, np.abs(x)).max())


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize(
    "x", [1e-30, 1e-10, 1e-3, 0.7, 3.0, 1e3, 1e10, 1e30, -1e-30, -1e-10, -1e-3, -0.7, -3.0, -1e3, -1e10, -1e30]
)
def test_values_against_mpmath_at_extreme_inputs(dtype, x):
    with jax.enable_x64(dtype == "float64"):
        y = float(jax.jit(lambda x: swim(x, K))(jnp.asarray(x, dtype)))
    exact = swim_mp(x)
    eps = float(np.finfo(dtype).eps)
    if x > 0:
        assert abs(mpmath.mpf(y) / exact - 1) < 8 * eps
    else:
        # Negative tail: |f| ≤ 0.31, accuracy is absolute (eps-scaled), and never NaN or positive.
        assert y <= 0.0
        assert abs(mpmath.mpf(y) - exact) < 8 * eps * max(1.0, abs(x)) ** 0.5 + 1e-300


@pytest.mark.parametrize("dtype,huge", [("float32", 1e30), ("float32", 3.4e38), ("float16", 6e4), ("bfloat16", 3e38), ("float64", 1e300)])
def test_no_overflow_and_limits(dtype, huge):
    with jax.enable_x64(dtype == "float64"):
        x = jnp.asarray([huge, -huge, jnp.inf, -jnp.inf, jnp.nan, 0.0], dtype)
        y = swim(x, K)
        d = jax.vmap(jax.grad(lambda v: swim(v, K)))(x)
        assert y.dtype == x.dtype and d.dtype == x.dtype
        y, d = np.asarray(y, np.float64), np.asarray(d, np.float64)
        big = float(x[0])
    assert y[0] == pytest.approx(big, rel=1e-2)  # f(x) → x
    assert y[1] == 0.0  # f(x) → 0⁻ (rounds to −0)
    assert y[2] == np.inf and y[3] == 0.0
    assert np.isnan(y[4]) and y[5] == 0.0
    assert d[0] == 1.0 and d[1] == 0.0 and d[2] == 1.0 and d[3] == 0.0
    assert np.isnan(d[4]) and d[5] == 0.5


@pytest.mark.parametrize("dtype", ["float16", "bfloat16", "float32"])
def test_no_nan_from_any_finite_input(dtype):
    finfo = jnp.finfo(dtype)
    mags = np.logspace(np.log10(float(finfo.tiny)), np.log10(float(finfo.max)), 4001)
    x = jnp.asarray(np.concatenate([mags, -mags, [float(finfo.max), -float(finfo.max)]]), dtype)
    y = swim(x, K)
    d = jax.vmap(jax.grad(lambda v: swim(v, K)))(x)
    dk = jax.vmap(jax.grad(lambda kk, v: swim(v, kk)), (None, 0))(jnp.asarray(K, dtype), x)
    for arr in (y, d, dk):
        assert arr.dtype == x.dtype
        assert bool(jnp.all(jnp.isfinite(arr)))


def test_nan_in_nan_out():
    y = swim(jnp.asarray([jnp.nan, 1.0]), K)
    assert bool(jnp.isnan(y[0])) and bool(jnp.isfinite(y[1]))


# --------------------------------------------------------------------------- derivatives


def test_derivative_against_eq1_f32():
    d = np.asarray(swim_grad_f32(GRID), np.float64)
    np.testing.assert_allclose(d, swim_prime_f64(GRID), rtol=0, atol=2e-6)  # measured 6.8e-7


def test_derivative_against_eq1_and_plain_autodiff_f64():
    x = np.linspace(-40, 40, 4001)
    with jax.enable_x64(True):
        xj = jnp.asarray(x)
        d = np.asarray(jax.vmap(jax.grad(lambda v: swim(v, K)))(xj))
        d_plain = np.asarray(jax.vmap(jax.grad(lambda v: swim_reference(v, K)))(xj))
        dk = np.asarray(jax.vmap(jax.grad(lambda kk, v: swim(v, kk)), (None, 0))(jnp.asarray(K), xj))
        dk_plain = np.asarray(jax.vmap(jax.grad(lambda kk, v: swim_reference(v, kk)), (None, 0))(jnp.asarray(K), xj))
        dd = np.asarray(jax.vmap(jax.grad(jax.grad(lambda v: swim(v, K))))(xj))
        dd_plain = np.asarray(jax.vmap(jax.grad(jax.grad(lambda v: swim_reference(v, K))))(xj))
    np.testing.assert_allclose(d, swim_prime_f64(x), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(d, d_plain, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(dk, swim_dk_f64(x), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(dk, dk_plain, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(dd, dd_plain, rtol=1e-10, atol=1e-13)


@pytest.mark.parametrize("variant", sorted(SWIM_VARIANTS))
def test_finite_differences_first_and_second_order_f64(variant):
    fn = SWIM_VARIANTS[variant]
    with jax.enable_x64(True):
        x = jnp.asarray([-7.0, -2.3, -0.4, 0.0, 0.3, 1.7, 9.0])
        k = jnp.asarray(0.5)
        # The Newton variants stop at their f32 accuracy in f64 too; FD tolerances reflect that.
        tol = 1e-6 if variant in ("default", "rsqrt") else 1e-2
        check_grads(lambda x, k: fn(x, k), (x, k), order=2, modes=("fwd", "rev"), atol=tol, rtol=tol)
        check_grads(lambda x: fn(x, jnp.asarray(1.7)), (x,), order=2, modes=("fwd", "rev"), atol=tol, rtol=tol)


def test_finite_differences_f32():
    x = jnp.asarray([-5.0, -1.1, 0.2, 2.5], jnp.float32)
    check_grads(lambda x, k: swim(x, k), (x, jnp.float32(0.5)), order=1, modes=("fwd", "rev"), atol=2e-2, rtol=2e-2)


def test_rsqrt_newton_accuracy_every_float32_mantissa():
    """Two binades cover every (mantissa, exponent parity) pair, which fixes the relative error."""
    bits = np.arange(0x3F800000, 0x40800000, 61, dtype=np.uint32)  # every 61st of 2^24 floats
    v = bits.view(np.float32)
    exact = 1 / np.sqrt(v.astype(np.float64))
    y2 = np.asarray(jax.jit(lambda v: rsqrt_newton(v, 2))(v), np.float64)
    y1 = np.asarray(jax.jit(lambda v: rsqrt_newton(v, 1))(v), np.float64)
    assert np.max(np.abs(y2 / exact - 1)) < 1e-6  # measured 7.5e-7 over all 2^24
    assert 1e-4 < np.max(np.abs(y1 / exact - 1)) < 1e-3  # one step is not enough: 6.5e-4
    with jax.enable_x64(True):
        v64 = np.linspace(1e-3, 1e3, 10001)
        y4 = np.asarray(rsqrt_newton(jnp.asarray(v64), 4))
    assert np.max(np.abs(y4 * np.sqrt(v64) - 1)) < 1e-14


# --------------------------------------------------------------------------- the paper's properties


def _dense_grid():
    return np.linspace(-20, 20, 400001)


def test_properties_unbounded_above_bounded_below_non_monotonic_smooth():
    x = _dense_grid()
    with jax.enable_x64(True):
        y = np.asarray(swim(jnp.asarray(x), K))
        d = np.asarray(jax.vmap(jax.grad(lambda v: swim(v, K)))(jnp.asarray(x)))
        dd = np.asarray(jax.vmap(jax.grad(jax.grad(lambda v: swim(v, K))))(jnp.asarray(x)))
        big = np.asarray(swim(jnp.asarray([1e3, 1e6, 1e9]), K))
    assert np.all(np.diff(big) > 0) and big[-1] > 0.99e9  # unbounded above: f(x) ~ x
    assert y.min() > -0.31  # bounded below
    assert (d < 0).any() and (d > 0).any()  # non-monotonic
    # smooth: f' and f'' are continuous (no jumps between neighbouring grid points)
    h = x[1] - x[0]
    assert np.max(np.abs(np.diff(d))) < 1.0 * h and np.max(np.abs(np.diff(dd))) < 2.0 * h


def _minimum(fn):
    x = _dense_grid()
    with jax.enable_x64(True):
        y = np.asarray(fn(jnp.asarray(x)))
    i = int(np.argmin(y))
    return x[i], y[i]


def test_minimum_vs_swish():
    x_swim, y_swim = _minimum(lambda x: swim(x, K))
    x_swish, y_swish = _minimum(lambda x: swish(x, 1.0))
    # Independent reference: the root of eq. (1), f'(x) = 0, found by mpmath.
    mpmath.mp.dps = 30
    root = mpmath.findroot(lambda v: swim_prime_mp(v), -1.5)
    assert x_swim == pytest.approx(float(root), abs=1e-4)  # x* = −1.57230
    assert y_swim == pytest.approx(float(swim_mp(root)), abs=1e-9)  # f(x*) = −0.300283
    assert y_swim == pytest.approx(-0.300283, abs=1e-6)
    # Swish(β=1): minimum at x ≈ −1.27846, f ≈ −0.278465: both about −0.3, as the paper says;
    # Swim's is deeper and further left.
    assert x_swish == pytest.approx(-1.27846, abs=1e-4)
    assert y_swish == pytest.approx(-0.278465, abs=1e-6)
    assert y_swim < y_swish and x_swim < x_swish


def test_close_to_swish_on_minus6_6():
    x = np.linspace(-6, 6, 120001)
    with jax.enable_x64(True):
        gap = np.abs(np.asarray(swim(jnp.asarray(x), K)) - np.asarray(swish(jnp.asarray(x), 1.0)))
    # measured: max |Swim(k=0.5) − Swish(β=1)| over [−6, 6] = 0.14546, at x ≈ −4.864
    assert gap.max() == pytest.approx(0.14546, abs=1e-4)
    assert x[np.argmax(gap)] == pytest.approx(-4.864, abs=2e-3)


def test_negative_inputs_saturate_more_slowly_than_swish():
    x = np.array([-3.0, -5.0, -10.0, -20.0, -50.0])
    with jax.enable_x64(True):
        ys = np.asarray(swim(jnp.asarray(x), K))
        yw = np.asarray(swish(jnp.asarray(x), 1.0))
    assert np.all(ys < yw)  # Swim bounds Swish from below (larger negative values)
    assert np.all(np.abs(ys) > 10 * np.abs(yw)[[-1]].max())
    # Swim decays like 1/(4k²|x|) (polynomially), Swish like |x|e^{−|x|}
    np.testing.assert_allclose(ys[-2:], 1 / (4 * K * K * x[-2:]), rtol=2e-2)


# --------------------------------------------------------------------------- compositions


def test_jit_vmap_grad_jvp_vjp_compose():
    x = jnp.linspace(-4, 4, 9)
    direct = swim(x, K)
    np.testing.assert_allclose(jax.jit(swim)(x, K), direct, rtol=1e-6)
    np.testing.assert_allclose(jax.vmap(swim, (0, None))(x, K), direct, rtol=1e-6)
    y, t = jax.jvp(lambda v: swim(v, K), (x,), (jnp.ones_like(x),))
    np.testing.assert_allclose(t, swim_prime_f64(np.asarray(x)), atol=2e-6)
    y2, vjp = jax.vjp(lambda v: swim(v, K), x)
    np.testing.assert_allclose(vjp(jnp.ones_like(x))[0], t, rtol=1e-6)
    np.testing.assert_allclose(jax.jit(jax.grad(lambda v: swim(v, K).sum()))(x), t, rtol=1e-6, atol=2e-7)


def test_vmap_over_k_and_grad_wrt_k():
    x = jnp.linspace(-3, 3, 7)
    ks = jnp.asarray([0.25, 0.5, 1.0, 2.0])
    ys = jax.jit(jax.vmap(swim, (None, 0)))(x, ks)
    for i, k in enumerate([0.25, 0.5, 1.0, 2.0]):
        np.testing.assert_allclose(ys[i], swim_f64(np.asarray(x), k), atol=2e-6)
    gk = jax.jit(jax.vmap(jax.grad(lambda k: swim(x, k).sum())))(ks)
    for i, k in enumerate([0.25, 0.5, 1.0, 2.0]):
        assert float(gk[i]) == pytest.approx(swim_dk_f64(np.asarray(x), k).sum(), rel=2e-5)


@pytest.mark.parametrize("dtype", ["float16", "bfloat16", "float32"])
@pytest.mark.parametrize("name", sorted(ACTIVATIONS))
def test_dtype_preserved(name, dtype):
    x = jnp.linspace(-3, 3, 5).astype(dtype)
    fn = get_activation(name)
    assert fn(x).dtype == x.dtype
    assert jax.grad(lambda v: fn(v).astype(jnp.float32).sum())(x).dtype == x.dtype


# --------------------------------------------------------------------------- rivals and registry


def test_rivals_against_formulas():
    x = np.linspace(-8, 8, 1601)
    with jax.enable_x64(True):
        xj = jnp.asarray(x)
        np.testing.assert_allclose(swish(xj, 1.3), x / (1 + np.exp(-1.3 * x)), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(relu(xj), np.maximum(x, 0))
        np.testing.assert_allclose(hard_swish(xj), x * np.clip(x + 3, 0, 6) / 6, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(mish(xj), x * np.tanh(np.log1p(np.exp(x))), rtol=1e-12, atol=1e-15)


def test_registry_and_errors():
    assert set(ACTIVATIONS) >= {"swim", "swish", "relu", "hard_swish", "mish"}
    f = get_activation("swim", k=0.75)
    np.testing.assert_allclose(f(jnp.asarray([1.0, -1.0])), swim_f64([1.0, -1.0], 0.75), rtol=1e-6)
    with pytest.raises(ValueError, match="unknown activation 'swimm'; valid: .*swim.*swish"):
        get_activation("swimm")
    with pytest.raises(ValueError, match="unknown parameter.*beta.*valid: k"):
        get_activation("swim", beta=1.0)
    for bad in (0.0, -0.5, float("inf"), float("nan")):
        with pytest.raises(ValueError, match="must be finite and > 0"):
            get_activation("swim", k=bad)
        with pytest.raises(ValueError, match="must be finite and > 0"):
            swim(jnp.ones(2), bad)
    with pytest.raises(ValueError, match="valid: none"):
        get_activation("relu", k=1.0)


def test_flax_module_fixed_and_learnable_k():
    x = jnp.linspace(-2, 2, 5)
    fixed = Activation(kind="swim", params={"k": 0.75})
    assert fixed.init(jax.random.key(0), x) == {}
    np.testing.assert_allclose(fixed.apply({}, x), swim_f64(np.asarray(x), 0.75), atol=2e-6)

    class TwoLayers(nn.Module):
        @nn.compact
        def __call__(self, v):
            v = Activation(kind="swim", params={"k": 0.5}, learnable=True)(nn.Dense(4)(v))
            return Activation(kind="swim", params={"k": 0.5}, learnable=True)(nn.Dense(1)(v))

    net = TwoLayers()
    params = net.init(jax.random.key(1), x[:, None])
    def k_leaves(tree):
        return [leaf for path, leaf in jax.tree_util.tree_leaves_with_path(tree) if path[-1].key == "k"]

    ks = k_leaves(params)
    assert len(ks) == 2 and all(float(k) == 0.5 for k in ks)  # one k per layer
    grads = jax.grad(lambda p: net.apply(p, x[:, None]).sum())(params)
    gks = k_leaves(grads)
    assert all(float(jnp.abs(g)) > 0 for g in gks)
    with pytest.raises(ValueError, match="no parameter to learn"):
        Activation(kind="relu", learnable=True).init(jax.random.key(0), x)
    with pytest.raises(ValueError, match="needs kind="):
        Activation().init(jax.random.key(0), x)


def test_swim_variant_is_an_explicit_argument_so_programs_never_mix_kernels():
    """The kernel is an argument (``swim(x, k, variant)``, or the activation name ``swim[v]``),
    not a global switch: a jitted function keeps its own kernel whatever is traced after it."""
    x = jnp.asarray([0.3, -2.0])
    traced = str(jax.make_jaxpr(lambda v: swim(v, K, "rsqrt"))(x))
    assert "= rsqrt " in traced and "rsqrt_newton" not in traced
    default = str(jax.make_jaxpr(lambda v: swim(v, K))(x))
    assert "rsqrt_newton" in default and "= rsqrt " not in default  # default f32 kernel: Newton
    by_name = str(jax.make_jaxpr(get_activation("swim[rsqrt]", k=K))(x))
    assert "= rsqrt " in by_name
    f_default, f_rsqrt = jax.jit(get_activation("swim", k=K)), jax.jit(get_activation("swim[rsqrt]", k=K))
    a, b = f_default(x), f_rsqrt(x)  # compiled in turn; each keeps its own kernel
    np.testing.assert_array_equal(np.asarray(f_default(x)), np.asarray(a))
    np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-5)  # two float32 kernels
    with pytest.raises(ValueError, match="unknown Swim variant 'fast'; valid: default, rsqrt"):
        swim(x, K, "fast")
    with pytest.raises(ValueError, match="unknown activation 'swim\\[fast\\]'"):
        get_activation("swim[fast]")


# --------------------------------------------------------------------------- ELU(α)


def elu_f64(x, alpha):
    """ELU in numpy float64: x for x > 0, α(eˣ − 1) otherwise."""
    x = np.asarray(x, np.float64)
    return np.where(x > 0, x, alpha * np.expm1(np.minimum(x, 0)))


def elu_prime_f64(x, alpha):
    """f'(x) = 1 for x > 0, α·eˣ otherwise."""
    x = np.asarray(x, np.float64)
    return np.where(x > 0, 1.0, alpha * np.exp(np.minimum(x, 0)))


def elu_dalpha_f64(x):
    """∂f/∂α = eˣ − 1 for x ≤ 0, 0 otherwise."""
    x = np.asarray(x, np.float64)
    return np.where(x > 0, 0.0, np.expm1(np.minimum(x, 0)))


ALPHAS = (0.25, 1.0, 1.7)


@pytest.mark.parametrize("alpha", ALPHAS)
def test_elu_values_against_float64_formula(alpha):
    x64 = GRID.astype(np.float64)
    with jax.enable_x64(True):
        y64 = np.asarray(jax.jit(lambda v: elu(v, alpha))(jnp.asarray(x64)))
    assert y64.dtype == np.float64
    np.testing.assert_allclose(y64, elu_f64(x64, alpha), rtol=1e-15, atol=0)
    y32 = np.asarray(jax.jit(lambda v: elu(v, alpha))(GRID), np.float64)
    np.testing.assert_allclose(y32, elu_f64(GRID, alpha), rtol=4 * np.finfo(np.float32).eps, atol=0)
    np.testing.assert_allclose(get_activation("elu", alpha=alpha)(GRID), y32, rtol=0, atol=0)


@pytest.mark.parametrize("alpha", ALPHAS)
def test_elu_derivatives_against_formula_and_finite_differences_f64(alpha):
    x = np.concatenate([np.linspace(-40, 40, 4000), [-1e-8, 1e-8, 0.0]])  # 4000 points: 0 is not on the grid
    with jax.enable_x64(True):
        xj, aj = jnp.asarray(x), jnp.asarray(alpha)
        d = np.asarray(jax.vmap(jax.grad(lambda v: elu(v, alpha)))(xj))
        da = np.asarray(jax.vmap(jax.grad(lambda a, v: elu(v, a)), (None, 0))(aj, xj))
        off_kink = jnp.asarray([-7.0, -2.3, -0.4, 0.3, 1.7, 9.0])  # FD steps never cross x = 0
        check_grads(lambda v, a: elu(v, a), (off_kink, aj), order=2, modes=("fwd", "rev"), atol=1e-7, rtol=1e-7)
    # d/dx expm1 is computed as expm1(x) + 1: exact to an absolute eps·α, not relative far left
    np.testing.assert_allclose(d, elu_prime_f64(x, alpha), rtol=1e-15, atol=np.finfo(np.float64).eps * alpha)
    np.testing.assert_allclose(da, elu_dalpha_f64(x), rtol=1e-15, atol=0)
    assert d[-1] == alpha  # at the kink: the left derivative α·e⁰


def test_elu_finite_differences_f32():
    x = jnp.asarray([-5.0, -1.1, 0.2, 2.5], jnp.float32)
    check_grads(lambda x, a: elu(x, a), (x, jnp.float32(0.6)), order=1, modes=("fwd", "rev"), atol=2e-2, rtol=2e-2)


@pytest.mark.parametrize("dtype", ["float16", "bfloat16", "float32", "float64"])
def test_elu_limits_no_overflow_no_nan(dtype):
    with jax.enable_x64(dtype == "float64"):
        big = float(jnp.finfo(dtype).max)
        x = jnp.asarray([big, -big, jnp.inf, -jnp.inf, jnp.nan, 0.0], dtype)
        y = elu(x, 0.5)
        d = jax.vmap(jax.grad(lambda v: elu(v, 0.5)))(x)
        assert y.dtype == x.dtype and d.dtype == x.dtype
        y, d = np.asarray(y, np.float64), np.asarray(d, np.float64)
    assert y[0] == big and y[1] == -0.5 and y[2] == np.inf and y[3] == -0.5
    assert np.isnan(y[4]) and y[5] == 0.0
    assert d[0] == 1.0 and d[1] == 0.0 and d[2] == 1.0 and d[3] == 0.0  # no inf·0 from the unselected branch
    assert np.isnan(d[4]) and d[5] == 0.5  # at the kink x = 0: the left derivative α·e⁰


def test_elu_vmap_over_alpha_and_learnable_per_layer():
    x = jnp.linspace(-3, 3, 7)
    alphas = jnp.asarray([0.25, 1.0, 2.0])
    ys = jax.jit(jax.vmap(elu, (None, 0)))(x, alphas)
    for i, a in enumerate([0.25, 1.0, 2.0]):
        np.testing.assert_allclose(ys[i], elu_f64(np.asarray(x), a), rtol=1e-6)
    layer = Activation(kind="elu", params={"alpha": 0.5}, learnable=True)
    params = layer.init(jax.random.key(0), x)
    assert float(params["params"]["alpha"]) == 0.5
    g = jax.grad(lambda p: layer.apply(p, x).sum())(params)
    assert float(g["params"]["alpha"]) == pytest.approx(elu_dalpha_f64(np.asarray(x)).sum(), rel=1e-6)
    with pytest.raises(ValueError, match="must be finite and > 0"):
        get_activation("elu", alpha=0.0)
    with pytest.raises(ValueError, match="unknown parameter.*k.*valid: alpha"):
        get_activation("elu", k=1.0)


# --------------------------------------------------------------------------- what derives from the registry


def test_registry_derives_parameters_labels_and_legends():
    assert parameter_defaults() == {"k": 0.5, "beta": 1.0, "alpha": 1.0}
    assert learnable_activations() == ("swim", "swish", "elu")
    assert param_names("elu") == ("alpha",) and param_names("swim[rsqrt]") == ("k",) and param_names("nope") == ()
    label = lambda act: ActivationSetting.from_config(act).label
    assert label({"name": "swim", "k": 0.25, "beta": 2.0, "alpha": 3.0}) == "swim(k=0.25)"  # others' params ignored
    assert label({"name": "swish", "beta": 1.0, "learnable": True}) == "swish+learnable"
    assert label({"name": "elu", "alpha": 0.5}) == "elu(alpha=0.5)"
    assert label({"name": "elu", "k": 0.75}) == "elu"  # a config.yaml without alpha: the default
    assert label({"name": "relu", "k": 0.75}) == "relu"
    assert ActivationSetting.from_config({"name": "elu"}).params == (("alpha", 1.0),)
    assert [display_name(lab) for lab in ("swim", "swim(k=0.75)+learnable", "elu(alpha=0.5)", "mish", "swim[tau=0.01]")] \
        == ["Swim", "Swim(k=0.75)+learnable", "ELU(alpha=0.5)", "mish", "swim[tau=0.01]"]
    assert [legend_name(n) for n in ("swim", "swish", "relu", "elu")] == ["Swim (k=0.5)", "Swish (β=1)", "ReLU", "ELU (α=1)"]
    assert ActivationParam("t", 0.5, 0.0, 1.0).problem(1.0) == "it must be finite and in (0, 1)"


def test_registry_refuses_one_parameter_name_with_two_defaults():
    ok = {"elu": ActivationSpec(elu, (ActivationParam("alpha", 1.0),), numpy=activations_np.elu)}
    _check_registry(ok)
    with pytest.raises(ValueError, match="one config field, one default"):
        _check_registry({**ok, "b": ActivationSpec(elu, (ActivationParam("alpha", 0.01),))})
    with pytest.raises(ValueError, match="reserved"):
        _check_registry({"c": ActivationSpec(elu, (ActivationParam("learnable", 1.0),))})
    with pytest.raises(ValueError, match="is invalid"):
        _check_registry({"d": ActivationSpec(elu, (ActivationParam("alpha", -1.0),))})
