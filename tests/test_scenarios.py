"""Every scenario file in scenarios/ validates, declares a valid sweep if it has one, and
runs at a reduced size (fewer contacts) with a cheap physics assertion."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from nanoblock.coarse.activation import measure_activation
from nanoblock.coarse.runs import run_scenarios, scaled, sweep_assignments, sweep_of, varied
from nanoblock.coarse.steady import measure_steady
from nanoblock.coarse.stickslip import oscillation
from nanoblock.engine import protocol_table, simulate
from nanoblock.params import Scenario, load_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
FILES = sorted(SCENARIOS.glob("*.toml"))


def _segment_means(run: xr.Dataset, scenario: Scenario, fraction: float = 0.5) -> list[float]:
    """Mean friction over the last ``fraction`` of each segment's samples."""
    starts = protocol_table(scenario)[0]
    time, mu = run.time.values, run.friction_coefficient.values
    means = []
    for begin, end in zip(starts[:-1], np.append(starts[1:-1], np.inf), strict=True):
        inside = np.flatnonzero((time > begin) & (time <= end))
        means.append(float(mu[inside[int(len(inside) * (1 - fraction)) :]].mean()))
    return means


def check_quickstart(path: Path) -> None:
    """Run by tests/test_cli.py at a reduced size; here only validated."""
    assert load_scenario(path).loading.steps


def check_velocity_step(path: Path) -> None:
    """1 -> 10 um/s, 200 contacts: a spike up, then velocity weakening (B > A)."""
    scenario = scaled(load_scenario(path), 0.05)
    run = simulate(scenario)
    before, after = _segment_means(run, scenario, 0.2)
    assert run.friction_coefficient.max() > before + 0.005
    assert after < before - 0.01


def check_slide_hold_slide(path: Path) -> None:
    """Holds 1-1000 s, 200 contacts: the reload peak grows with the hold time."""
    scenario = scaled(load_scenario(path), 0.05)
    run = simulate(scenario)
    starts = protocol_table(scenario)[0]
    time, mu = run.time.values, run.friction_coefficient.values
    peaks = [mu[(time > starts[i]) & (time < starts[i + 1])].max() for i in (2, 4, 6, 8)]
    assert peaks[-1] > peaks[0] + 0.01


def check_stiffness_sweep(path: Path) -> None:
    """The softest and stiffest springs, 400 contacts: the slider sticks on the softest
    (stick-slip) and not on the stiffest (steady sliding)."""
    sweep = sweep_of(path)
    assert [axis.key for axis in sweep.axes] == ["loading.stiffness"]
    tasks = sweep.tasks()
    runs = run_scenarios([scaled(tasks[i].scenario, 0.1) for i in (0, -1)])
    soft, stiff = (oscillation(run) for run in runs)
    assert soft.sticks.item() == 1 and stiff.sticks.item() == 0


def check_temperature_sweep(path: Path) -> None:
    """Coldest and hottest, 400 contacts: the direct effect grows with T (A ~ T / x_f)."""
    temperatures = sweep_of(path).axes[0].values
    chosen = [temperatures[0], temperatures[-1]]
    result = measure_activation(scaled(load_scenario(path), 0.1), chosen)
    assert float(result.a[1] / result.a[0]) > 1.1


def check_steady_velocity_sweep(path: Path) -> None:
    """Three of its velocities, 200 contacts over 2 D0: velocity weakening below V_sat."""
    scenario = scaled(load_scenario(path), 0.05)
    velocities = [1e-9, 1e-7, 1e-5]
    assert set(velocities) <= set(sweep_of(path).axes[0].values)
    curve = measure_steady(scenario, velocities, 2 * scenario.interface.memory_length)
    assert np.all(np.diff(curve.mu_ss.values) < 0.0)


def check_silicon_stepped(path: Path) -> None:
    """000/Fig. 2 protocol, 200 contacts: the friction relaxes during every hold (creep)
    and never exceeds the athermal bound sigma_a / p."""
    scenario = scaled(load_scenario(path), 0.05)
    run = simulate(scenario)
    starts = protocol_table(scenario)[0]
    time, mu = run.time.values, run.friction_coefficient.values
    for hold in (1, 3, 5, 7):
        inside = mu[(time > starts[hold]) & (time <= starts[hold + 1])]
        assert inside[-1] < inside[0]
    assert mu.max() < scenario.joint.threshold_stress / scenario.interface.hardness


def check_silicon_ramped(path: Path) -> None:
    """000/Fig. 3 at 100 and 600 N, 200 contacts: the ramp ends in sliding at mu_s = 0.16
    (000/Table 2, Si/steel 2) within 5 %."""
    sweep = sweep_of(path)
    assert sweep.axes[0].key == "interface.normal_force"
    base = scaled(load_scenario(path), 0.05)
    runs = run_scenarios([varied(base, {"interface.normal_force": n}) for n in (100.0, 600.0)])
    for run in runs:
        assert float(run.friction_coefficient[-1]) == pytest.approx(0.16, rel=0.05)


CHECKS: dict[str, Callable[[Path], None]] = {
    name.removeprefix("check_"): check
    for name, check in globals().items()
    if name.startswith("check_")
}


@pytest.mark.parametrize("path", FILES, ids=[path.stem for path in FILES])
def test_scenario_file_validates_and_runs_reduced(path: Path) -> None:
    load_scenario(path)
    if sweep_assignments(path):
        assert sweep_of(path).tasks()
    CHECKS[path.stem](path)


def test_every_scenario_file_has_a_check() -> None:
    assert {path.stem for path in FILES} == set(CHECKS)
