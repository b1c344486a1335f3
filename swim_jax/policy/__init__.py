"""Trained policies as plain NumPy functions, without JAX (this room imports no JAX):

    from swim_jax.policy import load_policy
    policy = load_policy("runs/cheetah_swim-20260101-120000", seed=0)
    action = policy(obs)

The policy and its export format: swim_jax/policy/policy.py; a run folder's policies:
swim_jax/policy/run_folder.py; Gymnasium's envs and their action bounds: swim_jax/policy/gymnasium_env.py;
the activations in NumPy: swim_jax/policy/activations.py; the actor out of a training checkpoint:
swim_jax/policy/checkpoint.py.
"""

from swim_jax.policy.policy import Policy, PolicyError, load_exported
from swim_jax.policy.run_folder import RunPolicies, load_policy, run_policies

__all__ = ["Policy", "PolicyError", "RunPolicies", "load_exported", "load_policy", "run_policies"]
