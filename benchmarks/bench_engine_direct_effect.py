"""Why the diagnosis does not call the engine's effect-free records ``none`` (issue 15).

Run: ``python benchmarks/bench_engine_direct_effect.py [CONTACTS ...]`` (default 1000
4000). For the two effect-free records of the engine's hidden-effect matrix
(``tests/engine_synthetic.py``: cases ``engine_time_series:none`` 0 and 1, their own
draws) it separates three suspects of the aging law's misfit:

- **contact noise** (correlated over D0): the engine's friction without the matrix's
  measurement noise is fitted at 1000 contacts and at 4x as many; a misfit that is noise
  falls by 2x;
- **the calibration**: the steady-state (a - b) of the engine against the targets, from
  the levels at the end of the up-step and of the down-step;
- **the direct effect's velocity dependence**: the simulation check's calibration
  matches a / mu0 to the joint's slope d ln sigma_s / d ln V (001/Eq. 28) at the
  log-centre of the sliding velocities, but the slope of a nanoblock joint grows as the
  slider slows; A(V) = mu0 d ln sigma_s / d ln V is tabulated from 1e-5 to 1e-10 m/s, the
  slider's creep velocity in the hold is read from the spring, V = -(d mu / dt) / (K / W),
  and the aging law is fitted to the sliding segments alone and to the end of the
  down-step with the hold and reslide alone.

Writes ``benchmarks/results_engine_direct_effect.json``.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
from host import describe

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.diagnosis.simulation import ROOM_TEMPERATURE, Targets, base_scenario  # noqa: E402
from nanoblock.engine import mean_field_joint  # noqa: E402
from nanoblock.rsf.fit import fit_rsf, prepare_runs  # noqa: E402
from nanoblock.theory.meanfield import log_slope  # noqa: E402
from tests.engine_synthetic import clean_record  # noqa: E402
from tests.hidden_matrix import Case  # noqa: E402

VELOCITIES = (1e-5, 3.16e-6, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
"""Where A(V) is tabulated [m/s]."""


def _edges(data) -> np.ndarray:
    (run, *_) = prepare_runs(data)
    return np.append(run.history.starts, run.time[-1])


def _level(data, edges: np.ndarray, segment: int, low: float, high: float) -> float:
    """Mean friction over the fraction [low, high) of ``segment``, all runs."""
    t = data["time"].values
    start, end = edges[segment], edges[segment + 1]
    inside = (t >= start + low * (end - start)) & (t < start + high * (end - start))
    return float(data["mu"].values[inside].mean())


def _creep_velocity(data, edges: np.ndarray, stiffness: float, low: float, high: float) -> float:
    """Slider velocity [m/s] in the fraction [low, high) of the hold (segment 3), from the
    spring: V = -(d mu / dt) / (K / W), d mu / dt the least-squares slope of the first run."""
    first = data["run"].values == data["run"].values[0]
    t, mu = data["time"].values[first], data["mu"].values[first]
    start, end = edges[3], edges[4]
    inside = (t >= start + low * (end - start)) & (t < start + high * (end - start))
    slope = np.polyfit(t[inside], mu[inside], 1)[0]
    return float(-slope / stiffness)


def _fit(data, mask=None) -> dict[str, float]:
    part = data if mask is None else data.isel(sample=np.flatnonzero(mask))
    result = fit_rsf(part, "aging")
    keys = ("mu0", "a", "b", "dc")
    return {**{k: float(result.params[k]) for k in keys}, "rms": float(result.rms_residual)}


def study(index: int, contacts: list[int]) -> dict:
    """One effect-free engine case: the three suspects measured (see the module docstring)."""
    out: dict = {}
    for n in contacts:
        data, base, sigma, _ = clean_record(
            "none", Case("engine_time_series", "none", index).rng(), n
        )
        edges = _edges(data)
        t = data["time"].values
        sliding = t < edges[3]
        late = t >= edges[2] + 0.8 * (edges[3] - edges[2])
        out[str(n)] = {
            "aging_fit": _fit(data),
            "aging_fit_sliding_segments": _fit(data, sliding),
            "aging_fit_hold_and_reslide": _fit(data, late),
            "steady_a_minus_b": (
                _level(data, edges, 1, 0.7, 1.0) - _level(data, edges, 2, 0.8, 1.0)
            )
            / math.log(10.0),
            "hold_creep_velocity": {
                "middle": _creep_velocity(data, edges, base["stiffness"], 0.45, 0.55),
                "end": _creep_velocity(data, edges, base["stiffness"], 0.9, 1.0),
            },
        }
    (run, *_) = prepare_runs(data)
    scenario, _ = base_scenario(
        Targets.from_fit(base, "aging"), run, base["stiffness"], ROOM_TEMPERATURE
    )
    joint = mean_field_joint(scenario)
    slopes = base["mu0"] * np.asarray(log_slope(np.array(VELOCITIES), joint))
    return {
        "targets": {k: float(base[k]) for k in ("mu0", "a", "b", "dc", "stiffness")},
        "target_a_minus_b": float(base["a"] - base["b"]),
        "matrix_noise_sigma": float(sigma),
        "direct_effect_A_of_V": {
            f"{v:g}": float(s) for v, s in zip(VELOCITIES, slopes, strict=True)
        },
        "by_contacts": out,
    }


def main(argv: list[str]) -> None:
    contacts = [int(n) for n in argv] or [1000, 4000]
    results = {"host": describe(), "contacts": contacts}
    for index in (0, 1):
        results[f"case_{index}"] = study(index, contacts)
        print(json.dumps(results[f"case_{index}"], indent=1), flush=True)
    path = Path(__file__).with_name("results_engine_direct_effect.json")
    path.write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main(sys.argv[1:])
