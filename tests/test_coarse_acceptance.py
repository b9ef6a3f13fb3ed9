"""Issue 4 acceptance: the simulated interface coarse-grained to rate-and-state.

System (unless a test says otherwise): the reference mean-field joint of physics.md
section 4 (b = 2.75 nm, sigma_a = 1e8 Pa, E_J = 1e9 Pa, omega_a = 1e12 1/s, 300 K:
u = 50, reset slip, k2 = 0), 3000 contacts x 1 block, W = 1 N, p = 1e8 Pa, ageing
m = 0.05 with tau_m = 0.1 ms, renewal after D0 = 0.1 um of slip, a steady start, seed 0,
K/W = 1e7 1/m. Fits use the aging law on a 1 -> 2 -> 1 um/s step pair (2.5 D0 each).
The stick-slip onset uses D0 = 0.3 um and 2000 contacts: at D0 = 0.1 um it lies 15 %
above (B - A)/Dc, as the direct effect is not adiabatic at the Hopf frequency
(001/Eqs. 36-38). Tolerances are the issue's (10 %) where it sets them, else z_bound or
Z_MAX Monte Carlo standard errors or seed-to-seed sds (false alarm <= SIGNIFICANCE each);
the measured numbers and their seed-to-seed scatter are in docs/validation.md and below;
levels and powers in tests/README.md.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy.stats import norm

from nanoblock.coarse.activation import measure_activation
from nanoblock.coarse.estimates import fit_line
from nanoblock.coarse.runs import quiet_seed, scenario_file, sweep_of, varied
from nanoblock.coarse.steady import direct_effect_slope, measure_steady
from nanoblock.coarse.stickslip import measure_onset, renewal_onset
from nanoblock.coarse.transients import fit_transient, measure_steps, spike
from nanoblock.engine import simulate
from nanoblock.params import Scenario
from tests.conftest import scenario
from tests.naive_rsf import renewal_fit_bias
from tests.tolerances import POWER, Z_MAX, z_bound

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"

D0 = 1e-7
"""Memory length of the base interface [m]."""

TAU_M = 1e-4
"""Ageing time tau_m of the base interface [s]."""

ISSUE_RTOL = 0.10
"""The issue's 10 % (A vs alpha mu0, v_act); the spike's level and power are at
:data:`SPIKE_SEEDS`."""

SLOPE_SEED_SD = {"dc": 0.057, "b": 0.033}
"""Seed-to-seed sd of d ln Dc / d ln D0 and of d ln B / d ln m, seeds 1-10 (2026-11-27;
two seeds had given 0.04): the slopes must be 1 within z_bound() of it (0.19 and 0.11;
power 0.9 against a slope off by 0.26 and 0.15). Measured means 1.075 +- 0.018 (Dc/D0
0.468, 0.504, 0.518 at D0 = 0.05, 0.1, 0.2 um: D_c falls short of self-similarity at
the smallest D0, 50 samples per D0 there) and 1.012 +- 0.010."""

RATIO_SEED_SD = 0.034
"""Seed-to-seed sd of Dc/D0 and of B / (m sigma_s/p), seeds 1-10 (2026-11-27; 0.033 and
0.034 pooled over the three runs of each; four seeds had given 0.02): the ratios must be
the renewal prediction within z_bound(3) of it (0.122 for the three runs; power 0.9
against a departure of 0.119, 0.98 against the unbiased B = m sigma_s/p, > 0.999 against
Dc = D0). Measured means: Dc/D0 0.468, 0.504, 0.518 (prediction 0.494); B / (m
sigma_s/p) 0.850, 0.869, 0.861 at m = 0.025, 0.05, 0.1 (prediction 0.858)."""


VACT_EXTRAPOLATION_BIAS = 0.042
"""Relative bias of the T -> 0 straight-line intercept of v_act(T) over v_act (001/Eq. 33),
from the mean-field quadrature of A(T) at 0.1 and 100 um/s (+4.3 % with the weights of
seed 1's run)."""

VACT_SEED_SD = 0.008
"""Seed-to-seed sd of the intercept's relative error in
``test_temperature_sweep_recovers_the_activation_volume``, measured on seeds 1-11
(2026-11-25): mean +3.55 % +- 0.24 %, sd 0.80 %; each run's own standard error is
0.77-1.29 % (rms 1.05 %), so it is calibrated, slightly conservative. The runs sit 0.67 %
(2.7 standard errors of that mean) below the quadrature's +4.2 %."""


STEADY_STEP = 1 / 16
"""Internal step of the direct-effect sweep, in rho~_max (see that test)."""


def _interface_base(
    steps: list[dict],
    record_every: float,
    memory_length: float = D0,
    contacts: int = 3000,
    seed: int = 0,
) -> Scenario:
    """The test interface on a stiff drive (K/W = 1e7 1/m), steady start."""
    return scenario(
        interface={
            "n_contacts": contacts,
            "blocks_per_contact": 1,
            "memory_length": memory_length,
            "aging_m": 0.05,
            "aging_time": TAU_M,
        },
        loading={"stiffness": 1e7, "steps": steps},
        run={"seed": seed, "record_every": record_every, "initial_state": "steady"},
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


@pytest.fixture(scope="module")
def renewal_bias() -> tuple[float, float]:
    """(B / (m sigma_s/p), Dc/D0) of the aging-law fit to the mean-field renewal relaxation
    on the step pair's protocol and sampling (``tests/naive_rsf.renewal_fit_bias``)."""
    segments = [
        (step["velocity"], step["displacement"] / step["velocity"]) for step in step_pair(D0)
    ]
    times = np.arange(0.0, sum(d for _, d in segments), PAIR_SAMPLING)
    return renewal_fit_bias(segments, times, D0, TAU_M)


def test_fitted_dc_is_linear_in_d0(memory_fits, renewal_bias) -> None:
    """Dc of the aging law at D0 = 0.05, 0.1, 0.2 um: d ln Dc / d ln D0 = 1 (the renewal
    process is self-similar in D0 while D0 >> rho~_max and D0/V >> tau_m), and Dc/D0 is the
    one-state fit's bias on the renewal relaxation, 0.494 (not 1: the relaxation
    e^(-x)(1 - x e^x E1(x)), x = slip/D0, has area 1/2 and falls faster at first than any
    exponential)."""
    d0 = memory_fits["interface.memory_length"].values
    dc, err = memory_fits.dc.values, memory_fits.dc_stderr.values
    line = fit_line(np.log(d0), np.log(dc), err / dc)
    predicted = renewal_bias[1]
    print(
        f"Dc/D0 = {np.round(dc / d0, 3)} (renewal fit {predicted:.3f}), slope "
        f"{line.slope:.3f} +- {line.slope_stderr:.3f}"
    )
    assert abs(line.slope - 1.0) < z_bound() * SLOPE_SEED_SD["dc"]
    assert np.all(np.abs(dc / d0 - predicted) < z_bound(3) * RATIO_SEED_SD)


def test_fitted_b_is_linear_in_aging_m(ageing_fits, renewal_bias) -> None:
    """B of the aging law at m = 0.025, 0.05, 0.1: d ln B / d ln m = 1, and B is
    m sigma_s/p (001/Eqs. 5, 16: the state acts on the area at birth) times the one-state
    fit's bias on the renewal relaxation, 0.858: the relaxation falls faster at first than
    ln theta, and the fit gives part of that drop to A."""
    m = ageing_fits["interface.aging_m"].values
    b, err = ageing_fits.b.values, ageing_fits.b_stderr.values
    line = fit_line(np.log(m), np.log(b), err / b)
    ratio = b / ageing_fits.b_theory.values
    predicted = renewal_bias[0]
    slope = f"{line.slope:.3f} +- {line.slope_stderr:.3f}"
    print(f"B / (m sigma_s/p) = {np.round(ratio, 3)} (renewal fit {predicted:.3f}), slope {slope}")
    assert abs(line.slope - 1.0) < z_bound() * SLOPE_SEED_SD["b"]
    assert np.all(np.abs(ratio - predicted) < z_bound(3) * RATIO_SEED_SD)


RENEWAL_SEED_SD = {"dc": 0.11, "b": 0.024}
"""Seed-to-seed sd of the renewal law's D / D0 and B / (m sigma_s/p) at D0 = 0.1 um, seeds
0-5 (2026-11-26): D / D0 = 0.905, 0.969, 0.754, 1.001, 1.093, 0.974 and B / (m sigma_s/p)
= 0.981, 1.023, 1.038, 1.000, 1.010, 0.976."""


def test_the_renewal_law_reads_the_interface_s_own_memory_length_and_ageing() -> None:
    """The renewal law (the contacts' population without the aging law's closure) fitted to
    the step pair at D0 = 0.05, 0.1, 0.2 um: its renewal slip D is D0 and its B is
    m sigma_s/p (001/Eqs. 3, 5, 16), with no closure bias (the aging law's are 0.494 and
    0.858): the diagnosis maps a renewal fit to the simulator with D0 = D
    (``nanoblock.diagnosis.simulation.memory_length``). Bounds: z_bound(2) seed sds of the
    mean of the three runs (0.23 on D / D0, 0.05 on B); power ~1 against the aging law's
    biases, 0.3 against D / D0 = 0.8."""
    base = _interface_base(step_pair(D0), PAIR_SAMPLING)
    fits = measure_steps(base, "interface.memory_length", [0.5 * D0, D0, 2 * D0], "renewal")
    memory = fits.dc.values / fits["interface.memory_length"].values
    ageing = fits.b.values / fits.b_theory.values
    print(f"D / D0 = {np.round(memory, 3)}, B / (m sigma_s/p) = {np.round(ageing, 3)}")
    bound = z_bound(2) / math.sqrt(memory.size)
    assert abs(memory.mean() - 1.0) < bound * RENEWAL_SEED_SD["dc"]
    assert abs(ageing.mean() - 1.0) < bound * RENEWAL_SEED_SD["b"]


def spike_run(memory_length: float, contacts: int = 4000, seed: int = 0) -> xr.Dataset:
    """1 -> 10 um/s at K/W = 1e8 1/m (001/Eq. 13 ratio ~2400 at D0 = 0.1 um): the spike."""
    steps = [
        {"velocity": 1e-6, "displacement": 0.5 * memory_length},
        {"velocity": 1e-5, "displacement": 0.3 * memory_length},
    ]
    base = _interface_base(steps, 1e-4, memory_length, contacts, seed)
    return simulate(varied(base, {"loading.stiffness": 1e8}))


SPIKE_SEEDS = 32
"""Seeds of the spike test. One spike's error scatters by ~6 % (sd of seeds 0-15,
2026-11-26: +5.8 % +- 1.4 % on their mean, +6.5 % +- 1.5 % with thinned escapes), four
times its own sample-noise stderr: the level before the step is a 0.1 D0 batch mean and
the contacts' area fluctuates over D0. The mean of 32 has se ~1.06 %."""


def test_spike_direct_effect_is_alpha_mu0_within_ten_percent() -> None:
    """A from the 1 -> 10 um/s spike (001/Eq. 12), 4000 contacts, vs alpha mu0 with the
    exact secant alpha of 001/Eq. 28: the mean error of :data:`SPIKE_SEEDS` seeds within
    the issue's 10 %. It is ~+6 %: the peak is the largest of ~30 noisy samples, biased
    up by about two sample sds (~3 %), and the state evolves a little during the loading
    (at K/W = 1e7, ratio 240, the spike is 5 % lower). At a true error of +6.5 % the mean
    leaves 10 % with probability 5e-4 (3.5 / 1.06 se, below SIGNIFICANCE); a true error of
    15 % is caught with power > 0.999. 001/Eq. 30's alpha = 1/2u would give alpha mu0 30 % lower."""
    results = [spike(spike_run(D0, seed=seed)) for seed in range(SPIKE_SEEDS)]
    errors = np.array([float(r.a / r.a_theory - 1) for r in results])
    mean, stderr = errors.mean(), errors.std(ddof=1) / math.sqrt(errors.size)
    print(f"spike A / alpha mu0 - 1: {mean:+.4f} +- {stderr:.4f} (sd {errors.std(ddof=1):.4f})")
    assert abs(mean) < ISSUE_RTOL
    assert all(float(r.a_eq30) < 0.8 * float(r.a_theory) for r in results)


ONSET_SWEEP_SE = 0.49
"""Relative delta-method standard error of one sweep's onset (-10.9 % +- 49 %, lambda T =
-0.46, -0.71, -0.62 at 1.02, 1.1, 1.2 (B - A)/Dc); earlier sweeps gave -5.7 % and +1.9 %."""


def onset_sweeps_needed(standard_error: float = ONSET_SWEEP_SE) -> int:
    """Sweeps, each with relative ``standard_error``, whose pooled onset detects the issue's
    10 % at level SIGNIFICANCE with power POWER: 502 at 49 % (~67 h at 8 min a sweep; the
    same cost as one sweep of 2e6 contacts if the error falls as contacts^-1/2)."""
    return math.ceil(((z_bound() + norm.ppf(POWER)) * standard_error / ISSUE_RTOL) ** 2)


@pytest.mark.slow
def test_stick_slip_onset_is_consistent_with_b_minus_a_over_dc() -> None:
    """D0 = 0.3 um. As in 001 (Eq. 12), A is the spike's (4000 contacts); B and Dc come
    from an aging-law fit of a step pair (4000 contacts) with A held; they predict
    (K/W)_c = (B - A)/Dc (001/Eq. 9). A stiffness sweep at 1.02, 1.1 and 1.2 times it
    (4000 contacts, the quietest of 16 seeds; steady 1 um/s, then a step to 1.5 um/s)
    locates the zero of the oscillations' growth rate, with a delta-method standard error
    of ~50 % (:data:`ONSET_SWEEP_SE`): the onset must agree with the prediction within
    z_bound() of its own standard error (false alarm SIGNIFICANCE). That is all one sweep
    can decide: its power is 0.9 only against an error of ~2.2 times the prediction, and
    deciding the issue's 10 % needs `onset_sweeps_needed()` = 502 sweeps. The renewal
    model's own linear theory (nanoblock.coarse.stickslip.renewal_onset) and 001/Eq. 10's
    pulsation are printed. Slow: 95 s on 2 shared cores (2026-11-25, load ~5; ~8 min when
    it was moved to the battery in d750454), so it runs in .ci/run."""
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
        f"{np.round((2 * np.pi * runs.growth / runs.pulsation).values, 2)}; deciding 10 % "
        f"needs {onset_sweeps_needed(float(onset.stiffness_per_load_c_stderr) / predicted)} sweeps"
    )
    assert abs(measured - predicted) < z_bound() * float(onset.stiffness_per_load_c_stderr)


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
    quadrature puts the bias of the straight-line extrapolation at +4.2 %).

    Level: the 10 % bound must lie at least z_bound() of the run's own standard error (or
    the seed-to-seed sd, whichever is larger) beyond that bias, so a false alarm has
    probability below SIGNIFICANCE / 2; with the measured 0.80-1.05 % it is 5.6-7.3
    standard errors out (false alarm < 1e-8). Power 0.9 against a true intercept error of
    10 % + 1.28 x 1.05 % = 11.3 %. v_act(T) lies 16-22 % below v_act, > 30 standard errors
    (0.15-0.18 %) inside the 0.9 bound: any v_act(T) without the finite-T reduction fails."""
    path = SCENARIOS / "temperature_sweep.toml"
    temperatures = sweep_of(path).axes[0].values
    result = measure_activation(scenario_file(path, 0.5), temperatures, (1e-7, 1e-4))
    theory = float(result.v_act_theory)
    error = float(result.v_act) / theory - 1
    stderr = float(result.v_act_stderr) / theory
    print(
        f"v_act(T)/v_act = {np.round(result.v_act_t.values / theory, 3)}; intercept "
        f"{error:+.3f} +- {stderr:.3f}"
    )
    assert z_bound() * max(stderr, VACT_SEED_SD) < ISSUE_RTOL - VACT_EXTRAPOLATION_BIAS
    assert abs(error) < ISSUE_RTOL
    assert np.all(result.v_act_t.values < 0.9 * theory)
