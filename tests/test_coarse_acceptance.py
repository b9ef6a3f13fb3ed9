"""Issue 4 acceptance: the simulated interface coarse-grained to rate-and-state.

System (unless a test says otherwise): the reference mean-field joint of physics.md
section 4 (b = 2.75 nm, sigma_a = 1e8 Pa, E_J = 1e9 Pa, omega_a = 1e12 1/s, 300 K:
u = 50, reset slip, k2 = 0), 3000 contacts x 1 block, W = 1 N, p = 1e8 Pa, ageing
m = 0.05 with tau_m = 0.1 ms, renewal after D0 = 0.1 um of slip, a steady start, seed 0,
K/W = 1e7 1/m. Fits use the aging law on a 1 -> 2 -> 1 um/s step pair (2.5 D0 each).
The stick-slip onset uses D0 = 0.3 um and 2000 contacts: at D0 = 0.1 um it lies 15 %
above (B - A)/Dc, as the direct effect is not adiabatic at the Hopf frequency
(001/Eqs. 36-38). Tolerances are the issue's (10 %) where it sets them, else Z_MAX Monte
Carlo standard errors; the measured numbers and their seed-to-seed scatter are in the
README section "Coarse-graining: from nanoblocks to rate-and-state".
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from nanoblock.coarse.activation import measure_activation
from nanoblock.coarse.estimates import fit_line
from nanoblock.coarse.runs import quiet_seed, scenario_file, sweep_of, varied
from nanoblock.coarse.steady import direct_effect_slope, measure_steady
from nanoblock.coarse.stickslip import measure_onset, renewal_onset
from nanoblock.coarse.transients import fit_transient, measure_steps, spike
from nanoblock.engine import simulate
from nanoblock.params import Scenario
from tests.conftest import scenario
from tests.tolerances import Z_MAX

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"

D0 = 1e-7
"""Memory length of the base interface [m]."""

ISSUE_RTOL = 0.10
"""The issue's 10 % (A vs alpha mu0, onset vs (B - A)/Dc, v_act)."""

LINEAR_SLOPE_TOL = 0.15
"""|d ln Dc / d ln D0 - 1| and |d ln B / d ln m - 1|: the slopes scatter by ~0.04 between
seeds (two base seeds: Dc/D0 = 0.47-0.52 at each D0, B within 5 %), so 0.15 is ~4 sigma."""


B_BIAS_TOL = 0.20
"""|B / (m sigma_s/p) - 1|. The one-state aging law splits the weakening B - A between A
and B with a bias: B / (m sigma_s/p) = 0.855, 0.897, 0.896, 0.883 with seeds 0-3 (mean
-11 %, seed-to-seed sd 2 %; the three m of one seed share its noise), so 0.20 is ~4.5 sd
from the mean."""


STEADY_STEP = 1 / 16
"""Internal step of the direct-effect sweep, in rho~_max (see that test)."""


def _interface_base(
    steps: list[dict], record_every: float, memory_length: float = D0, contacts: int = 3000
) -> Scenario:
    """The test interface on a stiff drive (K/W = 1e7 1/m), steady start, seed 0."""
    return scenario(
        interface={
            "n_contacts": contacts,
            "blocks_per_contact": 1,
            "memory_length": memory_length,
            "aging_m": 0.05,
            "aging_time": 1e-4,
        },
        loading={"stiffness": 1e7, "steps": steps},
        run={"seed": 0, "record_every": record_every, "initial_state": "steady"},
    )


ONSET_D0 = 3e-7
"""D0 of the stick-slip test [m]: the onset pulsation y V/D0 with y ~ 3.5 must stay far
below V / L, L = b k_B T / (4 sigma_bar b^3) = 2.7 nm the activation length of the
direct effect (001/Eq. 38); y L / D0 = 0.03 here, 0.1 at D0 = 0.1 um."""


def step_pair(memory_length: float) -> list[dict]:
    """1 -> 2 -> 1 um/s, 2.5 D0 each (5 Dc) after 0.5 D0 of steady sliding."""
    return [
        {"velocity": 1e-6, "displacement": 0.5 * memory_length},
        {"velocity": 2e-6, "displacement": 2.5 * memory_length},
        {"velocity": 1e-6, "displacement": 2.5 * memory_length},
    ]


PAIR_SAMPLING = D0 / 2e-6 / 100
"""100 samples per D0 at 2 um/s: each stored sample costs a pass over all blocks, and at 50
the fit can slip into a spurious Dc ~ rho~_max (the spike's rise is then unresolved)."""


@pytest.fixture(scope="module")
def memory_fits():
    """Aging-law fits of the step pair at D0 = 0.05, 0.1, 0.2 um (protocol in units of D0)."""
    base = _interface_base(step_pair(D0), PAIR_SAMPLING)
    return measure_steps(base, "interface.memory_length", [0.5 * D0, D0, 2 * D0], "aging")


@pytest.fixture(scope="module")
def ageing_fits(memory_fits):
    """Aging-law fits of the step pair at m = 0.025, 0.05, 0.1 (D0 = 0.1 um)."""
    base = _interface_base(step_pair(D0), PAIR_SAMPLING)
    others = measure_steps(base, "interface.aging_m", [0.025, 0.1], "aging")
    middle = memory_fits.sel({"interface.memory_length": D0}).drop_vars("interface.memory_length")
    middle = middle.expand_dims({"interface.aging_m": [0.05]})
    parts = [
        others.isel({"interface.aging_m": [0]}),
        middle,
        others.isel({"interface.aging_m": [1]}),
    ]
    return xr.concat(parts, dim="interface.aging_m")


def test_fitted_dc_is_linear_in_d0(memory_fits) -> None:
    """Dc of the aging law at D0 = 0.05, 0.1, 0.2 um: d ln Dc / d ln D0 = 1 (the renewal
    process is self-similar in D0 while D0 >> rho~_max and D0/V >> tau_m)."""
    d0 = memory_fits["interface.memory_length"].values
    dc, err = memory_fits.dc.values, memory_fits.dc_stderr.values
    line = fit_line(np.log(d0), np.log(dc), err / dc)
    print(f"Dc/D0 = {np.round(dc / d0, 3)}, slope {line.slope:.3f} +- {line.slope_stderr:.3f}")
    assert abs(line.slope - 1.0) < LINEAR_SLOPE_TOL


def test_fitted_b_is_linear_in_aging_m(ageing_fits) -> None:
    """B of the aging law at m = 0.025, 0.05, 0.1: d ln B / d ln m = 1, and B = m sigma_s/p
    (001/Eqs. 5, 16: the state acts on the area at birth) within :data:`B_BIAS_TOL`."""
    m = ageing_fits["interface.aging_m"].values
    b, err = ageing_fits.b.values, ageing_fits.b_stderr.values
    line = fit_line(np.log(m), np.log(b), err / b)
    ratio = b / ageing_fits.b_theory.values
    slope = f"{line.slope:.3f} +- {line.slope_stderr:.3f}"
    print(f"B / (m sigma_s/p) = {np.round(ratio, 3)}, slope {slope}")
    assert abs(line.slope - 1.0) < LINEAR_SLOPE_TOL
    assert np.all(np.abs(ratio - 1.0) < B_BIAS_TOL)


def spike_run(memory_length: float, contacts: int = 4000) -> xr.Dataset:
    """1 -> 10 um/s at K/W = 1e8 1/m (001/Eq. 13 ratio ~2400 at D0 = 0.1 um): the spike."""
    steps = [
        {"velocity": 1e-6, "displacement": 0.5 * memory_length},
        {"velocity": 1e-5, "displacement": 0.3 * memory_length},
    ]
    base = _interface_base(steps, 1e-4, memory_length, contacts)
    return simulate(varied(base, {"loading.stiffness": 1e8}))


def test_spike_direct_effect_is_alpha_mu0_within_ten_percent() -> None:
    """A from the 1 -> 10 um/s spike (001/Eq. 12), 4000 contacts, vs alpha mu0 with the
    exact secant alpha of 001/Eq. 28: within 10 % (seeds 0-4: -0.9 % +- 1.7 %; at
    K/W = 1e7, ratio 240, -5.5 % +- 0.7 %: the state evolves during the loading);
    001/Eq. 30's alpha = 1/2u would give alpha mu0 30 % lower."""
    result = spike(spike_run(D0))
    error = float(result.a / result.a_theory - 1)
    print(
        f"spike A = {float(result.a):.5f}, alpha mu0 = {float(result.a_theory):.5f}: {error:+.3f}"
    )
    assert abs(error) < ISSUE_RTOL
    assert float(result.a_eq30) < 0.8 * float(result.a_theory)


@pytest.mark.battery
def test_stick_slip_onset_is_b_minus_a_over_dc_within_ten_percent() -> None:
    """D0 = 0.3 um. As in 001 (Eq. 12), A is the spike's (4000 contacts); B and Dc come
    from an aging-law fit of a step pair (4000 contacts) with A held; they predict
    (K/W)_c = (B - A)/Dc (001/Eq. 9). A stiffness sweep at 1.02, 1.1 and 1.2 times it
    (4000 contacts, the quietest of 16 seeds; steady 1 um/s, then a step to 1.5 um/s) puts
    the zero of the oscillations' growth rate within 10 % of it. Measured: -5.7 % and
    +1.9 % with sweep seeds 0 and 100. A sweep at 1.1-1.4 times it with 2000 contacts
    scattered by -16 % and +13 % between the same seeds (the line through the two softest
    runs extrapolates over 10-25 % of K). The renewal model's own linear theory
    (nanoblock.coarse.stickslip.renewal_onset) and 001/Eq. 10's pulsation are printed.
    A battery check (``pytest -m battery``), not in .ci/run: one sweep's onset carries a
    delta-method standard error of ~50 % (a realisation after a round-off change of the
    kernels: -10.9 % +- 49 %, lambda T = -0.46, -0.71, -0.62 at the three stiffnesses), so
    a single 8-minute sweep cannot resolve the 10 %; a sound check pools several sweep
    seeds, which does not fit the suite's budget."""
    direct = spike(spike_run(ONSET_D0))
    pair = simulate(_interface_base(step_pair(ONSET_D0), ONSET_D0 / 2e-6 / 100, ONSET_D0, 4000))
    fit = fit_transient(pair, "aging", hold={"a": float(direct.a)})
    a, b, dc = float(fit.a), float(fit.b), float(fit.dc)
    predicted = (b - a) / dc
    sweep = quiet_seed(
        _interface_base(
            [
                {"velocity": 1e-6, "displacement": 0.5 * ONSET_D0},
                {"velocity": 1.5e-6, "displacement": 3.5 * ONSET_D0},
            ],
            ONSET_D0 / 1.5e-6 / 25,
            ONSET_D0,
            4000,
        )
    )
    stiffness = predicted * sweep.interface.normal_force * np.array([1.02, 1.1, 1.2])
    runs, onset = measure_onset(sweep, stiffness)
    measured = float(onset.stiffness_per_load_c)
    error = measured / predicted - 1
    renewal, y = renewal_onset(float(direct.a_theory), float(fit.b_theory), ONSET_D0)
    unit = 1.5e-6 / ONSET_D0
    print(
        f"onset {measured:.4g} +- {float(onset.stiffness_per_load_c_stderr):.2g} 1/m vs "
        f"(B - A)/Dc = {predicted:.4g}: {error:+.3f} (A {a:.5f}, B {b:.5f}, Dc/D0 "
        f"{dc / ONSET_D0:.3f}; renewal theory {renewal:.4g}); pulsation "
        f"{float(onset.pulsation_c) / unit:.2f} V/D0 vs 001/Eq. 10 "
        f"{math.sqrt((b - a) / a) * ONSET_D0 / dc:.2f}, renewal {y:.2f}; lambda T "
        f"{np.round((2 * np.pi * runs.growth / runs.pulsation).values, 2)}"
    )
    assert abs(error) < ISSUE_RTOL


def test_direct_effect_slope_matches_theory_over_six_decades() -> None:
    """mu_ss(V) from 1 nm/s to 1 mm/s (steady_velocity_sweep.toml at 2000 contacts,
    without ageing: m = 0, D0 = inf; 300 rho~_max per velocity): each decade's secant
    slope is within Z_MAX standard errors and 3 % of the secant of sigma_s(V)/p (001/Eq.
    28), i.e. alpha mu0 with the exact alpha, where V << V* = 4.9 m/s (001/Eq. 30
    applies); Eq. 30's alpha = 1/2u is 20-40 % low there. Internal steps of
    :data:`STEADY_STEP` rho~_max: at the default rho~_max / 4 the stiff drive's predicted
    slider velocity lags enough to put the 1 -> 10 nm/s secant 0.9 % +- 0.15 % low (12
    realisations; rho~_max / 16: +0.02 % +- 0.13 %, 6 seeds) and to double the noise."""
    path = SCENARIOS / "steady_velocity_sweep.toml"
    base = scenario_file(path, 0.5)
    no_ageing = {"interface.aging_m": 0.0, "interface.memory_length": math.inf}
    base = varied(base, {**no_ageing, "run.step_slip": STEADY_STEP * base.joint.rho_max})
    velocities = sweep_of(path).axes[0].values
    curve = measure_steady(base, velocities, 300 * base.joint.rho_max)
    slopes = direct_effect_slope(curve)
    z = (slopes.slope - slopes.slope_theory) / slopes.slope_stderr
    relative = slopes.slope / slopes.slope_theory - 1
    print(f"secant slope / theory - 1: {np.round(relative.values, 4)}; z = {np.round(z.values, 2)}")
    assert float(np.abs(z).max()) < Z_MAX
    assert float(np.abs(relative).max()) < 0.03
    assert np.all(curve.alpha_eq30 < 0.85 * curve.alpha_theory)


def test_temperature_sweep_recovers_the_activation_volume() -> None:
    """temperature_sweep.toml (20-100 C, 2000 blocks), A(T) from steady runs at 0.1 um/s
    and 100 um/s (three decades: three times the signal of a 1 -> 10 um/s step at the same
    cost): v_act(T) = k_B T / (p A) of 001/Eq. 19 is 15-25 % below 8 b^3 sigma_bar / E_J
    (001/Eq. 33) at each T, and its T -> 0 intercept recovers it within 10 % (the mean-field
    quadrature puts the bias of the straight-line extrapolation at +4.2 %)."""
    path = SCENARIOS / "temperature_sweep.toml"
    temperatures = sweep_of(path).axes[0].values
    result = measure_activation(scenario_file(path, 0.5), temperatures, (1e-7, 1e-4))
    theory = float(result.v_act_theory)
    error = float(result.v_act) / theory - 1
    print(
        f"v_act(T)/v_act = {np.round(result.v_act_t.values / theory, 3)}; intercept "
        f"{error:+.3f} +- {float(result.v_act_stderr) / theory:.3f}"
    )
    assert abs(error) < ISSUE_RTOL
    assert np.all(result.v_act_t.values < 0.9 * theory)
