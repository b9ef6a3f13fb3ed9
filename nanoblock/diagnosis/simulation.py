"""The simulation check (issue 4 of the diagnosis): run the nanoblock simulator on the
data's own protocol with the base parameters and with the diagnosed extension switched
on, and measure how much the misfit of the *simulation itself* falls.

Calibration (time series: velocity steps, slide-hold-slide). The base RSF fit (mu0, a, b,
D_c, K/W at v0) is turned into a mean-field interface by the micro-to-macro mapping
(physics.md section 2; 001/Eqs. 16, 28): the reference joint of physics.md section 4 at
the data's temperature with its threshold sigma_a chosen so that the exact local slope
d ln sigma_s / d ln V at v0 equals a / mu0 (A = alpha mu0); the hardness so that
sigma_s(v0) / p = mu0; the ageing m = b / mu0 (B = m mu0); the memory length
D0 = D_c / DC_PER_D0 (the renewal model's fitted D_c is half of D0:
``tests/test_coarse_acceptance.py``, Dc/D0 = 0.47-0.52).

Similarity scaling. Laboratory memory lengths are microns while a block slips
rho~_max ~ 0.3 nm per event, so the run is simulated with every memory length, slip
distance and time multiplied by ``scale`` = SIMULATED_D0 / D0 and velocities unchanged
(K/W divided by ``scale``, tau_m multiplied by it). The aging law is invariant under this
map (theta' = 1 - V theta / D_c with theta, t, D_c all scaled), and the direct effect
depends on V only; ageing's ln(theta / tau_m) shifts by a constant that the calibration
of mu0 absorbs. The simulated friction is compared with the data at the mapped times.

The friction level is matched per run by the mean difference (the ageing area factor
m ln(theta / tau_m) and the mapping's bias shift it by a few per cent; the fitted A and B
of the renewal model differ from alpha mu0 and m mu0 by 10-50 %, README section
"Coarse-graining"), so the check compares shapes. The misfit is reported as the RMS
difference and as its systematic part,
sqrt(rms^2 - noise_data^2 - noise_simulation^2), both noises estimated by
:func:`~nanoblock.diagnosis.statistics.noise_level`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import xarray as xr
from scipy.optimize import brentq

from nanoblock.diagnosis.statistics import noise_level
from nanoblock.engine import simulate
from nanoblock.params import Scenario, from_mapping
from nanoblock.rsf.fit import (
    LOAD_EXPONENT,
    STIFFNESS,
    RunData,
    prepare_runs,
    reference_load,
    stiffness_scales,
)
from nanoblock.theory.meanfield import MeanFieldJoint, log_slope, steady_stress

DC_PER_D0 = 0.5
"""Fitted aging-law D_c per memory length D0 of the renewal model (measured)."""
SIMULATED_D0 = 3e-8
"""Memory length of the simulated interface [m]: ~110 rho~_max per renewal (D_c stays
linear in D0 down to 0.05 um and below, ``tests/test_coarse_acceptance.py``)."""
N_CONTACTS = 500
"""Simulated contacts (one block each)."""
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
    def from_fit(cls, params: Mapping[str, float]) -> Targets:
        """The mapping's first guess from a base aging-law fit (D0 = D_c / DC_PER_D0)."""
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
        return cls(mu0, a / mu0, b / mu0, dc / DC_PER_D0)


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
    the similarity scaling; returns (scenario, scale)."""
    v0 = float(run.history.velocities[0])
    threshold = calibrated_threshold(targets.alpha, v0, temperature)
    sigma_s = float(steady_stress(v0, _joint(threshold, temperature)))
    scale = SIMULATED_D0 / targets.memory_length
    force = run.normal_force if math.isfinite(run.normal_force) else 1.0
    v_max = float(np.max(run.history.velocities))
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
    """A second contact population with D0_2 / D0 = D_c2 / D_c holding the share
    f = b2 / (b + b2) of the state effect; the ageing m = (b + b2) / mu0 of all contacts."""
    mu0, b, b2 = (float(params[key]) for key in ("mu0", "b", "b2"))
    ratio = float(params["dc2"]) / float(params["dc"])
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
            "second_memory_length": scenario.interface.memory_length * ratio,
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


def calibrated_scenarios(
    data: xr.Dataset,
    base_params: Mapping[str, float],
    extension: str | None,
    extension_params: Mapping[str, float],
) -> tuple[dict[str, Scenario], str]:
    """The calibrated nanoblock interfaces of the first run, as ``nanoblock run`` takes
    them: ``base`` and, where the extension has a simulator option, ``extended``; and a
    note on the scaling (or why one is missing)."""
    if data.attrs.get("kind") != "time_series":
        return {}, f"{data.attrs.get('kind')} data have no runnable spring-slider scenario"
    run = prepare_runs(data)[0]
    factor = stiffness_scales(data, [run])[0]
    stiffness = float(base_params[STIFFNESS]) * factor
    temperature = float(data.attrs.get("temperature", ROOM_TEMPERATURE))
    try:
        base, scale = base_scenario(Targets.from_fit(base_params), run, stiffness, temperature)
        out = {"base": base}
        note = f"similarity scaling: every length and time x {scale:.4g} (velocities unchanged)"
        if extension in SWITCHES:
            plain, scales = base_scenario(
                Targets.from_fit(extension_params), run,
                float(extension_params.get(STIFFNESS, stiffness / factor)) * factor, temperature,
            )  # fmt: skip
            reference = reference_load([run.normal_force], False)
            out["extended"] = SWITCHES[extension](plain, extension_params, scales, reference)
        elif extension is not None:
            note += f"; no extended scenario: {NOT_SIMULATED.get(extension, 'not simulated')}"
    except CalibrationError as error:
        return {}, str(error)
    return out, note


def _misfit(simulated: xr.Dataset, run: RunData, scale: float, data_noise: float) -> dict:
    """RMS of simulation minus data at the mapped times (levels matched), and its
    systematic part."""
    mu = np.interp(
        (run.time - run.time[0]) * scale,
        simulated["time"].values - float(simulated["time"].values[0]),
        simulated["friction_coefficient"].values,
    )
    difference = mu - run.mu
    difference -= difference.mean()
    rms = float(np.sqrt(np.mean(difference**2)))
    simulation_noise = noise_level([mu])
    systematic = math.sqrt(max(rms**2 - data_noise**2 - simulation_noise**2, 0.0))
    return {"rms": rms, "systematic": systematic, "simulation_noise": simulation_noise}


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
    n_contacts: int = N_CONTACTS,
    seed: int = 0,
    progress: bool = False,
) -> dict[str, Any]:
    """Simulate the data's protocol with the base interface and with ``extension``
    switched on; the misfit of each against the data (``status`` ``"ran"``) or why the
    check cannot run (``"not_run"``).

    The base interface is built by the mapping (:class:`Targets`); its friction level is
    matched to each run by the mean difference (the ageing area factor and the bias of
    the mapping shift mu by a few per cent), so the misfit measures shape, not level."""
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
    options = {"n_contacts": n_contacts, "seed": seed}
    try:
        targets = {
            "base": Targets.from_fit(base_params),
            "extended": Targets.from_fit(extension_params),
        }
        misfits: dict[str, list[dict]] = {"base": [], "extended": []}
        for run, per_run in zip(prepared, stiffness_scales(data, prepared), strict=True):
            base, scale = base_scenario(
                targets["base"], run, stiffness * per_run, temperature, **options
            )
            plain, scales = base_scenario(
                targets["extended"],
                run,
                float(extension_params.get(STIFFNESS, stiffness)) * per_run,
                temperature,
                **options,
            )
            extended = SWITCHES[extension](plain, extension_params, scales, reference_force)
            for name, scenario, factor in (("base", base, scale), ("extended", extended, scales)):
                simulated = simulate(scenario, progress=progress)
                misfits[name].append(_misfit(simulated, run, factor, noise))
    except CalibrationError as error:
        return {"status": "not_run", "reason": str(error)}
    sizes = [r.mu.size for r in prepared]
    base_misfit = _pooled(misfits["base"], sizes)
    extended_misfit = _pooled(misfits["extended"], sizes)
    fall = 1.0 - extended_misfit["systematic"] ** 2 / max(base_misfit["systematic"] ** 2, 1e-300)
    return {
        "status": "ran",
        "extension": extension,
        "n_contacts": n_contacts,
        "scale": {"base": scale, "extended": scales},
        "targets": {name: asdict(value) for name, value in targets.items()},
        "base": base_misfit,
        "extended": extended_misfit,
        "systematic_variance_removed": fall,
        "summary": (
            f"nanoblock simulation ({n_contacts} contacts, lengths and times x {scale:.3g}, "
            f"{scales:.3g} extended): "
            f"systematic misfit {base_misfit['systematic']:.3g} with the base interface, "
            f"{extended_misfit['systematic']:.3g} with {extension} switched on "
            f"({100 * fall:.0f} % of its variance removed)"
        ),
        "scenario_extended": extended.resolved_json(),
    }
