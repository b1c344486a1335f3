"""bench sgemm: the update's products on one core, XLA against NumPy's OpenBLAS. The canonical
[B, M, K] @ [B, K, N] layout equals lax.dot_general for every dimension-number form the update uses;
a tiny run times every product of one update and adds them up as the roofline does."""

from __future__ import annotations

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from swim_jax.bench import roofline, sgemm


@pytest.mark.parametrize("lhs, rhs, dims", [
    ((8, 5), (5, 3), (((1,), (0,)), ((), ()))),          # x @ W
    ((8, 5), (8, 3), (((0,), (0,)), ((), ()))),          # xᵀ g (a kernel's gradient)
    ((8, 5), (3, 5), (((1,), (1,)), ((), ()))),          # g Wᵀ
    ((2, 8, 5), (2, 5, 3), (((2,), (1,)), ((0,), (0,)))),  # the twin critics, batched
    ((2, 8, 5), (2, 8, 3), (((1,), (1,)), ((0,), (0,)))),
])
def test_canonical_layout_is_the_dot_general(lhs, rhs, dims):
    rng = np.random.default_rng(0)
    x, y = rng.normal(size=lhs).astype(np.float32), rng.normal(size=rhs).astype(np.float32)
    d = roofline.Dot(lhs, rhs, dims, "float32", "float32")
    a, b = sgemm.canonical(d, x, y)
    ref = np.asarray(jax.lax.dot_general(jnp.asarray(x), jnp.asarray(y), dims, precision="highest"))
    np.testing.assert_allclose(np.matmul(a, b).reshape(ref.shape), ref, rtol=1e-5, atol=1e-5)
    assert a.flags["C_CONTIGUOUS"] and b.flags["C_CONTIGUOUS"]


def test_tiny_run_times_every_product_of_an_update(capsys):
    tiny = ["agent.hidden=[16,16]", "agent.batch_size=16"]
    assert sgemm.main(["--config", "hopper_relu", *(f"--set={t}" for t in tiny), "--repeats", "1", "--loop", "2"]) == 0
    res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert res["cpu"].startswith("one core") and res["products"] and res["blas"]
    assert res["update_matmul_gflop"] > 0 and res["xla_fraction_of_blas"] == pytest.approx(
        res["update_blas_s"] / res["update_xla_s"])
    assert sgemm.main(["--config", "hopper_relu", "--set=matmul_dtype=bfloat16", "--repeats", "1"]) == 2
    assert "float32 products only" in capsys.readouterr().err
