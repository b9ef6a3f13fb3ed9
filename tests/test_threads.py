"""Issue 16: the thread budget uses the cores other processes leave idle."""

from __future__ import annotations

import numba
import pytest

import nanoblock.threads as threads


@pytest.mark.parametrize(("others", "expected"), [(0.0, 2), (0.9, 1), (1.6, 1)])
def test_budget_leaves_the_cores_other_processes_use(monkeypatch, others, expected) -> None:
    """Over one interval the machine's 2 cores were busy for ``others`` core-seconds
    beyond this process's own 0.5 s: it runs on the cores left, at least one."""
    clock = {"wall": 0.0, "busy": 10.0, "own": 3.0}
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    monkeypatch.setattr(threads.os, "cpu_count", lambda: 2)
    monkeypatch.setattr(threads.numba.config, "NUMBA_NUM_THREADS", 2)
    monkeypatch.setattr(threads.time, "perf_counter", lambda: clock["wall"])
    monkeypatch.setattr(threads, "_busy_seconds", lambda: clock["busy"])
    monkeypatch.setattr(threads, "_own_seconds", lambda: clock["own"])
    chosen = []
    monkeypatch.setattr(threads.numba, "set_num_threads", chosen.append)
    with threads.ThreadBudget(interval=1.0) as budget:
        clock["wall"] = 0.5
        budget.update()  # before the interval: no change
        assert chosen == []
        clock.update(wall=1.0, busy=10.5 + others, own=3.5)
        budget.update()
        assert chosen == [expected]
    assert chosen[-1] == budget.original


def test_an_explicit_thread_count_is_kept(monkeypatch) -> None:
    monkeypatch.setenv("NUMBA_NUM_THREADS", str(numba.config.NUMBA_NUM_THREADS))
    assert not threads.ThreadBudget().active
