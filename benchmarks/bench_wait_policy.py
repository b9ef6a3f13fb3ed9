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

import tempfile
from pathlib import Path

from bench_quickstart import busy_core, fresh_install, run_quickstart, save_results

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
        with busy_core():
            for policy, environment in POLICIES.items():
                results[f"busy, 2 threads, {policy}"] = run_quickstart(
                    nanoblock, Path(cache), 2, environment=environment
                )
            results["busy, 1 thread"] = run_quickstart(nanoblock, Path(cache), 1)
            results["busy, default threads"] = run_quickstart(nanoblock, Path(cache))
    save_results(results, "results_wait_policy.json")


if __name__ == "__main__":
    main()
