"""XLA CPU compiler options for the training chunk, compared interleaved in one process.

    python tools/bench_compiler_options.py [--config cheetah_relu] [--lanes 5] [--rounds 10] [--steps 200]
        [--options NAME:KEY=VALUE[,KEY=VALUE] ...]

The chunk of a ``--lanes``-lane learning-phase program (native physics, float32 products,
``learning_starts=0``) is lowered once and compiled with each option set below (and each
``--options`` set); the executables then run ``--rounds`` interleaved rounds of ``--steps`` steps
each. Prints the median ms per step and the median ratio of step times against XLA's defaults (the
project's own default, ``xla_cpu_ynn_fusions=false``, is "ynn_off"; ``--options`` sets also start
from XLA's defaults).
"""

from __future__ import annotations

import argparse

import jax
import jax.numpy as jnp

from swim_jax.io import cli_parser
from swim_jax import config as cfgmod
from swim_jax.bench.train import interleaved_chunk_ratios, lanes_program, learning_phase_overrides

OPTION_SETS = {
    "xla_default": {},
    "ynn_off": {"xla_cpu_experimental_ynn_fusion_type": ""},
    "ynn_single_dots": {"xla_cpu_experimental_ynn_fusion_type": "LIBRARY_FUSION_TYPE_INDIVIDUAL_DOT"},
    "no_eigen_threads": {"xla_cpu_multi_thread_eigen": False},
    "ynn_off_no_eigen_threads": {"xla_cpu_experimental_ynn_fusion_type": "", "xla_cpu_multi_thread_eigen": False},
}


def _option_set(text: str) -> tuple[str, dict]:
    """``NAME:KEY=VALUE[,KEY=VALUE]`` → (NAME, {KEY: VALUE}); true/false become booleans, integers ints."""
    name, sep, body = text.partition(":")
    if not name or not sep:
        raise argparse.ArgumentTypeError(f"expected NAME:KEY=VALUE[,KEY=VALUE], got {text!r}")
    options = {}
    for item in filter(None, body.split(",")):
        key, eq, value = item.partition("=")
        if not eq:
            raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {item!r} in {text!r}")
        options[key] = {"true": True, "false": False}.get(value.lower(), int(value) if value.lstrip("-").isdigit() else value)
    return name, options


def main(argv=None) -> int:
    p = cli_parser.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--config", default="cheetah_relu")
    p.add_argument("--rounds", type=int, default=10)
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--lanes", type=int, default=5)
    p.add_argument("--options", type=_option_set, action="append", default=[], metavar="NAME:KEY=VALUE[,KEY=VALUE]",
                   help="one more option set, e.g. no_tiling:xla_cpu_use_fusion_emitters=false (repeatable)")
    args = p.parse_args(argv)
    steps = args.steps
    overrides = ["env.backend=mujoco", "matmul_dtype=full",  # float32 products: YNNPACK off cannot run bf16 ones
                 # the chunk jitted with XLA's own options; each set below adds its own
                 "xla_cpu_ynn_fusions=true"]
    _, prog, state0 = lanes_program(cfgmod.resolve(args.config, learning_phase_overrides(steps, overrides)), args.lanes)
    init = lambda: jax.tree.map(jnp.copy, state0)
    lowered = prog.chunk_fn.lower(init(), jnp.asarray(0, jnp.int32), None)
    exes, states = {}, {}
    for name, options in {**OPTION_SETS, **dict(args.options)}.items():
        exes[name] = lowered.compile(compiler_options=options) if options else lowered.compile()
        ynn = "__ynn_fusion" in exes[name].as_text()
        print(f"{name}: compiled, YNNPACK fusions {'present' if ynn else 'absent'}", flush=True)
        states[name] = jax.block_until_ready(exes[name](init(), jnp.asarray(0, jnp.int32), None)[0])
    for name, (ms, ratio) in interleaved_chunk_ratios(exes, states, args.rounds, steps, "xla_default").items():
        print(f"{name}: {ms:.2f} ms per step, ratio vs XLA default {ratio:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
