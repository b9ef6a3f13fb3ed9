"""Numba kernel of the two-branch occupancy with back jumps (physics.md section 5).

A pure function over flat arrays, called by :func:`nanoblock.theory.meanfield.steady_stress`
and the stationary density: the exponential integrator of q' = -a q - p_eq' on uniform
cells (see ``meanfield._lattice_solution``), one sequential pass per velocity.
"""

from __future__ import annotations

import math

import numpy as np

from nanoblock.kernels._jit import kernel

_SERIES_BELOW = 1e-2
"""Below this x, the weights g_k(x) are summed as series (relative error < 1e-10)."""


@kernel
def _weights(x: float) -> tuple[float, float, float]:
    """g1 = (1 - e^-x) / x, g2 = (x - 1 + e^-x) / x^2, g3 = (x^2/2 - x + 1 - e^-x) / x^3."""
    if x < _SERIES_BELOW:
        return (
            1.0 - x / 2 + x**2 / 6 - x**3 / 24,
            1.0 / 2 - x / 6 + x**2 / 24 - x**3 / 120,
            1.0 / 6 - x / 24 + x**2 / 120 - x**3 / 720,
        )
    decayed = -math.expm1(-x)
    return decayed / x, (x - decayed) / x**2, (x**2 / 2 - x + decayed) / x**3


@kernel
def occupancy_departure(
    rate_h: np.ndarray,
    source: np.ndarray,
    lam: np.ndarray,
    q0: float,
    q: np.ndarray,
    integral: np.ndarray,
) -> None:
    """Fill q[i, k] = q(s_k) and integral[i] = int_0^1 q ds for each Lambda = lam[i].

    ``rate_h[k]`` is the cell mean of a / Lambda times the cell size h (a cell's relaxation
    exponent is x = Lambda rate_h[k]), ``source`` = -dp_eq/ds at the cell edges (linear in
    between), q0 = q(0). Exact for constant a and linear source on each cell:
    q_{k+1} = e^-x q_k + h g1 c_k + h^2 g2 c'_k, int q = h g1 q_k + h^2 g2 c_k + h^3 g3 c'_k.
    """
    cells = rate_h.size
    h = 1.0 / cells
    for i in range(lam.size):
        current = q0
        q[i, 0] = current
        total = 0.0
        for k in range(cells):
            x = lam[i] * rate_h[k]
            g1, g2, g3 = _weights(x)
            start = source[k]
            slope = (source[k + 1] - start) / h
            total += current * h * g1 + start * h**2 * g2 + slope * h**3 * g3
            current = math.exp(-x) * current + start * h * g1 + slope * h**2 * g2
            q[i, k + 1] = current
        integral[i] = total
