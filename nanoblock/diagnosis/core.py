"""The diagnosis: base fit, misfit against the noise, every catalogue extension fitted and
ranked out of sample, the verdict and its gain (issue 6; physics.md section 5).

Verdict rule. Let IC be the Bayesian information criterion of a fit, and the held-out
error the RMS residual of samples hidden from the fit (whole runs, or contiguous blocks).
An extension is *supported* when it lowers IC by more than ``STRONG_EVIDENCE`` (very
strong evidence; for one extra parameter a false alarm on white noise has probability
~1e-5 at 5,000 samples), predicts held-out data better than the base model, and removes
the systematic misfit (its residuals pass the structure tests) or at least half of the
base model's excess variance over the noise. The cause is the supported extension with
the lowest IC; without one, the answer is ``none`` when the base residuals are within
noise and without structure, and ``unexplained`` otherwise.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from tqdm.auto import tqdm

from nanoblock.diagnosis.catalogue import BASE, CATALOGUE, Effect, Surrogate
from nanoblock.diagnosis.statistics import (
    Structure,
    information_criterion,
    noise_level,
    structure,
)
from nanoblock.diagnosis.surrogates import Fit, Measurement
from nanoblock.diagnosis.validation import check_diagnosable

STRONG_EVIDENCE = 10.0
"""Delta IC above which an extension counts (Kass and Raftery's 'very strong')."""
EXCESS_EXPLAINED = 0.5
"""Fraction of the base model's variance in excess of the noise an extension must remove
when its own residuals still show structure."""


@dataclass
class Candidate:
    """A fitted model (the base or one extension) with its out-of-sample and IC scores."""

    id: str
    fit: Fit
    residuals: list[np.ndarray]
    information_criterion: float
    heldout_error: float
    structure: Structure

    @property
    def rms(self) -> float:
        pooled = np.concatenate(self.residuals)
        return float(np.sqrt(np.mean(pooled**2)))

    def ranking_entry(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "heldout_error": self.heldout_error,
            "information_criterion": self.information_criterion,
            "rms_residual": self.rms,
            "params": self.fit.params,
            "stderr": self.fit.stderr,
            "residual_structure": self.structure.to_json(),
        }


@dataclass
class Diagnosis:
    """What is wrong with the base model on these data, why, and what the fix gains."""

    kind: str
    noise: float
    base: Candidate
    candidates: list[Candidate]
    """Extensions fitted, best (lowest IC) first."""
    untestable: dict[str, str]
    """Catalogue ids that these data cannot test, with the data that would."""
    cause: str
    trends: dict[str, float]
    observed: list[np.ndarray] = field(repr=False)
    covariates: dict[str, list[np.ndarray]] = field(repr=False)
    signal_label: str = "friction mu"
    simulation_check: dict[str, Any] = field(default_factory=dict)

    @property
    def extended(self) -> Candidate | None:
        """The candidate named as the cause (None for ``none`` / ``unexplained``)."""
        return next((c for c in self.candidates if c.id == self.cause), None)

    @property
    def best(self) -> Candidate | None:
        """The best-ranked extension, whether or not it was accepted."""
        return self.candidates[0] if self.candidates else None

    def gain(self) -> dict[str, float | None]:
        """Held-out error ratio base / extended, residual variance explained, Delta IC
        (of the cause; of the best extension when the verdict is none/unexplained)."""
        other = self.extended or self.best
        if other is None:
            return {
                "heldout_error_ratio": None,
                "variance_explained": None,
                "delta_information_criterion": None,
            }
        return {
            "heldout_error_ratio": self.base.heldout_error / other.heldout_error,
            "variance_explained": 1.0 - other.rms**2 / self.base.rms**2,
            "delta_information_criterion": (
                self.base.information_criterion - other.information_criterion
            ),
        }

    def to_json(self) -> dict[str, Any]:
        """The ``diagnosis.json`` contract (issue 6)."""
        other = self.extended or self.best
        return {
            "cause": self.cause,
            "kind": self.kind,
            "ranking": [c.ranking_entry() for c in self.candidates],
            "untestable": self.untestable,
            "base": {
                "params": self.base.fit.params,
                "stderr": self.base.fit.stderr,
                "rms_residual": self.base.rms,
                "noise": self.noise,
                "heldout_error": self.base.heldout_error,
                "information_criterion": self.base.information_criterion,
                "residual_structure": self.base.structure.to_json(),
                "residual_trends": self.trends,
            },
            "extended": (
                None
                if other is None
                else {
                    "id": other.id,
                    "accepted": other.id == self.cause,
                    "params": other.fit.params,
                    "stderr": other.fit.stderr,
                    "rms_residual": other.rms,
                    "residual_structure": other.structure.to_json(),
                }
            ),
            "gain": self.gain(),
            "simulation_check": self.simulation_check,
        }


def _candidate(
    name: str,
    measurement: Measurement,
    surrogate: Surrogate,
    noise: float,
    tick: Callable,
    base: Fit | None = None,
) -> Candidate:
    """Fit on all data (an extension warm-started from the base fit it nests), then refit
    warm-started with each fold held out."""
    fit = measurement.fit(surrogate, start=None if base is None else base.start)
    tick()
    residuals = [m - y for m, y in zip(fit.model, measurement.observed, strict=True)]
    squared, count = 0.0, 0
    for masks in measurement.folds():
        refit = measurement.fit(surrogate, holdout=masks, start=fit.start)
        for model, y, held in zip(refit.model, measurement.observed, masks, strict=True):
            squared += float(np.sum((model[held] - y[held]) ** 2))
            count += int(held.sum())
        tick()
    return Candidate(
        name,
        fit,
        residuals,
        information_criterion(residuals, fit.n_free),
        math.sqrt(squared / count),
        structure(residuals, noise),
    )


def _testable(effect: Effect, measurement: Measurement) -> str | None:
    """None if the data can test ``effect``, else the reason (the data it needs)."""
    if measurement.kind not in effect.surrogates:
        return f"needs {effect.needs}" if effect.needs else "no signature in these data"
    if effect.varies and measurement.distinct(effect.varies) < 2:
        return f"needs {effect.needs}"
    return None


def _trends(residuals: list[np.ndarray], covariates: dict[str, list[np.ndarray]]) -> dict:
    """Correlation of the residuals with each covariate (time, displacement, load,
    temperature, velocity), pooled over runs; 0 for a covariate that does not vary."""
    pooled = np.concatenate(residuals)
    out = {}
    for name, values in covariates.items():
        x = np.concatenate(values).astype(float)
        if np.ptp(x) == 0.0 or np.ptp(pooled) == 0.0:
            out[name] = 0.0
            continue
        out[name] = float(np.corrcoef(x, pooled)[0, 1])
    return out


def _supported(candidate: Candidate, base: Candidate, noise: float) -> bool:
    delta = base.information_criterion - candidate.information_criterion
    if delta <= STRONG_EVIDENCE or candidate.heldout_error >= base.heldout_error:
        return False
    excess = base.rms**2 - noise**2
    explained = (base.rms**2 - candidate.rms**2) / excess if excess > 0 else 0.0
    return not candidate.structure.systematic or explained >= EXCESS_EXPLAINED


def diagnose(data: xr.Dataset, *, progress: bool = False) -> Diagnosis:
    """Diagnose a :func:`~nanoblock.measured.load_measurement` Dataset (any kind).

    Raises :class:`~nanoblock.diagnosis.validation.DiagnosisError` (a ``DataError``) for
    data that cannot support a diagnosis, saying what data would.
    """
    check_diagnosable(data)
    measurement = Measurement(data)
    noise = noise_level(measurement.observed)
    testable = {
        effect.id: effect for effect in CATALOGUE.values() if _testable(effect, measurement) is None
    }
    untestable = {
        effect.id: reason
        for effect in CATALOGUE.values()
        if (reason := _testable(effect, measurement)) is not None
    }
    steps = (1 + len(testable)) * (1 + len(measurement.folds()))
    with tqdm(total=steps, desc="diagnosis", disable=not progress, leave=False) as bar:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            base = _candidate("base", measurement, BASE[measurement.kind], noise, bar.update)
            candidates = [
                _candidate(effect.id, measurement, surrogate, noise, bar.update, base.fit)
                for effect in testable.values()
                if (surrogate := effect.surrogates[measurement.kind])
            ]
    candidates.sort(key=lambda c: c.information_criterion)
    supported = [c for c in candidates if _supported(c, base, noise)]
    if supported:
        cause = supported[0].id
    else:
        cause = "unexplained" if base.structure.systematic else "none"
    return Diagnosis(
        kind=measurement.kind,
        noise=noise,
        base=base,
        candidates=candidates,
        untestable=untestable,
        cause=cause,
        trends=_trends(base.residuals, measurement.covariates),
        observed=measurement.observed,
        covariates=measurement.covariates,
        signal_label=measurement.signal_label,
    )
