"""Block-level snapshots of a run (the agents) as a lazy Dataset, and the steady window."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from nanoblock.params import Scenario
from nanoblock.store import SNAPSHOTS, RunStore

STEADY_TRAVEL = 3.0
"""Load-point travel into a segment, in units of rho~_max, after which it slides steadily."""

RENEWAL_TRAVEL = 5.0
"""Load-point travel, in units of D0, after which an unloaded start is forgotten (all but
e^-5 of the contacts, born with synchronised blocks, have been renewed)."""


def open_snapshots(store: str | Path) -> xr.Dataset:
    """The block snapshots of a run store, dask-backed (nothing is loaded).

    Dims ``(time, contact, block)``: ``time`` [s] is the simulated time of each snapshot,
    ``contact`` and ``block`` are indices. Variables are those of
    :data:`nanoblock.store.SNAPSHOTS` (``block_stress`` [Pa], ``block_position`` [m],
    ``block_pinned``, ``contact_age`` [s]); attrs are the run's provenance.
    ValueError if the run stored no snapshots (``run.snapshot_every = 0``).
    """
    run = RunStore(store)
    if not run.exists():
        raise FileNotFoundError(f"{store}: no nanoblock run store")
    stored = run.open()
    if "snapshot_time" not in stored.dims:
        raise ValueError(f"{store}: the run stored no block snapshots (run.snapshot_every = 0)")
    snaps = stored[list(SNAPSHOTS)].rename(snapshot_time="time")
    index = {"units": "1"}
    return snaps.assign_coords(
        contact=("contact", np.arange(snaps.sizes["contact"]), {**index, "long_name": "contact"}),
        block=("block", np.arange(snaps.sizes["block"]), {**index, "long_name": "block in chain"}),
    )


def steady_window(scenario: Scenario, times: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Snapshots taken in steady sliding: a mask over ``times`` [s] and the velocity [m/s].

    Steady means: in a segment moving at load-point velocity V, after the load point has
    travelled :data:`STEADY_TRAVEL` rho~_max in it (from t = 0 in the first segment of an
    ``initial_state = "steady"`` run), and, after an unloaded start (all blocks at zero
    stress fire in step for many cycles), only once :data:`RENEWAL_TRAVEL` D0 of travel
    has renewed the contacts. Exact for a rigid drive. Of several segments, the one with
    most snapshots is chosen; None if there is none.
    """
    steps = scenario.loading.steps
    lengths = np.array([step.length for step in steps])
    velocities = np.array([step.load_velocity for step in steps])
    starts = np.cumsum(lengths) - lengths
    travelled = np.cumsum(lengths * velocities) - lengths * velocities  # at segment starts [m]
    steady_start = scenario.run.initial_state == "steady"
    forget = 0.0 if steady_start else RENEWAL_TRAVEL * scenario.interface.memory_length
    best: tuple[np.ndarray, float] | None = None
    for i, velocity in enumerate(velocities):
        if velocity == 0.0:
            continue
        settle = 0.0 if (i == 0 and steady_start) else STEADY_TRAVEL * scenario.joint.rho_max
        first = starts[i] + max(settle, forget - travelled[i]) / velocity
        mask = (times >= first) & (times <= starts[i] + lengths[i])
        if mask.any() and (best is None or mask.sum() > best[0].sum()):
            best = (mask, float(velocity))
    return best
