"""Learning validation (slow): HalfCheetah-v5, ReLU and Swim, 3 seeds, 200k steps each.

Target: mean evaluation return ≥ 5,000 at 200k steps for both activations
(original TD3 on gym v1: 6,833 at 200k). Hours of CPU time; run with ``pytest -m slow``.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.mark.slow
@pytest.mark.parametrize("config", ["cheetah_relu", "cheetah_swim"])
def test_halfcheetah_200k_reaches_5000(config, tmp_path):
    out = os.environ.get("SWIM_VALIDATION_OUT", str(tmp_path))
    p = subprocess.run(
        [sys.executable, "-m", "swim_jax.train", f"config={config}", "seeds=3", "total_steps=200000",
         f"out_dir={out}"],
        cwd=REPO, capture_output=True, text=True,
    )
    assert p.returncode == 0, p.stderr[-3000:]
    run_dir = next(l.split(": ", 1)[1] for l in p.stdout.splitlines() if l.startswith("run dir: "))
    ev = np.load(os.path.join(run_dir, "evaluations.npy"))  # [41, 3]
    assert ev.shape == (41, 3)
    print(config, "final mean", ev[-1].mean(), "per seed", ev[-1])
    assert ev[-1].mean() >= 5000
