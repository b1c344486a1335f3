"""Variants of the training program's code, compared interleaved in one process.

    python tools/bench_program_variants.py [--config cheetah_relu] [--lanes 5] [--rounds 16] [--steps 200]
        [--variants current,kernel_nt,shared_critic_input] [--set KEY=VALUE ...]

Each variant patches the project's code (see VARIANTS), builds the ``--lanes``-lane learning-phase
program afresh (native physics, float32 products unless ``--set matmul_dtype=...``), compiles its
chunk and undoes the patch; the executables then run ``--rounds`` interleaved rounds of ``--steps``
steps each. Prints a hash of every variant's optimized HLO (equal hashes: the patch changed
nothing), the median ms per step and the median ratio of step times against the first variant.
With bfloat16 products (``--set matmul_dtype=bfloat16``) the current code already has the
``kernel_nt`` and ``shared_critic_input`` forms, so those variants compile the same program there.

The program cache (``swim_jax.run.programs._PROGRAMS``) and JAX's trace caches are cleared before every
variant: without that, every variant would compile the first one's program.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import hashlib

import flax.linen as nn
import jax
import jax.numpy as jnp
from jax import lax

from swim_jax.agents import loop, networks, td3
from swim_jax.io import cli_parser
from swim_jax import config as cfgmod
from swim_jax.run import programs
from swim_jax.bench.train import interleaved_chunk_ratios, lanes_program, learning_phase_overrides


@contextlib.contextmanager
def _patched(module, name, value):
    old = getattr(module, name)
    setattr(module, name, value)
    try:
        yield
    finally:
        setattr(module, name, old)


@functools.partial(jax.custom_vjp, nondiff_argnums=(2,))
def _nt_matmul(x, w, accumulate):
    return lax.dot_general(x, w, (((x.ndim - 1,), (0,)), ((), ())), preferred_element_type=accumulate)


def _nt_matmul_bwd(accumulate, residuals, g):
    """As ``networks._dense_matmul_bwd`` but dx = g·Wᵀ folded into one dot (the form before 38ac350)."""
    x, w = residuals
    g = g.astype(x.dtype)
    dx = lax.dot_general(g, w, (((g.ndim - 1,), (1,)), ((), ())), preferred_element_type=accumulate)
    rows_x, rows_g = x.reshape(-1, x.shape[-1]), g.reshape(-1, g.shape[-1])
    if accumulate is None:
        dw = lax.dot_general(rows_x, rows_g, (((0,), (0,)), ((), ())))
    else:
        dw = lax.dot_general(lax.optimization_barrier(rows_x.T), rows_g, (((1,), (0,)), ((), ())),
                             preferred_element_type=accumulate)
    return dx.astype(x.dtype), dw.astype(w.dtype)


_nt_matmul.defvjp(lambda x, w, acc: (_nt_matmul(x, w, acc), (x, w)), _nt_matmul_bwd)


def kernel_nt():
    """dx = g·Wᵀ as XLA folds it (an "NT" product) instead of a product with an explicit Wᵀ."""
    return _patched(networks, "dense_dot_general",
                    lambda lhs, rhs, dn, precision=None, preferred_element_type=None, *, accumulate=None:
                    _nt_matmul(lhs, rhs, accumulate))


class _SharedInputTwinCritic(networks.TwinCritic):
    """The twin critics reading one shared (obs, action) (``in_axes=None``), the form before 38ac350."""

    @nn.compact
    def __call__(self, obs, action):
        vmapped = nn.vmap(networks._Critic, variable_axes={"params": 0}, split_rngs={"params": True},
                          in_axes=None, out_axes=0, axis_size=self.num_critics)
        return vmapped(self.options, name="critics")(obs, action)


def shared_critic_input():
    """The critics' first layers merged by XLA into one wider product (shared input)."""
    return _patched(td3, "TwinCritic", _SharedInputTwinCritic)


def finite_sum():
    """The NaN/inf watch as one sum per parameter, isfinite(Σ x·0) (the same verdict)."""
    return _patched(loop, "_all_finite",
                    lambda tree: jnp.isfinite(sum(jnp.sum(x * 0) for x in jax.tree.leaves(tree))))


@contextlib.contextmanager
def threefry_unrolled():
    """Threefry lowered as on GPUs (unrolled rounds, the same bits) instead of the CPU's while loops."""
    from jax._src.interpreters import mlir
    from jax._src.random import threefry2x32 as tf
    mlir.register_lowering(tf.threefry2x32_p, tf._threefry2x32_lowering_rule, platform="cpu")
    try:
        yield
    finally:
        mlir.register_lowering(tf.threefry2x32_p, tf._threefry2x32_cpu_lowering_rule, platform="cpu")


VARIANTS = {"current": contextlib.nullcontext, "kernel_nt": kernel_nt, "shared_critic_input": shared_critic_input,
            "finite_sum": finite_sum, "threefry_unrolled": threefry_unrolled}


def _variants(text: str) -> list[str]:
    names = [n for n in text.split(",") if n]
    bad = [n for n in names if n not in VARIANTS]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"unknown variant(s) {bad or text!r}; valid: {', '.join(VARIANTS)}")
    return names


def main(argv=None) -> int:
    p = cli_parser.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--config", default="cheetah_relu")
    p.add_argument("--lanes", type=int, default=5)
    p.add_argument("--rounds", type=int, default=16)
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--variants", type=_variants, default=["current", "kernel_nt", "shared_critic_input"],
                   help=f"comma-separated, the first is the reference; valid: {', '.join(VARIANTS)}")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="config override (repeatable)")
    args = p.parse_args(argv)
    overrides = learning_phase_overrides(args.steps, ["env.backend=mujoco", "matmul_dtype=full", *args.set])
    cfg = cfgmod.resolve(args.config, overrides)
    exes, states = {}, {}
    for name in args.variants:
        programs._PROGRAMS.clear()
        jax.clear_caches()
        with VARIANTS[name]():
            _, prog, state = lanes_program(cfg, args.lanes)
            exes[name] = prog.chunk_fn.lower(state, jnp.asarray(0, jnp.int32), None).compile()
        digest = hashlib.sha256(exes[name].as_text().encode()).hexdigest()[:10]
        print(f"{name}: compiled, optimized HLO {digest}", flush=True)
        states[name] = jax.block_until_ready(exes[name](state, jnp.asarray(0, jnp.int32), None)[0])
    reference = args.variants[0]
    for name, (ms, ratio) in interleaved_chunk_ratios(exes, states, args.rounds, args.steps, reference).items():
        print(f"{name}: {ms:.2f} ms per step, ratio vs {reference} {ratio:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
