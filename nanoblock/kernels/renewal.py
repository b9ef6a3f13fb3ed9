"""The renewal laws' quasi-static spring-slider: right-hand side and exact Jacobian.

State y = (w, E_1 .. E_n, [s2], delta) with w = ln(v / v0), E_j = <exp(-sigma_j u)> over
the contacts' ages u (001/Eqs. 3, 5), s2 the optional second memory's ln(theta2 v0 / Dc2)
by the aging law and delta the slip. With h_j the quadrature weights (b / a times the
trapezoid step and e^(-sigma_j tau_m)):

    E_j' = v / D - (sigma_j (v0 / D) r(v) + v / D) E_j,   r = v / (v + v_theta) or 1,
    w'   = K (V_L - v) / a + sum_j h_j E_j' - (b2 / a) s2',  s2' = e^(-s2) - v / Dc2.

LSODA calls them thousands of times per fit, so they write into the caller's buffers and
allocate nothing (``benchmarks/bench_renewal_lab.py`` times the fits;
``tests/test_rsf_laws.py`` checks them against the generic right-hand side built from the
law's ``state_rate`` and ``gradient``, and the Jacobian against its central differences).
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import kernel


@kernel(inline=True, nrt=False)
def _rates(w: float, constants: np.ndarray) -> tuple[float, float, float, float]:
    """(v [m/s], birth rate v / D [1/s], clock r(v), ageing rate r v0 / D [1/s]) at
    w = ln(v / v0), with ``constants`` as :func:`renewal_slider_rate` takes them."""
    memory, v0, v_theta = constants[1], constants[2], constants[4]
    v = v0 * math.exp(w)
    clock = v / (v + v_theta) if v_theta > 0.0 else 1.0
    return v, v / memory, clock, clock * v0 / memory


@kernel(nrt=False)
def renewal_slider_rate(
    y: np.ndarray,
    drive: float,
    nodes: np.ndarray,
    weights: np.ndarray,
    constants: np.ndarray,
    out: np.ndarray,
) -> None:
    """dy/dt [1/s] at drive V_L [m/s] into ``out``; ``constants`` = (a, D [m], v0 [m/s],
    K/W [1/m], v_theta [m/s] or 0 for no cutoff, b2, Dc2 [m]), b2 and Dc2 read only when
    y holds the second memory (``y.size == nodes.size + 3``)."""
    a, stiffness, b2, dc2 = constants[0], constants[3], constants[5], constants[6]
    n = nodes.size
    v, birth, _, ageing = _rates(y[0], constants)
    total = 0.0
    for j in range(n):
        rate = birth - (nodes[j] * ageing + birth) * y[1 + j]
        out[1 + j] = rate
        total += weights[j] * rate
    out[0] = stiffness * (drive - v) / a + total
    if y.size == n + 3:
        second = math.exp(-y[n + 1]) - v / dc2
        out[n + 1] = second
        out[0] -= b2 / a * second
    out[y.size - 1] = v


@kernel(nrt=False)
def renewal_slider_jacobian(
    y: np.ndarray,
    drive: float,
    nodes: np.ndarray,
    weights: np.ndarray,
    constants: np.ndarray,
    out: np.ndarray,
) -> None:
    """d(dy/dt)/dy of :func:`renewal_slider_rate` into ``out`` (dr/dw = r (1 - r) with the
    cutoff)."""
    a, stiffness, b2, dc2 = constants[0], constants[3], constants[5], constants[6]
    n = nodes.size
    size = y.size
    v, birth, clock, ageing = _rates(y[0], constants)
    slope = 1.0 - clock if constants[4] > 0.0 else 0.0
    out[:, :] = 0.0
    corner = -stiffness * v / a
    for j in range(n):
        e = y[1 + j]
        by_w = birth * (1.0 - e) - nodes[j] * ageing * slope * e
        decay = nodes[j] * ageing + birth
        out[1 + j, 0] = by_w
        out[1 + j, 1 + j] = -decay
        out[0, 1 + j] = -weights[j] * decay
        corner += weights[j] * by_w
    if size == n + 3:
        out[n + 1, 0] = -v / dc2
        out[n + 1, n + 1] = -math.exp(-y[n + 1])
        corner += b2 / a * v / dc2
        out[0, n + 1] = b2 / a * math.exp(-y[n + 1])
    out[0, 0] = corner
    out[size - 1, 0] = v
