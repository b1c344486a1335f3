"""One run's lanes over several processes (swim_jax/placement/distributed.py): the launch facts from flags,
environment or SLURM, and real ``jax.distributed`` runs of 2 processes on 127.0.0.1 against one
process holding the same lanes on 2 host devices (the same per-device program): bit for bit."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import jax
import numpy as np
import pytest

from swim_jax.placement import distributed, local_processes
from swim_jax.run import train
from swim_jax.config import ConfigError
from swim_jax.placement.distributed import Launch, launch_from, pop_flags

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TINY = ["config=hopper_relu", "seeds=4", "eval_freq=1000", "learning_starts=1000", "eval_episodes=2",
        "replay_size=4000", "agent.hidden=[16,16]", "agent.batch_size=32", "env.backend=mujoco"]


# ------------------------------------------------------------------------------------------------
# launch facts
# ------------------------------------------------------------------------------------------------

def test_pop_flags_takes_both_spellings_and_leaves_the_rest():
    flags, rest = pop_flags(["config=x", "--coordinator", "h:1", "--num-processes=2", "seeds=4", "--process-id", "1"])
    assert flags == {"--coordinator": "h:1", "--num-processes": "2", "--process-id": "1"}
    assert rest == ["config=x", "seeds=4"]
    with pytest.raises(ConfigError, match="--process-id needs a value"):
        pop_flags(["--process-id"])


def test_launch_from_flags_environment_and_slurm():
    flags = {"--coordinator": "10.0.0.1:4567", "--num-processes": "2", "--process-id": "1"}
    assert launch_from(flags, {}) == Launch(2, 1, "10.0.0.1:4567", "flags")
    env = {"JAX_COORDINATOR_ADDRESS": "h:9", "JAX_NUM_PROCESSES": "3", "JAX_PROCESS_ID": "2"}
    assert launch_from({}, env) == Launch(3, 2, "h:9", "environment")
    slurm = {"SLURM_NTASKS": "4", "SLURM_PROCID": "3", "SLURM_STEP_NODELIST": "node[1-2]", "SLURM_JOB_ID": "7"}
    assert launch_from({}, slurm) == Launch(4, 3, None, "slurm")
    assert launch_from({}, {**slurm, "SLURM_NTASKS": "1"}) == Launch()  # one task: a plain run
    assert launch_from({"--num-processes": "1"}, env) == Launch()  # flags win; 1 = single process
    assert launch_from({}, {}) == Launch() and not Launch().multi


@pytest.mark.parametrize("flags, needle", [
    ({"--num-processes": "2", "--process-id": "0"}, "2 processes need --coordinator too"),
    ({"--coordinator": "h:1", "--num-processes": "2", "--process-id": "2"}, "--process-id must be in 0..1"),
    ({"--coordinator": "h:1", "--num-processes": "two", "--process-id": "0"}, "--num-processes must be an integer >= 1"),
    ({"--coordinator": "h", "--num-processes": "2", "--process-id": "0"}, "--coordinator must be host:port"),
])
def test_bad_launch_flags_one_line(flags, needle):
    with pytest.raises(ConfigError, match=needle):
        launch_from(flags, {})


def test_cli_bad_launch_flag_exit_2_nothing_written(tmp_path, capsys):
    rc = train.main([*TINY, f"out_dir={tmp_path}/out", "--coordinator", "127.0.0.1:1", "--num-processes", "2",
                     "--process-id", "5"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and err.startswith("error: --process-id must be in 0..1")
    assert not os.path.exists(tmp_path / "out")


# ------------------------------------------------------------------------------------------------
# real processes on 127.0.0.1
# ------------------------------------------------------------------------------------------------

def _env(tmp_path) -> dict:
    """The processes share a persistent compilation cache: the session's (tests/conftest.py), so a
    rerun of the suite loads their executables instead of compiling them; else one of their own."""
    shared = jax.config.jax_compilation_cache_dir
    cache = {"JAX_COMPILATION_CACHE_DIR": shared} if shared else {
        "JAX_COMPILATION_CACHE_DIR": str(tmp_path / "jax_cache"), "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS": "0"}
    return dict(os.environ, JAX_PLATFORMS="cpu", PYTHONUNBUFFERED="1", **cache)


def _start(args: list[str], tmp_path, n: int = 2) -> list[subprocess.Popen]:
    """``n`` processes of ``swim_jax.run.train args`` meeting at a free local port; process 0 last."""
    launch = ["--coordinator", f"127.0.0.1:{local_processes.free_port()}", "--num-processes", str(n)]
    return [subprocess.Popen([sys.executable, "-m", "swim_jax.train", *args, *launch, "--process-id", str(i)],
                             cwd=REPO, env=_env(tmp_path), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for i in reversed(range(n))][::-1]


def _run_dir(stdout: str) -> str:
    return next(l.split(": ", 1)[1] for l in stdout.splitlines() if l.startswith("run dir: "))


def _start_reference(tmp_path, total_steps: int) -> subprocess.Popen:
    """One process, the same 4 lanes split over 2 host devices (2 lanes per device, as in each of
    the 2 processes); :func:`_reference_dir` waits for it."""
    return subprocess.Popen([sys.executable, "-m", "swim_jax.train", *TINY, f"total_steps={total_steps}", "host_devices=2",
                             "lane_groups=false", f"out_dir={tmp_path / 'one'}"], cwd=REPO, env=_env(tmp_path), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _reference_dir(p: subprocess.Popen) -> str:
    out, err = p.communicate(timeout=900)
    assert p.returncode == 0, err[-3000:]
    assert "lanes: 4 lanes over 2 cpu devices" in out
    return _run_dir(out)


def _assert_same_run(got: str, want: str) -> None:
    for name in ("evaluations_episodes.npy", "evaluations.npy"):
        np.testing.assert_array_equal(np.load(os.path.join(got, name)), np.load(os.path.join(want, name)), err_msg=name)
    a, b = np.load(os.path.join(got, "final_policy.npz")), np.load(os.path.join(want, "final_policy.npz"))
    assert sorted(a.files) == sorted(b.files)
    for k in b.files:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    with open(os.path.join(got, "metrics.csv")) as f, open(os.path.join(want, "metrics.csv")) as g:
        assert f.read() == g.read()


def test_two_processes_equal_one_process_with_the_same_lanes_bit_for_bit(tmp_path):
    """2 processes × 1 CPU device (2 lanes each) vs 1 process × 2 host devices: identical
    evaluations (every episode), learning metrics and final policies; process 0 alone writes and
    prints; every process compiles its chunk once."""
    ref = _start_reference(tmp_path, 2000)  # alongside: the machine's cores are idle while they compile
    procs = _start([*TINY, "total_steps=2000", f"out_dir={tmp_path / 'two'}"], tmp_path)
    outs = [p.communicate(timeout=900) for p in procs]
    for p, (out, err) in zip(procs, outs):
        assert p.returncode == 0, err[-3000:]
    run_dir = _run_dir(outs[0][0])
    assert "lanes: 4 lanes over 2 cpu devices in 2 processes" in outs[0][0] and "done in" in outs[0][0]
    assert "run dir" not in outs[1][0] and "process 1 of 2 (flags)" in outs[1][0]
    timing = json.load(open(os.path.join(run_dir, "timing.json")))
    assert (timing["processes"], timing["devices"], timing["chunk_compiles"]) == (2, 2, 1)
    assert sorted(os.listdir(os.path.join(run_dir, "checkpoints"))) == ["1000", "2000", "replay"]
    _assert_same_run(run_dir, _reference_dir(ref))


@pytest.mark.slow
def test_a_lost_process_stops_the_other_with_one_line_and_resume_continues(tmp_path):
    """Process 1 SIGKILLed after the step-2000 checkpoint: process 0 stops at its next gather
    with one line (exit 4) naming the checkpoint; both resumed with ``--resume`` finish the run
    identical to an uninterrupted one."""
    procs = _start([*TINY, "total_steps=5000", f"out_dir={tmp_path / 'two'}"], tmp_path)
    run_dir = None
    for line in procs[0].stdout:
        if line.startswith("run dir: "):
            run_dir = line.split(": ", 1)[1].strip()
        if line.startswith("step ") and " 2000/" in line.split("|")[0]:
            procs[1].send_signal(signal.SIGKILL)
            break
    _, err = procs[0].communicate(timeout=600)
    procs[1].wait(timeout=60)
    assert procs[0].returncode == distributed.EXIT_LOST_PROCESS, err[-3000:]
    errors = [l for l in err.splitlines() if l.startswith("error:")]
    assert len(errors) == 1 and "process 0 of 2: lost contact with another process" in errors[0], err[-3000:]
    assert f"--resume {run_dir}" in errors[0]
    assert not os.path.exists(os.path.join(run_dir, "final_policy.npz"))

    ref = _start_reference(tmp_path, 5000)
    procs = _start(["--resume", run_dir], tmp_path)
    outs = [p.communicate(timeout=900) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs[0][1][-3000:]
    assert f"resumed {run_dir} at step" in outs[0][0]
    timing = json.load(open(os.path.join(run_dir, "timing.json")))
    assert timing["chunk_compiles"] == 1 and timing["eval_compiles"] == 1  # restored onto the lanes' devices
    _assert_same_run(run_dir, _reference_dir(ref))


# ------------------------------------------------------------------------------------------------
# local_processes=N: the same, started by one command
# ------------------------------------------------------------------------------------------------

def test_core_shares_partition_the_usable_cores():
    cores = sorted(os.sched_getaffinity(0))
    for n in range(1, len(cores) + 1):
        shares = local_processes.core_shares(n)
        assert len(shares) == n and sum(shares, []) == cores
        assert max(map(len, shares)) - min(map(len, shares)) <= 1


@pytest.mark.parametrize("extra, needle", [
    (["seeds=3", "local_processes=2"], "3 lanes (sweep points × seeds) do not divide over local_processes=2"),
    (["local_processes=4096"], "local_processes=4096 but this machine lets this process use"),
])
def test_local_processes_bad_input_one_line_exit_2_nothing_written(extra, needle, tmp_path, capsys):
    rc = train.main([*TINY, "total_steps=2000", f"out_dir={tmp_path}/out", *extra])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and needle in err, err
    assert not os.path.exists(tmp_path / "out")


@pytest.mark.slow
def test_local_processes_equal_the_same_lanes_on_host_devices(tmp_path):
    """``local_processes=2`` (one command, 2 pinned processes) == 1 process × 2 host devices, bit for bit."""
    ref = _start_reference(tmp_path, 2000)
    r = subprocess.run([sys.executable, "-m", "swim_jax.train", *TINY, "total_steps=2000", "local_processes=2",
                        f"out_dir={tmp_path / 'local'}"], cwd=REPO, env=_env(tmp_path), capture_output=True,
                       text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "lanes: 4 lanes over 2 cpu devices in 2 processes" in r.stdout and r.stdout.count("run dir: ") == 1
    _assert_same_run(_run_dir(r.stdout), _reference_dir(ref))
