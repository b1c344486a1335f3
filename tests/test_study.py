"""``python -m swim_jax.study``: study files, the skip / resume / start logic on a tiny study of real
runs (MuJoCo C physics, small nets), --status, --slurm, --report, cell locks and provenance.

One module fixture builds a study folder in the state a user meets after an interruption: cell 0
finished, cell 1 stopped after its first checkpoint (its training raised there), cell 2 never
started. The study command is then run for real (subprocesses pinned to cores) and must skip 0,
resume 1 from its checkpoint and start 2.
"""

from __future__ import annotations

import contextlib
import dataclasses
import filecmp
import json
import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

from swim_jax.io import provenance
from swim_jax.run import study, study_cells, study_file, train

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TINY = {
    "name": "tiny",
    "envs": ["hopper"],
    "activations": ["swim", "relu", "swish"],
    "seeds": 2,
    "total_steps": 2000,
    "overrides": {"env.backend": "mujoco", "eval_freq": 1000, "learning_starts": 500, "eval_episodes": 2,
                  "replay_size": 4000, "agent.hidden": [32, 32], "agent.batch_size": 32,
                  "env.max_episode_steps": 200},
}


def write_study(tmp_path, data: dict, name: str = "tiny.yaml") -> str:
    path = os.path.join(tmp_path, name)
    with open(path, "w") as f:
        yaml.safe_dump(data, f)
    return path


def cli(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "swim_jax.study", *args], cwd=REPO, capture_output=True, text=True,
                          env=env)


class Interrupted(Exception):
    pass


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory):
    """(study file, study): cell 0 done, cell 1 stopped after its step-1000 checkpoint, cell 2 not started."""
    tmp = tmp_path_factory.mktemp("study")
    path = write_study(str(tmp), {**TINY, "out_dir": str(tmp / "out")})
    s = study_file.load(path)
    assert study_cells.run_cell(s.cells[0], log=lambda _: None) == 0

    def stop_after_first_chunk(line: str) -> None:
        if line.startswith("step "):  # logged after the chunk's checkpoint was saved
            raise Interrupted

    c1 = s.cells[1]
    with pytest.raises(Interrupted):
        train.run(c1.cfg, c1.run_dir, log=stop_after_first_chunk)
    return path, s


def test_cells_in_order_with_stable_folders(interrupted):
    path, s = interrupted
    assert [c.name for c in s.cells] == ["hopper_swim", "hopper_relu", "hopper_swish"]
    assert [c.run_dir for c in s.cells] == [os.path.join(s.out_dir, c.name) for c in s.cells]
    assert all(c.cfg.seeds == 2 and c.cfg.total_steps == 2000 and c.cfg.env.backend == "mujoco" for c in s.cells)
    assert [c.cfg.agent.activation.name for c in s.cells] == ["swim", "relu", "swish"]


def test_status_before_resume(interrupted):
    path, s = interrupted
    states = [study_cells.cell_state(c) for c in s.cells]
    assert [(x.state, x.step) for x in states] == [("done", 2000), ("started", 1000), ("left", 0)]
    res = cli(path, "--status")
    assert res.returncode == 0, res.stderr
    rows = {line.split()[0]: line.split() for line in res.stdout.splitlines()[1:4]}
    assert rows["hopper_swim"][1:3] == ["done", "2000/2000"]
    assert rows["hopper_relu"][1:3] == ["started", "1000/2000"]
    assert rows["hopper_swish"][1:3] == ["left", "0/2000"]
    assert "1/3 done, 0 running, 1 started, 1 not started; 3000 steps left" in res.stdout
    assert "ETA 0:" in res.stdout  # the finished cell measured the seconds per step


def test_partial_report_is_marked(interrupted, tmp_path):
    path, s = interrupted
    out = str(tmp_path / "report")
    res = cli(path, "--report", out)
    assert res.returncode == 0, res.stderr
    text = open(os.path.join(out, "REPORT.md")).read()
    assert "**Partial study**: 2 cell(s) not finished" in text and "hopper_relu (started, step 1000)" in text
    cells = json.load(open(os.path.join(out, "study.json")))["cells"]
    assert [c["state"] for c in cells] == ["done", "started", "left"]


def test_slurm_script_runs_a_cell(interrupted, tmp_path):
    path, s = interrupted
    res = cli(path, "--slurm", "--cpus-per-task", "2", "--hours", "3")
    assert res.returncode == 0, res.stderr
    script = res.stdout
    assert "#SBATCH --array=0-2" in script and "#SBATCH --cpus-per-task=2" in script and "#SBATCH --time=3:00:00" in script
    assert "--cell $SLURM_ARRAY_TASK_ID" in script and "0=hopper_swim 1=hopper_relu 2=hopper_swish" in script
    # the array task of the finished cell, as SLURM would run it: the cell is skipped
    sh = tmp_path / "job.sh"
    sh.write_text(script)
    done = subprocess.run(["bash", str(sh)], capture_output=True, text=True,
                          env=dict(os.environ, SLURM_ARRAY_TASK_ID="0"))
    assert done.returncode == 0, done.stderr
    assert "hopper_swim: done; skipped" in done.stdout


def test_a_locked_cell_is_not_run_twice(interrupted):
    path, s = interrupted
    c = s.cells[2]
    with study_cells.cell_lock(c.run_dir) as held:
        assert held and study_cells.is_locked(c.run_dir)
        assert study_cells.cell_state(c).state == "running"
        res = cli(path, "--cell", "hopper_swish")
        assert res.returncode == 0 and "already being trained by another process" in res.stdout
    assert not study_cells.is_locked(c.run_dir)
    assert not os.path.exists(os.path.join(c.run_dir, "config.yaml"))


def test_logged_to_file_appends_each_line_once(tmp_path):
    """A cell trained by hand (stdout a terminal, a pipe, pytest's capture) appends its lines to
    train.log; one whose stdout already is that file (the study's runner) does not write them twice."""
    import io

    path = tmp_path / study_cells.LOG_FILE
    printed = []
    with study_cells.logged_to_file(str(tmp_path), printed.append, stream=io.StringIO()) as log:
        log("by hand")
    assert printed == ["by hand"] and path.read_text() == "by hand\n"
    with open(path, "a") as redirected:  # as run_study's Popen(stdout=...) leaves it
        def to_stdout(line):
            redirected.write(line + "\n")
            redirected.flush()

        with study_cells.logged_to_file(str(tmp_path), to_stdout, stream=redirected) as log:
            log("from the runner")
    assert path.read_text() == "by hand\nfrom the runner\n"


@pytest.fixture(scope="module")
def finished(interrupted):
    """The study command run on the interrupted folder: (study file, study, its output)."""
    path, s = interrupted
    before = {n: open(os.path.join(s.cells[0].run_dir, n), "rb").read()
              for n in ("evaluations.csv", "final_policy.npz", "timing.json", "provenance.json")}
    # cell 1's first stretch as if another CPU had run it: the other products than this one's
    prov1 = os.path.join(s.cells[1].run_dir, provenance.FILENAME)
    entries = json.load(open(prov1))
    here = json.load(open(os.path.join(s.cells[0].run_dir, "timing.json")))["matmul_dtype"]
    assert [e["matmul_dtype"] for e in entries] == [here]  # each stretch records its products
    entries[-1]["matmul_dtype"] = "float32" if here == "bfloat16" else "bfloat16"
    json.dump(entries, open(prov1, "w"))
    res = cli(path, "--parallel", "2")
    return path, s, res, before


def test_study_skips_resumes_and_starts(finished):
    path, s, res, before = finished
    assert res.returncode == 0, res.stdout + res.stderr
    out = res.stdout
    assert "hopper_swim: done; skipped" in out
    assert "hopper_relu: started (cores 0" in out and "hopper_swish: started (cores 1" in out
    assert "study tiny: 3/3 cells done" in out
    # the finished cell was not touched
    for n, data in before.items():
        assert open(os.path.join(s.cells[0].run_dir, n), "rb").read() == data, n
    # cell 1 resumed from its checkpoint; cell 2 started at step 0
    log1 = open(os.path.join(s.cells[1].run_dir, study_cells.LOG_FILE)).read()
    assert "hopper_relu: resuming" in log1 and f"resumed {s.cells[1].run_dir} at step 1000" in log1
    assert [e["step"] for e in provenance.read(s.cells[1].run_dir)] == [0, 1000]
    # the resumed stretch multiplies in this CPU's products and says that they changed
    first, second = (e["matmul_dtype"] for e in provenance.read(s.cells[1].run_dir))
    assert second == json.load(open(os.path.join(s.cells[1].run_dir, "timing.json")))["matmul_dtype"] != first
    assert f"warning: this stretch multiplies in {second}, the run's last one in {first}" in log1
    log2 = open(os.path.join(s.cells[2].run_dir, study_cells.LOG_FILE)).read()
    assert "hopper_swish: starting" in log2
    # the runner redirects a cell's output into its train.log: each line is there once, not twice
    assert log2.count("hopper_swish: starting") == 1 and log2.count("step     1000/2000") == 1
    # cell 0 was trained by hand (run_cell in this process, as --cell does): its lines went to its train.log
    log0 = open(os.path.join(s.cells[0].run_dir, study_cells.LOG_FILE)).read()
    assert log0.count("hopper_swim: starting") == 1 and log0.count("step     2000/2000") == 1
    assert "hopper_swim: done in" in log0
    assert [e["step"] for e in provenance.read(s.cells[2].run_dir)] == [0]
    for c in s.cells:
        ev = np.load(os.path.join(c.run_dir, "evaluations.npy"))
        assert ev.shape == (3, 2) and np.isfinite(ev).all()
        assert study_cells.cell_state(c).state == "done"
    # and again: nothing left to do
    again = cli(path)
    assert again.returncode == 0 and again.stdout.count("done; skipped") == 3


def test_full_report(finished, tmp_path):
    path, s, _, _ = finished
    out = str(tmp_path / "report")
    # cell 1's stretches multiplied in different dtypes (the finished fixture): no comparison unless asked
    refused = cli(path, "--report", out)
    assert refused.returncode == 2 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr
    assert "runs differ in precision or matmul_dtype" in refused.stderr and "hopper_relu" in refused.stderr
    assert "--mixed-precision" in refused.stderr and not os.path.exists(out)
    res = cli(path, "--report", out, "--mixed-precision")
    assert res.returncode == 0, res.stderr
    text = open(os.path.join(out, "REPORT.md")).read()
    assert "## The study" in text and "Partial study" not in text and "pools the **3 finished**" in text
    assert "Table II" in text and os.path.isfile(os.path.join(out, "figure4.png"))
    assert "--cell hopper_swish" in text
    # compared on request: cell 1's row names both dtypes, the env's Table II rows and verdict are marked
    first, second = (e["matmul_dtype"] for e in provenance.read(s.cells[1].run_dir))
    assert f"| {first}→{second} |" in next(line for line in text.splitlines() if line.startswith("| hopper_relu |"))
    assert "### Hopper-v5 ‡ (runs differ in precision or matmul_dtype" in text
    assert "- **Hopper-v5 ‡ (runs differ" in text and "--mixed-precision" in text


def test_a_raised_budget_reopens_done_cells_and_a_lowered_one_is_refused(finished, tmp_path):
    """A study file whose total_steps was raised keeps its cells (they are resumed to the new budget
    by train.run, tests/test_train.py: the grown budget equals a run started with it); one whose
    total_steps was lowered is refused with one line naming the cell."""
    path, s, _, _ = finished
    raised = study_file.load(write_study(str(tmp_path), {**TINY, "out_dir": s.out_dir, "total_steps": 3000}))
    assert all(study_cells.cell_state(c).state == "started" and c.cfg.total_steps == 3000 for c in raised.cells)
    with pytest.raises(study_file.StudyError, match="started with total_steps=2000, the study now gives "
                                               "total_steps=1000; a budget can only grow"):
        study_file.load(write_study(str(tmp_path), {**TINY, "out_dir": s.out_dir, "total_steps": 1000}, "low.yaml"))


def test_provenance_of_a_cell(finished):
    path, s, _, _ = finished
    e = provenance.read(s.cells[2].run_dir)[0]
    head = subprocess.run(["git", "-C", REPO, "rev-parse", "HEAD"], capture_output=True, text=True)
    if head.returncode == 0:
        assert e["git"]["commit"] == head.stdout.strip() and isinstance(e["git"]["dirty"], bool)
    import jax
    import mujoco

    assert e["packages"]["jax"] == jax.__version__ and e["packages"]["mujoco"] == mujoco.__version__
    assert set(provenance.PACKAGES) <= set(e["packages"])
    assert e["command"][1:3] == ["-m", "swim_jax.study"] and e["command"][-2:] == ["--cell", "hopper_swish"]
    assert e["cpu"] and e["cores"] >= 1 and e["step"] == 0


# ------------------------------------------------------------------------------------------------
# bad input: one line, exit 2, nothing started or written
# ------------------------------------------------------------------------------------------------

BAD = [
    ({"envs": ["hopper"], "activations": ["swim"], "colour": 1}, "unknown key 'colour'; valid keys: name, out_dir"),
    ({"envs": ["hopper"]}, "activations must be a non-empty list"),
    ({"envs": ["hoppr"], "activations": ["swim"]}, "no config 'hoppr_swim'"),
    ({"seeds": 2}, "name the cells' configs"),
    ({"configs": ["hopper_swim"], "overrides": {"seeds": 3}}, "overrides.seeds is set by the study itself"),
    ({"configs": ["hopper_swim"], "overrides": {"agent.tau": "x"}}, "cell hopper_swim: agent.tau: expected float"),
    ({"configs": ["hopper_swim"], "total_steps": 1234}, "must be a multiple of eval_freq"),
    ({"configs": ["hopper_swim"], "grid": {"agent.tau": [0.005, 0.01]}}, "cannot be pooled"),
    ({"configs": ["hopper_swim"], "grid": {"agent.tau": []}}, "grid.agent.tau must be a non-empty list"),
]


@pytest.mark.parametrize("data,message", BAD, ids=[m.split()[0] for _, m in BAD])
def test_bad_study_file(tmp_path, capsys, data, message):
    path = write_study(str(tmp_path), {**data, "out_dir": str(tmp_path / "out")})
    assert study.main([path]) == 2
    err = capsys.readouterr().err
    assert err.startswith("study: error: ") and message in err and err.count("\n") == 1
    assert not os.path.exists(tmp_path / "out")


def test_bad_options(tmp_path, capsys):
    path = write_study(str(tmp_path), {"configs": ["hopper_swim"], "out_dir": str(tmp_path / "out")})
    for argv, message in [([str(tmp_path / "none.yaml")], "not found"),
                          ([path, "--parallel", "0"], "--parallel 0: must be between 1 and"),
                          ([path, "--cell", "hopper_relu"], "no such cell; valid: hopper_swim"),
                          ([path, "--cell", "5"], "the study has 1 cells (0..0)"),
                          ([path, "--bench", "x.json"], "--bench goes with --report DIR or --curate DIR"),
                          ([path, "--report", str(tmp_path / "r")], "no finished cell"),
                          ([path, "--curate", str(tmp_path / "r")], "no finished cell")]:
        assert study.main(argv) == 2, argv
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, (argv, err)
    assert not os.path.exists(tmp_path / "out") and not os.path.exists(tmp_path / "r")
    with open(path, "w") as f:
        f.write("envs: [hopper\n")
    assert study.main([path]) == 2 and "invalid YAML" in capsys.readouterr().err


def test_a_changed_study_is_refused(interrupted, tmp_path, capsys):
    path, s = interrupted
    changed = yaml.safe_load(open(path))
    changed["overrides"]["agent.batch_size"] = 64  # (a raised total_steps is not a change: the budget grows)
    other = write_study(str(tmp_path), changed, "changed.yaml")
    before = sorted(os.listdir(s.out_dir))
    assert study.main([other, "--status"]) == 2
    err = capsys.readouterr().err
    assert "cell hopper_swim:" in err and "was started with agent.batch_size=32, the study now gives agent.batch_size=64" in err
    assert sorted(os.listdir(s.out_dir)) == before


def test_a_study_on_the_auto_backend_keeps_each_cells_recorded_physics(interrupted, tmp_path, capsys):
    """A study that leaves env.backend at its default (auto) meets the tiny study's folders, whose
    config.yaml records env.backend=mujoco: not a changed study; a resumed cell keeps MuJoCo C;
    a folder recorded with MJX keeps MJX; another recorded key still refuses."""
    path, s = interrupted
    auto = yaml.safe_load(open(path))
    del auto["overrides"]["env.backend"]
    other = study_file.load(write_study(str(tmp_path), auto, "auto.yaml"))
    assert all(c.cfg.env.backend == "auto" for c in other.cells)
    assert study.main([os.path.join(str(tmp_path), "auto.yaml"), "--status"]) == 0
    assert study_cells.recorded_backend(other.cells[1]).env.backend == "mujoco"
    folder = tmp_path / "mjx_cell"
    folder.mkdir()
    cell = other.cells[0]
    with open(os.path.join(cell.run_dir, "config.yaml")) as f:
        text = f.read()
    assert "backend: mujoco" in text and "\nseeds: 2\n" in text
    moved = dataclasses.replace(cell, run_dir=str(folder))
    (folder / "config.yaml").write_text(text.replace("backend: mujoco", "backend: mjx"))
    study_file._check_existing(moved)  # auto accepts what auto chose where the cell started
    assert study_cells.recorded_backend(moved).env.backend == "mjx"
    (folder / "config.yaml").write_text(text.replace("backend: mujoco", "backend: mjx").replace("\nseeds: 2\n", "\nseeds: 3\n"))
    with pytest.raises(study_file.StudyError, match="was started with seeds=3"):
        study_file._check_existing(moved)


def test_curate_copies_finished_cells_without_checkpoints_and_reports_them(interrupted, tmp_path, capsys):
    """--curate DIR: every finished cell copied once (no checkpoints, no lock; evaluations, metrics,
    final policies, config, timing, provenance kept), the report over the copies in DIR/report;
    run again, the copies are left as they are and the report is rewritten."""
    path, s = interrupted
    done = [c for c in s.cells if study_cells.cell_state(c).state == "done"]
    assert done  # cell 0 at least
    out = tmp_path / "curated"
    # (--mixed-precision: after the finished fixture, cell 1's stretches multiplied in both dtypes)
    assert study.main([path, "--curate", str(out), "--mixed-precision"]) == 0
    for c in done:
        names = set(os.listdir(out / c.name))
        assert {"config.yaml", "evaluations.csv", "metrics.csv", "final_policy.npz", "timing.json",
                "provenance.json"} <= names  # (and train.log for cells the study command ran)
        assert "checkpoints" not in names and study_cells.LOCK_FILE not in names
        np.testing.assert_array_equal(np.load(out / c.name / "evaluations.npy"),
                                      np.load(os.path.join(c.run_dir, "evaluations.npy")))
    report_md = (out / "report" / "REPORT.md").read_text()
    assert all(c.name in report_md for c in done)
    # the commands train into the study's own folder (the copies have no checkpoints), and the
    # report names the --curate command that wrote it
    assert f"--out-dir {s.out_dir} --cell {done[0].name}" in report_md and f"--out-dir {out} --cell" not in report_md
    assert f"--curate {out}" in report_md.splitlines()[2]
    products = json.load(open(os.path.join(done[0].run_dir, "timing.json")))["matmul_dtype"]
    row = next(line for line in report_md.splitlines() if line.startswith(f"| {done[0].name} | done |"))
    assert f"| {products} |" in row and products in ("float32", "bfloat16")
    # curated inside the working directory (as in the repository): inputs and the study file by
    # paths relative to it, not by this machine's absolute ones
    with contextlib.chdir(tmp_path):
        assert study.main([path, "--curate", "curated", "--mixed-precision"]) == 0
    inside = (out / "report" / "REPORT.md").read_text()
    assert f": `{os.path.join('curated', done[0].name)}`" in inside and str(out) not in inside
    assert f"`{os.path.relpath(path, tmp_path)}`" in inside or f"`{path}`" in inside
    stamp = os.path.getmtime(out / done[0].name / "evaluations.csv")
    capsys.readouterr()
    assert study.main([path, "--curate", str(out), "--mixed-precision"]) == 0
    assert f"{done[0].name}: already in" in capsys.readouterr().out
    assert os.path.getmtime(out / done[0].name / "evaluations.csv") == stamp


def test_adopt_brings_curated_cells_back_as_done_on_a_new_machine(finished, tmp_path, capsys):
    """--adopt DIR (the way back from --curate DIR, e.g. on a new machine whose study folder is gone):
    every cell DIR holds finished at the study's budget is copied into the study's folder and counts
    as done (the study skips it), also where a copy cut short left a `.partial` folder; run again, it
    is left as it is. A raised budget adopts nothing (a curated cell has no checkpoints to grow from),
    each cell said in a line; a copy of another config, or a folder without the study's cells: one
    line, exit 2, nothing copied."""
    path, s, _, _ = finished
    curated = tmp_path / "curated"
    assert study.main([path, "--curate", str(curated), "--mixed-precision"]) == 0
    new = tmp_path / "new-machine"
    cut_short = new / f"{s.cells[0].name}.partial"  # what a copy stopped midway leaves: not a cell, not a block
    os.makedirs(cut_short)
    (cut_short / "evaluations.csv").write_text("step,mean\n")
    capsys.readouterr()
    assert study.main([path, "--out-dir", str(new), "--adopt", str(curated)]) == 0
    out = capsys.readouterr().out
    moved = study_file.load(path, str(new))
    for c, old in zip(moved.cells, s.cells):
        assert f"{c.name}: adopted from {curated / c.name}" in out
        assert study_cells.cell_state(c).state == "done"
        np.testing.assert_array_equal(np.load(os.path.join(c.run_dir, "evaluations.npy")),
                                      np.load(os.path.join(old.run_dir, "evaluations.npy")))
        assert not os.path.exists(c.run_dir + ".partial") and "checkpoints" not in os.listdir(c.run_dir)
        assert filecmp.cmp(os.path.join(c.run_dir, "evaluations.csv"), curated / c.name / "evaluations.csv", shallow=False)
    stamp = os.path.getmtime(os.path.join(moved.cells[0].run_dir, "evaluations.csv"))
    assert study.main([path, "--out-dir", str(new), "--adopt", str(curated)]) == 0
    assert capsys.readouterr().out.count("already in") == 3
    assert os.path.getmtime(os.path.join(moved.cells[0].run_dir, "evaluations.csv")) == stamp
    # a raised budget: nothing to adopt, every cell named with the step its copy stopped at
    raised = write_study(str(tmp_path), {**TINY, "out_dir": str(tmp_path / "raised"), "total_steps": 3000}, "raised.yaml")
    assert study.main([raised, "--adopt", str(curated)]) == 0
    out = capsys.readouterr().out
    assert out.count("stopped at step 2000 of 3000 and has no checkpoints to grow from; not adopted") == 3
    assert not os.path.exists(tmp_path / "raised")
    # another config, or no cell of the study: one line, exit 2, nothing copied
    other = write_study(str(tmp_path), {**TINY, "out_dir": str(tmp_path / "other"), "seeds": 3}, "other.yaml")
    for args, message in [([other, "--adopt", str(curated)], "was run with seeds=2, cell hopper_swim of study tiny gives seeds=3"),
                          ([path, "--out-dir", str(tmp_path / "x"), "--adopt", str(tmp_path / "nothing")],
                           "holds none of study tiny's cells (hopper_swim, hopper_relu, hopper_swish)")]:
        assert study.main(args) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and message in err, err
    assert not os.path.exists(tmp_path / "other") and not os.path.exists(tmp_path / "x")


def test_a_curated_report_shows_uncopied_cells_as_they_stand_where_the_study_trains(interrupted, tmp_path):
    """--curate: a cell not finished (so not copied) is listed with its state and step in the
    study's own out_dir ("started", its checkpoint's step), not as "left" from the copies' folder."""
    import shutil

    path, s = interrupted
    trained = tmp_path / "trained"
    shutil.copytree(s.out_dir, trained, ignore=shutil.ignore_patterns(study_cells.LOCK_FILE))
    last = s.cells[1].name  # started (interrupted) or done (after the study ran): "started" once unfinished
    if (trained / last / "final_policy.npz").exists():
        os.remove(trained / last / "final_policy.npz")
    data = yaml.safe_load(open(path))
    copy = study_file.load(write_study(str(tmp_path), {**data, "out_dir": str(trained)}, "copy.yaml"))
    st = study_cells.cell_state(copy.cell(last))
    assert st.state == "started" and st.step > 0  # its checkpoints are there
    assert study.main([copy.path, "--curate", str(tmp_path / "curated")]) == 0
    report_md = (tmp_path / "curated" / "report" / "REPORT.md").read_text()
    assert not (tmp_path / "curated" / last).exists()
    assert f"| {last} | started | {st.step} |" in report_md
    assert f"(their state in {trained}): " in report_md and f"{last} (started, step {st.step})" in report_md



@pytest.mark.parametrize("path", sorted(os.listdir(os.path.join(REPO, "configs", "studies"))))
def test_every_shipped_study_file_loads_and_its_cells_validate(path, tmp_path):
    """Each configs/studies/*.yaml is a valid study: every cell's config resolves and validates
    (study_file.load), the cells do not pool, and its float32 study files multiply in float32."""
    s = study_file.load(os.path.join(REPO, "configs", "studies", path), out_dir=str(tmp_path))
    assert s.cells and all(c.run_dir.startswith(str(tmp_path)) for c in s.cells)
    if path.startswith("f32-"):
        assert {c.cfg.matmul_dtype for c in s.cells} == {"full"}
