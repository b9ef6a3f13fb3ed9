"""The ``nanoblock run`` command end to end: store, figure, summary, resume."""

from __future__ import annotations

import xarray as xr
from typer.testing import CliRunner

from nanoblock.cli import app, default_scenario

SMALL = {
    "n_contacts = 400": "n_contacts = 20",
    "record_every = 2.0e-3": "record_every = 1.0e-2",
    "{ hold = 2.0 }": "{ hold = 0.1 }",
}


def small_quickstart(tmp_path):
    text = default_scenario().read_text()
    for old, new in SMALL.items():
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "small.toml"
    path.write_text(text)
    return path


def test_run_writes_store_figure_and_summary(tmp_path) -> None:
    out = tmp_path / "small.zarr"
    result = CliRunner().invoke(
        app, ["run", str(small_quickstart(tmp_path)), "--out", str(out), "--quiet"]
    )
    assert result.exit_code == 0, result.output
    assert "block depinnings" in result.output and "friction coefficient" in result.output
    assert (tmp_path / "small.png").stat().st_size > 10_000
    stored = xr.open_zarr(out, consolidated=False)
    assert stored.attrs["complete"] and stored.sizes["time"] > 50
    again = CliRunner().invoke(
        app, ["run", str(small_quickstart(tmp_path)), "--out", str(out), "--quiet"]
    )
    assert again.exit_code == 0  # a finished store is reported, not recomputed or replaced
    assert xr.open_zarr(out, consolidated=False).sizes["time"] == stored.sizes["time"]
