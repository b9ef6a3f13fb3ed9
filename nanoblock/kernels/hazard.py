"""Exact cumulative hazard of thermal escape along a linear stress ramp (001/Eq. 24).

Reduced stress x = sigma / sigma_a, reduced rate r(x) (escape rate over omega_a),
cumulative R(x) = int_0^x r. In the base model r(x) = exp(-u f(|x|)) and R is odd; with
back jumps (:func:`nanoblock.tables.lattice_hazard_table`) negative stresses have their
own rate, read from a second table packed behind the first (header slot 5 holds its
offset, 0 when both signs share one table). All functions read the packed tables of
:mod:`nanoblock.tables`; they allocate nothing and trust their inputs.
"""

from __future__ import annotations

import numpy as np

from nanoblock.kernels._jit import kernel

_HEADER = 10
_NEGATIVE = 5  # header slot: offset of the table for negative stresses (0: the same)
_FULL = 6  # header slot: R(1)
_BOUNDS = 7  # header slot: offset of the rate bounds (0: none)
_EXACT_SEED = 8  # header slots 8, 9: the ln R levels between which the seed is exact


@kernel(inline=True)
def _side(x: float, table: np.ndarray) -> int:
    """Start of the table that serves reduced stress x, or a signed cumulative hazard x
    (the second one for x < 0). Never the literal 0, so that every caller of a function
    taking it shares one compiled specialization."""
    return int(table[_NEGATIVE]) if x < 0.0 else 0


@kernel(nrt=False)
def _hermite(x: float, table: np.ndarray, start: int) -> tuple[float, float]:
    """g(x) = ln(R(x) / x) and g'(x) for x in [0, 1] by cubic Hermite interpolation, from
    the table that begins at ``start``."""
    n_nodes = int(table[start])
    position = x * n_nodes
    k = min(int(position), n_nodes - 1)
    s = position - k
    h = 1.0 / n_nodes
    cell = start + _HEADER + 2 * k  # (g, g') pairs
    g0 = table[cell]
    d0 = table[cell + 1] * h
    g1 = table[cell + 2]
    d1 = table[cell + 3] * h
    s2 = s * s
    s3 = s2 * s
    value = (
        (2 * s3 - 3 * s2 + 1) * g0
        + (s3 - 2 * s2 + s) * d0
        + (3 * s2 - 2 * s3) * g1
        + (s3 - s2) * d1
    )
    slope = ((6 * s2 - 6 * s) * (g0 - g1) + (3 * s2 - 4 * s + 1) * d0 + (3 * s2 - 2 * s) * d1) / h
    return value, slope


@kernel(nrt=False)
def _cumulative(x: float, table: np.ndarray, start: int) -> float:
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return table[start + _FULL]
    value, _ = _hermite(x, table, start)
    return x * np.exp(value)


@kernel(inline=True)
def cumulative(x: float, table: np.ndarray) -> float:
    """R(x) = int_0^x r(s) ds for x in [0, 1] (dimensionless)."""
    return _cumulative(x, table, _side(x, table))


@kernel(inline=True)
def signed_cumulative(x: float, table: np.ndarray) -> float:
    """R(x) for x in [-1, 1] (odd in x in the base model: escape follows the stress)."""
    if x < 0.0:
        return -_cumulative(-x, table, _side(x, table))
    return _cumulative(x, table, _side(x, table))


@kernel(inline=True)
def rate(x: float, table: np.ndarray) -> float:
    """Reduced escape rate r(x) for x in [-1, 1] (exp(-u f(|x|)) in the base model)."""
    magnitude = abs(x)
    value, slope = _hermite(magnitude, table, _side(x, table))
    if magnitude == 0.0:
        return np.exp(value)
    return np.exp(value) * (1.0 + magnitude * slope)


@kernel(inline=True)
def rate_cells(table: np.ndarray) -> tuple[int, int, float]:
    """Where the table's rate bounds start, their number of cells, and the lowest stress
    they serve: -(1 - 2^-53) when negative stresses share the table, 0 with back jumps (the
    negative ones have their own rate). Offset 0: the table has no bounds.

    ``table[offset + k]`` bounds r(|x|) for |x| <= (k + 1) / cells
    (:func:`nanoblock.tables.rate_bounds`), and ``table[offset + cells + k]`` is
    R(k / cells), k <= cells."""
    offset = int(table[_BOUNDS])
    end = table.shape[0] if table[_NEGATIVE] == 0.0 else int(table[_NEGATIVE])
    lowest = -(1.0 - 2.0**-53) if table[_NEGATIVE] == 0.0 else 0.0
    return offset, (end - offset - 1) // 2, lowest


@kernel(inline=True)
def inverse_cumulative(level: float, table: np.ndarray) -> float:
    """x in [0, 1] with R(x) = ``level`` (0 <= level <= R(1)), by seeded Newton on ln R."""
    return _inverse(level, table, _side(level, table))


@kernel(inline=True)
def signed_inverse(level: float, table: np.ndarray) -> float:
    """x in [-1, 1] with signed R(x) = ``level``: the inverse of :func:`signed_cumulative`."""
    start = _side(level, table)
    if level < 0.0:
        return -_inverse(-level, table, start)
    return _inverse(level, table, start)


_SEED_TOLERANCE = 1e-8
"""Newton stops after a relative step below this: the error left is ~ its square."""

_MAX_NEWTON = 100
"""Enough for bisection to reach round-off where R is flat (a reverse rate that underflows)."""


@kernel(nrt=False)
def _inverse(level: float, table: np.ndarray, start: int) -> float:
    """Newton on ln x + g(x) = ln ``level``, seeded by the cubic Hermite inverse table
    (error ~1e-9 where R is smallest, so one step usually reaches round-off); between the
    header's levels the seed is exact to 1e-13 (:data:`nanoblock.tables.SEED_TOLERANCE`)
    and is the inverse."""
    if level <= 0.0:
        return 0.0
    n_nodes = int(table[start])
    n_inverse = int(table[start + 1])
    log_low, log_high, g_zero = table[start + 2], table[start + 3], table[start + 4]
    target = np.log(level)
    if target >= log_high:
        return 1.0
    if target <= log_low:
        x = min(np.exp(target - g_zero), 1.0 / n_nodes)
    else:
        spacing = (log_high - log_low) / n_inverse
        position = (target - log_low) / spacing
        k = min(int(position), n_inverse - 1)
        s = position - k
        cell = start + _HEADER + 2 * (n_nodes + 1) + 2 * k  # (x, dx/d ln R) pairs
        x0, d0 = table[cell], table[cell + 1] * spacing
        x1, d1 = table[cell + 2], table[cell + 3] * spacing
        s2 = s * s
        s3 = s2 * s
        seed = (
            (2 * s3 - 3 * s2 + 1) * x0
            + (s3 - 2 * s2 + s) * d0
            + (3 * s2 - 2 * s3) * x1
            + (s3 - s2) * d1
        )
        x = min(max(seed, x0), x1)  # R^-1 is monotone; a steep cell's cubic may overshoot
        if table[start + _EXACT_SEED] <= target < table[start + _EXACT_SEED + 1]:
            return x
    low, high = 0.0, 1.0  # brackets the root; Newton steps that leave it are bisected
    for _ in range(_MAX_NEWTON):
        value, slope = _hermite(x, table, start)
        residual = np.log(x) + value - target
        if residual == 0.0:
            return x
        if residual > 0.0:
            high = x
        else:
            low = x
        derivative = 1.0 / x + slope  # r / R: zero where the rate underflows (R flat)
        step = residual / derivative if derivative > 0.0 else np.inf
        if abs(step) <= _SEED_TOLERANCE * x:
            return x - step
        x = x - step if low < x - step < high else 0.5 * (low + high)
    return x


@kernel(inline=True)
def hazard_between(
    x0: float, x1: float, x_rate: float, duration: float, table: np.ndarray
) -> float:
    """Reduced hazard int r(x(t)) dt [s] along a linear ramp; times omega_a it is the hazard.

    The ramp goes from ``x0`` to ``x1`` in ``duration`` seconds at rate ``x_rate`` = dx/dt.
    """
    return ramp_hazard(x0, signed_cumulative(x0, table), x1, x_rate, duration, table)


@kernel(inline=True)
def ramp_hazard(
    x0: float, start: float, x1: float, x_rate: float, duration: float, table: np.ndarray
) -> float:
    """:func:`hazard_between` with ``start`` = R(x0) (:func:`signed_cumulative`) known.

    A ramp too short for a difference of cumulatives to be accurate uses the midpoint rule
    (relative error below 1e-10 for |x1 - x0| < 1e-6), unless it crosses zero stress where
    the rate jumps (back jumps); there the cumulatives add without cancellation.
    """
    if abs(x1 - x0) < 1e-6 and (x0 * x1 >= 0.0 or table[_NEGATIVE] == 0.0):
        return rate(0.5 * (x0 + x1), table) * duration
    return abs(signed_cumulative(x1, table) - start) / abs(x_rate)
