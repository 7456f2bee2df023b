"""The one spec layer of studies and scenes: read, parse, check, hash.

Every kind of spec (a study: ``[study]``; a scene: ``[scene]``; a fit, a design; the
kinds of :mod:`study.engine.kinds`, each marked by its top table) goes through the same
steps, each refusing bad input with a :class:`SpecError` that names the file, the key
and what is allowed, before anything is computed:

1. :func:`read_spec_text`: bytes from disk, at most :data:`MAX_SPEC_BYTES`, UTF-8.
2. :func:`parse_toml`: TOML to tables, no deeper than :data:`MAX_NESTING` levels and
   no infinite or NaN numbers (TOML allows ``inf`` and ``nan``; no spec key does).
3. :func:`check_schema`: the kind's JSON schema (package data in ``study/schemas/``),
   every violation explained as ``'FILE: [table] key: problem; allowed: ...'``.
4. The kind's own cross-field checks (:mod:`study.studies.spec`,
   :mod:`study.scenes.scene_spec`), with
   :func:`axis_values` for the axis grammar both share.

:func:`canonical_sha256` hashes the canonical form of a spec (what the numbers depend
on), so comments, formatting and key order never change it.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import sys
import tomllib
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.engine.files import NotRegularFile, open_regular
from study.engine.kinds import UnknownKind, kind_of_table
from study.model.inputs import InputTypeError

__all__ = [
    "AXIS_FORMS",
    "MAX_AXIS_VALUES",
    "MAX_NESTING",
    "MAX_SPEC_BYTES",
    "SCHEMA_DIR",
    "SpecError",
    "axis_length",
    "axis_values",
    "canonical_json",
    "canonical_sha256",
    "check_schema",
    "decode_spec_bytes",
    "detect_kind",
    "jsonable",
    "kind_of",
    "load_schema",
    "parse_toml",
    "read_spec_text",
    "schema_error",
    "schema_problems",
    "where",
]

#: The JSON schemas, shipped inside the package (``results_schema/`` at the top of the
#: repository holds an exact copy for readers; the code never reads it).
SCHEMA_DIR = Path(__file__).resolve().parents[1] / "schemas"

#: Largest spec file accepted [bytes]. The workflows are 1-3 kB; a 1 MiB spec is a
#: mistake (a result file or a data dump passed as a spec) and would only be slow.
MAX_SPEC_BYTES = 1 << 20

#: Deepest nesting of tables and arrays accepted. The specs need 4 (``[plan]
#: waypoints = [[x, y], ...]``); deeper input is refused before any recursive work
#: (schema validation, hashing) could exhaust the stack.
MAX_NESTING = 8

#: Values of one axis at most (also the schemas' maximum of ``num``).
MAX_AXIS_VALUES = 10_000_000


class SpecError(ValueError):
    """A spec that cannot be run; the message names file, key and what is allowed."""


# ---------------------------------------------------------------------------
# Reading and parsing

_BOMS = (
    (b"\xef\xbb\xbf", None),  # UTF-8 with a byte-order mark: accepted
    (b"\xff\xfe\x00\x00", "UTF-32"),
    (b"\x00\x00\xfe\xff", "UTF-32"),
    (b"\xff\xfe", "UTF-16"),
    (b"\xfe\xff", "UTF-16"),
)


def decode_spec_bytes(data: bytes, path: str, what: str = "spec", size: int | None = None
                      ) -> str:
    """Bytes of a spec file as text, or a :class:`SpecError` saying what is wrong.

    ``size`` is the file's size when ``data`` holds only its start.
    """
    if len(data) > MAX_SPEC_BYTES:
        total = max(size or 0, len(data))
        raise SpecError(
            f"{path}: {what} is {total} bytes; allowed at most {MAX_SPEC_BYTES} bytes "
            "(is this really a spec?)"
        )
    for mark, encoding in _BOMS:
        if encoding is not None and data.startswith(mark):
            raise SpecError(
                f"{path}: a {what} must be UTF-8 text (TOML); this file is {encoding} "
                "(save it as UTF-8)"
            )
    nul = data.find(b"\x00")
    if nul >= 0:
        # Valid UTF-8 but never TOML: most likely UTF-16 or UTF-32 without a mark.
        raise SpecError(
            f"{path}: a {what} must be UTF-8 text (TOML); byte {nul} is a NUL (is the file "
            "UTF-16 or UTF-32? save it as UTF-8)"
        )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise SpecError(
            f"{path}: a {what} must be UTF-8 text (TOML); byte {err.start} is not"
        ) from None


def read_spec_text(path: str | Path, what: str = "spec") -> str:
    """The text of a spec file (UTF-8, at most :data:`MAX_SPEC_BYTES` bytes).

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    what : str
        What the file is ("study spec", "scene spec"), for messages.

    Raises
    ------
    SpecError
        If the file cannot be read, is too large or is not UTF-8 text.
    """
    path = Path(path)
    try:
        # A FIFO named as the spec would wait for a writer forever, a device or a folder
        # is no spec; its size is judged by decode_spec_bytes, from what is read.
        with open_regular(path, sys.maxsize, follow_links=True) as stream:
            # One byte more than allowed tells "too large" without reading a huge file.
            data = stream.read(MAX_SPEC_BYTES + 1)
            size = os.fstat(stream.fileno()).st_size
    except NotRegularFile as err:
        if err.kind == "a folder":
            raise SpecError(f"{path}: cannot read the {what} (a folder, not a TOML file)"
                            ) from None
        kind = "a device" if err.kind.endswith("device") else err.kind
        raise SpecError(f"{path}: {kind}, not a regular file; a {what} is a TOML "
                        "file") from None
    except OSError as err:
        reason = err.strerror or str(err)
        raise SpecError(f"{path}: cannot read the {what} ({reason})") from None
    return decode_spec_bytes(data, str(path), what, size)


def _depth_and_non_finite(raw: Any) -> tuple[list[Any] | None, tuple[list[Any], float] | None]:
    """Where ``raw`` is nested deeper than :data:`MAX_NESTING` (None: it is not), and the
    location and value of a non-finite number.

    Iterative (an explicit stack): the input may be nested deep enough to exhaust
    Python's recursion limit.
    """
    bad: tuple[list[Any], float] | None = None
    stack: list[tuple[Any, int, list[Any]]] = [(raw, 0, [])]
    while stack:
        value, depth, location = stack.pop()
        if isinstance(value, dict | list):
            depth += 1
            if depth > MAX_NESTING:
                return location, bad
            items = value.items() if isinstance(value, dict) else enumerate(value)
            stack.extend((item, depth, [*location, key]) for key, item in items)
        elif isinstance(value, float) and not math.isfinite(value) and bad is None:
            bad = (location, value)
    return None, bad


def _key_of(location: list[Any]) -> list[Any]:
    """A location cut after its last key: ``[plate #2] f0``, not the indices below it."""
    last = max((i for i, part in enumerate(location) if isinstance(part, str)), default=-1)
    return location[:last + 1]


def _too_deep_line(text: str) -> str:
    """The line where brackets first nest deeper than :data:`MAX_NESTING`, as
    ``line N (key)``, found by a scan of the text (for input too deep to parse)."""
    depth = 0
    quote = ""
    keys: list[str] = []  # the key each open bracket belongs to ("" for none)
    for number, line in enumerate(text.splitlines(), 1):
        if depth == 0 and line.lstrip().startswith("["):
            continue  # a table header
        escaped = False
        for position, char in enumerate(line):
            if quote:
                if escaped:
                    escaped = False
                elif char == "\\" and quote == '"':
                    escaped = True
                elif char == quote:
                    quote = ""
            elif char in "\"'":
                quote = char
            elif char == "#":
                break
            elif char in "[{":
                before = line[:position].rstrip()
                key = ""
                if before.endswith("="):
                    # The key just before the "=": after the last separator.
                    start = max(before.rfind(mark) for mark in "{[,")
                    key = before[start + 1:-1].strip()
                keys.append(key)
                depth += 1
                if depth > MAX_NESTING:
                    path = ".".join(k for k in keys if k)
                    return f"line {number}" + (f" ({path})" if path else "")
            elif char in "]}":
                depth = max(depth - 1, 0)
                if keys:
                    keys.pop()
        quote = ""  # basic and literal strings end with their line
    return "the file"


def parse_toml(text: str, path: str = "<string>") -> dict[str, Any]:
    """TOML text as tables, refused cleanly when it is not a plausible spec.

    Raises
    ------
    SpecError
        For text larger than :data:`MAX_SPEC_BYTES`, TOML syntax errors, nesting
        deeper than :data:`MAX_NESTING` and ``inf`` or ``nan`` values.
    """
    if not isinstance(text, str):
        raise InputTypeError(f"{path}: the spec text must be a string (TOML), got "
                             f"{type(text).__name__}")
    size = len(text.encode("utf-8", errors="surrogatepass"))
    if size > MAX_SPEC_BYTES:
        raise SpecError(f"{path}: spec is {size} bytes; allowed at most {MAX_SPEC_BYTES} bytes")
    # A byte-order mark is not TOML; editors write one, so read past it (the text
    # kept for provenance stays the file's text).
    body = text[1:] if text.startswith("\ufeff") else text
    try:
        raw = tomllib.loads(body)
    except tomllib.TOMLDecodeError as err:
        raise SpecError(f"{path}: not valid TOML: {err}") from None
    except RecursionError:
        raise SpecError(
            f"{path}: tables or arrays nested too deeply at {_too_deep_line(body)}; allowed at "
            f"most {MAX_NESTING} levels"
        ) from None
    too_deep, bad = _depth_and_non_finite(raw)
    if too_deep is not None:
        raise SpecError(
            f"{path}: tables or arrays nested {MAX_NESTING + 1} levels deep or more at "
            f"{where(_key_of(too_deep))}; allowed at most {MAX_NESTING} levels"
        )
    if bad is not None:
        location, value = bad
        raise SpecError(
            f"{path}: {where(location)} = {value!r} is not a finite number; allowed: finite "
            "numbers (TOML's inf and nan are not spec values)"
        )
    return raw


def kind_of(raw: Mapping[str, Any], path: str = "<string>") -> str:
    """The name of the result kind (:mod:`study.engine.kinds`) whose top table a parsed
    TOML document has: ``"study"``, ``"scene"``, ``"fit"`` or ``"design"``."""
    try:
        return kind_of_table(raw, path).name
    except UnknownKind as err:
        raise SpecError(str(err)) from None


def detect_kind(source: str | Path) -> str:
    """The name of the result kind of a spec: the kind whose top table it has.

    Parameters
    ----------
    source : pathlib.Path or str
        A spec file (a :class:`pathlib.Path`), or a spec's TOML text (a ``str``).

    Raises
    ------
    SpecError
        If the file cannot be read or parsed (see :func:`read_spec_text` and
        :func:`parse_toml`), or has no kind's table or more than one.
    """
    if isinstance(source, Path):
        path = str(source)
        text = read_spec_text(source)
    else:
        path, text = "<string>", source
    return kind_of(parse_toml(text, path), path)


# ---------------------------------------------------------------------------
# Schemas


@cache
def load_schema(name: str) -> dict[str, Any]:
    """A JSON schema of the package by name, e.g. ``"study-spec-v1"``."""
    return json.loads((SCHEMA_DIR / f"{name}.schema.json").read_text(encoding="utf-8"))


def where(location: list[Any] | tuple[Any, ...]) -> str:
    """A location in a spec as the user wrote it: ``[sweep] f.num``, ``[plate #2] Q``."""
    if not location:
        return "top level"
    table, *rest = location
    head = f"[{table}]"
    if rest and isinstance(rest[0], int):
        # An array of tables: number its entries from 1, as a reader counts them.
        head = f"[{table} #{rest[0] + 1}]"
        rest = rest[1:]
    key = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in rest).lstrip(".")
    return head + (f" {key}" if key else "")


_BOUNDS = {"minimum": ">=", "exclusiveMinimum": ">", "maximum": "<=", "exclusiveMaximum": "<"}


def _explain(error: Any) -> str:
    """One schema violation as 'where: what is wrong; allowed: what'."""
    location = list(error.absolute_path)
    at = where(location)
    hint = error.schema.get("description", "")
    if error.validator == "additionalProperties":
        allowed = sorted(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(allowed))
        what = "unknown key" + ("s " if len(extra) > 1 else " ") + ", ".join(map(repr, extra))
        return f"{at}: {what}; allowed keys: {', '.join(allowed)}"
    if error.validator == "required":
        required = list(error.validator_value)
        if not location:
            # The top level's description is the whole schema's prose: name the tables.
            return f"{at}: {error.message}; required tables: {', '.join(required)}"
        return f"{at}: {error.message}; required keys: {', '.join(required)}" + (
            f" ({hint})" if hint else "")
    if error.validator in ("oneOf", "anyOf"):
        chosen = _chosen_branch(error)
        if chosen:
            # The form the user evidently meant (its required keys are there): say
            # what is wrong inside it, e.g. a string among an axis's values.
            reason = " (" + "; ".join(dict.fromkeys(_explain(e) for e in chosen)) + ")"
        else:
            from jsonschema.exceptions import best_match

            detail = best_match(error.context) if error.context else None
            reason = f" ({detail.message})" if detail is not None else ""
        return f"{at}: {_short(error.instance)} does not match any allowed form{reason}; {hint}"
    if error.validator == "enum":
        allowed = ", ".join(map(repr, error.validator_value))
        return f"{at}: {_short(error.instance)} is not allowed; allowed: {allowed}"
    if error.validator in _BOUNDS:
        limits = " and ".join(
            f"{_BOUNDS[key]} {error.schema[key]}" for key in _BOUNDS if key in error.schema
        )
        return (f"{at} = {_short(error.instance)} is out of range; allowed: {limits}"
                + (f" ({hint})" if hint else ""))
    if error.validator == "type":
        expected = error.validator_value
        return (
            f"{at}: {_short(error.instance)} has the wrong type; expected {expected}"
            + (f" ({hint})" if hint else "")
        )
    return f"{at}: {error.message}" + (f"; allowed: {hint}" if hint else "")


def _chosen_branch(error: Any) -> list[Any]:
    """The errors of the one ``oneOf`` branch whose required keys the instance has."""
    if not isinstance(error.instance, dict) or not error.context:
        return []
    branches = error.schema.get(error.validator, [])
    meant = [i for i, branch in enumerate(branches)
             if branch.get("required") and set(branch["required"]) <= set(error.instance)]
    if len(meant) != 1:
        return []
    return [e for e in error.context if e.relative_schema_path
            and e.relative_schema_path[0] == meant[0]]


def _short(value: Any, limit: int = 80) -> str:
    """``repr`` of a value, cut short (a message must stay one readable line)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 5] + " ...]"


def _is_integer(checker: Any, instance: Any) -> bool:
    # TOML tells integers from floats; JSON schema counts 60.0 as an integer, and a
    # count written 60.0 would reach range() and numpy shapes as a float.
    return isinstance(instance, int) and not isinstance(instance, bool)


@cache
def _validator_class() -> Any:
    """Draft 2020-12 with TOML's integers: ``num = 3.0`` is a float, not an integer."""
    import jsonschema

    base = jsonschema.Draft202012Validator
    return jsonschema.validators.extend(
        base, type_checker=base.TYPE_CHECKER.redefine("integer", _is_integer))


def check_schema(raw: Mapping[str, Any], schema: Mapping[str, Any], path: str,
                 what: str = "spec") -> None:
    """Validate parsed tables against a JSON schema (Draft 2020-12).

    Raises
    ------
    SpecError
        Listing every violation, one per line, as ``[table] key: problem; allowed: ...``.
    """
    found = schema_problems(raw, schema)
    if found:
        raise schema_error(found, path, what)


def schema_error(found: list[tuple[str, tuple[Any, ...]]], path: str,
                 what: str = "spec") -> SpecError:
    """The refusal of :func:`check_schema` for the violations ``found``."""
    return SpecError(f"{path}: invalid {what}:\n  "
                     + "\n  ".join(dict.fromkeys(message for message, _ in found)))


def schema_problems(raw: Mapping[str, Any], schema: Mapping[str, Any]
                    ) -> list[tuple[str, tuple[Any, ...]]]:
    """Every violation of ``schema`` by ``raw``, as ``(message, tainted)``: the message of
    :func:`check_schema` and the location it leaves unknown (the value's own path; the
    whole table for an unknown or missing key, which may be any of its keys misspelt).
    A spec's other checks run on what no violation taints
    (:func:`study.studies.spec.parse_spec`)."""
    validator = _validator_class()(schema)
    errors = sorted(validator.iter_errors(raw), key=lambda e: list(map(str, e.absolute_path)))
    return [(_explain(error), tuple(error.absolute_path)) for error in errors]


# ---------------------------------------------------------------------------
# The axis grammar: { start, stop, num [, spacing] } or { values = [...] }

#: The grammar, as the schemas' ``description`` of an axis says it.
AXIS_FORMS = (
    'allowed forms: { start = x, stop = y, num = n } with optional spacing = "linear" | '
    '"log", or { values = [x, y, ...] }'
)


def axis_length(table: Mapping[str, Any]) -> int:
    """Number of values an axis table (already schema-checked) describes."""
    if "values" in table:
        return len(table["values"])
    return int(table["num"])


def axis_values(table: Mapping[str, Any], at: str) -> NDArray[np.float64]:
    """The values of an axis table (already schema-checked), distinct and finite.

    Parameters
    ----------
    table : mapping
        ``{start, stop, num[, spacing]}`` or ``{values = [...]}``.
    at : str
        Where the axis is, ``"FILE: [sweep] f"``, for messages.

    Raises
    ------
    SpecError
        For a float ``num``, a log spacing through zero, an empty axis, non-finite
        or repeated values.
    """
    if "values" in table:
        values = np.asarray(table["values"], dtype=np.float64)
    else:
        num = table["num"]
        if isinstance(num, bool) or not isinstance(num, int):
            raise SpecError(f"{at}: num = {num!r} must be an integer")
        if not 1 <= num <= MAX_AXIS_VALUES:
            raise SpecError(f"{at}: num = {num!r}; allowed: 1 to {MAX_AXIS_VALUES}")
        start, stop = float(table["start"]), float(table["stop"])
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise SpecError(f"{at}: start and stop must be finite numbers")
        log = table.get("spacing", "linear") == "log"
        if log and (start <= 0 or stop <= 0):
            raise SpecError(f"{at}: log spacing needs start > 0 and stop > 0")
        # Ends near the largest double overflow in between: refused as not finite below.
        with np.errstate(over="ignore", invalid="ignore"):
            values = np.geomspace(start, stop, num) if log else np.linspace(start, stop, num)
    if values.size == 0:
        raise SpecError(f"{at}: empty axis; give at least one value")
    if not np.all(np.isfinite(values)):
        raise SpecError(f"{at}: values must be finite")
    if np.unique(values).size != values.size:
        raise SpecError(f"{at}: values must be distinct (is num larger than the range "
                        "holds in double precision?)")
    return values


# ---------------------------------------------------------------------------
# Canonical form and hash


def jsonable(value: Any) -> Any:
    """``value`` with numpy arrays and scalars (and tuples) turned into JSON types."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def canonical_json(obj: Any) -> str:
    """``obj`` as canonical JSON: sorted keys, compact separators, numbers as Python
    writes them (the shortest text that reads back to the same double)."""
    return json.dumps(jsonable(obj), sort_keys=True, separators=(",", ":"), allow_nan=False)


def canonical_sha256(obj: Any) -> str:
    """SHA-256 (hex) of :func:`canonical_json`: the hash of a spec's canonical form."""
    return hashlib.sha256(canonical_json(obj).encode("utf-8")).hexdigest()
