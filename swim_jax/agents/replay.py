"""Replay buffer as a pytree of preallocated JAX arrays (one buffer per seed; vmap for many).

Slots 0..capacity-1; transition n (0-based insertion count) goes to slot n mod capacity, so the
oldest transition is overwritten once the buffer is full. ``size`` = min(n_inserted, capacity).
Sampling draws ``batch`` slot indices i.i.d. uniform on {0, …, size−1} (with replacement): O(batch).

Each transition stores (obs, action, reward, next_obs, terminated). ``next_obs`` is the TRUE
observation the step reached (also for the last step of an episode, before any reset), and
``terminated`` is 1 only for a true termination: time-limit truncation is stored as 0 so the TD
target bootstraps through it.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

Array = jax.Array


class Transition(NamedTuple):
    """One transition (or a batch of them along a leading axis)."""

    obs: Array
    action: Array
    reward: Array
    next_obs: Array
    terminated: Array


class ReplayState(NamedTuple):
    """Buffer contents (leading axis = capacity) plus insertion pointer and fill level (int32)."""

    data: Transition
    ptr: Array
    size: Array


def init(capacity: int, obs_dim: int, action_dim: int, dtype=jnp.float32) -> ReplayState:
    """An empty buffer of ``capacity`` zero-filled slots; ptr = size = 0 (int32, not weak)."""
    data = Transition(
        obs=jnp.zeros((capacity, obs_dim), dtype),
        action=jnp.zeros((capacity, action_dim), dtype),
        reward=jnp.zeros((capacity,), dtype),
        next_obs=jnp.zeros((capacity, obs_dim), dtype),
        terminated=jnp.zeros((capacity,), dtype),
    )
    zero = jnp.zeros((), jnp.int32)
    return ReplayState(data, zero, zero)


def capacity(state: ReplayState) -> int:
    """Number of slots (static)."""
    return state.data.reward.shape[0]


def add(state: ReplayState, transition: Transition) -> ReplayState:
    """Write one transition at slot ``ptr``; ptr ← (ptr + 1) mod capacity, size ← min(size + 1, capacity)."""
    cap = capacity(state)
    data = jax.tree.map(
        lambda buf, x: buf.at[state.ptr].set(jnp.asarray(x, buf.dtype)), state.data, transition
    )
    ptr = (state.ptr + 1) % cap
    size = jnp.minimum(state.size + 1, cap)
    return ReplayState(data, ptr.astype(jnp.int32), size.astype(jnp.int32))


def sample_indices(state: ReplayState, key: Array, batch_size: int) -> Array:
    """``batch_size`` i.i.d. slot indices uniform on {0, …, size−1} (size ≥ 1 required)."""
    return jax.random.randint(key, (batch_size,), 0, jnp.maximum(state.size, 1), dtype=jnp.int32)


def sample(state: ReplayState, key: Array, batch_size: int) -> Transition:
    """A uniform batch (with replacement) of filled transitions: gathers ``batch_size`` rows."""
    idx = sample_indices(state, key, batch_size)
    return jax.tree.map(lambda buf: buf[idx], state.data)
