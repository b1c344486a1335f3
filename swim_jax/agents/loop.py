"""The jitted training program of any agent: per-seed state, a ``lax.scan`` chunk of env steps, batched eval.

Seeds are a leading (vmapped) axis of every array in :class:`TrainState`. Each seed's randomness
comes only from its own keys: ``fold_in(PRNGKey(base_seed), seed_index)`` split into
(init, train, env, eval) keys, so seed i alone equals seed i in a vmapped run.

The agent is anything with the interface of ``swim_jax.agents.base.Agent`` (TD3, SAC: the
registry ``swim_jax.agents.registry``). One env step t (global index, shared by all seeds, so the
branches below stay real branches under vmap) for one seed, following the original TD3 ``main.py``:

    a_t  = U(low, high)                         if t < learning_starts
         = agent.explore(actor, s_t)            otherwise (TD3: clip(μ(s_t) + N(0,(0.1 m)²), low, high))
    (s', s_final) = step_autoreset(env, s_t, a_t)       s_final = true obs reached by the step
                    (all lanes at once; resets computed only when some lane's episode ended)
    replay ← (s_t, a_t, r_t, s_final, terminated = done·(1 − truncation))
    if t ≥ learning_starts: one agent update at iteration it = t − learning_starts + 1 (delays such
                            as TD3's actor on it mod policy_freq = 0 are the agent's own)

Evaluation: ``episodes`` episodes per seed with the deterministic policy (``agent.act``), all seeds × episodes
stepped together in one ``lax.while_loop`` that stops once every episode has ended (or after
``max_steps``); rewards after an episode's end are masked out.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from swim_jax import envs
from swim_jax.agents import replay
from swim_jax.agents.base import Agent

Array = jax.Array


class TrainState(NamedTuple):
    """Everything one seed's training needs to continue (leading seed axis when batched)."""

    key: Array  # training key stream (uint32[2])
    eval_key: Array  # evaluation key (fold_in with the evaluation index)
    env_state: Any  # envs State (obs, physics, step counter)
    buffer: replay.ReplayState
    agent: Any  # the agent's state (its ``actor`` field: the deterministic policy's parameters)
    episode_return: Array  # return of the running training episode
    last_return: Array  # return of the last finished training episode (nan before the first)
    episodes: Array  # finished training episodes (int32)
    bad_step: Array  # int32[len(agent.CHECKED)]: first step where the quantity was non-finite, or -1


def seed_keys(base_seed, seed_index: Array) -> tuple[Array, Array, Array, Array]:
    """(init, train, env, eval) keys of seed ``seed_index``: split(fold_in(PRNGKey(base), i), 4).
    ``base_seed`` may be a Python int or a traced integer scalar."""
    k = jax.random.fold_in(jax.random.PRNGKey(base_seed), seed_index)
    k_init, k_train, k_env, k_eval = jax.random.split(k, 4)
    return k_init, k_train, k_env, k_eval


def init_state(agent: Agent, env, replay_size: int, base_seed, seed_index: Array, hparams=None) -> TrainState:
    """Fresh per-seed state: initial params, empty buffer, env reset with the seed's env key.
    ``hparams``: this lane's sweep values (``agent.with_hparams``; a learnable k starts at its value)."""
    agent = agent.with_hparams(hparams)
    k_init, k_train, k_env, k_eval = seed_keys(base_seed, seed_index)
    dt = agent.dtype
    return TrainState(
        key=k_train,
        eval_key=k_eval,
        env_state=env.reset(k_env),
        buffer=replay.init(replay_size, agent.obs_dim, agent.action_dim, dt),
        agent=agent.init(k_init),
        episode_return=jnp.zeros((), dt),
        last_return=jnp.full((), jnp.nan, dt),
        episodes=jnp.zeros((), jnp.int32),
        bad_step=jnp.full((len(agent.CHECKED),), -1, jnp.int32),
    )


def summarize_updates(m, updated: Array):
    """The per-lane summary of one call (the agent's ``ChunkMetrics``, each field [L]: its counts
    and the count-weighted means of its metrics, nan where a count is 0) from per-step update
    metrics stacked on axis 0 ([T, L]; their type carries the agent's ``MetricSpec``) and the
    per-step "an update ran" flags ([T]): ``swim_jax.agents.metrics.MetricSpec.summarize``."""
    return type(m).spec.summarize(m, updated)


def _act(agent: Agent, learning_starts: int, s: TrainState, t: Array, hparams=None):
    """One lane's action at step t (uniform before ``learning_starts``, else exploration) and its
    key stream: (action, next training key, reset key, update key)."""
    agent = agent.with_hparams(hparams)
    key, k_act, k_reset, k_update = jax.random.split(s.key, 4)
    action = jax.lax.cond(
        t < learning_starts,
        lambda: agent.random_action(k_act),
        lambda: agent.explore(s.agent.actor, s.env_state.obs, k_act),
    )
    return action, key, k_reset, k_update


def _record(s: TrainState, key: Array, action: Array, next_state, final_obs) -> TrainState:
    """One lane's bookkeeping after its env step: replay insert and episode statistics."""
    done = next_state.done > 0
    terminated = next_state.done * (1 - next_state.info["truncation"])
    buffer = replay.add(s.buffer, replay.Transition(s.env_state.obs, action, next_state.reward,
                                                    final_obs, terminated))
    ep_ret = s.episode_return + next_state.reward.astype(s.episode_return.dtype)
    return s._replace(
        key=key,
        env_state=next_state,
        buffer=buffer,
        episode_return=jnp.where(done, jnp.zeros_like(ep_ret), ep_ret),
        last_return=jnp.where(done, ep_ret, s.last_return),
        episodes=s.episodes + done.astype(jnp.int32),
    )


def env_step_lanes(agent: Agent, env, learning_starts: int, states: TrainState, t: Array, hparams=None):
    """Every lane (axis 0 of ``states``) acts, the env steps all lanes at once with auto-reset
    (resets computed only on steps where some lane finished), and each lane stores its transition.
    Returns (states with new key/env/buffer/episode stats, update keys[L])."""
    actions, keys, k_reset, k_update = jax.vmap(
        lambda s, h: _act(agent, learning_starts, s, t, h))(states, hparams)
    next_env, final_obs = envs.step_autoreset_lanes(env, states.env_state, actions, k_reset)
    states = jax.vmap(_record)(states, keys, actions, next_env, final_obs)
    return states, k_update


def update_step(agent: Agent, learning_starts: int, s: TrainState, k_update: Array, t: Array,
                hparams=None):
    """One lane's agent update at global step t (from ``learning_starts`` on, at iteration
    ``t - learning_starts + 1``), the NaN/inf watch, and the update's metrics (zeros when no
    update ran)."""
    agent = agent.with_hparams(hparams)
    k_sample, k_agent = jax.random.split(k_update)
    it = t - learning_starts + 1

    def do_update(a):
        batch = replay.sample(s.buffer, k_sample, agent.config.batch_size)
        new, m = agent.update(a, batch, k_agent, it)
        return new, m, agent.finite(new, m)

    def no_update(a):  # parameters unchanged: nothing new can be non-finite
        return a, agent.zero_metrics(), jnp.ones((len(agent.CHECKED),), jnp.bool_)

    agent_state, m, ok = jax.lax.cond(t >= learning_starts, do_update, no_update, s.agent)
    bad_step = jnp.where((s.bad_step < 0) & ~ok, t.astype(jnp.int32), s.bad_step)
    return s._replace(agent=agent_state, bad_step=bad_step), m


def train_step_lanes(agent: Agent, env, learning_starts: int, states: TrainState, t: Array,
                     hparams=None):
    """One env step and (from ``learning_starts`` on) one agent update for every lane at step t;
    returns the new states and each lane's update metrics. ``hparams``: per-lane sweep values
    ``{path: [L]}`` (see ``Agent.with_hparams``), None for none."""
    states, k_update = env_step_lanes(agent, env, learning_starts, states, t, hparams)
    return jax.vmap(lambda s, k, h: update_step(agent, learning_starts, s, k, t, h))(states, k_update, hparams)


def make_chunk_fn(agent: Agent, env, learning_starts: int, num_steps: int):
    """``chunk(states, t0, hparams) -> (states, ChunkMetrics)`` (the agent's ``METRICS.chunk_type``): ``num_steps`` env steps
    t0 … t0+num_steps−1 for all lanes (states batched on axis 0; t0 an int32 scalar shared by the
    lanes; ``hparams`` a dict of per-lane sweep values ``{path: [L]}``, None for a plain
    multi-seed run) and the lanes' learning diagnostics over those steps. Jit it once."""

    def chunk(states: TrainState, t0: Array, hparams=None):
        def body(carry, i):
            t = (t0 + i).astype(jnp.int32)
            carry, m = train_step_lanes(agent, env, learning_starts, carry, t, hparams)
            return carry, (m, t >= learning_starts)

        states, (m, updated) = jax.lax.scan(body, states, jnp.arange(num_steps, dtype=jnp.int32))
        return states, summarize_updates(m, updated)

    return chunk


def eval_reset_keys(eval_keys: Array, eval_index: Array, episodes: int) -> Array:
    """Reset keys ``[S, episodes]`` of evaluation ``eval_index``: episode e of seed s starts from
    ``split(fold_in(eval_keys[s], eval_index), episodes)[e]``."""
    return jax.vmap(lambda k: jax.random.split(jax.random.fold_in(k, eval_index), episodes))(eval_keys)


def episode_returns(env, reset_keys: Array, policy, max_steps: int) -> Array:
    """Returns ``[S, E]`` of one episode per reset key (``reset_keys[S, E]``) under ``policy(obs[S, E, o],
    t) -> actions[S, E, a]`` (t the int32 step index). All S×E envs step together in one
    ``lax.while_loop`` until every one is done (or ``max_steps``); an episode's return sums its
    rewards up to and including its terminal step (later rewards are masked, also if non-finite)."""
    states = jax.vmap(jax.vmap(env.reset))(reset_keys)
    done0 = jnp.zeros(reset_keys.shape[:2], jnp.bool_)
    init = (jnp.zeros((), jnp.int32), states, done0, jnp.zeros(done0.shape, states.reward.dtype))

    def cond(c):
        t, _, done, _ = c
        return (t < max_steps) & ~jnp.all(done)

    def body(c):
        t, st, done, ret = c
        st = jax.vmap(jax.vmap(env.step))(st, policy(st.obs, t))
        ret = ret + jnp.where(done, jnp.zeros_like(st.reward), st.reward)
        return t + 1, st, done | (st.done > 0), ret

    return jax.lax.while_loop(cond, body, init)[3]


def make_eval_fn(agent: Agent, env, episodes: int, max_steps: int):
    """``evaluate(actor_params[S], eval_keys[S], eval_index, hparams) -> returns[S, episodes]``:
    :func:`episode_returns` of the episodes from :func:`eval_reset_keys` with actions μ_s(obs).
    ``hparams``: per-lane sweep values ``{path: [S]}`` (the actor of a swept k uses its lane's k),
    empty/None for none."""

    def evaluate(actor_params, eval_keys: Array, eval_index: Array, hparams=None) -> Array:
        def policy(obs: Array, t: Array) -> Array:
            return jax.vmap(lambda p, o, h: agent.with_hparams(h).act(p, o))(actor_params, obs, hparams)

        return episode_returns(env, eval_reset_keys(eval_keys, eval_index, episodes), policy, max_steps)

    return evaluate
