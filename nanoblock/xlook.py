"""Penn State xlook binaries and their reduction recipes, read without xlook.

An xlook binary (the biax lab's raw record) is big-endian: a 20-byte title; int32
``nrec``, ``nchan``, ``swp``; float32 ``dtime``; then 32 channel headers (16 in older
files) of 84 bytes each: name[13], units[13], float32 gain, comment[50], int32 ``nelem``;
then ``nchan`` x ``nrec`` float32 values, channel by channel. Channel k of the header is
xlook column k + 1. A file whose size or header does not fit this layout is refused with
a :class:`~nanoblock.measured.DataError` saying what is wrong.

A recipe (the lab's ``*_r`` command file) turns the raw bits into engineering units. Its
lines run from ``begin`` to ``end``; ``#`` starts a comment, commas separate like blanks;
columns are 1-based slots, rows 0-based with ``-1`` for the last row, ranges inclusive
(a range that runs backwards, an output column outside 1..32, an empty input column or a
``r_row`` that removes every row is refused by its line).
These commands are applied (xlook's ``array.c`` semantics, in float64):

* ``math c op v = out [name unit]`` (constant v) and ``math c op c2 : out`` (column c2),
  op one of ``+ - * /``; ``math_int`` adds ``first last`` before the name, for a row range;
* ``summation c out``: the running sum of c;
* ``zero c row``: subtract the value at ``row``;
* ``offset_int c r1 r2 y|n``: remove the jump between r1 and r2 (``y`` also flattens the
  rows in between to the value at r1);
* ``ec disp tau out first last k``: the elastic correction
  ``out = disp - (tau - tau[first]) / k`` over ``first..last``;
* ``r_col c`` (empty a slot; others keep their numbers) and ``r_row first last`` (remove
  rows; later rows move up).

Plot and print commands (``plot*``, ``type``, ``head``, ``stats``) are ignored. Other
commands are skipped with one :class:`RecipeWarning` listing them by line. A skipped
command whose output column is known (``strain``, ``cs``, ``ras``, ``smooth``, ``deriv``,
the ``qi`` fits) leaves that column out, so a needed column it would have written is
refused, never read stale; the effect of a command of unknown syntax cannot be known.

:func:`load_xlook` gives the time series :func:`~nanoblock.measured.load_measurement`
gives for a CSV: ``time`` [s], ``mu``, ``load_point_displacement`` [m], ``slip`` [m] (the
elastically corrected displacement, when the recipe makes one) and
``load_point_velocity`` [m/s], piecewise constant, detected from the displacement by
:func:`step_velocity` (differentiating the raw displacement is far too noisy for a fit).
Columns are found by their recipe names (case-insensitive; see ``NAMES``), and converted
to SI from their unit strings (``micron``, ``mic``, ``um``, ``mm``, ``sec``, ``MPa``...).
``rows=(first, last)`` keeps an inclusive window of rows of the reduced table (xlook's row
numbers after the recipe ran), as the lab files hold whole experiments.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from nanoblock.measured import DataError

__all__ = [
    "NAMES",
    "RecipeWarning",
    "XlookTable",
    "apply_recipe",
    "is_xlook",
    "load_xlook",
    "parse_rows",
    "read_xlook",
    "recipe_reads",
    "reduce_xlook",
    "step_velocity",
]

_TITLE = 20
_FIXED = _TITLE + 16  # title, nrec, nchan, swp, dtime
_CHANNEL = 84
_HEADERS = (32, 16)  # channel headers in newer and older files


class RecipeWarning(UserWarning):
    """Recipe commands that were skipped (the message lists them by line)."""


@dataclass
class XlookTable:
    """xlook columns by slot number: name, unit and float64 values (NaN where unset)."""

    title: str
    names: dict[int, str]
    units: dict[int, str]
    values: dict[int, np.ndarray]
    nrec: int
    skipped: dict[int, tuple[str, str]] = field(default_factory=dict)
    """Slots a skipped recipe command would have written: their name then, and the command."""
    elastic: dict[int, float] = field(default_factory=dict)
    """Slots written by ``ec``: its elastic constant in SI [Pa/m] (NaN: unknown units)."""

    def set(self, slot: int, values: np.ndarray, name: str, unit: str) -> None:
        """Write column ``slot`` (named ``name`` [``unit``])."""
        self.values[slot], self.names[slot], self.units[slot] = values, name, unit
        self.skipped.pop(slot, None)

    def remove(self, slot: int) -> None:
        """Empty column ``slot``."""
        for mapping in (self.values, self.names, self.units):
            mapping.pop(slot, None)


def _header_count(size: int, nrec: int, nchan: int) -> int | None:
    for count in _HEADERS:
        if size == _FIXED + count * _CHANNEL + 4 * nrec * nchan:
            return count
    return None


def _text(raw: bytes) -> str:
    return raw.split(b"\0", 1)[0].decode("latin-1").strip()


def is_xlook(path: str | Path) -> bool:
    """Whether ``path`` is a file whose size and header fit the xlook binary layout."""
    path = Path(path)
    if not path.is_file() or path.stat().st_size < _FIXED + _HEADERS[1] * _CHANNEL:
        return False
    with path.open("rb") as handle:
        handle.seek(_TITLE)
        nrec, nchan = np.frombuffer(handle.read(8), ">i4")
    return (
        0 < nchan <= _HEADERS[0]
        and nrec > 0
        and bool(_header_count(path.stat().st_size, int(nrec), int(nchan)))
    )


def read_xlook(path: str | Path) -> XlookTable:
    """The raw channels of an xlook binary, validated; see the module docstring."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    raw = path.read_bytes()
    if len(raw) < _FIXED + _HEADERS[1] * _CHANNEL:
        raise DataError(
            f"{path}: not an xlook binary: {len(raw)} bytes, shorter than the smallest "
            f"header ({_FIXED + _HEADERS[1] * _CHANNEL} bytes)"
        )
    nrec, nchan = (int(n) for n in np.frombuffer(raw, ">i4", 2, _TITLE))
    if not (nrec > 0 and 0 < nchan <= _HEADERS[0]):
        raise DataError(
            f"{path}: not an xlook binary: header says nrec = {nrec}, nchan = {nchan} "
            f"(need nrec > 0 and 1 <= nchan <= {_HEADERS[0]})"
        )
    count = _header_count(len(raw), nrec, nchan)
    if count is None:
        expected = [_FIXED + c * _CHANNEL + 4 * nrec * nchan for c in _HEADERS]
        raise DataError(
            f"{path}: not an xlook binary, or truncated: {len(raw)} bytes, but "
            f"nrec = {nrec} x nchan = {nchan} float32 after a 32- or 16-channel header "
            f"makes {expected[0]} or {expected[1]}"
        )
    headers = np.frombuffer(
        raw,
        np.dtype(
            [
                ("name", "S13"),
                ("units", "S13"),
                ("gain", ">f4"),
                ("comment", "S50"),
                ("nelem", ">i4"),
            ]
        ),
        count,
        _FIXED,
    )
    data = np.frombuffer(raw, ">f4", nrec * nchan, _FIXED + count * _CHANNEL)
    data = data.reshape(nchan, nrec).astype(float)
    table = XlookTable(_text(raw[:_TITLE]), {}, {}, {}, nrec)
    for k in range(nchan):
        name, nelem = _text(headers["name"][k]), int(headers["nelem"][k])
        if not name.isprintable() or not name or not 0 <= nelem <= nrec:
            raise DataError(
                f"{path}: not an xlook binary: channel {k + 1} header has name {name!r} "
                f"and nelem = {nelem} (need a printable name and 0 <= nelem <= {nrec})"
            )
        data[k, nelem:] = np.nan
        table.set(k + 1, data[k], name, _text(headers["units"][k]))
    return table


# ---------------------------------------------------------------- recipes

_IGNORED = re.compile(r"^(plot\w*|pa|type|head|stats|begin|com_file|read)$")
_SKIPPED_OUTPUT = {"strain": 3, "cs": 3, "ras": 3, "smooth": 2, "deriv": 3, "qi": 3}
"""Commands not implemented, with the argument position of the column they write."""

_SLOTS = _HEADERS[0]
"""Columns of an xlook table (one per channel header of a binary)."""

_OPERATIONS = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide}


@dataclass
class _Line:
    recipe: Path
    number: int
    words: list[str]

    def fail(self, what: str) -> DataError:
        return DataError(f"{self.recipe} line {self.number} ({' '.join(self.words)}): {what}")

    def integer(self, position: int) -> int:
        try:
            return int(self.words[position])
        except (IndexError, ValueError):
            raise self.fail(f"argument {position} must be an integer") from None

    def number_at(self, position: int) -> float:
        try:
            return float(self.words[position])
        except (IndexError, ValueError):
            raise self.fail(f"argument {position} must be a number") from None

    def label(self, position: int, table: XlookTable, source: int) -> tuple[str, str]:
        """Name and unit given at ``position`` (default: those of column ``source``)."""
        name = self.words[position] if len(self.words) > position else table.names[source]
        unit = self.words[position + 1] if len(self.words) > position + 1 else ""
        return name, unit or table.units.get(source, "")


def _recipe_lines(recipe: Path) -> list[_Line]:
    try:
        text = recipe.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise DataError(f"{recipe}: an xlook recipe must be a text file") from None
    lines, started = [], False
    for number, line in enumerate(text.splitlines(), start=1):
        words = line.split("#", 1)[0].replace(",", " ").split()
        if not words:
            continue
        started |= words[0] == "begin"
        if words[0] == "end" and started:
            break
        lines.append(_Line(recipe, number, words))
    return lines


def recipe_reads(recipe: str | Path) -> str | None:
    """The file name a recipe's ``read`` line names (without its directory); None when
    ``recipe`` is no recipe (a file not starting with ``begin``) or names none."""
    recipe = Path(recipe)
    with recipe.open("rb") as handle:
        if handle.read(5) != b"begin":
            return None
    for line in _recipe_lines(recipe):
        if line.words[0] == "read" and len(line.words) > 1:
            return Path(line.words[1]).name
    return None


def _column(line: _Line, table: XlookTable, position: int) -> np.ndarray:
    slot = line.integer(position)
    if slot not in table.values:
        raise line.fail(f"column {slot} is empty (filled: {sorted(table.values)})")
    return table.values[slot]


def _row(line: _Line, table: XlookTable, position: int) -> int:
    row = line.integer(position)
    row = table.nrec - 1 if row == -1 else row
    if not 0 <= row < table.nrec:
        raise line.fail(f"row {line.words[position]} outside 0..{table.nrec - 1} (or -1)")
    return row


def _range(line: _Line, table: XlookTable, position: int) -> tuple[int, int]:
    """The rows ``first last`` at ``position`` (inclusive; -1 is the last row), in order."""
    first, last = _row(line, table, position), _row(line, table, position + 1)
    if last < first:
        raise line.fail(
            f"rows {line.words[position]} {line.words[position + 1]} run backwards "
            f"({first} > {last}): give the first row, then the last"
        )
    return first, last


def _output(line: _Line, position: int) -> int:
    """The output column at ``position``: a slot 1..``_SLOTS``."""
    slot = line.integer(position)
    if not 1 <= slot <= _SLOTS:
        raise line.fail(f"output column {slot} outside 1..{_SLOTS}")
    return slot


def _math(line: _Line, table: XlookTable, ranged: bool) -> None:
    source = _column(line, table, 1)
    operation = _OPERATIONS.get(line.words[2] if len(line.words) > 2 else "")
    kind = line.words[4] if len(line.words) > 4 else ""
    if operation is None or kind not in ("=", ":"):
        raise line.fail("expected 'math COL OP VALUE = OUT' or 'math COL OP COL : OUT'")
    operand = _column(line, table, 3) if kind == ":" else line.number_at(3)
    out = _output(line, 5)
    first, last = _range(line, table, 6) if ranged else (0, table.nrec - 1)
    result = table.values.get(out, np.full(table.nrec, np.nan)).copy()
    piece = slice(first, last + 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        result[piece] = operation(source[piece], operand[piece] if kind == ":" else operand)
    table.set(out, result, *line.label(8 if ranged else 6, table, line.integer(1)))


def _apply(line: _Line, table: XlookTable) -> bool:
    """Apply one implemented command; False when ``line`` is not one."""
    command = line.words[0]
    if command in ("math", "math_int"):
        _math(line, table, command == "math_int")
    elif command == "summation":
        table.set(
            _output(line, 2),
            np.cumsum(_column(line, table, 1)),
            *line.label(3, table, line.integer(1)),
        )
    elif command == "zero":
        values = _column(line, table, 1)
        values -= values[_row(line, table, 2)]
    elif command == "offset_int":
        values = _column(line, table, 1)
        first, last = _range(line, table, 2)
        jump = values[last] - values[first]
        if line.words[4:5] == ["y"]:
            values[first:last] = values[first]
        values[last:] -= jump
    elif command == "ec":
        disp, tau = _column(line, table, 1), _column(line, table, 2)
        out, (first, last) = _output(line, 3), _range(line, table, 4)
        stiffness = line.number_at(6)
        if stiffness == 0.0:
            raise line.fail("the elastic constant must not be 0")
        result = table.values.get(out, np.full(table.nrec, np.nan)).copy()
        piece = slice(first, last + 1)
        result[piece] = disp[piece] - (tau[piece] - tau[first]) / stiffness
        table.set(out, result, *line.label(7, table, line.integer(1)))
        scales = [_SI.get(table.units[line.integer(k)].lower(), np.nan) for k in (2, 1)]
        table.elastic[out] = stiffness * scales[0] / scales[1]
    elif command == "r_col":
        _column(line, table, 1)  # an empty slot is named, as for any other command
        table.remove(line.integer(1))
    elif command == "r_row":
        first, last = _range(line, table, 1)
        if last - first + 1 == table.nrec:
            raise line.fail(f"removes all {table.nrec} rows")
        keep = np.ones(table.nrec, dtype=bool)
        keep[first : last + 1] = False
        table.values = {slot: values[keep] for slot, values in table.values.items()}
        table.nrec = int(keep.sum())
    else:
        return False
    return True


def apply_recipe(table: XlookTable, recipe: str | Path) -> list[str]:
    """Run ``recipe`` on ``table`` in place; returns the skipped commands ('line N: ...')
    and warns once (:class:`RecipeWarning`) when there are any."""
    recipe = Path(recipe)
    if not recipe.is_file():
        raise DataError(f"{recipe}: no such recipe file")
    lines = _recipe_lines(recipe)
    if not any(line.words[0] == "begin" for line in lines):
        raise DataError(
            f"{recipe}: not an xlook recipe (no 'begin' line; a recipe runs from 'begin' to 'end')"
        )
    skipped = []
    for line in lines:
        if _IGNORED.match(line.words[0]) or _apply(line, table):
            continue
        skipped.append(f"line {line.number}: {' '.join(line.words)}")
        position = _SKIPPED_OUTPUT.get(line.words[0].split(".")[0].removesuffix("_tool"))
        if position is not None and line.words[position:] and line.words[position].isdigit():
            slot = int(line.words[position])
            table.skipped[slot] = (table.names.get(slot, ""), skipped[-1])
            table.remove(slot)
    if skipped:
        warnings.warn(
            f"{recipe}: skipped {len(skipped)} command(s) nanoblock does not implement "
            f"(the columns they write are left out): {'; '.join(skipped)}",
            RecipeWarning,
            stacklevel=2,
        )
    return skipped


# ---------------------------------------------------------------- to a measurement

NAMES: dict[str, tuple[str, ...]] = {
    "time": ("time",),
    "mu": ("mu",),
    "load_point_displacement": ("lp_disp", "lp_displacement", "load_point_disp"),
    "slip": ("ec_disp",),
    "shear_stress": ("shear_stress", "shr_stress", "tau"),
    "normal_stress": ("nor_stress", "normal_stress", "sigma_n"),
}
"""Recipe column names (lower case) that each measured variable is read from."""

_SI = {
    "s": 1.0, "sec": 1.0, "msec": 1e-3, "ms": 1e-3,
    "m": 1.0, "mm": 1e-3, "um": 1e-6, "mic": 1e-6, "micron": 1e-6, "microns": 1e-6,
    "pa": 1.0, "kpa": 1e3, "mpa": 1e6,
    ".": 1.0, "-": 1.0, "1": 1.0, "": 1.0,
}  # fmt: skip
"""Scale to SI of xlook unit strings (lower case)."""


def _find(table: XlookTable, variable: str, wanted: str | int | None, where: str) -> int | None:
    if isinstance(wanted, int):
        if wanted not in table.values:
            raise DataError(f"{where}: column {wanted} for {variable!r} is empty")
        return wanted
    names = (wanted.lower(),) if wanted else NAMES[variable]
    slots = [slot for slot, name in table.names.items() if name.lower() in names]
    stale = [(slot, why) for slot, (name, why) in table.skipped.items() if name.lower() in names]
    if not slots and stale:
        raise DataError(
            f"{where}: column {stale[0][0]} for {variable!r} was rewritten by a command "
            f"nanoblock does not implement ({stale[0][1]})"
        )
    if len(slots) > 1:
        raise DataError(f"{where}: columns {slots} are all named like {variable!r}")
    if not slots and wanted:
        raise DataError(
            f"{where}: no column named {wanted!r} for {variable!r}; columns: "
            f"{ {slot: table.names[slot] for slot in sorted(table.names)} }"
        )
    return slots[0] if slots else None


def _si(table: XlookTable, slot: int, variable: str, where: str) -> np.ndarray:
    unit = table.units[slot]
    if unit.lower() not in _SI:
        raise DataError(
            f"{where}: column {slot} ({table.names[slot]!r}, read as {variable!r}) has unit "
            f"{unit!r}; known: {sorted(u for u in _SI if u)}"
        )
    return table.values[slot] * _SI[unit.lower()]


def _measured(
    table: XlookTable,
    columns: Mapping[str, str | int] | None,
    where: str,
) -> tuple[dict[str, np.ndarray], dict[str, int | None]]:
    """The measured variables (SI) found in a reduced table, and their slots."""
    chosen = dict(columns or {})
    unknown = sorted(set(chosen) - set(NAMES))
    if unknown:
        raise DataError(f"{where}: unknown variable(s) {unknown} in columns; known: {list(NAMES)}")
    found = {variable: _find(table, variable, chosen.get(variable), where) for variable in NAMES}
    out = {v: _si(table, slot, v, where) for v, slot in found.items() if slot is not None}
    if "mu" not in out and {"shear_stress", "normal_stress"} <= set(out):
        out["mu"] = out["shear_stress"] / out["normal_stress"]
    for variable in ("time", "mu", "load_point_displacement"):
        if variable not in out:
            why = [why for _, why in table.skipped.values()]
            left_out = f"; left out by skipped commands: {why}" if why else ""
            raise DataError(
                f"{where}: the reduced table has no column for {variable!r} (names tried: "
                f"{list(NAMES[variable])}; columns: "
                f"{ {slot: table.names[slot] for slot in sorted(table.names)} }{left_out}). "
                f"Name it with columns={{{variable!r}: NAME_OR_NUMBER}}"
            )
    return out, found


def step_velocity(time: np.ndarray, displacement: np.ndarray, window: float = 2.0) -> np.ndarray:
    """Piecewise-constant load-point velocity [m/s] from a noisy displacement record [m].

    Least-squares slopes over ``window`` [s] before and after each sample flag candidate
    steps where they differ by more than a factor 1.5 (slopes below three standard errors
    of the displacement noise, or 1e-3 of the median slope, count as a hold); each
    candidate is placed at the best continuous two-slope (hinge) fit within +-``window``;
    segments under 50 samples, or within a factor 1.5 of a neighbour, are merged; each
    segment's velocity is the least-squares slope over it (0 for a hold).
    """
    t, x = np.asarray(time, dtype=float), np.asarray(displacement, dtype=float)
    n = t.size
    index = np.arange(n)
    starts = np.searchsorted(t, t - window)
    ends = np.searchsorted(t, t + window, side="right")
    curvature = np.diff(x, 2)
    noise = 1.4826 / np.sqrt(6.0) * np.median(np.abs(curvature - np.median(curvature)))
    floor = 1e-3 * (np.nanmedian(np.abs(_slopes(t, x, index, ends)[0])) or 1.0)

    def resolved(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Slopes over lo..hi-1 and the smallest slope told apart from a hold."""
        slope, spread = _slopes(t, x, lo, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            return slope, np.fmax(floor, 3.0 * noise / np.sqrt(np.maximum(spread, 0.0)))

    (left, left_min), (right, right_min) = resolved(starts, index + 1), resolved(index, ends)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(np.log(np.maximum(right, right_min) / np.maximum(left, left_min)))
    covered = (t - t[starts] > 0.5 * window) & (t[ends - 1] - t > 0.5 * window)
    ratio[~(covered & np.isfinite(ratio))] = 0.0
    candidates: list[int] = []
    for i in np.argsort(ratio)[::-1]:
        if ratio[i] < np.log(1.5):
            break
        if all(abs(t[i] - t[j]) > window for j in candidates):
            candidates.append(int(i))
    bounds = np.unique([0, *(_hinge(t, x, starts[i], ends[i]) for i in candidates), n])
    while bounds.size > 2:
        velocity, minimum = resolved(bounds[:-1], bounds[1:])
        velocity = np.maximum(velocity, minimum)
        with np.errstate(invalid="ignore"):
            similar = np.nan_to_num(np.abs(np.log(velocity[1:] / velocity[:-1])))
        weak = np.where(np.diff(bounds)[1:] < 50, 0.0, similar)  # a short segment goes
        weak = np.minimum(weak, np.where(np.diff(bounds)[:-1] < 50, 0.0, similar))
        if weak.min() >= np.log(1.5):
            break
        bounds = np.delete(bounds, int(np.argmin(weak)) + 1)
    velocity, minimum = resolved(bounds[:-1], bounds[1:])
    return np.repeat(np.where(velocity > minimum, velocity, 0.0), np.diff(bounds))


def _slopes(
    t: np.ndarray, x: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares slopes of x(t) over samples lo..hi-1 and the spread sum (t - mean)^2
    of their times (prefix sums of t and x centred)."""
    t, x = t - t.mean(), x - x.mean()
    s0, st, sx, stt, stx = (
        np.concatenate([[0.0], np.cumsum(v)])[hi] - np.concatenate([[0.0], np.cumsum(v)])[lo]
        for v in (np.ones_like(t), t, x, t * t, t * x)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        return (s0 * stx - st * sx) / (s0 * stt - st * st), stt - st * st / s0


def _hinge(t: np.ndarray, x: np.ndarray, lo: int, hi: int) -> int:
    """First sample after the best continuous two-slope break of x(t) over lo..hi-1."""
    tw, xw = t[lo:hi] - t[lo:hi].mean(), x[lo:hi] - x[lo:hi].mean()
    # normal equations of x = a + b t + c max(t - t_k, 0) for every break t_k at once
    tail = [np.cumsum(v[::-1])[::-1] for v in (np.ones_like(tw), tw, tw * tw, xw, tw * xw)]
    count, t1, t2, x1, tx = tail
    u1, u2, tu, ux = t1 - tw * count, t2 - 2 * tw * t1 + tw**2 * count, t2 - tw * t1, tx - tw * x1
    m, st, stt = tw.size, tw.sum(), (tw * tw).sum()
    matrix = np.stack(
        [
            np.stack([np.full_like(tw, m), np.full_like(tw, st), u1], -1),
            np.stack([np.full_like(tw, st), np.full_like(tw, stt), tu], -1),
            np.stack([u1, tu, u2], -1),
        ],
        -2,
    )[2:-2]
    rhs = np.stack([np.full_like(tw, xw.sum()), np.full_like(tw, (tw * xw).sum()), ux], -1)[2:-2]
    explained = np.einsum("ki,ki->k", np.linalg.solve(matrix, rhs[..., None])[..., 0], rhs)
    return lo + 2 + int(np.argmax(explained))


def parse_rows(text: str) -> tuple[int, int]:
    """``"FIRST:LAST"`` (inclusive xlook rows, as a command-line option gives them)."""
    first, sep, last = text.partition(":")
    try:
        if sep:
            return int(first), int(last)
    except ValueError:
        pass
    raise DataError(f"rows {text!r} must be FIRST:LAST, two integers (inclusive xlook rows)")


def reduce_xlook(
    binary: str | Path,
    recipe: str | Path | None = None,
    rows: tuple[int, int] | None = None,
    columns: Mapping[str, str | int] | None = None,
) -> tuple[dict[str, np.ndarray], dict[str, object]]:
    """The measured columns (SI) and metadata of an xlook binary reduced by ``recipe``,
    over the inclusive row window ``rows``; :func:`load_xlook` validates them."""
    binary = Path(binary)
    table = read_xlook(binary)
    if recipe is None:
        raise DataError(
            f"{binary}: an xlook binary holds raw channels {list(table.names.values())}; give "
            "its reduction recipe (the lab's *_r command file) to get mu and displacements"
        )
    named = recipe_reads(recipe) if Path(recipe).is_file() else None
    if named is not None and named != binary.name:
        warnings.warn(
            f"{recipe}: reads {named!r} (its 'read' line), not {binary.name!r}: its gains, "
            "zeros and row numbers are those of that record; check that they apply",
            RecipeWarning,
            stacklevel=2,
        )
    skipped = apply_recipe(table, recipe)
    where = f"{binary} reduced by {recipe}"
    found, slots = _measured(table, columns, where)
    first, last = (0, table.nrec - 1) if rows is None else rows
    if not 0 <= first <= last < table.nrec:
        raise DataError(f"{where}: rows {rows} must satisfy 0 <= first <= last <= {table.nrec - 1}")
    found = {name: values[first : last + 1] for name, values in found.items()}
    measured = {
        v: found[v] for v in ("time", "mu", "load_point_displacement", "slip") if v in found
    }
    ok = np.isfinite(measured["time"]) & np.isfinite(measured["load_point_displacement"])
    measured["load_point_velocity"] = np.full(ok.size, np.nan)
    measured["load_point_velocity"][ok] = step_velocity(
        measured["time"][ok], measured["load_point_displacement"][ok]
    )
    metadata: dict[str, object] = {
        "source": f"xlook binary {binary.name} ({table.title}) reduced with {Path(recipe).name}, "
        f"rows {first}-{last}",
        "apparatus": "spring_slider",
    }
    if "normal_stress" in found:
        metadata["normal_stress"] = float(np.nanmean(found["normal_stress"]))
        stiffness = table.elastic.get(slots["slip"], np.nan) / metadata["normal_stress"]
        if np.isfinite(stiffness) and stiffness > 0.0:
            metadata["stiffness_per_load"] = float(stiffness)  # the ec constant / sigma_n
    if skipped:
        metadata["recipe_skipped"] = "; ".join(skipped)
    return measured, metadata


def load_xlook(
    binary: str | Path,
    recipe: str | Path | None = None,
    rows: tuple[int, int] | None = None,
    columns: Mapping[str, str | int] | None = None,
) -> xr.Dataset:
    """An xlook binary reduced by its recipe, as a validated ``time_series`` Dataset (the
    layout :func:`~nanoblock.measured.load_measurement` gives a CSV).

    ``rows``: inclusive (first, last) rows of the reduced table; ``columns``: recipe
    column names or numbers for ``time``, ``mu``, ``load_point_displacement``, ``slip``
    (or ``shear_stress`` with ``normal_stress``) where the defaults of ``NAMES`` miss.
    """
    from nanoblock.measured import load_measurement

    return load_measurement(binary, recipe=recipe, rows=rows, columns=columns)
