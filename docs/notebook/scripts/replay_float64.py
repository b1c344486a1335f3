"""The Gymnasium cross-check's two diagnostics, as run (2026-12-04):

    python runs/curated/results/gymnasium/replay_float64.py

1. Gymnasium's low-return episodes of cheetah_relu_native (reset seeds 151 of seed 0, 5 and 192 of
   seed 1, from evaluate-cheetah_relu_native-500.json), replayed in our env (env.backend=mujoco,
   float64) from Gymnasium's reset state with the same NumPy policy on our env's observations:
   the whole 1000-step trajectory and return, bit for bit.
2. Chaos: the same Gymnasium episode with the first action moved by 1e-6, or the policy in float64
   instead of float32: the returns move by ~10-250, so single episodes of two evaluations can
   only be compared as distributions, never paired.
"""

import jax
import jax.numpy as jnp
import numpy as np

jax.config.update("jax_enable_x64", True)

import envs  # noqa: E402
from swim_jax import policy as pol  # noqa: E402

RUN = "runs/curated/validation/halfcheetah-v5-200k/cheetah_relu_native"
env = envs.make("HalfCheetah-v5", backend="mujoco")
reset = jax.jit(lambda q, v: env.reset(jax.random.PRNGKey(0)).replace(pipeline_state=env.physics_reset(q, v)))
observe = jax.jit(lambda st: st.replace(obs=env.observation(st.pipeline_state)))
step = jax.jit(env.step)
genv = pol.make_gymnasium("HalfCheetah-v5")


def gym_episode(policy, reset_seed, first_action_shift=0.0):
    obs, _ = genv.reset(seed=reset_seed)
    start = np.array(genv.unwrapped.data.qpos), np.array(genv.unwrapped.data.qvel)
    seen, total = [obs], 0.0
    for t in range(1000):
        a = policy(obs) + (first_action_shift if t == 0 else 0.0)
        obs, r, term, trunc, _ = genv.step(a)
        seen.append(obs)
        total += r
    return total, np.array(seen), start


print("1. Gymnasium's low-return episodes replayed in our env (float64, MuJoCo C)")
for seed, reset_seed in ((0, 151), (1, 5), (1, 192)):
    policy = pol.load_policy(RUN, seed)
    g_ret, g_obs, (q, v) = gym_episode(policy, reset_seed)
    st = observe(reset(jnp.asarray(q), jnp.asarray(v)))
    seen, total = [np.asarray(st.obs)], 0.0
    for _ in range(1000):
        st = step(st, jnp.asarray(policy(np.asarray(st.obs))))
        seen.append(np.asarray(st.obs))
        total += float(st.reward)
    print(f"  seed {seed}, reset seed {reset_seed}: Gymnasium {g_ret:.4f}, ours {total:.4f}, "
          f"max |obs difference| over the episode {np.abs(np.array(seen) - g_obs).max():.1e}")

print("2. chaos: one Gymnasium episode, the first action moved by 1e-6 / the policy in float64")
p32, p64 = pol.load_policy(RUN, 0), pol.load_policy(RUN, 0, dtype=np.float64)
for reset_seed in range(4):
    base = gym_episode(p32, reset_seed)[0]
    print(f"  reset seed {reset_seed}: {base:.1f}; shifted {gym_episode(p32, reset_seed, 1e-6)[0]:.1f}; "
          f"float64 policy {gym_episode(p64, reset_seed)[0]:.1f}")
