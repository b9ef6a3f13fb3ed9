"""The diagnosis: base fit, misfit against the noise, every catalogue extension fitted and
ranked out of sample, the verdict and its gain (issue 6; physics.md section 5).

Real records first. A time series is averaged to uniform load-point travel
(:mod:`.resample`), so mixed sampling rates weigh per unit slip and a decimated record
gives the same verdict; it is searched for stick-slip (:mod:`.drops`), which no smooth
law can fit (verdict ``unstable_sliding``). The noise is measured twice: white noise at the
sample scale (second differences) and the floor at the model's resolution (the base
residuals' scatter about their own running mean over 5 % of the travel). When the floor
exceeds the white noise by 1.5, or the best fit's residuals in steady sliding, high-passed by that
running mean, keep a lag-1 autocorrelation beyond white noise's at the 1e-3 level
(:func:`~.statistics.noise_lag1_z`), the noise is *coloured*: residuals are tested against
the floor, and information criteria count the effective samples n (1 - phi) / (1 + phi) of
residuals with lag-1 autocorrelation phi (that of the best-fitting candidate).

Verdict rule. Let IC be that Bayesian information criterion of a fit, and the held-out
error the RMS residual of samples hidden from the fit (whole runs; for time series a
forecast of the second half of every segment after the first; contiguous blocks
otherwise). An extension is *supported* when it lowers IC by more than
``STRONG_EVIDENCE`` (very strong evidence; for one extra parameter a false alarm on white
noise has probability ~1e-5 at 5,000 samples), predicts held-out data better than the
base model, removes the systematic misfit (its residuals pass the structure tests) or at
least half of the base model's excess variance over the noise floor, and has every
parameter in its physical range (:mod:`.plausibility`). The cause is the supported
extension with the lowest IC (on time series: with the best forecast, which a decimated
record keeps) that the simulation check, where it runs, does not contradict (switching the
extension on must lower the simulation's systematic misfit; a veto needs ``VETO_SEEDS``
seeds, as two seeds' noise can flip the sign; an extension whose fit the simulator cannot
make while it makes the base is not confirmed either); without one, the answer is
``none`` when the base residuals are within noise and without structure, and
``unexplained`` otherwise.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from tqdm.auto import tqdm

from nanoblock.diagnosis.catalogue import BASE, CATALOGUE, CLOSURES, Effect, Surrogate, in_closure
from nanoblock.diagnosis.drops import StickSlip, find_stick_slip
from nanoblock.diagnosis.plausibility import implausible
from nanoblock.diagnosis.resample import resample_by_travel
from nanoblock.diagnosis.simulation import SEEDS, SWITCHES, simulation_check
from nanoblock.diagnosis.statistics import (
    COLOURED,
    COLOURED_Z,
    Structure,
    effective_size,
    information_criterion,
    lag1_autocorrelation,
    noise_lag1_z,
    noise_level,
    resolution_noise,
    structure,
)
from nanoblock.diagnosis.surrogates import Fit, Masks, Measurement, forecast_mask
from nanoblock.diagnosis.validation import check_diagnosable
from nanoblock.diagnosis.window_study import window_study
from nanoblock.rsf.fit import metadata_stiffness, prepare_runs

STRONG_EVIDENCE = 10.0
"""Delta IC above which an extension counts (Kass and Raftery's 'very strong')."""
EXCESS_EXPLAINED = 0.5
"""Fraction of the base model's variance in excess of the noise an extension must remove
when its own residuals still show structure."""
SIMULATION_TRIES = 2
"""Supported extensions checked by simulation, best first, before the verdict is
``unexplained``."""
VETO_SEEDS = 6
"""Seeds per interface a veto needs: a check with
:data:`~nanoblock.diagnosis.simulation.SEEDS` seeds in which the extension does not lower
the simulated misfit is rerun with this many (the first check's runs reused) before the
cause is refused. Measured on
p655 100 MPa 23 -> 229 um/s (two_state_variable): seed pairs 0-1, 2-3, ..., 8-9 remove
-9, 67, 51, 51, 32 % of the systematic variance, seeds 0-3 46 %, seeds 0-5 46 %."""


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
    implausible: list[str] = field(default_factory=list)
    """Parameters outside their physical ranges (empty: plausible)."""

    @property
    def rms(self) -> float:
        pooled = np.concatenate(self.residuals)
        return float(np.sqrt(np.mean(pooled**2)))

    def ranking_entry(self) -> dict[str, Any]:
        failed = self.heldout_error is not None and not math.isfinite(self.heldout_error)
        return {
            "id": self.id,
            "heldout_error": None if failed else self.heldout_error,
            **({"forecast_failed": True} if failed else {}),
            "information_criterion": self.information_criterion,
            "rms_residual": self.rms,
            "params": self.fit.params,
            "stderr": self.fit.stderr,
            "residual_structure": self.structure.to_json(),
            "implausible": self.implausible,
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
    noise_model: dict[str, Any] = field(default_factory=dict)
    """White noise, floor at the model's resolution, whether coloured, effective size."""
    stick_slip: list[StickSlip] = field(default_factory=list)
    not_confirmed: dict[str, str] = field(default_factory=dict)
    """Supported extensions the simulation check contradicted, with why."""
    window_study: dict[str, Any] = field(default_factory=dict)
    """Time series: the aging law's D_c against the fit window after the steps."""
    closures: dict[str, dict[str, Any]] = field(default_factory=dict)
    """``closure="best"``: each closure's final model (``base`` or the accepted cause),
    base law and information criterion; the lowest one's pass gives the verdict."""

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
                "law": self.base.fit.law,
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
            "noise_model": self.noise_model,
            "stick_slip": [event.to_json() for event in self.stick_slip],
            "not_confirmed": self.not_confirmed,
            "window_study": self.window_study,
            "closures": self.closures,
        }


def _full_fit(measurement: Measurement, surrogate: Surrogate, start: dict | None) -> Fit:
    """Fit on all data (an extension warm-started from the base fit it nests)."""
    return measurement.fit(surrogate, start=start)


def _extension_fit(measurement: Measurement, surrogate: Surrogate, start: dict) -> Fit | str:
    """:func:`_full_fit` of an extension, or why it failed (an integration its optimum
    cannot finish): the extension is then reported as not testable, not as a crash."""
    try:
        return _full_fit(measurement, surrogate, start)
    except (RuntimeError, FloatingPointError) as error:
        return f"its fit failed ({error})"


def _heldout_squares(
    measurement: Measurement, surrogate: Surrogate, start: dict, masks: Masks
) -> tuple[float, int]:
    """Refit (warm-started) with one fold hidden: squared error on it, and its size
    (infinite if the refit fails: a model that cannot be integrated does not forecast)."""
    held = sum(int(mask.sum()) for mask in masks)
    try:
        refit = measurement.fit(surrogate, holdout=masks, start=start)
    except (RuntimeError, FloatingPointError):
        return math.inf, held
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


@dataclass(frozen=True)
class _NoiseModel:
    """The noise a fit is judged against (see the module docstring)."""

    white: float
    floor: float
    lag1_z: float
    """:func:`~.statistics.noise_lag1_z` of the base's steady stretches (0 off time series)."""
    coloured: bool
    n_effective: float | None

    @property
    def level(self) -> float:
        return self.floor if self.coloured else self.white

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def _noise_model(measurement: Measurement, residuals: dict[str, list[np.ndarray]]) -> _NoiseModel:
    """White noise of the data, the floor at the model's resolution (time series: from the
    base residuals in steady sliding), the whiteness test of the noise (from the best
    fit's residuals in steady sliding, so a misfit of the base that bends within the
    floor's window does not read as colour) and, for coloured noise, the effective size of
    the best fit's residuals."""
    white = noise_level(measurement.observed)
    if measurement.kind != "time_series":
        return _NoiseModel(white, white, 0.0, False, None)
    best = min(residuals.values(), key=lambda r: float(sum(np.dot(x, x) for x in r)))
    floor = resolution_noise(_steady_stretches(measurement, residuals["base"]))
    lag1_z = noise_lag1_z(_steady_stretches(measurement, best))
    if floor <= COLOURED * white and lag1_z <= COLOURED_Z:
        return _NoiseModel(white, floor, lag1_z, False, None)
    n = sum(r.size for r in best)
    return _NoiseModel(white, floor, lag1_z, True, effective_size(n, lag1_autocorrelation(best)))


def _steady_stretches(measurement: Measurement, residuals: list[np.ndarray]) -> list[np.ndarray]:
    """The residuals in steady sliding: each run's first segment and the second half of
    every later segment (after the transient), as contiguous stretches."""
    stretches = []
    for run, r in zip(measurement.prepared, residuals, strict=True):
        held = forecast_mask(run)
        first = np.searchsorted(run.time, run.history.starts[1]) if held.any() else r.size
        stretches.append(r[:first])
        edges = np.flatnonzero(np.diff(np.concatenate([[0], held.astype(np.int8), [0]])))
        stretches.extend(r[i:j] for i, j in zip(edges[::2], edges[1::2], strict=True))
    return stretches


CLOSURE_CHOICES = (*CLOSURES, "auto", "best")
"""The ``closure`` arguments of :func:`diagnose`."""
DEFAULT_CLOSURE = "aging"
"""The default ``closure``. ``"best"`` gets more of the hidden-effect matrix right (the
aging closure calls effect-free records of the contacts' renewal a cause), but its
verdict on a laboratory record changes when the record is decimated (the diagnosis
guide, "The base law's closure")."""


def check_closure(closure: str) -> None:
    """``ValueError`` naming ``closure`` and the choices unless it is one of them."""
    if closure not in CLOSURE_CHOICES:
        raise ValueError(
            f"--closure / closure {closure!r} is not one of {', '.join(CLOSURE_CHOICES)}"
        )


def closed_base(measurement: Measurement, closure: str = "auto") -> tuple[str, Fit]:
    """The base model's closure (:data:`~nanoblock.diagnosis.catalogue.CLOSURES`) and its
    fit: ``closure`` itself, or with ``"auto"`` (and ``"best"``) on time series the closure
    whose base fit leaves the smaller residual sum of squares (the same parameters, so the
    information criteria rank them alike); the aging law's on other kinds of data."""
    check_closure(closure)
    base = BASE[measurement.kind]
    if measurement.kind != "time_series":
        closure = "aging"
    closures = CLOSURES if closure in ("auto", "best") else {closure: CLOSURES[closure]}
    fits = {name: _full_fit(measurement, in_closure(base, name), None) for name in closures}

    def squares(fit: Fit) -> float:
        pairs = zip(fit.model, measurement.observed, strict=True)
        return sum(float(np.sum((m - y) ** 2)) for m, y in pairs)

    closure = min(fits, key=lambda name: squares(fits[name]))
    return closure, fits[closure]


def _fit_candidates(
    measurement: Measurement, models: dict[str, Surrogate], base_fit: Fit, runner: _Runner
) -> tuple[dict[str, Fit], _NoiseModel, dict[str, Candidate], dict[str, str]]:
    """Score the ``base_fit`` of ``models["base"]`` and fit every extension on all data
    (warm-started from the base), then measure the noise model and score each fit against
    it; the extensions whose fit failed are returned apart, with why."""
    runner.tick(1)
    names = [name for name in models if name != "base"]
    jobs = [(measurement, models[name], base_fit.start) for name in names]
    outcomes = dict(zip(names, runner.map(_extension_fit, jobs), strict=True))
    failed = {name: why for name, why in outcomes.items() if isinstance(why, str)}
    fits = {"base": base_fit}
    fits.update({name: fit for name, fit in outcomes.items() if not isinstance(fit, str)})
    residuals = {
        name: [m - y for m, y in zip(fit.model, measurement.observed, strict=True)]
        for name, fit in fits.items()
    }
    noise = _noise_model(measurement, residuals)
    candidates = {}
    for name, fit in fits.items():
        candidates[name] = Candidate(
            name,
            fit,
            residuals[name],
            information_criterion(residuals[name], fit.n_free, noise.n_effective),
            None,
            structure(
                residuals[name],
                noise.level,
                coloured=noise.coloured,
                n_effective=noise.n_effective,
            ),
            _implausible(measurement, name, fit),
        )
    return fits, noise, candidates, failed


def _implausible(measurement: Measurement, name: str, fit: Fit) -> list[str]:
    """Parameters of a time-series fit outside their physical ranges."""
    if measurement.kind != "time_series":
        return []
    travel = max(float(np.ptp(run.load_point_displacement)) for run in measurement.prepared)
    return implausible(
        CATALOGUE.get(name), fit.params, measurement.observed, travel,
        metadata_stiffness(measurement.data),
    )  # fmt: skip


def _score_heldout(
    measurement: Measurement,
    models: dict[str, Surrogate],
    fits: dict[str, Fit],
    candidates: dict[str, Candidate],
    runner: _Runner,
) -> list[Candidate]:
    """Held-out errors for the base, the extension with the lowest IC and every plausible
    extension that passes the IC test of the verdict rule; the others cannot be the cause
    and keep ``heldout_error = None`` (saving most of the cost on data without an effect).
    Returns the extensions, lowest IC first."""
    base_ic = candidates["base"].information_criterion
    ranked = sorted(
        (name for name in candidates if name != "base"),
        key=lambda name: candidates[name].information_criterion,
    )
    scored = ["base", *ranked[:1]] + [
        name
        for name in ranked[1:]
        if base_ic - candidates[name].information_criterion > STRONG_EVIDENCE
        and not candidates[name].implausible
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
    return [candidates[name] for name in ranked]


def _testable(effect: Effect, measurement: Measurement) -> str | None:
    """None if the data can test ``effect``, else the reason (the data it needs)."""
    if effect.detector and measurement.kind == "time_series":
        return None
    if measurement.kind not in effect.surrogates:
        return f"needs {effect.needs}" if effect.needs else "no signature in these data"
    if effect.varies and measurement.distinct(effect.varies) < 2:
        return f"needs {effect.needs}"
    surrogate = effect.surrogates[measurement.kind]
    stated = metadata_stiffness(measurement.data)
    if getattr(surrogate, "fit_stiffness", False) and stated in (None, math.inf):
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


def excess_explained(candidate: Candidate, base: Candidate, noise: float) -> float:
    """Share of the base model's variance above ``noise`` (the floor) that ``candidate``
    removes (0 when the base is within it)."""
    excess = base.rms**2 - noise**2
    return (base.rms**2 - candidate.rms**2) / excess if excess > 0 else 0.0


def shortfalls(candidate: Candidate, base: Candidate, noise: float) -> list[str]:
    """Why the verdict rule (module docstring) does not support ``candidate`` as a cause,
    one phrase per test it fails, judged against the base and the noise floor ``noise``;
    empty when it is supported."""
    reasons = []
    delta = base.information_criterion - candidate.information_criterion
    if delta <= STRONG_EVIDENCE:
        reasons.append(
            f"it gains {delta:.1f} in the information criterion, "
            f"more than {STRONG_EVIDENCE:g} needed"
        )
    reasons += candidate.implausible
    heldout = candidate.heldout_error
    if heldout is None:
        if not reasons:
            reasons.append("it was not scored out of sample")
    elif heldout >= base.heldout_error:
        ratio = (
            f" (error ratio {base.heldout_error / heldout:.2f})" if math.isfinite(heldout) else ""
        )
        reasons.append(f"it forecasts the held-out data no better than the base model{ratio}")
    explained = excess_explained(candidate, base, noise)
    if candidate.structure.systematic and explained < EXCESS_EXPLAINED:
        reasons.append(
            f"it removes {100 * explained:.0f} % of the misfit above the noise floor, "
            f"{100 * EXCESS_EXPLAINED:.0f} % needed"
        )
    return reasons


def _supported(candidate: Candidate, base: Candidate, noise: float) -> bool:
    return not shortfalls(candidate, base, noise)


@dataclass
class _Closure:
    """One closure's pass of the diagnosis: its noise model, scored base, extensions
    (lowest IC first), failed fits and the extensions the verdict rule supports."""

    closure: str
    noise: _NoiseModel
    base: Candidate
    candidates: list[Candidate]
    failed: dict[str, str]
    supported: list[Candidate]
    accepted: Candidate | None = None
    """The cause this pass accepts (None: none), set by :func:`_accept`."""
    not_confirmed: dict[str, str] = field(default_factory=dict)
    """Supported extensions the simulation check refused, with why."""
    simulation_check: dict[str, Any] = field(default_factory=dict)
    """The last check :func:`_accept` ran."""

    @property
    def final(self) -> Candidate:
        """The model this pass ends with: the accepted cause's, or the base."""
        return self.accepted or self.base


def _closure_pass(
    measurement: Measurement, testable: dict[str, Effect], closure: str, runner: _Runner
) -> _Closure:
    """Fit, score and rank the base and the ``testable`` extensions in ``closure``."""
    closure, base_fit = closed_base(measurement, closure)
    models = {"base": in_closure(BASE[measurement.kind], closure)}
    models.update(
        {
            name: in_closure(effect.surrogates[measurement.kind], closure)
            for name, effect in testable.items()
            if measurement.kind in effect.surrogates
        }
    )
    fits, noise, scored, failed = _fit_candidates(measurement, models, base_fit, runner)
    candidates = _score_heldout(measurement, models, fits, scored, runner)
    # the excess a cause must halve is the base variance above the floor at the model's
    # resolution (the white noise of synthetic records; more on real ones, whichever the
    # coloured-noise flag says), so a record and its decimation weigh causes alike
    supported = [c for c in candidates if _supported(c, scored["base"], noise.floor)]
    if measurement.kind == "time_series":  # the best forecast among the supported
        supported.sort(key=lambda c: c.heldout_error)
    return _Closure(closure, noise, scored["base"], candidates, failed, supported)


def _accept(done: _Closure, data: xr.Dataset, simulate: bool, progress: bool) -> None:
    """Set the cause the pass accepts: its best supported extension, or with ``simulate``
    the best one the simulation check does not refuse (one without a simulator option
    needs none). A cause is refused if switching it on fails to lower the simulated misfit
    with ``VETO_SEEDS`` seeds (a check of ``SEEDS`` that fails is rerun with them) or if
    its fit has no interface while the base's has (status ``"refused"``). After
    ``SIMULATION_TRIES`` refusals none is accepted."""
    for candidate in done.supported:
        if not simulate or candidate.id not in SWITCHES:
            done.accepted = candidate
            return
        if len(done.not_confirmed) == SIMULATION_TRIES:
            return
        simulated: dict = {}  # the veto's rerun adds seeds to the first check's
        check = _simulate(data, done.base, candidate, progress, cache=simulated)
        if check["status"] == "ran" and check["systematic_variance_removed"] <= 0.0:
            check = _simulate(data, done.base, candidate, progress, VETO_SEEDS, simulated)
        done.simulation_check = check
        status = check["status"]  # "refused": the simulator cannot make the fitted cause
        if status == "not_run" or (status == "ran" and check["systematic_variance_removed"] > 0):
            done.accepted = candidate
            return
        done.not_confirmed[candidate.id] = check["summary"]


def _best_closure(passes: list[_Closure]) -> tuple[_Closure, dict[str, dict[str, Any]]]:
    """The pass whose final model (base plus the cause it accepts, after the simulation
    check where it ran) has the lowest information criterion, all scored with the
    smallest effective sample size among the passes' noise models (so the comparison does
    not depend on whose residuals measured it), and each pass's final model, base law,
    criterion and refused causes, for the report."""
    sizes = [p.noise.n_effective for p in passes if p.noise.n_effective is not None]
    n_effective = min(sizes) if sizes else None
    scores = {
        p.closure: information_criterion(p.final.residuals, p.final.fit.n_free, n_effective)
        for p in passes
    }
    table = {
        p.closure: {
            "final": p.final.id,
            "law": p.base.fit.law,
            "information_criterion": scores[p.closure],
            "not_confirmed": list(p.not_confirmed),
        }
        for p in passes
    }
    return min(passes, key=lambda p: scores[p.closure]), table


def diagnose(
    data: xr.Dataset,
    *,
    progress: bool = False,
    workers: int = 1,
    simulate: bool = False,
    closure: str = DEFAULT_CLOSURE,
) -> Diagnosis:
    """Diagnose a :func:`~nanoblock.measured.load_measurement` Dataset (any kind).

    Raises :class:`~nanoblock.diagnosis.validation.DiagnosisError` (a ``DataError``) for
    data that cannot support a diagnosis, saying what data would. ``workers`` > 1 fits
    the candidate models on that many processes (the result does not depend on it).
    ``simulate`` runs the simulation check (:mod:`nanoblock.diagnosis.simulation`) on the
    supported extensions, best first, and accepts the first it does not refuse
    (:func:`_accept`); with no supported extension it checks the best one, for the
    report. ``closure``: of the time-series base and extensions (:func:`closed_base`):
    ``"aging"``, ``"renewal"``, ``"auto"``, the one whose base fits better, or ``"best"``:
    a full pass in each (with ``simulate``, each pass's causes checked), and the verdict
    of the pass whose final model (base plus the cause it accepts) has the lower
    information criterion (:func:`_best_closure`; twice the cost of one pass). The
    default: :data:`DEFAULT_CLOSURE`.
    """
    if workers < 1:
        raise ValueError(f"workers = {workers!r} is out of range [1, inf)")
    check_closure(closure)
    check_diagnosable(data)
    stick_slip = []
    if data.attrs.get("kind") == "time_series":
        stick_slip = find_stick_slip(prepare_runs(data))
        data = resample_by_travel(data)
    measurement = Measurement(data)
    testable = {
        effect.id: effect for effect in CATALOGUE.values() if _testable(effect, measurement) is None
    }
    untestable = {
        effect.id: reason
        for effect in CATALOGUE.values()
        if (reason := _testable(effect, measurement)) is not None
    }
    time_series = measurement.kind == "time_series"
    passes = list(CLOSURES) if closure == "best" and time_series else [closure]
    surrogates = sum(measurement.kind in effect.surrogates for effect in testable.values())
    steps = len(passes) * (surrogates + 1 + 2 * len(measurement.folds()))
    with tqdm(total=steps, desc="diagnosis", disable=not progress, leave=False) as bar:
        runner = _Runner(workers, bar.update)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                done = [_closure_pass(measurement, testable, name, runner) for name in passes]
        finally:
            runner.close()
    for each in done:
        _accept(each, data, simulate and not stick_slip, progress)
    chosen, closures = _best_closure(done) if len(done) > 1 else (done[0], {})
    untestable.update(chosen.failed)
    noise, base = chosen.noise, chosen.base
    unaccepted = "unexplained" if base.structure.systematic else "none"
    diagnosis = Diagnosis(
        kind=measurement.kind,
        noise=noise.level,
        base=base,
        candidates=chosen.candidates,
        untestable=untestable,
        cause=unaccepted if chosen.accepted is None else chosen.accepted.id,
        trends=_trends(base.residuals, measurement.covariates),
        observed=measurement.observed,
        covariates=measurement.covariates,
        signal_label=measurement.signal_label,
        noise_model={**noise.to_json(), "samples": int(data.attrs.get("resampled_from", 0))},
        stick_slip=stick_slip,
        closures=closures,
        simulation_check=chosen.simulation_check,
        not_confirmed=chosen.not_confirmed,
    )
    if measurement.kind == "time_series":
        diagnosis.window_study = window_study(data)
    if stick_slip:
        diagnosis.cause = "unstable_sliding"
        return diagnosis
    if simulate and not diagnosis.simulation_check:
        other = diagnosis.extended or diagnosis.best
        diagnosis.simulation_check = _simulate(data, base, other, progress)
    return diagnosis


def _simulate(
    data: xr.Dataset,
    base: Candidate,
    other: Candidate | None,
    progress: bool,
    seeds: int = SEEDS,
    cache: dict | None = None,
) -> dict[str, Any]:
    """The simulation check of ``other`` (None: no extension) against the base, ``seeds``
    runs of each interface (``cache``: :func:`simulation_check`'s)."""
    return simulation_check(
        data,
        base.fit.params,
        None if other is None else other.id,
        {} if other is None else other.fit.params,
        laws=(base.fit.law, (base if other is None else other).fit.law),
        seeds=seeds,
        progress=progress,
        cache=cache,
    )
