"""Steady sliding: mu_ss(V) over decades of velocity, and the slope of its direct effect.

One run per velocity, all alike but for the load-point velocity (a single segment of fixed
travel, sampled every fixed slip). Each steady level is the batch mean of the friction
coefficient after a settling travel (:func:`~nanoblock.coarse.estimates.batch_mean`). The
mean-field theory of the same joint gives the friction stress sigma_s(V) (quadrature of
001/Eq. 28) and its exact log slope (``nanoblock.theory.meanfield.log_slope``), which
tends to alpha of 001/Eq. 30 only as V -> V*.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from nanoblock.coarse.estimates import BATCHES, batch_mean, estimate
from nanoblock.coarse.runs import run_scenarios, varied
from nanoblock.engine import mean_field_joint
from nanoblock.params import Scenario
from nanoblock.theory.meanfield import log_slope, steady_stress

__all__ = [
    "SETTLE",
    "direct_effect_slope",
    "measure_steady",
    "steady_curve",
    "steady_level",
    "steady_scenarios",
]

SETTLE = 20.0
"""Load-point travel skipped at the start of a steady window, in rho~_max (a steady start
and the drive spring settle within a few rho~_max)."""

SAMPLES_PER_RHO = 1.0
"""Samples per rho~_max of load-point travel in a steady run."""


def steady_level(
    run: xr.Dataset,
    start: float,
    end: float = np.inf,
    quantity: xr.DataArray | None = None,
    n_batches: int = BATCHES,
) -> tuple[float, float]:
    """Batch mean and standard error of ``quantity`` (default: the friction coefficient)
    over the samples whose load-point displacement [m] lies in [``start``, ``end``]."""
    travel = run["load_point_displacement"].values
    window = (travel >= start) & (travel <= end)
    values = run["friction_coefficient"] if quantity is None else quantity
    return batch_mean(values.values[window], n_batches)


def steady_scenarios(base: Scenario, velocities: ArrayLike, travel: float) -> list[Scenario]:
    """One steady run per velocity [m/s]: ``base`` with a single segment of ``travel`` [m]
    at that velocity, sampled every rho~_max / :data:`SAMPLES_PER_RHO` of travel."""
    spacing = base.joint.rho_max / SAMPLES_PER_RHO
    return [
        varied(
            base,
            {
                "loading.steps": [{"velocity": float(v), "displacement": travel}],
                "run.record_every": spacing / float(v),
            },
        )
        for v in np.asarray(velocities, dtype=float)
    ]


def steady_curve(runs: Sequence[xr.Dataset], settle: float = SETTLE) -> xr.Dataset:
    """mu_ss(V) from steady runs (:func:`steady_scenarios`), with the theory of their joint.

    Variables over ``velocity`` [m/s]: ``mu_ss`` and its stderr (batch means after
    ``settle`` rho~_max of travel), ``stress_ss`` [Pa] (friction force / real contact
    area, the area-weighted mean block stress) and its stderr, ``stress_theory`` [Pa]
    (sigma_s of 001/Eq. 28) and ``alpha_theory`` (its exact log slope; 001/Eq. 30's
    alpha = 1/2u only near V*). Attrs: ``v_star`` [m/s], ``alpha_eq30`` = 1/2u.
    """
    scenario = Scenario.from_json(runs[0].attrs["scenario"])
    joint = mean_field_joint(scenario)
    skip = settle * scenario.joint.rho_max
    velocities, mu, stress = [], [], []
    for run in runs:
        velocities.append(Scenario.from_json(run.attrs["scenario"]).loading.first_velocity)
        mu.append(steady_level(run, skip))
        stress.append(steady_level(run, skip, quantity=run.friction_force / run.real_contact_area))
    v = np.array(velocities)
    dims = ("velocity",)
    data_vars = {
        **estimate("mu_ss", *np.array(mu).T, "1", "steady friction coefficient", dims),
        **estimate("stress_ss", *np.array(stress).T, "Pa", "steady friction stress", dims),
        "stress_theory": xr.Variable(
            dims,
            steady_stress(v, joint),
            {"units": "Pa", "long_name": "mean-field friction stress sigma_s (001/Eq. 28)"},
        ),
        "alpha_theory": xr.Variable(
            dims,
            log_slope(v, joint),
            {"units": "1", "long_name": "exact log slope d ln sigma_s / d ln V (001/Eq. 28)"},
        ),
    }
    coords = {"velocity": ("velocity", v, {"units": "m/s", "long_name": "load-point velocity"})}
    attrs = {
        "v_star": joint.v_star,
        "alpha_eq30": joint.alpha,
        "scenario": runs[0].attrs["scenario"],
    }
    return xr.Dataset(data_vars, coords, attrs)


def direct_effect_slope(curve: xr.Dataset) -> xr.Dataset:
    """Secant slopes d mu_ss / d ln V between neighbouring velocities of a steady curve,
    against the theory: the secant of sigma_s(V) Sigma_r / W (001/Eq. 28; the whole
    steady slope when contacts do not age, m = 0) and alpha mu_ss (001/Eq. 16) with the
    exact local alpha at the geometric mid-velocity. Dim ``interval``."""
    curve = curve.sortby("velocity")
    v = curve.velocity.values
    log_v = np.log(v)
    width = np.diff(log_v)
    slope = np.diff(curve.mu_ss.values) / width
    stderr = np.hypot(curve.mu_ss_stderr.values[1:], curve.mu_ss_stderr.values[:-1]) / width
    scenario = Scenario.from_json(curve.attrs["scenario"])
    joint = mean_field_joint(scenario)
    area_per_load = 1.0 / scenario.interface.hardness  # Sigma_r / W at birth
    middle = np.exp(0.5 * (log_v[1:] + log_v[:-1]))
    mu_middle = 0.5 * (curve.mu_ss.values[1:] + curve.mu_ss.values[:-1])
    dims = ("interval",)
    data_vars = {
        **estimate("slope", slope, stderr, "1", "secant slope d mu_ss / d ln V", dims),
        "slope_theory": xr.Variable(
            dims,
            np.diff(curve.stress_theory.values) * area_per_load / width,
            {"units": "1", "long_name": "secant slope of sigma_s(V) / p (001/Eq. 28)"},
        ),
        "alpha_mu_theory": xr.Variable(
            dims,
            log_slope(middle, joint) * mu_middle,
            {
                "units": "1",
                "long_name": "alpha mu_ss, exact alpha at the mid-velocity (001/Eq. 16)",
            },
        ),
    }
    coords = {
        "velocity": (dims, middle, {"units": "m/s", "long_name": "geometric mid-velocity"}),
        "interval": ("interval", np.arange(slope.size), {"units": "1", "long_name": "interval"}),
    }
    return xr.Dataset(data_vars, coords, dict(curve.attrs))


def measure_steady(
    base: Scenario,
    velocities: ArrayLike,
    travel: float,
    *,
    settle: float = SETTLE,
    directory: str | Path | None = None,
    workers: int | None = None,
) -> xr.Dataset:
    """Run :func:`steady_scenarios` (in process, or on Dask into ``directory``) and return
    their :func:`steady_curve`."""
    runs = run_scenarios(steady_scenarios(base, velocities, travel), directory, workers=workers)
    return steady_curve(runs, settle)
