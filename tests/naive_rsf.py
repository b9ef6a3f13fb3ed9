"""Naive reference spring-slider for the aging, slip, cutoff and saturation laws, written
the usual way.

As common RSF tools do it: state (mu, theta) in natural variables, the load-point
velocity looked up inside the right-hand side, v recovered from the friction law, and
(``solver="odeint"``) one ``scipy.integrate.odeint`` call over the whole output array.
That usual way fails on the reload after a long hold (LSODA's error test breaks down as
v jumps by decades in natural variables); ``solver="radau"`` (implicit Radau IIA,
``solve_ivp``, one call per segment, the default) survives it and is the test reference.
Neither shares code with :mod:`nanoblock.rsf`, so agreement tests both. Also, from
nanoblock-free code, the aging-law fit to the mean-field renewal relaxation
(:func:`renewal_fit_bias`), the reference for the coarse-graining's B and Dc biases.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import odeint, solve_ivp
from scipy.optimize import least_squares


def naive_slider(
    law: str,
    params: dict[str, float],
    segments: list[tuple[float, float]],
    times: np.ndarray,
    stiffness: float,
    *,
    solver: str = "radau",
    rtol: float = 1e-11,
    atol: float = 1e-13,
    initial_velocity: float | None = None,
) -> np.ndarray:
    """Friction at ``times`` (starting at 0) for (velocity, duration) load-point segments,
    starting in steady state at ``initial_velocity`` (default: the first segment's).
    ``stiffness`` is K/W [1/m]."""
    mu0, a, b, dc, v0 = (params[k] for k in ("mu0", "a", "b", "dc", "v0"))
    ends = np.cumsum([d for _, d in segments])
    velocities = [v for v, _ in segments]

    def load_velocity(t: float) -> float:
        i = int(np.searchsorted(ends, t, side="left"))
        return velocities[min(i, len(velocities) - 1)]

    v_theta = params.get("v_theta", 0.0)  # cutoff law: healing rate v / (v + v_theta)
    tau = params.get("tau_m", 0.0)  # saturation law: area ~ ln(theta + tau_m)

    def state_friction(theta: float) -> float:
        if law == "saturation":
            return b * math.log((theta + tau) / (dc / v0 + tau))
        return b * math.log(v0 * theta / dc)

    def rhs(t: float, y: np.ndarray) -> list[float]:
        mu, theta = y
        theta = max(theta, 1e-300)  # Newton iterates of Radau may probe theta <= 0
        v = v0 * math.exp(min((mu - mu0 - state_friction(theta)) / a, 700.0))
        if law == "slip":
            dtheta = -v * theta / dc * math.log(v * theta / dc)
        else:
            dtheta = v / (v + v_theta) - v * theta / dc
        return [stiffness * (load_velocity(t) - v), dtheta]

    v_start = velocities[0] if initial_velocity is None else initial_velocity
    theta_start = dc / (v_start + v_theta)
    y0 = [mu0 + a * math.log(v_start / v0) + state_friction(theta_start), theta_start]
    if solver == "odeint":
        return odeint(rhs, y0, times, rtol=rtol, atol=atol, tfirst=True, mxstep=10**6)[:, 0]
    mu = np.empty(times.size)
    t0, y = 0.0, np.array(y0)
    for end in [*ends[:-1], np.nextafter(max(times[-1], ends[-1]), np.inf)]:
        inside = (times >= t0) & (times < end)
        solution = solve_ivp(
            rhs, (t0, end), y, method="Radau", rtol=rtol, atol=atol,
            t_eval=np.concatenate([times[inside], [end]]),
        )  # fmt: skip
        mu[inside] = solution.y[0, :-1]
        t0, y = end, solution.y[:, -1]
    return mu


def renewal_fit_bias(
    segments: list[tuple[float, float]],
    times: np.ndarray,
    memory_length: float,
    aging_time: float,
) -> tuple[float, float]:
    """(B / B0, Dc / D0) of an aging-law fit to the mean-field renewal relaxation.

    Contacts renew after exponentially distributed slip of mean D0 and carry
    B0 ln(1 + phi/tau_m) at age phi (001/Eqs. 3, 5), so on a rigid drive through the
    (velocity, duration) segments, from a steady start at the first velocity,
    mu = A ln V + B0 <ln(1 + phi/tau_m)>, with <ln(1 + phi/tau_m)> = int exp(-X(phi)/D0)
    d ln(tau_m + phi), X(phi) the slip of the last phi seconds. The aging law
    (mu0, A, B, Dc free, imposed velocity, exact per segment) is fitted at ``times``;
    the model is linear in A and B0, so the ratios depend on neither."""
    v1 = segments[0][0]
    ends = np.cumsum([d for _, d in segments])
    starts = ends - [d for _, d in segments]
    slip = np.concatenate([[0.0], np.cumsum([v * d for v, d in segments])])

    def displacement(t: np.ndarray) -> np.ndarray:
        i = np.clip(np.searchsorted(ends, t, side="right"), 0, len(segments) - 1)
        velocity = np.array([v for v, _ in segments])[i]
        return np.where(t < 0.0, v1 * t, slip[i] + velocity * (t - starts[i]))

    u = np.linspace(math.log(aging_time), math.log(aging_time + 60 * memory_length / v1), 8001)
    ages = np.exp(u) - aging_time
    lost = displacement(times[:, None]) - displacement(times[:, None] - ages[None, :])
    area = np.trapezoid(np.exp(-lost / memory_length), u, axis=1)
    index = np.clip(np.searchsorted(ends, times, side="right"), 0, len(segments) - 1)
    velocity = np.array([v for v, _ in segments])[index]

    def aging(x: np.ndarray) -> np.ndarray:
        mu0, a, b, dc = x[0], x[1], x[2], math.exp(x[3])
        theta, boundary = [dc / v1], []
        for v, d in segments:
            boundary.append(theta[-1])
            theta.append(dc / v + (theta[-1] - dc / v) * math.exp(-v * d / dc))
        start = np.array(boundary)[index]
        relaxed = dc / velocity + (start - dc / velocity) * np.exp(
            -velocity * (times - starts[index]) / dc
        )
        return mu0 + a * np.log(velocity / v1) + b * np.log(v1 * relaxed / dc)

    result = least_squares(
        lambda x: aging(x) - area, [area[0], 0.0, 1.0, math.log(memory_length / 2)]
    )
    return float(result.x[2]), float(math.exp(result.x[3]) / memory_length)
