"""Issue 2 acceptance: the mean-field simulation reproduces Q_st and sigma_s(V) (001/Eqs. 27-30).

Mean-field joint (k2 = 0, reset), no ageing or renewal, rigid drive. Runs start from the
stationary state and are measured after a burn-in of several firing cycles, so a kernel
that moved blocks wrongly would drift away from it; a power check shows each comparison
rejects the theory at a slightly different temperature.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.optimize import brentq

from nanoblock.engine import Run, mean_field_joint, simulate
from nanoblock.theory.meanfield import (
    MeanFieldJoint,
    log_slope,
    q_stationary_cdf,
    sample_q_stationary,
    steady_stress,
)
from tests.conftest import RHO_MAX, scenario
from tests.naive_meanfield import simulate_mean_field
from tests.tolerances import (
    FORCE_BALANCE_RTOL,
    SIGNIFICANCE,
    STEADY_STRESS_RTOL,
    Z_MAX,
    z_bound,
)

VELOCITIES = [1e-9, 1e-7, 1e-5, 1e-3, 1e-1, 1.0, 10.0]
"""Seven drive velocities over ten decades, up to 2 V* (saturation), m/s."""

CYCLES, BURN_IN, SPACING = 70, 10, 1.37
"""Run length, discarded burn-in and sample spacing, in units of rho~_max of slip. The
spacing is incommensurate with rho~_max: at saturation (V > V*) blocks depin
deterministically and keep their phases, so samples one period apart would repeat."""


STIFF_VELOCITIES = [1e-9, 1e-8, 1e-7, 1e-5, 1e-3]
"""Five drive velocities over six decades for the stiff-spring sweep, m/s."""

STIFF = 1e12
"""A stiff frame, K / W = 1e12 1/m (W = 1 N): K = 275 k_int, the interface's stiffness."""


def steady_run(
    velocity: float,
    seed: int = 11,
    snapshot_every: int = 0,
    n_contacts: int = 40,
    stiffness: float = float("inf"),
):
    run = scenario(
        interface={"n_contacts": n_contacts, "blocks_per_contact": 500},
        loading={
            "stiffness": stiffness,
            "steps": [{"velocity": velocity, "displacement": CYCLES * RHO_MAX}],
        },
        run={
            "seed": seed,
            "record_every": SPACING * RHO_MAX / velocity,
            "snapshot_every": snapshot_every,
        },
    )
    return run, simulate(run)


def measured_stress(result) -> tuple[float, float]:
    """Mean block stress after burn-in [Pa] and its standard error sd / sqrt(n) (samples
    SPACING rho~_max apart taken as independent)."""
    stress = (result.friction_force / result.real_contact_area).values[int(BURN_IN / SPACING) + 1 :]
    return float(stress.mean()), float(stress.std(ddof=1) / np.sqrt(stress.size))


@pytest.fixture(scope="module")
def sweep():
    out = {}
    for velocity in VELOCITIES:
        run, result = steady_run(velocity)
        out[velocity] = measured_stress(result)
    return run, out


def test_steady_stress_matches_quadrature_at_each_velocity(sweep) -> None:
    run, measured = sweep
    joint = mean_field_joint(run)
    for velocity, (stress, error) in measured.items():
        theory = float(steady_stress(velocity, joint))
        assert abs(stress / theory - 1) < STEADY_STRESS_RTOL, (velocity, stress, theory)
        assert abs(stress - theory) < Z_MAX * error + 1e-4 * theory, (velocity, error)
    # saturation: at 2 V* the stress is within 1 % of sigma_a / 2
    assert measured[10.0][0] == pytest.approx(0.5e8, rel=1e-2)


def test_steady_stress_on_a_stiff_spring_matches_quadrature() -> None:
    """The finite-spring stepper at K / W = 1e12 1/m: the slider follows the load point
    in closed form between depinnings and the depinnings' drift (~k_int / K of the slip)
    is predicted, so the stress is the rigid drive's, 001/Eq. 28 within 0.5 % and Z_MAX
    standard errors, and every sample is in force balance."""
    for velocity in STIFF_VELOCITIES:
        run, result = steady_run(velocity, seed=12, stiffness=STIFF)
        stress, error = measured_stress(result)
        theory = float(steady_stress(velocity, mean_field_joint(run)))
        assert abs(stress / theory - 1) < STEADY_STRESS_RTOL, (velocity, stress, theory)
        assert abs(stress - theory) < Z_MAX * error + 1e-4 * theory, (velocity, error)
        spring = STIFF * (result.load_point_displacement - result.slider_displacement)
        np.testing.assert_allclose(spring, result.friction_force, rtol=FORCE_BALANCE_RTOL)


SOFT = 1e4
"""A soft lab machine, K / W = 1e4 1/m (W = 1 N): K = 2.8e-6 k_int."""

CREEP_SEEDS = 8
"""Seeds of the soft-spring creep test."""

CREEP_RTOL = 5e-3
"""Bound on the mean ln(V / V_Eq28) of the soft-spring creep test: 7.5e-5 of the stress
(alpha ~ 0.015)."""

CREEP_RMS = 1e-2
"""Bound on the root mean square of ln(V / V_Eq28) over the seeds: 1.5e-4 of the stress,
30 times below the steady-stress tolerance (STEADY_STRESS_RTOL)."""


def test_a_soft_spring_slider_creeps_at_the_velocity_of_its_stress() -> None:
    """On a soft spring (K / W = 1e4 1/m, 2e4 blocks, 1 um/s) the force stays where the
    initial state put it (a draw: ~4 % off the load point's velocity in ln V), so the slider
    creeps at the velocity whose 001/Eq. 28 stress it carries: a check of the stepper's
    predicted velocity feedback. Over :data:`CREEP_SEEDS` seeds, from 100 to 300 rho~_max
    of slip: the mean ln(V / V_Eq28) within CREEP_RTOL and z_bound() standard errors
    (level SIGNIFICANCE; power 0.9 against a 0.9 % bias at the measured sd), and its root
    mean square within CREEP_RMS (numerical). Measured (2026-11-29), mean +- standard
    error, sd: the default step (rho~_max / 8) -0.12 % +- 0.10 %, 0.28 %; rho~_max / 32
    -0.12 % +- 0.05 %, 0.13 %. Steps too long for the slider's velocity to be restored
    fail the rms: rho~_max / 2 +1.57 % +- 0.58 % (rms 2.2 %), 2 rho~_max -0.6 % +- 4.4 %
    (sd 12.6 %)."""
    logs = []
    for seed in range(13, 13 + CREEP_SEEDS):
        run = Run(
            scenario(
                interface={"n_contacts": 40, "blocks_per_contact": 500},
                loading={
                    "stiffness": SOFT,
                    "steps": [{"velocity": 1e-6, "displacement": 300 * RHO_MAX}],
                },
                run={"seed": seed, "record_every": SPACING * RHO_MAX / 1e-6},
            )
        )
        samples = [run.step_to_next_sample() for _ in run.times][len(run.times) // 3 :]
        first, last = samples[0], samples[-1]
        velocity = (last["slider_displacement"] - first["slider_displacement"]) / (
            last["time"] - first["time"]
        )
        stress = np.mean([s["friction_force"] / s["real_contact_area"] for s in samples])
        joint = mean_field_joint(run.scenario)
        log_theory = brentq(
            lambda log_v, joint=joint, stress=stress: (
                float(steady_stress(np.exp(log_v), joint)) - stress
            ),
            np.log(1e-6) - 5,
            np.log(1e-6) + 5,
        )
        logs.append(np.log(velocity) - log_theory)
    logs = np.array(logs)
    error = logs.std(ddof=1) / np.sqrt(logs.size)
    rms = np.sqrt(np.mean(logs**2))
    print(f"ln(V / V_Eq28): {logs.mean():+.3%} +- {error:.3%}, rms {rms:.3%}")
    assert abs(logs.mean()) < CREEP_RTOL + z_bound() * error, (logs.mean(), error)
    assert rms < CREEP_RMS, logs


def test_power_a_warmer_joint_is_rejected(sweep) -> None:
    run, measured = sweep
    joint = mean_field_joint(run)
    warmer = MeanFieldJoint(**{**joint.__dict__, "temperature": 330.0})
    stress, error = measured[1e-5]
    assert abs(stress - float(steady_stress(1e-5, warmer))) > 3 * Z_MAX * error


def test_log_slope_matches_quadrature_and_tends_to_alpha(sweep) -> None:
    run, measured = sweep
    joint = mean_field_joint(run)
    v = np.array(VELOCITIES)
    stress = np.array([measured[x][0] for x in VELOCITIES])
    error = np.array([measured[x][1] for x in VELOCITIES])
    theory = steady_stress(v, joint)
    spacing = np.diff(np.log(v))
    simulated = np.diff(np.log(stress)) / spacing
    expected = np.diff(np.log(theory)) / spacing
    slope_error = np.hypot(error[1:] / stress[1:], error[:-1] / stress[:-1]) / spacing
    np.testing.assert_array_less(np.abs(simulated - expected), Z_MAX * slope_error + 1e-4)
    # near V* (between 0.1 and 1 m/s) the local slope is alpha = 1/(2u) within 10 %: the
    # quadrature's secant (1.061 alpha), which the simulated one matches within Z_MAX se
    # above; the simulated secant itself scatters by 3-6 % of alpha (seeds 11-14: 1.04 to
    # 1.10 alpha), too much for a 10 % bound around alpha
    near = VELOCITIES.index(0.1)
    assert expected[near] == pytest.approx(joint.alpha, rel=0.1)
    assert float(log_slope(0.3, joint)) == pytest.approx(joint.alpha, rel=0.1)
    # at lab velocities the slope is well above alpha (the linear law fails there)
    assert simulated[0] > 1.5 * joint.alpha


def test_rho_histogram_matches_q_stationary() -> None:
    velocity = 1e-6
    run, result = steady_run(velocity, seed=5, snapshot_every=2, n_contacts=20)
    joint = mean_field_joint(run)
    late = result.snapshot_time > BURN_IN * RHO_MAX / velocity
    rho = (result.block_stress.sel(snapshot_time=late).values.ravel() / 1e8) * joint.rho_max
    edges = np.quantile(
        sample_q_stationary(200_000, velocity, joint, np.random.default_rng(0)),
        np.linspace(0, 1, 41),
    )
    edges[0], edges[-1] = 0.0, joint.rho_max

    def p_value(reference: MeanFieldJoint) -> float:
        expected = np.diff(q_stationary_cdf(edges, velocity, reference)) * rho.size
        observed = np.histogram(rho, edges)[0]
        return float(stats.chisquare(observed, expected * observed.sum() / expected.sum()).pvalue)

    assert rho.size > 200_000
    assert p_value(joint) > SIGNIFICANCE
    warmer = MeanFieldJoint(**{**joint.__dict__, "temperature": 315.0})
    assert p_value(warmer) < 1e-9


def test_kernel_agrees_with_naive_time_stepped_reference() -> None:
    velocity = 1e-6
    run, result = steady_run(velocity, seed=3)
    kernel_stress, kernel_error = measured_stress(result)
    joint = mean_field_joint(run)
    rng = np.random.default_rng(42)
    x = sample_q_stationary(4000, velocity, joint, rng) / joint.rho_max
    cycle = RHO_MAX / velocity
    dt = 1e-7  # hazard per step <~ 0.03 where blocks fire
    samples, _ = simulate_mean_field(
        x,
        velocity,
        joint.rho_max,
        joint.attempt_frequency,
        joint.u,
        12 * cycle,
        dt,
        rng,
        sample_every=int(SPACING * cycle / dt),
    )
    naive = samples[2:] * 1e8
    naive_error = naive.std(ddof=1) / np.sqrt(naive.size)
    assert abs(kernel_stress - naive.mean()) < Z_MAX * np.hypot(kernel_error, naive_error)
