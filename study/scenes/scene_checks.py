"""The scene kind's own checks of its result files (:func:`scene_problems`, registered as
its validator in :mod:`study.scenes.scene_kind`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from study.engine.kinds import ResultFormat
from study.engine.validation.checks import (
    Checker,
    checksum_problems,
    fingerprint_problems,
    flag_problems,
    identity_problems,
    is_number,
    not_required_checksum,
    parse_embedded,
    provenance_problems,
    provenance_spec_problems,
    same_number,
    same_text,
    shown_format,
    size_problems,
)
from study.engine.validation.header import (
    SCENE_SCHEMA,
    SCENE_SCHEMA_PATH,
    file_header,
    schema_problems,
)
from study.engine.validation.reading import StoredFile
from study.scenes.scene_kind import SCENE_FORMAT, disk_method_attributes
from study.scenes.scene_spec import parse_scene

__all__ = ["scene_problems"]

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


def scene_problems(nc: Any, meta: StoredFile, source: str,
                   written: ResultFormat) -> list[str]:
    attrs = meta.attrs
    written = attrs.get("study_scene_format", 1)
    if not (is_number(written) and written == SCENE_FORMAT):
        # Its numbers would be misread (format 1 stored angles in rad, format 2 the heading
        # drift in rad per diameter): refuse it whole.
        held = _STALE_SCENE_FORMATS.get(written if is_number(written) else None,
                                        "an unknown layout")
        return [f"scene format {shown_format(written)} ({held}) is stale: this study reads format "
                f"{SCENE_FORMAT} (every angle in degree, the heading drift in degree per "
                "diameter, spec key heading_drift_deg); rerun its spec"]
    problems = [p for p in schema_problems(SCENE_SCHEMA_PATH, file_header(meta))
                if not_required_checksum(p)]
    problems += fingerprint_problems(attrs)
    problems += provenance_problems(attrs, SCENE_SCHEMA)
    too_large = size_problems(meta)
    if too_large:  # reading the values would be pointless, and could take hours
        return problems + too_large
    spec, spec_problems = parse_embedded(attrs, source, parse_scene)
    problems += spec_problems
    if spec is not None:
        problems += identity_problems(attrs, spec)
        problems += provenance_spec_problems(attrs, spec, "scene")
        if not same_text(attrs.get("study_scene_kind"), spec.kind):
            problems.append("study_scene_kind does not match the embedded spec")
        for key, value in _scene_attribute_values(spec).items():
            if value is not None and not same_number(attrs.get(key), value):
                problems.append(f"{key} differs from the embedded spec ({value!r})")
        # The contact laws (issue 33): optional (files written before lack them), so
        # compared only where present.
        for key, value in disk_method_attributes(spec.disk).items():
            if key in attrs and not (same_text(attrs[key], value) if isinstance(value, str)
                                     else same_number(attrs[key], value)):
                problems.append(f"{key} differs from the embedded spec ({value!r})")
    for key in ("study_end_time",):
        if key in attrs and not (is_number(attrs[key]) and math.isfinite(attrs[key])):
            problems.append(f"{key} must be a finite number")
    for key in ("study_steps", "study_slips"):
        if key in attrs and not (isinstance(attrs[key], int | np.integer) and attrs[key] >= 0):
            problems.append(f"{key} must be an integer >= 0")
    if "study_outcome" in attrs and not isinstance(attrs["study_outcome"], str):
        problems.append("study_outcome must be text")
    check = Checker(nc, meta)
    for name, var in meta.variables.items():
        if var.type_name.startswith("unsupported"):
            problems.append(f"{name} has a type study never writes ({var.type_name})")
            continue
        if var.dtype is not None and var.dtype.kind == "f" and "units" not in var.attrs:
            problems.append(f"{name} has no units")
        if "flag_values" in var.attrs or "flag_meanings" in var.attrs:
            flag_found, codes = flag_problems(name, var)
            problems += flag_found
            if codes is not None:
                if var.dtype is None or var.dtype.kind not in "iu":
                    problems.append(f"{name}: a flag variable must hold integers")
                else:
                    problems += check.flags_in_range(name, codes)
    problems += checksum_problems(nc, meta)
    return problems
