"""xlook binaries and recipes: a synthetic binary from an independent writer (the layout of
the module docstring), recipe semantics against closed forms, refusals by name, and the
Penn State originals against the shared CSVs reduced from them."""

from __future__ import annotations

import struct
import warnings
from pathlib import Path

import numpy as np
import pytest

from nanoblock.measured import DataError, load_measurement
from nanoblock.xlook import RecipeWarning, load_xlook, parse_rows, read_xlook, step_velocity

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
RAW = SHARED_DATA / "raw"
WINDOWS = {  # shared CSV -> its source rows (the CSVs' `source` metadata line)
    "p655_100MPa_vstep_2p3to23": (71297, 76954),
    "p655_100MPa_vstep_23to229": (74428, 80583),
    "p655_100MPa_vstep_229to2p3": (78854, 82353),
    "p655_75MPa_vstep_2p3to23": (21058, 33559),
    "p655_75MPa_vstep_23to229": (29401, 37078),
}
needs_raw = pytest.mark.skipif(not RAW.is_dir(), reason=f"laboratory originals absent ({RAW})")


def write_xlook(path: Path, channels: dict[str, tuple[str, np.ndarray]], headers=32) -> Path:
    """An xlook binary: title, nrec/nchan/swp/dtime, 84-byte channel headers, big-endian
    float32 channels one after another."""
    nrec = len(next(iter(channels.values()))[1])
    out = bytearray(b"synthetic".ljust(20, b"\0"))
    out += struct.pack(">iiif", nrec, len(channels), 0, 0.0)
    for k in range(headers):
        name, (unit, _) = (list(channels.items()) + [("no_val", ("no_val", None))] * headers)[k]
        nelem = nrec if k < len(channels) else 0
        out += struct.pack(">13s13sf50si", name.encode(), unit.encode(), 1.0, b"", nelem)
    for _, values in channels.values():
        out += struct.pack(f">{nrec}f", *values)
    path.write_bytes(bytes(out))
    return path


def _experiment(n: int = 600) -> dict[str, tuple[str, np.ndarray]]:
    """Raw channels of a synthetic step: period 0.1 s (1000 x 1e-4 s), load point at 1 then
    10 um/s from row 299 (t = 30 s) in bits of 0.5 um, shear and normal stress in bits."""
    period, row = np.full(n, 1000.0), np.arange(n)
    lp_um = np.where(row < 300, 0.1 * row, 29.9 + (row - 299) * 1.0)
    shear = 3000.0 + 10.0 * np.sin(np.arange(n) / 7.0)
    normal = np.full(n, 5000.0) + np.arange(n) % 3
    return {
        "Time": ("sec", period),
        "Vert_Disp": ("bits", lp_um / 0.5),
        "Vert_Load": ("bits", shear),
        "Hor_Load": ("bits", normal),
    }


RECIPE = """begin
read synthetic_l
# the period to column 6, time into column 5
math 1 * 1 = 6 period msec
math 6 / 10000 = 5 period sec
summation 5 5 Time sec
r_col 6
math 2 * 0.5 = 1 LP_disp micron
math 3 * 0.001 = 2 Shear_stress MPa
math 4,*,0.002,=,3 Nor_stress MPa   # commas separate too
r_col 4
offset_int 1 100 110 y
zero 1 5
math_int 2 * 0.0 = 2 0 5 Shear_stress MPa
ec 1 2 8 0 -1 0.2 ec_disp mic
math 2 / 3 : 6 mu .
r_row 590 599
plotall 8 6
end
anything after end is not read
"""


def _expected(n: int = 600) -> dict[str, np.ndarray]:
    """The recipe above in closed form (float64 from the float32 bits)."""
    raw = {name: values.astype(np.float32).astype(float) for name, (_, values) in
           _experiment(n).items()}  # fmt: skip
    time = np.cumsum(raw["Time"] / 10000)
    lp = raw["Vert_Disp"] * 0.5
    lp[100:110] = lp[100]
    lp[110:] -= raw["Vert_Disp"][110] * 0.5 - lp[100]
    lp -= lp[5]
    shear = raw["Vert_Load"] * 0.001
    shear[:6] = 0.0
    normal = raw["Hor_Load"] * 0.002
    slip = lp - (shear - shear[0]) / 0.2
    keep = np.r_[0:590]
    return {
        "time": time[keep],
        "mu": (shear / normal)[keep],
        "load_point_displacement": lp[keep] * 1e-6,
        "slip": slip[keep] * 1e-6,
        "normal_stress": normal[keep] * 1e6,
    }


@pytest.fixture
def synthetic(tmp_path) -> tuple[Path, Path]:
    binary = write_xlook(tmp_path / "synthetic_l", _experiment())
    recipe = tmp_path / "synthetic_r"
    recipe.write_text(RECIPE)
    return binary, recipe


def test_raw_channels_read_as_written(tmp_path) -> None:
    channels = _experiment(50)
    for headers in (32, 16):
        table = read_xlook(write_xlook(tmp_path / f"h{headers}", channels, headers))
        assert table.title == "synthetic" and table.nrec == 50
        assert table.names == {1: "Time", 2: "Vert_Disp", 3: "Vert_Load", 4: "Hor_Load"}
        assert table.units[2] == "bits"
        np.testing.assert_array_equal(table.values[2], channels["Vert_Disp"][1].astype(np.float32))


def test_recipe_reduces_as_the_closed_form(synthetic) -> None:
    """Every implemented command (math = and :, commas, math_int, summation, r_col,
    offset_int, zero, ec, r_row) against the same reduction written out by hand."""
    binary, recipe = synthetic
    data = load_xlook(binary, recipe)
    expected = _expected()
    assert data.attrs["kind"] == "time_series" and data.sizes["sample"] == 590
    for name in ("time", "mu", "load_point_displacement", "slip"):
        np.testing.assert_allclose(data[name].values, expected[name], rtol=1e-12, atol=1e-15)
        assert data[name].attrs["units"] and data[name].attrs["long_name"]
    assert data.attrs["normal_stress"] == pytest.approx(expected["normal_stress"].mean())
    # ec 0.2 MPa/um = 2e11 Pa/m over the mean normal stress
    assert data.attrs["stiffness_per_load"] == pytest.approx(2e11 / data.attrs["normal_stress"])


def test_row_window_and_the_detected_load_point_velocity(synthetic) -> None:
    """Rows 200-499 hold the 1 -> 10 um/s step at row 299 (time 30 s)."""
    binary, recipe = synthetic
    data = load_measurement(binary, recipe=recipe, rows=(200, 499))
    assert data.sizes["sample"] == 300
    np.testing.assert_allclose(data["time"].values[[0, -1]], [20.1, 50.0])
    velocity = data["load_point_velocity"].values
    np.testing.assert_allclose(velocity[:99], 1e-6, rtol=1e-6)
    np.testing.assert_allclose(velocity[99:], 1e-5, rtol=1e-6)  # from the kink sample on


def test_step_velocity_on_noisy_steps_and_a_hold() -> None:
    """1 um/s, a 20 s hold, 10 um/s, 3 um/s at 10 Hz with 0.05 um noise."""
    rng = np.random.default_rng(0)
    time = np.arange(0.0, 80.0, 0.1)
    speed = np.select([time < 20, time < 40, time < 60], [1e-6, 0.0, 1e-5], 3e-6)
    x = np.concatenate([[0.0], np.cumsum(speed[:-1] * 0.1)]) + rng.normal(0, 5e-8, time.size)
    velocity = step_velocity(time, x)
    changes = time[np.flatnonzero(np.diff(velocity)) + 1]
    np.testing.assert_allclose(changes, [20.0, 40.0, 60.0], atol=0.15)
    assert velocity[300] == 0.0
    np.testing.assert_allclose(velocity[[100, 500, 700]], [1e-6, 1e-5, 3e-6], rtol=0.01)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda raw: raw[:-7], "truncated"),
        (lambda raw: b"\x00" * 20 + struct.pack(">ii", 5, 0) + raw[28:], "nchan = 0"),
        (lambda raw: bytes(np.random.default_rng(1).integers(0, 256, 3000, np.uint8)), "xlook"),
        (lambda raw: raw[:100], "shorter than the smallest header"),
    ],
)
def test_truncated_or_garbage_binary_is_refused_by_name(synthetic, edit, message) -> None:
    binary, recipe = synthetic
    binary.write_bytes(edit(binary.read_bytes()))
    with pytest.raises(DataError, match=message) as error:
        load_measurement(binary, recipe=recipe)
    assert str(binary) in str(error.value)


def test_binary_without_recipe_asks_for_one_and_a_recipe_finds_its_binary(synthetic) -> None:
    binary, recipe = synthetic
    with pytest.raises(DataError, match=r"raw channels \['Time', .*give its reduction recipe"):
        load_measurement(binary)
    np.testing.assert_array_equal(
        load_measurement(recipe)["mu"].values, load_xlook(binary, recipe)["mu"].values
    )
    # a recipe away from its binary was read as a CSV ("header has 1 columns ['begin']"),
    # and a CSV given as the recipe warned of 5659 skipped 'commands', one per data row
    alone = recipe.parent / "elsewhere" / recipe.name
    alone.parent.mkdir()
    alone.write_text(recipe.read_text())
    with pytest.raises(DataError, match=r"an xlook recipe; the binary it reads \('synthetic_l'\)"):
        load_measurement(alone)
    table = recipe.parent / "friction.csv"
    table.write_text("time,mu\n0,0.6\n1,0.61\n")
    with pytest.raises(DataError, match=r"friction.csv: not an xlook recipe \(no 'begin' line"):
        load_xlook(binary, table)


def test_a_recipe_that_reads_another_binary_is_said_so(synthetic) -> None:
    """p655_r applied to p446s7tr005l gave mu0 0.036 with exit 0 and no word: the gains
    of one record applied to another. The recipe's own binary reads without the warning."""
    binary, recipe = synthetic
    renamed = binary.with_name("other_l")
    renamed.write_bytes(binary.read_bytes())
    with pytest.warns(RecipeWarning, match=r"reads 'synthetic_l' .*not 'other_l'"):
        load_xlook(renamed, recipe)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RecipeWarning)
        load_xlook(binary, recipe)


def test_skipped_commands_warn_and_never_leave_a_stale_column(synthetic) -> None:
    binary, recipe = synthetic
    text = recipe.read_text()
    recipe.write_text(text.replace("plotall 8 6", "frobnicate 1 2"))
    with pytest.warns(RecipeWarning, match=r"line 18: frobnicate 1 2"):
        load_xlook(binary, recipe)
    recipe.write_text(text.replace("plotall 8 6", "smooth 6 6 0 -1 5 mu ."))
    with (
        pytest.warns(RecipeWarning),
        pytest.raises(DataError, match=r"column 6 for 'mu' was rewritten .*smooth 6 6"),
    ):
        load_xlook(binary, recipe)


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("zero 9 3", r"line 18 \(zero 9 3\): column 9 is empty"),
        ("zero 1 7000", r"row 7000 outside 0\.\.589"),
        ("math 1 ^ 2 = 7", "expected 'math COL OP VALUE = OUT'"),
        ("ec 1 2 8 0 -1 0", "elastic constant must not be 0"),
        # accepted until 2026-11-29: reversed ranges did nothing or shifted the wrong way
        ("offset_int 1 40 20 n", r"rows 40 20 run backwards \(40 > 20\)"),
        ("math_int 1 * 2 = 7 -1 3", r"rows -1 3 run backwards \(589 > 3\)"),
        ("r_row 30 10", r"rows 30 10 run backwards"),
        ("ec 1 2 8 -1 0 1e3", r"rows -1 0 run backwards"),
        ("r_row 0 -1", r"removes all 590 rows"),
        ("math 1 * 2 = 0", r"output column 0 outside 1\.\.32"),
        ("summation 1 -3", r"output column -3 outside 1\.\.32"),
        ("r_col 9", r"column 9 is empty"),
    ],
)
def test_bad_recipe_lines_are_refused_with_the_line(synthetic, line, message) -> None:
    binary, recipe = synthetic
    recipe.write_text(recipe.read_text().replace("plotall 8 6", line))
    with pytest.raises(DataError, match=message) as error:
        load_xlook(binary, recipe)
    assert str(recipe) in str(error.value)


@pytest.mark.parametrize(("rows", "row"), [(None, 250), ((200, 499), 250)])
def test_a_recipe_that_divides_by_zero_is_refused_at_its_xlook_row(synthetic, rows, row):
    """mu = shear / normal with the normal stress zeroed from row 250 on (a recipe's own
    arithmetic, not a typo in a CSV): refused at that row of the reduced table, not at a
    CSV file line the binary does not have (until 2026-11-29: "data row 51 (file line
    51)" for the window 200:499)."""
    binary, recipe = synthetic
    zeroed = "math_int 3 * 0.0 = 3 250 -1 Nor_stress MPa\nmath 2 / 3 : 6 mu ."
    recipe.write_text(recipe.read_text().replace("math 2 / 3 : 6 mu .", zeroed))
    with pytest.raises(DataError, match=rf"'mu' has inf at xlook row {row} \(after the recipe\)"):
        load_xlook(binary, recipe, rows=rows)


def test_rows_outside_the_table_and_unknown_column_names_are_refused(synthetic) -> None:
    binary, recipe = synthetic
    with pytest.raises(DataError, match=r"rows \(10, 700\) must satisfy .* <= 589"):
        load_xlook(binary, recipe, rows=(10, 700))
    with pytest.raises(DataError, match=r"no column named 'friction' for 'mu'"):
        load_xlook(binary, recipe, columns={"mu": "friction"})
    data = load_xlook(binary, recipe, columns={"load_point_displacement": 8})  # the ec column
    np.testing.assert_allclose(data["load_point_displacement"].values, _expected()["slip"])


@needs_raw
@pytest.mark.filterwarnings("ignore::nanoblock.xlook.RecipeWarning")
@pytest.mark.parametrize("name", sorted(WINDOWS))
def test_p655_binary_gives_the_shared_csv(name) -> None:
    """mu, load-point displacement, slip and velocity of each shared p655 window, from the
    original binary and recipe; rows matched on time."""
    csv = load_measurement(SHARED_DATA / f"{name}.csv")
    data = load_xlook(RAW / "p655intact100l", RAW / "p655_r", rows=WINDOWS[name])
    np.testing.assert_allclose(data["time"].values, csv["time"].values, atol=1e-6)
    assert np.abs(data["mu"].values - csv["mu"].values).max() < 1e-5
    for displacement in ("load_point_displacement", "slip"):
        np.testing.assert_allclose(data[displacement], csv[displacement], atol=1e-10)
    velocity = data["load_point_velocity"].values / csv["load_point_velocity"].values
    assert np.mean(np.abs(velocity - 1.0) < 1e-3) > 0.999  # the step placed within a sample
    assert data.attrs["stiffness_per_load"] == pytest.approx(csv.attrs["stiffness_per_load"], 1e-3)


@needs_raw
def test_p446_binary_reads_with_plausible_friction() -> None:
    with pytest.warns(RecipeWarning, match=r"ras 5 1 9 .*smooth 6 10"):
        data = load_xlook(RAW / "p446s7tr005l", RAW / "p446_r")
    mu = data["mu"].values
    assert data.sizes["sample"] == 149058 and np.isfinite(mu).all()
    assert 0.55 < np.median(mu[600:148000]) < 0.62 and mu.max() < 0.7
    assert 1e7 < data.attrs["normal_stress"] < 1.5e7


def test_rows_option_text_and_the_diagnosis_loader(synthetic) -> None:
    from nanoblock.diagnosis.validation import load_for_diagnosis

    binary, recipe = synthetic
    assert parse_rows("200:499") == (200, 499)
    for text in ("", "200", "a:b", "1:2:3"):
        with pytest.raises(DataError, match=f"rows '{text}' must be FIRST:LAST"):
            parse_rows(text)
    data = load_for_diagnosis(binary, recipe=recipe, rows=parse_rows("200:499"))
    np.testing.assert_allclose(data["mu"].values, _expected()["mu"][200:500], rtol=1e-12)
    from typer.testing import CliRunner

    from nanoblock.cli import app

    # --rows "" read the whole file, as if the option had not been given
    done = CliRunner().invoke(app, ["fit", str(binary), "--recipe", str(recipe), "--rows", ""])
    assert done.exit_code == 2 and "rows '' must be FIRST:LAST" in done.output, done.output


@needs_raw
@pytest.mark.filterwarnings("ignore::nanoblock.xlook.RecipeWarning")
def test_p655_binary_fits_as_the_csv() -> None:
    """The aging-law fit of the 100 MPa 2.3 -> 23 um/s step from the binary and from the
    CSV agree (the detected velocity history is as usable as the CSV's)."""
    from nanoblock.rsf.fit import fit_rsf

    name = "p655_100MPa_vstep_2p3to23"
    data = load_xlook(RAW / "p655intact100l", RAW / "p655_r", rows=WINDOWS[name])
    ours = fit_rsf(data, "aging", trend=True).contract
    theirs = fit_rsf(load_measurement(SHARED_DATA / f"{name}.csv"), "aging", trend=True).contract
    for key in ("mu0", "a", "b", "dc"):
        assert ours[key] == pytest.approx(theirs[key], rel=0.01), key
