"""brax's own wrappers and acting code run unchanged on our env (brax Env API, real MJX physics).

brax 0.14.2's agent ``train`` functions (PPO, SAC, ...) call ``jax.device_put_replicated``, which
jax 0.10 removed, so none of them can run in this venv on any env (AttributeError inside
brax/training/agents/ppo/train.py). The test below therefore drives brax's training machinery
that does not depend on pmap: ``brax.envs.wrappers.training.wrap`` (EpisodeWrapper +
AutoResetWrapper + VmapWrapper) and ``brax.training.acting.generate_unroll`` — the rollout code
PPO uses — with a brax PPO policy network (``make_ppo_networks`` / ``make_inference_fn``).
Our own time limit is off (``max_episode_steps=None``); brax's EpisodeWrapper keeps
``info['steps']`` / ``info['truncation']`` itself.
"""

import jax
import numpy as np
import pytest

from swim_jax import envs


@pytest.mark.slow
def test_brax_wrappers_and_ppo_rollout_run_on_our_env():
    from brax.envs.wrappers import training as brax_wrappers
    from brax.training import acting
    from brax.training.agents.ppo import networks as ppo_networks

    env = envs.make("Swimmer-v5", max_episode_steps=None)
    wenv = brax_wrappers.wrap(env, episode_length=5, action_repeat=1)
    nets = ppo_networks.make_ppo_networks(env.observation_size, env.action_size)
    key = jax.random.PRNGKey(0)
    policy_params = nets.policy_network.init(key)
    make_policy = ppo_networks.make_inference_fn(nets)
    policy = make_policy((None, policy_params))

    state = wenv.reset(jax.random.split(key, 3))
    unroll = jax.jit(lambda s, k: acting.generate_unroll(
        wenv, s, policy, k, unroll_length=7, extra_fields=("truncation",)))
    state, tr = unroll(state, key)
    assert tr.observation.shape == (7, 3, env.observation_size)
    assert tr.action.shape == (7, 3, env.action_size)
    trunc = np.asarray(tr.extras["state_extras"]["truncation"])
    # brax's EpisodeWrapper truncates our (never-terminating) Swimmer at step 5
    np.testing.assert_array_equal(trunc[:, 0], [0, 0, 0, 0, 1, 0, 0])
    assert np.all(np.isfinite(np.asarray(tr.reward)))
