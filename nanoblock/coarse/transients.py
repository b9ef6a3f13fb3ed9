"""Transients: the direct effect A from a velocity-step spike, and mu0, A, B, Dc from a full
rate-and-state fit of simulated steps or slide-hold-slide, against the expected mapping
A = alpha mu0, B = m mu0, Dc ~ D0 (001/Eqs. 16, 18, 33).

The spike: with a stiff enough drive (001/Eq. 13) the friction peaks when the slider
reaches the new velocity, before the contacts have aged or renewed, so
A = (mu_peak - mu_before) / ln(V2 / V1) (001/Eq. 12). The full fit is
:func:`nanoblock.rsf.fit.fit_rsf` on the run read as a measured time series
(:func:`nanoblock.measured.from_simulation`). The prediction uses the exact mean-field
alpha (``nanoblock.theory.meanfield.log_slope``), the secant over the step for the spike.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from nanoblock.coarse.estimates import estimate, rate_coefficient, stack
from nanoblock.coarse.runs import run_scenarios, varied
from nanoblock.coarse.steady import SETTLE, steady_level
from nanoblock.engine import mean_field_joint, protocol_table
from nanoblock.measured import from_simulation
from nanoblock.params import Scenario
from nanoblock.rsf.fit import fit_rsf
from nanoblock.rsf.laws import law as rsf_law
from nanoblock.theory.meanfield import log_slope, steady_stress

__all__ = [
    "PRE_STEP",
    "SPIKE_WINDOW",
    "fit_transient",
    "measure_steps",
    "spike",
    "with_memory_length",
]

PRE_STEP = 0.1
"""The level before a step is the batch mean over the last PRE_STEP D0 of travel before it
(short, so that the slow fluctuation of the contact area, correlated over D0, cancels
between level and peak)."""

SPIKE_WINDOW = 0.3
"""The peak is searched within SPIKE_WINDOW D0 of load-point travel after the step."""

START_DC = 0.5
"""Fits start from Dc = START_DC D0, the aging-law Dc that matches the renewal model's
linearised response ln(1 + s/r)/(s/r) (r = V/D0) to first order. The memory lengths are
not gridded: a grid down to a few rho~_max finds a spurious minimum there (the direct
effect's own relaxation over the activation length, 001/Eq. 38), where the fitted law
is too stiff to integrate."""


def _segment(scenario: Scenario, step: int) -> tuple[float, float, float]:
    """Load-point position [m] where segment ``step`` starts, and the velocities [m/s]
    before and after it."""
    _, velocities, positions = protocol_table(scenario)
    if not 1 <= step < len(scenario.loading.steps):
        raise ValueError(
            f"step {step}: the protocol has segments 1..{len(scenario.loading.steps) - 1}"
        )
    return float(positions[step]), float(velocities[step - 1]), float(velocities[step])


def spike(run: xr.Dataset, step: int = 1) -> xr.Dataset:
    """The direct effect A from the friction spike at the start of segment ``step``
    (001/Eq. 12), against alpha mu_before with the exact mean-field secant alpha.

    Variables: ``mu_before``, ``peak`` and ``a`` with stderr (level noise and the
    sample-to-sample noise at the peak), ``a_theory`` = mu_before ln(sigma_s(V2) /
    sigma_s(V1)) / ln(V2/V1) (001/Eqs. 16, 28 at constant state) and ``a_eq30`` =
    alpha mu_before with 001/Eq. 30's alpha = 1/2u.
    """
    scenario = Scenario.from_json(run.attrs["scenario"])
    where, v1, v2 = _segment(scenario, step)
    if v1 <= 0.0 or v2 <= 0.0:
        raise ValueError("a velocity-step spike needs sliding on both sides of the step")
    d0 = scenario.interface.memory_length
    travel = run["load_point_displacement"].values
    mu = run["friction_coefficient"].values
    before, before_err = steady_level(run, where - PRE_STEP * d0, where)
    window = (travel > where) & (travel <= where + SPIKE_WINDOW * d0)
    peak = float(mu[window].max() if v2 > v1 else mu[window].min())
    prior = mu[(travel >= where - PRE_STEP * d0) & (travel <= where)]
    noise = float(np.std(np.diff(prior), ddof=1) / math.sqrt(2.0))
    jump = math.log(v2 / v1)
    joint = mean_field_joint(scenario)
    secant = math.log(float(steady_stress(v2, joint) / steady_stress(v1, joint))) / jump
    return xr.Dataset(
        {
            **estimate("mu_before", before, before_err, "1", "friction before the step"),
            **estimate("peak", peak, noise, "1", "friction at the spike"),
            **rate_coefficient(
                (before, before_err),
                (peak, noise),
                v2 / v1,
                "direct effect A from the spike (001/Eq. 12)",
            ),
            "a_theory": xr.Variable(
                (),
                secant * before,
                {"units": "1", "long_name": "alpha mu, exact secant alpha (001/Eqs. 16, 28)"},
            ),
            "a_eq30": xr.Variable(
                (), joint.alpha * before, {"units": "1", "long_name": "alpha mu, 001/Eq. 30 alpha"}
            ),
        },
        attrs={"v1": v1, "v2": v2, "step": step},
    )


def fit_transient(
    run: xr.Dataset,
    law: str = "slip",
    settle: float = SETTLE,
    hold: Mapping[str, float] | None = None,
) -> xr.Dataset:
    """mu0, A, B, Dc of ``law`` fitted to a simulated run (velocity steps, slide-hold-slide)
    through the measured-data path, after ``settle`` rho~_max of travel; against the
    expected mapping at the first velocity V: A = alpha mu_ss (exact alpha, 001/Eq. 16),
    B = m sigma_s / p (001/Eqs. 5, 16: the state effect acts on the area at birth),
    Dc = D0. ``hold`` fixes law parameters at given values (e.g. ``{"a": A}`` with A
    from a spike, as experimenters do with 001/Eq. 12); their stderr is 0. The search
    starts from Dc = :data:`START_DC` D0 and grids only A (see there). ``mu_fit``
    (dim ``sample``, coordinate ``load_point_displacement``) is the fitted friction at the
    fitted samples."""
    scenario = Scenario.from_json(run.attrs["scenario"])
    data = from_simulation(run)
    data = data.isel(sample=data.load_point_displacement.values >= settle * scenario.joint.rho_max)
    held = dict(hold or {})
    model = rsf_law(law)
    free = [name for name in model.default_free if name not in held]
    start = dict(held)
    if math.isfinite(scenario.interface.memory_length):
        for name in {"dc", "d0"} & set(free):
            start[name] = START_DC * scenario.interface.memory_length
    search = [name for name in free if name == "a"]
    result = fit_rsf(data, law, free=free, initial=start, search=search)
    joint = mean_field_joint(scenario)
    interface = scenario.interface
    velocity = scenario.loading.first_velocity
    bare = float(steady_stress(velocity, joint)) / interface.hardness
    mu0 = result.contract["mu0"]
    units = {"mu0": "1", "a": "1", "b": "1", "dc": "m"}
    names = {"mu0": "mu0", "a": "direct effect A", "b": "state effect B", "dc": "memory length Dc"}
    data_vars = {}
    for key in units:
        error = 0.0 if key in held else result.contract_stderr[key]
        data_vars.update(
            estimate(
                key,
                result.contract[key],
                np.inf if error is None else error,
                units[key],
                f"fitted {names[key]} ({law} law)",
            )
        )
    predicted = {
        "a_theory": (
            float(log_slope(velocity, joint)) * mu0,
            "alpha mu0, exact alpha (001/Eq. 16)",
        ),
        "b_theory": (interface.aging_m * bare, "m sigma_s / p (001/Eqs. 5, 16)"),
        "dc_theory": (interface.memory_length, "D0 (001/Eq. 3)"),
    }
    for key, (value, long_name) in predicted.items():
        unit = "m" if key == "dc_theory" else "1"
        data_vars[key] = xr.Variable((), value, {"units": unit, "long_name": long_name})
    data_vars["rms_residual"] = xr.Variable(
        (), result.rms_residual, {"units": "1", "long_name": "rms residual of the fit"}
    )
    data_vars["mu_fit"] = xr.Variable(
        ("sample",), result.model[0], {"units": "1", "long_name": f"fitted friction ({law} law)"}
    )
    travel = xr.Variable(
        ("sample",),
        data.load_point_displacement.values,
        {"units": "m", "long_name": "load-point displacement"},
    )
    return xr.Dataset(
        data_vars, {"load_point_displacement": travel}, {"law": law, "velocity": velocity}
    )


def with_memory_length(base: Scenario, memory_length: float) -> Scenario:
    """``base`` with D0 = ``memory_length`` [m] and its protocol stretched alike (segment
    displacements, durations, holds and the sampling interval times D0 / D0_base): the
    same experiment in units of D0."""
    ratio = memory_length / base.interface.memory_length
    steps = [
        {
            key: value * ratio if key != "velocity" else value
            for key, value in step.items()
            if value is not None
        }
        for step in base.model_dump()["loading"]["steps"]
    ]
    changes = {
        "interface.memory_length": memory_length,
        "loading.steps": steps,
        "run.record_every": base.run.record_every * ratio,
    }
    return varied(base, changes)


def measure_steps(
    base: Scenario,
    key: str,
    values: ArrayLike,
    law: str = "slip",
    *,
    directory: str | Path | None = None,
    workers: int | None = None,
) -> xr.Dataset:
    """Fit ``law`` to runs of ``base`` with one scenario key varied (D0 via
    ``interface.memory_length`` keeps the protocol in units of D0, :func:`with_memory_length`).

    Returns the scalar :func:`fit_transient` variables over a dim named after the key."""
    values = np.asarray(values, dtype=float)
    if key == "interface.memory_length":
        scenarios = [with_memory_length(base, float(v)) for v in values]
    else:
        scenarios = [varied(base, {key: float(v)}) for v in values]
    runs = run_scenarios(scenarios, directory, workers=workers)
    fits = [
        fit_transient(run, law).drop_vars(["mu_fit", "load_point_displacement"]) for run in runs
    ]
    return stack(fits, key, values)
