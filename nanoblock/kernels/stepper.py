"""The slider in quasi-static force balance with the drive spring (physics.md section 2).

K (X_L(t) - X) = F, with F the sum of the contacts' forces. The slider path is advanced in
internal steps of at most ``step_slip`` of slip: within a step it slides at the velocity
of the previous step (blocks see an exact linear ramp, events and renewals exact on it);
at the step's end the balance is restored by an elastic jump
dX = (K (X_L - X) - F) / (K + k_int) (k_int = dF/dX of the pinned interface), applied at
the start of the next step, or at once, iterated to convergence, before a stored sample.
The steps are taken on the slip scale, so the cost follows events, not simulated time;
in transients a step may also change the spring force K |V_L - V| dt by at most
``force_step`` F (a fraction of alpha F, so the slider velocity changes by a few percent
per step and the prediction lags little). A rigid spring (K = inf) needs no prediction:
the slider moves with the load point, velocity steps included.

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


@kernel
def load_point(t: float, protocol: np.ndarray) -> tuple[float, float, float]:
    """Load-point position X_L(t) [m], velocity [m/s] and the end of the current segment [s]."""
    starts = protocol[0]
    k = max(np.searchsorted(starts, t, side="right") - 1, 0)
    k = min(k, starts.shape[0] - 2)
    return protocol[2, k] + protocol[1, k] * (t - starts[k]), protocol[1, k], starts[k + 1]


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
    while s.time < t_stop:
        _, load_velocity, segment_end = load_point(s.time, protocol)
        if params.stiffness == np.inf:  # a rigid spring: the slider is the load point
            s.velocity = load_velocity
        target = min(t_stop, segment_end)
        dt = target - s.time
        if s.velocity != 0.0:
            dt = min(dt, params.step_slip / abs(s.velocity))
        mismatch = params.stiffness * abs(load_velocity - s.velocity)
        if mismatch > 0.0 and params.stiffness != np.inf and s.force > 0.0:
            dt = min(dt, params.force_step * s.force / mismatch)
        if s.last_dt > 0.0:
            dt = min(dt, 2.0 * s.last_dt)
        _advance_interface(
            slider, state, streams, events, scratch, param_array, strength, tables, s.velocity, dt
        )
        start = s.position
        moved = s.position + s.velocity * dt
        s.time = target if dt >= target - s.time else s.time + dt
        s.load_point, _, _ = load_point(s.time, protocol)
        s.pending = _balance_jump(moved, s.load_point, s.force, s.stiffness, params)
        s.position = moved + s.pending
        s.velocity = (s.position - start) / dt
        s.last_dt = dt
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
