"""Kernels against closed forms and naive references: streams, hazard, depinning, landing."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.integrate import quad
from scipy.special import dawsn

from nanoblock.barriers import barrier_law
from nanoblock.kernels import hazard
from nanoblock.kernels.blocks import (
    _SPLIT_CANDIDATES,
    _split_edge,
    advance_free_blocks,
    landing_overshoot,
    next_depinning,
)
from nanoblock.kernels.chain import cluster_workspace, integrate_cluster, reduced_stress
from nanoblock.kernels.contacts import log_one_plus
from nanoblock.kernels.rng import next_uint64, seed_streams, standard_exponential
from nanoblock.tables import EXACT_SEED, hazard_table, lattice_hazard_table
from tests.tolerances import HAZARD_RTOL, LANDING_EXACT_RTOL, SIGNIFICANCE


def test_xoshiro_reference_vector() -> None:
    # first outputs of xoshiro256** from state {1, 2, 3, 4} (reference C implementation)
    state = np.array([1, 2, 3, 4], dtype=np.uint64)
    assert [int(next_uint64(state)) for _ in range(4)] == [
        11520,
        0,
        1509978240,
        1215971899390074240,
    ]


def test_streams_are_distinct_and_exponential() -> None:
    streams = seed_streams(7, 3)
    assert len({tuple(row) for row in streams}) == 3
    draws = np.array([standard_exponential(streams[0]) for _ in range(20000)])
    assert stats.kstest(draws, "expon").pvalue > SIGNIFICANCE


@pytest.mark.parametrize("u", [1.0, 50.21, 500.0])
def test_persson_cumulative_hazard_matches_dawson(u: float) -> None:
    table = hazard_table("persson", u)
    for x in np.linspace(1e-6, 1.0, 97):
        exact = np.exp(-u * (1 - x * x)) * dawsn(np.sqrt(u) * x) / np.sqrt(u)
        assert hazard.cumulative(x, table) == pytest.approx(exact, rel=HAZARD_RTOL * u)


@pytest.mark.parametrize("barrier", ["persson", "spinodal"])
def test_cumulative_hazard_matches_quadrature_and_inverts(barrier: str) -> None:
    u = 50.21
    law = barrier_law(barrier)
    table = hazard_table(barrier, u)
    for x in [1e-3, 0.2, 0.5, 0.8, 0.95, 0.999]:
        exact = quad(lambda s: np.exp(-u * law(s)), 0, x, epsabs=0, epsrel=1e-13, limit=200)[0]
        value = hazard.cumulative(x, table)
        assert value == pytest.approx(exact, rel=1e-7)
        assert hazard.inverse_cumulative(value, table) == pytest.approx(x, rel=1e-12)
        assert hazard.signed_cumulative(-x, table) == -value
        assert hazard.rate(x, table) == pytest.approx(np.exp(-u * law(x)), rel=1e-6)


@pytest.mark.parametrize("u", [2.0, 50.21, 300.0])
@pytest.mark.parametrize("barrier", ["persson", "spinodal"])
def test_inverse_hazard_is_exact_over_the_whole_range(barrier: str, u: float) -> None:
    """R^-1 (cubic inverse table, then safeguarded Newton) hits the level to 1e-12 across
    every decade of R on both branches of a back-jump table, and recovers x to 1e-12 on
    the forward branch. (The reverse rate of a high barrier underflows, so R goes flat and
    x is defined there only as far as R resolves it; a seed too coarse for the kernel's
    single Newton step, or a stall in a flat cell, would show in the level.)"""
    table = lattice_hazard_table(barrier, u, 0.5 * u)
    x = np.concatenate((np.geomspace(1e-9, 1e-3, 50), np.linspace(1e-3, 1.0, 4001)[:-1]))
    for sign in (1.0, -1.0):
        levels = np.array([hazard.signed_cumulative(sign * xi, table) for xi in x])
        back = np.array([hazard.signed_inverse(level, table) for level in levels])
        again = np.array([hazard.signed_cumulative(xi, table) for xi in back])
        np.testing.assert_allclose(again, levels, rtol=1e-12, atol=0)
        if sign > 0:
            np.testing.assert_allclose(back, x, rtol=1e-12, atol=0)


@pytest.mark.parametrize("u", [50.21, 300.0])
@pytest.mark.parametrize("barrier", ["persson", "spinodal"])
def test_seed_taken_as_the_inverse_only_where_it_is_exact(barrier: str, u: float) -> None:
    """Between the header's levels the kernels return the inverse table's seed without
    Newton: at 20,001 levels there (every inverse-table cell, several points each), R of
    the returned x is the level to 1e-12, as Newton's result is everywhere. The reference
    joint (persson, u = 50.21) takes the seed from ln R = -20 up to R(1), where its
    thermal escapes happen."""
    table = hazard_table(barrier, u)
    low, high = table[EXACT_SEED], table[EXACT_SEED + 1]
    if barrier == "persson" and u == 50.21:
        assert low < -20.0 and high == table[3]
    levels = np.exp(np.linspace(low, high, 20001)[:-1])
    back = [hazard.inverse_cumulative(level, table) for level in levels]
    again = np.array([hazard.cumulative(x, table) for x in back])
    np.testing.assert_allclose(again, levels, rtol=1e-12, atol=0)


def naive_firing_cdf(x0: float, x_rate: float, omega_a: float, u: float, x: np.ndarray):
    """P(depinned before reduced stress x) on the ramp, by direct quadrature of 001/Eq. 24."""
    hazards = [
        omega_a / x_rate * quad(lambda s: np.exp(-u * (1 - s * s)), x0, xi, epsrel=1e-12)[0]
        for xi in x
    ]
    return 1 - np.exp(-np.array(hazards))


def test_next_depinning_is_the_exact_time_dependent_poisson_process() -> None:
    u, omega_a, x_rate, x0 = 50.21, 1e12, 1e-6 / 2.75e-10, 0.3
    table = hazard_table("persson", u)
    rng = np.random.default_rng(5)
    fired = []
    for threshold in rng.standard_exponential(4000):
        t, x, left = next_depinning(x0, threshold, x_rate, 1.0, omega_a, table)
        assert left == 0.0 and t == pytest.approx((x - x0) / x_rate)
        fired.append(x)
    fired = np.array(fired)
    assert fired.max() < 1.0  # thermal escape long before sigma_a at this rate
    result = stats.kstest(
        fired, lambda x: naive_firing_cdf(x0, x_rate, omega_a, u, np.atleast_1d(x))
    )
    assert result.pvalue > SIGNIFICANCE


@pytest.mark.parametrize("u", [2.0, 50.21, 300.0])
@pytest.mark.parametrize("barrier", ["persson", "spinodal"])
def test_rate_bounds_dominate_the_kernel_rate(barrier: str, u: float) -> None:
    """Thinning is exact only if omega_a r(x) never exceeds the bound it is thinned under:
    bound k is at least the kernel's interpolated rate anywhere below its cell's top (the
    forward branch of a back-jump table too), and within 2 % of the largest such rate
    (looser bounds would cost candidates, not accuracy). The tabulated R at the cells'
    edges, where a split ramp's exact part starts, is the kernel's R there."""
    for table in (hazard_table(barrier, u), lattice_hazard_table(barrier, u, 0.5 * u)):
        offset, cells, lowest = hazard.rate_cells(table)
        assert offset > 0 and cells == 64
        assert lowest == (0.0 if table[5] else -(1.0 - 2.0**-53))
        bounds = table[offset : offset + cells]
        x = np.linspace(0.0, 1.0, cells * 200 + 1)
        rates = np.array([hazard.rate(xi, table) for xi in x])
        highest = np.maximum.accumulate(rates)
        below = np.minimum((x * cells).astype(int), cells - 1)
        assert np.all(rates <= bounds[below])
        tops = highest[200::200]
        assert np.all(bounds >= tops) and np.all(bounds <= 1.02 * tops)
        edges = [hazard.cumulative(k / cells, table) for k in range(cells + 1)]
        np.testing.assert_allclose(table[offset + cells :][: cells + 1], edges, rtol=1e-12)


@pytest.mark.parametrize("barrier", ["persson", "spinodal"])
def test_split_edge_bisection_is_the_linear_scan(barrier: str) -> None:
    """The split edge of a rising ramp (the highest cell edge whose bound gives at most
    _SPLIT_CANDIDATES candidates over the call) found by bisection equals the naive scan
    down from the top cell, for calls from 1e-20 s to 1e5 s and for a table without bounds."""
    omega_a = 1e12

    def scan(table: np.ndarray, offset: int, cells: int, duration: float) -> int:
        edge = cells
        while edge > 0 and omega_a * table[offset + edge - 1] * duration > _SPLIT_CANDIDATES:
            edge -= 1
        return edge

    for table in (hazard_table(barrier, 50.21), lattice_hazard_table(barrier, 50.21, 25.0)):
        offset, cells, _ = hazard.rate_cells(table)
        durations = np.concatenate(([0.0], np.logspace(-20.0, 5.0, 2001)))
        found = [_split_edge(table, offset, cells, omega_a, d) for d in durations]
        assert found == [scan(table, offset, cells, d) for d in durations]
        assert len(set(found)) > cells // 2  # the sweep crosses most edges
    assert _split_edge(table, 0, cells, omega_a, 1.0) == 0


@pytest.mark.parametrize("steps", [1, 10, 40, 1000])
def test_free_blocks_fire_as_the_exact_poisson_process_in_any_steps(steps: int) -> None:
    """Independent blocks ramped from x0 = 0.3 in ``steps`` calls (a finite spring's short
    steps: most ramps then thin their escapes, or the part below a cell edge and the rest
    exactly, :func:`advance_free_blocks`) first escape at the stresses of the exact
    time-dependent Poisson process (001/Eq. 24), as in one call (the exact ramp of
    :func:`next_depinning`): Kolmogorov-Smirnov against the quadrature. Checked: bounds
    scaled to 0.6 of the rate fail it at 1000 steps (p = 4e-8), 0.4 at 40 (p = 0.007).
    """
    u, omega_a, x_rate, x0 = 50.21, 1e12, 1e-6 / 2.75e-10, 0.3
    table = hazard_table("persson", u)
    n = 4000
    y = np.full(n, x0)
    h = np.random.default_rng(9).standard_exponential(n)
    stream = seed_streams(4, 1)[0]
    ramp = 0.65 / steps  # to x = 0.95: every block escapes, and only once
    fired = np.full(n, np.nan)
    for _ in range(steps):
        unfired = y + ramp
        advance_free_blocks(y, h, 0.0, x_rate, ramp / x_rate, 0.0, omega_a, table, stream)
        now = np.isnan(fired) & (y < unfired - 1e-9)
        fired[now] = (unfired - y)[now]  # reset to 0 at the escape, then ramped on
    assert not np.isnan(fired).any() and fired.max() < 1.0
    result = stats.kstest(
        fired, lambda x: naive_firing_cdf(x0, x_rate, omega_a, u, np.atleast_1d(x))
    )
    assert result.pvalue > SIGNIFICANCE


def test_next_depinning_splits_hazard_across_horizons() -> None:
    """Integrating in two halves gives the same firing as in one (hazard is carried)."""
    table = hazard_table("persson", 50.21)
    x_rate, omega_a = 3636.0, 1e12
    t_one, x_one, _ = next_depinning(0.1, 2.0, x_rate, 1.0, omega_a, table)
    t_a, x_a, left = next_depinning(0.1, 2.0, x_rate, 0.5 * t_one, omega_a, table)
    assert t_a == np.inf and 0 < left < 2.0
    t_b, x_b, _ = next_depinning(x_a, left, x_rate, 1.0, omega_a, table)
    assert x_b == pytest.approx(x_one, rel=1e-12)
    assert 0.5 * t_one + t_b == pytest.approx(t_one, rel=1e-9)


@pytest.mark.parametrize("x_rate", [1e-14, -1e-14, 1e-300])
def test_a_ramp_slower_than_an_ulp_keeps_its_thermal_escape(x_rate: float) -> None:
    """At a creeping slider's velocity (a hold on a finite spring, where the drift decays
    to ~1e-25 m/s) x0 + x_rate t rounds to x0: the block must still escape at the rate
    of its stress, as on a ramp at rest (after need / r(x0), or with that hazard spent).
    Reading the hazard from x differences froze the creep of every such hold."""
    table = hazard_table("persson", 50.21)
    omega_a, x0 = 1e12, 0.8
    still_t, still_x, _ = next_depinning(x0, 2.0, 0.0, 1.0, omega_a, table)
    t, x, left = next_depinning(x0, 2.0, x_rate, 1.0, omega_a, table)
    assert left == 0.0 and still_t < 1.0
    assert t == pytest.approx(still_t, rel=1e-12) and x == pytest.approx(still_x, abs=1e-13)
    short = 0.5 * still_t
    _, _, spent_still = next_depinning(x0, 2.0, 0.0, short, omega_a, table)
    t, _, spent = next_depinning(x0, 2.0, x_rate, short, omega_a, table)
    assert t == np.inf and spent == pytest.approx(spent_still, rel=1e-12) and spent < 2.0


def test_deterministic_depinning_at_threshold() -> None:
    table = hazard_table("persson", 500.0)  # escape negligible: the ramp reaches sigma_a
    t, x, _ = next_depinning(0.5, 50.0, 1.0, 10.0, 1.0, table)
    assert x == 1.0 and t == pytest.approx(0.5)
    t, x, _ = next_depinning(-0.5, 50.0, -2.0, 10.0, 1.0, table)
    assert x == -1.0 and t == pytest.approx(0.25)


def test_free_blocks_reset_and_count_events() -> None:
    table = hazard_table("persson", 500.0)
    stream = seed_streams(3, 1)[0]
    y = np.array([0.0, 0.5, 0.9])
    h = np.full(3, 1e6)  # thermal escape impossible: only threshold depinnings
    events = advance_free_blocks(y, h, 0.0, 1.0, 0.35, 0.0, 1.0, table, stream)
    assert events == 1
    np.testing.assert_allclose(y, [0.35, 0.85, 0.25], atol=1e-12)


def damped_landing(x0: float, omega_sq: float, damping: float) -> float:
    """Closed form: stress where an isolated block first stops (001/Eq. 21)."""
    return -landing_overshoot(omega_sq, damping) * x0


@pytest.mark.parametrize("damping_ratio", [0.05, 0.3, 0.9, 1.0, 3.0])
def test_cluster_integrator_lands_isolated_block_like_the_closed_form(damping_ratio) -> None:
    kappa, omega1_sq = 1.0, 1.0
    omega_0 = np.sqrt(omega1_sq * (1 + 2 * kappa))  # interior block, neighbours fixed
    damping = 2 * damping_ratio * omega_0
    z = np.array([0.0, 0.0, 0.3, 0.0, 0.0])  # middle block at x = 0.9, neighbours far below
    x0 = reduced_stress(z, 2, kappa)
    on_depin = np.zeros(5, dtype=np.int64)
    moved = np.zeros(5, dtype=np.int64)
    events, n_moved = integrate_cluster(
        z, 0.0, 2, kappa, omega1_sq, damping, on_depin, moved, *cluster_workspace(z.size)
    )
    assert (events, n_moved) == (1, 1)
    landed = reduced_stress(z, 2, kappa)
    expected = damped_landing(x0, omega1_sq * (1 + 2 * kappa), damping)
    tolerance = LANDING_EXACT_RTOL * abs(x0)  # (over)damped: exactly at equilibrium, x = 0
    assert landed == pytest.approx(expected, rel=LANDING_EXACT_RTOL, abs=tolerance)


def test_cluster_avalanche_pushes_a_neighbour_over_threshold() -> None:
    kappa, omega1_sq, damping = 1.0, 1.0, 0.2
    z = np.array([0.0, 0.98, 0.9, 0.0])
    x = [reduced_stress(z, i, kappa) for i in range(4)]
    on_depin = np.zeros(4, dtype=np.int64)
    moved = np.zeros(4, dtype=np.int64)
    events, n_moved = integrate_cluster(
        z, 0.0, 1, kappa, omega1_sq, damping, on_depin, moved, *cluster_workspace(z.size)
    )
    assert events >= 2 and n_moved >= 2
    assert max(abs(reduced_stress(z, i, kappa)) for i in range(4)) < 1.0
    # the chain's total force (sum of plate-spring stretches) only falls in an avalanche
    assert sum(reduced_stress(z, i, kappa) for i in range(4)) < sum(x)


def test_log_one_plus_is_log1p_to_a_few_ulps() -> None:
    """001/Eq. 5's ln(1 + age / tau_m), computed per contact and step without log1p, agrees
    with numpy's log1p to 4 ulps from z = 0 (a fresh contact) through 1e-300 ... 1e300; the
    naive ln(1 + z) loses every digit below z ~ 1e-16 and fails this at 1e-12."""
    z = np.concatenate(([0.0], np.geomspace(1e-300, 1e300, 20001)))
    values = np.array([log_one_plus(v) for v in z])
    np.testing.assert_allclose(values, np.log1p(z), rtol=4 * np.finfo(float).eps, atol=0)
