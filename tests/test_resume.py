"""Issue 5: a run killed with SIGKILL at a random moment resumes, from its last checkpoint,
to the trajectory of an uninterrupted run, bit for bit."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import xarray as xr

from nanoblock.engine import simulate
from nanoblock.params import load_scenario
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

    second = launch(scenario, out)
    stdout, stderr = second.communicate(timeout=300)
    assert second.returncode == 0, stderr
    assert f"resuming {out} from sample {checkpoint} " in stdout

    resumed = xr.open_zarr(out, consolidated=False)
    reference = simulate(load_scenario(scenario))
    assert resumed.attrs["complete"] and resumed.sizes == reference.sizes
    for name in [*SAMPLES, *SNAPSHOTS, "time", "snapshot_time"]:
        np.testing.assert_array_equal(resumed[name].values, reference[name].values, name)
    progress = resumed.attrs["progress"]
    assert progress["fraction"] == 1.0 and progress["simulated_time"] == progress["end_time"]
    assert progress["events"] == int(reference.n_events[-1]) and progress["wall_seconds"] > 0
