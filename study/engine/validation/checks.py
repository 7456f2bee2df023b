"""Checks of result files that every kind shares: the fingerprint, the provenance, flag
variables, sizes, the checksum and the embedded spec. Each kind's own checks live with
the kind and are found through :mod:`study.engine.kinds` (its ``validator``)."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from study.engine.provenance import fingerprint
from study.engine.spec_files import SpecError
from study.engine.validation.checksums import CONTENT_ATTRIBUTE, content_digest
from study.engine.validation.header import PROVENANCE_SCHEMA_PATH, schema_problems, short
from study.engine.validation.reading import (
    MAX_EXPANSION,
    MIN_DATA_BYTES,
    StoredFile,
    StoredVariable,
    read_slab,
    slabs,
)
from study.model.status import INVALID_STATUSES, Status

__all__ = ["HEX64", "Checker", "checksum_problems", "fingerprint_problems", "flag_problems",
           "identity_problems", "is_number", "not_required_checksum", "parse_embedded",
           "provenance_problems", "provenance_spec_problems", "same_number", "same_text",
           "shown_format", "size_problems"]

HEX64 = re.compile(r"[0-9a-f]{64}")


def is_number(value: Any) -> bool:
    return (isinstance(value, int | float | np.integer | np.floating)
            and not isinstance(value, bool | np.bool_))


def same_text(value: Any, expected: str) -> bool:
    # Attributes may be arrays or numbers: never compare them elementwise.
    return isinstance(value, str) and value == expected


def same_number(value: Any, expected: float) -> bool:
    return is_number(value) and float(value) == float(expected)


def fingerprint_problems(attrs: dict[str, Any]) -> list[str]:
    """``study_fingerprint`` must be what the file's own spec and code hashes give.

    The definition is :func:`study.engine.provenance.fingerprint`'s, applied to the code
    hash recorded in the file (not the running code's): an old but honest file is
    valid, only stale.
    """
    value = attrs.get("study_fingerprint")
    spec_sha = attrs.get("study_spec_sha256")
    code_sha = attrs.get("study_code_sha256")
    if not isinstance(value, str) or not HEX64.fullmatch(value):
        return []  # the schema reports a missing or malformed fingerprint
    if not isinstance(spec_sha, str) or not isinstance(code_sha, str):
        return []
    if value != fingerprint(spec_sha, code_sha):
        return ["study_fingerprint does not match study_spec_sha256 and study_code_sha256"]
    return []


def provenance_problems(attrs: dict[str, Any], kind: str) -> list[str]:
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
    problems = schema_problems(PROVENANCE_SCHEMA_PATH, document, "provenance")
    if problems:
        return problems
    code, run = document["code"], document["run"]
    for key, attr in (("code_sha256", "study_code_sha256"), ("fingerprint", "study_fingerprint")):
        if not same_text(attrs.get(attr), code[key]):
            problems.append(f"provenance: code.{key} differs from the attribute {attr}")
    if document["result_schema"] != kind:
        problems.append(f"provenance: result_schema {document['result_schema']!r} differs "
                        f"from the file's {kind!r}")
    if not same_text(attrs.get("study_version"), document["package"]["version"]):
        problems.append("provenance: package.version differs from the attribute study_version")
    wall = run["wall_seconds"]
    if isinstance(wall, float) and not math.isfinite(wall):  # JSON allows NaN, Infinity
        problems.append("provenance: run.wall_seconds is not finite")
    if _finished_before_started(run):
        problems.append("provenance: run.finished_utc is before run.started_utc")
    # A run that counts points (a study of the incremental runner) says how many were
    # computed and reused; files of the first runner have chunk counts instead.
    if "points" in run:
        if run["points_computed"] + run["points_reused"] != run["points"]:
            problems.append("provenance: run.points_computed + run.points_reused != run.points")
    return problems


def _finished_before_started(run: dict[str, Any]) -> bool:
    """Whether ``run`` ends before it starts (both ISO 8601 UTC times, as written)."""
    return str(run["finished_utc"]) < str(run["started_utc"])


def flag_problems(name: str, var: StoredVariable) -> tuple[list[str], np.ndarray | None]:
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


class Checker:
    """Value checks of one file, each reading its variables in slabs."""

    def __init__(self, nc: Any, meta: StoredFile) -> None:
        self.nc = nc
        self.meta = meta

    def slabs(self, *names: str) -> Iterator[tuple[np.ndarray, ...]]:
        """Equal slabs of variables of one shape."""
        variables = [self.meta.variables[n] for n in names]
        itemsize = max(64 if v.dtype is None else v.dtype.itemsize for v in variables)
        for index in slabs(variables[0].shape, itemsize):
            yield tuple(read_slab(self.nc.variables[n], index, self.meta.path) for n in names)

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

    def invalid_where(self, name: str, status: str, zero_when_static: bool = True,
                      missing_where: tuple[str, ...] = ()) -> list[str]:
        mismatched = not_zero = 0
        missing = (*INVALID_STATUSES, *(Status[flag.upper()] for flag in missing_where))
        invalid = [int(s) for s in missing]
        for values, codes in self.slabs(name, status):
            mismatched += int(np.count_nonzero(np.isnan(values) != np.isin(codes, invalid)))
            if zero_when_static:
                not_zero += int(np.count_nonzero((codes == Status.STATIC) & ~(values == 0.0)))
        problems = []
        if mismatched:
            names = ", ".join(s.flag for s in missing)
            problems.append(
                f"{name} must be NaN exactly where {status} is one of {names}; "
                f"{mismatched} points disagree")
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


def size_problems(meta: StoredFile) -> list[str]:
    total = sum(var.nbytes for var in meta.variables.values())
    limit = max(MIN_DATA_BYTES, MAX_EXPANSION * meta.path.stat().st_size)
    if total > limit:
        return [f"the variables declare {total} bytes of data in a file of "
                f"{meta.path.stat().st_size} bytes: the file's structure is damaged"]
    return []


def checksum_problems(nc: Any, meta: StoredFile) -> list[str]:
    recorded = meta.attrs.get(CONTENT_ATTRIBUTE)
    if recorded is None:
        return [f"no content checksum (global attribute {CONTENT_ATTRIBUTE!r}): written by "
                "an older version of study, its data cannot be verified; rerun its study "
                "(study run SPEC) to rewrite it"]
    if not isinstance(recorded, str) or not HEX64.fullmatch(recorded):
        return []  # the schema reports the malformed value
    if content_digest(nc, meta) != recorded:
        return [f"the content differs from the checksum recorded when the file was written "
                f"({CONTENT_ATTRIBUTE}): its data, dimensions or variable attributes changed"]
    return []


def not_required_checksum(problem: str) -> bool:
    # A missing checksum gets its own message (with what to do about it).
    return not (CONTENT_ATTRIBUTE in problem and "required property" in problem)


def parse_embedded(attrs: dict[str, Any], source: str,
                    parse: Callable[[str, str], Any]) -> tuple[Any, list[str]]:
    text = attrs.get("study_spec")
    if not isinstance(text, str):
        return None, []  # the schema reports it
    try:
        return parse(text, f"{source} (embedded spec)"), []
    except SpecError as err:
        return None, [f"embedded spec does not parse: {short(str(err), 400)}"]
    except Exception as err:  # the spec is untrusted input: never crash on it
        return None, [f"embedded spec cannot be read ({type(err).__name__}: "
                      f"{short(str(err))})"]


def provenance_spec_problems(attrs: dict[str, Any], spec: Any, section: str) -> list[str]:
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


def identity_problems(attrs: dict[str, Any], spec: Any) -> list[str]:
    problems = []
    if not same_text(attrs.get("study_spec_sha256"), spec.sha256):
        problems.append("study_spec_sha256 does not match the embedded spec")
    if not same_text(attrs.get("study_name"), spec.name):
        problems.append("study_name differs from the embedded spec's name")
    if not same_text(attrs.get("title"), spec.title):
        problems.append("title differs from the embedded spec's title")
    return problems


def shown_format(value: Any) -> str:
    """A format attribute as a person reads it (2, not np.int64(2))."""
    if is_number(value) and math.isfinite(float(value)) and float(value).is_integer():
        return str(int(value))
    return repr(value)
