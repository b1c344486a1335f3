"""Trained policies as plain NumPy functions, without JAX (this room imports no JAX):

    from swim_jax.policy import load_policy
    policy = load_policy("runs/cheetah_swim-20260101-120000", seed=0)
    action = policy(obs)

The contract and the export format: swim_jax/policy/policy.py; the activations in NumPy:
swim_jax/policy/activations.py; the actor out of a training checkpoint: swim_jax/policy/checkpoint.py.
"""

from swim_jax.policy.policy import Policy, PolicyError, RunPolicies, load_exported, load_policy, run_policies

__all__ = ["Policy", "PolicyError", "RunPolicies", "load_exported", "load_policy", "run_policies"]
