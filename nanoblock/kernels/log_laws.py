"""The Dieterich-Ruina laws' quasi-static spring-slider right-hand side.

State y = (w, s_1, [s_2], delta) with w = ln(v / v0), s_i = ln(theta_i) and delta the slip
(001/Eq. 2; :mod:`nanoblock.rsf.laws`). Each state variable evolves by

    aging (001/Eq. 3):          s_i' = r(v) e^(-s_i) - v / Dc_i,  r = v / (v + v_theta),
    slip (000/Eq. 3):           s_i' = -(v / Dc_i) (ln(v / Dc_i) + s_i)   (0 at v = 0),

with r = 1 without the cutoff velocity v_theta (000/Eq. 7), and the slider by
w' = (K (V_L - v) - b g s_1' - b2 s_2') / a, g = theta_1 / (theta_1 + tau_m) with a
creep onset time tau_m (the saturation law, 001/Eq. 5), else g = 1.

It does the operations of the laws' generic right-hand side (``state_rate`` and
``gradient`` in :func:`nanoblock.rsf.slider._quasi_static_rhs`) in the same order, so LSODA
takes the same steps and every fit is the same to the last bit, 1.15-1.6x sooner (LSODA
calls it thousands of times per fit; it writes into the caller's buffer and allocates
nothing). LSODA gets no Jacobian: with the exact one it took other steps, and a fit's
finite differences over them led some fits to other optima (a combined two-load
diagnosis took 37 s instead of 16 s, measured 2026-11-27). ``tests/test_rsf_laws.py``
checks the equality.
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
def _evolution(v: float, s: float, dc: float, v_theta: float, slip: bool) -> float:
    """s' [1/s] of one state variable s = ln(theta) at velocity v [m/s]."""
    if slip:
        if v <= 0.0:  # v ln v -> 0: no evolution at rest (v underflows after long holds)
            return 0.0
        return -(v / dc) * (math.log(v / dc) + s)
    if v_theta > 0.0:
        return v / (v + v_theta) * math.exp(-s) - v / dc
    return math.exp(-s) - v / dc


@kernel(nrt=False)
def log_slider_rate(y: np.ndarray, drive: float, constants: np.ndarray, out: np.ndarray) -> bool:
    """dy/dt [1/s] at drive V_L [m/s] into ``out``; ``constants`` = (a, b, Dc [m], v0 [m/s],
    K/W [1/m], v_theta [m/s] or 0 for no cutoff, b2, Dc2 [m], AGING or SLIP, tau_m [s] or 0
    for no saturation), b2 and Dc2 read only when y holds a second state variable
    (``y.size == 4``). Returns whether w' and s_1' are finite (exp(w) overflows where a fit
    probes absurd parameters)."""
    a, b, dc, v0, stiffness = constants[0], constants[1], constants[2], constants[3], constants[4]
    v_theta, slip, tau = constants[5], constants[8] == SLIP, constants[9]
    v = v0 * math.exp(y[0])
    first = _evolution(v, y[1], dc, v_theta, slip)
    out[1] = first
    if tau > 0.0:
        theta = math.exp(y[1])
        b = b * theta / (theta + tau)
    elastic = stiffness * (drive - v)
    elastic -= b * first
    if y.size == 4:
        second = _evolution(v, y[2], constants[7], v_theta, slip)
        out[2] = second
        elastic -= constants[6] * second
    out[0] = elastic / a
    out[y.size - 1] = v
    return math.isfinite(out[0]) and math.isfinite(first)
