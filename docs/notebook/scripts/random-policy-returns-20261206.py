"""Random-policy returns of every env id in Gymnasium itself (the lower anchor of the normalized
scores, swim_jax/analysis/aggregate.py): uniform actions in the action space, 100 episodes each
(episode e resets with seed e, the action space seeded with 0), the 1000-step time limit.
Run: .venv/bin/python docs/notebook/scripts/random-policy-returns-20261206.py"""
import gymnasium as gym
import numpy as np

for env_id in ["Walker2d-v5", "Walker2d-v4", "Hopper-v5", "Hopper-v4", "HalfCheetah-v5", "Swimmer-v5", "Ant-v5"]:
    env = gym.make(env_id)
    env.action_space.seed(0)
    returns = []
    for e in range(100):
        env.reset(seed=e)
        total, done = 0.0, False
        while not done:
            _, r, term, trunc, _ = env.step(env.action_space.sample())
            total += r
            done = term or trunc
        returns.append(total)
    print(f"{env_id}: {np.mean(returns):.2f} ± {np.std(returns):.2f} over {len(returns)} episodes")
