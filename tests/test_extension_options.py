"""Catalogue extensions as simulator options (physics.md section 5), checked against physics.

Each option is off by default (the base model); switched on, the simulation must agree with
its closed form or mean-field theory within Monte Carlo error (fixed seeds, Z_MAX standard
errors), and the theory must show the catalogue's signature:

- back_jumps: reverse hops in detailed balance on the periodic characteristic: steady
  stress vs the two-branch theory (three velocities, one in the sinh regime), Boltzmann
  occupancy at rest, Eyring (asinh) crossover at the stress k_B T / (b^2 rho~_max), and a
  naive fixed-step reference;
- state_velocity_cutoff: steady mean age D0 / (V + v_theta) (000/Eq. 7), no ageing in holds;
- load_dependent_dc: mean age D0 (W / W_ref)^n / V at two loads (000/Fig. 3 caption);
- two_state_variable: a second population renewed over D0_2, mean age mixing both;
- strength_heterogeneity: steady stress vs the class average; zero spread is the base run;
- joint_softening: sigma_a(T) follows the linear law; alpha(T) rises faster than T.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
import xarray as xr
from scipy import stats

from nanoblock.barriers import BOLTZMANN, lattice_reverse_barrier
from nanoblock.engine import mean_field_joint, simulate
from nanoblock.kernels.blocks import advance_free_blocks
from nanoblock.kernels.rng import seed_streams
from nanoblock.params import Scenario, ScenarioError
from nanoblock.store import SAMPLES
from nanoblock.tables import lattice_hazard_table
from nanoblock.theory.meanfield import (
    MeanFieldJoint,
    sample_q_stationary,
    steady_stress,
    strength_factors,
)
from tests.conftest import RHO_MAX, scenario
from tests.naive_meanfield import simulate_lattice
from tests.tolerances import MEAN_AGE_RTOL, SIGNIFICANCE, Z_MAX

E_J, B = 1.0e9, 2.75e-9

BACK_JUMP_K1 = 0.7 * E_J * B
"""k1 [N/m] of the back-jump runs: u_el = u / 0.7. With k1 = E_J b (u_el = u) a block on
the lower branch near zero stress swaps with the dying upper branch ~e^(u/4) / u times per
period in the sinh regime, which is exact but costs 1e4 events per block and period."""

BACK_JUMP_RHO = B**2 * 1.0e8 / BACK_JUMP_K1
"""rho~_max [m] of the back-jump runs."""

PERIODS, BURN_IN, SPACING = 30, 3, 1.37
"""Run length and burn-in [periods rho~_max of slip], sample spacing (incommensurate with
the period: with back jumps a block's phase s = x mod 1 never changes by a hop)."""

EYRING_RTOL = 0.10
"""Back jumps: the theory's friction vs the Eyring law sigma_E asinh(V / V_0) across the
crossover decade, with sigma_E = k_B T / (b^2 rho~_max) fixed by detailed balance and V_0
from the linear response; measured within 5 %, off by 15 % a decade above, where the
cutoff has moved away from the Maxwell point and the barrier is no longer linear."""

LINEAR_RESPONSE_RTOL = 0.01
"""Back jumps: sigma_s / V constant over two decades at the lowest velocities (the
quasilinear drop of 001 after Eq. 33); the theory's absolute accuracy is ~1e-9 sigma_a."""


def steady_friction(result: xr.Dataset, burn_in: int) -> tuple[float, float]:
    """Mean stress F / Sigma_r [Pa] after ``burn_in`` samples and its standard error."""
    stress = (result.friction_force / result.real_contact_area).values[burn_in:]
    return float(stress.mean()), float(stress.std(ddof=1) / math.sqrt(stress.size))


def steady_run(velocity: float, rho_max: float, seed: int, **changes) -> Scenario:
    """A rigid drive at ``velocity`` for PERIODS rho~_max, from the stationary state."""
    return scenario(
        loading={
            "stiffness": float("inf"),
            "steps": [{"velocity": velocity, "displacement": PERIODS * rho_max}],
        },
        run={"seed": seed, "record_every": SPACING * rho_max / velocity},
        **changes,
    )


def assert_matches(measured: tuple[float, float], theory: float) -> None:
    mean, error = measured
    assert abs(mean - theory) < Z_MAX * error + 1e-6 * abs(theory), (mean, error, theory)


# ----------------------------------------------------------------------------- back jumps

BACK_JUMP_VELOCITIES = (3e-15, 1e-13, 1e-8)
"""m/s: the Eyring crossover (friction 8x below the base model), its upper end, and the
logarithmic regime."""


def back_jump_scenario(velocity: float, seed: int = 3) -> Scenario:
    return steady_run(
        velocity,
        BACK_JUMP_RHO,
        seed,
        joint={"back_jumps": True, "k1": BACK_JUMP_K1},
        interface={"n_contacts": 20, "blocks_per_contact": 100},
    )


@pytest.fixture(scope="module")
def back_jump_runs() -> dict[float, tuple[float, float]]:
    burn_in = int(BURN_IN / SPACING) + 1
    return {
        v: steady_friction(simulate(back_jump_scenario(v)), burn_in) for v in BACK_JUMP_VELOCITIES
    }


def test_back_jumps_steady_stress_matches_two_branch_theory(back_jump_runs) -> None:
    joint = mean_field_joint(back_jump_scenario(1.0))
    forward_only = replace(joint, back_jumps=False)
    for velocity, measured in back_jump_runs.items():
        assert_matches(measured, float(steady_stress(velocity, joint)))
    crossover = BACK_JUMP_VELOCITIES[0]
    mean, error = back_jump_runs[crossover]
    assert mean < 0.2 * float(steady_stress(crossover, forward_only))
    assert error < 0.1 * mean  # the comparison resolves the crossover


def test_back_jumps_make_friction_fall_to_zero_like_eyring() -> None:
    """Theory: below the crossover sigma_s ~ V (not the forward-only log law), and across it
    sigma_s = sigma_E asinh(V / V_0) with the detailed-balance stress k_B T / (b^2 rho~_max)."""
    joint = mean_field_joint(back_jump_scenario(1.0))
    forward_only = replace(joint, back_jumps=False)
    linear = np.logspace(-19, -17, 5)
    response = steady_stress(linear, joint) / linear
    np.testing.assert_allclose(response, response[0], rtol=LINEAR_RESPONSE_RTOL)
    sigma_e = BOLTZMANN * joint.temperature / (B**2 * joint.rho_max)
    assert sigma_e == pytest.approx(joint.threshold_stress / joint.u_elastic, rel=1e-12)
    v_0 = sigma_e / response[0]
    crossover = np.logspace(-18, math.log10(3e-15), 8)
    eyring = sigma_e * np.arcsinh(crossover / v_0)
    np.testing.assert_allclose(steady_stress(crossover, joint), eyring, rtol=EYRING_RTOL)
    # forward-only escape is still logarithmic there and 5x above
    assert np.all(steady_stress(crossover, forward_only) > 5 * eyring)
    # both saturate at sigma_a / 2 far above V* (7 m/s here)
    assert float(steady_stress(500.0, joint)) == pytest.approx(0.5e8, rel=1e-3)


def test_back_jumps_occupancy_at_rest_is_boltzmann() -> None:
    """Kernel and table: at a fixed drive phase s, blocks hop between the branches s and
    s - 1 until their occupancy is Boltzmann's, 1 / (1 + exp(u_el (s - 1/2)))."""
    u, u_el, n = 10.0, 14.0, 20000
    table = lattice_hazard_table("persson", u, u_el)
    stream = seed_streams(11, 1)[0]
    for phase in (0.45, 0.55, 0.7):
        y = np.where(np.arange(n) % 2 == 0, phase, phase - 1.0)
        h = np.random.default_rng(1).standard_exponential(n)
        highest = u * (1.0 - phase**2) + max(0.0, u_el * (phase - 0.5))  # slower branch
        slowest = math.exp(-highest)
        assert highest == pytest.approx(
            max(u * (1.0 - phase**2), float(lattice_reverse_barrier(phase, "persson", u, u_el)))
        )
        hops = advance_free_blocks(y, h, 0.0, 0.0, 200.0 / slowest, 0.0, 1.0, table, stream, 1.0)
        assert hops > 50 * n
        upper = float(np.mean(y > 0.0))
        expected = 1.0 / (1.0 + math.exp(u_el * (phase - 0.5)))
        assert abs(upper - expected) < Z_MAX * math.sqrt(expected * (1 - expected) / n)
        np.testing.assert_allclose(np.where(y > 0.0, y, y + 1.0), phase, atol=1e-12)


def test_back_jumps_kernel_agrees_with_naive_time_stepped_reference(back_jump_runs) -> None:
    velocity = BACK_JUMP_VELOCITIES[1]
    joint = mean_field_joint(back_jump_scenario(velocity))
    rng = np.random.default_rng(7)
    x = sample_q_stationary(3000, velocity, joint, rng) / joint.rho_max
    period = joint.rho_max / velocity
    dt = 2.0  # hazard per step <~ 0.03 where blocks hop
    samples, hops = simulate_lattice(
        x,
        velocity,
        joint.rho_max,
        joint.attempt_frequency,
        joint.u,
        joint.u_elastic,
        12 * period,
        dt,
        rng,
        sample_every=int(SPACING * period / dt),
    )
    naive = samples[2:] * joint.threshold_stress
    naive_error = naive.std(ddof=1) / math.sqrt(naive.size)
    kernel, kernel_error = back_jump_runs[velocity]
    assert hops > 3000 * 12  # more than one hop per block and period
    assert abs(kernel - naive.mean()) < Z_MAX * math.hypot(kernel_error, naive_error)
    assert abs(naive.mean() - float(steady_stress(velocity, joint))) < Z_MAX * naive_error


@pytest.mark.parametrize(
    ("joint", "fragment"),
    [
        ({"back_jumps": True, "k2": 0.0, "slip": "chain"}, "slip = 'reset' and k2 = 0"),
        ({"back_jumps": True, "k2": None}, "k2 = 0"),
        ({"back_jumps": True, "k1": 0.4 * E_J * B}, "k1 >= E_J b / 2"),
    ],
)
def test_back_jumps_outside_the_mean_field_joint_are_refused(joint, fragment) -> None:
    with pytest.raises(ScenarioError, match="back_jumps") as error:
        scenario(joint=joint)
    assert fragment in str(error.value)


# ------------------------------------------------------------- ageing clock and renewal


def mean_age_run(velocity: float, memory: float, **interface) -> tuple[float, float]:
    """Mean contact age [s] and its standard error over 30 D0 of steady sliding, sampled
    every 2 D0 (``memory``: the run's D0 [m]; ``interface``: keys of the section)."""
    run = scenario(
        interface={"n_contacts": 2000, "blocks_per_contact": 1} | interface,
        loading={
            "stiffness": float("inf"),
            "steps": [{"velocity": velocity, "displacement": 30 * memory}],
        },
        run={"record_every": 2 * memory / velocity, "step_slip": memory / 4, "seed": 5},
    )
    ages = simulate(run).mean_contact_age.values[1:]
    return float(ages.mean()), float(ages.std(ddof=1) / math.sqrt(ages.size))


def assert_age(measured: tuple[float, float], expected: float) -> None:
    mean, error = measured
    assert mean == pytest.approx(expected, rel=MEAN_AGE_RTOL)
    assert abs(mean - expected) < Z_MAX * error + 0.002 * expected, (mean, error, expected)


@pytest.mark.parametrize("ratio", [1 / 30, 30.0])
def test_state_cutoff_steady_age_is_d0_over_v_plus_v_theta(ratio: float) -> None:
    """000/Eq. 7: theta_ss = 1 / (1 + V / v_theta) with theta = v_theta <age> / D0."""
    v_theta, memory = 1e-6, 2e-8
    velocity = ratio * v_theta
    measured = mean_age_run(velocity, memory, memory_length=memory, state_cutoff_velocity=v_theta)
    assert_age(measured, memory / (velocity + v_theta))
    # at V << v_theta the age saturates at D0 / v_theta, far below the base D0 / V
    if ratio < 1:
        assert measured[0] < 0.05 * memory / velocity


def test_no_ageing_during_a_hold_with_state_cutoff() -> None:
    def hold(cutoff: dict) -> xr.Dataset:
        return simulate(
            scenario(
                interface={
                    "n_contacts": 10,
                    "blocks_per_contact": 5,
                    "memory_length": 1e-7,
                    "aging_m": 0.05,
                }
                | cutoff,
                loading={
                    "stiffness": float("inf"),
                    "steps": [{"velocity": 1e-6, "displacement": 3e-8}, {"hold": 1.0}],
                },
                run={"record_every": 0.01, "initial_state": "unloaded"},
            )
        )

    held = hold({"state_cutoff_velocity": 1e-7})
    during = held.time > 0.03 + 1e-9
    age = held.mean_contact_age.values[during]
    area = held.real_contact_area.values[during]
    assert np.all(age == age[0]) and np.all(area == area[0]) and age[0] > 0
    base = hold({})
    grown = base.mean_contact_age.values[during]
    assert grown[-1] - grown[0] == pytest.approx(held.time.values[during][-1] - 0.03 - 0.01)


def test_memory_length_grows_with_load() -> None:
    """D0(W) = D0 (W / W_ref)^n (000/Fig. 3 caption): resolved value and mean age D0(W) / V."""
    memory, velocity, exponent = 1e-8, 1e-6, 1.0
    for load in (0.5, 2.0):
        changes = {"normal_force": load, "memory_length_exponent": exponent, "reference_force": 1.0}
        resolved = scenario(interface={"memory_length": memory} | changes).interface
        expected = memory * (load / 1.0) ** exponent
        assert resolved.memory_length == pytest.approx(expected, rel=1e-15)
        assert resolved.reference_force == load  # resolved in place: re-validation is a no-op
        measured = mean_age_run(velocity, expected, memory_length=memory, **changes)
        assert_age(measured, expected / velocity)


@pytest.mark.parametrize("fraction", [0.25, 0.5])
def test_second_population_steady_age_mixes_both_memory_lengths(fraction: float) -> None:
    """two_state_variable: round(f N_c) contacts renewed after Exp(D0_2) of slip, the
    rest after Exp(D0), so the steady mean age is ((1 - f) D0 + f D0_2) / V (one
    population with the wrong length, or the wrong share, is off by > 40 %)."""
    memory, second, velocity = 1e-8, 4e-8, 1e-6
    measured = mean_age_run(
        velocity,
        second,
        memory_length=memory,
        second_memory_length=second,
        second_population=fraction,
    )
    assert_age(measured, ((1 - fraction) * memory + fraction * second) / velocity)


def test_second_population_contacts_are_the_last_round_f_n() -> None:
    from nanoblock.engine import contact_memory_lengths

    run = scenario(
        interface={
            "n_contacts": 10,
            "memory_length": 1e-8,
            "second_memory_length": 5e-7,
            "second_population": 0.34,
        }
    )
    assert run.interface.second_contacts == 3
    assert list(contact_memory_lengths(run)) == [1e-8] * 7 + [5e-7] * 3


# ----------------------------------------------------------------- strength heterogeneity


def test_strength_factors_keep_the_mean_and_approach_the_lognormal() -> None:
    assert np.array_equal(strength_factors(0.0, 5), np.ones(5))
    assert strength_factors(0.4, 1) == pytest.approx([1.0])
    for n in (4, 8, 64):
        factors = strength_factors(0.4, n)
        assert factors.mean() == pytest.approx(1.0, rel=1e-12)
        assert np.all(np.diff(factors) > 0)
    # equal-probability classes lose the within-class variance, less with more classes
    log_sd = [np.std(np.log(strength_factors(0.4, n))) for n in (8, 64, 1024)]
    assert log_sd[0] < log_sd[1] < log_sd[2] < 0.4 and log_sd[2] == pytest.approx(0.4, rel=0.01)


@pytest.mark.parametrize("velocity", [1e-6, 1.0])
def test_threshold_spread_steady_stress_matches_class_average(velocity: float) -> None:
    """Logarithmic regime, where the spread lowers friction by 5 %, and near V*."""
    run = steady_run(
        velocity,
        RHO_MAX,
        seed=9,
        joint={"threshold_spread": 0.3},
        interface={"n_contacts": 40, "blocks_per_contact": 100},
    )
    assert run.joint.strength_classes == 8
    measured = steady_friction(simulate(run), int(BURN_IN / SPACING) + 1)
    joint = mean_field_joint(run)
    theory = float(steady_stress(velocity, joint))
    assert_matches(measured, theory)
    if velocity < 1e-3:
        one_class = float(steady_stress(velocity, replace(joint, strength_classes=1)))
        assert abs(theory - one_class) > 2 * Z_MAX * measured[1]  # the spread is resolved


@pytest.mark.parametrize(
    ("joint", "start", "stiffness"),
    [({"threshold_spread": 0.0}, "steady", 1e6), ({"strength_classes": 4}, "unloaded", math.inf)],
)
def test_zero_spread_is_the_base_trajectory(joint: dict, start: str, stiffness: float) -> None:
    """Spread 0 resolves to one class: the base run, bit for bit. Several identical classes
    also give it from an unloaded start (a steady start draws the stresses class by class)."""
    base = {
        "interface": {"n_contacts": 12, "blocks_per_contact": 20, "memory_length": 3e-8},
        "loading": {
            "stiffness": stiffness,
            "steps": [{"velocity": 1e-6, "displacement": 4e-8}],
        },
        "run": {"record_every": 2e-3, "seed": 2, "initial_state": start},
    }
    reference = simulate(scenario(**base))
    again = simulate(scenario(joint=joint, **base))
    for name in SAMPLES:
        np.testing.assert_array_equal(again[name].values, reference[name].values, err_msg=name)


# ------------------------------------------------------------------------- joint softening


def test_softening_law_is_resolved_to_concrete_numbers() -> None:
    t_g, t_ref, sigma_ref = 380.0, 293.0, 1.0e8
    for temperature in (293.0, 330.0, 370.0):
        run = scenario(
            joint={
                "temperature": temperature,
                "glass_temperature": t_g,
                "reference_temperature": t_ref,
            }
        )
        expected = sigma_ref * (t_g - temperature) / (t_g - t_ref)
        assert run.joint.threshold_stress == pytest.approx(expected, rel=1e-15)
        assert run.joint.reference_temperature == temperature
        assert Scenario.from_json(run.resolved_json()) == run
        assert mean_field_joint(run).threshold_stress == run.joint.threshold_stress
    with pytest.raises(ScenarioError, match="must be below glass_temperature"):
        scenario(
            joint={"temperature": 390.0, "glass_temperature": t_g, "reference_temperature": t_ref}
        )


def test_softening_makes_alpha_rise_faster_than_temperature() -> None:
    """alpha = k_B T E_J / (2 sigma_a^2 b^3) (001/Eq. 30) and the exact local slope of
    sigma_s(V) at 1 um/s both grow faster than T as sigma_a(T) softens towards T_g."""
    temperatures = np.array([293.0, 310.0, 330.0, 350.0])
    softened, stiff = [], []
    for temperature in temperatures:
        joint = {"temperature": temperature}
        warm = scenario(joint=joint | {"glass_temperature": 450.0, "reference_temperature": 293.0})
        softened.append(mean_field_joint(warm))
        stiff.append(mean_field_joint(scenario(joint=joint)))
    alpha_over_t = np.array([j.alpha for j in softened]) / temperatures
    assert np.all(np.diff(alpha_over_t) > 0)
    np.testing.assert_allclose([j.alpha for j in stiff] / temperatures, stiff[0].alpha / 293.0)
    slope = [np.diff(np.log(steady_stress([1e-6, 1.1e-6], j)))[0] / np.log(1.1) for j in softened]
    assert np.all(np.diff(np.array(slope) / temperatures) > 0)


# ------------------------------------------------------------------ validation, determinism


@pytest.mark.parametrize(
    ("changes", "fragments"),
    [
        ({"joint": {"threshold_spread": -0.1}}, ["joint.threshold_spread", "allowed range [0"]),
        ({"joint": {"strength_classes": 0}}, ["joint.strength_classes", "allowed range [1"]),
        ({"joint": {"threshold_spread": 0.2, "strength_classes": 3}}, ["multiple of", "= 3"]),
        ({"joint": {"glass_temperature": 400.0}}, ["reference_temperature", "glass_temperature"]),
        ({"joint": {"reference_temperature": 290.0}}, ["no effect", "glass_temperature"]),
        ({"joint": {"glass_temperature": -1.0}}, ["joint.glass_temperature", "allowed range (0"]),
        (
            {"interface": {"state_cutoff_velocity": 0.0}},
            ["interface.state_cutoff_velocity", "allowed range (0"],
        ),
        ({"interface": {"memory_length_exponent": 1.0}}, ["reference_force", "(N)"]),
        (
            {"interface": {"memory_length_exponent": -1.0}},
            ["interface.memory_length_exponent", "allowed range [0"],
        ),
        ({"interface": {"reference_force": 1.0}}, ["no effect", "memory_length_exponent"]),
        ({"interface": {"memory_length_exponent": math.nan}}, ["memory_length_exponent", "NaN"]),
        ({"interface": {"second_memory_length": 1e-6}}, ["second_population", "both or neither"]),
        (
            {"interface": {"second_memory_length": 1e-6, "second_population": 1.0}},
            ["interface.second_population", "less than 1"],
        ),
        (
            {
                "interface": {
                    "n_contacts": 4,
                    "second_memory_length": 1e-6,
                    "second_population": 0.1,
                }
            },
            ["second_population = 0.1", "n_contacts = 4", "0 contacts"],
        ),
    ],
)
def test_bad_extension_options_name_key_and_range(changes, fragments) -> None:
    with pytest.raises(ScenarioError) as error:
        scenario(**changes)
    for fragment in fragments:
        assert fragment in str(error.value), str(error.value)


def extension_protocol() -> Scenario:
    """Every extension on at once, on a finite spring with a velocity step and a hold
    (u ~ 30-60 over the classes: no fast exchange at the spinodal, see BACK_JUMP_K1)."""
    return scenario(
        joint={
            "back_jumps": True,
            "k1": BACK_JUMP_K1,
            "threshold_spread": 0.2,
            "strength_classes": 4,
            "glass_temperature": 1000.0,
            "reference_temperature": 280.0,
        },
        interface={
            "n_contacts": 8,
            "blocks_per_contact": 30,
            "memory_length": 5e-8,
            "aging_m": 0.05,
            "state_cutoff_velocity": 3e-6,
            "memory_length_exponent": 0.5,
            "reference_force": 2.0,
            "second_memory_length": 2e-7,
            "second_population": 0.25,
        },
        loading={
            "stiffness": 2e5,
            "steps": [
                {"velocity": 1e-6, "displacement": 4e-8},
                {"velocity": 1e-5, "displacement": 6e-8},
                {"hold": 0.02},
                {"velocity": 1e-5, "displacement": 3e-8},
            ],
        },
        run={"record_every": 2e-3, "seed": 6},
    )


def test_extensions_same_seed_same_trajectory_with_one_or_two_threads(tmp_path) -> None:
    root = os.path.dirname(os.path.dirname(__file__))
    code = (
        "import sys; sys.path.insert(0, sys.argv[2]);"
        "from tests.test_extension_options import extension_protocol;"
        "from nanoblock.engine import simulate;"
        "simulate(extension_protocol()).to_netcdf(sys.argv[1])"
    )
    runs = []
    for threads in (1, 2):
        out = tmp_path / f"threads{threads}.nc"
        env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
        subprocess.run([sys.executable, "-c", code, str(out), root], check=True, env=env)
        runs.append(xr.open_dataset(out).load())
    for name in SAMPLES:
        np.testing.assert_array_equal(runs[0][name].values, runs[1][name].values, err_msg=name)
    assert int(runs[0].n_events[-1]) > 1000


def test_steady_initial_state_with_back_jumps_is_the_two_branch_state() -> None:
    """The sampler draws a uniform phase and the branch with probability p(s)."""
    joint = MeanFieldJoint(B, E_J, 1e8, BACK_JUMP_K1, 1e12, 300.0, back_jumps=True)
    rho = sample_q_stationary(200_000, 1e-13, joint, np.random.default_rng(3))
    x = rho / joint.rho_max
    assert x.min() >= -1.0 and x.max() <= 1.0 and np.any(x < 0)
    assert np.mean(x) * joint.threshold_stress == pytest.approx(
        float(steady_stress(1e-13, joint)), abs=Z_MAX * np.std(x) / math.sqrt(x.size) * 1e8
    )
    phase = np.where(x >= 0.0, x, x + 1.0)
    assert stats.kstest(phase, "uniform").pvalue > SIGNIFICANCE
