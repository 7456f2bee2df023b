"""Scene specs: their types (:class:`SceneSpec`, :class:`SceneError`), their size
budgets, and a ``[scene]`` TOML file parsed and checked into a :class:`SceneSpec`.

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

Running a scene is :mod:`study.scenes.scene_run`'s; its result file and the scene kind
are :mod:`study.scenes.scene_kind`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

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
from study.model.disk import Disk, Plate, describe_disk
from study.scenes.planner import COMMANDS
from study.solvers.integrator import IntegratorSettings

__all__ = [
    "MAX_CALIBRATION_PERIODS",
    "MAX_CALIBRATION_POINTS",
    "MAX_SCENE_SAMPLES",
    "MAX_TRAJECTORY_PERIODS",
    "PLATE_OSCILLATION_COST",
    "SCENE_KINDS",
    "SCENE_SPEC_SCHEMA",
    "SceneError",
    "SceneSpec",
    "disk_from_spec",
    "is_scene_file",
    "load_scene",
    "parse_scene",
    "period_weight",
]

SCENE_KINDS = ("trajectory", "calibration", "plan")
#: The JSON schema of scene specs (package data in ``study/schemas/``).
SCENE_SPEC_SCHEMA = "study-scene-spec-v1"

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
