"""Issue 2 acceptance: force balance, ageing and renewal, determinism, store and resume."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import xarray as xr

import nanoblock.engine as engine
from nanoblock.engine import simulate
from nanoblock.kernels._jit import cached
from nanoblock.kernels.stepper import advance_to_sample
from nanoblock.params import ScenarioError
from nanoblock.store import SAMPLES, SNAPSHOTS
from tests.conftest import RHO_MAX, scenario
from tests.naive_quasistatic import (
    REFERENCE_FILE,
    RUNAWAY_FILE,
    SAMPLE_EVERY,
    STEP_TIME,
    runaway,
    velocity_step,
)
from tests.tolerances import FORCE_BALANCE_RTOL, MEAN_AGE_RTOL, Z_MAX, z_bound

ageing_interface = {"memory_length": 5e-8, "aging_m": 0.05, "aging_time": 1e-3}


def soft_protocol(slip: str = "reset", k2: float = 0.0, stiffness: float = 2e5):
    """Velocity step, hold and reload on a finite spring, with ageing and renewal."""
    return scenario(
        joint={"slip": slip, "k2": k2},
        interface={**ageing_interface, "n_contacts": 30, "blocks_per_contact": 20},
        loading={
            "stiffness": stiffness,
            "steps": [
                {"velocity": 1e-6, "displacement": 6e-8},
                {"velocity": 1e-5, "displacement": 1e-7},
                {"hold": 0.05},
                {"velocity": 1e-5, "displacement": 5e-8},
            ],
        },
        run={"record_every": 2e-3, "seed": 4},
    )


@pytest.mark.parametrize(("slip", "k2"), [("reset", 0.0), ("chain", 0.0), ("chain", 0.5 * 2.75)])
def test_force_balance_at_every_sample(slip: str, k2: float) -> None:
    run = soft_protocol(slip, k2)
    result = simulate(run)
    spring = run.loading.stiffness * (result.load_point_displacement - result.slider_displacement)
    force = result.friction_force
    assert float(force.min()) > 0
    np.testing.assert_allclose(spring, force, rtol=FORCE_BALANCE_RTOL)
    assert int(result.n_events[-1]) > 1000
    mu = result.friction_coefficient
    assert np.all(np.isfinite(mu)) and float(mu.max()) < 1.0


@pytest.mark.parametrize("stiffness", [1e13, 1e15])
def test_a_stiff_spring_balances_each_sample_in_one_round_through_a_hold(stiffness) -> None:
    """K/W = 1e12 and 1e14 1/m (W = 10 N; k_int/W = 3.6e9 1/m): 2 um of sliding, a 0.2 s
    hold, a reload. The spring force K (X_L - X) is known to K eps |X| only (~1e-8 N here,
    above 1e-13 F), so the settling stops at that round-off: every sample balances in at
    most 2 rounds (each a pass over all blocks; before, the hold took 55 and 524 rounds per
    sample on average, up to the cap of 1000, as jumps below the ulp of X never moved the
    slider), and the balance holds to that round-off. The hold's internal steps per sample
    are printed, not asserted (measured 26 and 34; 92 and 5 before)."""
    run = engine.Run(
        scenario(
            interface={**ageing_interface, "normal_force": 10.0, "memory_length": 2e-7},
            loading={
                "stiffness": stiffness,
                "steps": [
                    {"velocity": 1e-5, "displacement": 2e-6},
                    {"hold": 0.2},
                    {"velocity": 1e-5, "displacement": 2e-7},
                ],
            },
            run={"record_every": 2e-3, "seed": 3, "initial_state": "steady"},
        )
    )
    rounds, steps, residuals = [], [], []
    while not run.done:
        slider = run.state.slider[0]
        before = int(slider["steps"])
        rounds.append(advance_to_sample(*run.kernel_arguments(run.times[run.next_sample])))
        run.next_sample += 1
        steps.append(int(slider["steps"]) - before)
        spring = stiffness * (slider["load_point"] - slider["position"])
        rounding = np.finfo(float).eps * stiffness * abs(slider["position"])
        residuals.append(abs(spring - slider["force"]) / max(1e-13 * slider["force"], rounding))
    print(f"hold: {np.mean(steps[101:200]):.1f} steps per sample")
    assert max(rounds) <= 2, rounds
    assert max(residuals) < 16.0


def test_mean_contact_age_is_d0_over_v_in_steady_sliding() -> None:
    velocity, memory = 1e-6, 2e-8
    run = scenario(
        interface={
            "n_contacts": 2000,
            "blocks_per_contact": 2,
            "memory_length": memory,
            "aging_m": 0.05,
        },
        loading={
            "stiffness": float("inf"),
            "steps": [{"velocity": velocity, "displacement": 60 * memory}],
        },
        run={"record_every": 2 * memory / velocity, "initial_state": "unloaded"},
    )
    result = simulate(run)
    ages = result.mean_contact_age.values[6:]  # after 10 lifetimes from newborn contacts
    expected = memory / velocity
    error = ages.std(ddof=1) / np.sqrt(ages.size)
    assert ages.mean() == pytest.approx(expected, rel=MEAN_AGE_RTOL)
    assert abs(ages.mean() - expected) < Z_MAX * error + 0.002 * expected


def test_contact_area_grows_by_eq5_during_a_hold() -> None:
    m, tau, hold = 0.07, 2e-3, 10.0
    run = scenario(
        interface={
            "n_contacts": 10,
            "blocks_per_contact": 5,
            "memory_length": 1e-6,
            "aging_m": m,
            "aging_time": tau,
        },
        loading={"stiffness": 1e5, "steps": [{"hold": hold}]},
        run={"record_every": 0.25, "initial_state": "unloaded"},
    )
    result = simulate(run)
    base = run.interface.real_area
    expected = base * (1 + m * np.log1p(result.time.values / tau))  # 001/Eq. 5
    np.testing.assert_allclose(result.real_contact_area, expected, rtol=1e-12)
    np.testing.assert_allclose(result.mean_contact_age, result.time, rtol=1e-12)


def trajectory_in_subprocess(threads: int, tmp_path, protocol: str) -> xr.Dataset:
    out = tmp_path / f"threads{threads}.nc"
    code = (
        "import sys; sys.path.insert(0, sys.argv[2]);"
        "from tests.test_engine import soft_protocol; from nanoblock.engine import simulate;"
        f"simulate(soft_protocol({protocol})).to_netcdf(sys.argv[1])"
    )
    env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
    root = os.path.dirname(os.path.dirname(__file__))
    subprocess.run([sys.executable, "-c", code, str(out), root], check=True, env=env)
    return xr.open_dataset(out).load()


@pytest.mark.parametrize("protocol", ["'chain', 1.0", "'reset', 0.0, 1e12"])
def test_same_seed_same_trajectory_with_one_or_two_threads(tmp_path, protocol) -> None:
    """A soft spring with a chain joint, and a stiff frame (K/W = 1e12 1/m) whose steps
    run to the samples: each contact draws from its own stream, whatever the threads."""
    one = trajectory_in_subprocess(1, tmp_path, protocol)
    two = trajectory_in_subprocess(2, tmp_path, protocol)
    for name in SAMPLES:
        np.testing.assert_array_equal(one[name].values, two[name].values, err_msg=name)


def test_a_run_stepped_outside_simulate_in_a_fresh_process_does_not_crash() -> None:
    """``Run.step_to_next_sample`` is public: called in a fresh process before anything
    started Numba's thread pool, the stepper's nested parallel loop segfaulted."""
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]);"
        "from tests.test_engine import soft_protocol; from nanoblock.engine import Run;"
        "run = Run(soft_protocol('reset', 0.0)); print(run.step_to_next_sample()['time'])"
    )
    root = os.path.dirname(os.path.dirname(__file__))
    done = subprocess.run([sys.executable, "-c", code, root], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert float(done.stdout) == 0.0


def test_friction_at_runs_the_trajectory_simulate_records() -> None:
    """``friction_at`` at simulate's own sample times returns its friction exactly, on one
    thread, on two (where NUMBA_NUM_THREADS allows), and with two runs at once on
    concurrent Python threads (the kernels release the GIL; each contact draws from its
    own stream)."""
    import numba

    run = soft_protocol()
    expected = simulate(run)["friction_coefficient"].values
    times = engine.sample_times(run)
    for threads in range(1, min(2, numba.config.NUMBA_NUM_THREADS) + 1):
        np.testing.assert_array_equal(engine.friction_at(run, times, threads=threads), expected)
    numba.get_num_threads()
    if numba.threading_layer() == "workqueue":
        pytest.skip("the workqueue threading layer cannot run parallel kernels concurrently")
    with ThreadPoolExecutor(2) as pool:
        other, same = pool.map(
            lambda s: engine.friction_at(s, times, threads=1), [run.with_seed(99), run]
        )
    np.testing.assert_array_equal(same, expected)
    assert not np.array_equal(other, expected)


def test_different_seeds_differ() -> None:
    first = simulate(soft_protocol())
    second = simulate(soft_protocol().with_seed(99))
    assert not np.array_equal(first.friction_force.values, second.friction_force.values)


def test_store_has_contract_variables_units_and_provenance(tmp_path) -> None:
    run = soft_protocol().model_copy(
        update={"run": soft_protocol().run.model_copy(update={"snapshot_every": 10})}
    )
    stored = simulate(run, tmp_path / "run.zarr")
    for name, spec in {**SAMPLES, **SNAPSHOTS}.items():
        assert stored[name].attrs["units"] == spec.units
        assert stored[name].attrs["long_name"] == spec.long_name
    assert stored.time.attrs["units"] == "s"
    assert json.loads(stored.attrs["scenario"])["run"]["seed"] == 4
    assert stored.attrs["seed"] == 4 and stored.attrs["complete"]
    assert {"nanoblock_version", "numba_version"} <= set(stored.attrs)
    assert stored.block_stress.dims == ("snapshot_time", "contact", "block")
    assert stored.block_stress.shape == (stored.sizes["snapshot_time"], 30, 20)
    assert stored.block_stress.chunks is not None  # lazily opened, chunked on disk
    np.testing.assert_allclose(stored.snapshot_time, stored.time[::10])
    in_memory = simulate(run)
    for name in SAMPLES:
        np.testing.assert_array_equal(stored[name].values, in_memory[name].values)


def test_killed_run_resumes_to_the_same_trajectory(tmp_path, monkeypatch) -> None:
    run = soft_protocol()
    reference = simulate(run)
    monkeypatch.setattr(engine, "FLUSH_SECONDS", 0.0)  # flush and checkpoint every sample
    calls = {"n": 0}
    original = engine.Run.step_to_next_sample

    def crash_after_40(self):
        calls["n"] += 1
        if calls["n"] > 40:
            raise KeyboardInterrupt("simulated kill")
        return original(self)

    monkeypatch.setattr(engine.Run, "step_to_next_sample", crash_after_40)
    with pytest.raises(KeyboardInterrupt):
        simulate(run, tmp_path / "run.zarr")
    monkeypatch.setattr(engine.Run, "step_to_next_sample", original)
    partial = xr.open_zarr(tmp_path / "run.zarr", consolidated=False)
    assert 0 < partial.sizes["time"] <= 40 and not partial.attrs["complete"]
    resumed = simulate(run, tmp_path / "run.zarr")
    for name in SAMPLES:
        np.testing.assert_array_equal(resumed[name].values, reference[name].values)


def test_store_of_another_scenario_is_not_overwritten(tmp_path) -> None:
    simulate(soft_protocol(), tmp_path / "run.zarr")
    with pytest.raises(ScenarioError, match="another scenario"):
        simulate(soft_protocol().with_seed(5), tmp_path / "run.zarr")


def test_velocity_step_transient_converges_in_step_size() -> None:
    """Halving the internal step slip leaves a stable velocity-step transient unchanged
    within its noise. (The step partition changes the order of each contact's random
    draws, so the two runs are different realizations: compare smoothed curves.)"""

    def run_with(step_slip: float) -> np.ndarray:
        run = scenario(
            interface={
                **ageing_interface,
                "memory_length": 2e-7,
                "n_contacts": 200,
                "blocks_per_contact": 50,
            },
            loading={
                "stiffness": 3e6,
                "steps": [
                    {"velocity": 1e-6, "displacement": 4e-8},
                    {"velocity": 1e-5, "displacement": 3e-7},
                ],
            },
            run={"record_every": 1e-3, "seed": 8, "step_slip": step_slip},
        )
        mu = simulate(run).friction_coefficient
        return mu.rolling(time=5, center=True).mean().values[2:-2]

    coarse, fine = run_with(RHO_MAX / 2), run_with(RHO_MAX / 8)
    excursion = fine.max() - fine.min()
    assert excursion > 0.01  # the direct-effect spike and the decay to a new steady state
    assert np.sqrt(np.mean((coarse - fine) ** 2)) < 0.1 * excursion


@pytest.mark.parametrize("divisor", [16, None], ids=["fine", "default"])
def test_velocity_step_converges_to_the_event_by_event_reference(divisor: int | None) -> None:
    """The stepper at steps of rho~_max / 16 and at the default rho~_max / 8 against the
    quasi-static dynamics itself: a 10x
    velocity step at K / W = 3e6 1/m (:func:`tests.naive_quasistatic.velocity_step`, 1000
    blocks in 200 ageing, renewing contacts) reproduces the friction rise over the 1 ms
    before the step of the event-by-event reference (the slider rebalanced after every
    depinning) seed by seed at 0.5, 1, 1.5 and 2.5 ms after the step, within z_bound(4)
    standard errors of the paired difference (16 seeds share their initial states) and
    2 % of the peak rise. Measured: within 0.1e-3 (SE 0.03-0.1e-3) at rho~_max / 16 and
    / 64; at the default rho~_max / 8 up to 0.4e-3 high (passes); at rho~_max / 4 up to
    1.0e-3 (6 % of the rise, 4-6 SE: fails) in the millisecond after the peak, as did the
    stepper before issue 16 at that step (0.7e-3), whose refinement of the force step
    alone moved it further off (-1.7e-3 at force_step / 8). Steps lengthened to 2 rho~_max
    in steady sliding (tried 2026-11-29, not kept) failed: 1.9e-3 high 1.5 ms after the
    step."""
    reference = json.loads(REFERENCE_FILE.read_text())
    first = reference["first_time"]
    offsets = np.array([0.5e-3, 1e-3, 1.5e-3, 2.5e-3])
    index = np.rint((STEP_TIME + offsets - first) / SAMPLE_EVERY).astype(int)
    differences, peaks = [], []
    for seed, curve in reference["curves"].items():
        step_slip = None if divisor is None else RHO_MAX / divisor
        mu = simulate(velocity_step(int(seed), step_slip)).friction_coefficient
        mu = mu.sel(time=slice(first - 1e-9, None)).values
        expected = np.array(curve)
        assert mu.shape == expected.shape
        rise, expected_rise = mu - mu[:10].mean(), expected - expected[:10].mean()
        differences.append((rise - expected_rise)[index])
        peaks.append(expected_rise.max())
    differences = np.array(differences)
    mean = differences.mean(axis=0)
    error = differences.std(axis=0, ddof=1) / np.sqrt(len(differences))
    peak = float(np.mean(peaks))
    assert peak > 0.01  # the direct effect: about 0.015
    assert np.all(np.abs(mean) < z_bound(4) * error + 0.02 * peak), (mean, error)


@pytest.mark.slow
def test_a_runaway_slip_converges_to_the_event_by_event_reference() -> None:
    """The slip phase of stick-slip (:func:`tests.naive_quasistatic.runaway`, K / W = 4e4
    1/m): the spring outpulls the saturated friction, the stepper's drift runs at its
    athermal cap and the slider slides ~3.7 um before the spring arrests it. Against the
    event-by-event reference (the slider rebalanced after every depinning; 12 seeds with
    the same initial states): the same seeds run away, and the friction the slider is
    arrested at converges to the reference's as the step shrinks. Paired over the seeds
    that run away (level 1e-3 over the two comparisons): the arrest moves between rho~_max
    / 8 (the default) and / 128 by more than z_bound(2) standard errors, and at / 128 its
    error is within z_bound(2) standard errors of zero. Measured (7 seeds, 2026-11-27):
    errors -1.6e-3 (1 % of the 0.14 drop) at / 8, -0.08e-3 +- 0.31e-3 at / 128, a shift
    of -1.53e-3 +- 0.14e-3; power 0.91 against an error at / 128 as large as the
    default's. (The seed-to-seed scatter of the arrest, ~0.8e-3, exceeds the step's
    error: the unsigned |error| fell by only 2.5 standard errors.) A cap 1e5 times lower
    gave the same arrest at / 8 (it sets only the slide's duration)."""
    reference = {
        int(k): np.array(v) for k, v in json.loads(RUNAWAY_FILE.read_text())["curves"].items()
    }
    errors = []
    for seed, expected in reference.items():
        default = simulate(runaway(seed)).friction_coefficient.values
        ran_away = np.diff(expected).min() < -0.05
        assert (np.diff(default).min() < -0.05) == ran_away, seed
        if ran_away:
            fine = simulate(runaway(seed, RHO_MAX / 128)).friction_coefficient.values
            errors.append([default[-1] - expected[-1], fine[-1] - expected[-1]])
    errors = np.array(errors)
    assert len(errors) >= 5
    shift = errors[:, 0] - errors[:, 1]
    assert abs(shift.mean()) > z_bound(2) * shift.std(ddof=1) / np.sqrt(len(shift)), errors
    fine_error = errors[:, 1].std(ddof=1) / np.sqrt(len(errors))
    assert abs(errors[:, 1].mean()) < z_bound(2) * fine_error, errors


def test_lab_stiffness_velocity_step_matches_its_step_refined_reference() -> None:
    """A 10x velocity step on a lab spring (K / W = 1e4 1/m, 3e-6 of the interface's
    stiffness: the slider moves almost only by the depinnings' drift, which the stepper
    predicts one step ahead): the friction rise over 4000 rho~_max of load travel at the
    default step equals that at steps 4x finer to 5 % of its excursion."""
    travel = 4000 * RHO_MAX
    base = scenario(
        interface={"n_contacts": 10, "blocks_per_contact": 100},
        loading={
            "stiffness": 1e4,
            "steps": [
                {"velocity": 1e-6, "displacement": 20 * RHO_MAX},
                {"velocity": 1e-5, "displacement": travel},
            ],
        },
        run={"record_every": travel / 50 / 1e-5, "seed": 3},
    )
    finer = base.run.model_copy(update={"step_slip": base.step_slip / 4})
    default = simulate(base).friction_coefficient.values
    fine = simulate(base.model_copy(update={"run": finer})).friction_coefficient.values
    excursion = fine.max() - fine.min()
    assert excursion > 0.005  # the spring loads the interface to the faster stress
    assert np.sqrt(np.mean((default - fine) ** 2)) < 0.05 * excursion


def test_rigid_spring_steps_run_to_each_sample_through_velocity_steps_and_holds() -> None:
    """K = inf prescribes the slider path, so the blocks' exact ramps run uninterrupted to
    each sample (step_slip unlimited) and the slider moves with the load point in every
    segment: a 100x velocity drop, a hold and a reload give the friction of steps of
    rho~_max / 16 (a different realization: within 0.02 rms, the noise of 5000 blocks being
    ~0.004; blocks advanced at the previous segment's velocity miss by ~0.2)."""
    steps = [
        {"velocity": 1e-6, "displacement": 20 * RHO_MAX},
        {"velocity": 1e-8, "displacement": 4 * RHO_MAX},
        {"hold": 0.05},
        {"velocity": 1e-6, "displacement": 4 * RHO_MAX},
    ]

    def run_with(step_slip: float | None):
        return simulate(
            scenario(
                interface={"n_contacts": 100, "blocks_per_contact": 50},
                loading={"stiffness": float("inf"), "steps": steps},
                run={"record_every": 2e-3, "seed": 2, "step_slip": step_slip},
            )
        )

    whole, fine = run_with(None), run_with(RHO_MAX / 16)
    assert json.loads(whole.attrs["scenario"])["run"]["step_slip"] is None
    np.testing.assert_array_equal(whole.slider_displacement, whole.load_point_displacement)
    difference = whole.friction_coefficient.values - fine.friction_coefficient.values
    assert np.sqrt(np.mean(difference**2)) < 0.02


def test_cached_tells_a_cold_kernel_from_a_compiled_one(tmp_path, monkeypatch) -> None:
    """The compile notice's check reads Numba's cache index: False before the first call
    of a fresh cached kernel, True once it has compiled into the cache for those argument
    types, and still False for types it has not compiled (a chain run after a mean-field
    one compiles the chain kernel)."""
    (tmp_path / "fresh_kernel.py").write_text(
        "from nanoblock.kernels._jit import kernel\n\n\n"
        "@kernel\ndef twice(x: float) -> float:\n    return 2.0 * x\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("fresh_kernel")
    assert not cached(module.twice, (1.5,))
    assert module.twice(1.5) == 3.0
    assert cached(module.twice, (2.5,))
    assert not cached(module.twice, (2,))


def test_progress_says_when_kernels_compile(capsys, monkeypatch) -> None:
    run = scenario(loading={"stiffness": 1e6, "steps": [{"velocity": 1e-6, "duration": 1e-3}]})
    simulate(run)  # compiles into the cache if this is the first run
    simulate(run, progress=True)
    assert "compiling kernels" not in capsys.readouterr().err
    monkeypatch.setattr(engine, "cached", lambda dispatcher, arguments: False)
    simulate(run, progress=True)
    assert "compiling kernels (once after install)" in capsys.readouterr().err
    simulate(run)
    assert "compiling" not in capsys.readouterr().err


def test_progress_follows_the_expected_work_not_the_simulated_time(make_scenario) -> None:
    """The bar's work measure is 0 at the start and 100 % at the end, grows with load-point
    travel at the ramp's slope (one depinning per rho~_max per block), and stands still
    during a hold of the reference joint (u = 50: thermal escape negligible)."""
    from nanoblock.engine import expected_work

    steps = [
        {"velocity": 1e-6, "displacement": 1e-8},
        {"hold": 5.0},
        {"velocity": 1e-5, "displacement": 3e-8},
    ]
    scenario = make_scenario(loading={"stiffness": float("inf"), "steps": steps})
    work = expected_work(scenario)
    hold_start, hold_end, end = 1e-2, 5.01, 5.013
    assert work(0.0) == 0.0 and work(end) == pytest.approx(100.0)
    assert work(hold_start) == pytest.approx(25.0)
    assert work(hold_end) - work(hold_start) < 1e-6
    assert work(hold_end + 1.5e-3) == pytest.approx(62.5)
