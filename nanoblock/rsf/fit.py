"""Fitting rate-and-state laws to friction time series (velocity steps, slide-hold-slide).

The model of each run is the spring-slider of :mod:`nanoblock.rsf.slider`, started in
steady sliding at the first sample's load-point velocity, with the run's own load-point
history; optionally plus a linear trend of friction with load-point displacement (as
laboratory fitting tools offer). Free parameters are fitted by nonlinear least squares
(``scipy.optimize.least_squares``, trust-region reflective) in a scaled space (log for
lengths, velocities and the stiffness). Standard errors come from the Jacobian at the
optimum, s^2 (J^T J)^-1 with s^2 the residual variance, computed by SVD so that an
unidentifiable direction (e.g. D_c on a very soft machine) gets an infinite error
instead of a spuriously tight one; s^2 is inflated by (1 + phi) / (1 - phi), phi the
lag-1 autocorrelation of the residuals, since correlated residuals (real records: phi =
0.8-0.98) carry fewer independent samples than they count. An optional MCMC mode
(``emcee``) samples the posterior with flat priors in the scaled space.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from scipy.optimize import OptimizeResult, least_squares
from scipy.stats import median_abs_deviation

from nanoblock.measured import DataError, runs
from nanoblock.rsf.laws import Law, law
from nanoblock.rsf.slider import LoadPointHistory, solve_slider

FloatArray = NDArray[np.float64]

__all__ = ["FitResult", "RunData", "fit_rsf", "prepare_runs"]

STIFFNESS = "stiffness"
"""Name of the fitted machine stiffness per normal load K/W [1/m]."""
TREND = "slip_trend"
"""Name of the linear trend of friction with load-point displacement [1/m]."""
LOAD_EXPONENT = "dc_load_exponent"
"""Name of the exponent n of a load-dependent memory length D_c (W / W_ref)^n."""
COHESION = "cohesion_ratio"
"""Name of c / sigma_ref: a cohesive shear strength c that does not grow with the normal
load adds c / sigma to mu, so the friction level of runs at several loads W goes as
mu0 + (c / sigma_ref) (W_ref / W - 1) (Amontons' load-independent mu0 at c = 0)."""
INITIAL_OFFSET = "initial_state_offset"
"""Prefix of the fitted initial-state offsets, one per run (``initial_state_offset_0``,
...): the record starts in the state of steady sliding at V(0) e^(-offset), not at V(0),
so that offset = ln(theta(0) / theta_ss(V(0))) for the aging law."""
INITIAL_VELOCITY = "initial_velocity_offset"
"""Prefix of the fitted initial slip-velocity offsets ln(v(0) / V_L(0)), one per run: a
record cut out after a change of drive starts with the slider still at its old pace."""
_INITIAL = (INITIAL_OFFSET, INITIAL_VELOCITY)
MEMORY_LENGTHS = ("dc", "d0", "dc2")
"""Parameters searched within 1e-6 to 1e3 of the data's slip scale."""

_COARSE_RTOL = 1e-7
_SINGULAR = 1e-9
_DIFF_STEP = 1e-6
_PENALTY = 1e3
_START_GRID = {
    "dc": np.arange(-3.0, 3.5, 1.0),
    "d0": np.arange(-3.0, 3.5, 1.0),
    "dc2": (0.0, 1.5, 3.0),
    "a": (-0.005, 0.0, 0.01),
    "theta_star": (-1.5, 0.0, 1.5),
    "v_theta": (-2.5, 0.0, 2.5),
    "tau_m": (-2.5, 0.0, 2.5),
    "aging_rate": (-2.5, 0.0, 2.5),
    STIFFNESS: (-1.5, 0.0, 1.5),
    LOAD_EXPONENT: (0.0, 0.5, 1.0),
    INITIAL_OFFSET: (-1.0, 0.0, 1.0),
    INITIAL_VELOCITY: (-1.0, 0.0, 1.0),
}
"""Shifts of the starting point (scaled space: ln for dc, d0, theta* and K/W; additive for a
and the load exponent n of D_c ~ W^n, whose local optimum from n = 0 can stop at a third of
the true exponent), evaluated once each; the best ``_REFINED_STARTS`` are refined. The
runs' initial offsets shift together (:func:`_family`): warm-started at 0 from a renewal
base, a fit's trust-region steps were all rejected (the coarse tolerance's scatter of the
base parameters' finite-difference gradients, 3-19, swamped the offsets' 3e-4), and the
offsets stayed at 0 with the cost falling steadily towards -1.5 and +1."""
_REFINED_STARTS = 2
LOSSES = ("linear", "huber")
"""``loss`` of :func:`fit_rsf`: least squares, or Huber's loss (quadratic within
``HUBER_K`` robust standard deviations of the residuals, linear beyond), which bounds the
pull of spikes (a sensor glitch, a dropped sample) on the fit."""
HUBER_K = 1.345
"""Huber's tuning constant in robust standard deviations: 95 % efficiency at Gaussian
noise (Huber 1981, Sec. 4.6)."""
MAX_LAG1 = 0.99
"""Largest residual autocorrelation used to inflate standard errors."""
_FIT_MAX_STEPS = 5_000
"""LSODA steps per output interval during fits: pathological trial parameters fail fast."""
_CACHED_RUNS = 64
"""Integrated runs a time-series fit remembers (see ``_time_series_setup``)."""
AVERAGING_COLUMNS = ("model_time", "model_weight")
"""Columns of a record resampled by travel that average a model over each bin's samples
(:mod:`nanoblock.diagnosis.resample`; :attr:`RunData.model_time`)."""


@dataclass(frozen=True)
class RunData:
    """One experiment: samples and the load-point history that drove it (SI units)."""

    time: FloatArray
    mu: FloatArray
    history: LoadPointHistory
    load_point_displacement: FloatArray
    """Measured from the run's first sample [m]."""
    normal_force: float
    """The run's normal force W [N] (NaN when the data do not give it)."""
    model_time: FloatArray | None = None
    """For samples that are bin means (:mod:`nanoblock.diagnosis.resample`): the times
    [s] a model is averaged over, (samples, nodes), with ``model_weight``."""
    model_weight: FloatArray | None = None

    @property
    def evaluation_times(self) -> FloatArray:
        """The times [s] a model of the run is evaluated at, non-decreasing."""
        return self.time if self.model_time is None else self.model_time.ravel()

    def sampled(self, model: FloatArray) -> FloatArray:
        """A model at :attr:`evaluation_times` as the samples see it (bin means)."""
        if self.model_time is None or self.model_weight is None:
            return model
        return np.sum(model.reshape(self.model_time.shape) * self.model_weight, axis=1)


def _history_from_displacement(time: FloatArray, displacement: FloatArray) -> LoadPointHistory:
    """Piecewise-constant V_L from a displacement record: finite differences, merged into
    segments whose velocities agree within 20 % (holds: |V| below 1e-3 of the median).
    An interval shorter than 1e-9 of the record (repeated or near-repeated times) takes
    its neighbour's velocity: its difference quotient is rounding error, and a segment
    that short stops the integrator."""
    step = np.diff(time)
    tiny = step <= 1e-9 * (time[-1] - time[0])
    velocity = np.diff(displacement) / np.where(tiny, 1.0, step)
    if tiny.any() and not tiny.all():
        good = np.flatnonzero(~tiny)
        nearest = good[
            np.clip(np.searchsorted(good, np.arange(step.size), side="right") - 1, 0, None)
        ]
        velocity = velocity[np.where(tiny, nearest, np.arange(step.size))]
    scale = np.median(np.abs(velocity)) or 1.0
    velocity = np.where(np.abs(velocity) < 1e-3 * scale, 0.0, np.maximum(velocity, 0.0))
    starts, values, begin = [time[0]], [], 0
    for i in range(1, velocity.size + 1):
        block = velocity[begin:i]
        ratio = (block.max() + 1e-300) / (block.min() + 1e-300)
        if i == velocity.size or (block.min() == 0.0) != (block.max() == 0.0) or ratio > 1.2:
            end = i if i == velocity.size else i - 1
            dx = displacement[end] - displacement[begin]
            values.append(max(dx / (time[end] - time[begin]), 0.0))
            if i < velocity.size:
                starts.append(time[end])
            begin = end
    return LoadPointHistory(np.array(starts), np.array(values))


def prepare_runs(data: xr.Dataset) -> list[RunData]:
    """Split a ``time_series`` measurement into runs with their load-point histories."""
    if data.attrs.get("kind") != "time_series":
        raise DataError(
            f"an RSF fit needs time-series friction data (velocity steps or slide-hold-slide); "
            f"this file holds {data.attrs.get('kind')!r} data"
        )
    prepared = []
    for run in runs(data):
        time = run["time"].values
        if time.size < 10:
            source = data.attrs.get("source_file", "the data")
            named = "run" in run and time.size > 0
            which = f"run {run['run'].values[0].item()!r}" if named else "a run"
            raise DataError(
                f"{source}: {which} has only {time.size} samples; at least 10 are needed "
                "to fit it (after any --rows or --window selection)"
            )
        if "load_point_velocity" in run:
            measured = (
                run["load_point_displacement"].values if "load_point_displacement" in run else None
            )
            history = LoadPointHistory.from_samples(
                time, run["load_point_velocity"].values, measured
            )
            displacement = history.displacement_at(time)
        else:
            displacement = run["load_point_displacement"].values
            history = _history_from_displacement(time, displacement)
        force = (
            float(np.mean(run["normal_force"].values))
            if "normal_force" in run
            else float(data.attrs.get("normal_force", math.nan))
        )
        averaged = {name: run[name].values for name in AVERAGING_COLUMNS if name in run}
        prepared.append(
            RunData(
                time, run["mu"].values, history, displacement - displacement[0], force, **averaged
            )
        )
    return prepared


def metadata_stiffness(data: xr.Dataset) -> float | None:
    """K/W [1/m] from the metadata (``stiffness_per_load``, or ``stiffness`` [N/m] with a
    normal force), or None when it must be fitted."""
    attrs = data.attrs
    if "stiffness_per_load" in attrs:
        return float(attrs["stiffness_per_load"])
    if "stiffness" in attrs:
        if "normal_force" in attrs:
            return float(attrs["stiffness"]) / float(attrs["normal_force"])
        if "normal_force" in data:
            return float(attrs["stiffness"]) / float(data["normal_force"].mean())
    return None


def stiffness_scales(data: xr.Dataset, runs_: Sequence[RunData]) -> list[float]:
    """Per-run factors on the fitted K/W: a machine stiffness K [N/m] stated in the metadata
    (``stiffness``, not ``stiffness_per_load``) acts on each run's own load, so run i has
    K/W_i = (K/W_mean) W_mean / W_i; 1 for every run otherwise."""
    forces = [run.normal_force for run in runs_]
    per_load = "stiffness_per_load" in data.attrs or "normal_force" in data.attrs
    if "stiffness" not in data.attrs or per_load or "normal_force" not in data:
        return [1.0] * len(forces)
    if not all(math.isfinite(f) and f > 0.0 for f in forces):
        return [1.0] * len(forces)
    mean = float(data["normal_force"].mean())
    return [mean / force for force in forces]


@dataclass
class FitResult:
    """Fitted parameters with standard errors (SI units), residuals and the fitted model."""

    law: str
    params: dict[str, float]
    stderr: dict[str, float]
    free: tuple[str, ...]
    contract: dict[str, float | None]
    contract_stderr: dict[str, float | None]
    rms_residual: float
    n_points: int
    method: str
    reference_velocity: float
    model: list[FloatArray] = field(repr=False)
    residuals: list[FloatArray] = field(repr=False)
    observed: list[FloatArray] = field(repr=False)
    abscissa: list[FloatArray] = field(repr=False)
    """What to plot the runs against (load-point displacement, s_ext or velocity)."""
    abscissa_label: str
    observed_label: str
    residual_lag1: float = 0.0
    """Lag-1 autocorrelation of the residuals (clipped to [0, MAX_LAG1]; with Huber's loss,
    of the residuals clipped at its corner); the standard errors are inflated by
    sqrt((1 + phi) / (1 - phi)), the AR(1) effective-size factor."""
    loss: str = "linear"
    """:data:`LOSSES`: least squares or Huber's loss."""
    loss_corner: float | None = None
    """Huber's corner c in units of the data (None for least squares): residuals beyond it
    pull with a constant force."""
    downweighted: int = 0
    """Samples beyond the corner (Huber's loss)."""

    def to_json(self) -> dict:
        """The ``fit.json`` contract: law, params (mu0, a, b, dc and the law's own), stderr,
        rms_residual, n_points (plus method, free parameters and the law's native set)."""

        def clean(value: float | None) -> float | None:
            return None if value is None or not math.isfinite(value) else float(value)

        params = {**self.contract, **self.params}
        stderr = {**self.contract_stderr, **self.stderr}
        return {
            "law": self.law,
            "params": {k: clean(v) for k, v in params.items()},
            "stderr": {k: clean(v) for k, v in stderr.items()},
            "rms_residual": self.rms_residual,
            "n_points": self.n_points,
            "residual_lag1": self.residual_lag1,
            "method": self.method,
            "loss": {
                "name": self.loss,
                "corner": None if self.loss_corner is None else clean(self.loss_corner),
                "downweighted": self.downweighted,
            },
            "free": list(self.free),
            "reference_velocity": self.reference_velocity,
            "units": {"dc": "m", "d0": "m", "v0": "m/s", STIFFNESS: "1/m", TREND: "1/m"},
        }

    def write_json(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(json.dumps(self.to_json(), indent=2) + "\n")
        return path


@dataclass(frozen=True)
class _Problem:
    law: Law
    forward: Callable[[Mapping[str, float], float], list[FloatArray]]
    """Model of each run from all parameters, at an ODE relative tolerance."""
    observed: list[FloatArray]
    travel: float
    """Slip scale of the data [m]: memory lengths are searched within 1e-6 to 1e3 of it."""
    scale: float
    """Typical magnitude of the observations: residuals are divided by it so that the
    optimiser's tolerances mean the same for mu ~ 0.5 and for s ~ 1e-7 m."""
    fixed: dict[str, float]
    free: tuple[str, ...]
    log_scale: tuple[bool, ...]
    fitted: NDArray[np.bool_] | None = None
    """Which samples (all runs concatenated) the fit sees; the others are held out."""

    def unpack(self, x: Sequence[float]) -> dict[str, float]:
        values = {
            name: math.exp(xi) if log else float(xi)
            for name, xi, log in zip(self.free, x, self.log_scale, strict=True)
        }
        return {**self.fixed, **values}

    def pack(self, params: Mapping[str, float]) -> FloatArray:
        return np.array(
            [
                math.log(params[name]) if log else params[name]
                for name, log in zip(self.free, self.log_scale, strict=True)
            ]
        )

    def contract(self, x: Sequence[float], v0: float) -> dict[str, float | None]:
        return self.law.contract(self.law.own(self.unpack(x)), v0)

    def models(self, params: Mapping[str, float], rtol: float) -> list[FloatArray]:
        return self.forward(params, rtol)

    def residuals(self, x: Sequence[float], rtol: float) -> FloatArray:
        """Model minus data; a failed or non-finite forward run gives a flat penalty so the
        optimiser backs off instead of stopping."""
        try:
            with np.errstate(all="ignore"):
                models = self.models(self.unpack(x), rtol)
            residual = np.concatenate(
                [(m - y) / self.scale for m, y in zip(models, self.observed, strict=True)]
            )
        except (RuntimeError, ValueError, OverflowError):
            residual = np.full(1, np.nan)
        if self.fitted is not None and residual.size == self.fitted.size:
            residual = residual[self.fitted]
        if not np.all(np.isfinite(residual)):
            return np.full(self.n_fitted, _PENALTY)
        return residual

    @property
    def n_fitted(self) -> int:
        """Number of samples the fit sees."""
        if self.fitted is not None:
            return int(self.fitted.sum())
        return sum(y.size for y in self.observed)


def _standard_guess(runs_: list[RunData]) -> dict[str, float]:
    """Rough mu0, a, b, dc and K/W from the first velocity change of the first run that
    has one."""
    run = next((r for r in runs_ if r.history.starts.size > 1), runs_[0])
    starts, velocities = run.history.starts, run.history.velocities
    before = run.time < (starts[1] if starts.size > 1 else run.time[-1])
    mu0 = float(np.median(run.mu[before][: max(10, before.sum() // 5)]))
    guess = {"mu0": mu0, "a": 0.01, "b": 0.01, "dc": 1e-5, "stiffness": 1e3}
    if starts.size > 1 and velocities[0] > 0 and velocities[1] > 0:
        jump = math.log(velocities[1] / velocities[0])
        after = (run.time >= starts[1]) & (run.time < (starts[2] if starts.size > 2 else np.inf))
        mu_after = run.mu[after]
        tail = float(np.median(mu_after[-max(5, mu_after.size // 10) :]))
        early = mu_after[: max(5, mu_after.size // 4)]  # the peak comes within a few Dc
        peak = float(early.max() if jump > 0 else early.min())
        a = max(abs((peak - mu0) / jump), 1e-4)
        b = a - (tail - mu0) / jump
        slip = velocities[1] * (run.time[after][-1] - starts[1])
        extreme = int(np.argmax(early) if jump > 0 else np.argmin(early))
        lp_after = run.load_point_displacement[after]
        loading = lp_after[extreme] - lp_after[0]
        # secant of the elastic loading from the step to the peak: a lower bound of K/W
        secant = abs(peak - mu0) / loading if loading > 0 else 1e-2 / max(slip / 20.0, 1e-9)
        guess.update(a=a, b=b, dc=max(slip / 20.0, 1e-9), stiffness=secant)
    return guess


def _search_bounds(problem: _Problem, x0: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Box of the search in the scaled space: memory lengths between 1e-6 and 1e3 times
    the load-point travel L of the longest run (a D_c outside cannot be told from the
    data; tinier ones only make the ODE stiff), K/W within 1e4 of its first guess,
    positive coefficients (a, alpha, ...) above zero and a cohesion >= 0."""
    travel = problem.travel
    lower, upper = np.full(x0.size, -np.inf), np.full(x0.size, np.inf)
    positive = {spec.name for spec in problem.law.parameters if spec.positive}
    for i, name in enumerate(problem.free):
        if name in positive and not problem.log_scale[i]:
            lower[i] = 1e-12
        if name in MEMORY_LENGTHS:
            lower[i], upper[i] = math.log(1e-6 * travel), math.log(1e3 * travel)
        elif name == STIFFNESS:
            lower[i], upper[i] = x0[i] - math.log(1e4), x0[i] + math.log(1e4)
        elif name == COHESION:
            lower[i] = 0.0  # a cohesion adds shear strength
    return lower, upper


def _initial_params(lw: Law, guess: Mapping[str, float], v0: float) -> dict[str, float]:
    mu0, a, b, dc = guess["mu0"], guess["a"], guess["b"], guess["dc"]
    if lw.name in ("aging", "slip"):
        return {"mu0": mu0, "a": a, "b": b, "dc": dc, "v0": v0}
    if lw.name.startswith("renewal"):  # the aging law's D_c is about half the slip D
        base = {"mu0": mu0, "a": a, "b": b, "dc": 2.0 * dc, "v0": v0}
        extra = {
            "renewal_cutoff": {"v_theta": v0},
            "renewal_saturation": {"tau_m": 2.0 * dc / v0},
            "renewal2": {"b2": 0.25 * abs(b), "dc2": 20.0 * dc},
        }
        return {**base, **extra.get(lw.name, {})}
    if lw.name in ("aging2", "slip2"):  # a second, longer memory carrying part of b
        base = {"mu0": mu0, "a": a, "b": b, "dc": dc}
        return {**base, "b2": 0.25 * abs(b), "dc2": 10.0 * dc, "v0": v0}
    if lw.name == "cutoff":
        return {"mu0": mu0, "a": a, "b": b, "dc": dc, "v_theta": v0, "v0": v0}
    if lw.name == "saturation":
        return {"mu0": mu0, "a": a, "b": b, "dc": dc, "tau_m": dc / v0, "v0": v0}
    if lw.name == "tabor":
        return {"mu0": mu0, "alpha": a / mu0, "m": b / mu0, "d0": dc, "v0": v0}
    theta_star = 1.0
    params = {
        "a": a,
        "b": mu0 / math.log1p(1.0 / theta_star),
        "dc": dc,
        "theta_star": theta_star,
        "v_theta": 10.0 * v0,
        "v_star": 1e-12,
    }
    if lw.name == "two_state":
        params["aging_rate"] = 1e-3
    return params


def parameter_covariance(jacobian: FloatArray, variance: float) -> FloatArray:
    """s^2 (J^T J)^-1 by SVD; directions with singular values below 1e-9 of the largest
    are unidentifiable and get infinite variance."""
    _, singular, vt = np.linalg.svd(jacobian, full_matrices=False)
    inverse = np.where(singular > _SINGULAR * singular[0], 1.0 / np.maximum(singular, 1e-300), 0.0)
    covariance = (vt.T * inverse**2) @ vt * variance
    unidentified = vt[singular <= _SINGULAR * singular[0]]
    if unidentified.size:
        weak = np.any(np.abs(unidentified) > 1e-3, axis=0)
        covariance[weak, :] = np.inf
        covariance[:, weak] = np.inf
    return covariance


def _natural_errors(problem: _Problem, x: FloatArray, covariance: FloatArray) -> dict[str, float]:
    params = problem.unpack(x)
    errors = {}
    for i, (name, log) in enumerate(zip(problem.free, problem.log_scale, strict=True)):
        sigma = math.sqrt(covariance[i, i]) if math.isfinite(covariance[i, i]) else math.inf
        errors[name] = params[name] * sigma if log else sigma
    return errors


def _contract_errors(
    problem: _Problem, x: FloatArray, covariance: FloatArray, v0: float
) -> dict[str, float | None]:
    """Standard errors of mu0, a, b, dc by the delta method (finite differences)."""
    base = problem.contract(x, v0)
    gradient = np.zeros((len(base), x.size))
    for j in range(x.size):
        step = 1e-6 * max(1.0, abs(x[j]))
        shifted = x.copy()
        shifted[j] += step
        values = problem.contract(shifted, v0)
        gradient[:, j] = [(values[k] - base[k]) / step for k in base]
    errors: dict[str, float | None] = {}
    for i, key in enumerate(base):
        used = np.abs(gradient[i]) > 0.0
        if not used.any():
            errors[key] = None
            continue
        sub = covariance[np.ix_(used, used)]
        g = gradient[i, used]
        errors[key] = math.sqrt(max(g @ sub @ g, 0.0)) if np.all(np.isfinite(sub)) else math.inf
    return errors


def _mcmc(
    problem: _Problem, x: FloatArray, covariance: FloatArray, variance: float, steps: int, seed: int
) -> tuple[FloatArray, FloatArray]:
    """Posterior median and covariance in the scaled space (emcee, flat priors)."""
    try:
        import emcee
    except ImportError:
        raise RuntimeError("the MCMC mode needs emcee: pip install 'nanoblock[mcmc]'") from None

    def log_probability(theta: FloatArray) -> float:
        r = problem.residuals(theta, _COARSE_RTOL)
        return -0.5 * float(r @ r) / variance

    rng = np.random.default_rng(seed)
    n_walkers = max(4 * x.size, 16)
    finite = np.where(np.isfinite(np.diag(covariance)), np.diag(covariance), 1.0)
    spread = np.sqrt(np.maximum(finite, 1e-12))
    start = x + 0.1 * spread * rng.standard_normal((n_walkers, x.size))
    sampler = emcee.EnsembleSampler(n_walkers, x.size, log_probability)
    sampler.random_state = np.random.RandomState(seed).get_state()
    sampler.run_mcmc(start, steps, progress=False)
    chain = sampler.get_chain(discard=steps // 2, flat=True)
    return np.median(chain, axis=0), np.cov(chain, rowvar=False).reshape(x.size, x.size)


@dataclass(frozen=True)
class _Setup:
    """What a data kind contributes to a fit: the problem, its start and how to plot it."""

    problem: _Problem
    start: dict[str, float]
    reference_velocity: float
    abscissa: list[FloatArray]
    abscissa_label: str
    observed_label: str


def _free_names(lw: Law, free: Sequence[str] | None, default: Sequence[str]) -> list[str]:
    names = list(free if free is not None else default)
    unknown = {n for n in names if not n.startswith(_INITIAL)}
    unknown -= set(lw.names) | {STIFFNESS, TREND, LOAD_EXPONENT, COHESION}
    if unknown:
        raise ValueError(f"cannot fit {sorted(unknown)}: law {lw.name!r} takes {list(lw.names)}")
    return names


def _problem(
    lw: Law,
    forward: Callable[[Mapping[str, float], float], list[FloatArray]],
    observed: list[FloatArray],
    travel: float,
    params: dict[str, float],
    free_names: list[str],
) -> _Problem:
    lw.pack(lw.own(params))
    log_scale = {p.name: p.log_scale for p in lw.parameters} | {
        STIFFNESS: True,
        TREND: False,
        LOAD_EXPONENT: False,
        COHESION: False,
    }
    log_scale.update({name: False for name in free_names if name.startswith(_INITIAL)})
    scale = float(np.sqrt(np.mean(np.concatenate(observed) ** 2))) or 1.0
    return _Problem(
        lw,
        forward,
        observed,
        travel,
        scale,
        {k: v for k, v in params.items() if k not in free_names},
        tuple(free_names),
        tuple(log_scale[name] for name in free_names),
    )


def reference_load(forces: Sequence[float], wanted: bool) -> float:
    """W_ref [N] of a load-dependent memory length: the geometric mean of the runs' loads
    (1 when not wanted); ``DataError`` unless at least two distinct loads are known."""
    if not wanted:
        return 1.0
    known = np.unique([f for f in forces if math.isfinite(f) and f > 0.0])
    if known.size < 2 or len(known) != len(np.unique(forces)):
        raise DataError(
            "a load-dependent memory length or friction level needs runs at two or more "
            "normal forces, each "
            "with its normal force (column 'normal_force' or a run per load)"
        )
    return float(np.exp(np.mean(np.log(known))))


def _law_params(lw: Law, values: Mapping[str, float], force: float, w_ref: float) -> dict:
    """The law's parameters for one run: D_c (or D0) times (W / W_ref)^n when the fit has a
    load exponent n (000/Fig. 3 caption)."""
    params = lw.own(values)
    exponent = values.get(LOAD_EXPONENT, 0.0)
    if exponent:
        key = "dc" if "dc" in params else "d0"
        params[key] *= (force / w_ref) ** exponent
    return params


@dataclass(frozen=True)
class _Options:
    """Time-series extras: K/W free even when the metadata state it (``fit_stiffness``),
    and a free initial state and slip velocity per run (``initial_state``)."""

    fit_stiffness: bool = False
    initial_state: bool = False
    cohesion: bool = False
    """A friction level mu0 + c/sigma_ref (W_ref / W - 1) across runs at several loads."""


def _time_series_setup(
    data: xr.Dataset,
    lw: Law,
    stiffness: float | None,
    trend: bool,
    load_exponent: bool,
    free: Sequence[str] | None,
    initial: Mapping[str, float],
    options: _Options,
) -> _Setup:
    """Velocity steps and slide-hold-slide: the spring-slider from steady sliding (or, with
    ``options.initial_state``, from a fitted state and slip-velocity offset per run)."""
    prepared = prepare_runs(data)
    _check_drive(data, prepared)
    v0 = float(prepared[0].history.velocities[0])
    if not v0 > 0.0:
        raise DataError("the first sample must be in steady sliding (load-point velocity > 0)")
    guess = _standard_guess(prepared)
    params = {**_initial_params(lw, {**guess, **initial}, v0), **initial}
    free_names = _free_names(lw, free, lw.default_free)
    given = stiffness if stiffness is not None else metadata_stiffness(data)
    if given is None or options.fit_stiffness:
        free_names.append(STIFFNESS)
        params.setdefault(STIFFNESS, 2.0 * guess["stiffness"] if given is None else float(given))
    else:
        params[STIFFNESS] = float(given)
    offsets = [f"{INITIAL_OFFSET}_{i}" for i in range(len(prepared))]
    paces = [f"{INITIAL_VELOCITY}_{i}" for i in range(len(prepared))]
    scales = stiffness_scales(data, prepared)
    if options.initial_state:
        free_names.extend([*offsets, *paces])
        for name in (*offsets, *paces):
            params.setdefault(name, 0.0)
    if trend:
        free_names.append(TREND)
        params.setdefault(TREND, 0.0)
    w_ref = reference_load([run.normal_force for run in prepared], load_exponent)
    if load_exponent:
        free_names.append(LOAD_EXPONENT)
        params.setdefault(LOAD_EXPONENT, 0.0)
    levels = [0.0] * len(prepared)
    if options.cohesion:
        w_level = reference_load([run.normal_force for run in prepared], True)
        levels = [w_level / run.normal_force - 1.0 for run in prepared]
        free_names.append(COHESION)
        params.setdefault(COHESION, 0.0)

    twins = _twins(prepared)
    cache: dict[tuple, FloatArray] = {}

    def friction(index: int, values: Mapping[str, float], rtol: float) -> FloatArray:
        """Run ``index``'s slider friction, integrated once per distinct input: a run
        with the time grid, history and parameters of an earlier one (runs at several
        loads sampled alike) or a repeated evaluation (a finite-difference column of a
        parameter it does not depend on, such as another run's initial state or the
        trend) is looked up."""
        run, offset = prepared[index], offsets[index]
        law_params = _law_params(lw, values, run.normal_force, w_ref)
        stiffness = values[STIFFNESS] * scales[index]
        start, pace = None, None
        if offset in values:  # the steady state at V(0) e^-offset
            velocity = run.history.velocities[0] * math.exp(-values[offset])
            start = tuple(float(s) for s in lw.steady_state(velocity, lw.pack(law_params)))
        if paces[index] in values:  # ln v(0) = ln V_L(0) + offset
            pace = float(run.history.velocities[0]) * math.exp(values[paces[index]])
        key = (twins[index], tuple(sorted(law_params.items())), stiffness, start, pace, rtol)
        if key not in cache:
            if len(cache) >= _CACHED_RUNS:
                del cache[next(iter(cache))]
            cache[key] = run.sampled(solve_slider(
                lw, law_params, run.history, run.evaluation_times, stiffness, rtol=rtol,
                initial_velocity=pace, initial_state=start, max_steps=_FIT_MAX_STEPS,
            ).friction)  # fmt: skip
        return cache[key]

    def forward(values: Mapping[str, float], rtol: float) -> list[FloatArray]:
        out = []
        for index, run in enumerate(prepared):
            trend = values.get(TREND, 0.0) * run.load_point_displacement
            level = values.get(COHESION, 0.0) * levels[index]
            out.append(friction(index, values, rtol) + trend + level)
        return out

    travel = max(float(np.ptp(run.load_point_displacement)) for run in prepared)
    problem = _problem(lw, forward, [r.mu for r in prepared], travel, params, free_names)
    return _Setup(
        problem, params, v0, [r.load_point_displacement for r in prepared],
        "load-point displacement (m)", "friction coefficient",
    )  # fmt: skip


def _twins(prepared: Sequence[RunData]) -> list[int]:
    """For each run, the first run with the same time grid and load-point history (whose
    integration it can share when the parameters agree too)."""
    twins: list[int] = []
    for run in prepared:
        twins.append(
            next(
                j
                for j, other in enumerate(prepared[: len(twins) + 1])
                if np.array_equal(other.evaluation_times, run.evaluation_times)
                and np.array_equal(other.model_weight, run.model_weight)
                and np.array_equal(other.history.starts, run.history.starts)
                and np.array_equal(other.history.velocities, run.history.velocities)
            )
        )
    return twins


def _steady_setup(
    data: xr.Dataset, lw: Law, free: Sequence[str] | None, initial: Mapping[str, float]
) -> _Setup:
    """Steady-state tables: mu_ss(V) of the law. Memory lengths do not enter, and for the
    aging and slip laws only a - b does: a is held (at ``initial`` or 0.01) and b fitted."""
    velocity = data["load_point_velocity"].values
    mu = data["mu"].values
    if np.unique(velocity).size < 2:
        raise DataError(
            "a steady-state table needs at least two distinct velocities to fit a rate dependence"
        )
    v0 = float(np.exp(np.mean(np.log(velocity))))
    slope = float(np.polyfit(np.log(velocity / v0), mu, 1)[0])
    mu0 = float(np.mean(mu))
    guess = {"mu0": mu0, "a": 0.01, "b": 0.01 - slope, "dc": 1e-5}
    params = {**_initial_params(lw, guess, v0), **initial}
    held = {"dc", "d0"} | ({"a"} if lw.name in ("aging", "slip") else set())
    free_names = _free_names(lw, free, [n for n in lw.default_free if n not in held])

    def forward(values: Mapping[str, float], rtol: float) -> list[FloatArray]:
        return [lw.steady_friction(velocity, lw.own(values))]

    problem = _problem(lw, forward, [mu], 1e-5, params, free_names)
    return _Setup(problem, params, v0, [velocity], "velocity (m/s)", "steady friction coefficient")


def _clamped_setup(
    data: xr.Dataset,
    lw: Law,
    load_exponent: bool,
    free: Sequence[str] | None,
    initial: Mapping[str, float],
) -> _Setup:
    """000's clamped sample: s(t) under the motor extension s_ext(t) for each run (one
    normal force each), from a relaxed start (000/Eqs. 9-14)."""
    from nanoblock.rsf.apparatus import Apparatus, ExtensionProtocol, solve_apparatus

    attrs = data.attrs
    if {"k_s", "c_ext", "c_x"} <= set(attrs):
        apparatus = Apparatus(attrs["k_s"], attrs["c_ext"], attrs["c_x"])
    elif {"k_s", "k_f", "k_ext"} <= set(attrs):
        apparatus = Apparatus.from_stiffnesses(attrs["k_s"], attrs["k_f"], attrs["k_ext"])
    else:
        raise DataError(
            "clamped-sample data need metadata k_s, k_f, k_ext [N/m] (or k_s, c_ext, c_x)"
        )
    if not lw.allows_rest:
        raise ValueError(f"law {lw.name!r} cannot start a clamped sample at rest; use silicon")
    parts = runs(data) if "run" in data else split_by_force(data)
    experiments = []
    for part in parts:
        force = (
            float(part["normal_force"].values[0])
            if "normal_force" in part
            else float(attrs.get("normal_force", math.nan))
        )
        if not force > 0.0:
            raise DataError("clamped-sample data need a normal force (column or metadata) > 0 N")
        time, extension = part["time"].values, part["s_ext"].values
        if np.any(np.diff(extension) < 0.0):
            row = int(np.flatnonzero(np.diff(extension) < 0.0)[0]) + 2
            raise DataError(
                f"column 's_ext' decreases at data row {row} of a run: 000/Eqs. 9-14 assume "
                "a growing motor extension"
            )
        slope = np.diff(extension) / np.diff(time)
        bends = np.flatnonzero(np.abs(np.diff(slope)) > 1e-3 * np.max(np.abs(slope))) + 1
        knots = np.unique(np.concatenate([[0], bends, [time.size - 1]]))
        protocol = ExtensionProtocol(time[knots], extension[knots])
        experiments.append((force, protocol, time, part["s"].values, extension))
    mu_s = max(float(np.max(e[3])) * apparatus.k_s / (2.0 * e[0]) for e in experiments)
    rate = max(float(np.max(np.diff(p.extensions) / np.diff(p.times))) for _, p, *_ in experiments)
    v_drive = rate * apparatus.c_ext / apparatus.c_x
    params = {**_initial_params(lw, {"mu0": mu_s, "a": 1e-3, "b": 0.0, "dc": 1e-6}, v_drive)}
    params.update(initial)
    free_names = _free_names(lw, free, lw.default_free)
    w_ref = reference_load([e[0] for e in experiments], load_exponent)
    if load_exponent:
        free_names.append(LOAD_EXPONENT)
        params.setdefault(LOAD_EXPONENT, 0.0)

    def forward(values: Mapping[str, float], rtol: float) -> list[FloatArray]:
        return [
            solve_apparatus(
                lw, _law_params(lw, values, force, w_ref), apparatus, force, protocol, time
            )["s"].values
            for force, protocol, time, _, _ in experiments
        ]

    travel = max(float(np.max(e[4])) for e in experiments)
    observed = [e[3] for e in experiments]
    problem = _problem(lw, forward, observed, travel, params, free_names)
    return _Setup(
        problem, params, v_drive, [e[4] for e in experiments],
        "motor extension s_ext (m)", "sample extension s (m)",
    )  # fmt: skip


def split_by_force(data: xr.Dataset) -> list[xr.Dataset]:
    """Runs of a clamped-sample file without a ``run`` column: one per normal force."""
    if "normal_force" not in data:
        return [data]
    force = data["normal_force"].values
    return [data.isel(sample=force == value) for value in dict.fromkeys(force)]


def _check_drive(data: xr.Dataset, prepared: Sequence[RunData]) -> None:
    """Refuse a time series whose load point keeps one velocity (the segments of its
    load-point histories, from the velocity column or the displacement's finite
    differences), naming the column the drive came from."""
    velocities = np.unique(np.concatenate([run.history.velocities for run in prepared]))
    if velocities.size < 2:
        drive = next(n for n in ("load_point_velocity", "load_point_displacement") if n in data)
        raise DataError(
            f"{data.attrs.get('source_file', 'the data')}: column {drive!r} gives one velocity "
            f"({float(velocities[0]):.6g} m/s): a rate-and-state fit needs a velocity step, a "
            "hold or several velocities"
        )


def _check_fittable(data: xr.Dataset) -> None:
    """Refuse data a rate-and-state fit cannot say anything about, naming the column:
    non-finite or negative friction, or a constant signal (unless the load point keeps
    one velocity, which :func:`_check_drive` names)."""
    source = data.attrs.get("source_file", "the data")
    name = "s" if data.attrs.get("kind") == "clamped_sample" else "mu"
    if name not in data:
        return
    signal = np.asarray(data[name].values, dtype=float)
    bad = np.flatnonzero(~np.isfinite(signal) | ((signal < 0.0) if name == "mu" else False))
    if bad.size:
        raise DataError(
            f"{source}: column {name!r} has {float(signal[bad[0]])!r} at data row "
            f"{bad[0] + 1}; a fit needs finite friction >= 0"
        )
    velocities = (
        np.unique(data["load_point_velocity"].values) if "load_point_velocity" in data else None
    )
    if np.ptp(signal) == 0.0 and (velocities is None or velocities.size > 1):
        raise DataError(
            f"{source}: column {name!r} is constant ({float(signal[0])!r}): there is no rate "
            "or state effect to fit"
        )


def slip_after_steps(data: xr.Dataset) -> float:
    """Longest load-point travel [m] recorded after a change of the load-point velocity
    and before the next one or the end of its run (0 without a change)."""
    longest = 0.0
    for run in runs(data):
        time = np.asarray(run["time"].values, dtype=float)
        velocity = np.asarray(run["load_point_velocity"].values, dtype=float)
        change = np.flatnonzero(np.diff(velocity) != 0.0) + 1
        for start, stop in zip(change, [*change[1:], velocity.size], strict=True):
            if "load_point_displacement" in run:
                x = run["load_point_displacement"].values
                travel = float(x[stop - 1] - x[start - 1])
            else:
                travel = float(velocity[start] * (time[stop - 1] - time[start - 1]))
            longest = max(longest, travel)
    return longest


MEASURED_DC_Z = 2.0
"""Standard errors above the fitted D_c that must still lie within the record's slip
after a step for D_c to count as measured (a two-sided 95 % bound)."""


def check_state_evolves(data: xr.Dataset, dc: float | None, dc_stderr: float | None) -> None:
    """Refuse a velocity-step record too short after its steps to measure the state's
    evolution: D_c is measured only if the fit excludes D_c beyond the longest load-point
    travel after a velocity change (``dc + MEASURED_DC_Z * dc_stderr`` within it, [m]);
    otherwise friction need not have relaxed by 1/e (001/Eq. 3: theta -> D_c / V over
    D_c of slip) when the record ends, and D_c and b are not measured. (A diagnosis does
    not apply it: there an unbounded base-model D_c is a symptom to explain.)"""
    if data.attrs.get("kind") != "time_series" or dc is None or "load_point_velocity" not in data:
        return
    travel = slip_after_steps(data)
    error = math.inf if dc_stderr is None or not math.isfinite(dc_stderr) else dc_stderr
    if dc + MEASURED_DC_Z * error > travel:
        source = data.attrs.get("source_file", "the data")
        raise DataError(
            f"{source}: at most {travel * 1e6:.3g} um of load-point travel follows a change of "
            f"'load_point_velocity'; the fit (D_c = {dc * 1e6:.3g} +- {error * 1e6:.3g} um) "
            "cannot exclude a D_c beyond it, so D_c and b are not measured: the record ends "
            "too soon after its steps (a fit needs several D_c of slip after a step), or the "
            "law does not describe it (`nanoblock diagnose` names what it misses)"
        )


def check_loss(loss: str, method: str = "lsq") -> None:
    """``ValueError`` naming ``loss`` unless it is one of :data:`LOSSES` and, if robust, goes
    with the least-squares ``method`` (the MCMC likelihood is Gaussian)."""
    if loss not in LOSSES:
        raise ValueError(f"--loss / loss {loss!r} is not one of {', '.join(LOSSES)}")
    if loss != "linear" and method != "lsq":
        raise ValueError(
            f"--loss / loss {loss!r} needs the least-squares fit: the MCMC likelihood is "
            "Gaussian (drop --mcmc, or use loss 'linear')"
        )


def fit_rsf(
    data: xr.Dataset,
    law_name: str = "aging",
    *,
    stiffness: float | None = None,
    trend: bool = False,
    load_exponent: bool = False,
    fit_stiffness: bool = False,
    initial_state: bool = False,
    cohesion: bool = False,
    free: Sequence[str] | None = None,
    initial: Mapping[str, float] | None = None,
    holdout: Sequence[NDArray[np.bool_]] | None = None,
    search: bool | Sequence[str] = True,
    method: str = "lsq",
    mcmc_steps: int = 2000,
    seed: int = 0,
    loss: str = "linear",
) -> FitResult:
    """Fit ``law_name`` to measured data (a :func:`load_measurement` Dataset).

    Time series (velocity steps, slide-hold-slide) go through the spring-slider:
    ``stiffness`` is K/W [1/m], taken from the metadata or fitted when None, and ``trend``
    adds a linear friction trend with load-point displacement [1/m]. Steady-state tables
    are fitted by the law's mu_ss(V); clamped-sample curves (s against s_ext) by 000's
    apparatus (use the ``silicon`` or ``two_state`` law). ``load_exponent`` fits
    D_c (W / W_ref)^n across runs at several normal forces (time series and clamped
    samples). ``fit_stiffness`` fits K/W of a time series even when the metadata state it
    (starting there); ``initial_state`` fits the offsets (:data:`INITIAL_OFFSET`: the
    state of steady sliding at V(0) e^-offset) and ln(v(0) / V(0)) of every run
    (``initial_state_offset_<run>``, ``initial_velocity_offset_<run>``) for records
    that do not start in steady sliding;
    ``cohesion`` fits :data:`COHESION`, a friction level falling with the load across runs.
    ``free`` overrides the free parameters; ``initial`` the starting values (and
    fixes any law parameter that is not free). ``holdout`` (one boolean array per run,
    True = held out) hides samples from the fit; the result's model and residuals still
    cover every sample. ``search`` selects the multi-start grid: every gridded parameter
    (True), only the named ones (a warm start that explores new parameters), or none
    (False: a quick refit from ``initial`` alone, stopped at the coarse ODE tolerance).
    ``method`` is ``"lsq"`` or ``"mcmc"``. ``loss`` (:data:`LOSSES`) is the least-squares
    one or ``"huber"``, the robust fit of :func:`_robust_refit` (``"lsq"`` only).
    """
    lw = law(law_name)
    if method not in ("lsq", "mcmc"):
        raise ValueError(f"method {method!r} is not one of 'lsq', 'mcmc'")
    check_loss(loss, method)
    kind = data.attrs.get("kind")
    initial = dict(initial or {})
    _check_fittable(data)
    options = _Options(fit_stiffness, initial_state, cohesion)
    if kind == "time_series":
        setup = _time_series_setup(
            data, lw, stiffness, trend, load_exponent, free, initial, options
        )
    elif trend or stiffness is not None or options != _Options():
        raise ValueError(f"stiffness and trend apply to time series, not to {kind!r} data")
    elif kind == "steady_state":
        if load_exponent:
            raise ValueError("memory lengths do not enter steady-state tables")
        setup = _steady_setup(data, lw, free, initial)
    elif kind == "clamped_sample":
        setup = _clamped_setup(data, lw, load_exponent, free, initial)
    else:
        raise DataError(f"unknown data kind {kind!r}; read the file with load_measurement")
    if holdout is not None:
        fitted = ~np.concatenate([np.asarray(h, dtype=bool) for h in holdout])
        if fitted.size != sum(y.size for y in setup.problem.observed):
            raise ValueError("holdout needs one boolean array per run, one entry per sample")
        setup = _without_hidden_runs(
            replace(setup, problem=replace(setup.problem, fitted=fitted)), holdout
        )
    if setup.problem.n_fitted <= len(setup.problem.free) + 2:
        raise DataError(
            f"{setup.problem.n_fitted} samples cannot constrain "
            f"{len(setup.problem.free)} free parameters"
        )
    return _solve(lw, setup, method, mcmc_steps, seed, search, loss)


def _without_hidden_runs(setup: _Setup, holdout: Sequence[NDArray[np.bool_]]) -> _Setup:
    """A run held out whole has no sample to fit its own initial offsets by: they are fixed
    at the mean of the other runs' (its forecast assumes runs prepared alike) instead of
    drifting freely along a null direction of the fit."""
    problem = setup.problem
    hidden = [i for i, mask in enumerate(holdout) if np.all(mask)]
    seen = [i for i in range(len(holdout)) if i not in hidden]
    fixed = {}
    for prefix in _INITIAL:
        if hidden and seen and f"{prefix}_{seen[0]}" in problem.free:
            mean = float(np.mean([setup.start[f"{prefix}_{i}"] for i in seen]))
            fixed.update({f"{prefix}_{i}": mean for i in hidden})
    if not fixed:
        return setup
    keep = [i for i, name in enumerate(problem.free) if name not in fixed]
    problem = replace(
        problem,
        fixed={**problem.fixed, **fixed},
        free=tuple(problem.free[i] for i in keep),
        log_scale=tuple(problem.log_scale[i] for i in keep),
    )
    return replace(setup, problem=problem, start={**setup.start, **fixed})


def _ordered(
    problem: _Problem, x: FloatArray, jacobian: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The mirror image of an optimum of an exchangeable law (two state variables with
    the memory lengths in the wrong order), with the Jacobian's columns swapped alike."""
    pairs = problem.law.exchangeable
    names = problem.free
    if not pairs or not all(n in names for pair in pairs for n in pair):
        return x, jacobian
    params = problem.unpack(x)
    short, long = pairs[-1]
    if params[long] >= params[short]:
        return x, jacobian
    order = list(range(len(names)))
    for first, second in pairs:
        i, j = names.index(first), names.index(second)
        order[i], order[j] = j, i
    return x[order], jacobian[:, order]


def _residual_lag1(problem: _Problem, residual: FloatArray) -> float:
    """Lag-1 autocorrelation of the fitted residuals within runs, clipped to
    [0, MAX_LAG1] (residuals of a record with held-out samples are taken as one series)."""
    sizes = [y.size for y in problem.observed] if problem.fitted is None else [residual.size]
    parts = np.split(residual, np.cumsum(sizes)[:-1]) if sum(sizes) == residual.size else [residual]
    products = sum(float(r[1:] @ r[:-1]) for r in parts)
    squares = float(residual @ residual)
    phi = products / squares if squares > 0.0 else 0.0
    return min(max(phi, 0.0), MAX_LAG1)


def _family(name: str) -> str:
    """A parameter's name in the start grid: the prefix of a per-run initial offset (the
    runs' offsets shift together), else the name itself."""
    return next((prefix for prefix in _INITIAL if name.startswith(prefix + "_")), name)


@dataclass(frozen=True)
class _Robust:
    """Huber's fit at its optimum: the loss's corner c (scaled residual units), the samples
    beyond it and the variance numerator sum psi^2 / mean psi' of its standard errors."""

    corner: float
    downweighted: int
    spread: float


def _robust_refit(
    problem: _Problem, start: OptimizeResult, bounds: tuple, rtol: float
) -> tuple[OptimizeResult, _Robust]:
    """Refit from the least-squares optimum ``start`` under Huber's loss, its corner c at
    ``HUBER_K`` robust standard deviations (1.4826 MAD) of ``start``'s residuals.

    Standard errors of the M-estimate (Huber 1981, Eq. 7.6.12 without its small-sample
    factor): s^2 = sum psi(r)^2 / (n - p) / mean psi'(r), psi(r) = clip(r, -c, c), times
    (J_c^T J_c)^-1 with the Jacobian scipy returns for the loss, whose rows beyond c
    vanish (J_c^T J_c = J^T diag(psi') J: the mean psi' of the textbook formula is already
    in it, once)."""
    residual = start.fun
    corner = HUBER_K * float(median_abs_deviation(residual, scale="normal"))
    if not corner > 0.0:  # an exact fit: nothing to down-weight
        return start, _Robust(math.inf, 0, float(residual @ residual))
    fit = least_squares(
        problem.residuals, start.x, args=(rtol,), method="trf", x_scale="jac",
        diff_step=_DIFF_STEP, max_nfev=100, bounds=bounds, loss="huber", f_scale=corner,
    )  # fmt: skip
    inside = np.abs(fit.fun) <= corner
    psi = np.clip(fit.fun, -corner, corner)
    spread = float(psi @ psi) / max(float(np.mean(inside)), 1.0 / fit.fun.size)
    return fit, _Robust(corner, int(np.sum(~inside)), spread)


def _solve(
    lw: Law,
    setup: _Setup,
    method: str,
    mcmc_steps: int,
    seed: int,
    search: bool | Sequence[str],
    loss: str = "linear",
) -> FitResult:
    """Multi-start grid, coarse then fine least squares (then Huber's loss, with ``loss``
    "huber": :func:`_robust_refit`), SVD errors (and optional MCMC)."""
    problem, v0 = setup.problem, setup.reference_velocity
    x0 = problem.pack(setup.start)
    starts = [x0]
    for name, shifts in _START_GRID.items():
        gridded = search is True or (search is not False and name in search)
        members = [i for i, free in enumerate(problem.free) if _family(free) == name]
        if gridded and members:
            step = np.eye(x0.size)[members].sum(axis=0)
            starts = [s + shift * step for s in starts for shift in shifts]
    bounds = _search_bounds(problem, x0)
    costs = []
    for start in starts:
        r = problem.residuals(start, _COARSE_RTOL)
        costs.append(float(r @ r))
    coarse = None
    for index in np.argsort(costs)[:_REFINED_STARTS]:
        trial = least_squares(
            problem.residuals, np.clip(starts[index], *bounds), args=(_COARSE_RTOL,),
            method="trf", x_scale="jac", diff_step=1e-4, max_nfev=200, bounds=bounds,
        )  # fmt: skip
        if coarse is None or trial.cost < coarse.cost:
            coarse = trial
    fine = coarse
    if search is not False:  # a warm refit (search=False) stops at the coarse tolerance
        fine = least_squares(
            problem.residuals, coarse.x, args=(1e-10,), method="trf", x_scale="jac",
            diff_step=_DIFF_STEP, max_nfev=100, bounds=bounds,
        )  # fmt: skip
    robust = None
    if loss == "huber":
        fine, robust = _robust_refit(
            problem, fine, bounds, 1e-10 if search is not False else _COARSE_RTOL
        )
    x, jacobian = _ordered(problem, fine.x, fine.jac)
    residual = fine.fun
    n = residual.size
    dof = max(n - x.size, 1)
    if robust is None:
        lag1 = _residual_lag1(problem, residual)
        squares = float(residual @ residual)
    else:  # the spikes' own (white) scatter would hide the noise's correlation
        lag1 = _residual_lag1(problem, np.clip(residual, -robust.corner, robust.corner))
        squares = robust.spread
    inflation = (1.0 + lag1) / (1.0 - lag1)
    variance = squares / dof * inflation
    covariance = parameter_covariance(jacobian, variance)
    if method == "mcmc":
        x, covariance = _mcmc(problem, x, covariance, variance, mcmc_steps, seed)
        residual = problem.residuals(x, 1e-10)
    best_params = problem.unpack(x)
    try:
        models = problem.models(best_params, 1e-10)
    except RuntimeError:  # stiff at the fine tolerance (a warm refit stops at the coarse one)
        models = problem.models(best_params, _COARSE_RTOL)
    errors = _natural_errors(problem, x, covariance)
    return FitResult(
        law=lw.name,
        params=best_params,
        stderr=errors,
        free=problem.free,
        contract=problem.contract(x, v0),
        contract_stderr=_contract_errors(problem, x, covariance, v0),
        rms_residual=float(np.sqrt(np.mean(residual**2))) * problem.scale,
        n_points=n,
        residual_lag1=lag1,
        method=method,
        loss=loss,
        loss_corner=None if robust is None else robust.corner * problem.scale,
        downweighted=0 if robust is None else robust.downweighted,
        reference_velocity=v0,
        model=models,
        residuals=[m - y for m, y in zip(models, problem.observed, strict=True)],
        observed=problem.observed,
        abscissa=setup.abscissa,
        abscissa_label=setup.abscissa_label,
        observed_label=setup.observed_label,
    )
