"""Benchmarks: ``python -m swim_jax.bench {activations,rsqrt,envs,train,processes,study,profile,checkpoint,startup} [options]``.

Every benchmark compiles first, interleaves its candidates in one process, prints a table of
medians (and min–max), and writes a JSON file under runs/bench/. See docs/BENCHMARKS.md for the
figures measured on this project's machines and the commands that produced them.
"""

from __future__ import annotations

import sys

USAGE = """usage: python -m swim_jax.bench {activations,rsqrt,envs,train,processes,study,profile,checkpoint,startup} [options]
  activations  elementwise fwd / fwd+bwd, TD3 actor inference (Table III), full TD3 update
  rsqrt        accuracy (every float32 mantissa) and speed of the inverse-square-root variants
  envs         MJX env steps/s vs native MuJoCo
  train        whole training program (env step + update) throughput vs number of lanes/seeds
  processes    the same lanes as 1 process, 1 process × N host devices, N processes × 1 core
  study        study cells one at a time on all cores vs N at once, each on its own cores
  profile      where a training step's time goes: XLA operations by kind, matrix products' rates
  checkpoint   a checkpoint's seconds and disk at the main job's scale: whole state vs appended replay
  startup      seconds to the main job's first lines and its longest silence, cold and warm caches
run a subcommand with --help for its options"""


def main(argv: list[str] | None = None) -> int:
    """Dispatch to a benchmark; unknown subcommands exit with status 2 and the valid ones."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(USAGE)
        return 0 if argv else 2
    command, rest = argv[0], argv[1:]
    # each benchmark is imported only when chosen: its imports load what it times (envs, agents)
    if command == "activations":
        from swim_jax.bench_activations import main as run
    elif command == "rsqrt":
        from swim_jax.bench_activations import main_rsqrt as run
    elif command == "train":
        from swim_jax.bench_train import main as run
    elif command == "processes":
        from swim_jax.bench_processes import main as run
    elif command == "study":
        from swim_jax.bench_study import main as run
    elif command == "profile":
        from swim_jax.bench_profile import main as run
    elif command == "checkpoint":
        from swim_jax.bench_checkpoint import main as run
    elif command == "startup":
        from swim_jax.bench_startup import main as run
    elif command == "envs":
        try:
            from envs.bench import main as run
        except ImportError as exc:  # pragma: no cover - depends on the envs package state
            print(f"swim_jax.bench: the envs benchmark is unavailable: {exc}", file=sys.stderr)
            return 2
    else:
        print(
            f"swim_jax.bench: unknown benchmark {command!r}; valid: activations, rsqrt, envs, train, processes, study, profile, checkpoint, startup",
            file=sys.stderr,
        )
        return 2
    status = run(rest)
    return status if isinstance(status, int) else 0  # envs.bench.main returns its result dict


if __name__ == "__main__":
    sys.exit(main())
