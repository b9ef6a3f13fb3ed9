"""Physics checks of the analytic mean-field theory (001/Eqs. 24-30; physics.md section 1).

Reference joint of physics.md section 4: b = 2.75 nm, sigma_a = 1e8 Pa, E_J = 1e9 Pa,
k1 = E_J b, omega_a = 1e12 1/s, T = 300 K (u ~ 50.2, V* ~ 4.9 m/s). Other values of u are
obtained by changing T only (u is proportional to 1/T), which leaves rho~_max unchanged.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import dawsn
from scipy.stats import kstest

from nanoblock.barriers import BOLTZMANN
from nanoblock.theory import meanfield as mf

B = 2.75e-9
REFERENCE = mf.MeanFieldJoint(
    block_size=B,
    shear_modulus=1e9,
    threshold_stress=1e8,
    k1=1e9 * B,
    attempt_frequency=1e12,
    temperature=300.0,
)
BARRIER_NAMES = ("persson", "spinodal")
U_VALUES = (1.0, 5.0, 50.0, 500.0)
LAB_VELOCITIES = np.logspace(-12, -3, 10)


def joint_at(u: float, barrier: str = "persson") -> mf.MeanFieldJoint:
    """Reference joint with T rescaled so that U_a / k_B T = u."""
    return replace(REFERENCE, temperature=REFERENCE.temperature * REFERENCE.u / u, barrier=barrier)


def quad_survival_moment(power: int, velocity: float, joint: mf.MeanFieldJoint) -> float:
    """Brute force int_0^1 x^power exp(-I(x)) dx with scipy quad in s = ln x.

    Break points where I crosses 10^-3 ... 10^3 (read off a dense grid of ln I, which is
    smooth even where exp(-I) is not) let quad resolve cutoffs as narrow as 1e-3 x_c.
    """
    s_grid = np.linspace(math.log(1e-45), 0.0, 4001)
    log_i = np.log(mf.survival_exponent(np.exp(s_grid) * joint.rho_max, velocity, joint))
    levels = np.log(10.0 ** np.arange(-3.0, 3.01, 0.125))
    inside = (levels > log_i[0]) & (levels < log_i[-1])
    points = np.interp(levels[inside], log_i, s_grid)

    def integrand(s: float) -> float:
        x = math.exp(s)
        return x ** (power + 1) * math.exp(
            -float(mf.survival_exponent(x * joint.rho_max, velocity, joint))
        )

    value, _ = quad(integrand, s_grid[0], 0.0, points=points, limit=2000, epsabs=0.0, epsrel=1e-13)
    return value


# ------------------------------------------------------------------------- the joint


def test_reference_joint_parameters() -> None:
    """u, V*, alpha and v_act of the reference joint agree with physics.md section 4."""
    joint = REFERENCE
    assert joint.u == pytest.approx(50.21, rel=1e-3)
    assert joint.v_star == pytest.approx(4.877, rel=1e-3)
    assert joint.rho_max == pytest.approx(2.75e-10, rel=1e-12)
    # alpha of 001/Eq. 30 equals 1/(2u): two independent formulas for the same number.
    assert joint.alpha == pytest.approx(1.0 / (2.0 * joint.u), rel=1e-12)
    assert joint.barrier_energy == pytest.approx(joint.u * BOLTZMANN * 300.0, rel=1e-12)
    # v_act = k_B T / (alpha sigma_bar) (001/Eqs. 18, 33)
    assert joint.activation_volume == pytest.approx(
        BOLTZMANN * 300.0 / (joint.alpha * joint.sigma_bar), rel=1e-12
    )


@pytest.mark.parametrize(
    "field",
    ["block_size", "shear_modulus", "threshold_stress", "k1", "attempt_frequency", "temperature"],
)
@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_joint_validation_names_field(field: str, bad: float) -> None:
    with pytest.raises(ValueError, match=field):
        replace(REFERENCE, **{field: bad})


def test_joint_validation_unknown_barrier() -> None:
    with pytest.raises(ValueError, match=r"barrier.*persson"):
        replace(REFERENCE, barrier="parabolic")


def test_escape_rate_limits() -> None:
    """1/tau = omega_a e^-u at zero stress, omega_a at the threshold (001/Eqs. 24, 37)."""
    joint = REFERENCE
    rates = mf.escape_rate(np.array([0.0, 0.5, 1.0]), joint)
    expected = joint.attempt_frequency * np.exp(-joint.u * np.array([1.0, 0.75, 0.0]))
    np.testing.assert_allclose(rates, expected, rtol=1e-12)


# ------------------------------------------------------------- survival exponent


@pytest.mark.parametrize("u", U_VALUES)
def test_survival_exponent_dawson_matches_quadrature(u: float) -> None:
    """Persson's closed form (Dawson) and the generic table agree to 1e-10 relative."""
    joint = joint_at(u)
    x = np.concatenate([[1e-25, 1e-8], np.linspace(0.005, 0.995, 199), [0.999999, 1.0]])
    rho = x * joint.rho_max
    for velocity in (1e-15, 1e-6, 1e2):
        closed = mf.survival_exponent(rho, velocity, joint, method="closed_form")
        table = mf.survival_exponent(rho, velocity, joint, method="quadrature")
        np.testing.assert_allclose(table, closed, rtol=1e-10)


@pytest.mark.parametrize("barrier", BARRIER_NAMES)
@pytest.mark.parametrize("u", (1.0, 50.0, 500.0))
def test_survival_exponent_matches_direct_quad(barrier: str, u: float) -> None:
    """I(rho~) against scipy quad of d rho' / (V tau(rho')) (001/Eq. 27), rtol 1e-9."""
    joint = joint_at(u, barrier)
    velocity = 1e-7
    for x in (1e-3, 0.3, 0.8, 0.97, 1.0):
        brute, _ = quad(
            lambda xi: float(mf.escape_rate(xi, joint)) * joint.rho_max / velocity,
            0.0,
            x,
            points=[p for p in (0.5, 0.9, 0.99) if p < x] or None,
            epsabs=0.0,
            epsrel=1e-13,
            limit=500,
        )
        exact = mf.survival_exponent(x * joint.rho_max, velocity, joint)
        assert exact == pytest.approx(brute, rel=1e-9)


@pytest.mark.parametrize("barrier", BARRIER_NAMES)
@pytest.mark.parametrize("u", (1.0, 500.0))
def test_survival_exponent_finite_and_monotone(barrier: str, u: float) -> None:
    joint = joint_at(u, barrier)
    rho = np.linspace(0.0, 1.0, 501) * joint.rho_max
    exponents = mf.survival_exponent(rho[None, :], np.logspace(-15, 2, 18)[:, None], joint)
    assert np.all(np.isfinite(exponents))
    assert np.all(exponents[:, 0] == 0.0)
    assert np.all(np.diff(exponents, axis=1) > 0.0)
    assert mf.survival_exponent(1.01 * joint.rho_max, 1e-6, joint) == np.inf


# ----------------------------------------------------------- stationary density


@pytest.mark.parametrize("barrier", BARRIER_NAMES)
@pytest.mark.parametrize("u", U_VALUES)
def test_q_stationary_normalised_nonnegative(barrier: str, u: float) -> None:
    """Q_st >= 0, finite, zero outside [0, rho_max] and of unit mass (brute quad, 1e-10)."""
    joint = joint_at(u, barrier)
    velocities = np.logspace(-15, 2, 18)
    rho = np.linspace(-0.1, 1.1, 1201) * joint.rho_max
    density = mf.q_stationary(rho[None, :], velocities[:, None], joint)
    assert np.all(np.isfinite(density))
    assert np.all(density >= 0.0)
    outside = (rho < 0.0) | (rho > joint.rho_max)
    assert np.all(density[:, outside] == 0.0)
    for velocity in velocities[::4]:
        # Q_st(0) = 1/Z, so Q_st(0) * int_0^rho_max exp(-I) d rho~ must equal 1.
        mass = float(mf.q_stationary(0.0, velocity, joint)) * joint.rho_max
        mass *= quad_survival_moment(0, velocity, joint)
        assert mass == pytest.approx(1.0, rel=1e-10)


@pytest.mark.parametrize("barrier", BARRIER_NAMES)
def test_q_stationary_cdf_matches_quad(barrier: str) -> None:
    """CDF around the cutoff against brute-force quad of Q_st = Q_st(0) exp(-I), abs 1e-10."""
    joint = replace(REFERENCE, barrier=barrier)
    for velocity in (1e-12, 1e-6, 1.0):
        rho_c = float(mf.cutoff_rho(velocity, joint))
        rho = np.minimum(rho_c * np.array([0.0, 0.5, 0.99, 1.0, 1.01]), joint.rho_max)
        cdf = mf.q_stationary_cdf(rho, velocity, joint)
        q0 = float(mf.q_stationary(0.0, velocity, joint))

        def density(r: float, velocity: float = velocity, q0: float = q0) -> float:
            return q0 * math.exp(-float(mf.survival_exponent(r, velocity, joint)))

        for r, value in zip(rho[1:], cdf[1:], strict=True):
            brute, _ = quad(density, 0.0, r, epsabs=1e-14, epsrel=1e-12, limit=200)
            assert value == pytest.approx(brute, abs=1e-10)
        assert cdf[0] == 0.0
    assert mf.q_stationary_cdf(joint.rho_max, 1e-6, joint) == pytest.approx(1.0, abs=1e-14)


def test_sample_q_stationary_follows_q_st() -> None:
    """Samples pass a KS test against the CDF and reproduce sigma_s within 5 std errors."""
    joint = REFERENCE
    velocity = 1e-6
    rho = mf.sample_q_stationary(50_000, velocity, joint, rng=np.random.default_rng(7))
    assert rho.shape == (50_000,)
    assert np.all((rho >= 0.0) & (rho <= joint.rho_max))
    result = kstest(rho, lambda r: mf.q_stationary_cdf(r, velocity, joint))
    assert result.pvalue > 1e-3
    stress = joint.k1 * rho / joint.block_size**2
    error = stress.std() / math.sqrt(stress.size)
    assert abs(stress.mean() - float(mf.steady_stress(velocity, joint))) < 5.0 * error


# ----------------------------------------------------------------- steady stress


@pytest.mark.parametrize("barrier", BARRIER_NAMES)
@pytest.mark.parametrize("u", U_VALUES)
def test_steady_stress_bounded_monotone(barrier: str, u: float) -> None:
    """0 < sigma_s <= sigma_bar (x_f <= 1), finite and strictly increasing in V."""
    joint = joint_at(u, barrier)
    stress = mf.steady_stress(np.logspace(-15, 2, 69), joint)
    assert np.all(np.isfinite(stress))
    assert np.all(stress > 0.0)
    assert np.all(stress <= joint.sigma_bar * (1.0 + 1e-12))
    assert np.all(np.diff(stress) > 0.0)


@pytest.mark.parametrize("barrier", BARRIER_NAMES)
@pytest.mark.parametrize("u", (5.0, 50.0, 500.0))
def test_steady_stress_matches_brute_force(barrier: str, u: float) -> None:
    """001/Eq. 28 by brute-force scipy quad (N_1 / N_0) agrees to 1e-9 relative."""
    joint = joint_at(u, barrier)
    for velocity in (1e-12, 1e-6, 1e-3, 10.0):
        brute = (
            joint.threshold_stress
            * quad_survival_moment(1, velocity, joint)
            / quad_survival_moment(0, velocity, joint)
        )
        assert mf.steady_stress(velocity, joint) == pytest.approx(brute, rel=1e-9)


@pytest.mark.parametrize(("u", "rtol"), [(500.0, 1e-6), (50.0, 3e-4)])
def test_steady_stress_matches_large_u_asymptotics(u: float, rtol: float) -> None:
    """sigma_s = sigma_a E[x_f^2] / (2 E[x_f]) -> sigma_a x_f / 2 at large u.

    Derivation of the tolerance: near the cutoff ln I(x) ~ ln(Lambda e^{-u(1-x^2)} / (2ux))
    and ln I at firing is Gumbel distributed (mean -gamma_E, variance pi^2 / 6). The
    neglected terms are the Dawson correction 1 / (2 u x^2) to I, and the Gumbel spread
    (width 1 / (2 u x) in x) entering E[x^2] / E[x] and the curvature of x(ln I): all give
    relative corrections O(1 / (2 u x_f^2)^2). Measured: 2e-7 at u = 500, 1.5e-4 at u = 50.
    """
    joint = joint_at(u)
    exact = mf.steady_stress(LAB_VELOCITIES, joint)
    asymptotic = mf.steady_stress_asymptotic(LAB_VELOCITIES, joint)
    np.testing.assert_allclose(exact, asymptotic, rtol=rtol)
    x_f = mf.firing_stress_asymptotic(LAB_VELOCITIES, joint)
    np.testing.assert_allclose(
        joint.u * (1 - x_f**2),
        np.log(
            math.exp(mf.EULER_GAMMA)
            * joint.attempt_frequency
            * joint.rho_max
            / (2 * joint.u * LAB_VELOCITIES * x_f)
        ),
        rtol=1e-12,
    )


def test_steady_stress_matches_firing_renewal_monte_carlo() -> None:
    """Renewal picture: firing stresses drawn from survival exp(-I) reproduce
    E[x_f] = mean_firing_reduced_stress and sigma_s = sigma_a E[x_f^2] / (2 E[x_f]).

    u = 5 and V = V*/2: broad firing distribution with ~25 % deterministic releases at
    rho_max, a regime far from the large-u asymptotics. Tolerance 5 standard errors.
    """
    joint = joint_at(5.0)
    velocity = joint.v_star / 2
    rng = np.random.default_rng(11)
    targets = rng.exponential(size=40_000)
    lo, hi = np.zeros_like(targets), np.ones_like(targets)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        fired = mf.survival_exponent(mid * joint.rho_max, velocity, joint) > targets
        lo, hi = np.where(fired, lo, mid), np.where(fired, mid, hi)
    x_f = 0.5 * (lo + hi)
    released = np.mean(x_f > 1 - 1e-12)
    assert 0.05 < released < 0.5
    mean = float(mf.mean_firing_reduced_stress(velocity, joint))
    assert abs(x_f.mean() - mean) < 5 * x_f.std() / math.sqrt(x_f.size)
    ratio = float(mf.steady_stress(velocity, joint)) / joint.threshold_stress
    mc_ratio = np.mean(x_f**2) / (2 * x_f.mean())
    # delta method: standard error of E[x^2] / (2 E[x]) is below that of x^2 / (2 E[x])
    error = np.std(x_f**2 / (2 * x_f.mean()) - mc_ratio * x_f / x_f.mean()) / math.sqrt(x_f.size)
    assert abs(mc_ratio - ratio) < 5 * error


def test_saturation_above_v_star() -> None:
    """sigma_s -> sigma_bar for V >> V* (001/Fig. 15); the asymptotics saturate at x_f = 1."""
    joint = REFERENCE
    velocity = 100 * joint.v_star
    assert mf.steady_stress(velocity, joint) == pytest.approx(joint.sigma_bar, rel=1e-4)
    assert mf.firing_stress_asymptotic(np.array([1.0, 10.0]) * joint.v_star, joint) == (
        pytest.approx([1.0, 1.0], abs=1e-12)
    )
    assert mf.firing_stress_asymptotic(0.99 * joint.v_star, joint) < 1.0
    assert mf.log_slope_asymptotic(2 * joint.v_star, joint) == 0.0


# ---------------------------------------------------------------- local slope


@pytest.mark.parametrize("barrier", BARRIER_NAMES)
def test_log_slope_matches_finite_difference(barrier: str) -> None:
    """Analytic d ln sigma_s / d ln V against a 5-point central difference (step 5e-3)."""
    joint = replace(REFERENCE, barrier=barrier)
    velocities = np.logspace(-14, 1, 8)
    step = 5e-3
    log_s = [np.log(mf.steady_stress(velocities * math.exp(k * step), joint)) for k in range(-2, 3)]
    difference = (log_s[0] - 8 * log_s[1] + 8 * log_s[3] - log_s[4]) / (12 * step)
    np.testing.assert_allclose(mf.log_slope(velocities, joint), difference, rtol=1e-8)


@pytest.mark.parametrize(("u", "rtol"), [(500.0, 1e-5), (50.0, 1e-3)])
def test_log_slope_matches_asymptotics(u: float, rtol: float) -> None:
    """Slope vs 1 / (2 u x_f^2 - 1) at lab velocities (measured 8e-7 at u=500, 7e-4 at 50)."""
    joint = joint_at(u)
    x_f = mf.firing_stress_asymptotic(LAB_VELOCITIES, joint)
    formula = 1.0 / (2 * joint.u * x_f**2 - 1)
    np.testing.assert_allclose(mf.log_slope_asymptotic(LAB_VELOCITIES, joint), formula, rtol=1e-8)
    np.testing.assert_allclose(mf.log_slope(LAB_VELOCITIES, joint), formula, rtol=rtol)


def test_log_slope_tends_to_alpha_near_v_star() -> None:
    """Slope -> alpha = 1/(2u) as V -> V* (measured 1.056 alpha at u=50, 1.002 at u=500).

    Closer to V* the truncation at rho~_max takes over: at V* itself the slope is only
    ~0.44 alpha, and it vanishes above (saturation).
    """
    for u, rtol in ((50.0, 0.08), (500.0, 0.005)):
        joint = joint_at(u)
        assert mf.log_slope(joint.v_star / 10, joint) == pytest.approx(joint.alpha, rel=rtol)
        assert mf.log_slope(joint.v_star, joint) < 0.6 * joint.alpha
    joint = REFERENCE
    lab_slope = mf.log_slope(1e-9, joint)
    assert 1.5 * joint.alpha < lab_slope < 2.5 * joint.alpha  # "up to 2x" at lab velocities
    near = mf.log_slope_asymptotic(joint.v_star * (1 - 1e-9), joint)
    assert near == pytest.approx(1 / (2 * joint.u - 1), rel=1e-6)


def test_linear_log_law_is_not_the_reference() -> None:
    """001/Eq. 30 is off by 1-7 % at lab velocities (so tests use the exact quadrature),
    but is the linearisation of the exact result near V* (0.5 % at V*/10)."""
    joint = REFERENCE
    velocities = np.logspace(-10, -5, 6)
    deviation = np.abs(
        mf.steady_stress_loglaw(velocities, joint) / mf.steady_stress(velocities, joint) - 1
    )
    assert np.all((deviation > 0.01) & (deviation < 0.07))
    assert mf.steady_stress_loglaw(1e-9, joint) != pytest.approx(
        mf.steady_stress(1e-9, joint), rel=5e-3
    )
    assert mf.steady_stress_loglaw(joint.v_star / 10, joint) == pytest.approx(
        mf.steady_stress(joint.v_star / 10, joint), rel=5e-3
    )


# -------------------------------------------------------------------- the cutoff


@pytest.mark.parametrize("barrier", BARRIER_NAMES)
def test_cutoff_increases_and_marks_the_drop(barrier: str) -> None:
    """rho~_c (001/Eq. 29) increases with V and sits where Q_st has fallen to ~Q0 / e.

    At large u, I(rho~_c) = 1 + O(1 / (u x_c^2)) (Laplace estimate of 001/Eq. 27):
    measured 1.01-1.03 (Persson) and 0.97-0.99 (spinodal) at u = 50.
    """
    joint = replace(REFERENCE, barrier=barrier)
    rho_c = mf.cutoff_rho(LAB_VELOCITIES, joint)
    assert np.all(np.diff(rho_c) > 0.0)
    assert np.all((rho_c > 0.0) & (rho_c < joint.rho_max))
    ratio = mf.q_stationary(rho_c, LAB_VELOCITIES, joint) / mf.q_stationary(
        0.0, LAB_VELOCITIES, joint
    )
    assert np.all((ratio > math.exp(-1.1)) & (ratio < math.exp(-0.9)))


def test_cutoff_persson_exact_relation() -> None:
    """For Persson's law Eq. 29 gives I(rho~_c) = 2 y D(y), y = sqrt(u) x_c, exactly."""
    joint = joint_at(500.0)
    rho_c = mf.cutoff_rho(LAB_VELOCITIES, joint)
    y = math.sqrt(joint.u) * rho_c / joint.rho_max
    np.testing.assert_allclose(
        mf.survival_exponent(rho_c, LAB_VELOCITIES, joint), 2 * y * dawsn(y), rtol=1e-10
    )
    above = joint.v_star * math.exp(-mf.EULER_GAMMA) * 1.01
    assert mf.cutoff_rho(above, joint) == joint.rho_max


def test_no_asymptotic_root_in_the_creep_regime() -> None:
    """At u = 1 and tiny V blocks creep off at ~zero stress: no cutoff, no x_f (NaN)."""
    joint = joint_at(1.0)
    assert np.isnan(mf.cutoff_rho(1e-12, joint))
    assert np.isnan(mf.firing_stress_asymptotic(1e-12, joint))
    assert np.isfinite(mf.steady_stress(1e-12, joint))


# ------------------------------------------------------------- spinodal barrier


def excess_exponent(joint: mf.MeanFieldJoint, velocities: np.ndarray) -> float:
    """Fitted p in sigma_bar - sigma_s ~ ln(V*/V)^p."""
    excess = joint.sigma_bar - mf.steady_stress(velocities, joint)
    return float(np.polyfit(np.log(np.log(joint.v_star / velocities)), np.log(excess), 1)[0])


def test_spinodal_excess_scales_with_two_thirds_power() -> None:
    """Saddle-node barrier (1 - x)^(3/2): 1 - x_f = (ln(.../V) / u)^(2/3), so the excess
    sigma_bar - sigma_s ~ ln(V*/V)^(2/3) (001 after Eq. 33), while Persson's law gives an
    exponent >= 1 (1 - sqrt(1 - L/u)); fits over three decades (measured 0.65 and 1.23).
    """
    velocities = np.logspace(-12, -9, 7)
    spinodal = replace(REFERENCE, barrier="spinodal")
    assert excess_exponent(spinodal, velocities) == pytest.approx(2 / 3, abs=0.1)
    assert excess_exponent(REFERENCE, velocities) > 1.0
    # Different curvature: the spinodal law's slope is several times Persson's.
    ratio = mf.log_slope(LAB_VELOCITIES, spinodal) / mf.log_slope(LAB_VELOCITIES, REFERENCE)
    assert np.all(ratio > 2.0)
    # the generic asymptotics follow the quadrature (within 1 % at u = 50)
    np.testing.assert_allclose(
        mf.steady_stress_asymptotic(LAB_VELOCITIES, spinodal),
        mf.steady_stress(LAB_VELOCITIES, spinodal),
        rtol=1e-2,
    )
