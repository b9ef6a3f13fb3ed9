"""Outputs of ``nanoblock fit``: ``fit.json``, a two-minute ``report.md`` and a PNG of
data, fitted model and residuals."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.stats import norm

from nanoblock.rsf.fit import HUBER_K, STIFFNESS, TREND, FitResult
from nanoblock.rsf.laws import law
from nanoblock.rsf.steps import StepComparison, step_text

__all__ = ["plot_fit", "residual_summary", "write_fit"]

_UNITS = {"dc": "m", "d0": "m", "v0": "m/s", "v_theta": "m/s", "v_star": "m/s"}
_UNITS |= {"aging_rate": "1/s", STIFFNESS: "1/m", TREND: "1/m"}


def plot_fit(result: FitResult, data: xr.Dataset, path: str | Path) -> Path:
    """Data and fitted model of every run against its abscissa, with residuals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 5.5), height_ratios=[3, 1])
    runs = zip(result.abscissa, result.observed, result.model, result.residuals, strict=True)
    for i, (x, observed, model, residual) in enumerate(runs):
        order = np.argsort(x, kind="stable")
        top.plot(x, observed, ".", ms=2, color="0.6", label="data" if i == 0 else None)
        top.plot(x[order], model[order], "-", color="C3", lw=1.2,
                 label=f"{result.law} law" if i == 0 else None)  # fmt: skip
        bottom.plot(x, residual, ".", ms=2, color="C0")
    if result.abscissa_label.startswith("velocity"):
        bottom.set_xscale("log")
    bottom.axhline(0.0, color="k", lw=0.8)
    top.set_ylabel(result.observed_label)
    top.legend(frameon=False)
    top.set_title(Path(str(data.attrs.get("source_file", "data"))).name, fontsize=9)
    bottom.set_ylabel("model - data")
    bottom.set_xlabel(result.abscissa_label)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return Path(path)


def residual_summary(result: FitResult) -> dict[str, float]:
    """Lag-1 autocorrelation and RMS of the residuals (structure left by the law)."""
    r = np.concatenate(result.residuals)
    lag1 = float(np.corrcoef(r[:-1], r[1:])[0, 1]) if r.size > 2 else math.nan
    return {"rms": float(np.sqrt(np.mean(r**2))), "lag1_autocorrelation": lag1}


def _format(value: float | None, error: float | None) -> tuple[str, str]:
    if value is None:
        return "-", "-"
    text = f"{value:.5g}"
    if error is None:
        return text, "fixed"
    return text, "unidentified" if not math.isfinite(error) else f"{error:.2g}"


def _loss_text(result: FitResult) -> str:
    """With Huber's loss: how many samples it down-weighted, against Gaussian noise's share."""
    if result.loss != "huber":
        return ""
    gaussian = 2.0 * float(norm.sf(HUBER_K))
    return (
        f" Huber's loss: {result.downweighted} of {result.n_points} samples "
        f"({100 * result.downweighted / result.n_points:.0f} %; {100 * gaussian:.0f} % for "
        f"Gaussian noise) lie beyond its corner {result.loss_corner:.3g} ({HUBER_K} robust "
        "standard deviations of the least-squares residuals) and pull with a constant force. "
        "Where the parameters move much from the least-squares fit's, the misfit's tails "
        "carry them (spikes, or a systematic misfit: `nanoblock diagnose` tells which)."
    )


def _report(result: FitResult, data: xr.Dataset, figure: str) -> str:
    contract_rows = []
    for key in ("mu0", "a", "b", "dc"):
        value, error = _format(result.contract[key], result.contract_stderr[key])
        unit = "m" if key == "dc" else "-"
        contract_rows.append(f"| {key} | {value} | {error} | {unit} |")
    native_rows = []
    for key, value in result.params.items():
        fitted, error = _format(value, result.stderr.get(key))
        native_rows.append(f"| {key} | {fitted} | {error} | {_UNITS.get(key, '-')} |")
    a, b = result.contract["a"], result.contract["b"]
    regime = "velocity weakening (b > a)" if b > a else "velocity strengthening (a >= b)"
    structure = residual_summary(result)
    unidentified = [k for k, e in result.stderr.items() if not math.isfinite(e)]
    stiffness_note = ""
    if STIFFNESS in result.params:
        source = "fitted" if STIFFNESS in result.free else "from the metadata or the caller"
        stiffness_note = f"Machine stiffness K/W {result.params[STIFFNESS]:.4g} 1/m, {source}."
    lines = [
        f"# Rate-and-state fit: {law(result.law).summary}",
        "",
        f"Data: `{data.attrs.get('source_file', 'in memory')}`, {result.n_points} samples, "
        f"method `{result.method}`, reference velocity {result.reference_velocity:.4g} m/s. "
        + stiffness_note
        + (
            f" {data.attrs['dropped_rows']} rows with a missing (NaN or empty) value "
            "were dropped before the fit."
            if data.attrs.get("dropped_rows")
            else ""
        ),
        "",
        f"**Result.** a - b = {a - b:.3g}: {regime}. RMS residual {result.rms_residual:.3g}; "
        f"lag-1 autocorrelation of the residuals {structure['lag1_autocorrelation']:.2f} "
        "(near 0: white; near 1: structure the law leaves unexplained).",
        "",
        "| parameter | value | standard error | unit |",
        "|---|---|---|---|",
        *contract_rows,
        "",
        "The law's own parameters:",
        "",
        "| parameter | value | standard error | unit |",
        "|---|---|---|---|",
        *native_rows,
        "",
        "Standard errors come from the Jacobian at the optimum, inflated by "
        f"sqrt((1 + phi) / (1 - phi)) for the residuals' lag-1 autocorrelation phi = "
        f"{result.residual_lag1:.2f} (AR(1)); structure beyond AR(1) makes them optimistic."
        + _loss_text(result),
    ]
    if unidentified:
        lines += [
            "",
            f"**Not identifiable from these data:** {', '.join(unidentified)} (the Jacobian "
            "is singular along them; e.g. a machine too soft to resolve D_c).",
        ]
    lines += ["", f"![data, fit and residuals]({figure})", ""]
    return "\n".join(lines)


def write_fit(
    result: FitResult, data: xr.Dataset, out: str | Path, steps: StepComparison | None = None
) -> dict[str, Path]:
    """Write ``fit.json``, ``report.md`` and ``fit.png`` into directory ``out``; with
    ``steps`` (:func:`~nanoblock.rsf.steps.compare_steps`) the per-step comparison goes
    into the report and under ``per_step`` in ``fit.json``. ``dropped_rows`` in
    ``fit.json`` (and a sentence of the report) counts the rows dropped for a missing
    value when the file was read."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    figure = plot_fit(result, data, out / "fit.png")
    report = out / "report.md"
    text = _report(result, data, figure.name)
    written = result.write_json(out / "fit.json")
    extra = {"dropped_rows": int(data.attrs.get("dropped_rows", 0))}
    if steps is not None:
        text += "\n" + step_text(steps)
        extra["per_step"] = steps.to_json()
    summary = json.loads(written.read_text())
    written.write_text(json.dumps({**summary, **extra}, indent=2) + "\n")
    report.write_text(text)
    return {"json": written, "report": report, "figure": figure}
