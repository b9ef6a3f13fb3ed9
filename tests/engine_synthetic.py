"""Hidden-effect time series made by the nanoblock engine itself (issue 15: "generate the
data of each effect ... by the nanoblock simulator with the effect's simulator option
switched on").

Each case draws rate-and-state targets and an effect as the renewal generator of
``tests/hidden_synthetic.py`` does (same protocol, sample times, three normal forces,
stated stiffness and noise), turns them into a mean-field nanoblock interface by the
simulation check's calibration (:mod:`nanoblock.diagnosis.simulation`: the similarity
scaling, the threshold and the ageing m), switches the effect on through its simulator
option, and runs the agent-based engine (contacts ageing and renewing, blocks depinning
thermally) on each run's protocol. The friction it returns at the record's times, plus
the matrix's white or AR(1) noise, is the record: no rate-and-state law made it, and the
engine's own contact noise (correlated over D0) comes with it. Only the calibration is
shared with the diagnosis; no fit is.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from nanoblock.diagnosis.simulation import (
    AGING_FAMILY,
    DC_PER_D0,
    ROOM_TEMPERATURE,
    SWITCHES,
    _interfaces,
    record_times,
)
from nanoblock.engine import friction_at
from nanoblock.rsf.fit import LOAD_EXPONENT, prepare_runs
from tests.diagnosis_synthetic import NOISE, _dataset, _displacement
from tests.hidden_synthetic import (
    COLOURED_SHARE,
    FORCES,
    V1,
    _noise,
    _protocol,
    _sample_times,
    draw_effect,
    draw_interface,
    stated_stiffness,
)

ENGINE_EFFECTS = tuple(SWITCHES)
"""The effects with a simulator option on time series."""
N_CONTACTS = 1000
"""Contacts of the simulated interface (one block each)."""


def _targets(effect: str, rng: np.random.Generator) -> tuple[dict, dict, float, float]:
    """(base targets, targets with the effect, memory length D0 [m], stated K/W [1/m]), in
    the aging law's parameters (D_c = DC_PER_D0 D0); the draws of the renewal generator."""
    if effect not in (*ENGINE_EFFECTS, "none"):
        raise ValueError(f"{effect!r} has no simulator option ({', '.join(ENGINE_EFFECTS)})")
    a, b, d0, mu0 = draw_interface(rng)
    stated = stated_stiffness(a, b, d0)
    base = {"mu0": mu0, "a": a, "b": b, "dc": DC_PER_D0 * d0, "v0": V1, "stiffness": stated}
    drawn = draw_effect(effect, rng, b, d0)
    extra = {key: drawn[key] for key in ("v_theta", "tau_m", "b2") if key in drawn}
    if "exponent" in drawn:
        extra[LOAD_EXPONENT] = drawn["exponent"]
    if "d2_per_d0" in drawn:
        extra["dc2"] = DC_PER_D0 * d0 * drawn["d2_per_d0"]
    if "stiffness_factor" in drawn:
        extra["stiffness"] = stated * drawn["stiffness_factor"]
    return base, {**base, **extra}, d0, stated


def clean_record(
    effect: str, rng: np.random.Generator, n_contacts: int = N_CONTACTS
) -> tuple[xr.Dataset, dict, float, float]:
    """The engine's friction for ``effect`` (or ``none``) without measurement noise, the
    base targets, and the sigma and lag-1 autocorrelation phi of the noise
    :func:`engine_time_series` adds (drawn from ``rng`` in its order)."""
    base, extended, d0, stated = _targets(effect, rng)
    sigma = NOISE["time_series"] * rng.uniform(0.7, 1.4)
    phi = rng.uniform(0.5, 0.9) if rng.random() < COLOURED_SHARE else 0.0
    seed = int(rng.integers(2**31))
    segments = _protocol(d0, base["v0"])
    time = _sample_times(segments)
    displacement = _displacement(segments, time)
    columns = {
        "time": np.tile(time, len(FORCES)),
        "mu": np.zeros(time.size * len(FORCES)),
        "load_point_displacement": np.tile(displacement, len(FORCES)),
        "normal_force": np.repeat(FORCES, time.size),
        "run": np.repeat(np.arange(len(FORCES)), time.size),
    }
    attrs = {"stiffness_per_load": stated, "apparatus": "spring_slider"}
    skeleton = _dataset(columns, "time_series", **attrs)
    reference = math.exp(np.mean(np.log(FORCES)))
    name = "base" if effect == "none" else "extended"
    friction = []
    for index, run in enumerate(prepare_runs(skeleton)):
        built = _interfaces(
            run, stated, ROOM_TEMPERATURE, base, None if effect == "none" else effect,
            extended, reference, AGING_FAMILY, n_contacts=n_contacts, seed=seed + index,
        )  # fmt: skip
        times = record_times(run, built.scales[name], built.run_in[name])
        friction.append(friction_at(built.scenarios[name], times))
    columns["mu"] = np.concatenate(friction)
    return _dataset(columns, "time_series", **attrs), base, sigma, phi


def engine_time_series(effect: str, rng: np.random.Generator) -> tuple[xr.Dataset, None]:
    """An engine-made record with ``effect`` (or ``none``): (data, None); there is no
    noiseless twin (the engine's contact noise is part of the data)."""
    clean, _, sigma, phi = clean_record(effect, rng)
    size = clean.sizes["sample"] // len(FORCES)
    clean["mu"].values += np.concatenate([_noise(rng, size, sigma, phi) for _ in FORCES])
    return clean, None
