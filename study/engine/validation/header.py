"""A result file's header (attributes, dimensions, variables) as JSON data, and the JSON
schemas it is checked against (``results_schema/``)."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

import xarray as xr

from study.engine.spec_files import SCHEMA_DIR
from study.engine.validation.reading import StoredFile, jsonable
from study.model import starts

__all__ = ["DESIGN_SCHEMA", "DESIGN_SCHEMA_PATH", "FIT_SCHEMA", "FIT_SCHEMA_PATH",
           "PROVENANCE_SCHEMA_PATH", "RESULT_SCHEMA", "RESULT_SCHEMA_PATH", "SCENE_SCHEMA",
           "SCENE_SCHEMA_PATH", "export_result_schema", "file_header", "header",
           "schema_problems", "short"]

#: Parameter studies (study.engine.runner).
RESULT_SCHEMA = "study-result-v1"
#: Steering scenes (study.scenes.scene_kind): trajectories, calibrations, plans.
SCENE_SCHEMA = "study-scene-v1"
RESULT_SCHEMA_PATH = SCHEMA_DIR / f"{RESULT_SCHEMA}.schema.json"
SCENE_SCHEMA_PATH = SCHEMA_DIR / f"{SCENE_SCHEMA}.schema.json"
#: Files written by ``study fit`` (:mod:`study.analyses.fit`).
FIT_SCHEMA = "study-fit-v1"
FIT_SCHEMA_PATH = SCHEMA_DIR / f"{FIT_SCHEMA}.schema.json"
#: Files written by ``study design`` (:mod:`study.analyses.design`).
DESIGN_SCHEMA = "study-design-v1"
DESIGN_SCHEMA_PATH = SCHEMA_DIR / f"{DESIGN_SCHEMA}.schema.json"
#: The structure every result's ``provenance`` attribute (a JSON document) has.
PROVENANCE_SCHEMA_PATH = SCHEMA_DIR / "study-provenance-v1.schema.json"


def export_result_schema(text: str | None = None) -> str:
    """The result schema as written to ``study/schemas`` (``make schemas``): the
    committed file (or ``text``) with the parts the declarations decide rewritten from
    them, the start attributes of :func:`study.model.starts.result_schema` (the kinds'
    enum, each parameter's attribute with its bounds, which go together, and which kind
    records which). The rest of the schema is written by hand."""
    schema = json.loads(RESULT_SCHEMA_PATH.read_text(encoding="utf-8") if text is None
                        else text)
    attrs = schema["properties"]["attrs"]
    declared = starts.result_schema()
    stale = [key for key in attrs["properties"] if key.startswith("study_start_")]
    # Rebuilt in place (the order of the other attributes kept): the kinds' enum first,
    # then the parameters, where the start attributes stood.
    properties = {}
    for key, value in attrs["properties"].items():
        if key == "study_start_kind":
            properties.update(declared["properties"])
        elif key not in stale:
            properties[key] = value
    attrs["properties"] = properties
    dependent: dict[str, Any] = {}
    for key, value in attrs.get("dependentRequired", {}).items():
        if key in stale:
            dependent.update(declared["dependentRequired"])
        else:
            dependent[key] = value
    attrs["dependentRequired"] = {**dependent, **declared["dependentRequired"]}
    others = [rule for rule in attrs.get("allOf", []) if not _is_start_rule(rule)]
    attrs["allOf"] = declared["allOf"] + others
    return json.dumps(schema, indent=2) + "\n"


def _is_start_rule(rule: dict[str, Any]) -> bool:
    """A rule of ``allOf`` that :func:`study.model.starts.result_schema` writes."""
    return "study_start_kind" in rule.get("if", {}).get("properties", {})


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
            "attrs": {k: jsonable(v) for k, v in var.attrs.items()},
        }
    return {
        "attrs": {k: jsonable(v) for k, v in dataset.attrs.items()},
        "dims": {str(k): int(v) for k, v in dataset.sizes.items()},
        "variables": variables,
    }


def file_header(meta: StoredFile) -> dict[str, Any]:
    """:func:`header` of a file read with netCDF4 (the stored attributes)."""
    return {
        "attrs": {k: jsonable(v) for k, v in meta.attrs.items()},
        "dims": dict(meta.dims),
        "variables": {
            name: {"dims": list(var.dims), "dtype": var.type_name,
                   "attrs": {k: jsonable(v) for k, v in var.attrs.items()}}
            for name, var in meta.variables.items()
        },
    }


@cache
def _validator(path: Path):
    import jsonschema

    return jsonschema.Draft202012Validator(json.loads(path.read_text()))


def schema_problems(schema_path: Path, document: Any, where: str = "") -> list[str]:
    errors = sorted(_validator(schema_path).iter_errors(document),
                    key=lambda e: [str(p) for p in e.absolute_path])
    problems = []
    for error in errors:
        location = "/".join(map(str, error.absolute_path))
        if where:
            location = f"{where}/{location}" if location else where
        problems.append(f"{location or 'file'}: {short(error.message)}")
    return problems


def short(text: str, limit: int = 200) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[:limit] + "..."
