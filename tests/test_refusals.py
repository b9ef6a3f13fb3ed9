"""Issue 17, "nothing lost, nothing silent": a battery of bad inputs to the CLI (scenario
keys, options, output paths, damaged stores, resource and physics ranges). Each one exits
with code 2 and one message naming the offending item, without a traceback, within 30 s,
and leaves every file as it was."""

from __future__ import annotations

import hashlib
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import zarr
from typer.testing import CliRunner

from nanoblock.cli import app
from nanoblock.engine import simulate
from nanoblock.params import ScenarioError, load_scenario
from tests.test_resume import TINY

SECONDS = 30.0


def tree(root: Path) -> dict[str, str]:
    """Every file under ``root`` with the digest of its bytes (directories as '/')."""
    return {
        str(path.relative_to(root)): "/"
        if path.is_dir()
        else hashlib.sha256(path.read_bytes()).hexdigest()
        for path in sorted(root.rglob("*"))
    }


def refused(root: Path, args: list[str], *names: str) -> str:
    """Run the CLI on ``args`` and check the refusal: exit 2, every one of ``names`` in
    the message, no traceback, nothing under ``root`` changed, within 30 s."""
    before = tree(root)
    started = time.monotonic()
    result = CliRunner().invoke(app, args)
    elapsed = time.monotonic() - started
    output = result.output
    assert result.exit_code == 2, (result.exit_code, output, result.exception)
    assert isinstance(result.exception, SystemExit), result.exception
    assert "Traceback" not in output, output
    for name in names:
        assert name in output, (name, output)
    assert tree(root) == before, "the refusal changed files"
    assert elapsed < SECONDS, elapsed
    return output


def scenario_file(root: Path, text: str, name: str = "bad.toml") -> Path:
    path = root / name
    path.write_text(text)
    return path


def edited(old: str, new: str) -> str:
    assert old in TINY, old
    return TINY.replace(old, new)


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A finished run of TINY: a directory with tiny.toml, run.zarr and run.png."""
    root = tmp_path_factory.mktemp("finished")
    scenario = scenario_file(root, TINY, "tiny.toml")
    result = CliRunner().invoke(app, ["run", str(scenario), "--out", str(root / "run.zarr"), "-q"])
    assert result.exit_code == 0, result.output
    return root


@pytest.fixture
def work(finished, tmp_path) -> Path:
    """A private copy of the finished run to damage."""
    shutil.copytree(finished, tmp_path / "work")
    return tmp_path / "work"


SCENARIO_EDITS = [
    (  # refused only once the run started, naming no file
        "steps = [{ velocity = 1e-6, displacement = 1e-8 }]",
        "steps = [{ hold = 0.01 }]",
        ["bad.toml", "run.initial_state = 'steady'", "every loading.steps segment is a hold"],
    ),
    ("block_size = 2.75e-9", "block_size = -1e-9", ["joint.block_size", "-1e-09"]),
    ("threshold_stress = 1.0e8", "threshold_stress = 0.0", ["joint.threshold_stress"]),
    ("temperature = 300.0", "temperature = true", ["joint.temperature", "True"]),
    ("temperature = 300.0", 'temperature = "300"', ["joint.temperature", "'300'"]),
    ("temperature = 300.0", "temperature = nan", ["temperature", "NaN"]),
    ("temperature = 300.0", "temperature = inf", ["joint.temperature", "finite"]),
    ("temperature = 300.0", "temperature = 20.0", ["at 20 K", "never depin", "u = "]),
    ("threshold_stress = 1.0e8", "threshold_stress = 1e300", ["threshold_stress = 1e+300"]),
    ("shear_modulus = 1.0e9", "shear_modulus = inf", ["joint.shear_modulus"]),
    ('slip = "reset"', 'slip = "teleport"', ["joint.slip", "teleport"]),
    ('slip = "reset"', 'slip = "reset"\nbarrier = "cubic"', ["joint.barrier", "cubic"]),
    ('slip = "reset"', 'slip = "reset"\nback_jumps = 1', ["joint.back_jumps"]),
    ('slip = "reset"', 'slip = "reset"\ncolour = "red"', ["unknown key 'joint.colour'"]),
    ("k2 = 0.0", "k2 = -1.0", ["joint.k2", "-1.0"]),
    ('slip = "reset"', 'slip = "reset"\nstrength_classes = 0', ["joint.strength_classes"]),
    ('slip = "reset"', 'slip = "reset"\nstrength_classes = true', ["joint.strength_classes"]),
    (
        'slip = "reset"',
        'slip = "reset"\nglass_temperature = 250.0\nreference_temperature = 200.0',
        ["temperature = 300.0", "glass_temperature = 250.0"],
    ),
    ("n_contacts = 4", "n_contacts = 0", ["interface.n_contacts", "= 0"]),
    ("n_contacts = 4", "n_contacts = 2.5", ["interface.n_contacts", "2.5"]),
    ("n_contacts = 4", "n_contacts = true", ["interface.n_contacts", "not a bool"]),
    (
        "n_contacts = 4\nblocks_per_contact = 10",
        "n_contacts = 1000000000\nblocks_per_contact = 1000000000",
        ["interface.n_contacts = 1000000000", "GB of memory"],
    ),
    ("blocks_per_contact = 10", "blocks_per_contact = 1000000000", ["blocks_per_contact", "GB"]),
    ("memory_length = 5e-8", "memory_length = 5e-8\naging_m = 1e6", ["interface.aging_m"]),
    ("memory_length = 5e-8", "memory_length = -1.0", ["interface.memory_length"]),
    ("hardness = 1.0e8", 'hardness = "hard"', ["interface.hardness", "'hard'"]),
    (
        "memory_length = 5e-8",
        "memory_length = 5e-8\nmemory_length_exponent = 1.0",
        ["memory_length_exponent", "reference_force"],
    ),
    (
        'slip = "reset"',
        'slip = "reset"\nthreshold_spread = 0.3',
        ["interface.n_contacts = 4", "strength_classes = 8"],
    ),
    ("stiffness = inf", "stiffness = 0.0", ["loading.stiffness"]),
    ("steps = [{ velocity = 1e-6, displacement = 1e-8 }]", "steps = []", ["loading.steps"]),
    (", displacement = 1e-8 }", " }", ["loading.steps.0", "'duration' (s) or 'displacement'"]),
    ("{ velocity = 1e-6,", "{ hold = 1.0, velocity = 1e-6,", ["loading.steps.0", "hold"]),
    ("velocity = 1e-6", "velocity = -1e-6", ["loading.steps.0.velocity", "-1e-06"]),
    ("record_every = 1e-4", "record_every = 1e-15", ["run.record_every = 1e-15", "samples"]),
    ("record_every = 1e-4", "record_every = 0.0", ["run.record_every"]),
    ("seed = 1", "seed = -1", ["run.seed", "-1"]),
    ("seed = 1", "seed = 1.5", ["run.seed", "1.5"]),
    ('initial_state = "steady"', 'initial_state = "hot"', ["run.initial_state", "hot"]),
    ("snapshot_every = 20", "snapshot_every = -1", ["run.snapshot_every"]),
    ("[interface]", "[tribology]\nx = 1\n\n[interface]", ["unknown key 'tribology'"]),
    ("[run]\nseed = 1", "[runs]\nseed = 1", ["unknown key 'runs'", "run"]),
    ("[joint]", "[joint\n", ["bad.toml", "not valid TOML"]),
]


@pytest.mark.parametrize(("old", "new", "names"), SCENARIO_EDITS)
def test_bad_scenario_keys_are_refused_by_name(tmp_path, old, new, names) -> None:
    scenario = scenario_file(tmp_path, edited(old, new))
    refused(tmp_path, ["run", str(scenario), "--out", str(tmp_path / "x.zarr"), "-q"], *names)
    assert not (tmp_path / "x.zarr").exists()


def test_a_hot_joint_whose_blocks_hop_without_load_is_refused(tmp_path) -> None:
    """3000 K on the reference joint at quickstart's size would never finish."""
    text = edited("temperature = 300.0", "temperature = 3000.0").replace(
        "n_contacts = 4", "n_contacts = 400"
    )
    args = ["run", str(scenario_file(tmp_path, text)), "--out", str(tmp_path / "x.zarr")]
    refused(tmp_path, args, "bad.toml: cannot run", "3000 K", "u = 5.02", "without load")


def test_the_python_api_refuses_an_infeasible_run_before_allocating(tmp_path) -> None:
    """simulate() checks what the CLI checks: 1e-15 s between samples would need 1e11
    samples (a MemoryError of TiB before issue 17)."""
    text = edited("record_every = 1e-4", "record_every = 1e-15")
    scenario = load_scenario(scenario_file(tmp_path, text))
    with pytest.raises(ScenarioError, match=r"run.record_every = 1e-15 .* samples"):
        simulate(scenario)


def test_scenario_that_is_not_text_is_refused(tmp_path) -> None:
    binary = tmp_path / "binary.toml"
    binary.write_bytes(bytes(range(256)))
    refused(tmp_path, ["run", str(binary), "--out", str(tmp_path / "x.zarr")], "binary.toml")


def test_scenario_that_is_a_directory_is_refused(tmp_path) -> None:
    (tmp_path / "folder.toml").mkdir()
    args = ["run", str(tmp_path / "folder.toml"), "--out", str(tmp_path / "x.zarr")]
    refused(tmp_path, args, "folder.toml", "is a directory")


def test_missing_scenario_is_refused(tmp_path) -> None:
    refused(tmp_path, ["run", str(tmp_path / "none.toml")], "none.toml", "not found")


def _tiny(root: Path) -> str:
    return str(scenario_file(root, TINY, "tiny.toml"))


OPTIONS: list[tuple[list[str], list[str]]] = [
    (["run", "{tiny}", "--seed", "-1"], ["--seed"]),
    (["run", "{tiny}", "--seed", "abc"], ["--seed"]),
    (["run", "{tiny}", "--flush-seconds", "-1"], ["--flush-seconds"]),
    (["run", "{tiny}", "--out", "{file}"], ["user.txt", "existing file"]),
    (["run", "{tiny}", "--out", "{file}/x.zarr"], ["user.txt", "existing file"]),
    (["run", "{tiny}", "--out", "{tmp}/new.zarr", "--figure", "{tmp}"], ["--figure"]),
    (["run", "{tiny}", "--out", "{tmp}/n.zarr", "--figure", "{file}/f.png"], ["user.txt"]),
    (["sweep", "{tiny}", "--set", "joint.temperature=290,300", "--out", "{file}"], ["user.txt"]),
    (["sweep", "{tiny}", "--set", "joint.colour=1,2", "--out", "{tmp}/s"], ["joint.colour"]),
    (["sweep", "{tiny}", "--seeds", "0", "--out", "{tmp}/s"], ["--seeds"]),
    (["fit", "{file}", "--out", "{file}"], ["user.txt", "existing file"]),
    (["fit", "{file}", "--mcmc-steps", "5"], ["--mcmc-steps"]),
    (["fit", "{file}", "--law", "aging", "--stiffness", "x"], ["--stiffness"]),
    (["fit", "{file}", "--loss", "cauchy", "--out", "{tmp}/f"], ["--loss", "'cauchy'", "huber"]),
    (["fit", "{file}", "--loss", "huber", "--mcmc", "--out", "{tmp}/f"], ["--loss", "--mcmc"]),
    (["fit", "{file}", "--loss", "huber", "--per-step", "--out", "{tmp}/f"], ["--per-step"]),
    (["diagnose", "{file}", "--out", "{file}"], ["user.txt", "existing file"]),
    (["diagnose", "{file}", "--workers", "0"], ["--workers"]),
    (["diagnose", "{file}", "--closure", "bogus"], ["--closure", "'bogus'", "auto"]),
    (["fit", "{file}", "--recipe", "{tmp}/p655_r", "--out", "{tmp}/f"], ["p655_r", "--recipe"]),
    (["diagnose", "{file}", "--recipe", "{tmp}/nofile", "--out", "{tmp}/d"], ["nofile"]),
    (["plot", "{tmp}"], ["not a nanoblock run store"]),
    (["plot", "{tmp}/missing.zarr"], ["missing.zarr", "does not exist"]),
    (["info", "{tmp}"], ["not a nanoblock run store"]),
    (["info", "{tmp}/missing.zarr"], ["missing.zarr", "does not exist"]),
    (["simulate", "{tiny}"], ["simulate"]),
]


@pytest.mark.parametrize(("args", "names"), OPTIONS)
def test_bad_options_are_refused_by_name(tmp_path, args, names) -> None:
    user = tmp_path / "user.txt"
    user.write_text("the user's own file")
    values = {"tiny": _tiny(tmp_path), "file": str(user), "tmp": str(tmp_path)}
    refused(tmp_path, [arg.format(**values) for arg in args], *names)


def test_fit_mcmc_without_emcee_is_refused_before_work(tmp_path, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "emcee", None)  # import emcee raises ImportError
    data = tmp_path / "data.csv"
    data.write_text("time,friction\n")
    refused(tmp_path, ["fit", str(data), "--mcmc", "--out", str(tmp_path / "f")], "--mcmc", "emcee")


def test_unexpected_errors_are_one_line_and_debug_shows_the_traceback(tmp_path, monkeypatch):
    def broken(path):
        raise RuntimeError("a bug")

    monkeypatch.setattr("nanoblock.cli.load_scenario", broken)
    output = refused(tmp_path, ["run", _tiny(tmp_path)], "RuntimeError", "a bug", "--debug")
    assert len(output.strip().splitlines()) == 1
    debug = CliRunner().invoke(app, ["--debug", "run", _tiny(tmp_path)])
    assert isinstance(debug.exception, RuntimeError)


# Output paths: nothing that nanoblock did not write is replaced.


def test_run_out_on_a_directory_with_a_users_file_keeps_it(tmp_path) -> None:
    folder = tmp_path / "thesis"
    folder.mkdir()
    (folder / "thesis.tex").write_text("\\documentclass{book} years of work")
    refused(tmp_path, ["run", _tiny(tmp_path), "--out", str(folder), "-q"], "thesis", "thesis.tex")
    assert (folder / "thesis.tex").read_text().endswith("years of work")


def test_run_does_not_replace_a_users_png_beside_the_store(tmp_path) -> None:
    png = tmp_path / "run.png"
    png.write_bytes(b"\x89PNG the user's picture")
    args = ["run", _tiny(tmp_path), "--out", str(tmp_path / "run.zarr"), "-q"]
    refused(tmp_path, args, "run.png", "--figure")
    assert not (tmp_path / "run.zarr").exists()


def test_run_replaces_its_own_figure_and_refuses_another_seeds_store(work) -> None:
    args = ["run", str(work / "tiny.toml"), "--out", str(work / "run.zarr"), "-q"]
    again = CliRunner().invoke(app, args)
    assert again.exit_code == 0, again.output
    refused(work, [*args, "--seed", "2"], "run.zarr", "seed", "2")


def test_a_store_holding_a_users_file_is_not_recreated(work) -> None:
    """A store of the same scenario without a checkpoint would be written afresh: never
    over a file that is not the store's."""
    (work / "run.zarr" / "notes.txt").write_text("mine")
    store = zarr.open_group(work / "run.zarr", mode="a")
    del store.attrs["checkpoint"]
    store.attrs["complete"] = False
    args = ["run", str(work / "tiny.toml"), "--out", str(work / "run.zarr"), "-q"]
    refused(work, args, "run.zarr", "notes.txt")


def test_plot_does_not_replace_a_users_png(work) -> None:
    (work / "run_friction.png").write_bytes(b"the user's figure")
    refused(work, ["plot", str(work / "run.zarr")], "run_friction.png")


@pytest.mark.parametrize(
    "setup",
    [
        lambda store: (store / "zarr.json").write_text("{not json"),
        lambda store: zarr.open_group(store, mode="a").attrs.pop("scenario"),
        lambda store: zarr.open_group(store, mode="a").attrs.update(scenario='{"joint": '),
        lambda store: zarr.open_group(store, mode="a").attrs.update(scenario="[1, 2]"),
    ],
    ids=["garbled zarr.json", "no scenario attr", "garbled scenario", "scenario not a table"],
)
@pytest.mark.parametrize("command", ["info", "plot", "run", "fit"])
def test_unreadable_or_foreign_stores_are_refused(work, setup: Callable, command) -> None:
    setup(work / "run.zarr")
    args = [command, str(work / "run.zarr")]
    if command == "run":
        args = ["run", str(work / "tiny.toml"), "--out", str(work / "run.zarr")]
    if command == "fit":
        args += ["--out", str(work.parent / "fit")]
    refused(work, args, "run.zarr")


# Damaged stores.


def _flip_bytes(chunk: Path) -> None:
    data = bytearray(chunk.read_bytes())
    data[len(data) // 2] ^= 0xFF
    chunk.write_bytes(bytes(data))


DAMAGE = {
    "data chunk deleted": (lambda s: (s / "friction_force/c/0").unlink(), "missing"),
    "time chunk deleted": (lambda s: (s / "time/c/0").unlink(), "missing"),
    "snapshot chunk deleted": (lambda s: (s / "block_stress/c/2/0/0").unlink(), "missing"),
    "bytes flipped": (lambda s: _flip_bytes(s / "slider_velocity/c/0"), "unreadable"),
    "array metadata deleted": (lambda s: (s / "n_events/zarr.json").unlink(), "missing"),
    "snapshot array deleted": (lambda s: shutil.rmtree(s / "block_pinned"), "missing"),
    "root metadata deleted": (lambda s: (s / "zarr.json").unlink(), "missing"),
}
NAMED = {
    "data chunk deleted": "friction_force: samples 0-100",
    "time chunk deleted": "time: samples 0-100",
    "snapshot chunk deleted": "block_stress: snapshots 2-2",
    "bytes flipped": "slider_velocity: samples 0-100",
    "array metadata deleted": "n_events: array missing",
    "snapshot array deleted": "block_pinned: array missing",
    "root metadata deleted": "root zarr.json missing",
}


@pytest.mark.parametrize("damage", DAMAGE)
@pytest.mark.parametrize("command", ["info", "plot", "run", "fit", "diagnose"])
def test_damaged_stores_are_reported_by_array_and_range(work, damage, command) -> None:
    """Every command that reads a run store names its damage (fit and diagnose read it as
    data: a lost chunk would otherwise be fill values, a lost array a made-up column)."""
    harm, word = DAMAGE[damage]
    harm(work / "run.zarr")
    args = [command, str(work / "run.zarr")]
    if command == "run":
        args = ["run", str(work / "tiny.toml"), "--out", str(work / "run.zarr"), "-q"]
    if command in ("fit", "diagnose"):
        args += ["--out", str(work.parent / command)]
    refused(work, args, "run.zarr", "damaged", NAMED[damage], word)


@pytest.mark.parametrize("command", ["fit", "diagnose"])
@pytest.mark.parametrize("suffix", [".nc", ".zarr"])
def test_a_file_that_is_not_what_its_name_says_is_refused_by_name(tmp_path, command, suffix):
    """Garbage named .nc, and a directory named .zarr that is no zarr store."""
    data = tmp_path / f"data{suffix}"
    if suffix == ".nc":
        data.write_bytes(b"not a netCDF file\n" * 10)
    else:
        data.mkdir()
        (data / "notes.txt").write_text("a user's notes")
    form = "netCDF" if suffix == ".nc" else "zarr"
    refused(tmp_path, [command, str(data), "--out", str(tmp_path / "out")], str(data), form)


def test_a_sweep_point_that_cannot_run_is_refused_before_any_task(tmp_path) -> None:
    args = ["sweep", _tiny(tmp_path), "--set", "joint.temperature=300,3000"]
    args += ["--set", "interface.n_contacts=400", "--out", str(tmp_path / "s")]
    refused(tmp_path, args, "tiny.toml, task 0001", "3000 K", "per sample")


def test_a_store_written_before_checksums_still_opens_and_reports_bad_bytes(tmp_path) -> None:
    """Stores from before issue 17 have no crc32c and may omit chunks of fill values:
    they open as before; a chunk of random bytes (not zstd) is still reported, and so is a
    missing chunk of an array filled with NaN (a run never stores NaN)."""
    run = simulate(load_scenario(scenario_file(tmp_path, TINY)))
    old = tmp_path / "old.zarr"
    run.to_zarr(old, zarr_format=3, consolidated=False)
    result = CliRunner().invoke(app, ["info", str(old)])
    assert result.exit_code == 0, result.output
    assert "block depinnings" in result.output
    chunk = old / "friction_force" / "c" / "0"
    chunk.write_bytes(np.random.default_rng(17).bytes(chunk.stat().st_size))
    refused(tmp_path, ["info", str(old)], "friction_force: samples 0-100 unreadable")
    chunk.unlink()  # a missing chunk of a NaN-filled array would read as NaN: lost data
    refused(tmp_path, ["info", str(old)], "friction_force: samples 0-100 missing")


def test_a_record_ending_before_the_state_evolves_is_refused(tmp_path) -> None:
    """31 um of travel after the step of a D_c = 20 um record: the aging-law fit gives D_c
    = 50 +- 124 um, which the record cannot bound; refused naming the column and both
    lengths. The same record run on to 105 um after the step is fitted (D_c 20.0 +- 0.09
    um)."""
    from tests.rsf_synthetic import record

    truth = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6}
    data = record("aging", truth, "velocity_step", 2500.0, np.random.default_rng(4), n_samples=2000)
    step = int(np.flatnonzero(np.diff(data["load_point_velocity"].values))[0]) + 1
    columns = ("time", "mu", "load_point_velocity", "load_point_displacement")
    for after, ok in ((30, False), (100, True)):
        csv = tmp_path / f"step{after}.csv"
        table = np.column_stack([data[c].values[: step + after] for c in columns])
        header = "# stiffness_per_load: 2500\n" + ",".join(columns)
        np.savetxt(csv, table, delimiter=",", header=header, comments="")
        args = ["fit", str(csv), "--out", str(tmp_path / f"out{after}")]
        if ok:
            done = CliRunner().invoke(app, args)
            assert done.exit_code == 0, done.output
        else:
            refused(tmp_path, args, "step30.csv", "load_point_velocity", "31.5 um", "D_c =")


@pytest.mark.parametrize("command", ["fit", "diagnose"])
def test_fit_and_diagnose_keep_a_users_files_and_replace_their_own(tmp_path, command) -> None:
    """--out holding a user's file is refused before work; a previous output of the same
    command is replaced."""
    from tests.rsf_synthetic import record

    rng = np.random.default_rng(4)
    truth = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6}
    data = record("aging", truth, "velocity_step", 2500.0, rng, n_samples=200)
    csv = tmp_path / "step.csv"
    columns = ("time", "mu", "load_point_velocity")
    table = np.column_stack([data[c].values for c in columns])
    header = "# stiffness_per_load: 2500\n" + ",".join(columns)
    np.savetxt(csv, table, delimiter=",", header=header, comments="")
    folder = tmp_path / "results"
    folder.mkdir()
    (folder / "notes.md").write_text("my notes")
    extra = ["--no-simulate", "--no-progress"] if command == "diagnose" else []
    refused(tmp_path, [command, str(csv), "--out", str(folder), *extra], "results", "notes.md")
    own = tmp_path / "own"
    for _ in range(2):
        done = CliRunner().invoke(app, [command, str(csv), "--out", str(own), *extra])
        assert done.exit_code == 0, done.output


def test_fit_on_a_run_store_at_one_velocity_is_refused(work) -> None:
    """A simulator store carries its drive as load-point displacement only: a single
    velocity was fitted with a, b and D_c +- inf (rc 0) before the displacement's segments
    were counted as the CSV's velocity column is."""
    out = work.parent / "fit"
    refused(work, ["fit", str(work / "run.zarr"), "--out", str(out)], "run.zarr",
            "'load_point_displacement' gives one velocity (1e-06 m/s)")  # fmt: skip


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc")
@pytest.mark.parametrize("command", ["run", "sweep", "plot", "fit", "diagnose"])
def test_an_output_where_no_file_can_be_made_is_refused_before_work(work, command) -> None:
    """/proc refuses new files even to root (a read-only or foreign directory for a user):
    the commands failed with an unexpected FileNotFoundError, run after the simulation."""
    store, out = str(work / "run.zarr"), "/proc/nanoblock-output"
    args = {
        "run": ["run", str(work / "tiny.toml"), "--out", f"{out}.zarr"],
        "sweep": ["sweep", str(work / "tiny.toml"), "--out", out],
        "plot": ["plot", store, "--out", out],
        "fit": ["fit", store, "--out", out],
        "diagnose": ["diagnose", store, "--out", out],
    }[command]
    refused(work, args, "/proc: refuses a new file", "--out must lie in a writable directory")
