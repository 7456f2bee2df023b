"""Validation and reading of result files of every kind, streaming.

A result file is a netCDF-4 file with a global attribute ``study_result_schema``:

``study-result-v1``
    a parameter study (:mod:`study.engine.runner`): its variables are declared once in
    :mod:`study.engine.variables` and chosen by the spec's observables
    (:func:`study.engine.observables.variables_of`);
``study-scene-v1``
    a steering scene (:mod:`study.scenes.scene_kind`): a trajectory, a calibration or a plan.

:func:`validate_file` checks a file against its JSON schema (``results_schema/``),
its embedded spec, its declarations, its provenance and its content checksum, and
lists every problem in one :class:`ResultError`. It reads the data in slabs of at
most :data:`SLAB_BYTES` along the leading dimensions, so the memory it needs does
not grow with the file. :func:`seal` records the content checksum
(:func:`content_sha256`) in a freshly written file and validates it: the writer
calls it on its temporary file before the atomic rename.

:func:`read_attributes` reads the global attributes only (deciding "up to date"
needs no data), :func:`open_result` returns a validated file loaded into memory
(for figures) and :func:`describe` summarises any result for people.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from study.engine.observables import variables_of
from study.engine.provenance import fingerprint
from study.engine.study_spec import SPEC_SCHEMA_PATH, SpecError, parse_spec
from study.engine.variables import RESULT_FORMAT, STALE_RESULT_FORMATS, VARIABLES
from study.model.status import INVALID_STATUSES, Status

__all__ = [
    "CONTENT_ATTRIBUTE",
    "DESIGN_SCHEMA",
    "DESIGN_SCHEMA_PATH",
    "FIT_SCHEMA",
    "FIT_SCHEMA_PATH",
    "PROVENANCE_SCHEMA_PATH",
    "RESULT_SCHEMA",
    "RESULT_SCHEMA_PATH",
    "SCENE_SCHEMA",
    "SCENE_SCHEMA_PATH",
    "SLAB_BYTES",
    "ResultError",
    "content_sha256",
    "describe",
    "header",
    "open_result",
    "read_attributes",
    "seal",
    "validate_file",
]

#: Parameter studies (study.engine.runner).
RESULT_SCHEMA = "study-result-v1"
#: Steering scenes (study.scenes.scene_kind): trajectories, calibrations, plans.
SCENE_SCHEMA = "study-scene-v1"
_SCHEMA_DIR = SPEC_SCHEMA_PATH.parent
RESULT_SCHEMA_PATH = _SCHEMA_DIR / f"{RESULT_SCHEMA}.schema.json"
SCENE_SCHEMA_PATH = _SCHEMA_DIR / f"{SCENE_SCHEMA}.schema.json"
#: Files written by ``study fit`` (:mod:`study.analyses.fit`).
FIT_SCHEMA = "study-fit-v1"
FIT_SCHEMA_PATH = _SCHEMA_DIR / f"{FIT_SCHEMA}.schema.json"
#: Files written by ``study design`` (:mod:`study.analyses.design`).
DESIGN_SCHEMA = "study-design-v1"
DESIGN_SCHEMA_PATH = _SCHEMA_DIR / f"{DESIGN_SCHEMA}.schema.json"
#: The structure every result's ``provenance`` attribute (a JSON document) has.
PROVENANCE_SCHEMA_PATH = _SCHEMA_DIR / "study-provenance-v1.schema.json"

#: Global attribute holding :func:`content_sha256` of the file.
CONTENT_ATTRIBUTE = "study_content_sha256"

#: Most bytes one read of a variable asks for (validation, checksum, describe).
SLAB_BYTES = 32 * 2**20

#: A file may hold at most this many bytes of data per byte on disk (and at least
#: :data:`_MIN_DATA_BYTES`): deflate compresses at most ~1000:1, so more means a
#: corrupt header (a damaged dimension size), which would otherwise make
#: validation read terabytes of fill values.
_MAX_EXPANSION = 4096
_MIN_DATA_BYTES = 64 * 2**20

_HEX64 = re.compile(r"[0-9a-f]{64}")

#: What the netCDF/HDF5 libraries raise on a damaged file (through netCDF4-python).
_LIBRARY_ERRORS = (OSError, RuntimeError, ValueError, IndexError, KeyError, TypeError,
                   AttributeError, UnicodeError, MemoryError, OverflowError)


class ResultError(ValueError):
    """A result file that is unreadable, foreign, outdated or inconsistent."""


# ---------------------------------------------------------------------------
# Reading a file's metadata with netCDF4 (no data)


@dataclass(frozen=True)
class _Variable:
    """One variable's metadata as stored (no values)."""

    name: str
    dims: tuple[str, ...]
    shape: tuple[int, ...]
    #: numpy dtype of the values, None for variable-length strings.
    dtype: np.dtype | None
    #: "float64", "int8", ... or "str"; "unsupported ..." for types study never writes.
    type_name: str
    attrs: dict[str, Any]

    @property
    def nbytes(self) -> int:
        itemsize = 64 if self.dtype is None else self.dtype.itemsize
        return itemsize * math.prod(self.shape)


@dataclass(frozen=True)
class _File:
    """A result file's metadata: global attributes, dimensions and variables."""

    path: Path
    attrs: dict[str, Any]
    dims: dict[str, int]
    variables: dict[str, _Variable]
    groups: tuple[str, ...]


def _unreadable(path: Path, err: BaseException) -> ResultError:
    detail = " ".join(str(err).split()) or type(err).__name__
    return ResultError(f"{path}: not a readable netCDF file (truncated or corrupt?): {detail}")


def _open(path: Path, mode: str = "r"):
    """A netCDF4 dataset on ``path`` giving the stored values unchanged."""
    import netCDF4

    path = Path(path)
    try:
        regular = path.is_file()
    except OSError as err:  # a name too long, a permission denied on the way...
        raise ResultError(f"{path}: cannot read the result file ({err.strerror or err})"
                          ) from None
    if not regular:
        raise ResultError(f"{path}: no such file")
    try:
        nc = netCDF4.Dataset(path, mode)
    except Exception as err:  # the C library reports damage as OSError, RuntimeError...
        raise _unreadable(path, err) from None
    try:
        # Raw values: no masking, no scaling, char arrays stay char arrays.
        nc.set_auto_maskandscale(False)
        nc.set_always_mask(False)
        nc.set_auto_chartostring(False)
    except _LIBRARY_ERRORS as err:
        nc.close()
        raise _unreadable(path, err) from None
    return nc


def _variable_type(var: Any) -> tuple[np.dtype | None, str]:
    import netCDF4

    if var.dtype is str:
        return None, "str"
    datatype = var.datatype
    if isinstance(datatype, netCDF4.CompoundType | netCDF4.VLType | netCDF4.EnumType):
        return None, f"unsupported {type(datatype).__name__}"
    dtype = np.dtype(var.dtype)
    if dtype.kind not in "biufS":
        return None, f"unsupported {dtype}"
    return dtype, dtype.name


def _metadata(nc: Any, path: Path) -> _File:
    """Everything but the values, read once."""
    try:
        attrs = {str(k): nc.getncattr(k) for k in nc.ncattrs()}
        dims = {str(k): len(v) for k, v in nc.dimensions.items()}
        variables = {}
        for name, var in nc.variables.items():
            dtype, type_name = _variable_type(var)
            variables[str(name)] = _Variable(
                str(name), tuple(str(d) for d in var.dimensions),
                tuple(int(n) for n in var.shape), dtype, type_name,
                {str(k): var.getncattr(k) for k in var.ncattrs()})
        groups = tuple(str(g) for g in nc.groups)
    except _LIBRARY_ERRORS as err:
        raise _unreadable(path, err) from None
    return _File(Path(path), attrs, dims, variables, groups)


def read_attributes(path: str | Path) -> dict[str, Any]:
    """The global attributes of a result file, as plain Python values; no data is read.

    Raises
    ------
    ResultError
        For a missing, unreadable, truncated or non-netCDF file (one line naming it).
    """
    path = Path(path)
    nc = _open(path)
    try:
        return {k: _jsonable(v) for k, v in _metadata(nc, path).attrs.items()}
    finally:
        nc.close()


# ---------------------------------------------------------------------------
# Reading values in slabs


def _slabs(shape: tuple[int, ...], itemsize: int) -> Iterator[tuple[Any, ...]]:
    """Indices of consecutive slabs of at most :data:`SLAB_BYTES`, in C order.

    The slabs split the leading dimensions: one index of every dimension before
    the first whose trailing block fits the budget, then as many of its indices
    as fit. Concatenated, the slabs are the array in C order.
    """
    if not shape:
        yield (Ellipsis,)
        return
    if 0 in shape:
        return
    axis = next(k for k in range(len(shape))
                if math.prod(shape[k + 1:]) * itemsize <= SLAB_BYTES or k == len(shape) - 1)
    step = max(1, SLAB_BYTES // (math.prod(shape[axis + 1:]) * itemsize))
    for outer in np.ndindex(*shape[:axis]):
        for start in range(0, shape[axis], step):
            yield (*outer, slice(start, min(start + step, shape[axis])))


def _read(var: Any, index: tuple[Any, ...], path: Path) -> np.ndarray:
    try:
        values = var[index[0] if index == (Ellipsis,) else index]
    except _LIBRARY_ERRORS as err:
        raise _unreadable(path, err) from None
    return np.asarray(values)


# ---------------------------------------------------------------------------
# The content checksum


def _text_bytes(values: np.ndarray) -> bytes:
    out = bytearray()
    for item in values.ravel(order="C"):
        text = item.decode("utf-8", "surrogateescape") if isinstance(item, bytes) else str(item)
        out += text.encode("utf-8", "surrogateescape") + b"\0"
    return bytes(out)


def _numeric_bytes(values: np.ndarray) -> bytes:
    little = values.dtype.newbyteorder("<")
    return np.ascontiguousarray(values, dtype=little).tobytes(order="C")


def _type_token(dtype: np.dtype | None) -> str:
    return "str" if dtype is None else dtype.newbyteorder("<").str


def _attribute_bytes(value: Any) -> bytes:
    array = np.asarray(value)
    if isinstance(value, str) or array.dtype.kind in "OU":
        head = f"str\0{','.join(map(str, array.shape))}\0"
        return head.encode() + _text_bytes(array.astype(object))
    head = f"{_type_token(array.dtype)}\0{','.join(map(str, array.shape))}\0"
    return head.encode() + _numeric_bytes(array)


def _digest(nc: Any, meta: _File) -> str:
    digest = hashlib.sha256()
    for name in sorted(meta.variables):
        var = meta.variables[name]
        if var.type_name.startswith("unsupported"):
            raise ResultError(f"{meta.path}: variable {name!r} has a type study never writes "
                              f"({var.type_name.removeprefix('unsupported ')})")
        digest.update(
            f"{name}\0{_type_token(var.dtype)}\0{','.join(var.dims)}\0"
            f"{','.join(map(str, var.shape))}\0{len(var.attrs)}\0".encode("utf-8",
                                                                            "surrogateescape"))
        for key in sorted(var.attrs):
            digest.update(key.encode("utf-8", "surrogateescape") + b"\0")
            digest.update(_attribute_bytes(var.attrs[key]))
        handle = nc.variables[name]
        for index in _slabs(var.shape, 64 if var.dtype is None else var.dtype.itemsize):
            values = _read(handle, index, meta.path)
            digest.update(_text_bytes(values) if var.dtype is None else _numeric_bytes(values))
    return digest.hexdigest()


def content_sha256(path: str | Path) -> str:
    """SHA-256 of everything a result file holds in its variables.

    This definition is part of the file format: the global attribute
    ``study_content_sha256`` holds it, and :func:`validate_file` recomputes it.
    It is the SHA-256 of the following byte stream, built from every variable of
    the file's root group (data and coordinate variables alike), taken in sorted
    name order (Python ``str`` order):

    1. the variable's header, ``NAME 0 TYPE 0 DIMS 0 SHAPE 0 NATTRS 0`` (``0``
       is one NUL byte): ``NAME`` in UTF-8; ``TYPE`` the numpy dtype string of the
       little-endian type (``<f8``, ``|i1``, ``<i4``, ``|S1``...), or ``str``
       for variable-length strings; ``DIMS`` the dimension names joined by
       ``,``; ``SHAPE`` the sizes in decimal joined by ``,`` (both empty for a
       scalar); ``NATTRS`` the number of its attributes in decimal;
    2. each of its attributes in sorted name order: ``ANAME 0 TYPE 0 SHAPE 0``
       then the attribute's values (a text attribute has ``TYPE`` ``str`` and
       shape empty);
    3. its values as stored (no masking or scaling), in C order.

    Values are encoded as little-endian bytes for numbers, and as UTF-8 followed
    by one NUL byte per element for strings.

    Global attributes are not covered: validation checks them against the
    schema, the embedded spec and each other, and rewriting metadata (title,
    history) must not require reading the data again.

    Raises
    ------
    ResultError
        For a missing, unreadable or truncated file.
    """
    path = Path(path)
    nc = _open(path)
    try:
        return _digest(nc, _metadata(nc, path))
    finally:
        nc.close()


def seal(path: str | Path) -> str:
    """Record the content checksum in a freshly written result file, then validate it.

    Writes :func:`content_sha256` as the global attribute ``study_content_sha256``
    (appending to the file in place), then runs :func:`validate_file`.

    Returns
    -------
    str
        The checksum.

    Raises
    ------
    ResultError
        If the file cannot be read or does not validate.
    """
    path = Path(path)
    checksum = content_sha256(path)
    nc = _open(path, "a")
    try:
        nc.setncattr(CONTENT_ATTRIBUTE, checksum)
    except _LIBRARY_ERRORS as err:
        raise _unreadable(path, err) from None
    finally:
        nc.close()
    validate_file(path)
    return checksum


# ---------------------------------------------------------------------------
# Headers and schemas


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


def header(dataset: xr.Dataset) -> dict[str, Any]:
    """A dataset's structure as plain JSON data: what the result schemas validate.

    ``{"attrs": {...}, "dims": {name: size}, "variables": {name: {"dims": [...],
    "dtype": "float64", "attrs": {...}}}}``.
    """
    variables = {}
    for name, var in dataset.variables.items():
        variables[str(name)] = {
            "dims": list(var.dims),
            "dtype": str(var.dtype),
            "attrs": {k: _jsonable(v) for k, v in var.attrs.items()},
        }
    return {
        "attrs": {k: _jsonable(v) for k, v in dataset.attrs.items()},
        "dims": {str(k): int(v) for k, v in dataset.sizes.items()},
        "variables": variables,
    }


def _file_header(meta: _File) -> dict[str, Any]:
    """:func:`header` of a file read with netCDF4 (the stored attributes)."""
    return {
        "attrs": {k: _jsonable(v) for k, v in meta.attrs.items()},
        "dims": dict(meta.dims),
        "variables": {
            name: {"dims": list(var.dims), "dtype": var.type_name,
                   "attrs": {k: _jsonable(v) for k, v in var.attrs.items()}}
            for name, var in meta.variables.items()
        },
    }


@cache
def _validator(path: Path):
    import jsonschema

    return jsonschema.Draft202012Validator(json.loads(path.read_text()))


def _schema_problems(schema_path: Path, document: Any, where: str = "") -> list[str]:
    errors = sorted(_validator(schema_path).iter_errors(document),
                    key=lambda e: [str(p) for p in e.absolute_path])
    problems = []
    for error in errors:
        location = "/".join(map(str, error.absolute_path))
        if where:
            location = f"{where}/{location}" if location else where
        problems.append(f"{location or 'file'}: {_short(error.message)}")
    return problems


def _short(text: str, limit: int = 200) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[:limit] + "..."


# ---------------------------------------------------------------------------
# Checks shared by every kind


def _is_number(value: Any) -> bool:
    return (isinstance(value, int | float | np.integer | np.floating)
            and not isinstance(value, bool | np.bool_))


def _same_text(value: Any, expected: str) -> bool:
    # Attributes may be arrays or numbers: never compare them elementwise.
    return isinstance(value, str) and value == expected


def _same_number(value: Any, expected: float) -> bool:
    return _is_number(value) and float(value) == float(expected)


def _fingerprint_problems(attrs: dict[str, Any]) -> list[str]:
    """``study_fingerprint`` must be what the file's own spec and code hashes give.

    The definition is :func:`study.engine.provenance.fingerprint`'s, applied to the code
    hash recorded in the file (not the running code's): an old but honest file is
    valid, only stale.
    """
    value = attrs.get("study_fingerprint")
    spec_sha = attrs.get("study_spec_sha256")
    code_sha = attrs.get("study_code_sha256")
    if not isinstance(value, str) or not _HEX64.fullmatch(value):
        return []  # the schema reports a missing or malformed fingerprint
    if not isinstance(spec_sha, str) or not isinstance(code_sha, str):
        return []
    if value != fingerprint(spec_sha, code_sha):
        return ["study_fingerprint does not match study_spec_sha256 and study_code_sha256"]
    return []


def _provenance_problems(attrs: dict[str, Any], kind: str) -> list[str]:
    """The ``provenance`` attribute: a JSON object of the required structure,
    agreeing with the global attributes it repeats."""
    raw = attrs.get("provenance")
    if raw is None:
        return []  # the schema reports it missing
    if not isinstance(raw, str):
        return ["global attribute 'provenance' is not text"]
    try:
        document = json.loads(raw)
    except (ValueError, RecursionError):
        return ["global attribute 'provenance' is not a JSON document"]
    problems = _schema_problems(PROVENANCE_SCHEMA_PATH, document, "provenance")
    if problems:
        return problems
    code, run = document["code"], document["run"]
    for key, attr in (("code_sha256", "study_code_sha256"), ("fingerprint", "study_fingerprint")):
        if not _same_text(attrs.get(attr), code[key]):
            problems.append(f"provenance: code.{key} differs from the attribute {attr}")
    if document["result_schema"] != kind:
        problems.append(f"provenance: result_schema {document['result_schema']!r} differs "
                        f"from the file's {kind!r}")
    if not _same_text(attrs.get("study_version"), document["package"]["version"]):
        problems.append("provenance: package.version differs from the attribute study_version")
    wall = run["wall_seconds"]
    if isinstance(wall, float) and not math.isfinite(wall):  # JSON allows NaN, Infinity
        problems.append("provenance: run.wall_seconds is not finite")
    if _finished_before_started(run):
        problems.append("provenance: run.finished_utc is before run.started_utc")
    # Studies record how many points were computed and reused (the incremental
    # runner); files of the first runner have chunk counts instead.
    if kind == RESULT_SCHEMA and "points" in run:
        if run["points_computed"] + run["points_reused"] != run["points"]:
            problems.append("provenance: run.points_computed + run.points_reused != run.points")
    return problems


def _finished_before_started(run: dict[str, Any]) -> bool:
    """Whether ``run`` ends before it starts (both ISO 8601 UTC times, as written)."""
    return str(run["finished_utc"]) < str(run["started_utc"])


def _flag_problems(name: str, var: _Variable) -> tuple[list[str], np.ndarray | None]:
    """A flag variable's attributes, and its flag values if they are usable."""
    values, meanings = var.attrs.get("flag_values"), var.attrs.get("flag_meanings")
    if values is None or meanings is None:
        return [f"{name}: a flag variable needs both flag_values and flag_meanings"], None
    codes = np.atleast_1d(np.asarray(values))
    if codes.dtype.kind not in "iu" or codes.ndim != 1:
        return [f"{name}: flag_values must be integers"], None
    if not isinstance(meanings, str) or len(meanings.split()) != codes.size:
        return [f"{name}: flag_meanings must name each of the {codes.size} flag_values"], None
    if np.unique(codes).size != codes.size:
        return [f"{name}: flag_values repeat a value"], None
    return [], codes


class _Checker:
    """Value checks of one file, each reading its variables in slabs."""

    def __init__(self, nc: Any, meta: _File) -> None:
        self.nc = nc
        self.meta = meta

    def slabs(self, *names: str) -> Iterator[tuple[np.ndarray, ...]]:
        """Equal slabs of variables of one shape."""
        variables = [self.meta.variables[n] for n in names]
        itemsize = max(64 if v.dtype is None else v.dtype.itemsize for v in variables)
        for index in _slabs(variables[0].shape, itemsize):
            yield tuple(_read(self.nc.variables[n], index, self.meta.path) for n in names)

    def flags_in_range(self, name: str, codes: np.ndarray) -> list[str]:
        outside: dict[int, int] = {}
        for (values,) in self.slabs(name):
            bad = values[~np.isin(values, codes)]
            for value, count in zip(*np.unique(bad, return_counts=True), strict=True):
                outside[int(value)] = outside.get(int(value), 0) + int(count)
        if not outside:
            return []
        found = ", ".join(f"{v} ({c} points)" for v, c in sorted(outside.items())[:5])
        return [f"{name} holds values outside its flag_values "
                f"{codes.tolist()}: {found}"]

    def invalid_where(self, name: str, status: str, zero_when_static: bool = True
                      ) -> list[str]:
        mismatched = not_zero = 0
        invalid = [int(s) for s in INVALID_STATUSES]
        for values, codes in self.slabs(name, status):
            mismatched += int(np.count_nonzero(np.isnan(values) != np.isin(codes, invalid)))
            if zero_when_static:
                not_zero += int(np.count_nonzero((codes == Status.STATIC) & ~(values == 0.0)))
        problems = []
        if mismatched:
            problems.append(
                f"{name} must be NaN exactly where {status} is lift_off, not_converged or "
                f"friction_paradox; {mismatched} points disagree")
        if not_zero:
            problems.append(f"{name} is not 0 where {status} is static ({not_zero} points)")
        return problems

    def equals(self, name: str, expected: np.ndarray) -> bool:
        expected = np.asarray(expected).ravel()
        offset = 0
        for (values,) in self.slabs(name):
            flat = values.ravel()
            if not np.array_equal(flat, expected[offset:offset + flat.size]):
                return False
            offset += flat.size
        return offset == expected.size


def _size_problems(meta: _File) -> list[str]:
    total = sum(var.nbytes for var in meta.variables.values())
    limit = max(_MIN_DATA_BYTES, _MAX_EXPANSION * meta.path.stat().st_size)
    if total > limit:
        return [f"the variables declare {total} bytes of data in a file of "
                f"{meta.path.stat().st_size} bytes: the file's structure is damaged"]
    return []


def _checksum_problems(nc: Any, meta: _File) -> list[str]:
    recorded = meta.attrs.get(CONTENT_ATTRIBUTE)
    if recorded is None:
        return [f"no content checksum (global attribute {CONTENT_ATTRIBUTE!r}): written by "
                "an older version of study, its data cannot be verified; rerun its study "
                "(study run SPEC) to rewrite it"]
    if not isinstance(recorded, str) or not _HEX64.fullmatch(recorded):
        return []  # the schema reports the malformed value
    if _digest(nc, meta) != recorded:
        return [f"the content differs from the checksum recorded when the file was written "
                f"({CONTENT_ATTRIBUTE}): its data, dimensions or variable attributes changed"]
    return []


def _not_required_checksum(problem: str) -> bool:
    # A missing checksum gets its own message (with what to do about it).
    return not (CONTENT_ATTRIBUTE in problem and "required property" in problem)


def _parse_embedded(attrs: dict[str, Any], source: str,
                    parse: Callable[[str, str], Any]) -> tuple[Any, list[str]]:
    text = attrs.get("study_spec")
    if not isinstance(text, str):
        return None, []  # the schema reports it
    try:
        return parse(text, f"{source} (embedded spec)"), []
    except SpecError as err:
        return None, [f"embedded spec does not parse: {_short(str(err), 400)}"]
    except Exception as err:  # the spec is untrusted input: never crash on it
        return None, [f"embedded spec cannot be read ({type(err).__name__}: "
                      f"{_short(str(err))})"]


def _provenance_spec_problems(attrs: dict[str, Any], spec: Any, section: str) -> list[str]:
    """What the provenance repeats of the spec (``provenance[section]``, if there) must be
    the embedded spec's."""
    try:
        document = json.loads(str(attrs.get("provenance")))
    except (ValueError, RecursionError):
        return []  # reported with the provenance's structure
    part = document.get(section) if isinstance(document, dict) else None
    if not isinstance(part, dict):
        return []
    try:
        canonical = json.loads(json.dumps(spec.canonical, sort_keys=True))
    except (TypeError, ValueError):
        canonical = None
    expected = {"name": spec.name, "spec_sha256": spec.sha256, "canonical_spec": canonical,
                "kind": getattr(spec, "kind", None)}
    return [f"provenance: {section}.{key} differs from the embedded spec"
            for key, value in expected.items()
            if key in part and value is not None and part[key] != value]


def _identity_problems(attrs: dict[str, Any], spec: Any) -> list[str]:
    problems = []
    if not _same_text(attrs.get("study_spec_sha256"), spec.sha256):
        problems.append("study_spec_sha256 does not match the embedded spec")
    if not _same_text(attrs.get("study_name"), spec.name):
        problems.append("study_name differs from the embedded spec's name")
    if not _same_text(attrs.get("title"), spec.title):
        problems.append("title differs from the embedded spec's title")
    return problems


# ---------------------------------------------------------------------------
# Parameter studies


def _shown_format(value: Any) -> str:
    """A format attribute as a person reads it (2, not np.int64(2))."""
    if _is_number(value) and math.isfinite(float(value)) and float(value).is_integer():
        return str(int(value))
    return repr(value)


def _stale_format_problems(meta: _File) -> list[str]:
    """A study file of an older ``study_result_format`` that holds a variable whose units
    changed since: its numbers would be misread, so it is refused whole as stale."""
    written = meta.attrs.get("study_result_format", 1)
    if _is_number(written) and written == RESULT_FORMAT:
        return []
    changed = STALE_RESULT_FORMATS.get(written if _is_number(written) else None)
    if changed is None:
        return [f"study_result_format {_shown_format(written)} is unknown: this study reads format "
                f"{RESULT_FORMAT}; rerun its spec"]
    held = [f"{name} in {units}" for name, units in changed.items() if name in meta.variables]
    if not held:
        return []  # nothing in it changed units
    now = ", ".join(f"{name} in {VARIABLES[name].units}" for name in changed
                    if name in meta.variables)
    return [f"study result format {_shown_format(written)} ({', '.join(held)}) is stale: "
            f"this study reads format {RESULT_FORMAT} ({now}); rerun its spec"]


def _study_problems(nc: Any, meta: _File, source: str) -> list[str]:
    attrs = meta.attrs
    stale = _stale_format_problems(meta)
    if stale:
        return stale
    problems = [p for p in _schema_problems(RESULT_SCHEMA_PATH, _file_header(meta))
                if _not_required_checksum(p)]
    problems += _fingerprint_problems(attrs)
    problems += _provenance_problems(attrs, RESULT_SCHEMA)
    size_problems = _size_problems(meta)
    if size_problems:  # reading the values would be pointless, and could take hours
        return problems + size_problems
    check = _Checker(nc, meta)
    spec, spec_problems = _parse_embedded(attrs, source, parse_spec)
    problems += spec_problems
    if spec is not None:
        problems += _identity_problems(attrs, spec)
        problems += _provenance_spec_problems(attrs, spec, "study")
        for key, value in (("study_solver_method", spec.method),
                           ("study_coupling", spec.coupling)):
            if not _same_text(attrs.get(key), value):
                problems.append(f"{key} differs from the embedded spec ({value!r})")
        problems += _study_content_problems(check, meta, spec)
    problems += _checksum_problems(nc, meta)
    return problems


def _study_content_problems(check: _Checker, meta: _File, spec: Any) -> list[str]:
    """Coordinates and variables against the spec and the declarations."""
    problems = []
    variables = meta.variables
    for axis in spec.axes:
        var = variables.get(axis.name)
        if var is None:
            problems.append(f"coordinate {axis.name!r} of the embedded spec is missing")
        elif var.dims != (axis.name,) or var.type_name != "float64":
            problems.append(f"coordinate {axis.name!r} must be float64 over ({axis.name},)")
        elif not _same_text(var.attrs.get("units"), axis.units):
            problems.append(f"coordinate {axis.name!r}: units {var.attrs.get('units')!r}, "
                            f"declared {axis.units!r}")
        elif not check.equals(axis.name, axis.values):
            problems.append(f"coordinate {axis.name!r} differs from the embedded spec")
    structure = spec.canonical.get("structure") if isinstance(spec.canonical, dict) else None
    for name, value in (structure.items() if isinstance(structure, dict) else ()):
        var = variables.get(name)
        if not _is_number(value):
            continue  # not a fixed value in the spec layer's form
        if var is None or var.shape != () or var.type_name != "float64":
            problems.append(f"fixed parameter {name!r} must be a float64 scalar")
        elif not check.equals(name, np.array([value], dtype=np.float64)):
            problems.append(f"{name} differs from the embedded spec's {value!r}")
    structure_dims = tuple(axis.name for axis in spec.axes if axis.name not in ("f", "a"))
    wanted = variables_of(spec.observables)
    wanted_names = {v.name for v in wanted}
    for name in variables:
        if name in VARIABLES and name not in wanted_names:
            problems.append(f"variable {name!r} is not among the spec's observables")
    good: set[str] = set()
    for declared in wanted:
        name = declared.name
        var = variables.get(name)
        if var is None:
            problems.append(f"variable {name!r} asked for by the spec is missing")
            continue
        before = len(problems)
        dims = declared.dims(structure_dims)
        if var.dims != dims:
            problems.append(f"{name} has dimensions ({', '.join(var.dims)}); declared "
                            f"({', '.join(dims)})")
        if var.type_name != declared.dtype:
            problems.append(f"{name} is {var.type_name}; declared {declared.dtype}")
        for key in ("units", "long_name"):
            if not _same_text(var.attrs.get(key), getattr(declared, key)):
                problems.append(f"{name}: {key} {_short(repr(var.attrs.get(key)), 80)}; "
                                f"declared {getattr(declared, key)!r}")
        if declared.is_flag:
            flag_values = np.atleast_1d(np.asarray(var.attrs.get("flag_values", [])))
            if (flag_values.dtype != np.dtype(declared.dtype)
                    or flag_values.tolist() != list(declared.flag_values)):
                problems.append(f"{name}: flag_values {flag_values.tolist()}; declared "
                                f"{list(declared.flag_values)} ({declared.dtype})")
            if not _same_text(var.attrs.get("flag_meanings"), " ".join(declared.flags)):
                problems.append(f"{name}: flag_meanings differ from the declared "
                                f"{' '.join(declared.flags)!r}")
        elif "flag_values" in var.attrs or "flag_meanings" in var.attrs:
            problems.append(f"{name} is not a flag variable but has flag attributes")
        if len(problems) == before:
            good.add(name)
    for declared in wanted:
        if declared.name not in good:
            continue  # its values cannot be checked against a wrong layout
        if declared.is_flag:
            problems += check.flags_in_range(declared.name,
                                             np.asarray(declared.flag_values))
        if declared.invalid_where and declared.invalid_where in good:
            problems += check.invalid_where(declared.name, declared.invalid_where,
                                            declared.zero_when_static)
    return problems


# ---------------------------------------------------------------------------
# Steering scenes


#: What the stale scene formats held, for the message refusing them.
_STALE_SCENE_FORMATS = {
    1: "angles in rad",
    2: "heading drift in rad per diameter, spec key heading_drift",
}


def _scene_attribute_values(spec: Any) -> dict[str, float]:
    """Global attributes a scene file repeats from its spec (what figures read)."""
    disk = spec.disk
    expected = {f"disk_{key}": getattr(disk, key) for key in
                ("radius", "cs", "ck", "g", "gyration_radius", "friction_length")}
    expected["integrator_tolerance"] = spec.settings.tolerance
    expected["integrator_slaving"] = spec.slaving
    if spec.kind == "plan":
        x, y, heading = spec.options["start"]  # heading in degree, as in the spec
        expected.update(start_x=x, start_y=y, start_heading=heading)
    return expected


def _scene_problems(nc: Any, meta: _File, source: str) -> list[str]:
    from study.scenes.scene_kind import SCENE_FORMAT, parse_scene

    attrs = meta.attrs
    written = attrs.get("study_scene_format", 1)
    if not (_is_number(written) and written == SCENE_FORMAT):
        # Its numbers would be misread (format 1 stored angles in rad, format 2 the heading
        # drift in rad per diameter): refuse it whole.
        held = _STALE_SCENE_FORMATS.get(written if _is_number(written) else None,
                                        "an unknown layout")
        return [f"scene format {_shown_format(written)} ({held}) is stale: this study reads format "
                f"{SCENE_FORMAT} (every angle in degree, the heading drift in degree per "
                "diameter, spec key heading_drift_deg); rerun its spec"]
    problems = [p for p in _schema_problems(SCENE_SCHEMA_PATH, _file_header(meta))
                if _not_required_checksum(p)]
    problems += _fingerprint_problems(attrs)
    problems += _provenance_problems(attrs, SCENE_SCHEMA)
    size_problems = _size_problems(meta)
    if size_problems:  # reading the values would be pointless, and could take hours
        return problems + size_problems
    spec, spec_problems = _parse_embedded(attrs, source, parse_scene)
    problems += spec_problems
    if spec is not None:
        problems += _identity_problems(attrs, spec)
        problems += _provenance_spec_problems(attrs, spec, "scene")
        if not _same_text(attrs.get("study_scene_kind"), spec.kind):
            problems.append("study_scene_kind does not match the embedded spec")
        for key, value in _scene_attribute_values(spec).items():
            if value is not None and not _same_number(attrs.get(key), value):
                problems.append(f"{key} differs from the embedded spec ({value!r})")
    for key in ("study_end_time",):
        if key in attrs and not (_is_number(attrs[key]) and math.isfinite(attrs[key])):
            problems.append(f"{key} must be a finite number")
    for key in ("study_steps", "study_slips"):
        if key in attrs and not (isinstance(attrs[key], int | np.integer) and attrs[key] >= 0):
            problems.append(f"{key} must be an integer >= 0")
    if "study_outcome" in attrs and not isinstance(attrs["study_outcome"], str):
        problems.append("study_outcome must be text")
    check = _Checker(nc, meta)
    for name, var in meta.variables.items():
        if var.type_name.startswith("unsupported"):
            problems.append(f"{name} has a type study never writes ({var.type_name})")
            continue
        if var.dtype is not None and var.dtype.kind == "f" and "units" not in var.attrs:
            problems.append(f"{name} has no units")
        if "flag_values" in var.attrs or "flag_meanings" in var.attrs:
            flag_problems, codes = _flag_problems(name, var)
            problems += flag_problems
            if codes is not None:
                if var.dtype is None or var.dtype.kind not in "iu":
                    problems.append(f"{name}: a flag variable must hold integers")
                else:
                    problems += check.flags_in_range(name, codes)
    problems += _checksum_problems(nc, meta)
    return problems


#: What the stale fit and design formats held, for the message refusing them.
_STALE_FIT_FORMATS = {1: "units spelled deg, not degree"}


def _stale_fit_problems(meta: _File, design: bool) -> list[str]:
    """A fit or design file of an older format: refused whole, as scenes are."""
    if design:
        from study.analyses.design import DESIGN_FORMAT as current
    else:
        from study.analyses.fit import FIT_FORMAT as current
    what = "design" if design else "fit"
    written = meta.attrs.get(f"study_{what}_format", 1)
    if _is_number(written) and written == current:
        return []
    held = _STALE_FIT_FORMATS.get(written if _is_number(written) else None, "an unknown layout")
    return [f"{what} format {_shown_format(written)} ({held}) is stale: this study reads "
            f"format {current} (every unit in CF/UDUNITS spelling, angles in degree); "
            f"rerun its spec with `study {what}`"]


def _fit_problems(nc: Any, meta: _File, schema_path: Path = FIT_SCHEMA_PATH) -> list[str]:
    """A fit result: its header against ``study-fit-v1``, sizes that agree, the checksum
    (a design result the same way, against ``study-design-v1``)."""
    stale = _stale_fit_problems(meta, design=schema_path != FIT_SCHEMA_PATH)
    if stale:
        return stale
    problems = [p for p in _schema_problems(schema_path, _file_header(meta))
                if _not_required_checksum(p)]
    names = meta.dims.get("parameter")
    if (schema_path == FIT_SCHEMA_PATH and names is not None
            and meta.dims.get("parameter_2") != names):
        problems.append("dimensions parameter and parameter_2 differ in size")
    try:
        json.loads(meta.attrs.get("provenance", ""))
    except (TypeError, ValueError):
        problems.append("provenance is not JSON")
    if schema_path == FIT_SCHEMA_PATH and "study_warnings" in meta.attrs:
        try:
            warnings = json.loads(meta.attrs["study_warnings"])
        except (TypeError, ValueError):
            warnings = None
        if not (isinstance(warnings, list) and all(isinstance(w, str) for w in warnings)):
            problems.append("study_warnings is not a JSON list of strings")
    for name, var in meta.variables.items():
        if var.type_name.startswith("unsupported"):
            problems.append(f"{name} has a type study never writes ({var.type_name})")
    problems += _checksum_problems(nc, meta)
    return problems


# ---------------------------------------------------------------------------
# The entry points


def validate_file(path: str | Path) -> str:
    """Check a result file of any kind, reading its data in bounded slabs.

    Studies (``study-result-v1``): the header against
    ``results_schema/study-result-v1.schema.json``; the embedded spec parses and
    its hash, name and title are the file's; ``study_fingerprint`` follows from
    the file's spec and code hashes; every variable the spec's observables
    declare (:mod:`study.engine.variables`) is present with the declared dimensions,
    dtype, units, long_name and flags, every flag value is declared, and
    ``velocity``-like variables are NaN exactly where their status is invalid
    and 0 where static; coordinates and fixed parameters equal the spec's; the
    ``provenance`` attribute has the structure of
    ``study-provenance-v1.schema.json``; the content checksum matches.

    Scenes (``study-scene-v1``): the header against the scene schema; the
    embedded spec parses and its hash, name, title, kind and the attributes
    repeated from it are the file's; the fingerprint, the provenance's
    structure, units on every float variable, flag values within their
    ``flag_values``; the content checksum matches.

    Returns
    -------
    str
        What the file is: "study result", "steering scene result" or "fit result".

    Raises
    ------
    ResultError
        Naming the file and listing every problem found.
    """
    path = Path(path)
    nc = _open(path)
    try:
        meta = _metadata(nc, path)
        attrs = meta.attrs
        kind = attrs.get("study_result_schema")
        if kind is None:
            raise ResultError(
                f"{path}: not a study result file (no 'study_result_schema' attribute; "
                f"global attributes: {_short(', '.join(sorted(attrs)) or 'none')})")
        if not any(_same_text(kind, k) for k in (RESULT_SCHEMA, SCENE_SCHEMA, FIT_SCHEMA,
                                                 DESIGN_SCHEMA)):
            raise ResultError(
                f"{path}: written with result schema {_short(repr(_jsonable(kind)), 80)}; "
                f"this version of study reads {RESULT_SCHEMA!r}, {SCENE_SCHEMA!r}, "
                f"{FIT_SCHEMA!r} and {DESIGN_SCHEMA!r}. Rerun "
                "its study to rewrite it.")
        if meta.groups:
            problems = [f"groups {', '.join(meta.groups)}: study writes no groups"]
        elif kind == RESULT_SCHEMA:
            problems = _study_problems(nc, meta, str(path))
        elif kind == FIT_SCHEMA:
            problems = _fit_problems(nc, meta)
        elif kind == DESIGN_SCHEMA:
            problems = _fit_problems(nc, meta, DESIGN_SCHEMA_PATH)
        else:
            problems = _scene_problems(nc, meta, str(path))
    finally:
        nc.close()
    what = {RESULT_SCHEMA: "study result", FIT_SCHEMA: "fit result",
            DESIGN_SCHEMA: "design result"}.get(kind, "steering scene result")
    if problems:
        problems = list(dict.fromkeys(problems))  # two schema branches may see one fault
        raise ResultError(f"{path}: invalid {what}:\n  " + "\n  ".join(problems))
    return what


def open_result(path: str | Path) -> xr.Dataset:
    """Validate a result file, then return it loaded into memory (the file is closed).

    Every kind of result opens here: a study, a scene, a fit or a design file.
    Validation checks the file against its schema, its checksum and its spec before a
    value is read, as ``study validate`` does.

    Parameters
    ----------
    path : str or pathlib.Path
        A result file (netCDF) written by ``study run``, ``study fit``, ``study design``
        or :func:`study.run`.

    Returns
    -------
    xarray.Dataset
        The file's variables with their ``units``, ``long_name`` and CF flag attributes
        (``status`` holds :class:`study.Status` codes, named by ``flag_meanings``), its
        coordinates and global attributes (``study_coupling`` names the coupling),
        loaded into memory: no file handle stays open, nothing needs closing. For a
        file larger than memory use ``xarray.open_dataset(path, chunks={})`` in a
        ``with`` block instead.

    Raises
    ------
    ResultError
        For a missing, truncated, foreign, outdated or inconsistent file; the message
        starts with the file's path.
    """
    path = Path(path)
    validate_file(path)
    try:
        with xr.open_dataset(path, engine="netcdf4", mask_and_scale=True) as dataset:
            return dataset.load()
    except Exception as err:  # netCDF4 raises OSError, RuntimeError, ValueError...
        raise _unreadable(path, err) from None


# ---------------------------------------------------------------------------
# Reading for people


def _format(value: Any) -> str:
    """A number as ``%.6g``, anything else as text."""
    if _is_number(value):
        return f"{float(value):.6g}"
    return str(value)


def _flag_counts(variable: xr.DataArray) -> str:
    """``name share (count)`` of every value a flag variable holds, read in slabs."""
    counts: dict[Any, int] = {}
    for index in _slabs(tuple(variable.shape), variable.dtype.itemsize):
        values = np.asarray(variable[index[0] if index == (Ellipsis,) else index].values)
        for value, count in zip(*np.unique(values, return_counts=True), strict=True):
            counts[value.item()] = counts.get(value.item(), 0) + int(count)
    names: dict[Any, str] = {}
    try:
        codes = np.atleast_1d(np.asarray(variable.attrs.get("flag_values"))).tolist()
        meanings = str(variable.attrs.get("flag_meanings", "")).split()
        names = dict(zip(codes, meanings, strict=False))
    except (TypeError, ValueError):
        names = {}
    total = sum(counts.values()) or 1
    return ", ".join(f"{names.get(value, f'value {value}')} {count / total:.1%} ({count})"
                     for value, count in sorted(counts.items()))


def _provenance_of(attrs: dict[str, Any]) -> dict[str, Any]:
    try:
        document = json.loads(str(attrs.get("provenance", "{}")))
    except (ValueError, RecursionError):
        return {}
    return document if isinstance(document, dict) else {}


def _section(document: dict[str, Any], key: str) -> dict[str, Any]:
    value = document.get(key)
    return value if isinstance(value, dict) else {}


def _describe_dataset(dataset: xr.Dataset, path: str) -> str:
    attrs = dataset.attrs
    provenance = _provenance_of(attrs)
    run = _section(provenance, "run")
    package = _section(provenance, "package")
    lines = [f"{path or attrs.get('study_name')}: {attrs.get('title')}"]
    kind = attrs.get("study_scene_kind") if isinstance(attrs.get("study_scene_kind"), str) else ""
    # A fit or a design result is named by its own spec, not by a study's.
    what, name = next(((label, attrs[key]) for label, key in
                       (("fit", "study_fit_name"), ("design", "study_design_name"))
                       if key in attrs), ("scene" if kind else "study", attrs.get("study_name")))
    coupling = attrs.get("study_coupling")
    lines.append(f"  {what} {name!r}"
                 f"{f' ({kind})' if kind else ''}"
                 f"{f', {coupling} coupling' if isinstance(coupling, str) else ''}, spec sha256 "
                 f"{str(attrs.get('study_spec_sha256', ''))[:16]}, schema "
                 f"{attrs.get('study_result_schema')}")
    try:
        warnings = json.loads(str(attrs.get("study_warnings", "[]")))
    except ValueError:
        warnings = []
    lines += [f"  warning: {w}" for w in (warnings if isinstance(warnings, list) else [])]
    for name, size in dataset.sizes.items():
        if name not in dataset.coords:
            lines.append(f"  dim {name!s:>7}: {size:6d}")
            continue
        coord = dataset[name]
        if coord.dtype.kind not in "iuf" or size == 0:
            shown = ", ".join(_format(v) for v in coord.values[:12])
            lines.append(f"  axis {name!s:>6}: {shown}{', ...' if size > 12 else ''}")
            continue
        lines.append(
            f"  axis {name!s:>6}: {size:6d} values, {_format(coord.values.min())} .. "
            f"{_format(coord.values.max())} {coord.attrs.get('units', '')}")
    for name, coord in dataset.coords.items():
        if coord.ndim == 1 and name not in dataset.dims:
            shown = ", ".join(_format(v) for v in coord.values[:12])
            lines.append(f"  {name} along {coord.dims[0]}: {shown}"
                         f"{', ...' if coord.size > 12 else ''} {coord.attrs.get('units', '')}")
    fixed = [f"{name}={_format(dataset[name].values.item())}" for name in dataset.coords
             if dataset[name].ndim == 0]
    if fixed:
        lines.append("  fixed: " + ", ".join(fixed))
    for name, var in dataset.data_vars.items():
        # Values in each parameter's own units name the variable that holds them.
        units = var.attrs.get("units", "")
        if "units" not in var.attrs and "units_variable" in var.attrs:
            units = f"in {var.attrs['units_variable']}"
        lines.append(f"  {name} {var.dims} [{units}]: "
                     f"{var.attrs.get('long_name', '')}")
    for name, var in dataset.variables.items():
        if "flag_meanings" in var.attrs and var.dtype.kind in "iu" and var.size:
            lines.append(f"  {name}: {_flag_counts(var)}")
    made = [f"  made by study {package.get('version')}"]
    if "git_commit" in package:
        made.append(f" (git {str(package.get('git_commit'))[:12]}"
                    f"{', dirty' if package.get('git_dirty') is True else ''})")
    host = run.get("host") or _section(provenance, "environment").get("host")
    if host:
        made.append(f" on {host}")
    made.append(f", {run.get('started_utc')} .. {run.get('finished_utc')}")
    wall = run.get("wall_seconds")
    details = [f"{wall:.2f} s" if _is_number(wall) else f"{wall} s"]
    if "scheduler" in run:
        details.append(f"scheduler {run.get('scheduler')}, {run.get('workers')} workers")
    if "points" in run:
        details.append(f"{run.get('points')} points: {run.get('points_computed')} computed, "
                       f"{run.get('points_reused')} reused")
    elif "chunks" in run:
        details.append(f"{run.get('chunks')} chunks: {run.get('chunks_computed')} computed, "
                       f"{run.get('chunks_reused')} reused")
    lines.append("".join(made) + f" ({'; '.join(details)})")
    for line in str(attrs.get("history", "")).splitlines():
        lines.append(f"  history: {line}")
    return "\n".join(lines)


def describe(path_or_dataset: str | Path | xr.Dataset, path: str = "") -> str:
    """A readable summary of a result of any kind: what was swept, what is inside
    (with the counts of every flag value), where it came from.

    Parameters
    ----------
    path_or_dataset : path or xarray.Dataset
        A (validated) result file, read lazily and in slabs, or a dataset.
    path : str
        Name to show (default: the file's path, or the study name).
    """
    if isinstance(path_or_dataset, xr.Dataset):
        return _describe_dataset(path_or_dataset, path)
    source = Path(path_or_dataset)
    try:
        with xr.open_dataset(source, engine="netcdf4") as dataset:
            return _describe_dataset(dataset, path or str(source))
    except (OSError, RuntimeError) as err:
        raise _unreadable(source, err) from None
