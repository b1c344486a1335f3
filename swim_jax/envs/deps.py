"""The MuJoCo/MJX/JAX versions this package was tested with, and a quiet import of MJX.

swim_jax/envs/physics/mjx_compat.py and swim_jax/envs/physics/mjx_solver.py replace private functions of MJX (the RK4 integrator,
the constraint solver, a collision function) whose code was read from exactly the versions in
:data:`TESTED`. ``requirements.lock`` pins them (the README's install command uses it); a newer
release may change those internals, so :func:`check_versions` warns, once, naming the tested
versions whenever it finds others. How to move the lock forward: docs/ENVS.md, "Moving the lock".

:func:`import_mjx_quietly` imports ``mujoco.mjx`` with the two "Failed to import warp" lines that
mujoco-mjx prints to stdout when the optional GPU package ``warp`` is absent filtered out.
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
import warnings
from importlib import metadata

# distribution -> version the equivalence tests (tests/test_envs_equivalence*.py) passed with
TESTED = {"mujoco": "4.0.0", "mujoco-mjx": "3.17.0", "jax": "0.10.2", "jaxlib": "0.10.2"}
ENV_SKIP_CHECK = "SWIM_JAX_SKIP_VERSION_CHECK"


def installed_versions() -> dict[str, str | None]:
    """``{distribution: installed version or None}`` for every entry of :data:`TESTED`."""
    out = {}
    for name in TESTED:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def version_mismatch(installed: dict[str, str | None]) -> str | None:
    """One line naming every distribution whose version differs from :data:`TESTED`, or None."""
    diff = [f"{n} {v} (tested {TESTED[n]})" for n, v in installed.items() if v != TESTED[n]]
    if not diff:
        return None
    return ("swim-jax patches MJX internals tested only with "
            + ", ".join(f"{n}=={v}" for n, v in TESTED.items())
            + "; found " + ", ".join(diff)
            + ". Install with `pip install -c requirements.lock -e .` or run the equivalence tests "
            + "(docs/ENVS.md, 'Moving the lock').")


def check_versions() -> str | None:
    """Warn (``UserWarning``) if the installed versions differ from :data:`TESTED`; return the
    message, or None when they match. Set ``SWIM_JAX_SKIP_VERSION_CHECK=1`` to skip."""
    if os.environ.get(ENV_SKIP_CHECK):
        return None
    msg = version_mismatch(installed_versions())
    if msg:
        warnings.warn(msg, stacklevel=3)
    return msg


class _DropWarpLines(io.TextIOBase):
    """A line-buffered stdout filter that drops mujoco-mjx's 'Failed to import (mujoco_)warp'
    lines (``print`` writes a line in several pieces, so whole lines are assembled first)."""

    def __init__(self, target):
        self._target = target
        self._pending = ""

    def write(self, text: str) -> int:
        self._pending += text
        *lines, self._pending = self._pending.split("\n")
        for line in lines:
            if not line.startswith(("Failed to import warp", "Failed to import mujoco_warp")):
                self._target.write(line + "\n")
        return len(text)

    def flush(self) -> None:
        if self._pending:
            self._target.write(self._pending)
            self._pending = ""
        self._target.flush()


def import_mjx_quietly():
    """Import and return ``mujoco.mjx`` without its 'Failed to import warp' stdout lines."""
    if "mujoco.mjx" in sys.modules:
        return sys.modules["mujoco.mjx"]
    quiet = _DropWarpLines(sys.stdout)
    with contextlib.redirect_stdout(quiet):
        from mujoco import mjx  # here, not at the top: the import is what this function quietens
    quiet.flush()
    return mjx
