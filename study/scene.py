"""Steering scenes: specs, runs and result datasets of the planar disk (paper Fig. 4).

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
{values = [...]}``; ``kind = "plan"`` takes ``[plan]`` with the waypoints, the four
command frequencies and the operating acceleration. Every refusal is a
:class:`SceneError` naming the file, the key and what is allowed.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from study.planar import (
    Disk,
    Plate,
    contact_margins,
    describe_disk,
    periodic_motion,
    rest_state,
    simulate_planar,
)
from study.planner import (
    COMMANDS,
    STRATEGIES,
    PlanError,
    calibrate_commands,
    plan_route,
    refined_route,
    run_plan,
)
from study.spec import SpecError
from study.status import Status
from study.transient import IntegratorSettings, Schedule

__all__ = [
    "SCENE_KINDS",
    "SceneError",
    "SceneSpec",
    "is_scene_file",
    "load_scene",
    "parse_scene",
    "run_scene",
]

SCENE_KINDS = ("trajectory", "calibration", "plan")

_TOP = {"scene", "disk", "plate", "integrator", "segment", "trajectory", "calibration", "plan"}
_SCENE_KEYS = {"name": str, "kind": str, "title": str, "description": str}
_DISK_KEYS = {"radius": "m", "cs": "1", "ck": "1", "g": "m s-2", "gyration_radius": "m",
              "friction_length": "m"}
_PLATE_KEYS = {"name": "", "f0": "Hz", "Q": "1", "alpha": "degree", "M": "1",
               "direction": "degree", "attachment": "m"}
_INTEGRATOR_KEYS = {"tolerance": "1", "slaving": "1"}
_SEGMENT_KEYS = {"label": "", "f": "Hz", "a": "m s-2", "duration": "s"}
_TRAJECTORY_KEYS = {"sample_interval": "s", "start": "m, m, degree", "heading_drift": "rad",
                    "seed": ""}
_CALIBRATION_KEYS = {"f": "Hz", "a": "m s-2", "max_periods": ""}
_PLAN_KEYS = {"acceleration": "m s-2", "forward": "Hz", "backward": "Hz", "left": "Hz",
              "right": "Hz", "waypoints": "m", "start": "m, m, degree",
              "heading_drift": "rad", "realisations": "", "seed": "", "sample_interval": "s"}
_KIND_TABLES = {"trajectory": ("segment", "trajectory"), "calibration": ("calibration",),
                "plan": ("plan",)}


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
        The kind's own table(s), validated, in SI units (angles in rad).
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
                "options": _jsonable(self.options)}

    @property
    def sha256(self) -> str:
        """Hash of the canonical spec: comments and key order do not change it."""
        text = json.dumps(self.canonical, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def is_scene_file(path: str | Path) -> bool:
    """True if ``path`` is a TOML file with a ``[scene]`` table (not a study spec)."""
    try:
        raw = tomllib.loads(Path(path).read_text())
    except (OSError, tomllib.TOMLDecodeError):
        return False
    return "scene" in raw


def load_scene(path: str | Path) -> SceneSpec:
    """Read and validate a scene spec file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as err:
        raise SceneError(f"{path}: cannot read the scene spec: {err}") from None
    return parse_scene(text, str(path))


def _keys(table: Any, where: str, allowed: dict[str, Any], path: str,
          required: tuple[str, ...] = ()) -> dict[str, Any]:
    if not isinstance(table, dict):
        raise SceneError(f"{path}: [{where}] must be a table")
    for key in table:
        if key not in allowed:
            raise SceneError(
                f"{path}: unknown key {key!r} in [{where}]; allowed: {', '.join(sorted(allowed))}"
            )
    for key in required:
        if key not in table:
            raise SceneError(f"{path}: [{where}] needs {key!r}")
    return table


def _number(table: dict[str, Any], key: str, where: str, path: str, *, low: float = -math.inf,
            high: float = math.inf, low_open: bool = False, units: str = "") -> float:
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SceneError(f"{path}: [{where}] {key} must be a finite number, got {value!r}")
    if value < low or value > high or (low_open and value == low):
        bracket = "(" if low_open else "["
        raise SceneError(
            f"{path}: [{where}] {key} = {value!r}{' ' + units if units else ''} is out of "
            f"range; allowed: {bracket}{low}, {high}]"
        )
    return float(value)


def _axis(table: dict[str, Any], key: str, where: str, path: str) -> np.ndarray:
    value = table[key]
    if isinstance(value, dict):
        if set(value) == {"values"} and isinstance(value["values"], list) and value["values"]:
            out = np.array(value["values"], dtype=float)
        elif set(value) == {"start", "stop", "num"}:
            num = value["num"]
            if isinstance(num, bool) or not isinstance(num, int) or num < 1:
                raise SceneError(f"{path}: [{where}] {key}.num must be an integer >= 1")
            out = np.linspace(float(value["start"]), float(value["stop"]), num)
        else:
            raise SceneError(f"{path}: [{where}] {key} must be {{start, stop, num}} or "
                             "{values = [...]}")
    else:
        raise SceneError(f"{path}: [{where}] {key} must be {{start, stop, num}} or "
                         "{values = [...]}")
    if not np.all(np.isfinite(out)) or np.any(out <= 0.0):
        raise SceneError(f"{path}: [{where}] {key} values must be finite and > 0")
    return out


def _pose(value: Any, where: str, path: str) -> tuple[float, float, float]:
    if (not isinstance(value, list) or len(value) != 3
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)):
        raise SceneError(f"{path}: [{where}] start must be [x (m), y (m), heading (degree)]")
    return float(value[0]), float(value[1]), math.radians(float(value[2]))


def parse_scene(text: str, path: str = "<string>") -> SceneSpec:
    """Validate a scene spec's text."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{path}: not valid TOML: {err}") from None
    for key in raw:
        if key not in _TOP:
            raise SceneError(f"{path}: unknown table {key!r}; allowed: {', '.join(sorted(_TOP))}")
    scene = _keys(raw.get("scene"), "scene", _SCENE_KEYS, path, ("name", "kind"))
    kind = scene["kind"]
    if kind not in SCENE_KINDS:
        raise SceneError(f"{path}: [scene] kind = {kind!r}; allowed: {', '.join(SCENE_KINDS)}")
    for table in {"segment", "trajectory", "calibration", "plan"} - set(_KIND_TABLES[kind]):
        if table in raw:
            raise SceneError(f"{path}: [{table}] does not belong to a {kind!r} scene; "
                             f"a {kind!r} scene takes {', '.join(_KIND_TABLES[kind])}")
    disk_table = _keys(raw.get("disk"), "disk", _DISK_KEYS, path, ("radius", "cs"))
    plates_raw = raw.get("plate")
    if not isinstance(plates_raw, list) or not plates_raw:
        raise SceneError(f"{path}: at least one [[plate]] is needed")
    plates = []
    for i, entry in enumerate(plates_raw):
        where = f"plate #{i + 1}"
        table = _keys(entry, where, _PLATE_KEYS, path, ("f0", "Q", "alpha", "M"))
        try:
            plates.append(Plate(
                f0=table["f0"], Q=table["Q"], alpha=table["alpha"], M=table["M"],
                direction=table.get("direction", 0.0),
                attachment=tuple(table.get("attachment", (0.0, 0.0))),
                name=str(table.get("name", f"plate{i + 1}")),
            ))
        except (TypeError, ValueError) as err:
            raise SceneError(f"{path}: [[plate]] #{i + 1}: {err}") from None
    try:
        disk = Disk(plates=tuple(plates), **disk_table)
    except (TypeError, ValueError) as err:
        raise SceneError(f"{path}: [disk]: {err}") from None
    integrator = _keys(raw.get("integrator", {}), "integrator", _INTEGRATOR_KEYS, path)
    tolerance = 1e-9
    if "tolerance" in integrator:
        tolerance = _number(integrator, "tolerance", "integrator", path, low=0.0, high=1e-3,
                            low_open=True)
    slaving = 1e-4
    if "slaving" in integrator:
        slaving = _number(integrator, "slaving", "integrator", path, low=0.0, high=0.1,
                          low_open=True)
    options = _kind_options(kind, raw, path)
    return SceneSpec(
        name=str(scene["name"]), kind=kind, title=str(scene.get("title", scene["name"])),
        description=str(scene.get("description", "")), disk=disk,
        settings=IntegratorSettings(tolerance=tolerance), slaving=slaving, options=options,
        text=text, path=path,
    )


def _kind_options(kind: str, raw: dict[str, Any], path: str) -> dict[str, Any]:
    if kind == "trajectory":
        segments = raw.get("segment")
        if not isinstance(segments, list) or not segments:
            raise SceneError(f"{path}: a trajectory scene needs [[segment]] tables "
                             "(label, f [Hz], a [m s-2], duration [s])")
        rows = []
        for i, entry in enumerate(segments):
            where = f"segment #{i + 1}"
            table = _keys(entry, where, _SEGMENT_KEYS, path, ("f", "a", "duration"))
            rows.append({
                "label": str(table.get("label", f"segment {i + 1}")),
                "f": _number(table, "f", where, path, low=0.0, low_open=True, units="Hz"),
                "a": _number(table, "a", where, path, low=0.0, units="m s-2"),
                "duration": _number(table, "duration", where, path, low=0.0, low_open=True,
                                    units="s"),
            })
        table = _keys(raw.get("trajectory", {}), "trajectory", _TRAJECTORY_KEYS, path)
        return {
            "segments": rows,
            "sample_interval": _number(table, "sample_interval", "trajectory", path, low=0.0,
                                       low_open=True, units="s")
            if "sample_interval" in table else 0.05,
            "start": _pose(table["start"], "trajectory", path) if "start" in table
            else (0.0, 0.0, math.pi / 2),
            "heading_drift": _number(table, "heading_drift", "trajectory", path, low=0.0,
                                     units="rad") if "heading_drift" in table else 0.0,
            "seed": int(table.get("seed", 0)),
        }
    if kind == "calibration":
        table = _keys(raw.get("calibration"), "calibration", _CALIBRATION_KEYS, path, ("f", "a"))
        max_periods = table.get("max_periods", 400)
        if isinstance(max_periods, bool) or not isinstance(max_periods, int) or max_periods < 2:
            raise SceneError(f"{path}: [calibration] max_periods must be an integer >= 2")
        return {"f": _axis(table, "f", "calibration", path),
                "a": _axis(table, "a", "calibration", path), "max_periods": max_periods}
    table = _keys(raw.get("plan"), "plan", _PLAN_KEYS, path,
                  ("acceleration", "waypoints", *COMMANDS))
    waypoints = table["waypoints"]
    if (not isinstance(waypoints, list) or not waypoints
            or not all(isinstance(p, list) and len(p) == 2 for p in waypoints)):
        raise SceneError(f"{path}: [plan] waypoints must be a list of [x, y] pairs (m)")
    points = np.array(waypoints, dtype=float)
    if not np.all(np.isfinite(points)):
        raise SceneError(f"{path}: [plan] waypoints must be finite")
    realisations = table.get("realisations", 4)
    if isinstance(realisations, bool) or not isinstance(realisations, int) or realisations < 0:
        raise SceneError(f"{path}: [plan] realisations must be an integer >= 0")
    return {
        "acceleration": _number(table, "acceleration", "plan", path, low=0.0, low_open=True,
                                units="m s-2"),
        "frequencies": {name: _number(table, name, "plan", path, low=0.0, low_open=True,
                                      units="Hz") for name in COMMANDS},
        "waypoints": points,
        "start": _pose(table["start"], "plan", path) if "start" in table else (0.0, 0.0, 0.0),
        "heading_drift": _number(table, "heading_drift", "plan", path, low=0.0, units="rad")
        if "heading_drift" in table else 0.1,
        "realisations": realisations,
        "seed": int(table.get("seed", 0)),
        "sample_interval": _number(table, "sample_interval", "plan", path, low=0.0,
                                   low_open=True, units="s")
        if "sample_interval" in table else 0.05,
    }


# ---------------------------------------------------------------------------
# Running


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
MOTION_STATUS = tuple(s.name.lower() for s in Status)[:5]


def _heading_noise(drift: float, disk: Disk) -> float:
    """Diffusion [rad m^-1/2] giving ``drift`` rad of heading spread per diameter slid."""
    return drift / math.sqrt(disk.diameter)


def _run_trajectory(spec: SceneSpec) -> tuple[dict[str, xr.Variable], dict[str, Any]]:
    options = spec.options
    rows = options["segments"]
    schedule = Schedule(np.array([r["f"] for r in rows]), np.array([r["a"] for r in rows]),
                        np.array([r["duration"] for r in rows]))
    end = float(schedule.ends[-1])
    grid = np.arange(0.0, end, options["sample_interval"])
    out_t = np.unique(np.concatenate([grid, schedule.starts, [end]]))
    run = simulate_planar(
        spec.disk, schedule, initial_state=rest_state(spec.disk, options["start"]),
        output_times=out_t, settings=spec.settings,
        heading_noise=_heading_noise(options["heading_drift"], spec.disk),
        rng=options["seed"], slaving=spec.slaving,
    )
    t = run.time
    index = np.clip(np.searchsorted(schedule.ends, t, side="right"), 0, len(rows) - 1)
    index[t == end] = len(rows) - 1
    summary = {k: np.zeros(len(rows)) for k in ("fwd", "lat", "turn", "path")}
    status = np.zeros(len(rows), dtype=np.int8)
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
        c, s = math.cos(run.heading[i0]), math.sin(run.heading[i0])
        summary["fwd"][j] = c * dx + s * dy
        summary["lat"][j] = -s * dx + c * dy
        summary["turn"][j] = run.heading[i1] - run.heading[i0]
        summary["path"][j] = run.path[i1] - run.path[i0]
    variables = {
        "x": _variable("t", run.x, "m", "x position of the disk's centre"),
        "y": _variable("t", run.y, "m", "y position of the disk's centre"),
        "heading": _variable("t", run.heading, "rad",
                             "heading, counterclockwise from the x axis (unwrapped)"),
        "path_length": _variable("t", run.path, "m", "distance slid since the start"),
        "slipping": _flag("t", run.slipping.astype(np.int8), ("stuck", "slipping"),
                          "contact state at the sample"),
        "segment_index": _variable("t", index.astype(np.int32), None,
                                   "segment of the schedule the sample belongs to"),
        "segment_label": _variable("segment", np.array([r["label"] for r in rows], dtype=str),
                                   None, "command of the segment"),
        "frequency": _variable("segment", schedule.frequency, "Hz", "drive frequency"),
        "acceleration": _variable("segment", schedule.acceleration, "m s-2",
                                  "drive acceleration amplitude"),
        "duration": _variable("segment", schedule.duration, "s", "segment duration"),
        "start_time": _variable("segment", schedule.starts, "s", "segment start"),
        "end_time": _variable("segment", schedule.ends, "s", "segment end"),
        "forward_displacement": _variable(
            "segment", summary["fwd"], "m",
            "displacement along the heading at the segment's start"),
        "lateral_displacement": _variable(
            "segment", summary["lat"], "m",
            "displacement to the left of the heading at the segment's start"),
        "heading_change": _variable("segment", summary["turn"], "rad",
                                    "heading change over the segment"),
        "segment_path_length": _variable("segment", summary["path"], "m",
                                         "distance slid in the segment"),
        "segment_status": _flag("segment", status, SEGMENT_STATUS, "how the segment ended"),
        "edge_contact_margin": _variable(
            "segment", [contact_margins(spec.disk, r["f"], r["a"])[0] for r in rows], "1",
            "rim contact margin of the segment's drive", comment=RIM_NOTE),
    }
    coords = {"t": _variable("t", t, "s", "time since the drive started"),
              "segment": _variable("segment", np.arange(len(rows)), None, "segment number")}
    attrs = {"study_outcome": run.outcome, "study_end_time": run.end_time,
             "study_steps": run.steps, "study_slips": run.slips}
    return {**coords, **variables}, attrs


def _run_calibration(spec: SceneSpec) -> tuple[dict[str, xr.Variable], dict[str, Any]]:
    f = spec.options["f"]
    a = spec.options["a"]
    points = [(i, j) for i in range(f.size) for j in range(a.size)]

    def one(point):
        i, j = point
        return periodic_motion(spec.disk, float(f[i]), float(a[j]), settings=spec.settings,
                               max_periods=spec.options["max_periods"], slaving=spec.slaving)

    # The kernel releases the GIL: threads use every core without copying the disk.
    with ThreadPoolExecutor() as pool:
        motions = list(pool.map(one, points))
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
        "f": _variable("f", f, "Hz", "drive frequency"),
        "a": _variable("a", a, "m s-2", "drive acceleration amplitude"),
        "forward_speed": _variable(dims, fields["forward_speed"], "m s-1",
                                   "steady mean velocity along the heading"),
        "lateral_speed": _variable(dims, fields["lateral_speed"], "m s-1",
                                   "steady mean velocity to the left of the heading"),
        "turn_rate": _variable(dims, fields["turn_rate"], "rad s-1",
                               "steady mean angular velocity, counterclockwise positive"),
        "slips_per_period": _variable(dims, fields["slips_per_period"], "1",
                                      "slips starting per drive period"),
        "stuck_fraction": _variable(dims, fields["stuck_fraction"], "1",
                                    "fraction of the period stuck"),
        "status": _flag(dims, status, MOTION_STATUS, "outcome at the point"),
        "periods": _variable(dims, periods, "1", "drive periods integrated"),
        "orbit_period": _variable(dims, orbit, "1",
                                  "drive periods after which the motion repeats (0: none)"),
        "edge_contact_margin": _variable(dims, rim, "1", "rim contact margin",
                                         comment=RIM_NOTE),
    }
    return variables, {}


def _run_plan(spec: SceneSpec) -> tuple[dict[str, xr.Variable], dict[str, Any]]:
    options = spec.options
    disk = spec.disk
    try:
        commands = calibrate_commands(disk, options["frequencies"], options["acceleration"],
                                      settings=spec.settings, slaving=spec.slaving)
        waypoints = options["waypoints"]
        # The blind strategies' legs do not depend on the noise: plan them once.
        routes = {
            "calibration": plan_route(options["start"], waypoints, commands),
            "open_loop": refined_route(disk, options["start"], waypoints, commands,
                                       spec.settings, slaving=spec.slaving),
            "closed_loop": None,
        }
    except PlanError as err:
        raise SceneError(f"{spec.path}: [plan]: {err}") from None
    noise = _heading_noise(options["heading_drift"], disk)
    strategies = STRATEGIES
    count = options["realisations"] + 1
    runs = {}
    for s, strategy in enumerate(strategies):
        for r in range(count):
            runs[s, r] = run_plan(
                disk, options["start"], waypoints, commands, strategy=strategy,
                heading_noise=noise if r > 0 else 0.0, seed=options["seed"] * 1000 + r,
                settings=spec.settings, sample_interval=options["sample_interval"],
                slaving=spec.slaving, route=routes[strategy],
            )
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
        "t": _variable("t", t, "s", "time since the drive started"),
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
        "waypoint_x": _variable("waypoint", waypoints[:, 0], "m", "waypoint x"),
        "waypoint_y": _variable("waypoint", waypoints[:, 1], "m", "waypoint y"),
        "planned_x": _variable("waypoint", planned[:, 0], "m",
                               "x where the calibrated plan predicts the leg ends"),
        "planned_y": _variable("waypoint", planned[:, 1], "m",
                               "y where the calibrated plan predicts the leg ends"),
        "x": _variable(dims, paths["x"], "m", "x position of the disk's centre"),
        "y": _variable(dims, paths["y"], "m", "y position of the disk's centre"),
        "heading": _variable(dims, paths["heading"], "rad", "heading (unwrapped)"),
        "miss_distance": _variable(("strategy", "realisation", "waypoint"), miss, "m",
                                   "distance from the waypoint at the end of its leg"),
        "run_status": _flag(("strategy", "realisation"), outcome, SEGMENT_STATUS,
                            "how the run ended"),
        "realisation_heading_drift": _variable(
            "realisation", np.where(np.arange(count) > 0, options["heading_drift"], 0.0),
            "rad", "heading spread per disk diameter slid"),
        "segment_label": _variable("segment", np.array(plan_run.labels, dtype=str), None,
                                   "command of the segment (the open-loop plan)"),
        "frequency": _variable("segment", plan_run.schedule.frequency, "Hz", "drive frequency"),
        "acceleration": _variable("segment", plan_run.schedule.acceleration, "m s-2",
                                  "drive acceleration amplitude"),
        "duration": _variable("segment", plan_run.schedule.duration, "s", "segment duration"),
    }
    for name, command in commands.items():
        variables[f"command_{name}"] = xr.Variable((), command.frequency, {
            "units": "Hz", "long_name": f"{name} command frequency",
            "forward_speed": command.forward_speed, "lateral_speed": command.lateral_speed,
            "turn_rate": command.turn_rate,
        })
    attrs = {"start_x": options["start"][0], "start_y": options["start"][1],
             "start_heading": options["start"][2]}
    return variables, attrs


_RUNNERS = {"trajectory": _run_trajectory, "calibration": _run_calibration, "plan": _run_plan}


def scene_dataset(spec: SceneSpec) -> xr.Dataset:
    """Compute a scene and return its labelled dataset (with provenance attributes)."""
    from study.provenance import (
        environment,
        git_state,
        package_version,
        scene_code_sha256,
        scene_fingerprint,
        utc_now,
    )
    from study.store import PAPER_REFERENCE, SCENE_SCHEMA

    started = time.perf_counter()
    started_utc = utc_now()
    variables, extra = _RUNNERS[spec.kind](spec)
    finished = utc_now()
    git = git_state()
    disk = spec.disk
    provenance = {
        "result_schema": SCENE_SCHEMA,
        "scene": {"name": spec.name, "kind": spec.kind, "spec_path": spec.path,
                  "spec_sha256": spec.sha256, "canonical_spec": spec.canonical},
        "code": {"code_sha256": scene_code_sha256(),
                 "fingerprint": scene_fingerprint(spec.sha256)},
        "package": {"name": "study", "version": package_version(), **git},
        "environment": environment(),
        "run": {"started_utc": started_utc, "finished_utc": finished,
                "wall_seconds": time.perf_counter() - started},
    }
    attrs = {
        "Conventions": "CF-1.11, ACDD-1.3",
        "title": spec.title,
        "summary": spec.description or (
            f"Steering scene '{spec.name}' ({spec.kind}) of a rigid disk with resonant plates "
            "on a vertically shaken table: planar stick-slip with an ellipsoidal limit "
            "surface, integrated with events (study.planar)."),
        "keywords": "stick-slip, friction, locomotion, steering, limit surface, resonance",
        "id": f"{spec.name}-{spec.sha256[:16]}",
        "naming_authority": "study",
        "source": "study.planar: Dormand-Prince 5(4) time integration with events of the "
                  "planar disk with resonant plates",
        "processing_level": "model output",
        "references": PAPER_REFERENCE,
        "comment": "SI units; angles in rad, counterclockwise positive; the body frame's x "
                   "axis is the heading.",
        "history": f"{finished} study run {spec.path}",
        "date_created": finished,
        "study_result_schema": SCENE_SCHEMA,
        "study_scene_kind": spec.kind,
        "study_name": spec.name,
        "study_spec": spec.text,
        "study_spec_path": spec.path,
        "study_spec_sha256": spec.sha256,
        "study_code_sha256": scene_code_sha256(),
        "study_fingerprint": scene_fingerprint(spec.sha256),
        "study_version": package_version(),
        "git_commit": str(git["git_commit"]),
        "git_dirty": str(git["git_dirty"]).lower(),
        "provenance": json.dumps(provenance, sort_keys=True),
        "disk_radius": disk.radius,
        "disk_cs": disk.cs,
        "disk_ck": disk.ck,
        "disk_g": disk.g,
        "disk_gyration_radius": disk.gyration_radius,
        "disk_friction_length": disk.friction_length,
        "integrator_tolerance": spec.settings.tolerance,
        "integrator_slaving": spec.slaving,
        **extra,
    }
    plate_vars = {
        "plate_name": _variable("plate", np.array([p.name for p in disk.plates], dtype=str),
                                None, "plate"),
        "plate_f0": _variable("plate", [p.f0 for p in disk.plates], "Hz", "plate resonance"),
        "plate_Q": _variable("plate", [p.Q for p in disk.plates], "1", "plate quality factor"),
        "plate_alpha": _variable("plate", [p.alpha for p in disk.plates], "degree",
                                 "plate tilt from the horizontal"),
        "plate_M": _variable("plate", [p.M for p in disk.plates], "1",
                             "plate modal mass over the structure's mass"),
        "plate_direction": _variable("plate", [p.direction for p in disk.plates], "degree",
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


def scene_up_to_date(spec: SceneSpec, output: Path) -> bool:
    """True if ``output`` holds this scene computed by the current code."""
    from study.provenance import scene_fingerprint

    if not output.is_file():
        return False
    try:
        with xr.open_dataset(output, engine="netcdf4") as dataset:
            return dataset.attrs.get("study_fingerprint") == scene_fingerprint(spec.sha256)
    except Exception:  # unreadable: recompute
        return False


def run_scene(spec: SceneSpec | str | Path, output: str | Path, *, force: bool = False
              ) -> tuple[Path, bool, float]:
    """Compute a scene and write its result atomically.

    Returns
    -------
    (path, up_to_date, wall_seconds)
    """
    from study.store import write_atomic

    started = time.perf_counter()
    if not isinstance(spec, SceneSpec):
        spec = load_scene(spec)
    output = Path(output)
    if not force and scene_up_to_date(spec, output):
        output.touch()
        return output, True, time.perf_counter() - started
    from study.store import exclusive as _exclusive

    output.parent.mkdir(parents=True, exist_ok=True)
    # One writer per result file (the write itself is atomic: temporary, check, rename).
    with _exclusive(output):
        dataset = scene_dataset(spec)
        write_atomic(dataset, output)
    return output, False, time.perf_counter() - started
