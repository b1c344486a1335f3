"""Scratch of docs/BENCHMARKS.md §14 (kept as run; dropped): envs/small_linalg's Cholesky and solves
written right-looking (elementwise whole-matrix updates, no scatters) against the landed ones.

    python runs/curated/bench/mjx-cholesky-right-looking-ab-20261203.py Walker2d-v5 5
"""
import sys, statistics
import jax, jax.numpy as jnp, numpy as np
import envs
from envs import bench, small_linalg
from swim_jax.timing import time_interleaved

def chol_rl(a):
    n = a.shape[-1]
    u = jnp.zeros_like(a)
    ar = jnp.arange(n)
    for j in range(n):
        row = jnp.where(ar >= j, a[j] / jnp.sqrt(a[j, j]), 0)
        a = a - row[:, None] * row[None, :]
        u = u + jnp.where((ar == j)[:, None], row[None, :], 0)
    return u

def solve_rl(u, b):
    n = u.shape[-1]
    ar = jnp.arange(n)
    oh = lambda j: (ar == j).reshape((n,) + (1,) * (b.ndim - 1))
    col = lambda v: v.reshape((n,) + (1,) * (b.ndim - 1))
    y = jnp.zeros_like(b)
    for j in range(n):
        yj = b[j] / u[j, j]
        b = b - col(u[j]) * yj
        y = y + jnp.where(oh(j), yj, 0)
    x = jnp.zeros_like(b)
    for j in reversed(range(n)):
        xj = y[j] / u[j, j]
        y = y - col(u[:, j]) * xj
        x = x + jnp.where(oh(j), xj, 0)
    return x

# check
rng = np.random.default_rng(0)
A = rng.normal(size=(9, 9)); A = A @ A.T + 9 * np.eye(9); B = rng.normal(size=(9, 3))
U = np.asarray(chol_rl(jnp.asarray(A, jnp.float32))); print("chol err", np.abs(U.T @ U - A).max())
X = np.asarray(solve_rl(jnp.asarray(U), jnp.asarray(B, jnp.float32))); print("solve err", np.abs(A @ X - B).max())

env_id, batch = sys.argv[1], int(sys.argv[2]); scan_len = 50
orig = (small_linalg.cholesky_upper, small_linalg.cho_solve_upper)
cands = {}
for name, fns in (("unrolled rows (now)", orig), ("right-looking elementwise", (chol_rl, solve_rl))):
    small_linalg.cholesky_upper, small_linalg.cho_solve_upper = fns
    f, states, key = bench.make_rollout(envs.make(env_id), batch, scan_len, False)
    c = f.lower(states, key).compile()
    small_linalg.cholesky_upper, small_linalg.cho_solve_upper = orig
    out = c(states, key)
    print(name, "hlo lines", c.as_text().count("\n"), flush=True)
    cands[name] = lambda c=c, s=states, k=key: jax.block_until_ready(c(s, k))
t = time_interleaved(cands, repeats=int(sys.argv[3]) if len(sys.argv) > 3 else 7, warmup=1)
base = statistics.median(t["unrolled rows (now)"].samples)
for n in cands:
    m = statistics.median(t[n].samples)
    print(f"{n:40s} {1000*m/scan_len:7.3f} ms/step  {m/base:.3f}x  rounds {[round(a/b,3) for a,b in zip(t[n].samples, t['unrolled rows (now)'].samples)]}")
