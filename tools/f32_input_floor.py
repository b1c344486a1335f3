"""How close can any float32 env get to Gymnasium? Teacher-force our env in float64 from the
recorded inputs rounded to float32 (state, warm start, action: what a float32 env is given) and
report the observation error against Gymnasium's float64 outputs (docs/ENVS.md, "Measured equivalence").

Usage: python tools/f32_input_floor.py [ENV_ID]   (default HalfCheetah-v5; 1000 random + 1000 sine steps, seed 7)
An unknown env id or extra arguments: one line on stderr naming the valid ids, exit status 2.
"""

import sys

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from swim_jax import envs  # noqa: E402
from swim_jax.envs import gym_reference as gr  # noqa: E402


def main(env_id: str = "HalfCheetah-v5") -> None:
    env = envs.make(env_id)
    rec = gr.record_random_and_sine(env_id, 1000, seed=7)
    for k in ("qpos", "qvel", "qacc_warmstart", "xpos", "action"):
        rec[k] = rec[k].astype(np.float32).astype(np.float64)
    err = np.abs(np.asarray(gr.run_teacher_forced(env, rec).obs) - rec["obs"])
    print(f"{env_id}: float64 physics from float32-rounded inputs: obs max {err.max():.3g}, "
          f"p99 {np.percentile(err.max(axis=1), 99):.3g}")


if __name__ == "__main__":
    args = sys.argv[1:]
    if len(args) > 1 or (args and args[0] not in envs.ENV_IDS):
        print(f"f32_input_floor.py: error: expected at most one env id; valid: {', '.join(envs.ENV_IDS)}", file=sys.stderr)
        sys.exit(2)
    main(*args)
