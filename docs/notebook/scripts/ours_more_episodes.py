"""Our own evaluation of a finished run's final policy with more episodes, for the Gymnasium cross-check.

    python runs/curated/results/gymnasium/ours_more_episodes.py RUN_DIR EPISODES OUT.json [GYMNASIUM.json]

The run's own program pieces as training builds them (swim_jax.programs.build: our env with the
run's physics backend and precision, the JAX actor; matmul_dtype as timing.json records it) and
agents.loop.make_eval_fn, at the final evaluation index, with EPISODES episodes per seed instead
of the run's eval_episodes (so other reset keys than the recorded ones: split(key, EPISODES)).
With GYMNASIUM.json (``python -m swim_jax.evaluate ... --json``), prints per seed our mean, theirs
and the Welch 95 % CI of the difference. Needs the project's JAX stack.
"""

import dataclasses
import json
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
import yaml

from agents import loop
from swim_jax import config as cfgmod
from swim_jax import policy, programs, stats
from swim_jax.render import unflatten

run, episodes, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
t0 = time.time()
with open(f"{run}/config.yaml") as f:
    cfg = cfgmod.from_dict(cfgmod.Config, yaml.safe_load(f))
cfg = dataclasses.replace(cfg, matmul_dtype="bfloat16" if policy.run_matmul(run, cfgmod.to_dict(cfg)) == "bfloat16" else "full")
env, eval_env, agent = programs.build(cfg)
with np.load(f"{run}/final_policy.npz") as z:
    params = jax.tree.map(jnp.asarray, unflatten({k: z[k] for k in z.files}))
index = cfg.total_steps // cfg.eval_freq
evaluate = jax.jit(loop.make_eval_fn(agent, eval_env, episodes, cfg.env.max_episode_steps))
keys = jax.vmap(lambda i: loop.seed_keys(cfg.seed, i)[3])(jnp.arange(cfg.first_seed, cfg.first_seed + cfg.seeds, dtype=jnp.int32))
returns = np.asarray(evaluate(params, keys, jnp.int32(index)), np.float64)
result = {"run": run, "step": cfg.total_steps, "episodes": episodes, "backend": cfg.env.backend,
          "precision": cfg.precision, "matmul_dtype": cfg.matmul_dtype, "seconds": time.time() - t0,
          "returns": {str(cfg.first_seed + i): r.tolist() for i, r in enumerate(returns)}}
with open(out, "w") as f:
    json.dump(result, f, indent=1)
    f.write("\n")
print(f"ours: {episodes} episodes per seed in {result['seconds']:.0f} s; wrote {out}")
if len(sys.argv) > 4:
    with open(sys.argv[4]) as f:
        rows = {r["seed"]: r for r in json.load(f)["rows"] if r["run"].rstrip("/").endswith(run.rstrip("/").split("/")[-1])}
    print("| seed | ours (n) | Gymnasium (n) | ours − Gymnasium [95% CI] | Welch p | 1st percentile ours / Gymnasium | "
          "median ours / Gymnasium |")
    print("|---|---|---|---|---|---|---|")
    for i, r in enumerate(returns):
        g = np.asarray(rows[cfg.first_seed + i]["gymnasium"]["returns"])
        lo, hi = stats.welch_diff_ci(r, g)
        p = stats.welch_t_test(r, g).p_two_sided
        print(f"| {cfg.first_seed + i} | {r.mean():.2f} ({r.size}) | {g.mean():.2f} ({g.size}) | "
              f"{r.mean() - g.mean():+.2f} [{lo:+.2f}, {hi:+.2f}] | {stats.fmt_p(p)} | "
              f"{np.percentile(r, 1):.0f} / {np.percentile(g, 1):.0f} | {np.median(r):.0f} / {np.median(g):.0f} |")
