# Scratch A/B of 2026-12-02 (docs/BENCHMARKS.md §11): one program vs lane groups as landed (train_chunk)
# vs hand-placed groups, 5 lanes on 2 host devices, interleaved rounds. Run: python runs/curated/bench/lane-groups-three-forms-20261202.py
import os, sys, time, statistics
os.environ["XLA_FLAGS"] = os.environ.get("XLA_FLAGS", "") + " --xla_force_host_platform_device_count=2"
import jax, jax.numpy as jnp
sys.path.insert(0, ".")  # run from the repository root
from swim_jax import config as cfgmod, train, lane_groups
from swim_jax.bench_train import learning_phase_overrides, lanes_program
N = 400
cfg = cfgmod.resolve("cheetah_relu", learning_phase_overrides(N, ["env.backend=mujoco", "matmul_dtype=full", "progress_steps=200"]))
d0, d1 = jax.devices()
_, prog, s5 = lanes_program(cfg, 5)
_, _, sg = lanes_program(cfg, 5)
G = lane_groups.GroupedChunks(lane_groups.plan(5, jax.devices()), prog.chunk_fn)
def build(lanes, dev):
    _, p, st = lanes_program(cfg, lanes); st = jax.device_put(st, dev)
    return p.chunk_fn.lower(st, jnp.asarray(0, jnp.int32)).compile(), st
e2a, s2a = build(2, d0); e2b, s2b = build(2, d1); e1a, s1 = build(1, d0); e1b, _ = build(1, d1)
def one(r):
    global s5
    for j in range(2):
        s5, _ = prog.chunk_fn(s5, jnp.asarray(N * r + 200 * j, jnp.int32))
    jax.block_until_ready(s5)
def grouped(r):
    global sg
    sg = jax.block_until_ready(train.train_chunk(cfg, prog.chunk_fn, sg, r, (), None, lambda _: None, G)[0])
def manual(r):
    global s2a, s2b, s1
    for j in range(2):
        t = jnp.asarray(N * r + 200 * j, jnp.int32)
        s2a, _ = e2a(s2a, t); s2b, _ = e2b(s2b, t)
        s1, _ = (e1a(jax.device_put(s1, d0), t) if j % 2 else e1b(jax.device_put(s1, d1), t))
    jax.block_until_ready((s2a, s2b, s1))
_, _, sp = lanes_program(cfg, 5)
PP = G.split(sp, (), 0)
def persist(r):
    global PP
    parts, args = PP
    for j in range(2):
        parts, _ = G.step(parts, args, N * r + 200 * j, 2 * r + j)
    PP = (jax.block_until_ready(parts), args)
fs = [one, grouped, manual, persist]
for f in fs: f(0)
T = {f.__name__: [] for f in fs}
for r in range(1, 13):
    for f in (fs if r % 2 else fs[::-1]):
        t0 = time.perf_counter(); f(r); T[f.__name__].append((time.perf_counter() - t0) / N * 1e3)
for k, v in T.items():
    q = [a / b for a, b in zip(v, T["one"])]
    print(k, f"{statistics.median(v):.2f} ms/step; / one: median {statistics.median(q):.3f}", " ".join(f"{x:.2f}" for x in q))
