# Scratch A/B of 2026-12-02 (docs/BENCHMARKS.md §12): one program vs hand-placed groups vs lane_groups as landed
# (GroupedChunks.step on kept parts) with and without the per-chunk join; 5 lanes, 2 host devices, interleaved.
# Run from the repository root: R=6 N=400 python runs/curated/bench/lane-groups-kept-ab-20261202.py
import os, sys, time, statistics
os.environ["XLA_FLAGS"] = os.environ.get("XLA_FLAGS", "") + " --xla_force_host_platform_device_count=2"
import jax, jax.numpy as jnp
sys.path.insert(0, ".")
from swim_jax import config as cfgmod, programs, train
from swim_jax.bench_train import learning_phase_overrides, lanes_program
N = int(os.environ.get("N", 400)); ENV = os.environ.get("CFG", "cheetah_relu")
ov = ["env.backend=mujoco", "matmul_dtype=full"]
cfg = cfgmod.resolve(ENV, learning_phase_overrides(N, ov))
cfgh = cfgmod.resolve(ENV, learning_phase_overrides(N, ov + [f"progress_steps={N//2}"]))
d0, d1 = jax.devices()
c5, prog, s5 = lanes_program(cfg, 5)
def build(c, lanes, dev):
    _, p, st = lanes_program(c, lanes); st = jax.device_put(st, dev)
    return p.chunk_fn.lower(st, jnp.asarray(0, jnp.int32)).compile(), st
e2a, s2a = build(cfg, 2, d0); e2b, s2b = build(cfg, 2, d1); h1a, sh = build(cfgh, 1, d0); h1b, _ = build(cfgh, 1, d1)
S = {"h": [s2a, s2b, sh]}
G = programs.grouped_chunks(c5, prog, programs.lane_groups.plan(5, jax.devices(), N))
_, _, x = lanes_program(cfg, 5); S["g"] = G.split(x, ())
_, _, x = lanes_program(cfg, 5); S["j"] = G.split(x, ())
def one(r):
    global s5
    s5, _ = prog.chunk_fn(s5, jnp.asarray(N * r, jnp.int32)); jax.block_until_ready(s5)
def half(r):
    a, b, l = S["h"]; t = jnp.asarray(N * r, jnp.int32)
    l, _ = h1a(jax.device_put(l, d0), t)
    a, _ = e2a(a, t); b, _ = e2b(b, t)
    l, _ = h1b(jax.device_put(l, d1), t + N // 2)
    S["h"] = jax.block_until_ready([a, b, l])
def landed(r):
    S["g"], _ = G.step(S["g"], N * r); S["g"].ready(); jax.block_until_ready(S["g"].states)
def landed_join(r):
    S["j"], m = G.step(S["j"], N * r); jax.block_until_ready(G.join(S["j"]))
fs = [one, half, landed, landed_join]
for f in fs: f(0)
T = {f.__name__: [] for f in fs}
R = int(os.environ.get("R", 8))
for r in range(1, R + 1):
    for f in (fs if r % 2 else fs[::-1]):
        t0 = time.perf_counter(); f(r); T[f.__name__].append((time.perf_counter() - t0) / N * 1e3)
for k, v in T.items():
    q = [a / b for a, b in zip(v, T["one"])]
    print(ENV, k, f"{statistics.median(v):.2f} ms/step; / one: median {statistics.median(q):.3f}", " ".join(f"{x:.2f}" for x in q), flush=True)
