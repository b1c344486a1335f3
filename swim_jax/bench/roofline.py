"""The matmul roofline of one TD3 update: how fast this CPU runs the update's own matrix products.

:func:`update_dots` lists every ``dot_general`` of one update (critic step, and the actor step on
every ``policy_freq``-th update) from its jaxpr: operand shapes, dimension numbers and the
operand dtype (bfloat16 where ``matmul_dtype=bfloat16``). :func:`time_dots` compiles each distinct
product alone and times it (median of interleaved repeats), so

    roofline rate R = Σ FLOPs of the update's products / Σ their standalone times   (FLOP/s)

is the best an update made only of those products could do here, with XLA's own GEMM kernels.
``python -m swim_jax.bench roofline --config cheetah_relu`` prints R on all cores (this process) and on
one core (a child process pinned to one CPU with XLA's intra-op threading off), as JSON;
``swim_jax.bench train`` reports the training program's update rate as a fraction of
``cores × R(one core)``: lanes spread over cores, each product single-threaded, is the ceiling.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np
from jax._src.interpreters.partial_eval import dce_jaxpr  # pinned by requirements.lock
from jax.extend.core import jaxprs_in_params

from swim_jax.agents.replay import Transition
from swim_jax.io import cli_parser
from swim_jax import config as cfgmod
from swim_jax.run.programs import build
from swim_jax.bench import timing


@dataclass(frozen=True)
class Dot:
    """One matrix product: operand shapes, ``lax.dot_general`` dimension numbers, operand and
    result dtypes."""

    lhs: tuple
    rhs: tuple
    dimension_numbers: tuple
    dtype: str
    out_dtype: str

    @property
    def flops(self) -> float:
        """2 · batch · M · N · K (multiply and add per term)."""
        (lc, rc), (lb, _rb) = self.dimension_numbers
        k = int(np.prod([self.lhs[i] for i in lc]))
        batch = int(np.prod([self.lhs[i] for i in lb]))
        m = int(np.prod([d for i, d in enumerate(self.lhs) if i not in lc and i not in lb]))
        n = int(np.prod([d for i, d in enumerate(self.rhs) if i not in rc and i not in _rb]))
        return 2.0 * batch * m * n * k


def _walk(jaxpr, out: list, heavy_branch: bool) -> None:
    """Append the dots of ``jaxpr`` (recursively) to ``out``; of a ``cond`` only one branch: the
    one with the most FLOPs if ``heavy_branch``, else the one with the fewest (the update's only
    cond is "actor step or skip")."""
    for eqn in jaxpr.eqns:
        if eqn.primitive.name == "dot_general":
            a, b = (v.aval for v in eqn.invars)
            dn = eqn.params["dimension_numbers"]
            dn = tuple(tuple(tuple(int(i) for i in x) for x in pair) for pair in dn)
            out.append(Dot(tuple(a.shape), tuple(b.shape), dn, str(a.dtype), str(eqn.outvars[0].aval.dtype)))
        elif eqn.primitive.name == "cond":
            per_branch = []
            for br in eqn.params["branches"]:
                dots: list[Dot] = []
                _walk(br.jaxpr, dots, heavy_branch)
                per_branch.append(dots)
            cost = lambda ds: sum(d.flops for d in ds)
            out.extend((max if heavy_branch else min)(per_branch, key=cost))
        else:
            for sub in jaxprs_in_params(eqn.params):
                _walk(sub, out, heavy_branch)


def update_dots(agent) -> dict[bool, list[Dot]]:
    """``{False: dots of a critic-only update, True: dots of an update with the actor step}`` for
    one lane of ``agent`` (a ``TD3``), read from the jaxpr of ``agent.update`` after dead-code
    elimination (a custom derivative, e.g. ``swim_jax.agents.networks.dense_dot_general``, computes the
    cotangent of every input, also of the batch, which XLA then drops as unused)."""
    b, o, a = agent.config.batch_size, agent.obs_dim, agent.action_dim
    z = lambda *shape: jnp.zeros(shape, agent.dtype)
    batch = Transition(z(b, o), z(b, a), z(b), z(b, o), z(b))
    state = jax.eval_shape(agent.init, jax.random.key(0))
    out = {}
    for with_actor in (False, True):
        jaxpr = jax.make_jaxpr(lambda s, bt, k: agent.update_delayed(s, bt, k, jnp.asarray(with_actor)))(
            state, batch, jax.random.key(1))
        live, _ = dce_jaxpr(jaxpr.jaxpr, [True] * len(jaxpr.jaxpr.outvars))
        dots: list[Dot] = []
        _walk(live, dots, heavy_branch=with_actor)
        out[with_actor] = dots
    return out


def _product_loop(d: Dot, n: int):
    """Jitted ``f(lhs, rhs)``: the product ``d`` ``n`` times in a ``fori_loop``, each iteration's
    lhs carrying one entry of the previous result (an O(1) in-place update) so that XLA can
    neither hoist the product out of the loop nor skip iterations; no dispatch per product."""

    def body(_, lhs_rhs):
        lhs, rhs = lhs_rhs
        r = jax.lax.dot_general(lhs, rhs, d.dimension_numbers, preferred_element_type=d.out_dtype)
        flat = lhs.reshape(-1).at[0].set(r.reshape(-1)[0].astype(lhs.dtype))
        return flat.reshape(lhs.shape), rhs

    return jax.jit(lambda lhs, rhs: jax.lax.fori_loop(0, n, body, (lhs, rhs))[0])


def time_dots(dots: list[Dot], repeats: int = 7, loop: int = 50) -> dict[Dot, float]:
    """Median seconds of each distinct product compiled alone (random operands, ``loop``
    products per call, see :func:`_product_loop`), interleaved over ``repeats`` rounds."""
    candidates = {}
    for d in set(dots):
        rng = np.random.default_rng(0)
        x = jnp.asarray(rng.normal(size=d.lhs), d.dtype)
        y = jnp.asarray(rng.normal(size=d.rhs), d.dtype)
        f = _product_loop(d, loop)
        jax.block_until_ready(f(x, y))
        candidates[d] = timing.timed(lambda _r, f=f, x=x, y=y: f(x, y))
    samples = timing.interleave(candidates, repeats, rotate=False)
    return {d: timing.summarise(s).median / loop for d, s in samples.items()}


def roofline(agent, repeats: int = 7) -> dict:
    """Roofline of one update of ``agent`` here: FLOPs and standalone time of its products,
    averaged over the policy delay, and their rate R (GFLOP/s)."""
    by_kind = update_dots(agent)
    times = time_dots([d for ds in by_kind.values() for d in ds], repeats)
    d = agent.config.policy_freq
    per = {k: (sum(x.flops for x in ds), sum(times[x] for x in ds)) for k, ds in by_kind.items()}
    flops = ((d - 1) * per[False][0] + per[True][0]) / d
    seconds = ((d - 1) * per[False][1] + per[True][1]) / d
    return {"update_matmul_gflop": flops / 1e9, "update_matmul_s": seconds,
            "roofline_gflop_per_s": flops / seconds / 1e9, "distinct_products": len(times),
            "products_per_update": {str(k): len(v) for k, v in by_kind.items()}}


def one_core_roofline(config: str, overrides=(), timeout: float = 600.0) -> dict:
    """:func:`roofline` measured in a child process pinned to one CPU with XLA's intra-op
    threading off (the setting of a lane placed alone on a core)."""
    env = dict(os.environ)
    env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") + " --xla_cpu_multi_thread_eigen=false").strip()
    cmd = [sys.executable, "-m", "swim_jax.bench", "roofline", "--config", config, "--pin-one-core",
           *(f"--set={o}" for o in overrides)]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.bench roofline", description=__doc__.split("\n")[0])
    p.add_argument("--config", default="cheetah_relu")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--pin-one-core", action="store_true", help="pin this process to one CPU first")
    args = p.parse_args(argv)
    if args.pin_one_core:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    try:
        cfg = cfgmod.resolve(args.config, args.set)
    except cfgmod.ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    _env, _eval_env, agent = build(cfg)
    res = roofline(agent)
    res["threads"] = "one core" if args.pin_one_core else f"{len(os.sched_getaffinity(0))} cores"
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
