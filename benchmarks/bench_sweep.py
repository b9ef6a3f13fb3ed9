"""Benchmark of sweeps (issue 5): scheduling and storage overhead per task.

Run: ``python benchmarks/bench_sweep.py [--quick]`` on an idle machine (about 5 min). The
same n = 12 tasks (mean-field joint, 1e4 blocks, ageing and renewal, soft drive; 3
temperatures x 4 seeds), each calibrated to about 10 s, run

* serially, in memory, in one process with one Numba thread: the compute c per task;
* two at a time, in memory, in two such processes (no Dask, no store): p per task, what
  two runs sharing the machine cost at best;
* as a ``nanoblock sweep`` (:func:`nanoblock.sweep.run_sweep`) on a LocalCluster of W = 2
  single-threaded workers, each task writing its zarr store: the task phase T (first
  submission to last result, :attr:`~nanoblock.sweep.SweepReport.timings`), each task's
  wall time w inside its worker, with when it started and ended.

The in-memory runs and the sweep's workers are warmed up alike (:func:`nanoblock.sweep.
warm_up`); the sweep's warm-up is part of its fixed cost. The overhead the issue bounds,
scheduling and storage per task as a fraction of c, is measured in the sweep itself:

* storage: the task's wall time on its store, the flushes (samples, checkpoint, progress;
  ``nanoblock.engine._flush``) and the few other calls, timed by wrappers in the
  benchmark's task function; it includes waiting for zarr's I/O threads;
* Dask's other threads in the worker (event loop, monitors), from per-thread CPU times;
* the scheduler, nannies and client meanwhile: CPU of the main process over the tasks;
* a worker waiting for its next task: W T - tail - sum w, the task phase's worker time
  not spent in a task, without the tail (after its last task, a worker idle until the
  other ends: the last round's imbalance, at most one task per worker per sweep).

These are small, direct measurements, little affected by other work on the machine. The
same overhead as a difference between phases run one after the other, (W T - tail -
sum p) / n / c with wall times, and with CPU times, is reported beside them: it is sound
on an idle machine only (a phase that shares the machine with other work shows it as
overhead or as a gain), as are two runs sharing the machine (sum p - sum c) and the tail.
The fixed cost F of the sweep (cluster start, worker warm-up, cluster stop) is reported in
seconds and amortised over these n tasks, W F / n / c, and the all-inclusive (W M - sum c)
/ n / c, with M the makespan of the whole call. The one-minute load average before and
after each phase is recorded.

Prints a Markdown table and writes ``benchmarks/results_sweep.json``.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import platform
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import psutil
from host import describe

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.sweep import Sweep, run_sweep, run_task  # noqa: E402

SCENARIO = """
[joint]
block_size = 2.75e-9
shear_modulus = 1.0e9
threshold_stress = 1.0e8
attempt_frequency = 1.0e12
temperature = 300.0
k2 = 0.0
slip = "reset"

[interface]
normal_force = 1.0
hardness = 1.0e8
n_contacts = 200
blocks_per_contact = 50
memory_length = 2e-7
aging_m = 0.05

[loading]
stiffness = 1e6
steps = [{{ velocity = 1e-6, displacement = {displacement:.4g} }}]

[run]
seed = 1
record_every = 1e-3
initial_state = "steady"
"""

SETS = ["joint.temperature=290,300,310"]
SEEDS = 4
WORKERS = 2
STORE_CALLS = ("exists", "update_attrs", "open")
"""The calls :func:`nanoblock.engine.simulate` makes on its store besides the flushes."""
CALIBRATION_DISPLACEMENT = 1e-7
"""Slip [m] of the calibration run (about 2 s); the tasks' slip is scaled from it."""

SERIAL = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
from nanoblock.engine import simulate
from nanoblock.sweep import Sweep, warm_up
tasks = Sweep.from_file(sys.argv[2], json.loads(sys.argv[3]), int(sys.argv[4])).tasks()
warm_up(tasks[0].scenario.resolved_json())  # as the sweep's workers are
runs = []
for task in tasks[int(sys.argv[5]) :: int(sys.argv[6])]:
    started, cpu = time.perf_counter(), time.process_time()
    simulate(task.scenario)
    runs.append((time.perf_counter() - started, time.process_time() - cpu))
print(json.dumps(runs))
"""


def in_memory_runs(scenario: Path, processes: int) -> tuple[list[float], list[float]]:
    """Wall and CPU times [s] of each task run in memory on one thread, in ``processes``
    processes at once (task i in process i mod processes), in task order."""
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    args = [str(ROOT), str(scenario), json.dumps(SETS), str(SEEDS)]
    running = [
        subprocess.Popen(
            [sys.executable, "-c", SERIAL, *args, str(i), str(processes)],
            env=env,
            stdout=subprocess.PIPE,
            text=True,
        )
        for i in range(processes)
    ]
    runs = [json.loads(process.communicate()[0].strip().splitlines()[-1]) for process in running]
    ordered = [runs[i % processes][i // processes] for i in range(sum(map(len, runs)))]
    return [wall for wall, _ in ordered], [cpu for _, cpu in ordered]


def calibrated_displacement(scenario: Path, seconds: float) -> float:
    """Slip [m] for a task of about ``seconds`` of compute, from a short warmed-up run."""
    scenario.write_text(SCENARIO.format(displacement=CALIBRATION_DISPLACEMENT))
    code = SERIAL.replace("tasks[int(sys.argv[5]) :: int(sys.argv[6])]", "tasks[:1]")
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    args = [str(ROOT), str(scenario), "[]", "1", "0", "1"]
    output = subprocess.run(
        [sys.executable, "-c", code, *args], env=env, capture_output=True, text=True, check=True
    )
    ((wall, _),) = json.loads(output.stdout.strip().splitlines()[-1])
    return CALIBRATION_DISPLACEMENT * seconds / wall


def thread_cpu() -> dict[str, float]:
    """CPU seconds of each thread of this process, keyed by ``name:native id``."""
    names = {thread.native_id: thread.name for thread in threading.enumerate()}
    return {
        f"{names.get(thread.id, '?')}:{thread.id}": thread.user_time + thread.system_time
        for thread in psutil.Process().threads()
    }


def timed_task(scenario_json: str, store: str, *, log: str) -> float:
    """:func:`nanoblock.sweep.run_task`, logging its worker, start and end (epoch
    seconds), the wall and CPU seconds its thread spent on the store (timed by wrapping
    ``nanoblock.engine._flush``: samples, checkpoint, progress; and the other calls
    ``simulate`` makes on it, :data:`STORE_CALLS`), and the CPU seconds of each of the
    worker's threads over the task."""
    import nanoblock.engine as engine
    from nanoblock.store import RunStore

    spent = {"flushes": 0, "wall": 0.0, "cpu": 0.0}

    def timed(function, flush=False):
        def wrapper(*args, **kwargs):
            started, cpu = time.perf_counter(), time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                spent["flushes"] += flush
                spent["wall"] += time.perf_counter() - started
                spent["cpu"] += time.thread_time() - cpu

        return wrapper

    originals = {name: getattr(RunStore, name) for name in STORE_CALLS}
    flush = engine._flush
    engine._flush = timed(flush, flush=True)
    for name, method in originals.items():
        setattr(RunStore, name, timed(method))
    before = thread_cpu()
    started, task_cpu = time.time(), time.thread_time()
    try:
        wall = run_task(scenario_json, store)
    finally:
        engine._flush = flush
        for name, method in originals.items():
            setattr(RunStore, name, method)
    ended, task_cpu = time.time(), time.thread_time() - task_cpu
    threads = {name: cpu - before.get(name, 0.0) for name, cpu in thread_cpu().items()}
    zarr = sum(cpu for name, cpu in threads.items() if name.startswith(("zarr", "asyncio")))
    record = {
        "worker": f"{os.getpid()}-{threading.get_ident()}",
        "start": started,
        "end": ended,
        "wall": wall,
        "flushes": spent["flushes"],
        "store_wall": spent["wall"],
        "store_cpu": spent["cpu"],
        "thread_cpu": task_cpu,
        "zarr_threads_cpu": zarr,
        "other_threads_cpu": sum(threads.values()) - task_cpu - zarr,
    }
    Path(log, Path(store).stem + ".json").write_text(json.dumps(record))
    return wall


class CpuSampler(threading.Thread):
    """CPU seconds of this process (the LocalCluster's scheduler and nannies, the
    client, and this sampler), sampled against epoch time every ``interval`` seconds."""

    def __init__(self, interval: float = 0.25) -> None:
        super().__init__(daemon=True)
        self.interval = interval
        self.samples: list[tuple[float, float]] = []
        self.stopped = threading.Event()
        self.process = psutil.Process()

    def sample(self) -> None:
        self.samples.append((time.time(), sum(self.process.cpu_times()[:2])))

    def run(self) -> None:
        self.sample()
        while not self.stopped.wait(self.interval):
            self.sample()

    def stop(self) -> None:
        self.stopped.set()
        self.join()
        self.sample()

    def between(self, start: float, end: float) -> float:
        """CPU seconds spent from ``start`` to ``end`` (epoch seconds), interpolated."""
        times, cpu = np.array(self.samples).T
        return float(np.interp(end, times, cpu) - np.interp(start, times, cpu))


def load() -> float:
    """One-minute load average of the machine."""
    return os.getloadavg()[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="~1 s tasks (smoke test)")
    parser.add_argument("--task-seconds", type=float, default=10.0, help="compute per task")
    args = parser.parse_args()
    seconds = 1.0 if args.quick else args.task_seconds
    loads = {"start": load()}
    with tempfile.TemporaryDirectory() as tmp:
        scenario = Path(tmp) / "bench.toml"
        displacement = calibrated_displacement(scenario, seconds)
        scenario.write_text(SCENARIO.format(displacement=displacement))
        serial, serial_cpu = in_memory_runs(scenario, 1)
        loads["after serial"] = load()
        concurrent, concurrent_cpu = in_memory_runs(scenario, WORKERS)
        loads["after two at a time"] = load()
        sweep = Sweep.from_file(scenario, SETS, SEEDS)
        log = Path(tmp) / "log"
        log.mkdir()
        task_function = functools.partial(timed_task, log=str(log))
        sampler = CpuSampler()
        sampler.start()
        started = time.perf_counter()
        report = run_sweep(sweep, Path(tmp) / "sweep", workers=WORKERS, task_function=task_function)
        makespan = time.perf_counter() - started
        returned = time.time()
        sampler.stop()
        loads["after sweep"] = load()
        if report.entries("failed"):
            raise SystemExit(f"failed tasks: {report.entries('failed')}")
        records = [json.loads((log / f"{task.name}.json").read_text()) for task in sweep.tasks()]
    timings = report.timings
    phase_end = returned - timings["cluster_stop"]
    in_worker = [entry["wall_seconds"] for entry in report.manifest["tasks"]]
    n = len(serial)
    compute = sum(serial) / n
    tail = sum(
        phase_end - max(r["end"] for r in records if r["worker"] == worker)
        for worker in {r["worker"] for r in records}
    )
    fixed = timings["cluster_start"] + timings["warm_up"] + timings["cluster_stop"]
    busy = WORKERS * timings["tasks"]

    def per_task(seconds: float) -> float:
        """Seconds summed over tasks, per task, as a fraction of c."""
        return seconds / n / compute

    scheduling = busy - tail - sum(in_worker)
    in_tasks = sum(in_worker) - sum(concurrent)
    compute_cpu = sum(serial_cpu) / n
    worker_cpu = sum(
        r["thread_cpu"] + r["zarr_threads_cpu"] + r["other_threads_cpu"] for r in records
    )
    first_start, last_end = min(r["start"] for r in records), max(r["end"] for r in records)
    cluster_cpu = sampler.between(first_start, last_end)

    def per_task_cpu(seconds: float) -> float:
        """Seconds summed over tasks, per task, as a fraction of the serial CPU per task."""
        return seconds / n / compute_cpu

    storage = sum(r["store_wall"] for r in records)
    dask_threads = sum(r["other_threads_cpu"] for r in records)
    measured = {
        "scheduling and storage": per_task(storage + dask_threads + cluster_cpu + scheduling),
        "  storage: the task's wall time on its store": per_task(storage),
        "  Dask's other threads in the worker (CPU)": per_task(dask_threads),
        "  scheduler, nannies and client meanwhile (CPU of the main process)": per_task(
            cluster_cpu
        ),
        "  a worker waiting for its next task, (W T - tail - sum w)": per_task(scheduling),
        "(zarr's I/O threads, CPU; not added: the flushes wait for them)": per_task(
            sum(r["zarr_threads_cpu"] for r in records)
        ),
    }
    overhead_cpu = {
        "in the tasks: store, Dask's threads, (sum cpu_w - sum cpu_p)": per_task_cpu(
            worker_cpu - sum(concurrent_cpu)
        ),
        "two runs sharing the machine, (sum cpu_p - sum cpu_c)": per_task_cpu(
            sum(concurrent_cpu) - sum(serial_cpu)
        ),
    }
    overhead = {
        "scheduling and storage, (W T - tail - sum p) / n / c": per_task(scheduling + in_tasks),
        "  a worker waiting for its next task, (W T - tail - sum w)": per_task(scheduling),
        "  in the tasks: zarr store, Dask's threads, (sum w - sum p)": per_task(in_tasks),
        "end of the task phase: a worker idle after its last task (tail)": per_task(tail),
        "two runs sharing the machine, (sum p - sum c)": per_task(sum(concurrent) - sum(serial)),
        "total of the task phase, (W T - sum c) / n / c": per_task(busy - sum(serial)),
    }
    fixed_cost = {
        "cluster start (LocalCluster, client)": timings["cluster_start"],
        "worker warm-up (imports, kernels, zarr)": timings["warm_up"],
        "cluster stop": timings["cluster_stop"],
        "total F": fixed,
    }
    results = {
        "tasks n": n,
        "workers W": WORKERS,
        "serial compute per task c [s]": compute,
        "two at a time, per task p [s]": sum(concurrent) / n,
        "sweep task in its worker w, with store [s]": sum(in_worker) / n,
        "sweep task phase T, first submission to last result [s]": timings["tasks"],
        "serial CPU per task [s]": compute_cpu,
        "overhead per task / c, measured in the sweep": measured,
        "store flushes per task": sum(r["flushes"] for r in records) / n,
        "overhead per task / c, sweep phase minus in-memory phases, wall times": overhead,
        "the same from CPU times, / serial CPU per task": overhead_cpu,
        "fixed cost per sweep [s]": fixed_cost,
        "fixed cost amortised over these n tasks, W F / n / c": per_task(WORKERS * fixed),
        "sweep makespan M, the whole call [s]": makespan,
        "all-inclusive overhead per task, (W M - sum c) / n / c": per_task(
            WORKERS * makespan - sum(serial)
        ),
    }
    machine = (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}"
    )
    print(f"Machine: {machine}; one-minute load average {loads}\n")
    if max(loads.values()) > 0.5 * (os.cpu_count() or 1):
        print("Other work shared the machine: phase differences below are not reliable.\n")
    print("| measurement | value |\n|---|---|")
    for name, value in results.items():
        for key, number in value.items() if isinstance(value, dict) else [(None, value)]:
            label = name if key is None else f"{name}: {key}"
            print(f"| {label} | {number:.3g} |")
    results["task slip [m]"] = displacement
    results["serial walls [s]"] = serial
    results["two at a time walls [s]"] = concurrent
    results["worker walls [s]"] = in_worker
    results["serial CPU [s]"] = serial_cpu
    results["two at a time CPU [s]"] = concurrent_cpu
    results["worker records"] = records
    results["machine"] = machine
    results["one-minute load average"] = loads
    results["timestamp"] = time.strftime("%Y-%m-%d %H:%M")
    results["host"] = describe()
    if not args.quick:
        (ROOT / "benchmarks" / "results_sweep.json").write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
