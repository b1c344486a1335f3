"""tools/compare_runs.py on synthetic run folders with known curves (expectations by hand; Welch's p
against scipy's own test)."""

import os
import subprocess
import sys

import numpy as np
import pytest
from scipy import stats as scipy_stats

from test_report import SWIM, SWISH, write_run

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOOL = os.path.join(ROOT, "tools", "compare_runs.py")


def run_tool(*args):
    return subprocess.run([sys.executable, TOOL, *map(str, args)], capture_output=True, text=True, cwd=ROOT)


def test_table_gives_the_scores_their_difference_and_welch_p(tmp_path):
    # A = SWIM, B = SWISH at steps 0, 100, 200 (2 seeds). By hand: max 55 vs 35, final 45 vs 35,
    # AUC (trapezoid / 200 steps) (40 + 35)/2 = 37.5 vs (17.5 + 25)/2 = 21.25.
    a, b = write_run(tmp_path, "a", returns=SWIM), write_run(tmp_path, "b", act="swish", returns=SWISH)
    done = run_tool(a, b)
    assert done.returncode == 0, done.stderr
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
            for line in done.stdout.splitlines()[2:]}
    assert set(rows) == {"max", "final", "auc"}
    expected = {"max": (55, 35, -20, ([60, 50], [30, 40])), "final": (45, 35, -10, ([40, 50], [30, 40])),
                "auc": (37.5, 21.25, -16.25, ([40, 35], [17.5, 25]))}
    for score, (mean_a, mean_b, diff, (per_seed_a, per_seed_b)) in expected.items():
        cells = rows[score]
        assert cells[0].startswith(f"{mean_a:.0f} [") and cells[1].startswith(f"{mean_b:.0f} [")
        assert cells[2].startswith(f"{diff:+.0f} [")
        p = scipy_stats.ttest_ind(per_seed_b, per_seed_a, equal_var=False).pvalue
        assert cells[3] == f"{p:.2f}"


@pytest.mark.parametrize("case", ["missing", "other_env", "other_grid", "one_arg"])
def test_bad_input_is_one_line_and_exit_2(tmp_path, case):
    a = write_run(tmp_path, "a")
    if case == "missing":
        args, needle = (a, tmp_path / "nope"), "nope: not a directory"
    elif case == "other_env":
        args, needle = (a, write_run(tmp_path, "b", env="Hopper-v5")), "env Hopper-v5 differs"
    elif case == "other_grid":
        longer = np.vstack([SWIM, SWIM[-1:]])  # 4 evaluations every 100 steps (total_steps 300)
        args, needle = (a, write_run(tmp_path, "b", returns=longer, total_steps=300)), "the scores need the same grid"
    else:
        args, needle = (a,), "expected two run folders"
    done = run_tool(*args)
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], done.stderr
