"""The zarr v3 store of a run: a registry of output variables, streaming and checkpoints.

Samples are appended along ``time`` as the run goes (xarray ``to_zarr(append_dim=...)``),
block snapshots along ``snapshot_time``. After each flush the full kernel state is written
to one of two alternating checkpoint slots in the ``checkpoint`` subgroup, and only then
is the root attribute pointing to it updated, so a run killed at any moment keeps every
flushed sample and a complete checkpoint to resume from.

Integrity: every array written since the ``integrity`` root attr exists carries a crc32c
checksum on each chunk and writes every chunk, even one of fill values, so a chunk that is
missing or altered is found by :meth:`RunStore.damage` (older stores: unreadable chunks,
and missing chunks of arrays whose fill value is NaN, since a run never stores NaN). Each
checkpoint slot also holds its own resume data, so a resume falls back to the other slot
when the last one is damaged.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
import zarr
from zarr.codecs import Crc32cCodec, ZstdCodec

TIME_CHUNK = 4096
"""Samples per zarr chunk along ``time``."""


@dataclass(frozen=True)
class VariableSpec:
    """An output variable: its dims, dtype, units and long name."""

    dims: tuple[str, ...]
    units: str
    long_name: str
    dtype: str = "float64"


SAMPLES: dict[str, VariableSpec] = {
    "friction_coefficient": VariableSpec(("time",), "1", "friction coefficient mu = F / W"),
    "friction_force": VariableSpec(("time",), "N", "interface friction force F"),
    "slider_displacement": VariableSpec(("time",), "m", "slider displacement X"),
    "load_point_displacement": VariableSpec(("time",), "m", "load-point displacement X_L"),
    "slider_velocity": VariableSpec(
        ("time",), "m/s", "slider velocity, mean over the preceding sample interval"
    ),
    "mean_contact_age": VariableSpec(("time",), "s", "mean age of the contacts"),
    "real_contact_area": VariableSpec(("time",), "m2", "total load-bearing contact area"),
    "n_events": VariableSpec(("time",), "1", "cumulative block depinnings", "int64"),
}
"""Per-sample variables (the public contract of a run's Dataset)."""

SNAPSHOTS: dict[str, VariableSpec] = {
    "block_stress": VariableSpec(
        ("snapshot_time", "contact", "block"), "Pa", "shear stress on each block"
    ),
    "block_position": VariableSpec(
        ("snapshot_time", "contact", "block"), "m", "position q of each block"
    ),
    "block_pinned": VariableSpec(
        ("snapshot_time", "contact", "block"),
        "1",
        "block pinned (avalanches are resolved instantly, so every block is pinned at a sample)",
        "bool",
    ),
    "contact_age": VariableSpec(("snapshot_time", "contact"), "s", "age of each contact"),
}
"""Block-level snapshots (the agents' trajectories)."""

INTEGRITY = "crc32c"
"""Root attr ``integrity`` of a store whose chunks are all written and checksummed."""

CHECKED = {"compressors": (ZstdCodec(), Crc32cCodec())}
"""Encoding of every array of a store: zstd, then a crc32c checksum of each chunk."""


class StoreError(ValueError):
    """A store that cannot be used as asked: the message names the path and the reason."""


COORDINATES: dict[str, VariableSpec] = {
    "time": VariableSpec(("time",), "s", "simulated time"),
    "snapshot_time": VariableSpec(("snapshot_time",), "s", "simulated time of the snapshot"),
}


def dataset(
    values: Mapping[str, np.ndarray], specs: Mapping[str, VariableSpec], coord: str
) -> xr.Dataset:
    """Build a Dataset from arrays, checked against ``specs`` and carrying their attrs."""
    missing = set(specs) - set(values)
    if missing:
        raise KeyError(f"missing output variables: {sorted(missing)}")
    data_vars = {}
    for name, spec in specs.items():
        array = np.asarray(values[name], dtype=spec.dtype)
        if array.ndim != len(spec.dims):
            raise ValueError(f"{name}: expected dims {spec.dims}, got shape {array.shape}")
        data_vars[name] = xr.Variable(
            spec.dims, array, {"units": spec.units, "long_name": spec.long_name}
        )
    coord_spec = COORDINATES[coord]
    coords = {
        coord: xr.Variable(
            (coord,),
            np.asarray(values[coord], dtype=float),
            {"units": coord_spec.units, "long_name": coord_spec.long_name},
        )
    }
    return xr.Dataset(data_vars, coords)


UNSTARTED = (
    "unfinished: interrupted before its first samples were stored; the same `nanoblock run` "
    "command writes it afresh"
)
"""What a store that :meth:`RunStore.unstarted` is holds, as the commands say it."""


class RunStore:
    """A run's zarr v3 store: samples, snapshots, provenance attrs and checkpoints."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    def exists(self) -> bool:
        """Whether a store has been created at the path."""
        return (self.path / "zarr.json").exists()

    @property
    def attrs(self) -> dict[str, Any]:
        """Root attributes (provenance, progress, checkpoint pointer)."""
        return dict(zarr.open_group(self.path, mode="r").attrs)

    def root_damage(self) -> list[str]:
        """``[why]`` when the path is a directory of run-store arrays without the root
        ``zarr.json`` (a store whose root metadata was lost), else ``[]``."""
        if self.exists() or not self.path.is_dir():
            return []
        ours = sorted(set(SAMPLES) & {entry.name for entry in self.path.iterdir()})
        return [f"root zarr.json missing (it holds {', '.join(ours[:3])}, ...)"] if ours else []

    def unstarted(self) -> bool:
        """Whether the run was interrupted before its first samples were stored: the
        provenance is written (:meth:`create`), no sample array and no checkpoint is."""
        attrs = self.attrs
        if attrs.get("complete", True) or attrs.get("checkpoint"):
            return False
        with warnings.catch_warnings():  # a folder without zarr.json: not an array
            warnings.simplefilter("ignore", UserWarning)
            present = set(zarr.open_group(self.path, mode="r").array_keys())
        return not present & {*SAMPLES, "time"}

    def update_attrs(self, **attrs: Any) -> None:
        """Set root attributes."""
        zarr.open_group(self.path, mode="a").attrs.update(attrs)

    def create(self, first: xr.Dataset, attrs: Mapping[str, Any]) -> None:
        """Write the provenance attributes, then the first samples, replacing only a store
        of nanoblock's own arrays (StoreError if the path holds anything else). A run
        interrupted in between leaves a store of its scenario without a checkpoint, which
        the same run writes afresh."""
        self._refuse_foreign()
        attrs = {**attrs, "integrity": INTEGRITY}
        zarr.open_group(self.path, mode="w", zarr_format=3, attributes=attrs)
        encoding = {name: {"chunks": (TIME_CHUNK,), **CHECKED} for name in [*SAMPLES, "time"]}
        first.assign_attrs(attrs).to_zarr(
            self.path,
            mode="a",
            zarr_format=3,
            consolidated=False,
            encoding=encoding,
            write_empty_chunks=True,
        )

    def _refuse_foreign(self) -> None:
        """StoreError if the path is a file or holds entries a run store does not have."""
        if not self.path.exists():
            return
        if not self.path.is_dir():
            raise StoreError(f"{self.path}: is a file, not a nanoblock run store")
        ours = {"zarr.json", "checkpoint", *SAMPLES, *SNAPSHOTS, *COORDINATES}
        foreign = sorted(p.name for p in self.path.iterdir() if p.name not in ours)
        if foreign or (any(self.path.iterdir()) and not self.exists()):
            shown = ", ".join(foreign[:3]) or "arrays without zarr.json"
            raise StoreError(
                f"{self.path}: not a nanoblock run store (it holds {shown}); nothing was "
                "written: choose a new path"
            )

    def append(self, samples: xr.Dataset) -> None:
        """Append samples along ``time`` (xarray rewrites root attrs: keep the stored ones)."""
        samples = samples.assign_attrs(self.attrs)
        samples.to_zarr(self.path, append_dim="time", consolidated=False, write_empty_chunks=True)

    def append_snapshots(self, snapshots: xr.Dataset) -> None:
        """Append block snapshots along ``snapshot_time`` (creating them the first time)."""
        snapshots = snapshots.assign_attrs(self.attrs)
        if "snapshot_time" in self._root_arrays():
            snapshots.to_zarr(
                self.path, append_dim="snapshot_time", consolidated=False, write_empty_chunks=True
            )
        else:
            n_contacts, n_blocks = snapshots.sizes["contact"], snapshots.sizes["block"]
            chunks = (1, min(n_contacts, max(1, 2**20 // max(n_blocks, 1))), n_blocks)
            encoding = {
                name: {"chunks": chunks[: len(spec.dims)], **CHECKED}
                for name, spec in SNAPSHOTS.items()
            }
            encoding["snapshot_time"] = {"chunks": (1,), **CHECKED}
            snapshots.to_zarr(
                self.path,
                mode="a",
                consolidated=False,
                encoding=encoding,
                write_empty_chunks=True,
            )

    def _root_arrays(self) -> set[str]:
        return set(zarr.open_group(self.path, mode="r").array_keys())

    def n_samples(self) -> int:
        """Number of samples stored along ``time``."""
        return int(zarr.open_group(self.path, mode="r")["time"].shape[0])

    def truncate(self, n_samples: int, n_snapshots: int) -> None:
        """Drop samples (and snapshots) written after the last checkpoint."""
        for array, keep in _appended(zarr.open_group(self.path, mode="a"), n_samples, n_snapshots):
            if keep is not None:
                array.resize((keep, *array.shape[1:]))

    def write_checkpoint(
        self,
        arrays: Mapping[str, np.ndarray],
        resume: Mapping[str, Any],
        progress: Mapping[str, Any],
    ) -> None:
        """Store the full kernel state in the free slot (its resume data and the names of
        its arrays cleared first and written last), then, in one metadata write, point the
        ``checkpoint`` attr at it (with the ``resume`` data) and set ``progress``."""
        root = zarr.open_group(self.path, mode="a")
        current = root.attrs.get("checkpoint", {}).get("slot")
        slot = "b" if current == "a" else "a"
        group = root.require_group("checkpoint").require_group(slot)
        group.attrs.put({})
        for name, array in arrays.items():
            group.create_array(
                name,
                data=np.asarray(array),
                overwrite=True,
                config={"write_empty_chunks": True},
                **CHECKED,
            )
        group.attrs.put({**resume, "arrays": sorted(arrays)})
        root.attrs.update({"checkpoint": {"slot": slot, **resume}, "progress": dict(progress)})

    def read_checkpoint(self) -> tuple[dict[str, np.ndarray], dict[str, Any]] | None:
        """The last intact checkpoint (arrays, resume data), or None if none was written.

        If the slot the root attrs point to is damaged, the other slot's checkpoint is
        used when it is intact, and the root attrs are pointed at it and mark the run
        unfinished (a resume truncates back to it); StoreError if neither slot is intact,
        or if a stored sample or snapshot before the checkpoint is damaged.
        """
        root = zarr.open_group(self.path, mode="r")
        pointer = root.attrs.get("checkpoint")
        if not pointer:
            return None
        current = pointer["slot"]
        damaged = self.checkpoint_damage(current)
        slot, resume = current, {k: v for k, v in pointer.items() if k != "slot"}
        if damaged:
            slot = "b" if current == "a" else "a"
            resume = self._slot_resume(slot)
            if resume is None or self.checkpoint_damage(slot):
                raise StoreError(
                    f"{self.path}: checkpoint damaged ({'; '.join(damaged)}) and no intact "
                    "earlier one: the run cannot be resumed on its own trajectory"
                )
        data = self.damage(int(resume["samples"]), int(resume.get("snapshots", 0)))
        if data:
            raise StoreError(f"{self.path}: damaged ({'; '.join(data)}): the run cannot be resumed")
        if slot != current:  # what follows the earlier checkpoint is to be recomputed
            self.update_attrs(checkpoint={"slot": slot, **resume}, complete=False)
        group = root["checkpoint"][slot]
        return {name: group[name][...] for name in group.array_keys()}, resume

    def _slot(self, slot: str) -> zarr.Group | None:
        """A checkpoint slot's group (None if it was never written)."""
        try:
            return zarr.open_group(self.path, mode="r")[f"checkpoint/{slot}"]
        except KeyError:
            return None

    def _slot_resume(self, slot: str) -> dict[str, Any] | None:
        """The resume data a checkpoint slot was completed with (None: never completed)."""
        group = self._slot(slot)
        attrs = dict(group.attrs) if group is not None else {}
        attrs.pop("arrays", None)
        return attrs if "samples" in attrs else None

    def checkpoint_damage(self, slot: str) -> list[str]:
        """Missing arrays (of those the slot's attrs list), missing or unreadable chunks
        of a checkpoint slot."""
        group = self._slot(slot)
        if group is None:
            return [f"checkpoint/{slot}: missing"]
        checked = self.attrs.get("integrity") == INTEGRITY
        present = set(group.array_keys())
        listed = group.attrs.get("arrays", [])
        problems = [
            f"checkpoint/{slot}/{name}: array missing" for name in listed if name not in present
        ]
        for name in sorted(present):
            where = f"checkpoint/{slot}/{name}"
            problems += _chunk_damage(group[name], where, None, self.path, checked)
        if not problems and not present:
            problems.append(f"checkpoint/{slot}: holds no arrays")
        return problems

    def damage(
        self, n_samples: int | None = None, n_snapshots: int | None = None, *, read: bool = True
    ) -> list[str]:
        """Every missing array, missing or unreadable chunk of the stored samples and
        snapshots, named by array and sample (or snapshot) range, up to ``n_samples`` and
        ``n_snapshots`` (default: what :meth:`open` shows). ``read=False`` looks for missing
        arrays and chunk files only, without decoding the chunks (a stat per chunk)."""
        attrs = self.attrs
        pointer = attrs.get("checkpoint") or {}
        unfinished = not attrs.get("complete", True) and pointer
        if n_samples is None:
            n_samples = int(pointer["samples"]) if unfinished else None
            n_snapshots = int(pointer.get("snapshots", 0)) if unfinished else None
        group = zarr.open_group(self.path, mode="r")
        checked = attrs.get("integrity") == INTEGRITY
        with warnings.catch_warnings():  # a folder without zarr.json: reported as missing
            warnings.simplefilter("ignore", UserWarning)
            present = set(group.array_keys())
            expected = [*SAMPLES, "time"]
            if present & {*SNAPSHOTS, "snapshot_time"}:  # snapshots are written all together
                expected += [*SNAPSHOTS, "snapshot_time"]
            problems = [f"{name}: array missing" for name in expected if name not in present]
            for array, keep in _appended(group, n_samples, n_snapshots):
                problems += _chunk_damage(array, array.basename, keep, self.path, checked, read)
        return problems

    def open(self) -> xr.Dataset:
        """Open the stored run lazily; an unfinished run as far as its last checkpoint.

        A run killed inside an append can leave some arrays a chunk longer than others,
        which xarray refuses to open; what a resume keeps is what this shows (the store is
        not written to).
        """
        attrs = self.attrs
        pointer = attrs.get("checkpoint")
        if attrs.get("complete", True) or not pointer:
            return xr.open_zarr(self.path, consolidated=False)
        return self.open_to(int(pointer["samples"]), int(pointer.get("snapshots", 0)))

    def load_samples(self) -> xr.Dataset:
        """The samples of a finished run (no snapshots) read into memory as numpy arrays,
        decoded as :meth:`open` decodes them. Unlike :meth:`open` it builds no dask arrays,
        so reading them computes nothing with dask: a dask compute imports ``distributed``
        (about 0.2 s) to look for a client."""
        if not self.attrs.get("complete", True):
            raise StoreError(f"{self.path}: the run is unfinished; open() shows what it holds")
        snapshots = [*SNAPSHOTS, "snapshot_time"]
        return xr.open_zarr(
            self.path, consolidated=False, chunks=None, drop_variables=snapshots
        ).load()

    def open_to(self, n_samples: int, n_snapshots: int) -> xr.Dataset:
        """The first ``n_samples`` samples and ``n_snapshots`` snapshots, read lazily
        array by array and decoded as xarray does (zarr v3: no fill-value mask), whatever
        lies beyond them."""
        import dask.array  # here only: a finished run is read without dask (load_samples)

        group = zarr.open_group(self.path, mode="r")
        variables = {}
        for array, keep in _appended(group, n_samples, n_snapshots):
            data = dask.array.from_zarr(array)[:keep]
            dims = tuple(array.metadata.dimension_names or ())
            variables[array.basename] = xr.Variable(dims, data, dict(array.attrs))
        return xr.decode_cf(xr.Dataset(variables, attrs=dict(group.attrs)))


def _appended(
    group: zarr.Group, n_samples: int, n_snapshots: int
) -> Iterator[tuple[zarr.Array, int | None]]:
    """Each root array with the length it keeps: ``n_samples`` along ``time``,
    ``n_snapshots`` along ``snapshot_time``, None (all of it) for the rest."""
    keep = {"time": n_samples, "snapshot_time": n_snapshots}
    for name in group.array_keys():
        array = group[name]
        dims = array.metadata.dimension_names or ()
        yield array, keep.get(dims[0]) if dims else None


def _chunk_damage(
    array: zarr.Array,
    name: str,
    keep: int | None,
    root: Path,
    all_written: bool = True,
    read: bool = True,
) -> list[str]:
    """Chunks of ``array`` in the store at ``root`` (its first ``keep`` rows; None: all)
    that are missing or (with ``read``) fail to decode. Without ``all_written`` (a store from before
    :data:`INTEGRITY`, which omitted chunks of fill values) a chunk counts as missing only
    if the fill value is NaN, which a run never stores."""
    fill = array.fill_value
    look = all_written or (isinstance(fill, float | np.floating) and bool(np.isnan(fill)))
    if not array.shape:
        return _unreadable(array, (), name) if read else []
    keep = array.shape[0] if keep is None else min(keep, array.shape[0])
    step = array.chunks[0]
    dims = array.metadata.dimension_names or ("",)
    unit = {"time": "samples", "snapshot_time": "snapshots"}.get(dims[0], "rows")
    counts = [-(-size // chunk) for size, chunk in zip(array.shape, array.chunks, strict=True)]
    problems = []
    for index in range(-(-keep // step)):
        rows = slice(index * step, min((index + 1) * step, keep))
        where = f"{name}: {unit} {rows.start}-{rows.stop - 1}"
        keys = (
            array.metadata.encode_chunk_key((index, *coords)) for coords in np.ndindex(*counts[1:])
        )
        missing = [key for key in keys if look and not (root / array.path / key).exists()]
        if missing:
            problems.append(f"{where} missing (chunk {missing[0]})")
        elif read:
            problems += _unreadable(array, rows, where)
    return problems


def _unreadable(array: zarr.Array, rows: slice | tuple[()], where: str) -> list[str]:
    """``[where unreadable (the error)]`` if ``array[rows]`` fails to decode, else ``[]``."""
    try:
        array[rows]
    except Exception as error:  # any decoding failure: checksum, codec or shape
        return [f"{where} unreadable ({type(error).__name__}: {error})"]
    return []


def scenario_of(store: RunStore) -> dict[str, Any]:
    """The resolved scenario stored with a run, as a mapping."""
    return json.loads(store.attrs["scenario"])


def scenario_damage(attrs: Mapping[str, Any]) -> list[str]:
    """``[why]`` when the root attr ``scenario`` of a run store is not a resolved scenario
    (a JSON table of scenario keys), else ``[]``."""
    try:
        if isinstance(json.loads(attrs["scenario"]), dict):
            return []
        error: Exception = ValueError("not a table of scenario keys")
    except (KeyError, TypeError, ValueError) as failure:  # JSONDecodeError is a ValueError
        error = failure
    return [f"root attribute 'scenario' is not a resolved scenario ({error})"]
