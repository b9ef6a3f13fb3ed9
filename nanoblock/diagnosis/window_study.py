"""How the one-state memory length moves with the fit window (issue 15).

Laboratory fits take a window after each step (xlook's ``qi``: a few hundred microns). A
single state variable fitted to a record with a second, longer evolution length finds a
D_c that grows with the window: the fit trades the contact-scale decay against the slow
tail. This module refits the base aging law with the window after each step at
``FRACTIONS`` of the shortest travel after a change to a moving load point (a hold has
none), all the travel before the step kept, and reports D_c per window, the signature of
``two_state_variable``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from nanoblock.measured import DataError
from nanoblock.rsf.fit import fit_rsf, prepare_runs
from nanoblock.rsf.windows import step_windows

FRACTIONS = (0.125, 0.25, 0.5, 1.0)
"""Windows after each step, as fractions of the shortest travel after a step."""


def window_study(data: xr.Dataset) -> dict[str, Any]:
    """D_c [m] (with its standard error) of the aging law for each window after the steps,
    and its growth from the shortest to the longest window."""
    after = math.inf
    for run in prepare_runs(data):
        starts = run.history.starts
        for k, start in enumerate(starts[1:], start=1):
            if run.history.velocities[k] <= 0.0:  # a hold: no travel after it
                continue
            end = starts[k + 1] if k + 1 < starts.size else run.time[-1]
            after = min(
                after, float(run.history.displacement_at(end) - run.history.displacement_at(start))
            )
    rows = []
    for fraction in FRACTIONS:
        try:
            fit = fit_rsf(step_windows(data, math.inf, fraction * after), "aging").to_json()
        except (DataError, RuntimeError, ValueError) as error:
            rows.append({"after": fraction * after, "error": str(error)})
            continue
        rows.append(
            {"after": fraction * after, "dc": fit["params"]["dc"], "dc_stderr": fit["stderr"]["dc"]}
        )
    found = [row["dc"] for row in rows if row.get("dc")]
    growth = found[-1] / found[0] if len(found) >= 2 else None
    return {"windows": rows, "dc_growth": growth, "units": {"after": "m", "dc": "m"}}


def window_text(study: dict[str, Any]) -> str:
    """One sentence for the report."""
    parts = [
        f"{row['after'] * 1e6:.0f} um: {row['dc'] * 1e6:.3g} um"
        for row in study["windows"]
        if row.get("dc") and np.isfinite(row["dc"])
    ]
    text = "One-state D_c against the fit window after the step(s): " + "; ".join(parts) + "."
    if study["dc_growth"]:
        text += f" D_c grows {study['dc_growth']:.2g}-fold"
        text += " (a second, longer evolution length)." if study["dc_growth"] > 1.5 else "."
    return text
