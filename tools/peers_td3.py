"""One single-threaded run of a reference TD3 ("peer"), timed in its learning phase.

    python tools/peers_td3.py --impl {pytorch,cleanrl} --env Hopper-v5 --steps 1000 --warmup 25000 --seed 0

This is the worker of ``tools/bench_peers.py``; it needs torch (``--impl pytorch``) or jax/flax/optax
(``--impl cleanrl``) plus gymnasium[mujoco], none of which need be the project's own venv (see
``tools/bench_peers.py`` for the separate peers venv). Two peers:

* ``pytorch``: Fujimoto et al.'s original TD3, as transcribed in ``tools/bench_pytorch_td3.py``
  (imported from there, not copied), with ``torch.set_num_threads(1)``.
* ``cleanrl``: a cleanrl-style JAX TD3 (cleanrl's ``td3_continuous_action_jax.py``): flax Actor and
  QNetwork 256-256 ReLU, optax Adam 3e-4, one jitted update of the two critics every step and, every
  2nd step, a jitted actor update + soft target updates (τ 0.005); γ 0.99, batch 256, policy noise
  0.2, noise clip 0.5, Gaussian exploration 0.1·max_action; a NumPy replay buffer (cleanrl uses
  Stable-Baselines3's, which adds a NumPy→torch→NumPy round trip per batch: left out, which can only
  favour the peer) and a Python loop over Gymnasium's own env, ``gymnasium.make(env_id)``. JAX runs
  single-threaded: XLA_FLAGS gets ``--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1``
  before JAX is imported.

Both: OMP/MKL/OPENBLAS_NUM_THREADS=1; first ``--warmup`` uniform-random env steps fill the buffer
(both originals use 25 000 by default), then 50 untimed learning steps (JIT compile / allocator warm
up), then ``--steps`` timed learning-phase steps, each one env step + one training iteration. Output:
ONE JSON line on stdout,

    {"impl", "env", "steps", "seconds", "env_steps_per_s", ...}

with extras: ``cpu_seconds`` (process CPU time, all threads, over the timed steps; ≈ ``seconds`` when
the run really is single-threaded), ``t_start``/``t_end`` (wall-clock epoch seconds of the timed
window, so a caller can check that concurrent runs overlapped), seed, warm-up and library versions.

``--sync`` (used by bench_peers.py to start P concurrent runs' timed windows together): after the
untimed steps print ``ready`` on stdout, wait for a line on stdin, then time; the JSON line follows.
Bad arguments: one line on stderr, exit status 2.
"""

from __future__ import annotations

import os
import sys

# single-threaded numerics: must be set before numpy / torch / jax are imported
for _var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ[_var] = "1"
os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") +
                           " --xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1").strip()

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

TOOLS = os.path.dirname(os.path.abspath(__file__))
if TOOLS not in sys.path:
    sys.path.insert(0, TOOLS)
from bench_pytorch_td3 import CONFIGS, pytorch_td3  # noqa: E402  (numpy only at import time)

IMPLS = ("pytorch", "cleanrl")
COMPILE_STEPS = 50  # untimed learning steps before the timed ones


class _Parser(argparse.ArgumentParser):
    """argparse whose errors are one line on stderr and exit status 2."""

    def error(self, message):
        print(f"peers_td3.py: error: {message}", file=sys.stderr)
        sys.exit(2)


def _positive(text: str) -> int:
    """argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive integer")
    return value


def _seed(text: str) -> int:
    """argparse type: an integer >= 0."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a non-negative integer")
    return value


def parse_args(argv=None) -> argparse.Namespace:
    """The worker's command line (see the module docstring)."""
    p = _Parser(description=__doc__.split("\n")[0])
    p.add_argument("--impl", required=True, choices=IMPLS)
    p.add_argument("--env", required=True, choices=sorted(CONFIGS))
    p.add_argument("--steps", type=_positive, default=1000, help="timed learning-phase steps (default 1000)")
    p.add_argument("--warmup", type=_positive, default=25_000, help="uniform-random steps first (default 25000)")
    p.add_argument("--seed", type=_seed, default=0)
    p.add_argument("--sync", action="store_true", help="print 'ready', wait for a stdin line, then time")
    return p.parse_args(argv)


def cleanrl_td3(env_id: str, seed: int = 0):
    """A step function running a cleanrl-style JAX TD3 (one env step + one update per learning call).

    Follows cleanrl's td3_continuous_action_jax.py: separate jitted ``update_critic`` (both critics)
    and ``update_actor`` (actor + soft updates of all three targets, every ``policy_frequency``
    steps), a jitted ``actor.apply`` for acting, NumPy exploration noise. ``step(learn=False)`` takes
    a uniform-random action and does not train. ``step.sync()`` waits for pending device work.
    """
    import flax
    import flax.linen as nn
    import gymnasium as gym
    import jax
    import jax.numpy as jnp
    import numpy as np
    import optax
    from flax.training.train_state import TrainState

    gamma, tau, batch_size, policy_noise, noise_clip, exploration_noise = 0.99, 0.005, 256, 0.2, 0.5, 0.1
    policy_frequency, learning_rate, buffer_size = 2, 3e-4, 1_000_000

    env = gym.make(env_id)
    env.action_space.seed(seed)
    np.random.seed(seed)
    low, high = env.action_space.low, env.action_space.high
    max_action = float(high[0])
    s_dim, a_dim = env.observation_space.shape[0], env.action_space.shape[0]

    class QNetwork(nn.Module):
        @nn.compact
        def __call__(self, x, a):
            x = jnp.concatenate([x, a], -1)
            x = nn.relu(nn.Dense(256)(x))
            x = nn.relu(nn.Dense(256)(x))
            return nn.Dense(1)(x)

    class Actor(nn.Module):
        action_dim: int
        action_scale: jnp.ndarray
        action_bias: jnp.ndarray

        @nn.compact
        def __call__(self, x):
            x = nn.relu(nn.Dense(256)(x))
            x = nn.relu(nn.Dense(256)(x))
            x = jnp.tanh(nn.Dense(self.action_dim)(x))
            return x * self.action_scale + self.action_bias

    class TrainStateT(TrainState):
        target_params: flax.core.FrozenDict

    key = jax.random.PRNGKey(seed)
    key, actor_key, qf1_key, qf2_key = jax.random.split(key, 4)
    obs, _ = env.reset(seed=seed)
    actor = Actor(action_dim=a_dim, action_scale=jnp.array((high - low) / 2.0, jnp.float32),
                  action_bias=jnp.array((high + low) / 2.0, jnp.float32))
    qf = QNetwork()
    obs0, act0 = jnp.zeros((1, s_dim), jnp.float32), jnp.zeros((1, a_dim), jnp.float32)
    actor_params = actor.init(actor_key, obs0)
    actor_state = TrainStateT.create(apply_fn=actor.apply, params=actor_params, target_params=actor_params,
                                     tx=optax.adam(learning_rate=learning_rate))
    qf1_params, qf2_params = qf.init(qf1_key, obs0, act0), qf.init(qf2_key, obs0, act0)
    qf1_state = TrainStateT.create(apply_fn=qf.apply, params=qf1_params, target_params=qf1_params,
                                   tx=optax.adam(learning_rate=learning_rate))
    qf2_state = TrainStateT.create(apply_fn=qf.apply, params=qf2_params, target_params=qf2_params,
                                   tx=optax.adam(learning_rate=learning_rate))
    actor_apply = jax.jit(actor.apply)

    @jax.jit
    def update_critic(actor_state, qf1_state, qf2_state, observations, actions, next_observations, rewards,
                      terminations, key):
        key, noise_key = jax.random.split(key, 2)
        clipped_noise = jnp.clip(jax.random.normal(noise_key, actions.shape) * policy_noise,
                                 -noise_clip, noise_clip) * actor.action_scale
        next_state_actions = jnp.clip(actor.apply(actor_state.target_params, next_observations) + clipped_noise,
                                      low, high)
        qf1_next_target = qf.apply(qf1_state.target_params, next_observations, next_state_actions).reshape(-1)
        qf2_next_target = qf.apply(qf2_state.target_params, next_observations, next_state_actions).reshape(-1)
        min_qf_next_target = jnp.minimum(qf1_next_target, qf2_next_target)
        next_q_value = (rewards + (1 - terminations) * gamma * min_qf_next_target).reshape(-1)

        def mse_loss(params):
            qf_a_values = qf.apply(params, observations, actions).squeeze()
            return ((qf_a_values - next_q_value) ** 2).mean(), qf_a_values.mean()

        (qf1_loss, _), grads1 = jax.value_and_grad(mse_loss, has_aux=True)(qf1_state.params)
        (qf2_loss, _), grads2 = jax.value_and_grad(mse_loss, has_aux=True)(qf2_state.params)
        qf1_state = qf1_state.apply_gradients(grads=grads1)
        qf2_state = qf2_state.apply_gradients(grads=grads2)
        return (qf1_state, qf2_state), (qf1_loss, qf2_loss), key

    @jax.jit
    def update_actor(actor_state, qf1_state, qf2_state, observations):
        def actor_loss(params):
            return -qf.apply(qf1_state.params, observations, actor.apply(params, observations)).mean()

        actor_loss_value, grads = jax.value_and_grad(actor_loss)(actor_state.params)
        actor_state = actor_state.apply_gradients(grads=grads)
        actor_state = actor_state.replace(
            target_params=optax.incremental_update(actor_state.params, actor_state.target_params, tau))
        qf1_state = qf1_state.replace(
            target_params=optax.incremental_update(qf1_state.params, qf1_state.target_params, tau))
        qf2_state = qf2_state.replace(
            target_params=optax.incremental_update(qf2_state.params, qf2_state.target_params, tau))
        return actor_state, (qf1_state, qf2_state), actor_loss_value

    buf = {k: np.zeros((buffer_size, d), np.float32) for k, d in
           (("obs", s_dim), ("next_obs", s_dim), ("actions", a_dim), ("rewards", 1), ("dones", 1))}
    st = {"ptr": 0, "n": 0, "global_step": 0, "obs": obs, "key": key,
          "actor": actor_state, "qf1": qf1_state, "qf2": qf2_state}

    def step(learn: bool = True):
        st["global_step"] += 1
        obs = st["obs"]
        if learn:
            action = jax.device_get(actor_apply(st["actor"].params, obs[None].astype(np.float32)))[0]
            action = (action + np.random.normal(0, max_action * exploration_noise, size=a_dim)).clip(low, high)
        else:
            action = env.action_space.sample()
        next_obs, reward, term, trunc, _ = env.step(action)
        i = st["ptr"]
        buf["obs"][i], buf["next_obs"][i], buf["actions"][i] = obs, next_obs, action
        buf["rewards"][i], buf["dones"][i] = reward, float(term)
        st["ptr"], st["n"] = (i + 1) % buffer_size, min(st["n"] + 1, buffer_size)
        st["obs"] = env.reset()[0] if (term or trunc) else next_obs
        if learn:
            idx = np.random.randint(0, st["n"], size=batch_size)
            (st["qf1"], st["qf2"]), _, st["key"] = update_critic(
                st["actor"], st["qf1"], st["qf2"], buf["obs"][idx], buf["actions"][idx], buf["next_obs"][idx],
                buf["rewards"][idx].reshape(-1), buf["dones"][idx].reshape(-1), st["key"])
            if st["global_step"] % policy_frequency == 0:
                st["actor"], (st["qf1"], st["qf2"]), _ = update_actor(st["actor"], st["qf1"], st["qf2"],
                                                                      buf["obs"][idx])

    step.sync = lambda: jax.block_until_ready((st["actor"], st["qf1"], st["qf2"]))
    step.versions = {"jax": jax.__version__, "flax": flax.__version__, "optax": optax.__version__,
                     "gymnasium": gym.__version__}
    return step


def make_step(impl: str, env_id: str, seed: int):
    """The chosen peer's step function, with ``.sync()`` and ``.versions`` attributes."""
    if impl == "pytorch":
        import gymnasium as gym
        import torch

        torch.set_num_threads(1)
        torch.set_num_interop_threads(1)
        step = pytorch_td3(env_id, seed)  # synchronous on CPU: nothing to wait for
        step.sync = lambda: None
        step.versions = {"torch": torch.__version__, "torch_threads": torch.get_num_threads(),
                         "gymnasium": gym.__version__}
        return step
    return cleanrl_td3(env_id, seed)


def main(argv=None) -> int:
    """Warm up, compile, time ``--steps`` learning steps, print one JSON line."""
    args = parse_args(argv)
    step = make_step(args.impl, args.env, args.seed)
    for _ in range(args.warmup):
        step(learn=False)
    for _ in range(COMPILE_STEPS):
        step()
    step.sync()
    if args.sync:
        print("ready", flush=True)
        sys.stdin.readline()
    t_start, c0, t0 = time.time(), time.process_time(), time.perf_counter()
    for _ in range(args.steps):
        step()
    step.sync()
    seconds, cpu_seconds, t_end = time.perf_counter() - t0, time.process_time() - c0, time.time()
    print(json.dumps({"impl": args.impl, "env": args.env, "steps": args.steps, "seconds": seconds,
                      "env_steps_per_s": args.steps / seconds, "cpu_seconds": cpu_seconds,
                      "t_start": t_start, "t_end": t_end, "seed": args.seed, "warmup": args.warmup,
                      "compile_steps": COMPILE_STEPS, "versions": step.versions}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
