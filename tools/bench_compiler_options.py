"""XLA CPU compiler options for the training chunk, compared interleaved in one process.

    python tools/bench_compiler_options.py [--config cheetah_relu] [--rounds 10] [--steps 200]

The chunk of a 5-lane learning-phase program (native physics, ``learning_starts=0``) is lowered
once and compiled with each option set below; the executables then run ``--rounds`` interleaved
rounds of ``--steps`` steps each. Prints the median ms per step and the median ratio of step times
against XLA's defaults (the project's own default, ``xla_cpu_ynn_fusions=false``, is "ynn_off").
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

import jax
import jax.numpy as jnp

from swim_jax import config as cfgmod
from swim_jax import programs

OPTION_SETS = {
    "xla_default": {},
    "ynn_off": {"xla_cpu_experimental_ynn_fusion_type": ""},
    "ynn_single_dots": {"xla_cpu_experimental_ynn_fusion_type": "LIBRARY_FUSION_TYPE_INDIVIDUAL_DOT"},
    "no_eigen_threads": {"xla_cpu_multi_thread_eigen": False},
    "ynn_off_no_eigen_threads": {"xla_cpu_experimental_ynn_fusion_type": "", "xla_cpu_multi_thread_eigen": False},
}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--config", default="cheetah_relu")
    p.add_argument("--rounds", type=int, default=10)
    p.add_argument("--steps", type=int, default=200)
    args = p.parse_args(argv)
    steps = args.steps
    cfg = cfgmod.resolve(args.config, [f"eval_freq={steps}", f"total_steps={steps}", "learning_starts=0",
                                       "replay_size=100000", f"progress_steps={steps}", "env.backend=mujoco",
                                       # the chunk jitted with XLA's own options; each set below adds its own
                                       "xla_cpu_ynn_fusions=true"])
    prog = programs.programs(dataclasses.replace(cfg, seeds=5, pad_single_seed=False))
    init = lambda: prog.init_fn(jnp.asarray(0, jnp.uint32), jnp.arange(5, dtype=jnp.int32))
    lowered = prog.chunk_fn.lower(init(), jnp.asarray(0, jnp.int32), None)
    exes, states, times = {}, {}, {}
    for name, options in OPTION_SETS.items():
        exes[name] = lowered.compile(compiler_options=options) if options else lowered.compile()
        ynn = "__ynn_fusion" in exes[name].as_text()
        print(f"{name}: compiled, YNNPACK fusions {'present' if ynn else 'absent'}", flush=True)
        states[name] = jax.block_until_ready(exes[name](init(), jnp.asarray(0, jnp.int32), None)[0])
        times[name] = []
    for r in range(args.rounds):
        for name, exe in exes.items():
            t0 = time.perf_counter()
            states[name] = jax.block_until_ready(exe(states[name], jnp.asarray(steps * (r + 1), jnp.int32), None)[0])
            times[name].append((time.perf_counter() - t0) / steps * 1e3)
    base = times["xla_default"]
    for name, t in times.items():
        ratio = statistics.median([a / b for a, b in zip(t, base)])
        print(f"{name}: {statistics.median(t):.2f} ms per step, ratio vs XLA default {ratio:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
