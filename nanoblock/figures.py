"""Standard figures of a run (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import xarray as xr


def plot_friction(run: xr.Dataset, path: str | Path, title: str = "") -> Path:
    """Friction coefficient vs slider slip, and slider velocity vs time, to a PNG."""
    path = Path(path)
    slip_um = (run.slider_displacement - run.slider_displacement[0]) * 1e6
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), constrained_layout=True)
    top.plot(slip_um, run.friction_coefficient, lw=1.0)
    top.set_xlabel("slider slip X - X(0) [um]")
    top.set_ylabel("friction coefficient mu = F / W")
    top.set_title(title or "nanoblock run")
    bottom.plot(run.time, run.slider_velocity, lw=1.0, label="slider")
    load_velocity = run.load_point_displacement.differentiate("time")
    bottom.plot(run.time, load_velocity, lw=1.0, ls="--", label="load point")
    bottom.set_xlabel("time [s]")
    bottom.set_ylabel("velocity [m/s]")
    bottom.legend(loc="best")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
