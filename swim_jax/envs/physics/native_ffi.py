"""The native backend's physics as XLA FFI calls (C++, swim_jax/envs/physics/native_ffi.cc) instead of Python callbacks.

A ``jax.pure_callback`` step costs a Python round trip inside the training program, even with a
trivial host function (docs/PERFORMANCE.md: native-ffi-vs-callback). The same step as an XLA FFI
custom call runs MuJoCo C directly on XLA's thread.

:func:`library` compiles swim_jax/envs/physics/native_ffi.cc once per (source, jaxlib, mujoco) into
``$XDG_CACHE_HOME/swim-jax/native`` (default ``~/.cache``; libraries not loaded for 30 days are
deleted when a new one is built, :func:`prune_cache`) with the system C++ compiler, against
jaxlib's FFI headers and the MuJoCo library and headers of the installed ``mujoco`` wheel, loads it
and registers its handlers with JAX (CPU only). It returns None, with the reason in
:func:`unavailable_reason`, when no compiler is found or the build fails; the native backend then
keeps its Python callbacks. :func:`model_key` registers a copy of a model in the library under a
hash of its bytes: a compiled program names its model by content, never by an address, so a
program loaded from JAX's compilation cache in another process finds the same model (or fails
with a clear error if that process never built it).
"""

from __future__ import annotations

import ctypes
import functools
import glob
import hashlib
import os
import shutil
import subprocess
import tempfile
import time
from typing import Optional

import jax
import mujoco
import numpy as np

SOURCE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "native_ffi.cc")
STEP_TARGET = "swim_jax_native_step"
RESET_TARGET = "swim_jax_native_reset"
_REASON: list[str] = []
STALE_DAYS = 30  # a library not loaded for this long is deleted when a new one is built (prune_cache)


def cache_dir() -> str:
    """``$XDG_CACHE_HOME/swim-jax/native`` (default ``~/.cache/swim-jax/native``)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "swim-jax", "native")


def prune_cache(keep: str, now: Optional[float] = None) -> list[str]:
    """Delete from :func:`cache_dir` every other ``native_ffi-*.so`` not loaded for ``STALE_DAYS``
    days (:func:`library` refreshes a library's modification time each time it loads it) and every
    temporary ``*.so`` of an interrupted build older than a day; ``keep`` (a path) is never deleted.
    Returns the deleted paths. Libraries of other checkouts or versions in use within the window stay."""
    now = time.time() if now is None else now
    removed = []
    for path in glob.glob(os.path.join(cache_dir(), "*.so")):
        if os.path.abspath(path) == os.path.abspath(keep):
            continue
        limit = STALE_DAYS * 86400 if os.path.basename(path).startswith("native_ffi-") else 86400
        try:
            if now - os.path.getmtime(path) > limit:
                os.unlink(path)
                removed.append(path)
        except OSError:  # deleted by another process meanwhile
            pass
    return removed


def _touch(path: str) -> None:
    """Mark ``path`` as just loaded (for :func:`prune_cache`); a read-only cache is left as it is."""
    try:
        os.utime(path)
    except OSError:
        pass


def _mujoco_library() -> str:
    folder = os.path.dirname(mujoco.__file__)
    found = sorted(glob.glob(os.path.join(folder, "libmujoco.so*")))
    if not found:
        raise FileNotFoundError(f"no libmujoco.so* next to {mujoco.__file__}")
    return found[0]


def _build(target: str) -> None:
    """Compile the handlers into ``target`` (written to a temporary file, then renamed, so
    processes building at once never load a half-written library)."""
    compiler = os.environ.get("CXX") or shutil.which("c++") or shutil.which("g++") or shutil.which("clang++")
    if compiler is None:
        raise RuntimeError("no C++ compiler (c++, g++ or clang++; or set CXX)")
    lib = _mujoco_library()
    folder = os.path.dirname(lib)
    os.makedirs(os.path.dirname(target), exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=".so", dir=os.path.dirname(target))
    os.close(fd)
    cmd = [compiler, "-O2", "-std=c++17", "-shared", "-fPIC", "-w", SOURCE, "-I", jax.ffi.include_dir(),
           "-I", os.path.join(folder, "include"), "-L", folder, f"-l:{os.path.basename(lib)}",
           f"-Wl,-rpath,{folder}", "-o", tmp]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        os.unlink(tmp)
        first = next((line for line in done.stderr.splitlines() if "error" in line), done.stderr.strip()[:200])
        raise RuntimeError(f"{os.path.basename(compiler)} failed: {first}")
    os.replace(tmp, target)


@functools.lru_cache(maxsize=None)
def library() -> Optional[ctypes.CDLL]:
    """The compiled handlers, registered with JAX for the CPU (built on first use), or None (see
    :func:`unavailable_reason`)."""
    with open(SOURCE, "rb") as f:
        tag = hashlib.sha256(f.read() + f"{jax.__version__} {mujoco.__version__}".encode()).hexdigest()[:16]
    path = os.path.join(cache_dir(), f"native_ffi-{tag}.so")
    try:
        if not os.path.exists(path):
            _build(path)
            prune_cache(keep=path)
        else:
            _touch(path)
        lib = ctypes.CDLL(path)
    except (OSError, RuntimeError) as e:
        _REASON.append(str(e).splitlines()[0] if str(e) else type(e).__name__)
        return None
    lib.swim_native_register.argtypes = [ctypes.c_int64, ctypes.c_void_p]
    lib.swim_native_register.restype = ctypes.c_int
    jax.ffi.register_ffi_target(STEP_TARGET, jax.ffi.pycapsule(lib.SwimNativeStep), platform="cpu")
    jax.ffi.register_ffi_target(RESET_TARGET, jax.ffi.pycapsule(lib.SwimNativeReset), platform="cpu")
    return lib


def unavailable_reason() -> str:
    """Why :func:`library` returned None ("" when it did not)."""
    return _REASON[-1] if _REASON else ""


def model_key(model: mujoco.MjModel) -> int:
    """Register a copy of ``model`` in the library and return its key: the first 8 bytes of the
    SHA-256 of the model's binary form, as a signed int64 (an FFI attribute)."""
    buffer = np.empty(mujoco.mj_sizeModel(model), np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    key = int.from_bytes(hashlib.sha256(buffer.tobytes()).digest()[:8], "little", signed=True)
    lib = library()
    if lib is None:
        raise RuntimeError(f"native physics FFI unavailable: {unavailable_reason()}")
    lib.swim_native_register(key, model._address)
    return key
