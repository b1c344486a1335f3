"""Scratch of docs/BENCHMARKS.md §14 (kept as run): the MJX step's unprofiled ms per step and XLA
operations ('thunks') per env step under jax.profiler, by operation kind, at each batch.

    python runs/curated/bench/mjx-dispatch-profile-20261203.py Walker2d-v5 1,10
"""
import sys, collections
import jax
import envs
from envs import bench
from swim_jax import bench_profile as bp
env_id = sys.argv[1]; batches = [int(b) for b in sys.argv[2].split(",")]
scan_len = 20
res = {}
for batch in batches:
    f, states, key = bench.make_rollout(envs.make(env_id), batch, scan_len, False)
    c = f.lower(states, key).compile()
    hlo = c.as_text()
    jax.block_until_ready(c(states, key))
    import time
    t0=time.perf_counter(); 
    for _ in range(3): jax.block_until_ready(c(states, key))
    wall=(time.perf_counter()-t0)/3/scan_len*1e3
    prof = bp.profile_call(lambda: jax.block_until_ready(c(states, key)), hlo)
    bk = collections.Counter(); nk = collections.Counter()
    for n, us in prof["self_us"].items():
        bk[bp.kind(n)] += us; nk[bp.kind(n)] += prof["calls"][n]
    tot = sum(bk.values())
    res[batch] = (wall, tot/scan_len/1e3, sum(nk.values())/scan_len, {k:(bk[k]/scan_len/1e3, nk[k]/scan_len) for k in bk})
    print(f"batch {batch}: wall {wall:.2f} ms/step (unprofiled), busy {tot/scan_len/1e3:.2f} ms, thunks/step {sum(nk.values())/scan_len:.0f}", flush=True)
kinds = sorted(res[batches[-1]][3], key=lambda k: -res[batches[-1]][3][k][0])
print("kind".ljust(40) + "".join(f"  b{b}: ms  n".rjust(18) for b in batches))
for k in kinds[:40]:
    print(k[:40].ljust(40) + "".join(f"{res[b][3].get(k,(0,0))[0]:9.3f} {res[b][3].get(k,(0,0))[1]:7.0f}" for b in batches))
