"""How many study cells to train at once: ``python -m swim_jax.bench study``.

Runs the real ``python -m swim_jax.study`` command on a study of ``--parallel``'s largest count of
cells (``--configs``, each with ``--seeds`` seeds, one warm-up chunk with the compilation, then
``--chunks`` learning chunks; swim_jax/bench/processes.py's ``train_args``) once per candidate
``--parallel P`` (P cells at once, each pinned to its 1/P share of the cores; P = 1: one cell at a
time on every core, its lanes as one program per core), the candidates alternated over ``--rounds``.
Each cell's ``timing.json`` gives its learning-phase env-steps/s (chunks after the first); a
candidate's study throughput is P × (env steps timed over all cells) / (the cells' summed training
seconds), i.e. what P cells progressing side by side deliver. Reported: medians per candidate and
each one's ratio to P = 1; JSON under ``--out``.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import tempfile
import time

import yaml

from swim_jax.io import cli_parser
from swim_jax.io.bench_results import cpu_model, measure_and_write
from swim_jax.bench import timing
from swim_jax.bench.processes import REPO


def _parser():
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.bench study", description=__doc__.split("\n")[0])
    p.add_argument("--configs", default="walker_relu,walker_swim", help="cells' configs (default walker_relu,walker_swim)")
    p.add_argument("--seeds", type=int, default=5, help="seeds per cell (default 5, the study's)")
    p.add_argument("--parallel", default="1,2", help="candidate cells at once (default 1,2)")
    p.add_argument("--chunk-steps", type=int, default=1000, help="steps per chunk (default 1000)")
    p.add_argument("--chunks", type=int, default=1, help="timed learning chunks per cell (default 1)")
    p.add_argument("--rounds", type=int, default=2, help="rounds of the candidates (default 2)")
    p.add_argument("--set", action="append", default=["env.backend=mujoco"], metavar="KEY=VALUE",
                   help="config override for every cell (default env.backend=mujoco, the study's; repeatable)")
    p.add_argument("--out", default=os.path.join("runs", "bench"), help="folder of the JSON result")
    return p


def study_file(path: str, configs: list[str], seeds: int, chunk_steps: int, chunks: int, overrides: list[str]) -> None:
    """Write the benchmark's study file: ``configs`` as cells, each a short timed run."""
    over = {"eval_freq": chunk_steps, "learning_starts": chunk_steps, "eval_episodes": 1,
            "progress_steps": chunk_steps, "replay_size": chunk_steps * (chunks + 1)}
    for item in overrides:
        k, v = item.split("=", 1)
        over[k] = yaml.safe_load(v)
    with open(path, "w") as f:
        yaml.safe_dump({"name": "bench", "configs": configs, "seeds": seeds,
                        "total_steps": chunk_steps * (chunks + 1), "overrides": over}, f)


def study_rate(path: str, out_dir: str, parallel: int) -> dict:
    """One run of the study at ``path`` with ``--parallel``: its wall time and throughput."""
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    t0 = time.time()
    p = subprocess.run([sys.executable, "-m", "swim_jax.study", path, "--out-dir", out_dir, "--parallel", str(parallel)],
                       cwd=REPO, env=env, capture_output=True, text=True)
    wall = time.time() - t0
    if p.returncode != 0:
        raise RuntimeError(f"--parallel {parallel} failed (exit {p.returncode}): {p.stdout.strip().splitlines()[-1:]}")
    steps, train_s = 0.0, 0.0
    for cell in sorted(os.listdir(out_dir)):
        with open(os.path.join(out_dir, cell, "timing.json")) as f:
            t = json.load(f)
        steps += t["env_steps_per_s"] * t["train_time_s_excluding_first_chunk"]
        train_s += t["train_time_s_excluding_first_chunk"]
    return {"wall_s": wall, "env_steps_per_s": parallel * steps / train_s}


def measure(configs: list[str], seeds: int, parallel: list[int], chunk_steps: int, chunks: int, rounds: int,
            overrides: list[str], log=print) -> dict:
    """Every candidate's study throughput in every round (alternated) and their medians."""
    with tempfile.TemporaryDirectory(prefix="swim-bench-study-") as tmp:
        path = os.path.join(tmp, "bench.yaml")
        study_file(path, configs, seeds, chunk_steps, chunks, overrides)

        def run(p):  # a candidate: round r's study in its own folder, its wall time and throughput
            def measured(r):
                res = study_rate(path, os.path.join(tmp, f"p{p}-{r}"), p)
                log(f"round {r + 1}: --parallel {p}: {res['env_steps_per_s']:.0f} env-steps/s "
                    f"(study wall {res['wall_s']:.0f} s)")
                return res
            return measured
        runs = timing.interleave({p: run(p) for p in parallel}, rounds, rotate=False)
    rates = {p: [res["env_steps_per_s"] for res in v] for p, v in runs.items()}
    walls = {p: [res["wall_s"] for res in v] for p, v in runs.items()}
    medians = {p: timing.summarise(v).median for p, v in rates.items()}
    return {
        "benchmark": "study", "configs": configs, "seeds": seeds, "overrides": overrides,
        "chunk_steps": chunk_steps, "chunks": chunks, "rounds": rounds, "cores": len(os.sched_getaffinity(0)),
        "env_steps_per_s": {str(p): v for p, v in rates.items()}, "wall_s": {str(p): v for p, v in walls.items()},
        "median": {str(p): m for p, m in medians.items()},
        "ratio_vs_parallel_1": {str(p): medians[p] / medians[parallel[0]] for p in parallel},
        "machine": {"cpu": cpu_model(), "cpu_count": os.cpu_count(), "python": platform.python_version()},
        "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def markdown(res: dict) -> str:
    """The result as a Markdown table (medians over the rounds; min–max)."""
    lines = [f"{', '.join(res['configs'])} × {res['seeds']} seeds, {' '.join(res['overrides'])}, {res['cores']} cores "
             f"({res['machine']['cpu']}), {res['chunks']} × {res['chunk_steps']} learning steps per cell, "
             f"{res['rounds']} rounds", "",
             "| cells at once | study env-steps/s (median) | min–max | vs the first |", "|---|---|---|---|"]
    for p, v in res["env_steps_per_s"].items():
        lines.append(f"| {p} | {res['median'][p]:.0f} | {min(v):.0f}–{max(v):.0f} | {res['ratio_vs_parallel_1'][p]:.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)

    def run() -> dict:
        parallel = [int(x) for x in args.parallel.split(",")]
        configs = args.configs.split(",")
        if min(args.seeds, args.chunk_steps, args.chunks, args.rounds, *parallel) < 1:
            raise ValueError("--seeds, --chunk-steps, --chunks, --rounds and --parallel must be >= 1")
        if max(parallel) > len(configs):
            raise ValueError(f"--parallel {max(parallel)} needs at least that many --configs, got {len(configs)}")
        return measure(configs, args.seeds, parallel, args.chunk_steps, args.chunks, args.rounds, args.set)

    return measure_and_write(run, markdown, args.out, "study")


if __name__ == "__main__":
    sys.exit(main())
