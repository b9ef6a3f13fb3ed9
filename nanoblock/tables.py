"""Tabulated cumulative escape hazard of a barrier law, the input of the hazard kernels.

For a block whose reduced stress x = sigma / sigma_a moves at a constant rate, the hazard
accumulated between x0 and x1 is (omega_a / |dx/dt|) |R(x1) - R(x0)| with
R(x) = int_0^x exp(-u f(s)) ds (001/Eq. 24 integrated along the drive; f from
:mod:`nanoblock.barriers`). The table holds g(x) = ln(R(x) / x) and g'(x) on a uniform
grid, for cubic Hermite evaluation to ~1e-14 relative over the whole range of R (which
spans e^-u to 1), plus an inverse table, x and dx/d ln R on a uniform grid of ln R, whose
cubic Hermite interpolant seeds Newton's method for R^-1. The seed's error falls from ~1e-9
at the smallest R to round-off where escapes happen; the header holds the level of ln R
between which it is below :data:`SEED_TOLERANCE` in every cell; there the kernels take the
seed as the inverse and skip Newton (a third of a mean-field depinning's cost).
With back jumps a second table, for negative stresses, follows the first
(:func:`lattice_hazard_table`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from nanoblock.barriers import barrier_law, lattice_reverse_barrier

HEADER = 10
"""Scalars before the arrays: n_nodes, n_inverse, ln R(1/n), ln R(1), g(0), the offset of
the table for negative stresses (0: the same table, R odd), R(1), the offset of the
rate bounds (:data:`RATE_BOUNDS`; 0: none) and the two levels of ln R between which the
inverse table's seed is exact (:data:`SEED_TOLERANCE`; equal: nowhere)."""

BOUNDS_OFFSET = 7
"""Header slot of the offset of the rate bounds."""

RATE_BOUNDS = 64
"""Cells of the rate bounds that close a table (one whose nodes fall on the cells' edges):
RATE_BOUNDS upper bounds of the reduced rate, the k-th on [0, k + 1] / RATE_BOUNDS, then
R at the RATE_BOUNDS + 1 edges k / RATE_BOUNDS, for the kernels' thinning of escapes
(:func:`nanoblock.kernels.blocks.advance_free_blocks`)."""

_BOUND_SAMPLES = 33
"""Points per cell at which the rate is maximized for its bound."""

_BOUND_MARGIN = 1e-2
"""Relative margin of a bound over the sampled maximum: the kernels' r, interpolated from
the table, exceeds that by up to 1e-3 (measured); a margin costs only as many more
thinning candidates."""

NEGATIVE_OFFSET = 5
"""Header slot of the offset of the negative-stress table."""

_FULL = 6
"""Header slot of R(1), the hazard of a whole ramp to the threshold (read at every
deterministic depinning)."""

EXACT_SEED = 8
"""Header slots (this one and the next) of the levels of ln R between which the inverse
table's seed is exact."""

SEED_TOLERANCE = 2.5e-13
"""Error of a seed of R^-1, relative in x and absolute in ln R, below which it counts as
the inverse: twice its largest value at the quarter points of a cell (the cubic's error
peaks mid-cell), 4x below the kernels' accuracy bound on R^-1 (1e-12 in both,
``tests/test_kernels.py``)."""

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(10)

_INVERSE_NEWTON = 6
"""Newton steps that take the linear-interpolation seeds of R^-1 (error ~1e-4) to round-off."""

LogRate = Callable[[np.ndarray], np.ndarray]


def hazard_table(barrier: str, u: float, n_nodes: int = 4096, n_inverse: int = 2048) -> np.ndarray:
    """Build the packed hazard table for ``barrier`` at reduced barrier height ``u``.

    Layout: ``HEADER`` scalars, then the pairs (g, g') on the ``n_nodes + 1`` nodes
    x_k = k / n_nodes, then the pairs (x, dx/d ln R = R / r) on ``n_inverse + 1`` equally
    spaced values of ln R between ln R(x_1) and ln R(1). Pairs keep the four numbers of
    one interpolation cell in one cache line.
    """
    if not (np.isfinite(u) and u > 0):
        raise ValueError(f"reduced barrier u = {u!r} must be finite and > 0")
    law = barrier_law(barrier)
    return _table(lambda x: -u * law(x), n_nodes, n_inverse)


def lattice_hazard_table(
    barrier: str, u: float, u_elastic: float, n_nodes: int = 4096, n_inverse: int = 2048
) -> np.ndarray:
    """Forward and reverse hazard tables of a joint with back jumps, packed end to end.

    x >= 0 (upper branch): the forward rate exp(-u f(x)) of :func:`hazard_table`.
    x = -t < 0 (lower branch, upper branch at stress 1 - t): the reverse rate
    exp(-[u f(1 - t) + u_el (1/2 - t)]) of :func:`nanoblock.barriers.lattice_reverse_barrier`,
    tabulated in t = |x| in the same layout; header slot :data:`NEGATIVE_OFFSET` of the
    first table points to the second.
    """
    forward = hazard_table(barrier, u, n_nodes, n_inverse)
    reverse = _table(
        lambda t: -lattice_reverse_barrier(1.0 - t, barrier, u, u_elastic), n_nodes, n_inverse
    )
    forward[NEGATIVE_OFFSET] = forward.size
    return np.concatenate((forward, reverse))


def _table(log_rate: LogRate, n_nodes: int, n_inverse: int) -> np.ndarray:
    """The packed table of the reduced rate exp(log_rate(x)) on x in [0, 1]."""
    nodes = np.linspace(0.0, 1.0, n_nodes + 1)
    cumulative = np.concatenate(([0.0], np.cumsum(_integral(log_rate, nodes[:-1], nodes[1:]))))

    g = np.empty(n_nodes + 1)
    slope = np.empty(n_nodes + 1)
    g[0] = log_rate(np.array([0.0]))[0]
    g[1:] = np.log(cumulative[1:] / nodes[1:])
    # g'(x) = r(x) / R(x) - 1 / x; at x = 0 the limit is (ln r)'(0) / 2 (R = x r(0)(1 + ...)).
    step = 1e-4
    near_zero = log_rate(np.array([0.0, step, 2 * step]))
    slope[0] = 0.5 * (-3 * near_zero[0] + 4 * near_zero[1] - near_zero[2]) / (2 * step)
    slope[1:] = np.exp(log_rate(nodes[1:])) / cumulative[1:] - 1.0 / nodes[1:]

    log_cumulative = np.log(cumulative[1:])
    inverse_levels = np.linspace(log_cumulative[0], log_cumulative[-1], n_inverse + 1)
    inverse_x, inverse_slope = _inverse_nodes(
        log_rate, nodes, cumulative, log_cumulative, inverse_levels
    )

    header = np.zeros(HEADER)
    header[:5] = (n_nodes, n_inverse, log_cumulative[0], log_cumulative[-1], g[0])
    header[_FULL] = np.exp(g[-1])  # R(1) = 1 * exp(g(1)), the kernels' value at the threshold
    header[EXACT_SEED : EXACT_SEED + 2] = _exact_seed_levels(
        CubicHermiteSpline(nodes, g, slope), inverse_levels, inverse_x, inverse_slope
    )
    pairs = np.column_stack((g, slope)).ravel()
    inverse_pairs = np.column_stack((inverse_x, inverse_slope)).ravel()
    if n_nodes % RATE_BOUNDS:
        return np.concatenate((header, pairs, inverse_pairs))
    header[BOUNDS_OFFSET] = HEADER + pairs.size + inverse_pairs.size
    edges = cumulative[:: n_nodes // RATE_BOUNDS]
    return np.concatenate((header, pairs, inverse_pairs, rate_bounds(log_rate), edges))


def rate_bounds(log_rate: LogRate, cells: int = RATE_BOUNDS) -> np.ndarray:
    """Upper bounds of the reduced rate exp(log_rate(x)) on [0, (k + 1) / ``cells``],
    k < ``cells`` (maxima over ``_BOUND_SAMPLES`` points of each cell, ends included, plus
    ``_BOUND_MARGIN``; the rates of the barrier laws increase with x, so bound k is
    cell k's own)."""
    points = np.linspace(0.0, 1.0, cells * (_BOUND_SAMPLES - 1) + 1)
    rates = np.exp(log_rate(points))
    windows = np.lib.stride_tricks.sliding_window_view(rates, _BOUND_SAMPLES)
    cell_maxima = windows[:: _BOUND_SAMPLES - 1].max(axis=1)
    return np.maximum.accumulate(cell_maxima) * (1.0 + _BOUND_MARGIN)


def _exact_seed_levels(
    forward: CubicHermiteSpline, levels: np.ndarray, x: np.ndarray, slope: np.ndarray
) -> tuple[float, float]:
    """The ends of the longest run of inverse-table cells whose cubic Hermite seed (clamped
    to its cell, as the kernels take it) is within :data:`SEED_TOLERANCE` of the root of
    ln x + g(x) = ln R that the kernels' Newton finds (g: the ``forward`` interpolant), in
    x and in ln R, at the cell's quarter points, with a factor 2 of margin (two equal
    levels: no such cell)."""
    quarters = (levels[:-1, None] + np.diff(levels)[:, None] * np.array([0.25, 0.5, 0.75])).ravel()
    seed = CubicHermiteSpline(levels, x, slope)(quarters)
    seed = np.clip(seed, np.repeat(x[:-1], 3), np.repeat(x[1:], 3))
    derivative = forward.derivative()
    root = seed.copy()
    for _ in range(_INVERSE_NEWTON):
        root -= (np.log(root) + forward(root) - quarters) / (1.0 / root + derivative(root))
    log_slope = 1.0 / root + derivative(root)  # d ln R / dx
    error = (np.abs(seed - root) * np.maximum(1.0 / root, log_slope)).reshape(-1, 3).max(axis=1)
    good = np.concatenate(([0], (2.0 * error <= SEED_TOLERANCE).astype(np.int8), [0]))
    starts, ends = np.flatnonzero(np.diff(good) == 1), np.flatnonzero(np.diff(good) == -1)
    if starts.size == 0:
        return float(levels[0]), float(levels[0])
    longest = np.argmax(ends - starts)
    return float(levels[starts[longest]]), float(levels[ends[longest]])


def _integral(log_rate: LogRate, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """int_left^right exp(log_rate) by 10-point Gauss-Legendre, elementwise (short spans)."""
    half = 0.5 * (right - left)
    points = (0.5 * (left + right))[:, None] + half[:, None] * _GAUSS_X[None, :]
    return half * (np.exp(log_rate(points)) @ _GAUSS_W)


def _inverse_nodes(
    log_rate: LogRate,
    nodes: np.ndarray,
    cumulative: np.ndarray,
    log_cumulative: np.ndarray,
    levels: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """x with ln R(x) = ``levels`` to round-off, and dx/d ln R = R(x) / r(x) there.

    Newton's method on ln R from linear interpolation, with R(x) = R(x_k) + the integral
    from the node x_k below x (the same quadrature as the table's cumulative)."""
    x = np.interp(levels, log_cumulative, nodes[1:])
    n_nodes = nodes.size - 1
    for _ in range(_INVERSE_NEWTON):
        k = np.clip((x * n_nodes).astype(np.int64), 0, n_nodes - 1)
        total = cumulative[k] + _integral(log_rate, nodes[k], x)
        x = np.clip(x - (np.log(total) - levels) * total / np.exp(log_rate(x)), 0.0, 1.0)
    k = np.clip((x * n_nodes).astype(np.int64), 0, n_nodes - 1)
    total = cumulative[k] + _integral(log_rate, nodes[k], x)
    return x, total / np.exp(log_rate(x))
