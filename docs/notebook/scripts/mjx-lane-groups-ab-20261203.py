"""The A/B of docs/BENCHMARKS.md §14: the MJX env step (jit(scan(vmap(step))), float32) as one
program over all lanes before the line search's slope floor (envs/mjx_solver._SLOPE_NOISE = 0, the
code when issue 14 was filed), as one program with it (8, the default), and with the lanes placed
over the host CPU devices as training places them (swim_jax.lane_groups.plan: one group per core,
each leftover lane in one piece of 1/D of the steps per device, one piece after another). A timed
sample is CALLS consecutive calls of SCAN_LEN steps from the same start, each call's states fed to
the next and nothing waited for between calls (as the training loop runs its chunks), then a wait
for every device. All compiled in one process and timed interleaved
(swim_jax.timing.time_interleaved, rotating order, medians). Run from the repository root:

    python runs/curated/bench/mjx-lane-groups-ab-20261203.py ENV_ID BATCH [REPEATS] >> out.jsonl
"""
import os
import sys

os.environ["XLA_FLAGS"] = os.environ.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={os.cpu_count()}"

import json  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import jax  # noqa: E402

import envs  # noqa: E402
from envs import bench, mjx_solver  # noqa: E402
from swim_jax import lane_groups  # noqa: E402
from swim_jax.bench_io import cpu_model  # noqa: E402
from swim_jax.timing import time_interleaved  # noqa: E402

env_id, batch = sys.argv[1], int(sys.argv[2])
repeats = int(sys.argv[3]) if len(sys.argv) > 3 else 9
scan_len, calls = 100, 3
SLOPE_FLOOR = mjx_solver._SLOPE_NOISE  # the default, before program() sets it
env = envs.make(env_id)


def program(lanes: int, steps: int, slope_noise: float, device):
    """A compiled rollout of ``steps`` steps of ``lanes`` lanes on ``device`` and its inputs."""
    mjx_solver._SLOPE_NOISE = slope_noise  # read when the step is traced, i.e. by lower() below
    f, states, key = bench.make_rollout(env, lanes, steps, False)
    states, key = jax.device_put((states, key), device)
    compiled = f.lower(states, key).compile()
    jax.block_until_ready(compiled(states, key))
    return compiled, states, key


def one_program(slope_noise: float):
    compiled, states, key = program(batch, scan_len, slope_noise, jax.devices()[0])

    def run():
        s = states
        for _ in range(calls):
            s = compiled(s, key)
        jax.block_until_ready(s)
    return run


def grouped(groups: lane_groups.LaneGroups):
    """Per call: every group's program on its device, then each leftover lane's pieces in turn."""
    D = len(groups.devices)
    group_runs = [program(groups.per_group, scan_len, SLOPE_FLOOR, d) for d in groups.devices]
    pieces = [program(1, scan_len // D, SLOPE_FLOOR, d) for d in groups.devices]  # a leftover lane's piece per device

    def run():
        group_states = [s for _c, s, _k in group_runs]
        lane_states = [None] * len(groups.leftover)
        for _ in range(calls):
            group_states = [c(s, k) for (c, _s, k), s in zip(group_runs, group_states)]
            for j in range(len(groups.leftover)):
                for d in groups.piece_devices(j):
                    c, s, k = pieces[d]
                    state = lane_states[j]
                    lane_states[j] = c(s if state is None else jax.device_put(state, groups.devices[d]), k)
        jax.block_until_ready((group_states, lane_states))
    return run


cands = {"one program, no floor (before)": one_program(0.0), "one program, slope floor": one_program(SLOPE_FLOOR)}
groups = lane_groups.plan(batch, jax.devices(), scan_len)
if groups is not None:
    cands[f"lane groups ({groups.describe()}), slope floor"] = grouped(groups)
t = time_interleaved(cands, repeats=repeats, warmup=1)
before = t["one program, no floor (before)"].samples
print(json.dumps({
    "env": env_id, "batch": batch, "scan_len": scan_len, "calls": calls, "repeats": repeats, "devices": len(jax.devices()),
    "ms_per_batched_step": {n: round(1000 * statistics.median(t[n].samples) / (calls * scan_len), 3) for n in cands},
    "over_before": {n: round(statistics.median(a / b for a, b in zip(t[n].samples, before)), 3) for n in cands},
    "per_round": {n: [round(a / b, 3) for a, b in zip(t[n].samples, before)] for n in cands},
    "cpu": cpu_model(), "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}))
