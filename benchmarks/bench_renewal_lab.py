"""How much of the laboratory records' misfit is the aging law's closure: the aging law,
the renewal law (its population without the closure) and the two-state aging law, each
fitted to every record of ``../shared/data`` whole, as the diagnosis sees it (averaged
to uniform load-point travel).

Run: ``python benchmarks/bench_renewal_lab.py`` (needs ``../shared/data``); writes
``benchmarks/results_renewal_lab.json`` with the RMS residual, a, b, D_c and CPU seconds
of every fit.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from datetime import date
from pathlib import Path

import numpy as np
from host import describe

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.diagnosis.catalogue import RsfVariant  # noqa: E402
from nanoblock.diagnosis.resample import resample_by_travel  # noqa: E402
from nanoblock.diagnosis.surrogates import Measurement  # noqa: E402
from nanoblock.measured import load_measurement  # noqa: E402
from tests.test_real_records import SHARED_DATA  # noqa: E402

LAWS = ("aging", "renewal", "aging2")


def main() -> None:
    rows = []
    for path in sorted(SHARED_DATA.glob("*.csv")):
        measurement = Measurement(resample_by_travel(load_measurement(path)))
        for name in LAWS:
            started = time.process_time()
            fit = measurement.fit(RsfVariant(name))
            residual = np.concatenate(
                [m - y for m, y in zip(fit.model, measurement.observed, strict=True)]
            )
            rows.append({
                "record": path.name, "law": name,
                "rms": float(np.sqrt(np.mean(residual**2))),
                **{key: float(fit.params[key]) for key in ("a", "b", "dc")},
                "cpu_seconds": time.process_time() - started,
            })  # fmt: skip
            print(rows[-1], flush=True)
    out = {
        "date": date.today().isoformat(),
        "machine": platform.platform(),
        "fits": rows,
        "host": describe(),
    }
    target = ROOT / "benchmarks" / "results_renewal_lab.json"
    target.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
