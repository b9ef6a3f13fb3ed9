"""Parameter sweeps on Dask distributed: one resumable run store per task.

A sweep is the product of the values given for some scenario keys (``--set KEY=V1,V2``)
and of ``n`` seeds. Each task is one :func:`nanoblock.engine.simulate` run into its own
zarr store, executed on a Dask cluster (a process-per-core ``LocalCluster`` by default).
The sweep directory holds::

    DIR/sweep.json        manifest: base scenario, keys, values, seeds, tasks with status
    DIR/tasks/NNNN.zarr   the run store of task NNNN (complete when attrs["complete"])

A failed task (an exception, or its worker dying) is recorded in the manifest with its
error; the others are kept. Running the same sweep again skips finished stores and
resumes unfinished ones from their checkpoints (a task flushes its store every
:data:`FLUSH_SECONDS`, 30 s). :func:`open_sweep` combines the finished stores lazily
into one Dataset with dims ``(*keys, seed, sample)``.

Before the tasks start, every worker is warmed once (:func:`warm_up`: the imports, the
compiled kernels loaded from Numba's cache, zarr's write path), so that these one-off
costs of a new worker process fall in the sweep's fixed start-up cost, not in its first
task; :attr:`SweepReport.timings` splits the sweep's wall time into that fixed cost and
the task phase.
"""

from __future__ import annotations

import asyncio
import copy
import importlib
import itertools
import json
import logging
import os
import re
import signal
import tempfile
import threading
import time
import tomllib
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, get_args, get_origin

import dask
import dask.array as da
import numba
import numpy as np
import xarray as xr
from distributed import Client, LocalCluster, as_completed
from numba.core import config as numba_config
from pydantic import BaseModel, ValidationError
from pydantic.fields import FieldInfo
from tqdm.auto import tqdm

import nanoblock
from nanoblock.engine import Run, simulate
from nanoblock.params import Scenario, from_mapping, read_toml
from nanoblock.store import COORDINATES, SAMPLES, TIME_CHUNK, RunStore, VariableSpec

MANIFEST = "sweep.json"
"""Name of the manifest file in a sweep directory."""

Format = Literal["nanoblock-sweep/1"]
FORMAT: str = get_args(Format)[0]
"""Manifest format tag."""

Status = Literal["done", "failed", "pending"]
STATUSES: tuple[str, ...] = get_args(Status)
"""Task states in the manifest."""

WORKER_ENV = {"NUMBA_NUM_THREADS": "1"}
"""Environment of LocalCluster workers: one Numba thread per single-threaded worker."""

LOCAL_CONFIG = {
    "distributed.scheduler.worker-saturation": 1.0,
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
}
"""Dask config of a LocalCluster. Worker saturation 1: a worker holds only the task it
runs (the others wait in the scheduler's queue for the next free worker, and a dying
worker takes no other). The rest quietens Dask's monitoring, which a batch of long
single-threaded tasks does not need: the statistical profiler (every 10 ms in each
worker), the event-loop tick (20 ms), the memory (100 ms) and system (500 ms) monitors
cost the cluster's processes CPU worth 8-15 % of the tasks' own (2 workers on 2 cores,
runs of a few seconds); 2-2.5 % with these settings, most of it the scheduler's."""

FLUSH_SECONDS = 30.0
"""Wall time [s] between flushes of a sweep task's samples, checkpoint and progress to its
store (``nanoblock run`` flushes every :data:`nanoblock.engine.FLUSH_SECONDS`, 5 s). A flush
costs ~0.1 s of zarr writes, 2 % of a task's time at one every 5 s, whatever the task's
length, and under 0.4 % at this interval; a task whose worker is lost resumes from at most
this much before. ``functools.partial(run_task, flush_seconds=S)`` as ``task_function``
of :func:`run_sweep` sets another."""

WARM_UP = """
[joint]
block_size = 2.75e-9
shear_modulus = 1.0e9
threshold_stress = 1.0e8
attempt_frequency = 1.0e12
temperature = 300.0

[interface]
normal_force = 1.0
hardness = 1.0e8
n_contacts = 4
blocks_per_contact = 4
memory_length = 1e-8

[loading]
stiffness = 1e6
steps = [{ velocity = 1e-6, displacement = 1e-9 }]

[run]
seed = 0
record_every = 5e-4
initial_state = "steady"
"""
"""The throwaway run of :func:`warm_up`: 16 blocks, 3 samples, a few milliseconds."""


class SweepError(ValueError):
    """A sweep that cannot start: the message names the key, value, path or address."""


@dataclass(frozen=True)
class Axis:
    """One swept scenario key (dotted, e.g. ``loading.steps.0.velocity``) and its values."""

    key: str
    values: tuple[Any, ...]


def parse_assignment(text: str) -> Axis:
    """Parse ``KEY=V1,V2,...``; values are read as TOML scalars (``1e-6``, ``inf``,
    ``true``), anything else is taken as a string (``persson``)."""
    key, sep, values = text.partition("=")
    key = key.strip()
    if not sep or not key or not values.strip():
        raise SweepError(f"--set {text!r}: expected KEY=V1,V2,... (e.g. joint.temperature=280,300)")
    return Axis(key, tuple(_parse_value(value.strip()) for value in values.split(",")))


def _parse_value(text: str) -> Any:
    try:
        return tomllib.loads(f"value = {text}")["value"]
    except tomllib.TOMLDecodeError:
        return text


def _submodel(annotation: Any) -> tuple[type[BaseModel] | None, bool]:
    """The scenario table a field holds, and whether it is a list of such tables."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation, False
    if get_origin(annotation) is list:
        (item,) = get_args(annotation)
        if isinstance(item, type) and issubclass(item, BaseModel):
            return item, True
    return None, False


def key_field(key: str) -> FieldInfo:
    """The field a dotted scenario key refers to; SweepError if there is none."""
    parts = key.split(".")
    model: type[BaseModel] | None = Scenario
    info: FieldInfo | None = None
    i = 0
    while i < len(parts):
        where = ".".join(parts[:i]) or "the scenario"
        if model is None:
            raise SweepError(f"unknown key {key!r}: {where} is a value, not a table")
        info = model.model_fields.get(parts[i])
        if info is None:
            known = ", ".join(model.model_fields)
            raise SweepError(f"unknown key {key!r}: {where} has no {parts[i]!r} (keys: {known})")
        model, is_list = _submodel(info.annotation)
        i += 1
        if is_list:
            if i == len(parts) or not parts[i].isdigit():
                raise SweepError(f"key {key!r}: {'.'.join(parts[:i])} is a list; give an index")
            i += 1
    if model is not None or info is None:
        raise SweepError(f"key {key!r} is a table, not a value")
    return info


def key_attrs(key: str) -> dict[str, str]:
    """``units`` and ``long_name`` of a scenario key, from its field description."""
    description = key_field(key).description or key.rsplit(".", 1)[-1]
    unit = re.search(r"\[([^\]]+)\]", description)
    name = description.split(";")[0]
    name = re.sub(r"\s*\[[^\]]*\]", "", name).strip()
    return {"units": unit.group(1) if unit else "1", "long_name": f"{name} ({key})"}


def _assign(mapping: dict[str, Any], key: str, value: Any) -> None:
    """Set a dotted key in a nested scenario mapping (lists indexed by number)."""
    *path, last = key.split(".")
    node: Any = mapping
    for depth, part in enumerate([*path, last]):
        where = ".".join(path[:depth]) or "the scenario"
        if isinstance(node, list):
            index = int(part)
            if index >= len(node):
                raise SweepError(
                    f"key {key!r}: {where} has {len(node)} entries (indices 0-{len(node) - 1})"
                )
            part = index
        elif not isinstance(node, dict):
            raise SweepError(f"key {key!r}: {where} is not a table in the scenario file")
        if depth == len(path):
            node[part] = value
        else:
            node = node.setdefault(part, {}) if isinstance(node, dict) else node[part]


@dataclass(frozen=True)
class Task:
    """One run of a sweep: its position in the grid, parameters, seed and scenario."""

    index: int
    params: dict[str, Any]
    seed: int
    scenario: Scenario = field(repr=False)

    @property
    def name(self) -> str:
        """Task name, also the store name (``tasks/<name>.zarr``)."""
        return f"{self.index:04d}"

    @property
    def store(self) -> str:
        """Store path relative to the sweep directory."""
        return f"tasks/{self.name}.zarr"


def describe(entry: Mapping[str, Any]) -> str:
    """A manifest task entry as ``NNNN (key=value, ..., seed=n)``."""
    params = [f"{key}={value!r}" for key, value in entry["params"].items()]
    params.append(f"seed={entry['seed']}")
    return f"{entry['task']} ({', '.join(params)})"


@dataclass(frozen=True)
class Sweep:
    """A validated sweep: base scenario mapping (as read from TOML), axes and seeds."""

    base: dict[str, Any]
    axes: tuple[Axis, ...]
    seeds: tuple[int, ...]

    @classmethod
    def from_file(cls, path: str | Path, assignments: Sequence[str], n_seeds: int = 1) -> Sweep:
        """Read a scenario file and ``--set`` assignments; seeds are run.seed (or 0) + 0..n-1.

        Every key and every task's scenario is validated here, before anything runs.
        """
        path = Path(path)
        base = read_toml(path)
        if n_seeds < 1:
            raise SweepError(f"--seeds {n_seeds}: at least one seed is needed")
        axes = tuple(parse_assignment(text) for text in assignments)
        keys = [axis.key for axis in axes]
        for axis in axes:
            if axis.key == "run.seed":
                raise SweepError("run.seed is swept with --seeds N, not --set")
            if keys.count(axis.key) > 1:
                raise SweepError(f"key {axis.key!r} is set more than once")
            if len(set(map(repr, axis.values))) < len(axis.values):
                raise SweepError(f"key {axis.key!r}: repeated values {list(axis.values)}")
            key_field(axis.key)
        first = base.get("run", {}).get("seed", 0)
        if not isinstance(first, int) or first < 0:
            raise SweepError(f"{path}: run.seed = {first!r}; a non-negative integer is required")
        sweep = cls(base, axes, tuple(range(first, first + n_seeds)))
        sweep.tasks()
        return sweep

    @property
    def keys(self) -> list[str]:
        """The swept keys, in grid order."""
        return [axis.key for axis in self.axes]

    def tasks(self) -> list[Task]:
        """Every task, in C order over (*keys, seed); ScenarioError names a bad value."""
        tasks = []
        combos = itertools.product(*(axis.values for axis in self.axes), self.seeds)
        for index, (*values, seed) in enumerate(combos):
            params = dict(zip(self.keys, values, strict=True))
            mapping = copy.deepcopy(self.base)
            for key, value in params.items():
                _assign(mapping, key, value)
            source = "--set " + ", ".join(f"{k}={v!r}" for k, v in params.items())
            scenario = from_mapping(mapping, source=source if params else "scenario")
            tasks.append(Task(index, params, seed, scenario.with_seed(seed)))
        return tasks

    def identity(self) -> dict[str, Any]:
        """What makes two sweeps the same (compared when a directory is reused)."""
        spec = {
            "scenario": self.base,
            "keys": self.keys,
            "values": [list(axis.values) for axis in self.axes],
            "seeds": list(self.seeds),
        }
        return json.loads(json.dumps(spec))


class _Spec(BaseModel, extra="forbid"):
    """The ``sweep`` entry of a manifest (:meth:`Sweep.identity`)."""

    scenario: dict[str, Any]
    keys: list[str]
    values: list[list[Any]]
    seeds: list[int]


class _Entry(BaseModel, extra="forbid"):
    """One task of a manifest."""

    task: str
    params: dict[str, Any]
    seed: int
    store: str
    status: Status
    error: str | None
    wall_seconds: float | None


class _Manifest(BaseModel, extra="forbid"):
    """A sweep directory's ``sweep.json``."""

    format: Format
    nanoblock_version: str
    sweep: _Spec
    tasks: list[_Entry]


def read_manifest(directory: str | Path) -> dict[str, Any]:
    """The manifest of a sweep directory; SweepError if it is not one, or if its manifest
    is not valid JSON of the manifest's layout (naming the first problem)."""
    path = Path(directory) / MANIFEST
    if not path.exists():
        raise SweepError(f"{directory}: not a sweep directory (no {MANIFEST})")
    try:
        return _Manifest.model_validate_json(path.read_bytes()).model_dump()
    except ValidationError as error:
        first = error.errors()[0]
        where = ".".join(str(part) for part in first["loc"]) or "the file"
        raise SweepError(
            f"{path}: damaged manifest: {where}: {first['msg']}; the task stores under "
            f"{Path(directory) / 'tasks'} are kept: move the directory away to start again"
        ) from None


def _write_manifest(directory: Path, manifest: Mapping[str, Any]) -> None:
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / MANIFEST
    partial = path.with_suffix(".json.partial")
    partial.write_text(json.dumps(manifest, indent=1))
    os.replace(partial, path)


def is_finished(store: str | Path) -> bool:
    """Whether a run store exists and carries the completion marker."""
    run = RunStore(store)
    return run.exists() and bool(run.attrs.get("complete"))


def _damaged_entry(directory: Path, entry: dict[str, Any]) -> dict[str, Any]:
    """A finished task's manifest entry as ``failed`` when arrays or chunk files of its
    store are missing (read back as made-up coordinates or fill values otherwise; chunks
    are not decoded: a stat per chunk). The store is kept: the task runs again once it is
    moved away."""
    damage = RunStore(directory / entry["store"]).damage(read=False)
    if damage:
        entry.update(
            status="failed",
            error=f"{entry['store']} damaged ({'; '.join(damage)}): move it away to run "
            "the task again",
        )
    return entry


def _check_directory(directory: Path, sweep: Sweep) -> None:
    """Refuse a directory holding anything but this same sweep (nothing is overwritten)."""
    if (directory / MANIFEST).exists():
        stored = read_manifest(directory)["sweep"]
        if stored != sweep.identity():
            changed = [name for name in stored if stored[name] != sweep.identity().get(name)]
            raise SweepError(
                f"{directory} holds another sweep (different {', '.join(changed)}); "
                "choose another --out directory or delete it"
            )
    elif directory.exists() and any(directory.iterdir()):
        raise SweepError(
            f"{directory} exists and is not a sweep directory (no {MANIFEST}); "
            "choose another --out directory"
        )


def one_numba_thread() -> None:
    """Run this thread's kernels on one Numba thread.

    Numba's config is reloaded first: a LocalCluster worker gets :data:`WORKER_ENV` from
    its nanny only after its process has started, and a spawned worker may have imported
    numba before (with the parent's ``__main__``, e.g. a script importing nanoblock).
    Launching the thread pool with the stale size would make the next compilation in that
    worker (kernels not in Numba's cache) fail on the changed NUMBA_NUM_THREADS.
    """
    numba_config.reload_config()
    numba.set_num_threads(1)


def run_task(scenario_json: str, store: str, flush_seconds: float = FLUSH_SECONDS) -> float:
    """Run one task into its store (on a worker, one Numba thread), flushed every
    ``flush_seconds`` of wall time (default :data:`FLUSH_SECONDS`); wall seconds."""
    one_numba_thread()
    started = time.perf_counter()
    simulate(Scenario.from_json(scenario_json), store, flush_seconds=flush_seconds)
    return time.perf_counter() - started


def warm_up(scenario_json: str | None = None) -> float:
    """Pay, in this process, the one-off costs of its first task; wall seconds.

    A throwaway run of :data:`WARM_UP` into a temporary store, flushed at every sample,
    loads the compiled kernels from Numba's cache (or compiles them) and the code paths
    of creating, appending to and checkpointing a store; with
    ``scenario_json``, that scenario's run is also set up and advanced to its first sample
    (t = 0), which loads any kernel its options call from Python. Nothing else is kept.
    """
    one_numba_thread()
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="nanoblock-warm-up-") as tmp:
        scenario = from_mapping(tomllib.loads(WARM_UP), source="WARM_UP")
        simulate(scenario, Path(tmp) / "run.zarr", flush_seconds=0.0)
    if scenario_json is not None:
        Run(Scenario.from_json(scenario_json)).step_to_next_sample()
    return time.perf_counter() - started


def warm_workers(client: Client, scenario_json: str | None = None) -> dict[str, Any]:
    """Run :func:`warm_up` once on every worker of ``client``, all at once; per worker
    its seconds, or the exception it raised (a worker that fails to warm up is left to
    fail its tasks, which report the error). Both steps run in a thread of the worker
    (``asyncio.to_thread``): its event loop keeps answering the scheduler meanwhile, and
    the first, importing ``nanoblock.sweep``, is passed as standard-library calls, since
    unpickling a reference to this module would import it in the event loop."""
    client.run(asyncio.to_thread, importlib.import_module, __name__, on_error="return")
    return client.run(asyncio.to_thread, warm_up, scenario_json, on_error="return")


@contextmanager
def _interrupts_ignored_by_children() -> Iterator[None]:
    """Start processes that ignore SIGINT (the disposition survives their exec): Ctrl-C
    reaches the whole process group, and a LocalCluster's workers and nannies each printed
    a KeyboardInterrupt traceback while the client was shutting them down. The parent
    ignores it meanwhile too (the cluster's start, about 2 s); off the main thread, where
    signals cannot be set, nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextmanager
def dask_client(
    scheduler: str | None = None, workers: int | None = None, connect_timeout: float = 10.0
) -> Iterator[Client]:
    """A client of the cluster at ``scheduler``, or of a new LocalCluster of ``workers``
    single-threaded processes (default: one per CPU) with :data:`WORKER_ENV` and
    :data:`LOCAL_CONFIG`, whose workers ignore SIGINT and log errors only."""
    with ExitStack() as stack:
        if scheduler is None:
            stack.enter_context(dask.config.set(LOCAL_CONFIG))
            with _interrupts_ignored_by_children():
                cluster = LocalCluster(
                    n_workers=workers or os.cpu_count() or 1,
                    threads_per_worker=1,
                    processes=True,
                    env=WORKER_ENV,
                    dashboard_address=None,
                    silence_logs=logging.ERROR,
                )
            stack.enter_context(cluster)
            client = stack.enter_context(Client(cluster))
        else:
            try:
                client = stack.enter_context(Client(scheduler, timeout=connect_timeout))
            except (OSError, TimeoutError, ValueError) as error:
                raise SweepError(
                    f"cannot reach the Dask scheduler at {scheduler!r} "
                    f"within {connect_timeout:g} s ({error})"
                ) from None
        yield client


@dataclass
class SweepReport:
    """Outcome of :func:`run_sweep`: the manifest written, the tasks run this time, and
    where the wall time went (seconds): ``cluster_start`` (LocalCluster and client, or
    connecting to the scheduler), ``warm_up`` (:func:`warm_workers`), ``tasks`` (from
    the first submission to the last result) and ``cluster_stop``. Empty if nothing ran."""

    manifest: dict[str, Any]
    ran: list[str]
    timings: dict[str, float] = field(default_factory=dict)

    def entries(self, status: str) -> list[dict[str, Any]]:
        """Manifest entries of the tasks with this status (``done``, ``failed``, ...)."""
        return [entry for entry in self.manifest["tasks"] if entry["status"] == status]


def run_sweep(
    sweep: Sweep,
    directory: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    connect_timeout: float = 10.0,
    progress: bool = False,
    task_function: Callable[[str, str], float] = run_task,
) -> SweepReport:
    """Run every unfinished task of ``sweep`` on a Dask cluster, into ``directory``.

    Finished stores are skipped (``failed`` and kept when arrays or chunks of one are
    missing); unfinished ones resume from their checkpoints. Every
    worker is warmed up first (:func:`warm_workers`, with the first pending task's
    scenario). The manifest is rewritten after each task, with status ``done`` (and
    ``wall_seconds``), ``failed`` (and ``error``) or ``pending``.
    ``task_function(scenario_json, store)`` runs one task (default :func:`run_task`).
    SweepError if the directory holds something else or the scheduler cannot be reached
    (then nothing is written).
    """
    directory = Path(directory)
    _check_directory(directory, sweep)
    tasks = sweep.tasks()
    previous = {}
    if (directory / MANIFEST).exists():
        previous = {entry["task"]: entry for entry in read_manifest(directory)["tasks"]}
    entries = {}
    for task in tasks:
        done = is_finished(directory / task.store)
        entry = {
            "task": task.name,
            "params": task.params,
            "seed": task.seed,
            "store": task.store,
            "status": "done" if done else "pending",
            "error": None,
            "wall_seconds": previous.get(task.name, {}).get("wall_seconds") if done else None,
        }
        entries[task.name] = _damaged_entry(directory, entry) if done else entry
    manifest = {
        "format": FORMAT,
        "nanoblock_version": nanoblock.__version__,
        "sweep": sweep.identity(),
        "tasks": list(entries.values()),
    }
    pending = [task for task in tasks if entries[task.name]["status"] == "pending"]
    if not pending:
        _write_manifest(directory, manifest)
        return SweepReport(manifest, [])
    timings: dict[str, float] = {}
    started = time.perf_counter()
    with dask_client(scheduler, workers, connect_timeout) as client:
        _write_manifest(directory, manifest)
        connected = time.perf_counter()
        warm_workers(client, pending[0].scenario.resolved_json())
        warm = time.perf_counter()
        futures = {
            client.submit(
                task_function,
                task.scenario.resolved_json(),
                str((directory / task.store).resolve()),
                pure=False,
            ): task
            for task in pending
        }
        with tqdm(total=len(pending), unit="task", disable=not progress) as bar:
            for future in as_completed(futures):
                task = futures[future]
                entry = entries[task.name]
                try:
                    entry.update(status="done", wall_seconds=future.result())
                except Exception as error:  # any failure of one task is recorded, not raised
                    # a run that completed but whose worker died before returning is done
                    failed = not is_finished(directory / task.store)
                    entry["status"] = "failed" if failed else "done"
                    entry["error"] = f"{type(error).__name__}: {error}" if failed else None
                _write_manifest(directory, manifest)
                bar.update()
        finished = time.perf_counter()
    timings["cluster_start"] = connected - started
    timings["warm_up"] = warm - connected
    timings["tasks"] = finished - warm
    timings["cluster_stop"] = time.perf_counter() - finished
    return SweepReport(manifest, [task.name for task in pending], timings)


def open_sweep(directory: str | Path) -> xr.Dataset:
    """The finished runs of a sweep as one lazy (dask-backed) Dataset.

    Dims ``(*keys, seed, sample)``: one per swept key (coordinate = the values, with the
    key's ``units`` and ``long_name``), ``seed``, and ``sample``, the index of a run's
    stored samples. Variables are those of :data:`nanoblock.store.SAMPLES` as float64
    (``n_events`` too), plus the coordinate ``time`` [s] over all dims: runs may differ in
    length and sample times, so each keeps its own, NaN-padded after its last sample. A
    task not finished is all NaN and listed in ``attrs["missing_tasks"]``; coordinate
    ``task`` names each run's store (``tasks/<task>.zarr``). Nothing is loaded until
    computed. SweepError if arrays or chunks of a finished task's store are missing.
    """
    directory = Path(directory)
    manifest = read_manifest(directory)
    spec = manifest["sweep"]
    keys, seeds = spec["keys"], spec["seeds"]
    names = [entry["task"] for entry in manifest["tasks"]]
    finished = [entry for entry in manifest["tasks"] if is_finished(directory / entry["store"])]
    for entry in finished:
        if _damaged_entry(directory, entry)["status"] == "failed":
            raise SweepError(f"{directory}: {entry['error']}")
    runs = {
        entry["task"]: xr.open_zarr(directory / entry["store"], consolidated=False)
        for entry in finished
    }
    if not runs:
        raise SweepError(f"{directory}: no finished task yet")
    length = max(run.sizes["time"] for run in runs.values())
    shape = (*(len(values) for values in spec["values"]), len(seeds))
    dims = (*keys, "seed", "sample")

    def column(name: str, variable: str) -> da.Array:
        """One run's variable as float64, NaN-padded to ``length``."""
        run = runs.get(name)
        data = da.full(0, np.nan) if run is None else da.asarray(run[variable].data)
        padding = da.full(length - data.shape[0], np.nan)
        return da.concatenate([data.astype(np.float64), padding]).rechunk(TIME_CHUNK)

    def stacked(variable: str, meta: VariableSpec) -> xr.Variable:
        columns = da.stack([column(name, variable) for name in names])
        attrs = {"units": meta.units, "long_name": meta.long_name}
        return xr.Variable(dims, columns.reshape(*shape, length), attrs)

    data_vars = {name: stacked(name, meta) for name, meta in SAMPLES.items()}
    coords = {
        key: xr.Variable((key,), np.asarray(values), key_attrs(key))
        for key, values in zip(keys, spec["values"], strict=True)
    }
    coords["seed"] = xr.Variable(
        ("seed",), np.asarray(seeds), {"units": "1", "long_name": "random seed (run.seed)"}
    )
    coords["sample"] = xr.Variable(
        ("sample",), np.arange(length), {"units": "1", "long_name": "index of the stored sample"}
    )
    coords["time"] = stacked("time", COORDINATES["time"])
    coords["task"] = xr.Variable(
        dims[:-1],
        np.asarray(names).reshape(shape),
        {"units": "1", "long_name": "task name (run store tasks/<task>.zarr)"},
    )
    attrs = {
        "title": "nanoblock sweep",
        "sweep": json.dumps(spec),
        "missing_tasks": [name for name in names if name not in runs],
        "nanoblock_version": manifest["nanoblock_version"],
    }
    return xr.Dataset(data_vars, coords, attrs)


def sweep_summary(directory: str | Path) -> str:
    """Text summary of a sweep directory: keys, values, seeds, task counts, failures.
    A task counts as done when its store is finished, whatever the manifest says, and as
    failed when arrays or chunks of its finished store are missing."""
    directory = Path(directory)
    manifest = read_manifest(directory)
    spec = manifest["sweep"]
    entries = manifest["tasks"]
    for entry in entries:
        if is_finished(directory / entry["store"]):
            entry.update(status="done", error=None)
            _damaged_entry(directory, entry)
    counts = {status: sum(e["status"] == status for e in entries) for status in STATUSES}
    lines = [f"sweep                 {directory} ({manifest['format']})"]
    lines += [
        f"  {key} = {values}" for key, values in zip(spec["keys"], spec["values"], strict=True)
    ]
    lines.append(f"seeds                 {spec['seeds']}")
    lines.append(
        f"tasks                 {len(entries)}: "
        + ", ".join(f"{count} {status}" for status, count in counts.items())
    )
    lines += [
        f"failed                {describe(entry)}: {entry['error']}"
        for entry in entries
        if entry["status"] == "failed"
    ]
    return "\n".join(lines)
