"""swim_jax.envs.physics.small_linalg (plain-JAX Cholesky used for MJX's M and the Newton Hessian) vs NumPy float64."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from swim_jax.envs.physics.small_linalg import cho_solve_upper, cholesky_upper


@pytest.mark.parametrize("n", [1, 6, 14])
def test_cholesky_and_solves_match_numpy(n):
    rng = np.random.default_rng(n)
    g = rng.normal(size=(n, n))
    a = (g @ g.T + n * np.eye(n)).astype(np.float32)  # SPD, float32 as in the default run
    b, bm = rng.normal(size=n).astype(np.float32), rng.normal(size=(n, 3)).astype(np.float32)
    # jitted, as MJX runs them (eagerly, each of the unrolled steps compiled on its own: 161 compiles at n = 14)
    u = np.asarray(jax.jit(cholesky_upper)(jnp.asarray(a)), np.float64)
    assert np.all(np.tril(u, -1) == 0) and np.all(np.diag(u) > 0)
    np.testing.assert_allclose(u, np.linalg.cholesky(a.astype(np.float64)).T, rtol=1e-5, atol=1e-5)
    a64 = a.astype(np.float64)
    for rhs in (b, bm):
        x = np.asarray(jax.jit(cho_solve_upper)(jnp.asarray(u, jnp.float32), jnp.asarray(rhs)), np.float64)
        np.testing.assert_allclose(x, np.linalg.solve(a64, rhs.astype(np.float64)), rtol=1e-4, atol=1e-5)
