"""Diagnosis of real laboratory records (issue 15): resampling to uniform travel, the noise
at the model's resolution, stick-slip detection, plausibility, forecasts, the two-state
laws, and the verdicts on the laboratory files when they are present."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy.integrate import solve_ivp
from scipy.signal import lfilter
from typer.testing import CliRunner

from nanoblock.cli import app
from nanoblock.diagnosis import CATALOGUE, core, diagnose, drops
from nanoblock.diagnosis.core import DEFAULT_CLOSURE
from nanoblock.diagnosis.drops import find_stick_slip
from nanoblock.diagnosis.plausibility import implausible
from nanoblock.diagnosis.report import _summary
from nanoblock.diagnosis.resample import BINS_PER_RUN, resample_by_travel
from nanoblock.diagnosis.statistics import (
    COLOURED,
    COLOURED_Z,
    effective_size,
    noise_lag1_z,
    noise_level,
    resolution_noise,
    structure,
)
from nanoblock.diagnosis.surrogates import forecast_mask
from nanoblock.measured import load_measurement
from nanoblock.rsf.fit import fit_rsf, prepare_runs
from nanoblock.rsf.slider import LoadPointHistory
from nanoblock.rsf.windows import step_windows
from tests.hidden_matrix import Case
from tests.hidden_synthetic import time_series
from tests.tolerances import max_misses, z_bound

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
needs_lab = pytest.mark.skipif(
    not SHARED_DATA.is_dir(), reason=f"laboratory data absent ({SHARED_DATA})"
)


def _series(time, mu, velocity, displacement=None) -> xr.Dataset:
    columns = {"time": time, "mu": mu, "load_point_velocity": velocity}
    if displacement is not None:
        columns["load_point_displacement"] = displacement
    return xr.Dataset(
        {k: ("sample", np.asarray(v, dtype=float)) for k, v in columns.items()},
        attrs={"kind": "time_series"},
    )


def _two_state_step(noise: float, rng: np.random.Generator) -> xr.Dataset:
    """A velocity step of the two-state aging law on a quasi-static spring, integrated here
    by scipy's Radau in (mu, theta1, theta2) (an independent code path)."""
    mu0, a, b1, dc1, b2, dc2, k = 0.6, 0.01, 0.006, 5e-6, 0.006, 2e-4, 1500.0
    v1, v2 = 1e-6, 1e-5

    def rhs(t, y, vl):
        mu, t1, t2 = y
        v = v1 * math.exp(
            (mu - mu0 - b1 * math.log(v1 * t1 / dc1) - b2 * math.log(v1 * t2 / dc2)) / a
        )
        return [k * (vl - v), 1 - v * t1 / dc1, 1 - v * t2 / dc2]

    t_step, t_end = 60.0, 60.0 + 1.5e-3 / v2
    before = np.linspace(0.0, t_step, 301)
    after = t_step + np.geomspace(0.05, t_end - t_step, 1200)
    options = {"method": "Radau", "rtol": 1e-10, "atol": 1e-12}
    first = solve_ivp(rhs, (0, t_step), [mu0, dc1 / v1, dc2 / v1], args=(v1,), t_eval=before,
                      **options)  # fmt: skip
    second = solve_ivp(rhs, (t_step, t_end), first.y[:, -1], args=(v2,), t_eval=after, **options)
    before, first_mu = before[:-1], first.y[0][:-1]
    time = np.concatenate([before, after])
    mu = np.concatenate([first_mu, second.y[0]]) + noise * rng.standard_normal(time.size)
    velocity = np.where(time < t_step, v1, v2)
    travel = np.where(time < t_step, v1 * time, v1 * t_step + v2 * (time - t_step))
    data = _series(time, mu, velocity, travel)  # the travel places the step exactly
    data.attrs["stiffness_per_load"] = k
    return data


def test_two_state_aging_law_recovers_both_memory_lengths() -> None:
    """aging2 fitted to an independent Radau integration recovers b, D_c, b2 and D_c2
    within z_bound(4) of their Jacobian errors (noise 2e-5, white: the residuals' lag-1
    autocorrelation is 0.00-0.06; seeds 3-6 gave |z| <= 1.96). Until 2026-11-29 the bound
    was the larger of 4 errors and 5 % of the truth, which is 77-275 errors here."""
    data = _two_state_step(2e-5, np.random.default_rng(3))
    result = fit_rsf(data, "aging2")
    for name, truth in (("b", 0.006), ("dc", 5e-6), ("b2", 0.006), ("dc2", 2e-4)):
        value, error = result.params[name], result.stderr[name]
        assert math.isfinite(error) and error > 0.0
        assert abs(value - truth) < z_bound(4) * error, (name, value, error)
    one = fit_rsf(data, "aging")
    assert one.rms_residual > 3.0 * result.rms_residual


def test_resampling_averages_bins_of_equal_travel_within_segments() -> None:
    """A linear signal of travel is reproduced exactly by the bin means; no bin straddles a
    velocity change; a record coarser than the bins passes unchanged."""
    time = np.concatenate([np.linspace(0.0, 10.0, 5001), np.linspace(10.001, 11.0, 5000)])
    velocity = np.where(time < 10.0, 1e-6, 1e-5)
    travel = np.where(time < 10.0, 1e-6 * time, 1e-5 + 1e-5 * (time - 10.0))
    data = _series(time, 0.5 + 100.0 * travel, velocity, travel)
    binned = resample_by_travel(data)
    assert binned.sizes["sample"] <= BINS_PER_RUN + 2
    np.testing.assert_allclose(
        binned["mu"].values, 0.5 + 100.0 * binned["load_point_displacement"].values, rtol=1e-12
    )
    assert set(np.unique(binned["load_point_velocity"].values)) == {1e-6, 1e-5}
    # consecutive bin means lie one bin width apart, within the samples' spacing (0.1 of
    # a width; the partial bins at the step: 0.55): a bin of double width, or two merged
    # across the step, would leave a gap of ~1.5 (the identity above holds for any bins)
    gaps = np.diff(binned["load_point_displacement"].values) / (travel[-1] / BINS_PER_RUN)
    assert gaps.min() > 0.5 and gaps.max() < 1.1, (gaps.min(), gaps.max())
    coarse = data.isel(sample=slice(None, None, 20))
    assert resample_by_travel(coarse).sizes["sample"] == coarse.sizes["sample"]


def test_a_model_is_averaged_over_the_samples_its_bin_mean_holds() -> None:
    """A transient 0.03 exp(-t / 0.2 s) on a record of 100 samples per bin (0.01 s): the
    model averaged at the bin's ``model_time`` with ``model_weight`` (16 nodes, evenly
    spread in rank) matches the bin mean of the samples within the midpoint rule's
    bound, max|f''| (0.01 s)^2 / (24 * 16^2) = 1.2e-8, where evaluating it at the bin's
    mean time is off by up to max|f''| (0.01 s)^2 / 24 = 3.1e-6; and exactly (1e-12) on
    a record of 5-6 samples per bin, where every sample is a node."""

    def transient(t):
        return 0.5 + 0.03 * np.exp(-t / 0.2)

    curvature = 0.03 / 0.2**2
    for samples, bound in ((50_001, curvature * 0.01**2 / (24 * 16**2)), (5_001, 1e-12)):
        time = np.linspace(0.0, 10.0, samples)
        data = _series(time, transient(time), np.full(samples, 1e-6), 1e-6 * time)
        binned = resample_by_travel(data)
        assert resample_by_travel(binned) is binned  # a resampled record stays as it is
        run = prepare_runs(binned)[0]
        assert run.model_time is not None and run.model_weight is not None
        averaged = run.sampled(transient(run.evaluation_times))
        assert np.max(np.abs(averaged - run.mu)) <= bound
        np.testing.assert_allclose(run.model_weight.sum(axis=1), 1.0, rtol=1e-12)
    at_mean_time = np.max(np.abs(transient(run.time) - run.mu))
    assert at_mean_time > 1e-7, at_mean_time  # what the averaging removes


def test_resampling_keeps_an_effect_free_record_in_its_laws_family() -> None:
    """The renewal law at the generator's true parameters (only mu0 refitted) fits
    effect-free matrix draw #1 to chi^2 1.7 over its three runs (noise actually added) as
    recorded, and must do as well once the record is resampled by travel: below
    VISIBLE_CHI2 = 25. Before the model was averaged over each bin's samples it left
    1673, the worst bin 3.6 D into the reslide, where the friction drops by ~0.03 within
    one bin of load-point travel (``benchmarks/bench_resampling_bias.py``: every
    effect-free draw)."""
    from tests.hidden_matrix import VISIBLE_CHI2, truth_chi2

    chi2 = truth_chi2(Case("time_series", "none", 1))
    assert chi2["recorded"] < VISIBLE_CHI2, chi2
    assert chi2["resampled"] < VISIBLE_CHI2, chi2


def test_displacement_only_record_keeps_its_history_through_resampling() -> None:
    """Without a velocity column the history comes from the displacement: a repeated time
    stamp (1e-13 s apart, displacement read to 1 pm) makes no segment of its own, and the
    resampled record carries the velocities of that history, so bin means either side of a
    change cannot add a segment at their secant velocity."""
    dense = [start + np.geomspace(1e-4, 1.0, 200) for start in (100.0, 150.0)]
    time = np.unique(np.concatenate([np.linspace(0.0, 200.0, 20001), [3.0 + 1e-13], *dense]))
    starts, velocities = np.array([0.0, 100.0, 150.0]), np.array([1e-6, 0.0, 1e-6])
    travel = np.round(LoadPointHistory(starts, velocities).displacement_at(time), 12)
    data = xr.Dataset(
        {"time": ("sample", time), "mu": ("sample", 0.6 + 0.0 * time),
         "load_point_displacement": ("sample", travel)},
        attrs={"kind": "time_series"},
    )  # fmt: skip
    binned = resample_by_travel(data)
    moving = (binned["time"].values < 100.0) | (binned["time"].values >= 150.0)
    np.testing.assert_allclose(binned["load_point_velocity"].values, np.where(moving, 1e-6, 0.0))
    for record in (data, binned):
        (run,) = prepare_runs(record)
        np.testing.assert_allclose(run.history.starts[1:], starts[1:], atol=1e-9)
        np.testing.assert_allclose(run.history.velocities, velocities, atol=1e-15)


def test_a_switch_located_on_a_sample_is_put_on_it() -> None:
    """A velocity change located from the displacement within rounding of a sample starts
    there: the resampled synthetic record (seed 8) had a segment 5.7e-14 s long before
    the down-step's sample, an illegal input for LSODA at every trial point."""
    from tests.diagnosis_synthetic import NOISE, time_series_case

    data = resample_by_travel(
        time_series_case("none", np.random.default_rng(8), NOISE["time_series"])
    )
    (run,) = prepare_runs(data)
    assert np.all(np.isin(run.history.starts[1:], run.time))
    assert fit_rsf(data, "aging").rms_residual < 2.0 * NOISE["time_series"]


FLOOR_SCATTER = 1.24
"""Relative standard deviation of the white-noise floor times sqrt(n), measured: 300 seeds
of 20,000 samples about a 50-sample running mean and 400 seeds of 1,000 stretches of 30
about their own means both gave 1.24 (+- 0.05). It exceeds the 1.08 of the MAD of
independent deviations (efficiency 0.37) because the deviations about a common mean are
correlated; until 2026-11-29 the tests used 1.08 and doubled it."""


AR_FLOOR_SCATTER = 0.62
"""Standard deviation of the AR(1) floor (phi = 0.7, stretches of 30) times sqrt(n_eff),
measured over 300 seeds of 30,000 samples (mean 0.9242 against the exact 0.9257); the
tests used 1.08 until 2026-11-29, 1.7 times looser."""


def test_resolution_noise_equals_white_noise_and_sees_coloured_noise() -> None:
    """On white noise the floor is sigma within z_bound() Monte Carlo errors (relative
    error :data:`FLOOR_SCATTER` / sqrt(n); level 1e-3, power 0.9 against a 4 % bias); on
    AR(1) noise (phi = 0.9)
    it exceeds the sample-scale white estimate by more than the 1.5 that marks coloured
    noise."""
    rng = np.random.default_rng(5)
    n = 20_000
    white = rng.standard_normal(n)
    floor = resolution_noise([white])
    assert abs(floor - 1.0) < z_bound() * FLOOR_SCATTER / math.sqrt(n)
    ar = np.zeros(n)
    for i in range(1, n):
        ar[i] = 0.9 * ar[i - 1] + rng.standard_normal()
    assert resolution_noise([ar]) > 1.5 * noise_level([ar])
    assert effective_size(1000, 0.9) == pytest.approx(1000 * 0.1 / 1.9)


def _ar1(rng: np.random.Generator, n: int, phi: float) -> np.ndarray:
    """Stationary AR(1) noise of unit variance (a 200-sample run-in dropped)."""
    shocks = rng.standard_normal(n + 200) * math.sqrt(1.0 - phi * phi)
    return lfilter([1.0], [1.0, -phi], shocks)[200:]


@pytest.mark.parametrize("layout", ["long", "short"])
def test_noise_lag1_z_is_standard_normal_on_white_noise_and_sees_mild_colour(layout) -> None:
    """The whiteness test of the colour switch, on 900 samples in three stretches of
    250-300 (``long``, high-passed by the 50-sample running mean) or thirty of 30
    (``short``, each about its own mean). White noise, 2000 draws: mean z within z_bound(2)
    Monte Carlo errors of 0 (1 / sqrt(2000): power 0.9 against a bias of 0.1) and calls of
    colour at ``COLOURED_Z`` at most max_misses(2000, 1e-3) (level 1e-3). AR(1) with
    phi = 0.3, 200 draws: at most max_misses(200, 1e-3) missed (z 7-8, sd ~1; measured
    power 0.95 at phi = 0.2), while the floor over the white noise, the switch used alone
    until 2026-12-07, stays under its 1.5 in most draws."""
    rng = np.random.default_rng(11)

    def stretches(y: np.ndarray) -> list[np.ndarray]:
        if layout == "long":
            return [y[:300], y[400:700], y[750:]]
        return np.split(y, 30)

    white = np.array([noise_lag1_z(stretches(rng.standard_normal(900))) for _ in range(2000)])
    print(f"white: mean {white.mean():.3f}, sd {white.std():.3f}")
    assert abs(white.mean()) < z_bound(2) / math.sqrt(white.size)
    assert np.count_nonzero(white > COLOURED_Z) <= max_misses(white.size, 1e-3)
    coloured = [stretches(_ar1(rng, 900, 0.3)) for _ in range(200)]
    z = np.array([noise_lag1_z(s) for s in coloured])
    ratio = np.array([resolution_noise(s) / noise_level(s) for s in coloured])
    print(f"phi 0.3: z {z.mean():.2f} +- {z.std():.2f}, floor / white {np.median(ratio):.3f}")
    assert np.count_nonzero(z <= COLOURED_Z) <= max_misses(z.size, 1e-3)
    assert np.median(ratio) < COLOURED


def test_resolution_noise_of_steady_stretches_shorter_than_its_window() -> None:
    """Stretches of 30 samples (under the 50-sample window, as the steady stretches of a
    short record are), taken about their own means: white noise gives sigma within
    z_bound(2) Monte Carlo errors (:data:`FLOOR_SCATTER`); AR(1) noise (phi = 0.7) is still
    seen as coloured, its floor the exact AR(1) variance about a 30-sample mean over
    1 - 1/30 (0.927 of its sd) within z_bound(2) Monte Carlo errors (:data:`AR_FLOOR_SCATTER`
    / sqrt(n_eff), n_eff = n (1 - phi) / (1 + phi); level 1e-3, power 0.9 against biases of
    3.4 % and 4 %), where the sample-scale
    estimate gives 0.48 (no stretch used: the floor fell back to it before)."""
    rng = np.random.default_rng(6)
    n, phi = 30_000, 0.7
    white = np.split(rng.standard_normal(n), n // 30)
    assert abs(resolution_noise(white) - 1.0) < z_bound(2) * FLOOR_SCATTER / math.sqrt(n)
    shocks = rng.standard_normal(n) * math.sqrt(1.0 - phi * phi)
    ar = np.empty(n)
    ar[0] = rng.standard_normal()
    for i in range(1, n):
        ar[i] = phi * ar[i - 1] + shocks[i]
    pieces = np.split(ar, n // 30)
    floor = resolution_noise(pieces)
    w = 30
    kept = (
        1.0 - (1.0 + phi) / ((1.0 - phi) * w) + 2.0 * phi * (1.0 - phi**w) / ((1.0 - phi) * w) ** 2
    )
    expected = math.sqrt(kept / (1.0 - 1.0 / w))
    print(f"floor {floor:.3f} (AR(1): {expected:.3f}), white {noise_level(pieces):.3f}")
    n_eff = n * (1.0 - phi) / (1.0 + phi)
    assert abs(floor - expected) < z_bound(2) * AR_FLOOR_SCATTER / math.sqrt(n_eff)
    assert floor > 1.5 * noise_level(pieces)


def test_forecast_mask_holds_out_the_second_half_of_later_segments() -> None:
    time = np.linspace(0.0, 30.0, 301)
    velocity = np.where(time < 10.0, 1e-6, np.where(time < 20.0, 1e-5, 1e-6))
    run = prepare_runs(_series(time, np.full(time.size, 0.5) + 1e-3 * np.sin(time), velocity))[0]
    held = forecast_mask(run)
    assert not held[time < 10.0].any()
    assert (
        held[(time > 15.05) & (time < 19.95)].all()
        and not held[(time > 10.05) & (time < 14.95)].any()
    )
    assert held[time > 25.05].all() and not held[(time > 20.05) & (time < 24.95)].any()


def _sawtooth(rng: np.random.Generator, amplitude: float) -> xr.Dataset:
    """Slow stick-slip after a down-step: linear reloading over 0.7 um, then a drop."""
    time = np.linspace(0.0, 200.0, 8001)
    velocity = np.where(time < 20.0, 1e-5, 1e-6)
    travel = np.where(time < 20.0, 1e-5 * time, 2e-4 + 1e-6 * (time - 20.0))
    phase = np.where(time < 20.0, 0.0, ((travel - 2e-4) / 0.7e-6) % 1.0)
    mu = 0.6 + amplitude * phase + 3e-4 * rng.standard_normal(time.size)
    return _series(time, mu, velocity, travel)


def test_stick_slip_is_found_with_its_period_and_drop_size() -> None:
    """A sawtooth of 0.004 every 0.7 um under white noise of 3e-4 is found in the slow
    segment only, with its period within 5 % and its drop within 15 %; pure AR(1) noise
    (phi = 0.95) at the same level gives no stick-slip on any of 20 seeds (its largest
    periodicity there was 0.04 against the 0.3 required)."""
    found = find_stick_slip(prepare_runs(_sawtooth(np.random.default_rng(1), 0.004)))
    assert len(found) == 1 and found[0].load_point_velocity == 1e-6
    assert found[0].period == pytest.approx(0.7e-6, rel=0.05)
    assert found[0].median_drop == pytest.approx(0.004, rel=0.15)
    for seed in range(20):
        rng = np.random.default_rng(100 + seed)
        data = _sawtooth(rng, 0.0)
        noise = np.zeros(data.sizes["sample"])
        for i in range(1, noise.size):
            noise[i] = 0.95 * noise[i - 1] + 3e-4 * rng.standard_normal()
        data["mu"] = ("sample", 0.6 + noise)
        assert find_stick_slip(prepare_runs(data)) == []


def _ar1(rng: np.random.Generator, size: int, phi: float, sigma: float = 3e-4) -> np.ndarray:
    out = np.zeros(size)
    shocks = sigma * rng.standard_normal(size)
    for i in range(1, size):
        out[i] = phi * out[i - 1] + shocks[i]
    return out


def _slow_segment(mu: np.ndarray) -> xr.Dataset:
    """``mu`` as the 1 um/s segment of a record that starts with 200 samples at 10 um/s."""
    time = np.concatenate([np.linspace(0.0, 20.0, 200, endpoint=False),
                           np.linspace(20.0, 200.0, mu.size)])  # fmt: skip
    travel = np.where(time < 20.0, 1e-5 * time, 2e-4 + 1e-6 * (time - 20.0))
    fast = 0.6 + 3e-4 * np.random.default_rng(0).standard_normal(200)
    return _series(time, np.concatenate([fast, 0.6 + mu]), np.where(time < 20.0, 1e-5, 1e-6),
                   travel)  # fmt: skip


@pytest.mark.parametrize("index", [0, 1, 2])
def test_a_few_stick_slip_cycles_after_a_down_step_are_found(index: int) -> None:
    """The renewal spring-slider below its critical stiffness (the hidden-effect matrix's
    independent generator, tests/renewal_synthetic.py) makes only 4-6 cycles in its
    down-step segment, sampled ~12 times a cycle: too few for the autocorrelation test,
    found by the sawtooth test in every run and in no other segment (8 of 8 cases, 24 of
    24 runs, when measured on 2026-11-26; the cases without the effect gave none), with
    the generator's own number of cycles (4-6) and their period in slip."""
    case = Case("time_series", "unstable_sliding", index)
    data, clean = time_series("unstable_sliding", case.rng())
    found = sorted(find_stick_slip(prepare_runs(data)), key=lambda event: event.run)
    assert [event.run for event in found] == [0, 1, 2]
    for event, run in zip(found, prepare_runs(clean), strict=True):
        assert event.load_point_velocity == pytest.approx(1e-6)
        # the generator's own cycles: falls of the noiseless friction of over a quarter of
        # its range in the segment, and their median spacing in load-point travel
        segment = run.history.segment_at(run.time)
        inside = segment == segment[np.searchsorted(run.time, event.start_time)]
        mu, travel = run.mu[inside], run.load_point_displacement[inside]
        falls = np.diff(mu) < -0.25 * np.ptp(mu)
        starts = np.flatnonzero(falls & ~np.r_[False, falls[:-1]])
        assert event.drops == starts.size
        # one sample of the ~12 a cycle
        assert event.period == pytest.approx(np.median(np.diff(travel[starts])), rel=0.1)


@pytest.mark.slow
def test_the_sawtooth_test_refuses_noise_oscillations_spikes_and_transients(monkeypatch) -> None:
    """Level of the few-cycle sawtooth test (the autocorrelation test switched off): no
    stick-slip in 3000 AR(1) segments (phi 0 to 0.99, 60 to 2000 samples), in 200 each of
    sinusoids, periodic spikes, damped ringing and step relaxations 20-300 noise deviations
    tall, nor in 12 stable renewal spring-sliders (effect-free, machine_stiffness and
    two_state_variable cases of the matrix); 0 of 3812 bounds the false-alarm rate below
    0.08 % (one-sided 95 %, rule of three). It fails without the fall share (28 of the
    spike trains pass) or without both the size floor and the regularity (the
    two_state_variable case #0 passes), as measured on 2026-11-26."""
    monkeypatch.setattr(drops, "MIN_DROPS", 10**9)
    alarms = []
    for phi in (0.0, 0.5, 0.9, 0.95, 0.99):
        for size in (60, 300, 2000):
            for seed in range(200):
                rng = np.random.default_rng([7, int(100 * phi), size, seed])
                if find_stick_slip(prepare_runs(_slow_segment(_ar1(rng, size, phi)))):
                    alarms.append(("ar1", phi, size, seed))
    for seed in range(200):
        rng = np.random.default_rng([8, seed])
        size, period = int(rng.integers(60, 2000)), rng.uniform(4.0, 30.0)
        amplitude, phase = 3e-4 * rng.uniform(20.0, 300.0), np.arange(size) / period
        spikes = _ar1(rng, size, rng.uniform(0.0, 0.95))
        spikes[:: int(period)] += amplitude * rng.choice([-1.0, 1.0])
        shapes = {
            "sinusoid": amplitude * np.sin(2 * np.pi * phase),
            "spikes": spikes,
            "ringing": amplitude * np.exp(-phase / rng.uniform(1, 5)) * np.cos(2 * np.pi * phase),
            "relaxation": -amplitude * np.exp(-phase / rng.uniform(0.3, 10.0)),
        }
        for name, shape in shapes.items():
            noise = 0.0 if name == "spikes" else _ar1(rng, size, rng.uniform(0.0, 0.95))
            if find_stick_slip(prepare_runs(_slow_segment(shape + noise))):
                alarms.append((name, seed))
    for effect in ("none", "machine_stiffness", "two_state_variable"):
        for index in range(4):
            data, _ = time_series(effect, Case("time_series", effect, index).rng())
            if find_stick_slip(prepare_runs(data)):
                alarms.append((effect, index))
    assert alarms == []


PERIODIC_FALSE_ALARM = 0.01
"""False-alarm rate the periodic stick-slip test claims on periodic signals that are not
stick-slip (:func:`test_the_periodic_test_tells_stick_slip_from_other_periodic_signals`)."""
PERIODIC_MISS = 0.1
"""Miss rate it claims on noisy sawtooths of 20-300 noise deviations."""


def _periodic_shapes(seed: int) -> dict[str, np.ndarray]:
    """One segment of each periodic shape (4-60 samples a cycle, 20-300 noise deviations
    tall, 500-8000 samples, AR(1) noise with phi in [0, 0.95]) and of plain AR(1) noise."""
    rng = np.random.default_rng([11, seed])
    size, period = int(rng.integers(500, 8000)), rng.uniform(4.0, 60.0)
    amplitude, phase = 3e-4 * rng.uniform(20.0, 300.0), np.arange(size) / period
    noise = _ar1(rng, size, rng.uniform(0.0, 0.95))
    spikes = np.zeros(size)
    spikes[:: int(period)] = amplitude * rng.choice([-1.0, 1.0])
    cycle = phase.astype(int)
    return {
        "ar1": _ar1(rng, size, rng.uniform(0.0, 0.99)),
        "sinusoid": amplitude * np.sin(2 * np.pi * phase) + noise,
        "ringing": amplitude * np.exp(-phase / rng.uniform(1, 5)) * np.cos(2 * np.pi * phase)
        + noise,
        "spikes": spikes + noise,
        "square": amplitude * (phase % 1.0 < 0.5) + noise,
        "sawtooth": amplitude * (phase % 1.0) + noise,
        "irregular sawtooth": amplitude
        * (phase % 1.0)
        * rng.uniform(0.6, 1.4, cycle[-1] + 1)[cycle]
        + noise,
    }


def test_the_periodic_test_tells_stick_slip_from_other_periodic_signals() -> None:
    """Level and power of the long-record (periodic) stick-slip test: 1000 segments that
    are periodic or noisy but not stick-slip (200 each of AR(1) noise, sinusoids, damped
    ringing, spike and dip trains, square waves) may raise at most
    ``max_misses(1000, PERIODIC_FALSE_ALARM)`` = 21 alarms (exceeded with probability
    <= 1e-3 at a 1 % rate; power 0.95 against 3 %), and 400 noisy sawtooths (half with drop
    sizes scattered +-40 %) at most ``max_misses(400, PERIODIC_MISS)`` = 60 misses (power
    0.94 against an 18 % miss rate). Measured on 2026-11-29: 1 alarm (a sinusoid), 16
    misses (14 of them irregular); before the abruptness, reload and duration criteria the
    autocorrelation alone raised 193 alarms on 200 sinusoids and 192 on 200 spike trains."""
    alarms, misses = [], []
    for seed in range(200):
        for name, mu in _periodic_shapes(seed).items():
            found = bool(find_stick_slip(prepare_runs(_slow_segment(mu))))
            if found != ("sawtooth" in name):
                (misses if "sawtooth" in name else alarms).append((name, seed))
    print(f"alarms {alarms}; misses {len(misses)}: {misses}")
    assert len(alarms) <= max_misses(1000, PERIODIC_FALSE_ALARM), alarms
    assert len(misses) <= max_misses(400, PERIODIC_MISS), misses


def test_the_rule_refuses_an_implausible_or_worse_forecasting_extension() -> None:
    """The verdict rule (``core._supported``) on hand-made candidates: an extension that
    lowers the IC by 50, halves the excess variance over the noise floor and forecasts
    better is supported; the same one is refused with a parameter out of range, with a
    held-out error equal to the base's, or with an IC gain of exactly STRONG_EVIDENCE, and
    one that removes a tenth of the excess is refused too. ``core.shortfalls`` names the
    one test each refusal fails, as the report's first paragraph quotes it."""
    rng = np.random.default_rng(7)
    noise = 1.0

    def candidate(name, scale, ic, heldout, reasons=()):
        residuals = [scale * rng.standard_normal(4000)]
        return core.Candidate(
            name, None, residuals, ic, heldout, structure(residuals, noise), list(reasons)
        )

    base = candidate("base", 2.0, 0.0, 2.0)  # excess 4 - 1 = 3 over the floor
    good = candidate("x", 1.2, -50.0, 1.5)  # removes (4 - 1.44) / 3 = 85 % of it
    assert core._supported(good, base, noise)
    refused = {
        "tau_m = 1e+09 is outside": replace(
            good, implausible=["tau_m = 1e+09 is outside [1e-06, 1e+05]"]
        ),
        "no better than the base model (error ratio 1.00)": replace(
            good, heldout_error=base.heldout_error
        ),
        "gains 10.0 in the information criterion": replace(
            good, information_criterion=-core.STRONG_EVIDENCE
        ),
    }
    weak = candidate("weak", 1.9, -50.0, 1.5)  # removes about (4 - 3.61) / 3 of the excess
    squares = [float(np.mean(np.concatenate(c.residuals) ** 2)) for c in (base, weak)]
    removed = (squares[0] - squares[1]) / (squares[0] - noise**2)
    refused[f"removes {100 * removed:.0f} % of the misfit above the noise floor, 50 %"] = weak
    assert not any(core._supported(c, base, noise) for c in refused.values())
    assert core.shortfalls(good, base, noise) == []
    for phrase, refusal in refused.items():  # the report names the test each one fails
        (reason,) = core.shortfalls(refusal, base, noise)
        assert phrase in reason, (phrase, reason)


def test_implausible_extensions_are_named() -> None:
    """The laboratory fits the issue quotes (b = 1.07 of velocity_saturation, mu0 = 0.81 of
    state_velocity_cutoff on a record at mu ~ 0.49) are out of range; a lab-like fit is in."""
    observed = [np.linspace(0.48, 0.50, 100)]
    plain = {"mu0": 0.49, "a": 0.006, "b": 0.004, "dc": 1e-5}
    assert implausible(None, plain, observed, 1e-3, None) == []
    reasons = implausible(
        CATALOGUE["velocity_saturation"], {**plain, "b": 1.07, "tau_m": 1.0}, observed, 1e-3, None
    )
    assert len(reasons) == 1 and reasons[0].startswith("b = 1.07")
    assert implausible(CATALOGUE["state_velocity_cutoff"], {**plain, "mu0": 0.81}, observed,
                       1e-3, None)[0].startswith("mu0 = 0.81")  # fmt: skip
    stiff = implausible(
        CATALOGUE["machine_stiffness"], {**plain, "stiffness": 9000.0}, observed, 1e-3, 1000.0
    )
    assert stiff == ["stiffness_ratio = 9 is outside [0.2, 5]"]


LAB_FILES = {
    "p4309_vstep_11p6to1p2.csv": "unstable_sliding",
    "p655_100MPa_vstep_229to2p3.csv": None,
    "p655_100MPa_vstep_23to229.csv": None,
    "p655_100MPa_vstep_2p3to23.csv": None,
    "p655_75MPa_vstep_23to229.csv": None,
    "p655_75MPa_vstep_2p3to23.csv": None,
}
"""Expected verdicts chosen before the run (None: any catalogue cause)."""


@pytest.mark.slow
@needs_lab
@pytest.mark.xdist_group("lab_records")
@pytest.mark.usefixtures("cached_passes")
def test_laboratory_records_get_catalogue_causes_with_plausible_parameters() -> None:
    """At least 5 of the 6 records (the issue's acceptance) get a catalogue cause with the
    simulation check on, p4309's sawtooth is called unstable_sliding, and every accepted
    extension has plausible parameters and forecasts the held-out halves better than the
    base model; p4309's first paragraph compares K/W with (b - a)/D_c only when the mean
    fit is velocity-weakening (it is not: it says the drops are the evidence), and an
    ``unexplained`` record's names the closest extensions' shortfalls. Plausible
    parameters are part of the verdict rule
    (:func:`test_the_rule_refuses_an_implausible_or_worse_forecasting_extension`); the
    forecast gain must reach the issue's 1.2 (measured 1.22-1.39). Measured:
    5, the 100 MPa 2.3 -> 23 um/s step `unexplained` (machine
    stiffness and a second state each remove ~40 % of the excess over the noise); the
    75 MPa 2.3 -> 23 um/s step's two_state_variable is confirmed by the simulator
    (systematic misfit 0.00036 -> 0.00029), which contradicted it (4 of 6) before the
    calibration counted the contacts' area factor, the run-in and the seeds' noise; the
    100 MPa 23 -> 229 um/s step's two_state_variable, refused by its first two seeds
    (-9 %) after the kernels' last-bit change, is confirmed by the six a veto needs (46 %)."""
    named = 0
    for name, expected in LAB_FILES.items():
        result = diagnose(load_measurement(SHARED_DATA / name), simulate=True)
        if expected is not None:
            assert result.cause == expected, name
        if result.cause == "unstable_sliding":  # a strengthening mean fit judges nothing
            params = result.base.fit.params
            judged = "stability boundary" in _summary(result)
            assert judged == (params["b"] > params["a"]), name
        if result.cause in CATALOGUE:
            named += 1
        if result.cause == "unexplained":  # the first paragraph says why, test by test
            assert "noise floor" in _summary(result) and "Closest: `" in _summary(result)
        extended = result.extended
        if extended is not None:  # the issue's acceptance (the rule itself asks for > 1)
            assert result.base.heldout_error / extended.heldout_error >= 1.2, name
    assert named >= 5


@pytest.mark.slow
@needs_lab
@pytest.mark.xdist_group("lab_records")
@pytest.mark.usefixtures("cached_passes")
def test_best_closure_names_the_cause_the_renewal_base_alone_hides() -> None:
    """75 MPa 2.3 -> 23 um/s: the renewal base fits better than the aging base (rms
    3.43e-4 against 3.75e-4), so ``auto`` continues in the renewal closure, where no
    extension halves the excess, and says ``unexplained``; ``best`` also runs the aging
    pass, whose final model (aging law + second state) has the lower IC (measured: -16420
    against -15960 for the renewal base), and names ``two_state_variable``."""
    data = load_measurement(SHARED_DATA / "p655_75MPa_vstep_2p3to23.csv")
    result = diagnose(data, closure="best")
    passes = result.closures
    assert passes["aging"]["final"] == "two_state_variable"
    assert passes["renewal"]["final"] == "base"
    assert passes["aging"]["information_criterion"] < passes["renewal"]["information_criterion"]
    assert result.cause == "two_state_variable"


TWO_LOADS = ("p655_75MPa_vstep_2p3to23.csv", "p655_100MPa_vstep_2p3to23.csv")


def two_loads(directory: Path = SHARED_DATA) -> xr.Dataset:
    """The two 2.3 -> 23 um/s steps of p655 (75 and 100 MPa) as runs 0 and 1 of one
    record, each with its normal force (normal stress x the 5 x 5 cm contact) and the
    recipe's shear stiffness 0.1 MPa/um over that contact as K [N/m]."""
    parts = []
    for run, name in enumerate(TWO_LOADS):
        data = load_measurement(directory / name)
        force = float(data.attrs["normal_stress"]) * 25e-4
        n = data.sizes["sample"]
        parts.append(
            data.assign(run=("sample", np.full(n, run)), normal_force=("sample", np.full(n, force)))
        )
    out = xr.concat(parts, dim="sample", combine_attrs="drop_conflicts")
    out.attrs.update(kind="time_series", stiffness=1e11 * 25e-4)
    return out


@pytest.mark.slow
@needs_lab
def test_two_loads_of_one_experiment_show_a_friction_level_falling_with_load() -> None:
    """p655 at 75 and 100 MPa as two runs: mu is 0.026 lower at 100 MPa, which the shared
    mu0 of the base model cannot follow; expected before the run: load_dependent_level,
    with a cohesion c / sigma_ref within 10 % of the one the steady halves give alone
    (:func:`steady_cohesion`, 0.087; the fit's transients may trade a little of the
    offset with mu0; measured 0.088, c ~ 7.6 MPa) and a forecast gain above 1.2 (measured
    29). Until 2026-11-29 the ratio was held to [0, 0.3], its plausibility range, which the
    verdict rule already enforces."""
    data = two_loads()
    result = diagnose(data)
    assert result.cause == "load_dependent_level"
    ratio = result.extended.fit.params["cohesion_ratio"]
    assert abs(ratio / steady_cohesion(data) - 1.0) < 0.1
    assert result.base.heldout_error / result.extended.heldout_error > 1.2


def steady_cohesion(data: xr.Dataset) -> float:
    """c / sigma_ref from the data alone: the two runs' mean friction over the second half
    of each velocity's segment, differenced per velocity (0.0874 and 0.0867 at 2.3 and 23
    um/s: the offset does not depend on the rate) and divided by W_ref (1/W_1 - 1/W_2)."""
    levels, loads = [], []
    for run in prepare_runs(data):
        segment = run.history.segment_at(run.time)
        halves = []
        for k in range(run.history.starts.size):
            time, mu = run.time[segment == k], run.mu[segment == k]
            halves.append(float(np.mean(mu[time >= 0.5 * (time[0] + time[-1])])))
        levels.append(np.array(halves))
        loads.append(run.normal_force)
    reference = math.sqrt(loads[0] * loads[1])
    return float(np.mean(levels[0] - levels[1]) / (reference * (1 / loads[0] - 1 / loads[1])))


UNSTABLE_UNDER_DECIMATION = {
    ("p655_75MPa_vstep_2p3to23.csv", "best"): (
        "measured: two_state_variable on the record, machine_stiffness on its decimation; "
        "the renewal pass's fitted stiffness removes 49 % of the excess over the noise on "
        "one and 58 % on the other, across the rule's 50 %"
    ),
    ("p655_100MPa_vstep_229to2p3.csv", DEFAULT_CLOSURE): (
        "measured: non_steady_history on the record, unexplained on its decimation; the "
        "pre-step stretch (229 um/s) is 1 kHz, 500 travel bins, but 175 raw samples after "
        "decimation, so per-sample statistics weigh it 2x less: the initial state removes "
        "53 % of the excess on one and 27 % on the other (floor 2.4e-4 vs 1.7e-4)"
    ),
}
"""Records and closures whose verdict still moves with decimation, and why (strict
xfails: a fix makes them fail until the entry goes)."""


@pytest.mark.slow
@needs_lab
@pytest.mark.xdist_group("lab_records")
@pytest.mark.usefixtures("cached_passes")
@pytest.mark.parametrize(
    ("name", "closure"),
    [
        pytest.param(
            name,
            closure,
            marks=[pytest.mark.xfail(strict=True, reason=why)]
            if (why := UNSTABLE_UNDER_DECIMATION.get((name, closure)))
            else [],
        )
        for name, closure in [
            ("p655_75MPa_vstep_2p3to23.csv", DEFAULT_CLOSURE),
            ("p655_75MPa_vstep_2p3to23.csv", "best"),
            ("p655_100MPa_vstep_229to2p3.csv", DEFAULT_CLOSURE),
        ]
    ],
)
def test_verdict_survives_decimation_to_100_hz(name: str, closure: str) -> None:
    """A mixed-rate record (10/100/1000 Hz) and its decimation to at most 100 Hz get the
    same verdict. Measured in the default closure on all six records: five keep it; the
    100 MPa 229 -> 2.3 um/s step does not, nor does ``best`` on the 75 MPa 2.3 -> 23 um/s
    step (:data:`UNSTABLE_UNDER_DECIMATION`)."""
    data = load_measurement(SHARED_DATA / name)
    time = data["time"].values
    keep = np.concatenate([[True], np.diff(np.floor(time * 100.0 + 1e-6)) > 0])
    decimated = data.isel(sample=keep)
    assert decimated.sizes["sample"] < 0.8 * data.sizes["sample"]
    verdicts = [diagnose(d, closure=closure).cause for d in (decimated, data)]
    assert verdicts[0] == verdicts[1]


QI_FITS = [
    # file, law, K/W [1/m], window before/after [m], the lab's a, b, D_c [m] (p655_r)
    (
        "p655_100MPa_vstep_2p3to23.csv",
        "slip",
        1600.0,
        (5e-5, 1.5e-4),
        (0.006005, 0.004230, 17.745e-6),
    ),
    (
        "p655_100MPa_vstep_2p3to23.csv",
        "aging",
        1000.0,
        (5e-5, 1.5e-4),
        (0.006043, 0.004279, 6.505e-6),
    ),
    (
        "p655_100MPa_vstep_2p3to23.csv",
        "slip",
        1000.0,
        (5e-5, 1.5e-4),
        (0.005823, 0.004094, 12.817e-6),
    ),
    (
        "p655_100MPa_vstep_23to229.csv",
        "slip",
        1600.0,
        (5e-5, 3.5e-4),
        (0.005903, 0.004501, 40.959e-6),
    ),
]
"""The qi fits at the end of the lab's recipe p655_r, with their stiffnesses. Their row
numbers refer to another version of the file, so the windows are the labs' typical ones
(50 um before; 150 um after the 2.2 -> 22 um/s step, 350 um after the 23 -> 232 um/s one),
chosen inside the issue's stated ranges; D_c grows with the window after the step (the
two-state signature), by 10-20 % per 50 um."""


@needs_lab
@pytest.mark.parametrize(("name", "law", "stiffness", "window", "lab"), QI_FITS)
def test_lab_qi_fits_are_reproduced_within_10_percent(name, law, stiffness, window, lab):
    data = step_windows(load_measurement(SHARED_DATA / name), *window)
    result = fit_rsf(data, law, stiffness=stiffness)
    for key, value in zip(("a", "b", "dc"), lab, strict=True):
        assert result.contract[key] == pytest.approx(value, rel=0.10), key


def test_fit_cli_takes_a_window_and_refuses_a_bad_one(tmp_path: Path) -> None:
    """``nanoblock fit --window`` fits one run per step; a window without AFTER exits 2
    naming the option and what it takes."""
    data = _two_state_step(2e-5, np.random.default_rng(3))
    csv = tmp_path / "step.csv"
    table = np.column_stack([data[c].values for c in ("time", "mu", "load_point_velocity")])
    header = "# stiffness_per_load: 1500\ntime,mu,load_point_velocity"
    np.savetxt(csv, table, delimiter=",", header=header, comments="")
    runner = CliRunner()
    done = runner.invoke(
        app, ["fit", str(csv), "--window", "2e-5,1e-3", "--out", str(tmp_path / "f")]
    )
    assert done.exit_code == 0, done.output
    assert json.loads((tmp_path / "f" / "fit.json").read_text())["n_points"] < table.shape[0]
    refused = runner.invoke(
        app, ["fit", str(csv), "--window", "2e-5", "--out", str(tmp_path / "g")]
    )
    assert refused.exit_code == 2 and "--window '2e-5'" in refused.output
    assert "Traceback" not in refused.output


def test_standard_errors_cover_the_truth_under_ar1_noise() -> None:
    """Residuals with lag-1 autocorrelation 0.8 (AR(1) noise on a velocity step made by the
    independent Radau integration): with the (1 + phi) / (1 - phi) inflation the fitted
    b2 and D_c2 of 12 realisations give z-scores whose RMS is 1 within its sampling error
    (chi^2 with 24 degrees of freedom: RMS z in [0.55, 1.55] at level 1e-3); the white-noise
    errors, sqrt(9) = 3 times smaller, would put it near 3."""
    base = _two_state_step(0.0, np.random.default_rng(0))
    z = []
    for seed in range(12):
        rng = np.random.default_rng(seed)
        noise = np.zeros(base.sizes["sample"])
        for i in range(1, noise.size):
            noise[i] = 0.8 * noise[i - 1] + 2e-5 * math.sqrt(1 - 0.8**2) * rng.standard_normal()
        data = base.copy()
        data["mu"] = ("sample", base["mu"].values + noise)
        result = fit_rsf(data, "aging2", initial={"b2": 0.006, "dc2": 2e-4})
        assert result.residual_lag1 > 0.6
        for name, truth in (("b2", 0.006), ("dc2", 2e-4)):
            z.append((result.params[name] - truth) / result.stderr[name])
    rms = math.sqrt(np.mean(np.square(z)))
    assert 0.55 < rms < 1.55, z
