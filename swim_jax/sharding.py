"""Split the lane axis (seeds × sweep points) of the training state across devices.

Every array of the training state has the lanes as its leading axis and lanes never exchange data
(except the evaluation loop's "all episodes done" test), so the program is partitioned by placing
the state with ``NamedSharding(Mesh(devices, ("lane",)), P("lane"))``: jit then compiles it as one
SPMD program, each device running its own block of lanes. The same code uses

* several host CPU "devices" on one machine: ``XLA_FLAGS=--xla_force_host_platform_device_count=N``
  set before JAX starts (``swim_jax.train``'s ``host_devices=N`` does it for you);
* several GPUs of one machine: nothing to set, ``jax.devices()`` lists them.

Lanes must divide evenly by the device count; otherwise everything stays on the first device and
:func:`lane_sharding` says why. Several *hosts* (``jax.distributed``) are not supported yet: the
training loop reads per-lane results back with ``np.asarray``, which needs every lane addressable
from the one process.
"""

from __future__ import annotations

import os

import jax
from jax.sharding import Mesh, NamedSharding, PartitionSpec

AXIS = "lane"


def set_host_devices(n: int) -> None:
    """Ask XLA for ``n`` host CPU devices (must run before JAX initialises its backends)."""
    flag = f"--xla_force_host_platform_device_count={int(n)}"
    flags = [f for f in os.environ.get("XLA_FLAGS", "").split() if not f.startswith("--xla_force_host_platform_device_count=")]
    os.environ["XLA_FLAGS"] = " ".join([*flags, flag])


def lane_sharding(lanes: int, devices=None) -> tuple[NamedSharding | None, str]:
    """(sharding of a leading lane axis over ``devices`` (default: all), reason) — the sharding is
    None, with the reason in words, when there is one device or ``lanes`` does not divide evenly."""
    devices = list(jax.devices() if devices is None else devices)
    n = len(devices)
    if n == 1:
        return None, "one device"
    if lanes % n:
        return None, f"{lanes} lanes do not divide over {n} devices; running on one"
    mesh = Mesh(devices, (AXIS,))
    return NamedSharding(mesh, PartitionSpec(AXIS)), f"{lanes} lanes over {n} {devices[0].platform} devices"


def place(tree, sharding: NamedSharding | None):
    """Put every array of ``tree`` (leading lane axis) on ``sharding``; unchanged when None."""
    if sharding is None:
        return tree
    return jax.device_put(tree, sharding)
