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
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from study.specfile import SCHEMA_DIR, SpecError
from study.units import DIMENSIONLESS, HERTZ, KILOGRAM, METRE_PER_SECOND, METRE_PER_SECOND_SQUARED

__all__ = [
    "COLUMNS",
    "MEASUREMENT_SCHEMA",
    "MEASUREMENT_SCHEMA_PATH",
    "QUANTITIES",
    "Column",
    "MeasurementError",
    "Quantity",
    "export_measurement_schema",
    "measurement_schema",
    "parse_measurements",
    "read_measurements",
]

MEASUREMENT_SCHEMA = "study-measurements-v1"
MEASUREMENT_SCHEMA_PATH = SCHEMA_DIR / f"{MEASUREMENT_SCHEMA}.schema.json"

#: Largest measurement file read [bytes] (a lab file is kilobytes).
MAX_BYTES = 16 << 20


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


def _number(cell: str) -> float | None:
    try:
        value = float(cell)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def parse_measurements(text: str, path: str = "<string>") -> xr.Dataset:
    """Read measurement CSV text into a dataset over ``measurement`` (see module doc).

    Raises
    ------
    MeasurementError
        Listing every problem, each as ``FILE, line N, column C: problem; allowed: ...``.
    """
    lines = text.splitlines()
    numbered = [(i + 1, line) for i, line in enumerate(lines)
                if line.strip() and not line.lstrip().startswith("#")]
    if not numbered:
        raise MeasurementError(f"{path}: no header row; the first line names the columns, "
                               f"e.g. 'quantity,f,a,value,sigma'")
    reader = csv.reader(io.StringIO("\n".join(line for _, line in numbered)))
    rows = list(reader)
    header_line = numbered[0][0]
    header = [h.strip() for h in rows[0]]
    problems: list[str] = []
    unknown = [h for h in header if h not in COLUMNS]
    if unknown:
        problems.append(
            f"{path}, line {header_line}: unknown column"
            + ("s " if len(unknown) > 1 else " ") + ", ".join(map(repr, unknown))
            + "; allowed: " + ", ".join(COLUMNS))
    duplicated = sorted({h for h in header if header.count(h) > 1})
    if duplicated:
        problems.append(f"{path}, line {header_line}: column "
                        + ", ".join(map(repr, duplicated)) + " given twice")
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        problems.append(f"{path}, line {header_line}: missing required column "
                        + ", ".join(map(repr, missing)) + "; the header must name "
                        + ", ".join(REQUIRED_COLUMNS) + " (optional: "
                        + ", ".join(c for c in COLUMNS if c not in REQUIRED_COLUMNS) + ")")
    if problems:
        raise MeasurementError("\n  ".join([f"{path}: invalid measurement file:", *problems]))

    records: list[tuple[int, dict[str, Any]]] = []
    for (line_no, _), cells in zip(numbered[1:], rows[1:], strict=True):
        where = f"{path}, line {line_no}"
        if len(cells) != len(header):
            problems.append(f"{where}: {len(cells)} cells, the header has {len(header)} "
                            "(leave a cell empty, not out)")
            continue
        row: dict[str, Any] = {}
        bad = False
        for name, cell in zip(header, cells, strict=True):
            cell = cell.strip()
            if not cell:
                continue  # not applicable
            if COLUMNS[name].number:
                value = _number(cell)
                if value is None:
                    problems.append(f"{where}, column {name!r}: {cell!r} is not a finite "
                                    f"number")
                    bad = True
                    continue
                row[name] = value
            else:
                row[name] = cell
        if bad:
            continue
        errors = sorted(_validator().iter_errors(row), key=lambda e: list(map(str, e.path)))
        if errors:
            quantity = row.get("quantity")
            if quantity is not None and quantity not in QUANTITIES:
                errors = [e for e in errors if e.validator == "enum"] or errors
            problems += dict.fromkeys(_explain(e, row, where) for e in errors)
            continue
        if "m_add" in row and "M" in row:
            problems.append(f"{where}, columns 'm_add' and 'M': give the structure by one "
                            "of them")
            continue
        records.append((line_no, row))
    if problems:
        shown = problems[:30] + ([f"... and {len(problems) - 30} more"]
                                 if len(problems) > 30 else [])
        raise MeasurementError("\n  ".join([f"{path}: invalid measurement file:", *shown]))
    if not records:
        raise MeasurementError(f"{path}: no measurements (only a header)")
    return _dataset(records, path)


def _dataset(records: Sequence[tuple[int, dict[str, Any]]], path: str) -> xr.Dataset:
    def numbers(name: str) -> np.ndarray:
        return np.array([row.get(name, np.nan) for _, row in records], dtype=np.float64)

    quantity = [row["quantity"] for _, row in records]
    direction = [row.get("direction", "unknown" if row["quantity"] == "threshold" else "")
                 for _, row in records]
    dims = ("measurement",)

    def var(name: str, values: Any, **attrs: Any) -> xr.Variable:
        column = COLUMNS.get(name)
        base = {"long_name": column.long_name} if column else {}
        if column is not None and column.units not in ("", "value"):
            base["units"] = column.units
        return xr.Variable(dims, values, {**base, **attrs})

    units_note = "units by quantity, see value_units"
    data = {
        "quantity": var("quantity", np.array(quantity, dtype=object),
                        allowed_values=" ".join(QUANTITIES)),
        "f": var("f", numbers("f")),
        "a": var("a", numbers("a")),
        "value": var("value", numbers("value"), comment=units_note),
        "sigma": var("sigma", numbers("sigma"), comment=units_note + "; NaN: not given"),
        "value_units": var("value_units", np.array(
            [QUANTITIES[q].units for q in quantity], dtype=object),
            long_name="units of value and sigma"),
        "direction": var("direction", np.array(direction, dtype=object)),
        "m_add": var("m_add", numbers("m_add")),
        "M": var("M", numbers("M")),
        "source": var("source", np.array([path] * len(records), dtype=object),
                      long_name="measurement file"),
        "line": var("line", np.array([n for n, _ in records], dtype=np.int32),
                    long_name="line in the measurement file (1 = first line)"),
    }
    return xr.Dataset(data, attrs={"study_measurement_schema": MEASUREMENT_SCHEMA})


def read_measurements(paths: str | Path | Iterable[str | Path]) -> xr.Dataset:
    """Read one or more measurement files into one dataset over ``measurement``.

    Raises
    ------
    MeasurementError
        For a missing, unreadable or invalid file (file, line and column named).
    """
    if isinstance(paths, str | Path):
        paths = [paths]
    parts = []
    for path in paths:
        path = Path(path)
        try:
            data = path.read_bytes()
        except OSError as err:
            raise MeasurementError(f"{path}: cannot read the measurement file "
                                   f"({err.strerror or err})") from None
        if len(data) > MAX_BYTES:
            raise MeasurementError(f"{path}: {len(data)} bytes; a measurement file is at "
                                   f"most {MAX_BYTES} bytes")
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as err:
            line = data[: err.start].count(b"\n") + 1
            raise MeasurementError(f"{path}, line {line}: not UTF-8 text") from None
        parts.append(parse_measurements(text, str(path)))
    if not parts:
        raise MeasurementError("no measurement files given")
    return xr.concat(parts, dim="measurement") if len(parts) > 1 else parts[0]
