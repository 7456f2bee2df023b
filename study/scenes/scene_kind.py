"""The scene result kind: a scene's result file (its attributes, its formats, the
labelled dataset of a computed scene) and the kind registered with the engine
(:data:`SCENE_KIND`, :mod:`study.engine.kinds`).

A scene is parsed by :mod:`study.scenes.scene_spec` and run by
:mod:`study.scenes.scene_run`; this module builds what is written
(:func:`scene_build`, :func:`scene_dataset`). Writing result files with their
provenance is the runner's (:func:`study.engine.runner.run_scene`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from study.engine.contact_attributes import contact_law_attributes
from study.engine.kinds import ResultFormat, ResultKind, register
from study.model.disk import Disk
from study.model.units import DEGREE, DIMENSIONLESS, HERTZ
from study.scenes.scene_run import Report, scene_compute, scene_var, scene_work
from study.scenes.scene_spec import SCENE_SPEC_SCHEMA, SceneSpec, load_scene, parse_scene

__all__ = [
    "SCENE_FORMAT",
    "SCENE_KIND",
    "SCENE_RESULT_SCHEMA",
    "disk_method_attributes",
    "scene_build",
    "scene_dataset",
    "scene_metadata",
]

#: The ``study_result_schema`` of scene files (and the name of their JSON schema).
SCENE_RESULT_SCHEMA = "study-scene-v1"
#: Layout of a scene result's values (``study_scene_format``): 3 stores every angle in
#: degree (heading, heading_change, start_heading; turn rates in degree s-1; the plan's
#: realisation_heading_drift in degree per diameter, its spec key heading_drift_deg).
#: Files of format 1 (no attribute, angles in rad) and 2 (heading drift in rad per
#: diameter, spec key heading_drift), written before 0.1.0, are refused by validation and
#: rerun by ``study run``.
SCENE_FORMATS = (
    ResultFormat(1, "before 0.1.0", "angles in rad", SCENE_RESULT_SCHEMA),
    ResultFormat(2, "before 0.1.0", "every angle in degree but the heading drift (rad per "
                 "diameter, spec key heading_drift)", SCENE_RESULT_SCHEMA),
    ResultFormat(3, "0.1.0", "the heading drift in degree per diameter (spec key "
                 "heading_drift_deg)", SCENE_RESULT_SCHEMA),
)
#: The format this version writes.
SCENE_FORMAT = SCENE_FORMATS[-1].number


def scene_metadata(spec: SceneSpec) -> dict[str, Any]:
    """Attributes that follow the scene spec's text but not its numbers (rewritten without
    recomputing when only they change)."""
    return {
        "title": spec.title,
        "summary": spec.description or (
            f"Steering scene '{spec.name}' ({spec.kind}) of a rigid disk with resonant plates "
            "on a vertically shaken table: planar stick-slip with an ellipsoidal limit "
            "surface, integrated with events (study.scenes.planar_model)."),
        "id": f"{spec.name}-{spec.sha256[:16]}",
        "study_name": spec.name,
        "study_spec": spec.text,
        "study_spec_path": spec.path,
    }


def scene_dataset(spec: SceneSpec, report: Report | None = None) -> xr.Dataset:
    """Compute a scene: its labelled dataset with the scene's own attributes.

    ``report``, if given, is called with the work done (in the units of
    :func:`study.scenes.scene_run.scene_work`) as the scene runs: what ``study run``
    shows as progress.

    The attributes describe the scene (title, summary, the disk, the integrator and
    how the run ended); provenance (spec text and hash, code, environment, history)
    is added by the runner (:func:`study.engine.runner.run_scene`) when the result is
    written.

    Raises
    ------
    SceneError
        For a plan whose commands cannot steer the disk, or whose flights would be
        absurdly long (checked before any flight is simulated).
    """
    return scene_build(spec, scene_compute(spec, report))


def disk_method_attributes(disk: Disk) -> dict[str, str | float]:
    """The global attributes naming the contact laws of a scene's disk
    (:func:`study.engine.contact_attributes.contact_law_attributes`, as every result's).

    ``study_coupling`` is the disk's coupling of the plates' modes (one-way or two-way,
    its ``[disk] coupling``); ``study_friction_law`` is ``coulomb``, the only friction
    law of the planar model (its coefficients are ``disk_cs`` and ``disk_ck``; the
    ellipsoidal limit surface's length is ``disk_friction_length``); ``study_lift_off``
    is the disk's lift-off law, ``stop`` (a run ends with outcome ``lift_off``; the
    planar model refuses flight). The planar model chooses no solver: it has no
    ``study_solver_method``.
    """
    return contact_law_attributes(disk.coupling, "coulomb",
                                  "flight" if disk.flight else "stop")


def scene_build(spec: SceneSpec, computed: tuple[dict[str, xr.Variable], dict[str, Any]],
                command: str = "") -> xr.Dataset:
    """The labelled dataset of a computed scene
    (:func:`study.scenes.scene_run.scene_compute`), with the scene's own attributes
    (provenance is the runner's)."""
    variables, extra = computed
    disk = spec.disk
    metadata = scene_metadata(spec)
    attrs = {
        "title": metadata["title"],
        "summary": metadata["summary"],
        "keywords": "stick-slip, friction, locomotion, steering, limit surface, resonance",
        "source": "study.scenes.planar_model: Dormand-Prince 5(4) time integration with "
                  "events of the "
                  "planar disk with resonant plates",
        "comment": "SI units, except angles: degree (heading, heading changes, tilts, "
                   "directions; turn rates in degree s-1; the noise model's heading drift "
                   "in degree per disk diameter slid), counterclockwise positive. The body "
                   "frame's x axis is the heading.",
        "study_scene_format": SCENE_FORMAT,
        "study_scene_kind": spec.kind,
        "study_name": spec.name,
        "disk_radius": disk.radius,
        "disk_cs": disk.cs,
        "disk_ck": disk.ck,
        "disk_g": disk.g,
        "disk_gyration_radius": disk.gyration_radius,
        "disk_friction_length": disk.friction_length,
        "integrator_tolerance": spec.settings.tolerance,
        "integrator_slaving": spec.slaving,
        **disk_method_attributes(disk),
        **extra,
    }
    plate_vars = {
        "plate_name": scene_var("plate", np.array([p.name for p in disk.plates], dtype=str),
                                None, "plate"),
        "plate_f0": scene_var("plate", [p.f0 for p in disk.plates], HERTZ, "plate resonance"),
        "plate_Q": scene_var("plate", [p.Q for p in disk.plates], DIMENSIONLESS,
                             "plate quality factor"),
        "plate_alpha": scene_var("plate", [p.alpha for p in disk.plates], DEGREE,
                                 "plate tilt from the horizontal"),
        "plate_M": scene_var("plate", [p.M for p in disk.plates], DIMENSIONLESS,
                             "plate modal mass over the structure's mass"),
        "plate_direction": scene_var("plate", [p.direction for p in disk.plates], DEGREE,
                                     "plate direction, body frame, from the heading"),
        "plate_attachment_forward": scene_var("plate", [p.attachment[0] for p in disk.plates],
                                              "m", "plate attachment, forward of the centre"),
        "plate_attachment_left": scene_var("plate", [p.attachment[1] for p in disk.plates],
                                           "m", "plate attachment, left of the centre"),
    }
    coords = {k: v for k, v in variables.items() if k in ("t", "segment", "f", "a",
                                                          "strategy_name", "realisation",
                                                          "waypoint")}
    data = {k: v for k, v in {**variables, **plate_vars}.items() if k not in coords}
    return xr.Dataset(data, coords=coords, attrs=attrs)


# ---------------------------------------------------------------------------
# The scene kind (study.engine.kinds): everything the engine needs of a scene


def _compute_for_runner(spec: SceneSpec, progress: Any
                        ) -> tuple[dict[str, xr.Variable], dict[str, Any]]:
    return scene_compute(spec, progress.update)


def _variant(spec: SceneSpec) -> str:
    return spec.kind


#: The steering-scene kind.
SCENE_KIND = register(ResultKind(
    name="scene", spec_table="scene", spec_schema=SCENE_SPEC_SCHEMA,
    result_schema=SCENE_RESULT_SCHEMA, entry_modules=("study.scenes.scene_kind",),
    summary="steering scene of the planar disk: trajectory, calibration or plan",
    label="steering scene result", spec_type=SceneSpec, load=load_scene, parse=parse_scene,
    validator="study.scenes.scene_checks:scene_problems",
    compute=_compute_for_runner, build=scene_build, work=scene_work, variant=_variant,
    variant_attribute="study_scene_kind",
    metadata=scene_metadata, formats=SCENE_FORMATS, format_attribute="study_scene_format",
))
