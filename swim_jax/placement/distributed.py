"""One run's lanes over several processes (and hosts), with JAX's own runtime, ``jax.distributed``.

Every process runs the same command; they differ only in their process id::

    python -m swim_jax.train config=cheetah_swim seeds=4 --coordinator 10.0.0.1:4567 --num-processes 2 --process-id 0
    python -m swim_jax.train config=cheetah_swim seeds=4 --coordinator 10.0.0.1:4567 --num-processes 2 --process-id 1

The same three facts may come from the environment (``JAX_COORDINATOR_ADDRESS``,
``JAX_NUM_PROCESSES``, ``JAX_PROCESS_ID``), or from SLURM inside ``srun`` with two or more tasks
(``SLURM_NTASKS``/``SLURM_PROCID``; JAX's SLURM support picks the coordinator). Flags win over the
environment, and ``--num-processes 1`` runs a single process whatever the environment says.

After :func:`start`, ``jax.devices()`` lists every process's devices, so the lane mesh of
``swim_jax.placement.sharding`` spans them all: each process steps its own block of lanes (the compiled
program exchanges nothing between lanes), :func:`to_host` gathers per-lane results (CPU
collectives through gloo), process 0 writes the run folder and orbax writes the checkpoints from
every process. The run folder must be on a filesystem every process sees.

A process that dies stops the others: the survivors' next gather fails, and :func:`stop` prints one
line naming the failure and the checkpoint to ``--resume`` from, and ends the process at once (exit
status 4) instead of waiting for the lost process at JAX's shutdown barrier. One exception: when
process 0 dies, the JAX coordination service it hosts goes with it and JAX itself ends the others
within a second ("Terminating process because the JAX distributed service detected fatal errors",
exit status 134); orbax's checkpoints are unaffected either way.
"""

from __future__ import annotations

import os
import re
import sys
import traceback
from dataclasses import dataclass

import jax
import numpy as np
from jax.experimental import multihost_utils

from swim_jax.config import ConfigError

FLAGS = ("--coordinator", "--num-processes", "--process-id")
ENV = {"--coordinator": "JAX_COORDINATOR_ADDRESS", "--num-processes": "JAX_NUM_PROCESSES",
       "--process-id": "JAX_PROCESS_ID"}
EXIT_LOST_PROCESS = 4
# seconds without a heartbeat after which JAX's coordinator declares a process dead and ends every
# process from a C++ thread (a multi-line fatal log). Long, so that a lost process is normally noticed
# first by the survivors' next gather (after every chunk: seconds to minutes), which :func:`stop`
# reports in one line. JAX's default: 100.
HEARTBEAT_S = 600
# seconds a process waits at start-up for all the others to connect (JAX's default); after that
# JAX ends it from C++ ("Terminating process because the JAX distributed service detected fatal errors")
CONNECT_TIMEOUT_S = 300


@dataclass(frozen=True)
class Launch:
    """How this process was started: ``count`` processes, this one ``index``, meeting at
    ``coordinator`` (host:port; None: SLURM's choice); ``source`` says where that came from."""

    count: int = 1
    index: int = 0
    coordinator: str | None = None
    source: str = "single process"

    @property
    def multi(self) -> bool:
        return self.count > 1


def _int(name: str, text: str, lo: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise ConfigError(f"{name} must be an integer >= {lo}, got {text!r}") from None
    if value < lo:
        raise ConfigError(f"{name} must be an integer >= {lo}, got {value}")
    return value


def launch_from(flags: dict[str, str], environ=os.environ) -> Launch:
    """The :class:`Launch` of ``flags`` (``{"--coordinator": "host:port", "--num-processes": "2",
    "--process-id": "0"}``, any subset, strings as typed), else the ``JAX_*`` environment variables,
    else SLURM's; ConfigError (one line) when they are incomplete or inconsistent."""
    given = {f: flags[f] for f in FLAGS if f in flags}
    source = "flags"
    if not given:
        given = {f: environ[v] for f, v in ENV.items() if environ.get(v)}
        source = "environment"
    if not given:
        tasks = environ.get("SLURM_NTASKS")
        if tasks and int(tasks) > 1 and "SLURM_PROCID" in environ and "SLURM_STEP_NODELIST" in environ:
            return Launch(int(tasks), int(environ["SLURM_PROCID"]), None, "slurm")
        return Launch()
    count = _int("--num-processes", given.get("--num-processes", "1"), 1)
    if count == 1:
        return Launch()
    missing = [f for f in FLAGS if f not in given]
    if missing:
        raise ConfigError(f"{count} processes need {' and '.join(missing)} too (or {', '.join(ENV[f] for f in missing)})")
    index = _int("--process-id", given["--process-id"], 0)
    if index >= count:
        raise ConfigError(f"--process-id must be in 0..{count - 1} for {count} processes, got {index}")
    address = given["--coordinator"]
    if not re.fullmatch(r"[^\s:]+:\d+|\[[0-9a-fA-F:]+\]:\d+", address):
        raise ConfigError(f"--coordinator must be host:port (e.g. 10.0.0.1:4567), got {address!r}")
    return Launch(count, index, address, source)


def start(launch: Launch) -> None:
    """Join the other processes (``jax.distributed.initialize``; must run before JAX starts its
    backends). Nothing to do for a single process. Raises RuntimeError with one line when JAX
    raises; a coordinator that stays unreachable for ``CONNECT_TIMEOUT_S`` ends the process in JAX."""
    if not launch.multi:
        return
    try:
        if launch.source == "slurm":
            jax.distributed.initialize(cluster_detection_method="slurm", initialization_timeout=CONNECT_TIMEOUT_S,
                                       heartbeat_timeout_seconds=HEARTBEAT_S)
        else:
            jax.distributed.initialize(launch.coordinator, launch.count, launch.index,
                                       initialization_timeout=CONNECT_TIMEOUT_S,
                                       heartbeat_timeout_seconds=HEARTBEAT_S)
    except Exception as e:  # noqa: BLE001 - JAX raises several types; one line for the user
        raise RuntimeError(f"process {launch.index} of {launch.count} could not join the run at "
                           f"{launch.coordinator or 'the SLURM coordinator'}: {_first_line(e)}") from e


def processes() -> int:
    """How many processes run this program (1 without ``jax.distributed``)."""
    return jax.process_count()


def is_writer() -> bool:
    """Whether this process writes the run folder (process 0)."""
    return jax.process_index() == 0


def to_host(tree):
    """NumPy copies of ``tree``'s arrays with every lane, also those stepped by other processes
    (gathered to every process; a collective: all processes must call it in the same order)."""
    def one(x):
        if isinstance(x, jax.Array) and not x.is_fully_addressable:
            return np.asarray(multihost_utils.process_allgather(x, tiled=True))
        return np.asarray(x)
    return jax.tree.map(one, tree)


def broadcast_text(text: str) -> str:
    """Process 0's ``text`` on every process (a collective; the identity for one process)."""
    if processes() == 1:
        return text
    data = np.zeros(4096, np.uint8)
    raw = text.encode()
    if len(raw) > data.size:
        raise ValueError(f"text of {len(raw)} bytes is too long to broadcast (at most {data.size})")
    data[: len(raw)] = np.frombuffer(raw, np.uint8)
    out = np.asarray(multihost_utils.broadcast_one_to_all(data))
    return bytes(out[out != 0].astype(np.uint8)).decode()


_LOST = re.compile(r"gloo|coordination|heartbeat|barrier|UNAVAILABLE|DEADLINE_EXCEEDED|Connection (reset|refused|closed)",
                   re.IGNORECASE)


def _first_line(e: BaseException) -> str:
    text = str(e).strip().splitlines()
    return (text[0] if text else type(e).__name__)[:300]


def stop(error: BaseException, run_dir: str, last_checkpoint: int | None) -> None:
    """End this process of a multi-process run after ``error``: one line on stderr (with the
    traceback first when the error is this process's own, not a lost peer), then exit status 4
    (lost peer) or 1 at once, without JAX's shutdown barrier, which would wait for the lost process."""
    me = f"process {jax.process_index()} of {jax.process_count()}"
    resume = (f"continue from step {last_checkpoint} with --resume {run_dir} on every process"
              if last_checkpoint is not None else "no checkpoint was completed; start again")
    if _LOST.search(str(error)):
        print(f"error: {me}: lost contact with another process ({_first_line(error)}); stopped; {resume}",
              file=sys.stderr, flush=True)
        code = EXIT_LOST_PROCESS
    else:
        traceback.print_exception(error)
        print(f"error: {me} failed ({type(error).__name__}: {_first_line(error)}); stopping every process; {resume}",
              file=sys.stderr, flush=True)
        code = 1
    sys.stdout.flush()
    os._exit(code)


def pop_flags(argv: list[str]) -> tuple[dict[str, str], list[str]]:
    """(the launch flags of ``argv`` as ``{flag: value}``, the other arguments); a flag's value
    follows it (``--process-id 1``) or an ``=`` (``--process-id=1``). ConfigError on a missing value."""
    flags, rest, it = {}, [], iter(argv)
    for tok in it:
        name, eq, value = tok.partition("=")
        if name not in FLAGS:
            rest.append(tok)
            continue
        if not eq:
            value = next(it, None)
            if value is None or value.startswith("--"):
                raise ConfigError(f"{name} needs a value")
        flags[name] = value
    return flags, rest
