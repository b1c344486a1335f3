"""Where a training step's time goes: ``python -m swim_jax.bench profile``.

Builds the learning-phase program of a config with L lanes (as ``bench train`` does: env step +
replay insert + one TD3 update every step), compiles its chunk once, runs two warm-up calls, times
one call of ``--steps`` steps without the profiler, then runs one more call under ``jax.profiler``
and reads the trace back. Every XLA operation of the compiled chunk (an HLO instruction name) gets
its *self time*: its own duration minus that of the XLA operations nested in it (a ``cond`` around
the update, a ``while`` around the steps), so the times add up without double counting; a
``pure_callback`` keeps the Python it runs. Times are summed per step and grouped by kind (the name
without its number: ``dot``, ``multiply_add_fusion``, ``pure_callback``, ...). When XLA runs
operations on several threads at once, the busy time summed over threads can exceed the wall time.

Matrix products (plain ``dot`` instructions and fusions that contain dots, such as XLA's YNNPACK
fusions) are also listed one by one, with

    FLOPs = 2 · (output elements) · (contracted size),   GFLOP/s = FLOPs / time per call,

and the operands' layout: NN when the left operand is contracted on its last axis and the right one
on its first non-batch axis (``x @ W``), NT when the right one is contracted on its last axis
(``g · Wᵀ``), TN when the left one is contracted on its first non-batch axis (``xᵀ · g``), TT both.
Profiling slows the step a little (the JSON has the timed and the profiled ms per step).
"""

from __future__ import annotations

import argparse
import bisect
import collections
import dataclasses
import glob
import gzip
import json
import math
import os
import re
import sys
import tempfile
import time

import jax
import jax.numpy as jnp

from swim_jax.io import cli_parser
from swim_jax import config as cfgmod
from swim_jax.run import programs
from swim_jax.io.bench_results import cpu_model, write_result
from swim_jax.bench import timing
from swim_jax.bench.train import lanes_program, learning_phase_overrides
from swim_jax.config import ConfigError

_INSTRUCTION = re.compile(r"^\s*(?:ROOT )?%([\w.\-]+) = (\w+)\[([\d,]*)\]\S* ([\w\-]+)\((.*)$", re.M)
_NAME = re.compile(r"^\s*(?:ROOT )?%([\w.\-]+) = ", re.M)
_COMPUTATION = re.compile(r"^(?:ENTRY )?%([\w.\-]+) .*\{\s*$", re.M)


@dataclasses.dataclass(frozen=True)
class Product:
    """One matrix product of a compiled program: its HLO instruction, output shape, contracted
    size, operand layout (NN/NT/TN/TT, see the module docstring) and FLOPs per call."""

    name: str
    out: tuple[int, ...]
    contracted: int
    layout: str
    flops: float


def _dims(text: str, key: str) -> tuple[int, ...]:
    m = re.search(key + r"=\{([\d,]*)\}", text)
    return tuple(int(x) for x in m.group(1).split(",") if x) if m else ()


def _dot(name: str, out: tuple[int, ...], operands: str, shapes: dict) -> Product | None:
    """The Product of one ``dot`` instruction (``operands``: the text after ``dot(``)."""
    args = re.findall(r"%([\w.\-]+)", operands.split(")", 1)[0])
    if len(args) < 2 or args[0] not in shapes or args[1] not in shapes:
        return None
    lhs, rhs = shapes[args[0]], shapes[args[1]]
    lc, rc = _dims(operands, "lhs_contracting_dims"), _dims(operands, "rhs_contracting_dims")
    lb, rb = _dims(operands, "lhs_batch_dims"), _dims(operands, "rhs_batch_dims")
    k = math.prod(lhs[d] for d in lc)
    lhs_free = [d for d in range(len(lhs)) if d not in lb]
    rhs_free = [d for d in range(len(rhs)) if d not in rb]
    left = "N" if lc and lc[-1] == lhs_free[-1] else "T"
    right = "N" if rc and rc[0] == rhs_free[0] else "T"
    return Product(name, out, k, left + right, 2.0 * math.prod(out) * k)


def products(hlo_text: str) -> dict[str, Product]:
    """Every matrix product of an optimised HLO module (``compiled.as_text()``), by the name of the
    instruction that runs it: a ``dot`` itself, or a fusion whose computation contains dots (its
    FLOPs summed, the layout and shape of its first dot)."""
    shapes = {m.group(1): tuple(int(x) for x in m.group(3).split(",") if x) for m in _INSTRUCTION.finditer(hlo_text)}
    # the products of every computation (fused computations are printed before their callers); a
    # dot inside a fusion never runs as its own operation, so only its fusion gets calls in a trace
    headers = list(_COMPUTATION.finditer(hlo_text))
    starts, names = [m.start() for m in headers], [m.group(1) for m in headers]
    in_computation: dict[str, list[Product]] = collections.defaultdict(list)
    found: dict[str, Product] = {}
    for m in _INSTRUCTION.finditer(hlo_text):
        name, op, rest = m.group(1), m.group(4), m.group(5)
        i = bisect.bisect_left(starts, m.start()) - 1
        comp = names[i] if i >= 0 else ""
        if op == "dot":
            product = _dot(name, tuple(int(x) for x in m.group(3).split(",") if x), rest, shapes)
        elif op == "fusion" and (called := re.search(r"calls=%([\w.\-]+)", rest)) and in_computation.get(called.group(1)):
            inner = in_computation[called.group(1)]
            product = Product(name, inner[0].out, inner[0].contracted, inner[0].layout, sum(p.flops for p in inner))
        else:
            continue
        if product is not None:
            in_computation[comp].append(product)
            found[name] = product
    return found


def instruction_names(hlo_text: str) -> set[str]:
    """The names of every instruction of an HLO module (what a profiler trace names its events)."""
    return {m.group(1) for m in _NAME.finditer(hlo_text)}


def self_times(events: list[dict], ops: set[str]) -> tuple[collections.Counter, collections.Counter]:
    """(total self time in µs, number of calls) per operation name in ``ops``, from a trace's
    complete events (``"ph": "X"``, with ``ts``/``dur`` in µs, per ``pid``/``tid``): an operation's
    own duration minus that of the operations in ``ops`` nested in it on the same thread."""
    by_thread = collections.defaultdict(list)
    for e in events:
        if e.get("ph") == "X" and e.get("name") in ops:
            by_thread[(e.get("pid"), e.get("tid"))].append(e)
    total, calls = collections.Counter(), collections.Counter()
    for evs in by_thread.values():
        evs.sort(key=lambda e: (e["ts"], -e["dur"]))
        stack: list[list] = []  # open events: [end, name, duration, time of nested operations]
        for e in [*evs, None]:
            while stack and (e is None or stack[-1][0] <= e["ts"]):
                _end, name, dur, nested = stack.pop()
                total[name] += dur - nested
            if e is None:
                break
            if stack:
                stack[-1][3] += e["dur"]
            stack.append([e["ts"] + e["dur"], e["name"], e["dur"], 0.0])
            calls[e["name"]] += 1
    return total, calls


def kind(name: str) -> str:
    """An operation's kind: its name without the trailing number (``dot.18`` → ``dot``)."""
    return re.sub(r"\.\d+$", "", name)


def profile_call(run, hlo_text: str) -> dict:
    """Run ``run()`` (one call that blocks until done) under ``jax.profiler`` and return
    ``{"wall_s", "self_us", "calls"}``: the call's wall time and per-operation self times (µs) and
    call counts of the operations of ``hlo_text``."""
    ops = instruction_names(hlo_text)
    with tempfile.TemporaryDirectory() as folder:
        options = jax.profiler.ProfileOptions()
        options.python_tracer_level = 0  # Python frames would slow the callbacks they time
        jax.profiler.start_trace(folder, create_perfetto_trace=True, profiler_options=options)
        t0 = time.perf_counter()
        try:
            run()
            wall = time.perf_counter() - t0
        finally:
            jax.profiler.stop_trace()
        (path,) = glob.glob(os.path.join(folder, "**", "perfetto_trace.json.gz"), recursive=True)
        with gzip.open(path) as f:
            trace = json.load(f)
    events = trace["traceEvents"] if isinstance(trace, dict) else trace
    total, calls = self_times(events, ops)
    return {"wall_s": wall, "self_us": dict(total), "calls": dict(calls)}


def summarise(prof: dict, hlo_text: str, steps: int) -> dict:
    """Per-step tables from :func:`profile_call`'s result for a call of ``steps`` steps: time by
    kind, and every matrix product with its layout, calls per step, µs per call and GFLOP/s."""
    prods = products(hlo_text)
    by_kind = collections.Counter()
    for name, us in prof["self_us"].items():
        by_kind[kind(name)] += us
    busy = sum(by_kind.values())
    kinds = [{"kind": k, "ms_per_step": us / steps / 1e3, "share": us / busy} for k, us in by_kind.most_common()]
    rows, dot_us, dot_flops = [], 0.0, 0.0
    for name, p in prods.items():
        n = prof["calls"].get(name, 0)
        if not n:
            continue
        us = prof["self_us"][name]
        dot_us += us
        dot_flops += p.flops * n
        rows.append({"name": name, "out": list(p.out), "contracted": p.contracted, "layout": p.layout,
                     "calls_per_step": n / steps, "us_per_call": us / n, "ms_per_step": us / steps / 1e3,
                     "gflop_per_s": p.flops * n / us / 1e3})
    rows.sort(key=lambda r: -r["ms_per_step"])
    return {"wall_ms_per_step": prof["wall_s"] / steps * 1e3, "busy_ms_per_step": busy / steps / 1e3,
            "products_ms_per_step": dot_us / steps / 1e3, "products_gflop_per_step": dot_flops / steps / 1e9,
            "products_gflop_per_s": dot_flops / dot_us / 1e3 if dot_us else 0.0,
            "products_share_of_busy": dot_us / busy if busy else 0.0, "kinds": kinds, "products": rows}


def measure(config: str, lanes: int, steps: int, overrides=(), log=print) -> dict:
    """Compile the ``lanes``-lane learning-phase chunk of ``config`` (``steps`` steps per call), time
    one call, profile the next, and return the tables of :func:`summarise` with the run's facts."""
    cfg, prog, state = lanes_program(cfgmod.resolve(config, learning_phase_overrides(steps, overrides)), lanes)
    t0 = time.perf_counter()
    chunk = prog.chunk_fn.lower(state, jnp.asarray(0, jnp.int32)).compile()
    log(f"compiled the {lanes}-lane chunk in {time.perf_counter() - t0:.1f} s")
    hlo_text = chunk.as_text()
    box = [state]

    def run(call: int):
        box[0] = jax.block_until_ready(chunk(box[0], jnp.asarray(call * steps, jnp.int32))[0])

    run(0), run(1)  # warm-up: first-call allocations, the replay filling
    timed = timing.timed(run, wait=None)(2) / steps * 1e3  # call 2, timed alone (run blocks itself)
    res = summarise(profile_call(lambda: run(3), hlo_text), hlo_text, steps)
    return {"benchmark": "profile", "config": config, "overrides": list(overrides), "lanes": lanes, "steps": steps,
            "env": cfg.env.id, "backend": cfg.env.backend, "precision": cfg.precision,
            "matmul_dtype": programs.matmul_dtype(cfg)[1], "timed_ms_per_step": timed, **res,
            "machine": {"platform": jax.devices()[0].platform, "cpu": cpu_model(), "cpus": len(os.sched_getaffinity(0)),
                        "jax": jax.__version__},
            "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}


def markdown(res: dict, top: int = 20) -> str:
    """The profile as two Markdown tables: time by kind, and the ``top`` slowest products."""
    lines = [f"{res['env']} ({res['backend']}), {res['lanes']} lanes, {res['precision']}, {res['matmul_dtype']}; "
             f"{res['timed_ms_per_step']:.2f} ms per step timed, {res['wall_ms_per_step']:.2f} profiled; "
             f"XLA operations busy {res['busy_ms_per_step']:.2f} ms per step (summed over threads), "
             f"matrix products {res['products_ms_per_step']:.2f} ms ({res['products_share_of_busy']:.0%}) "
             f"at {res['products_gflop_per_s']:.1f} GFLOP/s",
             "", "| kind | ms per step | share of busy time |", "|---|---|---|"]
    lines += [f"| {k['kind']} | {k['ms_per_step']:.3f} | {k['share']:.1%} |" for k in res["kinds"][:top]]
    lines += ["", "| product | output shape | contracted | layout | calls per step | µs per call | GFLOP/s |",
              "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['name']} | {r['out']} | {r['contracted']} | {r['layout']} | {r['calls_per_step']:.2f} | "
              f"{r['us_per_call']:.1f} | {r['gflop_per_s']:.1f} |" for r in res["products"][:top]]
    return "\n".join(lines)


def _parser() -> argparse.ArgumentParser:
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.bench profile", description=__doc__.split("\n")[0])
    p.add_argument("--config", default="cheetah_relu", help="training config (default cheetah_relu)")
    p.add_argument("--lanes", type=int, default=5, help="lanes (seeds) of the program (default 5)")
    p.add_argument("--steps", type=int, default=200, help="steps per profiled call (default 200)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="config override, e.g. --set env.backend=mujoco (repeatable)")
    p.add_argument("--top", type=int, default=20, help="rows per printed table (default 20)")
    p.add_argument("--out", default=os.path.join("runs", "bench"), help="folder for the JSON (default runs/bench)")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.lanes < 1 or args.steps < 1 or args.top < 1:
            raise ValueError("--lanes, --steps and --top must be >= 1")
        res = measure(args.config, args.lanes, args.steps, tuple(args.set))
    except (ValueError, ConfigError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(markdown(res, args.top))
    write_result(args.out, "profile", res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
