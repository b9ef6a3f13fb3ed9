"""Rate-and-state friction laws as a registry (physics.md section 3).

Every law writes the friction coefficient as a function of a *velocity coordinate* w and
a state vector s, chosen so that the ODE drivers never take the log of a vanishing
quantity and mu depends linearly on w:

* ``aging``, ``slip`` and ``tabor`` use w = ln(v / v0) and s = ln(theta) (theta > 0);
  ``aging2`` and ``slip2`` (two state variables) use s = (ln theta_1, ln theta_2);
* ``renewal`` (the mean-field renewal population itself) uses w = ln(v / v0) and the
  Laplace transforms s_j = <exp(-sigma_j age)> of the contacts' age distribution;
* ``silicon`` and ``two_state`` (000's laws, zero static threshold) use
  w = ln(1 + v / v*) and s = theta (theta >= 0, and v > -v* allows tiny back-creep).

The hot-path methods (``velocity``, ``friction``, ``gradient``, ``state_rate``) take plain
floats and a parameter tuple in the order of ``Law.names`` so that the ODE right-hand
sides stay cheap; ``steady_state`` and ``steady_friction`` are vectorised. Velocities are
in m/s, lengths in m, times in s; friction and state parts are dimensionless.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nanoblock.kernels.log_laws import AGING, SLIP, log_slider_rate

FloatArray = NDArray[np.float64]
QuasiStatic = tuple[
    Callable[[float, FloatArray, float], FloatArray],
    Callable[[float, FloatArray, float], FloatArray] | None,
]

__all__ = ["LAWS", "Law", "Parameter", "law"]


@dataclass(frozen=True)
class Parameter:
    """One law parameter: SI unit, meaning, open lower bound and fitting scale."""

    name: str
    unit: str
    meaning: str
    positive: bool = True
    log_scale: bool = False
    """Fit in ln(value): lengths, velocities and rates that span decades."""


@dataclass(frozen=True)
class Law:
    """Base class: a registered RSF law (see the module docstring for w and s)."""

    name: str
    summary: str
    parameters: tuple[Parameter, ...]
    state_names: tuple[str, ...]
    default_free: tuple[str, ...]
    defaults: Mapping[str, float] = field(default_factory=dict)
    exchangeable: tuple[tuple[str, str], ...] = ()
    """Parameter pairs the law is symmetric under, ordered so that the second memory length
    (the last pair) is the longer one: a fit that lands on the mirror image is swapped."""

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    def own(self, params: Mapping[str, float]) -> dict[str, float]:
        """The entries of ``params`` that are this law's parameters."""
        return {k: v for k, v in params.items() if k in self.names}

    def pack(self, params: Mapping[str, float]) -> tuple[float, ...]:
        """Parameter tuple in the order of ``names``; defaults fill what is missing.

        Raises ``ValueError`` naming the parameter that is missing, non-finite or out of
        range (positive parameters must be > 0).
        """
        unknown = set(params) - set(self.names)
        if unknown:
            raise ValueError(
                f"law {self.name!r} has no parameter(s) {sorted(unknown)}; "
                f"it takes {list(self.names)}"
            )
        values = []
        for spec in self.parameters:
            value = params.get(spec.name, self.defaults.get(spec.name))
            if value is None:
                raise ValueError(f"law {self.name!r}: parameter {spec.name!r} is required")
            value = float(value)
            if not math.isfinite(value) or (spec.positive and value <= 0.0):
                allowed = "(0, inf)" if spec.positive else "(-inf, inf)"
                raise ValueError(
                    f"law {self.name!r}: parameter {spec.name!r} = {value!r} is out of "
                    f"its allowed range {allowed} [{spec.unit}]"
                )
            values.append(value)
        return tuple(values)

    @property
    def allows_rest(self) -> bool:
        """Whether v = 0 is a finite point of the law (False for mu ~ ln v laws)."""
        return True

    # --- hot path (floats) -------------------------------------------------------
    def velocity(self, w: float, p: Sequence[float]) -> float:
        """Slip velocity v(w) [m/s]."""
        raise NotImplementedError

    def velocity_slope(self, w: float, p: Sequence[float]) -> float:
        """dv/dw [m/s]."""
        raise NotImplementedError

    def coordinate(self, v: float, p: Sequence[float]) -> float:
        """Inverse of ``velocity``."""
        raise NotImplementedError

    def friction(self, w: float, s: Sequence[float], p: Sequence[float]) -> float:
        """Friction coefficient mu(w, s)."""
        raise NotImplementedError

    def gradient(
        self, w: float, s: Sequence[float], p: Sequence[float]
    ) -> tuple[float, tuple[float, ...]]:
        """(d mu / d w, d mu / d s_i)."""
        raise NotImplementedError

    def state_rate(self, v: float, s: Sequence[float], p: Sequence[float]) -> tuple[float, ...]:
        """ds/dt [1/s] at slip velocity v."""
        raise NotImplementedError

    def quasi_static_system(self, p: Sequence[float], stiffness: float) -> QuasiStatic | None:
        """(rhs, Jacobian or None) of the quasi-static spring-slider in y = (w, s, slip),
        with ``odeint``'s signature f(t, y, V_L), compiled where the generic scalar
        right-hand side would cost most of a fit's time; None (the default) uses the
        generic one. Each function may return its own buffer, overwritten by its next call
        (``odeint`` copies every result)."""
        return None

    # --- vectorised ----------------------------------------------------------------
    def velocities(self, w: ArrayLike, p: Sequence[float]) -> FloatArray:
        """Vectorised ``velocity`` [m/s]."""
        raise NotImplementedError

    def steady_state(self, v: ArrayLike, p: Sequence[float]) -> tuple[FloatArray, ...]:
        """The state coordinates of steady sliding at velocity v > 0."""
        raise NotImplementedError

    def steady_friction(self, v: ArrayLike, params: Mapping[str, float]) -> FloatArray:
        """Steady-state friction coefficient mu_ss(v) at v > 0 [m/s]."""
        p = self.pack(params)
        v = np.asarray(v, dtype=float)
        state = self.steady_state(v, p)
        w = np.vectorize(lambda x: self.coordinate(x, p), otypes=[float])(v)
        return np.vectorize(lambda wi, *si: self.friction(wi, si, p), otypes=[float])(w, *state)

    def reference_friction(self, params: Mapping[str, float], velocity: float) -> float:
        """mu0 of the contract: steady friction at the reference velocity [m/s]."""
        return float(self.steady_friction(velocity, params))

    def contract(self, params: Mapping[str, float], velocity: float) -> dict[str, float | None]:
        """The contract keys mu0, a, b, dc (a and b per unit ln v; dc in m)."""
        return {
            "mu0": self.reference_friction(params, velocity),
            "a": params["a"],
            "b": params["b"],
            "dc": params["dc"],
        }


_MU0 = Parameter("mu0", "1", "steady friction at v0", positive=False)
_A = Parameter("a", "1", "direct-effect coefficient A (> 0: the quasi-static slider needs it)")
_B = Parameter("b", "1", "evolution-effect coefficient B", positive=False)
_DC = Parameter("dc", "m", "memory (critical slip) length D_c", log_scale=True)
_V0 = Parameter("v0", "m/s", "reference velocity (held fixed)", log_scale=True)


@dataclass(frozen=True)
class _LogVelocityLaw(Law):
    """w = ln(v / v0), s = (ln theta,): Dieterich-Ruina laws (001/Eq. 2)."""

    @property
    def allows_rest(self) -> bool:
        return False

    def velocity(self, w, p):
        return p[-1] * math.exp(w)

    def velocity_slope(self, w, p):
        return p[-1] * math.exp(w)

    def coordinate(self, v, p):
        return math.log(v / p[-1])

    def velocities(self, w, p):
        return p[-1] * np.exp(w)

    def friction(self, w, s, p):
        mu0, a, b, dc, v0 = p[0], p[1], p[2], p[3], p[-1]
        return mu0 + a * w + b * (s[0] + math.log(v0 / dc))

    def gradient(self, w, s, p):
        return p[1], (p[2],)

    def steady_state(self, v, p):
        return (np.log(p[3] / np.asarray(v, dtype=float)),)


def _log_system(
    p: Sequence[float],
    stiffness: float,
    evolution: int,
    v_theta: float = 0.0,
    second: tuple[float, float] | None = None,
    tau_m: float = 0.0,
) -> QuasiStatic:
    """The compiled right-hand side of :mod:`nanoblock.kernels.log_laws` (no Jacobian: see
    there) for a law with parameters ``p`` = (mu0, a, b, dc, ..., v0), the evolution law of
    its state variables (``AGING`` or ``SLIP``), the cutoff velocity, the optional second
    (b2, Dc2) and the creep onset time of the saturation law."""
    b2, dc2 = second or (0.0, 1.0)
    constants = np.array([p[1], p[2], p[3], p[-1], stiffness, v_theta, b2, dc2, evolution, tau_m])
    rate = np.empty(4 if second else 3)  # odeint copies each result

    def rhs(t: float, y: FloatArray, drive: float) -> FloatArray:
        if not log_slider_rate(y, drive, constants, rate):
            raise OverflowError(f"slip velocity v0 exp(w) at w = {y[0]!r} is not finite")
        return rate

    return rhs, None


@dataclass(frozen=True)
class AgingLaw(_LogVelocityLaw):
    """Dieterich aging law: theta' = 1 - v theta / Dc (001/Eq. 3, 000/Eq. 2)."""

    def state_rate(self, v, s, p):
        return (math.exp(-s[0]) - v / p[3],)

    def quasi_static_system(self, p, stiffness):
        return _log_system(p, stiffness, AGING)


@dataclass(frozen=True)
class SlipLaw(_LogVelocityLaw):
    """Ruina slip law: theta' = -(v theta / Dc) ln(v theta / Dc) (000/Eq. 3)."""

    def state_rate(self, v, s, p):
        if v <= 0.0:  # v ln v -> 0: no evolution at rest (v underflows after long holds)
            return (0.0,)
        return (-(v / p[3]) * (math.log(v / p[3]) + s[0]),)

    def quasi_static_system(self, p, stiffness):
        return _log_system(p, stiffness, SLIP)


@dataclass(frozen=True)
class CutoffLaw(_LogVelocityLaw):
    """Aging law with 000/Eq. 7's state cutoff velocity v_theta, in dimensional form.

    With theta_D = (Dc / v_theta) theta_000, 000/Eq. 7 reads
    theta' = v / (v + v_theta) - v theta / Dc: the aging law for v >> v_theta, no healing
    at rest, and a steady state theta = Dc / (v + v_theta) whose weakening flattens below
    v_theta. Parameters (mu0, a, b, dc, v_theta, v0).
    """

    def state_rate(self, v, s, p):
        return (v / (v + p[4]) * math.exp(-s[0]) - v / p[3],)

    def steady_state(self, v, p):
        return (np.log(p[3] / (np.asarray(v, dtype=float) + p[4])),)

    def quasi_static_system(self, p, stiffness):
        return _log_system(p, stiffness, AGING, v_theta=p[4])


@dataclass(frozen=True)
class SaturationLaw(AgingLaw):
    """Aging law with a finite creep onset time tau_m (001/Eq. 5 before linearisation).

    The area of a contact of age theta grows as ln(1 + theta / tau_m), so
    mu = mu0 + a ln(v/v0) + b ln((theta + tau_m) / (Dc/v0 + tau_m)): the state effect
    saturates above V_sat = Dc / tau_m (001/Eq. 8). Parameters (mu0, a, b, dc, tau_m, v0).
    """

    def friction(self, w, s, p):
        mu0, a, b, dc, tau, v0 = p
        return mu0 + a * w + b * math.log((math.exp(s[0]) + tau) / (dc / v0 + tau))

    def gradient(self, w, s, p):
        theta = math.exp(s[0])
        return p[1], (p[2] * theta / (theta + p[4]),)

    def quasi_static_system(self, p, stiffness):
        return _log_system(p, stiffness, AGING, tau_m=p[4])


@dataclass(frozen=True)
class TaborLaw(_LogVelocityLaw):
    """Generalised Tabor product form (001/Eq. 14), aging-law state phi.

    mu = mu0 [1 + m ln(phi v0 / D0)] [1 + alpha ln(v / v0)]; parameters
    (mu0, alpha, m, d0, v0), so that A = alpha mu0 and B = m mu0 (001/Eq. 16).
    """

    def friction(self, w, s, p):
        mu0, alpha, m, d0, v0 = p
        return mu0 * (1.0 + m * (s[0] + math.log(v0 / d0))) * (1.0 + alpha * w)

    def gradient(self, w, s, p):
        mu0, alpha, m, d0, v0 = p
        area = 1.0 + m * (s[0] + math.log(v0 / d0))
        strength = 1.0 + alpha * w
        return mu0 * area * alpha, (mu0 * m * strength,)

    def state_rate(self, v, s, p):
        return (math.exp(-s[0]) - v / p[3],)

    def contract(self, params, velocity):
        return {
            "mu0": self.reference_friction(params, velocity),
            "a": params["alpha"] * params["mu0"],
            "b": params["m"] * params["mu0"],
            "dc": params["d0"],
        }


@dataclass(frozen=True)
class TwoStateAgingLaw(_LogVelocityLaw):
    """Two state variables, each with Dieterich's aging law (Ruina 1983; Rice et al. 2001):

    mu = mu0 + a ln(v/v0) + b ln(v0 theta_1 / Dc) + b2 ln(v0 theta_2 / Dc2),
    theta_i' = 1 - v theta_i / Dc_i: a contact-scale memory Dc and a longer one Dc2 (gouge
    fabric, porosity, a second contact population). Parameters (mu0, a, b, dc, b2, dc2, v0).
    """

    def friction(self, w, s, p):
        mu0, a, b, dc, b2, dc2, v0 = p
        return mu0 + a * w + b * (s[0] + math.log(v0 / dc)) + b2 * (s[1] + math.log(v0 / dc2))

    def gradient(self, w, s, p):
        return p[1], (p[2], p[4])

    def state_rate(self, v, s, p):
        return (math.exp(-s[0]) - v / p[3], math.exp(-s[1]) - v / p[5])

    def steady_state(self, v, p):
        v = np.asarray(v, dtype=float)
        return (np.log(p[3] / v), np.log(p[5] / v))

    def quasi_static_system(self, p, stiffness):
        return _log_system(p, stiffness, AGING, second=(p[4], p[5]))


@dataclass(frozen=True)
class TwoStateSlipLaw(TwoStateAgingLaw):
    """Two state variables, each with Ruina's slip law: theta_i' = -(v theta_i / Dc_i)
    ln(v theta_i / Dc_i); friction as :class:`TwoStateAgingLaw`."""

    def state_rate(self, v, s, p):
        if v <= 0.0:
            return (0.0, 0.0)
        return tuple(-(v / dc) * (math.log(v / dc) + si) for dc, si in ((p[3], s[0]), (p[5], s[1])))

    def quasi_static_system(self, p, stiffness):
        return _log_system(p, stiffness, SLIP, second=(p[4], p[5]))


RENEWAL_STEP = 1.0
"""Spacing of the renewal law's quadrature nodes in ln sigma (trapezoid rule)."""
RENEWAL_NODES = np.exp(np.arange(-20.0, 16.0 + 1e-9, RENEWAL_STEP))
"""Laplace variables sigma_j of the renewal law [v0 / D]: the quadrature of <ln age> and
of <ln(1 + age / tau_m)> is exact to 1e-4 (up to a constant) for exponential age
distributions of mean 1e-3 to 1e4 D / v0 (tested in ``tests/test_rsf_laws.py``)."""
_REFERENCE = 1.0 / (1.0 + RENEWAL_NODES)
"""E_j in steady sliding at v0."""
_ONES = np.ones(RENEWAL_NODES.size)


@dataclass(frozen=True)
class RenewalLaw(_LogVelocityLaw):
    """The mean-field renewal population without the aging law's closure (001/Eqs. 3, 5).

    Contacts are born in proportion to slip and die after exponentially distributed slip
    of mean D (001/Eq. 3); a contact of age u carries log area ln(1 + u / tau_m)
    (001/Eq. 5), so mu = mu0 + a ln(v/v0) + b (<ln(1 + u/tau_m)> - its steady value at
    v0). The aging law replaces <ln u> by ln <u> (its theta is the mean age); here the mean
    of the logarithm is kept, by Frullani's integral ln(1 + u/tau) = int (1 - e^(-sigma
    u)) e^(-sigma tau) d sigma / sigma on the nodes :data:`RENEWAL_NODES`, with the state
    E_j = <exp(-sigma_j u)>, which obeys the linear law E_j' = -sigma_j (v0/D) r(v) E_j +
    (v/D)(1 - E_j): every age grows at the clock rate r (1, or v / (v + v_theta) with the
    state cutoff of 000/Eq. 7), and a share v dt / D is reborn at age 0. Steady sliding
    has the aging law's mu_ss(v); transients relax with a fitted aging-law b of ~0.86 b
    and D_c of ~0.5 D. Parameters (mu0, a, b, dc = D, [extra], v0), ``extra`` naming the
    variant: ``"cutoff"`` (v_theta), ``"saturation"`` (a free tau_m; otherwise
    tau_m << D / v), ``"second"`` (b2, dc2: a second, longer memory by the aging law).
    """

    extra: str = ""

    def _weights(self, p: Sequence[float]) -> FloatArray:
        """The nodes' weights e^(-sigma_j tau_m) (1 with tau_m << D / v)."""
        if self.extra == "saturation":
            return np.exp(-RENEWAL_NODES * (p[4] * p[-1] / p[3]))
        return _ONES

    def _ageing(self, v: float, p: Sequence[float]) -> FloatArray:
        """The nodes' ageing rates sigma_j (v0 / D) r(v) [1/s]."""
        rate = p[-1] / p[3]
        if self.extra == "cutoff":
            rate *= v / (v + p[4]) if v > 0.0 else 0.0
        return RENEWAL_NODES * rate

    def friction(self, w, s, p):
        e = np.asarray(s[: RENEWAL_NODES.size], dtype=float)
        mu = p[0] + p[1] * w + p[2] * RENEWAL_STEP * float(self._weights(p) @ (_REFERENCE - e))
        if self.extra == "second":
            mu += p[4] * (s[-1] + math.log(p[-1] / p[5]))
        return mu

    def gradient(self, w, s, p):
        slopes = tuple((-p[2] * RENEWAL_STEP * self._weights(p)).tolist())
        return p[1], slopes + ((p[4],) if self.extra == "second" else ())

    def state_rate(self, v, s, p):
        ageing = self._ageing(v, p)
        birth = v / p[3]
        e = np.asarray(s[: RENEWAL_NODES.size], dtype=float)
        rates = tuple((birth - (ageing + birth) * e).tolist())
        if self.extra == "second":
            rates += (math.exp(-s[-1]) - v / p[5],)
        return rates

    def steady_state(self, v, p):
        v = np.asarray(v, dtype=float)
        clock = v / (v + p[4]) if self.extra == "cutoff" else 1.0
        state = tuple(v / (v + sigma * p[-1] * clock) for sigma in RENEWAL_NODES)
        if self.extra == "second":
            state += (np.log(p[5] / v),)
        return state

    def quasi_static_system(self, p, stiffness):
        """w' = (K (V_L - v) + b h sum_j c_j E_j' - b2 s2') / a with E_j' as in the class
        docstring (s2' by the aging law) and its exact Jacobian, compiled
        (:mod:`nanoblock.kernels.renewal`)."""
        from nanoblock.kernels.renewal import renewal_slider_jacobian, renewal_slider_rate

        second = self.extra == "second"
        nodes, weights = RENEWAL_NODES, p[2] * RENEWAL_STEP / p[1] * self._weights(p)
        constants = np.array([
            p[1], p[3], p[-1], stiffness,
            p[4] if self.extra == "cutoff" else 0.0,
            p[4] if second else 0.0,
            p[5] if second else 1.0,
        ])  # fmt: skip
        size = nodes.size + 2 + second
        rate, matrix = np.empty(size), np.empty((size, size))  # odeint copies each result

        def rhs(t: float, y: FloatArray, drive: float) -> FloatArray:
            renewal_slider_rate(y, drive, nodes, weights, constants, rate)
            return rate

        def jacobian(t: float, y: FloatArray, drive: float) -> FloatArray:
            renewal_slider_jacobian(y, drive, nodes, weights, constants, matrix)
            return matrix

        return rhs, jacobian

    def contract(self, params, velocity):
        contract = super().contract(params, velocity)
        if self.extra == "second":
            contract["b"] = params["b"] + params["b2"]
        return contract


@dataclass(frozen=True)
class SiliconLaw(Law):
    """000's silicon-on-steel law (000/Eqs. 1, 7, 14c-d): zero static threshold.

    mu = A ln(1 + v/v*) + B ln(1 + theta/theta*),
    theta' = (|v| / Dc) (1 / (1 + |v|/v_theta) - theta);
    static coefficient mu_s = B ln(1 + 1/theta*) (000/Eq. 8). Slip in either direction
    renews contacts, hence |v|. Parameters (a, b, dc, theta_star, v_theta, v_star).
    """

    def velocity(self, w, p):
        return p[-1] * math.expm1(w)

    def velocity_slope(self, w, p):
        return p[-1] * math.exp(w)

    def coordinate(self, v, p):
        return math.log1p(v / p[-1])

    def velocities(self, w, p):
        return p[-1] * np.expm1(w)

    def friction(self, w, s, p):
        return p[0] * w + p[1] * math.log1p(s[0] / p[3])

    def gradient(self, w, s, p):
        return p[0], (p[1] / (p[3] + s[0]),)

    def state_rate(self, v, s, p):
        speed = abs(v)
        return (speed / p[2] * (1.0 / (1.0 + speed / p[4]) - s[0]),)

    def steady_state(self, v, p):
        return (1.0 / (1.0 + np.abs(np.asarray(v, dtype=float)) / p[4]),)

    def static_friction(self, params: Mapping[str, float]) -> float:
        """mu_s = B ln(1 + 1/theta*) (000/Eq. 8)."""
        return params["b"] * math.log1p(1.0 / params["theta_star"])


@dataclass(frozen=True)
class TwoStateLaw(SiliconLaw):
    """000's two-state law (000/Eqs. 4-5) with the friction of 000/Eq. 1.

    theta' = (|v|/Dc) ((1 + phi)/(1 + |v|/v_theta) - theta),  phi' = h - |v| phi / Dc,
    with h = alpha N / tau the aging rate [1/s]; state (theta, phi). Parameters
    (a, b, dc, theta_star, v_theta, aging_rate, v_star).
    """

    def gradient(self, w, s, p):
        return p[0], (p[1] / (p[3] + s[0]), 0.0)

    def state_rate(self, v, s, p):
        speed = abs(v)
        theta, phi = s
        return (
            speed / p[2] * ((1.0 + phi) / (1.0 + speed / p[4]) - theta),
            p[5] - speed * phi / p[2],
        )

    def steady_state(self, v, p):
        speed = np.abs(np.asarray(v, dtype=float))
        phi = p[5] * p[2] / speed
        return ((1.0 + phi) / (1.0 + speed / p[4]), phi)


_V_THETA = Parameter("v_theta", "m/s", "state cutoff velocity v_theta", log_scale=True)
_SILICON_PARAMETERS = (
    Parameter("a", "1", "direct-effect coefficient A"),
    Parameter("b", "1", "state coefficient B"),
    _DC,
    Parameter("theta_star", "1", "state scale theta*", log_scale=True),
    _V_THETA,
)
_D2_B = Parameter("b2", "1", "second evolution-effect coefficient B2", positive=False)
_D2 = Parameter("dc2", "m", "second (long) memory length Dc2", log_scale=True)
_TWO_STATE_PARAMETERS = (_MU0, _A, _B, _DC, _D2_B, _D2, _V0)
_D = Parameter("dc", "m", "mean renewal slip D of a contact", log_scale=True)
_TAU_M = Parameter("tau_m", "s", "creep onset time tau_m", log_scale=True)
_RENEWAL_STATE = tuple(f"e{j:02d}" for j in range(RENEWAL_NODES.size))
_V_STAR = Parameter("v_star", "m/s", "velocity scale v* (held fixed)", log_scale=True)

LAWS: dict[str, Law] = {
    entry.name: entry
    for entry in (
        AgingLaw(
            "aging",
            "Dieterich aging law (001/Eqs. 2-3)",
            (_MU0, _A, _B, _DC, _V0),
            ("ln_theta",),
            ("mu0", "a", "b", "dc"),
        ),
        SlipLaw(
            "slip",
            "Ruina slip law (001/Eq. 2, 000/Eq. 3)",
            (_MU0, _A, _B, _DC, _V0),
            ("ln_theta",),
            ("mu0", "a", "b", "dc"),
        ),
        TwoStateAgingLaw(
            "aging2",
            "aging law with two state variables (contact-scale Dc, long Dc2)",
            _TWO_STATE_PARAMETERS,
            ("ln_theta1", "ln_theta2"),
            ("mu0", "a", "b", "dc", "b2", "dc2"),
            exchangeable=(("b", "b2"), ("dc", "dc2")),
        ),
        TwoStateSlipLaw(
            "slip2",
            "slip law with two state variables (contact-scale Dc, long Dc2)",
            _TWO_STATE_PARAMETERS,
            ("ln_theta1", "ln_theta2"),
            ("mu0", "a", "b", "dc", "b2", "dc2"),
            exchangeable=(("b", "b2"), ("dc", "dc2")),
        ),
        RenewalLaw(
            "renewal",
            "the contacts' renewal population (001/Eqs. 3, 5) without the aging closure",
            (_MU0, _A, _B, _D, _V0),
            _RENEWAL_STATE,
            ("mu0", "a", "b", "dc"),
        ),
        RenewalLaw(
            "renewal_cutoff",
            "renewal population ageing on 000/Eq. 7's clock v / (v + v_theta)",
            (_MU0, _A, _B, _D, _V_THETA, _V0),
            _RENEWAL_STATE,
            ("mu0", "a", "b", "dc", "v_theta"),
            extra="cutoff",
        ),
        RenewalLaw(
            "renewal_saturation",
            "renewal population with a finite creep onset time tau_m (001/Eqs. 5, 8)",
            (_MU0, _A, _B, _D, _TAU_M, _V0),
            _RENEWAL_STATE,
            ("mu0", "a", "b", "dc", "tau_m"),
            extra="saturation",
        ),
        RenewalLaw(
            "renewal2",
            "renewal population with a second, longer memory Dc2 (aging law)",
            (*_TWO_STATE_PARAMETERS[:4], _D2_B, _D2, _V0),
            (*_RENEWAL_STATE, "ln_theta2"),
            ("mu0", "a", "b", "dc", "b2", "dc2"),
            extra="second",
        ),
        CutoffLaw(
            "cutoff",
            "aging law with 000/Eq. 7's state cutoff velocity v_theta",
            (_MU0, _A, _B, _DC, _V_THETA, _V0),
            ("ln_theta",),
            ("mu0", "a", "b", "dc", "v_theta"),
        ),
        SaturationLaw(
            "saturation",
            "aging law with a finite creep onset time tau_m (001/Eqs. 5, 8)",
            (
                _MU0,
                _A,
                _B,
                _DC,
                _TAU_M,
                _V0,
            ),
            ("ln_theta",),
            ("mu0", "a", "b", "dc", "tau_m"),
        ),
        TaborLaw(
            "tabor",
            "generalised Tabor product form (001/Eq. 14)",
            (
                _MU0,
                Parameter("alpha", "1", "relative direct effect alpha"),
                Parameter("m", "1", "relative area creep m", positive=False),
                Parameter("d0", "m", "memory length D0", log_scale=True),
                _V0,
            ),
            ("ln_phi",),
            ("mu0", "alpha", "m", "d0"),
        ),
        SiliconLaw(
            "silicon",
            "silicon-on-steel law, no aging (000/Eqs. 1, 7)",
            (*_SILICON_PARAMETERS, _V_STAR),
            ("theta",),
            ("a", "b", "dc", "theta_star", "v_theta"),
            defaults={"v_star": 1e-12},
        ),
        TwoStateLaw(
            "two_state",
            "two-state aging law (000/Eqs. 1, 4-5)",
            (
                *_SILICON_PARAMETERS,
                Parameter("aging_rate", "1/s", "aging rate h = alpha N / tau", log_scale=True),
                _V_STAR,
            ),
            ("theta", "phi"),
            ("a", "b", "dc", "theta_star", "v_theta", "aging_rate"),
            defaults={"v_star": 1e-12},
        ),
    )
}


def law(name: str) -> Law:
    """The registered law called ``name``; ``ValueError`` lists the known ones."""
    try:
        return LAWS[name]
    except KeyError:
        raise ValueError(f"unknown law {name!r}; known laws: {sorted(LAWS)}") from None
