"""The Dieterich-Ruina laws' quasi-static spring-slider: right-hand side and exact Jacobian.

State y = (w, s_1, [s_2], delta) with w = ln(v / v0), s_i = ln(theta_i) and delta the slip
(001/Eq. 2; :mod:`nanoblock.rsf.laws`). Each state variable evolves by

    aging (001/Eq. 3):          s_i' = r(v) e^(-s_i) - v / Dc_i,  r = v / (v + v_theta),
    slip (000/Eq. 3):           s_i' = -(v / Dc_i) (ln(v / Dc_i) + s_i)   (0 at v = 0),

with r = 1 without the cutoff velocity v_theta (000/Eq. 7), and the slider by
w' = (K (V_L - v) - b g s_1' - b2 s_2') / a, g = theta_1 / (theta_1 + tau_m) with a
creep onset time tau_m (the saturation law, 001/Eq. 5), else g = 1. LSODA calls them
thousands of times per fit, so they write into the caller's buffers and allocate nothing;
each returns whether every value it wrote is finite (exp(w) overflows where a fit probes
absurd parameters).
``tests/test_rsf_laws.py`` checks them against the generic right-hand side built from the
law's ``state_rate`` and ``gradient``, and the Jacobian against its central differences.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import kernel

AGING = 0
"""``constants[8]`` of a law whose state variables follow the aging law."""
SLIP = 1
"""``constants[8]`` of a law whose state variables follow the slip law."""


@kernel(inline=True, nrt=False)
def _evolution(
    v: float, s: float, dc: float, v_theta: float, slip: bool
) -> tuple[float, float, float]:
    """(s', ds'/dw, ds'/ds) of one state variable s = ln(theta) at velocity v = v0 e^w."""
    if slip:
        if v <= 0.0:
            return 0.0, 0.0, 0.0
        rate = -(v / dc) * (math.log(v / dc) + s)
        return rate, rate - v / dc, -v / dc
    clock = v / (v + v_theta) if v_theta > 0.0 else 1.0
    healing = clock * math.exp(-s)
    return healing - v / dc, healing * (1.0 - clock) - v / dc, -healing


@kernel(inline=True, nrt=False)
def _state_weight(s: float, b: float, tau: float) -> tuple[float, float]:
    """(dmu/ds_1, its derivative in s_1): b, or b theta / (theta + tau_m) at theta = e^s
    with the creep onset time tau_m > 0 [s]."""
    if tau <= 0.0:
        return b, 0.0
    theta = math.exp(s)
    weight = b * theta / (theta + tau)
    return weight, weight * tau / (theta + tau)


@kernel(nrt=False)
def log_slider_rate(y: np.ndarray, drive: float, constants: np.ndarray, out: np.ndarray) -> bool:
    """dy/dt [1/s] at drive V_L [m/s] into ``out``; ``constants`` = (a, b, Dc [m], v0 [m/s],
    K/W [1/m], v_theta [m/s] or 0 for no cutoff, b2, Dc2 [m], AGING or SLIP, tau_m [s] or 0
    for no saturation), b2 and Dc2 read only when y holds a second state variable
    (``y.size == 4``)."""
    a, b, dc, v0, stiffness = constants[0], constants[1], constants[2], constants[3], constants[4]
    v_theta, slip = constants[5], constants[8] == SLIP
    v = v0 * math.exp(y[0])
    first, _, _ = _evolution(v, y[1], dc, v_theta, slip)
    out[1] = first
    weight, _ = _state_weight(y[1], b, constants[9])
    elastic = stiffness * (drive - v) - weight * first
    if y.size == 4:
        second, _, _ = _evolution(v, y[2], constants[7], v_theta, slip)
        out[2] = second
        elastic -= constants[6] * second
    out[0] = elastic / a
    out[y.size - 1] = v
    return math.isfinite(out[0]) and math.isfinite(first)


@kernel(nrt=False)
def log_slider_jacobian(
    y: np.ndarray, drive: float, constants: np.ndarray, out: np.ndarray
) -> bool:
    """d(dy/dt)/dy of :func:`log_slider_rate` into ``out`` (dv/dw = v)."""
    a, b, dc, v0, stiffness = constants[0], constants[1], constants[2], constants[3], constants[4]
    v_theta, slip = constants[5], constants[8] == SLIP
    size = y.size
    v = v0 * math.exp(y[0])
    out[:, :] = 0.0
    first, by_w, by_s = _evolution(v, y[1], dc, v_theta, slip)
    out[1, 0], out[1, 1] = by_w, by_s
    weight, slope = _state_weight(y[1], b, constants[9])
    out[0, 0] = -stiffness * v - weight * by_w
    out[0, 1] = -weight * by_s - slope * first
    if size == 4:
        b2 = constants[6]
        _, by_w2, by_s2 = _evolution(v, y[2], constants[7], v_theta, slip)
        out[2, 0], out[2, 2] = by_w2, by_s2
        out[0, 0] -= b2 * by_w2
        out[0, 2] = -b2 * by_s2
    for j in range(size - 1):
        out[0, j] /= a
    out[size - 1, 0] = v
    return math.isfinite(out[0, 0])
