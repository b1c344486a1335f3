"""The run's sign of life (swim_jax/run/heartbeat.py) and its ETA by phase (swim_jax/run/progress.py)."""

from __future__ import annotations

import time

from swim_jax import config as cfgmod
from swim_jax.run import progress
from swim_jax.run.heartbeat import Heartbeat


class FakeClock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def test_heartbeat_speaks_only_after_the_silence_and_names_the_activity():
    clock, out = FakeClock(), []
    beat = Heartbeat(out.append, every_s=30.0, clock=clock)
    assert not beat.beat()  # nothing done yet
    beat("compiling the training program")
    clock.t += 29.9
    assert not beat.beat() and out == ["compiling the training program"]
    clock.t += 0.2
    assert beat.beat()
    assert out[-1] == "compiling the training program ... still running (0:00:30)"
    clock.t += 10
    assert not beat.beat()  # its own line counts: the next one 30 s after it
    clock.t += 20
    assert beat.beat() and out[-1].endswith("(0:01:00)")
    beat.doing("training steps 0-1000 of 4000")  # names the activity, prints nothing
    assert len(out) == 3
    clock.t += 30
    assert beat.beat() and out[-1] == "training steps 0-1000 of 4000 ... still running (0:00:30)"
    other = []
    beat.say("step 1000/4000 | ...", out=other.append)  # a progress line printed elsewhere counts too
    clock.t += 29
    assert other == ["step 1000/4000 | ..."] and not beat.beat()


def test_heartbeat_thread_prints_while_the_caller_blocks():
    out = []
    with Heartbeat(out.append, every_s=0.1) as beat:
        beat("compiling")
        time.sleep(0.6)  # stands for a compile: the caller's thread does nothing
    n = len(out)
    assert n >= 3 and all(line.startswith("compiling ... still running") for line in out[1:])
    time.sleep(0.3)
    assert len(out) == n  # stopped with the context
    off = []
    with Heartbeat(off.append, every_s=0.0) as beat:  # 0: no thread
        beat("x")
        time.sleep(0.2)
    assert off == ["x"]


def test_chunks_left_split_the_warmup_from_the_learning_phase():
    cfg = cfgmod.resolve("walker_swim", ["total_steps=300000"])  # eval_freq 5000, learning_starts 25000
    assert progress.chunks_left(cfg, 0) == (5, 55)
    assert progress.chunks_left(cfg, 3) == (2, 55)
    assert progress.chunks_left(cfg, 5) == (0, 55)
    assert progress.chunks_left(cfg, 60) == (0, 0)
    odd = cfgmod.resolve("walker_swim", ["total_steps=20000", "learning_starts=7000"])  # chunk 2 is mixed
    assert progress.chunks_left(odd, 0) == (1, 3)
    none = cfgmod.resolve("walker_swim", ["total_steps=20000", "learning_starts=0"])
    assert progress.chunks_left(none, 1) == (0, 3)


def test_eta_times_each_phase_by_its_own_iterations():
    clock = progress.Clock(0.0)
    clock.iteration_done(40.0, learning=False, first=True)  # with the compilation
    eta = clock.eta(4, 55)
    assert not eta.known and eta.seconds == 59 * 40.0 and str(eta).startswith(">0:39:20 (learning phase not timed")
    for w in (6.0, 7.0, 8.0, 9.0):
        clock.iteration_done(w, learning=False)
    eta = clock.eta(0, 55)
    assert not eta.known and eta.seconds == 55 * 8.0  # the last three warm-up iterations: a lower bound
    clock.iteration_done(100.0, learning=True)
    clock.iteration_done(110.0, learning=True)
    eta = clock.eta(0, 54)
    assert eta.known and eta.seconds == 54 * 105.0 and str(eta) == "1:34:30"
    assert clock.eta(0, 0).known and clock.eta(0, 0).seconds == 0.0
