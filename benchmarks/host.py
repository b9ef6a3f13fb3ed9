"""The machine a benchmark ran on and how fast it was that day, stored with its results.

Seconds measured on one day are not comparable with those of another unless the host
ran at the same speed: on 2026-11-27 this project's 2-core host ran an unchanged commit's
quickstart 2.4x slower than on 2026-11-26 (22.2 s warm against 9.0 s). Every benchmark
JSON therefore stores :func:`describe`, which times two fixed workloads that use no
nanoblock code, so a number can be read against the host's speed that day:

- ``python_loop``: 10^7 additions in the interpreter (the CLI, fitting and diagnosis
  drivers);
- ``numpy_gather_exp``: exp and log of 10^6 doubles gathered in a random order, 20
  times, on one thread (the kernels' cost: transcendental functions over block arrays
  larger than the cache).

Each is the best of three repeats [s]. Run ``python benchmarks/host.py`` to print them.
"""

from __future__ import annotations

import json
import os
import platform
import time

import numpy as np

REPEATS = 3


def _python_loop() -> None:
    total = 0
    for i in range(10_000_000):
        total += i


def _numpy_gather_exp() -> None:
    rng = np.random.default_rng(0)
    values = rng.random(1_000_000) + 0.5
    order = rng.permutation(values.size)
    for _ in range(20):
        values = np.log(np.exp(values[order]) + 1.0)


def best_of(function, repeats: int = REPEATS) -> float:
    """Shortest wall time of ``repeats`` calls of ``function`` [s]."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def describe() -> dict:
    """Processor, cores, Python, date, load averages before the reference workloads and
    their times [s] (best of :data:`REPEATS`)."""
    load = os.getloadavg()
    return {
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}",
        "timestamp": time.strftime("%Y-%m-%d %H:%M"),
        "load_averages": load,
        "reference_seconds": {
            "python_loop": best_of(_python_loop),
            "numpy_gather_exp": best_of(_numpy_gather_exp),
        },
    }


if __name__ == "__main__":
    print(json.dumps(describe(), indent=2))
