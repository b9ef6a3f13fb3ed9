"""Physical plausibility of a fitted extension: a cause is accepted only with parameters a
real interface can have.

Two kinds of range. Every rate-and-state fit of a time series must keep its contract
parameters where laboratory friction puts them (``RSF_RANGES``: a > 0 up to 0.1 and
|b| <= 0.1, the span of rock, gouge, glass and polymer data, 001 Sec. II and 000 Table 2;
mu0 inside the friction the record shows, widened by ``MU0_MARGIN``; memory lengths below
the record's travel times ``TRAVEL_FACTOR``, as a D_c beyond it is not measured). Each
catalogue entry states the ranges of the parameters it adds (``Effect.ranges``); a prefix
names a family (``initial_state_offset`` covers every run's offset) and
``stiffness_ratio`` is the fitted K/W over the stated one.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from nanoblock.diagnosis.catalogue import Effect
from nanoblock.rsf.fit import STIFFNESS

RSF_RANGES: dict[str, tuple[float, float]] = {"a": (1e-5, 0.1), "b": (-0.1, 0.1)}
"""Contract parameters of a time-series fit: direct and evolution effects."""
MU0_MARGIN = 0.05
"""How far mu0 may lie outside the friction the record shows."""
TRAVEL_FACTOR = 10.0
"""Largest memory length per load-point travel of the record."""


def implausible(
    effect: Effect | None,
    params: Mapping[str, float],
    observed: list[np.ndarray],
    travel: float,
    stated_stiffness: float | None,
) -> list[str]:
    """Why ``params`` (a base or ``effect`` fit of a time series) are not physical: one
    sentence per parameter out of range, empty when all are inside."""
    values = dict(params)
    if stated_stiffness and STIFFNESS in values:
        values["stiffness_ratio"] = values[STIFFNESS] / stated_stiffness
    ranges = dict(RSF_RANGES)
    low, high = min(float(np.min(y)) for y in observed), max(float(np.max(y)) for y in observed)
    ranges["mu0"] = (low - MU0_MARGIN, high + MU0_MARGIN)
    for name in ("dc", "dc2"):
        ranges[name] = (0.0, TRAVEL_FACTOR * travel)
    reasons = []
    for name, value in values.items():
        family = next((r for r in (effect.ranges if effect else {}) if name.startswith(r)), None)
        bounds = (effect.ranges[family] if family else None) or ranges.get(name)
        if bounds is not None and not bounds[0] <= value <= bounds[1]:
            reasons.append(f"{name} = {value:.3g} is outside [{bounds[0]:.3g}, {bounds[1]:.3g}]")
    if effect is not None and effect.id == "two_state_variable" and values["dc2"] <= values["dc"]:
        reasons.append(f"dc2 = {values['dc2']:.3g} m is not longer than dc = {values['dc']:.3g} m")
    return reasons
