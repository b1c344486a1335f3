"""``python -m swim_jax.bench activations`` and ``... rsqrt``: Swim's efficiency, measured honestly.

activations:
  (a) elementwise forward and forward+backward (value and input-gradient in one jitted call) on
      (256, 256) and (4096, 4096) arrays, float32 and float64, every Swim kernel variant and every
      rival, interleaved; medians with min–max.
  (b) the paper's Table III protocol: the TD3 actor (obs → 256 → 256 → act, tanh head, from
      swim_jax.agents.td3) forward on 256 states, each of the first 100 calls after compilation timed alone,
      mean ± std in ms, per env's sizes, float32 and float64; Swim vs Swish improvement
      = (t_swish − t_swim)/t_swim, the paper's definition (0.810 vs 0.687 ms → 17.9 %).
  (c) the full TD3 update (swim_jax.agents.td3.TD3.update: twin critics every step, delayed actor and Polyak
      every 2nd) at 256-256, batch 256, run as it is in training: a lax.scan of updates in one jit.
rsqrt:
  max relative error of every inverse-square-root variant over a sweep of float32 mantissas
  (both exponent parities), and its elementwise speed.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from swim_jax.agents.replay import Transition
from swim_jax.agents.td3 import TD3, ActivationConfig, TD3Config
from swim_jax.io import cli_parser
from swim_jax import activations as A
from swim_jax.bench.timing import calls_for, time_interleaved

# Table III environments: (observation size, action size) of the Gymnasium v5 tasks.
ENV_SIZES = {"Walker2d": (17, 6), "Hopper": (11, 3), "HalfCheetah": (17, 6), "Swimmer": (8, 2)}
DTYPES = {"float32": jnp.float32, "float64": jnp.float64}


def elementwise_candidates() -> dict:
    """name -> f(x): every Swim kernel (k = 0.5) and every rival, same calling convention."""
    cands = {}
    for variant, kernel in A.SWIM_VARIANTS.items():
        label = "swim" if variant == "default" else f"swim[{variant}]"
        cands[label] = lambda x, kernel=kernel: kernel(x, jnp.asarray(0.5, x.dtype))
    cands["swim[plain autodiff]"] = lambda x: A.swim_reference(x, 0.5)
    cands["jax.nn.swish"] = jax.nn.swish
    cands["swish"] = lambda x: A.swish(x, 1.0)
    cands["relu"] = A.relu
    cands["hard_swish"] = A.hard_swish
    cands["mish"] = A.mish
    return cands


def _fwd_bwd(f):
    """x, g -> (f(x), g·f'(x)): the forward value and the input gradient in one program."""

    def run(x, g):
        y, vjp = jax.vjp(f, x)
        return y, vjp(g)[0]

    return run


def _in_place(fn, n_in: int, n_outputs: int):
    """jit(fn) of ``n_in`` arguments that writes its ``n_outputs`` results into donated scratch
    buffers passed after those arguments.

    XLA's CPU runtime maps fresh pages for every new output buffer; at (4096, 4096) float32 that is
    16,384 page faults per call, most of the call's time. Donating a scratch buffer of the output's
    shape lets the output reuse it, so this measures the kernel itself.
    """
    return jax.jit(
        lambda *args: fn(*args[:n_in]),
        donate_argnums=tuple(range(n_in, n_in + n_outputs)),
        keep_unused=True,
    )


def bench_elementwise(shapes, dtypes, repeats: int, clock: str = "wall") -> list[dict]:
    """Section (a): median µs per call, fwd and fwd+bwd, interleaved, in two memory modes.

    ``fresh``: a plain ``jit(f)(x)`` call, which allocates (and page-faults) a new output.
    ``in-place``: outputs written into donated buffers of the same shape (the kernel's own cost).
    ``floor (negate)`` is a one-operation kernel: the part of every time that is not activation math.
    """
    rows = []
    candidates = {"floor (negate)": jnp.negative, **elementwise_candidates()}
    for dtype_name in dtypes:
        dtype = DTYPES[dtype_name]
        for shape in shapes:
            x = (3 * jax.random.normal(jax.random.key(0), shape, dtype)).block_until_ready()
            g = jnp.ones_like(x)
            cands = {}
            for name, f in candidates.items():
                fb = _fwd_bwd(f)
                fwd, fwd_bwd = jax.jit(f), jax.jit(fb)
                fwd_ip, fwd_bwd_ip = _in_place(f, 1, 1), _in_place(fb, 2, 2)
                scratch = {"fwd": jnp.zeros_like(x), "fwd+bwd": (jnp.zeros_like(x), jnp.zeros_like(x))}

                def run_fwd_ip(fn=fwd_ip, s=scratch):
                    s["fwd"] = fn(x, s["fwd"])
                    return s["fwd"]

                def run_fwd_bwd_ip(fn=fwd_bwd_ip, s=scratch):
                    s["fwd+bwd"] = fn(x, g, *s["fwd+bwd"])
                    return s["fwd+bwd"]

                cands[(name, "fwd", "fresh")] = lambda fn=fwd: fn(x)
                cands[(name, "fwd+bwd", "fresh")] = lambda fn=fwd_bwd: fn(x, g)
                cands[(name, "fwd", "in-place")] = run_fwd_ip
                cands[(name, "fwd+bwd", "in-place")] = run_fwd_bwd_ip
            calls = calls_for(cands[("jax.nn.swish", "fwd", "fresh")], target_seconds=0.02)
            timings = time_interleaved(cands, repeats=repeats, calls_per_sample=calls, clock=clock)
            for (name, pass_, mode), t in timings.items():
                ref = timings[("jax.nn.swish", pass_, mode)].median
                rows.append(
                    {
                        "dtype": dtype_name,
                        "shape": list(shape),
                        "mode": mode,
                        "pass": pass_,
                        "activation": name,
                        **{f"{k}_us": v for k, v in t.as_dict(1e6).items()},
                        "speedup_vs_jax_nn_swish": ref / t.median,
                    }
                )
    rows.sort(key=lambda r: (r["dtype"], r["shape"], r["mode"], r["pass"]))
    return rows


def _td3_agent(activation: str, obs_dim: int, act_dim: int, dtype):
    """swim_jax.agents.td3.TD3 with the reference config, the given activation, actions in [−1, 1]."""
    return TD3(
        TD3Config(activation=ActivationConfig(name=activation)),
        obs_dim=obs_dim,
        action_low=(-1.0,) * act_dim,
        action_high=(1.0,) * act_dim,
        dtype=dtype,
    )


def _actor_forward(activation: str, obs_dim: int, act_dim: int, dtype):
    """A jitted TD3 actor forward (swim_jax.agents.td3's network) and its parameters."""
    agent = _td3_agent(activation, obs_dim, act_dim, dtype)
    params = agent.init(jax.random.key(0)).actor_target
    return jax.jit(agent.act), params


def bench_actor_inference(envs, dtypes, calls: int, activations=("swish", "swim", "relu"), clock: str = "wall") -> list[dict]:
    """Section (b), Table III: each of the first ``calls`` calls after compilation timed alone."""
    rows = []
    for dtype_name in dtypes:
        dtype = DTYPES[dtype_name]
        for env in envs:
            obs_dim, act_dim = ENV_SIZES[env]
            obs = jax.random.normal(jax.random.key(1), (256, obs_dim), dtype)
            cands = {}
            for act in activations:
                fn, params = _actor_forward(act, obs_dim, act_dim, dtype)
                cands[act] = lambda fn=fn, params=params: fn(params, obs)
            timings = time_interleaved(cands, repeats=calls, calls_per_sample=1, warmup=1, clock=clock)
            swim_t, swish_t = timings["swim"], timings["swish"]
            for act, t in timings.items():
                rows.append(
                    {"dtype": dtype_name, "env": env, "activation": act, **{f"{k}_ms": v for k, v in t.as_dict().items()}}
                )
            rows.append(
                {
                    "dtype": dtype_name,
                    "env": env,
                    "activation": "swim_vs_swish",
                    "improvement_pct_mean": 100 * (swish_t.mean - swim_t.mean) / swim_t.mean,
                    "improvement_pct_median": 100 * (swish_t.median - swim_t.median) / swim_t.median,
                }
            )
    return rows


def _update_program(activation: str, dtype, obs_dim=17, act_dim=6, updates=10):
    """A compiled lax.scan of ``updates`` real TD3 updates (actor on every 2nd) on a fixed batch.

    ``activation`` is a registry name, or ``swim[<variant>]`` for a Swim kernel variant.
    """
    agent = _td3_agent(activation, obs_dim, act_dim, dtype)  # "swim[<variant>]" is a registry name
    keys = jax.random.split(jax.random.key(2), 6)
    b = agent.config.batch_size
    batch = Transition(
        obs=jax.random.normal(keys[0], (b, obs_dim), dtype),
        action=jax.random.uniform(keys[1], (b, act_dim), dtype, -1, 1),
        reward=jax.random.normal(keys[2], (b,), dtype),
        next_obs=jax.random.normal(keys[3], (b, obs_dim), dtype),
        terminated=(jax.random.uniform(keys[4], (b,)) < 0.05).astype(dtype),
    )
    state = agent.init(keys[5])

    def run(state, key):
        def body(state, i):
            new, metrics = agent.update_delayed(state, batch, jax.random.fold_in(key, i), i % 2 == 1)
            return new, metrics.critic_loss

        return jax.lax.scan(body, state, jnp.arange(updates))

    key = jax.random.key(3)
    compiled = jax.jit(run).lower(state, key).compile()
    return compiled, state


def bench_td3_update(
    dtypes,
    repeats: int,
    activations=("relu", "swish", "swim", "swim[rsqrt]", "swim[newton2+shared-s]", "hard_swish", "mish"),
    updates=10,
    clock: str = "wall",
):
    """Section (c): ms per TD3 update (critic every update, actor every 2nd), median over repeats."""
    rows = []
    for dtype_name in dtypes:
        dtype = DTYPES[dtype_name]
        cands = {}
        for act in activations:
            compiled, state = _update_program(act, dtype, updates=updates)
            key = jax.random.key(3)
            cands[act] = lambda run=compiled, state=state, key=key: run(state, key)
        timings = time_interleaved(cands, repeats=repeats, calls_per_sample=1, clock=clock)
        for act, t in timings.items():
            per_update = {f"{k}_ms": v / updates for k, v in t.as_dict().items()}
            rows.append(
                {
                    "dtype": dtype_name,
                    "activation": act,
                    **per_update,
                    "ratio_vs_swish": t.median / timings["swish"].median,
                    "ratio_vs_relu": t.median / timings["relu"].median,
                }
            )
    return rows


# ----------------------------------------------------------------------------------------------


def machine_info() -> dict:
    """What the numbers were measured on: CPU, cores, versions, XLA flags, command line."""
    cpu = platform.processor()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "jax": jax.__version__,
        "backend": jax.default_backend(),
        "devices": [str(d) for d in jax.devices()],
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
        "python": platform.python_version(),
        "command": "python -m swim_jax.bench " + " ".join(sys.argv[1:]),
        "time": _dt.datetime.now().isoformat(timespec="seconds"),
    }


def write_result(result: dict, out_dir: Path, prefix: str) -> Path:
    """Write JSON to ``out_dir/<prefix>-<timestamp>.json`` without ever overwriting a file."""
    out_dir.mkdir(parents=True, exist_ok=True)
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    path = out_dir / f"{prefix}-{stamp}.json"
    n = 1
    while path.exists():
        path = out_dir / f"{prefix}-{stamp}-{n}.json"
        n += 1
    path.write_text(json.dumps(result, indent=2))
    return path


def _print_table(title: str, rows: list[dict], columns: list[str], markdown: bool = False) -> None:
    """Print rows as an aligned text table, or as a Markdown table (``markdown=True``)."""
    print(f"\n{title}\n")
    if markdown:
        print("| " + " | ".join(columns) + " |")
        print("|" + "---|" * len(columns))
        for r in rows:
            print("| " + " | ".join(_fmt(r.get(c)) for c in columns) + " |")
        return
    widths = [max(len(c), *(len(_fmt(r.get(c))) for r in rows)) for c in columns]
    print("  ".join(c.ljust(w) for c, w in zip(columns, widths)))
    for r in rows:
        print("  ".join(_fmt(r.get(c)).ljust(w) for c, w in zip(columns, widths)))


def _fmt(v) -> str:
    if isinstance(v, float):
        if v != 0 and abs(v) < 1e-3:
            return f"{v:.2e}"
        return f"{v:.3f}" if abs(v) < 1e4 else f"{v:.0f}"
    if isinstance(v, list):
        return "x".join(map(str, v))
    return "" if v is None else str(v)


def _parse(argv, prog: str, description: str, sections: bool):
    """Options of both benchmarks; ``sections=True`` adds the activations-only ones
    (--sections, --dtypes, --from-json). Bad values: one line, exit status 2."""
    p = cli_parser.ArgumentParser(prog=prog, description=description)
    p.add_argument("--quick", action="store_true", help="small sizes and few repeats (a smoke run, ~1 min)")
    p.add_argument("--repeats", type=int, default=None, help="timed repeats per candidate (default 21; quick 5)")
    p.add_argument(
        "--clock",
        default="wall",
        choices=["wall", "cpu"],
        help="wall: elapsed time (default); cpu: this process's CPU time, for a machine shared with other jobs",
    )
    p.add_argument("--markdown", action="store_true", help="print the tables as Markdown")
    p.add_argument("--out", default="runs/bench", help="folder for the JSON result (default runs/bench)")
    if sections:
        p.add_argument("--sections", default="a,b,c", help="comma list of a (elementwise), b (actor), c (update)")
        p.add_argument("--dtypes", default="float32,float64", help="comma list of float32, float64")
        p.add_argument(
            "--from-json", default=None, help="print the tables of an earlier result file instead of measuring"
        )
    args = p.parse_args(argv)
    if args.repeats is not None and args.repeats < 1:
        p.exit(2, f"{prog}: invalid --repeats {args.repeats}; it must be >= 1\n")
    if sections:
        dtypes = [d.strip() for d in args.dtypes.split(",") if d.strip()]
        if not dtypes or any(d not in DTYPES for d in dtypes):
            p.exit(2, f"{prog}: invalid --dtypes {args.dtypes!r}; valid: float32, float64\n")
        secs = [s.strip() for s in args.sections.split(",") if s.strip()]
        if not secs or any(s not in ("a", "b", "c") for s in secs):
            p.exit(2, f"{prog}: invalid --sections {args.sections!r}; valid: a, b, c\n")
        args.dtypes, args.sections = dtypes, secs
    return args


TABLES = {
    "elementwise": (
        "(a) elementwise, median µs per call [min–max], speed-up vs jax.nn.swish",
        ["dtype", "shape", "mode", "pass", "activation", "median_us", "min_us", "max_us", "speedup_vs_jax_nn_swish"],
    ),
    "actor_inference": (
        "(b) Table III protocol: actor forward on 256 states, each of the first calls after compilation, ms",
        ["dtype", "env", "activation", "mean_ms", "std_ms", "median_ms", "improvement_pct_mean", "improvement_pct_median"],
    ),
    "td3_update": (
        "(c) one TD3 update (256-256, batch 256; actor every 2nd), ms per update",
        ["dtype", "activation", "median_ms", "min_ms", "max_ms", "ratio_vs_swish", "ratio_vs_relu"],
    ),
}


def print_result(result: dict, markdown: bool = False) -> None:
    """Print every section present in an activations result (from this run or a JSON file)."""
    m = result.get("machine", {})
    print(f"{m.get('cpu', '?')}, {m.get('cores', '?')} cores, jax {m.get('jax', '?')}; clock: {result.get('clock', 'wall')}")
    print(f"command: {m.get('command', '?')}")
    for key, (title, columns) in TABLES.items():
        if key in result:
            _print_table(title, result[key], columns, markdown)


def main(argv: list[str]) -> int:
    """``python -m swim_jax.bench activations``: sections (a), (b), (c); JSON under --out."""
    args = _parse(argv, "swim_jax.bench activations", __doc__.split("\n")[0], sections=True)
    if args.from_json:
        try:
            result = json.loads(Path(args.from_json).read_text())
        except (OSError, ValueError) as exc:
            print(f"swim_jax.bench activations: cannot read --from-json {args.from_json}: {exc}", file=sys.stderr)
            return 2
        print_result(result, args.markdown)
        return 0
    with jax.enable_x64(True):  # float64 candidates need it; float32 ones name their dtype
        result = _run_activations(args)
    print_result(result, args.markdown)
    path = write_result(result, Path(args.out), "activations")
    print(f"\nwrote {path}")
    return 0


def _run_activations(args) -> dict:
    repeats = args.repeats or (5 if args.quick else 21)
    result = {"machine": machine_info(), "repeats": repeats, "quick": args.quick, "clock": args.clock}
    if "a" in args.sections:
        shapes = [(256, 256)] if args.quick else [(256, 256), (4096, 4096)]
        result["elementwise"] = bench_elementwise(shapes, args.dtypes, repeats, args.clock)
    if "b" in args.sections:
        envs = ["Hopper"] if args.quick else list(ENV_SIZES)
        calls = 20 if args.quick else 100
        result["actor_inference"] = bench_actor_inference(envs, args.dtypes, calls, clock=args.clock)
    if "c" in args.sections:
        kwargs = {"activations": ("relu", "swish", "swim")} if args.quick else {}
        result["td3_update"] = bench_td3_update(args.dtypes, repeats, clock=args.clock, **kwargs)
    return result


def rsqrt_variants() -> dict:
    """name -> v ↦ 1/√v for every inverse-square-root variant Swim can use."""
    return {
        "lax.rsqrt": jax.lax.rsqrt,
        "1/sqrt": lambda v: 1 / jnp.sqrt(v),
        **{f"newton{n}": (lambda v, n=n: A.rsqrt_newton(v, n)) for n in (1, 2, 3)},
    }


def rsqrt_accuracy(stride: int = 1) -> dict:
    """Max relative error of each variant on every ``stride``-th float32 in [1, 4).

    [1, 4) spans two binades, i.e. every (mantissa, exponent parity) pair; the relative error of
    a bit-level guess refined by Newton steps depends only on those, so this covers all normal
    float32 inputs. The reference is 1/√v in float64.
    """
    bits = np.arange(0x3F800000, 0x40800000, stride, dtype=np.uint32)
    v = bits.view(np.float32)
    exact = 1 / np.sqrt(v.astype(np.float64))
    out = {}
    for name, fn in rsqrt_variants().items():
        y = np.asarray(jax.jit(fn)(jnp.asarray(v)), np.float64)
        out[name] = float(np.max(np.abs(y / exact - 1)))
    return out


def main_rsqrt(argv: list[str]) -> int:
    """``python -m swim_jax.bench rsqrt``: accuracy over float32 and elementwise speed."""
    args = _parse(argv, "swim_jax.bench rsqrt", "inverse square root variants", sections=False)
    repeats = args.repeats or (5 if args.quick else 21)
    errors = rsqrt_accuracy(stride=61 if args.quick else 1)
    shapes = [(256, 256)] if args.quick else [(256, 256), (4096, 4096)]
    rows = []
    for shape in shapes:
        v = (1 + jax.random.uniform(jax.random.key(0), shape, jnp.float32, 0, 100)).block_until_ready()
        cands = {name: (lambda f=jax.jit(fn): f(v)) for name, fn in rsqrt_variants().items()}
        timings = time_interleaved(
            cands, repeats=repeats, calls_per_sample=calls_for(cands["lax.rsqrt"]), clock=args.clock
        )
        for name, t in timings.items():
            rows.append(
                {
                    "shape": list(shape),
                    "variant": name,
                    "max_rel_error_f32": errors[name],
                    **{f"{k}_us": x for k, x in t.as_dict(1e6).items()},
                    "speedup_vs_lax_rsqrt": timings["lax.rsqrt"].median / t.median,
                }
            )
    _print_table(
        "inverse square root, float32: max relative error over every mantissa; median µs per call",
        rows,
        ["shape", "variant", "max_rel_error_f32", "median_us", "min_us", "max_us", "speedup_vs_lax_rsqrt"],
        args.markdown,
    )
    path = write_result({"machine": machine_info(), "rows": rows}, Path(args.out), "rsqrt")
    print(f"\nwrote {path}")
    return 0

