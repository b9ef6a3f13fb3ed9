"""Reading measured friction data (physics.md section 6) into one validated Dataset.

Accepted files: UTF-8 CSV (a byte-order mark is dropped) whose leading ``# key: value``
lines are metadata, netCDF (``.nc`` or its signature) or zarr with the same variable
names, and Penn State xlook binaries (recognised by their header) with their reduction recipe
(:mod:`nanoblock.xlook`; ``recipe=``, ``rows=``; a recipe alone finds the binary its
``read`` line names). Three kinds of data come out, told apart by their columns and
recorded in ``attrs["kind"]``:

* ``time_series``: ``time`` [s], ``mu`` (or ``force`` [N] with ``normal_force`` [N], or
  ``shear_stress`` with ``normal_stress`` [Pa]) and
  the drive as ``load_point_velocity`` [m/s] and/or ``load_point_displacement`` [m]
  (velocity steps, slide-hold-slide);
* ``clamped_sample``: 000's apparatus, ``time``, ``s_ext`` and ``s`` [m] (metadata
  ``apparatus: clamped_sample``, ``k_s``, ``k_f``, ``k_ext`` [N/m]);
* ``steady_state``: a table without ``time``: ``mu`` against ``load_point_velocity``
  (or ``velocity``) [m/s] (optionally ``temperature`` [K], ``normal_force`` [N]).

Optional per-row columns: ``slip`` [m], ``normal_force`` [N], ``temperature`` [K] and
``run`` (an id, number or text, grouping the rows of one experiment). Displacements
(``load_point_displacement``, ``slip``, ``s_ext``, ``s``) and ``load_point_velocity`` are
in m and m/s unless the metadata says ``displacement_unit: um`` (m, mm, um, micron, nm) or
``velocity_unit: um/s`` (m/s, mm/s, um/s, micron/s, nm/s).

A simulator run store (the zarr directory of ``nanoblock run``, recognised by its
``scenario`` attribute) reads as a ``time_series`` too (:func:`from_simulation`), so
simulated and measured data go through one fitting path. The result has one dimension,
``sample``; every variable carries ``units`` and ``long_name``. Time must increase within
a run (in a clamped-sample file without ``run``, each normal force is a run). Rows with a missing
(NaN or empty) required value are dropped with a warning that counts them; anything else
that is wrong (an infinite value among them) raises :class:`DataError` naming the file,
the column and the row.
"""

from __future__ import annotations

import difflib
import math
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
import xarray as xr

__all__ = [
    "COLUMNS",
    "DataError",
    "DroppedRowsWarning",
    "from_simulation",
    "load_measurement",
    "runs",
]


class DataError(ValueError):
    """Measured data that cannot be used as given."""


class DroppedRowsWarning(UserWarning):
    """Rows with missing values were dropped (the message counts them)."""


COLUMNS: dict[str, tuple[str, str]] = {
    "time": ("s", "time"),
    "mu": ("1", "friction coefficient (shear / normal)"),
    "force": ("N", "friction force"),
    "normal_force": ("N", "normal force"),
    "load_point_velocity": ("m/s", "load-point velocity"),
    "load_point_displacement": ("m", "load-point displacement"),
    "slip": ("m", "slip (load point minus elastic stretch)"),
    "temperature": ("K", "temperature"),
    "run": ("1", "run id"),
    "shear_stress": ("Pa", "shear stress"),
    "normal_stress": ("Pa", "normal stress"),
    "s_ext": ("m", "external (motor) extension"),
    "s": ("m", "sample extension"),
}
"""Known columns: (units, long name)."""

_NUMERIC_METADATA = (
    "stiffness",
    "stiffness_per_load",
    "normal_force",
    "normal_stress",
    "temperature",
    "k_s",
    "k_f",
    "k_ext",
    "c_ext",
    "c_x",
    "step_time",
)


APPARATUS = ("spring_slider", "clamped_sample")
"""Values of the ``apparatus`` metadata key."""

_MISSPELT = 0.9
"""difflib similarity from which an unknown metadata key of 6 or more characters counts as
a misspelt known one (stifness_per_load, normal_forces; not stiffness_note or
normal_stress_range, notes the lab files carry)."""


def _parse_metadata(lines: list[str], path: Path) -> dict[str, object]:
    """``# key: value`` lines as metadata: numbers for the numeric keys; DataError for a
    malformed line, a non-number, an unknown apparatus or a misspelt known key (free-text
    keys such as ``source`` or ``material`` are kept as notes)."""
    known = [*_NUMERIC_METADATA, *_UNIT_KEYS, "apparatus"]
    metadata: dict[str, object] = {}
    for number, line in enumerate(lines, start=1):
        key, sep, value = line.lstrip("#").partition(":")
        if not sep:
            raise DataError(f"{path}: metadata line {number} is not '# key: value': {line!r}")
        key, value = key.strip(), value.strip()
        unknown = key not in known and len(key) >= 6
        if unknown and (close := difflib.get_close_matches(key, known, n=1, cutoff=_MISSPELT)):
            raise DataError(
                f"{path}: metadata key {key!r} on line {number} is not known; did you mean "
                f"{close[0]!r}? (known keys: {', '.join(known)})"
            )
        if key == "apparatus" and value not in APPARATUS:
            raise DataError(
                f"{path}: metadata 'apparatus' on line {number} is {value!r}; allowed: "
                f"{', '.join(APPARATUS)}"
            )
        if key in _NUMERIC_METADATA:
            try:
                metadata[key] = float(value)
            except ValueError:
                raise DataError(
                    f"{path}: metadata {key!r} on line {number} must be a number, got {value!r}"
                ) from None
        else:
            metadata[key] = value
    return metadata


def _read_text(path: Path) -> str:
    """The text of a UTF-8 file (a byte-order mark is dropped); other content is refused."""
    raw = path.read_bytes()
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise DataError(f"{path}: UTF-16 text; save the CSV as UTF-8")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise DataError(
            f"{path}: not UTF-8 text (byte {error.start} is {raw[error.start]:#04x}): binary "
            "data or another encoding; a CSV must be UTF-8"
        ) from None
    if "\0" in text:
        raise DataError(
            f"{path}: NUL bytes: binary data or UTF-16 text, not a UTF-8 CSV (an xlook binary "
            "is read with its reduction recipe)"
        )
    return text


_MISSING = ("", "na", "n/a", "null")
"""Cells read as a missing value (NaN), besides 'nan'."""


def _numbers(cells: np.ndarray, name: str, path: Path, first_line: int) -> np.ndarray:
    """A column of CSV cells as floats (``run`` may hold any text ids)."""
    cells = np.where(np.isin(np.char.lower(cells), _MISSING), "nan", cells)
    try:
        return cells.astype(float)
    except ValueError:
        if name == "run":
            return cells
    row = next(i for i, cell in enumerate(cells) if not _is_number(cell))
    raise DataError(
        f"{path}: column {name!r} must be numeric; data row {row + 1} (file line "
        f"{first_line + row}) has {str(cells[row])!r}"
    )


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _read_csv(path: Path) -> tuple[dict[str, np.ndarray], dict[str, object], int]:
    lines = _read_text(path).splitlines()
    n_meta = 0
    while n_meta < len(lines) and lines[n_meta].startswith("#"):
        n_meta += 1
    metadata = _parse_metadata(lines[:n_meta], path)
    if n_meta == len(lines):
        raise DataError(f"{path}: no header row after the metadata")
    header = [name.strip() for name in lines[n_meta].split(",")]
    others = [mark for mark in (";", "\t", "|") if mark in lines[n_meta]]
    if len(header) == 1 and others:
        raise DataError(
            f"{path}: the header {lines[n_meta].strip()!r} has no comma but {others[0]!r}: "
            "the columns of a CSV are separated by commas (with '.' as decimal mark)"
        )
    if len(set(header)) != len(header):
        raise DataError(f"{path}: repeated column names in the header {header}")
    rows = [line.split(",") for line in lines[n_meta + 1 :] if line.strip()]
    if not rows:
        raise DataError(f"{path}: no data rows")
    widths = np.array([len(row) for row in rows])
    bad = np.flatnonzero(widths != len(header))
    if bad.size:
        raise DataError(
            f"{path}: data row {bad[0] + 1} has {widths[bad[0]]} values but the header has "
            f"{len(header)} columns {header}"
        )
    cells = np.char.strip(np.array(rows, dtype=str))
    columns = {name: _numbers(cells[:, i], name, path, n_meta + 2) for i, name in enumerate(header)}
    return columns, metadata, n_meta + 2


def from_simulation(run: xr.Dataset) -> xr.Dataset:
    """A simulated run (``nanoblock.engine.simulate`` output, or its store opened) in the
    layout of a measured time series, without the validation of :func:`load_measurement`.

    Dim ``sample``; ``time`` [s], ``mu`` (the ``friction_coefficient``),
    ``load_point_displacement`` [m] (the drive, exact at every sample; a fit rebuilds the
    piecewise-constant load-point velocity from it), ``slip`` [m] (the slider
    displacement); metadata from the scenario: ``stiffness_per_load`` K/W [1/m] (``inf``
    for a rigid drive), ``normal_force`` W [N], ``temperature`` T [K], and the scenario
    JSON itself.
    """
    from nanoblock.params import Scenario

    scenario = Scenario.from_json(run.attrs["scenario"])
    columns = {
        "time": run["time"].values,
        "mu": run["friction_coefficient"].values,
        "load_point_displacement": run["load_point_displacement"].values,
        "slip": run["slider_displacement"].values,
    }
    interface = scenario.interface
    attrs = {
        "kind": "time_series",
        "apparatus": "spring_slider",
        "stiffness_per_load": scenario.loading.stiffness / interface.normal_force,
        "normal_force": interface.normal_force,
        "temperature": scenario.joint.temperature,
        "scenario": run.attrs["scenario"],
        "source": "nanoblock simulation",
    }
    data_vars = {
        name: ("sample", np.asarray(values, dtype=float), _attrs(name))
        for name, values in columns.items()
    }
    return xr.Dataset(data_vars, attrs=attrs)


def _attrs(name: str) -> dict[str, str]:
    return {"units": COLUMNS[name][0], "long_name": COLUMNS[name][1]}


def _read_dataset(path: Path) -> tuple[dict[str, np.ndarray], dict[str, object]]:
    """A netCDF file or zarr store's 1-D variables and attrs (a nanoblock run store as
    :func:`from_simulation` converts it, refused when arrays or chunks are missing)."""
    from nanoblock.store import UNSTARTED, RunStore, scenario_damage

    form = "netCDF" if path.suffix == ".nc" or path.is_file() else "zarr"
    run = RunStore(path)
    try:
        if form == "zarr":
            damage = run.root_damage()
            attrs = run.attrs if run.exists() else {}
            if "scenario" in attrs and run.unstarted():
                raise DataError(f"{path}: {UNSTARTED}")
            if "scenario" in attrs:  # a run store: its own checks
                damage = scenario_damage(attrs) + run.damage()
            if damage:
                raise DataError(f"{path}: damaged nanoblock run store: {'; '.join(damage)}")
        if form == "netCDF":
            dataset = xr.open_dataset(path)
        else:
            dataset = xr.open_zarr(path, consolidated=False)
    except DataError:
        raise
    except Exception as error:  # any reader failure: the file is not what its name says
        raise DataError(
            f"{path}: not readable as {form} ({type(error).__name__}: {error}); give a CSV, "
            "a netCDF file or a zarr store in the measured-data format"
        ) from None
    if "scenario" in dataset.attrs:
        dataset = from_simulation(dataset)
    columns = {}
    for name in dataset.variables:
        values = dataset[name].values
        if values.ndim == 1:
            columns[str(name)] = values if name == "run" else values.astype(float)
    metadata = {
        key: float(value) if key in _NUMERIC_METADATA else value
        for key, value in dataset.attrs.items()
    }
    return columns, metadata


def _kind(columns: dict[str, np.ndarray], metadata: dict[str, object], path: Path) -> str:
    if metadata.get("apparatus") == "clamped_sample":
        required = ("time", "s_ext", "s")
        kind = "clamped_sample"
    elif "time" not in columns:
        required, kind = ("mu", "load_point_velocity"), "steady_state"
    else:
        kind = "time_series"
        required = ("time",)
        if "mu" not in columns and not ({"force", "normal_force"} <= set(columns)):
            raise DataError(
                f"{path}: column 'mu' is missing (or give 'force' [N] with 'normal_force' [N], "
                "or 'shear_stress' with 'normal_stress' [Pa])"
            )
        if not ({"load_point_velocity", "load_point_displacement"} & set(columns)):
            raise DataError(
                f"{path}: the drive is missing: give column 'load_point_velocity' [m/s] "
                "or 'load_point_displacement' [m]"
            )
    for name in required:
        if name not in columns:
            also = {"load_point_velocity": " (or 'velocity')", "mu": " (or 'shear_stress' with "
                    "'normal_stress')"}.get(name, "")  # fmt: skip
            raise DataError(
                f"{path}: required column {name!r}{also} is missing for {kind} data; columns: "
                f"{sorted(columns)}"
            )
    return kind


_UNIT_KEYS = {
    "displacement_unit": (
        ("load_point_displacement", "slip", "s_ext", "s"),
        {"m": 1.0, "mm": 1e-3, "um": 1e-6, "micron": 1e-6, "nm": 1e-9},
    ),
    "velocity_unit": (
        ("load_point_velocity",),
        {"m/s": 1.0, "mm/s": 1e-3, "um/s": 1e-6, "micron/s": 1e-6, "nm/s": 1e-9},
    ),
}
"""Metadata keys giving the unit of the displacement or velocity columns (default SI)."""


def _normalise(columns: dict[str, np.ndarray], metadata: dict[str, object], path: Path) -> None:
    """Accept what users write, in place: ``velocity`` for a steady table's
    ``load_point_velocity``, ``shear_stress`` / ``normal_stress`` for ``mu``, and
    displacements or velocities in the unit of ``displacement_unit`` / ``velocity_unit``."""
    if "time" not in columns and "load_point_velocity" not in columns and "velocity" in columns:
        columns["load_point_velocity"] = columns.pop("velocity")
    if "mu" not in columns and {"shear_stress", "normal_stress"} <= set(columns):
        normal = columns["normal_stress"]
        bad = np.flatnonzero(normal <= 0.0)
        if bad.size:
            raise DataError(
                f"{path}: column 'normal_stress' must be > 0 (mu = shear_stress / "
                f"normal_stress); data row {bad[0] + 1} has {float(normal[bad[0]])!r}"
            )
        columns["mu"] = columns["shear_stress"] / normal
    for key, (names, scales) in _UNIT_KEYS.items():
        unit = metadata.pop(key, None)
        if unit is None:
            continue
        if unit not in scales:
            raise DataError(f"{path}: metadata {key!r} = {unit!r}; allowed: {list(scales)}")
        for name in set(names) & set(columns):
            columns[name] = columns[name] * scales[unit]


def _check_order(
    time: np.ndarray, run: np.ndarray, locate: Callable[[int], str], path: Path
) -> None:
    """DataError at the first time that repeats or decreases within a run; ``locate``
    names a row (0-based) in the user's file."""
    same_run = run[1:] == run[:-1]
    bad = np.flatnonzero(same_run & (np.diff(time) <= 0.0))
    if bad.size:
        row = int(bad[0]) + 1
        word = "repeated" if time[row] == time[row - 1] else "decreasing (unsorted)"
        raise DataError(
            f"{path}: column 'time' is {word} at {locate(row)}: {float(time[row])!r} after "
            f"{float(time[row - 1])!r}"
        )


def _is_netcdf(path: Path) -> bool:
    with path.open("rb") as handle:
        magic = handle.read(4)
    return path.suffix == ".nc" or magic in (b"CDF\x01", b"CDF\x02", b"\x89HDF")


def load_measurement(
    path: str | Path,
    *,
    recipe: str | Path | None = None,
    rows: tuple[int, int] | None = None,
    columns: Mapping[str, str | int] | None = None,
) -> xr.Dataset:
    """Read and validate a measured-data file; see the module docstring for the format.

    ``recipe``, ``rows`` and ``columns`` are for an xlook binary (:mod:`nanoblock.xlook`):
    its reduction recipe, the inclusive (first, last) rows to keep and recipe column names.
    """
    from nanoblock import xlook

    path = Path(path)
    if not path.exists():
        raise DataError(f"{path}: no such file")
    if path.is_file() and recipe is None and (named := xlook.recipe_reads(path)):
        binary = path.parent / named  # a recipe's binary lies next to it
        if not binary.is_file():
            raise DataError(
                f"{path}: an xlook recipe; the binary it reads ({named!r}) is not next to it: "
                "give the binary as the data file and this recipe with --recipe"
            )
        path, recipe = binary, path  # a recipe naming its binary
    if recipe is not None or xlook.is_xlook(path):
        table, metadata = xlook.reduce_xlook(path, recipe, rows, columns)
        first = rows[0] if rows is not None else 0

        def locate(row: int) -> str:
            return f"xlook row {first + row} (after the recipe)"

    elif rows is not None or columns is not None:
        raise DataError(f"{path}: rows and columns select from an xlook binary only")
    elif path.is_dir() or _is_netcdf(path):
        table, metadata = _read_dataset(path)

        def locate(row: int) -> str:
            return f"sample {row}"

    else:
        table, metadata, first_line = _read_csv(path)

        def locate(row: int) -> str:
            return f"data row {row + 1} (file line {first_line + row})"

    _normalise(table, metadata, path)
    columns = table
    unknown = sorted(set(columns) - set(COLUMNS))
    if unknown:
        warnings.warn(
            f"{path}: ignoring unknown column(s) {unknown}; known: {sorted(COLUMNS)}",
            stacklevel=2,
        )
    kind = _kind(columns, metadata, path)
    columns = {name: values for name, values in columns.items() if name in COLUMNS}
    if "mu" not in columns and "force" in columns:
        columns["mu"] = columns["force"] / columns["normal_force"]

    required = {
        "time_series": ("time", "mu"),
        "clamped_sample": ("time", "s_ext", "s"),
        "steady_state": ("mu", "load_point_velocity"),
    }[kind]
    _check_magnitudes(columns, locate, path)
    drive = [name for name in ("load_point_velocity", "load_point_displacement") if name in columns]
    missing = np.zeros(len(next(iter(columns.values()))), dtype=bool)
    for name in (*required, *drive[:1]):
        missing |= ~np.isfinite(columns[name])
    if missing.all():
        empty = [name for name in (*required, *drive[:1]) if np.isnan(columns[name]).all()]
        where = f"column(s) {empty} hold no value" if empty else "no row is complete"
        raise DataError(
            f"{path}: every row has a missing (NaN or empty) value in "
            f"{[*required, *drive[:1]]}: {where}"
        )
    if missing.any():
        rows = np.flatnonzero(missing)[:5] + 1
        warnings.warn(
            f"{path}: dropped {int(missing.sum())} of {missing.size} rows with a missing value "
            f"in {[*required, *drive[:1]]} (first data rows {rows.tolist()})",
            DroppedRowsWarning,
            stacklevel=2,
        )
        columns = {name: values[~missing] for name, values in columns.items()}
        metadata["dropped_rows"] = int(missing.sum())
        kept, locate_all = np.flatnonzero(~missing), locate

        def locate(row: int) -> str:  # rows of the kept data, named in the user's file
            return locate_all(int(kept[row]))

    run = columns.get("run", np.zeros(len(columns[required[0]])))
    if "run" not in columns and kind == "clamped_sample" and "normal_force" in columns:
        run = columns["normal_force"]  # one run per normal force
    if "time" in columns:
        _check_order(columns["time"], run, locate, path)
    if "load_point_velocity" in columns:
        velocity = columns["load_point_velocity"]
        if kind == "steady_state":
            bad, need = np.flatnonzero(~(velocity > 0.0)), "> 0 (its log is taken)"
        else:
            bad, need = np.flatnonzero(~np.isfinite(velocity) | (velocity < 0.0)), ">= 0"
        if bad.size:
            row = int(bad[0])
            raise DataError(
                f"{path}: column 'load_point_velocity' must be {need} m/s; {locate(row)} "
                f"has {float(velocity[row])!r}"
            )
    if "temperature" in columns:
        bad = np.flatnonzero(~(columns["temperature"] > 0.0))
        if bad.size:
            row = int(bad[0])
            raise DataError(
                f"{path}: column 'temperature' must be > 0 K (absolute temperature); "
                f"{locate(row)} has {float(columns['temperature'][row])!r}"
            )
    for key in ("stiffness", "stiffness_per_load", "normal_force", "k_s", "k_f", "k_ext"):
        value = metadata.get(key)
        stiffness = key in ("stiffness", "stiffness_per_load")
        if value is None or (stiffness and value == math.inf):  # inf: a rigid drive
            continue
        if not (math.isfinite(value) and value > 0.0):
            allowed = "> 0 (or inf, a rigid drive)" if stiffness else "> 0"
            raise DataError(f"{path}: metadata {key!r} = {value!r} must be {allowed}")

    data_vars = {name: ("sample", values, _attrs(name)) for name, values in columns.items()}
    attrs = {**metadata, "kind": kind, "source_file": str(path)}
    attrs.setdefault("apparatus", "spring_slider")
    return xr.Dataset(data_vars, attrs=attrs)


MU_LIMIT = 10.0
"""Largest |mu| accepted: dry friction coefficients lie below ~2 (rubber ~3); a larger
value is a unit, column or typing error, refused rather than fitted."""
MAGNITUDE_LIMIT = 1e100
"""Largest |value| of any column (SI units): no friction record comes near it, and the
squares of larger values overflow in the fits."""


def _check_magnitudes(
    columns: dict[str, np.ndarray], locate: Callable[[int], str], path: Path
) -> None:
    """DataError naming the column and row (``locate``) of the first infinite value, |mu|
    above :data:`MU_LIMIT` or value above :data:`MAGNITUDE_LIMIT` (NaN is a missing value,
    handled by the caller; inf is no measurement, and dropping it would hide an overflow
    such as 1e400)."""
    for name, values in columns.items():
        if name == "run" or values.dtype.kind not in "fiu":
            continue
        limit = MU_LIMIT if name == "mu" else MAGNITUDE_LIMIT
        bad = np.flatnonzero(~np.isnan(values) & ~(np.abs(values) <= limit))
        if bad.size:
            row = int(bad[0])
            raise DataError(
                f"{path}: column {name!r} has {float(values[row]):.6g} at {locate(row)}; "
                f"allowed: |{name}| <= {limit:g}"
                + (" (a friction coefficient)" if name == "mu" else " (SI units)")
            )


def runs(data: xr.Dataset) -> list[xr.Dataset]:
    """The data split by its ``run`` column (one run if there is none), in file order."""
    if "run" not in data:
        return [data]
    ids, first = np.unique(data["run"].values, return_index=True)
    return [data.isel(sample=data["run"].values == ids[i]) for i in np.argsort(first)]
