"""Measured-data reading: the format of physics.md section 6, bad data refused by name,
dropped rows counted; ``nanoblock fit`` end to end."""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from nanoblock.cli import app
from nanoblock.measured import DataError, DroppedRowsWarning, load_measurement, runs
from tests.rsf_synthetic import record, write_csv

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
TRUTH = {"mu0": 0.6, "a": 0.01, "b": 0.013, "dc": 2e-5, "v0": 1e-6}


@pytest.fixture
def csv_text(tmp_path) -> str:
    rng = np.random.default_rng(0)
    data = record("aging", TRUTH, "velocity_step", 2500.0, rng, n_samples=200)
    return write_csv(data, tmp_path / "good.csv", {"stiffness_per_load": 2500}).read_text()


def _write(tmp_path: Path, text: str, name: str = "data.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _edit_row(text: str, row: int, column: int, value: str) -> str:
    """Replace one value of data row ``row`` (1-based) in a CSV text."""
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if not line.startswith("#")) + 1
    cells = lines[first + row - 1].split(",")
    cells[column] = value
    lines[first + row - 1] = ",".join(cells)
    return "\n".join(lines) + "\n"


def test_good_file_reads_with_metadata_and_units(tmp_path, csv_text: str) -> None:
    data = load_measurement(_write(tmp_path, csv_text))
    assert data.attrs["kind"] == "time_series"
    assert data.attrs["stiffness_per_load"] == 2500.0
    assert data.sizes["sample"] == 200
    for variable in data.data_vars.values():
        assert variable.attrs["units"] and variable.attrs["long_name"]


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace(",mu,", ",friction,"), "column 'mu' is missing"),
        (
            lambda t: t.replace(",load_point_velocity,load_point_displacement", ",a,b"),
            "the drive is missing",
        ),
        (lambda t: t.replace("# stiffness_per_load: 2500", "# stiffness_per_load: -3"), "> 0"),
        (
            lambda t: t.replace("# stiffness_per_load: 2500", "# stiffness_per_load: stiff"),
            "number",
        ),
        (  # a typo once dropped the stated stiffness and the fit estimated one instead
            lambda t: t.replace("# stiffness_per_load: 2500", "# stifness_per_load: 2500"),
            "metadata key 'stifness_per_load' on line 1 is not known; did you mean "
            "'stiffness_per_load'?",
        ),
        (
            lambda t: "# apparatus: rocket\n" + t,
            "metadata 'apparatus' on line 1 is 'rocket'; allowed: spring_slider, clamped_sample",
        ),
    ],
)
def test_structural_errors_name_the_column_or_key(tmp_path, csv_text, edit, message) -> None:
    with pytest.raises(DataError) as error:
        load_measurement(_write(tmp_path, edit(csv_text)))
    assert message in str(error.value)


@pytest.mark.parametrize("mark", [";", "\t"])
def test_a_csv_with_another_separator_is_told_so(tmp_path, csv_text: str, mark: str) -> None:
    """A semicolon CSV was refused as 'column time;mu;... must be numeric'."""
    text = "\n".join(
        line if line.startswith("#") else line.replace(",", mark) for line in csv_text.splitlines()
    )
    with pytest.raises(DataError, match=re.escape(f"has no comma but {mark!r}: the columns")):
        load_measurement(_write(tmp_path, text))


def test_free_text_metadata_is_kept_as_notes(tmp_path, csv_text: str) -> None:
    """Keys the lab files carry beside the known ones are notes, not misspellings."""
    notes = "# stiffness_note: not stated\n# normal_stress_range: 7.9 to 8.0 MPa\n# k_sf: 3\n"
    data = load_measurement(_write(tmp_path, notes + csv_text))
    assert data.attrs["stiffness_note"] == "not stated" and data.attrs["k_sf"] == "3"
    assert data.attrs["stiffness_per_load"] == 2500.0


def test_unsorted_and_repeated_time_name_the_row(tmp_path, csv_text: str) -> None:
    lines = csv_text.splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    row_40 = lines[header + 40].split(",")
    repeated = _edit_row(csv_text, 41, 0, row_40[0])
    with pytest.raises(DataError, match=r"'time' is repeated at data row 41"):
        load_measurement(_write(tmp_path, repeated))
    unsorted = _edit_row(csv_text, 41, 0, "-1")
    with pytest.raises(DataError, match=r"decreasing \(unsorted\) at data row 41 .*: -1.0 after"):
        load_measurement(_write(tmp_path, unsorted))
    # rows with a missing value are dropped first; the row named is still the file's
    # (until 2026-11-29 it moved one row earlier per dropped row: "data row 39")
    lines = _edit_row(_edit_row(unsorted, 10, 1, "nan"), 20, 1, "").splitlines()
    first = header + 2  # file line (1-based) of data row 1
    with (
        pytest.warns(DroppedRowsWarning),
        pytest.raises(
            DataError, match=rf"decreasing \(unsorted\) at data row 41 \(file line {first + 40}\)"
        ),
    ):
        load_measurement(_write(tmp_path, "\n".join(lines) + "\n"))


@pytest.mark.parametrize(
    ("row", "column", "value", "message"),
    [
        (
            30,
            1,
            "1e308",
            r"'mu' has 1e\+308 at data row 30 \(file line \d+\); allowed: \|mu\| <= 10",
        ),
        (7, 1, "-25", r"'mu' has -25 at data row 7 .*\|mu\| <= 10 \(a friction coefficient\)"),
        (12, 3, "4e200", r"'load_point_displacement' has 4e\+200 at data row 12 .*1e\+100"),
        # inf was dropped as a missing value: an overflow (1e400) vanished from the record
        (15, 1, "inf", r"'mu' has inf at data row 15 \(file line \d+\); allowed: \|mu\| <= 10"),
        (16, 0, "-1e400", r"'time' has -inf at data row 16 .*allowed: \|time\| <= 1e\+100"),
        (17, 3, "-inf", r"'load_point_displacement' has -inf at data row 17 "),
    ],
)
def test_values_no_record_can_hold_are_refused_by_column_and_row(
    tmp_path, csv_text, row, column, value, message
) -> None:
    """A friction coefficient of 1e308 overflowed the fit (which then blamed the slip
    after the step) and the diagnosis stored inf; |mu| > 10, |value| > 1e100 and inf are
    refused where the file is read."""
    with pytest.raises(DataError, match=message):
        load_measurement(_write(tmp_path, _edit_row(csv_text, row, column, value)))


def test_nan_rows_are_dropped_with_a_counting_warning(tmp_path, csv_text: str) -> None:
    text = _edit_row(_edit_row(csv_text, 10, 1, "nan"), 20, 1, "")
    with pytest.warns(DroppedRowsWarning, match=r"dropped 2 of 200 rows .* \[10, 20\]"):
        data = load_measurement(_write(tmp_path, text))
    assert data.sizes["sample"] == 198 and data.attrs["dropped_rows"] == 2
    out = tmp_path / "fit"  # the drop is part of the fit's record, not only a warning
    result = CliRunner().invoke(app, ["fit", str(tmp_path / "data.csv"), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert json.loads((out / "fit.json").read_text())["dropped_rows"] == 2
    assert (
        "2 rows with a missing (NaN or empty) value were dropped" in (out / "report.md").read_text()
    )


def test_a_column_without_any_value_is_named(tmp_path) -> None:
    """An all-NaN load_point_velocity was reported as 'every row has a missing value in
    ['time', 'mu']', the two complete columns."""
    table = "time,mu,load_point_velocity\n0,0.6,nan\n1,0.61,nan\n2,0.62,\n"
    with pytest.raises(DataError, match=r"column\(s\) \['load_point_velocity'\] hold no value"):
        load_measurement(_write(tmp_path, table))


def test_the_command_line_shows_a_warning_in_one_line(tmp_path, csv_text: str) -> None:
    """Warnings printed the Python file, line and source line that raised them."""
    import subprocess
    import sys

    text = csv_text.replace("load_point_displacement", "load_point_displacement,x", 1)
    lines = [line + (",1" if line[0].isdigit() else "") for line in text.splitlines()]
    path = _write(tmp_path, "\n".join(lines) + "\n")
    done = subprocess.run(
        [sys.executable, "-m", "nanoblock", "fit", str(path), "--out", str(tmp_path / "f")],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stderr.startswith(f"warning: {path}: ignoring unknown column(s) ['x']")
    assert ".py:" not in done.stderr and "UserWarning" not in done.stderr, done.stderr


@pytest.mark.parametrize("value", ["0", "-20", "nan"])
def test_a_temperature_at_or_below_absolute_zero_is_refused(tmp_path, value) -> None:
    """0 K in a steady table's temperature column ended in 'block_size must be a finite
    positive number ... got inf', naming neither file nor column; fit accepted it."""
    rows = ["1e-6,0.60,300", "1e-5,0.61,300", f"1e-6,0.62,{value}", "1e-5,0.63,320"]
    path = _write(tmp_path, "load_point_velocity,mu,temperature\n" + "\n".join(rows) + "\n")
    with pytest.raises(DataError, match=r"column 'temperature' must be > 0 K .*data row 3"):
        load_measurement(path)


def test_a_run_too_short_to_fit_is_named_with_its_file(tmp_path) -> None:
    """'a run has only 2 samples; at least 10 are needed' named neither file nor run."""
    rows = [f"{t},0.6,1e-6,{'A' if t < 20 else 'B'}" for t in range(22)]
    path = _write(tmp_path, "time,mu,load_point_velocity,run\n" + "\n".join(rows) + "\n")
    result = CliRunner().invoke(app, ["fit", str(path), "--out", str(tmp_path / "f")])
    assert result.exit_code == 2
    assert f"{path}: run 'B' has only 2 samples; at least 10 are needed" in result.output


def test_negative_velocity_and_non_positive_steady_velocity_are_refused(tmp_path, csv_text):
    with pytest.raises(
        DataError,
        match=r"'load_point_velocity' must be >= 0 m/s; data row 5 \(file line \d+\) has -1e-06$",
    ):
        load_measurement(_write(tmp_path, _edit_row(csv_text, 5, 2, "-1e-6")))
    table = "load_point_velocity,mu\n1e-6,0.6\n0,0.61\n1e-4,0.62\n"
    with pytest.raises(DataError, match=r"must be > 0 \(its log is taken\) m/s; data row 2"):
        load_measurement(_write(tmp_path, table, "steady.csv"))


def test_runs_split_by_run_column(tmp_path) -> None:
    table = "time,mu,load_point_velocity,run\n0,0.6,1e-6,1\n1,0.6,1e-6,1\n0,0.5,1e-6,2\n"
    data = load_measurement(_write(tmp_path, table))
    assert [part.sizes["sample"] for part in runs(data)] == [2, 1]


def test_cli_fit_writes_the_contract_and_refuses_an_unknown_law(tmp_path, csv_text) -> None:
    path = _write(tmp_path, csv_text)
    result = CliRunner().invoke(
        app, ["fit", str(path), "--law", "aging", "--out", str(tmp_path / "f")]
    )
    assert result.exit_code == 0, result.output
    content = json.loads((tmp_path / "f" / "fit.json").read_text())
    assert content["params"]["dc"] == pytest.approx(TRUTH["dc"], rel=0.2)
    assert (tmp_path / "f" / "report.md").exists() and (tmp_path / "f" / "fit.png").exists()
    bad = CliRunner().invoke(
        app, ["fit", str(path), "--law", "ruina", "--out", str(tmp_path / "g")]
    )
    assert bad.exit_code == 2
    assert "unknown law 'ruina'" in bad.output
    assert not (tmp_path / "g").exists()


@pytest.mark.skipif(not SHARED_DATA.is_dir(), reason=f"laboratory data absent ({SHARED_DATA})")
def test_every_laboratory_file_reads_and_fits() -> None:
    """The shared p655 and p4309 steps load and fit with a positive a and a finite Dc."""
    from nanoblock.rsf.fit import fit_rsf

    for path in sorted(SHARED_DATA.glob("*.csv")):
        result = fit_rsf(load_measurement(path), "aging", trend=True)
        assert 0.001 < result.contract["a"] < 0.05, path.name
        assert np.isfinite(result.contract_stderr["dc"]), path.name


def test_simulator_store_reads_as_a_time_series_and_fits(tmp_path, make_scenario) -> None:
    """A run store of a 1 -> 10 um/s step (reference mean-field joint, 400 contacts x 1
    block, D0 = 0.1 um, m = 0.05) reads like a measured step and ``nanoblock fit`` fits it
    through the unchanged path: a direct effect and a positive state effect with a
    memory length of order D0."""
    from nanoblock.engine import simulate

    d0 = 1e-7
    scenario = make_scenario(
        interface={
            "n_contacts": 400,
            "blocks_per_contact": 1,
            "memory_length": d0,
            "aging_m": 0.05,
            "aging_time": 1e-4,
        },
        loading={
            "stiffness": 1e7,
            "steps": [
                {"velocity": 1e-6, "displacement": d0},
                {"velocity": 1e-5, "displacement": 4 * d0},
            ],
        },
        run={"seed": 3, "record_every": 2e-4, "initial_state": "steady"},
    )
    store = tmp_path / "step.zarr"
    simulate(scenario, store)
    data = load_measurement(store)
    assert data.attrs["kind"] == "time_series"
    assert data.attrs["stiffness_per_load"] == pytest.approx(1e7)
    assert data.attrs["normal_force"] == 1.0 and data.attrs["temperature"] == 300.0
    assert set(data.data_vars) >= {"time", "mu", "load_point_displacement", "slip"}
    speed = np.diff(data["load_point_displacement"].values) / np.diff(data["time"].values)
    np.testing.assert_allclose(speed[[0, -1]], [1e-6, 1e-5], rtol=1e-9)
    for variable in data.data_vars.values():
        assert variable.attrs["units"] and variable.attrs["long_name"]
    result = CliRunner().invoke(
        app, ["fit", str(store), "--law", "aging", "--out", str(tmp_path / "f")]
    )
    assert result.exit_code == 0, result.output
    params = json.loads((tmp_path / "f" / "fit.json").read_text())["params"]
    assert 0.0 < params["a"] < params["b"]
    assert 0.1 * d0 < params["dc"] < 3 * d0


def test_rigid_drive_is_infinite_stiffness_metadata(tmp_path, csv_text: str) -> None:
    text = csv_text.replace("# stiffness_per_load: 2500", "# stiffness_per_load: inf")
    assert load_measurement(_write(tmp_path, text)).attrs["stiffness_per_load"] == np.inf


def test_byte_order_mark_and_text_run_ids_are_accepted(tmp_path, csv_text: str) -> None:
    plain = load_measurement(_write(tmp_path, csv_text))
    marked = tmp_path / "bom.csv"
    marked.write_bytes(b"\xef\xbb\xbf" + csv_text.encode())
    np.testing.assert_array_equal(load_measurement(marked)["mu"].values, plain["mu"].values)
    table = "time,mu,load_point_velocity,run\n0,0.6,1e-6,p655 a\n1,0.6,1e-6,p655 a\n0,0.5,1e-6,b\n"
    parts = runs(load_measurement(_write(tmp_path, table)))
    assert [part["run"].values[0] for part in parts] == ["p655 a", "b"]
    assert [part.sizes["sample"] for part in parts] == [2, 1]


def test_velocity_stresses_and_micrometres_are_converted(tmp_path) -> None:
    """`velocity` names a steady table's load-point velocity; mu = shear / normal stress;
    `displacement_unit: um` and `velocity_unit: um/s` scale to SI."""
    steady = load_measurement(_write(tmp_path, "velocity,mu\n1e-6,0.6\n1e-5,0.61\n", "s.csv"))
    assert steady.attrs["kind"] == "steady_state"
    np.testing.assert_array_equal(steady["load_point_velocity"].values, [1e-6, 1e-5])
    text = (
        "# displacement_unit: um\n# velocity_unit: um/s\n"
        "time,shear_stress,normal_stress,load_point_displacement,load_point_velocity\n"
        "0,6e6,1e7,0,1\n1,3.1e6,5e6,1.5,1\n"
    )
    data = load_measurement(_write(tmp_path, text))
    np.testing.assert_allclose(data["mu"].values, [0.6, 0.62])
    np.testing.assert_allclose(data["load_point_displacement"].values, [0.0, 1.5e-6])
    np.testing.assert_allclose(data["load_point_velocity"].values, [1e-6, 1e-6])
    assert "displacement_unit" not in data.attrs
    with pytest.raises(DataError, match=r"'displacement_unit' = 'inch'; allowed: \['m', 'mm'"):
        load_measurement(_write(tmp_path, text.replace(": um\n", ": inch\n")))
    with pytest.raises(DataError, match=r"'normal_stress' must be > 0 .* data row 2 has 0\.0"):
        load_measurement(_write(tmp_path, text.replace("3.1e6,5e6", "3.1e6,0")))


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("time,mu\n0,0.6\n".encode("utf-16"), "UTF-16 text; save the CSV as UTF-8"),
        ("time,mu\n0,0.6\n".encode("utf-16-le"), "NUL bytes"),
        (bytes(range(128, 256)) * 4, r"not UTF-8 text \(byte 0 is 0x80\)"),
        (
            b"time,mu,load_point_velocity\n0,0.6,1e-6\n1,abc,1e-6\n",
            r"'mu' must be numeric; data row 2",
        ),
        (b"time,mu,load_point_velocity\n0,0.6\n", r"data row 1 has 2 values but the header has 3"),
        (
            b"time,friction\n0,0.6\n",
            r"column 'mu' is missing .*'shear_stress' with 'normal_stress'",
        ),
        (b"speed,mu\n1e-6,0.6\n", r"'load_point_velocity' \(or 'velocity'\) is missing .*\['mu'"),
    ],
)
def test_unreadable_or_incomplete_files_name_the_file(tmp_path, content, message) -> None:
    path = tmp_path / "user.csv"
    path.write_bytes(content)
    with pytest.raises(DataError, match=message) as error, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        load_measurement(path)
    assert str(path) in str(error.value)


NAMES = ["time", "mu", "load_point_velocity", "load_point_displacement", "run", "x"]
CELLS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=32),
    st.sampled_from(["", "nan", "inf", "-1e400", "abc", "1,5", " 2 "]),
)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    columns=st.lists(
        st.sampled_from(NAMES),
        min_size=1, max_size=5, unique=True,
    ),
    rows=st.lists(st.lists(CELLS, min_size=5, max_size=5), min_size=0, max_size=12),
)  # fmt: skip
def test_any_csv_table_is_read_with_finite_values_or_refused_by_name(
    tmp_path, columns, rows
) -> None:
    """Generated CSV tables: the reader returns finite required columns, or a DataError
    that names the file (never another exception, never NaN)."""
    path = tmp_path / "table.csv"
    lines = [",".join(columns)] + [",".join(str(c) for c in row[: len(columns)]) for row in rows]
    path.write_text("\n".join(lines) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            data = load_measurement(path)
        except DataError as error:
            assert "table.csv" in str(error)
            return
    for name in ("time", "mu", "load_point_velocity"):
        if name in data:
            assert np.all(np.isfinite(data[name].values)), name


@pytest.mark.parametrize("command", ["fit", "diagnose"])
@pytest.mark.parametrize("rows", [["1e-6,0.6"], ["1e-6,0.6", "1e-5,0.61"]])
def test_a_table_too_small_to_fit_is_refused_naming_its_file(tmp_path, command, rows) -> None:
    """A steady table of one or two rows was refused ('2 samples cannot constrain 2 free
    parameters') without saying which file; the commands now start such a message with it."""
    path = _write(tmp_path, "load_point_velocity,mu\n" + "\n".join(rows) + "\n", "small.csv")
    done = CliRunner().invoke(app, [command, str(path), "--out", str(tmp_path / "out")])
    assert done.exit_code == 2, done.output
    assert done.output.startswith(f"error: {path}: "), done.output
    assert done.output.count("\n") == 1 and "Traceback" not in done.output
