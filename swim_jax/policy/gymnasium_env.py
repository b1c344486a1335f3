"""Gymnasium's MuJoCo envs for the policies: made without the known notices about Gymnasium's XML,
and their sizes and action bounds (``env_spec``)."""

from __future__ import annotations

import functools

import numpy as np

from swim_jax.io.cli_parser import one_line
from swim_jax.policy.policy import PolicyError

# MuJoCo's notices about Gymnasium's own XML files, dropped when Gymnasium makes an env (as
# swim_jax.envs.base.KNOWN_XML_NOTICES drops them for our envs; tests/test_policy.py checks they agree)
KNOWN_XML_NOTICES = ("compiler attribute 'settotalmass' is deprecated",)


def make_gymnasium(env_id: str, **kwargs):
    """``gymnasium.make(env_id, **kwargs)`` with the known MuJoCo notices about Gymnasium's XML
    dropped (printed and appended to ./MUJOCO_LOG.TXT otherwise); other MuJoCo warnings become
    Python warnings."""
    import warnings

    import gymnasium as gym
    import mujoco

    previous = mujoco.get_mju_user_warning()
    messages: list[str] = []
    mujoco.set_mju_user_warning(messages.append)
    try:
        return gym.make(env_id, **kwargs)
    finally:
        mujoco.set_mju_user_warning(previous)
        for message in messages:
            if not any(notice in message for notice in KNOWN_XML_NOTICES):
                warnings.warn(f"MuJoCo: {message}", stacklevel=3)


@functools.cache
def env_spec(env_id: str) -> tuple[int, np.ndarray, np.ndarray]:
    """(observation size, action low, action high) of Gymnasium's ``env_id``; the bounds (float64)
    are the ``ctrlrange`` of its MuJoCo model's actuators, which ``envs`` reads from the same XML for
    the actor's tanh scaling."""
    try:
        env = make_gymnasium(env_id)
    except Exception as e:  # gymnasium raises several types for unknown or broken ids
        raise PolicyError(f"env {env_id!r}: Gymnasium cannot make it ({one_line(e)})") from None
    try:
        ctrl = np.array(env.unwrapped.model.actuator_ctrlrange, np.float64)
        obs_size = int(np.prod(env.observation_space.shape))
    finally:
        env.close()
    return obs_size, ctrl[:, 0].copy(), ctrl[:, 1].copy()
