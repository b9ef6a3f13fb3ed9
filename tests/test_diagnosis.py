"""Diagnosis: statistics against closed forms, the catalogue registry, refusals of bad data,
the command line, and hidden effects found in data made by other code paths."""

from __future__ import annotations

import functools
import inspect
import json
import math
import re
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy.signal import lfilter
from scipy.stats import binom
from typer.testing import CliRunner

from nanoblock.cli import app
from nanoblock.diagnosis import CATALOGUE, DiagnosisError, core, diagnose, load_for_diagnosis
from nanoblock.diagnosis.catalogue import BASE
from nanoblock.diagnosis.core import closed_base
from nanoblock.diagnosis.report import _closure_text, _summary
from nanoblock.diagnosis.resample import resample_by_travel
from nanoblock.diagnosis.simulation import SEEDS, SWITCHES
from nanoblock.diagnosis.statistics import blocked_folds, noise_level, runs_test, structure
from nanoblock.diagnosis.surrogates import Measurement
from nanoblock.diagnosis.validation import check_diagnosable
from nanoblock.rsf.laws import law
from tests.diagnosis_synthetic import NOISE, clamped_case, steady_case, time_series_case
from tests.hidden_matrix import Case, cases, run_case
from tests.hidden_synthetic import MAKERS
from tests.rsf_synthetic import record, write_csv
from tests.tolerances import SIGNIFICANCE, max_misses

PHYSICS = Path(__file__).resolve().parents[2] / "shared" / "physics.md"
CONTRACT = {"cause", "ranking", "base", "extended", "gain", "simulation_check"}


def test_noise_level_of_white_noise_on_a_smooth_signal() -> None:
    """Second-difference MAD estimate: unbiased for white noise; its relative standard
    error at n samples is ~ 1.65 / sqrt(n) (MAD efficiency 37 %, 3 overlapping terms)."""
    rng = np.random.default_rng(1)
    n, sigma = 20_000, 3e-4
    t = np.linspace(0.0, 1.0, n)
    signal = 0.6 + 0.02 * np.log1p(50 * t) + 0.01 * (t > 0.5)  # smooth, plus one jump
    estimate = noise_level([signal + sigma * rng.standard_normal(n)])
    assert estimate == pytest.approx(sigma, rel=5 * 1.65 / math.sqrt(n))


def test_structure_of_white_and_of_correlated_residuals() -> None:
    """White residuals: runs z and lag-1 z are N(0, 1); a random walk is systematic."""
    rng = np.random.default_rng(2)
    white = [rng.standard_normal(4000)]
    s = structure(white, 1.0)
    assert abs(s.runs_z) < 4 and abs(s.lag1_z) < 4 and not s.systematic
    walk = [np.cumsum(rng.standard_normal(4000)) * 0.05]
    assert structure(walk, 1.0).systematic
    assert runs_test(walk) < -5


def test_structure_names_its_failed_tests_and_drops_ordering_ones_on_coloured_noise() -> None:
    """AR(1) residuals (phi = 0.5) of unit variance judged against their own standard
    deviation: chi^2 ~ 1 passes, while lag-1 (z ~ 0.5 sqrt(4000) = 32) and sign runs fail
    on the white-noise branch; flagged as coloured noise only the variance test applies;
    twice the noise's variance fails it either way."""
    rng = np.random.default_rng(4)
    shocks = rng.standard_normal(4200) * math.sqrt(0.75)
    ar = [lfilter([1.0], [1.0, -0.5], shocks)[200:]]
    failed = structure(ar, 1.0).failed
    assert len(failed) == 2 and failed[0].startswith("sign runs") and "lag-1" in failed[1]
    assert structure(ar, 1.0, coloured=True, n_effective=4000 / 3).failed == []
    doubled = structure([math.sqrt(2.0) * ar[0]], 1.0, coloured=True, n_effective=4000 / 3)
    assert doubled.systematic and doubled.failed[0].startswith("chi^2 ratio")


def test_blocked_folds_hold_out_every_sample_once() -> None:
    folds = blocked_folds([95, 40], n_folds=4, block_length=10)
    for run in range(2):
        total = sum(fold[run].astype(int) for fold in folds)
        assert np.all(total == 1)
    assert folds[1][0][10:20].all() and not folds[1][0][:10].any()


def test_catalogue_is_complete_and_documented() -> None:
    """Every id of physics.md section 5's tables is registered, every registered id
    (those the records added too) is in the project's own physics page, each with a cause,
    a simulator option and a surrogate for at least one kind of data."""
    table = r"^\| `?([a-z_]+)`? \|"
    if PHYSICS.exists():
        section = PHYSICS.read_text().split("## 5.")[1].split("## 6.")[0]
        ids = set(re.findall(table, section, flags=re.MULTILINE)) - {"id"}
        assert ids <= set(CATALOGUE)
    own = (Path(__file__).resolve().parents[1] / "docs" / "physics.md").read_text()
    assert set(CATALOGUE) <= set(re.findall(table, own, flags=re.MULTILINE))
    for effect in CATALOGUE.values():
        assert effect.cause and effect.signature and effect.simulator
        assert effect.surrogates or effect.detector


_FLAGGED = {
    "trend": "slip_trend",
    "load_exponent": "dc_load_exponent",
    "cohesion": "cohesion_ratio",
    "fit_stiffness": "stiffness_ratio",
}
"""Parameters an RsfVariant flag adds to its law (its plausibility name)."""


@pytest.mark.parametrize(
    "effect",
    [e for e in CATALOGUE.values() if "time_series" in e.surrogates],
    ids=lambda e: e.id,
)
def test_every_parameter_a_time_series_extension_adds_has_a_physical_range(effect) -> None:
    """A cause is accepted only with plausible parameters (issue 15), so every parameter
    the time-series surrogate adds to the base law, from its own law or its flags, needs
    a range [low, high] with low < high. Until 2026-11-29 tau_m, v_theta and the load
    exponent had none: any value was accepted."""
    variant = effect.surrogates["time_series"]
    added = set(law(variant.law).names) - set(law(BASE["time_series"].law).names)
    added |= {name for flag, name in _FLAGGED.items() if getattr(variant, flag)}
    if variant.initial_state:
        added |= {"initial_state_offset", "initial_velocity_offset"}
    assert added <= set(effect.ranges)
    assert all(low < high for low, high in effect.ranges.values())


def _step_record(n: int = 400):
    rng = np.random.default_rng(4)
    truth = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6}
    data = record("aging", truth, "velocity_step", 2500.0, rng, n_samples=n)
    data.attrs["stiffness_per_load"] = 2500.0
    return data


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ("few", "needs at least 50"),
        ("one_velocity", "one velocity only"),
        ("constant", "is constant"),
        ("nan", "missing"),
    ],
)
def test_bad_data_is_refused_with_what_would_be_needed(change: str, message: str) -> None:
    data = _step_record()
    if change == "few":
        data = data.isel(sample=slice(0, 30))
    elif change == "one_velocity":
        data = data.isel(sample=slice(0, 250))  # before the step
    elif change == "constant":
        data["mu"].values[:] = 0.6
    else:
        data["mu"].values[7] = np.nan
    with pytest.raises(DiagnosisError, match=message):
        check_diagnosable(data)


def test_small_steady_table_is_refused() -> None:
    rng = np.random.default_rng(5)
    data = steady_case("none", rng, NOISE["steady_state"]).isel(sample=slice(0, 6))
    with pytest.raises(DiagnosisError, match="decades"):
        diagnose(data)


def test_csv_with_missing_values_is_refused(tmp_path: Path) -> None:
    data = _step_record()
    data["mu"].values[[3, 9]] = np.nan
    path = write_csv(data, tmp_path / "gappy.csv", {"stiffness_per_load": 2500.0})
    with pytest.raises(DiagnosisError, match="complete rows"):
        load_for_diagnosis(path)
    result = CliRunner().invoke(app, ["diagnose", str(path), "--out", str(tmp_path / "d")])
    assert result.exit_code == 2 and "complete rows" in result.output


def test_cli_writes_the_contract(tmp_path: Path) -> None:
    """A slip-trended velocity step: the command writes diagnosis.json with the contract
    keys, a report and two figures, and names the trend."""
    rng = np.random.default_rng(6)
    truth = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6}
    data = record("aging", truth, "velocity_step", 2500.0, rng, n_samples=400, trend=150.0)
    path = write_csv(data, tmp_path / "trend.csv", {"stiffness_per_load": 2500.0})
    out = tmp_path / "diagnosis"
    result = CliRunner().invoke(app, ["diagnose", str(path), "--out", str(out), "--no-progress"])
    assert result.exit_code == 0, result.output
    content = json.loads((out / "diagnosis.json").read_text())
    assert CONTRACT <= set(content)
    assert content["cause"] == "slip_trend"
    assert content["extended"]["params"]["slip_trend"] == pytest.approx(150.0, rel=0.1)
    assert {"id", "heldout_error", "information_criterion", "params"} <= set(content["ranking"][0])
    assert content["gain"]["heldout_error_ratio"] > 1.5
    assert content["base"]["noise"] == pytest.approx(2e-4, rel=0.2)
    report = (out / "report.md").read_text()
    assert "slip_trend" in report and "Verdict" in report
    assert (out / "fits.png").stat().st_size > 10_000
    assert (out / "residuals.png").stat().st_size > 10_000


DRAW_PER_EFFECT = 1
"""Cases per effect of the battery's stratified draw of the hidden-effect matrix (the first
case of each; the full matrix, 8 per effect: ``benchmarks/bench_hidden_effects.py``)."""
DRAW_NONE_PER_KIND = 2
"""Effect-free cases per kind of data in that draw."""
CLAIMED_RATE = 0.9
"""The claim: each case gets its expected answer with probability >= 0.9."""
DRAW_CASES = cases(DRAW_PER_EFFECT, DRAW_NONE_PER_KIND)
DRAW_MAX_MISSES = max_misses(len(DRAW_CASES), 1.0 - CLAIMED_RATE)


def test_the_stratified_draw_has_its_stated_level_and_power() -> None:
    """23 cases, at most 8 misses: level 2.2e-4 if the claim holds, power 0.61 against a
    true rate of 0.6 and 0.89 against 0.5 (binomial, cases taken as independent)."""
    n = len(DRAW_CASES)
    assert (n, DRAW_MAX_MISSES) == (23, 8)
    assert binom.sf(DRAW_MAX_MISSES, n, 1.0 - CLAIMED_RATE) <= SIGNIFICANCE
    assert binom.sf(DRAW_MAX_MISSES, n, 0.4) == pytest.approx(0.61, abs=0.01)
    assert binom.sf(DRAW_MAX_MISSES, n, 0.5) == pytest.approx(0.89, abs=0.01)


@pytest.mark.battery
def test_hidden_effects_are_found() -> None:
    """A stratified draw of the hidden-effect matrix (tests/hidden_matrix.py): one case of
    every effect every kind of data can show and two effect-free cases per kind, each with
    its answer fixed before the diagnosis by the noiseless base-fit chi^2 rule; at most
    DRAW_MAX_MISSES wrong verdicts. Battery: a three-load renewal time series takes more
    than 20 min of CPU to diagnose (2026-11-25, 2 shared cores), so the 10 of them
    exceed the 10-minute budget of a slow test (tests/README.md)."""
    with ProcessPoolExecutor(max_workers=2) as pool:  # the machine's 2 cores
        results = list(pool.map(run_case, DRAW_CASES))
    misses = [(r["kind"], r["effect"], r["expected"], r["verdict"]) for r in results
              if r["verdict"] != r["expected"]]  # fmt: skip
    assert len(misses) <= DRAW_MAX_MISSES, misses


@pytest.mark.slow
def test_silicon_fig3_with_load_dependent_memory_length(tmp_path: Path) -> None:
    """000/Fig. 3 ramps at six normal forces with D_c ~ N^0.7: diagnosed as
    load_dependent_dc, the exponent recovered, and a gain reported (measured, seed 3:
    exponent 0.7027 +- 0.0035, held-out error ratio 9.7, 98 % of the residual variance
    explained, delta BIC 3706; 31 s)."""
    rng = np.random.default_rng(3)
    forces = (100.0, 200.0, 300.0, 400.0, 500.0, 600.0)
    data = clamped_case(
        "load_dependent_dc", rng, NOISE["clamped_sample"], forces=forces, exponent=0.7
    )
    result = diagnose(data)
    assert result.cause == "load_dependent_dc"
    exponent = result.extended.fit.params["dc_load_exponent"]
    assert abs(exponent - 0.7) < 3 * result.extended.fit.stderr["dc_load_exponent"]
    gain = result.gain()
    assert gain["heldout_error_ratio"] > 1.2 and gain["delta_information_criterion"] > 10


@pytest.mark.parametrize("effect", ["none", "aging_rate"])
def test_effect_free_and_effect_time_series(effect: str) -> None:
    """One time series without and one with an effect (4-12 s each)."""
    rng = np.random.default_rng(8)
    assert diagnose(time_series_case(effect, rng, NOISE["time_series"])).cause == effect


@pytest.mark.xdist_group("cohort_record")
@pytest.mark.usefixtures("cached_passes")
def test_auto_closure_takes_the_generators_own_population_average(cohort_record) -> None:
    """``closure="auto"`` picks the renewal base for the independent cohort generator's
    effect-free record (matrix case #0, AR(1) noise phi 0.69) and the aging base for the
    aging-law generator's; on the cohort record the renewal closure finds nothing to
    explain (``none``), while the aging closure's misfit of the generator's own relaxation
    is taken for a cause (the aging closure's matrix: 8 of 8 effect-free records called
    ``state_velocity_cutoff``)."""
    cohorts = cohort_record
    aging_law = time_series_case("none", np.random.default_rng(8), NOISE["time_series"])
    assert closed_base(Measurement(resample_by_travel(cohorts)))[0] == "renewal"
    assert closed_base(Measurement(resample_by_travel(aging_law)))[0] == "aging"
    assert diagnose(cohorts, closure="auto").cause == "none"
    assert diagnose(cohorts, closure="aging").cause not in ("none", "unexplained")


@pytest.mark.slow
def test_a_non_steady_start_is_fitted_from_a_renewal_base() -> None:
    """Matrix case ``non_steady_history`` #1 in the renewal closure (``auto`` picks it):
    warm-started from the base at zero initial offsets, the extension's fit did not move
    (every trust-region step rejected: the coarse tolerance's scatter of the base
    parameters' finite-difference gradients swamps the offsets'), so it left the base's
    misfit (rms 8.56e-4) and the diagnosis said ``unexplained``. With the start grid
    shifting the runs' offsets together it must explain at least ``EXCESS_EXPLAINED`` of
    the base's excess over the noise actually added, binned as the record is (measured
    2026-11-29: the diagnosis's fit 4.13e-4 against a floor of 3.4e-4; stuck at 0 it
    explains 0)."""
    from nanoblock.diagnosis.catalogue import in_closure

    data, clean = MAKERS["time_series"](
        "non_steady_history", Case("time_series", "non_steady_history", 1).rng()
    )
    measurement = Measurement(resample_by_travel(data))
    closure, base = closed_base(measurement, "renewal")
    surrogate = in_closure(CATALOGUE["non_steady_history"].surrogates["time_series"], closure)
    fit = measurement.fit(surrogate, start=base.start)

    def squares(model: list[np.ndarray]) -> float:
        pairs = zip(model, measurement.observed, strict=True)
        return sum(float(np.sum((m - y) ** 2)) for m, y in pairs) / measurement.data.sizes["sample"]

    added = measurement.data["mu"].values - resample_by_travel(clean)["mu"].values
    noise = float(np.mean(added**2))  # in the same travel bins
    explained = (squares(base.model) - squares(fit.model)) / (squares(base.model) - noise)
    assert explained >= core.EXCESS_EXPLAINED, explained


def test_the_cli_and_the_api_default_to_the_same_closure() -> None:
    """``nanoblock diagnose`` spells the default closure out (its module does not import
    the diagnosis at start-up): it is :data:`~nanoblock.diagnosis.core.DEFAULT_CLOSURE`,
    the API's default."""
    from nanoblock import cli
    from nanoblock.diagnosis.core import CLOSURE_CHOICES, DEFAULT_CLOSURE

    default = inspect.signature(cli.diagnose).parameters["closure"].default
    assert default == DEFAULT_CLOSURE == inspect.signature(diagnose).parameters["closure"].default
    assert DEFAULT_CLOSURE in CLOSURE_CHOICES


@pytest.fixture(scope="module")
def cohort_record() -> xr.Dataset:
    """The cohort generator's effect-free record (matrix case #0)."""
    data, _ = MAKERS["time_series"]("none", Case("time_series", "none", 0).rng())
    return data


@pytest.mark.xdist_group("cohort_record")
@pytest.mark.usefixtures("cached_passes")
def test_best_closure_compares_final_models_not_bases(cohort_record) -> None:
    """``closure="best"`` runs a full pass in each closure and keeps the verdict whose
    final model has the lower information criterion. On the cohort generator's effect-free
    record (matrix case #0) the aging pass accepts ``state_velocity_cutoff`` (its misfit of
    the generator's own relaxation) and the renewal pass ends with its base, whose IC is
    lower (measured: -1682 against -1516), so the verdict is ``none``."""
    result = diagnose(cohort_record, closure="best")
    passes = result.closures
    assert passes["aging"]["final"] == "state_velocity_cutoff"
    assert passes["renewal"]["final"] == "base"
    assert passes["renewal"]["information_criterion"] < passes["aging"]["information_criterion"]
    assert result.cause == "none" and result.base.fit.law == "renewal"


@pytest.mark.xdist_group("cohort_record")
@pytest.mark.usefixtures("cached_passes")
def test_best_closure_compares_the_finals_the_simulation_check_left(
    monkeypatch, cohort_record
) -> None:
    """With the simulation check, each pass checks its own supported causes before the
    passes are compared (the verdict once compared unchecked finals and, when the winner's
    cause was then refused, fell to that pass's next cause, whatever the other pass ended
    with). The check scripted to refuse every cause (the simulator is not run), on the
    effect-free record of the test above: the aging pass checks ``state_velocity_cutoff``
    first, refuses it and ends with its base (measured IC -1458, against -1516 with the
    cutoff), which the report's closure line names; the renewal pass, with no supported
    cause, is checked only for the report."""
    asked = []

    def refuse(data, base, extension, params, *, laws, seeds, **kwargs) -> dict:
        asked.append((laws[0], extension))
        return {"status": "refused", "extension": extension, "summary": "scripted"}

    monkeypatch.setattr(core, "simulation_check", refuse)
    result = diagnose(cohort_record, closure="best", simulate=True)
    passes = result.closures
    assert asked[0] == ("aging", "state_velocity_cutoff")
    assert passes["aging"]["final"] == "base"
    assert passes["aging"]["not_confirmed"] == ["state_velocity_cutoff"]
    assert (
        "ends with `base` (the simulation did not confirm `state_velocity_cutoff`)"
        in (_closure_text(result)[0])
    )
    assert passes["renewal"] == {**passes["renewal"], "final": "base", "not_confirmed": []}
    assert [law for law, _ in asked] == ["aging", "renewal"]  # the renewal one: the report's
    assert result.cause == "none" and result.not_confirmed == {}


def test_calibrated_threshold_inverts_the_exact_slope() -> None:
    """sigma_a of the reference joint whose exact slope of 001/Eq. 28 at v0 is alpha."""
    from nanoblock.diagnosis.simulation import _joint, calibrated_threshold
    from nanoblock.theory.meanfield import log_slope

    for alpha in (0.008, 0.015, 0.03):
        threshold = calibrated_threshold(alpha, 1e-6, 293.15)
        assert float(log_slope(1e-6, _joint(threshold, 293.15))) == pytest.approx(alpha, rel=1e-8)


def test_steady_log_area_is_the_mean_log_area_of_exponential_ages() -> None:
    """<ln(1 + phi / tau_m)> of two renewal populations (D0 and 12 D0, 3:1) at V, with and
    without a state cutoff, against Monte Carlo ages phi ~ Exp(D0 / (V + v_theta))
    (001/Eqs. 3, 5): within 5 standard errors of 4e5 draws."""
    from nanoblock.theory.mapping import steady_log_area

    rng = np.random.default_rng(2)
    memory = np.repeat([3e-8, 3.6e-7], [300, 100])
    tau, velocity = 1e-6, 2e-6
    for cutoff in (0.0, 5e-6):
        ages = memory / (velocity + cutoff) * rng.standard_exponential((1000, memory.size))
        draws = np.log1p(ages / tau).mean(axis=1)
        expected = steady_log_area(memory, tau, velocity, cutoff)
        assert abs(draws.mean() - expected) < 5 * draws.std(ddof=1) / math.sqrt(draws.size)


CALIBRATED_SEEDS = 8
"""Seeds of the calibrated two-state interface test: one run's steady step scatters by ~5 %."""


def test_calibrated_two_state_interface_slides_at_the_fitted_level_and_step() -> None:
    """The simulation check's interface for a p655-like two-state fit (mu0 0.5, a 0.0094,
    b 0.0066, D_c 1.5 um, b2 0.0012, D_c2 7.5 um; 2.3 -> 23 um/s), simulated (500 contacts,
    :data:`CALIBRATED_SEEDS` seeds) with its run-in: each record starts in steady sliding
    (first 2 D0 within 2e-3 of the whole first segment; slow noise ~3e-4) at a steady level
    before the step of mu0 within 0.5 %, and the mean steady step is (a - b - b2) ln 10
    within 12 %. Measured (2026-11-29): level -0.1 %, step -4.2 % +- 1.7 % (seed sd 4.7 %):
    at that offset and sd the mean of 8 seeds leaves 12 % with probability ~1e-5; a single
    seed, the test until then, fails with probability ~0.05 (seed 0 gave -12.2 % with the
    calm steps tried that day, a new realisation). With the former mapping (p =
    sigma_s / mu0, m = B / mu0, threshold at v0, no run-in) the same run started 0.010
    low (a stall: the 500 drawn block stresses were 2 % short), slid 14 % high and stepped
    53 % too far (A inflated by the area factor 1 + m S of 001/Eq. 5)."""
    from nanoblock.diagnosis.simulation import SIMULATED_D0, calibrated_scenarios
    from nanoblock.engine import simulate
    from tests.diagnosis_synthetic import _dataset, _displacement

    v1, dc = 2.3e-6, 1.5e-6
    base = {"mu0": 0.5, "a": 0.0094, "b": 0.0078, "dc": dc, "v0": v1, "stiffness": 1340.0}
    fit = {**base, "b": 0.0066, "b2": 0.0012, "dc2": 5 * dc}
    segments = [(v1, 120 * dc / v1), (10 * v1, 160 * dc / (10 * v1))]
    switch, end = segments[0][1], sum(d for _, d in segments)
    time = np.unique(
        np.concatenate([np.linspace(0.0, switch, 2000), np.linspace(switch, end, 2000)])
    )
    columns = {"time": time, "mu": np.full(time.size, 0.5)}
    columns["load_point_displacement"] = _displacement(segments, time)
    data = _dataset(columns, "time_series", stiffness_per_load=1340.0)
    scenario = calibrated_scenarios(data, base, "two_state_variable", fit)[0]["extended"]
    run_in, first, second = (s.velocity * s.duration for s in scenario.loading.steps)
    step = run_in + first
    steps = []
    for seed in range(CALIBRATED_SEEDS):
        run = simulate(scenario.with_seed(seed))
        travel = run["load_point_displacement"].values
        mu = run["friction_coefficient"].values

        def level(start: float, end: float, travel=travel, mu=mu) -> float:
            return float(mu[(travel >= start) & (travel < end)].mean())

        before = level(run_in + first / 2, step)
        assert abs(level(run_in, run_in + 2 * SIMULATED_D0) - level(run_in, step)) < 2e-3
        assert before == pytest.approx(fit["mu0"], rel=0.005)
        steps.append(level(step + second / 2, step + second) - before)
    expected = (fit["a"] - fit["b"] - fit["b2"]) * math.log(10.0)
    print(f"steady step / expected - 1: {np.round(np.array(steps) / expected - 1, 3)}")
    assert np.mean(steps) == pytest.approx(expected, rel=0.12)


def test_simulation_check_runs_the_simulator_with_the_cause_switched_on() -> None:
    """A hidden state cutoff (generator, seed 3): diagnosed, then the nanoblock simulator
    run on the data's protocol with the base interface and with
    interface.state_cutoff_velocity switched on; the simulation's systematic misfit falls.
    Measured on 2026-11-29 over 10 independent checks (seeds 0-19 in pairs, 2 seeds of 500
    contacts each): variance removed 0.886 +- 0.019 (0.85-0.91), misfit ratio 0.34 +- 0.03
    (0.30-0.39), so the bounds 0.3 and 0.8 lie 31 and 17 standard deviations away; an
    option the simulator ignored would leave both interfaces alike (0 removed, ratio 1)."""
    data = time_series_case("state_velocity_cutoff", np.random.default_rng(3), NOISE["time_series"])
    result = diagnose(data, simulate=True)
    assert result.cause == "state_velocity_cutoff"
    check = result.simulation_check
    assert check["status"] == "ran" and check["extension"] == "state_velocity_cutoff"
    assert check["extended"]["systematic"] < 0.8 * check["base"]["systematic"]
    assert check["systematic_variance_removed"] > 0.3


@pytest.mark.parametrize(
    ("removed", "vetoed"),
    [((-0.1, 0.4), False), ((-0.1, -0.05), True), (("refused",), True)],
)
def test_a_simulation_veto_needs_the_veto_seeds(monkeypatch, removed, vetoed) -> None:
    """The check's outcome scripted (the simulator is not run): a check of SEEDS seeds in
    which the extension fails is rerun with VETO_SEEDS seeds, and only that rerun refuses
    the cause; a check that cannot build the extension's interface while it builds the
    base's (status "refused") refuses it at once. A refused cause is listed as not
    confirmed and the verdict moves to the next supported extension; the report's first
    paragraph says so."""
    asked = []

    def scripted(*args, seeds: int, **kwargs) -> dict:
        asked.append(seeds)
        outcome = removed[len(asked) - 1] if len(asked) <= len(removed) else 1.0
        if outcome == "refused":
            return {"status": "refused", "summary": "scripted"}
        return {"status": "ran", "systematic_variance_removed": outcome, "summary": "scripted"}

    monkeypatch.setattr(core, "simulation_check", scripted)
    data = time_series_case("state_velocity_cutoff", np.random.default_rng(3), NOISE["time_series"])
    result = diagnose(data, simulate=True)
    assert next(c.id for c in result.candidates if c.id in SWITCHES) == "state_velocity_cutoff"
    assert asked[: len(removed)] == [SEEDS, core.VETO_SEEDS][: len(removed)]
    assert ("state_velocity_cutoff" in result.not_confirmed) == vetoed
    assert (result.cause == "state_velocity_cutoff") != vetoed
    if vetoed:  # the report's first paragraph says what was refused
        refused = "not confirmed by the simulation: `state_velocity_cutoff`"
        assert refused in _summary(result).lower()


def test_an_extension_the_simulator_cannot_make_is_refused_not_skipped() -> None:
    """A two-state fit whose slow state ages the contacts beyond their friction (b2 = 0.05
    over D_c2 = 8 mm: m <ln(1 + phi / tau_m)> = 1.38 >= 1) while the base calibrates: the
    check says "refused" with the reason (it used to say "not_run", which vetoed nothing);
    with a base that cannot calibrate either it says "not_run"."""
    from nanoblock.diagnosis.simulation import simulation_check

    data = _step_record()
    base = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6, "stiffness": 2500.0}
    fit = {**base, "b": 0.011, "b2": 0.05, "dc2": 8e-3}
    check = simulation_check(data, base, "two_state_variable", fit, n_contacts=60)
    assert check["status"] == "refused"
    assert "cannot be simulated while the base fit can" in check["summary"]
    assert "leaves no friction for the fresh contacts" in check["summary"]
    unmade = {**base, "b": 0.2, "dc": 8e-3}
    check = simulation_check(data, unmade, "two_state_variable", {**fit, **unmade})
    assert check["status"] == "not_run" and "leaves no friction" in check["reason"]


@pytest.mark.xfail(
    strict=True,
    reason="measured 2026-12-07: on this record the check's outcome is not a property of "
    "the physics. At seed 0 the extended/base systematic misfit was 0.55 at the fit before "
    "the model was averaged over each travel bin's samples, 1.06 and 1.63 with its D2 "
    "0.25 % longer and shorter, 1.03 at today's fit (D2 0.1-0.25 % apart); with the "
    "spring doubled 0.55-1.21 over the same +-0.25 % (issue 15)",
)
def test_simulation_check_switches_on_a_second_contact_population() -> None:
    """two_state_variable in the simulator: a record of the independent renewal generator
    with a second population (b2 = 0.6 b, D2 = 12 D), its aging2 fit turned into
    interface.second_memory_length / second_population: the simulated systematic misfit
    falls to 0.41 +- 0.04 of the base's (0.34-0.47; variance removed 0.83 +- 0.04, over 10
    independent checks, seeds 0-19 in pairs, 2026-11-29): the bound 0.8 lies 9 standard
    deviations away, and a second population the simulator ignored would give 1. The spring
    is K/W = 1.2 a / (D / 2): at half that the fitted interfaces, with A no longer
    inflated by the area factor (1 + m S ~ 1.2), are within ~10 % of the simulator's
    stick-slip onset and slip-stick with drops of 0.1."""
    from nanoblock.diagnosis.catalogue import BASE, CATALOGUE
    from nanoblock.diagnosis.resample import resample_by_travel
    from nanoblock.diagnosis.simulation import simulation_check
    from nanoblock.diagnosis.surrogates import Measurement
    from tests.diagnosis_synthetic import _dataset, _displacement
    from tests.hidden_synthetic import _sample_times
    from tests.renewal_synthetic import Renewal, renewal_slider

    v1, d0, a, b = 1e-6, 2e-5, 0.01, 0.012
    truth = Renewal(mu0=0.6, a=a, b=b, d0=d0, tau_m=1e-6 * d0 / v1, b2=0.6 * b, d2=12 * d0)
    segments = [(v1, 10 * d0 / v1), (10 * v1, 6 * d0 / v1), (v1, 60 * d0 / v1)]
    stiffness = 1.2 * a / (0.5 * d0)
    t, mu = renewal_slider(truth, segments, stiffness, start_velocity=v1)
    time = _sample_times(segments)
    noisy = np.interp(time, t, mu) + 2e-4 * np.random.default_rng(1).standard_normal(time.size)
    columns = {"time": time, "mu": noisy, "load_point_displacement": _displacement(segments, time)}
    data = _dataset(columns, "time_series", stiffness_per_load=stiffness)
    measurement = Measurement(resample_by_travel(data))
    base = measurement.fit(BASE["time_series"])
    two_state = measurement.fit(
        CATALOGUE["two_state_variable"].surrogates["time_series"], start=base.start
    )
    check = simulation_check(data, base.params, "two_state_variable", two_state.params)
    assert check["status"] == "ran", check
    assert 0.0 < json.loads(check["scenario_extended"])["interface"]["second_population"] < 1.0
    assert check["extended"]["systematic"] < 0.8 * check["base"]["systematic"]


def test_a_fit_the_simulator_cannot_represent_is_said_not_silently_dropped() -> None:
    """Runnable scenarios: a two-state fit with b2 < 0 has no two-population interface, so
    ``base.toml`` is written alone and the note says why ``extended.toml`` is missing; a
    base fit with b < 0 (no ageing m >= 0 makes it, 001/Eq. 5) gives neither, and the
    report's section says so (it once wrote nothing and said nothing)."""
    from nanoblock.diagnosis.report import _scenario_text
    from nanoblock.diagnosis.simulation import calibrated_scenarios

    data = _step_record()
    base = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6, "stiffness": 2500.0}
    scenarios, note = calibrated_scenarios(
        data, base, "two_state_variable", {**base, "b2": -0.002, "dc2": 1e-4}
    )
    assert set(scenarios) == {"base"}
    assert "no extended scenario: the two_state_variable fit cannot be simulated" in note
    assert "b2 = -0.002" in note
    scenarios, note = calibrated_scenarios(data, {**base, "b": -0.001}, None, {})
    assert scenarios == {}
    assert _scenario_text({}, note) == (
        "None written: no runnable scenario: the base fit has b = -0.001 < 0: contact "
        "ageing (m >= 0, 001/Eq. 5) cannot make it."
    )


def test_simulation_check_does_not_depend_on_how_many_runs_go_at_once() -> None:
    """The check's runs (interfaces x seeds) one after another or two at once on
    concurrent threads: the same trajectories, so the same misfits (60 contacts: the
    determinism, not the statistics, is under test)."""
    from nanoblock.diagnosis.simulation import simulation_check

    data = _step_record()
    base = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6, "stiffness": 2500.0}
    fit = {**base, "b": 0.011, "b2": 0.002, "dc2": 1e-4}
    checks = [
        simulation_check(data, base, "two_state_variable", fit, n_contacts=60, workers=workers)
        for workers in (1, 2)
    ]
    for name in ("base", "extended"):
        assert checks[0][name] == checks[1][name]
        assert checks[0][name]["simulation_noise"] > 0.0


def test_a_rerun_with_more_seeds_simulates_only_the_new_ones(monkeypatch) -> None:
    """The veto's rerun: a six-seed check given the two-seed check's cache runs 2 x 4 new
    simulations (not 2 x 6) and returns exactly the misfits of a fresh six-seed check."""
    from nanoblock.diagnosis import simulation

    data = _step_record()
    base = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6, "stiffness": 2500.0}
    fit = {**base, "b": 0.011, "b2": 0.002, "dc2": 1e-4}
    runs = []
    friction_at = simulation.friction_at

    def counted(scenario, *args, **kwargs):
        runs.append(scenario.run.seed)
        return friction_at(scenario, *args, **kwargs)

    monkeypatch.setattr(simulation, "friction_at", counted)
    check = functools.partial(
        simulation.simulation_check, data, base, "two_state_variable", fit, n_contacts=60
    )
    cache: dict = {}
    check(seeds=2, cache=cache)
    assert sorted(runs) == [0, 0, 1, 1]
    runs.clear()
    rerun = check(seeds=6, cache=cache)
    assert sorted(runs) == [2, 2, 3, 3, 4, 4, 5, 5]
    fresh = check(seeds=6)
    for name in ("base", "extended"):
        assert rerun[name] == fresh[name]


def test_an_extension_whose_fit_fails_is_reported_not_raised(monkeypatch) -> None:
    """A candidate whose integration cannot finish (LSODA's 'excess work' at its optimum,
    as on a hidden-matrix record) is listed as not testable with the error; one whose
    held-out refits fail gets an infinite forecast error and cannot be the cause."""
    from nanoblock.diagnosis.catalogue import BASE
    from nanoblock.diagnosis.surrogates import Measurement

    fit = Measurement.fit

    def failing(self, surrogate, holdout=None, start=None):
        if getattr(surrogate, "law", "") == "cutoff" or (
            holdout is not None and surrogate is not BASE["time_series"]
        ):
            raise RuntimeError("spring-slider integration failed: Excess work done")
        return fit(self, surrogate, holdout, start)

    monkeypatch.setattr(Measurement, "fit", failing)
    result = diagnose(_step_record(), simulate=False)
    assert "Excess work" in result.untestable["state_velocity_cutoff"]
    forecast = [c for c in result.candidates if c.heldout_error is not None]
    assert forecast and all(c.heldout_error == math.inf for c in forecast)
    assert math.isfinite(result.base.heldout_error) and result.cause in ("none", "unexplained")


def test_simulation_check_says_why_it_cannot_run() -> None:
    from nanoblock.diagnosis.simulation import simulation_check

    table = steady_case("none", np.random.default_rng(5), NOISE["steady_state"])
    check = simulation_check(table, {}, "barrier_shape", {})
    assert check["status"] == "not_run" and "spring-slider" in check["reason"]
    step = _step_record()
    check = simulation_check(step, {}, "slip_trend", {})
    assert check["status"] == "not_run" and "wear" in check["reason"]
