"""Which format a result file was written in, and whether this version reads it.

Every kind declares the formats its files were ever written in
(:class:`study.engine.kinds.ResultFormat`, in ``ResultKind.formats``). A file records
its format in a global attribute (``ResultKind.format_attribute``:
``study_result_format`` for studies, ``study_scene_format``, ``study_fit_format``,
``study_design_format``; a file without it is its kind's first format). This module
answers, from the attributes alone:

- :func:`written_format`: the format of a file, or a one-line refusal for a format this
  version does not know (newer than this version: upgrade ``study``; or not a format
  at all);
- :func:`format_note`: one line for people when the file's format is older than the one
  this version writes (what it lacks, and ``study upgrade`` to rewrite it);
- :func:`schema_path`: the header schema of a format (``results_schema/``).

The promise (``docs/user-guide/result-files.md``): every later version reads every file
an earlier release wrote, by the rules of the format it was written in; the golden
corpus in ``tests/golden/`` holds files of every kind from each release and is read at
every change.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from study.engine.kinds import ResultFormat, ResultKind, kind_of_schema
from study.engine.spec_files import SCHEMA_DIR
from study.engine.validation.reading import ResultError
from study.version import DISTRIBUTION, VERSION

__all__ = ["UPGRADE_ADVICE", "file_format_note", "format_note", "newer_release_advice",
           "schema_path", "written_by", "written_format"]

#: What to do with a file this version cannot read because a later one wrote it.
UPGRADE_ADVICE = f"upgrade study (pip install --upgrade {DISTRIBUTION}) to read it"


def written_by(attrs: dict[str, Any]) -> str:
    """The version of study that wrote a file (``"?"`` if it does not say).

    Studies and scenes carry it as the attribute ``study_version`` (and in their
    provenance's ``package.version``); fits and designs in their provenance's
    ``package_version``.
    """
    version = attrs.get("study_version")
    if isinstance(version, str) and version:
        return version
    try:
        document = json.loads(str(attrs.get("provenance", "{}")))
    except (ValueError, RecursionError):
        return "?"
    if not isinstance(document, dict):
        return "?"
    package = document.get("package")
    found = (package.get("version") if isinstance(package, dict)
             else document.get("package_version"))
    return found if isinstance(found, str) and found else "?"


def _writer(attrs: dict[str, Any]) -> str:
    version = written_by(attrs)
    return f"study {version}" if version != "?" else "a study"


def newer_release_advice(attrs: dict[str, Any]) -> str:
    """``written by study X; this is study Y: upgrade ...`` for a file of a later
    version (its kind or format unknown here)."""
    return f"written by {_writer(attrs)}; this is study {VERSION}: {UPGRADE_ADVICE}"


def written_format(kind: ResultKind, attrs: dict[str, Any], path: Path) -> ResultFormat:
    """The declared format a file of ``kind`` was written in.

    Raises
    ------
    ResultError
        One line naming the file, the version that wrote it and this one: for a format
        newer than this version knows (upgrade ``study``), or a value that is no format.
    """
    attribute = kind.format_attribute
    value = attrs.get(attribute, kind.formats[0].number)
    numbers = f"{kind.formats[0].number}-{kind.current_format.number}"
    if isinstance(value, bool) or not _is_integral(value):
        raise ResultError(f"{path}: {attribute} {value!r} is not a format number; "
                          f"this study {VERSION} reads {kind.label} formats {numbers}")
    number = int(value)
    if number > kind.current_format.number:
        raise ResultError(
            f"{path}: {kind.label} format {number}, {newer_release_advice(attrs)} "
            f"(this version reads formats {numbers})")
    found = kind.format_numbered(number)
    if found is None:
        raise ResultError(f"{path}: {kind.label} format {number} was never written by "
                          f"study; this study {VERSION} reads formats {numbers}")
    return found


def _is_integral(value: Any) -> bool:
    try:
        return float(value) == int(value)
    except (TypeError, ValueError, OverflowError):
        return False


def format_note(kind: ResultKind, attrs: dict[str, Any], path: str | Path) -> str:
    """One line for people about a file of an older format; ``""`` for a current one.

    Says the version and format it came from, what the formats since changed, and how
    to rewrite it in today's format without recomputing it.
    """
    try:
        written = written_format(kind, attrs, Path(path))
    except ResultError:
        return ""
    current = kind.current_format
    if written.number == current.number:
        return ""
    since = "; ".join(f.changes for f in kind.formats if f.number > written.number)
    return (f"note: {path} is {kind.label} format {written.number} from {_writer(attrs)}, "
            f"read as written; format {current.number} of this study {VERSION} adds "
            f"{since}; `study upgrade {path} -o NEW.nc` rewrites it without recomputing")


def file_format_note(path: str | Path) -> str:
    """:func:`format_note` of a result file (reads its attributes only); ``""`` for a
    current file, or one that is not a result (validation says what is wrong)."""
    from study.engine.validation.reading import read_attributes

    try:
        attrs = read_attributes(path)
    except ResultError:
        return ""
    schema = attrs.get("study_result_schema")
    kind = kind_of_schema(schema) if isinstance(schema, str) else None
    return format_note(kind, attrs, path) if kind is not None else ""


def schema_path(result_format: ResultFormat) -> Path:
    """The JSON schema of the header of files of ``result_format``."""
    return SCHEMA_DIR / f"{result_format.schema}.schema.json"
