"""Fit windows around velocity steps, as laboratory fitting tools (xlook's ``qi``,
RSFit3000) take them: a stretch of load-point travel before each step and one after it.

Every step becomes a run of its own, so a file with several steps is fitted with shared
parameters (one law, one set of a, b, D_c) and each window starts in the steady sliding
that precedes its step; the windows never reach past the neighbouring steps.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from nanoblock.measured import DataError, runs
from nanoblock.rsf.fit import prepare_runs

__all__ = ["parse_window", "step_windows"]


def parse_window(text: str) -> tuple[float, float]:
    """``"BEFORE,AFTER"`` in metres (e.g. ``"5e-5,3e-4"``) -> (before, after); both > 0."""
    parts = text.split(",")
    try:
        values = tuple(float(part) for part in parts)
    except ValueError:
        values = ()
    if len(values) != 2 or not all(math.isfinite(v) and v > 0.0 for v in values):
        raise DataError(
            f"--window {text!r}: give BEFORE,AFTER, two load-point travels in metres > 0 "
            "(e.g. 5e-5,3e-4 for 50 um before and 300 um after each step)"
        )
    return values[0], values[1]


def step_windows(data: xr.Dataset, before: float, after: float) -> xr.Dataset:
    """The samples within ``before`` [m] of load-point travel before each change of
    load-point velocity and ``after`` [m] after it, one run per step (``run`` = 0, 1, ...
    in file order; attribute ``windows`` says which run and step each came from)."""
    pieces, labels, steps = [], [], 0
    for index, (part, run) in enumerate(zip(runs(data), prepare_runs(data), strict=True)):
        history = run.history
        origin = float(history.displacement_at(run.time[0]))
        edges = np.concatenate([[-np.inf], history.starts[1:], [np.inf]])
        for k, start in enumerate(history.starts[1:]):
            steps += 1
            at = float(history.displacement_at(start)) - origin
            travel = run.load_point_displacement
            keep = (run.time > edges[k]) & (run.time < edges[k + 2])
            keep &= (travel >= at - before) & (travel <= at + after)
            if keep.sum() < 2 or not np.any(run.time[keep] >= start):
                continue
            piece = part.isel(sample=keep)
            pieces.append(piece.assign(run=("sample", np.full(int(keep.sum()), len(labels)))))
            labels.append(f"run {index} step {k + 1} at t = {start:.6g} s")
    source = data.attrs.get("source_file", "the data")
    if not steps:
        raise DataError(f"{source}: no change of load-point velocity to put a window around")
    if not pieces:
        raise DataError(
            f"{source}: --window {before:g},{after:g} m holds fewer than two samples, or none "
            f"after the step, around each of its {steps} velocity changes: widen the window"
        )
    out = xr.concat(pieces, dim="sample")
    out["run"].attrs = {"units": "1", "long_name": "fit window (one per step)"}
    out.attrs = {**data.attrs, "windows": "; ".join(labels), "window": f"{before:g},{after:g} m"}
    return out
