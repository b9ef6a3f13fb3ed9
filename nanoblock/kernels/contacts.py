"""Contacts as agents: ageing, renewal and the force each contact carries (001/Eqs. 1-5).

Arrays (c = contacts, i = blocks): ``y[c, i]`` reduced stretch, ``h[c, i]`` remaining
hazard; per contact ``age[c]`` [s], ``slip[c]`` slider slip since birth [m],
``lifetime[c]`` slip at which it dies [m] (Exp(D0), so that in steady sliding the mean
age is D0 / V: the ageing law, 001/Eq. 3; D0_2 for a second population), ``events[c]``
cumulative depinnings and ``streams[c]`` its random stream. A contact's force is its area
Sigma_0 [1 + m ln(1 + age / tau_m)] (001/Eq. 5) times its blocks' mean stress, in units
of its strength class's sigma_a (``strength[c mod K]``, see :mod:`.layout`).

The age is the contact's ageing clock. It runs at rate 1, or, with a state cutoff
velocity v_theta, at V / (V + v_theta) (V: slider velocity): contacts then do not age at
rest and in steady sliding the mean age is D0 / (V + v_theta), which with
theta = v_theta <age> / D0 is the state law of 000/Eq. 7.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from nanoblock.kernels._jit import kernel
from nanoblock.kernels.blocks import advance_free_blocks
from nanoblock.kernels.chain import advance_chain
from nanoblock.kernels.rng import standard_exponential


@kernel(inline=True)
def log_one_plus(z: float) -> float:
    """ln(1 + z) for z >= 0 as ln(u) z / (u - 1), u = 1 + z rounded (Goldberg 1991): within
    a few ulps, as log1p, at less than half its cost."""
    u = 1.0 + z
    return np.log(u) * (z / (u - 1.0)) if u != 1.0 else z


@kernel(inline=True)
def contact_area(age: float, params: np.ndarray) -> float:
    """Load-bearing area of a contact of ``age`` [s]: 001/Eq. 5 [m^2] (its logarithm by
    :func:`log_one_plus`: it runs per contact and internal step, a tenth of a one-block
    contact's pass with log1p)."""
    log_area = log_one_plus(age / params.aging_time)
    return params.contact_area * (1.0 + params.aging_m * log_area)


@kernel
def memory_length(c: int, params) -> float:
    """D0 of contact c [m]: the second population's D0_2 from ``second_from`` on."""
    return params.memory_length2 if c >= params.second_from else params.memory_length


@kernel(nrt=False)
def renew_contact(y_row, h_row, stream, memory: float) -> float:
    """Replace a contact by a fresh, unstressed one; returns its slip lifetime [m],
    Exp with mean ``memory`` = D0."""
    for i in range(y_row.shape[0]):
        y_row[i] = 0.0
        h_row[i] = standard_exponential(stream)
    return memory * standard_exponential(stream)


@kernel(inline=True, nrt=False)
def _advance_blocks(
    y_row, h_row, jump, x_rate, duration, params, table, stream, coupled, edge
) -> int:
    # ``coupled is None`` is pruned at compile time: the chain kernel is then not compiled
    if coupled is not None and params.kappa != 0.0 and y_row.shape[0] > 1:
        return advance_chain(y_row, h_row, jump, x_rate, duration, params, table, stream)
    eta = params.eta_free if params.slip_chain == 1 else 0.0
    return advance_free_blocks(
        y_row, h_row, jump, x_rate, duration, eta, params.omega_a, table, stream,
        params.hop_period, edge,
    )  # fmt: skip


@kernel(inline=True)
def ageing_rate(velocity: float, params) -> float:
    """Rate of the ageing clock at slider velocity V [m/s]: 1, or V / (V + v_theta)."""
    if params.state_cutoff == 0.0:
        return 1.0
    return abs(velocity) / (abs(velocity) + params.state_cutoff)


# inlined in the contact loop with contact_area and ageing_rate: a step of 500 one-block
# contacts 93 -> 73 us, compile time unchanged (advance_free_blocks inlined too: 63 us, but
# the quick start's cold run 58 -> 112 s; measured 2026-11-27)
@kernel(inline=True, nrt=False)
def advance_contact(
    c,
    y,
    h,
    age,
    slip,
    lifetime,
    events,
    streams,
    jump,
    velocity,
    duration,
    params,
    strength,
    tables,
    coupled,
    edges,
) -> None:
    """Advance contact c: slider jump ``jump`` [m], then ``duration`` [s] at ``velocity``.

    The contact dies when its slip since birth reaches its lifetime, at the exact instant
    on the slider path, and the fresh contact takes the rest of the segment. ``coupled``:
    None when every contact's blocks are independent (k2 = 0 or one block per contact),
    True to run coupled chains through :func:`~.chain.advance_chain`. ``edges[k]``: the
    split edge of strength class k over the whole ``duration``
    (:func:`~.blocks.split_edge`); a part of it after a renewal computes its own.
    """
    k = c % strength.shape[0]
    rho = strength[k, 1]
    table = tables[k]
    clock = ageing_rate(velocity, params)
    remaining = duration
    pending = jump
    while True:
        gap = lifetime[c] - slip[c] - pending
        if gap <= 0.0:
            until_death = 0.0
        elif velocity > 0.0 and velocity * remaining > gap:
            until_death = gap / velocity
        else:
            until_death = np.inf
        dies = until_death <= remaining
        span = until_death if dies else remaining
        edge = edges[k] if span == duration else -1
        events[c] += _advance_blocks(
            y[c], h[c], pending / rho, velocity / rho, span, params, table, streams[c], coupled,
            edge,
        )  # fmt: skip
        slip[c] += pending + velocity * span
        age[c] += clock * span
        remaining -= span
        pending = 0.0
        if not dies:
            return
        lifetime[c] = renew_contact(y[c], h[c], streams[c], memory_length(c, params))
        slip[c] = 0.0
        age[c] = 0.0


@kernel(parallel=True, nrt=False)
def advance_contacts(
    y,
    h,
    age,
    slip,
    lifetime,
    events,
    streams,
    force,
    stiffness,
    jump,
    velocity,
    duration,
    param_array,
    strength,
    tables,
    coupled,
    edges,
) -> None:
    """Advance every contact (in parallel; each has its own stream) and store its force
    ``force[c]`` [N] and elastic stiffness ``stiffness[c]`` = dF_c / dX [N/m].

    ``param_array`` is the one-element PARAMS array (records cannot enter a parallel loop
    by value); ``strength`` and ``tables`` hold each strength class's (sigma_a, rho~_max)
    and hazard table; ``coupled`` and ``edges`` as in :func:`advance_contact`. Compiled
    without reference counting, like the contact step it inlines: the loop's views of each
    contact's rows otherwise cost two atomic updates each (a step of 500 one-block
    contacts 72 -> 62 us, measured 2026-11-28)."""
    for c in prange(y.shape[0]):
        params = param_array[0]
        advance_contact(
            c,
            y,
            h,
            age,
            slip,
            lifetime,
            events,
            streams,
            jump,
            velocity,
            duration,
            params,
            strength,
            tables,
            coupled,
            edges,
        )
        area = contact_area(age[c], params)
        sigma_a, rho_max = strength[c % strength.shape[0]]
        force[c] = area * sigma_a * np.mean(y[c])
        stiffness[c] = area * sigma_a / rho_max


@kernel
def total_contact_area(age: np.ndarray, params: np.ndarray) -> float:
    """Sum of the contacts' load-bearing areas (001/Eq. 5) [m^2]."""
    total = 0.0
    for c in range(age.shape[0]):
        total += contact_area(age[c], params)
    return total
