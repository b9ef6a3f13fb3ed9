"""The driver: allocation, initial state, sampling, progress, storage and resumption.

:func:`simulate` turns a :class:`~nanoblock.params.Scenario` into an ``xarray.Dataset``
of samples (variables of :data:`nanoblock.store.SAMPLES`), optionally streaming into a
zarr store that a killed run resumes from. The physics lives in :mod:`nanoblock.kernels`.
"""

from __future__ import annotations

import sys
import time as wallclock
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numba
import numpy as np
import xarray as xr
from scipy.linalg import solve_banded
from tqdm.auto import tqdm

import nanoblock
from nanoblock.kernels._jit import cached
from nanoblock.kernels.blocks import landing_overshoot
from nanoblock.kernels.chain import reduced_stresses
from nanoblock.kernels.contacts import ageing_rate, total_contact_area
from nanoblock.kernels.layout import PARAMS, SLIDER
from nanoblock.kernels.rng import seed_streams
from nanoblock.kernels.stepper import advance_to_sample, following_velocity
from nanoblock.params import (
    Scenario,
    ScenarioError,
    check_feasible,
    requirements,
    resolve_seed,
)
from nanoblock.store import SAMPLES, SNAPSHOTS, RunStore, StoreError, dataset
from nanoblock.tables import hazard_table, lattice_hazard_table
from nanoblock.theory.meanfield import MeanFieldJoint, sample_q_stationary
from nanoblock.threads import ThreadBudget

COMPILING = (
    "compiling kernels (once after install): about {seconds:.0f} s on 2 cores, "
    "then loaded from the cache in seconds"
)
"""Shown on stderr, with a progress bar, when the kernels are not in Numba's cache."""

COMPILE_SECONDS = {"independent blocks": 20.0, "chains": 45.0}
"""Measured cold compile of the kernels a run needs, 2-core host of 2026-11-28, rounded
up [s]: independent blocks (the quickstart, 18 s) and chains, which also compile the chain
kernel (41 s) (``benchmarks/bench_quickstart.py``, ``compile`` and ``chain, compile``; on
2026-11-27 the same host took 31 and 82 s, before the helpers that were inlined at every
call site compiled once on their own; at 04:14 on 2026-11-28, the host running twice as
fast, 12 and 31 s: the estimate keeps the slower day's)."""

TRANSIENT_FORCE_STEP = 0.005
"""epsilon: in transients one internal step changes the force by at most epsilon alpha F."""

FLUSH_SECONDS = 5.0
"""Default wall time [s] between flushes of samples, checkpoint and progress attrs to the
store (per run: ``simulate(..., flush_seconds=)``, ``nanoblock run --flush-seconds``)."""


def kernel_parameters(scenario: Scenario) -> np.ndarray:
    """The one-element :data:`~nanoblock.kernels.layout.PARAMS` record of a scenario."""
    joint, interface = scenario.joint, scenario.interface
    omega1_sq = joint.k1 / joint.block_mass
    kappa = joint.k2 / joint.k1
    params = np.zeros(1, dtype=PARAMS)
    record = params[0]
    record["omega_a"] = joint.attempt_frequency
    record["kappa"] = kappa
    record["slip_chain"] = 1 if joint.slip == "chain" else 0
    record["hop_period"] = 1.0 if joint.back_jumps else 0.0
    for name, neighbours in (("eta_free", 0), ("eta_end", 1), ("eta_interior", 2)):
        record[name] = landing_overshoot(omega1_sq * (1 + neighbours * kappa), joint.damping)
    record["omega1_sq"] = omega1_sq
    record["damping"] = joint.damping
    record["memory_length"] = interface.memory_length
    second = interface.second_memory_length
    record["memory_length2"] = interface.memory_length if second is None else second
    record["second_from"] = interface.n_contacts - interface.second_contacts
    record["aging_m"] = interface.aging_m
    record["aging_time"] = interface.aging_time
    cutoff = interface.state_cutoff_velocity
    record["state_cutoff"] = 0.0 if cutoff is None else cutoff
    record["contact_area"] = interface.real_area / interface.n_contacts
    record["stiffness"] = scenario.loading.stiffness
    record["step_slip"] = scenario.step_slip
    record["force_step"] = TRANSIENT_FORCE_STEP / (2.0 * joint.u)  # epsilon alpha, alpha = 1/2u
    return params


def protocol_table(scenario: Scenario) -> np.ndarray:
    """``(3, S + 1)`` segment start times [s], velocities [m/s] and start positions [m]."""
    steps = scenario.loading.steps
    durations = np.array([step.length for step in steps])
    velocities = np.array([step.load_velocity for step in steps])
    starts = np.concatenate(([0.0], np.cumsum(durations)))
    positions = np.concatenate(([0.0], np.cumsum(durations * velocities)))
    starts[-1] = np.inf  # the last segment runs on: sample times never leave the protocol
    return np.vstack((starts, np.append(velocities, 0.0), positions))


def mean_field_joint(scenario: Scenario) -> MeanFieldJoint:
    """The joint as seen by the analytic mean-field theory (001/Eqs. 24-30), with the
    catalogue options the theory honours (back jumps, strength classes; softening is
    already in the resolved sigma_a)."""
    joint = scenario.joint
    return MeanFieldJoint(
        block_size=joint.block_size,
        shear_modulus=joint.shear_modulus,
        threshold_stress=joint.threshold_stress,
        k1=joint.k1,
        attempt_frequency=joint.attempt_frequency,
        temperature=joint.temperature,
        barrier=joint.barrier,
        back_jumps=joint.back_jumps,
        threshold_spread=joint.threshold_spread,
        strength_classes=joint.strength_classes,
    )


def strength_classes(scenario: Scenario) -> np.ndarray:
    """``strength[k] = (sigma_a, rho~_max)`` [Pa, m] of each strength class
    (:mod:`nanoblock.kernels.layout`; one class without a threshold spread)."""
    members = mean_field_joint(scenario).classes()
    return np.array([(member.threshold_stress, member.rho_max) for member in members])


def hazard_tables(scenario: Scenario) -> np.ndarray:
    """``tables[k]``: the packed hazard table of each strength class (with back jumps, the
    forward and reverse tables of :func:`nanoblock.tables.lattice_hazard_table`)."""
    members = mean_field_joint(scenario).classes()
    if scenario.joint.back_jumps:
        return np.vstack([lattice_hazard_table(m.barrier, m.u, m.u_elastic) for m in members])
    return np.vstack([hazard_table(m.barrier, m.u) for m in members])


@dataclass
class InterfaceState:
    """Every array the kernels evolve; with the slider record it is a full checkpoint."""

    y: np.ndarray  # (contact, block) reduced stretch s / rho_max
    h: np.ndarray  # (contact, block) remaining hazard
    age: np.ndarray  # (contact,) [s]
    slip: np.ndarray  # (contact,) slip since birth [m]
    lifetime: np.ndarray  # (contact,) slip lifetime [m]
    events: np.ndarray  # (contact,) cumulative depinnings
    streams: np.ndarray  # (contact, 4) uint64 random streams
    slider: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=SLIDER))

    def arrays(self) -> dict[str, np.ndarray]:
        """The state as named arrays (the slider record as a float/int pair)."""
        names = ("y", "h", "age", "slip", "lifetime", "events", "streams")
        out = {name: getattr(self, name) for name in names}
        out["slider"] = self.slider.view(np.uint8)
        return out

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> InterfaceState:
        """Inverse of :meth:`arrays`."""
        slider = np.ascontiguousarray(arrays.pop("slider")).view(SLIDER).copy()
        fields = {name: np.ascontiguousarray(value) for name, value in arrays.items()}
        return cls(slider=slider, **fields)


def _chain_stretch(stress: np.ndarray, kappa: float) -> np.ndarray:
    """Solve (1 + kappa L) z = x along each chain (L: free-end Laplacian) for z."""
    n = stress.shape[1]
    if kappa == 0.0 or n == 1:
        return stress.copy()
    bands = np.zeros((3, n))
    bands[0, 1:] = -kappa
    bands[2, :-1] = -kappa
    neighbours = np.full(n, 2.0)
    neighbours[[0, -1]] = 1.0
    bands[1] = 1.0 + kappa * neighbours
    return solve_banded((1, 1), bands, stress.T).T


def contact_memory_lengths(scenario: Scenario) -> np.ndarray:
    """D0 of every contact [m]: ``memory_length``, and ``second_memory_length`` for the
    last ``second_contacts`` (the kernels' :func:`~nanoblock.kernels.contacts.memory_length`)."""
    interface = scenario.interface
    memory = np.full(interface.n_contacts, interface.memory_length)
    if interface.second_memory_length is not None:
        memory[interface.n_contacts - interface.second_contacts :] = interface.second_memory_length
    return memory


def initial_state(
    scenario: Scenario, params: np.ndarray, strength: np.ndarray | None = None
) -> InterfaceState:
    """The interface at t = 0: unloaded (all blocks at zero stress, newborn contacts) or
    steady (stresses from the stationary mean-field state at the first velocity, Q_st of
    001/Eq. 27 per strength class, or the two-branch state with back jumps; contact ages
    and remaining lifetimes from the stationary renewal process, both Exp, with means
    D0 / V times the ageing-clock rate, i.e. D0 / (V + v_theta) with a state cutoff, and
    D0). ``strength``: :func:`strength_classes`, computed if not given."""
    seed = scenario.run.seed
    interface = scenario.interface
    shape = (interface.n_contacts, interface.blocks_per_contact)
    strength = strength_classes(scenario) if strength is None else strength
    n_classes = strength.shape[0]
    contact_seed, setup_seed = np.random.SeedSequence(seed).spawn(2)
    streams = seed_streams(int(contact_seed.generate_state(1)[0]), shape[0])
    setup = np.random.default_rng(setup_seed)
    memory = contact_memory_lengths(scenario)
    h = setup.standard_exponential(shape)
    lifetime = memory * setup.standard_exponential(shape[0])
    if scenario.run.initial_state == "unloaded":
        y = np.zeros(shape)
        age = np.zeros(shape[0])
    else:
        velocity = scenario.loading.first_velocity
        y = np.empty(shape)
        for k, member in enumerate(mean_field_joint(scenario).classes()):
            rows = y[k::n_classes]
            rho = sample_q_stationary(rows.size, velocity, member, setup)
            rows[:] = rho.reshape(rows.shape) / member.rho_max
        y = _chain_stretch(y, float(params[0]["kappa"]))
        clock = ageing_rate(velocity, params[0])
        with np.errstate(invalid="ignore"):  # inf x 0 where D0 = inf: newborn, age 0
            age = (memory / velocity) * clock * setup.standard_exponential(shape[0])
        age[~np.isfinite(memory)] = 0.0
    slip = np.zeros(shape[0])
    events = np.zeros(shape[0], dtype=np.int64)
    state = InterfaceState(y, h, age, slip, lifetime, events, streams)
    slider = state.slider[0]
    area = total_contact_area(age, params[0])
    forces = (area * sigma_a * y[k::n_classes].mean() for k, (sigma_a, _) in enumerate(strength))
    slider["force"] = sum(forces) / n_classes
    slider["stiffness"] = area * strength[0, 0] / strength[0, 1]
    # the slider starts at the load point's velocity: the pinned response plus the drift
    load_velocity = scenario.loading.steps[0].load_velocity
    following = following_velocity(
        load_velocity, float(slider["stiffness"]), scenario.loading.stiffness
    )
    slider["drift"] = slider["smooth_drift"] = load_velocity - following
    slider["smooth_noise"] = abs(load_velocity - following)  # not measured yet
    if np.isfinite(scenario.loading.stiffness):
        # start in balance: the drive spring already carries the initial interface force
        slider["load_point"] = 0.0
        slider["position"] = -slider["force"] / scenario.loading.stiffness
    return state


def sample_times(scenario: Scenario) -> np.ndarray:
    """Stored sample times: every ``record_every`` from 0, plus the protocol's end [s]."""
    total = scenario.total_time
    step = scenario.run.record_every
    times = np.arange(0.0, total, step)
    times = times[times < total - 1e-9 * step]
    return np.append(times, total)


class Run:
    """One simulation: the scenario, the kernel inputs and the evolving state."""

    def __init__(self, scenario: Scenario, times: np.ndarray | None = None) -> None:
        """``times``: the sample times [s], increasing (default :func:`sample_times`)."""
        if scenario.run.seed is None:
            raise ScenarioError("run.seed must be resolved before a run (see resolve_seed)")
        self.scenario = scenario
        self.params = kernel_parameters(scenario)
        self.strength = strength_classes(scenario)
        self.tables = hazard_tables(scenario)
        self.protocol = protocol_table(scenario)
        self.times = sample_times(scenario) if times is None else np.asarray(times, dtype=float)
        self.state = initial_state(scenario, self.params, self.strength)
        self.scratch = np.zeros((3, scenario.interface.n_contacts))
        self.edges = np.empty(self.strength.shape[0], dtype=np.int64)
        chains = scenario.interface.blocks_per_contact > 1 and self.params[0]["kappa"] != 0.0
        # the parallel contact loop runs nested in the stepper, where Numba does not launch
        # its thread pool: without this a first step outside simulate() segfaulted
        numba.get_num_threads()
        self.coupled = True if chains else None  # None: the chain kernel is never compiled
        self.next_sample = 0
        self.snapshots_taken = 0
        self.last_position = float(self.state.slider[0]["position"])

    def _kernel_state(self) -> tuple[np.ndarray, ...]:
        s = self.state
        return (s.y, s.h, s.age, s.slip, s.lifetime)

    def kernel_arguments(self, t: float) -> tuple[Any, ...]:
        """The arguments of :func:`~nanoblock.kernels.stepper.advance_to_sample` to ``t`` [s]."""
        s = self.state
        return (
            t,
            s.slider,
            self._kernel_state(),
            s.streams,
            s.events,
            self.scratch,
            self.edges,
            self.params,
            self.strength,
            self.tables,
            self.coupled,
            self.protocol,
        )

    def step_to_next_sample(self) -> dict[str, float]:
        """Advance to the next sample time, balance the slider, and return the sample."""
        s = self.state
        t = self.times[self.next_sample]
        try:
            advance_to_sample(*self.kernel_arguments(t))
        except ArithmeticError as error:  # a kernel's division by zero or overflow
            joint, interface = self.scenario.joint, self.scenario.interface
            raise ScenarioError(
                f"the engine's arithmetic failed before t = {t:.4g} s ({type(error).__name__}: "
                f"{error}): a derived scale leaves what it resolves (joint.rho_max = "
                f"{joint.rho_max:.3g} m from joint.k1 = {joint.k1:.3g} N/m, "
                f"interface.memory_length = {interface.memory_length:.3g} m, run.step_slip = "
                f"{self.scenario.step_slip:.3g} m); use values within physical ranges"
            ) from None
        slider = s.slider[0]
        interval = self.scenario.run.record_every
        position = float(slider["position"])
        if self.next_sample:
            velocity = (position - self.last_position) / interval
        else:
            velocity = self.scenario.loading.steps[0].load_velocity
        self.last_position = position
        self.next_sample += 1
        force = float(slider["force"])
        return {
            "time": t,
            "friction_force": force,
            "friction_coefficient": force / self.scenario.interface.normal_force,
            "slider_displacement": position,
            "load_point_displacement": float(slider["load_point"]),
            "slider_velocity": velocity,
            "mean_contact_age": float(s.age.mean()),
            "real_contact_area": total_contact_area(s.age, self.params[0]),
            "n_events": int(s.events.sum()),
        }

    def snapshot(self) -> dict[str, np.ndarray]:
        """Block-level state now: stresses [Pa], positions [m], pinned flags, ages [s]."""
        s = self.state
        record = self.params[0]
        self.snapshots_taken += 1
        sigma_a, rho_max = self.strength[np.arange(s.y.shape[0]) % self.strength.shape[0]].T
        stress = reduced_stresses(s.y, float(record["kappa"])) * sigma_a[:, None]
        position = float(s.slider[0]["position"]) - s.y * rho_max[:, None]
        return {
            "snapshot_time": np.array([self.times[self.next_sample - 1]]),
            "block_stress": stress[None],
            "block_position": position[None],
            "block_pinned": np.ones((1, *s.y.shape), dtype=bool),
            "contact_age": s.age[None].copy(),
        }

    @property
    def done(self) -> bool:
        """Whether every sample has been computed."""
        return self.next_sample >= self.times.size

    @property
    def simulated_time(self) -> float:
        """Simulated time of the last computed sample [s] (0 before the first)."""
        return float(self.times[self.next_sample - 1]) if self.next_sample else 0.0

    def checkpoint(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Arrays and progress needed to resume exactly from the current sample."""
        progress = {
            "samples": self.next_sample,
            "last_position": self.last_position,
            "simulated_time": self.simulated_time,
            "snapshots": self.snapshots_taken,
        }
        return self.state.arrays(), progress

    def progress(self, wall_seconds: float) -> dict[str, Any]:
        """Machine-readable progress: simulated and end time [s], fraction done, samples,
        cumulative depinnings, and the wall time spent on the run so far [s]."""
        end = float(self.scenario.total_time)
        return {
            "simulated_time": self.simulated_time,
            "end_time": end,
            "fraction": self.simulated_time / end,
            "samples": self.next_sample,
            "events": int(self.state.events.sum()),
            "wall_seconds": float(wall_seconds),
        }

    def restore(self, arrays: dict[str, np.ndarray], progress: dict[str, Any]) -> None:
        """Continue from a checkpoint written by :meth:`checkpoint`."""
        self.state = InterfaceState.from_arrays(dict(arrays))
        self.next_sample = int(progress["samples"])
        self.last_position = float(progress["last_position"])
        self.snapshots_taken = int(progress.get("snapshots", 0))


def provenance(scenario: Scenario) -> dict[str, Any]:
    """Root attributes that make a store reproducible on its own."""
    return {
        "scenario": scenario.resolved_json(),
        "seed": int(scenario.run.seed),
        "nanoblock_version": nanoblock.__version__,
        "numba_version": numba.__version__,
        "numpy_version": np.__version__,
        "title": "nanoblock run",
        "complete": False,
    }


def _stack(samples: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    return {key: np.array([sample[key] for sample in samples]) for key in samples[0]}


def _concat_snapshots(snaps: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    return {key: np.concatenate([snap[key] for snap in snaps]) for key in snaps[0]}


def _snapshot_dataset(snaps: list[dict[str, np.ndarray]]) -> xr.Dataset:
    return dataset(_concat_snapshots(snaps), SNAPSHOTS, "snapshot_time")


def expected_work(scenario: Scenario) -> Callable[[float], float]:
    """Percentage of a run's expected depinnings done by simulated time t [s]: thermal
    escapes at the unloaded rate plus one per rho~_max of load-point travel and block
    (the estimate of :func:`nanoblock.params.requirements`), so a progress bar and its ETA
    follow the work, not the simulated time (a hold costs little, a fast segment much)."""
    needs = requirements(scenario)
    lengths = np.array([step.length for step in scenario.loading.steps])
    times = np.concatenate([[0.0], np.cumsum(lengths)])
    travel = np.concatenate(
        [[0.0], np.cumsum([step.load_velocity * step.length for step in scenario.loading.steps])]
    )

    def per_block(t: float) -> float:
        return (
            needs.thermal_rate * t + float(np.interp(t, times, travel)) * needs.crossings_per_travel
        )

    total = per_block(float(times[-1]))
    if not total > 0.0:
        return lambda t: 100.0 * t / max(float(times[-1]), 1e-300)
    return lambda t: 100.0 * per_block(t) / total


def simulate(
    scenario: Scenario,
    store: str | Path | None = None,
    *,
    seed: int | None = None,
    progress: bool = False,
    flush_seconds: float | None = None,
    lazy: bool = True,
) -> xr.Dataset:
    """Run ``scenario`` and return its samples as an ``xarray.Dataset``.

    With ``store``, samples stream into a zarr v3 store as the run goes, flushed with a
    checkpoint and the ``progress`` attrs every ``flush_seconds`` of wall time (default
    :data:`FLUSH_SECONDS`); if the store holds an unfinished run of the same scenario, the
    run resumes from its last checkpoint, and the store is returned opened lazily (dask
    arrays), or with ``lazy=False`` its samples only, read into memory without dask
    (:meth:`~nanoblock.store.RunStore.load_samples`). Without a store, the Dataset (with block
    snapshots if ``run.snapshot_every`` > 0) is built in memory. ``progress`` shows a
    progress bar (share of the expected depinnings done, slider slip since the run or its
    resume started, events/s, and an ETA from the work done), preceded on stderr by
    :data:`COMPILING` when the kernels are not in Numba's cache yet. A run this machine
    cannot hold or finish is refused before anything is allocated (``ScenarioError``, see
    :func:`~nanoblock.params.check_feasible`).
    """
    scenario = resolve_seed(scenario, seed)
    check_feasible(scenario)
    run = Run(scenario)
    if progress and not cached(advance_to_sample, run.kernel_arguments(0.0)):
        kind = "independent blocks" if run.coupled is None else "chains"
        print(COMPILING.format(seconds=COMPILE_SECONDS[kind]), file=sys.stderr, flush=True)
    writer = RunStore(store) if store is not None else None
    interval = FLUSH_SECONDS if flush_seconds is None else flush_seconds
    previous = None
    if writer is not None and writer.exists():
        previous = _resume(run, writer)
    fresh = previous is None
    wall_before = 0.0 if previous is None else float(previous.get("wall_seconds", 0.0))
    samples: list[dict[str, Any]] = []
    snaps: list[dict[str, np.ndarray]] = []
    every = scenario.run.snapshot_every
    all_samples: list[dict[str, Any]] = []
    all_snaps: list[dict[str, np.ndarray]] = []
    last_flush = wallclock.perf_counter()
    work = expected_work(scenario)
    bar = tqdm(
        total=100.0,
        initial=work(run.simulated_time),
        disable=not progress,
        leave=False,
        bar_format="{l_bar}{bar}| {n:.0f}% of the work [{elapsed}<{remaining}{postfix}]",
    )
    started = wallclock.perf_counter()
    events_at_start = int(run.state.events.sum())
    origin = None
    with ThreadBudget() as budget:
        while not run.done:
            budget.update()
            sample = run.step_to_next_sample()
            samples.append(sample)
            if every and (run.next_sample - 1) % every == 0:
                snaps.append(run.snapshot())
            bar.update(work(sample["time"]) - bar.n)
            rate = (sample["n_events"] - events_at_start) / max(
                wallclock.perf_counter() - started, 1e-9
            )
            origin = sample["slider_displacement"] if origin is None else origin
            slip = sample["slider_displacement"] - origin
            bar.set_postfix_str(f"slip {slip:.3g} m, {rate:.3g} events/s", refresh=False)
            now = wallclock.perf_counter()
            if writer is not None and (run.done or now - last_flush > interval):
                _flush(run, writer, samples, snaps, fresh, wall_before + now - started)
                fresh = False
                samples, snaps = [], []
                last_flush = now
            elif writer is None:
                all_samples.extend(samples)
                all_snaps.extend(snaps)
                samples, snaps = [], []
    bar.close()
    if writer is not None:
        writer.update_attrs(complete=True)
        return writer.open() if lazy else writer.load_samples()
    result = dataset(_stack(all_samples), SAMPLES, "time").assign_attrs(provenance(scenario))
    result.attrs["complete"] = True
    if all_snaps:
        result = xr.merge([result, _snapshot_dataset(all_snaps)], combine_attrs="override")
    return result


def friction_at(
    scenario: Scenario,
    times: np.ndarray,
    *,
    seed: int | None = None,
    threads: int | None = None,
    progress: bool = False,
) -> np.ndarray:
    """The friction coefficient of ``scenario``'s run at ``times`` [s] (increasing), each a
    balanced sample as :func:`simulate` stores it; nothing else is recorded (no Dataset,
    store or progress bar), for callers that need the friction at given instants only.

    The run is the one :func:`simulate` makes with ``times`` as its sample times: at its
    own :func:`sample_times` it returns ``simulate(scenario)["friction_coefficient"]``
    exactly; the same seed and times give the same values on any thread count.
    ``threads``: Numba threads for the contact loop (default: the cores other processes
    leave idle, :class:`~nanoblock.threads.ThreadBudget`; set per calling thread, so runs
    on concurrent Python threads each take their own). ``progress`` prints
    :data:`COMPILING` when the kernels are not in Numba's cache.
    """
    scenario = resolve_seed(scenario, seed)
    check_feasible(scenario)
    run = Run(scenario, times)
    if progress and not cached(advance_to_sample, run.kernel_arguments(0.0)):
        kind = "independent blocks" if run.coupled is None else "chains"
        print(COMPILING.format(seconds=COMPILE_SECONDS[kind]), file=sys.stderr, flush=True)
    force = np.empty(run.times.size)
    before = numba.get_num_threads()
    if threads is not None:
        numba.set_num_threads(threads)
    try:
        with ThreadBudget() if threads is None else nullcontext() as budget:
            for i, t in enumerate(run.times):
                if budget is not None:
                    budget.update()
                advance_to_sample(*run.kernel_arguments(t))
                force[i] = run.state.slider["force"][0]
    finally:
        numba.set_num_threads(before)
    return force / scenario.interface.normal_force


def _flush(run: Run, writer: RunStore, samples, snaps, fresh: bool, wall: float) -> None:
    block = dataset(_stack(samples), SAMPLES, "time")
    if fresh:
        writer.create(block, provenance(run.scenario))
    else:
        writer.append(block)
    if snaps:
        writer.append_snapshots(_snapshot_dataset(snaps))
    arrays, checkpoint = run.checkpoint()
    writer.write_checkpoint(arrays, checkpoint, run.progress(wall))


def _resume(run: Run, writer: RunStore) -> dict[str, Any] | None:
    """Prepare ``run`` to continue the run stored in ``writer``: the stored ``progress``
    attrs, or None to start afresh."""
    stored = writer.attrs
    if stored.get("scenario") != run.scenario.resolved_json():
        raise ScenarioError(
            f"{writer.path} holds a run of another scenario (or seed); "
            "choose another --out path or delete the store"
        )
    checkpoint = writer.read_checkpoint()
    if checkpoint is None:
        return None
    arrays, progress = checkpoint
    missing = sorted({f.name for f in fields(InterfaceState)} - set(arrays))
    if missing:  # a store written before checkpoint slots listed their arrays
        raise StoreError(
            f"{writer.path}: checkpoint damaged (arrays {', '.join(missing)} missing): "
            "the run cannot be resumed on its own trajectory"
        )
    if arrays["slider"].size != SLIDER.itemsize:  # a store of a version with another layout
        raise StoreError(
            f"{writer.path}: checkpoint holds a slider record of {arrays['slider'].size} "
            f"bytes, this nanoblock's has {SLIDER.itemsize} (written by another version): "
            "the run cannot be resumed on its own trajectory; run it into a new --out path"
        )
    writer.truncate(int(progress["samples"]), int(progress.get("snapshots", 0)))
    run.restore(arrays, progress)
    return dict(stored.get("progress", {}))
