"""The same lanes as one process or as several: ``python -m swim_jax.bench processes``.

Runs the real ``python -m swim_jax.train`` command of a config (learning phase: one env step and
one TD3 update per step) with the same lanes in three placements, alternated in ``--rounds``:

    one-process        1 process, 1 device, every core (XLA's threads)
    host-devices       1 process, ``host_devices=P`` (the lanes split over P host devices)
    P-processes        P processes × 1 device (``jax.distributed`` on 127.0.0.1), each pinned to
                       its own core: the run's ``local_processes=P`` (swim_jax/placement/local_processes.py)

with P = the cores this process may use. Each run's ``timing.json`` gives its env-steps/s (all
lanes, chunks after the first, so compilation and the warm-up phase are excluded). Reported:
the median per placement and its ratio to ``one-process``; JSON under ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

from swim_jax.io import cli_parser
from swim_jax.io.bench_results import cpu_model, measure_and_write
from swim_jax.bench import timing

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PLACEMENTS = ("one-process", "host-devices", "processes")


def _parser() -> argparse.ArgumentParser:
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.bench processes", description=__doc__.split("\n")[0])
    p.add_argument("--config", default="cheetah_relu", help="training config (default cheetah_relu)")
    p.add_argument("--seeds", type=int, default=4, help="lanes (seeds); must divide by the cores (default 4)")
    p.add_argument("--chunk-steps", type=int, default=1000, help="learning steps per timed chunk (default 1000)")
    p.add_argument("--chunks", type=int, default=2, help="timed chunks per run, after the first (default 2)")
    p.add_argument("--rounds", type=int, default=2, help="rounds of the three placements (default 2)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="extra config override, e.g. --set env.backend=mujoco (repeatable)")
    p.add_argument("--out", default=os.path.join("runs", "bench"), help="folder of the JSON result")
    return p


def _pinned(cpus: list[int]):
    return lambda: os.sched_setaffinity(0, cpus)


def train_args(config: str, seeds: int, chunk_steps: int, chunks: int, overrides=()) -> list[str]:
    """``swim_jax.run.train`` arguments of a timed run: a warm-up chunk of ``chunk_steps`` random steps
    (with the compilation, not timed), then ``chunks`` learning chunks (one update per step)."""
    return [f"config={config}", f"seeds={seeds}", f"eval_freq={chunk_steps}", f"learning_starts={chunk_steps}",
            f"total_steps={chunk_steps * (chunks + 1)}", "eval_episodes=1", f"progress_steps={chunk_steps}",
            f"replay_size={chunk_steps * (chunks + 1)}", *overrides]


def train_rate(args: list[str], out_dir: str, placement: str, cores: list[int]) -> float:
    """One ``swim_jax.run.train args`` run in ``placement`` (one of :data:`PLACEMENTS`) on ``cores`` (for
    "processes": ``local_processes=len(cores)``, one process pinned to each); its env-steps/s (all
    lanes) from timing.json."""
    env = dict(os.environ, JAX_PLATFORMS="cpu", SWIM_JAX_NO_COMPILATION_CACHE="1")
    extra = {"one-process": [], "host-devices": [f"host_devices={len(cores)}"],
             "processes": [f"local_processes={len(cores)}"]}[placement]
    cmd = [sys.executable, "-m", "swim_jax.train", *args, *extra, f"out_dir={out_dir}"]
    pin = _pinned(cores) if placement == "processes" else None  # local_processes splits these cores
    p = subprocess.Popen(cmd, cwd=REPO, env=env, preexec_fn=pin, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    out, err = p.communicate()
    if p.returncode != 0:
        raise RuntimeError(f"{placement} run failed (exit {p.returncode}): {err.strip().splitlines()[-1:]}")
    run_dir = next(line.split(": ", 1)[1] for line in out.splitlines() if line.startswith("run dir: "))
    with open(os.path.join(run_dir, "timing.json")) as f:
        return float(json.load(f)["env_steps_per_s"])


def measure(config: str, seeds: int, chunk_steps: int, chunks: int, rounds: int, overrides=(), log=print) -> dict:
    """Env-steps/s of every placement in every round (alternated) and their medians."""
    cores = sorted(os.sched_getaffinity(0))
    if len(cores) < 2 or seeds % len(cores):
        raise ValueError(f"{seeds} lanes must divide over the {len(cores)} cores (and at least 2 cores)")
    args = train_args(config, seeds, chunk_steps, chunks, overrides)
    with tempfile.TemporaryDirectory(prefix="swim-bench-processes-") as tmp:
        def run(placement):  # a candidate: round r's run in its own folder, its reported rate
            def rate(r):
                value = train_rate(args, os.path.join(tmp, f"{placement}-{r}"), placement, cores)
                log(f"round {r + 1}: {placement}: {value:.0f} env-steps/s")
                return value
            return rate
        rates = timing.interleave({p: run(p) for p in PLACEMENTS}, rounds, rotate=False)
    medians = {p: timing.summarise(v).median for p, v in rates.items()}
    return {
        "benchmark": "processes", "config": config, "seeds": seeds, "overrides": list(overrides),
        "chunk_steps": chunk_steps, "chunks": chunks, "rounds": rounds, "cores": len(cores),
        "env_steps_per_s": rates, "median": medians,
        "ratio_vs_one_process": {p: medians[p] / medians["one-process"] for p in PLACEMENTS},
        "machine": {"cpu": cpu_model(), "cpu_count": os.cpu_count(), "python": platform.python_version()},
        "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def markdown(res: dict) -> str:
    """The result as a Markdown table (medians over the rounds; min–max)."""
    lines = [f"{res['config']} {' '.join(res['overrides'])}, {res['seeds']} lanes, {res['cores']} cores "
             f"({res['machine']['cpu']}), {res['chunks']} × {res['chunk_steps']} learning steps per run, "
             f"{res['rounds']} rounds", "",
             "| placement | env-steps/s (median) | min–max | vs one process |", "|---|---|---|---|"]
    names = {"one-process": "1 process × all cores", "host-devices": f"1 process × {res['cores']} host devices",
             "processes": f"{res['cores']} processes × 1 core"}
    for p in PLACEMENTS:
        v = res["env_steps_per_s"][p]
        lines.append(f"| {names[p]} | {res['median'][p]:.0f} | {min(v):.0f}–{max(v):.0f} | {res['ratio_vs_one_process'][p]:.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)

    def run() -> dict:
        if min(args.seeds, args.chunk_steps, args.chunks, args.rounds) < 1:
            raise ValueError("--seeds, --chunk-steps, --chunks and --rounds must be >= 1")
        return measure(args.config, args.seeds, args.chunk_steps, args.chunks, args.rounds, tuple(args.set))

    return measure_and_write(run, markdown, args.out, "processes")


if __name__ == "__main__":
    sys.exit(main())
