"""What this machine's CPU is and multiplies natively, from the kernel's /proc/cpuinfo."""

from __future__ import annotations

import functools

# instruction sets with bfloat16 dot products (AVX-512 BF16: Zen 4+, Cooper Lake+; AMX: Sapphire Rapids+)
BF16_FLAGS = ("amx_bf16", "avx512_bf16")


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


def native_bf16(flags: frozenset[str] | None = None) -> str | None:
    """The first of :data:`BF16_FLAGS` the CPU has (``flags`` default: :func:`cpu_flags`), or None."""
    flags = cpu_flags() if flags is None else flags
    return next((f for f in BF16_FLAGS if f in flags), None)
