"""Friction time series from the mean-field renewal picture, integrated without any
rate-and-state law: the independent generator of the hidden-effect matrix.

Contacts are born in proportion to slip and die after exponentially distributed slip of
mean D (001/Eq. 3); a contact of age phi carries area 1 + m ln(1 + phi / tau_m) (001/Eq. 5),
its age running on the clock d phi / dt = V / (V + v_theta) (v_theta = 0: real time). The
population is a list of cohorts, one per 0.02 D of slip (weights exact for exponential
survival over each cohort's slip), so the state is a sum over the whole slip history,
not an ODE. Friction mu = mu0 + a ln(V / v0) + sum_p b_p (S_p - S_p(0)), S_p the mean log
area of population p, and a quasi-static spring dmu/dt = K (V_lp - V), stepped
semi-implicitly in ln V (slip per step <= 0.01 D, |d mu| <= a / 20, and steps <= 2 % of
the time since the segment began). Variants:

- ``slip_like``: a contact keeps the area of its birth, set by the contact time D / V at
  birth (stationary contacts do not heal; the slip law's state as a renewal average);
- a second population (b2, D2 >> D): two state variables;
- a preceding segment at another velocity cut off before the record.

It never imports :mod:`nanoblock`; the aging law it is fitted with is only its
coarse-grained approximation (``tests/naive_rsf.py::renewal_fit_bias``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

COHORT = 0.02
"""Cohort width [D]."""
STEP_SLIP = 0.01
"""Largest slip per step [D]."""
HISTORY = 18.0
"""Steady pre-history [longest D] (survival e^-18 ~ 1.5e-8 at its start)."""


@dataclass
class Renewal:
    """Parameters of the renewal spring-slider (SI; friction dimensionless)."""

    mu0: float
    a: float
    b: float
    d0: float
    """Memory length D [m] of the first population."""
    tau_m: float
    """Creep onset time [s]."""
    v0: float = 1e-6
    v_theta: float = 0.0
    """Ageing-clock cutoff velocity [m/s] (0: ages run in real time)."""
    slip_like: bool = False
    b2: float = 0.0
    d2: float = 0.0
    """Second population's coefficient and memory length [m] (b2 = 0: none)."""
    populations: list[tuple[float, float]] = field(init=False)

    def __post_init__(self) -> None:
        self.populations = [(self.b, self.d0)] + ([(self.b2, self.d2)] if self.b2 else [])

    def clock_rate(self, v: float) -> float:
        return v / (v + self.v_theta) if self.v_theta else 1.0


class _Cohorts:
    """Contacts grouped by birth: start slip x, slip width w, the clock when the cohort
    began (c) and ended (e), birth contact time g (used by ``slip_like``)."""

    def __init__(self, p: Renewal, v_start: float) -> None:
        self.p = p
        span = HISTORY * max(d for _, d in p.populations)
        width = COHORT * p.d0
        self.x = np.arange(-span, 0.0, width)
        self.w = np.full(self.x.size, width)
        rate = p.clock_rate(v_start)
        self.c = self.x / v_start * rate
        self.e = self.c + width / v_start * rate
        self.g = np.full(self.x.size, p.d0 / v_start)

    def state(self, x: float, clock: float) -> float:
        """sum_p b_p S_p: mean log area of each population at slip x and clock value."""
        p = self.p
        if p.slip_like:
            area = np.log1p(self.g / p.tau_m)
        else:  # ln(1 + u / tau_m) averaged over ages u spread evenly in [clock - e, clock - c]
            old, young = (np.maximum(clock - c, 0.0) / p.tau_m for c in (self.c, self.e))
            spread = np.maximum(old - young, 1e-9)
            primitive = [(1.0 + u) * np.log1p(u) - u for u in (old, young)]
            area = np.where(
                old - young > 1e-9, (primitive[0] - primitive[1]) / spread, np.log1p(old)
            )
        total = 0.0
        for b, d in p.populations:
            weight = np.exp(-(x - self.x - self.w) / d) * -np.expm1(-self.w / d)
            total += b * float(np.dot(weight, area))
        return total

    def grow(self, x_old: float, x_new: float, begun: float, clock: float, v: float) -> None:
        """Slip x_old -> x_new (clock ``begun`` -> ``clock``) joins the youngest cohort, or
        starts a new one."""
        if x_new <= x_old:
            return
        if self.w[-1] < COHORT * self.p.d0 and self.x[-1] + self.w[-1] >= x_old - 1e-30:
            self.w[-1] += x_new - x_old
            self.e[-1] = clock
            return
        self.x = np.append(self.x, x_old)
        self.w = np.append(self.w, x_new - x_old)
        self.c = np.append(self.c, begun)
        self.e = np.append(self.e, clock)
        self.g = np.append(self.g, self.p.d0 / v)
        alive = x_new - self.x < HISTORY * max(d for _, d in self.p.populations)
        if not alive[0]:
            self.x, self.w, self.c, self.e, self.g = (
                a[alive] for a in (self.x, self.w, self.c, self.e, self.g)
            )


def _implicit_log_velocity(a: float, gain: float, rest: float) -> float:
    """Root y of a y + gain e^y + rest = 0 (increasing, convex), by Newton from the right."""
    y = min(-rest / a, 700.0)
    for _ in range(100):
        h = a * y + gain * math.exp(y) + rest
        step = h / (a + gain * math.exp(y))
        y -= step
        if abs(step) < 1e-12:
            break
    return y


def renewal_slider(
    p: Renewal,
    segments: list[tuple[float, float]],
    stiffness: float,
    *,
    start_velocity: float | None = None,
    record_from: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """(time, mu) at every integration step for load-point (velocity, duration) segments,
    from steady sliding at ``start_velocity`` (default the first segment's); time is
    counted from ``record_from`` [s] and earlier steps are dropped. ``stiffness`` is K/W
    [1/m]."""
    v = segments[0][0] if start_velocity is None else start_velocity
    cohorts = _Cohorts(p, v)
    x, clock, t = 0.0, 0.0, 0.0
    reference = cohorts.state(x, clock)
    mu = p.mu0 + p.a * math.log(v / p.v0)
    times, frictions = [t], [mu]
    for v_lp, duration in segments:
        start, end = t, t + duration
        while t < end * (1 - 1e-12):
            state = cohorts.state(x, clock) - reference
            scale = max(v, v_lp, 1e-300)
            dt = min(
                STEP_SLIP * p.d0 / scale,
                0.05 * p.a / (stiffness * abs(v_lp - v) + 1e-300),
                0.02 * (t - start) + 1e-4 * p.d0 / max(v_lp, segments[0][0]),
                end - t,
            )
            gain = dt * stiffness * p.v0
            rest = p.mu0 + state - mu - dt * stiffness * v_lp
            y = _implicit_log_velocity(p.a, gain, rest)
            v_new = p.v0 * math.exp(y)
            mu = p.mu0 + state + p.a * y
            x_new = x + 0.5 * (v + v_new) * dt
            begun, clock = clock, clock + dt * 0.5 * (p.clock_rate(v) + p.clock_rate(v_new))
            cohorts.grow(x, x_new, begun, clock, v_new)
            x, v, t = x_new, v_new, t + dt
            times.append(t)
            frictions.append(mu)
    times_array = np.array(times) - record_from
    keep = times_array >= 0.0
    return times_array[keep], np.array(frictions)[keep]
