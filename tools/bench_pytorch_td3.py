"""Yardstick: the original PyTorch TD3's single-run rate vs our vmapped JAX program, in one process.

    pip install torch==2.13.0            # NOT a project dependency; CPU build
    python tools/bench_pytorch_td3.py --env HalfCheetah-v5 --lanes 5 --steps 500 --repeats 3

The PyTorch side is Fujimoto et al.'s TD3 (github.com/sfujim/TD3, TD3.py + main.py) transcribed:
Actor s→256→256→a (ReLU, tanh·max_action), twin critics (s,a)→256→256→1 (ReLU), Adam 3e-4,
γ 0.99, τ 0.005, policy noise 0.2, noise clip 0.5, policy_freq 2, batch 256, Gaussian exploration
0.1·max_action, a NumPy replay buffer, and Gymnasium's own (native MuJoCo) env. Each timed block is
``--steps`` env steps, each followed by one training iteration (the learning phase).

The JAX side is ``swim_jax.run.train``'s compiled chunk for ``config=<env>_relu`` with ``--lanes`` seeds
(every step an update, ``learning_starts=0``). Blocks of the two alternate in ONE process, so
machine noise hits both alike; medians are reported, and the ratio

    JAX env-steps/s over all lanes  /  PyTorch env-steps/s of one run

compares one program of all seeds with ONE PyTorch run; tools/bench_peers.py compares with the way users
run the original (one single-thread process per seed, all cores busy).
"""

from __future__ import annotations

import argparse
import copy
import sys

import numpy as np

CONFIGS = {"HalfCheetah-v5": "cheetah_relu", "Hopper-v5": "hopper_relu", "Walker2d-v5": "walker_relu",
           "Swimmer-v5": "swimmer_relu"}


def pytorch_td3(env_id: str, seed: int = 0):
    """A step function running the original TD3 (one env step + one train iteration per call)."""
    import gymnasium as gym
    import torch
    import torch.nn as nn
    import torch.nn.functional as F

    torch.manual_seed(seed)
    env = gym.make(env_id)
    s_dim, a_dim = env.observation_space.shape[0], env.action_space.shape[0]
    max_action = float(env.action_space.high[0])

    class Actor(nn.Module):
        def __init__(self):
            super().__init__()
            self.l1, self.l2, self.l3 = nn.Linear(s_dim, 256), nn.Linear(256, 256), nn.Linear(256, a_dim)

        def forward(self, s):
            a = F.relu(self.l1(s))
            a = F.relu(self.l2(a))
            return max_action * torch.tanh(self.l3(a))

    class Critic(nn.Module):
        def __init__(self):
            super().__init__()
            self.l1, self.l2, self.l3 = nn.Linear(s_dim + a_dim, 256), nn.Linear(256, 256), nn.Linear(256, 1)
            self.l4, self.l5, self.l6 = nn.Linear(s_dim + a_dim, 256), nn.Linear(256, 256), nn.Linear(256, 1)

        def forward(self, s, a):
            sa = torch.cat([s, a], 1)
            q1 = self.l3(F.relu(self.l2(F.relu(self.l1(sa)))))
            q2 = self.l6(F.relu(self.l5(F.relu(self.l4(sa)))))
            return q1, q2

        def Q1(self, s, a):
            sa = torch.cat([s, a], 1)
            return self.l3(F.relu(self.l2(F.relu(self.l1(sa)))))

    actor, critic = Actor(), Critic()
    actor_t, critic_t = copy.deepcopy(actor), copy.deepcopy(critic)
    a_opt = torch.optim.Adam(actor.parameters(), lr=3e-4)
    c_opt = torch.optim.Adam(critic.parameters(), lr=3e-4)
    size = 1_000_000
    buf = {k: np.zeros((size, d), np.float32) for k, d in
           (("s", s_dim), ("a", a_dim), ("s2", s_dim), ("r", 1), ("nd", 1))}
    state = {"ptr": 0, "n": 0, "it": 0, "obs": env.reset(seed=seed)[0]}
    rng = np.random.default_rng(seed)

    def train():
        state["it"] += 1
        idx = rng.integers(0, state["n"], size=256)
        s, a, s2, r, nd = (torch.as_tensor(buf[k][idx]) for k in ("s", "a", "s2", "r", "nd"))
        with torch.no_grad():
            noise = (torch.randn_like(a) * 0.2).clamp(-0.5, 0.5)
            a2 = (actor_t(s2) + noise).clamp(-max_action, max_action)
            q1t, q2t = critic_t(s2, a2)
            y = r + nd * 0.99 * torch.min(q1t, q2t)
        q1, q2 = critic(s, a)
        loss = F.mse_loss(q1, y) + F.mse_loss(q2, y)
        c_opt.zero_grad()
        loss.backward()
        c_opt.step()
        if state["it"] % 2 == 0:
            a_loss = -critic.Q1(s, actor(s)).mean()
            a_opt.zero_grad()
            a_loss.backward()
            a_opt.step()
            for p, tp in zip(critic.parameters(), critic_t.parameters()):
                tp.data.copy_(0.005 * p.data + 0.995 * tp.data)
            for p, tp in zip(actor.parameters(), actor_t.parameters()):
                tp.data.copy_(0.005 * p.data + 0.995 * tp.data)

    def step(learn: bool = True):
        obs = state["obs"]
        if learn:
            with torch.no_grad():
                a = actor(torch.as_tensor(obs, dtype=torch.float32)[None])[0].numpy()
            a = (a + rng.normal(0, 0.1 * max_action, a_dim)).clip(-max_action, max_action)
        else:
            a = env.action_space.sample()
        obs2, r, term, trunc, _ = env.step(a)
        i = state["ptr"]
        buf["s"][i], buf["a"][i], buf["s2"][i], buf["r"][i], buf["nd"][i] = obs, a, obs2, r, 1.0 - float(term)
        state["ptr"], state["n"] = (i + 1) % size, min(state["n"] + 1, size)
        state["obs"] = env.reset()[0] if (term or trunc) else obs2
        if learn:
            train()

    return step


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--env", default="HalfCheetah-v5", choices=sorted(CONFIGS))
    p.add_argument("--lanes", type=int, default=5)
    p.add_argument("--steps", type=int, default=500)
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args(argv)
    try:
        import torch
    except ImportError:
        print("error: this yardstick needs PyTorch (pip install torch==2.13.0); it is not a project dependency",
              file=sys.stderr)
        return 2
    import jax
    import jax.numpy as jnp

    from swim_jax import config as cfgmod
    from swim_jax.bench import timing
    from swim_jax.bench.train import lanes_program, learning_phase_overrides

    torch_step = pytorch_td3(args.env)
    for _ in range(1000):  # random warm-up fills the buffer (the original uses 25k; speed is the same)
        torch_step(learn=False)
    # one chunk call = --steps steps (progress_steps too: with its default 1000, --steps 2000 ran
    # chunks of 1000 steps while the rate counted 2000)
    _, prog, st = lanes_program(cfgmod.resolve(CONFIGS[args.env], learning_phase_overrides(args.steps)), args.lanes)
    st = jax.block_until_ready(prog.chunk_fn(st, jnp.asarray(0, jnp.int32))[0])  # compile
    for _ in range(50):
        torch_step()
    box = [st]

    def torch_block(_r):  # --steps learning steps of the PyTorch run (synchronous on a CPU)
        for _ in range(args.steps):
            torch_step()

    def jax_chunk(r):  # block r: the chunk from step (r + 1) · steps, advancing the state
        box[0] = prog.chunk_fn(box[0], jnp.asarray((r + 1) * args.steps, jnp.int32))[0]
        return box[0]

    blocks = timing.interleave({"torch": timing.timed(torch_block, wait=None),
                                "jax": timing.timed(jax_chunk)}, args.repeats, rotate=False)
    t_torch, t_jax = blocks["torch"], blocks["jax"]
    torch_rate = args.steps / timing.summarise(t_torch).median
    jax_rate = args.steps * args.lanes / timing.summarise(t_jax).median
    print(f"{args.env}, 256-256 ReLU TD3, learning phase, {args.steps} steps × {args.repeats} interleaved blocks "
          f"(torch {torch.__version__}, {torch.get_num_threads()} threads; jax {jax.__version__})")
    print(f"PyTorch TD3, 1 run:      {torch_rate:7.1f} env-steps/s (blocks {', '.join(f'{t:.2f}' for t in t_torch)} s)")
    print(f"swim-jax, {args.lanes} lanes:      {jax_rate:7.1f} env-steps/s all lanes, {jax_rate / args.lanes:.1f} per lane "
          f"(blocks {', '.join(f'{t:.2f}' for t in t_jax)} s)")
    print(f"ratio (all lanes / PyTorch single run): {jax_rate / torch_rate:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
