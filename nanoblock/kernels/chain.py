"""Coupled nanoblock chain (k2 > 0): event-driven depinning and avalanches (001/Eq. 21).

Reduced units: ``z[i]`` = stretch of block i's plate spring over rho_max at the start of
the slider segment, so that while all blocks are pinned every block's reduced stress is

    x_i(t) = xi_i + xdot t,   xi_i = z_i + kappa (n_i z_i - sum of neighbours' z),

with kappa = k2 / k1 and n_i the number of neighbours (free chain ends). Depinnings are
processed in time order with an indexed heap; a block's hazard is settled lazily, only
when its stress history changes (a neighbour slips) or the segment ends. Avalanches run
with the slider frozen: the ``reset`` rule releases each depinned block to zero force,
neighbours fixed; the ``chain`` rule lands an isolated block in closed form and
integrates Eq. 21, m q'' + m gamma q' = f, by RK4 for clusters, repinning each block
when its velocity first vanishes.
"""

from __future__ import annotations

import numpy as np

from nanoblock.kernels._jit import kernel
from nanoblock.kernels.blocks import next_depinning
from nanoblock.kernels.hazard import hazard_between
from nanoblock.kernels.rng import standard_exponential

_SETTLED = 1e-9
"""An overdamped block repins once |x| and |v| / omega_1 fall below this."""

_MAX_SUBSTEPS = 10_000_000


@kernel
def _neighbours(i: int, n: int) -> int:
    return (1 if i > 0 else 0) + (1 if i < n - 1 else 0)


@kernel
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
@kernel
def _swap(heap: np.ndarray, where: np.ndarray, a: int, b: int) -> None:
    heap[a], heap[b] = heap[b], heap[a]
    where[heap[a]] = a
    where[heap[b]] = b


@kernel
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
@kernel
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
@kernel
def _record_depinning(i, on_depin, moved, n_moved) -> int:
    if on_depin[i] == 0:
        moved[n_moved] = i
        n_moved += 1
    on_depin[i] += 1
    return n_moved


@kernel
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


@kernel
def _accelerate(z, v, moving, n_moving, offset, kappa, omega1_sq, damping, out) -> None:
    """dv/dt of the moving blocks, v = dz/dt: Eq. 21 in reduced units, z'' = -gamma z' - w1^2 x."""
    for m in range(n_moving):
        i = moving[m]
        out[i] = -damping * v[i] - omega1_sq * (reduced_stress(z, i, kappa) + offset)


@kernel
def _hermite_at(z0, z1, v0, v1, dt, s) -> float:
    """Cubic Hermite position at fraction s of a substep from end values and velocities."""
    s2 = s * s
    s3 = s2 * s
    return (
        (2 * s3 - 3 * s2 + 1) * z0
        + (s3 - 2 * s2 + s) * dt * v0
        + (3 * s2 - 2 * s3) * z1
        + (s3 - s2) * dt * v1
    )


@kernel
def integrate_cluster(
    z, offset, first, kappa, omega1_sq, damping, on_depin, moved
) -> tuple[int, int]:
    """Integrate Eq. 21 for the avalanche started by block ``first`` (slider frozen).

    RK4 on (z, v) of the moving blocks, pinned ones fixed; a pinned block next to a moving
    one joins when |x| >= 1; a moving block repins when its velocity first vanishes (the
    zero located by linear interpolation of v, the position by cubic Hermite), or, when
    overdamped, once |x| and |v| / omega_1 are below 1e-9. ``z`` changes in place.
    Returns (depinnings, number of distinct blocks listed in ``moved``).
    """
    n = z.shape[0]
    omega_1 = np.sqrt(omega1_sq)
    dt = 0.2 / max(omega_1 * np.sqrt(1.0 + 4.0 * kappa), damping)
    half = 0.5 * dt
    v = np.zeros(n)
    direction = np.zeros(n)
    in_motion = np.zeros(n, dtype=np.bool_)
    moving = np.empty(n, dtype=np.int64)
    was_moving = np.empty(n, dtype=np.int64)
    stage_z = z.copy()
    stage_v = np.zeros(n)
    z0 = np.empty(n)
    v0 = np.empty(n)
    acc = np.zeros((4, n))
    n_moving, events, n_moved = 0, 0, 0
    join = first
    for _ in range(_MAX_SUBSTEPS):
        if join >= 0:  # the starting block enters here; later joins happen below
            moving[n_moving] = join
            n_moving += 1
            in_motion[join] = True
            v[join] = 0.0
            direction[join] = -1.0 if reduced_stress(z, join, kappa) + offset > 0.0 else 1.0
            n_moved = _record_depinning(join, on_depin, moved, n_moved)
            events += 1
            join = -1
        if n_moving == 0:
            break
        for m in range(n_moving):
            i = moving[m]
            z0[i] = z[i]
            v0[i] = v[i]
            stage_z[i] = z[i]
            stage_v[i] = v[i]
        _accelerate(stage_z, stage_v, moving, n_moving, offset, kappa, omega1_sq, damping, acc[0])
        for stage in range(1, 4):
            scale = dt if stage == 3 else half
            for m in range(n_moving):
                i = moving[m]
                previous_v = v0[i] if stage == 1 else v0[i] + half * acc[stage - 2, i]
                stage_z[i] = z0[i] + scale * previous_v
                stage_v[i] = v0[i] + scale * acc[stage - 1, i]
            _accelerate(
                stage_z, stage_v, moving, n_moving, offset, kappa, omega1_sq, damping, acc[stage]
            )
        for m in range(n_moving):
            i = moving[m]
            z[i] = z0[i] + dt / 6.0 * (6.0 * v0[i] + dt * (acc[0, i] + acc[1, i] + acc[2, i]))
            v[i] = v0[i] + dt / 6.0 * (acc[0, i] + 2.0 * acc[1, i] + 2.0 * acc[2, i] + acc[3, i])
            stage_z[i] = z[i]
            was_moving[m] = i
        n_was_moving = n_moving
        m = 0
        while m < n_moving:  # repinning
            i = moving[m]
            turned = v0[i] * direction[i] > 0.0 and v[i] * direction[i] <= 0.0
            x = reduced_stress(z, i, kappa) + offset
            settled = abs(x) < _SETTLED and abs(v[i]) < _SETTLED * omega_1
            if turned:
                z[i] = _hermite_at(z0[i], z[i], v0[i], v[i], dt, v0[i] / (v0[i] - v[i]))
            if turned or settled:
                stage_z[i] = z[i]
                v[i] = 0.0
                in_motion[i] = False
                n_moving -= 1
                moving[m] = moving[n_moving]
            else:
                m += 1
        for m in range(n_was_moving):  # pinned blocks pushed over threshold join
            i = was_moving[m]
            for j in (i - 1, i, i + 1):
                if join < 0 and 0 <= j < n and not in_motion[j]:
                    if abs(reduced_stress(z, j, kappa) + offset) >= 1.0:
                        join = j
        if n_moving == 0 and join < 0:
            break
    return events, n_moved


# ---------------------------------------------------------------- one contact, one segment
@kernel
def _fire_time(i, xi, h, t_ref, x_rate, duration, omega_a, table) -> float:
    t, _, _ = next_depinning(
        xi[i] + x_rate * t_ref[i], h[i], x_rate, duration - t_ref[i], omega_a, table
    )
    return t_ref[i] + t


@kernel
def _avalanche(j, t, x_rate, z, xi, h, t_ref, work, params, table, stream) -> tuple[int, int]:
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
            events, n_moved = integrate_cluster(
                z, offset, j, kappa, params.omega1_sq, params.damping, on_depin, moved
            )
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
    for i in range(n):
        z[i] += jump
    for i in range(n):
        xi[i] = reduced_stress(z, i, params.kappa)
    events = 0
    for i in range(n):  # blocks pushed over threshold by the jump slip at t = 0
        if abs(xi[i]) >= 1.0:
            count, _ = _avalanche(i, 0.0, x_rate, z, xi, h, t_ref, work, params, table, stream)
            events += count
    for i in range(n):
        fire[i] = _fire_time(i, xi, h, t_ref, x_rate, duration, params.omega_a, table)
    _heapify(heap, where, fire)
    while fire[heap[0]] <= duration:
        j = heap[0]
        count, n_changed = _avalanche(
            j, fire[j], x_rate, z, xi, h, t_ref, work, params, table, stream
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
