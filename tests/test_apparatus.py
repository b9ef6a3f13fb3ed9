"""The silicon apparatus of 000 (Eqs. 9-14): presets, protocols, force balance, and the
shapes of 000/Figs. 2-3 with the Table 1-2 parameters."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nanoblock.rsf.apparatus import (
    APPARATUS,
    FIG2_NORMAL_FORCE,
    FIG2_PROTOCOL,
    FIG3_NORMAL_FORCES,
    FIG3_PROTOCOL,
    K_EXT,
    K_F,
    SURFACES,
    Apparatus,
    ExtensionProtocol,
    solve_apparatus,
)
from nanoblock.rsf.laws import LAWS, law
from tests.diagnosis_synthetic import naive_clamped
from tests.naive_rsf import naive_slider
from tests.test_rsf_laws import EXAMPLES
from tests.tolerances import (
    APPARATUS_BALANCE_RTOL,
    BENT_OVER_SLOPE,
    CREEP_SLOPE_RTOL,
    NAIVE_RSF_ATOL,
    PLATEAU_RTOL,
    PRINTED_RTOL,
)

SILICON = APPARATUS["silicon"]
SI_STEEL_1 = SURFACES["si_steel_1"]
SI_STEEL_2 = SURFACES["si_steel_2"]


def test_quartz_c_values_follow_from_k_values() -> None:
    """000/Eqs. 12-13 reproduce Table 1's quartz c-values from its k-values."""
    printed, derived = APPARATUS["quartz"], APPARATUS["quartz_from_k"]
    assert derived.c_ext == pytest.approx(printed.c_ext, rel=PRINTED_RTOL)
    assert derived.c_x == pytest.approx(printed.c_x, rel=PRINTED_RTOL)


def test_silicon_c_values_follow_from_transposed_k_s() -> None:
    """Table 1's silicon c-values are not Eqs. 12-13 of k_s = 279 N/um, but of 297 N/um."""
    printed, derived = APPARATUS["silicon"], APPARATUS["silicon_from_k"]
    assert derived.c_x == pytest.approx(266.7e6, rel=1e-3)
    assert abs(derived.c_x / printed.c_x - 1) > 0.05
    transposed = Apparatus.from_stiffnesses(297e6, K_F, K_EXT)
    assert transposed.c_ext == pytest.approx(printed.c_ext, rel=PRINTED_RTOL)
    assert transposed.c_x == pytest.approx(printed.c_x, rel=PRINTED_RTOL)


@pytest.mark.parametrize("name", sorted(SURFACES))
def test_surface_b_reproduces_table_2_static_coefficient(name: str) -> None:
    surface = SURFACES[name]
    assert law("silicon").static_friction(surface.params) == pytest.approx(surface.mu_s, rel=1e-12)


def test_protocols_of_figs_2_and_3() -> None:
    np.testing.assert_allclose(
        FIG2_PROTOCOL.extension_at([16, 300, 316, 1200]), [30e-6, 30e-6, 60e-6, 120e-6]
    )
    assert FIG2_PROTOCOL.times[-1] == 1200.0
    np.testing.assert_allclose(FIG3_PROTOCOL.rates, [127e-6 / 370])


@pytest.mark.parametrize(
    ("times", "extensions", "message"),
    [
        ([0, 1, 2], [0, 2e-6, 1e-6], "must not decrease"),
        ([0, 1], [-1e-6, 2e-6], "must be >= 0"),
        ([0, 0], [0, 1e-6], "increase strictly"),
        ([0], [0], "length >= 2"),
    ],
)
def test_protocol_rejects_bad_knots(times, extensions, message) -> None:
    with pytest.raises(ValueError, match=message):
        ExtensionProtocol(np.array(times, dtype=float), np.array(extensions, dtype=float))


def test_solver_rejects_bad_inputs() -> None:
    silicon = law("silicon")
    with pytest.raises(ValueError, match="normal force"):
        solve_apparatus(silicon, SI_STEEL_2.params, SILICON, 0.0, FIG3_PROTOCOL)
    with pytest.raises(ValueError, match="from t >= 0"):
        solve_apparatus(silicon, SI_STEEL_2.params, SILICON, 100.0, FIG3_PROTOCOL, [-1.0, 1.0])
    with pytest.raises(ValueError, match="initial_state"):
        solve_apparatus(law("aging"), EXAMPLES["aging"], SILICON, 100.0, FIG3_PROTOCOL)
    preloaded = ExtensionProtocol(np.array([0.0, 1.0]), np.array([100e-6, 101e-6]))
    with pytest.raises(ValueError, match="carries the preload"):
        solve_apparatus(silicon, SI_STEEL_2.params, SILICON, 100.0, preloaded)


def _fig3_run(name: str, apparatus: Apparatus, normal_force: float = 300.0):
    """The Fig. 3 ramp by ``solve_apparatus`` at 41 samples, with its protocol and start.

    Laws without a rest state (mu ~ ln v, ln theta) start sliding steadily at v0 = 1 um/s
    under the preload s_ext(0) = 2 mu_ss(v0) N / c_ext, then follow the ramp; the others
    start at rest from a fresh contact."""
    lw, params = law(name), EXAMPLES[name]
    protocol, initial, v0 = FIG3_PROTOCOL, None, None
    if not lw.allows_rest:
        v0 = 1e-6
        initial = [float(s) for s in lw.steady_state(v0, lw.pack(params))]
        preload = 2.0 * normal_force * float(lw.steady_friction(v0, params)) / apparatus.c_ext
        protocol = ExtensionProtocol(FIG3_PROTOCOL.times, FIG3_PROTOCOL.extensions + preload)
    times = np.linspace(0.0, 370.0, 41)
    run = solve_apparatus(
        lw, params, apparatus, normal_force, protocol, times, initial_state=initial
    )
    return run, protocol, v0


@pytest.mark.parametrize("name", sorted(LAWS))
def test_force_balance_and_output_contract_for_every_law(name: str) -> None:
    """000/Eqs. 9 and 14b at every sample, with mu evaluated by the law at the returned
    slip velocity and state (the solver's own mu is the elastic stress, the balance by
    construction, so only the law's mu can fail it); every variable carries units and a
    name."""
    lw, normal_force = law(name), 300.0
    ds, protocol, v0 = _fig3_run(name, SILICON, normal_force)
    if v0 is not None:
        assert protocol.extensions[0] > 0.0
        assert float(ds.v[0]) == pytest.approx(v0, rel=1e-9)
    np.testing.assert_array_equal(ds.time, np.linspace(0.0, 370.0, 41))
    assert set(ds.data_vars) >= {"s_ext", "s", "x", "mu", "v", *lw.state_names}
    for variable in [ds.time, *ds.data_vars.values()]:
        assert variable.attrs["units"] and variable.attrs["long_name"]
    p = lw.pack(EXAMPLES[name])
    states = np.column_stack([ds[state].values for state in lw.state_names])
    mu = [lw.friction(lw.coordinate(v, p), s, p) for v, s in zip(ds.v.values, states, strict=True)]
    load = 2.0 * normal_force * np.array(mu)
    residual = SILICON.c_ext * ds.s_ext.values - SILICON.c_x * ds.x.values - load
    scale = 2.0 * normal_force * SI_STEEL_2.mu_s
    assert float(np.abs(residual).max()) < APPARATUS_BALANCE_RTOL * scale
    np.testing.assert_allclose(ds.s, 2.0 * normal_force * ds.mu / SILICON.k_s, rtol=1e-14)


@pytest.mark.parametrize("name", ["aging", "slip", "cutoff", "saturation"])
def test_slip_matches_the_naive_spring_slider(name: str) -> None:
    """The apparatus is a spring-slider of K/W = c_x / 2N driven at c_ext s_ext' / c_x
    (000/Eq. 14b): its mu, hence the slip x = (c_ext s_ext - 2 mu N) / c_x, agrees with
    the naive Radau integration in (mu, theta) (``tests/naive_rsf.py``)."""
    normal_force = 300.0
    ds, _, v0 = _fig3_run(name, SILICON, normal_force)
    drive = float(FIG3_PROTOCOL.rates[0]) * SILICON.c_ext / SILICON.c_x
    stiffness = SILICON.c_x / (2.0 * normal_force)
    reference = naive_slider(
        name, EXAMPLES[name], [(drive, 370.0)], ds.time.values, stiffness, initial_velocity=v0
    )
    np.testing.assert_allclose(ds.mu, reference, rtol=0, atol=NAIVE_RSF_ATOL)


@pytest.mark.parametrize("name", ["silicon", "two_state"])
def test_sample_extension_matches_the_naive_clamped_sample(name: str) -> None:
    """From rest on the Table 1 k-values (Eqs. 12-13), s(t) agrees with the naive Radau
    integration of 000/Eqs. 4-5, 9-14 in natural variables (``naive_clamped``), to
    ``NAIVE_RSF_ATOL`` in mu."""
    apparatus, normal_force = APPARATUS["silicon_from_k"], 300.0
    ds, _, _ = _fig3_run(name, apparatus, normal_force)
    rate = float(FIG3_PROTOCOL.rates[0])
    reference = naive_clamped(EXAMPLES[name], normal_force, rate, ds.time.values)
    atol = NAIVE_RSF_ATOL * 2.0 * normal_force / apparatus.k_s
    np.testing.assert_allclose(ds.s, reference, rtol=0, atol=atol)


def test_two_state_law_without_aging_is_the_silicon_law() -> None:
    """000/Eqs. 4-5 reduce to Eq. 7 when phi stays 0 (aging rate -> 0)."""
    times = np.linspace(0.0, 370.0, 75)
    silicon = solve_apparatus(
        law("silicon"), SI_STEEL_2.params, SILICON, 300.0, FIG3_PROTOCOL, times
    )
    params = {**SI_STEEL_2.params, "aging_rate": 1e-15}
    two = solve_apparatus(law("two_state"), params, SILICON, 300.0, FIG3_PROTOCOL, times)
    np.testing.assert_allclose(two.s, silicon.s, rtol=1e-6, atol=1e-6 * float(silicon.s.max()))


def test_fig2_steps_slip_then_creep_back_logarithmically() -> None:
    """000/Fig. 2 (Si/steel 1, N = 467 N): each 30 um step extends the sample by about a
    fifth of the no-slip c_ext 30 um / k_s; during each 284 s hold s decreases, and from
    1 s into the hold ds/d ln(t - t_hold) is the slope derived in ``CREEP_SLOPE_RTOL`` in
    each half of the hold (split at the geometric mean time, beta at that half's mean
    theta): logarithmic creep, where a creep linear in t would change that slope by the
    ratio of the halves' times, ~17."""
    normal_force = FIG2_NORMAL_FORCE
    times = np.linspace(0.0, FIG2_PROTOCOL.times[-1], 2401)
    ds = solve_apparatus(
        law("silicon"), SI_STEEL_1.params, SILICON, normal_force, FIG2_PROTOCOL, times
    )
    rigid = SILICON.c_ext * 30e-6 / SILICON.k_s
    first = float(ds.s.sel(time=16.0))
    assert 0.6 < 1.0 - first / rigid < 0.9, "000 reports ~4/5 of the step lost to slip"
    p = SI_STEEL_1
    holds = zip(FIG2_PROTOCOL.times[1::2], FIG2_PROTOCOL.times[2::2], strict=True)
    for start, end in holds:
        hold = ds.sel(time=slice(start + 1.0, end))
        elapsed, s = hold.time.values - start, hold.s.values
        assert np.all(np.diff(s) < 0.0)
        middle = math.sqrt(elapsed[0] * elapsed[-1])
        for half in (elapsed <= middle, elapsed > middle):
            slope = np.polyfit(np.log(elapsed[half]), s[half], 1)[0]
            theta = float(hold.theta[half].mean())
            beta = (2 * normal_force * p.b * (1 - theta)) / (
                (p.theta_star + theta) * SILICON.c_x * p.dc
            )
            expected = -2 * normal_force * p.a / (SILICON.k_s * (1 + beta))
            print(f"hold from {start:.0f} s: ds/dln t / derived - 1 = {slope / expected - 1:+.4f}")
            assert slope == pytest.approx(expected, rel=CREEP_SLOPE_RTOL)


@pytest.mark.parametrize("normal_force", FIG3_NORMAL_FORCES)
def test_fig3_ramp_bends_over_to_static_threshold(normal_force: float) -> None:
    """000/Fig. 3 (Si/steel 2, s_ext 0 -> 127 um in 370 s): s rises, concave, and levels
    off at 2 mu_s N / k_s, mu_s = B ln(1 + 1/theta*) (000/Eq. 8)."""
    ds = solve_apparatus(law("silicon"), SI_STEEL_2.params, SILICON, normal_force, FIG3_PROTOCOL)
    s, s_ext = ds.s.values, ds.s_ext.values
    plateau = SILICON.sample_extension(normal_force, SI_STEEL_2.mu_s)
    slope = np.gradient(s, s_ext)
    rigid = SILICON.c_ext / SILICON.k_s
    assert np.all(np.diff(s) > 0.0)
    assert np.all(np.diff(slope) < 1e-6 * rigid)
    assert s[-1] == pytest.approx(plateau, rel=PLATEAU_RTOL)
    assert slope[-1] < BENT_OVER_SLOPE * rigid
    assert math.isclose(float(s.max()), s[-1])
