"""The report's Gymnasium check (swim_jax/analysis/gymnasium_check.py): each curve's final policies as
``python -m swim_jax.evaluate --json RUN/gymnasium-evaluation.json`` played them, read back from the
curated files and checked against the same numbers computed here from the JSON with NumPy."""

import json
import os
import shutil

import numpy as np
import pytest

from swim_jax.analysis import gymnasium_check, report

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CURATED = os.path.join(REPO, "runs", "curated", "study-table2")
SKIP = shutil.ignore_patterns("checkpoints", "*.npz", "evaluations_seed*.npy", "train.log")


def _copy(tmp_path, cell: str) -> str:
    dst = tmp_path / cell
    shutil.copytree(os.path.join(CURATED, cell), dst, ignore=SKIP)
    return str(dst)


def _rows(run: str) -> list[dict]:
    with open(os.path.join(run, gymnasium_check.FILE)) as f:
        return json.load(f)["rows"]


def test_the_report_section_and_json_equal_the_files(tmp_path, capsys):
    """Walker2d-v5 at 300k: Swim's and Swish's five seeds, each 100 Gymnasium episodes (the files
    written when those cells were curated): mean ± sample std over seeds and the mean difference."""
    runs = [_copy(tmp_path, c) for c in ("walker_swim", "walker_swish")]
    assert report.main(runs + ["--out", str(tmp_path / "rep"), "--mixed-precision"]) == 0
    res = json.load(open(tmp_path / "rep" / "results.json"))["gymnasium_check"]["Walker2d-v5"]
    md = open(tmp_path / "rep" / "REPORT.md").read()
    for run, label, name in zip(runs, ("swim", "swish"), ("Swim", "Swish")):
        rows = _rows(run)
        ours = np.array([r["ours"]["mean"] for r in rows])
        gym = np.array([r["gymnasium"]["mean"] for r in rows])
        got = res[label]
        assert got["checked"] == [r["seed"] for r in rows] == [0, 1, 2, 3, 4] and got["episodes"] == [100]
        assert got["gymnasium_mean"] == pytest.approx(gym.mean(), rel=1e-12)
        assert got["gymnasium_sd"] == pytest.approx(gym.std(ddof=1), rel=1e-12)
        assert got["ours_mean"] == pytest.approx(ours.mean(), rel=1e-12)
        assert got["gymnasium_minus_ours"] == pytest.approx((gym - ours).mean(), rel=1e-9)
        # our side is the run's own evaluation at that step, as the report reads it
        evals = np.load(os.path.join(run, "evaluations.npy"))[-1]
        np.testing.assert_allclose(ours, evals, rtol=1e-6)
        assert (f"| Walker2d-v5 | {name} | 300,000 | 5 of 5 | {ours.mean():.1f} ± {ours.std(ddof=1):.1f} | "
                f"{gym.mean():.1f} ± {gym.std(ddof=1):.1f} (100) | {(gym - ours).mean():+.1f} |") in md


def test_only_rows_at_the_curves_last_step_in_its_own_env_with_our_recorded_side(tmp_path, capsys):
    """A row at another step, one played in another env (``--in-env``) and one whose side of ours was
    played again (``--ours-episodes``) are left out of the curve's line."""
    run = _copy(tmp_path, "walker_swim")
    path = os.path.join(run, gymnasium_check.FILE)
    doc = json.load(open(path))
    doc["rows"][0]["step"] = 200_000
    doc["rows"][1]["trained_env_id"], doc["rows"][1]["env_id"] = "Walker2d-v5", "Walker2d-v4"
    doc["rows"][2]["ours"]["source"] = "played again"
    json.dump(doc, open(path, "w"))
    assert sorted(gymnasium_check.read(run, 300_000)) == [3, 4] and list(gymnasium_check.read(run, 200_000)) == [0]
    assert report.main([run, "--out", str(tmp_path / "rep")]) == 0
    assert "| Walker2d-v5 | Swim | 300,000 | 2 of 5 |" in open(tmp_path / "rep" / "REPORT.md").read()


def test_a_file_whose_record_of_our_return_is_not_the_runs_is_refused(tmp_path, capsys):
    """Read at 200k, the row moved there above still records the 300k return: not this run's evaluation
    at 200k, so the report names the file and the two numbers, exit 2, and writes nothing."""
    run = _copy(tmp_path, "walker_swim")
    path = os.path.join(run, gymnasium_check.FILE)
    doc = json.load(open(path))
    doc["rows"][0]["step"] = 200_000
    json.dump(doc, open(path, "w"))
    capsys.readouterr()
    assert report.main([run, "--at-step", "200000", "--out", str(tmp_path / "rep")]) == 2
    err = capsys.readouterr().err.strip()
    at_200k = np.load(os.path.join(run, "evaluations.npy"))[200_000 // 5000, 0]
    assert len(err.splitlines()) == 1 and gymnasium_check.FILE in err and f"is {at_200k:.2f}" in err
    assert not os.path.exists(tmp_path / "rep")
    doc["rows"][0]["step"], doc["rows"][0]["seed"] = 300_000, 7  # a seed the run does not have
    json.dump(doc, open(path, "w"))
    assert report.main([run, "--out", str(tmp_path / "rep")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "has seed 7; the run's seeds are 0, 1, 2, 3, 4" in err
    assert not os.path.exists(tmp_path / "rep")


def test_no_file_no_section_and_a_broken_file_is_one_line_exit_2(tmp_path, capsys):
    run = _copy(tmp_path, "walker_swim")
    os.remove(os.path.join(run, gymnasium_check.FILE))
    assert report.main([run, "--out", str(tmp_path / "rep")]) == 0
    assert "## Gymnasium check" not in open(tmp_path / "rep" / "REPORT.md").read()
    assert "gymnasium_check" not in json.load(open(tmp_path / "rep" / "results.json"))
    capsys.readouterr()
    with open(os.path.join(run, gymnasium_check.FILE), "w") as f:
        f.write('{"rows": [{"seed": 0}]}')
    assert report.main([run, "--out", str(tmp_path / "rep2")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and gymnasium_check.FILE in err and "swim_jax.evaluate" in err
    assert not os.path.exists(tmp_path / "rep2")
