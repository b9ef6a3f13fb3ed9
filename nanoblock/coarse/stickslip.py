"""The stick-slip bifurcation: onset stiffness (K/W)_c and pulsation from a stiffness sweep.

Each run slides steadily, then a small load-point velocity step sets off an oscillation
of the friction. Where steady sliding is stable the oscillation decays: a least-squares
fit of mu(t) = c + exp(lambda t) (a cos(omega t) + b sin(omega t)) gives its growth rate
lambda < 0 and pulsation omega. Where it is not, the oscillation grows until the slider
sticks (its velocity falls below :data:`STICK` of the drive's). The onset is where a line
through lambda(K/W) of the softest stable runs crosses zero (the Hopf bifurcation, 001/Eq. 9:
(K/W)_c = (B - A) / Dc for rate-and-state), and the pulsation there is read off a line
through omega(K/W) (001/Eq. 10: Omega_c = (V / Dc) sqrt((B - A) / A)).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy.optimize import brentq, least_squares

from nanoblock.coarse.estimates import estimate, fit_line, stack
from nanoblock.coarse.runs import run_scenarios, varied
from nanoblock.engine import protocol_table
from nanoblock.params import Scenario

__all__ = ["STICK", "measure_onset", "oscillation", "renewal_onset", "stick_slip_onset"]

STICK = 0.05
"""The slider sticks when its velocity falls below STICK times the load-point velocity."""

SKIP_PERIOD = 0.5
"""The fit window starts this many guessed periods after the step (the direct effect and
the fastest transients are over by then)."""

NEAREST = 2
"""Runs used for the onset line: the softest stable ones. Near the onset lambda(K) is close
to linear and well measured; far above it the ringing dies within a period."""

WINDOW_PERIODS = 3.0
"""The fit window lasts at most this many guessed periods (a strongly damped ringing is
gone by then, and what follows is noise)."""


def _basis(t: np.ndarray, growth: float, pulsation: float) -> np.ndarray:
    decay = np.exp(growth * t)
    return np.column_stack(
        [np.ones_like(t), decay * np.cos(pulsation * t), decay * np.sin(pulsation * t)]
    )


def _damped_fit(t: np.ndarray, mu: np.ndarray, pulsation: float) -> tuple[np.ndarray, np.ndarray]:
    """(lambda, omega) of c + e^(lambda t) (a cos omega t + b sin omega t) by variable
    projection (c, a, b linear), omega within 0.3-3 and |lambda| within 3 times the guessed
    pulsation, and their standard errors: the Jacobian's, inflated by (1 + r) / (1 - r) for
    a lag-1 autocorrelation r of the residuals."""
    t = t - t[0]

    def residual(x: np.ndarray) -> np.ndarray:
        design = _basis(t, x[0], x[1])
        return design @ np.linalg.lstsq(design, mu, rcond=None)[0] - mu

    bounds = ([-3.0 * pulsation, 0.3 * pulsation], [3.0 * pulsation, 3.0 * pulsation])
    best = None
    for guess in pulsation * np.array([0.6, 1.0, 1.6]):
        trial = least_squares(residual, [0.0, guess], x_scale=[guess, guess], bounds=bounds)
        if best is None or trial.cost < best.cost:
            best = trial
    r = best.fun
    lag = float(np.corrcoef(r[1:], r[:-1])[0, 1]) if r.size > 3 else 0.0
    inflation = (1.0 + lag) / (1.0 - lag) if -1.0 < lag < 1.0 else math.inf
    variance = float(r @ r) / max(r.size - 5, 1) * inflation
    covariance = np.linalg.pinv(best.jac.T @ best.jac) * variance
    return best.x, np.sqrt(np.diag(covariance))


def oscillation(run: xr.Dataset, step: int = 1, period_guess: float | None = None) -> xr.Dataset:
    """Growth rate and pulsation of the friction oscillation after the load-point velocity
    step at the start of segment ``step``.

    ``period_guess`` [s] seeds the fit (default: 1.7 D0 / V, the model's period near the
    onset). Variables: ``growth`` [1/s] and ``pulsation`` [rad/s] with stderr (NaN if the
    slider sticks), ``sticks`` (1 if the slider velocity falls below :data:`STICK` V).
    """
    scenario = Scenario.from_json(run.attrs["scenario"])
    starts, velocities, _ = protocol_table(scenario)
    velocity = float(velocities[step])
    if period_guess is None:
        period_guess = 1.7 * scenario.interface.memory_length / velocity
    time = run["time"].values
    after = time > starts[step]
    sticks = bool(np.any(run["slider_velocity"].values[after] < STICK * velocity))
    begin = starts[step] + SKIP_PERIOD * period_guess
    window = (time > begin) & (time < begin + WINDOW_PERIODS * period_guess)
    if sticks or window.sum() < 10:
        values, errors = np.full(2, np.nan), np.full(2, np.nan)
    else:
        mu = run["friction_coefficient"].values[window]
        values, errors = _damped_fit(time[window], mu, 2.0 * math.pi / period_guess)
    return xr.Dataset(
        {
            **estimate(
                "growth", values[0], errors[0], "1/s", "growth rate lambda of the oscillation"
            ),
            **estimate(
                "pulsation", values[1], errors[1], "rad/s", "pulsation omega of the oscillation"
            ),
            "sticks": xr.Variable(
                (), int(sticks), {"units": "1", "long_name": "the slider sticks"}
            ),
            "velocity": xr.Variable(
                (), velocity, {"units": "m/s", "long_name": "load-point velocity"}
            ),
        }
    )


def stick_slip_onset(
    oscillations: xr.Dataset, key: str = "loading.stiffness", nearest: int = NEAREST
) -> xr.Dataset:
    """(K/W)_c [1/m] and the pulsation there from the :func:`oscillation` results of a
    stiffness sweep (dim ``key``, the drive stiffness K [N/m]; K/W from the scenario).

    The onset is the zero of a weighted line through lambda(K/W) of the ``nearest`` runs
    closest above it (the softest that do not stick; at least two), its error by the
    delta method; the pulsation at onset is that line's companion through omega(K/W).
    ``stiffness_per_load_stick`` is the stiffest run that sticks (NaN if none) and
    ``stiffness_per_load_stable`` the softest that does not: the measured bracket.
    """
    normal_force = float(oscillations.attrs["normal_force"])
    per_load = oscillations[key].values / normal_force
    stable = np.flatnonzero(oscillations.sticks.values == 0)
    if stable.size < 2:
        raise ValueError(
            "the onset needs at least two stiffnesses at which the slider does not stick"
        )
    used = stable[np.argsort(per_load[stable])[:nearest]]
    growth = fit_line(
        per_load[used], oscillations.growth.values[used], oscillations.growth_stderr.values[used]
    )
    onset, onset_err = growth.root()
    pulsation = fit_line(
        per_load[used],
        oscillations.pulsation.values[used],
        oscillations.pulsation_stderr.values[used],
    )
    at_onset = pulsation.intercept + pulsation.slope * onset
    gradient = np.array([1.0, onset])
    at_onset_err = math.hypot(
        math.sqrt(float(gradient @ pulsation.covariance @ gradient)), pulsation.slope * onset_err
    )
    sticking = np.delete(per_load, stable)
    return xr.Dataset(
        {
            **estimate("stiffness_per_load_c", onset, onset_err, "1/m", "stick-slip onset (K/W)_c"),
            **estimate("pulsation_c", at_onset, at_onset_err, "rad/s", "pulsation at the onset"),
            "stiffness_per_load_stick": xr.Variable(
                (),
                float(sticking.max()) if sticking.size else np.nan,
                {"units": "1/m", "long_name": "stiffest K/W at which the slider sticks"},
            ),
            "stiffness_per_load_stable": xr.Variable(
                (),
                float(per_load[stable].min()),
                {"units": "1/m", "long_name": "softest K/W at which the slider does not stick"},
            ),
        }
    )


def measure_onset(
    base: Scenario,
    stiffness: ArrayLike,
    *,
    directory: str | Path | None = None,
    workers: int | None = None,
) -> tuple[xr.Dataset, xr.Dataset]:
    """Run ``base`` (steady sliding, then a small velocity step) at each drive stiffness K
    [N/m] and return the per-run :func:`oscillation` Dataset (dim ``loading.stiffness``)
    and the :func:`stick_slip_onset`."""
    stiffness = np.asarray(stiffness, dtype=float)
    scenarios = [varied(base, {"loading.stiffness": float(k)}) for k in stiffness]
    runs = run_scenarios(scenarios, directory, workers=workers)
    key = "loading.stiffness"
    results = stack([oscillation(run) for run in runs], key, stiffness)
    results.attrs["normal_force"] = base.interface.normal_force
    return results, stick_slip_onset(results, key)


def renewal_onset(a: float, b: float, memory_length: float) -> tuple[float, float]:
    """(K/W)_c [1/m] and the onset pulsation in units of V/D0 from the linear theory of the
    renewal model: contacts die at rate r = V/D0 per unit time and the area term of the
    friction, b E[ln(age)], responds to ln V through -ln(1 + s/r) / (s/r) (the aging law's
    response is -1/(1 + s Dc/V)). The quasi-static Hopf condition
    s A - B r ln(1 + s/r) + (K/W) V = 0 at s = i y r gives atan(y)/y = A/B and
    (K/W)_c D0 = (B/2) ln(1 + y^2) (compare 001/Eqs. 9-10). Needs 0 < A < B."""
    if not 0.0 < a < b:
        raise ValueError(f"the renewal onset needs 0 < A < B, got A = {a!r}, B = {b!r}")
    y = brentq(lambda z: math.atan(z) / z - a / b, 1e-9, 1e9)
    return 0.5 * b * math.log1p(y * y) / memory_length, y
