"""What a checkpoint costs at the main job's scale: ``python -m swim_jax.bench checkpoint``.

Builds a config's training state (default walker_swim, 5 seeds, a 1M-slot replay buffer) with the
buffer filled to ``--fill`` transitions (standard-normal values: about as compressible as real
observations, i.e. hardly), then, alternated over ``--rounds``, writes it as a checkpoint

- ``whole``: the whole training state in one orbax checkpoint (how every checkpoint was written
  before swim_jax/io/replay_store.py), and
- ``appended``: what training writes now (swim_jax/run/train.py ``_save``): the chunk's ``--chunk``
  new transitions appended as one replay segment, the rest of the state as an orbax checkpoint,
  the segments no kept checkpoint needs pruned (the store holds the ``--fill`` transitions before,
  written untimed),

each into its own folder keeping ``--keep`` checkpoints as training does. Reported: seconds per
checkpoint (median, min–max), the disk each folder takes after the rounds, one whole state's size,
and the seconds to restore the newest checkpoint (buffer included; median of ``--rounds`` restores,
alternating between the kinds). JSON under ``--out``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile

import jax
import jax.numpy as jnp
import numpy as np

from swim_jax.io import cli_parser
from swim_jax import config as cfgmod
from swim_jax.io.bench_results import cpu_model, write_result
from swim_jax.bench import timing


def _parser():
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.bench checkpoint", description=__doc__.split("\n")[0])
    p.add_argument("--config", default="walker_swim", help="config whose state is checkpointed (default walker_swim)")
    p.add_argument("--seeds", type=int, default=5, help="seeds (lanes) (default 5, the main job's)")
    p.add_argument("--replay-size", type=int, default=1_000_000, help="buffer slots (default 1000000, the main job's)")
    p.add_argument("--fill", type=int, default=1_000_000, help="transitions in the buffer (default: full)")
    p.add_argument("--chunk", type=int, default=5000, help="new transitions per checkpoint (default 5000, eval_freq)")
    p.add_argument("--rounds", type=int, default=3, help="checkpoints of each kind, alternated (default 3)")
    p.add_argument("--keep", type=int, default=3, help="checkpoints kept (default 3, keep_checkpoints)")
    p.add_argument("--dir", default=None, help="folder for the checkpoints (default: a temporary one, removed)")
    p.add_argument("--out", default=os.path.join("runs", "bench"), help="folder of the JSON result")
    return p


def _du(path: str) -> int:
    """Bytes on disk under ``path`` (``du``'s allocated size)."""
    return int(subprocess.run(["du", "-sb", path], capture_output=True, text=True, check=True).stdout.split()[0])


def filled_state(cfg, fill: int, seed: int = 0):
    """``cfg``'s initial training state (its lanes) with the buffer's first ``fill`` slots
    standard-normal (terminated: 0/1) and its pointer and size as after ``fill`` insertions."""
    from swim_jax.placement.layout import LaneLayout
    from swim_jax.run.programs import programs

    prog = programs(cfg)
    lanes = LaneLayout.of(cfg).count
    states = prog.init_fn(jnp.asarray(cfg.seed, jnp.uint32), jnp.arange(lanes, dtype=jnp.int32))
    rng = np.random.default_rng(seed)
    data = {}
    for k, a in states.buffer.data._asdict().items():
        host = np.zeros(a.shape, a.dtype)
        n = min(fill, a.shape[1])
        host[:, :n] = (rng.integers(0, 2, (a.shape[0], n, *a.shape[2:])) if k == "terminated"
                       else rng.standard_normal((a.shape[0], n, *a.shape[2:])))
        data[k] = jnp.asarray(host)
    cap = states.buffer.data.reward.shape[1]
    buf = states.buffer._replace(data=type(states.buffer.data)(**data),
                                 ptr=jnp.full_like(states.buffer.ptr, fill % cap),
                                 size=jnp.full_like(states.buffer.size, min(fill, cap)))
    return states._replace(buffer=buf)


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module docstring)."""
    from swim_jax.run import train
    from swim_jax.io.checkpoint import Checkpointer
    from swim_jax.io.replay_store import ReplayStore

    args = _parser().parse_args(argv)
    for name in ("seeds", "replay_size", "chunk", "rounds", "keep"):
        if getattr(args, name) < 1:
            _parser().error(f"--{name.replace('_', '-')} must be >= 1")
    if not 0 <= args.fill <= args.replay_size or args.fill % args.chunk:
        _parser().error(f"--fill must be a multiple of --chunk ({args.chunk}) between 0 and --replay-size")
    try:
        cfg = cfgmod.resolve(args.config, [f"seeds={args.seeds}", f"replay_size={args.replay_size}",
                                           "env.backend=mujoco", f"eval_freq={args.chunk}"])
    except cfgmod.ConfigError as e:
        _parser().error(str(e))
    states = filled_state(cfg, args.fill)
    lanes = states.buffer.data.reward.shape[0]
    evals = np.zeros((cfgmod.schedule(cfg).n_evals, lanes, cfg.eval_episodes), np.float32)

    class Evals:  # train._save's view of the evaluations
        def saved(self):
            return evals

    root = args.dir or tempfile.mkdtemp(prefix="bench-checkpoint-")
    whole_dir, appended_dir = os.path.join(root, "whole"), os.path.join(root, "appended")
    for d in (whole_dir, appended_dir):
        shutil.rmtree(d, ignore_errors=True)
    whole = Checkpointer(whole_dir, keep=args.keep)
    appended = Checkpointer(appended_dir, keep=args.keep)
    store = ReplayStore(os.path.join(appended_dir, "replay"), cfg.replay_size)
    host = jax.tree.map(np.asarray, states.buffer.data)
    for n0 in range(0, args.fill - args.chunk, args.chunk):  # the segments of the earlier chunks (untimed)
        a, b = store.new_range(n0, n0 + args.chunk)
        store.append(a, b, {k: v[:, a % cfg.replay_size:(a % cfg.replay_size) + (b - a)]
                            for k, v in host._asdict().items()})
    step = lambda r: max(args.fill, args.chunk) + r * args.chunk  # round r's checkpoint step
    times = timing.interleave({
        "whole": timing.timed(lambda r: whole.save(step(r), (states, evals)), wait=None),
        "appended": timing.timed(lambda r: train._save(appended, store, step(r), args.chunk, states, Evals()), wait=None),
    }, args.rounds, rotate=False, after_round=lambda r, t: print(
        f"round {r + 1}: whole {t['whole']:.2f} s, appended {t['appended']:.2f} s", flush=True))
    last = max(args.fill, args.chunk) + (args.rounds - 1) * args.chunk
    full_template = (jax.eval_shape(lambda: states), jax.ShapeDtypeStruct(evals.shape, evals.dtype))
    buffer_spec = {k: (a.shape, a.dtype) for k, a in states.buffer.data._asdict().items()}

    def restore_appended(r):
        appended.restore(last, (train._without_replay(full_template[0]), full_template[1]))
        return store.rebuild(last, buffer_spec)

    restore_times = timing.interleave({
        "whole": timing.timed(lambda r: whole.restore(last, full_template), wait=None),
        "appended": timing.timed(restore_appended, wait=None),
    }, args.rounds)
    whole.close()
    appended.close()
    one_state = _du(os.path.join(whole_dir, str(last)))
    result = {
        "config": args.config, "seeds": args.seeds, "lanes": lanes, "replay_size": args.replay_size,
        "fill": args.fill, "chunk": args.chunk, "keep": args.keep, "rounds": args.rounds,
        "cpu": cpu_model(), "cores": len(os.sched_getaffinity(0)),
        "seconds": times,
        "median_s": {k: timing.summarise(v).median for k, v in times.items()},
        "disk_bytes": {"whole": _du(whole_dir), "appended": _du(appended_dir), "one_whole_state": one_state},
        "restore_seconds": restore_times,
        "restore_s": {k: timing.summarise(v).median for k, v in restore_times.items()},
    }
    if args.dir is None:
        shutil.rmtree(root, ignore_errors=True)
    mb = lambda b: f"{b / 1e6:,.0f} MB"  # noqa: E731
    print(f"\n{args.config}, {lanes} lanes, {args.replay_size:,}-slot buffer holding {args.fill:,} transitions, "
          f"{args.chunk} new per checkpoint, {args.keep} kept; {result['cpu']}, {result['cores']} cores\n")
    print("| checkpoint | seconds (median) | min–max | disk after the rounds | vs one whole state | restore (s, median) |")
    print("|---|---|---|---|---|---|")
    for k in ("whole", "appended"):
        t = timing.summarise(times[k])
        print(f"| {k} | {t.median:.2f} | {t.min:.2f}–{t.max:.2f} | {mb(result['disk_bytes'][k])} | "
              f"{result['disk_bytes'][k] / one_state:.2f}× | {result['restore_s'][k]:.1f} |")
    print(f"one whole state: {mb(one_state)}")
    write_result(args.out, "checkpoint", result)
    return 0
