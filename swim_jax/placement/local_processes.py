"""``local_processes=N``: one run as N ``jax.distributed`` processes on this machine.

The command the user typed is started N times with ``--coordinator 127.0.0.1:<free port>
--num-processes N --process-id i`` added (swim_jax/placement/distributed.py does the rest), process i pinned
to the i-th of N equal shares of the cores this process may use, so each process runs its own
lanes' products single-threaded on its own cores. Process 0's output is this command's output; the
others print only errors. The exit status is the first non-zero one among the processes (by
process id), else 0. Why: on a CPU, XLA's small matmuls gain little from a second thread, while
separate processes on separate cores do not contend (docs/PERFORMANCE.md: local-processes-vs-one-process).
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys

from swim_jax.config import Config, ConfigError


def check(cfg: Config, lanes: int) -> None:
    """ConfigError (one line) unless ``lanes`` divide over ``cfg.local_processes`` processes of
    ``max(host_devices, 1)`` devices each and there are at least as many cores as processes."""
    n, per = cfg.local_processes, max(cfg.host_devices, 1)
    cores = len(os.sched_getaffinity(0))
    if n > cores:
        raise ConfigError(f"local_processes={n} but this machine lets this process use {cores} cores; use at most {cores}")
    if lanes % (n * per):
        raise ConfigError(f"{lanes} lanes (sweep points × seeds) do not divide over local_processes={n} × {per} "
                          f"device(s); use a multiple of {n * per} lanes")


def core_shares(n: int) -> list[list[int]]:
    """The usable cores split into ``n`` contiguous, equal-as-possible shares (process i gets share i)."""
    cores = sorted(os.sched_getaffinity(0))
    size, extra = divmod(len(cores), n)
    shares, start = [], 0
    for i in range(n):
        end = start + size + (1 if i < extra else 0)
        shares.append(cores[start:end])
        start = end
    return shares


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on now (the coordinator's)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def spawn(module: str, argv: list[str], n: int) -> int:
    """Run ``python -m module argv`` as ``n`` processes (see the module docstring); their exit status."""
    launch = ["--coordinator", f"127.0.0.1:{free_port()}", "--num-processes", str(n)]
    procs = []
    for i, share in enumerate(core_shares(n)):
        procs.append(subprocess.Popen(
            [sys.executable, "-m", module, *argv, *launch, "--process-id", str(i)],
            stdout=None if i == 0 else subprocess.DEVNULL,
            preexec_fn=lambda share=share: os.sched_setaffinity(0, share)))
    try:
        codes = [p.wait() for p in procs]
    except KeyboardInterrupt:  # the processes got the same Ctrl-C (one process group): let them end
        codes = [p.wait() for p in procs]
    return next((c for c in codes if c != 0), 0)

