"""Our own evaluation of a finished run's final policies, with as many episodes as asked.

A run records ``eval_episodes`` (e.g. 10) episodes per seed at each evaluation; next to Gymnasium's
100 (``python -m swim_jax.evaluate``) that few make a wide confidence interval, and on bimodal
tasks (a Walker2d that falls now and then) a misleading one. :func:`our_episodes` runs the run's
own evaluation program again (``agents.loop.make_eval_fn`` on the run's env, physics backend,
precision and matmul products, as ``run.programs.build`` builds them for training) on its final
policies at the final evaluation index, with ``episodes`` episodes per seed: the reset draws are
``eval_reset_keys(eval_key, index, episodes)``, and ``split(key, N)[e]`` does not depend on N (JAX's
partitionable threefry, its default), so the first ``eval_episodes`` are the recorded evaluation's
own episodes (the same returns) and the rest extend them. Needs JAX
(``python -m swim_jax.evaluate --ours-episodes N``).
"""

from __future__ import annotations

import os

import numpy as np


class OurEvaluationError(ValueError):
    """A run folder this cannot evaluate; ``str(e)`` is one line."""


def our_episodes(run_dir: str, episodes: int) -> np.ndarray:
    """``returns[seed position, episode]`` (float64) of ``episodes`` episodes per seed of
    ``run_dir``'s final policies (``final_policy.npz``) in our env, as the run evaluated them at its
    final evaluation (index ``total_steps // eval_freq``), deterministic actions. Sweep folders and
    their points are refused (their per-point values are not rebuilt here)."""
    import jax
    import jax.numpy as jnp

    from swim_jax import config as cfgmod
    from swim_jax.agents import loop
    from swim_jax.run.programs import build
    from swim_jax.run.render import unflatten

    if os.path.isfile(os.path.join(run_dir, "point.json")) or os.path.isdir(os.path.join(run_dir, "points")):
        raise OurEvaluationError(f"{run_dir}: a sweep or a sweep point; --ours-episodes evaluates plain runs only")
    _, cfg = cfgmod.read_run_config(run_dir)  # (as the run multiplied: an old folder's auto included)
    policy_file = os.path.join(run_dir, "final_policy.npz")
    if not os.path.isfile(policy_file):
        raise OurEvaluationError(f"{run_dir}: no final_policy.npz (the run has not finished)")
    _env, eval_env, agent = build(cfg)
    with np.load(policy_file, allow_pickle=False) as z:
        params = jax.tree.map(jnp.asarray, unflatten({k: z[k] for k in z.files}))
    evaluate = jax.jit(loop.make_eval_fn(agent, eval_env, episodes, cfg.env.max_episode_steps))
    seed_ids = jnp.arange(cfg.first_seed, cfg.first_seed + cfg.seeds, dtype=jnp.int32)
    keys = jax.vmap(lambda i: loop.seed_keys(cfg.seed, i)[3])(seed_ids)
    index = jnp.int32(cfgmod.schedule(cfg).n_chunks)  # the final evaluation's
    return np.asarray(evaluate(params, keys, index), np.float64)
