"""Micro-to-macro mapping: nanoblock joint and interface -> rate-and-state parameters.

The expected coarse-grained RSF parameters of a nanoblock interface (physics.md
section 2; to be checked against simulations, not assumed):

* A = alpha_eff mu0 (001/Eq. 16) with alpha_eff = d ln sigma_s / d ln V, the exact local
  slope of the mean-field friction stress (001/Eq. 28), which tends to
  alpha = k_B T / (sigma_s0 v_act) (001/Eq. 18) with v_act = 8 b^3 sigma_bar / E_J
  (001/Eq. 33) near V*;
* B = m mu0 (001/Eq. 16), m the area-creep coefficient of 001/Eq. 5;
* D_c ~ D0, the mean contact diameter (001/Eq. 3);
* mu0 = sigma_s(V) / p: real area W / p times the steady stress, per unit load (at
  birth; the steady contacts' area is larger by the factor 1 + m <ln(1 + phi / tau_m)>
  of 001/Eq. 5, :func:`steady_log_area`).

And the experimentalist's inverse, the activation volume from a measured A (001/Eq. 19):
v_act = k_B T / (p A).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import exp1

from nanoblock.barriers import BOLTZMANN
from nanoblock.theory.meanfield import MeanFieldJoint, log_slope, steady_stress

__all__ = [
    "PredictedRSF",
    "activation_volume_from_direct_effect",
    "predicted_rsf",
    "steady_log_area",
]

_EXP1_ASYMPTOTIC = 700.0
"""Above this tau_m / <phi>, e^z E1(z) is taken as 1 / z (relative error < 1 / z^2)."""


@dataclass(frozen=True)
class PredictedRSF:
    """RSF parameters predicted for a nanoblock interface at one velocity (SI units)."""

    velocity: float
    mu0: float
    a: float
    b: float
    dc: float
    alpha: float
    """Exact local slope d ln sigma_s / d ln V of 001/Eq. 28 at ``velocity``."""


def predicted_rsf(
    joint: MeanFieldJoint, hardness: float, aging_m: float, memory_length: float, velocity: float
) -> PredictedRSF:
    """A = alpha mu0, B = m mu0, D_c = D0, mu0 = sigma_s(V) / p (001/Eqs. 16, 28).

    ``hardness`` p [Pa], ``aging_m`` m (001/Eq. 5), ``memory_length`` D0 [m],
    ``velocity`` V [m/s].
    """
    if not hardness > 0.0:
        raise ValueError(f"hardness p = {hardness!r} Pa is out of range (0, inf)")
    if not memory_length > 0.0:
        raise ValueError(f"memory_length D0 = {memory_length!r} m is out of range (0, inf)")
    mu0 = float(steady_stress(velocity, joint)) / hardness
    alpha = float(log_slope(velocity, joint))
    return PredictedRSF(velocity, mu0, alpha * mu0, aging_m * mu0, memory_length, alpha)


def activation_volume_from_direct_effect(a: float, temperature: float, hardness: float) -> float:
    """v_act = k_B T / (p A) [m^3] (001/Eq. 19), from a measured direct effect A."""
    for name, value in (("a", a), ("temperature", temperature), ("hardness", hardness)):
        if not value > 0.0:
            raise ValueError(f"{name} = {value!r} is out of range (0, inf)")
    return BOLTZMANN * temperature / (hardness * a)


def steady_log_area(
    memory_lengths: ArrayLike, aging_time: float, velocity: float, state_cutoff: float = 0.0
) -> float:
    """<ln(1 + phi / tau_m)> over contacts in steady sliding at V [m/s] (001/Eqs. 3, 5).

    A contact renewed after Exp(D0) of slip has, in steady sliding, an age phi ~ Exp with
    mean D0 / (V + v_theta) (v_theta: ``state_cutoff`` [m/s], 0 for a clock that always
    runs), so E[ln(1 + phi / tau_m)] = e^z E1(z) with z = tau_m (V + v_theta) / D0
    (~ ln(1 / z) - gamma_E for z << 1). ``memory_lengths``: D0 [m] of every contact
    (one value per contact, or per population with equal weights); ``aging_time`` tau_m
    [s]. The steady friction is (sigma_s / p)(1 + m times this), 001/Eq. 5 averaged.
    """
    memory = np.asarray(memory_lengths, dtype=float)
    if not (np.all(memory > 0.0) and np.all(np.isfinite(memory))):
        raise ValueError("memory lengths D0 must be finite and > 0: without renewal the ages grow")
    if not (aging_time > 0.0 and velocity > 0.0 and state_cutoff >= 0.0):
        raise ValueError(
            f"tau_m = {aging_time!r} s and V = {velocity!r} m/s must be > 0, "
            f"v_theta = {state_cutoff!r} m/s >= 0"
        )
    z = aging_time * (velocity + state_cutoff) / memory
    small = np.minimum(z, _EXP1_ASYMPTOTIC)
    values = np.where(z < _EXP1_ASYMPTOTIC, np.exp(small) * exp1(small), 1.0 / z)
    return float(np.mean(values))
