"""Recognising stick-slip in a friction record: regular stress drops (``unstable_sliding``).

A spring-slider below its critical stiffness K_c / W = (b - a) / D_c (001/Eqs. 9-11) does
not slide steadily: friction rises elastically, then drops in a fast slip event, again and
again, with a period in load-point travel set by K and the drop size. No smooth
rate-and-state solution follows a sawtooth, so the diagnosis looks for the drops
themselves before it fits anything. A *drop* is a maximal run of falling samples whose
total fall exceeds ``DROP_NOISE`` times the white noise of the record. A
constant-velocity segment holds stick-slip when either

- it is long and periodic: at least ``MIN_DROPS`` drops, and friction, interpolated onto a
  uniform grid of load-point travel (lab sampling is irregular and densest during slip
  events) and detrended by a running mean over a tenth of the segment, keeps an
  autocorrelation of at least ``MIN_PERIODICITY`` at its first secondary peak and at
  twice that lag (a random bump of coloured noise does not repeat: AR(1) noise with
  phi = 0.95 reached at most 0.04 over 20 seeds), and the cycle is stick-slip, not any
  periodic signal: the drops are abrupt (median :func:`fall_travel` within
  ``ABRUPTNESS`` of their spacing: an apparatus oscillation falls over half its
  cycle), friction reloads gradually between them (:func:`reload_spread` at least
  ``RELOAD_SPREAD``: a train of spikes or dips rises as fast as it falls) and the cycle
  lasts (each half of the segment keeps half of ``MIN_PERIODICITY``: the ringing after a
  step dies out). Without these three, 193 of 200 noisy sinusoids, 192 of 200 spike
  trains and 46 of 200 damped ringings were called stick-slip (measured 2026-11-29); or
- it is short but a sawtooth: at least ``MIN_SAWTOOTH_DROPS`` drops. After the first
  (which may be a step's transient) each exceeds ``SAWTOOTH_NOISE`` white-noise
  deviations (drops just above the threshold would look regular by truncation alone),
  their sizes and spacings in travel stay within ``REGULARITY`` of their medians, and
  they carry at least ``FALL_SHARE`` of every fall up to the last (noise falls as often
  as it rises), while rises as fast as a drop carry at most the rest of every rise
  (friction reloads elastically; a spike rises as fast as it falls); each drop falls
  within ``ABRUPTNESS`` of the spacing (a fast slip, not the half-cycle of an
  oscillation). Coloured noise, oscillations and smooth transients do not pass it
  (``tests/test_real_records.py`` states the rate).
"""

from __future__ import annotations

import math
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
MIN_SAWTOOTH_DROPS = 4
"""Drops a short segment needs: three cycles after the first, two spacings to compare."""
SAWTOOTH_NOISE = 4 * DROP_NOISE
"""Smallest drop of a short sawtooth, in white-noise standard deviations."""
REGULARITY = 0.25
"""Largest relative deviation of a drop's size or spacing from their medians."""
ABRUPTNESS = 0.25
"""Largest travel of a drop, in units of the median spacing between drops."""
RELOAD_SPREAD = 0.25
"""Smallest :func:`reload_spread` of a periodic cycle (a linear reload: 0.5)."""
FALL_SHARE = 0.8
"""Smallest share of all falls (second drop to last) the drops carry."""


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
    """Secondary autocorrelation peak of the detrended friction (0 when too short)."""
    regularity: float
    """Largest relative deviation of drop sizes and spacings from their medians, after
    the first cycle."""

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


def regularity(travel: np.ndarray, fall: np.ndarray, ends: np.ndarray) -> float:
    """Largest |x / median(x) - 1| over the sizes of the drops after the first and the
    travel spacings after the first (inf below ``MIN_SAWTOOTH_DROPS`` drops)."""
    if fall.size < MIN_SAWTOOTH_DROPS:
        return math.inf
    sizes, spacings = fall[1:], np.diff(travel[ends])[1:]
    if np.median(spacings) <= 0.0:
        return math.inf
    return float(max(np.max(np.abs(x / np.median(x) - 1.0)) for x in (sizes, spacings)))


def fall_travel(travel: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Load-point travel of each drop from the midpoint of its first sampling interval to
    the midpoint of its last. The samples bound a drop's travel between that from its
    second sample to its second-to-last and that from its first to its last; a drop
    within one interval counts 0, a sinusoid's fall resolved by n samples a cycle about
    half a cycle less 1 / n."""
    return 0.5 * (travel[ends - 1] + travel[ends] - travel[starts] - travel[starts + 1])


def reload_spread(
    travel: np.ndarray, mu: np.ndarray, starts: np.ndarray, ends: np.ndarray
) -> float:
    """Median over the intervals between drops of the smaller of the rises in the
    interval's two halves of travel, in units of its whole rise (0 where friction does not
    rise): a linear elastic reload gives 1/2, a spike 0 (flat, then a rise as fast as the
    fall), a dip 0 (an immediate recovery)."""
    begin, finish = travel[ends[:-1]], travel[starts[1:]]
    rise = mu[starts[1:]] - mu[ends[:-1]]
    first = np.interp(0.5 * (begin + finish), travel, mu) - mu[ends[:-1]]
    rising = rise > 0.0
    share = np.zeros(rise.size)
    share[rising] = np.minimum(first, rise - first)[rising] / rise[rising]
    return float(np.median(share))


def sustained(travel: np.ndarray, mu: np.ndarray) -> float:
    """The smaller :func:`periodicity` of the segment's two halves: a stick-slip cycle
    repeats through the segment, a transient's ringing dies out."""
    half = travel.size // 2
    return min(periodicity(travel[:half], mu[:half]), periodicity(travel[half:], mu[half:]))


def is_sawtooth(
    travel: np.ndarray, mu: np.ndarray, starts: np.ndarray, ends: np.ndarray, period: float
) -> bool:
    """Whether the drops ``starts``/``ends`` (indices into a segment's ``travel`` and
    ``mu``; ``period`` their median spacing in travel) are abrupt and, after the first
    cycle, carry ``FALL_SHARE`` of all falls up to the last while rises as fast as a drop
    carry at most 1 - ``FALL_SHARE`` of all rises (the regularity of sizes and spacings is
    checked by :func:`regularity`)."""
    if np.max(travel[ends] - travel[starts]) > ABRUPTNESS * period:
        return False
    steps = np.diff(mu[starts[1] : ends[-1] + 1])
    carried = mu[starts[1:]] - mu[ends[1:]]
    if float(np.sum(carried)) < FALL_SHARE * float(-np.sum(steps[steps < 0])):
        return False
    rate = steps / np.maximum(np.diff(travel[starts[1] : ends[-1] + 1]), 1e-300)
    fast = rate > float(np.median(carried)) / (ABRUPTNESS * period)
    return float(np.sum(steps[fast])) <= (1.0 - FALL_SHARE) * float(np.sum(steps[steps > 0]))


def find_stick_slip(prepared: list[RunData]) -> list[StickSlip]:
    """Every segment of every run that holds a regular stick-slip cycle."""
    noise = noise_level([run.mu for run in prepared])
    found = []
    for index, run in enumerate(prepared):
        history = run.history
        segment = history.segment_at(run.time)
        for k, velocity in enumerate(history.velocities):
            inside = np.flatnonzero(segment == k)
            if velocity <= 0.0 or inside.size < 2 * MIN_SAWTOOTH_DROPS:
                continue
            mu = run.mu[inside]
            starts, ends = falling_runs(mu)
            fall = mu[starts] - mu[ends]
            big = fall > DROP_NOISE * noise
            starts, ends, fall = starts[big], ends[big], fall[big]
            if starts.size < MIN_SAWTOOTH_DROPS:
                continue
            travel = run.load_point_displacement[inside]
            period = float(np.median(np.diff(travel[ends])))
            peak = periodicity(travel, mu) if starts.size >= MIN_DROPS else 0.0
            periodic = (
                peak >= MIN_PERIODICITY
                and np.median(fall_travel(travel, starts, ends)) <= ABRUPTNESS * period
                and reload_spread(travel, mu, starts, ends) >= RELOAD_SPREAD
                and sustained(travel, mu) >= MIN_PERIODICITY / 2
            )
            regular = regularity(travel, fall, ends)
            sawtooth = (
                regular <= REGULARITY
                and np.min(fall[1:]) > SAWTOOTH_NOISE * noise
                and is_sawtooth(travel, mu, starts, ends, period)
            )
            if periodic or sawtooth:
                found.append(
                    StickSlip(
                        index, float(velocity), float(run.time[inside][starts[0]]),
                        int(starts.size), float(np.median(fall)), period, peak, regular,
                    )
                )  # fmt: skip
    return found
