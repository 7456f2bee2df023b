"""The study spec's JSON schema, generated from the declarations (parameters,
observables, contact laws, starts): :func:`spec_schema` and what ``make schemas`` writes
(:func:`export_spec_schema`)."""

from __future__ import annotations

from typing import Any

from study.engine.spec_files import (
    load_schema,
)
from study.model import starts
from study.model.contact import (
    DEFAULT_FRICTION,
    DEFAULT_LIFT_OFF,
    LAWS,
)
from study.model.parameters import (
    DRIVE,
    MASS,
    STRUCTURE,
    schema_definition,
    schema_properties,
)
from study.solvers.basins import DROP_HEIGHT_RANGE, FACTOR_RANGE
from study.solvers.integrator import MAX_INTEGRATOR_BUDGET
from study.solvers.protocol import SWEEP_AXES
from study.solvers.settings import MAX_SOLVER_BUDGET
from study.studies.observables import (
    BASIN_KEYS,
    BasinSettings,
)
from study.studies.observables import OBSERVABLES as OBSERVABLE_REGISTRY
from study.studies.spec_types import (
    MAX_BASIN_SETTINGS,
    OBSERVABLES,
    PROTOCOL_DIRECTIONS,
    SPEC_SCHEMA,
    SWEEPABLE,
)

__all__ = [
    "export_spec_schema",
    "spec_schema",
]


def spec_schema() -> dict[str, Any]:
    """The JSON schema of study specs (``study/schemas/study-spec-v1.schema.json``).

    The parameters' ranges and descriptions come from :mod:`study.model.parameters`, the
    observables allowed and their descriptions from :mod:`study.studies.observables`,
    the solvers' budgets' maxima from :data:`study.solvers.settings.MAX_SOLVER_BUDGET` and
    :data:`study.solvers.integrator.MAX_INTEGRATOR_BUDGET` (the file on disk is their
    export, see :func:`export_spec_schema`).
    """
    schema = load_schema(SPEC_SCHEMA)
    schema["$defs"]["parameter"] = {name: schema_definition(name) for name in SWEEPABLE}
    structure = schema["properties"]["structure"]
    mass = structure["properties"]["mass"]
    mass["properties"] = {**schema_properties(name for name in MASS if name != "m_add"),
                          "m_add": {"$ref": "#/$defs/parameter/m_add"}}
    structure["properties"] = {
        **{name: {"$ref": f"#/$defs/parameter/{name}"} for name in STRUCTURE}, "mass": mass}
    schema["properties"]["sweep"]["properties"] = {
        **{name: {"$ref": "#/$defs/axis"} for name in (*DRIVE, *STRUCTURE, "m_add")},
        "protocol": {
            "type": "object",
            "additionalProperties": False,
            "required": ["along"],
            "properties": {
                "along": {"enum": list(SWEEP_AXES), "description": "the drive axis stepped"},
                "direction": {"enum": list(PROTOCOL_DIRECTIONS), "default": "up",
                              "description": "up: increasing values; down: decreasing"},
            },
            "description": (
                "exact solver, two-way coupling: a slow sweep (docs/theory/starts.md): "
                "along the axis the drive steps to the next value at phase 0 with the "
                "state carried, one run for each value of the other drive axis, the "
                "first point of a run started by [solver] start; absent: every point "
                "from its start"),
        },
    }
    listed = schema["properties"]["study"]["properties"]["observables"]
    listed["description"] = ("a non-empty list of distinct names from: "
                             + ", ".join(OBSERVABLES))
    items = listed["items"]
    items["enum"] = list(OBSERVABLES)
    items["description"] = "; ".join(
        f"{name}: {o.summary}" for name, o in OBSERVABLE_REGISTRY.items())
    solver = schema["properties"]["solver"]["properties"]
    for name, largest in {**MAX_SOLVER_BUDGET, **MAX_INTEGRATOR_BUDGET}.items():
        solver[name]["maximum"] = largest
    solver["friction"] = _friction_schema()
    solver["flight"] = _flight_schema()
    solver["continuation"] = {
        "type": "boolean",
        "default": False,
        "description": (
            "exact solver, two-way coupling: true: each orbit's Newton search starts from "
            "the fixed points of the points before it along its line of the sweep (2-4x "
            "faster on fine maps; where several motions are stable it follows its "
            "neighbours' branch, as a slowly swept drive, and a point's value depends on "
            "its grid); false (default): every point from rest"),
    }
    solver["start"] = _start_schema()
    schema["properties"]["basins"] = _basins_schema()
    return schema


def _basins_schema() -> dict[str, Any]:
    """``[basins]``: the basins observable's sampling (:class:`BasinSettings`)."""
    defaults = BasinSettings()
    lowest = {"starts": 1, "seed": 0, "max_attractors": 1, "sweep_steps": 0}
    words = {
        "starts": "starts followed at each drive point: the solver's start ([solver] "
                  "start), then seeded draws (the base at rest at a drive phase drawn "
                  "uniformly, the mode at rest on a multiple of its steady response drawn "
                  f"from [{FACTOR_RANGE[0]:g}, {FACTOR_RANGE[1]:g}); with flight every third "
                  "draw dropped from a height drawn log-uniformly from "
                  f"{1e3 * DROP_HEIGHT_RANGE[0]:g} to {1e3 * DROP_HEIGHT_RANGE[1]:g} mm)",
        "seed": "seed of the draws: the same starts at every point and on every machine",
        "max_attractors": "attractor slots per point (the attractor dimension): a point "
                          "with more attractors keeps the first ones its starts reach "
                          "(attractor_count stays exact)",
        "sweep_steps": "steps of the slow sweep down along f, from 1.5 times each point's "
                       "frequency (the release there) to the point, whose end state is "
                       "followed as one more start: it reaches the motions born at faster "
                       "drives that no drawn start reaches, counted among the attractors "
                       "but not in the fractions (shares of the drawn starts); 0: none",
    }
    return {
        "type": "object",
        "additionalProperties": False,
        "properties": {
            key: {"type": "integer", "minimum": lowest[key],
                  "maximum": MAX_BASIN_SETTINGS[key], "default": getattr(defaults, key),
                  "description": f"{words[key]} (default {getattr(defaults, key)})"}
            for key in BASIN_KEYS},
        "description": (
            "only with the observable basins (exact solver, two-way coupling): how each "
            "drive point is sampled; absent: the defaults"),
    }


def _start_schema() -> dict[str, Any]:
    """``[solver] start``: a named start or a start's table, from the declared kinds
    (:func:`study.model.starts.spec_schema`; :func:`study.model.starts.as_start` checks
    them, with the messages the API gives)."""
    return starts.spec_schema()


def _flight_schema() -> dict[str, Any]:
    """``[solver] flight`` from the lift-off laws' declarations
    (:data:`study.model.contact.LAWS`)."""
    law = LAWS["lift_off"]["flight"]
    stop = LAWS["lift_off"][DEFAULT_LIFT_OFF]
    return {
        "type": "boolean",
        "default": False,
        "description": (
            f"true: the lift-off law 'flight': {law.description} (methods: "
            f"{', '.join(law.solvers)}; needs coupling = \"two-way\" and M < 1); false "
            f"(default): '{stop.name}', {stop.description}"),
    }


def _friction_schema() -> dict[str, Any]:
    """``[solver] friction`` from the friction laws' declarations
    (:data:`study.model.contact.LAWS`): a law's name, or a table of the law and its
    parameters."""
    laws = LAWS["friction"]
    forms: list[dict[str, Any]] = [
        {"enum": [name for name, law in laws.items() if not law.parameters]}]
    for name, law in laws.items():
        if law.parameters:
            forms.append({
                "type": "object",
                "additionalProperties": False,
                "required": ["law", *(p.name for p in law.parameters)],
                "properties": {
                    "law": {"const": name},
                    **{p.name: {"type": "number", "exclusiveMinimum": p.lower,
                                "description": f"{p.long_name} [{p.units}]"}
                       for p in law.parameters},
                },
            })
    return {
        "default": DEFAULT_FRICTION,
        "oneOf": forms,
        "description": "friction law: " + "; ".join(
            f"{name}{' (default)' if name == DEFAULT_FRICTION else ''}: {law.description}"
            + (f" (solvers: {', '.join(law.solvers)}; give "
               f"{{ law = \"{name}\", {', '.join(p.name + ' = ...' for p in law.parameters)} }})"
               if law.parameters else "")
            for name, law in laws.items()),
    }


def export_spec_schema() -> str:
    """The spec schema as written to ``study/schemas`` (``make schemas``)."""
    import json

    return json.dumps(spec_schema(), indent=2) + "\n"
