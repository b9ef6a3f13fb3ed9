"""Normal modes of a run of moving chain blocks and their exact damped motion (001/Eq. 21).

Reduced units of :mod:`nanoblock.kernels.chain`: stretches z over rho_max, time in s. A
run is a maximal string of moving blocks; its pinned neighbours are fixed, so its reduced
stresses are x = A z + c with A = I + kappa L, L the path Laplacian of the run whose end
diagonal is 2 next to a pinned block ("fixed" end) and 1 at a free chain end. Each block
obeys z'' = -gamma z' - omega_1^2 x (001/Eq. 21 divided by m_b k1 rho_max), so in the
orthonormal eigenbasis U of L (A U = U diag(a), a_k = 1 + kappa lambda_k) the modal
deviations q = U^T (z - z*) from the equilibrium z* = -A^-1 c and velocities p = U^T z'
are independent damped oscillators, q'' + gamma q' + w_k^2 q = 0 with w_k^2 = omega_1^2 a_k.

With s^2 = gamma^2 / 4 - w^2 [1/s^2], a mode started at (q0, p0) is

    q(t) = e^{-gamma t/2} [q0 C + (p0 + gamma q0 / 2) S],
    p(t) = e^{-gamma t/2} [p0 C - (w^2 q0 + gamma p0 / 2) S],

with C = cosh(st), S = sinh(st)/s (cos, sin for s^2 < 0, a Taylor series near s^2 t^2 = 0,
so the critical case is exact). Every quantity of the event loop is a linear combination
of such terms; this module evaluates them, finds their zeros, and bounds their future.
All functions are pure functions of scalars and flat arrays and allocate nothing.
"""

from __future__ import annotations

import numpy as np

from nanoblock.kernels._jit import kernel

_SERIES = 1e-2
"""|s^2 t^2| below which C and S use five Taylor terms (truncation < 1e-17 relative)."""

_ROOT_ITERATIONS = 200


@kernel(nrt=False)
def run_spectrum(
    length: int,
    left_fixed: bool,
    right_fixed: bool,
    eigenvalues: np.ndarray,
    vectors: np.ndarray,
    first: int,
) -> None:
    """Closed-form eigenpairs of the path Laplacian of a run of ``length`` blocks.

    Ascending eigenvalues go to ``eigenvalues[first + k]`` and the orthonormal eigenvectors
    to ``vectors[first + i, k]`` (block i of the run, mode k). Both ends fixed (Dirichlet):
    lambda_k = 4 sin^2(theta/2), theta = (k+1) pi/(n+1), U_ik ~ sin((i+1) theta); both free
    (Neumann): theta = k pi/n, U_ik ~ cos((i+1/2) theta); free at i = 0 and fixed at the
    other end: theta = (2k+1) pi/(2n+1), U_ik ~ cos((i+1/2) theta), mirrored for the
    opposite case. A lone block without neighbours has lambda = 0.
    """
    n = length
    both_fixed = left_fixed and right_fixed
    mixed = left_fixed != right_fixed
    for k in range(n):
        if both_fixed:
            theta = (k + 1) * np.pi / (n + 1)
        elif mixed:
            theta = (2 * k + 1) * np.pi / (2 * n + 1)
        else:
            theta = k * np.pi / n
        eigenvalues[first + k] = 4.0 * np.sin(0.5 * theta) ** 2
        twice_cos = 2.0 * np.cos(theta)
        # sin((i+1) theta) or cos((i+1/2) theta) by the Chebyshev recurrence in i
        previous = 0.0 if both_fixed else np.cos(0.5 * theta)
        current = np.sin(theta) if both_fixed else previous
        norm = 0.0
        for i in range(n):
            row = first + (n - 1 - i if left_fixed and mixed else i)
            vectors[row, k] = current
            norm += current * current
            previous, current = current, twice_cos * current - previous
        scale = 1.0 / np.sqrt(norm)
        for i in range(n):
            vectors[first + i, k] *= scale


TABLED_LENGTH = 16
"""Runs up to this long take their spectra from :data:`SPECTRA` instead of trigonometry."""


def _spectrum_table() -> np.ndarray:
    """Eigenvalues then row-major eigenvectors of every run of 1..TABLED_LENGTH blocks and
    end type (index left_fixed + 2 right_fixed), behind an offset header of 4 x (L + 1)."""
    header = 4 * (TABLED_LENGTH + 1)
    sizes = [length + length * length for length in range(1, TABLED_LENGTH + 1)]
    table = np.zeros(header + 4 * sum(sizes))
    position = header
    for kind in range(4):
        for length in range(1, TABLED_LENGTH + 1):
            eigenvalues, vectors = np.empty(length), np.empty((length, length))
            run_spectrum(length, kind % 2 == 1, kind >= 2, eigenvalues, vectors, 0)
            table[kind * (TABLED_LENGTH + 1) + length] = position
            table[position : position + length] = eigenvalues
            table[position + length : position + length + length * length] = vectors.ravel()
            position += length + length * length
    return table


SPECTRA = _spectrum_table()


@kernel(inline=True)
def tabled_spectrum(
    length: int,
    left_fixed: bool,
    right_fixed: bool,
    eigenvalues: np.ndarray,
    vectors: np.ndarray,
    first: int,
) -> None:
    """:func:`run_spectrum`, read from :data:`SPECTRA` when the run is short enough."""
    if length > TABLED_LENGTH:
        run_spectrum(length, left_fixed, right_fixed, eigenvalues, vectors, first)
        return
    kind = (1 if left_fixed else 0) + (2 if right_fixed else 0)
    position = int(SPECTRA[kind * (TABLED_LENGTH + 1) + length])
    for k in range(length):
        eigenvalues[first + k] = SPECTRA[position + k]
    position += length
    for i in range(length):
        for k in range(length):
            vectors[first + i, k] = SPECTRA[position + i * length + k]


@kernel(inline=True)
def damped_basis(s_sq: float, t: float) -> tuple[float, float]:
    """(C, S) = (cosh(st), sinh(st)/s) for s^2 > 0, (cos(|s|t), sin(|s|t)/|s|) for s^2 < 0,
    by series near s^2 t^2 = 0 (s^2 [1/s^2], t [s]; S in s)."""
    u = s_sq * t * t
    if abs(u) < _SERIES:
        c = 1.0 + u / 2.0 * (1.0 + u / 12.0 * (1.0 + u / 30.0 * (1.0 + u / 56.0)))
        s = t * (1.0 + u / 6.0 * (1.0 + u / 20.0 * (1.0 + u / 42.0 * (1.0 + u / 72.0))))
        return c, s
    if s_sq > 0.0:  # |st| > 0.1: e^{st} - e^{-st} loses at most a digit
        rate = np.sqrt(s_sq)
        grow = np.exp(rate * t)
        return 0.5 * (grow + 1.0 / grow), 0.5 * (grow - 1.0 / grow) / rate
    frequency = np.sqrt(-s_sq)
    return np.cos(frequency * t), np.sin(frequency * t) / frequency


@kernel(inline=True)
def _undecayed(
    q0: float, p0: float, w_sq: float, s_sq: float, gamma: float, t: float
) -> tuple[float, float]:
    """The bracketed factors of the module doc's q(t) and p(t), without e^{-gamma t/2}."""
    c, s = damped_basis(s_sq, t)
    return q0 * c + (p0 + 0.5 * gamma * q0) * s, p0 * c - (w_sq * q0 + 0.5 * gamma * p0) * s


@kernel(inline=True)
def propagate(
    q0: float, p0: float, w_sq: float, s_sq: float, gamma: float, t: float
) -> tuple[float, float]:
    """Modal deviation and velocity a time t [s] after (q0, p0) (closed form, module doc)."""
    q, p = _undecayed(q0, p0, w_sq, s_sq, gamma, t)
    decay = np.exp(-0.5 * gamma * t)
    return decay * q, decay * p


@kernel(inline=True)
def step_matrix(
    w_sq: float, s_sq: float, gamma: float, dt: float
) -> tuple[float, float, float, float]:
    """Entries (m00, m01, m10, m11) of the exact one-step map (q, p) -> M (q, p) over dt."""
    c, s = damped_basis(s_sq, dt)
    decay = np.exp(-0.5 * gamma * dt)
    return (
        decay * (c + 0.5 * gamma * s),
        decay * s,
        -decay * w_sq * s,
        decay * (c - 0.5 * gamma * s),
    )


@kernel(inline=True)
def combination_at(
    t: float,
    constant: float,
    slots: np.ndarray,
    weight_q: np.ndarray,
    weight_p: np.ndarray,
    n_terms: int,
    q0: np.ndarray,
    p0: np.ndarray,
    w_sq: np.ndarray,
    s_sq: np.ndarray,
    gamma: float,
) -> tuple[float, float]:
    """f(t) = constant + sum_j (weight_q[j] q_m(t) + weight_p[j] p_m(t)), m = slots[j], each
    mode propagated for t [s] from (q0[m], p0[m]), and its slope df/dt (q' = p,
    p' = -gamma p - w^2 q)."""
    value, slope = 0.0, 0.0
    for j in range(n_terms):
        m = slots[j]
        q, p = _undecayed(q0[m], p0[m], w_sq[m], s_sq[m], gamma, t)
        value += weight_q[j] * q + weight_p[j] * p
        slope += weight_q[j] * p - weight_p[j] * (gamma * p + w_sq[m] * q)
    decay = np.exp(-0.5 * gamma * t)
    return constant + decay * value, decay * slope


@kernel(nrt=False)
def combination_root(
    lo: float,
    hi: float,
    f_lo: float,
    f_hi: float,
    constant: float,
    slots: np.ndarray,
    weight_q: np.ndarray,
    weight_p: np.ndarray,
    n_terms: int,
    q0: np.ndarray,
    p0: np.ndarray,
    w_sq: np.ndarray,
    s_sq: np.ndarray,
    gamma: float,
) -> float:
    """A zero of :func:`combination_at` in [lo, hi] [s], where it changes sign.

    Newton steps kept inside the shrinking bracket (false position to start; bisection
    when a step leaves the bracket or three steps fail to halve it) until the Newton
    correction or the bracket is a few ulps.
    """
    tolerance = 4.0 * np.finfo(np.float64).eps
    widths = (np.inf, np.inf, np.inf)  # the bracket width three, two and one steps ago
    t = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
    for _ in range(_ROOT_ITERATIONS):
        if f_lo == 0.0 or f_hi == 0.0:
            return lo if f_lo == 0.0 else hi
        if hi - lo <= tolerance * max(abs(lo), abs(hi)):
            break
        if not lo < t < hi or hi - lo > 0.5 * widths[0]:
            t = 0.5 * (lo + hi)
        widths = (widths[1], widths[2], hi - lo)
        f, slope = combination_at(
            t, constant, slots, weight_q, weight_p, n_terms, q0, p0, w_sq, s_sq, gamma
        )
        if f == 0.0:
            return t
        if (f > 0.0) == (f_hi > 0.0):
            hi, f_hi = t, f
        else:
            lo, f_lo = t, f
        correction = f / slope if slope != 0.0 else np.inf
        if abs(correction) <= tolerance * abs(t) and lo <= t - correction <= hi:
            return t - correction
        t -= correction
    return lo if abs(f_lo) < abs(f_hi) else hi


@kernel(inline=True)
def _peak(alpha: float, beta: float, decay: float) -> float:
    """max over tau >= 0 of (alpha + beta tau) e^{-decay tau} (alpha, beta >= 0, decay > 0)."""
    if beta <= alpha * decay:
        return alpha
    return beta / decay * np.exp(alpha * decay / beta - 1.0)


@kernel(inline=True)
def envelope(a: float, b: float, s_sq: float, gamma: float, rate: float) -> float:
    """Bound on max over tau >= 0 of |e^{-gamma tau/2} (a C + b S)| e^{rate tau} (inf if none).

    |C| <= e^{s+ tau} and |S| <= tau e^{s+ tau} (s+ = max(s, 0)) give (|a| + |b| tau)
    e^{-(gamma/2 - s+ - rate) tau}; for s^2 > 0 the split a C + b S = (a + b/s)/2 e^{s tau}
    + (a - b/s)/2 e^{-s tau} gives |a + b/s|/2 + |a - b/s|/2 when gamma/2 - s >= rate.
    The smaller applies. For q: a = q0, b = p0 + gamma q0/2; for p: a = p0,
    b = -(w^2 q0 + gamma p0/2). ``rate`` [1/s] is the reference decay rate.
    """
    s_plus = np.sqrt(s_sq) if s_sq > 0.0 else 0.0
    decay = 0.5 * gamma - s_plus - rate
    bound = _peak(abs(a), abs(b), decay) if decay > 0.0 else np.inf
    if s_sq > 0.0 and decay >= 0.0:
        bound = min(bound, 0.5 * (abs(a + b / s_plus) + abs(a - b / s_plus)))
    return bound


@kernel(inline=True)
def slow_part(a: float, b: float, s_sq: float) -> tuple[float, float]:
    """(slow, fast) amplitudes of a C + b S = slow e^{s tau} + fast e^{-s tau}, s^2 > 0."""
    s = np.sqrt(s_sq)
    return 0.5 * (a + b / s), 0.5 * (a - b / s)


@kernel(inline=True)
def single_mode_keeps_sign(p0: float, b: float, s_sq: float) -> bool:
    """Whether p(tau) = e^{-gamma tau/2} (p0 C + b S) has no zero for tau > 0 (s^2 >= 0).

    C > 0 and S/C rises monotonically from 0 to 1/s (without bound if s = 0), so the one
    possible zero, S/C = -p0/b, exists unless p0 b >= 0 or s |p0| >= |b|. Exact for a run
    of one block (:func:`envelope` notation).
    """
    if s_sq < 0.0:
        return False
    if p0 == 0.0:
        return b != 0.0
    return p0 * b >= 0.0 or np.sqrt(s_sq) * abs(p0) >= abs(b)
