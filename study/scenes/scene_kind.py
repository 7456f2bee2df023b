"""Steering scenes: specs and computed datasets of the planar disk (paper Fig. 4).

A scene spec is a TOML file under ``workflows/`` with a ``[scene]`` table (a study
spec has ``[study]`` instead)::

    [scene]
    name = "steering"
    kind = "trajectory"          # or "calibration", "plan"

    [disk]
    radius = 0.02                # m
    cs = 0.25

    [[plate]]
    name = "head"
    f0 = 14.44                   # Hz
    Q = 17.5
    alpha = 64.0                 # degree
    M = 0.08
    direction = 0.0              # degree, body frame, counterclockwise from the heading
    attachment = [0.02, 0.0]     # m, body frame (forward, left)

    [[segment]]                  # kind "trajectory": the drive schedule
    label = "forward"
    f = 14.2                     # Hz
    a = 7.0                      # m s-2
    duration = 20.0              # s

``kind = "calibration"`` takes ``[calibration] f = {start, stop, num}`` and ``a =
{values = [...]}`` (the axis grammar of study sweeps); ``kind = "plan"`` takes
``[plan]`` with the waypoints, the four command frequencies and the operating
acceleration.

Specs go through :mod:`study.engine.spec_files` and the JSON schema
``study/schemas/study-scene-spec-v1.schema.json`` (types, ranges, keys); the checks a
schema cannot express (the kind's tables, ranges relative to the disk's radius, the
size budgets) are made here. Every refusal is a :class:`SceneError` naming the file,
the key and what is allowed, before anything is computed.

This module parses and computes (:func:`scene_dataset`); writing result files with
their provenance is :mod:`study.scene_run`'s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from study.engine.kinds import ResultFormat, ResultKind, register
from study.engine.layout import contact_law_attributes
from study.engine.spec_files import (
    SpecError,
    axis_length,
    axis_values,
    canonical_sha256,
    check_schema,
    jsonable,
    kind_of,
    load_schema,
    parse_toml,
    read_spec_text,
)
from study.model.status import Status
from study.model.units import (
    DEGREE,
    DEGREE_PER_SECOND,
    DIMENSIONLESS,
    HERTZ,
    METRE,
    METRE_PER_SECOND,
    METRE_PER_SECOND_SQUARED,
    SECOND,
)
from study.scenes.planar_model import (
    Disk,
    Plate,
    contact_margins,
    describe_disk,
    periodic_motion,
    rest_state,
    simulate_planar,
)
from study.scenes.planner import (
    COMMANDS,
    STRATEGIES,
    PlanError,
    calibrate_commands,
    plan_route,
    refined_route,
    run_plan,
)
from study.solvers.integrator import IntegratorSettings, Schedule

__all__ = [
    "MAX_CALIBRATION_PERIODS",
    "MAX_CALIBRATION_POINTS",
    "MAX_PLAN_DRIVE_SECONDS",
    "MAX_SCENE_SAMPLES",
    "MAX_TRAJECTORY_PERIODS",
    "PLATE_OSCILLATION_COST",
    "SCENE_FORMAT",
    "SCENE_KIND",
    "SCENE_KINDS",
    "SCENE_RESULT_SCHEMA",
    "SCENE_SPEC_SCHEMA",
    "SceneError",
    "SceneSpec",
    "disk_from_spec",
    "disk_method_attributes",
    "is_scene_file",
    "load_scene",
    "parse_scene",
    "period_weight",
    "scene_build",
    "scene_compute",
    "scene_dataset",
    "scene_metadata",
    "scene_work",
]

SCENE_KINDS = ("trajectory", "calibration", "plan")
#: The JSON schema of scene specs (package data in ``study/schemas/``).
SCENE_SPEC_SCHEMA = "study-scene-spec-v1"
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

#: Spec keys renamed when their unit changed: old key -> (new key, old unit, new unit,
#: factor from old to new). An old key is refused with the conversion, never read.
RENAMED_KEYS = {"heading_drift": ("heading_drift_deg", "rad per diameter",
                                  "degree per diameter", 180.0 / math.pi)}

_KIND_TABLES = {"trajectory": ("segment", "trajectory"), "calibration": ("calibration",),
                "plan": ("plan",)}

#: Stored samples of a scene at most (values of its largest variable): 1e7 doubles
#: are 80 MB per variable, and the integrator's own output several times that.
MAX_SCENE_SAMPLES = 10_000_000
#: Points of a calibration at most (the workflow has 324; each costs about 3 ms).
MAX_CALIBRATION_POINTS = 100_000
#: Drive periods a calibration may integrate at most (points x max_periods, then
#: each weighted by :func:`period_weight`): about 1 ms each on one core, so the
#: budget for points that never settle is about three core-hours.
MAX_CALIBRATION_PERIODS = 10_000_000
#: Drive periods a trajectory integrates at most (each weighted by
#: :func:`period_weight`): about 4 ms each on one core (the workflow's 430 periods
#: take 2 s), so about three core-hours. Samples alone do not bound the work: 1e7
#: samples 1000 s apart are 1e10 s of drive.
MAX_TRAJECTORY_PERIODS = 2_500_000
#: What one oscillation of a plate's mode costs the integrator, relative to one drive
#: period near the plates' resonance: far below it each drive period holds f0/f of
#: them (measured: 1 ms per period near f0; 2.4 s at 0.1 Hz against a 1e4 Hz plate;
#: 42 s, the step budget, at 1e-12 Hz against 14 Hz).
PLATE_OSCILLATION_COST = 1.0 / 40.0
#: Simulated drive time of a plan at most [s]: the planned flight times the flights
#: simulated (every strategy's run per realisation, and up to
#: :data:`_CORRECTIONS` corrective flights for the open-loop route and for each
#: closed-loop run). The workflow needs 38 s x 45 = 1.7e3 s, 20-70 s of computing
#: on a 2-core machine; 2e4 s is 11 times that.
MAX_PLAN_DRIVE_SECONDS = 20_000.0
#: Correction iterations of the planner's refined legs (its default, used here).
_CORRECTIONS = 5

#: Gyration radius over the disk's radius [1]. At most 1: all the mass within the
#: disk's footprint (a thin ring is the extreme). At least 1/4: a uniform disk has
#: 1/sqrt(2); below 1/4 the disk's spin is so light that the slips chatter in
#: rotation and the integrator's steps grow about as (radius / gyration_radius)^5
#: (a 3 s segment at 14.2 Hz: 7e4 steps at 1/4, 9e5 at 0.15, over 1e6 at 0.1),
#: and at 50 000 (gyration_radius = 1000 m) a 36 s schedule did not end in an hour.
GYRATION_RATIO = (0.25, 1.0)


def period_weight(f: Any, disk: Disk) -> Any:
    """Work of one drive period at ``f`` [Hz], in periods near the plates' resonance:
    ``1 + PLATE_OSCILLATION_COST * max(f0) / f``."""
    f0 = max(plate.f0 for plate in disk.plates)
    # A frequency as small as a double allows gives an infinite weight: a refusal,
    # not an overflow warning.
    with np.errstate(divide="ignore", over="ignore"):
        return 1.0 + PLATE_OSCILLATION_COST * f0 / np.asarray(f, dtype=np.float64)


class SceneError(SpecError):
    """A scene spec that cannot be run; the message names file, key and what is allowed."""


@dataclass(frozen=True)
class SceneSpec:
    """A validated scene spec.

    Attributes
    ----------
    name, kind, title, description : str
    disk : Disk
    settings : IntegratorSettings
    slaving : float
    options : dict
        The kind's own table(s), validated, in SI units (angles in degree, as in the spec).
    text : str
        The spec file's text (stored in the result).
    path : str
    """

    name: str
    kind: str
    title: str
    description: str
    disk: Disk
    settings: IntegratorSettings
    slaving: float
    options: dict[str, Any]
    text: str
    path: str

    @property
    def canonical(self) -> dict[str, Any]:
        """What the numbers depend on, in a canonical form (for the hash)."""
        return {"kind": self.kind, "disk": describe_disk(self.disk),
                "integrator": {"tolerance": self.settings.tolerance, "slaving": self.slaving},
                "options": jsonable(self.options)}

    @property
    def sha256(self) -> str:
        """Hash of the canonical spec: comments and key order do not change it."""
        return canonical_sha256(self.canonical)


def scene_spec_schema() -> dict[str, Any]:
    """The JSON schema of scene specs (``study/schemas/study-scene-spec-v1.schema.json``)."""
    return load_schema(SCENE_SPEC_SCHEMA)


def is_scene_file(path: str | Path) -> bool:
    """True if ``path`` is a readable TOML file with a ``[scene]`` table."""
    try:
        return kind_of(parse_toml(read_spec_text(path), str(path)), str(path)) == "scene"
    except SpecError:
        return False


def load_scene(path: str | Path) -> SceneSpec:
    """Read and validate a scene spec file (see :func:`parse_scene`)."""
    return parse_scene(read_spec_text(path, "scene spec"), str(path))


def _pose(value: list[float]) -> tuple[float, float, float]:
    """``[x (m), y (m), heading (degree)]`` as floats (degree, as :mod:`study.scenes.planner`
    takes them)."""
    return float(value[0]), float(value[1]), float(value[2])


def _renamed_key_problems(raw: Any, path: str) -> None:
    """Refuse a key whose unit changed (it was renamed), naming the conversion."""
    if not isinstance(raw, dict):
        return
    for table in ("trajectory", "plan"):
        entries = raw.get(table)
        if not isinstance(entries, dict):
            continue
        for old, (new, was, unit, factor) in RENAMED_KEYS.items():
            if old in entries:
                value = entries[old]
                shown = (f"{old} = {value!r} {was} is {new} = {value * factor:.4g} {unit}"
                         if isinstance(value, int | float) and not isinstance(value, bool)
                         else f"multiply by {factor:.6g}")
                raise SceneError(
                    f"{path}: [{table}] {old}: the key was in {was}; it is now {new}, in "
                    f"{unit} (x {factor:.6g}: the paper's 0.1 rad is 5.73 degree): {shown}"
                )


def parse_scene(text: str, path: str = "<string>") -> SceneSpec:
    """Validate a scene spec's text.

    Raises
    ------
    SceneError
        If the text is not a valid scene spec or the scene would be absurdly large;
        the message names the file, the key and what is allowed.
    """
    try:
        raw = parse_toml(text, path)
        _renamed_key_problems(raw, path)
        check_schema(raw, scene_spec_schema(), path, "scene spec")
    except SceneError:
        raise
    except SpecError as err:
        raise SceneError(str(err)) from None
    scene = raw["scene"]
    kind = scene["kind"]
    for table in ("segment", "trajectory", "calibration", "plan"):
        if table in raw and table not in _KIND_TABLES[kind]:
            raise SceneError(f"{path}: [{table}] does not belong to a {kind!r} scene; "
                             f"a {kind!r} scene takes {', '.join(_KIND_TABLES[kind])}")
    disk = disk_from_spec(raw, path)
    integrator = raw.get("integrator", {})
    tolerance = float(integrator.get("tolerance", 1e-9))
    slaving = float(integrator.get("slaving", 1e-4))
    options = _kind_options(kind, raw, path, disk)
    return SceneSpec(
        name=scene["name"], kind=kind, title=scene.get("title", scene["name"]),
        description=scene.get("description", ""), disk=disk,
        settings=IntegratorSettings(tolerance=tolerance), slaving=slaving, options=options,
        text=text, path=path,
    )


def disk_from_spec(raw: dict[str, Any], path: str) -> Disk:
    """The disk of a spec's ``[disk]`` and ``[[plate]]`` tables (already checked against
    the schema), with the checks the schema cannot make.

    Parameters
    ----------
    raw : dict
        The parsed spec.
    path : str
        The spec file, for messages.

    Raises
    ------
    SceneError
        Naming the file, the table and what is allowed.
    """
    table = raw["disk"]
    plates = []
    for i, entry in enumerate(raw["plate"]):
        try:
            plates.append(Plate(
                f0=entry["f0"], Q=entry["Q"], alpha=entry["alpha"], M=entry["M"],
                direction=entry.get("direction", 0.0),
                attachment=tuple(entry.get("attachment", (0.0, 0.0))),
                name=entry.get("name", f"plate{i + 1}"),
            ))
        except ValueError as err:
            raise SceneError(f"{path}: [plate #{i + 1}]: {err}") from None
    try:
        disk = Disk(plates=tuple(plates), **table)
    except ValueError as err:
        raise SceneError(f"{path}: [disk]: {err}") from None
    radius = disk.radius
    low, high = GYRATION_RATIO
    if not low * radius <= disk.gyration_radius <= high * radius:
        raise SceneError(
            f"{path}: [disk] gyration_radius = {disk.gyration_radius!r} m is out of range; "
            f"allowed: radius/4 to radius ({low * radius:g} to {high * radius:g} m; a "
            "uniform disk has radius/sqrt(2))"
        )
    return disk


def _calibration_axis(table: dict[str, Any], key: str, path: str) -> np.ndarray:
    values = axis_values(table[key], f"{path}: [calibration] {key}")
    maximum = scene_spec_schema()["$defs"]["parameter"][key]["maximum"]
    outside = values[(values <= 0.0) | (values > maximum)]
    if outside.size:
        raise SceneError(f"{path}: [calibration] {key}: value {float(outside[0])!r} is out of "
                         f"range; allowed: > 0 and <= {maximum}")
    return values


def _kind_options(kind: str, raw: dict[str, Any], path: str, disk: Disk) -> dict[str, Any]:
    try:
        if kind == "trajectory":
            return _trajectory_options(raw, path, disk)
        if kind == "calibration":
            return _calibration_options(raw, path, disk)
        return _plan_options(raw, path)
    except SceneError:
        raise
    except SpecError as err:  # the shared axis grammar's refusals
        raise SceneError(str(err)) from None


def _trajectory_options(raw: dict[str, Any], path: str, disk: Disk) -> dict[str, Any]:
    if "segment" not in raw:
        raise SceneError(f"{path}: a trajectory scene needs [[segment]] tables "
                         "(label, f [Hz], a [m s-2], duration [s])")
    rows = [{"label": entry.get("label", f"segment {i + 1}"), "f": float(entry["f"]),
             "a": float(entry["a"]), "duration": float(entry["duration"])}
            for i, entry in enumerate(raw["segment"])]
    table = raw.get("trajectory", {})
    interval = float(table.get("sample_interval", 0.05))
    total = math.fsum(row["duration"] for row in rows)
    samples = total / interval
    if samples > MAX_SCENE_SAMPLES:
        raise SceneError(
            f"{path}: [trajectory] sample_interval = {interval!r} s over the schedule's "
            f"{total:g} s ([[segment]] duration) gives {samples:.3g} samples; allowed at "
            f"most {MAX_SCENE_SAMPLES:.3g}: sample_interval >= {total / MAX_SCENE_SAMPLES:.3g} s"
        )
    # duration f (1 + c f0 / f) = duration (f + c f0): no overflow for a tiny f.
    f0 = max(plate.f0 for plate in disk.plates)
    periods = math.fsum(row["duration"] * (row["f"] + PLATE_OSCILLATION_COST * f0)
                        for row in rows)
    if periods > MAX_TRAJECTORY_PERIODS:
        raise SceneError(
            f"{path}: [[segment]] duration x f: the schedule's {total:g} s of drive are "
            f"{periods:.3g} drive periods of work (a period far below the plates' f0 counts "
            f"{PLATE_OSCILLATION_COST:g} x f0/f more); allowed at most "
            f"{MAX_TRAJECTORY_PERIODS:.3g}: shorter segments"
        )
    return {
        "segments": rows,
        "sample_interval": interval,
        "start": _pose(table["start"]) if "start" in table else (0.0, 0.0, 90.0),
        "heading_drift_deg": float(table.get("heading_drift_deg", 0.0)),
        "seed": int(table.get("seed", 0)),
    }


def _calibration_options(raw: dict[str, Any], path: str, disk: Disk) -> dict[str, Any]:
    if "calibration" not in raw:
        raise SceneError(f"{path}: a calibration scene needs a [calibration] table "
                         "(f and a axes, max_periods)")
    table = raw["calibration"]
    max_periods = table.get("max_periods", 400)
    points = axis_length(table["f"]) * axis_length(table["a"])
    if points > MAX_CALIBRATION_POINTS:
        raise SceneError(
            f"{path}: [calibration] f x a = {axis_length(table['f'])} x "
            f"{axis_length(table['a'])} = {points:.3g} points; allowed at most "
            f"{MAX_CALIBRATION_POINTS:.3g}"
        )
    if points * max_periods > MAX_CALIBRATION_PERIODS:
        raise SceneError(
            f"{path}: [calibration] f x a x max_periods = {axis_length(table['f'])} x "
            f"{axis_length(table['a'])} x {max_periods} = {points * max_periods:.3g} drive "
            f"periods; allowed at most {MAX_CALIBRATION_PERIODS:.3g}: fewer points or periods"
        )
    f = _calibration_axis(table, "f", path)
    a = _calibration_axis(table, "a", path)
    work = a.size * max_periods * float(np.sum(period_weight(f, disk)))
    if work > MAX_CALIBRATION_PERIODS:
        raise SceneError(
            f"{path}: [calibration] f: {f.size} x {a.size} points x max_periods = "
            f"{max_periods} from {float(np.min(f)):g} Hz, below the plates' f0 up to "
            f"{max(p.f0 for p in disk.plates):g} Hz (a period counts "
            f"{PLATE_OSCILLATION_COST:g} x f0/f more): {work:.3g} drive periods of work; "
            f"allowed at most {MAX_CALIBRATION_PERIODS:.3g}: higher f, fewer points or periods"
        )
    return {"f": f, "a": a, "max_periods": max_periods}


def _plan_options(raw: dict[str, Any], path: str) -> dict[str, Any]:
    if "plan" not in raw:
        raise SceneError(f"{path}: a plan scene needs a [plan] table (acceleration, "
                         f"waypoints, {', '.join(COMMANDS)})")
    table = raw["plan"]
    return {
        "acceleration": float(table["acceleration"]),
        "frequencies": {name: float(table[name]) for name in COMMANDS},
        "waypoints": np.array(table["waypoints"], dtype=float),
        "start": _pose(table["start"]) if "start" in table else (0.0, 0.0, 0.0),
        # The paper's measured 0.1 rad per diameter.
        "heading_drift_deg": float(table.get("heading_drift_deg", 5.73)),
        "realisations": table.get("realisations", 4),
        "seed": int(table.get("seed", 0)),
        "sample_interval": float(table.get("sample_interval", 0.05)),
    }


# ---------------------------------------------------------------------------
# Computing


def _variable(dims, values, units: str | None, long_name: str, **attrs: Any) -> xr.Variable:
    merged = {"long_name": long_name, **attrs}
    if units is not None:
        merged["units"] = units
    return xr.Variable(dims, values, merged)


def _flag(dims, values, meanings: tuple[str, ...], long_name: str) -> xr.Variable:
    return xr.Variable(dims, np.asarray(values, dtype=np.int8), {
        "long_name": long_name, "flag_values": np.arange(len(meanings), dtype=np.int8),
        "flag_meanings": " ".join(meanings),
    })


RIM_NOTE = (
    "min over a period of the steady drive of (n R/4 - |tilting moment of the plates' "
    "vertical forces|) / (g R/4); negative: the rim leaves the table and the full-contact, "
    "uniform-pressure friction model does not hold there (the numbers are still computed)"
)
SEGMENT_STATUS = ("completed", "lift_off", "not_reached", "step_budget")
# Every status the planar model can end with: all but BOUNCING (it does not fly). A
# calibration point whose slip has no solution is friction_paradox.
MOTION_STATUS = tuple(s.name.lower() for s in Status if s is not Status.BOUNCING)


def _heading_noise(drift: float, disk: Disk) -> float:
    """Diffusion [degree m^-1/2] giving ``drift`` degree of heading spread per diameter
    slid."""
    return drift / math.sqrt(disk.diameter)


#: Reports work done (in the units of :func:`scene_work`) as a scene runs.
Report = Callable[[float], None]


def _ignore(work: float) -> None:
    """A report that shows nothing."""


def scene_work(spec: SceneSpec) -> tuple[float, str]:
    """How much work computing a scene is, and its unit, for progress: the drive time of
    a trajectory [s], the points of a calibration, the flights of a plan (calibrating
    the commands counts as one, correcting the open-loop route and each closed-loop run
    as :data:`_CORRECTIONS` more, as in :func:`_check_plan_size`)."""
    options = spec.options
    if spec.kind == "trajectory":
        return math.fsum(row["duration"] for row in options["segments"]), "s"
    if spec.kind == "calibration":
        return float(options["f"].size * options["a"].size), "pt"
    count = options["realisations"] + 1
    return float(1 + _CORRECTIONS + (len(STRATEGIES) + _CORRECTIONS) * count), "flight"


def _segment_summaries(run: Any, schedule: Schedule, segments: int
                       ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Each segment's displacement in the frame of its start, heading change, path and
    how it ended (NaN and "not_reached" for segments the run never reached)."""
    t = run.time
    summary = {k: np.zeros(segments) for k in ("fwd", "lat", "turn", "path")}
    status = np.zeros(segments, dtype=np.int8)
    for j, (start, stop) in enumerate(zip(schedule.starts, schedule.ends, strict=True)):
        i0 = int(np.searchsorted(t, start))
        i1 = int(np.searchsorted(t, stop))
        if i0 >= t.size:
            status[j] = SEGMENT_STATUS.index("not_reached")
            for key in summary:
                summary[key][j] = math.nan
            continue
        if i1 >= t.size or t[i1] != stop:
            status[j] = SEGMENT_STATUS.index(run.outcome if run.outcome in SEGMENT_STATUS
                                             else "step_budget")
            i1 = t.size - 1
        dx, dy = run.x[i1] - run.x[i0], run.y[i1] - run.y[i0]
        heading = math.radians(run.heading[i0])
        c, s = math.cos(heading), math.sin(heading)
        summary["fwd"][j] = c * dx + s * dy
        summary["lat"][j] = -s * dx + c * dy
        summary["turn"][j] = run.heading[i1] - run.heading[i0]
        summary["path"][j] = run.path[i1] - run.path[i0]
    return summary, status


def _run_trajectory(spec: SceneSpec, report: Report = _ignore
                    ) -> tuple[dict[str, xr.Variable], dict[str, Any]]:
    options = spec.options
    rows = options["segments"]
    schedule = Schedule(np.array([r["f"] for r in rows]), np.array([r["a"] for r in rows]),
                        np.array([r["duration"] for r in rows]))
    end = float(schedule.ends[-1])
    grid = np.arange(0.0, end, options["sample_interval"])
    out_t = np.unique(np.concatenate([grid, schedule.starts, [end]]))
    reached = [0.0]

    def advanced(t: float) -> None:
        report(t - reached[0])
        reached[0] = t

    run = simulate_planar(
        spec.disk, schedule, initial_state=rest_state(spec.disk, options["start"]),
        output_times=out_t, settings=spec.settings,
        heading_noise=_heading_noise(options["heading_drift_deg"], spec.disk),
        rng=options["seed"], slaving=spec.slaving, on_progress=advanced,
    )
    t = run.time
    index = np.clip(np.searchsorted(schedule.ends, t, side="right"), 0, len(rows) - 1)
    index[t == end] = len(rows) - 1
    summary, status = _segment_summaries(run, schedule, len(rows))
    variables = {
        "x": _variable("t", run.x, METRE, "x position of the disk's centre"),
        "y": _variable("t", run.y, METRE, "y position of the disk's centre"),
        "heading": _variable("t", run.heading, DEGREE,
                             "heading, counterclockwise from the x axis (unwrapped)"),
        "path_length": _variable("t", run.path, METRE, "distance slid since the start"),
        "slipping": _flag("t", run.slipping.astype(np.int8), ("stuck", "slipping"),
                          "contact state at the sample"),
        "segment_index": _variable("t", index.astype(np.int32), None,
                                   "segment of the schedule the sample belongs to"),
        "segment_label": _variable("segment", np.array([r["label"] for r in rows], dtype=str),
                                   None, "command of the segment"),
        "frequency": _variable("segment", schedule.frequency, HERTZ, "drive frequency"),
        "acceleration": _variable("segment", schedule.acceleration, METRE_PER_SECOND_SQUARED,
                                  "drive acceleration amplitude"),
        "duration": _variable("segment", schedule.duration, SECOND, "segment duration"),
        "start_time": _variable("segment", schedule.starts, SECOND, "segment start"),
        "end_time": _variable("segment", schedule.ends, SECOND, "segment end"),
        "forward_displacement": _variable(
            "segment", summary["fwd"], METRE,
            "displacement along the heading at the segment's start"),
        "lateral_displacement": _variable(
            "segment", summary["lat"], METRE,
            "displacement to the left of the heading at the segment's start"),
        "heading_change": _variable("segment", summary["turn"], DEGREE,
                                    "heading change over the segment"),
        "segment_path_length": _variable("segment", summary["path"], METRE,
                                         "distance slid in the segment"),
        "segment_status": _flag("segment", status, SEGMENT_STATUS, "how the segment ended"),
        "edge_contact_margin": _variable(
            "segment", [contact_margins(spec.disk, r["f"], r["a"])[0] for r in rows],
            DIMENSIONLESS,
            "rim contact margin of the segment's drive", comment=RIM_NOTE),
    }
    coords = {"t": _variable("t", t, SECOND, "time since the drive started"),
              "segment": _variable("segment", np.arange(len(rows)), None, "segment number")}
    attrs = {"study_outcome": run.outcome, "study_end_time": run.end_time,
             "study_steps": run.steps, "study_slips": run.slips}
    return {**coords, **variables}, attrs


def _run_calibration(spec: SceneSpec, report: Report = _ignore
                     ) -> tuple[dict[str, xr.Variable], dict[str, Any]]:
    f = spec.options["f"]
    a = spec.options["a"]
    points = [(i, j) for i in range(f.size) for j in range(a.size)]

    def one(point):
        i, j = point
        return periodic_motion(spec.disk, float(f[i]), float(a[j]), settings=spec.settings,
                               max_periods=spec.options["max_periods"], slaving=spec.slaving)

    # The kernel releases the GIL: threads use every core without copying the disk.
    motions: list[Any] = [None] * len(points)
    with ThreadPoolExecutor() as pool:
        futures = {pool.submit(one, point): k for k, point in enumerate(points)}
        for future in as_completed(futures):
            motions[futures[future]] = future.result()
            report(1.0)
    shape = (f.size, a.size)
    fields = {k: np.full(shape, math.nan) for k in
              ("forward_speed", "lateral_speed", "turn_rate", "slips_per_period",
               "stuck_fraction")}
    status = np.zeros(shape, dtype=np.int8)
    periods = np.zeros(shape, dtype=np.int32)
    orbit = np.zeros(shape, dtype=np.int32)
    rim = np.array([[contact_margins(spec.disk, fi, aj)[0] for aj in a] for fi in f])
    for (i, j), motion in zip(points, motions, strict=True):
        for key in fields:
            fields[key][i, j] = getattr(motion, key)
        status[i, j] = motion.status
        periods[i, j] = motion.periods
        orbit[i, j] = motion.orbit_period
    dims = ("f", "a")
    variables = {
        "f": _variable("f", f, HERTZ, "drive frequency"),
        "a": _variable("a", a, METRE_PER_SECOND_SQUARED, "drive acceleration amplitude"),
        "forward_speed": _variable(dims, fields["forward_speed"], METRE_PER_SECOND,
                                   "steady mean velocity along the heading"),
        "lateral_speed": _variable(dims, fields["lateral_speed"], METRE_PER_SECOND,
                                   "steady mean velocity to the left of the heading"),
        "turn_rate": _variable(dims, fields["turn_rate"], DEGREE_PER_SECOND,
                               "steady mean angular velocity, counterclockwise positive"),
        "slips_per_period": _variable(dims, fields["slips_per_period"], DIMENSIONLESS,
                                      "slips starting per drive period"),
        "stuck_fraction": _variable(dims, fields["stuck_fraction"], DIMENSIONLESS,
                                    "fraction of the period stuck"),
        "status": _flag(dims, status, MOTION_STATUS, "outcome at the point"),
        "periods": _variable(dims, periods, DIMENSIONLESS, "drive periods integrated"),
        "orbit_period": _variable(dims, orbit, DIMENSIONLESS,
                                  "drive periods after which the motion repeats (0: none)"),
        "edge_contact_margin": _variable(dims, rim, DIMENSIONLESS, "rim contact margin",
                                         comment=RIM_NOTE),
    }
    return variables, {}


def _check_plan_size(spec: SceneSpec, route: list, count: int) -> None:
    """Refuse a plan whose flights or samples would be absurd, before flying any.

    The calibrated route (closed form, milliseconds) tells how long a flight takes;
    the model's own legs differ by the command-switch transients only. ``count``
    runs per strategy are flown (realisations + 1).
    """
    options = spec.options
    flight = math.fsum(leg.turn_duration + leg.straight_duration
                       for legs in route for leg in legs)
    flights = len(STRATEGIES) * count + _CORRECTIONS * (1 + count)
    if flight * flights > MAX_PLAN_DRIVE_SECONDS:
        raise SceneError(
            f"{spec.path}: [plan] waypoints: the planned route takes {flight:.4g} s of "
            f"drive, simulated up to {flights} times (strategies and corrections for "
            f"realisations = {count - 1}): {flight * flights:.3g} s; allowed at most "
            f"{MAX_PLAN_DRIVE_SECONDS:.3g} s: nearer waypoints or fewer realisations"
        )
    runs = len(STRATEGIES) * count
    samples = runs * flight / options["sample_interval"]
    if samples > MAX_SCENE_SAMPLES:
        raise SceneError(
            f"{spec.path}: [plan] sample_interval = {options['sample_interval']!r} s gives "
            f"{samples:.3g} samples over {runs} runs of {flight:.4g} s; allowed at most "
            f"{MAX_SCENE_SAMPLES:.3g}: sample_interval >= "
            f"{runs * flight / MAX_SCENE_SAMPLES:.3g} s"
        )


def _run_plan(spec: SceneSpec, report: Report = _ignore
              ) -> tuple[dict[str, xr.Variable], dict[str, Any]]:
    """Calibrate the commands, plan the routes, fly every strategy and realisation, and
    lay the flights out as variables."""
    commands, routes = _plan_routes(spec, report)
    runs = _fly_plans(spec, commands, routes, report)
    return _plan_variables(spec, commands, routes, runs)


def _plan_routes(spec: SceneSpec, report: Report) -> tuple[dict[str, Any], dict[str, Any]]:
    """The calibrated commands and each strategy's route (None: planned in flight)."""
    options = spec.options
    disk = spec.disk
    count = options["realisations"] + 1
    waypoints = options["waypoints"]
    try:
        commands = calibrate_commands(disk, options["frequencies"], options["acceleration"],
                                      settings=spec.settings, slaving=spec.slaving)
        report(1.0)
        # The blind strategies' legs do not depend on the noise: plan them once.
        calibrated = plan_route(options["start"], waypoints, commands)
        # Before the first simulated flight (the open-loop corrections fly the route).
        _check_plan_size(spec, calibrated, count)
        routes = {
            "calibration": calibrated,
            "open_loop": refined_route(disk, options["start"], waypoints, commands,
                                       spec.settings, slaving=spec.slaving),
            "closed_loop": None,
        }
        report(float(_CORRECTIONS))
    except PlanError as err:
        raise SceneError(f"{spec.path}: [plan]: {err}") from None
    return commands, routes


def _fly_plans(spec: SceneSpec, commands: dict[str, Any], routes: dict[str, Any],
               report: Report) -> dict[tuple[int, int], Any]:
    """Every strategy's flights: realisation 0 without heading noise, the others with."""
    options = spec.options
    disk = spec.disk
    strategies = STRATEGIES
    count = options["realisations"] + 1
    waypoints = options["waypoints"]
    noise = _heading_noise(options["heading_drift_deg"], disk)

    def fly(flight: tuple[int, int]) -> Any:
        s, r = flight
        strategy = strategies[s]
        return run_plan(
            disk, options["start"], waypoints, commands, strategy=strategy,
            heading_noise=noise if r > 0 else 0.0, seed=options["seed"] * 1000 + r,
            settings=spec.settings, sample_interval=options["sample_interval"],
            slaving=spec.slaving, route=routes[strategy],
        )

    # Each flight is a function of its own strategy, noise and seed alone (its own
    # random generator; the commands and routes are only read), so the flights run side
    # by side on threads (the kernel releases the GIL) and every value is the same as
    # flown one after another. The dearest (closed-loop: each leg corrected) go first.
    flights = [(s, r) for s in range(len(strategies)) for r in range(count)]
    dearest_first = sorted(flights, key=lambda k: strategies[k[0]] != "closed_loop")
    flown: dict[tuple[int, int], Any] = {}
    with ThreadPoolExecutor() as pool:
        futures = {pool.submit(fly, flight): flight for flight in dearest_first}
        for future in as_completed(futures):
            flight = futures[future]
            flown[flight] = future.result()
            # A closed-loop run corrects each leg as the open-loop route was corrected.
            report(1.0 + (_CORRECTIONS if strategies[flight[0]] == "closed_loop" else 0))
    return {flight: flown[flight] for flight in flights}


def _plan_variables(spec: SceneSpec, commands: dict[str, Any], routes: dict[str, Any],
                    runs: dict[tuple[int, int], Any]
                    ) -> tuple[dict[str, xr.Variable], dict[str, Any]]:
    """The flights sampled on one time axis, the waypoints, misses and commands."""
    options = spec.options
    strategies = STRATEGIES
    count = options["realisations"] + 1
    waypoints = options["waypoints"]
    end = max(float(run.time[-1]) for run in runs.values())
    t = np.arange(0.0, end + options["sample_interval"], options["sample_interval"])
    shape = (len(strategies), count, t.size)
    paths = {k: np.empty(shape) for k in ("x", "y", "heading")}
    miss = np.empty((len(strategies), count, len(waypoints)))
    outcome = np.zeros((len(strategies), count), dtype=np.int8)
    for (s, r), run in runs.items():
        for key in paths:
            # After its schedule a run stays where it ended (the table stops).
            paths[key][s, r] = np.interp(t, run.time, getattr(run, key))
        miss[s, r] = run.miss_distance
        outcome[s, r] = SEGMENT_STATUS.index(run.outcome)
    plan_run = runs[STRATEGIES.index("open_loop"), 0]
    planned = np.array([legs[-1].predicted_pose[:2] for legs in routes["calibration"]])
    dims = ("strategy", "realisation", "t")
    variables = {
        "t": _variable("t", t, SECOND, "time since the drive started"),
        # Strings name the strategies in an auxiliary coordinate: a string-valued
        # coordinate variable is not CF (coordinate variables must be monotonic).
        "strategy_name": _variable("strategy", np.array(strategies, dtype=str), None,
                              "calibration: legs from the calibration alone, flown blind; "
                              "open_loop: legs corrected in the noise-free model, flown "
                              "blind; closed_loop: each leg planned and corrected from the "
                              "pose reached"),
        "realisation": _variable("realisation", np.arange(count), None,
                                 "0: without heading noise; others: with"),
        "waypoint": _variable("waypoint", np.arange(len(waypoints)), None, "waypoint number"),
        "waypoint_x": _variable("waypoint", waypoints[:, 0], METRE, "waypoint x"),
        "waypoint_y": _variable("waypoint", waypoints[:, 1], METRE, "waypoint y"),
        "planned_x": _variable("waypoint", planned[:, 0], METRE,
                               "x where the calibrated plan predicts the leg ends"),
        "planned_y": _variable("waypoint", planned[:, 1], METRE,
                               "y where the calibrated plan predicts the leg ends"),
        "x": _variable(dims, paths["x"], METRE, "x position of the disk's centre"),
        "y": _variable(dims, paths["y"], METRE, "y position of the disk's centre"),
        "heading": _variable(dims, paths["heading"], DEGREE,
                             "heading, counterclockwise from the x axis (unwrapped)"),
        "miss_distance": _variable(("strategy", "realisation", "waypoint"), miss, METRE,
                                   "distance from the waypoint at the end of its leg"),
        "run_status": _flag(("strategy", "realisation"), outcome, SEGMENT_STATUS,
                            "how the run ended"),
        "realisation_heading_drift": _variable(
            "realisation", np.where(np.arange(count) > 0, options["heading_drift_deg"], 0.0),
            "degree", "heading spread per disk diameter slid"),
        "segment_label": _variable("segment", np.array(plan_run.labels, dtype=str), None,
                                   "command of the segment (the open-loop plan)"),
        "frequency": _variable("segment", plan_run.schedule.frequency, HERTZ, "drive frequency"),
        "acceleration": _variable("segment", plan_run.schedule.acceleration,
                                  METRE_PER_SECOND_SQUARED, "drive acceleration amplitude"),
        "duration": _variable("segment", plan_run.schedule.duration, SECOND, "segment duration"),
    }
    for name, command in commands.items():
        variables[f"command_{name}"] = xr.Variable((), command.frequency, {
            "units": HERTZ, "long_name": f"{name} command frequency",
            "forward_speed": command.forward_speed, "lateral_speed": command.lateral_speed,
            "turn_rate": command.turn_rate, "turn_rate_units": DEGREE_PER_SECOND,
        })
    attrs = {"start_x": options["start"][0], "start_y": options["start"][1],
             "start_heading": options["start"][2]}
    return variables, attrs


_RUNNERS = {"trajectory": _run_trajectory, "calibration": _run_calibration, "plan": _run_plan}


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
    :func:`scene_work`) as the scene runs: what ``study run`` shows as progress.

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


def scene_compute(spec: SceneSpec, report: Report | None = None
                  ) -> tuple[dict[str, xr.Variable], dict[str, Any]]:
    """Run a scene: its variables and the attributes its run found (how it ended)."""
    return _RUNNERS[spec.kind](spec, report or _ignore)


def disk_method_attributes(disk: Disk) -> dict[str, str | float]:
    """The global attributes naming the contact laws of a scene's disk
    (:func:`study.engine.layout.contact_law_attributes`, as every result's).

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
    """The labelled dataset of a computed scene (:func:`scene_compute`), with the scene's
    own attributes (provenance is the runner's)."""
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
        "plate_name": _variable("plate", np.array([p.name for p in disk.plates], dtype=str),
                                None, "plate"),
        "plate_f0": _variable("plate", [p.f0 for p in disk.plates], HERTZ, "plate resonance"),
        "plate_Q": _variable("plate", [p.Q for p in disk.plates], DIMENSIONLESS,
                             "plate quality factor"),
        "plate_alpha": _variable("plate", [p.alpha for p in disk.plates], DEGREE,
                                 "plate tilt from the horizontal"),
        "plate_M": _variable("plate", [p.M for p in disk.plates], DIMENSIONLESS,
                             "plate modal mass over the structure's mass"),
        "plate_direction": _variable("plate", [p.direction for p in disk.plates], DEGREE,
                                     "plate direction, body frame, from the heading"),
        "plate_attachment_forward": _variable("plate", [p.attachment[0] for p in disk.plates],
                                              "m", "plate attachment, forward of the centre"),
        "plate_attachment_left": _variable("plate", [p.attachment[1] for p in disk.plates],
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
