"""Exact modal avalanches of the coupled chain (001/Eq. 21) against linear algebra and ODEs.

Reduced units of :mod:`nanoblock.kernels.chain`: z = stretch / rho~_max, x = stress /
sigma_a, a moving block obeys z'' = -gamma z' - omega_1^2 x, a pinned one does not move.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nanoblock.kernels.chain import cluster_workspace, integrate_cluster, reduced_stress
from nanoblock.kernels.modes import (
    combination_root,
    propagate,
    run_spectrum,
    step_matrix,
    tabled_spectrum,
)
from tests.tolerances import AVALANCHE_ATOL, MODAL_RTOL

ODE = {"method": "DOP853", "rtol": 1e-12, "atol": 1e-14}


def stresses(z: np.ndarray, kappa: float, offset: float = 0.0) -> np.ndarray:
    """x_i = z_i + kappa (n_i z_i - neighbours' z) + offset, free chain ends."""
    return np.array([reduced_stress(z, i, kappa) for i in range(z.size)]) + offset


def stress_matrix(n: int, kappa: float) -> np.ndarray:
    """dx/dz of the whole chain (x is affine in z)."""
    return np.column_stack([stresses(np.eye(n)[k], kappa) for k in range(n)])


def run_modes(length: int, left_fixed: bool, right_fixed: bool) -> tuple[np.ndarray, np.ndarray]:
    eigenvalues = np.empty(length)
    vectors = np.empty((length, length))
    run_spectrum(length, left_fixed, right_fixed, eigenvalues, vectors, 0)
    return eigenvalues, vectors


@pytest.mark.parametrize("kappa", [0.3, 1.0, 3.0])
@pytest.mark.parametrize("ends", [(False, False), (True, True), (False, True), (True, False)])
@pytest.mark.parametrize("length", [*range(1, 9), 17, 40])
def test_run_spectra_match_eigh(length: int, ends: tuple[bool, bool], kappa: float) -> None:
    """Closed-form spectra of A = I + kappa L vs numpy.linalg.eigh of the chain's own
    stress matrix restricted to a run, a pinned block beside each fixed end."""
    left_fixed, right_fixed = ends
    start = 1 if left_fixed else 0
    n = start + length + (1 if right_fixed else 0)
    a_run = stress_matrix(n, kappa)[start : start + length, start : start + length]
    eigenvalues, vectors = run_modes(length, left_fixed, right_fixed)
    expected = np.linalg.eigh(a_run).eigenvalues
    np.testing.assert_allclose(1.0 + kappa * eigenvalues, expected, rtol=MODAL_RTOL, atol=0)
    assert np.all(np.diff(eigenvalues) > 0.0)
    np.testing.assert_allclose(vectors.T @ vectors, np.eye(length), atol=MODAL_RTOL)
    np.testing.assert_allclose(
        a_run @ vectors, vectors * (1.0 + kappa * eigenvalues), atol=MODAL_RTOL * (1 + 4 * kappa)
    )
    tabled = np.empty(length), np.empty((length, length))
    tabled_spectrum(length, left_fixed, right_fixed, *tabled, 0)
    assert np.array_equal(tabled[0], eigenvalues) and np.array_equal(tabled[1], vectors)


def modal_trajectory(z, v, run, kappa, omega1_sq, gamma, offset, times) -> np.ndarray:
    """z(t) of the moving run (a slice of the chain) by its closed-form modes."""
    n = z.size
    eigenvalues, vectors = run_modes(run.stop - run.start, run.start > 0, run.stop < n)
    stiffness = 1.0 + kappa * eigenvalues
    outside = z.copy()
    outside[run] = 0.0
    loading = stresses(outside, kappa, offset)[run]  # c of x = A z_run + c
    z_eq = vectors @ (-(vectors.T @ loading) / stiffness)
    q0, p0 = vectors.T @ (z[run] - z_eq), vectors.T @ v[run]
    w_sq = omega1_sq * stiffness
    s_sq = 0.25 * gamma**2 - w_sq
    q = np.array(
        [
            [propagate(q0[k], p0[k], w_sq[k], s_sq[k], gamma, t)[0] for k in range(q0.size)]
            for t in times
        ]
    )
    return z_eq + q @ vectors.T


def ode_trajectory(z, v, run, kappa, omega1_sq, gamma, offset, times) -> np.ndarray:
    """The same by solve_ivp on z'' = -gamma z' - omega_1^2 x (DOP853, rtol 1e-12)."""
    size = run.stop - run.start

    def rhs(_, y):
        position = z.copy()
        position[run] = y[:size]
        return np.concatenate(
            (y[size:], -gamma * y[size:] - omega1_sq * stresses(position, kappa, offset)[run])
        )

    solution = solve_ivp(
        rhs, (0.0, times[-1]), np.concatenate((z[run], v[run])), t_eval=times, **ODE
    )
    return solution.y[:size].T


@pytest.mark.parametrize("damping_ratio", [0.2, 1.0, 2.5])
@pytest.mark.parametrize("run", [slice(2, 5), slice(0, 4), slice(3, 7), slice(0, 7)])
def test_modal_propagator_matches_ode(run: slice, damping_ratio: float) -> None:
    """Closed-form modes vs direct integration, under-, critically (the middle mode of a
    three-block run between pinned blocks at damping ratio 1) and over-damped."""
    rng = np.random.default_rng(7)
    kappa, omega1_sq, offset = 1.3, 2.0, 0.17
    gamma = 2.0 * damping_ratio * np.sqrt(omega1_sq * (1.0 + 2.0 * kappa))
    z = rng.uniform(-1.0, 1.0, 7)
    v = np.zeros(7)
    v[run] = rng.uniform(-1.0, 1.0, run.stop - run.start)
    times = np.linspace(0.0, 6.0, 13)
    exact = modal_trajectory(z, v, run, kappa, omega1_sq, gamma, offset, times)
    direct = ode_trajectory(z, v, run, kappa, omega1_sq, gamma, offset, times)
    np.testing.assert_allclose(exact, direct, rtol=0, atol=MODAL_RTOL * 1e2)


@pytest.mark.parametrize("s_sq", [-3.0, -1e-9, 0.0, 1e-9, 2.0])
def test_step_matrix_is_the_propagator(s_sq: float) -> None:
    """The one-step map equals the closed form; the series branch joins cosh/cos smoothly."""
    gamma, dt = 1.7, 0.3
    w_sq = 0.25 * gamma**2 - s_sq
    m00, m01, m10, m11 = step_matrix(w_sq, s_sq, gamma, dt)
    for q0, p0 in ((1.0, 0.0), (0.0, 1.0), (0.4, -2.0)):
        q, p = propagate(q0, p0, w_sq, s_sq, gamma, dt)
        assert (q, p) == pytest.approx(
            (m00 * q0 + m01 * p0, m10 * q0 + m11 * p0), rel=1e-15, abs=1e-15
        )
    near = [propagate(0.4, -2.0, w_sq, s, gamma, dt) for s in (s_sq - 1e-6, s_sq + 1e-6)]
    np.testing.assert_allclose(near[0], near[1], rtol=1e-5)


def test_combination_root_finds_a_velocity_zero_to_round_off() -> None:
    """An underdamped mode's velocity vanishes at tan(|s| t) = |s| p0 / (w^2 q0 + gamma p0 / 2)."""
    gamma, w_sq, q0, p0 = 0.4, 3.0, 0.5, 1.0
    s_sq = 0.25 * gamma**2 - w_sq
    frequency = np.sqrt(-s_sq)
    expected = np.arctan2(frequency * p0, w_sq * q0 + 0.5 * gamma * p0) / frequency
    args = (0.0, np.array([0]), np.array([0.0]), np.array([1.0]), 1)
    state = (np.array([q0]), np.array([p0]), np.array([w_sq]), np.array([s_sq]), gamma)
    p_end = propagate(q0, p0, w_sq, s_sq, gamma, 1.5)[1]
    root = combination_root(0.0, 1.5, p0, p_end, *args, *state)
    assert root == pytest.approx(expected, rel=4e-16)


# ---------------------------------------------------------------- naive whole avalanches
def leg_problem(z, idx, watch, heading, kappa, omega1_sq, gamma, offset):
    """Right-hand side and terminal events of :func:`naive_avalanche` between two events."""
    size = idx.size

    def state(y):
        position = z.copy()
        position[idx] = y[:size]
        return position

    def rhs(_, y):
        x = stresses(state(y), kappa, offset)[idx]
        return np.concatenate((y[size:], -gamma * y[size:] - omega1_sq * x))

    def turn(m):
        event = lambda _, y: heading[idx[m]] * y[size + m]  # noqa: E731
        event.terminal, event.direction = True, -1
        return event

    def reach(j, level):
        event = lambda _, y: stresses(state(y), kappa, offset)[j] - level  # noqa: E731
        event.terminal, event.direction = True, level
        return event

    events = [turn(m) for m in range(size)]
    events += [reach(j, level) for j in watch for level in (1.0, -1.0)]
    return rhs, events


def naive_avalanche(z, offset, first, kappa, omega1_sq, gamma) -> tuple[np.ndarray, int, list]:
    """Plain reference: solve_ivp between events, restarted at each one.

    Turn: heading * v_i falls through 0 (block pinned where it is); join: a pinned
    neighbour of a moving block reaches |x| = 1 (it starts from rest, heading -sign x);
    pinned neighbours or just-stopped blocks at |x| >= 1 join at once. Without further
    events the moving blocks are integrated for 30 e-folds of their slowest mode (to
    within ~1e-13 of equilibrium). Returns (final z, number of depinnings, the blocks in
    the order of their first depinning).
    """
    z = z.astype(float).copy()
    n = z.size
    heading = np.zeros(n)
    velocity = np.zeros(n)
    moving: list[int] = []
    order: list[int] = []

    def join(j: int) -> None:
        moving.append(j)
        if j not in order:
            order.append(j)
        velocity[j] = 0.0
        heading[j] = -1.0 if stresses(z, kappa, offset)[j] > 0.0 else 1.0

    join(first)
    depinnings, stopped = 1, []
    while True:
        candidates = {j for i in moving for j in (i - 1, i + 1) if 0 <= j < n} | set(stopped)
        candidates -= set(moving)
        over = [j for j in sorted(candidates) if abs(stresses(z, kappa, offset)[j]) >= 1.0]
        if over:
            for j in over:
                join(j)
            depinnings += len(over)
            stopped = []
            continue
        if not moving:
            return z, depinnings, order
        idx = np.array(sorted(moving))
        size = idx.size
        watch = sorted({j for i in idx for j in (i - 1, i + 1) if 0 <= j < n} - set(moving))
        rhs, events = leg_problem(z, idx, watch, heading, kappa, omega1_sq, gamma, offset)
        a_run = stress_matrix(n, kappa)[np.ix_(idx, idx)]
        w_sq = omega1_sq * np.linalg.eigvalsh(a_run)
        decay = np.min(0.5 * gamma - np.sqrt(np.maximum(0.25 * gamma**2 - w_sq, 0.0)))
        solution = solve_ivp(
            rhs, (0.0, 30.0 / decay), np.concatenate((z[idx], velocity[idx])), events=events, **ODE
        )
        z[idx] = solution.y[:size, -1]
        velocity[idx] = solution.y[size:, -1]
        if solution.status != 1:
            return z, depinnings, order
        fired = min(
            range(len(events)),
            key=lambda e: solution.t_events[e][0] if solution.t_events[e].size else np.inf,
        )
        if fired < size:
            i = int(idx[fired])
            moving.remove(i)
            velocity[i] = 0.0
            stopped = [i]
        else:
            join(watch[(fired - size) // 2])
            depinnings += 1
            stopped = []


def random_chain(rng: np.random.Generator, low: float):
    """A chain of 4-12 blocks, stresses uniform in (low, 1) times a common random sign
    (low = -1: independent signs), one block pushed over threshold."""
    n = int(rng.integers(4, 13))
    kappa = rng.uniform(0.5, 2.0)
    omega1_sq = rng.uniform(0.5, 2.0)
    gamma = 2.0 * rng.uniform(0.1, 3.0) * np.sqrt(omega1_sq * (1.0 + 2.0 * kappa))
    offset = rng.uniform(-0.3, 0.3)
    sign = rng.choice([-1.0, 1.0])
    x = sign * rng.uniform(low, 1.0, n)
    first = int(rng.integers(n))
    x[first] = sign * rng.uniform(1.0, 1.2)
    z = np.linalg.solve(stress_matrix(n, kappa), x - offset)
    return z, offset, first, kappa, omega1_sq, gamma


@pytest.mark.parametrize(("low", "chains", "seed"), [(-1.0, 50, 20261122), (0.5, 20, 5)])
def test_avalanches_match_the_naive_event_integrator(low: float, chains: int, seed: int) -> None:
    """integrate_cluster vs :func:`naive_avalanche` on random chains (stresses in (-1, 1),
    and near-critical ones in (0.5, 1) for long avalanches): final z within AVALANCHE_ATOL
    (rho~_max units; measured worst 5e-13), the same depinnings in the same order."""
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(chains):
        z, offset, first, kappa, omega1_sq, gamma = random_chain(rng, low)
        expected, depinnings, order = naive_avalanche(z, offset, first, kappa, omega1_sq, gamma)
        on_depin = np.zeros(z.size, dtype=np.int64)
        moved = np.zeros(z.size, dtype=np.int64)
        events, n_moved = integrate_cluster(
            z, offset, first, kappa, omega1_sq, gamma, on_depin, moved, *cluster_workspace(z.size)
        )
        assert events == depinnings == on_depin.sum()
        assert list(moved[:n_moved]) == order  # joins in time order
        assert sorted(order) == list(np.flatnonzero(on_depin))
        worst = max(worst, np.max(np.abs(z - expected)))
    assert worst < AVALANCHE_ATOL
