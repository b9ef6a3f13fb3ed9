"""Recognising stick-slip in a friction record: regular stress drops (``unstable_sliding``).

A spring-slider below its critical stiffness K_c / W = (b - a) / D_c (001/Eqs. 9-11) does
not slide steadily: friction rises elastically, then drops in a fast slip event, again and
again, with a period in load-point travel set by K and the drop size. No smooth
rate-and-state solution follows a sawtooth, so the diagnosis looks for the drops
themselves before it fits anything. In each constant-velocity segment friction is
interpolated onto a uniform grid of load-point travel (the sampling of lab records is
irregular and densest during slip events), detrended by a running mean over a tenth of
the segment, and its autocorrelation searched for a secondary peak after the first zero
crossing: a repeating cycle keeps at least ``MIN_PERIODICITY`` both at that lag and at
twice it, while a random bump of coloured noise does not repeat (AR(1) noise with
phi = 0.95: at most 0.04 over 20 seeds). A segment holds stick-slip when it is periodic and has at
least ``MIN_DROPS`` *drops*, maximal runs of falling samples whose total fall exceeds
``DROP_NOISE`` times the white noise of the record.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from nanoblock.diagnosis.statistics import noise_level
from nanoblock.rsf.fit import RunData

DROP_NOISE = 5.0
"""Smallest drop, in white-noise standard deviations."""
MIN_DROPS = 8
"""Drops a segment needs to count as a stick-slip cycle."""
MIN_PERIODICITY = 0.3
"""Smallest autocorrelation of a cycle at its period and at twice it."""


@dataclass(frozen=True)
class StickSlip:
    """Stick-slip found in one constant-velocity segment of one run."""

    run: int
    load_point_velocity: float
    """[m/s]"""
    start_time: float
    """First drop [s]."""
    drops: int
    median_drop: float
    """Median fall of friction per drop."""
    period: float
    """Median load-point travel between drops [m]."""
    periodicity: float
    """Secondary autocorrelation peak of the detrended friction."""

    def to_json(self) -> dict[str, float | int]:
        return asdict(self)


def falling_runs(mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end indices of the maximal runs of strictly falling samples."""
    falling = np.diff(mu) < 0.0
    edges = np.diff(np.concatenate([[0], falling.astype(np.int8), [0]]))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def periodicity(travel: np.ndarray, mu: np.ndarray) -> float:
    """Autocorrelation of detrended friction on a uniform travel grid at its highest peak
    between the first zero crossing and a sixteenth of the segment, or at twice that lag
    if lower (0 when there is no such peak)."""
    order = np.argsort(travel, kind="stable")
    x, y = travel[order], mu[order]
    keep = np.concatenate([[True], np.diff(x) > 0.0])
    x, y = x[keep], y[keep]
    if x.size < 4 * MIN_DROPS:
        return 0.0
    grid = np.arange(x[0], x[-1], float(np.median(np.diff(x))))
    values = np.interp(grid, x, y)
    width = max(5, grid.size // 10)
    values = (values - np.convolve(values, np.full(width, 1.0 / width), mode="same"))[width:-width]
    values -= values.mean()
    n = values.size
    if n < 4 * MIN_DROPS or not np.any(values):
        return 0.0
    spectrum = np.fft.rfft(values, 2 * n)
    correlation = np.fft.irfft(spectrum * np.conj(spectrum))[:n]
    correlation /= correlation[0]
    negative = np.flatnonzero(correlation < 0.0)
    if negative.size == 0 or negative[0] >= n // 16:
        return 0.0
    lag = negative[0] + int(np.argmax(correlation[negative[0] : n // 16]))
    return float(min(correlation[lag], correlation[2 * lag]))


def find_stick_slip(prepared: list[RunData]) -> list[StickSlip]:
    """Every segment of every run that holds a regular stick-slip cycle."""
    noise = noise_level([run.mu for run in prepared])
    found = []
    for index, run in enumerate(prepared):
        history = run.history
        segment = history.segment_at(run.time)
        for k, velocity in enumerate(history.velocities):
            inside = np.flatnonzero(segment == k)
            if velocity <= 0.0 or inside.size < 2 * MIN_DROPS:
                continue
            mu = run.mu[inside]
            starts, ends = falling_runs(mu)
            fall = mu[starts] - mu[ends]
            big = fall > DROP_NOISE * noise
            if big.sum() < MIN_DROPS:
                continue
            travel = run.load_point_displacement[inside]
            peak = periodicity(travel, mu)
            if peak >= MIN_PERIODICITY:
                first = float(run.time[inside][starts[big][0]])
                period = float(np.median(np.diff(travel[ends[big]])))
                drop = float(np.median(fall[big]))
                found.append(
                    StickSlip(index, float(velocity), first, int(big.sum()), drop, period, peak)
                )
    return found
