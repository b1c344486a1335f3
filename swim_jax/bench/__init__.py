"""Benchmarks: ``python -m swim_jax.bench SUBCOMMAND [options]`` (the list: ``COMMANDS``).

Every benchmark compiles first, interleaves its candidates in one process, prints a table of
medians (and min–max), and writes a JSON file under runs/bench/. docs/PERFORMANCE.md holds the
current figures behind the defaults, each with the command that produced it and how to measure.
"""

from __future__ import annotations

import importlib
import sys

# subcommand -> (module, function, one line); each module is imported only when chosen: its imports
# load what it times (envs, agents)
COMMANDS = {
    "activations": ("activations", "main", "elementwise fwd / fwd+bwd, TD3 actor inference (Table III), full TD3 update"),
    "rsqrt": ("activations", "main_rsqrt", "accuracy (every float32 mantissa) and speed of the inverse-square-root variants"),
    "envs": ("envs", "main", "MJX env steps/s vs native MuJoCo"),
    "train": ("train", "main", "whole training program (env step + update) throughput vs number of lanes/seeds"),
    "roofline": ("roofline", "main", "the matmul roofline of one TD3 update on this CPU"),
    "sgemm": ("sgemm", "main", "the update's products on one core: XLA's kernels vs OpenBLAS (NumPy), shape by shape"),
    "processes": ("processes", "main", "the same lanes as 1 process, 1 process × N host devices, N processes × 1 core"),
    "study": ("study", "main", "study cells one at a time on all cores vs N at once, each on its own cores"),
    "profile": ("profile", "main", "where a training step's time goes: XLA operations by kind, matrix products' rates"),
    "checkpoint": ("checkpoint", "main", "a checkpoint's seconds and disk at the main job's scale: whole state vs appended replay"),
    "startup": ("startup", "main", "seconds to the main job's first lines and its longest silence, cold and warm caches"),
}
USAGE = "\n".join(
    [f"usage: python -m swim_jax.bench {{{','.join(COMMANDS)}}} [options]"]
    + [f"  {name:<12} {line}" for name, (_, _, line) in COMMANDS.items()]
    + ["run a subcommand with --help for its options"]
)


def main(argv: list[str] | None = None) -> int:
    """Dispatch to a benchmark; unknown subcommands exit with status 2 and the valid ones."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(USAGE)
        return 0 if argv else 2
    command, rest = argv[0], argv[1:]
    if command not in COMMANDS:
        print(f"swim_jax.bench: unknown benchmark {command!r}; valid: {', '.join(COMMANDS)}", file=sys.stderr)
        return 2
    module, function, _ = COMMANDS[command]
    run = getattr(importlib.import_module(f"swim_jax.bench.{module}"), function)
    status = run(rest)
    return status if isinstance(status, int) else 0  # the envs benchmark returns its result dict
