"""How soon the main job speaks: ``python -m swim_jax.bench startup``.

Runs the real command, ``python -m swim_jax.train config=<config> [--set ...]``, in a fresh
process per candidate ``--backends`` × {cold, warm}: ``cold`` with empty caches (a new
``XDG_CACHE_HOME``: no JAX compilation cache, no built native library, as on a fresh machine),
``warm`` right after it with the caches that run left (``--warm-runs N``: N such runs, ``warm 2``
… each with the caches of all before it). Each run is stopped once its progress line
for step ``--until-step`` is printed (or after ``--timeout`` seconds). Reported per run, from the
moment the command was started: seconds to its first line, to its first progress line (the
``step N/...`` line of the first chunk) and to the ``--until-step`` line, and the longest silence
between two lines. JSON under ``--out``.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time

from swim_jax.io import cli_parser
from swim_jax.io.bench_results import cpu_model, write_result
from swim_jax.bench.processes import REPO

_STEP = re.compile(r"^step\s+(\d+)/")


def _parser():
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.bench startup", description=__doc__.split("\n")[0])
    p.add_argument("--config", default="walker_swim", help="config (default walker_swim, the main job)")
    p.add_argument("--backends", default="mujoco,mjx", help="env.backend values (default mujoco,mjx)")
    p.add_argument("--until-step", type=int, default=5000, help="stop after this step's progress line (default 5000)")
    p.add_argument("--timeout", type=float, default=1200.0, help="seconds per run at most (default 1200)")
    p.add_argument("--warm-runs", type=int, default=1,
                   help="warm runs after the cold one, each with the caches the runs before it left (default 1)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="extra config override (repeatable)")
    p.add_argument("--out", default=os.path.join("runs", "bench"), help="folder of the JSON result")
    return p


def timed_lines(cmd: list[str], env: dict, until_step: int, timeout: float) -> dict:
    """Run ``cmd``; the seconds (from its start) of every stdout line until the progress line of
    ``until_step``, then stop it. Returns first/first-progress/until times and the longest gap."""
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    timer = threading.Timer(timeout, p.kill)
    timer.start()
    lines: list[tuple[float, str]] = []
    reached = False
    try:
        for line in p.stdout:
            lines.append((time.monotonic() - t0, line.rstrip("\n")))
            m = _STEP.match(line)
            if m and int(m.group(1)) >= until_step:
                reached = True
                break
    finally:
        timer.cancel()
        p.kill()
        p.wait()
    times = [t for t, _ in lines]
    gaps = [b - a for a, b in zip([0.0] + times, times)]
    first_progress = next((t for t, line in lines if _STEP.match(line)), None)
    return {"first_line_s": times[0] if times else None, "first_progress_line_s": first_progress,
            "until_step_s": times[-1] if reached else None, "longest_silence_s": max(gaps) if gaps else None,
            "lines": [f"{t:7.1f}  {line}" for t, line in lines]}


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module docstring)."""
    args = _parser().parse_args(argv)
    backends = [b for b in args.backends.split(",") if b]
    bad = [b for b in backends if b not in ("mujoco", "mjx", "auto")]
    if bad or not backends:
        _parser().error(f"--backends {args.backends!r}: valid: auto, mjx, mujoco (comma-separated)")
    if args.until_step < 1 or args.timeout <= 0 or args.warm_runs < 1:
        _parser().error("--until-step, --timeout and --warm-runs must be positive")
    runs = []
    for backend in backends:
        cache = tempfile.mkdtemp(prefix="bench-startup-cache-")
        out = tempfile.mkdtemp(prefix="bench-startup-runs-")
        try:
            for kind in ["cold", "warm"] + [f"warm {i}" for i in range(2, args.warm_runs + 1)]:
                env = dict(os.environ, XDG_CACHE_HOME=cache, JAX_PLATFORMS="cpu", PYTHONUNBUFFERED="1")
                env.pop("SWIM_JAX_NO_COMPILATION_CACHE", None)
                cmd = [sys.executable, "-m", "swim_jax.train", f"config={args.config}", f"env.backend={backend}",
                       f"out_dir={out}", *args.set]
                r = timed_lines(cmd, env, args.until_step, args.timeout)
                r.update(backend=backend, cache=kind, command=" ".join(cmd[1:]))
                runs.append(r)
                print(f"{backend} {kind}: first line {r['first_line_s']:.1f} s, first progress line "
                      f"{r['first_progress_line_s'] or float('nan'):.1f} s, step {args.until_step} "
                      f"{r['until_step_s'] or float('nan'):.1f} s, longest silence {r['longest_silence_s']:.1f} s",
                      flush=True)
        finally:
            shutil.rmtree(cache, ignore_errors=True)
            shutil.rmtree(out, ignore_errors=True)
    result = {"config": args.config, "until_step": args.until_step, "set": args.set, "cpu": cpu_model(),
              "cores": len(os.sched_getaffinity(0)), "runs": runs}
    print(f"\n{args.config}, {result['cpu']}, {result['cores']} cores (seconds from the command's start)\n")
    print(f"| backend | caches | first line | first progress line | step {args.until_step} line | longest silence |")
    print("|---|---|---|---|---|---|")
    fmt = lambda x: "—" if x is None else f"{x:.0f}"  # noqa: E731
    for r in runs:
        print(f"| {r['backend']} | {r['cache']} | {fmt(r['first_line_s'])} | {fmt(r['first_progress_line_s'])} | "
              f"{fmt(r['until_step_s'])} | {fmt(r['longest_silence_s'])} |")
    write_result(args.out, "startup", result)
    return 0
