"""Env throughput benchmark: batched ``jit(scan(vmap(step)))`` (MJX or the native backend) vs a plain MuJoCo C loop.

Entry point :func:`main` (``python -m swim_jax.bench envs ...``).
For each env and batch size: compile time of the scanned, vmapped step; env steps/s of MJX
(median over repeats, ``batch * scan_len / seconds``); interleaved with it, native MuJoCo C on
one core (same Gymnasium XML and frame skip, one ``mj_step(m, d, nstep=frame_skip)`` plus
``mj_rnePostConstraint`` per env step, as Gymnasium does). Random uniform actions in [-1, 1].
Writes JSON to ``runs/bench/envs-<UTC timestamp>.json``. XLA flags (e.g.
``--xla_force_host_platform_device_count=2``) are read from the environment at start; with more
than one JAX device and ``--shard``, the batch is split across devices.
"""

from __future__ import annotations

import json
import os
import platform
import time
from typing import Dict, List, Optional, Sequence

import jax
import mujoco
import numpy as np

from swim_jax.envs.base import BACKENDS
from swim_jax.envs.physics.mjx_solver import check_implementation
from swim_jax.envs.registry import ENV_IDS, make
from swim_jax.io import cli_parser
from swim_jax.bench.timing import summarise, time_interleaved

DEFAULT_ENVS = ("Hopper-v5", "Walker2d-v5", "HalfCheetah-v5", "Swimmer-v5", "Ant-v5")


def native_rollout(env, n_steps: int, seed: int = 0):
    """Zero-argument callable running ``n_steps`` env steps of native MuJoCo C on the calling
    thread (``env``'s XML and frame skip, fixed uniform random actions), from qpos0 each call."""
    m = env.mj_model
    d = mujoco.MjData(m)
    actions = np.random.default_rng(seed).uniform(-1.0, 1.0, size=(n_steps, m.nu))

    def run():
        mujoco.mj_resetData(m, d)
        mujoco.mj_forward(m, d)
        for a in actions:
            d.ctrl[:] = a
            mujoco.mj_step(m, d, nstep=env.frame_skip)
            mujoco.mj_rnePostConstraint(m, d)

    return run


def make_rollout(env, batch: int, scan_len: int, shard: bool):
    """Jitted ``f(states, key) -> states`` running ``scan_len`` vmapped env steps.

    Returns ``(f, states0, key)``; states are sharded over all JAX devices if ``shard``.
    """
    vstep = jax.vmap(env.step)

    def rollout(states, key):
        def body(s, k):
            a = jax.random.uniform(k, (batch, env.action_size), env.dtype, -1.0, 1.0)
            return vstep(s, a), None
        return jax.lax.scan(body, states, jax.random.split(key, scan_len))[0]

    states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), batch))
    if shard and jax.device_count() > 1 and batch % jax.device_count() == 0:
        mesh = jax.sharding.Mesh(np.array(jax.devices()), ("b",))
        sh = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("b"))
        states = jax.device_put(states, sh)
    return jax.jit(rollout), states, jax.random.PRNGKey(1)


def physics_variants(backends: Sequence[str], solver_impls: Sequence[str]) -> List[str]:
    """Row labels of the physics timed: ``mjx/<solver impl>`` per solver for the MJX backend,
    ``mujoco`` for the native backend (MuJoCo C through the jitted callback)."""
    out = []
    for b in backends:
        out += [f"mjx/{i}" for i in solver_impls] if b == "mjx" else [b]
    return out


def _make_variant(env_id: str, variant: str, options: Dict):
    if variant.startswith("mjx/"):
        return make(env_id, **options, solver_impl=variant.split("/", 1)[1])
    return make(env_id, **options, backend=variant)


def bench_env(env_id: str, batches: Sequence[int], scan_len: int, repeats: int,
              native_steps: int, options: Dict, shard: bool,
              solver_impls: Sequence[str] = ("c",), backends: Sequence[str] = ("mjx",)) -> List[Dict]:
    """Measure one env at every batch size, one row per physics variant (MJX with each solver
    implementation, and/or the native backend's jitted rollout): each is compiled first, then a
    plain MuJoCo C loop (one core, no JAX) and every variant are timed interleaved
    (:func:`swim_jax.bench.timing.time_interleaved`, rotating order, medians)."""
    variants = physics_variants(backends, solver_impls)
    env_by_variant = {v: _make_variant(env_id, v, options) for v in variants}
    native_env = env_by_variant[variants[0]]
    rows = []
    for batch in batches:
        candidates, compile_s = {"native": native_rollout(native_env, native_steps)}, {}
        for variant, env in env_by_variant.items():
            f, states, key = make_rollout(env, batch, scan_len, shard)
            t0 = time.perf_counter()
            compiled = f.lower(states, key).compile()
            compile_s[variant] = time.perf_counter() - t0
            candidates[variant] = lambda fn=compiled, st=states, k=key: fn(st, k)
        timings = time_interleaved(candidates, repeats=repeats, warmup=1)
        native_all = [native_steps / t for t in timings["native"].samples]
        nat_med = summarise(native_all).median
        for variant in variants:
            steps_all = [batch * scan_len / t for t in timings[variant].samples]
            med = summarise(steps_all).median
            row = dict(env=env_id, batch=batch, scan_len=scan_len, physics=variant,
                       ms_per_batched_step=round(1000 * batch / med, 4),
                       compile_s=round(compile_s[variant], 2),
                       steps_per_s=round(med, 1), native_steps_per_s=round(nat_med, 1),
                       ratio_vs_one_native_core=round(med / nat_med, 4),
                       steps_all=[round(x, 1) for x in steps_all],
                       native_all=[round(x, 1) for x in native_all])
            print(json.dumps(row), flush=True)
            rows.append(row)
    return rows


def _opt_int(s: str) -> Optional[int]:
    return None if s.lower() == "none" else int(s)


def main(argv: Optional[Sequence[str]] = None) -> Dict:
    """CLI: benchmark env throughput; returns the result dict it also writes as JSON.

    Flags: --envs (comma list, default the five v5 envs), --batches (default 1,8,64,256,1024),
    --scan-len (default 50), --repeats (3), --native-steps (2000), --solver-iterations /
    --ls-iterations (int or 'none' for the XML's 100 / 50; defaults 8 / 16), --solver-impl (comma
    list of c, mjx; timed interleaved, one row each), --backends (comma list of mjx, mujoco),
    --shard, --out-dir.
    """
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.bench envs", description=__doc__.split("\n")[0])
    p.add_argument("--envs", default=",".join(DEFAULT_ENVS))
    p.add_argument("--batches", default="1,8,64,256,1024")
    p.add_argument("--scan-len", type=int, default=50)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--native-steps", type=int, default=2000)
    p.add_argument("--solver-iterations", type=_opt_int, default=8)
    p.add_argument("--ls-iterations", type=_opt_int, default=16)
    p.add_argument("--solver-impl", default="c",
                   help="comma list of constraint solvers timed interleaved: c (MuJoCo C's Newton "
                        "method, the default) and/or mjx (MJX's own)")
    p.add_argument("--backends", default="mjx",
                   help="comma list of physics backends timed interleaved: mjx (one row per "
                        "--solver-impl) and/or mujoco (MuJoCo C inside the jitted program)")
    p.add_argument("--shard", action="store_true")
    p.add_argument("--out-dir", default=os.path.join("runs", "bench"))
    args = p.parse_args(argv)
    env_ids = [e for e in args.envs.split(",") if e]
    for e in env_ids:
        if e not in ENV_IDS:
            p.exit(2, f"swim_jax.bench envs: unknown env id {e!r}; valid ids: {', '.join(ENV_IDS)}\n")
    try:
        impls = [check_implementation(i) for i in args.solver_impl.split(",") if i]
    except ValueError as exc:
        p.exit(2, f"swim_jax.bench envs: {exc}\n")
    backends = [b for b in args.backends.split(",") if b]
    bad = [b for b in backends if b not in BACKENDS]
    if bad or not backends:
        p.exit(2, f"swim_jax.bench envs: unknown backend {','.join(bad)!r}; valid backends: {', '.join(BACKENDS)}\n")
    options = dict(solver_iterations=args.solver_iterations, ls_iterations=args.ls_iterations)
    batches = [int(b) for b in args.batches.split(",")]
    rows = []
    for e in env_ids:
        rows += bench_env(e, batches, args.scan_len, args.repeats, args.native_steps, options,
                          args.shard, tuple(impls), tuple(backends))
    stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
    result = dict(
        benchmark="envs", timestamp=stamp, options=options, shard=args.shard,
        jax=jax.__version__, mujoco=mujoco.__version__, x64=bool(jax.config.jax_enable_x64),
        devices=[str(d) for d in jax.devices()], cpu_count=os.cpu_count(),
        xla_flags=os.environ.get("XLA_FLAGS", ""), machine=platform.platform(), rows=rows)
    os.makedirs(args.out_dir, exist_ok=True)
    path = os.path.join(args.out_dir, f"envs-{stamp}.json")
    with open(path, "w") as fh:
        json.dump(result, fh, indent=1)
    print(f"wrote {path}")
    return result


if __name__ == "__main__":
    main()
