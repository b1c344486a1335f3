"""Whole-program training throughput vs number of lanes: ``python -m swim_jax.bench train``.

For each lane count L (seeds of one vmapped program) it builds the real training program of a
config (``swim_jax.run.programs.programs``: env step + replay insert + one TD3 update per step, every step
in the learning phase: ``learning_starts=0``), compiles it (the first chunk, timed as compile +
run), then times ``--repeats`` chunks of ``--chunk-steps`` steps per L, interleaved across L in one
process so machine noise hits every L alike. Reported per L (medians, min–max):

    env-steps/s (all lanes) = chunk_steps · L / t_chunk,   per lane = chunk_steps / t_chunk,
    ms per step (all lanes) = 1000 · t_chunk / chunk_steps,
    cost ratio = t_chunk(L) / (L · t_chunk(1))   (1 = lanes cost as much as separate runs).

On a CPU the program runs as ``swim_jax.run.train`` runs it: with ``lane_groups=true`` (the default) on
several cores, one host CPU device per core and the lanes as one group per device, each group its
own program (swim_jax/placement/lane_groups.py); ``--variant lane_groups=false`` times one program for all
lanes interleaved with them.
With several devices (GPUs, or ``--host-devices N`` host CPU devices) ``--shard both`` times each
L twice in the same process, lanes on one device and lanes split over all devices
(``swim_jax.placement.sharding``; rows without lane groups), so the effect of sharding is a ratio measured
interleaved. Likewise each ``--variant KEY=VALUE[,KEY=VALUE]`` adds a copy of every program built with those config overrides
(e.g. ``--variant matmul_dtype=bfloat16``), timed interleaved with the plain ones.

A sweep of P points × S seeds is a program of L = P·S lanes, so the table is its cost too.

``--roofline`` (default on) also measures the matmul roofline of the update's own products
(``swim_jax.bench.roofline``) on one core and on all cores, and reports each row's update rate as a
fraction of cores × the one-core roofline (lanes spread over cores, single-threaded products).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import sys
import time

import jax
import jax.numpy as jnp

from swim_jax.agents.replay import Transition
from swim_jax.io import cli_parser
from swim_jax import config as cfgmod
from swim_jax.run import programs, train
from swim_jax.bench import roofline, timing
from swim_jax.io.bench_results import write_result
from swim_jax.config import ConfigError
# importing these does not start the JAX backend, so --host-devices (XLA_FLAGS) still applies
from swim_jax.placement.sharding import lane_sharding, place, set_host_devices


def _parser() -> argparse.ArgumentParser:
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.bench train", description=__doc__.split("\n")[0])
    p.add_argument("--config", default="cheetah_swim", help="training config (default cheetah_swim)")
    p.add_argument("--lanes", default="1,5", help="comma-separated lane counts (default 1,5)")
    p.add_argument("--chunk-steps", type=int, default=500, help="env steps per timed chunk (default 500)")
    p.add_argument("--repeats", type=int, default=3, help="timed chunks per lane count (default 3)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="extra config override, e.g. --set precision=float64 (repeatable)")
    p.add_argument("--variant", action="append", default=[], metavar="KEY=VALUE[,KEY=VALUE]",
                   help="also time every lane count with these overrides, interleaved (repeatable)")
    p.add_argument("--shard", choices=("auto", "off", "both"), default="auto",
                   help="auto: split lanes over the devices when they divide evenly (as train does); "
                        "off: one device; both: time each lane count both ways")
    p.add_argument("--host-devices", type=int, default=0,
                   help="ask XLA for N host CPU devices (sets XLA_FLAGS before JAX starts); default 0: as "
                        "swim_jax.train asks, one per core (at most the largest lane count) when the config "
                        "or a variant has lane_groups=true (the default); 1: one device, so no lane groups")
    p.add_argument("--roofline", action=argparse.BooleanOptionalAction, default=True,
                   help="also measure the update's matmul roofline on one core and on all cores "
                        "(swim_jax.bench.roofline) and report each row's fraction of cores × one-core roofline")
    p.add_argument("--out", default=os.path.join("runs", "bench"), help="folder for the JSON (default runs/bench)")
    return p


def _lanes(text: str) -> list[int]:
    try:
        values = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        values = []
    if not values or any(v < 1 for v in values):
        raise ValueError(f"--lanes {text!r}: expected comma-separated positive integers such as 1,5,10")
    return sorted(set(values))


def update_flops(agent) -> float:
    """Floating-point operations of one TD3 update, averaged over the policy delay.

    Counted by XLA's cost analysis of the compiled single-lane update with and without the actor
    step: ``((d - 1) · F_critic + F_critic+actor) / d`` with d = ``policy_freq``. Multiplying by
    updates per second gives the arithmetic rate the training program sustains in its updates.
    """
    b, o, a = agent.config.batch_size, agent.obs_dim, agent.action_dim
    z = lambda *shape: jnp.zeros(shape, agent.dtype)
    batch = Transition(z(b, o), z(b, a), z(b), z(b, o), z(b))
    state = jax.eval_shape(agent.init, jax.random.key(0))
    counts = []
    for with_actor in (False, True):
        fn = jax.jit(lambda s, bt, k, w=with_actor: agent.update_delayed(s, bt, k, jnp.asarray(w)))
        cost = fn.lower(state, batch, jax.random.key(1)).compile().cost_analysis()
        counts.append(float((cost[0] if isinstance(cost, list) else cost)["flops"]))
    d = agent.config.policy_freq
    return ((d - 1) * counts[0] + counts[1]) / d


def _candidates(lanes: list[int], variant_cfgs: dict, shard: str) -> list[tuple]:
    """(lanes, sharding or None, variant, lane groups or None) for every program to time: each lane
    count as lane groups where its variant's config has them and there are several host CPU devices
    (as swim_jax.run.train places it), else on one device and/or split over the devices (``shard``),
    each with every variant."""
    candidates = []
    for L in lanes:
        sh, _why = lane_sharding(L)
        for v, cfg in variant_cfgs.items():
            groups = programs.groups_for(cfg, L)[0]
            if groups is not None:
                candidates.append((L, None, v, groups))
                continue
            if shard in ("off", "both") or sh is None:
                candidates.append((L, None, v, None))
            if shard in ("auto", "both") and sh is not None:
                candidates.append((L, sh, v, None))
    return candidates


def _row(c, stepper, times: list[float], compile_s: float, one_lane_s, chunk_steps: int, flops: float,
         roof, executables_before: int) -> dict:
    """One table row: medians and rates of candidate ``c`` = (lanes, sharding, variant, groups), run
    by ``stepper``, from its chunk times; ``one_lane_s``: the median chunk time of the 1-lane program of its variant (or
    None); ``executables_before``: the stepper's compiled chunk executables before the timed rounds
    (the row gives them after, and how many were added while timing)."""
    L, v = c[0], c[2]
    t = timing.summarise(times)
    med = t.median
    rate = flops * chunk_steps * L / med / 1e9
    return {
        "lanes": L, "variant": v,
        "devices": stepper.devices,
        "lane_groups": stepper.lane_groups,
        "median_s": med, "min_s": t.min, "max_s": t.max, "chunk_s": list(times),
        "env_steps_per_s": chunk_steps * L / med, "env_steps_per_s_per_lane": chunk_steps / med,
        "ms_per_step": 1000 * med / chunk_steps, "compile_plus_first_chunk_s": compile_s,
        "cost_ratio_vs_1": (med / (L * one_lane_s)) if one_lane_s else None,
        "update_gflop_per_s": rate,
        # the update's arithmetic rate over (cores × the one-core roofline of its own products)
        "fraction_of_per_core_roofline": (rate / (roof["cores"] * roof["one_core"]["roofline_gflop_per_s"])) if roof else None,
        # one executable per lane count and placement; none may be added while timing
        "chunk_executables": stepper.executables, "compiles_while_timing": stepper.executables - executables_before,
    }


def learning_phase_overrides(chunk_steps: int, overrides=()) -> list[str]:
    """Config overrides of a benchmark program: every step in the learning phase (env step + one
    update), one call of ``chunk_steps`` steps per chunk, a 100k-row replay, then ``overrides``."""
    return [f"eval_freq={chunk_steps}", f"total_steps={chunk_steps}", "learning_starts=0",
            "replay_size=100000", f"progress_steps={chunk_steps}", *overrides]


def lanes_program(cfg, lanes: int, sharding=None):
    """The training program of resolved config ``cfg`` with ``lanes`` lanes (seeds 0 … lanes−1, no
    padding of a single seed) and its initial state, placed by ``sharding`` (None: one device):
    ``(cfg with those lanes, program, state)``. What every benchmark of a training chunk times."""
    cfg = dataclasses.replace(cfg, seeds=lanes, pad_single_seed=False)
    prog = programs.programs(cfg, sharding)
    state = place(prog.init_fn(jnp.asarray(0, jnp.uint32), jnp.arange(lanes, dtype=jnp.int32)), sharding)
    return cfg, prog, state


def interleaved_chunk_ratios(executables: dict, states: dict, rounds: int, steps: int, reference: str) -> dict:
    """Run ``rounds`` interleaved rounds of every compiled chunk in ``executables`` (name → executable
    of ``steps`` steps, called as ``exe(state, first_step, None)`` with first step ``steps · (r + 1)``
    in round r, in the mapping's order each round; ``states`` holds each one's state and is
    advanced). Returns name → (median ms per step, median over rounds of its step time / the
    ``reference`` executable's in the same round): :func:`swim_jax.bench.timing.ratios`."""
    def chunk(name, exe):
        def run(r):
            states[name] = exe(states[name], jnp.asarray(steps * (r + 1), jnp.int32), None)[0]
            return states[name]
        return timing.timed(run)  # waits for the new state

    samples = timing.interleave({name: chunk(name, exe) for name, exe in executables.items()}, rounds, rotate=False)
    per_round = timing.ratios(samples, reference)
    return {name: (timing.summarise(s).median / steps * 1e3, per_round[name].median) for name, s in samples.items()}


def measure(config: str, lanes: list[int], chunk_steps: int, repeats: int, overrides=(), log=print,
            shard: str = "auto", variants=(), with_roofline: bool = False) -> dict:
    """Compile one program per (lane count, placement, variant), then time ``repeats`` interleaved
    chunks of each. ``variants``: extra override strings "k=v,k=v"; "" (always first) = none."""
    bench = learning_phase_overrides(chunk_steps, overrides)
    variant_cfgs = {v: cfgmod.resolve(config, [*bench, *(v.split(",") if v else [])]) for v in ("", *variants)}
    candidates = _candidates(lanes, variant_cfgs, shard)
    progs, states, compile_s, cfgs, steppers = {}, {}, {}, {}, {}

    def run_chunk(c, st, index):  # as the training loop runs it (calls of progress_steps steps)
        st = train.train_chunk(cfgs[c], steppers[c], st, index, lambda _: None)[0]
        # training joins a whole-lane copy after every chunk (evaluation, checkpoint)
        jax.block_until_ready(steppers[c].join(st))
        return st

    for c in candidates:
        L, sh, v, groups = c
        cfgs[c], progs[c], st = lanes_program(variant_cfgs[v], L, sh)
        steppers[c] = programs.stepper(cfgs[c], progs[c], sh, groups)
        t0 = time.perf_counter()
        st = steppers[c].split(st, ())  # with lane groups, compiles every group's program
        states[c] = run_chunk(c, st, 0)
        compile_s[c] = time.perf_counter() - t0
        how = " sharded" if sh else f" as {steppers[c].lane_groups}" if groups else ""
        log(f"lanes {L}{how}{' ' + v if v else ''}: compiled + first chunk {compile_s[c]:.1f} s")
    # one jitted chunk serves every lane count and placement of a config (one executable each; lane
    # groups make all of theirs before chunk 0)
    def timed_chunk(c):  # round r is the chunk r + 1 (chunk 0 compiled); run_chunk blocks itself
        def run(r):
            states[c] = run_chunk(c, states[c], r + 1)
        return timing.timed(run, wait=None)

    warm_sizes = {c: steppers[c].executables for c in candidates}
    times = timing.interleave({c: timed_chunk(c) for c in candidates}, repeats, rotate=False)
    agent = progs[candidates[0]].agent
    flops = update_flops(agent)
    roof = _rooflines(config, bench, agent, log) if with_roofline else None  # bench ends with overrides
    one = {}  # cost ratios against the first (single-device) 1-lane program of the same variant
    for c in candidates:
        if c[0] == 1 and c[2] not in one:
            one[c[2]] = timing.summarise(times[c]).median
    rows = [_row(c, steppers[c], times[c], compile_s[c], one.get(c[2]), chunk_steps, flops, roof, warm_sizes[c])
            for c in candidates]
    base = variant_cfgs[""]
    return {
        "benchmark": "train", "config": config, "overrides": list(overrides), "variants": list(variants),
        "chunk_steps": chunk_steps,
        "repeats": repeats, "env": base.env.id, "activation": dataclasses.asdict(base.agent.activation),
        "hidden": list(base.agent.hidden), "precision": base.precision, "rows": rows,
        "update_gflop": flops / 1e9,
        "roofline": roof,
        "machine": {"platform": jax.devices()[0].platform, "device": str(jax.devices()[0]),
                    "cpu_count": os.cpu_count(), "python": platform.python_version(), "jax": jax.__version__},
        "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def _rooflines(config: str, overrides, agent, log) -> dict:
    """The update's matmul roofline (``swim_jax.bench.roofline``) on all cores (this process) and on one
    core (a pinned child process with single-threaded XLA)."""
    all_cores = roofline.roofline(agent)
    one_core = roofline.one_core_roofline(config, overrides)
    cores = len(os.sched_getaffinity(0))
    log(f"update matmul roofline: {one_core['roofline_gflop_per_s']:.1f} GFLOP/s on one core, "
        f"{all_cores['roofline_gflop_per_s']:.1f} on all {cores} cores in one process")
    return {"cores": cores, "one_core": one_core, "all_cores": all_cores}


def markdown(res: dict) -> str:
    """The result as a Markdown table (medians; min–max of the chunk time)."""
    lines = [f"{res['env']} {res['activation']['name']} {res['hidden']} {res['precision']}, "
             f"{res['chunk_steps']} steps per chunk, {res['repeats']} chunks, {res['machine']['device']}; "
             f"one TD3 update = {res['update_gflop']:.3f} GFLOP (XLA cost analysis)",
             "", "| lanes | devices | variant | env-steps/s (all) | per lane | ms/step | chunk s (min–max) | cost ratio vs 1 | update GFLOP/s | of cores × 1-core roofline | compile + 1st chunk s |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    roof = res.get("roofline")
    if roof:
        lines.insert(1, f"update matmul roofline (its own products, XLA kernels): {roof['one_core']['roofline_gflop_per_s']:.1f} GFLOP/s "
                        f"on one core, {roof['all_cores']['roofline_gflop_per_s']:.1f} on all {roof['cores']} cores in one process")
    for r in res["rows"]:
        ratio = "—" if r["cost_ratio_vs_1"] is None else f"{r['cost_ratio_vs_1']:.2f}"
        frac = "—" if r.get("fraction_of_per_core_roofline") is None else f"{r['fraction_of_per_core_roofline']:.0%}"
        lines.append(f"| {r['lanes']} | {r['devices']} | {r.get('variant') or '—'} | {r['env_steps_per_s']:.0f} | {r['env_steps_per_s_per_lane']:.0f} | "
                     f"{r['ms_per_step']:.2f} | {r['median_s']:.2f} ({r['min_s']:.2f}–{r['max_s']:.2f}) | "
                     f"{ratio} | {r['update_gflop_per_s']:.1f} | {frac} | {r['compile_plus_first_chunk_s']:.0f} |")
    return "\n".join(lines)


def _auto_host_devices(config: str, lanes: int, overrides, variants) -> int:
    """The host devices swim_jax.run.train would ask for (``programs.auto_host_devices``) for ``lanes``
    seeds of ``config`` with ``overrides`` and any of ``variants``: the most of them."""
    return max(programs.auto_host_devices(cfgmod.resolve(config, [*overrides, f"seeds={lanes}", *(v.split(",") if v else [])]))
               for v in ("", *variants))


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        lanes = _lanes(args.lanes)
        if args.host_devices > 0:
            set_host_devices(args.host_devices)
        elif not programs.backends_started():  # e.g. called in a process where JAX already runs
            host_devices = _auto_host_devices(args.config, max(lanes), args.set, args.variant)
            if host_devices:
                set_host_devices(host_devices)
        if args.chunk_steps < 1 or args.repeats < 1:
            raise ValueError("--chunk-steps and --repeats must be >= 1")
        res = measure(args.config, lanes, args.chunk_steps, args.repeats, tuple(args.set), shard=args.shard,
                      variants=tuple(args.variant), with_roofline=args.roofline)
    except (ValueError, ConfigError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(markdown(res))
    write_result(args.out, "train", res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
