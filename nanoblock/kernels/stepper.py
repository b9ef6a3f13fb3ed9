"""The slider in quasi-static force balance with the drive spring (physics.md section 2).

K (X_L(t) - X) = F, with F the sum of the contacts' forces. While every block stays
pinned the interface is linear in the slider position, F = F0 + k_int (X - X0)
(k_int = dF/dX), so the balanced slider follows the load point at the closed-form
velocity V_f = K V_L / (K + k_int) (:func:`following_velocity`; V_L itself for a rigid
drive, K = inf); each depinning drops F and carries the slider on by its drop over
K + k_int. The path is advanced in internal steps: within a step the blocks see the
exact ramp at V_f plus the depinnings' drift D, the drift realized over the previous
step (events and renewals exact on that ramp); at the step's end the balance is restored
by the elastic jump dX = (K (X_L - X) - F) / (K + k_int), applied at the start of the
next step (or at once, iterated to convergence, before a stored sample), and D += dX / dt.

Step sizes. The drift may advance the slider by at most ``step_slip`` per step (at the
larger of the smoothed drift and the steady one, V_L - V_f), and in transients the drive
mismatch V_L - V_f - D may change the spring force by at most ``force_step`` F per step (a
fraction of alpha F: the slider velocity changes by about 0.5 % per step). Both read the
drift smoothed over about n_blocks / 8 depinnings (at most 1/8 of it from one step), and
the mismatch counts only beyond ``_NOISE_Z`` standard deviations of that smoothed drift's
depinning noise. Two reasons, both measured against an event-by-event reference
(:mod:`tests.naive_quasistatic`): the last step's drift scatters by 1/sqrt(depinnings)
(a stiff spring turns every depinning into a velocity spike), and a limiter reading it
shrank the steps without bound at K/W >= 1e9 1/m; and steps whose length followed that
noise (longer whenever the prediction ran ahead) biased the velocity-step transient by
up to 10 % of its rise, the more so the smaller the force step. The variance of a step's
depinning count is the larger of the count and its spread over the contacts
(:func:`_event_spread`): a chain's avalanches make the drift noisier than independent
depinnings, and a limiter that took them for a transient cut the chain's steps 15-fold at
K/W = 1e9 1/m and 1 mm/s. A stiff spring leaves a
drift of order k_int / K, so its steps run to the samples like a rigid drive's; a soft
one steps every ``step_slip`` of slip. Default rho~_max / 8; measured: at rho~_max / 16 the
transient after a velocity step within the reference's noise (0.1e-3 of mu); at
rho~_max / 4, the old default, up to 1e-3 (6 % of its rise) high, and the direct effect
of a 1 -> 10 um/s spike at K/W = 1e8 1/m 12-18 % high (+5 % at rho~_max / 8, -1 % to
-5 % at / 16): the old stepper's noise-following steps had offset part of that lag.
K = inf is the rigid drive: no drift, no jump, ``step_slip`` bounds the slider's own slip
(unlimited by default).

Runaway slips. When a soft spring's force exceeds what the interface can resist at any
speed (the saturated friction above V*, 001/Fig. 15: the slip phase of stick-slip), the
quasi-static slider has no finite velocity: each step's jump raises the predicted drift
by the factor 1 + jump / step_slip and the steps shrink until time stops advancing. The
drift is capped at ``_ATHERMAL`` omega_a rho~_max, where a block crosses its whole pinned
range in a tenth of an attempt period: a block escapes thermally before its threshold
with probability about 1 / (2 u _ATHERMAL) (1e-3 of the blocks at u = 50), so the slide is
athermal and rate-independent and the cap changes only the slip's duration (rho~_max /
(80 omega_a) per step). The excess force is then shed by the elastic jumps, each firing the
blocks it carries over their threshold, as in :func:`settle`. Checked against the
event-by-event reference (:func:`tests.naive_quasistatic.runaway`): the friction a 3.7 um
slide is arrested at is 1.4e-3 low at the default step (1 % of the drop) and converges to
the reference as the step shrinks.

``slider`` is a one-element record array of :data:`nanoblock.kernels.layout.SLIDER`;
``strength`` and ``tables`` the strength classes of :mod:`.layout`; ``protocol`` is
``(3, S + 1)``: segment start times (last column: end of protocol), load-point
velocities and load-point positions at the segment starts.
"""

from __future__ import annotations

import numpy as np

from nanoblock.kernels._jit import kernel
from nanoblock.kernels.blocks import split_edge
from nanoblock.kernels.contacts import advance_contacts

_BALANCE = 1e-13
"""Relative force residual at which a stored sample counts as balanced."""

_NOISE_Z = 3.0
"""Drive mismatches within this many standard deviations of the smoothed drift's scatter
(``slider.smooth_noise``) are taken for noise, not a transient."""

_WINDOW = 0.125
"""The smoothed drift averages over about this many depinnings per block."""

_MAX_WEIGHT = 0.125
"""Largest weight of one step in the smoothed drift: step sizes must not follow the last
step's noise."""

_MIN_WEIGHT = 1.0 / 64.0
"""Smallest weight of one step in the smoothed drift: with few depinnings per step (a hold,
or a reload, on a stiff spring) the average spans at most ~64 steps, not ~n_blocks / 8
depinnings, which there last thousands of steps: the drift of the last sliding, kept, was
a transient to the force limiter, whose short steps held fewer depinnings still. Measured
(2026-11-29, 1e4 blocks): K/W = 1e12 1/m at 1 nm/s (150 nm, a 100 s hold, 50 nm) 10.4 ->
1.2 s; the quick start's reload at K/W = 1e15 1/m from ~1e6 steps and 20-70 s per sample
to 13-400 steps and 30-500 ms."""

_ATHERMAL = 10.0
"""The drift is capped at this many omega_a rho~_max (see :func:`advance_to`)."""

_ROUNDING = 4.0 * np.finfo(np.float64).eps
"""Relative round-off of a position in units of eps (:func:`settle`)."""

_SETTLE_ROUNDS = 1000
"""Most rounds of elastic jumps and the depinnings they trigger before a sample is stored
(:func:`settle`)."""

_DROP = 2.0
"""Force drop of one depinning in units of the mean block force F / n_blocks (a mean-field
block fires at about twice the mean stress)."""


@kernel(inline=True)
def load_point(t: float, protocol: np.ndarray) -> tuple[float, float, float]:
    """Load-point position X_L(t) [m], velocity [m/s] and the end of the current segment [s]."""
    starts = protocol[0]
    k, last = 0, starts.shape[0] - 2  # bisection for the last segment starting at or before t
    while k < last:  # (np.searchsorted compiles for a second longer)
        middle = (k + last + 1) // 2
        if starts[middle] <= t:
            k = middle
        else:
            last = middle - 1
    return protocol[2, k] + protocol[1, k] * (t - starts[k]), protocol[1, k], starts[k + 1]


@kernel
def following_velocity(load_velocity: float, interface_stiffness: float, spring: float) -> float:
    """Slider velocity while every block stays pinned [m/s]: K V_L / (K + k_int), from
    K (X_L - X) = F0 + k_int (X - X0) (K = ``spring``, k_int [N/m]); V_L for a rigid
    drive (its K -> inf limit)."""
    if spring == np.inf:
        return load_velocity
    return spring * load_velocity / (spring + interface_stiffness)


@kernel(inline=True)
def _balance_jump(position: float, load: float, force: float, k_int: float, params) -> float:
    if params.stiffness == np.inf:
        return load - position
    return (params.stiffness * (load - position) - force) / (params.stiffness + k_int)


@kernel(inline=True)
def _advance_interface(
    slider, state, streams, events, scratch, edges, param_array, strength, tables, coupled,
    velocity, duration,
) -> None:  # fmt: skip
    """Apply the pending jump, slide ``duration`` at ``velocity``, sum forces into the slider."""
    y, h, age, slip, lifetime = state
    force, stiffness = scratch[0], scratch[1]
    s = slider[0]
    omega_a = param_array[0].omega_a
    # per class, not per contact: a step of 500 one-block contacts 99 -> 93 us
    for k in range(strength.shape[0]):
        edges[k] = split_edge(tables[k], omega_a, velocity / strength[k, 1], duration)
    advance_contacts(
        y,
        h,
        age,
        slip,
        lifetime,
        events,
        streams,
        force,
        stiffness,
        s.pending,
        velocity,
        duration,
        param_array,
        strength,
        tables,
        coupled,
        edges,
    )
    s.force = np.sum(force)
    s.stiffness = np.sum(stiffness)


@kernel(inline=True)
def _event_spread(events: np.ndarray, before: np.ndarray) -> tuple[float, float]:
    """Depinnings of one step and the spread of their count over the contacts.

    The spread, n / (n - 1) sum_c (e_c - mean)^2 over the n contacts' counts e_c, estimates
    the variance of the step's total count: the count itself for independent depinnings
    (Poisson), the count times E[S^2] / E[S] when they come in avalanches of S blocks (a
    chain's depinnings trigger their neighbours within the contact).
    """
    n = events.shape[0]
    count = 0.0
    for c in range(n):
        count += events[c] - before[c]
    if n < 2:
        return count, count
    mean = count / n
    spread = 0.0
    for c in range(n):
        spread += (events[c] - before[c] - mean) ** 2
    return count, spread * n / (n - 1)


@kernel(inline=True)
def advance_to(
    t_stop, slider, state, streams, events, scratch, edges, param_array, strength, tables,
    coupled, protocol,
) -> None:  # fmt: skip
    """Advance the interface and the slider from ``slider.time`` to ``t_stop`` [s].

    ``state`` is ``(y, h, age, slip, lifetime)`` (see :mod:`.contacts`); ``scratch`` three
    float arrays of length n_contacts: the contacts' forces, stiffnesses and event counts
    before the step; ``edges`` an int64 array of length n_classes that takes each step's
    split edges (:func:`~.blocks.split_edge`; both allocated by the driver);
    ``param_array`` the one-element PARAMS array; ``coupled`` None for independent blocks
    (the chain kernel is then not compiled), True for chains.
    """
    params = param_array[0]
    s = slider[0]
    spring = params.stiffness
    blocks = state[0].size
    window = max(1.0, blocks * _WINDOW)
    strongest = 0.0  # the largest rho~_max of the strength classes (a loop compiles sooner)
    for k in range(strength.shape[0]):
        strongest = max(strongest, strength[k, 1])
    athermal = _ATHERMAL * params.omega_a * strongest
    while s.time < t_stop:
        _, load_velocity, segment_end = load_point(s.time, protocol)
        following = following_velocity(load_velocity, s.stiffness, spring)
        target = min(t_stop, segment_end)
        dt = target - s.time
        # step sizes from the smoothed drift only: a step that lasted longer whenever the
        # last step's noisy drift ran ahead (or behind) would bias the blocks' path
        drift_rate = max(abs(s.smooth_drift), abs(load_velocity - following))
        if spring == np.inf:  # a rigid drive prescribes the whole path: step_slip bounds it
            drift_rate = abs(load_velocity)
        mismatch = abs(load_velocity - following - s.smooth_drift) - _NOISE_Z * s.smooth_noise
        if spring != np.inf and mismatch > 0.0 and s.force > 0.0:
            dt = min(dt, params.force_step * s.force / (spring * mismatch))
        if drift_rate > 0.0:
            dt = min(dt, params.step_slip / drift_rate)
        if s.last_dt > 0.0:
            dt = min(dt, 2.0 * s.last_dt)
        velocity = following + s.drift
        for c in range(events.shape[0]):  # a loop: a slice assignment compiles its shape check
            scratch[2, c] = events[c]
        _advance_interface(
            slider, state, streams, events, scratch, edges, param_array, strength, tables, coupled,
            velocity, dt,
        )  # fmt: skip
        moved = s.position + velocity * dt
        s.time = target if dt >= target - s.time else s.time + dt
        s.load_point, _, _ = load_point(s.time, protocol)
        s.pending = _balance_jump(moved, s.load_point, s.force, s.stiffness, params)
        s.position = moved + s.pending
        if spring != np.inf:
            # capped: a runaway slip (module docstring) would stop time
            s.drift = min(max(s.drift + s.pending / dt, -athermal), athermal)
            count, spread = _event_spread(events, scratch[2])
            weight = min(_MAX_WEIGHT, max((count + 1.0) / window, _MIN_WEIGHT))
            drop = _DROP * s.force / (blocks * (spring + s.stiffness))
            s.smooth_drift += weight * (s.drift - s.smooth_drift)
            variance = (1.0 - weight) ** 2 * s.smooth_noise**2 + weight**2 * max(count, spread) * (
                drop / dt
            ) ** 2
            s.smooth_noise = np.sqrt(variance)
        s.last_dt = dt
        s.steps += 1


@kernel(inline=True)
def settle(
    slider, state, streams, events, scratch, edges, param_array, strength, tables, coupled,
    max_rounds: int,
) -> int:  # fmt: skip
    """Apply the pending elastic jump and iterate (depinnings it triggers) to balance.

    Afterwards the blocks sit at ``slider.position`` and ``slider.force`` equals the
    spring force to a relative 1e-13, or to the round-off of the spring force, ``_ROUNDING``
    K |X|, where that is larger (a stiff spring: K eps |X| > 1e-13 F; measured: the quick
    start's 2 s hold at K/W = 1e12 1/m, 2 um into the run, took 250-580 rounds per sample,
    each over all blocks, 13.8 s in all, as jumps below the ulp of X left the spring force
    unchanged). Returns the number of rounds needed.
    """
    params = param_array[0]
    s = slider[0]
    for rounds in range(1, max_rounds + 1):
        _advance_interface(
            slider, state, streams, events, scratch, edges, param_array, strength, tables, coupled,
            0.0, 0.0,
        )  # fmt: skip
        s.pending = _balance_jump(s.position, s.load_point, s.force, s.stiffness, params)
        s.position += s.pending
        if abs(s.pending) * s.stiffness <= _BALANCE * max(abs(s.force), 1e-300):
            return rounds
        spring = params.stiffness  # its force K (X_L - X) is known to K eps |X| only
        # (a rigid drive has no spring force: inf * 0 would compare NaN, inf <= inf stop
        # before the jump reached the blocks)
        if spring != np.inf and abs(s.pending) * (spring + s.stiffness) <= (
            _ROUNDING * spring * max(abs(s.position), abs(s.load_point))
        ):
            return rounds
    return max_rounds


@kernel
def advance_to_sample(
    t_sample, slider, state, streams, events, scratch, edges, param_array, strength, tables,
    coupled, protocol,
) -> int:  # fmt: skip
    """:func:`advance_to` ``t_sample``, then :func:`settle`: a balanced stored sample.

    The stepper's one entry point besides :func:`following_velocity`: the other functions
    are inlined into it. Numba links each compiled function's callees into it and
    optimizes the whole tree again, so every wrapper level costs the first run a pass over
    the kernel (the quickstart's compile 19 -> 16 s, measured 2026-11-28)."""
    advance_to(
        t_sample, slider, state, streams, events, scratch, edges, param_array, strength, tables,
        coupled, protocol,
    )  # fmt: skip
    return settle(
        slider, state, streams, events, scratch, edges, param_array, strength, tables, coupled,
        _SETTLE_ROUNDS,
    )  # fmt: skip
