"""``python -m swim_jax.compare``: two sets of run folders compared cell by cell (the precision effect
of issue 48: float32 cells against the bfloat16 cells of the same seeds), checked against NumPy and
SciPy by hand on small folders in the format swim_jax.run.train writes."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import yaml
from scipy import stats as sps

from swim_jax.analysis import cell_pairs

RNG = np.random.default_rng(7)
# [n_evals = 5 (steps 0..400), 5 seeds]; B learns clearly less on walker, the same on hopper
WALKER_A = np.cumsum(RNG.uniform(50, 60, (5, 5)), axis=0)
WALKER_B = WALKER_A * 0.5
HOPPER_A = np.cumsum(RNG.uniform(0, 100, (5, 5)), axis=0)
HOPPER_B = HOPPER_A + RNG.normal(0, 30, (5, 5))


def write_cell(root, name, returns, env="Walker2d-v5", act="swim", matmul=None, recorded=None, total_steps=400,
               **extra):
    """A run folder as swim_jax.run.train writes it (config.yaml, evaluations.npy, and the products
    each stretch recorded in provenance.json when ``recorded`` is given)."""
    d = os.path.join(str(root), name)
    os.makedirs(d)
    cfg = {"env": {"id": env}, "agent": {"hidden": [8, 8], "activation": {"name": act, "k": 0.5, "beta": 1.0}},
           "seeds": returns.shape[1], "first_seed": 0, "seed": 0, "total_steps": total_steps, "eval_freq": 100,
           "precision": "float32", "out_dir": str(root), "name": name, **({"matmul_dtype": matmul} if matmul else {}),
           **extra}
    with open(os.path.join(d, "config.yaml"), "w") as f:
        yaml.safe_dump(cfg, f)
    np.save(os.path.join(d, "evaluations.npy"), returns)
    if recorded:
        with open(os.path.join(d, "provenance.json"), "w") as f:
            json.dump([{"step": 0, "matmul_dtype": recorded}], f)
    return d


@pytest.fixture
def sets(tmp_path):
    """A: float32 cells (matmul_dtype: full); B: the old default's folders that ran in bfloat16."""
    a, b = tmp_path / "f32", tmp_path / "bf16"
    write_cell(a, "walker_swim", WALKER_A, matmul="full", recorded="float32")
    write_cell(a, "hopper_swim", HOPPER_A, env="Hopper-v5", matmul="full", recorded="float32")
    write_cell(a, "cheetah_swim", HOPPER_A, env="HalfCheetah-v5", matmul="full")
    write_cell(b, "walker_swim", WALKER_B, matmul="auto", recorded="bfloat16")
    write_cell(b, "hopper_swim", HOPPER_B, env="Hopper-v5", matmul="auto", recorded="bfloat16")
    return str(a), str(b)


def test_each_pair_equals_numpy_and_scipy_and_says_whether_the_products_changed_learning(sets, tmp_path, capsys):
    a, b = sets
    out = tmp_path / "out"
    assert cell_pairs.main([a, b, "--out", str(out), "--n-boot", "2000"]) == 0
    data = json.loads((out / "compare.json").read_text())
    assert sorted(data["cells"]) == ["hopper_swim", "walker_swim"] and data["only_a"] == ["cheetah_swim"]
    for name, (ra, rb) in {"walker_swim": (WALKER_A, WALKER_B), "hopper_swim": (HOPPER_A, HOPPER_B)}.items():
        cell = data["cells"][name]
        assert cell["a"]["numerics"] == "float32" and cell["b"]["numerics"] == "float32, bfloat16 products"
        steps = np.arange(5) * 100.0
        by_hand = {"max": (ra.max(0), rb.max(0)), "final": (ra[-1], rb[-1]),
                   "auc": (np.trapezoid(ra, steps, axis=0) / 400, np.trapezoid(rb, steps, axis=0) / 400)}
        for score, (x, y) in by_hand.items():
            got = cell["scores"][score]
            assert got["diff"] == pytest.approx(x.mean() - y.mean(), rel=1e-12)
            assert got["welch_p"] == pytest.approx(sps.ttest_ind(x, y, equal_var=False).pvalue, rel=1e-6)
            lo, hi = got["diff_ci"]
            assert lo <= got["diff"] <= hi
    assert data["cells"]["walker_swim"]["changed"] == ["max", "final", "auc"]
    assert data["cells"]["walker_swim"]["sentence"].startswith("Yes: with float32, bfloat16 products TD3 learns")
    assert data["cells"]["hopper_swim"]["changed"] == []
    assert data["cells"]["hopper_swim"]["sentence"].startswith("No difference detected with 5 seeds")
    md = (out / "COMPARE.md").read_text()
    assert "**1 of 2 cells changed**: walker_swim." in md and "only in A: cheetah_swim" in md


def test_at_step_reads_both_sets_at_that_budget(sets, tmp_path):
    """--at-step 200: the first three evaluations of every run (Table II at 300k from 1M runs)."""
    a, b = sets
    pairs, _, _ = cell_pairs.compare_sets(a, b, at_step=200, n_boot=200)
    walker = next(p for p in pairs if p.name == "walker_swim")
    assert walker.a.total_steps == 200 and walker.comparisons["final"].diff == pytest.approx(
        WALKER_A[2].mean() - WALKER_B[2].mean())


def test_pairs_that_differ_beyond_the_compared_keys_or_bad_input_are_refused(sets, tmp_path, capsys):
    a, b = sets
    other = tmp_path / "other"
    write_cell(other, "walker_swim", WALKER_B, matmul="bfloat16", agent_tau=1)  # (an extra key: differs)
    rc = cell_pairs.main([a, str(other), "--out", str(tmp_path / "o1")])
    err = capsys.readouterr().err
    assert rc == 2 and "walker_swim:" in err and "differ in agent_tau" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o1").exists()
    longer = tmp_path / "longer"
    write_cell(longer, "walker_swim", np.concatenate([WALKER_B, WALKER_B[-1:]]), matmul="bfloat16", total_steps=500)
    rc = cell_pairs.main([a, str(longer), "--out", str(tmp_path / "o2")])
    assert rc == 2 and "give --at-step N" in capsys.readouterr().err
    assert cell_pairs.main([a, str(longer), "--out", str(tmp_path / "o3"), "--at-step", "400", "--n-boot", "200"]) == 0
    assert cell_pairs.main([a, str(tmp_path / "nothing"), "--out", str(tmp_path / "o4")]) == 2
    assert "not a folder of run folders" in capsys.readouterr().err
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "keep.txt").write_text("x")
    assert cell_pairs.main([a, b, "--out", str(tmp_path / "full")]) == 2
    assert "exists and is not empty" in capsys.readouterr().err and os.listdir(tmp_path / "full") == ["keep.txt"]
    # --force: compare's two files are written beside what is there, which stays (the rule of every --out)
    assert cell_pairs.main([a, b, "--out", str(tmp_path / "full"), "--force", "--n-boot", "200"]) == 0
    assert sorted(os.listdir(tmp_path / "full")) == ["COMPARE.md", "compare.json", "keep.txt"]
    assert (tmp_path / "full" / "keep.txt").read_text() == "x"
    (tmp_path / "dir").mkdir()
    (tmp_path / "dir" / "COMPARE.md").mkdir()  # in the way even with --force: refused, nothing written
    assert cell_pairs.main([a, b, "--out", str(tmp_path / "dir"), "--force", "--n-boot", "200"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "COMPARE.md is a directory" in err[0] and os.listdir(tmp_path / "dir") == ["COMPARE.md"]


def test_force_rewrites_a_comparison_as_cells_finish(sets, tmp_path, capsys):
    """--force: COMPARE.md and compare.json are written over with the new pairs (the comparison
    rerun as a study's cells finish); without it, refused with one line, untouched."""
    a, b = sets
    out = tmp_path / "out"
    assert cell_pairs.main([a, b, "--out", str(out), "--n-boot", "200"]) == 0
    (out / "compare.json").write_text("{}")
    assert cell_pairs.main([a, b, "--out", str(out), "--n-boot", "200"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "use --force to replace COMPARE.md, compare.json there" in err[0]
    assert (out / "compare.json").read_text() == "{}"
    assert cell_pairs.main([a, b, "--out", str(out), "--n-boot", "200", "--force"]) == 0
    assert sorted(json.loads((out / "compare.json").read_text())["cells"]) == ["hopper_swim", "walker_swim"]
    assert sorted(os.listdir(out)) == ["COMPARE.md", "compare.json"]


def test_cells_still_short_of_the_step_are_left_out_and_listed(sets, tmp_path):
    """A study in progress: a cell whose runs have not evaluated at --at-step yet is not compared
    (listed as such); with no cell there at all, one line."""
    a, b = sets
    short = tmp_path / "short"
    write_cell(short, "walker_swim", WALKER_A[:2], matmul="full", recorded="float32")  # at step 100 of 400
    write_cell(short, "hopper_swim", HOPPER_A, env="Hopper-v5", matmul="full", recorded="float32")
    pairs, only_a, _ = cell_pairs.compare_sets(str(short), b, at_step=300, n_boot=200)
    assert [p.name for p in pairs] == ["hopper_swim"] and only_a == ["walker_swim (not at step 300 yet)"]
    alone = tmp_path / "alone"
    write_cell(alone, "walker_swim", WALKER_A[:2], matmul="full", recorded="float32")
    with pytest.raises(cell_pairs.CompareError, match="no cell of both sets has reached step 300"):
        cell_pairs.compare_sets(str(alone), b, at_step=300, n_boot=200)
