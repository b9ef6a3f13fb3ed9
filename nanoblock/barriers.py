"""Registry of activation-barrier laws for thermal depinning of a pinned nanoblock.

A barrier law gives the reduced barrier f(x) = dU(sigma) / U_a as a function of the
reduced stress x = |sigma| / sigma_a in [0, 1], with U_a = sigma_a b^3 (sigma_a / E_J)
the barrier at zero stress (001/Eq. 37). The escape rate is (001/Eq. 24)

    1 / tau(sigma) = omega_a exp(-u f(x)),   u = U_a / (k_B T),

taken in the direction of the stress (physics.md section 1). Every law satisfies
f(0) = 1 and f(1) = 0, so the zero-stress barrier and the athermal threshold are shared
and only the shape between them differs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

BOLTZMANN = 1.380649e-23
"""Boltzmann constant k_B [J/K] (exact, SI 2019)."""


@dataclass(frozen=True)
class BarrierLaw:
    """A reduced barrier f(x) = dU / U_a on x = |sigma| / sigma_a in [0, 1]."""

    name: str
    description: str
    reduced: Callable[[NDArray[np.float64]], NDArray[np.float64]]

    def __call__(self, x: ArrayLike) -> NDArray[np.float64]:
        """Reduced barrier f(x) for x in [0, 1] (dimensionless)."""
        return self.reduced(np.clip(np.abs(np.asarray(x, dtype=float)), 0.0, 1.0))


def _persson(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return 1.0 - x * x


def _spinodal(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return (1.0 - x) ** 1.5


BARRIERS: dict[str, BarrierLaw] = {
    "persson": BarrierLaw(
        "persson",
        "Persson's barrier dU = U_a (1 - sigma^2 / sigma_a^2) (001/Eq. 37)",
        _persson,
    ),
    "spinodal": BarrierLaw(
        "spinodal",
        "generic saddle-node barrier dU = U_a (1 - sigma / sigma_a)^(3/2) "
        "(001 after Eq. 33; physics.md section 5, barrier_shape)",
        _spinodal,
    ),
}


def barrier_law(name: str) -> BarrierLaw:
    """Return the registered barrier law called ``name``."""
    try:
        return BARRIERS[name]
    except KeyError:
        raise ValueError(
            f"unknown barrier law {name!r}; allowed: {', '.join(sorted(BARRIERS))}"
        ) from None


def zero_stress_barrier(threshold_stress: float, block_size: float, shear_modulus: float) -> float:
    """U_a = sigma_a b^3 (sigma_a / E_J) [J], the barrier at zero stress (001/Eq. 37)."""
    return threshold_stress * block_size**3 * threshold_stress / shear_modulus


def reduced_barrier_height(
    threshold_stress: float, block_size: float, shear_modulus: float, temperature: float
) -> float:
    """u = U_a / (k_B T) (dimensionless; physics.md section 1)."""
    return zero_stress_barrier(threshold_stress, block_size, shear_modulus) / (
        BOLTZMANN * temperature
    )


def lattice_reverse_barrier(s: ArrayLike, barrier: str, u: float, u_elastic: float) -> NDArray:
    """Reduced barrier [k_B T] of a reverse hop on Persson's periodic characteristic.

    With back jumps (physics.md section 5, ``back_jumps``; 001 after Eq. 33) a block's
    pinned branches are one period rho~_max apart: at drive phase s in [0, 1] the upper
    branch carries reduced stress s and the lower one s - 1. The forward hop (upper to
    lower) has the barrier u f(s) of the law; the reverse hop crosses the same saddle
    from the lower branch, whose elastic energy is lower by u_elastic (s - 1/2) (the
    Maxwell point is s = 1/2), so its barrier is u f(s) + u_elastic (s - 1/2). Here
    u_elastic = k1 rho~_max^2 / k_B T (= u for k1 = E_J b).
    """
    s = np.asarray(s, dtype=float)
    return u * barrier_law(barrier)(s) + u_elastic * (s - 0.5)


def lattice_barrier_floor(barrier: str, u: float, u_elastic: float) -> float:
    """Smallest reverse-hop barrier [k_B T] over the period (negative: no consistent lattice)."""
    s = np.linspace(0.0, 1.0, 4097)
    return float(np.min(lattice_reverse_barrier(s, barrier, u, u_elastic)))
