"""Benchmark of the core simulator (issue 2): throughput, scaling and memory.

Run: ``python benchmarks/bench_core.py [--quick] [--table | --steps]`` (``--table``: only the
stiffness tables of issue 16, events/s from K/W = 1e2 1/m to a rigid drive in steady
sliding and the wall time of whole protocols with holds, one thread; ``--steps``: only
the free-block kernel's cost against the length of a finite spring's steps).
Prints a Markdown table and updates ``benchmarks/results_core.json``. Each measurement
runs in a fresh subprocess with the thread count set by NUMBA_NUM_THREADS (compilation is
cached and excluded by a warm-up).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from host import describe

ROOT = Path(__file__).resolve().parents[1]

WORKER = r"""
import json, sys, tempfile, time, shutil
sys.path.insert(0, sys.argv[1])
import numpy as np
from tests.conftest import scenario, RHO_MAX
from nanoblock.engine import simulate
spec = json.loads(sys.argv[2])
def build(slip_rho):
    return scenario(
        joint=spec["joint"],
        interface={"n_contacts": spec["contacts"], "blocks_per_contact": spec["blocks"]},
        loading={"stiffness": spec.get("stiffness", float("inf")),
                 "steps": [{"velocity": spec["velocity"], "displacement": slip_rho * RHO_MAX}]},
        run={"record_every": spec.get("record_rho", 5) * RHO_MAX / spec["velocity"],
             "initial_state": "steady", "seed": 1},
    )
simulate(build(2))  # warm-up: compile or load the cache
store = tempfile.mkdtemp() + "/bench.zarr" if spec.get("store") else None
started = time.perf_counter()
result = simulate(build(spec["slip_rho"]), store)
wall = time.perf_counter() - started
events = int(result.n_events[-1])
slip = float(result.slider_displacement[-1] - result.slider_displacement[0])
print(json.dumps({"wall": wall, "events": events, "slip": slip}))
"""

NAIVE = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np
from tests.naive_meanfield import simulate_mean_field
n, velocity = 100_000, 1e-6
rng = np.random.default_rng(1)
x = rng.uniform(0, 0.85, n)
started = time.perf_counter()
_, events = simulate_mean_field(x, velocity, 2.75e-10, 1e12, 50.21, 2.75e-10 / velocity, 1e-7,
                                rng, 10**9)
print(json.dumps({"wall": time.perf_counter() - started, "events": events}))
"""

RELAX = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np
from tests.conftest import scenario, RHO_MAX
from nanoblock.engine import Run
spec = json.loads(sys.argv[2])
def build(stiffness, velocity, slip_rho):
    return scenario(
        joint=spec["joint"],
        interface={"n_contacts": spec["contacts"], "blocks_per_contact": spec["blocks"]},
        loading={"stiffness": stiffness,
                 "steps": [{"velocity": velocity, "displacement": slip_rho * RHO_MAX}]},
        run={"record_every": 5 * RHO_MAX / velocity, "initial_state": "steady", "seed": 1},
    )
def relax(velocity):
    # a rigid drive's run-in of relax_rho at the velocity, and its friction force by sample
    run = Run(build(float("inf"), velocity, spec["relax_rho"]))
    forces = []
    while not run.done:
        forces.append(run.step_to_next_sample()["friction_force"])
    return run, forces
"""
"""The stiffness and step tables' workers start from the same relaxed interface."""

TABLE = (
    RELAX
    + r"""
from nanoblock.engine import simulate
from nanoblock.kernels.stepper import following_velocity
def relaxed(velocity):
    # the relaxed interface and its mean friction force from 15 rho on
    pre, forces = relax(velocity)
    return pre.state, float(np.mean(forces[3:]))
def cell(stiffness, velocity, start, mean_force):
    # the cell's run, its interface replaced by the relaxed one and the spring stretched
    # to the mean friction force (a finite spring; as engine.initial_state, with the
    # blocks' own force, for its "steady" state)
    run = Run(build(stiffness, velocity, spec["slip_rho"]))
    state = run.state
    for name in ("y", "h", "age", "slip", "lifetime", "streams"):
        getattr(state, name)[...] = getattr(start, name)
    slider, relaxed_slider = state.slider[0], start.slider[0]
    slider["force"] = relaxed_slider["force"]
    slider["stiffness"] = k_int = relaxed_slider["stiffness"]
    drift = velocity - following_velocity(velocity, k_int, stiffness)
    slider["drift"] = slider["smooth_drift"] = drift
    slider["smooth_noise"] = abs(drift)
    if np.isfinite(stiffness):
        slider["position"] = -mean_force / stiffness
    return run
simulate(build(1e6, 1e-6, 2))  # warm-up: compile or load the cache
rates = {}
for velocity in spec["velocities"]:
    start, mean_force = relaxed(velocity)
    for stiffness in spec["stiffnesses"]:
        walls, counts = [], set()
        for _ in range(spec["repeats"]):  # the same trajectory each time: the best wall
            run = cell(stiffness, velocity, start, mean_force)
            started = time.perf_counter()
            while not run.done:
                run.step_to_next_sample()
            walls.append(time.perf_counter() - started)
            counts.add(int(run.state.events.sum()))
        assert len(counts) == 1, counts
        rates[f"{velocity:g} {stiffness:g}"] = counts.pop() / min(walls)
print(json.dumps(rates))
"""
)

PROTOCOLS = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
from nanoblock.engine import Run
from nanoblock.params import load_scenario
spec = json.loads(sys.argv[2])
quickstart = load_scenario(spec["scenario"])
def build(name, ratio):
    weight = quickstart.interface.normal_force
    loading = {"stiffness": ratio * weight}
    run = {}
    if name == "creep":  # issue 16's stiff frame: 1 nm/s, a hold, a reload
        step = type(quickstart.loading.steps[0])
        loading["steps"] = [step(velocity=1e-9, displacement=150e-9), step(hold=100.0),
                            step(velocity=1e-9, displacement=50e-9)]
        run = {"record_every": 1.0}
    return quickstart.model_copy(update={
        "loading": quickstart.loading.model_copy(update=loading),
        "run": quickstart.run.model_copy(update=run)})
def timed(scenario):
    run = Run(scenario)
    started = time.perf_counter()
    while not run.done:
        run.step_to_next_sample()
    return time.perf_counter() - started, int(run.state.events.sum())
timed(build("quickstart", 1e12))  # warm-up: compile or load the cache
rates = {}
for name in ("quickstart", "creep"):
    for ratio in spec["ratios"]:
        wall, events = min(timed(build(name, ratio)) for _ in range(2))
        rates[f"{name} {ratio:g}"] = {"wall": wall, "events_per_s": events / wall}
print(json.dumps(rates))
"""

STEPS = (
    RELAX
    + r"""
from numba import njit
from nanoblock.kernels.blocks import advance_free_blocks, split_edge
velocity = spec["velocity"]
relaxed, _ = relax(velocity)
state, table = relaxed.state, relaxed.tables[0]
rho, omega_a = relaxed.strength[0, 1], relaxed.params[0]["omega_a"]
@njit
def passes(y, h, streams, x_rate, duration, edge, n):
    # n slider steps of every contact's blocks, as the stepper makes them (no jump)
    events = 0
    for _ in range(n):
        for c in range(y.shape[0]):
            events += advance_free_blocks(y[c], h[c], 0.0, x_rate, duration, 0.0, omega_a,
                                          table, streams[c], 0.0, edge)
    return events
out = {}
for step in spec["steps"]:  # step length [rho~_max of slip]
    duration = step * rho / velocity
    edge = split_edge(table, omega_a, velocity / rho, duration)
    n = max(1, int(round(spec["slip_rho"] / step))) if step >= 1e-3 else spec["cold_passes"]
    walls, counts = [], set()
    for _ in range(spec["repeats"] + 1):  # the first compiles
        y, h, streams = state.y.copy(), state.h.copy(), state.streams.copy()
        started = time.perf_counter()
        counts.add(passes(y, h, streams, velocity / rho, duration, edge, n))
        walls.append(time.perf_counter() - started)
    assert len(counts) == 1, counts
    events = counts.pop()
    wall = min(walls[1:])
    out[f"{step:g}"] = {"ns_per_block_step": 1e9 * wall / (n * y.size),
                        "ns_per_depinning": 1e9 * wall / events if events else None,
                        "depinnings_per_block_step": events / (n * y.size)}
print(json.dumps(out))
"""
)

STEP_LENGTHS = [1e-6, 1 / 32, 1 / 16, 1 / 8, 1 / 4, 4.0]
"""Slip per call of the free-block kernel in :func:`step_costs` [rho~_max]: the cold floor
(no block near its threshold), the finite spring's steps (default 1/8) and a rigid
drive's long ramps."""

PROTOCOL_RATIOS = [2e6, 1e9, 1e12, 1e14, float("inf")]
"""K/W [1/m] of the protocol table: the quick start's own spring to 1e14 and rigid."""

STIFFNESSES = [1e2, 1e4, 1e6, 1e9, 1e12, float("inf")]
"""Drive stiffnesses K of the stiffness table [N/m]; the scenarios' W = 1 N, so K/W [1/m]."""

TABLE_VELOCITIES = [1e-9, 1e-6, 1e-3]
"""Load-point velocities of the stiffness table [m/s]."""

RELAX_RHO = 100
"""Slip of the rigid-drive run that relaxes each table cell's interface [rho~_max] (the
chain's friction relaxes from the mean-field state within ~5 rho~_max at 1 mm/s; the
mean friction is taken over its 18 samples from 15 rho~_max on)."""

MEAN_FIELD = {"k2": 0.0, "slip": "reset"}
CHAIN = {"k2": 2.75, "slip": "chain"}


def measure(spec: dict, threads: int, code: str = WORKER) -> dict:
    env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
    out = subprocess.run(
        [sys.executable, "-c", code, str(ROOT), json.dumps(spec)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def stiffness_table(scale: float, record) -> dict:
    """Depinnings/s at every drive stiffness and velocity, mean field and chain (issue 16:
    within each velocity max/min <= 2). Returns the rates by joint, "V K" keys.

    Every cell starts in steady sliding at its velocity V: the interface of a rigid-drive
    run of ``RELAX_RHO`` rho~_max at V (untimed), with a finite spring stretched to that
    run's mean friction force; the cell then runs ``slip_rho`` rho~_max of load-point
    travel, three times from that same state (the same trajectory; the best wall time
    counts: a cell lasts 0.05-0.2 s).

    Why not the engine's "steady" initial state: it is the mean-field stationary state,
    exact for the mean field but not for a chain. At 1 mm/s it holds 0.465 W, above the
    chain's saturated friction (0.448 W at 0.1 m/s, rigid drive; 0.431 W at 1 mm/s), so a
    soft spring started there slips away, physically, until it has unloaded by ~0.01-0.02
    W: a slide of ~1e-2 W / K. Measured at K/W = 1e4 1/m: 2,900 rho~_max and 1.1e7
    depinnings in the first 5 rho~_max of load-point travel. At 1e2 1/m: ~3e5-6e5
    rho~_max, 1e9-2e9 depinnings, about 0.5-1 h at the 7e5/s the engine runs at the
    athermal drift cap (extrapolated; that cell never finished). That is the slip phase
    of stick-slip, not sliding at V, and not what the table compares. A soft spring holds
    its force for the whole cell (it relaxes over ~alpha W / K, ~1e-4 m at 1e2 1/m), so
    its slider slides at the speed the interface has at that force: stretched to the
    instantaneous force of the relaxed interface, a downward fluctuation of 0.016 W set
    the chain's slider at 0.02 V, an upward one the mean field's at 2.8 V; hence the mean.
    """
    tables = {}
    for name, joint, contacts in (("mean-field", MEAN_FIELD, 100), ("chain", CHAIN, 20)):
        spec = {
            "joint": joint,
            "contacts": contacts,
            "blocks": 100,
            "velocities": TABLE_VELOCITIES,
            "stiffnesses": STIFFNESSES,
            "slip_rho": 50 * scale,
            "relax_rho": RELAX_RHO,
            "repeats": 3,
        }
        rates = measure(spec, 1, TABLE)
        tables[name] = rates
        for velocity in TABLE_VELOCITIES:
            row = [rates[f"{velocity:g} {stiffness:g}"] for stiffness in STIFFNESSES]
            record(
                f"{name}, {contacts * 100} blocks, V = {velocity:g} m/s, 1 thread: max/min "
                "depinnings/s over K/W = 1e2..1e12 1/m and rigid",
                max(row) / min(row),
                "x",
                "<= 2",
            )
    return tables


def protocol_table(record) -> dict:
    """Wall time of whole protocols, holds and reloads included, one thread: the quick
    start (1 -> 10 um/s, a 2 s hold, a reload) and a creep protocol (1 nm/s for 150 nm, a
    100 s hold, 50 nm), each at every K/W of ``PROTOCOL_RATIOS`` (best of two)."""
    spec = {"scenario": str(ROOT / "scenarios" / "quickstart.toml"), "ratios": PROTOCOL_RATIOS}
    rates = measure(spec, 1, PROTOCOLS)
    for name in ("quickstart", "creep"):
        walls = [rates[f"{name} {ratio:g}"]["wall"] for ratio in PROTOCOL_RATIOS]
        record(
            f"{name} protocol, 1e4 blocks, 1 thread: max/min wall over K/W = 2e6..1e14 1/m "
            "and rigid",
            max(walls) / min(walls),
            "x",
            "(reported; issue 16: cost follows the events)",
        )
    return rates


def step_costs(record) -> dict:
    """What a finite spring's short steps cost in the free-block kernel alone
    (:func:`nanoblock.kernels.blocks.advance_free_blocks`, one thread): the relaxed
    mean-field interface of the stiffness table (10,000 blocks, 1 um/s) advanced over
    200 rho~_max of slip in steps of each of ``STEP_LENGTHS`` (the cold floor: 2,000 passes
    of 1e-6 rho~_max), best of three from the same state. Returns ns per block and step,
    ns per depinning and depinnings per block and step, by step length."""
    spec = {
        "joint": MEAN_FIELD,
        "contacts": 100,
        "blocks": 100,
        "velocity": 1e-6,
        "relax_rho": RELAX_RHO,
        "steps": STEP_LENGTHS,
        "slip_rho": 200,
        "cold_passes": 2000,
        "repeats": 3,
    }
    costs = measure(spec, 1, STEPS)
    default, long = costs[f"{1 / 8:g}"], costs[f"{4.0:g}"]
    record(
        "free-block kernel, 1e4 blocks, 1 um/s, 1 thread: ns per depinning, steps of "
        "rho~_max / 8 over steps of 4 rho~_max",
        default["ns_per_depinning"] / long["ns_per_depinning"],
        "x",
        "(reported: a finite spring's short steps)",
    )
    return costs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="shorter runs (smoke test)")
    parser.add_argument("--table", action="store_true", help="only the stiffness tables")
    parser.add_argument(
        "--steps", action="store_true", help="only the kernel's cost against step length"
    )
    args = parser.parse_args()
    scale = 0.2 if args.quick else 1.0
    rows, results = [], {}

    def record(name: str, value: float, unit: str, target: str) -> None:
        results[name] = value
        rows.append(f"| {name} | {value:.3g} {unit} | {target} |")

    if not args.steps:
        results["stiffness_table_1_thread"] = stiffness_table(scale, record)
        results["protocol_table_1_thread"] = protocol_table(record)
    results["step_costs_1_thread"] = step_costs(record)
    if not (args.table or args.steps):
        throughput(scale, record, results)
    host = describe()
    results["step_costs_host"] = host  # --steps alone: the other rows keep their run's host
    print(f"Machine: {host['machine']}, load averages {host['load_averages']} after the runs\n")
    print("| measurement | value | target |\n|---|---|---|")
    print("\n".join(rows))
    if not args.steps:
        results |= host
    path = ROOT / "benchmarks" / "results_core.json"
    stored = json.loads(path.read_text()) if path.exists() else {}
    if args.table or args.steps:  # the other rows of the last full run stay
        results = stored | results
    path.write_text(json.dumps(results, indent=2))


def throughput(scale: float, record, results: dict) -> None:
    """Issue 2's throughput, scaling and memory rows."""
    big = {
        "joint": MEAN_FIELD,
        "contacts": 1000,
        "blocks": 100,
        "velocity": 1e-6,
        "slip_rho": 200 * scale,
        "store": True,
    }
    for threads in (2, 1):
        r = measure(big, threads)
        record(
            f"mean-field, 1e5 blocks, run + zarr store, {threads} thread(s)",
            r["events"] / r["wall"],
            "depinnings/s",
            ">= 3e7 (issue 16)" if threads == 2 else ">= 8e6",
        )
    soft = {**big, "stiffness": 1e6}
    r = measure(soft, 1)
    record(
        "mean-field, 1e5 blocks, run + zarr store, finite spring K = 1e6 N/m, 1 thread",
        r["events"] / r["wall"],
        "depinnings/s",
        "(reported: steps of rho~_max / 8)",
    )
    chain = {
        "joint": CHAIN,
        "contacts": 200,
        "blocks": 100,
        "velocity": 1e-6,
        "slip_rho": 60 * scale,
    }
    r = measure(chain, 1)
    record(
        "chain (k2 = k1), 2e4 blocks, 1 thread", r["events"] / r["wall"], "depinnings/s", ">= 1e6"
    )
    per_um = {}
    for velocity in (1e-9, 1e-7, 1e-6, 1e-5, 1e-4):
        spec = {
            "joint": MEAN_FIELD,
            "contacts": 100,
            "blocks": 100,
            "velocity": velocity,
            "slip_rho": 200 * scale,
        }
        r = measure(spec, 2)
        per_um[velocity] = r["wall"] / (r["slip"] * 1e6)
    spread = max(per_um.values()) / min(per_um.values())
    record("wall time per um of slip, max/min over V = 1e-9..1e-4 m/s", spread, "x", "< 2")
    small = {
        "joint": CHAIN,
        "contacts": 200,
        "blocks": 100,
        "velocity": 1e-6,
        "slip_rho": 60 * scale,
    }
    one, two = measure(small, 1), measure(small, 2)
    ratio = (two["events"] / two["wall"]) / (one["events"] / one["wall"])
    record("2 threads / 1 thread throughput, 200 contacts (chain)", ratio, "x", ">= 1.6")
    bytes_per_block = 16 + (8 * 5 + 32) / 100  # y, h per block; per-contact state / 100
    record("state memory per block (100 blocks per contact)", bytes_per_block, "bytes", "<= 64")
    naive = measure({}, 1, NAIVE)
    kernel_1 = results["mean-field, 1e5 blocks, run + zarr store, 1 thread(s)"]
    record(
        "speedup of the kernel over the naive NumPy time-stepped reference",
        kernel_1 / (naive["events"] / naive["wall"]),
        "x",
        "(reported)",
    )
    results["wall_per_um"] = {str(k): v for k, v in per_um.items()}


if __name__ == "__main__":
    main()
