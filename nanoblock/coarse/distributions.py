"""Distributions over the agents: block stresses P(sigma), drive coordinates Q(rho~) and
contact ages, from block snapshots (:func:`nanoblock.snapshots.open_snapshots`), against
the mean-field Q_st (001/Eq. 27) and the renewal law of ages (Exp with mean D0 / V,
001/Eq. 3) in steady sliding.

Densities are pooled over the chosen snapshots; their standard errors are the scatter of
the densities of consecutive batches of snapshots (Poisson counting when there is only
one snapshot).
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from nanoblock.coarse.estimates import estimate
from nanoblock.engine import mean_field_joint
from nanoblock.params import Scenario
from nanoblock.snapshots import steady_window
from nanoblock.theory.meanfield import q_stationary

__all__ = ["BINS", "age_distribution", "stress_distribution", "window"]

BINS = 40
"""Default number of histogram bins."""

_BATCHES = 10


def window(snaps: xr.Dataset, scenario: Scenario) -> tuple[np.ndarray, float | None]:
    """Snapshots to pool: those in steady sliding (:func:`nanoblock.snapshots.steady_window`)
    and their velocity [m/s], or all of them and None when there are none."""
    found = steady_window(scenario, snaps.time.values)
    if found is None:
        return np.ones(snaps.sizes["time"], dtype=bool), None
    return found


def _densities(values: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pooled density over the first axis (snapshots) and its standard error."""
    n = values.shape[0]
    pooled = np.histogram(values.ravel(), bins=edges)[0]
    width = np.diff(edges)
    density = pooled / max(pooled.sum(), 1) / width
    if n < 2:
        return density, np.sqrt(pooled) / max(pooled.sum(), 1) / width
    groups = np.array_split(np.arange(n), min(_BATCHES, n))
    per_batch = []
    for group in groups:
        counts = np.histogram(values[group].ravel(), bins=edges)[0]
        per_batch.append(counts / max(counts.sum(), 1) / width)
    return density, np.std(per_batch, axis=0, ddof=1) / math.sqrt(len(groups))


def stress_distribution(snaps: xr.Dataset, scenario: Scenario, bins: int = BINS) -> xr.Dataset:
    """P(sigma) [1/Pa] and Q(rho~) [1/m] (rho~ = b^2 sigma / k1) of the block stresses
    pooled over the :func:`window` snapshots, with standard errors, and the mean-field
    Q_st of 001/Eq. 27 at the window's velocity (NaN where it does not apply: not a
    mean-field reset joint, or no steady window). Dim ``stress`` (bin centres [Pa])."""
    mask, velocity = window(snaps, scenario)
    joint = scenario.joint
    stress = snaps.block_stress.isel(time=np.flatnonzero(mask)).values
    stress = stress.reshape(stress.shape[0], -1)
    low = min(0.0, float(stress.min()))
    edges = np.linspace(low, joint.threshold_stress, bins + 1)
    density, error = _densities(stress, edges)
    centres = 0.5 * (edges[1:] + edges[:-1])
    to_rho = joint.block_size**2 / joint.k1  # rho~ per unit stress [m/Pa]
    mean_field = joint.slip == "reset" and joint.k2 == 0.0 and velocity is not None
    theory = np.full(bins, np.nan)
    if mean_field:
        theory = q_stationary(
            np.clip(centres, 0.0, None) * to_rho, velocity, mean_field_joint(scenario)
        )
    dims = ("stress",)
    data_vars = {
        **estimate("p_sigma", density, error, "1/Pa", "block stress density P(sigma)", dims),
        **estimate(
            "q_rho",
            density / to_rho,
            error / to_rho,
            "1/m",
            "drive coordinate density Q(rho~)",
            dims,
        ),
        "q_theory": xr.Variable(
            dims, theory, {"units": "1/m", "long_name": "mean-field Q_st (001/Eq. 27)"}
        ),
    }
    coords = {
        "stress": (
            "stress",
            centres,
            {"units": "Pa", "long_name": "block stress sigma (bin centre)"},
        ),
        "rho": ("stress", centres * to_rho, {"units": "m", "long_name": "rho~ = b^2 sigma / k1"}),
    }
    attrs = {"snapshots": int(mask.sum()), "velocity": np.nan if velocity is None else velocity}
    return xr.Dataset(data_vars, coords, attrs)


def age_distribution(snaps: xr.Dataset, scenario: Scenario, bins: int = BINS) -> xr.Dataset:
    """Density of contact ages [1/s] pooled over the :func:`window` snapshots, with standard
    errors, against the steady renewal law (V / D0) exp(-age V / D0) (001/Eq. 3; NaN
    without a steady window). Dim ``age`` (bin centres [s])."""
    mask, velocity = window(snaps, scenario)
    ages = snaps.contact_age.isel(time=np.flatnonzero(mask)).values
    edges = np.linspace(0.0, max(float(ages.max()), 1e-300), bins + 1)
    density, error = _densities(ages, edges)
    centres = 0.5 * (edges[1:] + edges[:-1])
    rate = np.nan if velocity is None else velocity / scenario.interface.memory_length
    dims = ("age",)
    return xr.Dataset(
        {
            **estimate("density", density, error, "1/s", "contact age density", dims),
            "density_theory": xr.Variable(
                dims,
                rate * np.exp(-rate * centres),
                {"units": "1/s", "long_name": "(V/D0) exp(-age V/D0) (001/Eq. 3)"},
            ),
        },
        {"age": ("age", centres, {"units": "s", "long_name": "contact age (bin centre)"})},
        {"snapshots": int(mask.sum()), "velocity": np.nan if velocity is None else velocity},
    )
