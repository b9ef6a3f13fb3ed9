"""Benchmark of sweeps (issue 5): scheduling and storage overhead per task.

Run: ``python benchmarks/bench_sweep.py [--quick]`` on an idle machine. The same 4 tasks
of about 10 s (mean-field joint, 1e4 blocks, ageing and renewal, soft drive) run

* serially, in memory, in one process with one Numba thread: the compute c per task;
* two at a time, in memory, in two such processes (no Dask, no store): p per task, what
  two runs sharing the machine cost at best;
* as ``nanoblock sweep`` tasks on a LocalCluster of W = 2 single-threaded workers, each
  writing its zarr store: the makespan M from the call to the return (cluster start and
  stop included), and each task's wall time w inside its worker.

Compilation is cached; the in-memory runs exclude it by a warm-up, the sweep does not
(each new worker loads the kernels). The overhead per task, (W M - sum c) / n as a
fraction of c, splits into what is spent outside the tasks (W M - sum w: cluster start
and stop, worker start, scheduling), inside them (sum w - sum p: zarr store, kernel
loading) and by two runs sharing the machine (sum p - sum c). Prints a Markdown table and
writes ``benchmarks/results_sweep.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.sweep import Sweep, run_sweep  # noqa: E402

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
steps = [{{ velocity = 1e-6, displacement = {displacement} }}]

[run]
seed = 1
record_every = 1e-3
initial_state = "steady"
"""

SETS = ["joint.temperature=290,310"]
SEEDS = 2
WORKERS = 2

SERIAL = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
from nanoblock.engine import simulate
from nanoblock.sweep import Sweep
tasks = Sweep.from_file(sys.argv[2], json.loads(sys.argv[3]), int(sys.argv[4])).tasks()
warm_up = Sweep.from_file(sys.argv[2], ["loading.steps.0.displacement=1e-9"]).tasks()[0]
simulate(warm_up.scenario)  # load the compiled kernels
walls = []
for task in tasks[int(sys.argv[5]) :: int(sys.argv[6])]:
    started = time.perf_counter()
    simulate(task.scenario)
    walls.append(time.perf_counter() - started)
print(json.dumps(walls))
"""


def in_memory_walls(scenario: Path, processes: int) -> list[float]:
    """Wall time [s] of each task run in memory on one thread, in ``processes`` processes
    at once (task i in process i mod processes)."""
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
    walls = [json.loads(process.communicate()[0].strip().splitlines()[-1]) for process in running]
    return [wall for process_walls in walls for wall in process_walls]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="~1 s tasks (smoke test)")
    args = parser.parse_args()
    displacement = 5e-8 if args.quick else 5e-7
    with tempfile.TemporaryDirectory() as tmp:
        scenario = Path(tmp) / "bench.toml"
        scenario.write_text(SCENARIO.format(displacement=displacement))
        serial = in_memory_walls(scenario, 1)
        concurrent = in_memory_walls(scenario, WORKERS)
        sweep = Sweep.from_file(scenario, SETS, SEEDS)
        started = time.perf_counter()
        report = run_sweep(sweep, Path(tmp) / "sweep", workers=WORKERS)
        makespan = time.perf_counter() - started
    in_worker = [entry["wall_seconds"] for entry in report.manifest["tasks"]]
    n = len(serial)
    compute = sum(serial) / n

    def per_task(seconds: float) -> float:
        """Seconds summed over tasks, per task, as a fraction of c."""
        return seconds / n / compute

    results = {
        "serial compute per task c [s]": compute,
        "two at a time, per task p [s]": sum(concurrent) / n,
        "sweep task in its worker w, with store [s]": sum(in_worker) / n,
        "sweep makespan M, cluster start and stop included [s]": makespan,
        "overhead per task / c, (W M - sum c) / n / c": per_task(WORKERS * makespan - sum(serial)),
        "  of which outside the tasks (cluster, worker start, scheduling), (W M - sum w)": (
            per_task(WORKERS * makespan - sum(in_worker))
        ),
        "  of which in the tasks (zarr store, kernel loading), (sum w - sum p)": (
            per_task(sum(in_worker) - sum(concurrent))
        ),
        "  of which two runs sharing the machine, (sum p - sum c)": (
            per_task(sum(concurrent) - sum(serial))
        ),
    }
    machine = (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}"
    )
    print(f"Machine: {machine}\n")
    print("| measurement | value |\n|---|---|")
    for name, value in results.items():
        print(f"| {name} | {value:.3g} |")
    results["tasks"], results["workers"] = n, WORKERS
    results["serial walls [s]"] = serial
    results["two at a time walls [s]"] = concurrent
    results["worker walls [s]"] = in_worker
    results["machine"] = machine
    results["timestamp"] = time.strftime("%Y-%m-%d")
    if not args.quick:
        (ROOT / "benchmarks" / "results_sweep.json").write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
