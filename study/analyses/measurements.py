"""Measurements beside the model: a documented CSV format read into a labelled dataset.

A measurement file is CSV (comma-separated, UTF-8) with a header row naming its
columns; every value is in SI units; a blank cell means "not applicable"; lines
starting with ``#`` and blank lines are skipped. The minimal file::

    quantity,f,a,value,sigma
    threshold,13.0,,6.25,0.05
    threshold,16.5,,6.6,0.05
    velocity,13.0,8.5,0.0022,0.0001

The columns are declared once, in :data:`COLUMNS` and :data:`QUANTITIES`; the JSON
schema of one row (``study/schemas/study-measurements-v1.schema.json``, exported by
:func:`export_measurement_schema`) is built from them and is what every row is
checked against. Every refusal is a :class:`MeasurementError` naming the file, the
line and the column. Pure: no figures, no files written.

Numbers are read strictly: ASCII digits with an optional sign, point and exponent
(``6.25``, ``-3``, ``1.5e-3``), spaces around them allowed. Everything else Python's
``float`` would take is refused: ``6_25``, ``0x10``, ``inf``, ``nan``, ``1e999``,
Unicode digits, trailing text. A missing value is a blank cell. ``sigma`` must be a
positive normal float64 (not below 2.2e-308: its square is a fit's weight).

Limits, declared once (:data:`MAX_BYTES`, :data:`MAX_ROWS`, :data:`MAX_FIELD_CHARS`,
:data:`MAX_LINE_CHARS`): a file of at most 64 MiB, at most 1,000,000 data rows, a cell
of at most 1000 characters, a line of at most 9027. Every row is on one line (a quoted
cell may hold a comma, not a line break). A file is read only if it is a regular file
(not a folder, FIFO or device) and a link only if it points into its own folder; a
million rows read in a few seconds.
"""

from __future__ import annotations

import csv
import gc
import json
import operator
import re
import sys
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from itertools import compress, repeat
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from study.engine.files import GrewWhileRead, NotRegularFile, SymbolicLink, TooLarge, read_regular
from study.engine.spec_files import SCHEMA_DIR, SpecError
from study.model.units import (
    DIMENSIONLESS,
    HERTZ,
    KILOGRAM,
    METRE_PER_SECOND,
    METRE_PER_SECOND_SQUARED,
)

__all__ = [
    "COLUMNS",
    "MEASUREMENT_SCHEMA",
    "MEASUREMENT_SCHEMA_PATH",
    "QUANTITIES",
    "Column",
    "MeasurementError",
    "Quantity",
    "check_velocity_units",
    "export_measurement_schema",
    "measurement_file_bytes",
    "measurement_schema",
    "parse_measurements",
    "read_measurements",
]

MEASUREMENT_SCHEMA = "study-measurements-v1"
MEASUREMENT_SCHEMA_PATH = SCHEMA_DIR / f"{MEASUREMENT_SCHEMA}.schema.json"

#: Largest measurement file read [bytes]: a million rows of five numbers and a short
#: note (a lab file is kilobytes).
MAX_BYTES = 64 << 20
#: Most data rows in one file.
MAX_ROWS = 1_000_000
#: Longest cell [characters]: a number needs about 25, a note a sentence or two.
MAX_FIELD_CHARS = 1000


class MeasurementError(SpecError):
    """A measurement file that cannot be used; names the file, line and column."""


@dataclass(frozen=True)
class Column:
    """One column of the format.

    Attributes
    ----------
    name : str
        Header name (case-sensitive).
    number : bool
        A number (else text).
    units : str
        SI units (UDUNITS spelling); ``"value"`` for the units of the row's quantity.
    long_name : str
        What it is.
    minimum, exclusive_minimum, maximum : float or None
        Allowed range of a number.
    allowed : tuple of str
        Allowed values of a text column (empty: any text).
    """

    name: str
    number: bool
    units: str
    long_name: str
    minimum: float | None = None
    exclusive_minimum: float | None = None
    maximum: float | None = None
    allowed: tuple[str, ...] = ()


@dataclass(frozen=True)
class Quantity:
    """One measured quantity: the units of its ``value`` and which columns it needs.

    Attributes
    ----------
    name : str
        Value of the ``quantity`` column.
    units : str
        Units of ``value`` and ``sigma``.
    meaning : str
        What the model compares it with.
    required : tuple of str
        Columns that must not be blank.
    blank : tuple of str
        Columns that must be blank (not applicable).
    positive : bool
        ``value`` must be > 0.
    """

    name: str
    units: str
    meaning: str
    required: tuple[str, ...]
    blank: tuple[str, ...]
    positive: bool


#: The quantities, declared once.
QUANTITIES: dict[str, Quantity] = {q.name: q for q in (
    Quantity("threshold", METRE_PER_SECOND_SQUARED,
             "measured motion threshold at f: the lowest drive acceleration amplitude at "
             "which the structure moves (direction: forward, backward or unknown = the "
             "lower of the two)", ("f",), ("a",), True),
    Quantity("velocity", METRE_PER_SECOND,
             "steady mean velocity at the drive (f, a), positive forward", ("f", "a"),
             ("direction",), False),
    Quantity("ringdown_f0", HERTZ, "resonance frequency of the plate's mode from a ring-down",
             (), ("f", "a", "direction"), True),
    Quantity("ringdown_Q", DIMENSIONLESS, "quality factor of the plate's mode from a ring-down",
             (), ("f", "a", "direction"), True),
)}

DIRECTIONS = ("forward", "backward", "unknown")

#: The columns, declared once.
COLUMNS: dict[str, Column] = {c.name: c for c in (
    Column("quantity", False, "", "measured quantity", allowed=tuple(QUANTITIES)),
    Column("f", True, HERTZ, "drive frequency", exclusive_minimum=0.0),
    Column("a", True, METRE_PER_SECOND_SQUARED, "drive acceleration amplitude",
           exclusive_minimum=0.0),
    Column("value", True, "value", "measured value"),
    Column("sigma", True, "value", "standard uncertainty of value (one standard deviation)",
           exclusive_minimum=0.0),
    Column("direction", False, "", "direction of a threshold", allowed=DIRECTIONS),
    Column("m_add", True, KILOGRAM, "added non-resonant mass of the structure measured",
           minimum=0.0),
    Column("M", True, DIMENSIONLESS, "mass ratio m1/m of the structure measured",
           exclusive_minimum=0.0, maximum=1.0),
    Column("note", False, "", "free text, ignored"),
)}

REQUIRED_COLUMNS = ("quantity", "value")
#: Longest line [characters]: every column's cell at its longest, quoted, with commas.
MAX_LINE_CHARS = (MAX_FIELD_CHARS + 3) * len(COLUMNS)


def _column_schema(column: Column) -> dict[str, Any]:
    units = "" if column.units in ("", "value") else f" [{column.units}]"
    out: dict[str, Any] = {"description": column.long_name + units}
    if column.number:
        out["type"] = "number"
        for key, bound in (("minimum", column.minimum),
                           ("exclusiveMinimum", column.exclusive_minimum),
                           ("maximum", column.maximum)):
            if bound is not None:
                out[key] = bound
    else:
        out["type"] = "string"
        if column.allowed:
            out["enum"] = list(column.allowed)
    return out


@cache
def measurement_schema() -> dict[str, Any]:
    """The JSON schema of one measurement row (blank cells are absent keys)."""
    rules = []
    for q in QUANTITIES.values():
        then: dict[str, Any] = {"description": f"{q.name}: value [{q.units}]"}
        if q.required:
            then["required"] = list(q.required)
        if q.blank:
            then["properties"] = {name: {"not": {}, "description": "not applicable"}
                                  for name in q.blank}
        if q.positive:
            then.setdefault("properties", {})["value"] = {"exclusiveMinimum": 0}
        rules.append({"if": {"properties": {"quantity": {"const": q.name}}}, "then": then})
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": f"{MEASUREMENT_SCHEMA}.schema.json",
        "title": "study measurement row, version 1",
        "description": (
            "One row of a measurement CSV file (header row; SI units; a blank cell means "
            "'not applicable' and is an absent key here). Units of value and sigma by "
            "quantity: " + "; ".join(f"{q.name} [{q.units}]" for q in QUANTITIES.values())),
        "type": "object",
        "additionalProperties": False,
        "required": list(REQUIRED_COLUMNS),
        "properties": {c.name: _column_schema(c) for c in COLUMNS.values()},
        "allOf": rules,
    }


def export_measurement_schema() -> str:
    """The schema file's text (``make schemas`` writes it)."""
    return json.dumps(measurement_schema(), indent=2) + "\n"


@cache
def _validator() -> Any:
    import jsonschema

    return jsonschema.Draft202012Validator(measurement_schema())


def _explain(error: Any, row: dict[str, Any], where: str) -> str:
    """One schema violation of a row as 'FILE, line N, column C: problem'."""
    path = list(error.absolute_path)
    quantity = row.get("quantity")
    if error.validator == "required":
        missing = [c for c in error.validator_value if c not in row]
        columns = ", ".join(repr(c) for c in missing)
        if error.validator_value == list(REQUIRED_COLUMNS):
            return f"{where}, column {columns}: blank; every row needs a quantity and a value"
        return (f"{where}, column {columns}: blank; a {quantity!r} row needs "
                + ", ".join(error.validator_value))
    if error.validator == "not":
        column = path[0]
        return (f"{where}, column {column!r}: must be blank for quantity {quantity!r} "
                "(not applicable)")
    column = path[0] if path else "?"
    value = row.get(column)
    if error.validator == "enum":
        allowed = ", ".join(error.validator_value)
        return f"{where}, column {column!r}: {value!r} is not allowed; allowed: {allowed}"
    if error.validator in ("minimum", "exclusiveMinimum", "maximum"):
        sign = {"minimum": ">=", "exclusiveMinimum": ">", "maximum": "<="}[error.validator]
        limits = []
        for key, s in (("minimum", ">="), ("exclusiveMinimum", ">"), ("maximum", "<=")):
            if key in error.schema:
                limits.append(f"{s} {error.schema[key]}")
        what = f"{column} {' and '.join(limits) or sign}"
        extra = ""
        if column == "value" and quantity in QUANTITIES:
            extra = f" for quantity {quantity!r}"
        if column == "sigma":
            extra = " (an uncertainty is positive; leave it blank if unknown)"
        return f"{where}, column {column!r}: {value!r} is out of range; allowed: {what}{extra}"
    if error.validator == "additionalProperties":
        return f"{where}: unknown column"
    return f"{where}, column {column!r}: {error.message}"


# One number in a cell: ASCII digits, an optional point and exponent. Nothing else that
# float() would take: no underscores (6_25), hex, inf/nan, Unicode digits or junk.
# Possessive quantifiers keep a failing match linear in the cell's length.
_NUMBER = r"[+-]?+(?:[0-9]++(?:\.[0-9]*+)?+|\.[0-9]++)(?:[eE][+-]?+[0-9]++)?+"
_NUMBER_CELL = re.compile(rf"(?:{_NUMBER})?+")
# A whole column of stripped cells joined by newlines (a cell never holds one: a quoted
# cell spanning lines is refused first), checked in one pass.
_NUMBER_COLUMN = re.compile(rf"(?:{_NUMBER})?+(?:\n(?:{_NUMBER})?+)*+")
#: Rows whose problems are explained one by one; the rest are counted.
_EXPLAINED_ROWS = 30


def _shown(cell: str) -> str:
    """A cell for a message: quoted, and cut short if long."""
    return repr(cell if len(cell) <= 40 else cell[:40] + "...")


class _Table:
    """The data rows of a file as stripped cells by column, with their line numbers."""

    def __init__(self, header: list[str], rows: list[list[str]], lines: np.ndarray):
        self.header = header
        self.lines = lines
        self.size = n = len(rows)
        columns = list(zip(*rows, strict=True)) if rows else [()] * len(header)
        self.cells = {name: list(map(str.strip, column))
                      for name, column in zip(header, columns, strict=True)}
        # Blank text cells; a number column's blanks are its NaN (see _numbers).
        self.blank = {name: np.fromiter(map(operator.not_, cells), bool, n)
                      for name, cells in self.cells.items() if not COLUMNS[name].number}
        self.quantity = np.array(self.cells["quantity"] if "quantity" in self.cells else
                                 [""] * n, dtype=object).reshape(-1)


def _csv_rows(text: str, path: str) -> tuple[list[str], int, list[list[str]], np.ndarray,
                                             list[tuple[int, str]]]:
    """The header, its line, the data rows, their lines and the problems of the layout.

    Comment and blank lines are skipped before the CSV parser sees them; every row must
    lie on one line and hold one cell per header column. The parser reads the whole
    file at once; only a file it finds fault with is read again a row at a time, to
    name the lines at fault.
    """
    lines = text.split("\n")
    stripped = list(map(str.strip, lines))
    skipped = (np.fromiter(map(operator.not_, stripped), bool, len(lines))
               | np.fromiter(map(str.startswith, stripped, repeat("#")), bool, len(lines)))
    del stripped
    kept = np.flatnonzero(~skipped) + 1  # line number of every line given to the parser
    content = list(compress(lines, ~skipped))
    del lines
    lengths = np.fromiter(map(len, content), np.int64, len(content))
    if len(content) and lengths.max() > MAX_LINE_CHARS:
        i = int(np.argmax(lengths > MAX_LINE_CHARS))
        raise MeasurementError(
            f"{path}, line {kept[i]}: {lengths[i]} characters; a line of a measurement "
            f"file holds at most {MAX_LINE_CHARS} (a cell at most {MAX_FIELD_CHARS})")
    if len(content) > MAX_ROWS + 1:
        raise MeasurementError(f"{path}, line {kept[MAX_ROWS + 1]}: more than {MAX_ROWS} "
                               f"rows; a measurement file holds at most {MAX_ROWS} (split it)")
    if not len(content):
        raise MeasurementError(f"{path}: no header row; the first line names the columns, "
                               f"e.g. 'quantity,f,a,value,sigma'")
    reader = csv.reader(content, strict=True, skipinitialspace=True)
    try:
        records = list(reader)
        clean = reader.line_num == len(records)  # no record spans lines
    except csv.Error:
        clean = False
    if not clean:
        records, kept, problems = _careful_rows(content, kept, path)
        if not records:
            raise MeasurementError("\n  ".join([f"{path}: invalid measurement file:",
                                                *(p for _, p in problems)]))
    else:
        problems = []
    header = [h.strip() for h in records[0]]
    rows = records[1:]
    lines = kept[1:]
    counts = np.fromiter(map(len, rows), np.int64, len(rows))
    wrong = np.flatnonzero(counts != len(header))
    if len(wrong):
        problems += [(int(lines[i]), f"{path}, line {lines[i]}: {counts[i]} cells, the header "
                      f"has {len(header)} (leave a cell empty, not out)") for i in wrong]
        right = counts == len(header)
        rows = list(compress(rows, right))
        lines = lines[right]
    return header, int(kept[0]), rows, lines, problems


def _careful_rows(content: list[str], kept: np.ndarray, path: str
                  ) -> tuple[list[list[str]], np.ndarray, list[tuple[int, str]]]:
    """The records of the lines ``content`` one at a time: the records on one line
    each, their line numbers, and a problem for each record that is not."""
    reader = csv.reader(content, strict=True, skipinitialspace=True)
    records: list[list[str]] = []
    lines: list[int] = []
    problems: list[tuple[int, str]] = []
    done = 0  # lines the parser has consumed
    while True:
        try:
            cells = next(reader)
        except StopIteration:
            break
        except csv.Error as err:
            first = int(kept[min(done, len(kept) - 1)])
            why = ("a carriage return inside a line" if "new-line" in str(err)
                   else "an unclosed quote" if "end of data" in str(err) else str(err))
            problems.append((first, f"{path}, line {first}: not CSV ({why}); a cell with a "
                             "comma is quoted as \"...\", a quote in it doubled"))
            if reader.line_num <= done:  # nothing consumed: the parser is stuck
                break
            done = reader.line_num
            continue
        first, last = int(kept[done]), int(kept[reader.line_num - 1])
        done = reader.line_num
        if first != last:
            problems.append((first, f"{path}, lines {first}-{last}: a quoted cell spans "
                             "lines; every row of a measurement file is on one line "
                             "(close the quote)"))
            continue
        records.append(cells)
        lines.append(first)
    return records, np.array(lines, dtype=np.int64), problems


def _header_problems(header: list[str], line: int, path: str) -> list[str]:
    problems = []
    unknown = [h for h in header if h not in COLUMNS]
    if unknown:
        problems.append(
            f"{path}, line {line}: unknown column"
            + ("s " if len(unknown) > 1 else " ") + ", ".join(map(_shown, unknown))
            + "; allowed: " + ", ".join(COLUMNS))
    duplicated = sorted({h for h in header if header.count(h) > 1})
    if duplicated:
        problems.append(f"{path}, line {line}: column "
                        + ", ".join(map(_shown, duplicated)) + " given twice")
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        problems.append(f"{path}, line {line}: missing required column "
                        + ", ".join(map(repr, missing)) + "; the header must name "
                        + ", ".join(REQUIRED_COLUMNS) + " (optional: "
                        + ", ".join(c for c in COLUMNS if c not in REQUIRED_COLUMNS) + ")")
    return problems


def _numbers(table: _Table, path: str) -> tuple[dict[str, np.ndarray], dict[int, list[str]]]:
    """The number columns as float64 (NaN where blank), and the cells that are not
    numbers (strictly: see :data:`_NUMBER`), finite, short or normal, by row."""
    values: dict[str, np.ndarray] = {}
    bad: dict[int, list[str]] = {}

    def refuse(row: int, name: str, problem: str) -> None:
        bad.setdefault(row, []).append(
            f"{path}, line {table.lines[row]}, column {name!r}: {problem}")

    for name, cells in table.cells.items():
        if max(map(len, cells), default=0) > MAX_FIELD_CHARS:
            for row in (i for i, c in enumerate(cells) if len(c) > MAX_FIELD_CHARS):
                refuse(row, name, f"{len(cells[row])} characters; a cell holds at most "
                       f"{MAX_FIELD_CHARS}")
            cells = [c if len(c) <= MAX_FIELD_CHARS else "" for c in cells]
        if not COLUMNS[name].number:
            continue
        if _NUMBER_COLUMN.fullmatch("\n".join(cells)) is None:
            for row in (i for i, c in enumerate(cells) if _NUMBER_CELL.fullmatch(c) is None):
                refuse(row, name, f"{_shown(cells[row])} is not a finite number; write "
                       "digits with an optional point and exponent (6.25, 1.5e-3), or "
                       "leave the cell blank if not applicable")
            cells = [c if _NUMBER_CELL.fullmatch(c) else "" for c in cells]
        column = np.fromiter(map(float, [c or "nan" for c in cells]), np.float64,
                             len(cells))
        table.blank[name] = np.isnan(column)  # "nan" is no number: NaN only where blank
        for row in np.flatnonzero(~table.blank[name] & ~np.isfinite(column)):
            refuse(int(row), name, f"{_shown(cells[row])} is not a finite number (beyond "
                   f"the largest float64, {sys.float_info.max:.4g})")
        if name == "sigma":
            tiny = np.flatnonzero((column != 0) & (np.abs(column) < sys.float_info.min))
            for row in tiny:
                refuse(int(row), name, f"{_shown(cells[row])} is below the smallest normal "
                       f"float64 ({sys.float_info.min:.4g}); an uncertainty is a positive "
                       "normal number (leave it blank if unknown)")
        values[name] = column
    return values, bad


def _invalid(table: _Table, values: dict[str, np.ndarray]) -> np.ndarray:
    """Rows that break the schema (:func:`measurement_schema`), from the same declarations
    but a column at a time: the schema itself, row by row, is a thousand times slower."""
    n = table.size
    invalid = np.zeros(n, dtype=bool)
    blank = table.blank
    nothing = np.ones(n, dtype=bool)
    for name in REQUIRED_COLUMNS:
        invalid |= blank.get(name, nothing)
    for name, cells in table.cells.items():
        column = COLUMNS[name]
        if column.allowed:
            allowed = set(column.allowed)
            invalid |= ~blank[name] & ~np.fromiter(map(allowed.__contains__, cells), bool, n)
        if column.number:
            v = values[name]
            with np.errstate(invalid="ignore"):
                if column.minimum is not None:
                    invalid |= v < column.minimum
                if column.exclusive_minimum is not None:
                    invalid |= v <= column.exclusive_minimum
                if column.maximum is not None:
                    invalid |= v > column.maximum
    for q in QUANTITIES.values():
        rows = table.quantity == q.name
        for name in q.required:
            invalid |= rows & blank.get(name, nothing)
        for name in q.blank:
            invalid |= rows & ~blank.get(name, nothing)
        if q.positive:
            with np.errstate(invalid="ignore"):
                invalid |= rows & (values["value"] <= 0)
    return invalid


def _row(table: _Table, values: dict[str, np.ndarray], i: int) -> dict[str, Any]:
    """Row ``i`` as the schema sees it: blank cells are absent keys."""
    return {name: float(values[name][i]) if COLUMNS[name].number else cells[i]
            for name, cells in table.cells.items() if cells[i]}


@contextmanager
def _no_cycle_collection() -> Iterator[None]:
    """Pause Python's cycle collector: a large file makes millions of small lists and
    strings, none in a cycle, which the collector would otherwise scan again and again
    (40 % of the time of a million rows)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def parse_measurements(text: str, path: str = "<string>") -> xr.Dataset:
    """Read measurement CSV text into a dataset over ``measurement`` (see module doc).

    Raises
    ------
    MeasurementError
        Listing every problem, each as ``FILE, line N, column C: problem; allowed: ...``.
    """
    with _no_cycle_collection():
        return _parse(text, path)


def _parse(text: str, path: str) -> xr.Dataset:
    header, header_line, rows, lines, layout = _csv_rows(text, path)
    problems = _header_problems(header, header_line, path)
    if problems:
        raise MeasurementError("\n  ".join([f"{path}: invalid measurement file:", *problems]))
    table = _Table(header, rows, lines)
    del rows
    values, bad = _numbers(table, path)
    for name in COLUMNS:
        if COLUMNS[name].number and name not in values:
            values[name] = np.full(table.size, np.nan)
    found: list[tuple[int, str]] = list(layout)
    for row, messages in bad.items():
        found += [(int(table.lines[row]), m) for m in messages]
    invalid = _invalid(table, values)
    invalid[list(bad)] = False
    both = np.isfinite(values["m_add"]) & np.isfinite(values["M"]) & ~invalid
    both[list(bad)] = False
    flagged = np.flatnonzero(invalid | both)
    for i in flagged[:_EXPLAINED_ROWS]:
        where = f"{path}, line {table.lines[i]}"
        row = _row(table, values, int(i))
        errors = sorted(_validator().iter_errors(row), key=lambda e: list(map(str, e.path)))
        quantity = row.get("quantity")
        if quantity is not None and quantity not in QUANTITIES:
            errors = [e for e in errors if e.validator == "enum"] or errors
        messages = list(dict.fromkeys(_explain(e, row, where) for e in errors))
        if not messages:
            messages = [f"{where}, columns 'm_add' and 'M': give the structure by one of "
                        "them"]
        found += [(int(table.lines[i]), m) for m in messages]
    if found:
        found.sort(key=lambda item: item[0])
        shown = [m for _, m in found[:30]]
        more = len(found) - len(shown) + max(0, len(flagged) - _EXPLAINED_ROWS)
        if more:
            shown.append(f"... and {more} more")
        raise MeasurementError("\n  ".join([f"{path}: invalid measurement file:", *shown]))
    if not table.size:
        raise MeasurementError(f"{path}: no measurements (only a header)")
    return _dataset(table, values, path)


def _dataset(table: _Table, values: dict[str, np.ndarray], path: str) -> xr.Dataset:
    quantity = table.quantity
    if "direction" in table.cells:
        direction = np.array(table.cells["direction"], dtype=object).reshape(-1)
    else:
        direction = np.full(table.size, "", dtype=object)
    direction[(direction == "") & (quantity == "threshold")] = "unknown"
    units = np.empty(table.size, dtype=object)
    for q in QUANTITIES.values():
        units[quantity == q.name] = q.units
    dims = ("measurement",)

    def var(name: str, data: Any, **attrs: Any) -> xr.Variable:
        column = COLUMNS.get(name)
        base = {"long_name": column.long_name} if column else {}
        if column is not None and column.units not in ("", "value"):
            base["units"] = column.units
        return xr.Variable(dims, data, {**base, **attrs})

    units_note = "units by quantity, see value_units"
    data = {
        "quantity": var("quantity", quantity, allowed_values=" ".join(QUANTITIES)),
        "f": var("f", values["f"]),
        "a": var("a", values["a"]),
        "value": var("value", values["value"], comment=units_note),
        "sigma": var("sigma", values["sigma"], comment=units_note + "; NaN: not given"),
        "value_units": var("value_units", units, long_name="units of value and sigma"),
        "direction": var("direction", direction),
        "m_add": var("m_add", values["m_add"]),
        "M": var("M", values["M"]),
        "source": var("source", np.full(table.size, path, dtype=object),
                      long_name="measurement file"),
        "line": var("line", table.lines.astype(np.int32),
                    long_name="line in the measurement file (1 = first line)"),
    }
    return xr.Dataset(data, attrs={"study_measurement_schema": MEASUREMENT_SCHEMA})


#: A measured velocity above this [m s-1] and above :data:`VELOCITY_UNITS_FACTOR` times
#: the model's fastest is taken for mm/s written as m/s (the structures move mm/s).
VELOCITY_UNITS_LIMIT = 0.05
#: How many times the model's fastest velocity a measured one may be.
VELOCITY_UNITS_FACTOR = 50.0


def check_velocity_units(data: xr.Dataset, rows: np.ndarray, model_speed: float) -> None:
    """Refuse velocities that are plainly not in m s-1 (mm/s written as m/s).

    The one check of ``study figure --measurements`` and ``study fit``.

    Parameters
    ----------
    data : xarray.Dataset
        Measurements (:func:`read_measurements`).
    rows : numpy.ndarray of int
        The ``velocity`` rows to check.
    model_speed : float
        The fastest steady velocity of the model beside them [m s-1].

    Raises
    ------
    MeasurementError
        When a velocity is larger than :data:`VELOCITY_UNITS_LIMIT` and than
        :data:`VELOCITY_UNITS_FACTOR` times ``model_speed``; names the file and line.
    """
    if not len(rows):
        return
    values = np.abs(data["value"].values[rows])
    limit = max(VELOCITY_UNITS_LIMIT, VELOCITY_UNITS_FACTOR * model_speed)
    worst = int(np.argmax(values))
    if values[worst] > limit:
        i = rows[worst]
        raise MeasurementError(
            f"{data['source'].values[i]}, line {int(data['line'][i])}: velocity "
            f"{data['value'].values[i]:g} m s-1 is {values[worst] / max(model_speed, 1e-12):.3g} "
            "times the fastest velocity of the model; measurement files are in SI units "
            "(m s-1, not mm/s)")


def measurement_file_bytes(path: str | Path) -> bytes:
    """The bytes of a measurement file: a regular file of at most :data:`MAX_BYTES`.

    A link is followed only to a file in the link's own folder (or below it); the file
    is then opened without following links and without blocking (``O_NOFOLLOW |
    O_NONBLOCK``, then ``fstat``), so a FIFO, a device such as ``/dev/zero``, a folder
    or a file swapped for a link is refused before a byte is read, and nothing is read
    beyond the limit.

    Raises
    ------
    MeasurementError
        Naming the file and why it is not read.
    """
    path = Path(path)
    target = path
    if path.is_symlink():
        folder = path.absolute().parent.resolve()
        target = path.resolve()
        if not target.is_relative_to(folder):
            raise MeasurementError(f"{path}: a symbolic link out of its folder (to "
                                   f"{target}); measurement files are read only in their "
                                   "own folder: copy the file there or name it directly")
    try:
        return read_regular(target, MAX_BYTES)
    except SymbolicLink:
        why = "a symbolic link, not followed"
    except NotRegularFile as err:
        raise MeasurementError(f"{path}: {err.kind}, not a regular file; a measurement "
                               "file is a CSV text file") from None
    except TooLarge as err:
        raise MeasurementError(f"{path}: {err.size} bytes; a measurement file is at most "
                               f"{MAX_BYTES} bytes") from None
    except GrewWhileRead:
        raise MeasurementError(f"{path}: grew beyond {MAX_BYTES} bytes while read; a "
                               f"measurement file is at most {MAX_BYTES} bytes") from None
    except OSError as err:
        why = err.strerror or str(err)
    raise MeasurementError(f"{path}: cannot read the measurement file ({why})")


def read_measurements(paths: str | Path | Iterable[str | Path]) -> xr.Dataset:
    """Read one or more measurement files into one dataset over ``measurement``.

    Raises
    ------
    MeasurementError
        For a missing, unreadable or invalid file (file, line and column named), a file
        that is not a regular file, a link out of its folder, or a file beyond the
        limits (:data:`MAX_BYTES`, :data:`MAX_ROWS`, :data:`MAX_FIELD_CHARS`).
    """
    if isinstance(paths, str | Path):
        paths = [paths]
    parts = []
    for path in paths:
        path = Path(path)
        data = measurement_file_bytes(path)
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as err:
            line = data[: err.start].count(b"\n") + 1
            raise MeasurementError(f"{path}, line {line}: not UTF-8 text") from None
        parts.append(parse_measurements(text, str(path)))
    if not parts:
        raise MeasurementError("no measurement files given")
    return xr.concat(parts, dim="measurement") if len(parts) > 1 else parts[0]
