"""Estimates with uncertainties: batch means of correlated series, weighted straight lines,
and the (value, stderr) variable pairs every coarse-grained Dataset is made of."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from nanoblock.sweep import key_attrs

__all__ = ["Line", "batch_mean", "estimate", "fit_line", "rate_coefficient", "stack"]

BATCHES = 10
"""Default number of batches of :func:`batch_mean`."""


def batch_mean(values: ArrayLike, n_batches: int = BATCHES) -> tuple[float, float]:
    """Mean of a correlated series and its standard error by batch means (block averaging).

    The series is cut into ``n_batches`` consecutive batches; if they are longer than its
    correlation length, their means are independent and the standard error is their
    standard deviation over sqrt(n_batches). Leftover samples at the start are dropped.
    """
    values = np.asarray(values, dtype=float)
    size = values.size // n_batches
    if n_batches < 2 or size < 1:
        raise ValueError(f"{values.size} samples cannot be cut into {n_batches} >= 2 batches")
    batches = values[values.size - size * n_batches :].reshape(n_batches, size).mean(axis=1)
    return float(batches.mean()), float(batches.std(ddof=1) / math.sqrt(n_batches))


@dataclass(frozen=True)
class Line:
    """y = intercept + slope x fitted by weighted least squares, with its covariance."""

    intercept: float
    slope: float
    covariance: np.ndarray
    """2 x 2 covariance of (intercept, slope)."""
    chi2: float
    """Sum of squared standardised residuals (n - 2 degrees of freedom)."""

    @property
    def intercept_stderr(self) -> float:
        return math.sqrt(self.covariance[0, 0])

    @property
    def slope_stderr(self) -> float:
        return math.sqrt(self.covariance[1, 1])

    def root(self) -> tuple[float, float]:
        """x where the line crosses zero, and its standard error (delta method)."""
        x0 = -self.intercept / self.slope
        gradient = np.array([-1.0 / self.slope, self.intercept / self.slope**2])
        return x0, math.sqrt(float(gradient @ self.covariance @ gradient))


def fit_line(x: ArrayLike, y: ArrayLike, stderr: ArrayLike) -> Line:
    """Weighted least-squares line through (x, y +- stderr); the covariance is the
    propagated one, scaled up by chi2 / (n - 2) when the scatter exceeds the errors."""
    x, y, stderr = (np.asarray(v, dtype=float) for v in (x, y, stderr))
    if x.size < 2:
        raise ValueError("a line needs at least two points")
    design = np.column_stack([np.ones_like(x), x]) / stderr[:, None]
    coefficients, *_ = np.linalg.lstsq(design, y / stderr, rcond=None)
    residual = (y - coefficients[0] - coefficients[1] * x) / stderr
    chi2 = float(residual @ residual)
    covariance = np.linalg.inv(design.T @ design)
    if x.size > 2:
        covariance *= max(1.0, chi2 / (x.size - 2))
    return Line(float(coefficients[0]), float(coefficients[1]), covariance, chi2)


def estimate(
    name: str,
    value: ArrayLike,
    stderr: ArrayLike,
    units: str,
    long_name: str,
    dims: Sequence[str] = (),
) -> dict[str, xr.Variable]:
    """The pair ``name`` and ``name_stderr`` as Dataset variables with units and long names."""
    return {
        name: xr.Variable(
            dims, np.asarray(value, dtype=float), {"units": units, "long_name": long_name}
        ),
        f"{name}_stderr": xr.Variable(
            dims,
            np.asarray(stderr, dtype=float),
            {"units": units, "long_name": f"standard error of {long_name}"},
        ),
    }


def stack(results: Sequence[xr.Dataset], key: str, values: ArrayLike) -> xr.Dataset:
    """Per-run result Datasets stacked along a dim named after the scenario ``key``, with
    coordinate ``values`` carrying the key's units and long name."""
    coord = xr.Variable((key,), np.asarray(values, dtype=float), key_attrs(key))
    stacked = xr.concat(list(results), dim=key, combine_attrs="drop_conflicts")
    return stacked.assign_coords({key: coord})


def rate_coefficient(
    before: tuple[float, float], after: tuple[float, float], ratio: float, long_name: str
) -> dict[str, xr.Variable]:
    """``a`` = (after - before) / ln(ratio) and its stderr from two (value, stderr) levels
    of the friction coefficient across a velocity change by ``ratio`` (001/Eq. 12)."""
    jump = math.log(ratio)
    value = (after[0] - before[0]) / jump
    return estimate("a", value, math.hypot(before[1], after[1]) / abs(jump), "1", long_name)
