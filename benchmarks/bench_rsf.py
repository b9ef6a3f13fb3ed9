"""Benchmark of the RSF forward model and fit (issue 3).

Times (best of several repeats, one process, this machine):
* a 5-step velocity-step forward model (aging law, 5,000 output samples) with
  ``nanoblock.rsf.solve_slider`` and with the naive ``odeint`` implementation written the
  usual way (``tests/naive_rsf.py``, one call over the whole record) at the same
  tolerances, each with its maximum error against the per-segment Radau reference;
* a full fit (aging law, with slip trend) of each velocity step in ``../shared/data``
  (skipped when absent) and of a synthetic 5,000-sample step.

Run: ``python benchmarks/bench_rsf.py``; writes ``benchmarks/results_rsf.json``.
"""

from __future__ import annotations

import json
import platform
import sys
from pathlib import Path

import numpy as np
from host import best_of, describe

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.measured import load_measurement  # noqa: E402
from nanoblock.rsf.fit import fit_rsf  # noqa: E402
from nanoblock.rsf.laws import law  # noqa: E402
from nanoblock.rsf.slider import LoadPointHistory, solve_slider  # noqa: E402
from tests.naive_rsf import naive_slider  # noqa: E402
from tests.rsf_synthetic import record  # noqa: E402

PARAMS = {"mu0": 0.6, "a": 0.01, "b": 0.014, "dc": 1e-5, "v0": 1e-6}
STIFFNESS = 3000.0
SEGMENTS = [(1e-6, 30.0), (1e-5, 10.0), (1e-6, 60.0), (1e-5, 10.0), (1e-4, 2.0)]
DATA = ROOT.parent / "shared" / "data"


def main() -> None:
    times = np.linspace(0.0, sum(d for _, d in SEGMENTS), 5000)
    history = LoadPointHistory.from_segments(SEGMENTS)
    ours = solve_slider(law("aging"), PARAMS, history, times, STIFFNESS, rtol=1e-10).friction
    usual = naive_slider("aging", PARAMS, SEGMENTS, times, STIFFNESS, solver="odeint", rtol=1e-10)
    radau = naive_slider("aging", PARAMS, SEGMENTS, times, STIFFNESS)
    results = {
        "machine": f"{platform.processor() or platform.machine()}, {platform.python_version()}",
        "forward_5_steps_nanoblock_s": best_of(
            lambda: solve_slider(law("aging"), PARAMS, history, times, STIFFNESS, rtol=1e-10),
            repeats=5,
        ),
        "forward_5_steps_usual_odeint_s": best_of(
            lambda: naive_slider(
                "aging", PARAMS, SEGMENTS, times, STIFFNESS, solver="odeint", rtol=1e-10
            ),
            repeats=5,
        ),
        "forward_error_nanoblock_vs_radau": float(np.max(np.abs(ours - radau))),
        "forward_error_usual_odeint_vs_radau": float(np.max(np.abs(usual - radau))),
    }
    rng = np.random.default_rng(0)
    synthetic = record("aging", PARAMS, "velocity_step", STIFFNESS, rng, n_samples=5000)
    results["fit_synthetic_5000_samples_s"] = best_of(
        lambda: fit_rsf(synthetic, "aging", stiffness=STIFFNESS), repeats=3
    )
    for path in sorted(DATA.glob("*.csv")):
        data = load_measurement(path)
        results[f"fit_{path.stem}_s"] = best_of(
            lambda data=data: fit_rsf(data, "aging", trend=True), repeats=3
        )
    for key, value in results.items():
        print(f"{key:<48} {value:.4g}" if isinstance(value, float) else f"{key:<48} {value}")
    results["host"] = describe()
    (ROOT / "benchmarks" / "results_rsf.json").write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
