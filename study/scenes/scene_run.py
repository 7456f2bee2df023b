"""Running a scene: a trajectory, a calibration or a plan of the planar disk computed
into its labelled variables (:func:`scene_compute`), and how much work that is, for
progress (:func:`scene_work`).

The variables are laid out as the result file holds them; the file's attributes and
the dataset are :mod:`study.scenes.scene_kind`'s. A plan's size is checked here, once
its route is calibrated and before any flight is simulated.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, as_completed
from typing import Any

import numpy as np
import xarray as xr

from study.model.disk import Disk
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
from study.scenes.planar_model import contact_margins, periodic_motion, rest_state
from study.scenes.planner import (
    STRATEGIES,
    PlanError,
    calibrate_commands,
    plan_route,
    refined_route,
    run_plan,
)
from study.scenes.scene_spec import MAX_SCENE_SAMPLES, SceneError, SceneSpec
from study.solvers.integrator import Schedule
from study.solvers.planar import simulate_planar

__all__ = [
    "MAX_PLAN_DRIVE_SECONDS",
    "Report",
    "scene_compute",
    "scene_var",
    "scene_work",
]

#: Simulated drive time of a plan at most [s]: the planned flight times the flights
#: simulated (every strategy's run per realisation, and up to
#: :data:`_CORRECTIONS` corrective flights for the open-loop route and for each
#: closed-loop run). The workflow needs 38 s x 45 = 1.7e3 s, 20-70 s of computing
#: on a 2-core machine; 2e4 s is 11 times that.
MAX_PLAN_DRIVE_SECONDS = 20_000.0
#: Correction iterations of the planner's refined legs (its default, used here).
_CORRECTIONS = 5


def scene_var(dims: Any, values: Any, units: str | None, long_name: str,
              **attrs: Any) -> xr.Variable:
    """A variable of a scene's result with its CF attributes.

    Parameters
    ----------
    dims : str or tuple of str
        Its dimensions.
    values : array_like
    units : str or None
        Its ``units`` (None: none, for labels, counts and indices).
    long_name : str
    **attrs
        Further attributes (``comment``...).

    Returns
    -------
    xarray.Variable
    """
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
        "x": scene_var("t", run.x, METRE, "x position of the disk's centre"),
        "y": scene_var("t", run.y, METRE, "y position of the disk's centre"),
        "heading": scene_var("t", run.heading, DEGREE,
                             "heading, counterclockwise from the x axis (unwrapped)"),
        "path_length": scene_var("t", run.path, METRE, "distance slid since the start"),
        "slipping": _flag("t", run.slipping.astype(np.int8), ("stuck", "slipping"),
                          "contact state at the sample"),
        "segment_index": scene_var("t", index.astype(np.int32), None,
                                   "segment of the schedule the sample belongs to"),
        "segment_label": scene_var("segment", np.array([r["label"] for r in rows], dtype=str),
                                   None, "command of the segment"),
        "frequency": scene_var("segment", schedule.frequency, HERTZ, "drive frequency"),
        "acceleration": scene_var("segment", schedule.acceleration, METRE_PER_SECOND_SQUARED,
                                  "drive acceleration amplitude"),
        "duration": scene_var("segment", schedule.duration, SECOND, "segment duration"),
        "start_time": scene_var("segment", schedule.starts, SECOND, "segment start"),
        "end_time": scene_var("segment", schedule.ends, SECOND, "segment end"),
        "forward_displacement": scene_var(
            "segment", summary["fwd"], METRE,
            "displacement along the heading at the segment's start"),
        "lateral_displacement": scene_var(
            "segment", summary["lat"], METRE,
            "displacement to the left of the heading at the segment's start"),
        "heading_change": scene_var("segment", summary["turn"], DEGREE,
                                    "heading change over the segment"),
        "segment_path_length": scene_var("segment", summary["path"], METRE,
                                         "distance slid in the segment"),
        "segment_status": _flag("segment", status, SEGMENT_STATUS, "how the segment ended"),
        "edge_contact_margin": scene_var(
            "segment", [contact_margins(spec.disk, r["f"], r["a"])[0] for r in rows],
            DIMENSIONLESS,
            "rim contact margin of the segment's drive", comment=RIM_NOTE),
    }
    coords = {"t": scene_var("t", t, SECOND, "time since the drive started"),
              "segment": scene_var("segment", np.arange(len(rows)), None, "segment number")}
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
        "f": scene_var("f", f, HERTZ, "drive frequency"),
        "a": scene_var("a", a, METRE_PER_SECOND_SQUARED, "drive acceleration amplitude"),
        "forward_speed": scene_var(dims, fields["forward_speed"], METRE_PER_SECOND,
                                   "steady mean velocity along the heading"),
        "lateral_speed": scene_var(dims, fields["lateral_speed"], METRE_PER_SECOND,
                                   "steady mean velocity to the left of the heading"),
        "turn_rate": scene_var(dims, fields["turn_rate"], DEGREE_PER_SECOND,
                               "steady mean angular velocity, counterclockwise positive"),
        "slips_per_period": scene_var(dims, fields["slips_per_period"], DIMENSIONLESS,
                                      "slips starting per drive period"),
        "stuck_fraction": scene_var(dims, fields["stuck_fraction"], DIMENSIONLESS,
                                    "fraction of the period stuck"),
        "status": _flag(dims, status, MOTION_STATUS, "outcome at the point"),
        "periods": scene_var(dims, periods, DIMENSIONLESS, "drive periods integrated"),
        "orbit_period": scene_var(dims, orbit, DIMENSIONLESS,
                                  "drive periods after which the motion repeats (0: none)"),
        "edge_contact_margin": scene_var(dims, rim, DIMENSIONLESS, "rim contact margin",
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
        "t": scene_var("t", t, SECOND, "time since the drive started"),
        # Strings name the strategies in an auxiliary coordinate: a string-valued
        # coordinate variable is not CF (coordinate variables must be monotonic).
        "strategy_name": scene_var("strategy", np.array(strategies, dtype=str), None,
                              "calibration: legs from the calibration alone, flown blind; "
                              "open_loop: legs corrected in the noise-free model, flown "
                              "blind; closed_loop: each leg planned and corrected from the "
                              "pose reached"),
        "realisation": scene_var("realisation", np.arange(count), None,
                                 "0: without heading noise; others: with"),
        "waypoint": scene_var("waypoint", np.arange(len(waypoints)), None, "waypoint number"),
        "waypoint_x": scene_var("waypoint", waypoints[:, 0], METRE, "waypoint x"),
        "waypoint_y": scene_var("waypoint", waypoints[:, 1], METRE, "waypoint y"),
        "planned_x": scene_var("waypoint", planned[:, 0], METRE,
                               "x where the calibrated plan predicts the leg ends"),
        "planned_y": scene_var("waypoint", planned[:, 1], METRE,
                               "y where the calibrated plan predicts the leg ends"),
        "x": scene_var(dims, paths["x"], METRE, "x position of the disk's centre"),
        "y": scene_var(dims, paths["y"], METRE, "y position of the disk's centre"),
        "heading": scene_var(dims, paths["heading"], DEGREE,
                             "heading, counterclockwise from the x axis (unwrapped)"),
        "miss_distance": scene_var(("strategy", "realisation", "waypoint"), miss, METRE,
                                   "distance from the waypoint at the end of its leg"),
        "run_status": _flag(("strategy", "realisation"), outcome, SEGMENT_STATUS,
                            "how the run ended"),
        "realisation_heading_drift": scene_var(
            "realisation", np.where(np.arange(count) > 0, options["heading_drift_deg"], 0.0),
            "degree", "heading spread per disk diameter slid"),
        "segment_label": scene_var("segment", np.array(plan_run.labels, dtype=str), None,
                                   "command of the segment (the open-loop plan)"),
        "frequency": scene_var("segment", plan_run.schedule.frequency, HERTZ, "drive frequency"),
        "acceleration": scene_var("segment", plan_run.schedule.acceleration,
                                  METRE_PER_SECOND_SQUARED, "drive acceleration amplitude"),
        "duration": scene_var("segment", plan_run.schedule.duration, SECOND, "segment duration"),
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


def scene_compute(spec: SceneSpec, report: Report | None = None
                  ) -> tuple[dict[str, xr.Variable], dict[str, Any]]:
    """Run a scene: its variables and the attributes its run found (how it ended)."""
    return _RUNNERS[spec.kind](spec, report or _ignore)
