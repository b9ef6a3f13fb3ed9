"""Hidden-effect data for the diagnosis tests, made by code paths the diagnosis never uses.

Time series come from the naive Radau spring-slider in (mu, theta) (``tests/naive_rsf.py``);
steady tables from a brute-force quadrature of Q_st on a fine grid (001/Eqs. 27-28) with
ageing averaged exactly over exponentially distributed contact ages (001/Eqs. 3, 5), the
strength spread sampled on 64 quantiles and the softening given by a linear fall of
sigma_a towards T_g (not the surrogates' forms); clamped-sample curves from a Radau
integration of 000/Eqs. 9-14 in natural variables. Each case draws its parameters from
the generator's random stream; the diagnosis sees only the data. The acceptance matrix
(``tests/hidden_matrix.py``) takes its steady tables and ramps from here and its time
series from the renewal picture (``tests/renewal_synthetic.py``).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import xarray as xr
from scipy.integrate import cumulative_trapezoid, solve_ivp
from scipy.special import exp1
from scipy.stats import norm

from nanoblock.measured import COLUMNS
from tests.naive_rsf import naive_slider

STEADY_EFFECTS = (
    "barrier_shape",
    "back_jumps",
    "strength_heterogeneity",
    "joint_softening",
    "velocity_saturation",
    "state_velocity_cutoff",
)
EULER_GAMMA = 0.5772156649015329


def _var(name: str, values: np.ndarray) -> tuple:
    units, long_name = COLUMNS[name]
    return ("sample", np.asarray(values, dtype=float), {"units": units, "long_name": long_name})


def _dataset(columns: dict[str, np.ndarray], kind: str, **attrs: object) -> xr.Dataset:
    data_vars = {name: _var(name, values) for name, values in columns.items()}
    return xr.Dataset(data_vars, attrs={"kind": kind, **attrs})


# ------------------------------------------------------------------ time series


def _protocol(dc: float, v1: float) -> list[tuple[float, float]]:
    """Up-step, down-step, hold and reslide: each effect leaves its own mark somewhere."""
    return [
        (v1, 10 * dc / v1),
        (10 * v1, 30 * dc / (10 * v1)),
        (v1, 15 * dc / v1),
        (0.0, 100 * dc / v1),
        (v1, 15 * dc / v1),
    ]


def _segment_times(segments: list[tuple[float, float]], per_segment: int) -> np.ndarray:
    edges = np.concatenate([[0.0], np.cumsum([d for _, d in segments])])
    parts = [np.linspace(a, b, per_segment, endpoint=False) for a, b in itertools.pairwise(edges)]
    return np.concatenate(parts)


def _displacement(segments: list[tuple[float, float]], time: np.ndarray) -> np.ndarray:
    ends = np.cumsum([d for _, d in segments])
    starts = np.concatenate([[0.0], ends[:-1]])
    base = np.concatenate([[0.0], np.cumsum([v * d for v, d in segments])[:-1]])
    index = np.minimum(np.searchsorted(ends, time, side="right"), len(segments) - 1)
    velocity = np.array([v for v, _ in segments])[index]
    return base[index] + velocity * (time - starts[index])


def time_series_case(effect: str, rng: np.random.Generator, noise: float) -> xr.Dataset:
    """Steps and a hold on a spring-slider, with ``effect`` (or ``none``) switched on."""
    a = rng.uniform(0.006, 0.015)
    truth = {
        "mu0": rng.uniform(0.5, 0.7),
        "a": a,
        "b": a + rng.uniform(-0.003, 0.005),
        "dc": math.exp(rng.uniform(math.log(5e-6), math.log(4e-5))),
        "v0": 1e-6,
    }
    v1 = truth["v0"]
    k = 3.0 * max(truth["b"] - truth["a"], 0.0) / truth["dc"] + 0.6 * truth["a"] / truth["dc"]
    law, trend, forces, exponent = "aging", 0.0, [100.0], 0.0
    if effect == "aging_rate":
        law = "slip"
    elif effect == "state_velocity_cutoff":
        law, truth["v_theta"] = "cutoff", v1 * math.exp(rng.uniform(math.log(0.5), math.log(5)))
    elif effect == "velocity_saturation":
        v_sat = v1 * math.exp(rng.uniform(math.log(0.5), math.log(5)))
        law, truth["tau_m"] = "saturation", truth["dc"] / v_sat
    elif effect == "slip_trend":
        slip = sum(v * d for v, d in _protocol(truth["dc"], v1))
        trend = rng.choice([-1.0, 1.0]) * rng.uniform(10.0, 40.0) * noise / slip
    elif effect == "load_dependent_dc":
        forces, exponent = [50.0, 100.0, 200.0], rng.uniform(0.5, 1.0)
    elif effect != "none":
        raise ValueError(effect)
    segments = _protocol(truth["dc"], v1)
    time = _segment_times(segments, 80)
    displacement = _displacement(segments, time)
    w_ref = math.exp(np.mean(np.log(forces)))
    columns: dict[str, list[np.ndarray]] = {}
    for run, force in enumerate(forces):
        params = {**truth, "dc": truth["dc"] * (force / w_ref) ** exponent}
        mu = naive_slider(law, params, segments, time, k) + trend * displacement
        mu += noise * rng.standard_normal(time.size)
        for name, values in (
            ("time", time), ("mu", mu), ("load_point_displacement", displacement),
            ("normal_force", np.full(time.size, force)), ("run", np.full(time.size, run)),
        ):  # fmt: skip
            columns.setdefault(name, []).append(values)
    merged = {name: np.concatenate(values) for name, values in columns.items()}
    return _dataset(merged, "time_series", stiffness_per_load=k, apparatus="spring_slider")


# ------------------------------------------------------------------ steady tables


def naive_steady_stress(
    velocity: np.ndarray,
    u: float,
    v_attempt: float,
    barrier: str = "persson",
    elastic_ratio: float | None = None,
) -> np.ndarray:
    """sigma_s / sigma_a by brute force: Q_st = exp(-I(x)), I = (v_a / V) int_0^x
    exp(-u f) dx' on a uniform grid of 40,001 points (001/Eqs. 27-28); with
    ``elastic_ratio`` r, reverse hops (:func:`naive_back_jump_stress`)."""
    if elastic_ratio is not None:
        return naive_back_jump_stress(velocity, u, v_attempt, elastic_ratio)
    x = np.linspace(0.0, 1.0, 40_001)
    f = 1.0 - x * x if barrier == "persson" else (1.0 - x) ** 1.5
    hazard = cumulative_trapezoid(np.exp(-u * f), x, initial=0.0)
    out = np.empty(velocity.size)
    for i, v in enumerate(velocity):
        q = np.exp(-(v_attempt / v) * hazard)
        out[i] = np.trapezoid(x * q, x) / np.trapezoid(q, x)
    return out


def naive_back_jump_stress(
    velocity: np.ndarray, u: float, v_attempt: float, elastic_ratio: float
) -> np.ndarray:
    """sigma_s / sigma_a with reverse hops (Persson's law), from the master equation.

    A block at drive phase s = rho~ / rho~_max mod 1 sits on the upper branch (stress s)
    with probability p, else on the lower one (s - 1); it hops down at
    omega_a e^{-u (1 - s^2)} and up at that rate times e^{-u_el (s - 1/2)}, u_el = r u (the
    elastic energy the down hop releases: detailed balance), and the phase advances at
    V / rho~_max, so dp/ds = (v_a / V) e^{-u (1 - s^2)} [(1 - p) e^{-u_el (s - 1/2)} - p]
    from p(0) = 1. Mean stress int_0^1 [p s + (1 - p)(s - 1)] ds, by Radau.
    """
    u_el = elastic_ratio * u

    def rates(s: float, v: float) -> tuple[float, float]:
        down = (v_attempt / v) * math.exp(-u * (1.0 - s * s))
        return down, down * math.exp(-u_el * (s - 0.5))

    out = np.empty(velocity.size)
    for i, v in enumerate(velocity):

        def rhs(s: float, y: np.ndarray, v: float = v) -> list[float]:
            down, up = rates(s, v)
            return [up * (1.0 - y[0]) - down * y[0], y[0] * s + (1.0 - y[0]) * (s - 1.0)]

        def jacobian(s: float, y: np.ndarray, v: float = v) -> list[list[float]]:
            down, up = rates(s, v)
            return [[-up - down, 0.0], [1.0, 0.0]]

        solution = solve_ivp(
            rhs, (0.0, 1.0), [1.0, 0.0], method="Radau", jac=jacobian, rtol=1e-9, atol=1e-12
        )
        out[i] = solution.y[1, -1]
    return out


def _area(velocity: np.ndarray, m: float, memory: float, effect: str, extra: float):
    """<1 + m ln(1 + phi / tau_m)> over exponential ages phi of mean D0 / V (001/Eqs. 3, 5).

    Base: tau_m far below every age, <ln(phi / tau)> = ln(D0 / (V tau)) - gamma. Finite
    tau_m: <ln(1 + phi / tau)> = e^{tau/mean} E_1(tau/mean). Cutoff: mean age D0/(V + v_t)."""
    tau = 1e-3
    if effect == "velocity_saturation":
        ratio = extra * velocity / memory  # tau_m / <phi>, extra = tau_m
        small = np.minimum(ratio, 50.0)  # e^x E_1(x) ~ (1 - 1/x + 2/x^2) / x beyond
        scaled = np.where(
            ratio < 50.0, np.exp(small) * exp1(small), (1 - 1 / ratio + 2 / ratio**2) / ratio
        )
        return 1.0 + m * scaled
    mean_age = memory / (velocity + (extra if effect == "state_velocity_cutoff" else 0.0))
    return 1.0 + m * (np.log(mean_age / tau) - EULER_GAMMA)


def steady_case(
    effect: str,
    rng: np.random.Generator,
    noise: float,
    temperatures: tuple[float, ...] | None = None,
) -> xr.Dataset:
    """A steady-state table over 10 decades of velocity (several temperatures when the
    effect is joint softening, or at ``temperatures`` [K] whatever the effect), with
    ``effect`` (or ``none``) switched on."""
    u_ref = rng.uniform(25.0, 50.0)
    v_attempt = math.exp(rng.uniform(math.log(30.0), math.log(3000.0)))
    memory, m = 1e-6 * rng.uniform(0.2, 2.0), rng.uniform(0.0, 0.03)
    scale = rng.uniform(0.3, 0.5)
    velocity = np.logspace(-10.0, 0.5, 36)
    layout = list(temperatures or [293.0])
    barrier, spread, extra, ratio = "persson", 0.0, 0.0, None
    t_ref, t_glass, drop = 293.0, 383.0, 0.0
    if effect == "barrier_shape":
        barrier = "spinodal"
    elif effect == "back_jumps":
        ratio = math.exp(rng.uniform(math.log(0.3), math.log(1.5)))  # u_el / u = E_J b / k1
    elif effect == "strength_heterogeneity":
        spread = rng.uniform(0.25, 0.5)
    elif effect == "joint_softening":
        layout, drop = list(temperatures or [293.0, 323.0, 353.0]), rng.uniform(0.25, 0.5)
    elif effect == "velocity_saturation":
        extra = memory / (v_attempt * math.exp(rng.uniform(-16.0, -10.0)))  # tau_m
    elif effect == "state_velocity_cutoff":
        extra = v_attempt * math.exp(rng.uniform(-19.0, -14.0))  # v_theta
    elif effect != "none":
        raise ValueError(effect)
    if len(layout) > 1:
        velocity = np.logspace(-9.0, 0.5, 16)
    quantiles = norm.ppf((np.arange(64) + 0.5) / 64) if spread else np.zeros(1)
    strengths = np.exp(spread * quantiles - 0.5 * spread**2)
    rows = []
    for temperature in layout:
        # sigma_a falls linearly to (1 - drop) of its value between T_ref and T_g
        soft = 1.0 - drop * (temperature - t_ref) / (t_glass - t_ref)
        stress = np.zeros(velocity.size)
        for g in strengths * soft:
            u = u_ref * (t_ref / temperature) * g * g
            stress += g * naive_steady_stress(velocity, u, v_attempt * g, barrier, ratio)
        mu = scale * stress / strengths.size * _area(velocity, m, memory, effect, extra)
        rows.append(np.column_stack([velocity, np.full(velocity.size, temperature), mu]))
    table = np.concatenate(rows)
    mu = table[:, 2] + noise * rng.standard_normal(table.shape[0])
    columns = {"load_point_velocity": table[:, 0], "mu": mu}
    if len(layout) > 1:
        columns["temperature"] = table[:, 1]
    return _dataset(columns, "steady_state", apparatus="spring_slider")


# ------------------------------------------------------------------ clamped samples

SILICON_APPARATUS = {"k_s": 279e6, "k_f": 5.93e9, "k_ext": 98.1e6}
"""000 Table 1 stiffnesses [N/m]."""


def naive_clamped(
    params: dict[str, float], force: float, rate: float, times: np.ndarray
) -> np.ndarray:
    """Sample extension s(t) [m] under s_ext = rate t, from rest, by Radau in natural
    variables (x, theta, phi) of 000/Eqs. 4-5, 9-14 (aging_rate 0: 000/Eq. 7)."""
    k_s, k_f, k_ext = (SILICON_APPARATUS[k] for k in ("k_s", "k_f", "k_ext"))
    c_ext = k_s * k_ext / (k_f + k_ext + k_s)
    c_x = k_s * (k_f + k_ext) / (k_f + k_ext + k_s)
    a, b, dc, theta_star, v_theta = (params[k] for k in ("a", "b", "dc", "theta_star", "v_theta"))
    h, v_star = params.get("aging_rate", 0.0), 1e-12

    def rhs(t: float, y: np.ndarray) -> list[float]:
        x, theta, phi = y
        mu = (c_ext * rate * t - c_x * x) / (2.0 * force)
        exponent = (mu - b * math.log1p(max(theta, 0.0) / theta_star)) / a
        v = v_star * math.expm1(min(exponent, 700.0))
        speed = abs(v)
        return [
            v,
            speed / dc * ((1.0 + phi) / (1.0 + speed / v_theta) - theta),
            h - speed * phi / dc,
        ]

    solution = solve_ivp(
        rhs, (0.0, times[-1]), [0.0, 0.0, 0.0], method="Radau", rtol=1e-9, atol=1e-13,
        t_eval=times,
    )  # fmt: skip
    x = solution.y[0]
    return (c_ext * rate * times - c_x * x) / k_s


def clamped_case(
    effect: str,
    rng: np.random.Generator,
    noise: float,
    forces: tuple[float, ...] = (100.0, 300.0, 600.0),
    exponent: float | None = None,
) -> xr.Dataset:
    """000/Fig. 3 ramps (s_ext 0 -> 127 um over 370 s) at several normal forces around
    Si/steel 2 of Table 2, with ``effect`` (or ``none``) switched on."""
    params = {
        "a": 5e-4 * rng.uniform(0.7, 1.4),
        "b": 0.16 / math.log1p(1.0 / 0.2) * rng.uniform(0.8, 1.2),
        "dc": 0.5e-6 * rng.uniform(0.7, 1.5),
        "theta_star": 0.2 * rng.uniform(0.7, 1.4),
        "v_theta": 0.2e-6 * rng.uniform(0.5, 2.0),
    }
    if effect == "aging_rate":
        params["aging_rate"] = math.exp(rng.uniform(math.log(0.01), math.log(0.1)))
    elif effect == "load_dependent_dc":
        exponent = rng.uniform(0.4, 1.0) if exponent is None else exponent
    elif effect != "none":
        raise ValueError(effect)
    rate, duration = 127e-6 / 370.0, 370.0
    times = np.linspace(0.0, duration, 150)
    w_ref = math.exp(np.mean(np.log(forces)))
    columns: dict[str, list[np.ndarray]] = {}
    for run, force in enumerate(forces):
        run_params = dict(params)
        if exponent:
            run_params["dc"] = params["dc"] * (force / w_ref) ** exponent
        s = naive_clamped(run_params, force, rate, times)
        s += noise * rng.standard_normal(times.size)
        for name, values in (
            ("time", times), ("s_ext", rate * times), ("s", s),
            ("normal_force", np.full(times.size, force)), ("run", np.full(times.size, run)),
        ):  # fmt: skip
            columns.setdefault(name, []).append(values)
    merged = {name: np.concatenate(values) for name, values in columns.items()}
    return _dataset(merged, "clamped_sample", apparatus="clamped_sample", **SILICON_APPARATUS)


# ------------------------------------------------------------------ noise

NOISE = {"time_series": 2e-4, "steady_state": 2e-4, "clamped_sample": 2e-9}
"""White noise of each kind: mu for friction, metres for the sample extension s."""
