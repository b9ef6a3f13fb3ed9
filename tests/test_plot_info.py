"""Issue 5: ``nanoblock plot`` and ``nanoblock info``, progress attrs, and the lazy
block-snapshot Dataset (the agents)."""

from __future__ import annotations

import dask.array as da
import matplotlib.image
import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

import nanoblock.engine as engine
from nanoblock.cli import app
from nanoblock.engine import simulate
from nanoblock.figures import q_st_window
from nanoblock.snapshots import RENEWAL_TRAVEL, STEADY_TRAVEL, open_snapshots
from nanoblock.store import SNAPSHOTS
from tests.conftest import RHO_MAX, scenario

VELOCITY = 1e-6


def mean_field_run(**run):
    """Reference mean-field joint on a rigid drive, steady from the start, with snapshots."""
    return scenario(
        interface={"n_contacts": 20, "blocks_per_contact": 25},
        loading={
            "stiffness": float("inf"),
            "steps": [{"velocity": VELOCITY, "displacement": 20 * RHO_MAX}, {"hold": 1e-3}],
        },
        run={"record_every": RHO_MAX / VELOCITY, "snapshot_every": 2, **run},
    )


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("plot") / "meanfield.zarr"
    simulate(mean_field_run(), path)
    return path


def test_plot_writes_the_standard_figures(store, tmp_path) -> None:
    out = tmp_path / "figures"
    result = CliRunner().invoke(app, ["plot", str(store), "--out", str(out)])
    assert result.exit_code == 0, result.output
    names = ["friction", "velocity", "stress", "contact_age"]
    for name in names:
        png = out / f"meanfield_{name}.png"
        assert str(png) in result.output
        assert matplotlib.image.imread(png).shape[0] > 300
    next_to_store = CliRunner().invoke(app, ["plot", str(store)])
    assert next_to_store.exit_code == 0
    assert (store.parent / "meanfield_stress.png").exists()


def test_q_st_applies_to_steady_mean_field_snapshots_only() -> None:
    steady = mean_field_run()
    times = np.arange(0.0, 23.0, 2.0) * RHO_MAX / VELOCITY  # the last one in the hold
    window = q_st_window(steady, times)
    assert window is not None and window[1] == VELOCITY
    assert window[0][:-1].all() and not window[0][-1]  # not during the hold
    unloaded = mean_field_run(initial_state="unloaded")
    assert q_st_window(unloaded, times) is None  # blocks fire in step: never forgotten
    renewed = unloaded.model_copy(
        update={"interface": unloaded.interface.model_copy(update={"memory_length": RHO_MAX})}
    )
    mask, _ = q_st_window(renewed, times)
    travel = max(STEADY_TRAVEL, RENEWAL_TRAVEL) * RHO_MAX
    np.testing.assert_array_equal(mask, (times >= travel / VELOCITY) & window[0])
    chain = steady.model_copy(update={"joint": steady.joint.model_copy(update={"k2": 1.0})})
    assert q_st_window(chain, times) is None


def test_open_snapshots_is_lazy_with_time_contact_block_dims(store) -> None:
    snaps = open_snapshots(store)
    stored = xr.open_zarr(store, consolidated=False)
    assert snaps.block_stress.dims == ("time", "contact", "block")
    assert snaps.contact_age.dims == ("time", "contact")
    assert snaps.block_stress.shape == (stored.sizes["snapshot_time"], 20, 25)
    for name, spec in SNAPSHOTS.items():
        assert isinstance(snaps[name].data, da.Array), name
        assert snaps[name].attrs == {"units": spec.units, "long_name": spec.long_name}
    for name in ("time", "contact", "block"):
        assert {"units", "long_name"} <= set(snaps[name].attrs)
    np.testing.assert_array_equal(snaps.time, stored.snapshot_time)
    one = snaps.block_stress.sel(time=snaps.time[3], contact=7)
    np.testing.assert_array_equal(one, stored.block_stress[3, 7])
    assert snaps.attrs["seed"] == 1


def test_open_snapshots_refuses_a_run_without_snapshots(tmp_path) -> None:
    path = tmp_path / "plain.zarr"
    simulate(mean_field_run(snapshot_every=0), path)
    with pytest.raises(ValueError, match="no block snapshots"):
        open_snapshots(path)
    result = CliRunner().invoke(app, ["plot", str(path), "--out", str(tmp_path)])
    assert result.exit_code == 0
    assert not (tmp_path / "plain_stress.png").exists()
    assert (tmp_path / "plain_friction.png").exists()


def test_info_prints_provenance_progress_and_summary(store) -> None:
    result = CliRunner().invoke(app, ["info", str(store)])
    assert result.exit_code == 0, result.output
    for text in (
        "complete              yes",
        "(100.0%)",
        "seed                  1",
        "nanoblock 0.1.0, numba",
        "joint.temperature = 300.0",
        "loading.steps.0.velocity = 1e-06",
        "block depinnings",
    ):
        assert text in result.output, text


def test_progress_attrs_of_an_interrupted_run(tmp_path, monkeypatch) -> None:
    run = mean_field_run()
    calls = {"n": 0}
    original = engine.Run.step_to_next_sample

    def crash_after_8(self):
        calls["n"] += 1
        if calls["n"] > 8:
            raise KeyboardInterrupt("simulated kill")
        return original(self)

    monkeypatch.setattr(engine.Run, "step_to_next_sample", crash_after_8)
    with pytest.raises(KeyboardInterrupt):
        simulate(run, tmp_path / "run.zarr", flush_seconds=0.0)
    stored = xr.open_zarr(tmp_path / "run.zarr", consolidated=False)
    progress = stored.attrs["progress"]
    assert progress["samples"] == 8 == stored.sizes["time"]
    assert progress["simulated_time"] == float(stored.time[-1])
    assert progress["end_time"] == pytest.approx(run.total_time)
    assert progress["fraction"] == pytest.approx(progress["simulated_time"] / run.total_time)
    assert progress["events"] == int(stored.n_events[-1]) > 0
    assert progress["wall_seconds"] > 0
    info = CliRunner().invoke(app, ["info", str(tmp_path / "run.zarr")])
    assert "complete              no" in info.output
    assert f"({progress['fraction']:.1%})" in info.output


@pytest.mark.parametrize("command", ["plot", "info"])
def test_plot_and_info_refuse_what_is_not_a_store(tmp_path, command) -> None:
    result = CliRunner().invoke(app, [command, str(tmp_path)])
    assert result.exit_code == 2 and "not a nanoblock run store" in result.output
    missing = CliRunner().invoke(app, [command, str(tmp_path / "missing.zarr")])
    assert missing.exit_code == 2 and "does not exist" in missing.output


@pytest.mark.parametrize(("duration", "samples"), [(1e-200, 1), (4096e-6, 4097)])
def test_runs_of_one_sample_or_a_last_chunk_of_one_are_drawn(tmp_path, duration, samples):
    """A protocol shorter than record_every stores one sample (a sweep's fastest tasks do)
    and a run of 4097 samples ends in a zarr chunk of one: ``run`` failed drawing the
    first (IndexError) and ``plot`` both (dask's gradient refuses a chunk of one)."""
    path = tmp_path / "short.zarr"
    simulate(
        scenario(
            interface={"n_contacts": 2, "blocks_per_contact": 5},
            loading={
                "stiffness": float("inf"),
                "steps": [{"velocity": 1e-6, "duration": duration}],
            },
            run={"record_every": 1e-6},
        ),
        path,
    )
    assert xr.open_zarr(path, consolidated=False).sizes["time"] == samples
    result = CliRunner().invoke(app, ["plot", str(path), "--out", str(tmp_path / "figures")])
    assert result.exit_code == 0, result.output
    for name in ("friction", "velocity"):
        assert matplotlib.image.imread(tmp_path / "figures" / f"short_{name}.png").shape[0] > 300
