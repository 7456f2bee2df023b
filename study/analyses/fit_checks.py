"""The fit and design kinds' own checks of their result files (:func:`fit_problems`,
:func:`design_problems`, registered as their validators in :mod:`study.analyses.fit` and
:mod:`study.analyses.design`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from study.analyses.design import DESIGN_FORMAT
from study.analyses.fit import FIT_FORMAT
from study.engine.kinds import ResultFormat
from study.engine.validation.checks import (
    checksum_problems,
    is_number,
    not_required_checksum,
    shown_format,
)
from study.engine.validation.header import (
    DESIGN_SCHEMA_PATH,
    FIT_SCHEMA_PATH,
    file_header,
    schema_problems,
)
from study.engine.validation.reading import StoredFile

__all__ = ["design_problems", "fit_problems"]

#: What the stale fit and design formats held, for the message refusing them.
_STALE_FIT_FORMATS = {1: "units spelled deg, not degree"}


def _stale_fit_problems(meta: StoredFile, design: bool) -> list[str]:
    """A fit or design file of an older format: refused whole, as scenes are."""
    current = DESIGN_FORMAT if design else FIT_FORMAT
    what = "design" if design else "fit"
    written = meta.attrs.get(f"study_{what}_format", 1)
    if is_number(written) and written == current:
        return []
    held = _STALE_FIT_FORMATS.get(written if is_number(written) else None, "an unknown layout")
    return [f"{what} format {shown_format(written)} ({held}) is stale: this study reads "
            f"format {current} (every unit in CF/UDUNITS spelling, angles in degree); "
            f"rerun its spec with `study {what}`"]


def _problems(nc: Any, meta: StoredFile, schema_path: Path) -> list[str]:
    """A fit result: its header against ``study-fit-v1``, sizes that agree, the checksum
    (a design result the same way, against ``study-design-v1``)."""
    stale = _stale_fit_problems(meta, design=schema_path != FIT_SCHEMA_PATH)
    if stale:
        return stale
    problems = [p for p in schema_problems(schema_path, file_header(meta))
                if not_required_checksum(p)]
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
    problems += checksum_problems(nc, meta)
    return problems


def fit_problems(nc: Any, meta: StoredFile, source: str,
                 written: ResultFormat) -> list[str]:
    """A fit result: its header against ``study-fit-v1``, sizes that agree, the checksum."""
    return _problems(nc, meta, FIT_SCHEMA_PATH)


def design_problems(nc: Any, meta: StoredFile, source: str,
                    written: ResultFormat) -> list[str]:
    """A design result: its header against ``study-design-v1``, the checksum."""
    return _problems(nc, meta, DESIGN_SCHEMA_PATH)
