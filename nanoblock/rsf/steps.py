"""Per-step against shared parameters (issue 15): is one law, with one set of a, b and
D_c, enough for every step of a record (or every file of one experiment)?

The runs of the data (one per step after :func:`~nanoblock.rsf.windows.step_windows`, or
the files of an experiment as runs) are fitted jointly with shared parameters and each on
its own. The two are compared by the information criterion of the diagnosis (Bayesian,
variance estimated, n_eff ln(RSS / n) + k ln n_eff), with n_eff = n (1 - phi) / (1 + phi)
the effective samples of the per-step residuals' lag-1 autocorrelation phi: the steps
*differ* when per-step parameters lower it by more than :data:`STRONG_EVIDENCE`. Under
shared parameters and white noise, twice the log-likelihood ratio is chi^2 with the
extra parameters' degrees of freedom, so the penalty (k_extra ln n_eff + 10) puts a false
alarm far below 1e-6 for two steps of a few hundred samples; a D_c doubled between steps
at noise 2e-4 is found (``tests/test_fit.py``). Each of a, b and ln D_c also gets a
chi^2 of the per-step values about their weighted mean, with the per-step standard errors
(inflated for autocorrelated residuals by :func:`~nanoblock.rsf.fit.fit_rsf`). A shared
mu0 means that a drift of the friction level between steps also counts as a difference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from scipy.stats import chi2

from nanoblock.measured import DataError, runs
from nanoblock.rsf.fit import MAX_LAG1, FitResult, fit_rsf

__all__ = ["STRONG_EVIDENCE", "StepComparison", "compare_steps"]

STRONG_EVIDENCE = 10.0
"""Drop of the information criterion that makes per-step parameters preferred."""
COMPARED = ("a", "b", "dc")
"""Parameters whose per-step values are tested for consistency (dc in ln)."""


@dataclass
class StepComparison:
    """The shared fit, the per-step fits and their comparison."""

    shared: FitResult
    steps: list[FitResult]
    labels: list[str]
    lag1: float
    n_effective: float
    information_criterion: dict[str, float]
    consistency: dict[str, dict[str, float]]

    @property
    def delta(self) -> float:
        """IC(shared) - IC(per step): above STRONG_EVIDENCE the steps differ."""
        return self.information_criterion["shared"] - self.information_criterion["per_step"]

    @property
    def differ(self) -> bool:
        return self.delta > STRONG_EVIDENCE

    def to_json(self) -> dict[str, Any]:
        def clean(value: float | None) -> float | None:
            return None if value is None or not math.isfinite(value) else float(value)

        return {
            "differ": self.differ,
            "delta_information_criterion": self.delta,
            "information_criterion": self.information_criterion,
            "lag1": self.lag1,
            "n_effective": self.n_effective,
            "steps": [
                {
                    "label": label,
                    "n_points": fit.n_points,
                    "rms_residual": fit.rms_residual,
                    **{k: clean(fit.contract[k]) for k in COMPARED},
                    "stderr": {k: clean(fit.contract_stderr[k]) for k in COMPARED},
                }
                for label, fit in zip(self.labels, self.steps, strict=True)
            ],
            "shared": {k: clean(self.shared.contract[k]) for k in COMPARED},
            "consistency": self.consistency,
        }


def _information_criterion(rss: float, n: int, n_free: int, n_effective: float) -> float:
    return n_effective * math.log(max(rss, 1e-300) / n) + n_free * math.log(max(n_effective, 2.0))


def _consistency(steps: list[FitResult]) -> dict[str, dict[str, float]]:
    """chi^2 of each compared parameter's per-step values about their weighted mean."""
    out = {}
    for name in COMPARED:
        values, errors = [], []
        for fit in steps:
            value, error = fit.contract[name], fit.contract_stderr[name]
            if value is None or error is None or not (math.isfinite(error) and error > 0.0):
                break
            if name == "dc":
                value, error = math.log(value), error / value
            values.append(value)
            errors.append(error)
        else:
            x, w = np.array(values), 1.0 / np.array(errors) ** 2
            mean = float(np.sum(w * x) / np.sum(w))
            statistic = float(np.sum(w * (x - mean) ** 2))
            dof = len(values) - 1
            out[name] = {"chi2": statistic, "dof": dof, "p_value": float(chi2.sf(statistic, dof))}
    return out


def compare_steps(data: xr.Dataset, law_name: str = "aging", **options: Any) -> StepComparison:
    """Fit the runs of a time series jointly and one by one (``options`` go to
    :func:`~nanoblock.rsf.fit.fit_rsf`, e.g. ``stiffness``) and compare them."""
    parts = runs(data)
    if data.attrs.get("kind") != "time_series" or len(parts) < 2:
        raise DataError(
            "per-step parameters need a time series with two or more steps: give a fit "
            "window (one run per step) or several runs"
        )
    shared = fit_rsf(data, law_name, **options)
    steps = []
    for part in parts:
        part.attrs = dict(data.attrs)
        steps.append(fit_rsf(part, law_name, **options))
    labels = str(data.attrs.get("windows", "")).split("; ")
    if len(labels) != len(steps):
        labels = [f"run {i}" for i in range(len(steps))]
    residuals = [r for fit in steps for r in fit.residuals]
    squares = sum(float(r @ r) for r in residuals)
    products = sum(float(r[1:] @ r[:-1]) for r in residuals)
    lag1 = min(max(products / squares if squares > 0.0 else 0.0, 0.0), MAX_LAG1)
    n = sum(r.size for r in residuals)
    n_effective = n * (1.0 - lag1) / (1.0 + lag1)
    shared_rss = sum(float(r @ r) for r in shared.residuals)
    criteria = {
        "shared": _information_criterion(shared_rss, n, len(shared.free), n_effective),
        "per_step": _information_criterion(
            squares, n, sum(len(fit.free) for fit in steps), n_effective
        ),
    }
    return StepComparison(shared, steps, labels, lag1, n_effective, criteria, _consistency(steps))


def step_text(comparison: StepComparison) -> str:
    """The report's section: per-step a, b, D_c with errors and the verdict."""
    rows = []
    for label, fit in zip(comparison.labels, comparison.steps, strict=True):
        cells = []
        for name in COMPARED:
            value, error = fit.contract[name], fit.contract_stderr[name]
            shown = "-" if error is None or not math.isfinite(error) else f"{error:.2g}"
            cells.append(f"{value:.4g} +- {shown}")
        rows.append(f"| {label} | " + " | ".join(cells) + " |")
    shared = " | ".join(f"{comparison.shared.contract[name]:.4g}" for name in COMPARED)
    tests = ", ".join(
        f"{name}: chi^2 {row['chi2']:.3g} on {row['dof']} dof (p = {row['p_value']:.2g})"
        for name, row in comparison.consistency.items()
    )
    verdict = (
        "the steps **differ**: per-step parameters"
        if comparison.differ
        else "shared parameters are enough: per-step ones do not"
    )
    return "\n".join(
        [
            "## Per-step against shared parameters",
            "",
            "| step | a | b | dc (m) |",
            "|---|---|---|---|",
            *rows,
            f"| shared | {shared} |",
            "",
            f"Information criterion (effective samples {comparison.n_effective:.0f}, lag-1 "
            f"autocorrelation {comparison.lag1:.2f}): {verdict} lower it by "
            f"{comparison.delta:.1f} (threshold {STRONG_EVIDENCE:g}). Consistency of the "
            f"per-step values within their errors: {tests or 'no finite errors'}.",
            "",
        ]
    )
