"""Coupled nanoblock chain (k2 > 0): event-driven depinning and avalanches (001/Eq. 21).

Reduced units: ``z[i]`` = stretch of block i's plate spring over rho_max at the start of
the slider segment, so that while all blocks are pinned every block's reduced stress is

    x_i(t) = xi_i + xdot t,   xi_i = z_i + kappa (n_i z_i - sum of neighbours' z),

with kappa = k2 / k1 and n_i the number of neighbours (free chain ends). Depinnings are
processed in time order with an indexed heap; a block's hazard is settled lazily, only
when its stress history changes (a neighbour slips) or the segment ends. Avalanches run
with the slider frozen: the ``reset`` rule releases each depinned block to zero force,
neighbours fixed; the ``chain`` rule lands an isolated block in closed form and solves
Eq. 21, m q'' + m gamma q' = f, exactly for clusters (normal modes of each run of moving
blocks, :mod:`nanoblock.kernels.modes`), repinning each block when its velocity first
vanishes; a cluster whose every block would never stop lands exactly at equilibrium.
"""

from __future__ import annotations

import numpy as np

from nanoblock.kernels._jit import kernel
from nanoblock.kernels.blocks import next_depinning
from nanoblock.kernels.hazard import hazard_between
from nanoblock.kernels.modes import (
    combination_at,
    combination_root,
    envelope,
    propagate,
    single_mode_keeps_sign,
    slow_part,
    step_matrix,
    tabled_spectrum,
)
from nanoblock.kernels.rng import standard_exponential

_SETTLED = 1e-9
"""Fallback: a block repins once |x| and |v| / omega_1 fall below this (when the proof of
an event-free future fails, e.g. a degenerate slowest mode)."""

_MAX_SUBSTEPS = 10_000_000

_GRID_PHASE = 0.25
"""Grid step of the event search: this phase [rad] of the fastest mode, and gamma dt."""

_PROOF_EVERY = 4
"""Fewest grid steps between two attempts to prove that an avalanche has no event left."""

_PROOF_PATIENCE = 0.25
"""Fraction of a failed proof's estimated wait before the next attempt (the estimate
overshoots: waiting the whole of it cost 25 % more time per avalanche than a quarter)."""

_HORIZON = 100.0
"""E-folds of the slowest mode after which a monotone stress that has not reached its
threshold is taken never to reach it (it lies within e^-100 of its limit)."""

# rows of the float work array of :func:`integrate_cluster`: per mode slot, then per block
_W_SQ, _S_SQ, _Q, _P, _Q_OLD, _P_OLD, _BOUND, _WEIGHT_Q, _WEIGHT_P = range(9)
_Z_EQ, _DEV, _VEL, _HEADING, _LAST_F, _X_EQ, _LAST_X = range(9, 16)
_STEP = 16  # four rows: the one-step map of each mode slot
_MODAL_ROWS = 20
# rows of the integer work array: moving blocks, runs (start, length), each block's run
# (first block, size), watched blocks, modal slots of an event function, stopped blocks
_IN_MOTION = 8  # last row: 1 while a block moves
_BLOCK_ROWS = 9


@kernel
def _neighbours(i: int, n: int) -> int:
    return (1 if i > 0 else 0) + (1 if i < n - 1 else 0)


@kernel(nrt=False)
def reduced_stress(z: np.ndarray, i: int, kappa: float) -> float:
    """xi_i = z_i + kappa (n_i z_i - z_{i-1} - z_{i+1}), free ends (reduced stress at t=0)."""
    n = z.shape[0]
    coupling = 0.0
    if i > 0:
        coupling += z[i] - z[i - 1]
    if i < n - 1:
        coupling += z[i] - z[i + 1]
    return z[i] + kappa * coupling


# ---------------------------------------------------------------- indexed min-heap on keys
@kernel(nrt=False)
def _swap(heap: np.ndarray, where: np.ndarray, a: int, b: int) -> None:
    heap[a], heap[b] = heap[b], heap[a]
    where[heap[a]] = a
    where[heap[b]] = b


@kernel(nrt=False)
def _sift(heap: np.ndarray, where: np.ndarray, keys: np.ndarray, slot: int) -> None:
    n = heap.shape[0]
    while slot > 0 and keys[heap[slot]] < keys[heap[(slot - 1) // 2]]:
        _swap(heap, where, slot, (slot - 1) // 2)
        slot = (slot - 1) // 2
    while True:
        smallest = slot
        for child in (2 * slot + 1, 2 * slot + 2):
            if child < n and keys[heap[child]] < keys[heap[smallest]]:
                smallest = child
        if smallest == slot:
            return
        _swap(heap, where, slot, smallest)
        slot = smallest


@kernel
def _heapify(heap: np.ndarray, where: np.ndarray, keys: np.ndarray) -> None:
    for i in range(heap.shape[0]):
        heap[i] = i
        where[i] = i
    for slot in range(heap.shape[0] // 2 - 1, -1, -1):
        _sift(heap, where, keys, slot)


# ---------------------------------------------------------------- the contact's clock
@kernel(nrt=False)
def _settle(i, t, xi, h, t_ref, x_rate, omega_a, table) -> None:
    """Accumulate block i's hazard from its reference time up to t (stress unchanged)."""
    if t > t_ref[i]:
        x0 = xi[i] + x_rate * t_ref[i]
        x1 = xi[i] + x_rate * t
        h[i] -= omega_a * hazard_between(x0, x1, x_rate, t - t_ref[i], table)
        t_ref[i] = t


@kernel
def isolated_landing(x: float, neighbours: int, eta: float, kappa: float) -> float:
    """Change of z of an isolated block slipping from reduced stress x, neighbours fixed.

    The block's effective spring is k1 (1 + n kappa); it lands with stress -eta x
    (closed-form damped oscillator of 001/Eq. 21; eta = 0 for the reset rule).
    """
    return -(1.0 + eta) * x / (1.0 + neighbours * kappa)


# ---------------------------------------------------------------- avalanches (slider frozen)
@kernel(inline=True)
def _record_depinning(i, on_depin, moved, n_moved) -> int:
    if on_depin[i] == 0:
        moved[n_moved] = i
        n_moved += 1
    on_depin[i] += 1
    return n_moved


@kernel(nrt=False)
def reset_cascade(z, offset, first, kappa, on_depin, moved, queue, queued) -> tuple[int, int]:
    """Reset rule: each depinned block jumps to zero force with its neighbours fixed.

    Block ``first`` slips whatever its stress; others slip when |x| >= 1. ``z`` changes in
    place. Returns (depinnings, number of distinct blocks listed in ``moved``).
    """
    n = z.shape[0]
    queue[0] = first
    queued[first] = True
    head, tail, events, n_moved = 0, 1, 0, 0
    while head != tail:
        i = queue[head]
        head = (head + 1) % n
        queued[i] = False
        x = reduced_stress(z, i, kappa) + offset
        if abs(x) < 1.0 and (i != first or on_depin[i] > 0):
            continue
        z[i] += isolated_landing(x, _neighbours(i, n), 0.0, kappa)
        n_moved = _record_depinning(i, on_depin, moved, n_moved)
        events += 1
        for j in (i - 1, i + 1):
            if 0 <= j < n and not queued[j] and abs(reduced_stress(z, j, kappa) + offset) >= 1.0:
                queue[tail] = j
                tail = (tail + 1) % n
                queued[j] = True
    return events, n_moved


@kernel(inline=True)
def _join(i, z, offset, kappa, moving, n_moving, in_motion, modal) -> int:
    """Block i starts moving from rest against its stress; returns the new n_moving."""
    moving[n_moving] = i
    in_motion[i] = 1
    modal[_VEL, i] = 0.0
    modal[_LAST_F, i] = 0.0
    modal[_HEADING, i] = -1.0 if reduced_stress(z, i, kappa) + offset > 0.0 else 1.0
    return n_moving + 1


@kernel(inline=True)
def _collect_runs(moving, n_moving, run_start, run_length, run_first, run_size) -> int:
    """Sort the moving blocks, split them into maximal contiguous runs (start, length),
    and note each block's run; returns the number of runs."""
    for m in range(1, n_moving):
        i = moving[m]
        k = m
        while k > 0 and moving[k - 1] > i:
            moving[k] = moving[k - 1]
            k -= 1
        moving[k] = i
    n_runs = 0
    for m in range(n_moving):
        if m > 0 and moving[m] == moving[m - 1] + 1:
            run_length[n_runs - 1] += 1
        else:
            run_start[n_runs] = moving[m]
            run_length[n_runs] = 1
            n_runs += 1
    for r in range(n_runs):
        for i in range(run_start[r], run_start[r] + run_length[r]):
            run_first[i] = run_start[r]
            run_size[i] = run_length[r]
    return n_runs


@kernel(nrt=False)
def _build_modes(z, offset, kappa, omega1_sq, gamma, run_start, run_length, n_runs, vectors, modal):
    """Spectrum, equilibrium z*, deviation z - z* and modal state (q, p) of every run from
    the blocks' z and velocities (:mod:`nanoblock.kernels.modes`); mode k of the run that
    starts at block a lives in slot a + k. Returns the largest modal frequency w [1/s]."""
    n = z.shape[0]
    w_sq, s_sq, q, p, z_eq = modal[_W_SQ], modal[_S_SQ], modal[_Q], modal[_P], modal[_Z_EQ]
    w_max_sq = 0.0
    for r in range(n_runs):
        a = run_start[r]
        last = a + run_length[r] - 1
        tabled_spectrum(run_length[r], a > 0, last < n - 1, w_sq, vectors, a)
        pinned_left = z[a - 1] if a > 0 else 0.0
        pinned_right = z[last + 1] if last < n - 1 else 0.0
        for i in range(a, last + 1):
            z_eq[i] = 0.0
        for k in range(run_length[r]):
            m = a + k
            stiffness = 1.0 + kappa * w_sq[m]  # a_k: w_sq holds lambda_k until below
            loading, position, velocity = 0.0, 0.0, 0.0
            for i in range(a, last + 1):
                loading += vectors[i, k] * offset
                position += vectors[i, k] * z[i]
                velocity += vectors[i, k] * modal[_VEL, i]
            loading -= kappa * (vectors[a, k] * pinned_left + vectors[last, k] * pinned_right)
            q_eq = -loading / stiffness
            for i in range(a, last + 1):
                z_eq[i] += vectors[i, k] * q_eq
            q[m] = position - q_eq
            p[m] = velocity
            w_sq[m] = omega1_sq * stiffness
            s_sq[m] = 0.25 * gamma * gamma - w_sq[m]
            w_max_sq = max(w_max_sq, w_sq[m])
        for i in range(a, last + 1):
            modal[_DEV, i] = z[i] - z_eq[i]
    return np.sqrt(w_max_sq)


@kernel(nrt=False)
def _watch_list(z, offset, kappa, in_motion, run_start, run_length, n_runs, modal, watch) -> int:
    """List the pinned neighbours of moving blocks with their present stress x_j and x_j*,
    their stress with the moving neighbours at equilibrium; returns their number."""
    n = z.shape[0]
    n_watch = 0
    for r in range(n_runs):
        for j in (run_start[r] - 1, run_start[r] + run_length[r]):
            if 0 <= j < n and not (n_watch > 0 and watch[n_watch - 1] == j):
                watch[n_watch] = j
                n_watch += 1
                modal[_LAST_X, j] = reduced_stress(z, j, kappa) + offset
                modal[_X_EQ, j] = modal[_LAST_X, j]
                for i in (j - 1, j + 1):
                    if 0 <= i < n and in_motion[i]:
                        modal[_X_EQ, j] += kappa * modal[_DEV, i]
    return n_watch


@kernel(inline=True)
def _block_motion(run_start, run_length, n_runs, vectors, q, p, modal) -> None:
    """Deviation z - z* and velocity of every moving block from its run's modes."""
    for r in range(n_runs):
        a = run_start[r]
        for i in range(a, a + run_length[r]):
            deviation, velocity = 0.0, 0.0
            for k in range(run_length[r]):
                deviation += vectors[i, k] * q[a + k]
                velocity += vectors[i, k] * p[a + k]
            modal[_DEV, i] = deviation
            modal[_VEL, i] = velocity


@kernel(nrt=False)
def _event_weights(j, kappa, in_motion, run_first, run_size, vectors, slots, modal) -> int:
    """Modal weights of block j's event function: its velocity along its heading if it
    moves, else minus kappa times its moving neighbours' deviations (its stress minus
    x_j*). Returns the number of terms."""
    n_terms = 0
    for i in (j - 1, j, j + 1):
        if 0 <= i < in_motion.shape[0] and in_motion[i] and (i == j) == in_motion[j]:
            for k in range(run_size[i]):
                slots[n_terms] = run_first[i] + k
                if i == j:
                    modal[_WEIGHT_Q, n_terms] = 0.0
                    modal[_WEIGHT_P, n_terms] = modal[_HEADING, j] * vectors[i, k]
                else:
                    modal[_WEIGHT_Q, n_terms] = -kappa * vectors[i, k]
                    modal[_WEIGHT_P, n_terms] = 0.0
                n_terms += 1
    return n_terms


@kernel(nrt=False)
def _time_to_steady(run_start, run_length, n_runs, vectors, modal, gamma) -> float:
    """0 if no moving block will ever turn, else a guess of how long [s] this proof will
    keep failing (inf: a turn is certain, or nothing is known).

    Velocity of block i: its run's slowest exponential c0 e^{-(gamma/2 - s_0) tau} must
    outweigh the sum of the :func:`~nanoblock.kernels.modes.envelope` bounds of all other
    terms, with c0 along the block's heading; a run of one block has an exact test. The
    guess lets the excess decay at the rate that separates the slowest term from the rest.
    """
    w_sq, s_sq, q, p, bound = modal[_W_SQ], modal[_S_SQ], modal[_Q], modal[_P], modal[_BOUND]
    half_gamma = 0.5 * gamma
    for r in range(n_runs):
        a = run_start[r]
        length = run_length[r]
        if s_sq[a] < 0.0 or (length > 1 and s_sq[a] == 0.0):
            return np.inf  # an underdamped spectrum: every block will turn
        pull = -(w_sq[a] * q[a] + half_gamma * p[a])
        if length == 1:
            initial = p[a] if p[a] != 0.0 else pull
            if not single_mode_keeps_sign(p[a], pull, s_sq[a]):
                return np.inf  # the block will turn
            if initial * vectors[a, 0] * modal[_HEADING, a] <= 0.0:
                return np.inf
            continue
        slowest = half_gamma - np.sqrt(s_sq[a])
        separation = np.sqrt(s_sq[a]) - (np.sqrt(s_sq[a + 1]) if s_sq[a + 1] > 0.0 else 0.0)
        slow, fast = slow_part(p[a], pull, s_sq[a])
        for m in range(a + 1, a + length):
            pull = -(w_sq[m] * q[m] + half_gamma * p[m])
            bound[m] = envelope(p[m], pull, s_sq[m], gamma, slowest)
        for i in range(a, a + length):
            leading = vectors[i, 0] * slow
            rest = abs(vectors[i, 0] * fast)
            for k in range(1, length):
                rest += abs(vectors[i, k]) * bound[a + k]
            if leading * modal[_HEADING, i] <= 0.0:
                return np.inf  # the slowest term turns the block, or nothing is known
            if rest >= abs(leading):
                return np.log(rest / abs(leading)) / separation
    return 0.0


@kernel(nrt=False)
def _first_join(
    watch, n_watch, in_motion, run_first, run_size, vectors, slots, modal, gamma, kappa, dt
) -> tuple[float, int]:
    """Earliest join (time [s] from now, block) when no moving block will ever turn: then
    every velocity keeps the sign of its heading, so a pinned block whose moving
    neighbours share a heading has a monotone stress, from x_j now to x_j*; it joins iff
    |x_j*| >= 1, at the crossing, reached by a Newton march and located to round-off. Between
    neighbours of opposite headings the :func:`~nanoblock.kernels.modes.envelope` bound
    must keep |x_j| < 1. Returns (inf, -1) if no block will join, (inf, -2) if unknown.
    """
    w_sq, s_sq, q, p = modal[_W_SQ], modal[_S_SQ], modal[_Q], modal[_P]
    first_time, first_block = np.inf, -1
    for w in range(n_watch):
        j = watch[w]
        limit = modal[_X_EQ, j]
        shared, mixed, slowest = 0.0, False, 0.5 * gamma
        for i in (j - 1, j + 1):
            if 0 <= i < in_motion.shape[0] and in_motion[i]:
                mixed = mixed or shared * modal[_HEADING, i] < 0.0
                shared = modal[_HEADING, i]
                slowest = min(slowest, 0.5 * gamma - np.sqrt(max(s_sq[run_first[i]], 0.0)))
        if mixed:  # both neighbours move
            reach = abs(limit)
            for i in (j - 1, j + 1):
                for k in range(run_size[i]):
                    m = run_first[i] + k
                    drift = envelope(q[m], p[m] + 0.5 * gamma * q[m], s_sq[m], gamma, 0.0)
                    reach += kappa * abs(vectors[i, k]) * drift
            if reach >= 1.0:
                return np.inf, -2
            continue
        if abs(limit) < 1.0:
            continue
        threshold = 1.0 if limit > 0.0 else -1.0
        n_terms = _event_weights(j, kappa, in_motion, run_first, run_size, vectors, slots, modal)
        weight_q, weight_p, shift = modal[_WEIGHT_Q], modal[_WEIGHT_P], limit - threshold
        lo = 0.0
        f_lo, slope = combination_at(
            lo, shift, slots, weight_q, weight_p, n_terms, q, p, w_sq, s_sq, gamma
        )
        stride = -f_lo / slope if f_lo * slope < 0.0 else dt
        end = min(first_time, _HORIZON / slowest)  # no later crossing matters
        while lo < end:  # Newton march to x_j = +-1; a convex stretch overshoots, so the
            t = min(lo + stride, end)  # march always tests the end before giving up
            f, slope = combination_at(
                t, shift, slots, weight_q, weight_p, n_terms, q, p, w_sq, s_sq, gamma
            )
            if (f > 0.0) != (f_lo > 0.0):
                first_time = combination_root(
                    lo,
                    t,
                    f_lo,
                    f,
                    shift,
                    slots,
                    weight_q,
                    weight_p,
                    n_terms,
                    q,
                    p,
                    w_sq,
                    s_sq,
                    gamma,
                )
                first_block = j
                break
            lo, f_lo = t, f
            if lo >= end:
                break
            if f * slope < 0.0:
                stride = -f / slope
                if stride <= 4.0 * np.finfo(np.float64).eps * t:  # converged from one side
                    first_time, first_block = t + stride, j
                    break
    return first_time, first_block


@kernel(nrt=False)
def _segment(
    z, offset, kappa, omega1_sq, gamma, on_depin, moved, modal, blocks, vectors, n_runs, longest,
    n_moving, n_stopped, events, n_moved, substeps,
) -> tuple[int, int, int, int, int, bool]:  # fmt: skip
    """One segment of :func:`integrate_cluster`, between two changes of the moving set:
    modes of the ``n_runs`` runs already collected in ``blocks`` (the longest has
    ``longest`` blocks), joins of watched or stopped blocks over threshold, then grid steps
    to the next event, which is applied. Returns the updated (n_moving, n_stopped, events,
    n_moved, substeps, landed); ``landed``: the moving blocks were put at their equilibrium
    and the avalanche is over. Compiled without reference counting (the caller owns every
    array; nothing here allocates): counting the array views of this loop cost a fifth of
    the chain's run time."""
    n = z.shape[0]
    omega_1 = np.sqrt(omega1_sq)
    w_sq, s_sq, q, p, q_old, p_old = (
        modal[_W_SQ],
        modal[_S_SQ],
        modal[_Q],
        modal[_P],
        modal[_Q_OLD],
        modal[_P_OLD],
    )
    dev, vel, heading, last_f = modal[_DEV], modal[_VEL], modal[_HEADING], modal[_LAST_F]
    moving, run_start, run_length, run_first = blocks[0], blocks[1], blocks[2], blocks[3]
    run_size, watch, slots, stopped = blocks[4], blocks[5], blocks[6], blocks[7]
    in_motion = blocks[_IN_MOTION]
    step = modal[_STEP : _STEP + 4]
    w_max = _build_modes(
        z, offset, kappa, omega1_sq, gamma, run_start, run_length, n_runs, vectors, modal
    )
    n_watch = _watch_list(z, offset, kappa, in_motion, run_start, run_length, n_runs, modal, watch)
    n_before = n_moving
    for m in range(n_watch + n_stopped):
        j = watch[m] if m < n_watch else stopped[m - n_watch]
        if not in_motion[j] and abs(reduced_stress(z, j, kappa) + offset) >= 1.0:
            n_moving = _join(j, z, offset, kappa, moving, n_moving, in_motion, modal)
            n_moved = _record_depinning(j, on_depin, moved, n_moved)
            events += 1
    n_stopped = 0
    if n_moving > n_before or n_moving == 0:
        return n_moving, n_stopped, events, n_moved, substeps, False
    dt = _GRID_PHASE / max(w_max, gamma)
    for m in range(n_moving):
        k = moving[m]
        step[0, k], step[1, k], step[2, k], step[3, k] = step_matrix(w_sq[k], s_sq[k], gamma, dt)
    # ---- grid steps until an event
    next_proof = substeps + (1 if longest == 1 else _PROOF_EVERY)  # joined from rest
    while substeps < _MAX_SUBSTEPS:
        substeps += 1
        exact_join = False
        if substeps >= next_proof:
            wait = _time_to_steady(run_start, run_length, n_runs, vectors, modal, gamma)
            next_proof = (
                substeps + _PROOF_EVERY + int(min(_PROOF_PATIENCE * wait / dt, _MAX_SUBSTEPS))
            )
            if wait == 0.0:
                t_event, event_block = _first_join(
                    watch, n_watch, in_motion, run_first, run_size, vectors, slots, modal,
                    gamma, kappa, dt,
                )  # fmt: skip
                if event_block == -1:  # nothing will ever happen: land at equilibrium
                    for m in range(n_moving):
                        z[moving[m]] = modal[_Z_EQ, moving[m]]
                    return n_moving, n_stopped, events, n_moved, substeps, True
                exact_join = event_block >= 0
        if exact_join:  # straight to the join, from the present state
            event_joins = True
            for m in range(n_moving):
                q_old[moving[m]], p_old[moving[m]] = q[moving[m]], p[moving[m]]
        else:  # one grid step; events located within it
            for m in range(n_moving):
                k = moving[m]
                q_old[k], p_old[k] = q[k], p[k]
                q[k] = step[0, k] * q_old[k] + step[1, k] * p_old[k]
                p[k] = step[2, k] * q_old[k] + step[3, k] * p_old[k]
            _block_motion(run_start, run_length, n_runs, vectors, q, p, modal)
            t_event, event_block, event_joins = np.inf, -1, False
            for m in range(n_moving + n_watch):
                j = moving[m] if m < n_moving else watch[m - n_moving]
                if in_motion[j]:  # a turn: heading * v from > 0 to <= 0
                    f_old, f_new, constant = last_f[j], heading[j] * vel[j], 0.0
                    crossed = f_old > 0.0 and f_new <= 0.0
                else:  # a join: |x| reaches 1
                    x = modal[_X_EQ, j]
                    for i in (j - 1, j + 1):
                        if 0 <= i < n and in_motion[i]:
                            x -= kappa * dev[i]
                    crossed = abs(x) >= 1.0
                    threshold = 1.0 if x > 0.0 else -1.0
                    f_old, f_new = modal[_LAST_X, j] - threshold, x - threshold
                    constant = modal[_X_EQ, j] - threshold
                    modal[_LAST_X, j] = x
                if crossed:
                    n_terms = _event_weights(
                        j, kappa, in_motion, run_first, run_size, vectors, slots, modal
                    )
                    t = combination_root(
                        0.0, dt, f_old, f_new, constant, slots, modal[_WEIGHT_Q],
                        modal[_WEIGHT_P], n_terms, q_old, p_old, w_sq, s_sq, gamma,
                    )  # fmt: skip
                    if t < t_event:
                        t_event, event_block, event_joins = t, j, not in_motion[j]
            if event_block < 0:
                for m in range(n_moving):  # fallback: blocks at rest at equilibrium stop
                    i = moving[m]
                    if abs(vel[i]) < _SETTLED * omega_1:
                        x = 0.0  # x = A (z - z*) = U diag(a) q
                        for k in range(run_size[i]):
                            slot = run_first[i] + k
                            x += vectors[i, k] * w_sq[slot] / omega1_sq * q[slot]
                        if abs(x) < _SETTLED:
                            stopped[n_stopped] = i
                            n_stopped += 1
                if n_stopped == 0:
                    for m in range(n_moving):
                        last_f[moving[m]] = heading[moving[m]] * vel[moving[m]]
                    continue
        # ---- the event: every mode to t_event; blocks that turned stop, one joins
        if event_block >= 0:
            for m in range(n_moving):
                k = moving[m]
                q[k], p[k] = propagate(q_old[k], p_old[k], w_sq[k], s_sq[k], gamma, t_event)
            _block_motion(run_start, run_length, n_runs, vectors, q, p, modal)
        for m in range(n_moving):
            i = moving[m]
            z[i] = modal[_Z_EQ, i] + dev[i]
            if i == event_block or (last_f[i] > 0.0 and heading[i] * vel[i] <= 0.0):
                stopped[n_stopped] = i
                n_stopped += 1
            last_f[i] = heading[i] * vel[i]
        for m in range(n_stopped):
            in_motion[stopped[m]] = 0
            vel[stopped[m]] = 0.0
        n_kept = 0
        for m in range(n_moving):
            if in_motion[moving[m]]:
                moving[n_kept] = moving[m]
                n_kept += 1
        n_moving = n_kept
        if event_joins:
            n_moving = _join(event_block, z, offset, kappa, moving, n_moving, in_motion, modal)
            n_moved = _record_depinning(event_block, on_depin, moved, n_moved)
            events += 1
        break
    return n_moving, n_stopped, events, n_moved, substeps, False


@kernel
def cluster_workspace(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Work arrays (modal, blocks, vectors) of :func:`integrate_cluster` for ``n`` blocks."""
    return (
        np.empty((_MODAL_ROWS, n)),
        np.empty((_BLOCK_ROWS, n), dtype=np.int64),
        np.empty((n, min(n, 8))),
    )


@kernel(nrt=False)
def _start_cluster(first, z, offset, kappa, on_depin, moved, modal, blocks) -> tuple[int, int]:
    """Block ``first`` starts moving, no other does; returns (n_moving, n_moved)."""
    blocks[_IN_MOTION, :] = 0
    n_moving = _join(first, z, offset, kappa, blocks[0], 0, blocks[_IN_MOTION], modal)
    return n_moving, _record_depinning(first, on_depin, moved, 0)


@kernel(nrt=False)
def _runs(blocks: np.ndarray, n_moving: int) -> tuple[int, int]:
    """:func:`_collect_runs` on the work rows; returns (number of runs, longest run)."""
    n_runs = _collect_runs(blocks[0], n_moving, blocks[1], blocks[2], blocks[3], blocks[4])
    longest = 0
    for r in range(n_runs):
        longest = max(longest, blocks[2, r])
    return n_runs, longest


@kernel
def integrate_cluster(
    z: np.ndarray,
    offset: float,
    first: int,
    kappa: float,
    omega1_sq: float,
    damping: float,
    on_depin: np.ndarray,
    moved: np.ndarray,
    modal: np.ndarray,
    blocks: np.ndarray,
    vectors: np.ndarray,
) -> tuple[int, int]:
    """Resolve the avalanche started by block ``first`` (slider frozen; 001/Eq. 21).

    Exact and event-driven (:mod:`nanoblock.kernels.modes`): between events every run of
    moving blocks follows the closed-form damped motion of its normal modes. A grid of
    steps (a quarter radian of the fastest mode, gamma dt <= 1/4) brackets the events,
    which are then located to round-off on the closed form: a moving block turns (repins
    where it is) when its velocity first vanishes; a pinned neighbour joins, from rest,
    when |x| reaches 1. Every few steps the runs are tested for a future without turns
    (each velocity dominated by its run's slowest exponential); once that holds, the
    neighbours' stresses are monotone and the next join is solved for directly, with no
    grid, and if none will come the moving blocks land exactly at their equilibrium x = 0,
    which an overdamped run approaches without ever stopping (the RK4 integrator stopped
    them within 1e-9). Failing the proof, a block stops once |x| and |v| / omega_1 are
    below 1e-9. ``z`` changes in place; ``modal``, ``blocks`` and ``vectors`` are the work
    arrays of :func:`cluster_workspace` (a longer run than ``vectors`` holds gets a larger
    copy). Returns (depinnings, number of distinct blocks listed in ``moved``).
    """
    n = z.shape[0]
    n_moving, n_moved = _start_cluster(first, z, offset, kappa, on_depin, moved, modal, blocks)
    # typed counters: literal 0 and 1 would compile _segment a second time for the first call
    events, n_stopped, substeps, landed = np.int64(1), np.int64(0), np.int64(0), False
    while (n_moving > 0 or n_stopped > 0) and substeps < _MAX_SUBSTEPS and not landed:
        n_runs, longest = _runs(blocks, n_moving)
        if longest > vectors.shape[1]:
            vectors = np.empty((n, min(n, 2 * longest)))
        n_moving, n_stopped, events, n_moved, substeps, landed = _segment(
            z, offset, kappa, omega1_sq, damping, on_depin, moved, modal, blocks, vectors,
            n_runs, longest, n_moving, n_stopped, events, n_moved, substeps,
        )  # fmt: skip
    return events, n_moved


# ---------------------------------------------------------------- one contact, one segment
@kernel(nrt=False)
def _fire_time(i, xi, h, t_ref, x_rate, duration, omega_a, table) -> float:
    t, _, _ = next_depinning(
        xi[i] + x_rate * t_ref[i], h[i], x_rate, duration - t_ref[i], omega_a, table
    )
    return t_ref[i] + t


@kernel(nrt=False)
def _avalanche(
    j, t, x_rate, z, xi, h, t_ref, work, cluster, params, table, stream
) -> tuple[int, int]:
    """Depin block j at time t and resolve the avalanche; bring every block whose stress
    history changed up to date: hazard settled with its old stress, a fresh Exp(1)
    threshold for blocks that slipped, new xi. The changed blocks are listed in
    ``work[2]``; returns (depinnings, number of changed blocks)."""
    n = z.shape[0]
    kappa = params.kappa
    on_depin, moved, changed, queue, marks = work[0], work[1], work[2], work[3], work[4]
    offset = x_rate * t
    if params.slip_chain == 0:
        events, n_moved = reset_cascade(z, offset, j, kappa, on_depin, moved, queue, marks)
    else:
        neighbours = _neighbours(j, n)
        eta = params.eta_interior if neighbours == 2 else params.eta_end
        step = isolated_landing(xi[j] + offset, neighbours, eta, kappa)
        isolated = True
        for k in (j - 1, j + 1):
            if 0 <= k < n and abs(xi[k] + offset - kappa * step) >= 1.0:
                isolated = False
        if isolated:
            z[j] += step
            on_depin[j] = 1
            moved[0] = j
            events, n_moved = 1, 1
        else:
            modal, blocks, vectors = cluster
            events, n_moved = integrate_cluster(
                z, offset, j, kappa, params.omega1_sq, params.damping, on_depin, moved, modal,
                blocks, vectors,
            )  # fmt: skip
    n_changed = 0
    for m in range(n_moved):
        for k in (moved[m] - 1, moved[m], moved[m] + 1):
            if 0 <= k < n and marks[k] == 0:
                marks[k] = 1
                changed[n_changed] = k
                n_changed += 1
    for m in range(n_changed):
        k = changed[m]
        marks[k] = 0
        _settle(k, t, xi, h, t_ref, x_rate, params.omega_a, table)
    for m in range(n_changed):
        k = changed[m]
        xi[k] = reduced_stress(z, k, kappa)
    for m in range(n_moved):
        k = moved[m]
        on_depin[k] = 0
        h[k] = standard_exponential(stream)
    return events, n_changed


@kernel
def advance_chain(
    z: np.ndarray,
    h: np.ndarray,
    jump: float,
    x_rate: float,
    duration: float,
    params: np.ndarray,
    table: np.ndarray,
    stream: np.ndarray,
) -> int:
    """Advance one contact's coupled chain over one slider segment (001/Eq. 21).

    The slider jumps by ``jump`` (reduced), then slides for ``duration`` [s] at ``x_rate``
    [1/s]; ``z`` (reduced stretches) and ``h`` (remaining hazards) are updated in place.
    ``params`` is a record of :data:`nanoblock.kernels.layout.PARAMS`. Returns the number
    of depinnings.
    """
    n = z.shape[0]
    xi = np.empty(n)
    t_ref = np.zeros(n)
    fire = np.empty(n)
    heap = np.empty(n, dtype=np.int64)
    where = np.empty(n, dtype=np.int64)
    work = np.zeros((5, n), dtype=np.int64)
    cluster = cluster_workspace(n)
    for i in range(n):
        z[i] += jump
    for i in range(n):
        xi[i] = reduced_stress(z, i, params.kappa)
    events = 0
    for i in range(n):  # blocks pushed over threshold by the jump slip at t = 0
        if abs(xi[i]) >= 1.0:
            count, _ = _avalanche(
                i, 0.0, x_rate, z, xi, h, t_ref, work, cluster, params, table, stream
            )
            events += count
    for i in range(n):
        fire[i] = _fire_time(i, xi, h, t_ref, x_rate, duration, params.omega_a, table)
    _heapify(heap, where, fire)
    while fire[heap[0]] <= duration:
        j = heap[0]
        count, n_changed = _avalanche(
            j, fire[j], x_rate, z, xi, h, t_ref, work, cluster, params, table, stream
        )
        events += count
        for m in range(n_changed):
            k = work[2, m]
            fire[k] = _fire_time(k, xi, h, t_ref, x_rate, duration, params.omega_a, table)
            _sift(heap, where, fire, where[k])
    for i in range(n):
        _settle(i, duration, xi, h, t_ref, x_rate, params.omega_a, table)
        z[i] += x_rate * duration
    return events


@kernel
def reduced_stresses(y: np.ndarray, kappa: float) -> np.ndarray:
    """Reduced stresses x[c, i] of every block from the stretches y[c, i] (c = contacts)."""
    out = np.empty_like(y)
    for c in range(y.shape[0]):
        for i in range(y.shape[1]):
            out[c, i] = reduced_stress(y[c], i, kappa)
    return out
