"""The dependency lock: installed versions equal the tested ones, mismatches are named, and
importing the envs prints nothing (mujoco-mjx's 'Failed to import warp' lines are filtered)."""

import os
import subprocess
import sys

import pytest

from swim_jax.envs import deps

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _locked_versions() -> dict[str, str]:
    out = {}
    with open(os.path.join(REPO, "requirements.lock")) as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if "==" in line:
                name, version = line.split("==", 1)
                out[name.strip().lower().replace("_", "-")] = version.strip()
    return out


def test_lock_pins_the_tested_versions_and_they_are_installed():
    locked = _locked_versions()
    for name, version in deps.TESTED.items():
        assert locked.get(name) == version, (name, locked.get(name), version)
    assert deps.version_mismatch(deps.installed_versions()) is None, deps.installed_versions()


def test_a_mismatch_names_every_differing_package_and_the_tested_versions():
    found = dict(deps.TESTED, **{"mujoco-mjx": "3.18.0", "jax": None})
    msg = deps.version_mismatch(found)
    assert "mujoco-mjx 3.18.0 (tested 3.17.0)" in msg
    assert "jax None (tested 0.10.2)" in msg
    assert "mujoco 4.0.0" not in msg.split("found", 1)[1]  # matching ones are not listed
    assert "requirements.lock" in msg and "\n" not in msg


def test_check_versions_warns_on_a_mismatch(monkeypatch):
    monkeypatch.delenv(deps.ENV_SKIP_CHECK, raising=False)
    monkeypatch.setattr(deps, "installed_versions", lambda: dict(deps.TESTED, mujoco="9.9.9"))
    with pytest.warns(UserWarning, match=r"mujoco 9\.9\.9 \(tested 4\.0\.0\)"):
        assert deps.check_versions() is not None
    monkeypatch.setenv(deps.ENV_SKIP_CHECK, "1")
    assert deps.check_versions() is None


def test_importing_envs_prints_nothing():
    out = subprocess.run([sys.executable, "-c", "import swim_jax.envs"], capture_output=True, text=True,
                         cwd=REPO, check=True)
    assert out.stdout == "", out.stdout
    assert "warp" not in out.stderr and "Warning" not in out.stderr, out.stderr


def test_the_stdout_filter_keeps_other_lines():
    import io

    sink = io.StringIO()
    f = deps._DropWarpLines(sink)
    print("Failed to import warp:", "No module named 'warp'", file=f)
    print("kept", 1, file=f)
    f.write("tail")
    f.flush()
    assert sink.getvalue() == "kept 1\ntail"
