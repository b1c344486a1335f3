"""Where the configs are found: the checkout's top-level ``configs/``, the copy a built wheel ships
inside the package (``swim_jax/_configs/``, setup.py's ``build_py``), and a user's own YAML file
(``config=path/to/my.yaml``) whose ``inherit:`` names a file beside it or a shipped config.

The slow test builds the wheel, installs it into a fresh venv that cannot see the checkout, and runs
the commands from another folder (swim_jax.config.locate_config_dir's second branch)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import time

import pytest

from swim_jax import config as cfgmod
from swim_jax.run import study_file

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def write(path, text: str) -> str:
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write(text)
    return str(path)


# ------------------------------------------------------------------------------------------------
# fast: lookup rules
# ------------------------------------------------------------------------------------------------

def test_a_checkout_reads_its_top_level_configs():
    assert cfgmod.CONFIG_DIR == cfgmod.locate_config_dir() == os.path.join(REPO, "configs")
    assert "walker_swim" in cfgmod.available_configs()
    assert "table2" in cfgmod.available_studies()


def test_a_users_file_inherits_a_shipped_config(tmp_path):
    path = write(tmp_path / "mine" / "my.yaml", "inherit: walker_swim\ntotal_steps: 200000\nagent:\n  activation:\n    k: 0.75\n")
    cfg = cfgmod.resolve(path, ["seeds=2"])
    assert (cfg.env.id, cfg.agent.activation.name, cfg.agent.activation.k) == ("Walker2d-v5", "swim", 0.75)
    assert (cfg.total_steps, cfg.seeds, cfg.name) == (200000, 2, "my")
    # a shipped env base, from the user's folder
    base = write(tmp_path / "mine" / "base.yaml", "inherit: _walker\nagent:\n  activation:\n    name: relu\n")
    cfg = cfgmod.resolve(base, [])
    assert (cfg.env.id, cfg.agent.activation.name) == ("Walker2d-v5", "relu")


def test_an_inherit_looks_beside_the_file_first_and_never_at_the_file_itself(tmp_path):
    write(tmp_path / "_walker.yaml", "env:\n  id: Hopper-v5\n")  # beside the file: wins over the shipped _walker
    path = write(tmp_path / "walker_x.yaml", "inherit: _walker\n")
    assert cfgmod.resolve(path, []).env.id == "Hopper-v5"
    # a file named like a shipped config inherits that shipped config, not itself
    same = write(tmp_path / "walker_swim.yaml", "inherit: walker_swim\nseeds: 3\n")
    cfg = cfgmod.resolve(same, [])
    assert (cfg.env.id, cfg.agent.activation.name, cfg.seeds) == ("Walker2d-v5", "swim", 3)
    # a relative path in inherit: relative to the inheriting file's folder, whatever the cwd
    write(tmp_path / "sub" / "child.yaml", "inherit: ../walker_x.yaml\nseeds: 1\n")
    cfg = cfgmod.resolve(str(tmp_path / "sub" / "child.yaml"), [])
    assert (cfg.env.id, cfg.seeds) == ("Hopper-v5", 1)


@pytest.mark.parametrize("text, needle", [
    (None, "config file {path} not found; config= takes a YAML file's path or one of the shipped configs: ant_relu"),
    ("inherit: walker_nope\n", "config {path}: inherit 'walker_nope' found neither in {folder} nor among the shipped"),
    ("inherit: my\n", "config {path}: circular inherit (it inherits itself)"),
    ("inherit: [\n", "invalid YAML"),
])
def test_bad_user_files_are_one_line_naming_the_path(tmp_path, text, needle):
    path = str(tmp_path / "my.yaml")
    if text is not None:
        write(path, text)
    with pytest.raises(cfgmod.ConfigError) as e:
        cfgmod.resolve(path, [])
    msg = str(e.value)
    assert needle.format(path=path, folder=str(tmp_path)) in msg and "\n" not in msg, msg


def test_a_missing_relative_path_names_it_and_its_absolute_form(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(cfgmod.ConfigError, match=f"config file nope/my.yaml not found \\({tmp_path}/nope/my.yaml\\)"):
        cfgmod.resolve("nope/my.yaml", [])


def test_a_study_by_bare_name_is_the_shipped_one(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no configs/studies/ here
    shipped = os.path.join(cfgmod.CONFIG_DIR, "studies", "table2.yaml")
    assert cfgmod.shipped_study("table2") == cfgmod.shipped_study("table2.yaml") == shipped
    assert cfgmod.shipped_study("configs/studies/table2.yaml") is None and cfgmod.shipped_study("nope") is None
    s = study_file.load("table2", str(tmp_path / "out"))
    assert s.path == shipped and s.name == "table2" and len(s.cells) == 12
    with pytest.raises(study_file.StudyError, match="study file nope.yaml not found; or a shipped study by name: .*table2"):
        study_file.load("nope.yaml")


# ------------------------------------------------------------------------------------------------
# slow: a built wheel in a fresh venv
# ------------------------------------------------------------------------------------------------

def _run(argv, cwd, env, timeout=300):
    return subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


@pytest.mark.slow
def test_a_wheel_installed_elsewhere_ships_its_configs(tmp_path):
    t0 = time.perf_counter()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    had_build = os.path.exists(os.path.join(REPO, "build"))
    try:
        p = _run([sys.executable, "-m", "pip", "wheel", ".", "--no-deps", "-w", str(tmp_path / "dist")], REPO, env)
    finally:
        if not had_build:  # setuptools builds in the tree; leave it as it was
            shutil.rmtree(os.path.join(REPO, "build"), ignore_errors=True)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    (wheel,) = [os.path.join(tmp_path / "dist", f) for f in os.listdir(tmp_path / "dist") if f.endswith(".whl")]

    venv = tmp_path / "venv"
    p = _run([sys.executable, "-m", "venv", str(venv)], tmp_path, env)
    assert p.returncode == 0, p.stderr
    python = str(venv / "bin" / "python")
    p = _run([python, "-m", "pip", "install", "--no-deps", "--no-index", wheel], tmp_path, env)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    purelib = _run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], tmp_path, env).stdout.strip()
    # the dependencies from this venv: a plain path line appends the folder to sys.path, after the new
    # venv's own site-packages; the .pth files in that folder (this venv's editable install of the
    # checkout, __editable__.swim_jax-*.pth and its finder) are not run, so the checkout stays unseen
    with open(os.path.join(purelib, "zz_swim_jax_test_deps.pth"), "w") as f:
        f.write(sysconfig.get_paths()["purelib"] + "\n")

    cwd = tmp_path / "elsewhere"
    cwd.mkdir()
    p = _run([python, "-c", "import swim_jax; from swim_jax import config; "
              "print(swim_jax.__file__); print(config.CONFIG_DIR); print(config.available_configs())"], cwd, env)
    assert p.returncode == 0, p.stderr[-2000:]
    where, config_dir, names = p.stdout.strip().splitlines()
    assert where == os.path.join(purelib, "swim_jax", "__init__.py")
    assert config_dir == os.path.join(purelib, "swim_jax", "_configs")
    assert "'walker_swim'" in names and "'_walker'" not in names

    p = _run([python, "-m", "swim_jax.train", "config=walker_swim", "bogus_key=1", f"out_dir={tmp_path}/out"], cwd, env)
    assert p.returncode == 2, p.stdout + p.stderr
    assert p.stderr.strip().splitlines()[-1].startswith("error: unknown key 'bogus_key'; valid keys: env, agent")
    assert not os.path.exists(tmp_path / "out")

    p = _run([python, "-m", "swim_jax.study", "table2", "--out-dir", str(tmp_path / "study"), "--status"], cwd, env)
    assert p.returncode == 0 and "study table2: 0/12 done" in p.stdout, p.stdout + p.stderr

    p = _run([python, "-c", "from swim_jax.analysis import published_curves; print(published_curves.anchor('Hopper-v5', 'sac', 300000).mean)"],
             cwd, env)  # the published curves ship as package data
    assert p.returncode == 0 and p.stdout.strip() == "3387.6597", p.stdout + p.stderr
    print(f"wheel built, installed and run in {time.perf_counter() - t0:.1f} s")
