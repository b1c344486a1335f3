"""Offscreen rendering renders a frame, or skips naming the GL backend it needs."""

import json
import os
import subprocess
import sys

import pytest

SCRIPT = r"""
import json, sys, numpy as np
import envs
from envs.render import render_trajectory, RenderingUnavailable
env = envs.make("Hopper-v5")
q = np.stack([np.array(env.mj_model.qpos0)] * 2)
q[1, 2] = 0.3
try:
    f = render_trajectory(env, q, height=64, width=80)
except RenderingUnavailable as e:
    print(json.dumps({"skip": str(e)})); sys.exit(0)
print(json.dumps({"shape": list(f.shape), "dtype": str(f.dtype), "std": float(f.std()),
                  "differ": bool((f[0] != f[1]).any())}))
"""


def test_render_frames_or_skip():
    # MUJOCO_GL is read when mujoco is imported, so each backend is tried in a fresh process
    tried = []
    for backend in ([os.environ["MUJOCO_GL"]] if "MUJOCO_GL" in os.environ else ["egl", "osmesa"]):
        env = dict(os.environ, MUJOCO_GL=backend, PYOPENGL_PLATFORM=backend)
        out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True,
                             text=True, timeout=120, cwd=os.path.dirname(os.path.dirname(__file__)))
        lines = [l for l in out.stdout.splitlines() if l.startswith("{")]
        res = json.loads(lines[-1]) if lines else {"skip": out.stderr.strip()[-300:]}
        if "skip" not in res:
            assert res["shape"] == [2, 64, 80, 3] and res["dtype"] == "uint8"
            assert res["std"] > 0 and res["differ"]  # a picture, and the pose changes it
            return
        tried.append(f"{backend}: {res['skip']}")
    pytest.skip("no offscreen GL backend; " + " | ".join(tried))
