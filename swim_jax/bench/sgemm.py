"""The update's products against a tuned sgemm on one core: XLA's kernels vs OpenBLAS (NumPy), shape by shape.

    python -m swim_jax.bench sgemm --config cheetah_relu [--repeats 7] [--set KEY=VALUE]

The physical anchor of the update's speed. Every distinct ``dot_general`` of one TD3 update
(``swim_jax.bench.roofline.update_dots``: operand shapes and dimension numbers as the program
multiplies them) is timed twice on the same random operands, interleaved over ``--repeats`` rounds,
in a child process pinned to one CPU (XLA's intra-op threading off, ``OPENBLAS_NUM_THREADS=1``):

- XLA: the product compiled alone (``roofline._product_loop``, ``--loop`` products per call);
- BLAS: NumPy's ``matmul`` (the OpenBLAS NumPy ships) on the operands laid out once, outside the
  timing, as the plain ``[B, M, K] @ [B, K, N]`` product the ``dot_general`` is (B the batch
  dimensions, M and N the free ones, K the contracted), ``--loop`` products into one output buffer.

Per shape: GFLOP/s of both and XLA/BLAS; over one update (averaged over the policy delay, as the
roofline): Σ FLOPs / Σ seconds of both, i.e. how close XLA's own kernels come to a tuned sgemm
here. float32 only (NumPy has no bfloat16 product). JSON on the last line of stdout.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

from swim_jax.bench import timing
from swim_jax.io import cli_parser


def canonical(d, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The operands of the product ``d`` (a ``roofline.Dot``) as contiguous ``[B, M, K]`` and
    ``[B, K, N]`` arrays: ``x``'s batch, free and contracted axes moved in that order, ``y``'s batch,
    contracted and free ones, so that ``a @ b`` is the ``dot_general`` (its output ``[B, M, N]``)."""
    (lc, rc), (lb, rb) = d.dimension_numbers
    lf = [i for i in range(x.ndim) if i not in lc and i not in lb]
    rf = [i for i in range(y.ndim) if i not in rc and i not in rb]
    size = lambda a, axes: int(np.prod([a.shape[i] for i in axes])) if axes else 1
    a = np.ascontiguousarray(np.transpose(x, [*lb, *lf, *lc]).reshape(size(x, lb), size(x, lf), size(x, lc)))
    b = np.ascontiguousarray(np.transpose(y, [*rb, *rc, *rf]).reshape(size(y, rb), size(y, rc), size(y, rf)))
    return a, b


def _blas_loop(a: np.ndarray, b: np.ndarray, n: int):
    """``n`` products ``a @ b`` into one preallocated output (a batch of one: a plain 2-D sgemm)."""
    a2, b2 = (a[0], b[0]) if a.shape[0] == 1 else (a, b)
    out = np.matmul(a2, b2)

    def run(_round=None):
        for _ in range(n):
            np.matmul(a2, b2, out=out)
        return out

    return run


def measure(config: str, overrides: list[str], repeats: int, loop: int) -> dict:
    """Both timings of every distinct product of one update of ``config`` in this process (meant to
    be pinned to one core: :func:`main` runs it so)."""
    import jax
    import jax.numpy as jnp

    from swim_jax import config as cfgmod
    from swim_jax.bench.roofline import _product_loop, update_dots
    from swim_jax.run.programs import build

    cfg = cfgmod.resolve(config, overrides)
    if cfg.matmul_dtype != "full" or cfg.precision != "float32":
        raise cfgmod.ConfigError("bench sgemm compares float32 products only (matmul_dtype=full, precision=float32)")
    _env, _eval, agent = build(cfg)
    by_kind = update_dots(agent)
    dots = sorted(set(d for ds in by_kind.values() for d in ds), key=lambda d: (d.lhs, d.rhs, d.dimension_numbers))
    candidates = {}
    for i, d in enumerate(dots):
        rng = np.random.default_rng(i)
        x, y = rng.normal(size=d.lhs).astype(np.float32), rng.normal(size=d.rhs).astype(np.float32)
        f = _product_loop(d, loop)
        xj, yj = jnp.asarray(x), jnp.asarray(y)
        jax.block_until_ready(f(xj, yj))
        a, b = canonical(d, x, y)
        ref = np.asarray(jax.lax.dot_general(xj, yj, d.dimension_numbers, precision="highest"))
        np.testing.assert_allclose(np.matmul(a, b).reshape(ref.shape), ref, rtol=1e-3, atol=1e-3)  # the same product
        candidates[("xla", i)] = timing.timed(lambda _r, f=f, x=xj, y=yj: f(x, y))
        blas = _blas_loop(a, b, loop)
        blas()  # (warm)
        candidates[("blas", i)] = timing.timed(blas, wait=None)
    samples = timing.interleave(candidates, repeats, rotate=False)
    med = {k: timing.summarise(s).median / loop for k, s in samples.items()}
    rows = []
    for i, d in enumerate(dots):
        xla, blas = med[("xla", i)], med[("blas", i)]
        rows.append({"lhs": list(d.lhs), "rhs": list(d.rhs), "dimension_numbers": json.loads(json.dumps(d.dimension_numbers)),
                     "gflop": d.flops / 1e9, "xla_gflop_per_s": d.flops / xla / 1e9, "blas_gflop_per_s": d.flops / blas / 1e9,
                     "xla_over_blas_time": xla / blas})
    delay = agent.config.policy_freq
    index = {d: i for i, d in enumerate(dots)}

    def per_update(kind: str) -> tuple[float, float]:
        tot = {k: (sum(x.flops for x in ds), sum(med[(kind, index[x])] for x in ds)) for k, ds in by_kind.items()}
        return (((delay - 1) * tot[False][0] + tot[True][0]) / delay, ((delay - 1) * tot[False][1] + tot[True][1]) / delay)

    flops, xla_s = per_update("xla")
    _, blas_s = per_update("blas")
    return {"config": config, "overrides": overrides, "products": rows, "update_matmul_gflop": flops / 1e9,
            "update_xla_s": xla_s, "update_blas_s": blas_s, "xla_gflop_per_s": flops / xla_s / 1e9,
            "blas_gflop_per_s": flops / blas_s / 1e9, "xla_fraction_of_blas": blas_s / xla_s,
            "repeats": repeats, "loop": loop, "numpy": np.__version__, "blas": _blas_name()}


def _blas_name() -> str:
    """The BLAS NumPy was built against (its build configuration's name and version)."""
    try:
        cfg = np.show_config(mode="dicts")
        blas = cfg["Build Dependencies"]["blas"]
        return f"{blas.get('name')} {blas.get('version')}"
    except Exception:  # noqa: BLE001 - older NumPy: unknown
        return "unknown"


def main(argv=None) -> int:
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.bench sgemm", description=__doc__.split("\n")[0])
    p.add_argument("--config", default="cheetah_relu")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--repeats", type=int, default=7)
    p.add_argument("--loop", type=int, default=50, help="products per timed call (default 50)")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)  # (main runs itself pinned)
    args = p.parse_args(argv)
    if args.repeats < 1 or args.loop < 1:
        p.error("--repeats and --loop must be >= 1")
    if args.child:
        from swim_jax.config import ConfigError

        try:
            print(json.dumps(measure(args.config, args.set, args.repeats, args.loop)))
        except ConfigError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        return 0
    cpu = min(os.sched_getaffinity(0))
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") + " --xla_cpu_multi_thread_eigen=false").strip()
    cmd = ["taskset", "-c", str(cpu), sys.executable, "-m", "swim_jax.bench", "sgemm", "--child",
           "--config", args.config, "--repeats", str(args.repeats), "--loop", str(args.loop),
           *(f"--set={o}" for o in args.set)]
    t0 = time.time()
    out = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if out.returncode:
        print(out.stderr.strip().splitlines()[-1] if out.stderr.strip() else f"exit {out.returncode}", file=sys.stderr)
        return out.returncode
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["cpu"] = f"one core (CPU {cpu})"
    res["wall_s"] = time.time() - t0
    for r in res["products"]:
        print(f"{str(r['lhs']):>16} x {str(r['rhs']):<16} {r['gflop'] * 1e3:8.2f} MFLOP  XLA {r['xla_gflop_per_s']:6.1f}  "
              f"BLAS {r['blas_gflop_per_s']:6.1f} GFLOP/s  XLA/BLAS time {r['xla_over_blas_time']:.2f}")
    print(f"one update's products: XLA {res['xla_gflop_per_s']:.1f} GFLOP/s, {res['blas']} {res['blas_gflop_per_s']:.1f} "
          f"GFLOP/s: XLA at {100 * res['xla_fraction_of_blas']:.0f} % of the tuned sgemm")
    print(json.dumps(res))
    return 0
