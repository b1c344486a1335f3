"""Scratch of docs/BENCHMARKS.md §14 (kept as run): the MJX step compiled with XLA CPU options
(compiler_options of Lowered.compile) against XLA's defaults, timed interleaved.

    python runs/curated/bench/mjx-xla-options-ab-20261203.py Walker2d-v5 5 xla_cpu_use_fusion_emitters=false ...
"""
import sys, statistics, time
import jax
import envs
from envs import bench
from swim_jax.timing import time_interleaved
env_id, batch = sys.argv[1], int(sys.argv[2])
variants = {"default": {}}
for spec in sys.argv[3:]:
    k, v = spec.split("=")
    variants[spec] = {k: {"true": True, "false": False}.get(v, int(v) if v.isdigit() else v)}
scan_len = 50
f, states, key = bench.make_rollout(envs.make(env_id), batch, scan_len, False)
lowered = f.lower(states, key)
cands = {}
for name, opts in variants.items():
    t0 = time.time()
    try:
        c = lowered.compile(compiler_options=opts) if opts else lowered.compile()
    except Exception as e:
        print(name, "FAILED", str(e)[:200]); continue
    ct = time.time() - t0
    out = c(states, key)
    n = c.as_text().count("\n")
    print(f"{name}: compile {ct:.1f}s, hlo lines {n}", flush=True)
    cands[name] = lambda c=c: jax.block_until_ready(c(states, key))
t = time_interleaved(cands, repeats=7, warmup=1)
base = statistics.median(t["default"].samples)
for n in cands:
    m = statistics.median(t[n].samples)
    print(f"{n:60s} {1000*m/scan_len:7.3f} ms/step  {m/base:.3f}x")
