"""Benchmark of a full diagnosis as ``nanoblock diagnose`` runs it (simulation check on).

Times ``nanoblock.diagnosis.diagnose(..., simulate=True)`` on a synthetic 5,000-sample
velocity-step record (aging law with a slip trend, noise 2e-4), on each laboratory velocity
step in ``../shared/data`` and on the two 2.3 -> 23 um/s steps at 75 and 100 MPa combined
as two runs of one record (18,160 samples; issue 15: under 60 s for the 12,502-sample
record, under 120 s for the combined one), and records each verdict with its forecast
gain, the accepted parameters, the noise model, the window study and the wall time of the
(last) simulation check (issue 16: under 15 s per record). Laboratory entries
are skipped when the data are absent.

Run: ``python benchmarks/bench_diagnosis.py [--closure=CLOSURE]``; writes
``benchmarks/results_diagnosis.json`` (``results_diagnosis_<CLOSURE>.json`` with a closure
other than the default ``aging``; the README's laboratory table is made from the default's).
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import xarray as xr
from host import describe

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.diagnosis import diagnose, load_for_diagnosis  # noqa: E402
from nanoblock.diagnosis.core import DEFAULT_CLOSURE  # noqa: E402
from tests.rsf_synthetic import record  # noqa: E402
from tests.test_real_records import two_loads  # noqa: E402

DATA = ROOT.parent / "shared" / "data"
TARGET_SECONDS = {"p655_75MPa_vstep_2p3to23.csv": 60.0, "combined_2p3to23": 120.0}


def timed(data: xr.Dataset, closure: str) -> dict:
    start = time.perf_counter()
    result = diagnose(data, simulate=True, closure=closure)
    seconds = time.perf_counter() - start
    accepted = result.extended
    return {
        "samples": int(data.sizes["sample"]),
        "seconds": seconds,
        "cause": result.cause,
        "base_law": result.base.fit.law,
        "base_rms": result.base.rms,
        "noise_model": result.noise_model,
        "best": None if result.best is None else result.best.id,
        "gain": result.gain(),
        "accepted_params": None if accepted is None else accepted.fit.params,
        "best_implausible": None if result.best is None else result.best.implausible,
        "stick_slip": [event.to_json() for event in result.stick_slip],
        "not_confirmed": result.not_confirmed,
        "simulation_check": result.simulation_check.get("status", "not_run"),
        "simulation_seconds": result.simulation_check.get("seconds"),
        "dc_growth": result.window_study.get("dc_growth"),
        "closures": result.closures,
    }


def main() -> None:
    closure = sys.argv[1].removeprefix("--closure=") if len(sys.argv) > 1 else DEFAULT_CLOSURE
    rng = np.random.default_rng(0)
    truth = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6}
    synthetic = record("aging", truth, "velocity_step", 2500.0, rng, n_samples=5000, trend=80.0)
    synthetic.attrs["stiffness_per_load"] = 2500.0
    results = {"synthetic_5000": timed(synthetic, closure)}
    if DATA.is_dir():
        for path in sorted(DATA.glob("*vstep*.csv")):
            results[path.name] = timed(load_for_diagnosis(path), closure)
        results["combined_2p3to23"] = timed(two_loads(DATA), closure)
    for name, entry in results.items():
        seconds, cause = entry["seconds"], entry["cause"]
        print(f"{name:38s} {entry['samples']:6d} samples {seconds:6.1f} s  {cause}")
    out = {
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
        "cores": os.cpu_count(),
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="minutes"),
        "load_average": os.getloadavg(),
        "python": platform.python_version(),
        "target_seconds": TARGET_SECONDS,
        "closure": closure,
        "results": results,
        "host": describe(),
    }
    suffix = "" if closure == DEFAULT_CLOSURE else f"_{closure}"
    path = ROOT / "benchmarks" / f"results_diagnosis{suffix}.json"
    path.write_text(json.dumps(out, indent=2, default=float) + "\n")
    print(markdown(results))


def markdown(results: dict) -> str:
    """The README's laboratory table."""
    lines = [
        "| record | samples | verdict | forecast ratio | variance explained | noise floor / white "
        "| D_c growth with window | seconds |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, entry in results.items():
        if name.startswith("synthetic"):
            continue
        gain, noise = entry["gain"], entry["noise_model"]
        ratio = gain["heldout_error_ratio"]
        shown = "-" if entry["cause"] == "unstable_sliding" or ratio is None else f"{ratio:.2f}"
        explained, growth = gain["variance_explained"], entry["dc_growth"]
        lines.append(
            f"| {name.removesuffix('.csv')} | {entry['samples']} | {entry['cause']} | {shown} | "
            f"{'-' if explained is None else f'{100 * explained:.0f} %'} | "
            f"{noise['floor'] / noise['white']:.1f} | "
            f"{'-' if growth is None else f'{growth:.1f}x'} | "
            f"{entry['seconds']:.0f} |"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    main()
