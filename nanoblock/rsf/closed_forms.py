"""Closed forms of the RSF theory: 000/Eq. 15 and 001/Eqs. 9-13 (SI units).

* The slow-ramp solution of the silicon apparatus, s_ext(s) (000/Eq. 15), and its inverse.
* Linear stability of the quasi-static spring-slider with the aging law: critical
  stiffness per load (K/W)_c = (B - A) / Dc and onset pulsation Omega_c (001/Eqs. 9-11).
* The velocity-jump spike d mu = A ln(V2 / V1) and its validity ratio (001/Eqs. 12-13).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq

from nanoblock.rsf.apparatus import Apparatus

FloatArray = NDArray[np.float64]

__all__ = [
    "critical_stiffness",
    "onset_pulsation",
    "slow_ramp_extension",
    "slow_ramp_limit",
    "slow_ramp_sample_extension",
    "velocity_jump_peak",
    "velocity_jump_validity",
]


def slow_ramp_limit(
    apparatus: Apparatus, normal_force: float, params: Mapping[str, float]
) -> float:
    """Plateau s_max = 2 mu_s N / k_s [m], mu_s = B ln(1 + 1/theta*) (000/Eqs. 8-9).

    ``params`` are the ``silicon`` law's (``b``, ``theta_star`` used); N in N.
    """
    mu_s = params["b"] * math.log1p(1.0 / params["theta_star"])
    return float(apparatus.sample_extension(normal_force, mu_s))


def slow_ramp_extension(
    s: ArrayLike, apparatus: Apparatus, normal_force: float, params: Mapping[str, float]
) -> FloatArray:
    """Motor extension s_ext [m] at sample extension s [m] on a slow ramp (000/Eq. 15):

        s_ext = k_s s / c_ext - (c_x Dc / c_ext) ln[1 + theta* (1 - exp(k_s s / 2BN))].

    Zero at s = 0, divergent (``inf`` from there on) at s = ``slow_ramp_limit``. Exact for
    000/Eqs. 14 with theta(0) = 0 in the limit A -> 0, v << v_theta.
    """
    s = np.asarray(s, dtype=float)
    b, dc, theta_star = params["b"], params["dc"], params["theta_star"]
    argument = 1.0 + theta_star * -np.expm1(apparatus.k_s * s / (2.0 * b * normal_force))
    with np.errstate(divide="ignore", invalid="ignore"):
        slip = np.where(argument > 0.0, -dc * np.log(argument), np.inf)
    return (apparatus.k_s * s + apparatus.c_x * slip) / apparatus.c_ext


def slow_ramp_sample_extension(
    s_ext: ArrayLike, apparatus: Apparatus, normal_force: float, params: Mapping[str, float]
) -> FloatArray:
    """Inverse of 000/Eq. 15: sample extension s [m] at motor extension s_ext >= 0 [m].

    Solved by Brent's method in y = x / Dc (slip per memory length), which 000/Eqs. 14b-d
    give in closed form as theta = 1 - exp(-y), s = (2BN / k_s) ln(1 + theta / theta*),
    s_ext = (k_s s + c_x Dc y) / c_ext: s_ext increases from 0 to infinity with y, and
    0 <= y <= c_ext s_ext / (c_x Dc) brackets the root for every s_ext.
    """
    s_ext = np.asarray(s_ext, dtype=float)
    if np.any(s_ext < 0.0) or not np.all(np.isfinite(s_ext)):
        raise ValueError("slow-ramp inverse: s_ext must be finite and >= 0 m")
    b, dc, theta_star = params["b"], params["dc"], params["theta_star"]
    scale = 2.0 * b * normal_force / apparatus.k_s

    def sample(y: float) -> float:
        return scale * math.log1p(-math.expm1(-y) / theta_star)

    def residual(y: float, target: float) -> float:
        return apparatus.k_s * sample(y) + apparatus.c_x * dc * y - apparatus.c_ext * target

    out = np.empty_like(s_ext)
    for index, target in np.ndenumerate(s_ext):
        top = apparatus.c_ext * target / (apparatus.c_x * dc)
        y = brentq(residual, 0.0, top, args=(target,), xtol=1e-14, rtol=1e-13) if top > 0 else 0.0
        out[index] = sample(y)
    return out


def critical_stiffness(a: float, b: float, dc: float) -> float:
    """Critical stiffness per load (K/W)_c = (B - A) / Dc [1/m] (001/Eqs. 9, 11).

    Quasi-static spring-slider, aging law: steady sliding is unstable (stick-slip) below
    it; chi_c = (K/W)_c Dc = B - A. ``dc`` in m; a value <= 0 means no instability.
    """
    return (b - a) / dc


def onset_pulsation(a: float, b: float, dc: float, velocity: float) -> float:
    """Stick-slip pulsation at onset Omega_c = (V / Dc) sqrt(chi_c / A) [rad/s] (001/Eq. 10).

    chi_c = B - A (001/Eq. 9); V is the drive velocity [m/s], ``dc`` in m. Needs B > A > 0.
    """
    if not (b > a > 0.0):
        raise ValueError(f"onset pulsation needs B > A > 0 (got A = {a!r}, B = {b!r})")
    return velocity / dc * math.sqrt((b - a) / a)


def velocity_jump_peak(a: float, v1: float, v2: float) -> float:
    """Spike height d mu = A ln(V2 / V1) after a load-point velocity jump V1 -> V2
    at constant age (001/Eq. 12); velocities in m/s."""
    return a * math.log(v2 / v1)


def velocity_jump_validity(stiffness: float, dc: float, a: float, v1: float, v2: float) -> float:
    """Validity ratio of 001/Eq. 12: (K Dc / W) / [A (V1/V2) ln(V2/V1)] (001/Eq. 13).

    The spike estimate holds when the ratio is >> 1. ``stiffness`` is K/W [1/m], ``dc``
    in m, velocities in m/s (V2 > V1).
    """
    if not (v2 > v1 > 0.0):
        raise ValueError(f"velocity jump needs V2 > V1 > 0 m/s (got V1 = {v1!r}, V2 = {v2!r})")
    return stiffness * dc / (a * (v1 / v2) * math.log(v2 / v1))
