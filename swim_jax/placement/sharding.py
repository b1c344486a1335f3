"""Split the lane axis (seeds × sweep points) of the training state across devices.

Every array of the training state has the lanes as its leading axis and lanes never exchange data,
so the state is placed with ``NamedSharding(Mesh(devices, ("lane",)), P("lane"))`` and each program
runs as :func:`over_lanes`: a ``shard_map`` in which every device steps its own block of lanes with
the one-device program (vmapped over fewer lanes; no collective inside, host callbacks of the
native physics run on the device that owns the lanes). The same code uses

* several host CPU "devices" on one machine: ``XLA_FLAGS=--xla_force_host_platform_device_count=N``
  set before JAX starts (``swim_jax.run.train``'s ``host_devices=N`` does it for you);
* several GPUs of one machine: nothing to set, ``jax.devices()`` lists them;
* several processes or hosts: ``jax.distributed`` (swim_jax/placement/distributed.py) makes ``jax.devices()``
  list every process's devices.

Lanes must divide evenly by the device count; otherwise (one process) everything stays on the first
device and :func:`lane_sharding` says why.
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


def over_lanes(fn, sharding: NamedSharding | None, replicated: tuple[int, ...] = ()):
    """``fn`` run per device on that device's block of lanes (``jax.shard_map``), or ``fn`` itself
    when ``sharding`` is None. Positional arguments in ``replicated`` (scalars such as a step index)
    are passed whole to every device; all others, and every output, carry the lane axis first."""
    if sharding is None:
        return fn

    def per_device(*args):
        specs = tuple(PartitionSpec() if i in replicated else PartitionSpec(AXIS) for i in range(len(args)))
        return jax.shard_map(fn, mesh=sharding.mesh, in_specs=specs, out_specs=PartitionSpec(AXIS),
                             check_vma=False)(*args)

    return per_device
