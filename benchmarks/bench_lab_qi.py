"""The lab's own qi fits of p655 against ``nanoblock fit`` with the same laws and
stiffnesses, and how the fitted values move with the window after the step.

Run: ``python benchmarks/bench_lab_qi.py`` (needs ``../shared/data``); writes
``benchmarks/results_lab_qi.json`` and prints the deviations the README quotes.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.measured import load_measurement  # noqa: E402
from nanoblock.rsf.fit import fit_rsf  # noqa: E402
from nanoblock.rsf.windows import step_windows  # noqa: E402
from tests.test_real_records import QI_FITS, SHARED_DATA  # noqa: E402

AFTER = (1e-4, 1.5e-4, 2e-4, 3e-4, 3.5e-4, 4e-4)
"""Windows after the step [m] (50 um before)."""


def main() -> None:
    rows = []
    for name, law, stiffness, window, lab in QI_FITS:
        data = load_measurement(SHARED_DATA / name)
        for after in sorted({*AFTER, window[1]}):
            fit = fit_rsf(step_windows(data, window[0], after), law, stiffness=stiffness)
            deviation = {
                k: fit.contract[k] / v - 1.0 for k, v in zip(("a", "b", "dc"), lab, strict=True)
            }
            rows.append(
                {"file": name, "law": law, "stiffness": stiffness, "before": window[0],
                 "after": after, "tested_window": after == window[1], "deviation": deviation}
            )  # fmt: skip
            mark = "  <- tested" if after == window[1] else ""
            print(
                f"{name:32s} {law:6s} K/W {stiffness:6.0f}  after {after * 1e6:4.0f} um: "
                + "  ".join(f"{k} {100 * v:+6.1f} %" for k, v in deviation.items())
                + mark
            )
    out = ROOT / "benchmarks" / "results_lab_qi.json"
    out.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
