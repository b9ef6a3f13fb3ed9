"""Hidden-effect cases of the acceptance matrix, one layout per kind of data.

Time series come from the mean-field renewal spring-slider (``tests/renewal_synthetic.py``),
not from any rate-and-state law; every one has the same layout: three runs at normal
forces 50, 100 and 200 N, the same protocol (up-step, down-step, hold, reslide, in units
of the memory length D), multi-rate sampling (dense after each change of velocity), white
or AR(1) noise. Steady tables all have three temperatures, clamped-sample ramps three
forces (``tests/diagnosis_synthetic.py``). Each maker returns the noisy data and the same
data without noise (for the expected-answer rule).
Nothing here imports the diagnosis or the fitting code.
"""

from __future__ import annotations

import copy
import itertools
import math

import numpy as np
import xarray as xr

from tests.diagnosis_synthetic import (
    NOISE,
    STEADY_EFFECTS,
    _dataset,
    _displacement,
    clamped_case,
    steady_case,
)
from tests.renewal_synthetic import Renewal, renewal_slider

TIME_SERIES_EFFECTS = (
    "slip_trend",
    "aging_rate",
    "state_velocity_cutoff",
    "velocity_saturation",
    "load_dependent_dc",
    "two_state_variable",
    "non_steady_history",
    "machine_stiffness",
    "unstable_sliding",
)
EFFECTS = {
    "time_series": TIME_SERIES_EFFECTS,
    "steady_state": STEADY_EFFECTS,
    "clamped_sample": ("load_dependent_dc", "aging_rate"),
}
"""Every catalogue effect each kind of data can show."""
FORCES = (50.0, 100.0, 200.0)
"""Normal force [N] of each time-series run."""
TEMPERATURES = (293.0, 323.0, 353.0)
"""Temperatures [K] of every steady table."""
RENEWAL_B, RENEWAL_DC = 0.86, 0.5
"""Aging-law B / b and D_c / D of the renewal relaxation (``naive_rsf.renewal_fit_bias``):
the stiffness is chosen against these effective values."""
BASE_TAU = 1e-6
"""tau_m of the effect-free picture [D / v1]: V_sat = 1e6 v1, so the saturation term
~ (tau_m V / D) ln(D / (tau_m V)) ~ 1e-4 at 10 v1 moves mu by ~1e-6 (1e-3 would put a
velocity saturation of ~5e-4 in every record)."""
V1 = 1e-6
"""First (and base) load-point velocity of every time series [m/s]."""
HOLD = 100.0
"""Hold of every time series [D / v1]."""
COLOURED_SHARE = 1.0 / 3.0
"""Share of time series with AR(1) noise (lag-1 autocorrelation 0.5-0.9)."""


def _protocol(d0: float, v1: float) -> list[tuple[float, float]]:
    """Load-point (velocity [m/s], duration [s]): 10 D, up-step 30 D, down-step 100 D
    (4-6 stick-slip cycles below the critical stiffness), hold :data:`HOLD` D / v1,
    reslide 15 D."""
    return [
        (v1, 10 * d0 / v1),
        (10 * v1, 30 * d0 / (10 * v1)),
        (v1, 100 * d0 / v1),
        (0.0, HOLD * d0 / v1),
        (v1, 15 * d0 / v1),
    ]


def _sample_times(segments: list[tuple[float, float]]) -> np.ndarray:
    """60 even samples per segment plus 40 log-spaced over its first 5 %."""
    edges = np.concatenate([[0.0], np.cumsum([d for _, d in segments])])
    parts = []
    for start, end in itertools.pairwise(edges):
        length = end - start
        dense = start + np.geomspace(1e-4 * length, 0.05 * length, 40)
        parts.append(np.concatenate([np.linspace(start, end, 60, endpoint=False), dense]))
    return np.unique(np.concatenate(parts))


def _noise(rng: np.random.Generator, size: int, sigma: float, phi: float) -> np.ndarray:
    """Stationary AR(1) noise of standard deviation sigma (phi = 0: white)."""
    shocks = sigma * math.sqrt(1.0 - phi * phi) * rng.standard_normal(size)
    out = np.empty(size)
    out[0] = sigma * rng.standard_normal()
    for i in range(1, size):
        out[i] = phi * out[i - 1] + shocks[i]
    return out


def draw_interface(rng: np.random.Generator) -> tuple[float, float, float, float]:
    """(a, b, D [m], mu0) of a time series, drawn in that order."""
    a = rng.uniform(0.006, 0.015)
    b = a + rng.uniform(-0.003, 0.005)
    d0 = math.exp(rng.uniform(math.log(1e-5), math.log(8e-5)))
    return a, b, d0, rng.uniform(0.5, 0.7)


def stated_stiffness(a: float, b: float, d0: float) -> float:
    """The K/W [1/m] a record states, in the renewal relaxation's effective aging-law values
    B, D_c (:data:`RENEWAL_B`, :data:`RENEWAL_DC`): 3 (B - a)+ + 0.6 a over D_c, and at
    least what unloads the hold's healing B ln(1 + t_h V1 / D_c), less a ln 20, over
    1.5 D_c. The reslide then peaks near 20 V1 (3-23 V1 on matrix draws 0-35), not in a
    quasi-static slip event: such an event's stress drop grows without bound as
    tau_m -> 0, so the creep onset time of every effect-free record would be visible in it
    (draw #8 at the first bound alone: 1e6 V1, 4.5 D of slip)."""
    healing = RENEWAL_B * b * math.log1p(HOLD / RENEWAL_DC)
    steady = 3 * max(RENEWAL_B * b - a, 0.0) + 0.6 * a
    return max(steady, (healing - a * math.log(20.0)) / 1.5) / (RENEWAL_DC * d0)


def draw_effect(effect: str, rng: np.random.Generator, b: float, d0: float) -> dict[str, float]:
    """The drawn size of an effect that the engine can switch on too (``{}`` for the
    others): v_theta [m/s], tau_m [s], the memory's load exponent, b2 and d2 / D, or the
    factor on the stated stiffness (halves below and above, 0.4-0.7 or 1.5-2.5)."""
    if effect == "state_velocity_cutoff":
        return {"v_theta": V1 * math.exp(rng.uniform(math.log(0.5), math.log(5.0)))}
    if effect == "velocity_saturation":
        return {"tau_m": d0 / (V1 * math.exp(rng.uniform(math.log(0.5), math.log(5.0))))}
    if effect == "load_dependent_dc":
        return {"exponent": rng.uniform(0.5, 1.0)}
    if effect == "two_state_variable":
        return {"b2": b * rng.uniform(0.3, 0.7), "d2_per_d0": rng.uniform(8.0, 20.0)}
    if effect == "machine_stiffness":
        low = rng.random() < 0.5
        return {"stiffness_factor": rng.uniform(0.4, 0.7) if low else rng.uniform(1.5, 2.5)}
    return {}


def time_series(effect: str, rng: np.random.Generator) -> tuple[xr.Dataset, xr.Dataset]:
    """A renewal spring-slider record with ``effect`` (or ``none``): (data, noiseless)."""
    if effect not in (*TIME_SERIES_EFFECTS, "none"):
        raise ValueError(effect)
    v1 = V1
    a, b, d0, mu0 = draw_interface(rng)
    p = {"mu0": mu0, "a": a, "b": b, "d0": d0, "tau_m": BASE_TAU * d0 / v1}
    sigma = NOISE["time_series"] * rng.uniform(0.7, 1.4)
    phi = rng.uniform(0.5, 0.9) if rng.random() < COLOURED_SHARE else 0.0
    k_stated = stated_stiffness(a, b, d0)
    drawn = draw_effect(effect, rng, b, d0)
    k_true = k_stated * drawn.pop("stiffness_factor", 1.0)
    exponent = drawn.pop("exponent", 0.0)
    if "d2_per_d0" in drawn:
        p["d2"] = d0 * drawn.pop("d2_per_d0")
    p.update(drawn)
    trend, before = 0.0, []
    if effect == "slip_trend":
        slip = sum(v * d for v, d in _protocol(d0, v1))
        trend = rng.choice([-1.0, 1.0]) * rng.uniform(10.0, 40.0) * sigma / slip
    elif effect == "aging_rate":
        p["slip_like"] = True
    elif effect == "non_steady_history":
        v_before = v1 * 10 ** (rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 1.0))
        before = [(v_before, rng.uniform(1.0, 3.0) * d0 / v_before)]
    elif effect == "unstable_sliding":
        p["b"] = (a + rng.uniform(0.002, 0.004)) / RENEWAL_B
        k_stated = k_true = rng.uniform(0.7, 0.9) * (RENEWAL_B * p["b"] - a) / (RENEWAL_DC * d0)
    segments = _protocol(d0, v1)
    time = _sample_times(segments)
    displacement = _displacement(segments, time)
    w_ref = math.exp(np.mean(np.log(FORCES)))
    clean: dict[str, list[np.ndarray]] = {}
    for run, force in enumerate(FORCES):
        params = Renewal(**{**p, "d0": d0 * (force / w_ref) ** exponent})
        t, mu = renewal_slider(
            params, before + segments, k_true, start_velocity=v1,
            record_from=sum(d for _, d in before),
        )  # fmt: skip
        mu = np.interp(time, t, mu) + trend * displacement
        for name, values in (
            ("time", time), ("mu", mu), ("load_point_displacement", displacement),
            ("normal_force", np.full(time.size, force)), ("run", np.full(time.size, run)),
        ):  # fmt: skip
            clean.setdefault(name, []).append(values)
    merged = {name: np.concatenate(values) for name, values in clean.items()}
    attrs = {"stiffness_per_load": k_stated, "apparatus": "spring_slider"}
    noiseless = _dataset(merged, "time_series", **attrs)
    merged["mu"] = merged["mu"] + np.concatenate(
        [_noise(rng, time.size, sigma, phi) for _ in FORCES]
    )
    return _dataset(merged, "time_series", **attrs), noiseless


def _twice(maker, effect: str, rng: np.random.Generator, noise: float, **kwargs):
    """(data, noiseless): the maker called on a copy of the stream without noise."""
    clean = maker(effect, copy.deepcopy(rng), 0.0, **kwargs)
    return maker(effect, rng, noise, **kwargs), clean


def steady_table(effect: str, rng: np.random.Generator) -> tuple[xr.Dataset, xr.Dataset]:
    """A steady table at :data:`TEMPERATURES` with ``effect`` (or ``none``)."""
    noise = NOISE["steady_state"] * rng.uniform(0.7, 1.4)
    return _twice(steady_case, effect, rng, noise, temperatures=TEMPERATURES)


def clamped_ramps(effect: str, rng: np.random.Generator) -> tuple[xr.Dataset, xr.Dataset]:
    """000/Fig. 3 ramps at three forces with ``effect`` (or ``none``)."""
    noise = NOISE["clamped_sample"] * rng.uniform(0.7, 1.4)
    return _twice(clamped_case, effect, rng, noise)


MAKERS = {"time_series": time_series, "steady_state": steady_table, "clamped_sample": clamped_ramps}
