"""Evaluate trained policies in Gymnasium itself: ``python -m swim_jax.evaluate RUN_DIR``.

    python -m swim_jax.evaluate runs/cheetah_swim-20260101-120000                 # every seed, 100 episodes
    python -m swim_jax.evaluate RUN_DIR --seed 2 --episodes 30 --step 100000 --env-seed 1000
    python -m swim_jax.evaluate RUN_DIR SWEEP_DIR --json table.json                # several runs; a sweep's points
    python -m swim_jax.evaluate RUN_DIR --seed 0 --export cheetah_swim.npz        # a self-contained policy file

For every run folder (a sweep folder stands for its points) and seed, the policy
(``swim_jax.policy.run_folder.load_policy``: NumPy, no JAX; from ``final_policy.npz``, or ``--step S``'s
checkpoint) runs ``--episodes`` episodes in ``gymnasium.make(env.id, max_episode_steps=...)``,
Gymnasium's own env on MuJoCo C, with deterministic actions (the actor's output, as our evaluations
act). Episode ``e`` starts from ``reset(seed=env_seed + e)``, so every seed and run sees the same
initial states. One table row per seed: our own evaluation at that step (the mean return of the
run's ``eval_episodes`` episodes in ``evaluations_episodes.npy``, their own reset noise), Gymnasium's
mean with its 95 % confidence interval (t-based: mean ± t₀.₉₇₅,ₙ₋₁ · sd/√n), the mean episode
length and how many episodes reached the time limit (a low return from falls, not from a slow
gait, shows there), whether ours lies inside it, the difference ours − Gymnasium with its Welch 95 % CI and Welch's two-sided p. Ours is
a mean of few episodes, so it can lie outside Gymnasium's (narrow) CI by its own sampling error; a
difference whose CI excludes 0 (marked bold) is the sign of a fidelity problem to look into. Single
episodes cannot be paired: a 1e-6 change in one action moves a HalfCheetah return by ~100.

``--ours-episodes N`` replaces our side by N fresh episodes per seed of the run's own evaluation
program on its final policies (swim_jax/run/our_evaluation.py: our env and physics, the run's
precision and products, JAX needed), so that both sides of the difference are large samples: the
first ``eval_episodes`` of them are the recorded episodes exactly, the rest extend them. Plain
runs' final policies only (not with ``--step`` or sweep points).

``--in-env ID`` runs the episodes in another Gymnasium env instead of each run's own ``env.id``,
one whose observation size and action bounds are the policy's (e.g. a Walker2d-v5 policy in
Walker2d-v4, whose only model difference is the right foot's friction): how a learned gait scores
under the other version. Our side is then n/a (our evaluation ran in the training env); each row
names both envs (``env_id`` and ``trained_env_id`` in the JSON).

``--json FILE`` also writes the table (every episode's return and length included);
``--export FILE.npz`` writes one seed's policy as weights plus a JSON header (``--seed N`` needed
when the run has several seeds) instead of evaluating; README ("Trained policies outside the
project") shows the NumPy lines that run such a file without this project.

Exit status: 0 done; 2 bad input (missing run folder, no config.yaml, seed out of range, no policy at
the step, no final policy and no --step, bad arguments, existing --json/--export without --force,
--ours-episodes with --step, --export or a sweep point, an ``--in-env`` Gymnasium cannot make or
whose observation size or action bounds differ from the policy's, --in-env with --ours-episodes
or --export):
one line on stderr, nothing written.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from swim_jax.io import cli_parser
from swim_jax.io.schedule import Schedule
from swim_jax.analysis import stats
from swim_jax.policy.gymnasium_env import env_spec, make_gymnasium
from swim_jax.policy.policy import Policy, PolicyError
from swim_jax.policy.run_folder import RunPolicies, load_policy, run_folders, run_policies

DEFAULT_EPISODES = 100


class EvaluateError(ValueError):
    """Bad input; ``str(e)`` is one line (exit 2)."""


@dataclass
class Target:
    """One row to compute: a seed of a run folder, its policy and our own evaluation there."""

    run: RunPolicies
    seed: int
    step: int
    policy: Policy
    ours: np.ndarray | None  # our evaluation's episode returns at ``step`` (None: not recorded)
    ours_mean: float | None  # their mean (from evaluations.npy when the episodes are not stored)
    ours_source: str = "recorded"  # "recorded" (the run's evaluation) or "re-evaluated" (--ours-episodes)

    @property
    def label(self) -> str:
        cfg = self.run.config
        act = cfg.get("agent", {}).get("activation", {})
        name = str(act.get("name"))
        point = os.path.join(self.run.path, "point.json")
        if os.path.isfile(point):
            with open(point) as f:
                name += f"[{json.load(f).get('label', '?')}]"
        return name + ("+learnable" if act.get("learnable") else "")


def our_evaluation(run: RunPolicies, seed_pos: int, step: int) -> tuple[np.ndarray | None, float | None]:
    """(episode returns, mean) of our own evaluation of seed position ``seed_pos`` at ``step``, from
    ``evaluations_episodes.npy`` (else the mean alone from ``evaluations.npy``); (None, None) when
    the run has not recorded that evaluation."""
    try:
        j = Schedule(run.total_steps, run.eval_freq).eval_index(step)
    except ValueError:
        return None, None
    for name in ("evaluations_episodes.npy", "evaluations.npy"):
        path = os.path.join(run.path, name)
        if not os.path.isfile(path):
            continue
        try:
            ev = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError):
            continue
        if ev.ndim >= 2 and j < ev.shape[0] and seed_pos < ev.shape[1]:
            if ev.ndim == 3:
                episodes = np.asarray(ev[j, seed_pos], np.float64)
                return episodes, float(episodes.mean())
            return None, float(ev[j, seed_pos])
    return None, None


def gymnasium_returns(policy, env_id: str, episodes: int, env_seed: int = 0,
                      max_episode_steps: int | None = None) -> tuple[np.ndarray, np.ndarray, int | None]:
    """(returns, lengths, time limit) of ``episodes`` episodes of ``policy`` in ``gymnasium.make(env_id)``:
    episode ``e`` from ``reset(seed=env_seed + e)``, actions ``policy(obs)`` until terminated or
    truncated (the time limit, ``max_episode_steps`` or the env's registered one, returned)."""
    kwargs = {} if max_episode_steps is None else {"max_episode_steps": int(max_episode_steps)}
    env = make_gymnasium(env_id, **kwargs)
    returns, lengths = np.zeros(episodes), np.zeros(episodes, np.int64)
    limit = env.spec.max_episode_steps if env.spec is not None else None
    try:
        for e in range(episodes):
            obs, _ = env.reset(seed=env_seed + e)
            total, t, done = 0.0, 0, False
            while not done:
                obs, reward, terminated, truncated, _ = env.step(policy(obs))
                total += float(reward)
                t += 1
                done = terminated or truncated
            returns[e], lengths[e] = total, t
    finally:
        env.close()
    return returns, lengths, limit


def targets(paths: list[str], seed: str, step: int | None, in_env: str | None = None) -> list[Target]:
    """Every (run folder, seed) to evaluate, policies loaded (all input checked before any episode);
    with ``in_env``, every policy checked to act in it (:func:`check_in_env`)."""
    out = []
    for path in paths:
        try:
            folders = run_folders(path) if os.path.isdir(path) else None
            if folders is None:
                raise PolicyError(f"{path}: no such run folder")
            for folder in folders:
                run = run_policies(folder)
                seeds = run.seeds if seed == "all" else (int(seed),)
                for s in seeds:
                    pos = run.seed_position(s)
                    policy = load_policy(folder, s, step)
                    at = int(policy.source["step"])
                    ours, mean = our_evaluation(run, pos, at)
                    if in_env is not None and in_env != run.env_id:
                        check_in_env(policy, run, in_env)
                        ours, mean = None, None  # our evaluation ran in the training env
                    out.append(Target(run, s, at, policy, ours, mean))
        except PolicyError as e:
            raise EvaluateError(str(e)) from None
    return out


def check_in_env(policy: Policy, run: RunPolicies, env_id: str) -> None:
    """Raise :class:`PolicyError` (one line) unless ``policy`` (trained in ``run.env_id``) can act in
    Gymnasium's ``env_id``: the same observation size and the same action bounds (the actor's tanh
    scaling is the training env's)."""
    obs_size, low, high = env_spec(env_id)
    same_bounds = low.shape == policy.action_low.shape and np.array_equal(low, policy.action_low) \
        and np.array_equal(high, policy.action_high)
    if obs_size != policy.obs_size or not same_bounds:
        raise PolicyError(f"--in-env {env_id}: observations of size {obs_size}, {low.size} actions in "
                          f"[{low.min():g}, {high.max():g}]; the policy of {run.path} ({run.env_id}) takes "
                          f"{policy.obs_size} and acts in {policy.action_size} dims in "
                          f"[{policy.action_low.min():g}, {policy.action_high.max():g}] (valid: an env with "
                          f"the same observation size and action bounds, e.g. another version of {run.env_id})")


def evaluate_row(t: Target, episodes: int, env_seed: int, in_env: str | None = None) -> dict:
    """One row of the table: our evaluation and Gymnasium's, with the comparison; with ``in_env``,
    Gymnasium's episodes run in that env (``t.ours`` is then None: see :func:`targets`)."""
    max_steps = t.run.config.get("env", {}).get("max_episode_steps")
    env_id = t.run.env_id if in_env is None else in_env
    t0 = time.time()
    returns, lengths, limit = gymnasium_returns(t.policy, env_id, episodes, env_seed, max_steps)
    ci = stats.mean_ci(returns)
    row = {
        "run": t.run.path, "env_id": env_id, "trained_env_id": t.run.env_id, "activation": t.label,
        "seed": t.seed, "step": t.step,
        "policy": {"dtype": t.policy.dtype.name, "matmul_dtype": t.policy.matmul_dtype,
                   "source": "final_policy.npz" if t.run.final and t.step == t.run.total_steps else "checkpoint"},
        "ours": None if t.ours_mean is None else {
            "source": t.ours_source,
            "mean": t.ours_mean, "episodes": None if t.ours is None else t.ours.tolist(),
            "n": None if t.ours is None else int(t.ours.size),
            "sd": None if t.ours is None or t.ours.size < 2 else float(t.ours.std(ddof=1))},
        "gymnasium": {"mean": ci.mean, "sd": ci.sd, "n": ci.n, "ci95": [ci.low, ci.high],
                      "returns": returns.tolist(), "lengths": lengths.tolist(), "time_limit": limit,
                      "at_time_limit": None if limit is None else int((lengths >= limit).sum()),
                      "reset_seeds": [env_seed, env_seed + episodes - 1], "seconds": time.time() - t0},
        "ours_in_ci": None if t.ours_mean is None else bool(t.ours_mean in ci),
        "difference_ci95": None,  # ours − Gymnasium, Welch
        "welch_p": None,
    }
    if t.ours is not None and t.ours.size >= 2:
        p = stats.welch_t_test(t.ours, returns).p_two_sided
        row["welch_p"] = None if math.isnan(p) else p
        row["difference_ci95"] = list(stats.welch_diff_ci(t.ours, returns))
    return row


def differs(row: dict) -> bool:
    """Whether ours and Gymnasium's means differ beyond their sampling: 0 outside the Welch 95 %
    CI of the difference (False where ours has fewer than 2 episodes recorded)."""
    d = row["difference_ci95"]
    return d is not None and not d[0] <= 0 <= d[1]


HEADER = ("| run | env | activation | seed | step | ours (episodes) | Gymnasium mean [95% CI] (episodes) | sd | "
          "mean length (at the time limit) | ours in CI | ours − Gymnasium [95% CI] | Welch p |")


def format_row(row: dict) -> str:
    """A markdown table row of :func:`evaluate_row`'s result."""
    ours, gym = row["ours"], row["gymnasium"]
    ours_s = "n/a" if ours is None else f"{ours['mean']:.2f}" + (f" ({ours['n']})" if ours["n"] else "")
    lo, hi = gym["ci95"]
    inside = "n/a" if row["ours_in_ci"] is None else ("yes" if row["ours_in_ci"] else "**no**")
    p = "n/a" if row["welch_p"] is None else stats.fmt_p(row["welch_p"])
    d = row["difference_ci95"]
    diff = "n/a" if d is None else f"{ours['mean'] - gym['mean']:+.2f} [{d[0]:+.2f}, {d[1]:+.2f}]"
    if differs(row):
        diff = f"**{diff}**"
    env = row["env_id"] if row["trained_env_id"] == row["env_id"] else \
        f"{row['env_id']} (trained in {row['trained_env_id']})"
    length = f"{np.mean(gym['lengths']):.0f}" + ("" if gym["at_time_limit"] is None else
                                                 f" ({gym['at_time_limit']}/{gym['n']})")
    return (f"| {row['run']} | {env} | {row['activation']} | {row['seed']} | {row['step']} | {ours_s} | "
            f"{gym['mean']:.2f} [{lo:.2f}, {hi:.2f}] ({gym['n']}) | {gym['sd']:.2f} | {length} | {inside} | "
            f"{diff} | {p} |")


def parse_args(argv):
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.evaluate", description=__doc__,
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run_dirs", metavar="RUN_DIR", nargs="+", help="run folders (a sweep folder: its points)")
    p.add_argument("--seed", default="all", help="a seed id of the runs, or all (default all)")
    p.add_argument("--episodes", type=int, default=DEFAULT_EPISODES,
                   help=f"Gymnasium episodes per seed (default {DEFAULT_EPISODES}; at least 2)")
    p.add_argument("--step", type=int, default=None,
                   help="the checkpoint step to evaluate (default: the final policy, final_policy.npz)")
    p.add_argument("--env-seed", type=int, default=0, help="episode e resets with seed env_seed + e (default 0)")
    p.add_argument("--json", default=None, metavar="FILE", help="also write the table as JSON")
    p.add_argument("--export", default=None, metavar="FILE.npz",
                   help="write the policy (one run folder, one seed) as a self-contained .npz instead of evaluating")
    p.add_argument("--ours-episodes", type=int, default=None, metavar="N",
                   help="our side: N fresh episodes per seed of the run's own evaluation program on its final "
                        "policies (JAX), instead of the run's recorded evaluation (at least 2)")
    p.add_argument("--in-env", default=None, metavar="ID",
                   help="run the episodes in this Gymnasium env instead of each run's env.id (the same observation "
                        "size and action bounds, e.g. Walker2d-v4 for a Walker2d-v5 policy)")
    p.add_argument("--force", action="store_true", help="replace an existing --json/--export file")
    a = p.parse_args(argv)
    if a.in_env is not None and (a.ours_episodes is not None or a.export is not None):
        p.error("--in-env evaluates in another env, where our own evaluation did not run; drop --ours-episodes "
                "and --export")
    if a.ours_episodes is not None:
        if a.ours_episodes < 2:
            p.error(f"--ours-episodes must be >= 2 (a confidence interval needs two episodes), got {a.ours_episodes}")
        if a.step is not None or a.export is not None:
            p.error("--ours-episodes evaluates the final policies; drop --step and --export")
    if a.seed != "all":
        try:
            a.seed = str(int(a.seed))
        except ValueError:
            p.error(f"--seed must be a seed id (an integer) or all, got {a.seed!r}")
    if a.episodes < 2:
        p.error(f"--episodes must be >= 2 (a confidence interval needs two episodes), got {a.episodes}")
    if a.env_seed < 0:
        p.error(f"--env-seed must be >= 0, got {a.env_seed}")
    if a.export is not None and not a.export.endswith(".npz"):
        p.error(f"--export must end in .npz, got {a.export!r}")
    if a.export is not None and a.json is not None:
        p.error("--export writes a policy file and evaluates nothing; drop --json")
    return a


def _check_out(path: str | None, force: bool, flag: str) -> None:
    problem = None if path is None else cli_parser.output_file_problem(flag, path, force)
    if problem:
        raise EvaluateError(problem)


def reevaluate(rows: list[Target], episodes: int, our_episodes: Callable[[str, int], np.ndarray]) -> None:
    """Replace every row's ``ours`` by ``our_episodes(run folder, episodes)[seed position]`` (one
    call per run folder). ``our_episodes`` raises ValueError (one line) for a folder it cannot
    evaluate; that becomes :class:`EvaluateError`."""
    done: dict[str, np.ndarray] = {}
    for t in rows:
        if t.run.path not in done:
            try:
                done[t.run.path] = our_episodes(t.run.path, episodes)
            except ValueError as e:
                raise EvaluateError(str(e)) from None
        t.ours = done[t.run.path][t.run.seed_position(t.seed)]
        t.ours_mean, t.ours_source = float(t.ours.mean()), "re-evaluated"


def main(argv=None, our_episodes: Callable[[str, int], np.ndarray] | None = None) -> int:
    """CLI entry point; returns the exit status (0 ok, 2 bad input with one line on stderr).
    ``our_episodes``: what ``--ours-episodes`` runs (swim_jax/run/our_evaluation.py, passed in by
    swim_jax/run/evaluate.py, the command's entry: this room stays free of JAX and of the run room)."""
    args = parse_args(sys.argv[1:] if argv is None else list(argv))
    try:
        _check_out(args.json, args.force, "--json")
        _check_out(args.export, args.force, "--export")
        rows = targets(args.run_dirs, args.seed, args.step, args.in_env)
        if args.export is not None and len(rows) != 1:
            where = sorted({t.run.path for t in rows})
            raise EvaluateError(f"--export writes one policy; {len(rows)} match ({len(where)} run folder(s): "
                                f"{', '.join(where)}; seeds {', '.join(str(t.seed) for t in rows)}): "
                                f"give one run folder and --seed N")
        if args.ours_episodes is not None:
            if our_episodes is None:
                raise EvaluateError("--ours-episodes needs the JAX side: run it as python -m swim_jax.evaluate")
            t_ours = time.time()
            reevaluate(rows, args.ours_episodes, our_episodes)
            print(f"ours: {args.ours_episodes} episodes per seed of our own evaluation program in "
                  f"{time.time() - t_ours:.0f} s")
    except EvaluateError as e:
        print(f"evaluate: error: {e}", file=sys.stderr)
        return 2
    if args.export is not None:
        t = rows[0]
        t.policy.export(args.export)
        print(f"evaluate: wrote {args.export}: {t.run.env_id} {t.label} seed {t.seed} step {t.step} "
              f"({t.policy.dtype.name}, {t.policy.matmul_dtype} matmuls, hidden {list(t.policy.hidden)})")
        return 0
    t_start = time.time()
    print(f"Gymnasium {_version('gymnasium')} (MuJoCo {_version('mujoco')}): {args.episodes} episodes per seed, "
          f"reset seeds {args.env_seed}..{args.env_seed + args.episodes - 1}, deterministic actions"
          + ("" if args.in_env is None else f", in {args.in_env}"))
    print(HEADER)
    print("|" + "---|" * (HEADER.count("|") - 1))
    table = []
    for t in rows:
        row = evaluate_row(t, args.episodes, args.env_seed, args.in_env)
        table.append(row)
        print(format_row(row), flush=True)
    outside = sum(r["ours_in_ci"] is False for r in table)
    print(f"evaluate: {len(table)} row(s) in {time.time() - t_start:.0f} s; ours outside Gymnasium's 95% CI: "
          f"{outside}; ours and Gymnasium's means differ beyond their sampling (0 outside the difference's "
          f"95% CI): {sum(map(differs, table))}")
    if args.json is not None:
        with open(args.json, "w") as f:
            json.dump({"command": "python -m swim_jax.evaluate " + " ".join(sys.argv[1:] if argv is None else argv),
                       "gymnasium": _version("gymnasium"), "mujoco": _version("mujoco"),
                       "episodes": args.episodes, "env_seed": args.env_seed, "ours_episodes": args.ours_episodes,
                       "in_env": args.in_env,
                       "rows": table}, f, indent=1)
            f.write("\n")
        print(f"evaluate: wrote {args.json}")
    return 0


def _version(name: str) -> str:
    import importlib.metadata

    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return "?"


if __name__ == "__main__":
    sys.exit(main())
