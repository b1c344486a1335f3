"""The A/B of docs/BENCHMARKS.md §13: the MJX env step, jit(scan(vmap(step))) of 100 steps,
with the line search's float32 slope floor (envs/mjx_solver._SLOPE_NOISE = 8, the default) and
without it (0: C's tolerance alone, the code before), both compiled in one process and timed
interleaved (swim_jax.timing.time_interleaved, medians). Run from the repository root:

    python runs/curated/bench/mjx-slope-floor-ab-20261202.py ENV_ID BATCH [REPEATS] >> out.jsonl
"""
import json
import statistics
import sys
import time

import envs
from envs import bench, mjx_solver
from swim_jax.timing import time_interleaved
from swim_jax.bench_io import cpu_model

env_id, batch = sys.argv[1], int(sys.argv[2])
repeats = int(sys.argv[3]) if len(sys.argv) > 3 else 9
scan_len, cands = 100, {}
for name, noise in (("no floor (before)", 0.0), ("slope floor (now)", 8.0)):
    mjx_solver._SLOPE_NOISE = noise  # read when the step is traced, i.e. by lower() below
    f, states, key = bench.make_rollout(envs.make(env_id), batch, scan_len, False)
    compiled = f.lower(states, key).compile()
    cands[name] = lambda c=compiled, s=states, k=key: c(s, k)
t = time_interleaved(cands, repeats=repeats, warmup=1)
ms = {n: 1000 * statistics.median(t[n].samples) / scan_len for n in cands}
before, now = ms["no floor (before)"], ms["slope floor (now)"]
print(json.dumps({"env": env_id, "batch": batch, "ms_per_batched_step": ms, "now_over_before": round(now / before, 3),
                  "per_round": [round(a / b, 3) for a, b in zip(t["slope floor (now)"].samples, t["no floor (before)"].samples)],
                  "repeats": repeats, "cpu": cpu_model(), "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}))
