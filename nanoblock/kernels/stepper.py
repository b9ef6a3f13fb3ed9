"""The slider in quasi-static force balance with the drive spring (physics.md section 2).

K (X_L(t) - X) = F, with F the sum of the contacts' forces. While every block stays
pinned the interface is linear in the slider position, F = F0 + k_int (X - X0)
(k_int = dF/dX), so the balanced slider follows the load point at the closed-form
velocity V_f = K V_L / (K + k_int) (:func:`following_velocity`; V_L itself for a rigid
drive, K = inf). Each depinning drops F and moves the slider on by its force drop over
K + k_int. The slider path is advanced in internal steps: within a step the blocks see
the exact ramp at V_f plus the depinnings' drift D predicted from the previous step
(events and renewals exact on that ramp); at the step's end the balance is restored by
the elastic jump dX = (K (X_L - X) - F) / (K + k_int), applied to the blocks at the
start of the next step (or at once, iterated to convergence, before a stored sample),
and the drift is corrected by it, D += dX / dt.

Only the depinning-driven slip is approximated (predicted from the previous step), so
only it bounds the steps: per step it may advance at most ``step_slip``, at the predicted
drift or at the steady one V_L - V_f = V_L k_int / (K + k_int). A stiff spring leaves a
drift of order k_int / K of the slip, and K -> inf is the rigid drive: no drift, no jump,
steps to the next sample or segment end. In transients (a velocity step, the loading of
a soft spring) the drive mismatch V_L - V_f - D changes the spring force at K times it;
a step may change the force so by at most ``force_step`` F (0.005 alpha F, so the
interface's velocity changes by about 0.5 % per step and the prediction lags little).
The mismatch counts only beyond ``_NOISE_Z`` standard deviations of the drift's scatter:
each depinning drops the force by about 2 F / n_blocks, so the drift measured over a
step with n depinnings scatters by 2 F sqrt(n) / (n_blocks (K + k_int) dt). On a stiff
spring that velocity noise is all the mismatch there is, and it bounds no step.

``slider`` is a one-element record array of :data:`nanoblock.kernels.layout.SLIDER`;
``strength`` and ``tables`` the strength classes of :mod:`.layout`; ``protocol`` is
``(3, S + 1)``: segment start times (last column: end of protocol), load-point
velocities and load-point positions at the segment starts.
"""

from __future__ import annotations

import numpy as np

from nanoblock.kernels._jit import kernel
from nanoblock.kernels.contacts import advance_contacts

_BALANCE = 1e-13
"""Relative force residual at which a stored sample counts as balanced."""

_NOISE_Z = 3.0
"""Drive mismatches within this many standard deviations of the predicted drift's scatter
(``slider.noise``) are taken for noise, not a transient."""


@kernel
def load_point(t: float, protocol: np.ndarray) -> tuple[float, float, float]:
    """Load-point position X_L(t) [m], velocity [m/s] and the end of the current segment [s]."""
    starts = protocol[0]
    k = max(np.searchsorted(starts, t, side="right") - 1, 0)
    k = min(k, starts.shape[0] - 2)
    return protocol[2, k] + protocol[1, k] * (t - starts[k]), protocol[1, k], starts[k + 1]


@kernel
def following_velocity(load_velocity: float, interface_stiffness: float, spring: float) -> float:
    """Slider velocity while every block stays pinned [m/s]: K V_L / (K + k_int), from
    K (X_L - X) = F0 + k_int (X - X0) (K = ``spring``, k_int [N/m]); V_L for a rigid
    drive (its K -> inf limit)."""
    if spring == np.inf:
        return load_velocity
    return spring * load_velocity / (spring + interface_stiffness)


@kernel
def _balance_jump(position: float, load: float, force: float, k_int: float, params) -> float:
    if params.stiffness == np.inf:
        return load - position
    return (params.stiffness * (load - position) - force) / (params.stiffness + k_int)


@kernel
def _advance_interface(
    slider, state, streams, events, scratch, param_array, strength, tables, velocity, duration
) -> None:
    """Apply the pending jump, slide ``duration`` at ``velocity``, sum forces into the slider."""
    y, h, age, slip, lifetime = state
    force, stiffness = scratch
    s = slider[0]
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
    )
    s.force = np.sum(force)
    s.stiffness = np.sum(stiffness)


@kernel
def advance_to(
    t_stop, slider, state, streams, events, scratch, param_array, strength, tables, protocol
) -> None:
    """Advance the interface and the slider from ``slider.time`` to ``t_stop`` [s].

    ``state`` is ``(y, h, age, slip, lifetime)`` (see :mod:`.contacts`); ``scratch`` two
    float arrays of length n_contacts for the contacts' forces and stiffnesses;
    ``param_array`` the one-element PARAMS array.
    """
    params = param_array[0]
    s = slider[0]
    spring = params.stiffness
    blocks = state[0].size
    while s.time < t_stop:
        _, load_velocity, segment_end = load_point(s.time, protocol)
        following = following_velocity(load_velocity, s.stiffness, spring)
        target = min(t_stop, segment_end)
        dt = target - s.time
        drift_rate = max(abs(s.drift), load_velocity - following)
        if drift_rate > 0.0:
            dt = min(dt, params.step_slip / drift_rate)
        mismatch = abs(load_velocity - following - s.drift) - _NOISE_Z * s.noise
        if spring != np.inf and mismatch > 0.0 and s.force > 0.0:
            dt = min(dt, params.force_step * s.force / (spring * mismatch))
        velocity = following + s.drift
        before = np.sum(events)
        _advance_interface(
            slider, state, streams, events, scratch, param_array, strength, tables, velocity, dt
        )
        moved = s.position + velocity * dt
        s.time = target if dt >= target - s.time else s.time + dt
        s.load_point, _, _ = load_point(s.time, protocol)
        s.pending = _balance_jump(moved, s.load_point, s.force, s.stiffness, params)
        s.position = moved + s.pending
        if spring != np.inf:
            s.drift += s.pending / dt
            drops = 2.0 * s.force * np.sqrt(np.sum(events) - before) / blocks
            s.noise = drops / ((spring + s.stiffness) * dt)
        s.steps += 1


@kernel
def settle(
    slider, state, streams, events, scratch, param_array, strength, tables, max_rounds: int = 1000
) -> int:
    """Apply the pending elastic jump and iterate (depinnings it triggers) to balance.

    Afterwards the blocks sit at ``slider.position`` and ``slider.force`` equals the
    spring force to a relative 1e-13. Returns the number of rounds needed.
    """
    params = param_array[0]
    s = slider[0]
    for rounds in range(1, max_rounds + 1):
        _advance_interface(
            slider, state, streams, events, scratch, param_array, strength, tables, 0.0, 0.0
        )
        s.pending = _balance_jump(s.position, s.load_point, s.force, s.stiffness, params)
        s.position += s.pending
        if abs(s.pending) * s.stiffness <= _BALANCE * max(abs(s.force), 1e-300):
            return rounds
    return max_rounds


@kernel
def advance_to_sample(
    t_sample, slider, state, streams, events, scratch, param_array, strength, tables, protocol
) -> int:
    """:func:`advance_to` ``t_sample``, then :func:`settle`: a balanced stored sample."""
    advance_to(
        t_sample, slider, state, streams, events, scratch, param_array, strength, tables, protocol
    )
    return settle(slider, state, streams, events, scratch, param_array, strength, tables)
