"""Exact cumulative hazard of thermal escape along a linear stress ramp (001/Eq. 24).

Reduced stress x = sigma / sigma_a, reduced rate r(x) = exp(-u f(|x|)) (escape rate over
omega_a), cumulative R(x) = int_0^x r (odd in x). All functions read the packed table of
:func:`nanoblock.tables.hazard_table`; they allocate nothing and trust their inputs.
"""

from __future__ import annotations

import numpy as np

from nanoblock.kernels._jit import kernel

_HEADER = 8


@kernel
def _hermite(x: float, table: np.ndarray) -> tuple[float, float]:
    """g(x) = ln(R(x) / x) and g'(x) for x in [0, 1] by cubic Hermite interpolation."""
    n_nodes = int(table[0])
    position = x * n_nodes
    k = min(int(position), n_nodes - 1)
    s = position - k
    h = 1.0 / n_nodes
    g0 = table[_HEADER + k]
    g1 = table[_HEADER + k + 1]
    d0 = table[_HEADER + n_nodes + 1 + k] * h
    d1 = table[_HEADER + n_nodes + 2 + k] * h
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


@kernel
def cumulative(x: float, table: np.ndarray) -> float:
    """R(x) = int_0^x r(s) ds for x in [0, 1] (dimensionless)."""
    if x <= 0.0:
        return 0.0
    value, _ = _hermite(x, table)
    return x * np.exp(value)


@kernel
def signed_cumulative(x: float, table: np.ndarray) -> float:
    """R(x) for x in [-1, 1], odd in x (escape follows the sign of the stress)."""
    if x < 0.0:
        return -cumulative(-x, table)
    return cumulative(x, table)


@kernel
def rate(x: float, table: np.ndarray) -> float:
    """Reduced escape rate r(|x|) = exp(-u f(|x|)) for x in [-1, 1]."""
    magnitude = abs(x)
    value, slope = _hermite(magnitude, table)
    if magnitude == 0.0:
        return np.exp(value)
    return np.exp(value) * (1.0 + magnitude * slope)


@kernel
def inverse_cumulative(level: float, table: np.ndarray) -> float:
    """x in [0, 1] with R(x) = ``level`` (0 <= level <= R(1)), by seeded Newton on ln R."""
    if level <= 0.0:
        return 0.0
    n_nodes = int(table[0])
    n_inverse = int(table[1])
    log_low, log_high, g_zero = table[2], table[3], table[4]
    target = np.log(level)
    if target >= log_high:
        return 1.0
    if target <= log_low:
        x = min(np.exp(target - g_zero), 1.0 / n_nodes)
    else:
        position = (target - log_low) / (log_high - log_low) * n_inverse
        k = min(int(position), n_inverse - 1)
        s = position - k
        base = _HEADER + 2 * (n_nodes + 1)
        x = (1.0 - s) * table[base + k] + s * table[base + k + 1]
    for _ in range(30):
        value, slope = _hermite(x, table)
        residual = np.log(x) + value - target
        step = residual / (1.0 / x + slope)
        updated = min(max(x - step, 0.5 * x), 1.0)
        if abs(updated - x) <= 1e-15 * updated:
            return updated
        x = updated
    return x


@kernel
def hazard_between(
    x0: float, x1: float, x_rate: float, duration: float, table: np.ndarray
) -> float:
    """Reduced hazard int r(x(t)) dt [s] along a linear ramp; times omega_a it is the hazard.

    The ramp goes from ``x0`` to ``x1`` in ``duration`` seconds at rate ``x_rate`` = dx/dt.
    A ramp too short for a difference of cumulatives to be accurate uses the midpoint rule
    (relative error below 1e-10 for |x1 - x0| < 1e-6).
    """
    if abs(x1 - x0) < 1e-6:
        return rate(0.5 * (x0 + x1), table) * duration
    return abs(signed_cumulative(x1, table) - signed_cumulative(x0, table)) / abs(x_rate)
