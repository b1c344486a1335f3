"""brax's own training code runs unchanged on our env (brax Env API, real MJX physics).

A few PPO iterations on Swimmer-v5 (no contacts: the cheapest compile) with brax's
``wrap_for_training`` wrappers (EpisodeWrapper + AutoResetWrapper + VmapWrapper). Our own time
limit is switched off (``max_episode_steps=None``) because brax's EpisodeWrapper keeps the same
``info['steps']`` / ``info['truncation']`` keys itself.
"""

import numpy as np
import pytest

import envs


@pytest.mark.slow
def test_brax_ppo_trains_a_few_steps():
    from brax.training.agents.ppo import train as ppo

    env = envs.make("Swimmer-v5", max_episode_steps=None)
    progress = []
    make_policy, params, metrics = ppo.train(
        environment=env, num_timesteps=64, episode_length=8, num_envs=4, batch_size=4,
        num_minibatches=1, unroll_length=4, num_updates_per_batch=1, num_evals=2,
        num_eval_envs=2, seed=0, progress_fn=lambda step, m: progress.append((step, m)))
    assert progress and progress[-1][0] >= 64
    assert np.isfinite(float(metrics["eval/episode_reward"]))
    assert params is not None and callable(make_policy)
