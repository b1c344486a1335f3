"""Host-side costs of the native backend, measured interleaved in one process.

    python tools/bench_native_host.py [--rounds 15] [--steps 200] [--lanes 5]

1. ``pure_callback`` floor: ms per call of a ``jax.pure_callback`` whose host function only
   returns its inputs (shapes of a 5-lane Hopper call), 1000 calls in a ``lax.scan``, median of 10.
2. MuJoCo's thread pool: ms per batched step of ``jit(scan(vmap(step)))`` with auto-reset for
   ``--lanes`` native lanes of each paper env, the lanes' ``mujoco.batch.Batch`` on 2 threads vs 1,
   ``--rounds`` interleaved rounds of ``--steps`` steps; medians and the median ratio 2/1.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from swim_jax import envs
from swim_jax.bench import timing
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
    seconds = timing.interleave({"floor": timing.timed(lambda _r: f(*args))}, repeats, warmup=1)["floor"]
    return timing.summarise(seconds).median / calls * 1e3


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
    box = [jax.block_until_ready(f(jax.vmap(env.reset)(jax.random.split(jax.random.PRNGKey(0), lanes)),
                                   jax.random.PRNGKey(1)))]  # one state, advanced by both candidates

    def advance(r):
        box[0] = f(box[0], jax.random.PRNGKey(r))
        return box[0]

    def on_threads(nt):  # a fresh Batch on nt threads whatever the call's physics time (untimed), then the timed call
        sample = timing.timed(advance)

        def candidate(r):
            native.threads, native.POOL_MIN_SECONDS = nt, 0.0
            native._batches.clear()
            return sample(r) / steps * 1e3
        return candidate

    times = timing.interleave({nt: on_threads(nt) for nt in (1, 2)}, rounds, rotate=False)
    return {"env": env_id, "ms_1_thread": timing.summarise(times[1]).median,
            "ms_2_threads": timing.summarise(times[2]).median, "ratio_2_over_1": timing.ratios(times, 1)[2].median}


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
