"""How many Numba threads a run uses: the cores other processes leave idle.

Each internal step runs one parallel loop over the contacts, which ends when its slowest
thread does. With a core held by another process, a thread scheduled there waits for its
time slice (milliseconds) at every step, so two threads can run slower than one. Unless
NUMBA_NUM_THREADS is set, :class:`ThreadBudget` re-measures every ``interval`` seconds of
the run how much CPU other processes took (all cores' busy time from ``/proc/stat`` minus
this process's own) and uses the cores they left free, at least one. The trajectory does
not depend on the thread count (each contact has its own random stream), so the choice
only changes the speed.

A run starts on the latest measurement when it is younger than ``interval``, else on a
probe of ``PROBE`` seconds: the budget is re-measured only between stored samples, and a
run whose first sample is far away (the simulation check's run-in) ran all of it on every
thread. Measured with both cores held by busy loops: an engine-made test record took
295 s that way, 24 s on one thread (2026-11-27).
"""

from __future__ import annotations

import os
import time

import numba

BUDGET_INTERVAL = 1.0
"""Wall time between two measurements of the other processes' CPU use [s]."""

PROBE = 0.05
"""Wall time of the measurement a run starts with, when none is recent [s] (/proc/stat
counts in 10 ms ticks: five per busy core)."""

_latest: dict[str, float] = {"wall": -float("inf"), "threads": 0.0}
"""The latest measurement of any budget in this process: its time and thread count."""


def _busy_seconds() -> float | None:
    """CPU time all cores have spent busy since boot [s] (None without /proc/stat)."""
    try:
        with open("/proc/stat") as stat:
            fields = [float(value) for value in stat.readline().split()[1:]]
    except (OSError, ValueError):
        return None
    idle = fields[3] + (fields[4] if len(fields) > 4 else 0.0)  # idle + iowait
    return (sum(fields[:8]) - idle) / os.sysconf("SC_CLK_TCK")


def _own_seconds() -> float:
    """CPU time of this process, every thread [s]."""
    times = os.times()
    return times.user + times.system


class ThreadBudget:
    """Sets Numba's thread count for a run from the cores other processes leave idle."""

    def __init__(self, interval: float = BUDGET_INTERVAL, probe: float = PROBE) -> None:
        self.interval = interval
        self.probe = probe
        self.maximum = numba.config.NUMBA_NUM_THREADS
        self.original = numba.get_num_threads()
        self.active = "NUMBA_NUM_THREADS" not in os.environ and self.maximum > 1
        self._mark()

    def _mark(self) -> None:
        self.wall, self.busy, self.own = time.perf_counter(), _busy_seconds(), _own_seconds()

    def update(self, *, now: bool = False) -> None:
        """Re-measure once ``interval`` has passed (``now``: at once) and set the thread
        count."""
        wall = time.perf_counter()
        if not self.active or (wall - self.wall < self.interval and not now):
            return
        busy = _busy_seconds()
        if busy is None or self.busy is None:
            self.active = False
            return
        others = max(busy - self.busy - (_own_seconds() - self.own), 0.0) / (wall - self.wall)
        free = (os.cpu_count() or 1) - others
        chosen = int(min(max(round(free), 1), self.maximum))
        numba.set_num_threads(chosen)
        self._mark()
        _latest.update(wall=self.wall, threads=chosen)

    def __enter__(self) -> ThreadBudget:
        """Start on the latest measurement when it is recent, else on a probe."""
        if not self.active:
            return self
        if time.perf_counter() - _latest["wall"] < self.interval:
            numba.set_num_threads(int(_latest["threads"]))
        elif self.probe > 0.0:
            self._mark()
            time.sleep(self.probe)
            self.update(now=True)
        return self

    def __exit__(self, *exc_info: object) -> None:
        """Restore the thread count the run started with."""
        numba.set_num_threads(self.original)
