"""The task files: each env's model, observation, reward and termination, and only what differs
from swim_jax/envs/base.py."""
