"""A short text summary of a run, for the CLI and ``nanoblock info``."""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
import xarray as xr


def summarize(run: xr.Dataset) -> str:
    """Key numbers of a run: size, slip, events, friction while sliding, and throughput
    (from the wall time stored with the run)."""
    scenario = json.loads(run.attrs["scenario"])
    interface = scenario["interface"]
    mu = run.friction_coefficient.values
    slip = float(run.slider_displacement[-1] - run.slider_displacement[0])
    events = int(run.n_events[-1])
    lines = [
        f"contacts x blocks     {interface['n_contacts']} x {interface['blocks_per_contact']}",
        f"seed                  {run.attrs['seed']}",
        f"samples               {mu.size} over {float(run.time[-1]):.4g} s simulated",
        f"slider slip           {slip * 1e6:.4g} um",
        f"block depinnings      {events:,}",
        f"friction coefficient  first {mu[0]:.4f}  peak {np.max(mu):.4f}  last {mu[-1]:.4f}",
        *_sliding_friction(run, scenario["loading"]["steps"]),
        f"mean contact age      {float(run.mean_contact_age[-1]):.4g} s (last sample)",
    ]
    wall = run.attrs.get("progress", {}).get("wall_seconds")
    if wall:
        lines.append(f"wall time             {wall:.3g} s ({events / wall:.3g} events/s)")
    return "\n".join(lines)


def _sliding_friction(run: xr.Dataset, steps: list[Mapping[str, Any]]) -> list[str]:
    """Mean and sd of the friction coefficient over the second half of each sliding
    segment's samples (holds are left out)."""
    time, mu = run.time.values, run.friction_coefficient.values
    lines, start = [], 0.0
    for number, step in enumerate(steps, 1):
        if step.get("hold") is not None:
            length, velocity = step["hold"], 0.0
        else:
            velocity = step["velocity"]
            length = step.get("duration") or step["displacement"] / velocity
        inside = mu[(time > start) & (time <= start + length)]
        start += length
        if velocity and inside.size:
            half = inside[inside.size // 2 :]
            lines.append(
                f"  sliding, segment {number}  {half.mean():.4f} +- {half.std():.2g} (sd, "
                f"last half of its samples at {velocity:.3g} m/s)"
            )
    return lines


def _dotted_items(mapping: Mapping[str, Any], prefix: str = "") -> Iterator[tuple[str, Any]]:
    """(dotted key, value) for every set leaf of a nested scenario mapping."""
    for name, value in mapping.items():
        key = f"{prefix}{name}"
        if isinstance(value, Mapping):
            yield from _dotted_items(value, f"{key}.")
        elif isinstance(value, list):
            yield from _dotted_items(dict(enumerate(value)), f"{key}.")
        elif value is not None:
            yield key, value


def provenance_text(run: xr.Dataset) -> str:
    """Provenance of a stored run: completion, progress, seed, versions, resolved scenario."""
    attrs = run.attrs
    progress = attrs.get("progress", {})
    lines = [f"complete              {'yes' if attrs.get('complete') else 'no'}"]
    if "fraction" in progress:
        lines.append(
            f"progress              {progress['simulated_time']:.4g} of "
            f"{progress['end_time']:.4g} s simulated ({progress['fraction']:.1%}), "
            f"{progress['events']:,} depinnings, {progress['wall_seconds']:.3g} s wall"
        )
    versions = ", ".join(
        f"{name} {attrs[f'{name}_version']}" for name in ("nanoblock", "numba", "numpy")
    )
    lines += [f"seed                  {attrs['seed']}", f"versions              {versions}"]
    lines.append("scenario")
    lines += [f"  {key} = {value}" for key, value in _dotted_items(json.loads(attrs["scenario"]))]
    return "\n".join(lines)
