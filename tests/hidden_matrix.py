"""The hidden-effect acceptance matrix: its cases, each case's expected answer (fixed by a
rule before any verdict), the diagnosis of one case, and the rates with Clopper-Pearson
bounds (``benchmarks/bench_hidden_effects.py`` runs it all; the suite a stratified draw).

Expected answer: ``none`` for an effect-free case; ``unstable_sliding`` for the slider
below its critical stiffness; otherwise the drawn effect when it is visible, else
``none``. Visible means that the base model (in the diagnosis's closure, ``closed_base``)
fitted to the *noiseless* data leaves
chi^2 >= :data:`VISIBLE_CHI2`, chi^2 = sum r^2 / (sigma^2 (1 + phi) / (1 - phi)) with
sigma and phi the standard deviation and lag-1 autocorrelation of the noise actually
added (so coloured noise counts its effective samples): an effect the base model absorbs
below that cannot pass the diagnosis's 10-unit information criterion with the 7-unit
penalty of a parameter at ~1000 samples.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np
from scipy.stats import beta

from nanoblock.diagnosis import diagnose
from nanoblock.diagnosis.core import DEFAULT_CLOSURE, closed_base
from nanoblock.diagnosis.resample import resample_by_travel
from nanoblock.diagnosis.surrogates import Measurement
from nanoblock.rsf.fit import fit_rsf, split_by_force
from tests.engine_synthetic import ENGINE_EFFECTS, engine_time_series
from tests.hidden_synthetic import EFFECTS, MAKERS, draw_interface

SEED = 20261125
VISIBLE_CHI2 = 25.0
"""Noiseless base-fit chi^2 from which an effect is expected to be named."""
CONFIDENCE = 0.95
"""Of the one-sided Clopper-Pearson lower bounds (2.5 % in each tail of the interval)."""
KINDS = tuple(EFFECTS)
"""The kinds of the suite's draw and of the default matrix."""
ENGINE_KIND = "engine_time_series"
"""Time series made by the nanoblock engine (``tests/engine_synthetic.py``): a matrix of
its own, run by naming the kind (``bench_hidden_effects.py 2 2 engine_time_series``)."""
ALL_EFFECTS = {**EFFECTS, ENGINE_KIND: ENGINE_EFFECTS}
ALL_MAKERS = {**MAKERS, ENGINE_KIND: engine_time_series}


@dataclass(frozen=True)
class Case:
    kind: str
    effect: str
    index: int

    def rng(self) -> np.random.Generator:
        """Its own stream: a case's data do not depend on which other cases run."""
        effects = ("none", *ALL_EFFECTS[self.kind])
        key = [SEED, list(ALL_EFFECTS).index(self.kind), effects.index(self.effect), self.index]
        return np.random.default_rng(key)


def cases(per_effect: int, none_per_kind: int, kinds: tuple[str, ...] = KINDS) -> list[Case]:
    """``per_effect`` cases of every effect of every kind (of ``kinds``) and
    ``none_per_kind`` effect-free ones per kind, interleaved (case i of every effect before
    case i + 1), so that any prefix is stratified."""
    out = []
    for i in range(max(per_effect, none_per_kind)):
        for kind in kinds:
            effects = ALL_EFFECTS[kind] if i < per_effect else ()
            out.extend(Case(kind, e, i) for e in (("none",) if i < none_per_kind else ()))
            out.extend(Case(kind, e, i) for e in effects)
    return out


def _signal(data) -> np.ndarray:
    return data["s" if data.attrs["kind"] == "clamped_sample" else "mu"].values


def base_chi2(data, clean, closure: str = DEFAULT_CLOSURE) -> float:
    """chi^2 of the base model (in the diagnosis's ``closure``) fitted to the noiseless
    ``clean`` (see the module docstring)."""
    noise = _signal(data) - _signal(clean)
    phi = float(np.corrcoef(noise[:-1], noise[1:])[0, 1])
    variance = np.var(noise) * (1.0 + phi) / (1.0 - phi)
    measurement = Measurement(resample_by_travel(clean))
    _, fit = closed_base(measurement, closure)
    squares = sum(
        float(np.sum((m - y) ** 2)) for m, y in zip(fit.model, measurement.observed, strict=True)
    )
    return squares / variance


def truth_chi2(case: Case) -> dict[str, float]:
    """chi^2 of the renewal law at a time-series case's true a, b, D (only mu0 refitted)
    against its noiseless record, over every run at the variance of the noise actually
    added: ``recorded`` (the record's samples) and ``resampled``
    (:func:`~nanoblock.diagnosis.resample.resample_by_travel`, the diagnosis's input).
    An effect-free record should leave both below :data:`VISIBLE_CHI2`."""
    a, b, d0, mu0 = draw_interface(case.rng())
    data, clean = ALL_MAKERS[case.kind](case.effect, case.rng())
    variance = float(np.var(_signal(data) - _signal(clean)))
    chi2 = {}
    for label, record in (("recorded", clean), ("resampled", resample_by_travel(clean))):
        squares = 0.0
        for run in split_by_force(record):
            fit = fit_rsf(
                run, "renewal", stiffness=clean.attrs["stiffness_per_load"],
                initial={"mu0": mu0, "a": a, "b": b, "dc": d0}, free=["mu0"], search=False,
            )  # fmt: skip
            squares += float(np.sum(fit.residuals[0] ** 2))
        chi2[label] = squares / variance
    return chi2


def expected_answer(
    case: Case, data, clean, closure: str = DEFAULT_CLOSURE
) -> tuple[str, float | None]:
    """(expected verdict, noiseless base chi^2 or None when the rule does not need it).
    An engine-made record has no noiseless twin: its expected answer is the effect drawn
    (each drawn from the renewal generator's ranges, where that generator's effects are
    visible)."""
    if case.effect in ("none", "unstable_sliding") or clean is None:
        return case.effect, None
    chi2 = base_chi2(data, clean, closure)
    return (case.effect if chi2 >= VISIBLE_CHI2 else "none"), chi2


def run_case(case: Case, closure: str = DEFAULT_CLOSURE) -> dict:
    """Make the case, fix its expected answer, then diagnose it with the base law's
    ``closure`` (CPU seconds recorded)."""
    started = time.process_time()
    data, clean = ALL_MAKERS[case.kind](case.effect, case.rng())
    expected, chi2 = expected_answer(case, data, clean, closure)
    verdict = diagnose(data, closure=closure).cause
    seconds = time.process_time() - started
    return {**asdict(case), "expected": expected, "chi2": chi2, "verdict": verdict,
            "cpu_seconds": seconds}  # fmt: skip


def lower_bound(right: int, total: int) -> float:
    """Clopper-Pearson lower bound of a rate (two-sided :data:`CONFIDENCE` interval)."""
    if right == 0:
        return 0.0
    return float(beta.ppf((1.0 - CONFIDENCE) / 2.0, right, total - right + 1))


def summary(results: list[dict]) -> dict:
    """Confusion counts (kind:truth x verdict), per-effect and overall rates with bounds."""
    confusion: dict[str, dict[str, int]] = {}
    groups: dict[str, list[bool]] = {}
    for r in results:
        truth = f"{r['kind']}:{r['effect']}"
        row = confusion.setdefault(truth, {})
        row[r["verdict"]] = row.get(r["verdict"], 0) + 1
        groups.setdefault(truth, []).append(r["verdict"] == r["expected"])
    expected_effect = [r["verdict"] == r["expected"] for r in results if r["expected"] != "none"]
    expected_none = [r["verdict"] == "none" for r in results if r["expected"] == "none"]

    def rate(hits: list[bool]) -> dict:
        k, n = int(sum(hits)), len(hits)
        return {"right": k, "cases": n, "rate": k / n if n else None,
                "lower_bound": lower_bound(k, n) if n else None}  # fmt: skip

    return {
        "confusion": confusion,
        "per_effect": {truth: rate(hits) for truth, hits in groups.items()},
        "effect_expected": rate(expected_effect),
        "none_expected": rate(expected_none),
        "all": rate([r["verdict"] == r["expected"] for r in results]),
    }


def markdown(confusion: dict[str, dict[str, int]]) -> str:
    """The confusion counts as a markdown table (rows: kind:truth; columns: verdicts)."""
    verdicts = sorted({v for row in confusion.values() for v in row})
    lines = ["| truth | " + " | ".join(verdicts) + " |", "|---" * (len(verdicts) + 1) + "|"]
    for truth in sorted(confusion):
        cells = [str(confusion[truth].get(v, "")) for v in verdicts]
        lines.append(f"| {truth} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
