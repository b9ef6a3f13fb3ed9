"""Resampling a friction time series to uniform load-point travel before a diagnosis.

Laboratory records mix sampling rates (10, 100 and 1000 Hz in one file, denser during
fast slip): fitted sample by sample, the densely sampled seconds outweigh the rest, and
both the noise estimate and the verdict change when the record is decimated. Each run is
therefore averaged over bins of equal progress of the drive, ``BINS_PER_RUN`` per run,
never across a change of load-point velocity: progress is the load-point travel, and
during a hold the time multiplied by the velocity before it. A bin holding several
samples becomes their mean (time, friction and every other column); a sparsely sampled
stretch keeps its samples as they are. Records sampled more coarsely than the bins pass
through unchanged. A record without a ``load_point_velocity`` column gets one from the
history its displacement gives: the bin means on either side of a change of velocity
would otherwise read as a spurious segment at the secant velocity between them (a slow
reload lasting half a bin of the hold before the real one).

A model compared with a bin mean must be averaged over the same samples: evaluated at the
bin's mean time instead, it misses the curvature inside the bin, and across a fast
transient (the friction drop after a reslide's peak) that bias reaches a hundred times the
noise. A bin of several samples therefore also keeps ``model_time`` (its samples' times
when it has at most ``NODES_PER_BIN``, else that many nodes evenly spread in rank:
:func:`_nodes`) and ``model_weight`` (the weight of each, summing to 1); the fits of
:mod:`nanoblock.rsf.fit` and the simulation check average the model over them.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from nanoblock.measured import runs
from nanoblock.rsf.fit import AVERAGING_COLUMNS, prepare_runs
from nanoblock.rsf.slider import LoadPointHistory

BINS_PER_RUN = 1000
"""Bins of equal load-point progress per run (the noise floor's running mean spans 5 % of a
run's travel: :data:`~nanoblock.diagnosis.statistics.RESOLUTION_SAMPLES` bins)."""


NODES_PER_BIN = 16
"""Sample times per bin a model is averaged over (all of a bin's samples up to this many)."""

_AVERAGING_ATTRS = (
    {"units": "s", "long_name": "sample times a model is averaged over"},
    {"units": "1", "long_name": "weight of each model time in the bin mean"},
)
"""Attributes of :data:`~nanoblock.rsf.fit.AVERAGING_COLUMNS`, in its order."""

_PIECEWISE = ("run", "load_point_velocity")
"""Columns constant within a bin, kept exactly (a mean would round them)."""


def _bin_index(time: np.ndarray, history: LoadPointHistory) -> np.ndarray:
    """Bin of every sample: (segment, floor(progress / width)) flattened to one integer."""
    segment = history.segment_at(time)
    velocities = history.velocities
    moving = np.where(velocities > 0.0, velocities, 0.0)
    carried = np.maximum.accumulate(np.where(moving > 0.0, np.arange(moving.size), 0))
    pace = np.where(moving > 0.0, moving, moving[carried])  # holds: the previous velocity
    if not np.any(pace > 0.0):
        return np.arange(time.size)
    pace = np.where(pace > 0.0, pace, pace[pace > 0.0][0])
    progress = np.concatenate([[0.0], np.cumsum(np.diff(time) * pace[segment[1:]])])
    width = progress[-1] / BINS_PER_RUN if progress[-1] > 0.0 else 1.0
    within = np.floor(progress / width).astype(np.int64)
    return segment.astype(np.int64) * (BINS_PER_RUN + 1) + within


def _nodes(time: np.ndarray, inverse: np.ndarray, counts: np.ndarray, width: int) -> tuple:
    """(times, weights), each (bins, ``width``): a bin of c samples gets m = min(c,
    ``width``) nodes, weighted 1/m, at fractional ranks (j + 1/2) c/m - 1/2, j < m (the
    centres of m equal groups of its samples; interpolated in time between samples, so the
    node average misses a group's mean only by its curvature); padded with its last
    sample, at weight 0. With c <= ``width`` the nodes are the samples."""
    grouped = time[np.argsort(inverse, kind="stable")]  # sample times, bin after bin
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])[:, None]
    used = np.minimum(counts, width)[:, None]
    slot = np.arange(width)[None, :]
    rank = np.minimum((slot + 0.5) * counts[:, None] / used - 0.5, counts[:, None] - 1)
    times = np.interp(starts + rank, np.arange(grouped.size), grouped)
    return times, np.where(slot < used, 1.0 / used, 0.0)


def resample_by_travel(data: xr.Dataset) -> xr.Dataset:
    """A ``time_series`` record averaged over bins of equal drive progress, run by run,
    with the sample times a model is averaged over in each bin (see the module
    docstring); other kinds of data, and a record already resampled, are returned
    unchanged. The result keeps the variables, their attributes and the record's
    attributes; ``resampled_from`` records the original number of samples."""
    if data.attrs.get("kind") != "time_series" or AVERAGING_COLUMNS[0] in data:
        return data
    binned = []
    for part, prepared in zip(runs(data), prepare_runs(data), strict=True):
        index = _bin_index(prepared.time, prepared.history)
        if "load_point_velocity" not in part:  # keep the history the bins were cut by
            velocity = prepared.history.velocity_at(prepared.time)
            part = part.assign(load_point_velocity=("sample", velocity, {"units": "m/s"}))
        _, first, inverse, counts = np.unique(
            index, return_index=True, return_inverse=True, return_counts=True
        )
        binned.append((part, first, inverse, counts))
    width = min(max(int(counts.max()) for *_, counts in binned), NODES_PER_BIN)
    pieces = []
    for part, first, inverse, counts in binned:
        order = np.argsort(first)
        columns = {}
        for name, variable in part.data_vars.items():
            values = variable.values
            if values.dtype.kind in "fiu" and name not in _PIECEWISE:
                sums = np.bincount(inverse, weights=values.astype(float), minlength=counts.size)
                columns[name] = ("sample", (sums / counts)[order], variable.attrs)
            else:
                columns[name] = ("sample", values[first[order]], variable.attrs)
        if width > 1:
            times, weights = _nodes(part["time"].values, inverse, counts, width)
            for name, values, attrs in zip(
                AVERAGING_COLUMNS, (times, weights), _AVERAGING_ATTRS, strict=True
            ):
                columns[name] = (("sample", "node"), values[order], attrs)
        pieces.append(xr.Dataset(columns))
    out = xr.concat(pieces, dim="sample") if len(pieces) > 1 else pieces[0]
    out.attrs = {**data.attrs, "resampled_from": int(data.sizes["sample"])}
    return out
