"""The simulation check (issue 4 of the diagnosis): run the nanoblock simulator on the
data's own protocol with the base parameters and with the diagnosed extension switched
on, and measure how much the misfit of the *simulation itself* falls.

Calibration (time series: velocity steps, slide-hold-slide). The base RSF fit (mu0, a, b,
D_c, K/W at v0) is turned into a mean-field interface by the micro-to-macro mapping
(physics.md section 2; 001/Eqs. 5, 16, 28): the reference joint of physics.md section 4
at the data's temperature with its threshold sigma_a chosen so that the exact local slope
d ln sigma_s / d ln V at the log-centre sqrt(V_min V_max) of the record's sliding
velocities equals a / mu0 (A = alpha mu0; the slope falls with V, so this matches the
secant over a step, which the RSF a measures, to second order in ln(V_max / V_min)); the
memory length D0 = D_c / DC_PER_D0 for the aging family (the renewal model's fitted D_c
is half of D0: ``tests/test_coarse_acceptance.py``, Dc/D0 = 0.47-0.52), D0 = D itself
for the renewal laws, whose ``dc`` is the contacts' mean renewal slip. The steady friction of that
interface is (sigma_s / p)(1 + m S), S = <ln(1 + phi / tau_m)> over its contacts
(001/Eq. 5, :func:`~nanoblock.theory.mapping.steady_log_area`), its direct effect alpha
times that level and its state effect m sigma_s / p: so the hardness and the ageing are
set by sigma_s / p = mu0 - B S and m = B / (mu0 - B S) (B = b, or b + b2 with a second
population), which give mu0, A = a and B = b at v0 exactly. (Taking p = sigma_s / mu0 and
m = b / mu0 instead inflates A by 1 + m S ~ 1.1 and the steady step a - b by up to 60 %
on laboratory gouge.)

Similarity scaling. Laboratory memory lengths are microns while a block slips
rho~_max ~ 0.3 nm per event, so the run is simulated with every memory length, slip
distance and time multiplied by ``scale`` = SIMULATED_D0 / D0 and velocities unchanged
(K/W divided by ``scale``, tau_m multiplied by it). The aging law is invariant under this
map (theta' = 1 - V theta / D_c with theta, t, D_c all scaled), and the direct effect
depends on V only. The simulated friction is compared with the data at the mapped times
(interpolated between its samples, every median data interval).

Run-in. The simulation starts from the steady state at the first velocity, each block's
stress drawn from Q_st (001/Eq. 27) independently: the friction of N blocks is off by up
to ~1 / sqrt(N) (0.013 at N = 500 and mu0 = 0.5), which the slider takes up by a stall
(or surge) over 1 / (sqrt(N) K/W) of load-point travel, and the contacts' ages relax from
that over D0. The record is therefore preceded by ``RUN_IN`` times (the longest D0 + that
loading travel) of sliding
at its first velocity, as the laboratory sample slid before the record, and compared
from there on (without it, the stall cost 0.0005-0.0009 of systematic misfit at 500
contacts on a 0.004 velocity step).

Misfit. The friction level is matched per run by the mean difference (a residual bias
of the mapping of ~0.1 %), so the check compares shapes. Each interface runs with
``SEEDS`` seeds; their mean is compared with the data, and the noise of that mean is
measured from the seeds' spread (it includes the slow fluctuation of the contact
population, correlated over D0, ~6x the sample-scale noise of one run at 500 contacts).
The misfit is reported as the RMS difference and as its systematic part,
sqrt(rms^2 - noise_data^2 - noise_simulation^2), the data's noise estimated by
:func:`~nanoblock.diagnosis.statistics.noise_level`.

Cost. A run's time goes almost all (> 95 %) into the kernels' internal steps, one every
rho~_max / 8 of slip at ~62 us for 500 contacts (measured 2026-11-28), so it grows with
the record's slip in memory lengths; only the friction is kept from each run
(:func:`~nanoblock.engine.friction_at`), and the runs (interfaces x seeds) are independent
and go at once on the idle cores (:func:`concurrent_runs`).
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from typing import Any, TypeVar

import numba
import numpy as np
import xarray as xr
from scipy.optimize import brentq
from tqdm.auto import tqdm

from nanoblock.diagnosis.statistics import noise_level
from nanoblock.engine import contact_memory_lengths, friction_at, sample_times
from nanoblock.params import Scenario, from_mapping
from nanoblock.rsf.fit import (
    LOAD_EXPONENT,
    STIFFNESS,
    FloatArray,
    RunData,
    prepare_runs,
    reference_load,
    stiffness_scales,
)
from nanoblock.rsf.laws import RenewalLaw, law
from nanoblock.theory.mapping import steady_log_area
from nanoblock.theory.meanfield import MeanFieldJoint, log_slope, steady_stress

DC_PER_D0 = 0.5
"""Fitted aging-law D_c per memory length D0 of the renewal model (measured)."""


AGING_FAMILY = ("aging", "aging")
"""``laws`` of fits by the aging law and its extensions (one memory convention)."""


def memory_length(law_name: str, dc: float) -> float:
    """The renewal model's memory length D0 [m] that a fit of law ``law_name`` with memory
    length ``dc`` [m] stands for: ``dc`` itself for a renewal law (its mean renewal slip
    D), ``dc / DC_PER_D0`` for the aging family (and any second memory, which follows the
    aging law in both families)."""
    return dc if isinstance(law(law_name), RenewalLaw) else dc / DC_PER_D0


SIMULATED_D0 = 3e-8
"""Memory length of the simulated interface [m]: ~110 rho~_max per renewal (D_c stays
linear in D0 down to 0.05 um and below, ``tests/test_coarse_acceptance.py``)."""
N_CONTACTS = 500
"""Simulated contacts (one block each)."""
SEEDS = 2
"""Runs of each interface (seeds ``seed``, ``seed + 1``, ...): their spread measures the
simulation's noise."""
RUN_IN = 1.0
"""Sliding before the record at its first velocity, in units of the longest memory
length plus the loading travel 1 / (sqrt(N) K/W) (module docstring)."""
REFERENCE_JOINT = {
    "block_size": 2.75e-9,
    "shear_modulus": 1.0e9,
    "attempt_frequency": 1.0e12,
    "k2": 0.0,
    "slip": "reset",
}
"""The reference mean-field joint (physics.md section 4) without its threshold."""
ROOM_TEMPERATURE = 293.15
"""Temperature [K] of data that do not state one."""
SATURATION_MARGIN = 1e-3
"""Base tau_m as a fraction of the shortest steady contact lifetime D0 / V_max: the
aging law's area grows logarithmically at every age the data probe."""


def sliding_velocities(run: RunData) -> FloatArray:
    """The run's load-point velocities while sliding [m/s]."""
    velocities = run.history.velocities
    return velocities[velocities > 0.0]


class CalibrationError(ValueError):
    """The base fit cannot be represented by a nanoblock interface (reason in message)."""


def _joint(threshold: float, temperature: float) -> MeanFieldJoint:
    block = REFERENCE_JOINT["block_size"]
    modulus = REFERENCE_JOINT["shear_modulus"]
    return MeanFieldJoint(
        block, modulus, threshold, modulus * block, REFERENCE_JOINT["attempt_frequency"],
        temperature,
    )  # fmt: skip


def calibrated_threshold(alpha: float, velocity: float, temperature: float) -> float:
    """sigma_a [Pa] of the reference joint whose slope d ln sigma_s / d ln V at
    ``velocity`` [m/s] is ``alpha`` (001/Eq. 28; alpha ~ 1 / 2u, u ~ sigma_a^2)."""

    def mismatch(log_threshold: float) -> float:
        joint = _joint(math.exp(log_threshold), temperature)
        return float(log_slope(velocity, joint)) - alpha

    low, high = math.log(1e6), math.log(1e11)
    if not mismatch(low) > 0.0 > mismatch(high):
        raise CalibrationError(
            f"no joint threshold in [1e6, 1e11] Pa gives a direct effect a / mu0 = {alpha:.3g} "
            f"at {velocity:.3g} m/s and {temperature:.4g} K"
        )
    return math.exp(brentq(mismatch, low, high, xtol=1e-10))


def _steps(run: RunData, scale: float) -> list[dict[str, float]]:
    """The run's load-point history as scenario steps, times multiplied by ``scale``."""
    history, t0, t1 = run.history, float(run.time[0]), float(run.time[-1])
    ends = np.append(history.starts[1:], np.inf)
    steps = []
    for start, end, velocity in zip(history.starts, ends, history.velocities, strict=True):
        duration = (min(end, t1) - max(start, t0)) * scale
        if duration <= 0.0:
            continue
        if velocity > 0.0:
            steps.append({"velocity": float(velocity), "duration": duration})
        else:
            steps.append({"hold": duration})
    return steps


@dataclass(frozen=True)
class Targets:
    """What the simulated interface is built to show (001/Eq. 16): mu0 and the relative
    direct effect alpha = A / mu0 at v0, the relative ageing m = B / mu0, and the memory
    length D0 [m] in data units."""

    mu0: float
    alpha: float
    m: float
    memory_length: float

    @classmethod
    def from_fit(cls, params: Mapping[str, float], law_name: str) -> Targets:
        """The mapping's first guess from a fit of law ``law_name`` (D0 by
        :func:`memory_length`)."""
        mu0, a, b, dc = (float(params[key]) for key in ("mu0", "a", "b", "dc"))
        if not (mu0 > 0.0 and a > 0.0):
            raise CalibrationError(
                f"the base fit has mu0 = {mu0:.3g}, a = {a:.3g}; both must be > 0"
            )
        if b < 0.0:
            raise CalibrationError(
                f"the base fit has b = {b:.3g} < 0: contact ageing (m >= 0, 001/Eq. 5) "
                "cannot make it"
            )
        return cls(mu0, a / mu0, b / mu0, memory_length(law_name, dc))


def base_scenario(
    targets: Targets,
    run: RunData,
    stiffness_per_load: float,
    temperature: float,
    *,
    n_contacts: int = N_CONTACTS,
    seed: int = 0,
) -> tuple[Scenario, float]:
    """The mean-field nanoblock interface built for ``targets`` on ``run``'s protocol under
    the similarity scaling, hardness sigma_s(v0) / mu0 and ageing m (its level is set by
    :func:`finished` once the extension's populations are switched on); returns
    (scenario, scale)."""
    velocities = sliding_velocities(run)
    v0, v_max = float(velocities[0]), float(velocities.max())
    centre = math.sqrt(float(velocities.min()) * v_max)
    threshold = calibrated_threshold(targets.alpha, centre, temperature)
    sigma_s = float(steady_stress(v0, _joint(threshold, temperature)))
    scale = SIMULATED_D0 / targets.memory_length
    force = run.normal_force if math.isfinite(run.normal_force) else 1.0
    scenario = from_mapping(
        {
            "joint": {**REFERENCE_JOINT, "threshold_stress": threshold, "temperature": temperature},
            "interface": {
                "normal_force": force,
                "hardness": sigma_s / targets.mu0,
                "n_contacts": n_contacts,
                "blocks_per_contact": 1,
                "memory_length": SIMULATED_D0,
                "aging_m": targets.m,
                "aging_time": SATURATION_MARGIN * SIMULATED_D0 / v_max,
            },
            "loading": {
                "stiffness": stiffness_per_load / scale * force,
                "steps": _steps(run, scale),
            },
            "run": {
                "seed": seed,
                "record_every": float(np.median(np.diff(run.time))) * scale,
                "initial_state": "steady",
            },
        }
    )
    return scenario, scale


def _with(scenario: Scenario, section: str, values: Mapping[str, Any]) -> Scenario:
    data = json.loads(scenario.resolved_json())
    data[section].update(values)
    return from_mapping(data)


def _saturation(scenario: Scenario, params: Mapping[str, float], scale: float, _) -> Scenario:
    return _with(scenario, "interface", {"aging_time": float(params["tau_m"]) * scale})


def _cutoff(scenario: Scenario, params: Mapping[str, float], scale: float, _) -> Scenario:
    return _with(scenario, "interface", {"state_cutoff_velocity": float(params["v_theta"])})


def _load_memory(
    scenario: Scenario, params: Mapping[str, float], scale: float, reference_force: float
) -> Scenario:
    return _with(
        scenario,
        "interface",
        {
            "memory_length_exponent": float(params[LOAD_EXPONENT]),
            "reference_force": reference_force,
        },
    )


def _two_state(scenario: Scenario, params: Mapping[str, float], scale: float, _) -> Scenario:
    """A second contact population of memory length D0_2 = D_c2 / DC_PER_D0 (scaled)
    holding the share f = b2 / (b + b2) of the state effect B = b + b2 of all contacts
    (aging_m = B / mu0 until :func:`finished` sets the level)."""
    mu0, b, b2 = (float(params[key]) for key in ("mu0", "b", "b2"))
    n_contacts = scenario.interface.n_contacts
    share = b2 / (b + b2) if b > 0.0 and b2 > 0.0 else 0.0
    if not 1 <= round(share * n_contacts) <= n_contacts - 1:
        raise CalibrationError(
            f"the two-state fit has b = {b:.3g}, b2 = {b2:.3g}: a second population holding "
            f"b2 / (b + b2) of the ageing needs both > 0 and at least one of "
            f"{n_contacts} contacts in each population"
        )
    return _with(
        scenario,
        "interface",
        {
            "aging_m": (b + b2) / mu0,
            "second_memory_length": float(params["dc2"]) / DC_PER_D0 * scale,
            "second_population": share,
        },
    )


def _stiffness(scenario: Scenario, params: Mapping[str, float], scale: float, _) -> Scenario:
    """The extended interface is already built at the fitted K/W (loading.stiffness)."""
    return scenario


SWITCHES: dict[str, Callable[[Scenario, Mapping[str, float], float, float], Scenario]] = {
    "velocity_saturation": _saturation,
    "state_velocity_cutoff": _cutoff,
    "load_dependent_dc": _load_memory,
    "machine_stiffness": _stiffness,
    "two_state_variable": _two_state,
}
"""Extensions with a simulator option on time series: (base scenario, extension fit,
scale, W_ref) -> the scenario with the extension switched on."""
NOT_SIMULATED = {
    "aging_rate": "the slip law's slip-only healing has no exact renewal-model counterpart "
    "on time series (interface.state_cutoff_velocity is the closest option)",
    "slip_trend": "wear and gouge evolution are outside the nanoblock model",
    "load_dependent_level": "a cohesive force beside the contacts is not a simulator option "
    "yet, and the check matches each run's friction level already",
    "non_steady_history": "the simulation starts in steady sliding at the first velocity; a "
    "preceding loading step is not yet aligned with the record's time origin",
    "unstable_sliding": "stick-slip is recognised from the record's drops, not fitted",
}


def finished(scenario: Scenario, run: RunData) -> tuple[Scenario, float]:
    """``scenario`` (hardness sigma_s(v0) / mu0, aging_m = B / mu0) with its friction level
    and state effect set for its contact populations, and the run-in prepended (module
    docstring); returns the scenario and the simulated time [s] at which the record starts.

    Hardness and aging_m are both multiplied by 1 / (1 - m S), S = <ln(1 + phi / tau_m)>
    at v0 (:func:`~nanoblock.theory.mapping.steady_log_area`): the steady level
    (sigma_s / p)(1 + m S) is then mu0 and m sigma_s / p stays B (001/Eq. 5)."""
    interface = scenario.interface
    v0 = float(sliding_velocities(run)[0])
    memory = contact_memory_lengths(scenario)
    cutoff = interface.state_cutoff_velocity or 0.0
    ageing = interface.aging_m * steady_log_area(memory, interface.aging_time, v0, cutoff)
    if not ageing < 1.0:
        raise CalibrationError(
            f"the contacts' ageing m <ln(1 + phi / tau_m)> = {ageing:.3g} at {v0:.3g} m/s "
            "leaves no friction for the fresh contacts (B ln(theta / tau_m) >= mu0)"
        )
    gain = 1.0 / (1.0 - ageing)
    stiffness = scenario.loading.stiffness / interface.normal_force
    loading = 1.0 / (stiffness * math.sqrt(interface.n_contacts * interface.blocks_per_contact))
    run_in = RUN_IN * (float(memory.max()) + loading) / v0
    data = json.loads(scenario.resolved_json())
    data["interface"].update(
        {"hardness": interface.hardness * gain, "aging_m": interface.aging_m * gain}
    )
    data["loading"]["steps"].insert(0, {"velocity": v0, "duration": run_in})
    return from_mapping(data), run_in


NAMES = ("base", "extended")
"""The interfaces the check compares."""


@dataclass(frozen=True)
class Interfaces:
    """The calibrated interfaces of one run: scenario, scale and run-in time [s] each."""

    scenarios: dict[str, Scenario]
    scales: dict[str, float]
    run_in: dict[str, float]


def _interfaces(
    run: RunData,
    stiffness: float,
    temperature: float,
    base_params: Mapping[str, float],
    extension: str | None,
    extension_params: Mapping[str, float],
    reference_force: float,
    laws: tuple[str, str],
    **options: int,
) -> Interfaces:
    """``base`` and, where the extension has a simulator option, ``extended`` on ``run``
    (``stiffness``: the base K/W of this run [1/m]; ``laws``: of the base and extension
    fits; ``options``: n_contacts, seed)."""
    base = Targets.from_fit(base_params, laws[0])
    built = {"base": base_scenario(base, run, stiffness, temperature, **options)}
    if extension in SWITCHES:
        fitted = float(extension_params.get(STIFFNESS, base_params[STIFFNESS]))
        plain, scale = base_scenario(
            Targets.from_fit(extension_params, laws[1]), run,
            stiffness * fitted / float(base_params[STIFFNESS]), temperature, **options,
        )  # fmt: skip
        switched = SWITCHES[extension](plain, extension_params, scale, reference_force)
        built["extended"] = (switched, scale)
    scenarios, scales, run_in = {}, {}, {}
    for name, (scenario, scale) in built.items():
        scenarios[name], run_in[name] = finished(scenario, run)
        scales[name] = scale
    return Interfaces(scenarios, scales, run_in)


Built = TypeVar("Built")


def _calibrate(
    build: Callable[[str | None], Built], extension: str | None
) -> tuple[Built, str | None]:
    """``build(extension)`` and None; or, when the extension's fit cannot be calibrated
    while the base's can, ``build(None)`` and why. Raises the base's
    :class:`CalibrationError` when neither can."""
    try:
        return build(extension), None
    except CalibrationError as error:
        built = build(None)
        return built, f"the {extension} fit cannot be simulated while the base fit can: {error}"


def calibrated_scenarios(
    data: xr.Dataset,
    base_params: Mapping[str, float],
    extension: str | None,
    extension_params: Mapping[str, float],
    *,
    laws: tuple[str, str] = AGING_FAMILY,
) -> tuple[dict[str, Scenario], str]:
    """The calibrated nanoblock interfaces of the first run, as ``nanoblock run`` takes
    them: ``base`` and, where the extension has a simulator option, ``extended``; and a
    note on the scaling and run-in (or why one is missing). ``laws``: of the base and
    extension fits, as :func:`simulation_check` takes them."""
    if data.attrs.get("kind") != "time_series":
        return {}, f"{data.attrs.get('kind')} data have no runnable spring-slider scenario"
    run = prepare_runs(data)[0]
    stiffness = float(base_params[STIFFNESS]) * stiffness_scales(data, [run])[0]
    temperature = float(data.attrs.get("temperature", ROOM_TEMPERATURE))
    reference = reference_load([run.normal_force], False)
    try:
        built, missing = _calibrate(
            lambda switched: _interfaces(
                run, stiffness, temperature, base_params, switched, extension_params,
                reference, laws,
            ),
            extension,
        )  # fmt: skip
    except CalibrationError as error:
        return {}, f"no runnable scenario: {error}"
    if missing is None and extension is not None and extension not in SWITCHES:
        missing = NOT_SIMULATED.get(extension, "not simulated")
    scale, run_in = built.scales["base"], built.run_in["base"]
    note = (
        f"similarity scaling: every length and time x {scale:.4g} (velocities unchanged); "
        f"the record starts after a run-in of {run_in:.4g} s"
    )
    if missing is not None:
        note += f"; no extended scenario: {missing}"
    return built.scenarios, note


def record_times(run: RunData, scale: float, run_in: float) -> FloatArray:
    """The times a model of the record is evaluated at (:attr:`RunData.evaluation_times`)
    on the simulation's clock [s]: scaled, after the run-in."""
    times = run.evaluation_times
    return (times - times[0]) * scale + run_in


def _misfit(simulated: list[FloatArray], run: RunData, data_noise: float) -> dict:
    """RMS of the seeds' mean simulated friction (at :func:`record_times`, as the samples
    see it) minus the data (levels matched), the noise of that mean from the seeds'
    spread, and the systematic part."""
    seeds = np.array([mu - mu.mean() for mu in map(run.sampled, simulated)])
    difference = seeds.mean(axis=0) - (run.mu - run.mu.mean())
    rms = float(np.sqrt(np.mean(difference**2)))
    spread = float(np.mean(np.var(seeds, axis=0, ddof=1))) if len(seeds) > 1 else 0.0
    simulation_noise = math.sqrt(spread / len(seeds))
    systematic = math.sqrt(max(rms**2 - data_noise**2 - simulation_noise**2, 0.0))
    return {"rms": rms, "systematic": systematic, "simulation_noise": simulation_noise}


def concurrent_runs(jobs: int, workers: int | None = None) -> int:
    """How many of ``jobs`` simulations run at once: ``workers``, by default one per core
    this process may use, at most NUMBA_NUM_THREADS (NUMBA_NUM_THREADS=1 runs them one
    after another); 1 where Numba's threading layer cannot launch parallel kernels from
    two threads at once (workqueue aborts the process)."""
    numba.get_num_threads()  # launches the threading layer, which can then be named
    if numba.threading_layer() == "workqueue":
        return 1
    if workers is None:
        affinity = getattr(os, "sched_getaffinity", None)
        cores = len(affinity(0)) if affinity is not None else os.cpu_count() or 1
        workers = min(cores, numba.config.NUMBA_NUM_THREADS)
    return max(1, min(jobs, workers))


def _work(scenario: Scenario) -> float:
    """Expected depinnings per block of a run: load-point travel / rho~_max."""
    travel = sum(step.load_velocity * step.length for step in scenario.loading.steps)
    return travel / scenario.joint.rho_max


def _frictions(
    jobs: list[tuple[Scenario, FloatArray]], workers: int, progress: bool
) -> list[FloatArray]:
    """Each job's friction at the record's times: its scenario run (samples every
    ``run.record_every``, as :func:`~nanoblock.engine.simulate` stores them) and
    interpolated. One run after another with the contact loop on the idle cores, or
    ``workers`` runs at once on one Numba thread each, longest first (the kernels release
    the GIL; each run has its own random streams, so the values do not depend on which
    thread or how many run it)."""
    bar = tqdm(total=len(jobs), desc="simulation check", disable=not progress, leave=False)

    def one(k: int, threads: int | None) -> FloatArray:
        scenario, times = jobs[k]
        grid = sample_times(scenario)
        friction = friction_at(scenario, grid, threads=threads, progress=progress and k == 0)
        bar.update()
        return np.interp(times, grid, friction)

    with bar:
        if workers == 1:
            return [one(k, None) for k in range(len(jobs))]
        longest_first = sorted(range(len(jobs)), key=lambda k: -_work(jobs[k][0]))
        with ThreadPoolExecutor(workers) as pool:
            futures = {k: pool.submit(one, k, 1) for k in longest_first}
            return [futures[k].result() for k in range(len(jobs))]


def _pooled(parts: list[dict], sizes: list[int]) -> dict[str, float]:
    weights = np.asarray(sizes, dtype=float) / sum(sizes)
    return {
        key: float(np.sqrt(np.sum(weights * np.array([p[key] ** 2 for p in parts]))))
        for key in ("rms", "systematic", "simulation_noise")
    }


def simulation_check(
    data: xr.Dataset,
    base_params: Mapping[str, float],
    extension: str | None,
    extension_params: Mapping[str, float],
    *,
    laws: tuple[str, str] = AGING_FAMILY,
    n_contacts: int = N_CONTACTS,
    seed: int = 0,
    seeds: int = SEEDS,
    progress: bool = False,
    workers: int | None = None,
    cache: dict[tuple[str, bytes], FloatArray] | None = None,
) -> dict[str, Any]:
    """Simulate the data's protocol with the base interface and with ``extension``
    switched on, each with ``seeds`` seeds from ``seed``; ``laws``: the RSF laws of the
    base and extension fits (their memory lengths map to D0 by :func:`memory_length`).
    The misfit of each against the data (``status`` ``"ran"``, with the wall ``seconds``
    the simulations took), why the extension's fit has no interface while the base's has
    (``"refused"``: the simulator cannot make that cause, so it is not confirmed) or why
    the check cannot run (``"not_run"``). ``workers``:
    simulations run at once (default :func:`concurrent_runs`); the result does not depend
    on it. ``cache``: the caller's store of simulated frictions, keyed by the run's
    scenario (seed included) and record times; runs found there are not simulated again,
    so a rerun with more seeds simulates only the new ones.

    The interfaces are built by the mapping (:class:`Targets`, :func:`finished`); the
    friction level is matched to each run by the mean difference, so the misfit measures
    shape, not level (module docstring)."""
    if data.attrs.get("kind") != "time_series":
        return {
            "status": "not_run",
            "reason": f"the simulator drives a spring-slider; {data.attrs.get('kind')} data "
            "would need its apparatus (clamped sample) or a run per table row",
        }
    if extension is None or extension not in SWITCHES:
        why = NOT_SIMULATED.get(extension or "", "no extension was diagnosed")
        return {"status": "not_run", "reason": why}
    prepared = prepare_runs(data)
    reference_force = reference_load(
        [r.normal_force for r in prepared], extension == "load_dependent_dc"
    )
    temperature = float(data.attrs.get("temperature", ROOM_TEMPERATURE))
    stiffness = float(base_params[STIFFNESS])
    noise = noise_level([r.mu for r in prepared])
    started = time.perf_counter()

    per_run = list(zip(prepared, stiffness_scales(data, prepared), strict=True))
    options = {"n_contacts": n_contacts, "seed": seed}

    def build(switched: str | None) -> list[Interfaces]:
        return [
            _interfaces(
                run,
                stiffness * scale,
                temperature,
                base_params,
                switched,
                extension_params,
                reference_force,
                laws,
                **options,
            )
            for run, scale in per_run
        ]

    try:
        built, refused = _calibrate(build, extension)
    except CalibrationError as error:
        return {"status": "not_run", "reason": str(error)}
    if refused is not None:
        return {"status": "refused", "extension": extension, "reason": refused, "summary": refused}
    keys = [(r, name, i) for r in range(len(built)) for name in NAMES for i in range(seeds)]
    jobs = [
        (
            _with(built[r].scenarios[name], "run", {"seed": seed + i}),
            record_times(prepared[r], built[r].scales[name], built[r].run_in[name]),
        )
        for r, name, i in keys
    ]
    cache = {} if cache is None else cache
    stored = [(scenario.resolved_json(), times.tobytes()) for scenario, times in jobs]
    todo = [k for k, key in enumerate(stored) if key not in cache]
    simulated = _frictions([jobs[k] for k in todo], concurrent_runs(len(todo), workers), progress)
    cache.update(zip([stored[k] for k in todo], simulated, strict=True))
    frictions = {key: cache[k] for key, k in zip(keys, stored, strict=True)}
    misfits = {
        name: [
            _misfit([frictions[r, name, i] for i in range(seeds)], run, noise)
            for r, run in enumerate(prepared)
        ]
        for name in NAMES
    }
    sizes = [r.mu.size for r in prepared]
    base_misfit = _pooled(misfits["base"], sizes)
    extended_misfit = _pooled(misfits["extended"], sizes)
    fall = 1.0 - extended_misfit["systematic"] ** 2 / max(base_misfit["systematic"] ** 2, 1e-300)
    last = built[-1]
    scale, scales = last.scales["base"], last.scales["extended"]
    return {
        "status": "ran",
        "extension": extension,
        "n_contacts": n_contacts,
        "seeds": seeds,
        "scale": dict(last.scales),
        "run_in": dict(last.run_in),
        "targets": {
            "base": asdict(Targets.from_fit(base_params, laws[0])),
            "extended": asdict(Targets.from_fit(extension_params, laws[1])),
        },
        "base": base_misfit,
        "extended": extended_misfit,
        "systematic_variance_removed": fall,
        "seconds": time.perf_counter() - started,
        "summary": (
            f"nanoblock simulation ({seeds} x {n_contacts} contacts, lengths and times "
            f"x {scale:.3g}, {scales:.3g} extended): "
            f"systematic misfit {base_misfit['systematic']:.3g} with the base interface, "
            f"{extended_misfit['systematic']:.3g} with {extension} switched on "
            f"({100 * fall:.0f} % of its variance removed)"
        ),
        "scenario_extended": last.scenarios["extended"].resolved_json(),
    }
