"""Friction time series from the mean-field renewal picture, integrated without any
rate-and-state law: the independent generator of the hidden-effect matrix.

Contacts are born in proportion to slip and die after exponentially distributed slip of
mean D (001/Eq. 3); a contact of age phi carries area 1 + m ln(1 + phi / tau_m) (001/Eq. 5),
its age running on the clock d phi / dt = V / (V + v_theta) (v_theta = 0: real time). The
population is a list of cohorts, one per 0.02 D of slip and per 2 % change of V (weights
exact for exponential survival over each cohort's slip; births even in time within a
cohort, as its ages assume), so the state is a sum over the whole slip history, not an
ODE. Friction mu = mu0 + a ln(V / v0) + sum_p b_p (S_p - S_p(0)), S_p the mean log area of
population p, and a quasi-static spring dmu/dt = K (V_lp - V), stepped implicitly in ln V
by a predictor-corrector: a backward-Euler predictor with the state at the step's start,
then the spring by the trapezoid rule with the predicted state at its end (slip per step
<= 0.01 D, |d mu| <= a / 20, and steps <= 2 % of the time since the segment began).
On the matrix's effect-free draws it agrees with the renewal law of
:mod:`nanoblock.rsf.laws` at the true parameters to chi^2 <= 17.4 per run at the matrix's
noise (median 0.8; the first-order step with the state lagged and cohorts blind to V left
up to 1e-3 after every change of velocity, chi^2 of hundreds). Variants:

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

import numba
import numpy as np

COHORT = 0.02
"""Cohort width [D]."""
STEP_SLIP = 0.01
"""Largest slip per step [D]."""
VELOCITY_SPREAD = 0.02
"""Largest change of ln V within a cohort (its ages are spread evenly in time, which
needs a steady birth rate V / D: a cohort spanning a hold's decaying creep would age its
early-born contacts as if born late)."""
FRICTION_STEP = 0.05
"""Largest friction change per step [a]."""
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


@numba.njit(cache=True)
def _state(
    clock: float,
    began: np.ndarray,
    ended: np.ndarray,
    birth_time: np.ndarray,
    tau_m: float,
    slip_like: bool,
    survivors: np.ndarray,
) -> float:
    """sum_i survivors_i A_i over the cohorts (see :class:`_Cohorts`): a cohort's log area
    A_i is ln(1 + u / tau_m) averaged over ages u spread evenly between its youngest and
    oldest contact (slip_like: fixed at birth). Walked from the youngest cohort, whose
    oldest age is the next older cohort's youngest when one began as the other ended."""
    total = 0.0
    shared, shared_at = 0.0, math.nan  # the primitive at the last cohort's oldest age
    for i in range(began.size - 1, -1, -1):
        if slip_like:
            area = math.log1p(birth_time[i] / tau_m)
        else:
            old = max(clock - began[i], 0.0) / tau_m
            young = max(clock - ended[i], 0.0) / tau_m
            if ended[i] == shared_at:
                primitive_young = shared
            else:
                primitive_young = (1.0 + young) * math.log1p(young) - young
            log_old = math.log1p(old)
            shared, shared_at = (1.0 + old) * log_old - old, began[i]
            area = (shared - primitive_young) / (old - young) if old - young > 1e-9 else log_old
        total += survivors[i] * area
    return total


class _Cohorts:
    """Contacts grouped by birth: start slip x, slip width w, the clock when the cohort
    began (c) and ended (e), birth contact time g (used by ``slip_like``); per population
    the survivors relative to slip ``reference`` (exact for exponential survival over the
    cohort's slip), rebased every shortest D of slip. The live cohorts are the columns
    ``lo:hi`` of preallocated buffers (oldest first): a new cohort is written at ``hi``, a
    forgotten one advances ``lo``, and the buffers are compacted only when full."""

    def __init__(self, p: Renewal, v_start: float) -> None:
        self.p = p
        self.coefficients, self.lengths = (np.array(v) for v in zip(*p.populations, strict=True))
        span = HISTORY * self.lengths.max()
        width = COHORT * p.d0
        x = width * np.arange(-math.ceil(span / width), 0)  # the youngest ends at slip 0
        self.columns = np.empty((5, 2 * x.size + 16))  # rows x, w, c, e, g
        self.survivors = np.empty((self.lengths.size, self.columns.shape[1]))
        self.lo, self.hi = 0, x.size
        rate = p.clock_rate(v_start)
        self.x[:] = x
        self.w[:] = width
        self.c[:] = x / v_start * rate
        self.e[:] = self.c + width / v_start * rate
        self.g[:] = p.d0 / v_start
        self.reference = 0.0
        self.factors[:] = self._factors(slice(None))

    def _row(self, k: int) -> np.ndarray:
        return self.columns[k, self.lo : self.hi]

    x = property(lambda self: self._row(0))
    w = property(lambda self: self._row(1))
    c = property(lambda self: self._row(2))
    e = property(lambda self: self._row(3))
    g = property(lambda self: self._row(4))
    factors = property(lambda self: self.survivors[:, self.lo : self.hi])

    def _factors(self, cohorts: slice) -> np.ndarray:
        """(populations, cohorts): e^{-(reference - end) / D_p} (1 - e^{-w / D_p}), the
        survivors of each cohort at slip ``reference`` (exact for exponential survival
        over the cohort's slip)."""
        end, w = self.x[cohorts] + self.w[cohorts], self.w[cohorts]
        d = self.lengths[:, None]
        return np.exp(-(self.reference - end) / d) * -np.expm1(-w / d)

    def state(self, x: float, clock: float) -> float:
        """sum_p b_p S_p: mean log area of each population at slip x and clock value."""
        if x - self.reference > self.lengths.min():
            self.reference = x
            self.factors[:] = self._factors(slice(None))
        shift = self.coefficients * np.exp(-(x - self.reference) / self.lengths)
        survivors = shift @ self.factors
        return _state(clock, self.c, self.e, self.g, self.p.tau_m, self.p.slip_like, survivors)

    def newborn(self, slip: float, ages: float, v: float) -> float:
        """sum_p b_p S_p of the contacts born over the last ``slip`` [m], their ages spread
        evenly over 0..``ages`` [s] (the youngest cohort :meth:`grow` would add)."""
        if self.p.slip_like:
            area = math.log1p(self.p.d0 / v / self.p.tau_m)
        else:
            y = ages / self.p.tau_m
            area = ((1.0 + y) * math.log1p(y) - y) / y if y > 1e-9 else 0.5 * y
        return area * float(self.coefficients @ -np.expm1(-slip / self.lengths))

    def grow(self, x_old: float, x_new: float, begun: float, clock: float, v: float) -> None:
        """Slip x_old -> x_new (clock ``begun`` -> ``clock``) joins the youngest cohort, or
        starts a new one."""
        if x_new <= x_old:
            return
        steady = abs(math.log(v * self.g[-1] / self.p.d0)) < VELOCITY_SPREAD
        if steady and self.w[-1] < COHORT * self.p.d0 and self.x[-1] + self.w[-1] >= x_old - 1e-30:
            self.w[-1] += x_new - x_old
            self.e[-1] = clock
            self.factors[:, -1:] = self._factors(slice(-1, None))
            return
        if self.hi == self.columns.shape[1]:  # full: move the live cohorts to the front
            live = self.hi - self.lo
            self.columns[:, :live] = self.columns[:, self.lo : self.hi]
            self.survivors[:, :live] = self.survivors[:, self.lo : self.hi]
            self.lo, self.hi = 0, live
            if 2 * live > self.columns.shape[1]:
                self.columns = np.hstack([self.columns, np.empty_like(self.columns)])
                self.survivors = np.hstack([self.survivors, np.empty_like(self.survivors)])
        self.columns[:, self.hi] = x_old, x_new - x_old, begun, clock, self.p.d0 / v
        self.hi += 1
        self.factors[:, -1:] = self._factors(slice(-1, None))
        alive = x_new - self.x < HISTORY * self.lengths.max()
        if not alive[0]:  # cohorts are oldest first: the forgotten ones are a prefix
            self.lo += int(np.argmax(alive))


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
                FRICTION_STEP * p.a / (stiffness * abs(v_lp - v) + 1e-300),
                0.02 * (t - start) + 1e-4 * p.d0 / max(v_lp, segments[0][0]),
                end - t,
            )
            # predictor: the state at the start (backward Euler on the spring)
            gain = dt * stiffness * p.v0
            y = _implicit_log_velocity(p.a, gain, p.mu0 + state - mu - dt * stiffness * v_lp)
            v_new = p.v0 * math.exp(y)
            slip = 0.5 * (v + v_new) * dt
            ages = dt * 0.5 * (p.clock_rate(v) + p.clock_rate(v_new))
            # corrector: the predicted state at the end, the spring by the trapezoid rule
            state = cohorts.state(x + slip, clock + ages) + cohorts.newborn(slip, ages, v_new)
            state -= reference
            rest = p.mu0 + state - mu - dt * stiffness * (v_lp - 0.5 * v)
            y = _implicit_log_velocity(p.a, 0.5 * gain, rest)
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
