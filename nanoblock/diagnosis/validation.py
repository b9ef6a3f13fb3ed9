"""Refusing data that cannot support a diagnosis, with what data would.

A diagnosis compares a model's residuals with the noise of the data and asks which
physical effect removes a systematic misfit; it needs enough samples, a change of
velocity (or load) to see a rate or state effect, a signal that varies, measurable noise,
and complete rows. Anything else is refused with a :class:`DiagnosisError` that names the
problem and the data that would be needed, instead of a guess.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import xarray as xr

from nanoblock.measured import DataError, DroppedRowsWarning, load_measurement
from nanoblock.rsf.fit import prepare_runs

MIN_RUN_SAMPLES = 50
"""Samples per run of a time series or clamped-sample curve."""
MIN_TABLE_ROWS = 8
"""Rows of a steady-state table."""
MIN_TABLE_VELOCITIES = 4
"""Distinct velocities of a steady-state table."""
MIN_TABLE_DECADES = 1.0
"""Velocity span of a steady-state table [decades]."""

_SIGNAL = {"time_series": "mu", "clamped_sample": "s", "steady_state": "mu"}


class DiagnosisError(DataError):
    """Data that cannot support a diagnosis (the message says what data would)."""


def load_for_diagnosis(
    path: str | Path,
    *,
    recipe: str | Path | None = None,
    rows: tuple[int, int] | None = None,
) -> xr.Dataset:
    """Read a measured-data file (or simulator store; an xlook binary with its ``recipe``
    and ``rows``); rows with missing values are refused rather than dropped, since the
    noise estimate needs the record as measured."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", DroppedRowsWarning)
        try:
            return load_measurement(path, recipe=recipe, rows=rows)
        except DroppedRowsWarning as warning:
            raise DiagnosisError(
                f"{warning}. A diagnosis needs complete rows: remove or repair the rows with "
                "missing (NaN) values, then run it again"
            ) from None
        except DataError as error:
            if "missing (NaN)" in str(error):
                raise DiagnosisError(f"{error}. A diagnosis needs complete rows") from None
            raise


def check_diagnosable(data: xr.Dataset) -> None:
    """Raise :class:`DiagnosisError` unless ``data`` can support a diagnosis."""
    kind = data.attrs.get("kind")
    if kind not in _SIGNAL:
        raise DiagnosisError(f"unknown data kind {kind!r}; read the file with load_measurement")
    for name, variable in data.data_vars.items():
        values = np.asarray(variable.values, dtype=float)
        if not np.all(np.isfinite(values)):
            row = int(np.flatnonzero(~np.isfinite(values))[0]) + 1
            raise DiagnosisError(
                f"column {name!r} has a missing or infinite value at data row {row}; a "
                "diagnosis needs complete rows"
            )
    signal = data[_SIGNAL[kind]].values
    if np.ptp(signal) == 0.0:
        raise DiagnosisError(
            f"the signal {_SIGNAL[kind]!r} is constant: there is nothing to diagnose. "
            "Record friction through a velocity step, a hold or a load change"
        )
    if kind == "steady_state":
        _check_table(data)
    else:
        _check_runs(data, kind)


def _check_table(data: xr.Dataset) -> None:
    velocity = data["load_point_velocity"].values
    distinct = np.unique(velocity)
    decades = float(np.log10(distinct.max() / distinct.min()))
    if (
        velocity.size < MIN_TABLE_ROWS
        or distinct.size < MIN_TABLE_VELOCITIES
        or decades < MIN_TABLE_DECADES
    ):
        raise DiagnosisError(
            f"a steady-state table of {velocity.size} rows at {distinct.size} velocities "
            f"spanning {decades:.1f} decades cannot separate the base model from its "
            f"extensions: it needs at least {MIN_TABLE_ROWS} rows at {MIN_TABLE_VELOCITIES} "
            f"or more velocities spanning {MIN_TABLE_DECADES:g} decade or more (the "
            "catalogue's signatures are curvatures of mu_ss against ln V)"
        )


def _check_runs(data: xr.Dataset, kind: str) -> None:
    sizes = _run_sizes(data, kind)
    if min(sizes) < MIN_RUN_SAMPLES:
        raise DiagnosisError(
            f"a run has only {min(sizes)} samples; a diagnosis needs at least "
            f"{MIN_RUN_SAMPLES} per run to estimate the noise and test residuals for structure"
        )
    if kind == "time_series":
        segments = max(run.history.starts.size for run in prepare_runs(data))
        if segments < 2:
            raise DiagnosisError(
                "the load point moves at one velocity only: steady sliding at a single rate "
                "carries no rate or state information. A diagnosis needs a velocity step, a "
                "slide-hold-slide, or a steady-state table over several velocities"
            )


def _run_sizes(data: xr.Dataset, kind: str) -> list[int]:
    if "run" in data:
        return [int(n) for n in np.unique(data["run"].values, return_counts=True)[1]]
    if kind == "clamped_sample" and "normal_force" in data:
        return [int(n) for n in np.unique(data["normal_force"].values, return_counts=True)[1]]
    return [data.sizes["sample"]]
