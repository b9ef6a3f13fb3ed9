"""How far the resampling by travel moves effect-free records from the base law's family.

Run: ``python benchmarks/bench_resampling_bias.py [DRAWS]`` (default 36). For each
effect-free time-series draw of the hidden-effect matrix, the renewal law at the draw's
true parameters (only mu0 refitted) is compared with the noiseless record as recorded
and as the diagnosis sees it, resampled by travel (:func:`tests.hidden_matrix.truth_chi2`:
chi^2 over the three runs at the noise actually added). Beside each, the auto closure's
verdict from ``results_hidden_effects_time_series_auto_none.json`` when it has that draw.
Writes ``benchmarks/results_resampling_bias.json``.
"""

from __future__ import annotations

import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from host import describe

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.hidden_matrix import VISIBLE_CHI2, Case, truth_chi2  # noqa: E402

VERDICTS = ROOT / "benchmarks" / "results_hidden_effects_time_series_auto_none.json"


def _draw(index: int) -> dict:
    return {"index": index, **truth_chi2(Case("time_series", "none", index))}


def main(draws: int) -> None:
    started = time.perf_counter()
    verdicts = {}
    if VERDICTS.exists():
        verdicts = {c["index"]: c["verdict"] for c in json.loads(VERDICTS.read_text())["cases"]}
    with ProcessPoolExecutor(max_workers=2) as pool:  # the machine's 2 cores
        rows = list(pool.map(_draw, range(draws)))
    for row in rows:
        row["auto_verdict"] = verdicts.get(row["index"])
        print(f"#{row['index']:2d} {row['auto_verdict']!s:18} recorded {row['recorded']:8.1f}"
              f"  resampled {row['resampled']:8.1f}")  # fmt: skip
    labels = ("recorded", "resampled")
    above = {label: sum(r[label] >= VISIBLE_CHI2 for r in rows) for label in labels}
    results = {
        "host": describe(),
        "draws": draws,
        "visible_chi2": VISIBLE_CHI2,
        "above_visible": above,
        "wall_seconds": time.perf_counter() - started,
        "rows": rows,
    }
    out = ROOT / "benchmarks" / "results_resampling_bias.json"
    out.write_text(json.dumps(results, indent=1) + "\n")
    print(f"above chi^2 {VISIBLE_CHI2:g}: {above}; wrote {out}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 36)
