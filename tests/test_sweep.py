"""Issue 5: parameter sweeps on Dask (LocalCluster of 2 workers), manifest, re-runs,
worker loss, the lazily combined Dataset, and refused input."""

from __future__ import annotations

import functools
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import dask
import dask.array as da
import numpy as np
import pytest
from distributed import Client, LocalCluster
from typer.testing import CliRunner

from nanoblock.cli import app
from nanoblock.engine import simulate
from nanoblock.store import SAMPLES
from nanoblock.sweep import (
    MANIFEST,
    Sweep,
    SweepError,
    is_finished,
    key_attrs,
    open_sweep,
    parse_assignment,
    read_manifest,
    run_sweep,
    run_task,
    warm_workers,
)

TINY = """
[joint]
block_size = 2.75e-9
shear_modulus = 1.0e9
threshold_stress = 1.0e8
attempt_frequency = 1.0e12
temperature = 300.0
k2 = 0.0
slip = "reset"

[interface]
normal_force = 1.0
hardness = 1.0e8
n_contacts = 10
blocks_per_contact = 10
memory_length = 1e-8
aging_m = 0.05

[loading]
stiffness = 1e6
steps = [{ velocity = 1e-6, displacement = 3e-9 }]

[run]
record_every = 5e-4
initial_state = "steady"
"""
"""A mean-field joint of 10 x 10 blocks sliding 3 nm: a few tenths of a second per run."""

SETS = ["joint.temperature=280,300,320", "loading.steps.0.velocity=1e-7,1e-6,1e-5"]
GRID = ["--set", SETS[0], "--set", SETS[1], "--seeds", "2"]


@pytest.fixture
def tiny(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return path


def sweep_cli(*args: str):
    return CliRunner().invoke(app, ["sweep", *args, "--quiet"])


def modification_times(directory: Path) -> dict[str, int]:
    return {str(p.relative_to(directory)): p.stat().st_mtime_ns for p in directory.rglob("*")}


def test_sweep_of_3x3x2_tasks_on_two_workers_combines_lazily(tiny: Path, tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    result = sweep_cli(str(tiny), *GRID, "--out", str(out), "--workers", "2")
    assert result.exit_code == 0, result.output
    assert "18 tasks, 18 run now" in result.output
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["sweep"]["keys"] == ["joint.temperature", "loading.steps.0.velocity"]
    assert manifest["sweep"]["values"] == [[280, 300, 320], [1e-7, 1e-6, 1e-5]]
    assert manifest["sweep"]["seeds"] == [0, 1]
    assert [entry["status"] for entry in manifest["tasks"]] == ["done"] * 18
    assert all(is_finished(out / entry["store"]) for entry in manifest["tasks"])

    combined = open_sweep(out)
    keys = ("joint.temperature", "loading.steps.0.velocity")
    assert combined.friction_coefficient.dims == (*keys, "seed", "sample")
    assert combined.friction_coefficient.shape[:3] == (3, 3, 2)
    assert combined["joint.temperature"].attrs["units"] == "K"
    assert combined["loading.steps.0.velocity"].attrs["units"] == "m/s"
    assert combined.time.attrs["units"] == "s"
    for name in [*SAMPLES, *combined.coords]:
        assert {"units", "long_name"} <= set(combined[name].attrs), name
    for name in [*SAMPLES, "time"]:
        assert isinstance(combined[name].data, da.Array), name  # lazy, nothing loaded

    # one task, read back through the combined Dataset, is the in-process run bit for bit
    point = {"joint.temperature": 320, "loading.steps.0.velocity": 1e-5, "seed": 1}
    task = combined.sel(point)
    assert task.task.item() == "0017"
    last = Sweep.from_file(tiny, SETS, n_seeds=2).tasks()[17]
    assert last.params | {"seed": last.seed} == point
    alone = simulate(last.scenario)
    n = alone.sizes["time"]
    for name in SAMPLES:
        np.testing.assert_array_equal(task[name].values[:n], alone[name].values, err_msg=name)
    assert np.isnan(task.time.values[n:]).all()  # a 100x faster run is shorter: NaN-padded
    assert combined.sel(point | {"loading.steps.0.velocity": 1e-7}).time.notnull().all()

    # the same command again runs nothing and touches no store
    before = modification_times(out / "tasks")
    again = sweep_cli(str(tiny), *GRID, "--out", str(out), "--workers", "2")
    assert again.exit_code == 0 and "0 run now, 18 finished before" in again.output
    assert modification_times(out / "tasks") == before

    # another sweep into the same directory is refused; nothing is overwritten
    manifest_text = (out / MANIFEST).read_text()
    other = sweep_cli(str(tiny), "--set", "joint.temperature=290", "--out", str(out))
    assert other.exit_code == 2
    assert "holds another sweep" in other.output and "values" in other.output
    assert (out / MANIFEST).read_text() == manifest_text
    assert modification_times(out / "tasks") == before


def kill_worker_for(scenario_json: str, store: str, *, victim: str) -> float:
    """Task function (test-only): the victim task kills its own worker process."""
    if Path(store).stem == victim:
        os._exit(1)
    return run_task(scenario_json, store)


def test_killed_worker_loses_only_its_task_and_rerun_completes_it(
    tiny: Path, tmp_path: Path
) -> None:
    out = tmp_path / "sweep"
    sweep = Sweep.from_file(tiny, ["joint.temperature=280,300,320"], n_seeds=2)
    victim = functools.partial(kill_worker_for, victim="0003")
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        report = run_sweep(sweep, out, workers=2, task_function=victim)
    (failed,) = report.entries("failed")
    assert failed["task"] == "0003" and "KilledWorker" in failed["error"]
    assert failed["params"] == {"joint.temperature": 300} and failed["seed"] == 1
    done = [entry["task"] for entry in report.entries("done")]
    assert done == ["0000", "0001", "0002", "0004", "0005"]
    assert not is_finished(out / "tasks/0003.zarr")
    partial = open_sweep(out)
    assert partial.attrs["missing_tasks"] == ["0003"]
    assert np.isnan(partial.friction_force.sel({"joint.temperature": 300, "seed": 1})).all()
    info = CliRunner().invoke(app, ["info", str(out)])
    assert "6: 5 done, 1 failed" in info.output
    assert "0003 (joint.temperature=300, seed=1): KilledWorker" in info.output

    before = modification_times(out / "tasks")
    rerun = run_sweep(sweep, out, workers=2)
    assert rerun.ran == ["0003"]
    assert [entry["status"] for entry in rerun.manifest["tasks"]] == ["done"] * 6
    after = modification_times(out / "tasks")
    assert {k: v for k, v in after.items() if not k.startswith("0003")} == before
    assert open_sweep(out).friction_force.notnull().any("sample").all()

    # a finished store that lost an array (read back as made-up times) or a chunk (as
    # fill values): failed, named, kept, and never combined
    shutil.rmtree(out / "tasks/0001.zarr/time")
    (out / "tasks/0004.zarr/friction_force/c/0").unlink()
    damaged = modification_times(out / "tasks")
    info = CliRunner().invoke(app, ["info", str(out)])
    assert "6: 4 done, 2 failed" in info.output, info.output
    assert "tasks/0001.zarr damaged (time: array missing)" in info.output
    assert "tasks/0004.zarr damaged (friction_force: samples 0-" in info.output
    with pytest.raises(SweepError, match=r"tasks/0001.zarr damaged \(time: array missing\)"):
        open_sweep(out)
    again = run_sweep(sweep, out, workers=2)
    assert again.ran == [] and [e["task"] for e in again.entries("failed")] == ["0001", "0004"]
    assert "move it away" in again.entries("failed")[0]["error"]
    assert modification_times(out / "tasks") == damaged


def test_ctrl_c_stops_a_sweep_in_one_line_and_the_same_command_resumes_it(
    tiny: Path, tmp_path: Path
) -> None:
    """Ctrl-C reaches the whole process group. It printed the scheduler's broadcast
    errors, each worker's cancelled tasks and KeyboardInterrupt tracebacks of the workers
    and nannies; now one line says how far the sweep got, exit 130, and the same command
    finishes it."""
    import signal
    import time

    long = tmp_path / "long.toml"  # tasks of ~20 s: running when interrupted (at 2e-5 m,
    # ~7 s, CI under load once saw both finish before the signal)
    long.write_text(TINY.replace("displacement = 3e-9", "displacement = 6e-5"))
    out = tmp_path / "sweep"
    command = [sys.executable, "-m", "nanoblock", "sweep", str(long), "--out", str(out)]
    command += ["--set", "joint.temperature=280,300", "--workers", "2", "--quiet"]
    path = os.pathsep.join([str(Path(__file__).parents[1]), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "PYTHONPATH": path}
    process = subprocess.Popen(  # SIGINT as a terminal leaves it (a pytest-xdist worker
        command,  # ignores it, and the child would inherit that)
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        env=env,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.monotonic() + 120
    while not list(out.glob("tasks/*.zarr/zarr.json")) and time.monotonic() < deadline:
        time.sleep(0.2)
    os.killpg(process.pid, signal.SIGINT)  # as a terminal's Ctrl-C does
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    # a task may finish while the cluster shuts down (its workers ignore SIGINT)
    line = rf"interrupted: [01] of 2 tasks done \({re.escape(str(out / MANIFEST))}\); the same"
    assert re.search(line + " command resumes the rest", stderr), stderr
    for noise in ("Traceback", "KeyboardInterrupt", " - distributed.", "CancelledError"):
        assert noise not in stderr, stderr
    again = sweep_cli(str(long), "--out", str(out), "--set", "joint.temperature=280,300")
    assert again.exit_code == 0 and "2 tasks" in again.output, again.output
    assert [entry["status"] for entry in read_manifest(out)["tasks"]] == ["done", "done"]


def test_an_interrupt_after_the_last_task_says_none_is_left(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Ctrl-C while the cluster shuts down after the last task: the line counts every task
    done and does not promise to resume anything."""
    import typer

    from nanoblock.cli import _sweep_interrupt

    out = tmp_path / "sweep"
    assert sweep_cli(str(tiny), "--out", str(out), "--seeds", "2").exit_code == 0
    with pytest.raises(typer.Exit) as stopped, _sweep_interrupt(out):
        raise KeyboardInterrupt
    assert stopped.value.exit_code == 130
    line = f"interrupted: 2 of 2 tasks done ({out / MANIFEST}); none is left"
    assert capsys.readouterr().err.strip() == line


ONE_THREAD_AFTER_IMPORT = """
import os
import numba
from nanoblock.sweep import WORKER_ENV, one_numba_thread
os.environ.update(WORKER_ENV)  # as a nanny does, once the spawned worker has imported numba
one_numba_thread()
numba.njit(lambda x: x + 1)(1)  # a compilation after the thread pool was launched
print(numba.config.NUMBA_NUM_THREADS, numba.get_num_threads())
"""


def test_one_numba_thread_takes_the_worker_env_set_after_numba_was_imported() -> None:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_NUM_THREADS"}
    run = subprocess.run(
        [sys.executable, "-c", ONE_THREAD_AFTER_IMPORT], env=env, capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split() == ["1", "1"]


def test_sweep_runs_on_an_existing_scheduler(tiny: Path, tmp_path: Path) -> None:
    sweep = Sweep.from_file(tiny, [], n_seeds=2)
    cluster = LocalCluster(n_workers=1, processes=False, dashboard_address=None)
    with cluster:
        with Client(cluster) as client:
            warmed = warm_workers(client, sweep.tasks()[0].scenario.resolved_json())
        report = run_sweep(sweep, tmp_path / "sweep", scheduler=cluster.scheduler_address)
    assert len(warmed) == 1 and all(isinstance(s, float) for s in warmed.values()), warmed
    assert report.ran == ["0000", "0001"]
    assert [entry["status"] for entry in report.manifest["tasks"]] == ["done", "done"]
    assert set(report.timings) == {"cluster_start", "warm_up", "tasks", "cluster_stop"}
    assert all(seconds >= 0 for seconds in report.timings.values())
    combined = open_sweep(tmp_path / "sweep")
    assert combined.friction_force.dims == ("seed", "sample")
    np.testing.assert_array_equal(combined.seed, [0, 1])


def test_values_are_read_as_toml_scalars_and_keys_carry_units() -> None:
    axis = parse_assignment("joint.barrier=persson,spinodal")
    assert axis.values == ("persson", "spinodal")
    assert parse_assignment("interface.memory_length=1e-7, inf").values == (1e-7, float("inf"))
    assert parse_assignment("interface.n_contacts=10,20").values == (10, 20)
    assert key_attrs("loading.steps.1.hold") == {
        "units": "s",
        "long_name": "hold duration at rest (loading.steps.1.hold)",
    }
    assert key_attrs("interface.n_contacts")["units"] == "1"


@pytest.mark.parametrize(
    ("assignment", "message"),
    [
        ("joint.temprature=280,300", "unknown key 'joint.temprature'"),
        ("joint.temperature=300,-5", "joint.temperature = -5"),
        ("joint.temperature=300,-5", "allowed range (0.0, inf)"),
        ("loading.steps.2.velocity=1e-6", "loading.steps has 1 entries"),
        ("loading.steps.velocity=1e-6", "loading.steps is a list; give an index"),
        ("joint=1", "'joint' is a table, not a value"),
        ("run.seed=1,2", "--seeds"),
        ("joint.temperature", "expected KEY=V1,V2"),
    ],
)
def test_bad_sweep_input_exits_2_naming_the_key(
    tiny: Path, tmp_path: Path, assignment: str, message: str
) -> None:
    out = tmp_path / "sweep"
    result = sweep_cli(str(tiny), "--set", assignment, "--out", str(out))
    assert result.exit_code == 2
    assert message in result.output
    assert not out.exists()


def test_unreachable_scheduler_exits_2_quickly(tiny: Path, tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    address = "tcp://127.0.0.1:9"
    args = ["--scheduler", address, "--connect-timeout", "1", "--out", str(out)]
    result = sweep_cli(str(tiny), *args)
    assert result.exit_code == 2
    assert f"cannot reach the Dask scheduler at '{address}'" in result.output
    assert not out.exists()


def test_a_directory_that_is_not_a_sweep_is_refused(tiny: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.zarr"
    simulate(Sweep.from_file(tiny, []).tasks()[0].scenario, out)
    before = modification_times(out)
    result = sweep_cli(str(tiny), "--out", str(out))
    assert result.exit_code == 2 and "is not a sweep directory" in result.output
    assert modification_times(out) == before
    with pytest.raises(SweepError, match="not a sweep directory"):
        open_sweep(out)


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ('{"format": ', "the file: Invalid JSON"),
        ('{"format": "nanoblock-sweep/1"}', "nanoblock_version: Field required"),
        (
            '{"format": "nanoblock-sweep/1", "nanoblock_version": "0", "sweep": {"scenario": '
            '{}, "keys": [], "values": [], "seeds": [1]}, "tasks": [{"task": "0000", "params": '
            '{}, "seed": 1, "store": "tasks/0000.zarr", "status": "finished", "error": null, '
            '"wall_seconds": null}]}',
            "tasks.0.status: Input should be 'done', 'failed' or 'pending'",
        ),
    ],
    ids=["not JSON", "fields missing", "unknown status"],
)
def test_a_damaged_manifest_is_named_and_nothing_is_written(tiny, tmp_path, text, named):
    """info and a rerun of the sweep failed with an unexpected JSONDecodeError, KeyError
    or TypeError on a damaged sweep.json."""
    out = tmp_path / "sweep"
    (out / "tasks").mkdir(parents=True)
    (out / MANIFEST).write_text(text)
    before = modification_times(out)
    for args in (["info", str(out)], ["sweep", str(tiny), "--out", str(out), "--quiet"]):
        result = CliRunner().invoke(app, args)
        assert result.exit_code == 2, result.output
        assert f"{out / MANIFEST}: damaged manifest: {named}" in result.output, result.output
        assert "unexpected" not in result.output
    assert modification_times(out) == before
