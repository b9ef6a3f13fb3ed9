"""Synthetic laboratory records for fitting tests, made by the naive reference integrator
(``tests/naive_rsf.py``), never by the code under test."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from nanoblock.measured import COLUMNS
from tests.naive_rsf import naive_slider

NOISE = 2e-4
"""Standard deviation of the white measurement noise added to mu (typical of lab data)."""
REFERENCE_RTOL, REFERENCE_ATOL = 1e-9, 1e-11
"""Tolerances of the naive integrator for these records: over the 40 cases of each
recovery test in ``test_fit.py`` (aging and slip, step and slide-hold-slide) the friction
differs from the naive default (1e-11, 1e-13) by at most 1.0e-10, 2e6 times below
``NOISE``, and the records are made 2.8x faster (measured 2026-11-27)."""


def random_parameters(rng: np.random.Generator) -> dict[str, float]:
    """mu0, a, b, dc drawn from laboratory-like ranges, with v0 = 1 um/s."""
    a = rng.uniform(0.005, 0.015)
    return {
        "mu0": rng.uniform(0.5, 0.7),
        "a": a,
        "b": a + rng.uniform(-0.004, 0.004),
        "dc": math.exp(rng.uniform(math.log(5e-6), math.log(5e-5))),
        "v0": 1e-6,
    }


def protocol(kind: str, dc: float) -> list[tuple[float, float]]:
    """(velocity, duration) segments: a 1 -> 10 um/s step, or a slide-hold-slide at
    10 um/s with a hold of 300 Dc / V (visible healing) and 20 Dc of reslide."""
    if kind == "velocity_step":
        return [(1e-6, 8 * dc / 1e-6), (1e-5, 25 * dc / 1e-5)]
    return [(1e-5, 5 * dc / 1e-5), (0.0, 300 * dc / 1e-5), (1e-5, 20 * dc / 1e-5)]


def record(
    law: str,
    params: dict[str, float],
    kind: str,
    stiffness: float,
    rng: np.random.Generator,
    *,
    n_samples: int = 800,
    noise: float = NOISE,
    trend: float = 0.0,
) -> xr.Dataset:
    """A measured-data Dataset (as :func:`load_measurement` returns) with noise on mu."""
    segments = protocol(kind, params["dc"])
    time = np.linspace(0.0, sum(d for _, d in segments), n_samples)
    ends = np.cumsum([d for _, d in segments])
    index = np.minimum(np.searchsorted(ends, time, side="right"), len(segments) - 1)
    velocity = np.array([v for v, _ in segments])[index]
    starts = np.concatenate([[0.0], ends[:-1]])
    base = np.concatenate([[0.0], np.cumsum([v * d for v, d in segments])[:-1]])
    displacement = base[index] + velocity * (time - starts[index])
    friction = naive_slider(
        law, params, segments, time, stiffness, rtol=REFERENCE_RTOL, atol=REFERENCE_ATOL
    )
    mu = friction + trend * displacement
    mu = mu + noise * rng.standard_normal(time.size)

    def var(name: str, values: np.ndarray) -> tuple:
        units, long_name = COLUMNS[name]
        return ("sample", values, {"units": units, "long_name": long_name})

    return xr.Dataset(
        {
            "time": var("time", time),
            "mu": var("mu", mu),
            "load_point_velocity": var("load_point_velocity", velocity),
            "load_point_displacement": var("load_point_displacement", displacement),
        },
        attrs={"kind": "time_series", "apparatus": "spring_slider"},
    )


def write_csv(dataset: xr.Dataset, path: Path, metadata: dict[str, object]) -> Path:
    """Write a Dataset in the CSV format of physics.md section 6."""
    names = list(dataset.data_vars)
    lines = [f"# {key}: {value}" for key, value in metadata.items()]
    lines.append(",".join(names))
    table = np.column_stack([dataset[name].values for name in names])
    lines += [",".join(f"{x:.12g}" for x in row) for row in table]
    path.write_text("\n".join(lines) + "\n")
    return path


def combine(records: list[xr.Dataset], forces: list[float]) -> xr.Dataset:
    """Several records as one multi-run Dataset with ``run`` and ``normal_force`` columns."""
    parts = []
    for index, (part, force) in enumerate(zip(records, forces, strict=True)):
        size = part.sizes["sample"]
        extra = {
            "run": ("sample", np.full(size, float(index)), _attrs("run")),
            "normal_force": ("sample", np.full(size, float(force)), _attrs("normal_force")),
        }
        parts.append(part.assign(extra))
    return xr.concat(parts, dim="sample", combine_attrs="override")


def _attrs(name: str) -> dict[str, str]:
    units, long_name = COLUMNS[name]
    return {"units": units, "long_name": long_name}
