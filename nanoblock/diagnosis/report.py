"""Outputs of ``nanoblock diagnose``: ``diagnosis.json`` (the contract), a report a
scientist reads in two minutes, and figures (data with base and extended fits; residuals
before and after)."""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from nanoblock.diagnosis.catalogue import CATALOGUE
from nanoblock.diagnosis.core import Candidate, Diagnosis, shortfalls
from nanoblock.diagnosis.simulation import calibrated_scenarios
from nanoblock.diagnosis.statistics import COLOURED_Z
from nanoblock.diagnosis.window_study import window_text
from nanoblock.toml_writer import scenario_toml

ABSCISSA = {
    "time_series": ("load_point_displacement", "load-point displacement (m)"),
    "clamped_sample": ("s_ext", "motor extension s_ext (m)"),
    "steady_state": ("ln_velocity", "ln velocity (ln m/s)"),
}


def _finite(value: Any) -> Any:
    """JSON-safe: non-finite floats become None, recursively."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer | np.bool_):
        return value.item()
    return value


def _abscissa(diagnosis: Diagnosis) -> tuple[list[np.ndarray], str]:
    name, label = ABSCISSA[diagnosis.kind]
    if name in diagnosis.covariates:
        return diagnosis.covariates[name], label
    return diagnosis.covariates["time"], "time (s)"


def plot_diagnosis(diagnosis: Diagnosis, out: Path) -> dict[str, Path]:
    """``fits.png``: data, base and extended models; ``residuals.png``: residuals of the
    base and the extended model against the abscissa, with the noise band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x_runs, label = _abscissa(diagnosis)
    other = diagnosis.extended or diagnosis.best
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for i, (x, y, base) in enumerate(
        zip(x_runs, diagnosis.observed, diagnosis.base.fit.model, strict=True)
    ):
        order = np.argsort(x, kind="stable")
        ax.plot(x, y, ".", ms=2, color="0.6", label="data" if i == 0 else None)
        ax.plot(x[order], base[order], "-", color="C0", lw=1.2,
                label="base model" if i == 0 else None)  # fmt: skip
        if other is not None:
            model = other.fit.model[i]
            ax.plot(x[order], model[order], "--", color="C3", lw=1.2,
                    label=f"extended: {other.id}" if i == 0 else None)  # fmt: skip
    ax.set_xlabel(label)
    ax.set_ylabel(diagnosis.signal_label)
    ax.set_title(f"diagnosis: {diagnosis.cause}", fontsize=10)
    ax.legend(frameon=False, fontsize=8)
    fig.tight_layout()
    fits = out / "fits.png"
    fig.savefig(fits, dpi=120)
    plt.close(fig)

    rows = [diagnosis.base] + ([other] if other is not None else [])
    fig, axes = plt.subplots(len(rows), 1, sharex=True, figsize=(7, 2.2 * len(rows) + 0.8))
    for ax, candidate in zip(np.atleast_1d(axes), rows, strict=True):
        for x, r in zip(x_runs, candidate.residuals, strict=True):
            ax.plot(x, r, ".", ms=2, color="C0" if candidate is diagnosis.base else "C3")
        ax.axhspan(-2 * diagnosis.noise, 2 * diagnosis.noise, color="0.85", zorder=0)
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_ylabel("model - data")
        ax.set_title(f"{candidate.id}: rms {candidate.rms:.3g} (noise {diagnosis.noise:.3g})",
                     fontsize=9)  # fmt: skip
    np.atleast_1d(axes)[-1].set_xlabel(label)
    fig.tight_layout()
    residuals = out / "residuals.png"
    fig.savefig(residuals, dpi=120)
    plt.close(fig)
    return {"fits": fits, "residuals": residuals}


def _verdict_text(diagnosis: Diagnosis) -> list[str]:
    base = diagnosis.base
    lines = [
        f"- Base model rms residual {base.rms:.3g} against a noise of {diagnosis.noise:.3g} "
        f"(chi^2 ratio {base.structure.chi2_ratio:.2f}; sign-runs z {base.structure.runs_z:.1f}; "
        f"lag-1 autocorrelation {base.structure.lag1:.2f}).",
    ]
    if diagnosis.cause == "none":
        lines.append(
            "- **Verdict: none.** The base model explains the data within noise; no catalogue "
            "extension earns its extra parameters out of sample."
        )
    elif diagnosis.cause == "unexplained":
        best = diagnosis.best
        lines.append(
            "- **Verdict: unexplained.** The residuals are systematic, and no catalogue "
            "extension removes the misfit"
            + (
                f" (the best, {best.id}, explains "
                f"{100 * diagnosis.gain()['variance_explained']:.0f} % of the residual "
                "variance)."
                if best is not None
                else "."
            )
        )
    else:
        effect = CATALOGUE[diagnosis.cause]
        if effect.detector:
            lines.append(f"- Recognised by: {effect.detector}.")
        lines += [
            f"- **Verdict: {effect.id}.** Cause: {effect.cause}.",
            f"- Signature in data: {effect.signature}.",
            f"- Simulator option: `{effect.simulator}`.",
        ]
    return lines


def _summary(diagnosis: Diagnosis) -> str:
    """The report's first paragraph: what is wrong, in plain words."""
    base = diagnosis.base.fit.params
    cause = diagnosis.cause
    if cause == "unstable_sliding":
        event = diagnosis.stick_slip[0]
        critical = (base["b"] - base["a"]) / base["dc"] if "dc" in base else math.nan
        stiffness = base.get("stiffness", math.nan)
        if critical > 0.0:
            stability = (
                f"Its stiffness K/W = {stiffness:.3g} 1/m against the critical "
                f"(b - a)/D_c = {critical:.3g} 1/m of the fit (001/Eqs. 9-11) places the "
                f"slider {'below' if stiffness < critical else 'near or above'} the "
                "stability boundary."
            )
        else:
            stability = (
                f"That mean fit is velocity-strengthening (b - a = {base['b'] - base['a']:.2g}), "
                "so it cannot judge the slider's stability (001/Eqs. 9-11): the drops "
                "themselves are the evidence of instability."
            )
        return (
            f"The record is not steady sliding: at {event.load_point_velocity * 1e6:.3g} um/s "
            f"friction is a regular stick-slip sawtooth ({event.drops} drops of about "
            f"{event.median_drop:.2g} every {event.period * 1e6:.2g} um of load-point travel). "
            "No smooth rate-and-state law can fit it, so the base fit there is only a mean "
            "curve. " + stability
        )
    if cause in ("none", "unexplained"):
        text = {
            "none": "The base model explains the record within its noise.",
            "unexplained": "The base model leaves a systematic misfit that no catalogue "
            "extension removes with plausible parameters and a better forecast."
            + _closest(diagnosis),
        }[cause]
        return text + _not_confirmed(diagnosis, "Not confirmed by the simulation")
    fitted = diagnosis.extended.fit.params
    ratio = diagnosis.gain()["heldout_error_ratio"]
    forecast = f"it forecasts the held-out data {ratio:.2f} times better than the base model."
    words = {
        "two_state_variable": lambda p: (
            f"After the step friction relaxes in two stages, a contact-scale decay over "
            f"D_c = {p['dc'] * 1e6:.3g} um and a slow tail over D_c2 = {p['dc2'] * 1e6:.3g} um "
            f"(b2 = {p['b2']:.2g}) that one state variable cannot follow; "
        ),
        "non_steady_history": lambda p: (
            "The record does not start in steady sliding: friction is still relaxing from an "
            "earlier change (initial state ln(theta/theta_ss) = "
            + ", ".join(f"{v:+.2f}" for k, v in p.items() if k.startswith("initial_state"))
            + "; slip velocity ln(v/V) = "
            + ", ".join(f"{v:+.2f}" for k, v in p.items() if k.startswith("initial_velocity"))
            + "); "
        ),
        "slip_trend": lambda p: (
            f"Friction drifts with slip ({p['slip_trend'] * 1e-3:+.3g} per mm) on top of the "
            "rate-and-state response, as wear or gouge evolution makes it; "
        ),
        "machine_stiffness": lambda p: (
            f"The rise to the peak after the step says the machine's stiffness is "
            f"K/W = {p['stiffness']:.4g} 1/m, not the stated "
            f"{diagnosis.base.fit.params.get('stiffness', math.nan):.4g} 1/m; "
        ),
    }
    effect = CATALOGUE[cause]
    opening = words[cause](fitted) if cause in words else f"The cause is that {effect.cause}; "
    return (
        opening
        + forecast
        + _not_confirmed(diagnosis, "Ranked above it but not confirmed by the simulation")
    )


CLOSEST = 2
"""Extensions (lowest information criterion first) whose shortfalls an ``unexplained``
report names in its first paragraph."""


def _closest(diagnosis: Diagnosis) -> str:
    """The misfit against the noise floor and why the closest extensions fall short of
    the verdict rule (:func:`~nanoblock.diagnosis.core.shortfalls`), in sentences."""
    floor = diagnosis.noise_model.get("floor", diagnosis.noise)
    failed = diagnosis.base.structure.failed
    text = (
        f" Its rms residual is {diagnosis.base.rms:.2g} against a noise floor of {floor:.2g} "
        "at the model's resolution"
        + (f"; systematic by {' and '.join(failed)}." if failed else ".")
    )
    if failed and not any(f.startswith("chi^2") for f in failed):
        z = diagnosis.noise_model.get("lag1_z", math.nan)
        text += (
            " The residuals are no larger than the noise but autocorrelated at its level: a "
            "misfit as fine as the noise, or noise coloured below the colour test (lag-1 z "
            f"{z:.1f} in steady sliding, coloured above {COLOURED_Z})."
        )
    named = [
        f"`{c.id}`: {'; '.join(reasons)}"
        for c in diagnosis.candidates[:CLOSEST]
        if (reasons := shortfalls(c, diagnosis.base, floor))
    ]
    return text + (f" Closest: {'. '.join(named)}." if named else "")


def _not_confirmed(diagnosis: Diagnosis, opening: str) -> str:
    """A sentence naming the causes the simulation check did not confirm ("" if none)."""
    if not diagnosis.not_confirmed:
        return ""
    return f" {opening}: {_names(diagnosis.not_confirmed)} (see the simulation check)."


def _names(ids: Iterable[str]) -> str:
    """Catalogue ids in backticks, comma-separated."""
    return ", ".join(f"`{name}`" for name in ids)


def _noise_text(diagnosis: Diagnosis) -> list[str]:
    noise = diagnosis.noise_model
    if not noise.get("coloured"):
        return []
    return [
        f"The noise is coloured: the scatter about a smooth curve in steady sliding is "
        f"{noise['floor']:.3g}, {noise['floor'] / noise['white']:.1f} times the sample-scale "
        f"white noise; residuals are judged against it, with {noise['n_effective']:.0f} "
        "effectively independent samples.",
        "",
    ]


def _closure_text(diagnosis: Diagnosis) -> list[str]:
    """With ``--closure best``: which closure's pass gave the verdict, and why."""
    if not diagnosis.closures:
        return []

    def refused(entry: dict[str, Any]) -> str:
        names = _names(entry.get("not_confirmed", []))
        return f" (the simulation did not confirm {names})" if names else ""

    passes = ", ".join(
        f"{name} (base law `{entry['law']}`) ends with `{entry['final']}`{refused(entry)} "
        f"at IC {entry['information_criterion']:.1f}"
        for name, entry in diagnosis.closures.items()
    )
    chosen = min(
        diagnosis.closures, key=lambda name: diagnosis.closures[name]["information_criterion"]
    )
    return [
        f"Closure: both were run; {passes}. The verdict is the {chosen} closure's, whose "
        "final model has the lower information criterion.",
        "",
    ]


def _table(candidates: list[Candidate], base: Candidate) -> list[str]:
    lines = [
        "| model | held-out error | IC | Delta IC vs base | rms | residuals systematic |",
        "|---|---|---|---|---|---|",
    ]
    for c in [base, *candidates]:
        heldout = "not scored (IC)" if c.heldout_error is None else f"{c.heldout_error:.4g}"
        lines.append(
            f"| {c.id} | {heldout} | {c.information_criterion:.1f} | "
            f"{base.information_criterion - c.information_criterion:+.1f} | {c.rms:.4g} | "
            f"{'yes' if c.structure.systematic else 'no'} |"
        )
    return lines


def _params(title: str, candidate: Candidate) -> list[str]:
    lines = [f"**{title}** ({candidate.id})", "", "| parameter | value | stderr |", "|---|---|---|"]
    for key, value in candidate.fit.params.items():
        error = candidate.fit.stderr.get(key)
        shown = "" if error is None else f"{error:.3g}"
        lines.append(f"| {key} | {value:.5g} | {shown} |")
    return lines


def write_report(
    diagnosis: Diagnosis,
    source: str,
    figures: dict[str, Path],
    scenarios: tuple[dict[str, Path], str] | None = None,
) -> str:
    """The two-minute report: what is wrong, why, what was changed, what was gained;
    ``scenarios``: the runnable scenarios written and their note (:func:`write_scenarios`)."""
    gain = diagnosis.gain()
    other = diagnosis.extended or diagnosis.best
    lines = [f"# Diagnosis of {source}", "", _summary(diagnosis), "", *_noise_text(diagnosis)]
    if diagnosis.window_study:
        lines += [window_text(diagnosis.window_study), ""]
    lines += [f"Data kind: {diagnosis.kind}.", "", *_closure_text(diagnosis)]
    lines += ["## What is wrong, and why", "", *_verdict_text(diagnosis), ""]
    if other is not None:
        lines += [
            "## What was changed, and what it gained",
            "",
            f"Extension `{other.id}` "
            + ("(accepted)" if other is diagnosis.extended else "(best, not accepted)")
            + f": held-out error ratio base/extended {gain['heldout_error_ratio']:.3f}, "
            f"residual variance explained {100 * gain['variance_explained']:.1f} %, "
            f"Delta IC {gain['delta_information_criterion']:+.1f}.",
            "",
        ]
    check = diagnosis.simulation_check
    if check:
        said = check.get("summary") or f"not run: {check.get('reason', check.get('status'))}"
        lines += ["## Simulation check", "", said, ""]
    if scenarios is not None:
        lines += ["## Runnable scenarios", "", _scenario_text(*scenarios), ""]
    lines += ["## Ranking (held-out blocks and BIC)", "", *_table(diagnosis.candidates,
                                                                 diagnosis.base), ""]  # fmt: skip
    if diagnosis.untestable:
        lines += ["Not testable on these data:", ""]
        lines += [f"- {key}: {reason}" for key, reason in diagnosis.untestable.items()]
        lines.append("")
    lines += [*_params("Base fit", diagnosis.base), ""]
    if other is not None:
        lines += [*_params("Extended fit", other), ""]
    lines += [f"![{name}]({path.name})" for name, path in figures.items()]
    return "\n".join(lines) + "\n"


def _scenario_text(written: dict[str, Path], note: str) -> str:
    """What the runnable scenarios are, or why there are none."""
    if not written:
        return f"None written: {note}."
    files = " and ".join(f"`{path.name}`" for path in written.values())
    run = "`nanoblock run FILE --out STORE.zarr`"
    return f"{files}: {run} simulates the calibrated interface ({note})."


def write_scenarios(
    diagnosis: Diagnosis, data: xr.Dataset, out: Path
) -> tuple[dict[str, Path], str]:
    """``base.toml`` and ``extended.toml``: the calibrated nanoblock interface without and
    with the cause (or the best extension), so ``nanoblock run`` reproduces the simulation
    check and a user can continue from it; and the note on their scaling, or on why one or
    both are missing."""
    other = diagnosis.extended or diagnosis.best
    base = diagnosis.base.fit
    scenarios, note = calibrated_scenarios(
        data, base.params,
        None if other is None else other.id, {} if other is None else other.fit.params,
        laws=(base.law, (diagnosis.base if other is None else other).fit.law),
    )  # fmt: skip
    written = {}
    for name, scenario in scenarios.items():
        what = "base model" if name == "base" else f"base model with {other.id} switched on"
        path = out / f"{name}.toml"
        path.write_text(scenario_toml(scenario, f"nanoblock diagnose: the {what}\n{note}"))
        written[name] = path
    return written, note


def write_diagnosis(
    diagnosis: Diagnosis, out: str | Path, source: str, data: xr.Dataset | None = None
) -> dict[str, Path]:
    """Write ``diagnosis.json``, ``report.md``, ``fits.png``, ``residuals.png`` and (given
    the ``data``) the runnable ``base.toml`` and ``extended.toml``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    figures = plot_diagnosis(diagnosis, out)
    json_path = out / "diagnosis.json"
    json_path.write_text(json.dumps(_finite(diagnosis.to_json()), indent=2) + "\n")
    scenarios = write_scenarios(diagnosis, data, out) if data is not None else None
    report = out / "report.md"
    report.write_text(write_report(diagnosis, source, figures, scenarios))
    written = scenarios[0] if scenarios is not None else {}
    return {"json": json_path, "report": report, **figures, **written}
