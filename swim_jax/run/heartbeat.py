"""A line at least every ``every_s`` seconds while a run is busy: :class:`Heartbeat`.

A run's long steps block its thread: compiling a program (seconds to minutes on a CPU), the first
evaluation, a call of the training program. Every line the run prints goes through the heartbeat,
which remembers the newest one as the current activity; a daemon thread prints
``<activity> ... still running (m:ss)`` whenever nothing was printed for ``every_s`` seconds, so a
user (or a log watcher) never waits longer than that for a sign of life.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Callable


def fmt_duration(sec: float | None) -> str:
    """``h:mm:ss`` of ``sec`` seconds (rounded), or ``?`` when it is None or not finite."""
    if sec is None or not math.isfinite(sec):
        return "?"
    sec = int(round(sec))
    return f"{sec // 3600}:{sec % 3600 // 60:02d}:{sec % 60:02d}"


class Heartbeat:
    """Serialises the lines of ``say`` (one per call) and, between :meth:`start` and :meth:`stop`
    (or as a context manager), prints ``"<activity> ... still running (<time in it>)"`` whenever
    ``every_s`` seconds pass without a line. ``every_s <= 0`` turns the thread off."""

    def __init__(self, say: Callable[[str], None], every_s: float, clock: Callable[[], float] = time.monotonic):
        self._say, self.every_s, self._clock = say, every_s, clock
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.last_line = self.activity_since = clock()
        self.activity: str | None = None

    def __call__(self, line: str) -> None:
        """Print ``line``; it becomes the current activity."""
        self.say(line, activity=line)

    def say(self, line: str, activity: str | None = None, out: Callable[[str], None] | None = None) -> None:
        """Print ``line`` (through ``out``, default the heartbeat's own ``say``); ``activity`` (if
        given) becomes what a later heartbeat line names."""
        with self._lock:
            (out or self._say)(line)
            self.last_line = self._clock()
            if activity is not None:
                self.activity, self.activity_since = activity, self.last_line

    def doing(self, activity: str) -> None:
        """Name what the run does now (nothing is printed)."""
        with self._lock:
            self.activity, self.activity_since = activity, self._clock()

    def beat(self) -> bool:
        """Print the heartbeat line if ``every_s`` passed without a line; whether it printed."""
        with self._lock:
            now = self._clock()
            if self.activity is None or now - self.last_line < self.every_s:
                return False
            self._say(f"{self.activity} ... still running ({fmt_duration(now - self.activity_since)})")
            self.last_line = now
            return True

    def start(self) -> "Heartbeat":
        if self.every_s > 0 and self._thread is None:
            self._thread = threading.Thread(target=self._loop, name="swim-jax-heartbeat", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def _loop(self) -> None:
        while not self._stop.wait(min(1.0, self.every_s / 4)):
            self.beat()

    def __enter__(self) -> "Heartbeat":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
