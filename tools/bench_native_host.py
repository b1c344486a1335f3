"""Host-side costs of the native backend, measured interleaved in one process.

    python tools/bench_native_host.py [--rounds 15] [--steps 200] [--lanes 5]

1. ``pure_callback`` floor: ms per call of a ``jax.pure_callback`` whose host function only
   returns its inputs (shapes of a 5-lane Hopper call), 1000 calls in a ``lax.scan``, median of 10.
2. MuJoCo's thread pool: ms per batched step of ``jit(scan(vmap(step)))`` with auto-reset for
   ``--lanes`` native lanes of each paper env, the lanes' ``mujoco.batch.Batch`` on 2 threads vs 1,
   ``--rounds`` interleaved rounds of ``--steps`` steps; medians and the median ratio 2/1.
"""

from __future__ import annotations

import statistics
import time

import jax
import jax.numpy as jnp
import numpy as np

from swim_jax import envs
from swim_jax.io import cli_parser


def callback_floor_ms(calls: int = 1000, repeats: int = 10) -> float:
    """Median ms per ``pure_callback`` call with a host function that does no work."""
    shapes = (jax.ShapeDtypeStruct((5, 36), jnp.uint32), jax.ShapeDtypeStruct((5, 60), jnp.float32))
    host = lambda x, y: (np.asarray(x), np.asarray(y).astype(np.float32))

    def body(carry, _):
        a, b = jax.pure_callback(host, shapes, *carry, vmap_method="broadcast_all")
        return (a, b + 1), None

    f = jax.jit(lambda x, y: jax.lax.scan(body, (x, y), None, length=calls)[0])
    args = (jnp.zeros((5, 36), jnp.uint32), jnp.zeros((5, 60), jnp.float32))
    jax.block_until_ready(f(*args))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(f(*args))
        times.append((time.perf_counter() - t0) / calls * 1e3)
    return statistics.median(times)


def threads_ms(env_id: str, lanes: int, steps: int, rounds: int) -> dict:
    """Median ms per batched step on 1 and 2 threads (interleaved) and the median ratio 2/1."""
    env = envs.make(env_id, backend="mujoco")
    native = env.native_physics

    def run(st, key):
        def body(s, k):
            a = jax.random.uniform(k, (lanes, env.action_size), minval=-1, maxval=1)
            return envs.step_autoreset_lanes(env, s, a, jax.random.split(k, lanes))[0], None
        return jax.lax.scan(body, st, jax.random.split(key, steps))[0]

    f = jax.jit(run)
    st = jax.block_until_ready(f(jax.vmap(env.reset)(jax.random.split(jax.random.PRNGKey(0), lanes)),
                                 jax.random.PRNGKey(1)))
    times = {1: [], 2: []}
    for r in range(rounds):
        for nt in (1, 2):
            # a fresh Batch on nt threads whatever the call's physics time
            native.threads, native.POOL_MIN_SECONDS = nt, 0.0
            native._batches.clear()
            t0 = time.perf_counter()
            st = jax.block_until_ready(f(st, jax.random.PRNGKey(r)))
            times[nt].append((time.perf_counter() - t0) / steps * 1e3)
    ratio = statistics.median([b / a for a, b in zip(times[1], times[2])])
    return {"env": env_id, "ms_1_thread": statistics.median(times[1]),
            "ms_2_threads": statistics.median(times[2]), "ratio_2_over_1": ratio}


def main(argv=None) -> int:
    p = cli_parser.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--rounds", type=int, default=15)
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--lanes", type=int, default=5)
    p.add_argument("--envs", default="HalfCheetah-v5,Hopper-v5,Walker2d-v5,Swimmer-v5")
    args = p.parse_args(argv)
    print(f"pure_callback round trip: {callback_floor_ms():.3f} ms per call")
    for env_id in args.envs.split(","):
        r = threads_ms(env_id, args.lanes, args.steps, args.rounds)
        print(f"{r['env']}: {r['ms_1_thread']:.3f} ms (1 thread), {r['ms_2_threads']:.3f} ms (2 threads), "
              f"ratio 2/1 {r['ratio_2_over_1']:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
