"""How many Numba threads a run uses: the cores other processes leave idle.

Each internal step runs one parallel loop over the contacts, which ends when its slowest
thread does. With a core held by another process, a thread scheduled there waits for its
time slice (milliseconds) at every step, so two threads can run slower than one. Unless
NUMBA_NUM_THREADS is set, :class:`ThreadBudget` re-measures every ``interval`` seconds of
the run how much CPU other processes took (all cores' busy time from ``/proc/stat`` minus
this process's own) and uses the cores they left free, at least one. The trajectory does
not depend on the thread count (each contact has its own random stream), so the choice
only changes the speed.
"""

from __future__ import annotations

import os
import time

import numba

BUDGET_INTERVAL = 1.0
"""Wall time between two measurements of the other processes' CPU use [s]."""


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

    def __init__(self, interval: float = BUDGET_INTERVAL) -> None:
        self.interval = interval
        self.maximum = numba.config.NUMBA_NUM_THREADS
        self.original = numba.get_num_threads()
        self.active = "NUMBA_NUM_THREADS" not in os.environ and self.maximum > 1
        self._mark()

    def _mark(self) -> None:
        self.wall, self.busy, self.own = time.perf_counter(), _busy_seconds(), _own_seconds()

    def update(self) -> None:
        """Re-measure once ``interval`` has passed and set the thread count."""
        wall = time.perf_counter()
        if not self.active or wall - self.wall < self.interval:
            return
        busy = _busy_seconds()
        if busy is None or self.busy is None:
            self.active = False
            return
        others = max(busy - self.busy - (_own_seconds() - self.own), 0.0) / (wall - self.wall)
        free = (os.cpu_count() or 1) - others
        numba.set_num_threads(int(min(max(round(free), 1), self.maximum)))
        self._mark()

    def __enter__(self) -> ThreadBudget:
        return self

    def __exit__(self, *exc_info: object) -> None:
        """Restore the thread count the run started with."""
        numba.set_num_threads(self.original)
