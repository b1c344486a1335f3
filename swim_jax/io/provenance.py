"""Where a run folder came from: ``provenance.json``, one entry per start or resume of the run.

Each entry records what produced that stretch of training, so a result can be traced to its code
and machine even when a run was resumed on another machine or commit::

    {"started_at": "2026-12-03T16:05:00Z", "step": 0 (the step it started or resumed from),
     "command": ["python", "-m", "swim_jax.train", ...], "cwd": ..., "hostname": ...,
     "git": {"commit": "<40 hex>", "dirty": false} (null outside a git checkout),
     "packages": {"jax": "0.10.2", "jaxlib": ..., "mujoco": ..., "mujoco-mjx": ..., "flax": ...,
                  "optax": ..., "orbax-checkpoint": ...},
     "python": "3.11.7", "cpu": "AMD EPYC (family 25, model 1)", "cores": 2,
     "matmul_dtype": "bfloat16"}  (what the stretch's products ran in; written by swim_jax.run.train
                                   since 2026-12-04, absent in older entries)

The file is a JSON list; :func:`record` appends an entry (the entries before it are kept).
"""

from __future__ import annotations

import datetime
import importlib.metadata
import json
import os
import platform
import socket
import subprocess
import sys

from swim_jax.io.bench_results import cpu_model

FILENAME = "provenance.json"
PACKAGES = ("jax", "jaxlib", "mujoco", "mujoco-mjx", "flax", "optax", "orbax-checkpoint")
SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # the checkout holding swim_jax


def git_state(path: str = SOURCE_DIR) -> dict | None:
    """``{"commit": HEAD's hash, "dirty": tracked files differ from HEAD}`` of the git checkout at
    ``path``, or None when it is not one (e.g. an installed wheel) or git is missing."""
    try:
        commit = subprocess.run(["git", "-C", path, "rev-parse", "HEAD"], capture_output=True, text=True,
                                timeout=30)
        if commit.returncode != 0:
            return None
        status = subprocess.run(["git", "-C", path, "status", "--porcelain", "--untracked-files=no"],
                                capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": commit.stdout.strip(), "dirty": bool(status.stdout.strip())}


def package_versions(names: tuple[str, ...] = PACKAGES) -> dict[str, str | None]:
    """Installed version of each distribution in ``names`` (None where it is not installed)."""
    out = {}
    for name in names:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = None
    return out


def entry(step: int, argv: list[str] | None = None) -> dict:
    """The provenance of this process starting (or resuming) a run at ``step`` (see the module
    docstring); ``argv`` default: this process's command line."""
    argv = [os.path.basename(sys.executable), *(sys.argv if argv is None else argv)]
    if argv[1:2] and argv[1].endswith(("__main__.py", ".py")) and "swim_jax" in argv[1]:  # python -m swim_jax.X
        module = os.path.splitext(os.path.relpath(argv[1], SOURCE_DIR))[0].replace(os.sep, ".")
        argv = [argv[0], "-m", module.removesuffix(".__main__"), *argv[2:]]
    return {
        "started_at": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "step": int(step),
        "command": argv,
        "cwd": os.getcwd(),
        "hostname": socket.gethostname(),
        "git": git_state(),
        "packages": package_versions(),
        "python": platform.python_version(),
        "cpu": cpu_model(),
        "cores": len(os.sched_getaffinity(0)),
    }


def read(run_dir: str) -> list[dict]:
    """The entries of ``run_dir``'s provenance.json (empty when there is none)."""
    path = os.path.join(run_dir, FILENAME)
    if not os.path.isfile(path):
        return []
    with open(path) as f:
        data = json.load(f)
    return data if isinstance(data, list) else [data]


def record(run_dir: str, step: int, argv: list[str] | None = None, facts: dict | None = None) -> dict:
    """Append :func:`entry` for ``step``, plus ``facts`` (what the caller resolved for this stretch,
    e.g. ``{"matmul_dtype": "bfloat16"}``), to ``run_dir``'s provenance.json (written whole through a
    temporary file, so a kill leaves the old file or the new one); returns the entry."""
    e = {**entry(step, argv), **(facts or {})}
    entries = read(run_dir) + [e]
    path = os.path.join(run_dir, FILENAME)
    with open(path + ".tmp", "w") as f:
        json.dump(entries, f, indent=1)
        f.write("\n")
    os.replace(path + ".tmp", path)
    return e


# ------------------------------------------------------------------------------------------------
# the products a run multiplied in (config key matmul_dtype)
# ------------------------------------------------------------------------------------------------

MATMUL_DTYPE_LEGACY = "auto"  # offered until 2026-12-06: bfloat16 on CPUs with bfloat16 dot instructions


def recorded_matmul_dtypes(run_dir: str) -> list[str]:
    """The dtype the run's Dense products ran in, per stretch (start or resume) in order:
    provenance.json's ``matmul_dtype`` entries, else timing.json's (folders written before the
    stretches recorded it hold only the last stretch's); empty when neither records it."""
    stretches = [e["matmul_dtype"] for e in read(run_dir) if isinstance(e.get("matmul_dtype"), str)]
    if stretches:
        return stretches
    try:
        with open(os.path.join(run_dir, "timing.json")) as f:
            value = json.load(f).get("matmul_dtype")
    except (OSError, ValueError, AttributeError):
        return []
    return [value] if isinstance(value, str) else []


def config_matmul_dtype(run_dir: str, cfg: dict) -> str:
    """The run folder's ``matmul_dtype`` as the code takes it today, ``"full"`` (products in the
    run's precision) or ``"bfloat16"``. A folder written with ``auto`` (the old default, which meant
    bfloat16 on a CPU with AVX-512 BF16 / AMX and full elsewhere) means what its first stretch
    recorded (:func:`recorded_matmul_dtypes`), so it resumes, reports and exports as it ran; with no
    record (folders from before ``auto`` could mean bfloat16) it means full."""
    choice = cfg.get("matmul_dtype", MATMUL_DTYPE_LEGACY)
    if choice != MATMUL_DTYPE_LEGACY:
        return choice
    stretches = recorded_matmul_dtypes(run_dir)
    return "bfloat16" if stretches and stretches[0] == "bfloat16" else "full"
