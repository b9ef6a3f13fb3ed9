"""Issue 5: a run killed with SIGKILL at a random moment resumes, from its last checkpoint,
to the trajectory of an uninterrupted run, bit for bit."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import zarr
from typer.testing import CliRunner

import nanoblock.engine as engine
from nanoblock.cli import app
from nanoblock.engine import simulate
from nanoblock.kernels.layout import SLIDER
from nanoblock.params import from_mapping, load_scenario
from nanoblock.store import SAMPLES, SNAPSHOTS, RunStore

ROOT = Path(__file__).resolve().parents[1]

SCENARIO = """
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
n_contacts = 300
blocks_per_contact = 40
memory_length = 5e-8
aging_m = 0.05

[loading]
stiffness = 2e5
steps = [
  { velocity = 1e-6, displacement = 1e-7 },
  { velocity = 1e-5, displacement = 1e-7 },
  { hold = 0.02 },
  { velocity = 1e-5, displacement = 1e-7 },
]

[run]
seed = 11
record_every = 5e-4
initial_state = "steady"
snapshot_every = 10
"""
"""Velocity step, hold and reload with ageing, renewal and block snapshots: ~5 s of work on
one thread, 281 samples."""

REFERENCE_JOINT = SCENARIO[: SCENARIO.index("[interface]")]
"""The reference mean-field joint (physics.md section 4) as a TOML section."""

TINY = (
    REFERENCE_JOINT
    + """[interface]
normal_force = 1.0
hardness = 1.0e8
n_contacts = 4
blocks_per_contact = 10
memory_length = 5e-8

[loading]
stiffness = inf
steps = [{ velocity = 1e-6, displacement = 1e-8 }]

[run]
seed = 1
record_every = 1e-4
initial_state = "steady"
snapshot_every = 20
"""
)
"""A run of 101 samples and 6 snapshots that takes well under a second."""


def variables_of(run: xr.Dataset) -> xr.Dataset:
    """The run without its root attributes (progress and checkpoint differ by design)."""
    bare = run.copy()
    bare.attrs = {}
    return bare


def launch(scenario: Path, out: Path) -> subprocess.Popen:
    """``python -m nanoblock.cli run`` in a subprocess on one Numba thread (robust to a
    busy machine; the trajectory does not depend on it), checkpointing every 0.5 s."""
    command = [sys.executable, "-m", "nanoblock.cli", "run", str(scenario), "--out", str(out)]
    command += ["--quiet", "--flush-seconds", "0.5"]
    env = {
        **os.environ,
        "NUMBA_NUM_THREADS": "1",
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    return subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def test_sigkilled_run_resumes_to_the_uninterrupted_trajectory(tmp_path: Path) -> None:
    scenario = tmp_path / "resume.toml"
    scenario.write_text(SCENARIO)
    out = tmp_path / "resume.zarr"
    rng = np.random.default_rng(20261121)

    first = launch(scenario, out)
    deadline = time.monotonic() + 120
    while not (out / "zarr.json").exists():
        assert first.poll() is None, first.communicate()
        assert time.monotonic() < deadline, "the store never appeared"
        time.sleep(0.01)
    time.sleep(rng.uniform(0.2, 2.5))
    os.kill(first.pid, signal.SIGKILL)
    first.communicate()
    assert first.returncode == -signal.SIGKILL
    # The kill may land inside an append, leaving some arrays one chunk longer than others
    # (xarray then refuses to open the store); the checkpoint in the root attrs, written
    # last, is what a resume truncates back to.
    killed = RunStore(out).attrs
    assert not killed["complete"]
    checkpoint = killed["checkpoint"]["samples"]
    assert 0 < checkpoint < 281
    seen = RunStore(out).open().load()  # what `nanoblock info` and `plot` read
    assert seen.sizes["time"] == checkpoint

    second = launch(scenario, out)
    stdout, stderr = second.communicate(timeout=300)
    assert second.returncode == 0, stderr
    assert f"resuming {out} from sample {checkpoint} " in stdout

    resumed = xr.open_zarr(out, consolidated=False)
    reference = simulate(load_scenario(scenario))
    before = reference[list(SAMPLES)].isel(time=slice(0, checkpoint))
    xr.testing.assert_identical(variables_of(seen[list(SAMPLES)]), variables_of(before))
    assert resumed.attrs["complete"] and resumed.sizes == reference.sizes
    for name in [*SAMPLES, *SNAPSHOTS, "time", "snapshot_time"]:
        np.testing.assert_array_equal(resumed[name].values, reference[name].values, name)
    progress = resumed.attrs["progress"]
    assert progress["fraction"] == 1.0 and progress["simulated_time"] == progress["end_time"]
    assert progress["events"] == int(reference.n_events[-1]) and progress["wall_seconds"] > 0


def test_a_store_killed_inside_an_append_opens_as_far_as_its_checkpoint(tmp_path: Path) -> None:
    """An append cut short leaves one array a chunk longer than the rest: xarray refuses
    the store, RunStore.open shows the checkpointed samples and snapshots, identical to the
    run read before the damage, and writes nothing."""
    out = tmp_path / "cut.zarr"
    scenario = from_mapping(tomllib.loads(SCENARIO.replace("= 1e-7 }", "= 1e-8 }")))
    simulate(scenario, out)
    store = RunStore(out)
    intact = xr.open_zarr(out, consolidated=False).load()
    group = zarr.open_group(out, mode="a")
    n_samples = group["time"].shape[0]
    group["friction_force"].resize((n_samples + 7,))  # the interrupted append
    checkpoint = {**store.attrs["checkpoint"], "samples": n_samples - 3}
    store.update_attrs(complete=False, checkpoint=checkpoint)
    listing = sorted(str(p.relative_to(out)) for p in out.rglob("*"))
    try:
        xr.open_zarr(out, consolidated=False)
    except ValueError as error:
        assert "time" in str(error)
    else:
        raise AssertionError("xarray opened arrays of unequal length")
    seen = store.open().load()
    expected = intact.isel(time=slice(0, n_samples - 3))
    xr.testing.assert_identical(variables_of(seen), variables_of(expected))
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*")) == listing


def _chunks(store: Path) -> list[Path]:
    """Every chunk file of a store (data, snapshots and both checkpoint slots)."""
    return sorted(p for p in store.rglob("*") if p.is_file() and "c" in p.relative_to(store).parts)


def _arrays(store: Path) -> list[Path]:
    """Every array directory of a store (data, snapshots and both checkpoint slots)."""
    return sorted(meta.parent for meta in store.rglob("zarr.json") if (meta.parent / "c").is_dir())


def test_deleting_any_chunk_is_reported_and_never_resumes_elsewhere(tmp_path, monkeypatch):
    """A run killed after 45 of its 101 samples, checkpointed at every sample (slots at
    samples 44 and 45): with any one chunk or whole array deleted (a checkpoint slot's
    attrs list its arrays), the resume either refuses naming the
    array, or (a checkpoint slot damaged) resumes from an intact checkpoint, saying so
    when it is not the last one, to the trajectory of the uninterrupted run; ``info``
    names the damage (but for the spare slot)."""
    scenario = tmp_path / "tiny.toml"
    scenario.write_text(TINY)
    reference = simulate(load_scenario(scenario))
    killed = tmp_path / "killed.zarr"
    original = engine.Run.step_to_next_sample
    with monkeypatch.context() as patch:

        def crash_after_45(self):
            if self.next_sample >= 45:
                raise KeyboardInterrupt("simulated kill")
            return original(self)

        patch.setattr(engine.Run, "step_to_next_sample", crash_after_45)
        with pytest.raises(KeyboardInterrupt):
            simulate(load_scenario(scenario), killed, flush_seconds=0.0)
    pointer = RunStore(killed).attrs["checkpoint"]
    assert pointer["samples"] == 45
    chunks = _chunks(killed)
    assert len(chunks) > 30
    outcomes = {"refused": 0, "resumed": 0}
    for chunk in [*chunks, *_arrays(killed)]:
        relative = chunk.relative_to(killed)
        parts = relative.parts
        array = "/".join(parts[: parts.index("c")] if "c" in parts else parts)
        damaged = tmp_path / "damaged.zarr"
        shutil.rmtree(damaged, ignore_errors=True)
        shutil.copytree(killed, damaged)
        if chunk.is_dir():
            shutil.rmtree(damaged / relative)
        else:
            (damaged / relative).unlink()
        spare = array.startswith("checkpoint/") and array.split("/")[1] != pointer["slot"]
        info = CliRunner().invoke(app, ["info", str(damaged)])
        assert info.exit_code == (0 if spare else 2), (relative, info.output)
        result = CliRunner().invoke(app, ["run", str(scenario), "--out", str(damaged), "-q"])
        if not spare:
            assert array in info.output and array in result.output, (relative, result.output)
        if result.exit_code == 2:
            outcomes["refused"] += 1
            assert "damaged" in result.output and "Traceback" not in result.output
            continue
        assert result.exit_code == 0, (relative, result.output)
        assert array.startswith("checkpoint/"), relative  # data damage is never resumed over
        outcomes["resumed"] += 1
        resumed = xr.open_zarr(damaged, consolidated=False)
        for name in [*SAMPLES, *SNAPSHOTS, "time", "snapshot_time"]:
            np.testing.assert_array_equal(resumed[name].values, reference[name].values, name)
    assert outcomes["refused"] and outcomes["resumed"], outcomes
    # a store from before the slots listed their arrays: the resume still names the loss
    damaged = tmp_path / "old.zarr"
    shutil.copytree(killed, damaged)
    for slot in "ab":
        zarr.open_group(damaged / "checkpoint" / slot, mode="a").attrs.pop("arrays")
    shutil.rmtree(damaged / "checkpoint" / pointer["slot"] / "age")
    result = CliRunner().invoke(app, ["run", str(scenario), "--out", str(damaged), "-q"])
    assert result.exit_code == 2 and "checkpoint damaged (arrays age missing)" in result.output
    assert "Traceback" not in result.output
    # a checkpoint from a version whose slider record had another layout
    shutil.rmtree(damaged)
    shutil.copytree(killed, damaged)
    for slot in "ab":
        group = zarr.open_group(damaged / "checkpoint" / slot, mode="a")
        old = group.create_array(
            "slider", shape=(SLIDER.itemsize - 8,), dtype="uint8", overwrite=True
        )
        old[...] = 1
    result = CliRunner().invoke(app, ["run", str(scenario), "--out", str(damaged), "-q"])
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    assert f"slider record of {SLIDER.itemsize - 8} bytes" in result.output, result.output
