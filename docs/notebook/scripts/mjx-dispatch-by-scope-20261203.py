"""Scratch of docs/BENCHMARKS.md §14 (kept as run): XLA operations per env step of the MJX step by JAX
name scope (the HLO op_name metadata, first DEPTH components), from one jax.profiler trace.

    python runs/curated/bench/mjx-dispatch-by-scope-20261203.py Walker2d-v5 1 4
"""
import sys, re, collections
import jax
import envs
from envs import bench
from swim_jax import bench_profile as bp
env_id = sys.argv[1]; batch = int(sys.argv[2]); scan_len = 10
f, states, key = bench.make_rollout(envs.make(env_id), batch, scan_len, False)
c = f.lower(states, key).compile()
hlo = c.as_text()
jax.block_until_ready(c(states, key))
prof = bp.profile_call(lambda: jax.block_until_ready(c(states, key)), hlo)
# map instruction name -> source
src = {}
for line in hlo.splitlines():
    m = re.match(r"\s*(?:ROOT )?%?([\w.\-]+) = ", line)
    if not m: continue
    on = re.search(r'op_name="([^"]+)"', line)
    p = on.group(1).replace("jit(rollout)/while/body/closed_call/vmap()/","").replace("/body","").replace("closed_call/","") if on else "?"
    src[m.group(1)] = p
by = collections.Counter(); byf = collections.Counter()
for n, k in prof["calls"].items():
    s = src.get(n, "?")
    by[s] += k / scan_len
    byf["/".join(s.split("/")[:int(sys.argv[3])])] += k / scan_len
tot = sum(by.values())
print("total thunks/step", round(tot))
for s, k in byf.most_common(25): print(f"{k:8.0f}  {s}")
print()
for s, k in by.most_common(60): print(f"{k:8.0f}  {s}")
