"""Micro-to-macro mapping: nanoblock joint and interface -> rate-and-state parameters.

The expected coarse-grained RSF parameters of a nanoblock interface (physics.md
section 2; to be checked against simulations, not assumed):

* A = alpha_eff mu0 (001/Eq. 16) with alpha_eff = d ln sigma_s / d ln V, the exact local
  slope of the mean-field friction stress (001/Eq. 28), which tends to
  alpha = k_B T / (sigma_s0 v_act) (001/Eq. 18) with v_act = 8 b^3 sigma_bar / E_J
  (001/Eq. 33) near V*;
* B = m mu0 (001/Eq. 16), m the area-creep coefficient of 001/Eq. 5;
* D_c ~ D0, the mean contact diameter (001/Eq. 3);
* mu0 = sigma_s(V) / p: real area W / p times the steady stress, per unit load.

And the experimentalist's inverse, the activation volume from a measured A (001/Eq. 19):
v_act = k_B T / (p A).
"""

from __future__ import annotations

from dataclasses import dataclass

from nanoblock.barriers import BOLTZMANN
from nanoblock.theory.meanfield import MeanFieldJoint, log_slope, steady_stress

__all__ = ["PredictedRSF", "activation_volume_from_direct_effect", "predicted_rsf"]


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
