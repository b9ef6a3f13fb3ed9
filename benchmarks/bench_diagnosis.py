"""Benchmark of a full diagnosis (issue 6: under 60 s for a 5,000-sample velocity step).

Times ``nanoblock.diagnosis.diagnose`` (base fit, every testable extension, blocked
held-out refits, ranking) on a synthetic 5,000-sample velocity-step record (aging law with
a slip trend, noise 2e-4) and on each laboratory velocity step in ``../shared/data``
(skipped when absent), and records the verdict of each.

Run: ``python benchmarks/bench_diagnosis.py``; writes ``benchmarks/results_diagnosis.json``.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.diagnosis import diagnose, load_for_diagnosis  # noqa: E402
from tests.rsf_synthetic import record  # noqa: E402

DATA = ROOT.parent / "shared" / "data"
TARGET_SECONDS = 60.0


def timed(data) -> dict:
    start = time.perf_counter()
    result = diagnose(data)
    return {
        "samples": int(data.sizes["sample"]),
        "seconds": time.perf_counter() - start,
        "cause": result.cause,
        "noise": result.noise,
        "base_rms": result.base.rms,
        "best": None if result.best is None else result.best.id,
        "gain": result.gain(),
    }


def main() -> None:
    rng = np.random.default_rng(0)
    truth = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6}
    synthetic = record("aging", truth, "velocity_step", 2500.0, rng, n_samples=5000, trend=80.0)
    synthetic.attrs["stiffness_per_load"] = 2500.0
    results = {"synthetic_5000": timed(synthetic)}
    for path in sorted(DATA.glob("*vstep*.csv")) if DATA.is_dir() else []:
        results[path.name] = timed(load_for_diagnosis(path))
    for name, entry in results.items():
        seconds, cause = entry["seconds"], entry["cause"]
        print(f"{name:38s} {entry['samples']:6d} samples {seconds:6.1f} s  {cause}")
    out = {
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
        "python": platform.python_version(),
        "target_seconds": TARGET_SECONDS,
        "results": results,
    }
    (ROOT / "benchmarks" / "results_diagnosis.json").write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
