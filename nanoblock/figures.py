"""Standard figures of a run (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from nanoblock.engine import mean_field_joint
from nanoblock.params import Scenario
from nanoblock.snapshots import open_snapshots, steady_window
from nanoblock.store import RunStore
from nanoblock.theory.meanfield import q_stationary

if TYPE_CHECKING:
    import dask.array as da

HISTOGRAM_BINS = 60
"""Bins of the block-stress and contact-age histograms."""


def _save(fig: Figure, path: Path) -> Path:
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _style(run: xr.Dataset) -> dict[str, object]:
    """Line style of a run's curves: with markers when a single sample makes no line."""
    return {"lw": 1.0, "marker": "o" if run.sizes["time"] < 2 else None}


def _friction_vs_slip(ax: Axes, run: xr.Dataset, title: str) -> None:
    slip_um = (run.slider_displacement - run.slider_displacement[0]) * 1e6
    ax.plot(slip_um, run.friction_coefficient, **_style(run))
    ax.set_xlabel("slider slip X - X(0) [um]")
    ax.set_ylabel("friction coefficient mu = F / W")
    ax.set_title(title or "nanoblock run")


def _velocities(ax: Axes, run: xr.Dataset) -> None:
    ax.plot(run.time, run.slider_velocity, label="slider", **_style(run))
    if run.sizes["time"] >= 2:  # in numpy: dask's gradient refuses a last chunk of 1 sample
        time = np.asarray(run.time.values)
        load_velocity = np.gradient(np.asarray(run.load_point_displacement.values), time)
        ax.plot(time, load_velocity, lw=1.0, ls="--", label="load point")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("velocity [m/s]")
    ax.legend(loc="best")


def plot_friction(run: xr.Dataset, path: str | Path, title: str = "") -> Path:
    """Friction coefficient vs slider slip, and slider velocity vs time, to a PNG."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), constrained_layout=True)
    _friction_vs_slip(top, run, title)
    _velocities(bottom, run)
    return _save(fig, Path(path))


def _friction_figure(run: xr.Dataset, path: Path, title: str) -> Path:
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), constrained_layout=True)
    _friction_vs_slip(top, run, title)
    bottom.plot(run.time, run.friction_coefficient, **_style(run))
    bottom.set_xlabel("time [s]")
    bottom.set_ylabel("friction coefficient mu = F / W")
    return _save(fig, path)


def _velocity_figure(run: xr.Dataset, path: Path, title: str) -> Path:
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    _velocities(ax, run)
    ax.set_title(title)
    return _save(fig, path)


def _density(values: da.Array, edges: np.ndarray) -> np.ndarray:
    """Normalised histogram of a dask array, computed chunk by chunk."""
    import dask.array as da  # here only: ``nanoblock run`` draws its figure without dask

    counts = da.histogram(values, bins=edges)[0].compute()
    return counts / max(counts.sum(), 1) / np.diff(edges)


def q_st_window(scenario: Scenario, times: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Where the mean-field Q_st (001/Eq. 27) describes the block stresses: for a
    mean-field reset joint (slip = "reset", k2 = 0), the snapshots at ``times`` [s] in
    steady sliding (:func:`~nanoblock.snapshots.steady_window`) and their velocity [m/s];
    None otherwise."""
    if scenario.joint.slip != "reset" or scenario.joint.k2 != 0.0:
        return None
    return steady_window(scenario, times)


def plot_stress_histogram(snaps: xr.Dataset, scenario: Scenario, path: str | Path) -> Path:
    """Histogram of reduced block stresses x = sigma / sigma_a: pooled over the snapshots
    of :func:`q_st_window` against Q_st where it applies, else at the last snapshot."""
    x = snaps.block_stress / scenario.joint.threshold_stress
    window = q_st_window(scenario, snaps.time.values)
    if window is None:
        chosen = x.isel(time=-1)
        label = f"blocks at t = {float(snaps.time[-1]):.4g} s"
    else:
        mask, velocity = window
        chosen = x.isel(time=np.flatnonzero(mask))
        label = f"blocks, {int(mask.sum())} snapshots in steady sliding at V = {velocity:.3g} m/s"
    low = min(0.0, float(chosen.min()))
    edges = np.linspace(low, 1.0, HISTOGRAM_BINS + 1)
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    ax.stairs(_density(chosen.data, edges), edges, label=label)
    if window is not None:
        grid = np.linspace(0.0, 1.0, 801)
        theory = mean_field_joint(scenario)
        q = q_stationary(grid * theory.rho_max, window[1], theory) * theory.rho_max
        ax.plot(grid, q, lw=1.2, label="mean-field Q_st (001/Eq. 27)")
    ax.set_xlabel("reduced block stress x = sigma / sigma_a")
    ax.set_ylabel("probability density")
    ax.legend(loc="upper left")
    return _save(fig, Path(path))


def plot_contact_ages(snaps: xr.Dataset, run: xr.Dataset, path: str | Path) -> Path:
    """Distribution of contact ages at the last snapshot, and the mean age vs time."""
    ages = snaps.contact_age.isel(time=-1)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), constrained_layout=True)
    edges = np.linspace(0.0, max(float(ages.max()), 1e-300), HISTOGRAM_BINS + 1)
    top.stairs(_density(ages.data, edges), edges)
    top.set_xlabel(f"contact age [s] at t = {float(snaps.time[-1]):.4g} s")
    top.set_ylabel("probability density [1/s]")
    bottom.plot(run.time, run.mean_contact_age, lw=1.0)
    bottom.set_xlabel("time [s]")
    bottom.set_ylabel("mean contact age [s]")
    return _save(fig, Path(path))


def standard_figures(store: str | Path, out_dir: str | Path | None = None) -> list[Path]:
    """Write the standard PNGs of a run store as ``<store stem>_<figure>.png`` in
    ``out_dir`` (default: next to the store): friction (vs slip and time), velocity,
    and with block snapshots, stress (histogram) and contact_age."""
    store = Path(store)
    run = RunStore(store).open()
    scenario = Scenario.from_json(run.attrs["scenario"])
    out = Path(out_dir) if out_dir is not None else store.parent
    out.mkdir(parents=True, exist_ok=True)
    title = f"{store.stem} (seed {run.attrs['seed']})"

    def target(name: str) -> Path:
        return out / f"{store.stem}_{name}.png"

    paths = [
        _friction_figure(run, target("friction"), title),
        _velocity_figure(run, target("velocity"), title),
    ]
    if "snapshot_time" in run.dims:
        snaps = open_snapshots(store)
        paths.append(plot_stress_histogram(snaps, scenario, target("stress")))
        paths.append(plot_contact_ages(snaps, run, target("contact_age")))
    return paths
