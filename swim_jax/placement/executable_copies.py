"""One compile for every CPU device: an executable compiled for one host device, loaded for another.

JAX compiles a jitted program once per device it is placed on (its caches, the persistent one
included, are keyed on the device assignment), although every host CPU device is the same CPU
running the same machine code. Lane groups run the same program on every device
(swim_jax/placement/lane_groups.py), so a cold start would compile each of them D times.
:func:`copy_to_device` compiles nothing: it serializes the compiled executable
(``jax.experimental.serialize_executable``, what the persistent compilation cache stores) and loads
it back with the other device in its device assignment and its argument shardings
(docs/PERFORMANCE.md: first-progress-line-cold).

Only an executable compiled in this process can be copied: one that JAX's persistent compilation
cache supplied serializes again without its kernels (running the copy fails with "Function ... not
found"). :func:`compile_noting_cache` tells which it was; on a warm cache the other devices'
executables are in the cache too, and compiling them is a cache read.
"""

from __future__ import annotations

import io
import pickle
import threading

import jax
from jax import monitoring
import numpy as np
from jax._src.lib import xla_client as xc
from jax.experimental import serialize_executable


_CACHE_HIT_EVENT = "/jax/compilation_cache/cache_hits"  # recorded by the thread that compiles
_seen = threading.local()


def _note_cache_hit(event: str, **kwargs) -> None:
    if event == _CACHE_HIT_EVENT:
        _seen.hit = True


monitoring.register_event_listener(_note_cache_hit)


def compile_noting_cache(lowered: jax.stages.Lowered) -> tuple[jax.stages.Compiled, bool]:
    """``lowered.compile()`` and whether JAX's persistent compilation cache supplied the executable
    (True: it cannot be copied with :func:`copy_to_device`). Safe to call from several threads."""
    _seen.hit = False
    compiled = lowered.compile()
    return compiled, _seen.hit


class _OnDevice(serialize_executable._JaxPjrtUnpickler):
    """Unpickles a serialized single-device executable with every device replaced by ``device``."""

    def __init__(self, file, device):
        super().__init__(file, device.client, [device])
        self.device = device

    def persistent_load(self, pid):
        if pid[0] == "device":  # the shardings of the arguments and results
            return self.device
        if pid[0] == "exec":  # the executable itself, its one replica on ``device``
            options = xc.CompileOptions()
            options.device_assignment = xc.DeviceAssignment.create(np.array([[self.device.id]]))
            return self.backend.deserialize_executable(pid[1], executable_devices=self.execution_devices,
                                                       compile_options=options)
        return super().persistent_load(pid)


def copy_to_device(compiled: jax.stages.Compiled, device) -> jax.stages.Compiled | None:
    """``compiled`` (a program compiled for one CPU device in this process, e.g.
    ``jax.jit(f).lower(...).compile()``, not read from the persistent cache: see
    :func:`compile_noting_cache`) as an executable for ``device``: the same machine code, so the same results bit for bit, taking
    (and donating) arguments on ``device`` and returning its results there. None when it cannot be
    copied (not a CPU device, or a program JAX cannot serialize, e.g. one with host callbacks such as
    ``jax.pure_callback``): compile it for ``device`` then."""
    if device.platform != "cpu":
        return None
    try:  # what serializing a program JAX cannot serialize raises (a callback: its Python closure)
        payload, in_tree, out_tree = serialize_executable.serialize(compiled)
    except (ValueError, NotImplementedError, TypeError, AttributeError, pickle.PicklingError,
            jax.errors.JaxRuntimeError):
        return None
    unloaded, args_info_flat, no_kwargs = _OnDevice(io.BytesIO(payload), device).load()
    return jax.stages.Compiled(unloaded.load(), [], in_tree.unflatten(args_info_flat), out_tree,
                               no_kwargs=no_kwargs)
