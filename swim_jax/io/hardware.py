"""What this machine's CPU is, from the kernel's /proc/cpuinfo."""

from __future__ import annotations

import functools


@functools.cache
def cpuinfo() -> dict[str, str]:
    """The first processor's fields in /proc/cpuinfo (``model name``, ``cpu family``, ``flags``, ...);
    empty where there is no such file."""
    info = {}
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, sep, value = line.partition(":")
                if sep and key.strip() not in info:
                    info[key.strip()] = value.strip()
    except OSError:
        pass
    return info


def cpu_flags() -> frozenset[str]:
    """The first processor's ``flags`` (empty where /proc/cpuinfo has none)."""
    return frozenset(cpuinfo().get("flags", "").split())
