"""The design kind: its registration (:mod:`study.engine.kinds`) and the layout of its result file.

A design searches structure parameters that achieve target behaviours at drive
commands with the largest margins (``study design``). Its pieces, one job each:

* :mod:`study.analyses.design_spec`: the spec (TOML), read and checked;
* :mod:`study.analyses.design_margins`: every target's motion and margins at one point;
* :mod:`study.analyses.design_search`: the max-min search and its report;
* this module: the result file (``study-design-v1``, :func:`design_dataset`) and the
  kind that ties them for the runner, validation and the CLI.

:func:`design` and :func:`parse_design_spec` are importable from here too, the way the
user guide calls them. The code fingerprint of a design (``study_code_sha256``) is the
import closure of this module, so it covers every piece.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import xarray as xr

from study.analyses.design_margins import FAILED
from study.analyses.design_search import DesignResult, design
from study.analyses.design_spec import (
    BEHAVIOURS,
    DESIGN_SPEC_SCHEMA,
    DesignSpec,
    load_design_spec,
    parse_design_spec,
)
from study.engine.contact_attributes import contact_law_attributes
from study.engine.kinds import ResultFormat, ResultKind, register
from study.model.status import Status
from study.model.units import (
    DEGREE_PER_SECOND,
    DIMENSIONLESS,
    HERTZ,
    METRE_PER_SECOND,
    METRE_PER_SECOND_SQUARED,
)

__all__ = [
    "DESIGN_FORMAT",
    "DESIGN_KIND",
    "DESIGN_RESULT_SCHEMA",
    "design",
    "design_dataset",
    "parse_design_spec",
]

DESIGN_RESULT_SCHEMA = "study-design-v1"
#: Layout of a design result (global attribute ``study_design_format``): 2 spells every
#: unit in CF/UDUNITS (``parameter_units`` of alpha and direction: ``degree``). Files
#: without it are format 1 (``deg``), refused as stale by validation.
DESIGN_FORMATS = (
    ResultFormat(1, "before 0.1.0", "units spelled deg", DESIGN_RESULT_SCHEMA),
    ResultFormat(2, "0.1.0", "every unit in CF/UDUNITS spelling (degree)", DESIGN_RESULT_SCHEMA),
)
#: The format this version writes.
DESIGN_FORMAT = DESIGN_FORMATS[-1].number


# ---------------------------------------------------------------------------
# The result file


def design_dataset(spec: DesignSpec, result: DesignResult, command: str = "") -> xr.Dataset:
    """The design as a self-describing dataset (the layout of ``study-design-v1``)."""
    from study.engine.fingerprint import code_fingerprint
    from study.engine.provenance import utc_now

    code = code_fingerprint(("study.analyses.design",)).sha256
    now = utc_now()
    variables = {**_parameter_variables(result), **_target_variables(spec, result),
                 **_summary_variables(spec, result)}
    designed = {k: v for k, v in result.params.items() if v is not None}
    attrs = {
        "Conventions": "CF-1.11",
        "title": spec.title,
        "study_result_schema": DESIGN_RESULT_SCHEMA,
        "study_design_format": DESIGN_FORMAT,
        "study_design_name": spec.name,
        "study_name": spec.name,
        "study_spec": spec.text,
        "study_spec_sha256": spec.sha256,
        "study_code_sha256": code,
        "study_model": spec.model,
        # The model's contact laws (issue 33): the spec's coupling, and the friction
        # and lift-off laws both models use unless told otherwise (Coulomb, stop at
        # lift-off: steady_velocity and the disk's planar model), which a design spec
        # cannot change.
        **contact_law_attributes(spec.coupling),
        "study_weights": json.dumps(spec.weights),
        "study_designed_structure": json.dumps(designed),
        "study_feasible": int(result.feasible),
        "study_failing_targets": json.dumps(result.failing),
        "study_report": result.message,
        "date_created": now,
        "history": f"{now}: {command or 'study.analyses.design'}",
        "provenance": json.dumps(_design_provenance(spec, result, code, now, command),
                                 default=str),
    }
    return xr.Dataset({k: xr.Variable(*v) for k, v in variables.items()},
                      coords={k: xr.Variable(*v) for k, v in _design_coords(spec, result).items()},
                      attrs=attrs)


def _design_provenance(spec: DesignSpec, result: DesignResult, code: str, now: str,
                       command: str) -> dict[str, Any]:
    """The run's provenance record: spec, code, environment and how the search went."""
    from study.engine.provenance import environment, git_state, package_version

    names = result.names
    return {
        "spec": spec.text, "spec_sha256": spec.sha256, "code_sha256": code,
        "package_version": package_version(), **git_state(),
        "environment": environment(), "end_time": now, "command": command,
        "optimizer": ("scan + scipy.optimize.minimize_scalar(method='bounded')"
                      if len(names) == 1 else
                      "scipy.optimize.differential_evolution + minimize(method='Nelder-Mead')"),
        "evaluations": result.evaluations, "wall_seconds": result.wall_seconds,
    }


def _design_coords(spec: DesignSpec, result: DesignResult) -> dict[str, tuple[Any, ...]]:
    """The free parameters' axis with their units, and the targets' axis."""
    names = result.names
    units = [spec.parameter(n).units for n in names]
    p, t = ("parameter",), ("target",)
    return {
        "parameter": (p, np.array(names, dtype=object), {"long_name": "free parameter"}),
        "parameter_units": (p, np.array(units, dtype=object),
                            {"long_name": "units of the parameter's values"}),
        "target": (t, np.array([x.label for x in spec.targets], dtype=object),
                   {"long_name": "target behaviour at a drive command"}),
    }


#: The per-parameter variables' note on units.
_PER_UNIT = {"units_variable": "parameter_units",
             "comment": "in each parameter's own units (parameter_units)"}


def _parameter_variables(result: DesignResult) -> dict[str, tuple[Any, ...]]:
    """The variables over the free parameters: the design, the bounds and the start."""
    p, per_unit = ("parameter",), _PER_UNIT
    return {
        "best": (p, result.best, {"long_name": "designed value", **per_unit}),
        "lower_bound": (p, result.lower, {"long_name": "lower bound of the search",
                                          **per_unit}),
        "upper_bound": (p, result.upper, {"long_name": "upper bound of the search",
                                          **per_unit}),
        "start": (p, result.start, {"long_name": "start value", **per_unit}),
    }


def _target_variables(spec: DesignSpec, result: DesignResult) -> dict[str, tuple[Any, ...]]:
    """The variables over the targets: the drive asked for, the motion and margins at
    the design, whether each is met and its best margin searched alone."""
    t, one, ev = ("target",), {"units": DIMENSIONLESS}, result.evaluation
    return {
        "f": (t, np.array([x.f for x in spec.targets]), {
            "long_name": "drive frequency", "units": HERTZ}),
        "a": (t, np.array([x.a for x in spec.targets]), {
            "long_name": "drive acceleration amplitude", "units": METRE_PER_SECOND_SQUARED}),
        "behaviour": (t, np.array([x.behaviour for x in spec.targets], dtype=object), {
            "long_name": "behaviour asked for (" + ", ".join(BEHAVIOURS) + ")"}),
        "forward_speed": (t, ev.forward_speed, {
            "long_name": "steady mean velocity (the disk's along its heading)",
            "units": METRE_PER_SECOND}),
        "lateral_speed": (t, ev.lateral_speed, {
            "long_name": "steady mean velocity to the left of the heading (disk)",
            "units": METRE_PER_SECOND}),
        "turn_rate": (t, np.degrees(ev.turn_rate), {
            "long_name": "steady mean angular velocity, counterclockwise positive (disk)",
            "units": DEGREE_PER_SECOND}),
        "solver_status": (t, np.array([Status(int(s)).name for s in ev.status],
                                      dtype=object), {"long_name": "solver status"}),
        "motion_threshold": (t, ev.threshold, {
            "long_name": "lowest drive at which the structure slips at f",
            "units": METRE_PER_SECOND_SQUARED}),
        "lift_off_acceleration": (t, ev.lift, {
            "long_name": "drive above which the normal force vanishes in the cycle",
            "units": METRE_PER_SECOND_SQUARED}),
        "edge_contact_margin": (t, ev.rim, {
            "long_name": "rim contact margin of the disk (NaN: single plate)", **one}),
        "speed_margin": (t, ev.speed_margin, {
            "long_name": "velocity in the target's direction over a/w", **one,
            "comment": f"turns: rim speed R spin; {FAILED:g}: no orbit; NaN: static target"}),
        "threshold_margin": (t, ev.threshold_margin, {
            "long_name": "(a - a*)/a above the motion threshold ((a* - a)/a for static)",
            **one}),
        "lift_margin": (t, ev.lift_margin, {
            "long_name": "(a_lift - a)/a below lift-off", **one}),
        "margin": (t, ev.margin, {
            "long_name": "the target's margin: the smallest weighted margin", **one}),
        "limiting_margin": (t, np.array(ev.limiting, dtype=object), {
            "long_name": "which margin is the target's (speed, threshold, lift)"}),
        "met": (t, ev.met.astype(np.int8), {
            "long_name": "whether the target is met at the design",
            "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "not_met met"}),
        "best_margin_alone": (t, result.alone, {
            "long_name": "the target's best margin searched alone (infeasible designs)",
            **one, "comment": "NaN: not searched (the design is feasible)"}),
    }


def _summary_variables(spec: DesignSpec, result: DesignResult) -> dict[str, tuple[Any, ...]]:
    """The design's score and feasibility, and the scan of a one-parameter search."""
    names, one = result.names, {"units": DIMENSIONLESS}
    variables: dict[str, tuple[Any, ...]] = {
        "score": ((), result.score, {
            "long_name": "smallest target margin at the design (the objective)", **one}),
        "feasible": ((), np.int8(result.feasible), {
            "long_name": "whether every target is met",
            "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "infeasible feasible"}),
    }
    if result.scan_values.size:
        variables["scan_value"] = (("scan",), result.scan_values, {
            "long_name": f"scanned value of {names[0]}",
            "units": spec.parameter(names[0]).units})
        variables["scan_score"] = (("scan",), result.scan_scores, {
            "long_name": "smallest target margin at the scanned value", **one})
    return variables


# ---------------------------------------------------------------------------
# The design kind (study.engine.kinds): what the runner, validation and the CLI need


def _design_for_runner(spec: DesignSpec, progress: Any) -> DesignResult:
    return design(spec, progress=progress.say)


#: The design kind: structure parameters searched for target behaviours.
DESIGN_KIND = register(ResultKind(
    name="design", spec_table="design", spec_schema=DESIGN_SPEC_SCHEMA,
    result_schema=DESIGN_RESULT_SCHEMA, entry_modules=("study.analyses.design",),
    summary="design: structure parameters that achieve target behaviours",
    label="design result", spec_type=DesignSpec, load=load_design_spec,
    parse=parse_design_spec, validator="study.analyses.fit_checks:design_problems",
    name_attribute="study_design_name", compute=_design_for_runner, build=design_dataset,
    own_provenance=True,
    formats=DESIGN_FORMATS, format_attribute="study_design_format",
))
