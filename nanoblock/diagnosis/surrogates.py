"""Fitting the base model and its catalogue extensions to one kind of data.

A :class:`Dataset` adapter gives every kind of data (physics.md section 6) the same face:
observed signals per run (or per temperature of a table), the covariates residuals are
tested against, held-out folds, and ``fit(surrogate, holdout, start)`` returning a
:class:`Fit` whose model covers every sample (held-out ones included).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from nanoblock.diagnosis.catalogue import RsfVariant, Surrogate
from nanoblock.diagnosis.statistics import blocked_folds, leave_one_run_out
from nanoblock.diagnosis.steady import SteadyTable, SteadyVariant, fit_steady
from nanoblock.measured import DataError, runs
from nanoblock.rsf.fit import RunData, fit_rsf, prepare_runs, split_by_force

FloatArray = NDArray[np.float64]
Masks = list[NDArray[np.bool_]]

N_FOLDS = 4
"""Cross-validation folds when there are too few runs to hold out whole ones."""
BLOCK_LENGTH = {"time_series": 10, "clamped_sample": 10, "steady_state": 1}
"""Samples per held-out block (blocked cross-validation; a table row is its own block)."""


@dataclass(frozen=True)
class Fit:
    """A fitted surrogate: parameters (SI), standard errors, free-parameter count, and the
    model for every run (held-out samples included)."""

    params: dict[str, float]
    stderr: dict[str, float]
    n_free: int
    model: list[FloatArray]
    start: dict[str, float]
    """Parameters to warm-start a refit from."""
    law: str = ""
    """The RSF law fitted (empty for a steady-state table)."""


def _clean(values: Mapping[str, float | None]) -> dict[str, float]:
    return {k: float(v) for k, v in values.items() if v is not None}


class Measurement:
    """One measured (or simulated) record, ready for the diagnosis."""

    def __init__(self, data: xr.Dataset) -> None:
        self.data = data
        self.kind: str = data.attrs["kind"]
        if self.kind == "steady_state":
            self._table, self._groups = _steady_table(data)
            self.observed = np.split(self._table.mu, self._groups)
        elif self.kind == "clamped_sample":
            self.observed = [part["s"].values for part in self._parts()]
        else:
            self.prepared = prepare_runs(data)
            self.observed = [run.mu for run in self.prepared]
        self.covariates = self._covariates()

    @property
    def sizes(self) -> list[int]:
        return [y.size for y in self.observed]

    @property
    def signal_label(self) -> str:
        return "sample extension s (m)" if self.kind == "clamped_sample" else "friction mu"

    def distinct(self, column: str) -> int:
        """Number of distinct values of a column (or 1 when it is absent)."""
        if column in self.data:
            return int(np.unique(self.data[column].values).size)
        return 1

    def folds(self) -> list[Masks]:
        """Held-out folds: whole runs when there are 3 or more (runs at other loads,
        temperatures or protocols); for fewer runs of a time series a forecast, the
        second half of every segment after the first (a step's relaxation, a hold, a
        reload) predicted from the record up to its middle, since interleaved blocks
        reward interpolation; else blocked folds: contiguous blocks spread over every
        run, so that each fold still sees every step, hold and velocity range."""
        if len(self.observed) >= 3:
            return leave_one_run_out(self.sizes)
        if self.kind == "time_series":
            return [[forecast_mask(run) for run in self.prepared]]
        return blocked_folds(self.sizes, N_FOLDS, BLOCK_LENGTH[self.kind])

    def _covariates(self) -> dict[str, list[FloatArray]]:
        """Columns that residuals are tested against, split like ``observed``."""
        if self.kind == "steady_state":
            table = self._table
            return {
                "ln_velocity": np.split(np.log(table.velocity), self._groups),
                "temperature": np.split(table.temperature, self._groups),
            }
        parts = self._parts()
        out = {"time": [p["time"].values for p in parts]}
        for name in ("load_point_displacement", "s_ext", "normal_force", "temperature"):
            if name in self.data:
                out[name] = [p[name].values for p in parts]
        return out

    def _parts(self) -> list[xr.Dataset]:
        """The record split into runs (a clamped-sample file without runs: by load)."""
        if self.kind == "clamped_sample" and "run" not in self.data:
            return split_by_force(self.data)
        return runs(self.data)

    def fit(
        self,
        surrogate: Surrogate,
        holdout: Masks | None = None,
        start: Mapping[str, float] | None = None,
    ) -> Fit:
        """Fit ``surrogate``; ``holdout`` hides samples; ``start`` warm-starts the fit
        (a refit, or an extension from the base fit: its new parameters are gridded)."""
        if isinstance(surrogate, SteadyVariant):
            mask = None if holdout is None else np.concatenate(holdout)
            result = fit_steady(surrogate, self._table, mask, start)
            free = surrogate.names
            return Fit(
                result.params, result.stderr, len(free),
                np.split(result.model, self._groups), result.params,
            )  # fmt: skip
        assert isinstance(surrogate, RsfVariant)
        result = fit_rsf(
            self.data, surrogate.law, trend=surrogate.trend,
            load_exponent=surrogate.load_exponent, fit_stiffness=surrogate.fit_stiffness,
            initial_state=surrogate.initial_state, cohesion=surrogate.cohesion, holdout=holdout,
            initial=start, search=True if start is None else surrogate.explore,
        )  # fmt: skip
        summary = result.to_json()
        return Fit(
            _clean(summary["params"]), _clean(summary["stderr"]), len(result.free),
            result.model, dict(result.params), result.law,
        )  # fmt: skip


def forecast_mask(run: RunData) -> NDArray[np.bool_]:
    """Samples in the second half (in time) of every load-point segment after the first."""
    segment = run.history.segment_at(run.time)
    held = np.zeros(run.time.size, dtype=bool)
    for k in range(1, run.history.starts.size):
        inside = segment == k
        if inside.any():
            times = run.time[inside]
            held |= inside & (run.time >= 0.5 * (times[0] + times[-1]))
    return held


def _steady_table(data: xr.Dataset) -> tuple[SteadyTable, list[int]]:
    """The table sorted by temperature then velocity, and where each temperature starts.

    The reference point is the geometric-mean velocity at the temperature closest to the
    mean (001/Eq. 28 is normalised there)."""
    velocity = data["load_point_velocity"].values.astype(float)
    mu = data["mu"].values.astype(float)
    if "temperature" in data:
        temperature = data["temperature"].values.astype(float)
    else:
        temperature = np.full(mu.size, float(data.attrs.get("temperature", 293.15)))
    order = np.lexsort((velocity, temperature))
    velocity, temperature, mu = velocity[order], temperature[order], mu[order]
    levels = np.unique(temperature)
    t_ref = float(levels[np.argmin(np.abs(levels - temperature.mean()))])
    v_ref = float(np.exp(np.mean(np.log(velocity))))
    if not math.isfinite(v_ref):
        raise DataError("load_point_velocity must be > 0 in a steady-state table")
    groups = [int(i) for i in np.flatnonzero(np.diff(temperature)) + 1]
    return SteadyTable(velocity, temperature, mu, v_ref, t_ref), groups
