"""The ``nanoblock run`` command end to end: store, figure, summary, resume."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import xarray as xr
from typer.testing import CliRunner

from nanoblock.cli import app, default_scenario

ROOT = Path(__file__).resolve().parents[1]

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
    wall = [line for line in result.output.splitlines() if line.startswith("wall time")]
    assert wall and wall[0] in again.output  # the stored wall time, not the re-run's
    assert "sliding, segment 2" in again.output and "segment 3" not in again.output  # hold


def nanoblock(*args: str) -> subprocess.CompletedProcess:
    """``python -m nanoblock.cli ARGS`` in a subprocess importing this tree."""
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    command = [sys.executable, "-m", "nanoblock.cli", *args]
    env = {**os.environ, "PYTHONPATH": path}
    return subprocess.run(command, capture_output=True, text=True, env=env, timeout=120)


def test_a_directory_holding_a_users_file_survives_run_out(tmp_path) -> None:
    folder = tmp_path / "thesis"
    folder.mkdir()
    (folder / "thesis.tex").write_text("\\chapter{Friction} years of work")
    done = nanoblock("run", str(small_quickstart(tmp_path)), "--out", str(folder), "--quiet")
    assert done.returncode == 2, done
    assert f"{folder}: --out is a directory that is not a nanoblock run store" in done.stderr
    assert "thesis.tex" in done.stderr and "Traceback" not in done.stderr + done.stdout
    assert [p.name for p in folder.iterdir()] == ["thesis.tex"]
    assert (folder / "thesis.tex").read_text().endswith("years of work")
    assert not (tmp_path / "thesis.png").exists()


def test_a_process_reports_a_bad_input_in_one_line(tmp_path) -> None:
    done = nanoblock("run", str(tmp_path))  # a directory as the scenario
    assert done.returncode == 2
    assert done.stderr == f"error: {tmp_path}: is a directory; a scenario TOML file is required\n"


def test_a_run_interrupted_while_creating_its_store_is_rerun_by_the_same_command(
    tmp_path, monkeypatch
) -> None:
    """Ctrl-C while the first samples are written left a store of only zarr.json, which
    the same command then refused as 'not a nanoblock run (no scenario attribute)'; the
    provenance is now written first, so the rerun writes it afresh, to the trajectory of
    an uninterrupted run; meanwhile info, plot and fit say the run was interrupted before
    its first samples (they said 'damaged: ... array missing')."""
    import xarray

    from nanoblock.store import SAMPLES

    scenario = small_quickstart(tmp_path)
    args = ["run", str(scenario), "--quiet", "--out"]
    reference = CliRunner().invoke(app, [*args, str(tmp_path / "reference.zarr")])
    assert reference.exit_code == 0, reference.output

    def interrupted(self, *arguments, **options):
        raise KeyboardInterrupt("Ctrl-C inside to_zarr")

    out = tmp_path / "interrupted.zarr"
    with monkeypatch.context() as patch:
        patch.setattr(xarray.Dataset, "to_zarr", interrupted)
        killed = CliRunner().invoke(app, [*args, str(out)])
    assert killed.exit_code != 0 and (out / "zarr.json").exists()
    # what the interrupted store holds is said as such, not as damage ('array missing')
    said = CliRunner().invoke(app, ["info", str(out)])
    assert said.exit_code == 0 and "interrupted before its first samples" in said.output
    for command in (["plot", str(out)], ["fit", str(out), "--out", str(tmp_path / "fit")]):
        refused = CliRunner().invoke(app, command)
        assert refused.exit_code == 2, (command, refused.output)
        assert f"{out}: unfinished: interrupted before its first samples" in refused.output
    again = CliRunner().invoke(app, [*args, str(out)])
    assert again.exit_code == 0, again.output
    rerun = xr.open_zarr(out, consolidated=False)
    expected = xr.open_zarr(tmp_path / "reference.zarr", consolidated=False)
    for name in [*SAMPLES, "time"]:
        assert (rerun[name].values == expected[name].values).all(), name


def test_a_reader_that_leaves_and_an_early_ctrl_c_end_in_one_line(tmp_path) -> None:
    """``nanoblock info STORE | head`` (the pipe closed before the output is written)
    ended in 'unexpected BrokenPipeError'; Ctrl-C while the command line's modules load
    printed a traceback of the import machinery. Now: exit 1 without a word, and
    'interrupted' with exit 130 (or death by SIGINT, if it lands before Python handles
    it)."""
    import signal
    import time

    out = tmp_path / "small.zarr"
    done = nanoblock("run", str(small_quickstart(tmp_path)), "--out", str(out), "--quiet")
    assert done.returncode == 0, done.stderr
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "PYTHONPATH": path}
    script = [sys.executable, "-m", "nanoblock"]
    reader = subprocess.Popen(
        [*script, "info", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env
    )
    reader.stdout.close()  # before the command can write
    _, stderr = reader.communicate(timeout=120)
    assert reader.returncode == 1 and stderr == b"", stderr.decode()[-2000:]
    early = subprocess.Popen(
        [*script, "info", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(0.3)  # the imports of nanoblock.cli take about a second
    early.send_signal(signal.SIGINT)
    _, stderr = early.communicate(timeout=120)
    assert early.returncode in (130, -signal.SIGINT), (early.returncode, stderr[-2000:])
    assert b"Traceback" not in stderr, stderr.decode()[-2000:]
