"""The clamped-sample apparatus of 000 (000/Fig. 1B, Eqs. 9-14), driven by any RSF law.

A sample of stiffness k_s is clamped by a normal force N on a frame (stiffness k_f) that is
stretched through external springs (k_ext) by a motor extension s_ext. With the slip
x = s_f - s, quasi-static equilibrium reads (000/Eqs. 9-14)

    k_s s = 2 mu N,    2 mu N = c_ext s_ext - c_x x,    x' = v,

with c_ext, c_x from 000/Eqs. 12-13. Differentiating, d mu / dt = (c_x / 2N) (V_L - v)
with V_L = c_ext s_ext' / c_x: the spring-slider of ``nanoblock.rsf.slider`` with stiffness
per load k = c_x / (2N) and load-point velocity V_L. ``solve_apparatus`` therefore calls
``solve_slider`` (quasi-static, LSODA per segment of the piecewise-linear s_ext(t)).

Presets: 000/Table 1 (apparatus) and 000/Table 2 (surfaces), converted to SI.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from nanoblock.rsf.laws import Law
from nanoblock.rsf.slider import LoadPointHistory, solve_slider

FloatArray = NDArray[np.float64]

__all__ = [
    "APPARATUS",
    "FIG2_NORMAL_FORCE",
    "FIG2_PROTOCOL",
    "FIG3_NORMAL_FORCES",
    "FIG3_PROTOCOL",
    "K_EXT",
    "K_F",
    "SURFACES",
    "Apparatus",
    "ExtensionProtocol",
    "Surface",
    "solve_apparatus",
]

_UM = 1e-6
"""One micrometre [m]."""
_N_PER_UM = 1e6
"""One N/um in N/m."""


@dataclass(frozen=True)
class Apparatus:
    """Sample stiffness k_s and the effective constants c_ext, c_x of 000/Eq. 11 [N/m]."""

    k_s: float
    c_ext: float
    c_x: float
    source: str = ""

    def __post_init__(self) -> None:
        for name in ("k_s", "c_ext", "c_x"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"apparatus: {name} = {value!r} N/m is out of range (0, inf)")

    @classmethod
    def from_stiffnesses(cls, k_s: float, k_f: float, k_ext: float, source: str = "") -> Apparatus:
        """From the spring constants [N/m]: c_ext, c_x by 000/Eqs. 12-13."""
        total = k_f + k_ext + k_s
        return cls(k_s, k_s * k_ext / total, k_s * (k_f + k_ext) / total, source)

    def sample_extension(self, normal_force: float, mu: ArrayLike) -> FloatArray:
        """Sample extension s = 2 mu N / k_s [m] at friction coefficient mu, N in N
        (000/Eq. 9)."""
        return 2.0 * np.asarray(mu, dtype=float) * normal_force / self.k_s


K_EXT = 98.1 * _N_PER_UM
"""External loading springs k_ext [N/m] (000/Table 1)."""
K_F = 5.93e3 * _N_PER_UM
"""Frame k_f [N/m] (000/Table 1)."""

APPARATUS: dict[str, Apparatus] = {
    "silicon": Apparatus(
        279 * _N_PER_UM, 4.60 * _N_PER_UM, 283 * _N_PER_UM, "000/Table 1, c-values as printed"
    ),
    "quartz": Apparatus(
        161.5 * _N_PER_UM, 2.56 * _N_PER_UM, 157 * _N_PER_UM, "000/Table 1, c-values as printed"
    ),
    "silicon_from_k": Apparatus.from_stiffnesses(
        279 * _N_PER_UM, K_F, K_EXT, "000/Table 1 k-values through 000/Eqs. 12-13"
    ),
    "quartz_from_k": Apparatus.from_stiffnesses(
        161.5 * _N_PER_UM, K_F, K_EXT, "000/Table 1 k-values through 000/Eqs. 12-13"
    ),
}
"""000/Table 1 in SI. The printed silicon c-values are not Eqs. 12-13 of the printed
k_s = 279 N/um (those give c_ext = 4.34, c_x = 266.7 N/um; Eq. 13 even forbids c_x > k_s)
but they are of k_s = 297 N/um (4.61, 283.0), likely transposed digits. The quartz
c-values agree with Eqs. 12-13. The ``*_from_k`` presets apply Eqs. 12-13."""


@dataclass(frozen=True)
class Surface:
    """One column of 000/Table 2, in SI; ``params`` are the ``silicon`` law's."""

    dc: float
    """Memory length D_c [m]."""
    mu_s: float
    """Static friction coefficient (tilted-block measurement)."""
    theta_star: float
    a: float
    v_theta: float
    """State cutoff velocity [m/s]."""
    v_star: float
    """Velocity scale v* [m/s]."""
    source: str = ""

    @property
    def b(self) -> float:
        """B = mu_s / ln(1 + 1/theta*) (000/Eq. 8)."""
        return self.mu_s / math.log1p(1.0 / self.theta_star)

    @property
    def params(self) -> dict[str, float]:
        """Parameters of ``law("silicon")``; add ``aging_rate`` for ``two_state``."""
        return {
            "a": self.a,
            "b": self.b,
            "dc": self.dc,
            "theta_star": self.theta_star,
            "v_theta": self.v_theta,
            "v_star": self.v_star,
        }


SURFACES: dict[str, Surface] = {
    "si_steel_1": Surface(1.33 * _UM, 0.188, 1.15, 7.5e-4, 0.0295 * _UM, 1e-6 * _UM, "000/Table 2"),
    "si_steel_2": Surface(0.5 * _UM, 0.16, 0.2, 5.0e-4, 0.2 * _UM, 1e-6 * _UM, "000/Table 2"),
    "quartz_steel": Surface(0.8 * _UM, 0.05, 1.15, 5.0e-4, 1.5 * _UM, 1e-6 * _UM, "000/Table 2"),
}
"""000/Table 2 (Si/steel 1: machine-ground steel, Fig. 2; Si/steel 2: sanded steel,
Fig. 3; quartz/steel), in SI."""


@dataclass(frozen=True)
class ExtensionProtocol:
    """Piecewise-linear motor extension s_ext(t) through knots (``times`` [s],
    ``extensions`` [m]), held after the last knot.

    s_ext is measured from the relaxed apparatus; it must be >= 0 and must not decrease
    (000/Eqs. 9-14 assume that no force changes sign).
    """

    times: FloatArray
    extensions: FloatArray

    def __post_init__(self) -> None:
        times = np.asarray(self.times, dtype=float)
        extensions = np.asarray(self.extensions, dtype=float)
        if times.ndim != 1 or times.shape != extensions.shape or times.size < 2:
            raise ValueError(
                "extension protocol: times and extensions must be 1-d, same length >= 2"
            )
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(extensions))):
            raise ValueError("extension protocol: knots must be finite")
        if np.any(np.diff(times) <= 0.0):
            raise ValueError("extension protocol: knot times must increase strictly [s]")
        if extensions[0] < 0.0 or np.any(np.diff(extensions) < 0.0):
            raise ValueError(
                "extension protocol: s_ext must be >= 0 m and must not decrease "
                "(000/Eqs. 9-14 assume no force changes sign)"
            )
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "extensions", extensions)

    @classmethod
    def stepped(
        cls, step: float = 30 * _UM, rise: float = 16.0, hold: float = 284.0, count: int = 4
    ) -> ExtensionProtocol:
        """``count`` rises by ``step`` [m] over ``rise`` [s], each held ``hold`` [s]
        (000/Fig. 2: 30 um over 16 s, 284 s hold, four times)."""
        period = rise + hold
        starts = period * np.arange(count)
        times = np.ravel(np.column_stack([starts, starts + rise]))
        levels = step * np.arange(count + 1)
        extensions = np.ravel(np.column_stack([levels[:-1], levels[1:]]))
        return cls(np.append(times, count * period), np.append(extensions, levels[-1]))

    @classmethod
    def ramp(cls, extension: float = 127 * _UM, duration: float = 370.0) -> ExtensionProtocol:
        """Steady rise from 0 to ``extension`` [m] over ``duration`` [s] (000/Fig. 3)."""
        return cls(np.array([0.0, duration]), np.array([0.0, extension]))

    @property
    def rates(self) -> FloatArray:
        """ds_ext/dt in each segment between knots [m/s]."""
        return np.diff(self.extensions) / np.diff(self.times)

    def extension_at(self, t: ArrayLike) -> FloatArray:
        """s_ext(t) [m]."""
        return np.interp(np.asarray(t, dtype=float), self.times, self.extensions)


FIG2_PROTOCOL = ExtensionProtocol.stepped()
"""000/Fig. 2: +30 um over 16 s, hold 284 s, four times."""
FIG2_NORMAL_FORCE = 467.0
"""000/Fig. 2 normal force [N]."""
FIG3_PROTOCOL = ExtensionProtocol.ramp()
"""000/Fig. 3: s_ext from 0 to 127 um over 370 s."""
FIG3_NORMAL_FORCES = (100.0, 200.0, 300.0, 400.0, 500.0, 600.0)
"""Six normal forces [N] for 000/Fig. 3. The paper does not list them; this range spans
its other loads (200 N in Fig. 4, 467 N in Fig. 2); with Si/steel 2 every curve comes
within 1.5 % of its plateau 2 mu_s N / k_s (0.11-0.69 um) by the end of the ramp."""


def _var(values: ArrayLike, units: str, long_name: str) -> tuple:
    return ("time", np.asarray(values), {"units": units, "long_name": long_name})


def solve_apparatus(
    law: Law,
    params: Mapping[str, float],
    apparatus: Apparatus,
    normal_force: float,
    protocol: ExtensionProtocol,
    times: ArrayLike | None = None,
    *,
    initial_state: Sequence[float] | None = None,
) -> xr.Dataset:
    """Integrate 000/Eqs. 14a-d (friction by ``law``) and sample at ``times`` [s].

    The run starts at ``protocol.times[0]`` with no slip, x = 0, so that
    2 mu N = c_ext s_ext (000/Eq. 14b; mu = 0 for a relaxed start, s_ext = 0), in
    ``initial_state`` (law state coordinates; default theta = 0, a fresh contact, for laws
    that allow rest); the initial slip velocity follows from that friction. ``times``
    (default 2001 points up to the last knot) must not precede the start; ``normal_force``
    N is in N. Returns time, s_ext, s, x, mu, v and the law's state coordinates, SI units
    in each variable's attrs.
    """
    if not (math.isfinite(normal_force) and normal_force > 0.0):
        raise ValueError(f"normal force N = {normal_force!r} N is out of range (0, inf)")
    start = protocol.times[0]
    times = (
        np.linspace(start, protocol.times[-1], 2001)
        if times is None
        else np.asarray(times, dtype=float)
    )
    if times.ndim != 1 or times.size == 0 or times[0] < start:
        raise ValueError(f"times must be a non-empty 1-d array from t >= {start} s (the start)")
    if initial_state is None:
        if not law.allows_rest:
            raise ValueError(
                f"law {law.name!r} cannot start from a fresh contact at rest; give initial_state"
            )
        initial_state = [0.0] * len(law.state_names)
    p = law.pack(params)
    # mu is linear in the velocity coordinate w: solve mu(w0, s0) = c_ext s_ext / 2N.
    state0 = [float(value) for value in initial_state]
    mu_start = protocol.extensions[0] * apparatus.c_ext / (2.0 * normal_force)
    w0 = (mu_start - law.friction(0.0, state0, p)) / law.gradient(0.0, state0, p)[0]
    try:
        v0 = law.velocity(w0, p)
    except OverflowError:
        raise ValueError(
            f"the initial friction mu = {mu_start!r} needs a slip velocity beyond float range in "
            f"state {state0}; give an initial_state that carries the preload"
        ) from None

    history = LoadPointHistory(
        protocol.times,
        np.append(protocol.rates * apparatus.c_ext / apparatus.c_x, 0.0),
    )
    grid = times if times[0] == start else np.concatenate([[start], times])
    solution = solve_slider(
        law,
        params,
        history,
        grid,
        apparatus.c_x / (2.0 * normal_force),
        initial_velocity=v0,
        initial_state=state0,
    )
    keep = slice(grid.size - times.size, None)
    data = {
        "s_ext": _var(protocol.extension_at(times), "m", "motor extension s_ext"),
        "s": _var(
            apparatus.sample_extension(normal_force, solution.friction[keep]),
            "m",
            "sample extension s = 2 mu N / k_s",
        ),
        "x": _var(solution.slip[keep], "m", "slip x = s_f - s"),
        "mu": _var(solution.friction[keep], "1", "friction coefficient mu"),
        "v": _var(solution.velocity[keep], "m/s", "slip velocity v = dx/dt"),
    }
    for name, values in zip(law.state_names, solution.state[:, keep], strict=True):
        data[name] = _var(values, "1", f"state coordinate {name}")
    return xr.Dataset(
        data,
        coords={"time": ("time", times, {"units": "s", "long_name": "time"})},
        attrs={
            "law": law.name,
            "normal_force_N": float(normal_force),
            "k_s_N_per_m": apparatus.k_s,
            "c_ext_N_per_m": apparatus.c_ext,
            "c_x_N_per_m": apparatus.c_x,
            **{f"param_{name}": value for name, value in zip(law.names, p, strict=True)},
        },
    )
