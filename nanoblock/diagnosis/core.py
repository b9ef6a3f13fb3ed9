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
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from tqdm.auto import tqdm

from nanoblock.diagnosis.catalogue import BASE, CATALOGUE, Effect, Surrogate
from nanoblock.diagnosis.simulation import simulation_check
from nanoblock.diagnosis.statistics import (
    Structure,
    information_criterion,
    noise_level,
    structure,
)
from nanoblock.diagnosis.surrogates import Fit, Masks, Measurement
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
    heldout_error: float | None
    """RMS error on held-out folds; None when the IC already rules the model out."""
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


def _full_fit(measurement: Measurement, surrogate: Surrogate, start: dict | None) -> Fit:
    """Fit on all data (an extension warm-started from the base fit it nests)."""
    return measurement.fit(surrogate, start=start)


def _heldout_squares(
    measurement: Measurement, surrogate: Surrogate, start: dict, masks: Masks
) -> tuple[float, int]:
    """Refit (warm-started) with one fold hidden: squared error on it, and its size."""
    refit = measurement.fit(surrogate, holdout=masks, start=start)
    squared, count = 0.0, 0
    for model, y, held in zip(refit.model, measurement.observed, masks, strict=True):
        squared += float(np.sum((model[held] - y[held]) ** 2))
        count += int(held.sum())
    return squared, count


class _Runner:
    """Runs fits in this process or on a process pool, in submission order."""

    def __init__(self, workers: int, tick: Callable[[int], Any]) -> None:
        self.pool = ProcessPoolExecutor(workers) if workers > 1 else None
        self.tick = tick

    def map(self, function: Callable, jobs: list[tuple]) -> list:
        if self.pool is None:
            results = []
            for job in jobs:
                results.append(function(*job))
                self.tick(1)
            return results
        futures = [self.pool.submit(function, *job) for job in jobs]
        for future in futures:
            future.add_done_callback(lambda _: self.tick(1))
        return [future.result() for future in futures]

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown()


def _fit_candidates(
    measurement: Measurement,
    models: dict[str, Surrogate],
    noise: float,
    runner: _Runner,
) -> tuple[Candidate, list[Candidate]]:
    """Fit the base and every extension, then score out of sample those that can matter.

    Held-out folds are refitted for the base, the extension with the lowest IC and every
    extension that passes the IC test of the verdict rule; the others cannot be the cause
    and keep ``heldout_error = None`` (saving most of the cost on data without an effect).
    """
    base_fit = _full_fit(measurement, models["base"], None)
    runner.tick(1)
    names = [name for name in models if name != "base"]
    jobs = [(measurement, models[name], base_fit.start) for name in names]
    fits = {"base": base_fit, **dict(zip(names, runner.map(_full_fit, jobs), strict=True))}
    candidates = {}
    for name, fit in fits.items():
        residuals = [m - y for m, y in zip(fit.model, measurement.observed, strict=True)]
        candidates[name] = Candidate(
            name,
            fit,
            residuals,
            information_criterion(residuals, fit.n_free),
            None,
            structure(residuals, noise),
        )
    base_ic = candidates["base"].information_criterion
    ranked = sorted(names, key=lambda name: candidates[name].information_criterion)
    scored = ["base", *ranked[:1]] + [
        name
        for name in ranked[1:]
        if base_ic - candidates[name].information_criterion > STRONG_EVIDENCE
    ]
    folds = measurement.folds()
    jobs = [
        (measurement, models[name], fits[name].start, masks) for name in scored for masks in folds
    ]
    results = iter(runner.map(_heldout_squares, jobs))
    for name in scored:
        parts = [next(results) for _ in folds]
        squared = sum(part[0] for part in parts)
        count = sum(part[1] for part in parts)
        candidates[name].heldout_error = math.sqrt(squared / count)
    return candidates["base"], [candidates[name] for name in ranked]


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
    if delta <= STRONG_EVIDENCE or candidate.heldout_error is None:
        return False
    if candidate.heldout_error >= base.heldout_error:
        return False
    excess = base.rms**2 - noise**2
    explained = (base.rms**2 - candidate.rms**2) / excess if excess > 0 else 0.0
    return not candidate.structure.systematic or explained >= EXCESS_EXPLAINED


def diagnose(
    data: xr.Dataset, *, progress: bool = False, workers: int = 1, simulate: bool = False
) -> Diagnosis:
    """Diagnose a :func:`~nanoblock.measured.load_measurement` Dataset (any kind).

    Raises :class:`~nanoblock.diagnosis.validation.DiagnosisError` (a ``DataError``) for
    data that cannot support a diagnosis, saying what data would. ``workers`` > 1 fits
    the candidate models on that many processes (the result does not depend on it).
    ``simulate`` runs the simulation check (:mod:`nanoblock.diagnosis.simulation`) on the
    cause, or on the best extension when there is none.
    """
    if workers < 1:
        raise ValueError(f"workers = {workers!r} is out of range [1, inf)")
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
    models = {"base": BASE[measurement.kind]}
    models.update({name: effect.surrogates[measurement.kind] for name, effect in testable.items()})
    n_folds = len(measurement.folds())
    steps = len(models) + 2 * n_folds  # the held-out count grows with what the IC supports
    with tqdm(total=steps, desc="diagnosis", disable=not progress, leave=False) as bar:
        runner = _Runner(workers, bar.update)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                base, candidates = _fit_candidates(measurement, models, noise, runner)
        finally:
            runner.close()
    supported = [c for c in candidates if _supported(c, base, noise)]
    if supported:
        cause = supported[0].id
    else:
        cause = "unexplained" if base.structure.systematic else "none"
    diagnosis = Diagnosis(
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
    if simulate:
        other = diagnosis.extended or diagnosis.best
        diagnosis.simulation_check = simulation_check(
            data,
            base.fit.params,
            None if other is None else other.id,
            {} if other is None else other.fit.params,
            progress=progress,
        )
    return diagnosis
