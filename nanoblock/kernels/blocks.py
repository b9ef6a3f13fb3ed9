"""Exact depinning of pinned blocks on a linear stress ramp, and independent (k2 = 0) blocks.

A pinned block's reduced stress x = sigma / sigma_a moves as x(t) = x0 + xdot t while the
slider slides at constant velocity. It depins deterministically when |x| reaches 1, or
thermally when its accumulated hazard omega_a int r(x(t)) dt (001/Eq. 24) reaches its
Exp(1) threshold: the remaining hazard ``h`` is carried per block, so thermal escape is an
exact time-dependent Poisson process, with no time-step coin flips (physics.md section 1).

Arrays: ``y[i]`` reduced stretch s_i / rho_max of block i, ``h[i]`` remaining hazard.
"""

from __future__ import annotations

import numpy as np

from nanoblock.kernels._jit import kernel
from nanoblock.kernels.hazard import (
    ramp_hazard,
    rate,
    rate_cells,
    signed_cumulative,
    signed_inverse,
)
from nanoblock.kernels.rng import standard_exponential, uniform

_SHORT_RAMP = 1e-9
"""Ramps shorter than this (in x) are integrated to first order in their length."""

_CANDIDATES = 1.0
"""A ramp escapes by thinning (:func:`advance_free_blocks`) when the rate bound of its
highest cell gives at most this many expected candidates; beyond, by the exact ramp of
:func:`next_depinning` (the bound then exceeds the rate along most of the ramp, and every
rejected candidate costs about as much as an exact ramp)."""

_SPLIT_CANDIDATES = 0.03
"""A ramp too steep for one bound thins its part below the highest cell edge whose bound
gives at most this many candidates over the call, and takes the exact ramp from that edge,
where the table holds R (one cumulative hazard instead of two)."""


@kernel(inline=True)
def _split_edge(table: np.ndarray, offset: int, cells: int, omega_a: float, duration: float) -> int:
    """The highest cell edge k <= ``cells`` whose rate bound omega_a table[offset + k - 1]
    gives at most ``_SPLIT_CANDIDATES`` candidates over ``duration`` [s] (0 if none, or the
    table has no bounds): a bisection, the bounds increase with k."""
    if offset == 0:
        return 0
    low, high = 0, cells  # the edge lies in [low, high]
    while low < high:
        middle = (low + high + 1) // 2
        if omega_a * table[offset + middle - 1] * duration > _SPLIT_CANDIDATES:
            high = middle - 1
        else:
            low = middle
    return low


@kernel(inline=True)
def split_edge(table: np.ndarray, omega_a: float, x_rate: float, duration: float) -> int:
    """The cell edge below which a rising ramp of ``duration`` [s] thins and above which it
    takes the exact ramp (:func:`_split_edge`); 0 for a ramp that does not rise. It depends
    on the table and the step only, so a caller advancing many contacts of one strength
    class over one step computes it once."""
    if x_rate <= 0.0:
        return 0
    offset, cells, _ = rate_cells(table)
    return _split_edge(table, offset, cells, omega_a, duration)


@kernel(inline=True)
def _land(x: float, eta: float, period: float) -> float:
    """Where a block depinned at stress ``x`` lands (see :func:`advance_free_blocks`)."""
    return x - np.copysign(period, x) if period > 0.0 else -eta * x


@kernel(nrt=False)
def _thin(x, h, x_rate, remaining, bound, omega_a, table, stream, eta, period):
    """A candidate of the thinning process of rate ``bound`` falls within ``remaining``
    (hazard ``h`` <= bound remaining): move there and accept it with probability
    omega_a r(x) / bound, landing as :func:`_land`. Returns the block's stress, the time
    left and 1 if it fired (else 0)."""
    t = h / bound
    x += x_rate * t
    left = max(remaining - t, 0.0)
    if uniform(stream) * bound < omega_a * rate(x, table):
        return _land(x, eta, period), left, 1
    return x, left, 0


@kernel(inline=True)
def next_depinning(
    x0: float, h: float, x_rate: float, horizon: float, omega_a: float, table: np.ndarray
) -> tuple[float, float, float]:
    """When a pinned block on the ramp x0 + x_rate t depins within ``horizon`` [s].

    Returns ``(t, x, h_left)``: the depinning time t <= horizon and stress x, with
    h_left = 0; or t = inf, the stress at the horizon, and the hazard still to go.
    """
    return _next_depinning(x0, np.nan, h, x_rate, horizon, omega_a, table)


@kernel(nrt=False)
def _next_depinning(
    x0: float,
    known: float,
    h: float,
    x_rate: float,
    horizon: float,
    omega_a: float,
    table: np.ndarray,
) -> tuple[float, float, float]:
    """:func:`next_depinning` with R(x0) = ``known`` (NaN: to compute)."""
    if abs(x0) >= 1.0:
        return 0.0, x0, 0.0
    need = h / omega_a  # reduced hazard [s] still to accumulate
    if x_rate == 0.0:
        r0 = rate(x0, table)
        if r0 * horizon >= need:
            return need / r0, x0, 0.0
        return np.inf, x0, h - omega_a * r0 * horizon
    direction = 1.0 if x_rate > 0.0 else -1.0
    x_end = x0 + x_rate * horizon
    crosses = direction * x_end >= 1.0
    x_limit = direction if crosses else x_end
    if abs(x_limit - x0) < _SHORT_RAMP:
        # the rate is constant to first order: hazard and firing time from the time spent,
        # not from x differences, which round to 0 when the ramp is slower than an ulp
        r0 = rate(x0, table)
        span = (direction - x0) / x_rate if crosses else horizon
        if r0 * span >= need:
            t_fire = need / r0
            return t_fire, x0 + x_rate * t_fire, 0.0
        if crosses:
            return span, direction, 0.0
        return np.inf, x_end, h - omega_a * r0 * span
    start = signed_cumulative(x0, table) if np.isnan(known) else known
    available = ramp_hazard(x0, start, x_limit, x_rate, horizon, table)
    if available >= need:
        x_fire = signed_inverse(start + direction * need * abs(x_rate), table)
        t_fire = (x_fire - x0) / x_rate
        t_fire = min(max(t_fire, 0.0), horizon)
        return t_fire, x_fire, 0.0
    if crosses:
        return (direction - x0) / x_rate, direction, 0.0
    return np.inf, x_end, h - omega_a * available


@kernel(nrt=False)
def advance_free_blocks(
    y: np.ndarray,
    h: np.ndarray,
    jump: float,
    x_rate: float,
    duration: float,
    eta: float,
    omega_a: float,
    table: np.ndarray,
    stream: np.ndarray,
    period: float = 0.0,
    edge: int = -1,
) -> int:
    """Advance independent blocks (k2 = 0, reduced stress x = y) over one slider segment.

    The slider first jumps by ``jump`` (reduced, instantaneous), then slides for
    ``duration`` [s] at ``x_rate`` [1/s]. A depinned block lands at x = -eta x_depin
    (``eta`` = 0: the mean-field reset of 001/Fig. 14; eta > 0: the underdamped landing
    of 001/Eq. 21), or, with back jumps (``period`` = 1), hops one period of the
    characteristic towards zero stress, x -> x - sign(x) (forward from the upper branch,
    back from the lower one; :func:`nanoblock.barriers.lattice_reverse_barrier`). It then
    draws a fresh Exp(1) threshold from the contact's ``stream``. Returns the number of
    depinnings.

    A ramp that stays below the threshold where the table bounds the escape rate,
    omega_a r(x) <= b (:func:`~nanoblock.kernels.hazard.rate_cells`), with at most
    ``_CANDIDATES`` expected over it, escapes by thinning (Lewis and Shedler): the remaining
    hazard counts candidates of a Poisson process of rate b, each accepted with probability
    omega_a r(x) / b where it falls; the accepted ones are exactly the escapes at rate
    omega_a r(x). By memorylessness the remaining Exp(1) hazard is the same variable for
    either count, and the choice depends on the ramp only, so a block passes freely between
    thinning and the exact ramp. A ramp that fires no candidate costs a subtraction instead
    of two cumulative hazards: most blocks, when a finite spring cuts the slider's path into
    short steps. A rising ramp too steep for one bound thins its part below a cell edge
    (``_SPLIT_CANDIDATES``) and starts its exact part there, from the tabulated R;
    ``edge``: that cell edge as :func:`split_edge` gives it (-1: computed here).
    """
    events = 0
    offset, cells, lowest = rate_cells(table)
    if edge < 0:
        edge = split_edge(table, omega_a, x_rate, duration)
    edge_x = edge / cells if edge > 0 else -1.0
    edge_bound = omega_a * table[offset + edge - 1] if edge > 0 else 0.0
    for i in range(y.shape[0]):  # i = blocks of one contact
        x = y[i] + jump
        remaining = duration
        while True:
            x_end = x + x_rate * remaining
            low, high = min(x, x_end), max(x, x_end)
            if offset > 0 and low >= lowest and high < 1.0:  # thinning, see the docstring
                bound = omega_a * table[offset + int(max(-low, high) * cells)]
                spent = bound * remaining
                if spent <= _CANDIDATES:
                    if h[i] > spent or bound == 0.0:  # no candidate
                        h[i] -= spent
                        x = x_end
                        break
                    x, remaining, fired = _thin(
                        x, h[i], x_rate, remaining, bound, omega_a, table, stream, eta, period
                    )
                    events += fired
                    h[i] = standard_exponential(stream)
                    continue
            known = np.nan
            if x < edge_x < x_end and x >= max(lowest, -edge_x):  # split (_SPLIT_CANDIDATES)
                below = (edge_x - x) / x_rate
                spent = edge_bound * below
                if h[i] <= spent:  # a candidate
                    x, remaining, fired = _thin(
                        x, h[i], x_rate, remaining, edge_bound, omega_a, table, stream, eta,
                        period,
                    )  # fmt: skip
                    events += fired
                    h[i] = standard_exponential(stream)
                    continue
                h[i] -= spent
                remaining = max(remaining - below, 0.0)
                x = edge_x
                known = table[offset + cells + edge]
            t, x_at, h_left = _next_depinning(x, known, h[i], x_rate, remaining, omega_a, table)
            if t == np.inf:
                x = x_at
                h[i] = h_left
                break
            events += 1
            x = _land(x_at, eta, period)
            h[i] = standard_exponential(stream)
            remaining -= t
        y[i] = x
    return events


@kernel
def landing_overshoot(omega_0_sq: float, damping: float) -> float:
    """eta = exp(-pi gamma / (2 omega_d)) of an isolated block (001/Eq. 21), 0 if overdamped.

    A block released at rest with force f0 towards its equilibrium, its neighbours and
    the plate fixed (omega_0^2 = spring / m_b [1/s^2]), first stops after half a damped
    period with force -eta f0; with gamma >= 2 omega_0 it never stops short (eta = 0).
    """
    discriminant = omega_0_sq - 0.25 * damping**2
    if discriminant <= 0.0:
        return 0.0
    return float(np.exp(-np.pi * damping / (2.0 * np.sqrt(discriminant))))
