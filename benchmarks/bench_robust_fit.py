"""Huber's loss against least squares on the laboratory records (``nanoblock fit --loss``).

Run: ``python benchmarks/bench_robust_fit.py`` (needs ``../shared/data``). For every record
beside the repository the aging law is fitted to the whole record, as ``nanoblock fit``
does, with least squares and with Huber's loss; the JSON holds both contracts (mu0, a, b,
D_c) with their standard errors, the share of samples beyond Huber's corner (17.9 % for
Gaussian noise) and the samples beyond ten robust standard deviations (spikes: 1.5e-23 of
Gaussian samples). It also runs the synthetic check of ``tests/test_fit.py``
(:func:`tests.test_fit.spiky_recovery`: 40 velocity steps of the independent reference
integrator with 1 % one-sided spikes of 20-40 noise deviations). Writes
``benchmarks/results_robust_fit.json``.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
from host import describe
from scipy.stats import median_abs_deviation

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.measured import load_measurement  # noqa: E402
from nanoblock.rsf.fit import HUBER_K, fit_rsf  # noqa: E402
from tests.test_fit import spiky_recovery  # noqa: E402
from tests.test_real_records import SHARED_DATA  # noqa: E402

SPIKE = 10.0
"""Robust standard deviations beyond which a least-squares residual counts as a spike."""


def _summary(fit) -> dict:
    residual = np.concatenate(fit.residuals)
    scale = float(median_abs_deviation(residual, scale="normal"))
    return {
        "contract": fit.contract,
        "stderr": fit.contract_stderr,
        "rms_residual": fit.rms_residual,
        "robust_sd": scale,
        "spikes": int(np.sum(np.abs(residual) > SPIKE * scale)),
        "n_points": fit.n_points,
    }


def main() -> None:
    results = {"host": describe(), "huber_k": HUBER_K, "spike_sd": SPIKE, "records": {}}
    for path in sorted(SHARED_DATA.glob("*.csv")):
        data = load_measurement(path)
        started = time.process_time()
        plain = fit_rsf(data, "aging")
        robust = fit_rsf(data, "aging", loss="huber")
        entry = {
            "linear": _summary(plain),
            "huber": {
                **_summary(robust),
                "downweighted_share": robust.downweighted / robust.n_points,
            },
            "cpu_seconds": time.process_time() - started,
        }
        entry["shift_in_stderr"] = {
            key: (robust.contract[key] - plain.contract[key]) / plain.contract_stderr[key]
            for key in ("mu0", "a", "b", "dc")
        }
        results["records"][path.name] = entry
        shifts = ", ".join(f"{k} {v:+.1f}" for k, v in entry["shift_in_stderr"].items())
        print(
            f"{path.name}: beyond the corner {100 * entry['huber']['downweighted_share']:.0f} %, "
            f"spikes {entry['linear']['spikes']}, Huber - least squares: {shifts} stderr"
        )
    results["synthetic_spikes"] = spiky_recovery()
    print("synthetic spikes:", results["synthetic_spikes"])
    out = Path(__file__).with_name("results_robust_fit.json")
    out.write_text(json.dumps(results, indent=2) + "\n")
    print(out)


if __name__ == "__main__":
    main()
