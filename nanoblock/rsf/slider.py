"""Spring-slider driver for the RSF laws (physics.md section 3; 001/Eqs. 9-13).

A block pulled through a spring of stiffness K by a load point moving at V_L(t) obeys,
per unit normal load W,

    d(f)/dt = k (V_L - v),            f = K (x_L - x) / W,  k = K / W   [1/m]
    f = mu(v, s)                      (quasi-static), or
    (M / W) dv/dt = f - mu(v, s)      (with slider inertia, mass per load M/W [s^2/m]),

with the state s following the law. The quasi-static system is integrated in the law's
velocity coordinate w (``laws`` module), d w / dt = [k (V_L - v) - sum_i dmu/ds_i s_i'] /
(dmu/dw). A stiffness of ``inf`` imposes v = V_L (velocity control). The load-point
history is piecewise constant; each segment is a separate LSODA integration
(``scipy.integrate.odeint``: it switches between Adams and BDF as stiffness demands), so
no step straddles a velocity jump, and output is LSODA's own interpolant at the requested
times, so the sampling rate never changes the solution.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import ODEintWarning, odeint

from nanoblock.rsf.laws import Law

FloatArray = NDArray[np.float64]

__all__ = ["LoadPointHistory", "SliderSolution", "solve_slider"]

RTOL = 1e-10
ATOL = 1e-12
MAX_STEPS = 1_000_000


@dataclass(frozen=True)
class LoadPointHistory:
    """Piecewise-constant load-point velocity V_L(t).

    Segment i applies ``velocities[i]`` [m/s] from ``starts[i]`` [s] until
    ``starts[i + 1]`` (the last segment never ends); a hold is velocity 0.
    """

    starts: FloatArray
    velocities: FloatArray

    def __post_init__(self) -> None:
        starts = np.asarray(self.starts, dtype=float)
        velocities = np.asarray(self.velocities, dtype=float)
        if starts.ndim != 1 or starts.shape != velocities.shape or starts.size == 0:
            raise ValueError("starts and velocities must be 1-d arrays of the same length >= 1")
        if not (np.all(np.isfinite(starts)) and np.all(np.isfinite(velocities))):
            raise ValueError("load-point history: starts and velocities must be finite")
        if np.any(np.diff(starts) <= 0.0):
            raise ValueError("load-point history: segment starts must increase strictly")
        if np.any(velocities < 0.0):
            raise ValueError("load-point history: velocities must be >= 0 m/s")
        object.__setattr__(self, "starts", starts)
        object.__setattr__(self, "velocities", velocities)

    @classmethod
    def from_segments(
        cls, segments: Sequence[tuple[float, float]], start: float = 0.0
    ) -> LoadPointHistory:
        """From (velocity [m/s], duration [s]) pairs; the last one is extended forever."""
        velocities = [float(v) for v, _ in segments]
        durations = np.array([float(d) for _, d in segments])
        if np.any(durations <= 0.0):
            raise ValueError("load-point history: every segment duration must be > 0 s")
        starts = start + np.concatenate([[0.0], np.cumsum(durations)[:-1]])
        return cls(starts, np.array(velocities))

    @classmethod
    def from_samples(
        cls, time: ArrayLike, velocity: ArrayLike, displacement: ArrayLike | None = None
    ) -> LoadPointHistory:
        """From a sampled piecewise-constant velocity column.

        A change between samples i-1 and i is placed where the measured load-point
        ``displacement`` (if given) says it happened, x_i - x_(i-1) = V_(i-1) (t_s -
        t_(i-1)) + V_i (t_i - t_s), kept within the two samples; midway otherwise.
        """
        time = np.asarray(time, dtype=float)
        velocity = np.asarray(velocity, dtype=float)
        change = np.flatnonzero(np.diff(velocity) != 0.0) + 1
        before, after = time[change - 1], time[change]
        switch = 0.5 * (before + after)
        if displacement is not None:
            x = np.asarray(displacement, dtype=float)
            v1, v2 = velocity[change - 1], velocity[change]
            located = (x[change] - x[change - 1] - v2 * after + v1 * before) / (v1 - v2)
            switch = np.where(np.isfinite(located), np.clip(located, before, after), switch)
            # a switch on a sample, up to rounding, is put on it: a segment 1e-14 s long
            # before the sample is an illegal input for LSODA
            near = 1e-9 * (after - before)
            switch = np.where(after - switch < near, after, switch)
            switch = np.where(switch - before < near, before, switch)
        starts = np.concatenate([[time[0]], switch])
        return cls(starts, np.concatenate([[velocity[0]], velocity[change]]))

    def segment_at(self, t: ArrayLike) -> NDArray[np.intp]:
        """Index of the segment in force at each time t [s] (0 before the first start)."""
        index = np.searchsorted(self.starts, np.asarray(t, dtype=float), side="right") - 1
        return np.clip(index, 0, None)

    def velocity_at(self, t: ArrayLike) -> FloatArray:
        """V_L(t) [m/s]."""
        return self.velocities[self.segment_at(t)]

    def displacement_at(self, t: ArrayLike) -> FloatArray:
        """x_L(t) - x_L(starts[0]) [m]."""
        t = np.asarray(t, dtype=float)
        ends = np.concatenate([[0.0], np.cumsum(np.diff(self.starts) * self.velocities[:-1])])
        index = self.segment_at(t)
        return ends[index] + self.velocities[index] * (t - self.starts[index])


@dataclass(frozen=True)
class SliderSolution:
    """Spring-slider trajectory at the requested times (SI units)."""

    law: str
    time: FloatArray
    friction: FloatArray
    velocity: FloatArray
    state: FloatArray
    """State coordinates, shape (n_state, n_time), as named by ``Law.state_names``."""
    slip: FloatArray
    load_point_displacement: FloatArray
    state_names: tuple[str, ...]

    def to_dataset(self) -> xr.Dataset:
        """The trajectory as an xarray Dataset with units and long names."""

        def var(values: ArrayLike, units: str, long_name: str) -> tuple:
            return ("time", np.asarray(values), {"units": units, "long_name": long_name})

        data = {
            "friction_coefficient": var(self.friction, "1", "friction coefficient mu"),
            "slider_velocity": var(self.velocity, "m/s", "slip velocity"),
            "slider_displacement": var(self.slip, "m", "slip since the first sample"),
            "load_point_displacement": var(
                self.load_point_displacement, "m", "load-point displacement since the first sample"
            ),
        }
        for name, values in zip(self.state_names, self.state, strict=True):
            data[f"state_{name}"] = var(values, "1", f"state coordinate {name}")
        return xr.Dataset(
            data,
            coords={"time": ("time", self.time, {"units": "s", "long_name": "time"})},
            attrs={"law": self.law},
        )


def _quasi_static_rhs(law: Law, p: tuple[float, ...], stiffness: float):
    """d/dt of (w, s, slip) for the quasi-static slider, on Python floats: numpy scalars
    and the generic loop over state coordinates cost most of a fit's time, so one state
    coordinate gets its own version. Both do the operations of ``evaluate`` in the same
    order (the same numbers); where a float division by zero raises, ``reference`` (the
    same on numpy scalars) gives inf or nan instead, as it always did."""
    velocity, gradient, state_rate = law.velocity, law.gradient, law.state_rate

    def evaluate(w, s, drive: float) -> list[float]:
        v = velocity(w, p)
        rates = state_rate(v, s, p)
        dmu_dw, dmu_ds = gradient(w, s, p)
        elastic = stiffness * (drive - v)
        for slope, rate in zip(dmu_ds, rates, strict=True):
            elastic -= slope * rate
        return [elastic / dmu_dw, *rates, v]

    def reference(t: float, y: FloatArray, drive: float) -> list[float]:
        return evaluate(y[0], y[1:-1], drive)

    def rhs(t: float, y: FloatArray, drive: float) -> list[float]:
        values = y.tolist()
        try:
            return evaluate(values[0], values[1:-1], drive)
        except ZeroDivisionError:
            return reference(t, y, drive)

    def one_state_rhs(t: float, y: FloatArray, drive: float) -> list[float]:
        w, state, _ = y.tolist()
        s = (state,)
        try:
            v = velocity(w, p)
            (rate,) = state_rate(v, s, p)
            dmu_dw, (slope,) = gradient(w, s, p)
            elastic = stiffness * (drive - v)
            elastic -= slope * rate
            return [elastic / dmu_dw, rate, v]
        except ZeroDivisionError:
            return reference(t, y, drive)

    return one_state_rhs if len(law.state_names) == 1 else rhs


def _inertial_rhs(law: Law, p: tuple[float, ...], stiffness: float, mass: float):
    velocity, slope_v, friction, state_rate = (
        law.velocity,
        law.velocity_slope,
        law.friction,
        law.state_rate,
    )

    def rhs(t: float, y: FloatArray, drive: float) -> list[float]:
        f, w, s = y[0], y[1], y[2:-1]
        v = velocity(w, p)
        acceleration = (f - friction(w, s, p)) / mass
        return [stiffness * (drive - v), acceleration / slope_v(w, p), *state_rate(v, s, p), v]

    return rhs


def _velocity_controlled_rhs(law: Law, p: tuple[float, ...]):
    state_rate = law.state_rate

    def rhs(t: float, y: FloatArray, drive: float) -> list[float]:
        return [*state_rate(drive, y[:-1], p), drive]

    return rhs


_UNRESOLVED = 64
"""Intervals of at most this many ulp of t are below the integrator's time resolution
(LSODA refuses to start on them): a segment that starts that close before a sample, as a
step located from rounded displacements can, begins at the sample."""


def solve_slider(
    law: Law,
    params: Mapping[str, float],
    history: LoadPointHistory,
    times: ArrayLike,
    stiffness: float,
    *,
    mass: float = 0.0,
    initial_velocity: float | None = None,
    initial_state: Sequence[float] | None = None,
    rtol: float = RTOL,
    atol: float = ATOL,
    max_steps: int = MAX_STEPS,
) -> SliderSolution:
    """Integrate the spring-slider from ``times[0]`` and sample it at ``times`` [s].

    ``stiffness`` is K/W [1/m] (``inf`` for velocity control), ``mass`` is M/W [s^2/m].
    The slider starts at ``initial_velocity`` (default V_L(times[0])) in ``initial_state``
    (law state coordinates; default the steady state at that velocity); slip and
    load-point displacement are measured from ``times[0]``. ``max_steps`` bounds the
    LSODA steps per output interval (a ``RuntimeError`` beyond).
    """
    p = law.pack(params)
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size == 0 or np.any(np.diff(times) < 0.0):
        raise ValueError("times must be a non-empty, non-decreasing 1-d array [s]")
    if not (stiffness > 0.0):
        raise ValueError(f"stiffness K/W = {stiffness!r} 1/m is out of range (0, inf]")
    if mass < 0.0 or not math.isfinite(mass):
        raise ValueError(f"mass M/W = {mass!r} s^2/m is out of range [0, inf)")
    controlled = math.isinf(stiffness)
    v_start = float(history.velocity_at(times[0])) if initial_velocity is None else initial_velocity
    if controlled and not law.allows_rest:
        if np.any(history.velocities[history.starts < times[-1]] <= 0.0):
            raise ValueError(
                f"law {law.name!r}: velocity control (stiffness inf) needs V_L > 0 in every segment"
            )
    if initial_state is None:
        initial_state = [float(x) for x in law.steady_state(max(v_start, 1e-300), p)]
    state0 = [float(x) for x in initial_state]
    if len(state0) != len(law.state_names):
        raise ValueError(f"law {law.name!r} has {len(law.state_names)} state coordinate(s)")

    jacobian = None
    if controlled:
        rhs = _velocity_controlled_rhs(law, p)
        y = np.array([*state0, 0.0])
    elif mass > 0.0:
        rhs = _inertial_rhs(law, p, stiffness, mass)
        w0 = law.coordinate(v_start, p)
        y = np.array([law.friction(w0, state0, p), w0, *state0, 0.0])
    else:
        system = law.quasi_static_system(p, stiffness)
        rhs, jacobian = system or (_quasi_static_rhs(law, p, stiffness), None)
        y = np.array([law.coordinate(v_start, p), *state0, 0.0])

    rows = np.empty((times.size, y.size))
    boundaries = np.concatenate([history.starts[1:], [np.inf]])
    t_now, filled = times[0], 0
    for end, drive in zip(boundaries, history.velocities, strict=True):
        if end <= t_now:
            continue
        stop = min(end, times[-1])
        inside = times[filled:][times[filled:] <= stop]
        grid = np.unique(np.concatenate([[t_now], inside, [stop]]))
        if grid.size > 1 and grid[1] - grid[0] <= _UNRESOLVED * np.spacing(abs(grid[1])):
            grid = grid[1:]  # a start a few ulp before the next time: LSODA cannot step it
        if grid.size > 1:
            try:
                with warnings.catch_warnings():  # failure is reported below, with context
                    warnings.simplefilter("ignore", ODEintWarning)
                    solution, info = odeint(
                        rhs, y, grid, args=(float(drive),), Dfun=jacobian, tfirst=True,
                        rtol=rtol, atol=atol, mxstep=max_steps, full_output=True,
                    )  # fmt: skip
                message = info["message"]
            except OverflowError as error:
                message = f"overflow ({error})"
            if message != "Integration successful.":
                hint = (
                    "a slider mass too small to resolve is better treated as mass = 0 "
                    "(quasi-static)"
                    if mass > 0.0
                    else f"the machine stiffness K/W = {stiffness:.3g} 1/m may be beyond what "
                    "the data resolve (stiffness inf: velocity control)"
                )
                raise RuntimeError(
                    f"spring-slider integration failed in the segment starting at t = {t_now} s "
                    f"(V_L = {drive} m/s): {message}; {hint}"
                )
        else:
            solution = y[None, :]
        rows[filled : filled + inside.size] = solution[np.searchsorted(grid, inside)]
        filled += inside.size
        y, t_now = solution[-1], stop
        if filled == times.size:
            break

    state = rows[:, -1 - len(state0) : -1].T
    slip = rows[:, -1]
    load_point = history.displacement_at(times) - history.displacement_at(times[0])
    if controlled:
        velocity = history.velocity_at(times)
        w = np.array([law.coordinate(v, p) for v in velocity])
    else:
        w = rows[:, 1] if mass > 0.0 else rows[:, 0]
        velocity = law.velocities(w, p)
    if controlled or mass > 0.0:
        friction = np.array([law.friction(wi, si, p) for wi, si in zip(w, state.T, strict=True)])
    else:
        # quasi-static: f = mu holds at all times and df/dt = k (V_L - v), so friction is
        # the elastic stress, with no law evaluation per sample
        friction = law.friction(w[0], state[:, 0], p) + stiffness * (load_point - slip)
    runaway = ~(np.isfinite(friction) & np.isfinite(velocity))
    if runaway.any():
        raise RuntimeError(
            f"the spring-slider runs away at t = {times[np.argmax(runaway)]} s (law "
            f"{law.name!r}, K/W = {stiffness} 1/m): slip becomes unbounded, as in stick-slip "
            "below the critical stiffness; it has no finite friction to report"
        )
    return SliderSolution(
        law=law.name,
        time=times,
        friction=friction,
        velocity=velocity,
        state=state,
        slip=slip,
        load_point_displacement=load_point,
        state_names=law.state_names,
    )
