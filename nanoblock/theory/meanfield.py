"""Analytic mean-field theory of Persson's nanoblock joint (001/Eqs. 24-30).

Mean-field limit of the joint (physics.md section 1; 001/Fig. 14): uncoupled blocks
(k2 = 0) with reduced coordinate rho~ in [0, rho~_max], rho~_max = b^2 sigma_a / k1, and
stress sigma = k1 rho~ / b^2. A block is advected at the slider velocity V
(d rho~ / dt = V), escapes thermally at the rate (001/Eq. 24)

    1 / tau = omega_a exp(-u f(x)),   x = sigma / sigma_a = rho~ / rho~_max,

(f the reduced barrier of :mod:`nanoblock.barriers`, u = U_a / k_B T), fires for certain at
rho~_max, and restarts unstressed at rho~ = 0. Its stationary density is 001/Eq. 27,

    Q_st(rho~) = exp(-I(rho~)) / Z,   I(rho~) = int_0^rho~ d rho' / (V tau(rho')),

and the friction stress sigma_s(V) is the mean stress under Q_st (001/Eq. 28).

Numerics. With Lambda = omega_a rho~_max / V and J(x) = int_0^x exp(-u f(s)) ds the
survival exponent is I = Lambda J(x). Persson's law has the closed form
J(x) = exp(-u (1 - x^2)) D(sqrt(u) x) / sqrt(u) (D: Dawson's function); other laws use a
cached Gauss-Legendre table of J. All integrals over x run in t = 1 - sqrt(1 - x), which
makes the generic (1 - x)^(3/2) saddle-node barrier analytic at x = 1, with Gauss-Legendre
cells whose edges are the points where I crosses fixed levels (1e-16 ... 745): the cells
follow the cutoff however sharp it is (u up to 500 and beyond) and wherever it lies
(x_c from 1e-17 to 1), and no exponential can overflow.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import PchipInterpolator
from scipy.special import dawsn, expit, ndtr, ndtri

from nanoblock.barriers import (
    BARRIERS,
    BOLTZMANN,
    barrier_law,
    lattice_barrier_floor,
    reduced_barrier_height,
    zero_stress_barrier,
)
from nanoblock.theory.lattice_kernel import occupancy_departure

__all__ = [
    "EULER_GAMMA",
    "MeanFieldJoint",
    "cutoff_rho",
    "escape_rate",
    "firing_stress_asymptotic",
    "log_slope",
    "log_slope_asymptotic",
    "mean_firing_reduced_stress",
    "q_stationary",
    "q_stationary_cdf",
    "sample_q_stationary",
    "steady_stress",
    "steady_stress_asymptotic",
    "steady_stress_loglaw",
    "strength_factors",
    "survival_exponent",
]

FloatArray = NDArray[np.float64]

EULER_GAMMA = float(np.euler_gamma)
"""Euler's constant gamma_E (dimensionless)."""

_GL_X, _GL_W = np.polynomial.legendre.leggauss(20)
_TABLE_GL_X, _TABLE_GL_W = np.polynomial.legendre.leggauss(16)
_TABLE_CELLS = 2048
_LEVELS = np.concatenate(
    [10.0 ** np.arange(-16, -1), np.geomspace(0.1, 40.0, 24), np.geomspace(40.0, 745.0, 6)[1:]]
)
_LOG_LEVELS = np.log(_LEVELS)
_LOG_I_CAP = 700.0  # exp(-exp(700)) == 0: larger exponents change nothing
_BISECTIONS = 64
_NEWTON_TOLERANCE = 1e-13
_SAMPLE_SUBCELLS = 16
_PEAK_GRID = 4097
_LATTICE_CELLS = 2**15  # the stationary density and sampling
_LATTICE_STRESS_CELLS = 2**13  # steady_stress, with Richardson extrapolation
_LATTICE_GL_X, _LATTICE_GL_W = np.polynomial.legendre.leggauss(4)


@dataclass(frozen=True)
class MeanFieldJoint:
    """Parameters of a mean-field nanoblock joint (physics.md section 1; 001/Sec. III).

    Parameters
    ----------
    block_size : float
        Block size b [m].
    shear_modulus : float
        Joint shear modulus E_J [Pa].
    threshold_stress : float
        Athermal depinning threshold sigma_a [Pa].
    k1 : float
        Stiffness coupling a block to its driving point [N/m] (k1 ~ E_J b).
    attempt_frequency : float
        Attempt frequency omega_a of thermal escape [1/s] (001/Eq. 24).
    temperature : float
        Temperature T [K].
    barrier : str
        Name of the barrier law in :data:`nanoblock.barriers.BARRIERS`.
    back_jumps : bool
        Reverse hops in detailed balance on Persson's periodic characteristic
        (physics.md section 5; :func:`nanoblock.barriers.lattice_reverse_barrier`):
        :func:`steady_stress`, :func:`q_stationary` and :func:`sample_q_stationary`
        then solve the two-branch occupancy equation instead of 001/Eq. 27.
    threshold_spread : float
        Log-standard deviation of sigma_a across contacts (lognormal of mean
        ``threshold_stress``); >= 0.
    strength_classes : int
        Number of equal-probability strength classes that discretise the spread
        (:func:`strength_factors`); the theory averages over them, as the simulation
        does over its contacts.
    """

    block_size: float
    shear_modulus: float
    threshold_stress: float
    k1: float
    attempt_frequency: float
    temperature: float
    barrier: str = "persson"
    back_jumps: bool = False
    threshold_spread: float = 0.0
    strength_classes: int = 1

    def __post_init__(self) -> None:
        for field in fields(self)[:6]:
            value = getattr(self, field.name)
            if not (
                isinstance(value, numbers.Real)
                and not isinstance(value, bool)
                and math.isfinite(value)
                and value > 0
            ):
                raise ValueError(
                    f"{field.name} must be a finite positive number (0 < {field.name} < inf), "
                    f"got {value!r}"
                )
        if self.barrier not in BARRIERS:
            raise ValueError(
                f"barrier must be one of {', '.join(sorted(BARRIERS))}, got {self.barrier!r}"
            )
        if not (math.isfinite(self.threshold_spread) and self.threshold_spread >= 0.0):
            raise ValueError(
                f"threshold_spread must be finite and >= 0, got {self.threshold_spread!r}"
            )
        classes = self.strength_classes
        if not (isinstance(classes, numbers.Integral) and classes >= 1):
            raise ValueError(f"strength_classes must be an integer >= 1, got {classes!r}")
        if self.back_jumps and lattice_barrier_floor(self.barrier, self.u, self.u_elastic) < 0.0:
            raise ValueError(
                "back_jumps: the reverse-hop barrier turns negative (k1 < E_J b / 2 for "
                "Persson's law); no consistent periodic characteristic"
            )

    @property
    def is_base(self) -> bool:
        """Whether the joint is the base model of 001/Eq. 27 (one class, forward hops only)."""
        return not self.back_jumps and self.strength_classes == 1

    def classes(self) -> tuple[MeanFieldJoint, ...]:
        """The equal-weight strength classes: joints with sigma_a times
        :func:`strength_factors` and no spread (the joint itself when it has one class)."""
        if self.strength_classes == 1:
            return (self,)
        return tuple(
            replace(
                self,
                threshold_stress=self.threshold_stress * factor,
                threshold_spread=0.0,
                strength_classes=1,
            )
            for factor in strength_factors(self.threshold_spread, self.strength_classes)
        )

    @property
    def u_elastic(self) -> float:
        """u_el = k1 rho~_max^2 / k_B T (dimensionless): the elastic energy drop of a hop
        across the Maxwell point of the periodic characteristic, per unit of stress."""
        return self.k1 * self.rho_max**2 / (BOLTZMANN * self.temperature)

    @property
    def rho_max(self) -> float:
        """rho~_max = b^2 sigma_a / k1 [m], the athermal depinning coordinate."""
        return self.block_size**2 * self.threshold_stress / self.k1

    @property
    def barrier_energy(self) -> float:
        """U_a = sigma_a b^3 (sigma_a / E_J) [J], the zero-stress barrier (001/Eq. 37)."""
        return zero_stress_barrier(self.threshold_stress, self.block_size, self.shear_modulus)

    @property
    def u(self) -> float:
        """u = U_a / (k_B T) (dimensionless)."""
        return reduced_barrier_height(
            self.threshold_stress, self.block_size, self.shear_modulus, self.temperature
        )

    @property
    def sigma_bar(self) -> float:
        """sigma_bar = sigma_a / 2 [Pa], the athermal friction stress (001 before Eq. 24)."""
        return 0.5 * self.threshold_stress

    @property
    def alpha(self) -> float:
        """alpha = k_B T E_J / (8 sigma_bar^2 b^3) = 1 / (2u) (001/Eqs. 30, 32)."""
        return (
            BOLTZMANN
            * self.temperature
            * self.shear_modulus
            / (8.0 * self.sigma_bar**2 * self.block_size**3)
        )

    @property
    def v_star(self) -> float:
        """V* = e^gamma_E omega_a rho~_max k_B T / (2 U_a) [m/s] (physics.md section 1)."""
        return math.exp(EULER_GAMMA) * self.attempt_frequency * self.rho_max / (2.0 * self.u)

    @property
    def activation_volume(self) -> float:
        """v_act = 8 b^3 sigma_bar / E_J [m^3] (001/Eq. 33)."""
        return 8.0 * self.block_size**3 * self.sigma_bar / self.shear_modulus


class _Moments(NamedTuple):
    """N_k = int_0^1 x^k S dx and M_k = int_0^1 x^k I S dx, S = exp(-I) (dimensionless)."""

    n0: FloatArray
    n1: FloatArray
    m0: FloatArray
    m1: FloatArray


# --------------------------------------------------------------------------- helpers


def _velocity(velocity: ArrayLike) -> FloatArray:
    """Validated velocity array V [m/s]."""
    v = np.asarray(velocity, dtype=float)
    if not np.all(np.isfinite(v) & (v > 0)):
        raise ValueError("V must be finite and positive (0 < V < inf) [m/s]")
    return v


def _log_lambda(velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """ln Lambda = ln(omega_a rho~_max / V) (dimensionless) of a base joint (001/Eq. 27)."""
    if not joint.is_base:
        raise ValueError(
            "this function is the theory of the base joint (001/Eq. 27); with back_jumps "
            "or strength classes use steady_stress, q_stationary or sample_q_stationary"
        )
    return math.log(joint.attempt_frequency * joint.rho_max) - np.log(_velocity(velocity))


def _x_to_t(x: ArrayLike) -> FloatArray:
    """t = 1 - sqrt(1 - x), written without cancellation."""
    x = np.asarray(x, dtype=float)
    return x / (1.0 + np.sqrt(1.0 - x))


def _t_to_x(t: ArrayLike) -> FloatArray:
    """x = 1 - (1 - t)^2, written without cancellation."""
    t = np.asarray(t, dtype=float)
    return t * (2.0 - t)


def _gauss_rule(
    a: ArrayLike, b: ArrayLike, nodes: FloatArray, weights: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Gauss-Legendre nodes and weights on [a, b] (broadcast; nodes on a new last axis)."""
    a = np.asarray(a, dtype=float)[..., None]
    half = 0.5 * (np.asarray(b, dtype=float)[..., None] - a)
    return a + half * (nodes + 1.0), half * weights


def _bisect(func: Callable[[FloatArray], FloatArray], lo: FloatArray, hi: FloatArray) -> FloatArray:
    """Vectorised bisection for the root of a function increasing on [lo, hi]."""
    lo, hi = np.broadcast_arrays(np.asarray(lo, dtype=float), np.asarray(hi, dtype=float))
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        above = func(mid) > 0.0
        lo, hi = np.where(above, lo, mid), np.where(above, mid, hi)
    return 0.5 * (lo + hi)


def _newton(
    func: Callable[[FloatArray], tuple[FloatArray, FloatArray]], lo: FloatArray, hi: FloatArray
) -> FloatArray:
    """Vectorised root of a function increasing on [lo, hi], from ``func`` returning its
    value and slope: Newton steps from ``hi``, a bisection wherever a step leaves the
    bracket, until every step is below 1e-13 (at most _BISECTIONS iterations)."""
    lo, hi = np.broadcast_arrays(np.asarray(lo, dtype=float), np.asarray(hi, dtype=float))
    y = hi.copy()
    for _ in range(_BISECTIONS):
        value, slope = func(y)
        above = value > 0.0
        lo, hi = np.where(above, lo, y), np.where(above, y, hi)
        step = y - value / slope
        step = np.where((step >= lo) & (step <= hi), step, 0.5 * (lo + hi))
        converged = np.all(np.abs(step - y) <= _NEWTON_TOLERANCE * (1.0 + np.abs(y)))
        y = step
        if converged:
            break
    return y


def _unique_velocities(velocity: FloatArray) -> tuple[FloatArray, NDArray[np.intp]]:
    """Distinct velocities and the inverse index (flattened)."""
    return np.unique(velocity.ravel(), return_inverse=True)


# ------------------------------------------------------------ survival exponent I(x)


def _j_rate_t(t: FloatArray, barrier: str, u: float) -> FloatArray:
    """dJ/dt = exp(-u f(x(t))) dx/dt, the reduced escape rate in the t variable."""
    return np.exp(-u * barrier_law(barrier)(_t_to_x(t))) * 2.0 * (1.0 - t)


def _partial_matrix() -> FloatArray:
    """Map from a cell's integrand at its Gauss-Legendre nodes y_i to the Legendre
    coefficients of G(y) = F(y) / (1 + y), F(y) = int_{-1}^y of the integrand's degree-15
    interpolant (y in [-1, 1]): F = (1 + y) G keeps full relative accuracy as y -> -1."""
    leg = np.polynomial.legendre
    degree = _TABLE_GL_X.size - 1
    scale = (2.0 * np.arange(degree + 1) + 1.0) / 2.0
    interpolants = scale[:, None] * (leg.legvander(_TABLE_GL_X, degree) * _TABLE_GL_W[:, None]).T
    rows = [leg.legdiv(leg.legint(c, lbnd=-1.0), [1.0, 1.0])[0] for c in interpolants.T]
    return np.array(rows)


_PARTIAL = _partial_matrix()


@lru_cache(maxsize=64)
def _j_table(barrier: str, u: float) -> tuple[FloatArray, FloatArray]:
    """Cumulative J at the uniform t-grid edges k / _TABLE_CELLS (Gauss-Legendre per cell)
    and, per cell, the Legendre coefficients of the partial integral's G (:data:`_PARTIAL`)."""
    edges = np.linspace(0.0, 1.0, _TABLE_CELLS + 1)
    t, w = _gauss_rule(edges[:-1], edges[1:], _TABLE_GL_X, _TABLE_GL_W)
    rate = _j_rate_t(t, barrier, u)
    cumulative = np.concatenate([[0.0], np.cumsum(np.sum(w * rate, axis=-1))])
    return cumulative, np.ascontiguousarray((rate @ _PARTIAL).T)


def _log_j_quadrature(x: FloatArray, barrier: str, u: float) -> FloatArray:
    """ln J(x) for any barrier law: table up to the cell edge, plus the integral of the
    cell's degree-15 interpolant of dJ/dt (exact to rounding for these smooth integrands)."""
    table, partial = _j_table(barrier, u)
    t = _x_to_t(np.clip(x, 0.0, 1.0))
    cell = np.minimum((t * _TABLE_CELLS).astype(np.intp), _TABLE_CELLS - 1)
    offset = t - cell / _TABLE_CELLS
    y = 2.0 * _TABLE_CELLS * offset - 1.0
    inner = np.polynomial.legendre.legval(y, partial[:, cell], tensor=False)
    with np.errstate(divide="ignore"):
        return np.log(table[cell] + offset * inner)


def _log_j_persson(x: FloatArray, u: float) -> FloatArray:
    """ln J(x) for Persson's law: J = exp(-u (1 - x^2)) D(sqrt(u) x) / sqrt(u)."""
    root_u = math.sqrt(u)
    with np.errstate(divide="ignore"):
        return -u * (1.0 - x) * (1.0 + x) + np.log(dawsn(root_u * x) / root_u)


def _log_j(x: ArrayLike, joint: MeanFieldJoint, method: str = "auto") -> FloatArray:
    """ln J(x), J(x) = int_0^x exp(-u f(s)) ds, for x in [0, 1] (-inf at x = 0)."""
    x = np.asarray(x, dtype=float)
    if method == "auto":
        method = "closed_form" if joint.barrier == "persson" else "quadrature"
    if method == "quadrature":
        return _log_j_quadrature(x, joint.barrier, joint.u)
    if method == "closed_form" and joint.barrier == "persson":
        return _log_j_persson(x, joint.u)
    raise ValueError(
        f"method must be 'auto', 'quadrature' or (Persson barrier only) 'closed_form', "
        f"got {method!r} for barrier {joint.barrier!r}"
    )


# ------------------------------------------------------- quadrature over Q_st(x)


def _level_edges(log_lam: FloatArray, joint: MeanFieldJoint) -> FloatArray:
    """t-edges [0, t(I = L_1), ..., t(I = L_K), 1] of the adaptive cells, shape (..., K + 2).

    Since exp(-u) x <= J(x) <= x, the level ln J = target lies in
    ln x in [target, target + u]; the root is found in ln x (so tiny cutoffs stay
    resolved) by safeguarded Newton steps, with d ln J / d ln x = x exp(-u f(x)) / J(x).
    """
    target = _LOG_LEVELS - np.asarray(log_lam, dtype=float)[..., None]
    hi = np.minimum(target + joint.u, 0.0)
    lo = np.minimum(target, hi)
    law = barrier_law(joint.barrier)

    def level(log_x: FloatArray) -> tuple[FloatArray, FloatArray]:
        x = np.exp(log_x)
        log_j = _log_j(x, joint)
        return log_j - target, np.exp(log_x - joint.u * law(x) - log_j)

    log_x = _newton(level, lo, hi)
    t = np.maximum.accumulate(_x_to_t(np.exp(log_x)), axis=-1)
    ends = np.ones((*t.shape[:-1], 1))
    return np.concatenate([0.0 * ends, t, ends], axis=-1)


def _survival_nodes(
    edges: FloatArray, log_lam: FloatArray, joint: MeanFieldJoint
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Nodes x, weights w * S (S = exp(-I)) and I on the cells between t-edges.

    ``edges`` has shape (..., K + 2) and ``log_lam`` shape (...); outputs have shape
    (..., K + 1, n_gauss). Sum over the two last axes to integrate dx.
    """
    t, w = _gauss_rule(edges[..., :-1], edges[..., 1:], _GL_X, _GL_W)
    x = _t_to_x(t)
    log_i = np.asarray(log_lam, dtype=float)[..., None, None] + _log_j(x, joint)
    exponent = np.exp(np.minimum(log_i, _LOG_I_CAP))
    return x, w * 2.0 * (1.0 - t) * np.exp(-exponent), exponent


def _moments(velocity: ArrayLike, joint: MeanFieldJoint) -> _Moments:
    """Moments N_k, M_k of the survival S(x) = exp(-Lambda J(x)), shaped like V."""
    log_lam = _log_lambda(velocity, joint)
    x, ws, exponent = _survival_nodes(_level_edges(log_lam, joint), log_lam, joint)

    def total(values: FloatArray) -> FloatArray:
        return np.sum(values, axis=(-2, -1))

    return _Moments(total(ws), total(ws * x), total(ws * exponent), total(ws * exponent * x))


def _broadcast_rho_velocity(rho: ArrayLike, velocity: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Broadcast rho~ [m] against a validated V [m/s]."""
    rho_arr, v_arr = np.broadcast_arrays(np.asarray(rho, dtype=float), _velocity(velocity))
    return rho_arr, v_arr


# ------------------------------------------------------------------ public API


def escape_rate(x: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Thermal escape rate 1/tau = omega_a exp(-u f(x)) [1/s] (001/Eq. 24).

    Parameters
    ----------
    x : array_like
        Reduced stress sigma / sigma_a (dimensionless; |x| is clipped to [0, 1]).
    joint : MeanFieldJoint
        Joint parameters.

    Returns
    -------
    ndarray
        Escape rate [1/s], same shape as ``x``.
    """
    return joint.attempt_frequency * np.exp(-joint.u * barrier_law(joint.barrier)(x))


def survival_exponent(
    rho: ArrayLike, velocity: ArrayLike, joint: MeanFieldJoint, method: str = "auto"
) -> FloatArray:
    """Survival exponent I(rho~) = int_0^rho~ d rho' / (V tau(rho')) (001/Eq. 27).

    Parameters
    ----------
    rho : array_like
        Reduced block coordinate rho~ >= 0 [m]; I = inf above rho~_max (certain firing).
    velocity : array_like
        Slider velocity V > 0 [m/s], broadcast against ``rho``.
    joint : MeanFieldJoint
        Joint parameters.
    method : {"auto", "closed_form", "quadrature"}
        "closed_form" is the Dawson-function result for Persson's law, "quadrature" the
        tabulated Gauss-Legendre integral valid for every law; "auto" picks the former
        when it applies.

    Returns
    -------
    ndarray
        I (dimensionless), shape of the broadcast inputs; exp(-I) is the probability that
        a block reset at rho~ = 0 reaches rho~ without firing.
    """
    rho_arr, v_arr = _broadcast_rho_velocity(rho, velocity)
    if np.any(rho_arr < 0) or np.any(np.isnan(rho_arr)):
        raise ValueError("rho must be >= 0 [m]")
    x = rho_arr / joint.rho_max
    log_i = _log_lambda(v_arr, joint) + _log_j(np.minimum(x, 1.0), joint, method)
    return np.where(x > 1.0, np.inf, np.exp(log_i))


def mean_firing_reduced_stress(velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Mean firing stress E[x_f] = int_0^1 exp(-I) dx in units of sigma_a (dimensionless).

    A block's reduced stress at firing, x_f, has survival function exp(-I(x)); the
    deterministic release at x = 1 is included. Also Z / rho~_max for Q_st (001/Eq. 27).

    Parameters
    ----------
    velocity : array_like
        Slider velocity V > 0 [m/s].
    joint : MeanFieldJoint
        Joint parameters.

    Returns
    -------
    ndarray
        E[x_f] (dimensionless), shaped like ``velocity``.
    """
    return _moments(velocity, joint).n0


def q_stationary(rho: ArrayLike, velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Normalised stationary density Q_st(rho~, V) = exp(-I(rho~)) / Z [1/m] (001/Eq. 27).

    Z = int_0^rho~_max exp(-I) d rho~ (by quadrature); the density vanishes outside
    [0, rho~_max]. Blocks that survive to rho~_max fire there at once, so Q_st has no atom.

    Parameters
    ----------
    rho : array_like
        Reduced coordinate rho~ [m].
    velocity : array_like
        Slider velocity V > 0 [m/s], broadcast against ``rho``.
    joint : MeanFieldJoint
        Joint parameters.

    Returns
    -------
    ndarray
        Q_st [1/m], shape of the broadcast inputs.

    With strength classes the density is the equal-weight mixture over the classes; with
    back jumps it is the two-branch density of :func:`_lattice_solution` on
    [-rho~_max, rho~_max].
    """
    if not joint.is_base:
        members = joint.classes()
        if len(members) > 1:
            return sum(q_stationary(rho, velocity, member) for member in members) / len(members)
        return _lattice_density(rho, velocity, joint)
    rho_arr, v_arr = _broadcast_rho_velocity(rho, velocity)
    inside = (rho_arr >= 0.0) & (rho_arr <= joint.rho_max)
    exponent = survival_exponent(np.where(inside, rho_arr, 0.0), v_arr, joint)
    speeds, inverse = _unique_velocities(v_arr)
    z = joint.rho_max * _moments(speeds, joint).n0[inverse].reshape(v_arr.shape)
    return np.where(inside, np.exp(-exponent) / z, 0.0)


def q_stationary_cdf(rho: ArrayLike, velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Cumulative distribution int_0^rho~ Q_st d rho' of 001/Eq. 27 (dimensionless).

    Cumulative sums over the adaptive Gauss-Legendre cells of the normalisation, plus one
    Gauss-Legendre rule on the partial cell, so it is accurate to ~1e-12. 0 below
    rho~ = 0, 1 from rho~_max on. Vectorised and broadcast over rho~ [m] and V [m/s].
    """
    rho_arr, v_arr = _broadcast_rho_velocity(rho, velocity)
    speeds, inverse = _unique_velocities(v_arr)
    log_lam = _log_lambda(speeds, joint)
    edges = _level_edges(log_lam, joint)
    cells = np.sum(_survival_nodes(edges, log_lam, joint)[1], axis=-1)
    cumulative = np.concatenate([np.zeros((speeds.size, 1)), np.cumsum(cells, axis=-1)], axis=-1)
    t_end = _x_to_t(np.clip(rho_arr.ravel() / joint.rho_max, 0.0, 1.0))
    row_edges = edges[inverse]
    cell = np.clip(np.sum(row_edges <= t_end[:, None], axis=-1) - 1, 0, cells.shape[-1] - 1)
    start = np.take_along_axis(row_edges, cell[:, None], axis=-1)
    partial_edges = np.concatenate([start, t_end[:, None]], axis=-1)
    partial = np.sum(_survival_nodes(partial_edges, log_lam[inverse], joint)[1], axis=(-2, -1))
    below = cumulative[inverse, cell]
    return ((below + partial) / cumulative[inverse, -1]).reshape(rho_arr.shape)


def _cdf_table(velocity: float, joint: MeanFieldJoint) -> tuple[FloatArray, FloatArray]:
    """Reduced coordinates x and exact CDF values on a grid refined around the cutoff."""
    edges = _level_edges(_log_lambda(velocity, joint), joint)
    fractions = np.linspace(0.0, 1.0, _SAMPLE_SUBCELLS + 1)[:-1]
    fine = np.append((edges[:-1, None] + np.diff(edges)[:, None] * fractions).ravel(), 1.0)
    x = _t_to_x(fine)
    return x, q_stationary_cdf(x * joint.rho_max, velocity, joint)


def sample_q_stationary(
    n: int,
    velocity: float,
    joint: MeanFieldJoint,
    rng: np.random.Generator | int | None = None,
) -> FloatArray:
    """Draw n block coordinates rho~ [m] from Q_st (001/Eq. 27), e.g. a steady initial state.

    Inverse-CDF sampling: the exact CDF is tabulated on ~1000 points concentrated around
    the cutoff and inverted by monotone (PCHIP) interpolation.

    Parameters
    ----------
    n : int
        Number of samples (>= 0).
    velocity : float
        Slider velocity V > 0 [m/s] (scalar).
    joint : MeanFieldJoint
        Joint parameters.
    rng : numpy.random.Generator, int or None
        Random generator or seed.

    Returns
    -------
    ndarray
        Samples rho~ [m], shape (n,), in [0, rho~_max] (in [-rho~_max, rho~_max] with
        back jumps). With strength classes, each draw comes from a uniformly chosen class.
    """
    if np.ndim(velocity) != 0:
        raise ValueError("velocity must be a scalar [m/s]")
    rng = np.random.default_rng(rng)
    members = joint.classes()
    if len(members) > 1:
        chosen = rng.integers(len(members), size=int(n))
        out = np.empty(int(n))
        for k, member in enumerate(members):
            out[chosen == k] = sample_q_stationary(int(np.sum(chosen == k)), velocity, member, rng)
        return out
    if joint.back_jumps:
        phase = rng.random(int(n))
        upper = rng.random(int(n)) < _upper_occupancy(phase, float(velocity), joint)
        return np.where(upper, phase, phase - 1.0) * joint.rho_max
    x_grid, cdf = _cdf_table(float(velocity), joint)
    keep = np.concatenate([[True], np.diff(cdf) > 0.0])
    inverse = PchipInterpolator(cdf[keep], x_grid[keep])
    draws = rng.random(int(n))
    return np.clip(inverse(draws), 0.0, 1.0) * joint.rho_max


def steady_stress(velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Steady friction stress sigma_s(V) = E[sigma] under Q_st [Pa] (001/Eq. 28).

    sigma_s = sigma_a N_1 / N_0 with N_k = int_0^1 x^k exp(-I(x)) dx, i.e.
    sigma_a E[x_f^2] / (2 E[x_f]) over the firing stress x_f. Adaptive Gauss-Legendre
    quadrature, relative accuracy ~1e-12. With back jumps, sigma_a (int_0^1 p ds - 1/2)
    from the branch occupancy p of :func:`_lattice_solution` (relative accuracy ~1e-9);
    with strength classes, the
    mean over the classes (the simulation's force is their equal-area sum).

    Parameters
    ----------
    velocity : array_like
        Slider velocity V > 0 [m/s].
    joint : MeanFieldJoint
        Joint parameters.

    Returns
    -------
    ndarray
        sigma_s [Pa], shaped like ``velocity``.
    """
    members = joint.classes()
    if len(members) > 1:
        return sum(steady_stress(velocity, member) for member in members) / len(members)
    if joint.back_jumps:
        v = _velocity(velocity)
        return joint.threshold_stress * _lattice_excess(v, joint).reshape(v.shape)
    moments = _moments(velocity, joint)
    return joint.threshold_stress * moments.n1 / moments.n0


def log_slope(velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Local slope d ln sigma_s / d ln V (dimensionless), exact derivative of 001/Eq. 28.

    Since I is proportional to 1/V, d exp(-I) / d ln V = I exp(-I), hence
    d ln sigma_s / d ln V = M_1 / N_1 - M_0 / N_0 with M_k = int x^k I exp(-I) dx.

    Parameters
    ----------
    velocity : array_like
        Slider velocity V > 0 [m/s].
    joint : MeanFieldJoint
        Joint parameters.

    Returns
    -------
    ndarray
        d ln sigma_s / d ln V (dimensionless), shaped like ``velocity``.
    """
    moments = _moments(velocity, joint)
    return moments.m1 / moments.n1 - moments.m0 / moments.n0


# ------------------------------------ extensions: strength classes and back jumps


def strength_factors(spread: float, n_classes: int) -> FloatArray:
    """sigma_a of each strength class over the mean sigma_a (dimensionless, mean 1).

    sigma_a / E[sigma_a] is lognormal with log-standard deviation ``spread`` (physics.md
    section 5, strength_heterogeneity); class k is its k-th of ``n_classes``
    equal-probability bins, represented by the bin's conditional mean
    n [Phi(z_{k+1} - s) - Phi(z_k - s)], z_k = Phi^-1(k / n), so the mean is exact.
    """
    if spread == 0.0:
        return np.ones(n_classes)
    edges = ndtri(np.linspace(0.0, 1.0, n_classes + 1))
    return n_classes * np.diff(ndtr(edges - spread))


def _lattice_solution(
    velocity: ArrayLike, joint: MeanFieldJoint, cells: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Departure q = p - p_eq of the upper-branch occupancy from Boltzmann's with back jumps:
    phases s_k, q(s_k) (one row per velocity) and int_0^1 q ds per velocity
    (dimensionless; ``velocity`` flattened).

    On the periodic characteristic (:func:`nanoblock.barriers.lattice_reverse_barrier`) a
    block at drive phase s in [0, 1] sits on the upper branch (stress s) or the lower one
    (s - 1); the phase advances at V / rho~_max and hops never change it. Forward hops
    leave the upper branch at r_+(s) = omega_a exp(-u f(s)), reverse hops the lower one at
    r_+(s) exp(-u_el (s - 1/2)) (detailed balance), so the occupancy p of the upper branch
    obeys

        dp/ds = -a(s) (p - p_eq(s)),  a = Lambda e^(-u f(s)) [1 + e^(-u_el (s - 1/2))],

    with Lambda = omega_a rho~_max / V, p_eq = 1 / (1 + e^(u_el (s - 1/2))) (Boltzmann),
    and p(0) = 1: every block starts a period on the branch at zero stress (the upper one
    at s = 1 is at its spinodal). The mean stress is sigma_a (int_0^1 p ds - 1/2) =
    sigma_a int_0^1 q ds (p_eq - 1/2 is odd about s = 1/2), and q' = -a q - p_eq' is
    integrated exactly for a constant a (its exact cell mean, 4-point Gauss-Legendre) and
    a linear source on each of ``cells`` uniform cells: second order in the cell size
    however stiff the cell (a ranges over 1e-20 ... 1e40). a / Lambda, p_eq and the source
    do not depend on V, so they are computed once for every velocity
    (:func:`nanoblock.theory.lattice_kernel.occupancy_departure` does the sweep).
    """
    u, u_el = joint.u, joint.u_elastic
    lam = joint.attempt_frequency * joint.rho_max / _velocity(velocity).ravel()
    edges = np.linspace(0.0, 1.0, cells + 1)
    h = 1.0 / cells
    points = 0.5 * (edges[:-1, None] + edges[1:, None]) + 0.5 * h * _LATTICE_GL_X
    log_rate = np.logaddexp(0.0, -u_el * (points - 0.5)) - u * barrier_law(joint.barrier)(points)
    rate_h = (0.5 * h * np.exp(log_rate)) @ _LATTICE_GL_W  # cell mean of a / Lambda, times h
    p_eq = expit(-u_el * (edges - 0.5))
    source = u_el * p_eq * (1.0 - p_eq)  # -dp_eq/ds
    q = np.empty((lam.size, cells + 1))
    integral = np.empty(lam.size)
    occupancy_departure(rate_h, source, lam, 1.0 - p_eq[0], q, integral)
    return edges, q, integral


def _lattice_excess(velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """int_0^1 q ds = sigma_s / sigma_a with back jumps per velocity (flattened),
    Richardson-extrapolated from 2^12 and 2^13 cells (relative accuracy ~1e-9; absolute
    ~1e-10 where friction nearly vanishes)."""
    coarse = _lattice_solution(velocity, joint, _LATTICE_STRESS_CELLS // 2)[2]
    fine = _lattice_solution(velocity, joint, _LATTICE_STRESS_CELLS)[2]
    return (4.0 * fine - coarse) / 3.0


def _upper_occupancy(phase: FloatArray, velocity: float, joint: MeanFieldJoint) -> FloatArray:
    """p(s) = p_eq(s) + q(s) of :func:`_lattice_solution` at drive phases s in [0, 1]."""
    edges, q, _ = _lattice_solution(velocity, joint, _LATTICE_CELLS)
    phase = np.asarray(phase, dtype=float)
    return expit(-joint.u_elastic * (phase - 0.5)) + np.interp(phase, edges, q[0])


def _lattice_density(rho: ArrayLike, velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Stationary density [1/m] of rho~ = b^2 sigma / k1 on [-rho~_max, rho~_max] with back
    jumps: p(x) / rho~_max on the upper branch (x >= 0), (1 - p(x + 1)) / rho~_max below."""
    rho_arr, v_arr = _broadcast_rho_velocity(rho, velocity)
    x = rho_arr / joint.rho_max
    out = np.zeros(x.shape)
    for speed in np.unique(v_arr):
        here = (v_arr == speed) & (np.abs(x) <= 1.0)
        phase = np.where(x[here] >= 0.0, x[here], x[here] + 1.0)
        p = _upper_occupancy(phase, float(speed), joint)
        out[here] = np.where(x[here] >= 0.0, p, 1.0 - p) / joint.rho_max
    return out


# --------------------------------------------- large-u asymptotics and the cutoff


def _barrier_slope(x: FloatArray, joint: MeanFieldJoint) -> FloatArray:
    """df/dx of the reduced barrier by complex-step differentiation (exact to rounding).

    Needs the law's ``reduced`` function to be a complex-analytic numpy expression, as the
    registered laws are (polynomials and powers of 1 - x).
    """
    step = 1e-30
    return np.imag(BARRIERS[joint.barrier].reduced(x + 1j * step)) / step


def _balance(x: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """g(x) = u f(x) + ln(u |f'(x)|): activation beats advection where ln Lambda > g(x)."""
    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore"):
        return joint.u * barrier_law(joint.barrier)(x) + np.log(
            joint.u * np.abs(_barrier_slope(x, joint))
        )


@lru_cache(maxsize=64)
def _balance_peak(joint: MeanFieldJoint) -> float:
    """x of the maximum of g on (0, 1); g decreases from there to x = 1."""
    x = _t_to_x(np.linspace(0.0, 1.0, _PEAK_GRID)[1:-1])
    return float(x[np.argmax(_balance(x, joint))])


def _balance_root(log_rhs: FloatArray, joint: MeanFieldJoint) -> FloatArray:
    """Root x of g(x) = log_rhs on the decreasing branch of g (dimensionless).

    1 where log_rhs <= g(1) (advection wins up to the threshold), NaN where
    log_rhs > max g (activation wins everywhere: blocks creep off near zero stress).
    """
    log_rhs = np.asarray(log_rhs, dtype=float)
    peak = _balance_peak(joint)
    root = _bisect(lambda x: log_rhs - _balance(x, joint), np.full_like(log_rhs, peak), 1.0)
    root = np.where(log_rhs <= _balance(1.0, joint), 1.0, root)
    return np.where(log_rhs > _balance(peak, joint), np.nan, root)


def cutoff_rho(velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Cutoff rho~_c(V) of Q_st [m] (001/Eq. 29): tau(rho~_c) = k_B T / (V |dU/d rho~|).

    In reduced form Lambda exp(-u f(x_c)) = u |f'(x_c)|, solved on the branch where the
    escape rate grows faster than advection. At large u, I(rho~_c) = 1 + O(1/(u x_c^2)),
    so Q_st(rho~_c) ~ Q_st(0) / e. Returns rho~_max if the condition is never met
    (V > V* e^-gamma for Persson's law) and NaN where no cutoff exists (activation
    dominates everywhere: small u and tiny V).

    Parameters
    ----------
    velocity : array_like
        Slider velocity V > 0 [m/s].
    joint : MeanFieldJoint
        Joint parameters.

    Returns
    -------
    ndarray
        rho~_c [m], shaped like ``velocity``.
    """
    return joint.rho_max * _balance_root(_log_lambda(velocity, joint), joint)


def firing_stress_asymptotic(velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Mean reduced firing stress x_f at large u (physics.md section 1), dimensionless.

    Near the cutoff I(x) ~ Lambda exp(-u f) / (u |f'|) and ln I at firing is Gumbel
    distributed with mean -gamma_E, so x_f solves u f(x_f) + ln(u |f'(x_f)|) =
    ln(e^gamma_E Lambda); for Persson's law u (1 - x_f^2) = ln(e^gamma_E omega_a rho~_max /
    (2 u V x_f)). Returns 1 for V >= V* (no root below the threshold: saturation) and NaN
    where the activated regime has no root (small u, tiny V).

    Parameters
    ----------
    velocity : array_like
        Slider velocity V > 0 [m/s].
    joint : MeanFieldJoint
        Joint parameters.

    Returns
    -------
    ndarray
        x_f = sigma_f / sigma_a (dimensionless), shaped like ``velocity``.
    """
    return _balance_root(EULER_GAMMA + _log_lambda(velocity, joint), joint)


def steady_stress_asymptotic(velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Large-u steady stress sigma_s ~ sigma_a x_f / 2 [Pa] (physics.md section 1).

    Relative error O(1/(u x_f^2)^2) against 001/Eq. 28.

    Parameters
    ----------
    velocity : array_like
        Slider velocity V > 0 [m/s].
    joint : MeanFieldJoint
        Joint parameters.

    Returns
    -------
    ndarray
        sigma_a x_f / 2 [Pa], shaped like ``velocity``.
    """
    return 0.5 * joint.threshold_stress * firing_stress_asymptotic(velocity, joint)


def log_slope_asymptotic(velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Large-u slope d ln x_f / d ln V (dimensionless) of :func:`firing_stress_asymptotic`.

    For Persson's law it equals 1 / (2 u x_f^2 - 1), which tends to alpha = 1 / (2u) as
    V -> V*; for any law -1 / (x_f g'(x_f)), g(x) = u f(x) + ln(u |f'(x)|). Computed by a
    fourth-order backward difference in ln V (step 1e-3), which stays below the saturation
    kink at V*; 0 at saturation (V >= V*).

    Parameters
    ----------
    velocity : array_like
        Slider velocity V > 0 [m/s].
    joint : MeanFieldJoint
        Joint parameters.

    Returns
    -------
    ndarray
        d ln x_f / d ln V (dimensionless), shaped like ``velocity``.
    """
    log_v = np.log(_velocity(velocity))
    step = 1e-3
    coefficients = (25.0, -48.0, 36.0, -16.0, 3.0)
    log_x = [np.log(firing_stress_asymptotic(np.exp(log_v - k * step), joint)) for k in range(5)]
    slope = sum(c * lx for c, lx in zip(coefficients, log_x, strict=True)) / (12.0 * step)
    return np.where(log_x[0] < 0.0, slope, np.where(np.isnan(log_x[0]), np.nan, 0.0))


def steady_stress_loglaw(velocity: ArrayLike, joint: MeanFieldJoint) -> FloatArray:
    """Linear log law sigma_bar (1 + alpha ln(V / V*)) [Pa] (001/Eq. 30).

    The linearisation of the exact result near V*; off by 1-7 % at lab velocities for
    u ~ 25-50 (physics.md section 1).

    Parameters
    ----------
    velocity : array_like
        Slider velocity V > 0 [m/s].
    joint : MeanFieldJoint
        Joint parameters.

    Returns
    -------
    ndarray
        sigma_bar (1 + alpha ln(V / V*)) [Pa], shaped like ``velocity``.
    """
    return joint.sigma_bar * (1.0 + joint.alpha * np.log(_velocity(velocity) / joint.v_star))
