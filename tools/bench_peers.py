"""Peer throughput benchmark: reference TD3 programs run the way a user runs them vs our program.

Set-up (once; the peers' packages stay OUT of the project's dependencies, in their own venv):

    python3 -m venv ~/peers-venv
    ~/peers-venv/bin/pip install -c requirements.lock "gymnasium[mujoco]" jax flax optax \
        && ~/peers-venv/bin/pip install torch==2.13.0

(torch is installed in a second, unconstrained step: torch → sympy needs mpmath < 1.4, which conflicts
with the lock's mpmath pin, so ``pip install torch==2.13.0 -c requirements.lock ...`` in one command
is unsatisfiable. The first step pins gymnasium/mujoco/jax/flax/optax to the project's versions.)

Run (on an otherwise idle machine):

    python tools/bench_peers.py --envs HalfCheetah-v5,Hopper-v5,Walker2d-v5,Swimmer-v5 --steps 1000 \
        --rounds 3 --lanes 5 --peer-python ~/peers-venv/bin/python --out runs/bench

Method. A user running S seeds of a reference implementation on a P-core machine runs one process
per seed, P at a time, each single-threaded. So each peer is measured as P concurrent single-threaded
processes (``tools/peers_td3.py``; P = ``--procs``, default ``os.cpu_count()``; seeds 0..P-1), and
its throughput is the AGGREGATE rate, the sum over the P processes of their env-steps/s in the
learning phase (one env step + one training iteration per step). The processes first warm up
(``--warmup`` random steps filling the replay buffer, 50 untimed learning steps for JIT / allocator
warm-up), then wait at a barrier so that their ``--steps`` timed steps run at the same time. The
peers are

* ``pytorch``: Fujimoto et al.'s original TD3 (the transcription in tools/bench_pytorch_td3.py),
* ``cleanrl``: a cleanrl-style JAX TD3 (td3_continuous_action_jax.py) on Gymnasium's own env,

both run with ``--peer-python`` (a Python that has torch, jax, flax, optax, gymnasium[mujoco]).

Ours is ONE process as our users run it (on several cores the default ``lane_groups=true``: one
program per core on its own host CPU device; ``native-one-program``: one program for all lanes,
JAX's default threading): the project's own
whole-program benchmark ``python -m swim_jax.bench train`` for the env's ``*_relu`` config with
``--lanes`` lanes (seeds of one vmapped program, every step an update), ``--chunk-steps`` = ``--steps``,
timed for both env backends (MJX and ``env.backend=mujoco``) with float32 matmuls
(``matmul_dtype=full``) and for native physics with bfloat16 matmuls (``matmul_dtype=bfloat16``, what
``auto`` picks on a CPU with AVX-512 BF16 or AMX), or only the rows named by ``--ours`` (e.g.
``--ours native`` for the float32 native row alone: more rounds in the same time;
``--ours native,native-one-program`` for lane groups against one program); its env-steps/s
count all lanes. Ours runs with
this script's own Python (``sys.executable``).

For each env, each of ``--rounds`` rounds runs (a) the pytorch peer, (b) the cleanrl peer, (c) ours,
one after the other, the order rotated from round to round so slow drifts of the machine (heat,
background load) do not favour one program. Reported per env and program: the median over rounds of
the aggregate env-steps/s, its min–max, and for ours the ratio ours / best peer (medians) and the
paired ratios: ours / the best peer of the same round, per round and their median. The JSON
written to ``<out>/peers-<UTC stamp>.json`` has every raw number (each process's JSON line, each of
our bench runs' JSON), the CPU model (lscpu), date and command line; it is rewritten after every env
(``finished`` stays null until the last), so an interrupted run keeps the envs it completed. Also recorded per peer run: the
wall-clock aggregate P·steps / (last end − first start), the overlap of the P timed windows and the
CPU time per wall second of each process (≈ 1 for a really single-threaded process).

``--our-processes P`` (P > 1) adds a row: ours with the same lanes as P ``jax.distributed`` processes,
one pinned to each core (the real ``python -m swim_jax.train`` command; env-steps/s of its one timed
learning chunk of ``--steps`` steps from timing.json; ``swim_jax.bench.processes``), float32 and bfloat16.

Bad input (unknown env, a non-positive number, a missing --peer-python or one lacking the peers'
packages): one line on stderr naming what is valid, exit status 2, nothing written.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time

TOOLS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TOOLS)
if TOOLS not in sys.path:
    sys.path.insert(0, TOOLS)
from bench_pytorch_td3 import CONFIGS  # noqa: E402  env id → our *_relu config
from swim_jax.io import cli_parser  # noqa: E402
from swim_jax.io.bench_results import cpu_model, write_result  # noqa: E402
from swim_jax.bench import timing  # noqa: E402
from swim_jax.bench.processes import train_args, train_rate  # noqa: E402

WORKER = os.path.join(TOOLS, "peers_td3.py")
PEERS = ("pytorch", "cleanrl")
PROGRAMS = ("pytorch", "cleanrl", "ours")
BEST_PEER = "best peer of the round"  # the reference of ours' per-round ratios (no program's name)
LABELS = {"pytorch": "PyTorch TD3 (Fujimoto, original)", "cleanrl": "cleanrl-style JAX TD3"}
PEER_MODULES = ("torch", "jax", "flax", "optax", "gymnasium", "mujoco")
SINGLE_THREAD_ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
BF16 = "matmul_dtype=bfloat16"  # our bfloat16 rows (float32 rows: matmul_dtype=full)
# our rows (``--ours``): name → the config overrides of that row of ``python -m swim_jax.bench train``
# (on several cores these run as lane groups, the default; "native-one-program" is the one-program form)
OURS = {"mjx": ("env.backend=mjx", "matmul_dtype=full"),
        "native": ("env.backend=mujoco", "matmul_dtype=full"),
        "native-bf16": ("env.backend=mujoco", BF16),
        "native-one-program": ("env.backend=mujoco", "matmul_dtype=full", "lane_groups=false")}


class BadInput(Exception):
    """A user error: reported as one line on stderr with exit status 2."""


def parse_args(argv=None) -> argparse.Namespace:
    """The command line; numbers and envs are checked by :func:`validate`."""
    p = cli_parser.ArgumentParser(prog="bench_peers.py", description=__doc__.split("\n")[0])
    p.add_argument("--envs", default="HalfCheetah-v5,Hopper-v5,Walker2d-v5,Swimmer-v5",
                   help=f"comma-separated env ids; valid: {', '.join(CONFIGS)}")
    p.add_argument("--steps", default="1000", help="timed learning-phase steps per process / chunk (default 1000)")
    p.add_argument("--rounds", default="3", help="rounds per env, program order rotated (default 3)")
    p.add_argument("--lanes", default="5", help="lanes of our program (default 5)")
    p.add_argument("--our-processes", default="1",
                   help="also time ours as this many jax.distributed processes, one per core "
                        "(swim_jax.bench.processes; --lanes must divide by it; default 1 = not)")
    p.add_argument("--ours", default=",".join(OURS),
                   help=f"comma-separated rows of ours to time (default all); valid: {', '.join(OURS)}")
    p.add_argument("--procs", default=str(os.cpu_count() or 1),
                   help="concurrent single-threaded processes per peer (default os.cpu_count())")
    p.add_argument("--warmup", default="25000",
                   help="uniform-random steps filling each peer's buffer first (default 25000, as both originals)")
    p.add_argument("--peer-python", default=sys.executable,
                   help="Python with torch, jax, flax, optax, gymnasium[mujoco] for the peers (default this one)")
    p.add_argument("--out", default=os.path.join("runs", "bench"), help="folder for the JSON (default runs/bench)")
    return p.parse_args(argv)


def validate(args: argparse.Namespace) -> dict:
    """Check the command line; return the settings, or raise BadInput with one line naming what is valid."""
    envs = [e.strip() for e in args.envs.split(",") if e.strip()]
    unknown = [e for e in envs if e not in CONFIGS]
    if not envs or unknown:
        raise BadInput(f"unknown env {', '.join(unknown) or repr(args.envs)}; valid: {', '.join(CONFIGS)}")
    ours = [o.strip() for o in args.ours.split(",") if o.strip()]
    if not ours or any(o not in OURS for o in ours) or len(set(ours)) < len(ours):
        raise BadInput(f"--ours {args.ours!r}: expected distinct names from {', '.join(OURS)}")
    numbers = {}
    for name in ("steps", "rounds", "lanes", "procs", "warmup", "our_processes"):
        text = getattr(args, name)
        try:
            value = int(text)
        except ValueError:
            value = 0
        if value < 1:
            raise BadInput(f"--{name.replace('_', '-')} {text!r}: expected a positive integer (>= 1)")
        numbers[name] = value
    P = numbers["our_processes"]
    if P > 1 and (numbers["lanes"] % P or P > len(os.sched_getaffinity(0))):
        raise BadInput(f"--our-processes {P}: expected a divisor of --lanes ({numbers['lanes']}) "
                       f"no larger than the {len(os.sched_getaffinity(0))} usable cores")
    peer_python = args.peer_python
    if not (os.path.isfile(peer_python) and os.access(peer_python, os.X_OK)):
        raise BadInput(f"--peer-python {peer_python!r} is not an executable file; expected a Python with "
                       f"{', '.join(PEER_MODULES)} (see this script's docstring for the peers venv)")
    check = subprocess.run([peer_python, "-c", f"import {', '.join(PEER_MODULES)}"], capture_output=True, text=True)
    if check.returncode != 0:
        last = (check.stderr.strip().splitlines() or ["?"])[-1]
        raise BadInput(f"--peer-python {peer_python!r} lacks the peers' packages ({last}); expected a Python with "
                       f"{', '.join(PEER_MODULES)} (see this script's docstring for the peers venv)")
    return {"envs": envs, "ours": ours, **numbers, "peer_python": peer_python, "out": args.out}


def _tail(path: str, n: int = 15) -> str:
    """The last n lines of a text file (a failed subprocess's stderr)."""
    with open(path, errors="replace") as f:
        return "\n".join(f.read().splitlines()[-n:])


def run_peer(impl: str, env_id: str, s: dict) -> dict:
    """Run ``s['procs']`` concurrent single-threaded worker processes of one peer; their aggregate rate.

    Each worker warms up on its own, reports ``ready``, and all are released together (a line on
    their stdin) so the timed windows coincide. Returns the processes' JSON lines and
    ``env_steps_per_s`` = the sum of their rates, plus the wall-clock aggregate and window overlap.
    """
    env = {**os.environ, **SINGLE_THREAD_ENV}
    procs = []
    with tempfile.TemporaryDirectory(prefix="peers-") as tmp:
        for seed in range(s["procs"]):
            err = open(os.path.join(tmp, f"stderr-{seed}.txt"), "w")
            cmd = [s["peer_python"], WORKER, "--impl", impl, "--env", env_id, "--steps", str(s["steps"]),
                   "--warmup", str(s["warmup"]), "--seed", str(seed), "--sync"]
            procs.append((subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err,
                                           text=True, cwd=ROOT, env=env), err))
        try:
            for p, err in procs:  # barrier: every process warmed up and compiled
                if p.stdout.readline().strip() != "ready":
                    p.wait()
                    raise RuntimeError(f"{impl} worker failed before timing (exit {p.returncode}):\n{_tail(err.name)}")
            for p, _ in procs:
                p.stdin.write("go\n")
                p.stdin.flush()
            runs = []
            for p, err in procs:
                out, _ = p.communicate()
                err.close()
                lines = [ln for ln in out.splitlines() if ln.strip()]
                if p.returncode != 0 or not lines:
                    raise RuntimeError(f"{impl} worker failed (exit {p.returncode}):\n{_tail(err.name)}")
                runs.append(json.loads(lines[-1]))
        finally:
            for p, err in procs:
                if p.poll() is None:
                    p.kill()  # only our own workers, by handle
                    p.wait()
                err.close()
    first, last = min(r["t_start"] for r in runs), max(r["t_end"] for r in runs)
    common = min(r["t_end"] for r in runs) - max(r["t_start"] for r in runs)
    return {
        "program": impl, "procs": len(runs),
        "env_steps_per_s": sum(r["env_steps_per_s"] for r in runs),
        "wall_env_steps_per_s": sum(r["steps"] for r in runs) / (last - first),
        "overlap_fraction": max(common, 0.0) / (last - first),
        "cpu_per_wall": [r["cpu_seconds"] / r["seconds"] for r in runs],
        "runs": runs,
    }


def ours_command(env_id: str, s: dict) -> list[str]:
    """Our benchmark's command line (without ``--out``): the first of ``s["ours"]`` as ``--set``
    overrides, every other one as a ``--variant``."""
    first, *others = s["ours"]
    cmd = [sys.executable, "-m", "swim_jax.bench", "train", "--config", CONFIGS[env_id],
           "--lanes", str(s["lanes"]), "--chunk-steps", str(s["steps"]), "--repeats", "1"]
    for override in OURS[first]:
        cmd += ["--set", override]
    for name in others:
        cmd += ["--variant", ",".join(OURS[name])]
    return cmd + ["--no-roofline"]


def our_rows(res: dict, s: dict) -> dict:
    """{key: {"env_steps_per_s", "label"}} from the JSON of :func:`ours_command`'s benchmark: its
    base row is the first of ``s["ours"]``, each variant row the ``OURS`` entry it names; rows of
    other lane counts are skipped."""
    first, *others = s["ours"]
    by_variant = {",".join(OURS[name]): name for name in others}
    rows = {}
    for row in res["rows"]:
        if row["lanes"] != s["lanes"]:
            continue
        name = by_variant[row["variant"]] if row.get("variant") else first
        backend = "mujoco" if name.startswith("native") else "mjx"
        bf16 = name.endswith("bf16")
        groups = row.get("lane_groups")
        placed = ("-groups" if groups else f"-{row['devices']}dev" if row["devices"] > 1 else "")
        key = f"ours-{backend}" + ("-bf16" if bf16 else "") + placed
        label = (f"swim-jax, {s['lanes']} lanes, {'native MuJoCo' if backend == 'mujoco' else 'MJX'}"
                 + (", bfloat16 matmuls" if bf16 else ", float32")
                 + (f", lane groups ({row['devices']} devices)" if groups else f", {row['devices']} devices"
                    if row["devices"] > 1 else ", one program"))
        rows[key] = {"env_steps_per_s": row["env_steps_per_s"], "label": label}
    return rows


def run_ours(env_id: str, s: dict) -> dict:
    """Run our whole-program benchmark once, one row per ``s["ours"]`` entry (``OURS``: MJX or native
    physics, float32 or bfloat16 matmuls), the first as the base config and the others as variants.

    ``python -m swim_jax.bench train --config <env>_relu --lanes L --chunk-steps N --repeats 1
    --set env.backend=mjx --set matmul_dtype=full --variant env.backend=mujoco,matmul_dtype=full
    --variant env.backend=mujoco,matmul_dtype=bfloat16 --out <tmp>`` (all three rows) with this script's
    Python, JAX's default threading; returns {key: {"env_steps_per_s", "label"}} and the JSON that
    benchmark wrote.
    """
    cmd = ours_command(env_id, s)
    with tempfile.TemporaryDirectory(prefix="ours-") as tmp:
        proc = subprocess.run(cmd + ["--out", tmp], capture_output=True, text=True, cwd=ROOT)
        files = sorted(glob.glob(os.path.join(tmp, "train-*.json")))
        if proc.returncode != 0 or not files:
            raise RuntimeError(f"our benchmark failed (exit {proc.returncode}): {shlex.join(cmd)}\n"
                               + "\n".join(proc.stderr.strip().splitlines()[-15:]))
        with open(files[-1]) as f:
            res = json.load(f)
    rows = our_rows(res, s)
    P = s["our_processes"]
    if P > 1:  # the same lanes as P processes, one per core (python -m swim_jax.train ... --num-processes P)
        for dtype, suffix in [(OURS[n][1], n[len("native"):]) for n in s["ours"] if n.startswith("native")]:
            args = train_args(CONFIGS[env_id], s["lanes"], s["steps"], 1, ("env.backend=mujoco", dtype))
            with tempfile.TemporaryDirectory(prefix="ours-processes-") as tmp:
                rate = train_rate(args, tmp, "processes", sorted(os.sched_getaffinity(0))[:P])
            rows[f"ours-mujoco{suffix}-{P}proc"] = {
                "env_steps_per_s": rate, "label": f"swim-jax, {s['lanes']} lanes, native MuJoCo, "
                                                  f"{'bfloat16 matmuls' if suffix else 'float32'}, {P} processes × 1 core"}
    return {"program": "ours", "command": cmd, "rows": rows, "bench_json": res}


def bench_env(env_id: str, s: dict, log=print) -> dict:
    """All rounds for one env, program order rotated per round (``swim_jax.bench.timing.interleave``);
    raw results and per-program rates."""
    def candidate(prog):  # round r's run of one program, logged as it ends
        def run(r):
            tag = f"[{env_id} round {r + 1}/{s['rounds']}]"
            if prog in PEERS:
                res = run_peer(prog, env_id, s)
                log(f"{tag} {prog}: {res['env_steps_per_s']:.1f} env-steps/s summed over {res['procs']} processes "
                    f"(wall-clock {res['wall_env_steps_per_s']:.1f}, overlap {res['overlap_fraction']:.2f}, "
                    f"CPU/wall {', '.join(f'{c:.2f}' for c in res['cpu_per_wall'])})")
            else:
                res = run_ours(env_id, s)
                for key, row in res["rows"].items():
                    log(f"{tag} {key}: {row['env_steps_per_s']:.1f} env-steps/s ({s['lanes']} lanes)")
            return res
        return run

    rounds = []
    runs = timing.interleave({prog: candidate(prog) for prog in PROGRAMS}, s["rounds"],
                             after_round=lambda r, done: rounds.append({"round": r, "order": list(done), **done}))
    rates, labels = {}, {}  # per program (ours: per row), in the order of the first round
    for prog in PROGRAMS:
        for res in runs[prog]:
            rows = ({prog: {"env_steps_per_s": res["env_steps_per_s"], "label": f"{LABELS[prog]}, {s['procs']} procs × 1 thread"}}
                    if prog in PEERS else res["rows"])
            for key, row in rows.items():
                rates.setdefault(key, []).append(row["env_steps_per_s"])
                labels[key] = row["label"]
    summary, best_peer = summarize(rates, labels)
    return {"rounds": rounds, "summary": summary, "best_peer_median": best_peer}


def summarize(rates: dict, labels: dict) -> tuple[dict, float | None]:
    """Per program: the median, min, max of its per-round rates (``rates[key]``, one per round);
    for ours also the ratio of medians to the best peer's median and the per-round ratios to the best
    peer OF THAT ROUND (paired: a drift of the machine between rounds cancels; ``timing.ratios``) with
    their median. Returns (summary, best peer's median)."""
    summary = {}
    for k, v in rates.items():
        t = timing.summarise(v)
        summary[k] = {"label": labels[k], "median": t.median, "min": t.min, "max": t.max, "values": v}
    best_peer = max((summary[p]["median"] for p in PEERS if p in summary), default=None)
    ours = [k for k in rates if k not in PEERS] if best_peer else []
    best_per_round = [max(r) for r in zip(*(rates[p] for p in PEERS if p in rates))]
    per_round = timing.ratios({**{k: rates[k] for k in ours}, BEST_PEER: best_per_round}, BEST_PEER) if ours else {}
    for k, v in summary.items():
        v["ratio_vs_best_peer"] = (v["median"] / best_peer) if k in per_round else None
        v["round_ratios"] = list(per_round[k].samples) if k in per_round else None
        v["median_round_ratio"] = per_round[k].median if k in per_round else None
    return summary, best_peer


def markdown(env_id: str, res: dict, s: dict) -> str:
    """One env's Markdown table: program, env-steps/s median (min–max), ratio ours / best peer (of the
    medians, and per round with its median)."""
    lines = [f"**{env_id}** — learning phase, {s['steps']} timed steps, {s['rounds']} round(s), "
             f"medians (min–max) of aggregate env-steps/s",
             "", "| program | env-steps/s | ratio ours / best peer | per round (median) |", "|---|---|---|---|"]
    for key, v in res["summary"].items():
        ratio = "—" if v["ratio_vs_best_peer"] is None else f"{v['ratio_vs_best_peer']:.2f}×"
        rounds = ("—" if v.get("round_ratios") is None else
                  f"{', '.join(f'{x:.2f}' for x in v['round_ratios'])} ({v['median_round_ratio']:.2f}×)")
        lines.append(f"| {v['label']} | {v['median']:.0f} ({v['min']:.0f}–{v['max']:.0f}) | {ratio} | {rounds} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Validate, benchmark every env, print the tables, write the JSON."""
    args = parse_args(argv)
    try:
        s = validate(args)
    except BadInput as e:
        print(f"bench_peers.py: error: {e}", file=sys.stderr)
        return 2
    started = time.gmtime()
    results = {}
    doc = {
        "benchmark": "peers", "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", started), "finished": None,
        "command": shlex.join([sys.executable, *sys.argv] if argv is None else [sys.executable, __file__, *argv]),
        "cpu_model": cpu_model(), "cpu_count": os.cpu_count(), "python": sys.executable,
        "settings": s, "results": results,
    }
    try:
        for env_id in s["envs"]:
            results[env_id] = bench_env(env_id, s)
            print("\n" + markdown(env_id, results[env_id], s) + "\n", flush=True)
            # after every env (same file), so an interrupted run keeps the envs it finished
            doc["finished"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()) if env_id == s["envs"][-1] else None
            write_result(s["out"], "peers", doc, started)
    except RuntimeError as e:
        print(f"bench_peers.py: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
