"""Coarse-grained surrogate of the nanoblock interface for steady-state tables.

The base model's steady friction is the mean-field joint stress (001/Eq. 28, exact
quadrature in :mod:`nanoblock.theory.meanfield`) times the aged contact area
(001/Eq. 5 with the steady age D0 / V, 001/Eq. 3):

    mu_ss(V, T) = mu_r [S(V, T) / S(V_r, T_r)] [1 + m ln(V_r / V)],

with S = sigma_s / sigma_a a function of the reduced barrier u(T) = u_r T_r / T and of
the attempt velocity v_a = omega_a rho~_max (physics.md sections 1-2). Catalogue
extensions (physics.md section 5) change one factor each: the barrier law, reverse hops
(the two-branch theory of ``MeanFieldJoint(back_jumps=True)``), the creep onset time or
state cutoff in the area factor, a distribution of sigma_a, or a joint that softens with
temperature.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from scipy.special import hyperu
from scipy.stats import norm

from nanoblock.barriers import BOLTZMANN
from nanoblock.rsf.fit import parameter_covariance
from nanoblock.theory.meanfield import MeanFieldJoint, steady_stress

FloatArray = NDArray[np.float64]

_SIGMA_A, _E_J, _T = 1.0e8, 1.0e9, 300.0
"""Canonical joint used to evaluate S(V; u, v_a): only u and v_a matter."""
STRENGTH_CLASSES = 16
_CLASSES = (
    norm.ppf((np.arange(STRENGTH_CLASSES) + 0.5) / STRENGTH_CLASSES),
    np.ones(STRENGTH_CLASSES),
)
"""Equal-probability strength classes of a standard normal (as the simulator's
``joint.strength_classes``): nodes at the class medians, equal weights. Each class
saturates at its own V*, so the class mixture has kinks in z and Gauss-Hermite rules
converge badly (5 nodes: 7 % shape error at a log-spread of 0.4); the midpoint rule
converges as 1/n (16 classes: 0.4 %, against 256)."""


@dataclass(frozen=True)
class SteadyTable:
    """A steady-state table: mu at (V, T), with the reference point of the fit."""

    velocity: FloatArray
    temperature: FloatArray
    mu: FloatArray
    v_ref: float
    t_ref: float

    @property
    def temperatures(self) -> int:
        """Number of distinct temperatures."""
        return int(np.unique(self.temperature).size)


@dataclass(frozen=True)
class SteadyVariant:
    """Which factors of mu_ss differ from the base model, and their extra parameters."""

    barrier: str = "persson"
    back_jumps: bool = False
    area: str = "log"
    """``log`` (base), ``saturation`` (finite tau_m) or ``cutoff`` (state cutoff v_theta)."""
    spread: bool = False
    softening: bool = False

    @property
    def extra(self) -> tuple[str, ...]:
        """Names of the parameters this variant adds to (mu_r, u, v_attempt, m)."""
        names = []
        if self.back_jumps:
            names.append("elastic_ratio")
        if self.area == "saturation":
            names.append("v_saturation")
        if self.area == "cutoff":
            names.append("v_theta")
        if self.spread:
            names.append("strength_spread")
        if self.softening:
            names.append("softening")
        return tuple(names)

    @property
    def names(self) -> tuple[str, ...]:
        return ("mu_r", "u", "v_attempt", "m", *self.extra)


UNITS = {
    "mu_r": "1",
    "u": "1",
    "v_attempt": "m/s",
    "m": "1",
    "elastic_ratio": "1",
    "v_saturation": "m/s",
    "v_theta": "m/s",
    "strength_spread": "1",
    "softening": "1",
}
"""Units of the surrogate's parameters (u at T_r; elastic_ratio = u_el / u = E_J b / k1,
the elastic energy of a hop over the barrier scale; softening: -d ln sigma_a / d ln T
at T_r)."""
_LINEAR = {"mu_r", "m", "softening"}
_STRENGTH = ("u", "v_attempt", "elastic_ratio", "strength_spread", "softening")
"""Parameters of the sigma_s factor (the others only scale or multiply it)."""
_MAX_ELASTIC_RATIO = 2.0
"""u_el <= 2u keeps the reverse-hop barrier of Persson's law >= 0 (k1 >= E_J b / 2)."""


def reduced_stress(
    velocity: FloatArray,
    u: float,
    v_attempt: float,
    barrier: str = "persson",
    elastic_ratio: float | None = None,
) -> FloatArray:
    """S = sigma_s / sigma_a of the mean-field joint with reduced barrier u and attempt
    velocity v_a = omega_a rho~_max [m/s] (001/Eq. 28); with ``elastic_ratio`` r, reverse
    hops in detailed balance on the periodic characteristic with u_el = r u, i.e.
    k1 = E_J b / r (physics.md section 5; scenarios/README.md, Catalogue extensions)."""
    block = (u * _E_J * BOLTZMANN * _T / _SIGMA_A**2) ** (1.0 / 3.0)
    k1 = _E_J * block / (1.0 if elastic_ratio is None else elastic_ratio)
    rho_max = block**2 * _SIGMA_A / k1
    joint = MeanFieldJoint(
        block, _E_J, _SIGMA_A, k1, v_attempt / rho_max, _T, barrier,
        back_jumps=elastic_ratio is not None,
    )  # fmt: skip
    return steady_stress(velocity, joint) / _SIGMA_A


def _strength(
    variant: SteadyVariant,
    velocity: FloatArray,
    temperature: FloatArray,
    p: Mapping[str, float],
    t_ref: float,
) -> FloatArray:
    """sigma_a-weighted S at each (V, T), averaged over strength classes when spread: one
    quadrature per temperature and class, over all its velocities."""
    out = np.empty(velocity.size)
    nodes, weights = _CLASSES if variant.spread else (np.zeros(1), np.ones(1))
    spread = p.get("strength_spread", 0.0)
    ratio = p["elastic_ratio"] if variant.back_jumps else None
    for t in np.unique(temperature):
        here = temperature == t
        softened = (t / t_ref) ** (-p.get("softening", 0.0))  # sigma_a(T) / sigma_a(T_r)
        total = np.zeros(int(here.sum()))
        for z, w in zip(nodes, weights / weights.sum(), strict=True):
            g = softened * math.exp(spread * z - 0.5 * spread**2)  # sigma_a class / sigma_a
            u = p["u"] * (t_ref / t) * g**2  # U_a ~ sigma_a^2 (001/Eq. 37)
            s = reduced_stress(velocity[here], u, p["v_attempt"] * g, variant.barrier, ratio)
            total += w * g * s
        out[here] = total
    return out


def normalised_strength(
    variant: SteadyVariant, table: SteadyTable, p: Mapping[str, float]
) -> FloatArray:
    """S(V, T) / S(V_r, T_r) at every row of ``table`` (the reference point rides along in
    the quadrature at T_r)."""
    velocity = np.append(table.velocity, table.v_ref)
    temperature = np.append(table.temperature, table.t_ref)
    strength = _strength(variant, velocity, temperature, p, table.t_ref)
    return strength[:-1] / strength[-1]


def _ageing(
    variant: SteadyVariant, velocity: FloatArray, p: Mapping[str, float], v_ref: float
) -> FloatArray:
    """<ln(1 + phi / tau_m)>(V) - <ln(1 + phi / tau_m)>(V_r) over the steady renewal ages,
    Exp with mean D0 / V (001/Eqs. 3, 5); the contact area is 1 + m times this.

    Base (tau_m far below every age) and cutoff (mean age D0 / (V + v_theta), 000/Eq. 7):
    <ln phi> = ln <phi> - gamma, so the log of the ratio of mean ages. Saturation:
    <ln(1 + phi / tau_m)> = e^x E_1(x) = U(1, 1, x), x = tau_m V / D0 = V / V_sat (the log
    of the mean age, ln(1 + V_sat / V), differs by up to gamma across the crossover)."""
    if variant.area == "saturation":
        v_sat = p["v_saturation"]
        return hyperu(1.0, 1.0, velocity / v_sat) - hyperu(1.0, 1.0, v_ref / v_sat)
    if variant.area == "cutoff":
        return np.log((v_ref + p["v_theta"]) / (velocity + p["v_theta"]))
    return np.log(v_ref / velocity)


def steady_model(
    variant: SteadyVariant,
    table: SteadyTable,
    p: Mapping[str, float],
    strength: FloatArray | None = None,
) -> FloatArray:
    """mu_ss of the surrogate at every row of ``table`` (``strength``: the
    :func:`normalised_strength` at ``p`` when already known)."""
    if strength is None:
        strength = normalised_strength(variant, table, p)
    return p["mu_r"] * strength * (1.0 + p["m"] * _ageing(variant, table.velocity, p, table.v_ref))


@dataclass(frozen=True)
class SteadyFit:
    """Fitted surrogate: parameters, standard errors and the model at every row."""

    params: dict[str, float]
    stderr: dict[str, float]
    model: FloatArray


_STARTS = {"u": (15.0, 35.0, 70.0), "v_attempt": (1e-1, 1e2, 1e5)}
_REFINED_STARTS = 2
"""Best grid starts refined by least squares."""
_MAX_NFEV = 60
"""Model evaluations per refinement (each costs one quadrature per strength class)."""
_PROFILE_NFEV = 10
"""Evaluations of a profile start (the extension's new parameters held fixed)."""
_EXTRA_GRID = {
    "elastic_ratio": (0.5, 0.05, 1.5),
    "strength_spread": (1e-3, 0.2, 0.5),
    "softening": (0.2, 0.5, 1.0),
}
"""Warm-start grids of the dimensionless extras over their physical ranges (u_el / u in
(0, 2]: k1 >= E_J b / 2; log-spreads of sigma_a from the nested base to 50 %;
softening exponents)."""
_AREA_LEVELS = 6
"""Saturation or cutoff velocities tried, log-spaced over the data, each with the warm and
every grid (u, v_a) and with mu_r and m re-solved: without the effect in its model, the
base mimics part of the flattening ageing term with a V* = e^gamma v_a / (2u) inside the
data and a wrong m (velocity_saturation seeds 1, 6, 7: base u = 25-61, v_a = 1e-7-6e3
against 38-41, 146-2390), where a warm start at any area velocity stays. A level costs no
quadrature (S does not depend on it)."""
_EXTRA_START = {
    "elastic_ratio": 0.5,
    "strength_spread": 0.2,
    "softening": 0.5,
}


def _starts(
    variant: SteadyVariant, table: SteadyTable, warm: Mapping[str, float] | None
) -> list[dict[str, float]]:
    """Starting points: a grid in (u, v_a) with mu_r, m and the extras at neutral values
    (saturation and cutoff velocities at the ends of the measured range); from a warm
    start, the extras alone are set on a grid (low, middle and high of their range), plus
    the (u, v_a) grid when the variant changes the shape of S (barrier law, back jumps),
    where the base's u and v_a can be far from the extension's; a missing area velocity
    takes each of :data:`_AREA_LEVELS` from the warm start and from every grid point."""
    v = table.velocity
    extra = dict(_EXTRA_START)
    extra["v_saturation"] = float(v.max())
    extra["v_theta"] = float(v.min())
    mu_r = float(np.interp(math.log(table.v_ref), np.log(np.sort(v)), table.mu[np.argsort(v)]))
    base = {"mu_r": mu_r, "m": 0.01}
    grid = [
        {**base, "u": u, "v_attempt": va, **{k: extra[k] for k in variant.extra}}
        for u in _STARTS["u"]
        for va in _STARTS["v_attempt"]
    ]
    if warm is None:
        return grid
    missing = [name for name in variant.names if name not in warm]
    if variant.area != SteadyVariant.area and missing:  # the area velocity on a log grid
        levels = [{name: float(level)} for name in missing for level in _area_levels(v)]
        return [{**start, **level} for start in (warm, *grid) for level in levels]
    levels = [
        dict(zip(missing, values, strict=True))
        for values in zip(*map(_EXTRA_GRID.get, missing), strict=True)
    ]
    warm_starts = [{**warm, **level} for level in levels or [{}]]
    reshaped = variant.barrier != SteadyVariant.barrier or variant.back_jumps or variant.spread
    return warm_starts + grid if reshaped else warm_starts


def _area_levels(velocity: FloatArray) -> FloatArray:
    """Starting saturation or cutoff velocities: :data:`_AREA_LEVELS` log-spaced over the
    measured velocities."""
    return np.geomspace(velocity.min(), velocity.max(), _AREA_LEVELS)


def fit_steady(
    variant: SteadyVariant,
    table: SteadyTable,
    holdout: NDArray[np.bool_] | None = None,
    start: Mapping[str, float] | None = None,
) -> SteadyFit:
    """Least-squares fit of the surrogate (log scale for u, velocities and spreads),
    multi-start, or warm-started from ``start`` (parameters it lacks are gridded);
    ``holdout`` rows are not fitted."""
    names = variant.names
    log = np.array([name not in _LINEAR for name in names])
    fitted = np.ones(table.mu.size, dtype=bool) if holdout is None else ~holdout

    def unpack(x: Sequence[float]) -> dict[str, float]:
        return {n: float(math.exp(v) if lg else v) for n, v, lg in zip(names, x, log, strict=True)}

    def pack(p: Mapping[str, float]) -> FloatArray:
        return np.array([math.log(p[n]) if lg else p[n] for n, lg in zip(names, log, strict=True)])

    strengths: dict[tuple[float, ...], FloatArray] = {}
    """The sigma_s factor by its parameters: Jacobian columns of mu_r, m and the area
    velocities reuse it."""

    def strength(p: Mapping[str, float]) -> FloatArray:
        key = tuple(p[name] for name in _STRENGTH if name in p)
        if key not in strengths:
            strengths[key] = normalised_strength(variant, table, p)
        return strengths[key]

    def residuals(x: FloatArray) -> FloatArray:
        with np.errstate(all="ignore"):
            try:
                p = unpack(x)
                r = steady_model(variant, table, p, strength(p))[fitted] - table.mu[fitted]
            except (ValueError, FloatingPointError, ZeroDivisionError, OverflowError):
                return np.full(int(fitted.sum()), 1e3)
        return np.where(np.isfinite(r), r, 1e3)

    def solved(x: FloatArray) -> FloatArray:
        """``x`` with the (mu_r, m) that fit best at its other parameters (mu_ss is linear
        in mu_r and mu_r m): an area velocity level changes the ageing term m multiplies."""
        with np.errstate(all="ignore"):
            p = unpack(x)
            s = strength(p)
            design = np.column_stack([s, s * _ageing(variant, table.velocity, p, table.v_ref)])
        if not np.all(np.isfinite(design[fitted])):
            return x
        (level, slope), *_ = np.linalg.lstsq(design[fitted], table.mu[fitted], rcond=None)
        out = x.copy()
        out[[names.index("mu_r"), names.index("m")]] = level, max(slope / level, 0.0)
        return out if level > 0.0 else x

    lower = np.full(len(names), -np.inf)
    upper = np.full(len(names), np.inf)
    for i, name in enumerate(names):
        if name == "u":
            lower[i], upper[i] = math.log(2.0), math.log(500.0)
        elif name == "v_attempt":  # omega_a rho~_max: 1e12 1/s x 0.3 nm ~ 300 m/s
            lower[i], upper[i] = math.log(1e-8), math.log(1e10)
        elif name == "elastic_ratio":
            lower[i], upper[i] = math.log(1e-4), math.log(_MAX_ELASTIC_RATIO)
        elif name == "strength_spread":
            lower[i], upper[i] = math.log(1e-4), math.log(3.0)
        elif name == "m":  # contact area grows with age (001/Eq. 5): m >= 0
            lower[i] = 0.0
    starts = [pack({n: s[n] for n in names}) for s in _starts(variant, table, start)]
    starts = [np.clip(x0, lower + 1e-9, upper - 1e-9) for x0 in starts]
    refit = holdout is not None  # a warm refit for held-out rows: fewer evaluations
    new = np.array([start is not None and name not in start for name in names])
    profile = variant.spread or variant.area != SteadyVariant.area
    if profile and new.any() and not refit:  # profile the warm starts at their new levels
        warm = starts[0][~new]
        starts = [
            _profiled(residuals, x0, ~new, lower, upper) if np.array_equal(x0[~new], warm) else x0
            for x0 in starts
        ]
    if variant.area != SteadyVariant.area and new.any():
        starts = [solved(x0) for x0 in starts]
    costs = [float(np.sum(residuals(x0) ** 2)) for x0 in starts]
    best = None
    for index in np.argsort(costs)[: 1 if refit else _REFINED_STARTS]:
        trial = least_squares(
            residuals, starts[index], bounds=(lower, upper), x_scale="jac",
            max_nfev=_MAX_NFEV // 3 if refit else _MAX_NFEV,
        )  # fmt: skip
        if best is None or trial.cost < best.cost:
            best = trial
    params = unpack(best.x)
    dof = max(best.fun.size - best.x.size, 1)
    variance = float(best.fun @ best.fun) / dof
    errors = _errors(best.jac, variance, params, names, log)
    return SteadyFit(params, errors, steady_model(variant, table, params))


def _profiled(
    residuals: Callable[[FloatArray], FloatArray],
    x0: FloatArray,
    free: NDArray[np.bool_],
    lower: FloatArray,
    upper: FloatArray,
) -> FloatArray:
    """``x0`` with the ``free`` coordinates refitted while the others (an extension's new
    parameters at a grid value) stay fixed. From the base optimum, a strength spread or an
    area velocity inside the data first raises the cost until (u, v_a, m) adapt, so a joint
    fit started there slides back to the nested base model (velocity_saturation seeds 4
    and 5: v_saturation -> 1e8-1e17 m/s unprofiled, 3.5e-4 and 1.3e-3 profiled, against
    3.4e-4 and 1.4e-3 true)."""

    def partial(y: FloatArray) -> FloatArray:
        x = x0.copy()
        x[free] = y
        return residuals(x)

    result = least_squares(
        partial, x0[free], bounds=(lower[free], upper[free]), x_scale="jac",
        max_nfev=_PROFILE_NFEV,
    )  # fmt: skip
    x = x0.copy()
    x[free] = result.x
    return x


def _errors(jac, variance, params, names, log) -> dict[str, float]:
    """Natural-unit standard errors (infinite along unidentified directions)."""
    covariance = parameter_covariance(jac, variance)
    out = {}
    for i, name in enumerate(names):
        sigma = math.sqrt(covariance[i, i]) if math.isfinite(covariance[i, i]) else math.inf
        out[name] = params[name] * sigma if log[i] else sigma
    return out
