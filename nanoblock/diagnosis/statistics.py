"""Statistics of a misfit: the noise of the data, structure in residuals, model comparison.

Everything here works on plain arrays, one per run (or per group of a table), so that the
same tests serve time series, clamped-sample curves and steady-state tables.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

MAD_TO_SIGMA = 1.4826
"""Standard deviation of a Gaussian per unit median absolute deviation."""
RESOLUTION_SAMPLES = 50
"""Width of the running mean that defines the noise at the model's resolution [samples of
a record resampled to uniform slip: 5 % of a run's travel]."""
COLOURED = 1.5
"""Floor over white noise above which the noise counts as coloured (whatever its lag-1)."""
COLOURED_Z = 3.09
"""z of :func:`noise_lag1_z` above which the noise counts as coloured: a one-sided level of
1e-3 on white noise."""
MAX_LAG1 = 0.99
"""Largest residual autocorrelation used for the effective sample size."""


def noise_level(signals: Sequence[FloatArray]) -> float:
    """White-noise standard deviation of the data, from the data alone.

    Second differences y[i+1] - 2 y[i] + y[i-1] cancel any signal that is smooth on the
    sampling scale and leave 6 sigma^2 of white noise; their median absolute deviation
    (pooled over runs) is robust to the few samples where the signal itself bends
    sharply (a velocity step, a reload). Units of the signal.
    """
    curvature = np.concatenate([np.diff(np.asarray(y, dtype=float), 2) for y in signals])
    if curvature.size < 3:
        raise ValueError("the noise estimate needs at least 3 samples in a run")
    centred = curvature - np.median(curvature)
    return float(MAD_TO_SIGMA * np.median(np.abs(centred)) / math.sqrt(6.0))


def _high_passed(residuals: Sequence[FloatArray], width: int) -> list[tuple[FloatArray, float]]:
    """Each stretch's deviations from its centred running mean over ``width`` samples, scaled
    to the white noise's standard deviation (divided by sqrt(1 - 1/w)), with the correlation
    of neighbouring deviations on white noise, -(w + 1) / (w (w - 1)) (their running means
    share w - 1 samples); a stretch no longer than the window (but at least ``width`` / 5)
    is taken about its own mean (correlation -1 / (w - 1) for its w samples), a shorter
    one is dropped."""
    deviations = []
    for r in residuals:
        r = np.asarray(r, dtype=float)
        if r.size <= width:
            if r.size >= max(width // 5, 2):
                w = r.size
                deviations.append(((r - r.mean()) / math.sqrt(1.0 - 1.0 / w), -1.0 / (w - 1)))
            continue
        mean = np.convolve(r, np.full(width, 1.0 / width), mode="valid")
        centre = r[width // 2 : width // 2 + mean.size]
        white_lag1 = -(width + 1.0) / (width * (width - 1.0))
        deviations.append(((centre - mean) / math.sqrt(1.0 - 1.0 / width), white_lag1))
    return deviations


def resolution_noise(residuals: Sequence[FloatArray], width: int = RESOLUTION_SAMPLES) -> float:
    """Noise at the model's resolution: the scatter of residuals about their own centred
    running mean over ``width`` samples, which keeps every fluctuation shorter than the
    window (coloured noise, sensor and servo wobble) and drops a misfit smooth on that
    scale; a stretch no longer than the window (but at least ``width`` / 5) is taken
    about its own mean. Each deviation is divided by sqrt(1 - 1/w), its standard
    deviation for white noise about a mean of w samples, and the spread is the MAD (robust
    to the few windows holding a step), so the floor equals :func:`noise_level` on white
    noise. On AR(1) noise of lag-1 autocorrelation phi a window of w samples keeps about
    1 - (1 + phi) / ((1 - phi) w) of its variance. Units of the signal; the sample-scale
    :func:`noise_level` when every stretch is shorter than ``width`` / 5."""
    deviations = _high_passed(residuals, width)
    if not deviations:
        return noise_level(residuals)
    pooled = np.concatenate([d for d, _ in deviations])
    return float(MAD_TO_SIGMA * np.median(np.abs(pooled - np.median(pooled))))


def noise_lag1_z(residuals: Sequence[FloatArray], width: int = RESOLUTION_SAMPLES) -> float:
    """Whiteness test of the noise at the model's resolution: the lag-1 autocorrelation of
    the residuals' deviations from their running mean (as in :func:`resolution_noise`, so
    a misfit smooth over ``width`` samples does not count), pooled over stretches, minus its
    white-noise expectation, times sqrt(n). About N(0, 1) on white noise; on AR(1) noise of
    lag-1 autocorrelation phi about phi sqrt(n), so it sees colour far below the variance
    ratio of floor over white noise (phi = 0.3 at 600 samples: z ~ 7, the ratio ~1.2).
    0 when no stretch is long enough."""
    deviations = _high_passed(residuals, width)
    n = sum(d.size for d, _ in deviations)
    if n < 3:
        return 0.0
    lag1 = lag1_autocorrelation([d for d, _ in deviations])
    expected = sum((d.size - 1) * white for d, white in deviations) / n
    return float((lag1 - expected) * math.sqrt(n))


def effective_size(n: int, lag1: float) -> float:
    """Effective number of independent samples of n residuals with lag-1 autocorrelation
    ``lag1`` (AR(1): n (1 - phi) / (1 + phi), phi clipped to [0, MAX_LAG1])."""
    phi = min(max(lag1, 0.0), MAX_LAG1)
    return n * (1.0 - phi) / (1.0 + phi)


@dataclass(frozen=True)
class Structure:
    """Tests of residuals for systematic structure (each run tested in sample order)."""

    chi2_ratio: float
    """Mean squared residual over the noise variance (1 for a model within noise)."""
    runs_z: float
    """Wald-Wolfowitz z of the number of sign runs (strongly negative: long runs)."""
    lag1: float
    """Lag-1 autocorrelation of the residuals (pooled over runs)."""
    lag1_z: float
    """lag1 sqrt(n): about N(0, 1) for white residuals."""
    n: int
    coloured: bool = False
    """Whether the noise itself is coloured (its floor at the model's resolution exceeds
    the sample-scale white noise by ``COLOURED``, or its lag-1 test :func:`noise_lag1_z`
    exceeds ``COLOURED_Z``): then only the variance test applies."""
    n_effective: float | None = None
    """Independent samples behind chi^2 (n for white noise)."""

    @property
    def failed(self) -> list[str]:
        """The structure tests the residuals fail, in words (empty: within the noise):
        chi^2 above 1 by more than 5 of its standard errors sqrt(2/n_eff) plus a 10 %
        allowance for the noise estimate, or (white noise only) sign runs / lag-1
        autocorrelation beyond 5 standard errors."""
        n = self.n_effective or self.n
        chi2_limit = 1.1 + 5.0 * math.sqrt(2.0 / max(n, 1.0))
        failed = []
        if self.chi2_ratio > chi2_limit:
            failed.append(f"chi^2 ratio {self.chi2_ratio:.3g} above {chi2_limit:.3g}")
        if not self.coloured and self.runs_z < -5.0:
            failed.append(f"sign runs too long (z {self.runs_z:.1f} below -5)")
        if not self.coloured and self.lag1_z > 5.0:
            failed.append(f"lag-1 autocorrelation {self.lag1:.2f} (z {self.lag1_z:.1f} above 5)")
        return failed

    @property
    def systematic(self) -> bool:
        """Whether the residuals show structure beyond the noise (:attr:`failed`)."""
        return bool(self.failed)

    def to_json(self) -> dict[str, float | bool | int]:
        return {
            "chi2_ratio": self.chi2_ratio,
            "runs_z": self.runs_z,
            "lag1_autocorrelation": self.lag1,
            "lag1_z": self.lag1_z,
            "n": self.n,
            "n_effective": self.n_effective or self.n,
            "coloured_noise": self.coloured,
            "systematic": self.systematic,
        }


def runs_test(residuals: Sequence[FloatArray]) -> float:
    """Wald-Wolfowitz z statistic of sign runs, pooled over runs (zeros dropped)."""
    n_runs = n_pos = n_neg = 0
    for r in residuals:
        signs = np.sign(np.asarray(r, dtype=float))
        signs = signs[signs != 0]
        if signs.size == 0:
            continue
        n_runs += 1 + int(np.count_nonzero(np.diff(signs)))
        n_pos += int(np.count_nonzero(signs > 0))
        n_neg += int(np.count_nonzero(signs < 0))
    n = n_pos + n_neg
    if n_pos == 0 or n_neg == 0:
        return -math.inf
    mean = 2.0 * n_pos * n_neg / n + len(residuals)
    variance = 2.0 * n_pos * n_neg * (2.0 * n_pos * n_neg - n) / (n * n * (n - 1))
    return float((n_runs - mean) / math.sqrt(max(variance, 1e-300)))


def lag1_autocorrelation(residuals: Sequence[FloatArray]) -> float:
    """Lag-1 autocorrelation of residuals about zero, pooled over runs."""
    products = sum(float(np.dot(r[1:], r[:-1])) for r in residuals)
    squares = sum(float(np.dot(r, r)) for r in residuals)
    return products / squares if squares > 0.0 else 0.0


def structure(
    residuals: Sequence[FloatArray],
    noise: float,
    *,
    coloured: bool = False,
    n_effective: float | None = None,
) -> Structure:
    """Residual structure of a fit against the noise level of the data (the floor at the
    model's resolution when ``coloured``)."""
    pooled = np.concatenate([np.asarray(r, dtype=float) for r in residuals])
    n = pooled.size
    lag1 = lag1_autocorrelation(residuals)
    return Structure(
        chi2_ratio=float(np.mean(pooled**2)) / noise**2 if noise > 0 else math.inf,
        runs_z=runs_test(residuals),
        lag1=lag1,
        lag1_z=lag1 * math.sqrt(n),
        n=n,
        coloured=coloured,
        n_effective=n_effective,
    )


def information_criterion(
    residuals: Sequence[FloatArray], n_free: int, n_effective: float | None = None
) -> float:
    """Bayesian information criterion n_eff ln(RSS / n) + k ln n_eff of a Gaussian fit whose
    variance is also estimated (so a wrong noise estimate does not bias the ranking);
    ``n_effective`` counts independent samples of autocorrelated residuals (default n)."""
    pooled = np.concatenate([np.asarray(r, dtype=float) for r in residuals])
    n = pooled.size
    rss = float(pooled @ pooled)
    m = float(n if n_effective is None else n_effective)
    return m * math.log(max(rss, 1e-300) / n) + n_free * math.log(max(m, 2.0))


def blocked_folds(
    sizes: Sequence[int], n_folds: int, block_length: int
) -> list[list[NDArray[np.bool_]]]:
    """Blocked cross-validation masks: each run is cut into contiguous blocks of
    ``block_length`` samples and fold j holds out blocks j, j + n_folds, ... of every run.
    Every sample is held out exactly once, each held-out block is a gap the model must
    bridge (longer than the noise correlation of a fit's residuals), and every fold still
    sees every part of the protocol (each step, hold and velocity range)."""
    folds = []
    for j in range(n_folds):
        masks = []
        for size in sizes:
            block = np.arange(size) // block_length
            masks.append(block % n_folds == j)
        folds.append(masks)
    return folds


def leave_one_run_out(sizes: Sequence[int]) -> list[list[NDArray[np.bool_]]]:
    """Held-out masks holding out one whole run at a time."""
    return [
        [np.full(size, i == j, dtype=bool) for i, size in enumerate(sizes)]
        for j in range(len(sizes))
    ]
