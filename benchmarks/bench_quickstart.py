"""Benchmark of the first run (issue 16): ``nanoblock run`` of the built-in quickstart,
cold (an empty Numba cache: every kernel compiles) and warm (the kernels load from it).

Run: ``python benchmarks/bench_quickstart.py [--busy]``. As a new user would: the script
makes a fresh virtual environment, installs this source tree into it with ``pip`` (not timed),
and times the installed ``nanoblock run --quiet`` of the quickstart as a fresh process,
with NUMBA_CACHE_DIR set to a new temporary directory so the machine's own cache is
neither used nor touched. Targets on the idle 2-core machine: cold < 30 s,
warm < 10 s. ``--busy`` also times warm runs while a busy loop holds one core: one thread,
the default (:class:`nanoblock.threads.ThreadBudget` picks the threads) and two forced
threads (issue 16: the default is never slower than one thread). The same cold and warm
pair of a small chain scenario (the quickstart with k2 = k1, 20 contacts, 10 nm) gives the
extra compile of the chain kernel, which a mean-field run never compiles. Writes
``benchmarks/results_quickstart.json`` with the load averages before each measurement.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import tomllib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from host import describe

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.params import from_mapping  # noqa: E402
from nanoblock.toml_writer import scenario_toml  # noqa: E402

BUSY = "while True: pass"


def fresh_install(venv: Path) -> Path:
    """A new virtual environment with this source tree installed; its ``nanoblock`` script."""
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "-q"]
    subprocess.run([*pip, str(ROOT)], check=True)
    return venv / "bin" / "nanoblock"


def chain_scenario(directory: Path) -> Path:
    """The quickstart as a small chain joint (k2 = k1, 20 contacts, 10 nm of slip)."""
    scenario = from_mapping(tomllib.loads((ROOT / "scenarios" / "quickstart.toml").read_text()))
    changes = {
        "joint": {"k1": None, "k2": None, "block_mass": None, "damping": None, "slip": "chain"},
        "interface": {"n_contacts": 20},
        "loading": {"steps": [{"velocity": 1e-6, "displacement": 1e-8}]},
    }
    data = json.loads(scenario.resolved_json())
    for section, values in changes.items():
        data[section].update(values)
    path = directory / "chain.toml"
    path.write_text(scenario_toml(from_mapping(data)))
    return path


def run_quickstart(
    nanoblock: Path,
    cache: Path,
    threads: int | None = None,
    scenario: Path | None = None,
    environment: dict[str, str] | None = None,
) -> dict:
    """Wall time [s] of one ``nanoblock run --quiet`` of the quickstart (or ``scenario``),
    and its stderr; ``environment``: variables to add (an OpenMP wait policy, say)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), **(environment or {})}
    if threads is not None:
        env["NUMBA_NUM_THREADS"] = str(threads)
    load = os.getloadavg()
    with tempfile.TemporaryDirectory() as out:
        command = [str(nanoblock), "run", *([str(scenario)] if scenario else [])]
        started = time.perf_counter()
        done = subprocess.run(
            [*command, "--quiet", "--out", f"{out}/q.zarr"],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
        wall = time.perf_counter() - started
    return {"wall": wall, "load_averages": load, "stderr": done.stderr.strip()}


@contextmanager
def busy_core() -> Iterator[None]:
    """A busy loop holding one core for the duration of the block."""
    hog = subprocess.Popen([sys.executable, "-c", BUSY])
    try:
        yield
    finally:
        hog.kill()


def save_results(results: dict, name: str) -> None:
    """Print each timed run, stamp ``results`` with the time and host and write them to
    ``benchmarks/<name>``."""
    for key, result in results.items():
        if isinstance(result, dict) and "wall" in result:
            print(f"{key}: {result['wall']:.1f} s (load averages {result['load_averages']})")
    results["timestamp"] = time.strftime("%Y-%m-%d %H:%M")
    results["cpu_count"] = os.cpu_count()
    results["host"] = describe()
    (ROOT / "benchmarks" / name).write_text(json.dumps(results, indent=2))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--busy", action="store_true", help="also 1 vs 2 threads, one core busy")
    args = parser.parse_args()
    results: dict = {}
    with tempfile.TemporaryDirectory() as venv, tempfile.TemporaryDirectory() as cache:
        nanoblock = fresh_install(Path(venv))
        results["cold"] = run_quickstart(nanoblock, Path(cache))
        results["warm"] = run_quickstart(nanoblock, Path(cache))
        chain = chain_scenario(Path(venv))
        results["chain, cold"] = run_quickstart(nanoblock, Path(cache), scenario=chain)
        results["chain, warm"] = run_quickstart(nanoblock, Path(cache), scenario=chain)
        if args.busy:
            with busy_core():
                for threads, label in ((1, "1 thread"), (None, "default"), (2, "2 threads")):
                    key = f"warm, one core busy, {label}"
                    results[key] = run_quickstart(nanoblock, Path(cache), threads)
    results["cold"]["target"], results["warm"]["target"] = "< 30 s idle", "< 10 s idle"
    for name in ("", "chain, "):
        results[f"{name}compile"] = results[f"{name}cold"]["wall"] - results[f"{name}warm"]["wall"]
    save_results(results, "results_quickstart.json")


if __name__ == "__main__":
    main()
