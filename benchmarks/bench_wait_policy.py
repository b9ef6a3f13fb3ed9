"""How the OpenMP wait policy changes two forced threads, idle and with a core busy
(issue 16, item 2).

Numba's threading layer here is OpenMP (libgomp), whose idle workers spin before they
sleep: with one core held by another process, the thread that waits there at the end of
each parallel loop takes its time slices from the busy loop. This times the warm quick
start (``nanoblock run --quiet`` of the built-in scenario, installed into a fresh virtual
environment as in ``bench_quickstart.py``, with its own Numba cache) on two forced threads
under libgomp's default, ``GOMP_SPINCOUNT=1000`` and ``OMP_WAIT_POLICY=PASSIVE``, idle and
with a busy loop on one core, beside one thread and the default thread choice
(:class:`nanoblock.threads.ThreadBudget`) under the same load.

Run: ``python benchmarks/bench_wait_policy.py``; writes
``benchmarks/results_wait_policy.json`` (wall [s] and load averages before each run).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_quickstart import BUSY, ROOT, fresh_install, run_quickstart
from host import describe

POLICIES = {
    "libgomp default": {},
    "GOMP_SPINCOUNT=1000": {"GOMP_SPINCOUNT": "1000"},
    "OMP_WAIT_POLICY=PASSIVE": {"OMP_WAIT_POLICY": "PASSIVE"},
}
"""Environment of each wait policy."""


def main() -> None:
    results: dict = {}
    with tempfile.TemporaryDirectory() as venv, tempfile.TemporaryDirectory() as cache:
        nanoblock = fresh_install(Path(venv))
        run_quickstart(nanoblock, Path(cache))  # compiles the kernels into the cache
        for policy, environment in POLICIES.items():
            results[f"idle, 2 threads, {policy}"] = run_quickstart(
                nanoblock, Path(cache), 2, environment=environment
            )
        results["idle, default threads"] = run_quickstart(nanoblock, Path(cache))
        hog = subprocess.Popen([sys.executable, "-c", BUSY])
        try:
            for policy, environment in POLICIES.items():
                results[f"busy, 2 threads, {policy}"] = run_quickstart(
                    nanoblock, Path(cache), 2, environment=environment
                )
            results["busy, 1 thread"] = run_quickstart(nanoblock, Path(cache), 1)
            results["busy, default threads"] = run_quickstart(nanoblock, Path(cache))
        finally:
            hog.kill()
    for name, result in results.items():
        print(f"{name}: {result['wall']:.1f} s (load averages {result['load_averages']})")
    results["timestamp"] = time.strftime("%Y-%m-%d %H:%M")
    results["cpu_count"] = os.cpu_count()
    results["host"] = describe()
    (ROOT / "benchmarks" / "results_wait_policy.json").write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
