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
    monkeypatch.setattr(threads, "_latest", {"wall": -float("inf"), "threads": 0.0})
    chosen = []
    monkeypatch.setattr(threads.numba, "set_num_threads", chosen.append)
    with threads.ThreadBudget(interval=1.0, probe=0.0) as budget:
        clock["wall"] = 0.5
        budget.update()  # before the interval: no change
        assert chosen == []
        clock.update(wall=1.0, busy=10.5 + others, own=3.5)
        budget.update()
        assert chosen == [expected]
    assert chosen[-1] == budget.original


@pytest.mark.parametrize(("others", "expected"), [(0.0, 2), (1.0, 1), (2.0, 1)])
def test_a_run_starts_on_a_probe_or_on_a_recent_measurement(monkeypatch, others, expected):
    """With no recent measurement a budget probes before the run starts (``others`` of the
    2 cores busy during the probe): a run whose first sample is far away does not spend
    it on a core another process holds. A second budget within the interval starts on
    that measurement without probing."""
    clock = {"wall": 100.0, "busy": 10.0}
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    monkeypatch.setattr(threads.os, "cpu_count", lambda: 2)
    monkeypatch.setattr(threads.numba.config, "NUMBA_NUM_THREADS", 2)
    monkeypatch.setattr(threads.time, "perf_counter", lambda: clock["wall"])
    monkeypatch.setattr(threads, "_busy_seconds", lambda: clock["busy"])
    monkeypatch.setattr(threads, "_own_seconds", lambda: 3.0)
    monkeypatch.setattr(threads, "_latest", {"wall": -float("inf"), "threads": 0.0})
    probes = []

    def sleep(seconds: float) -> None:
        probes.append(seconds)
        clock.update(wall=clock["wall"] + seconds, busy=clock["busy"] + others * seconds)

    monkeypatch.setattr(threads.time, "sleep", sleep)
    chosen = []
    monkeypatch.setattr(threads.numba, "set_num_threads", chosen.append)
    with threads.ThreadBudget(interval=1.0):
        assert probes == [threads.PROBE] and chosen == [expected]
    clock["wall"] += 0.5
    with threads.ThreadBudget(interval=1.0):
        assert probes == [threads.PROBE] and chosen[-1] == expected
    clock["wall"] += 1.0
    with threads.ThreadBudget(interval=1.0):
        assert probes == [threads.PROBE] * 2


def test_an_explicit_thread_count_is_kept(monkeypatch) -> None:
    monkeypatch.setenv("NUMBA_NUM_THREADS", str(numba.config.NUMBA_NUM_THREADS))
    assert not threads.ThreadBudget().active
