"""The Python API (swim_jax/run/api.py): README's snippet runs as written (its training budget cut to
a tiny one), the run it returns is the run folder read back, and ``results`` equals the folder's
evaluations; a report's results.csv holds the same rows."""

from __future__ import annotations

import csv
import os
import re

import numpy as np
import pytest

import swim_jax
from swim_jax.analysis import report
from swim_jax.config import ConfigError
from swim_jax.run import api

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TINY = {"total_steps": 2000, "eval_freq": 1000, "learning_starts": 500, "eval_episodes": 2, "replay_size": 4000,
        "agent.hidden": [32, 32], "agent.batch_size": 32, "env.max_episode_steps": 200}


def readme_snippet() -> str:
    text = open(os.path.join(REPO, "README.md")).read()
    section = text.split("### Python API", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


@pytest.fixture(scope="module")
def snippet(tmp_path_factory):
    """README's snippet run as written, with swim_jax.train's budget replaced by a tiny one."""
    out = tmp_path_factory.mktemp("api")
    real = api.train_run
    calls = []

    def tiny_train(config, overrides=None, **keys):
        calls.append((config, dict(overrides or {}), dict(keys)))
        return real(config, {**(overrides or {}), **TINY}, **{**keys, "total_steps": TINY["total_steps"],
                                                             "out_dir": str(out)}, log=lambda s: None)

    mp = pytest.MonkeyPatch()
    mp.setattr(api, "train_run", tiny_train)  # (swim_jax.train is the command module; the API says train_run)
    namespace: dict = {}
    try:
        exec(compile(readme_snippet(), "README.md", "exec"), namespace)
    finally:
        mp.undo()
    return namespace, calls, out


def test_readme_snippet_trains_reads_back_and_gives_tidy_rows(snippet):
    ns, calls, out = snippet
    assert calls == [("hopper_swim", {"agent.activation.k": 0.75}, {"seeds": 2, "total_steps": 50_000})]
    run = ns["run"]
    assert os.path.dirname(run.path) == str(out) and run.activation == "swim(k=0.75)"
    np.testing.assert_array_equal(run.returns, np.load(os.path.join(run.path, "evaluations.npy")))
    assert list(run.steps) == [0, 1000, 2000] and run.returns.shape == (3, 2)
    rows = ns["rows"]
    assert len(rows) == 3 * 2
    assert {(r["seed"], r["step"]): r["return"] for r in rows} == {
        (s, 1000 * i): run.returns[i, s] for s in (0, 1) for i in range(3)}
    assert {(r["env"], r["env_version"], r["algorithm"], r["activation"], r["activation_params"], r["precision"])
            for r in rows} == {("Hopper", "v5", "td3", "swim", "k=0.75", "float32")}
    assert ns["best"]["return"] == run.returns.max()


def test_results_csv_of_a_report_holds_the_same_rows(snippet, tmp_path):
    ns, _, _ = snippet
    assert report.main([ns["run"].path, "--out", str(tmp_path / "rep"), "--n-boot", "200"]) == 0
    with open(tmp_path / "rep" / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(int(r["seed"]), int(r["step"]), float(r["return"])) for r in rows] == [
        (r["seed"], r["step"], r["return"]) for r in ns["rows"]]
    assert list(rows[0]) == ["env", "env_version", "algorithm", "activation", "activation_params", "label",
                             "precision", "seed", "step", "return"]


def test_api_errors_are_one_line_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="unknown key 'nope'"):
        swim_jax.resolve("hopper_swim", nope=1)
    with pytest.raises(ConfigError, match="valid: full, bfloat16"):
        swim_jax.resolve("hopper_swim", matmul_dtype="float16")
    assert swim_jax.resolve("hopper_swim", {"agent.activation.k": 2}, seeds=3).agent.activation.k == 2.0
    with pytest.raises(AttributeError):
        swim_jax.nothing_here


def test_the_command_modules_and_the_api_do_not_shadow_each_other():
    """``from swim_jax import train`` is the command module (python -m swim_jax.train), whether or not
    it was imported before; the API's function is ``swim_jax.train_run``."""
    from swim_jax import train as door

    assert hasattr(door, "main") and door.__name__ == "swim_jax.train"
    assert swim_jax.train_run is api.train_run and swim_jax.load_runs is api.load_runs


def test_a_run_folder_is_continued_only_with_its_own_config(snippet):
    """train_run on an existing run folder with another config: one line naming the first key that
    differs, before anything is trained or written (the budget alone may grow)."""
    ns, _, out = snippet
    run = ns["run"]
    before = {f: os.path.getmtime(os.path.join(run.path, f)) for f in ("config.yaml", "evaluations.npy")}
    with pytest.raises(ConfigError, match=r"was started with agent\.activation\.k=0\.75, not 0\.5: a run continues"):
        api.train_run("hopper_swim", {**TINY, "agent.activation.k": 0.5}, seeds=2, out_dir=str(out), run_dir=run.path,
                      log=lambda s: None)
    assert before == {f: os.path.getmtime(os.path.join(run.path, f)) for f in before}
