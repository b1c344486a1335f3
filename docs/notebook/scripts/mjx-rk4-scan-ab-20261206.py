"""Interleaved A/B of the RK4 step, unrolled stages (f4bd760) vs stages as a lax.scan (ac1e60c), one process.

Usage (frozen provenance, 2026-12-06): git show f4bd760:swim_jax/envs/physics/mjx_compat.py > /tmp/old_compat.py;
SWIM_JAX_NO_COMPILATION_CACHE=1 python docs/notebook/scripts/mjx-rk4-scan-ab-20261206.py Hopper-v5 256 /tmp/old_compat.py
Compiles a 50-step scanned, vmapped env rollout with each variant installed while tracing, then times
them alternately (9 rounds); prints compile seconds, median steps/s and per-round time ratios.
"""
import sys, time, importlib.util, statistics
import jax, jax.numpy as jnp, numpy as np
from mujoco.mjx._src import forward
import swim_jax.envs as envs
from swim_jax.envs.physics import mjx_compat as new
spec = importlib.util.spec_from_file_location("old_compat", sys.argv[3]); old = importlib.util.module_from_spec(spec); spec.loader.exec_module(old)
env_id, batch = sys.argv[1], int(sys.argv[2])
env = envs.make(env_id)
variants = {"unrolled": old.rungekutta4_c, "scan": new.rungekutta4_c}
def rollout(states, actions):
    def body(s, a):
        return jax.vmap(env.step)(s, a), None
    return jax.lax.scan(body, states, actions)[0]
keys = jax.random.split(jax.random.PRNGKey(0), batch)
states = jax.jit(jax.vmap(env.reset))(keys)
actions = jax.random.uniform(jax.random.PRNGKey(1), (50, batch, env.action_size), minval=-1, maxval=1)
fns = {}
for name, fn in variants.items():
    forward.rungekutta4 = fn
    t0 = time.time(); fns[name] = jax.jit(lambda s, a: rollout(s, a)).lower(states, actions).compile(); print(name, "compile", round(time.time() - t0, 1), flush=True)
forward.rungekutta4 = new.rungekutta4_c
times = {n: [] for n in fns}
for r in range(9):
    for n in (list(fns) if r % 2 == 0 else list(fns)[::-1]):
        t0 = time.perf_counter(); jax.block_until_ready(fns[n](states, actions)); times[n].append(time.perf_counter() - t0)
med = {n: statistics.median(v) for n, v in times.items()}
ratios = [s / u for s, u in zip(times["scan"], times["unrolled"])]
print(env_id, batch, {n: round(batch * 50 / m) for n, m in med.items()}, "steps/s; scan/unrolled time per round", [round(x, 2) for x in ratios], "median", round(statistics.median(ratios), 3))
