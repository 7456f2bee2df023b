"""Waypoint planner for the steering disk: frequency schedules from the calibration.

The calibration gives, for each command (a drive frequency at the operating
acceleration), the disk's steady body-frame motion: forward and lateral speed and
turn rate. Under a constant command the disk moves along a circular arc, so where a
segment ends is known in closed form (:func:`arc_displacement`). A leg to a waypoint
is one turn (left or right command) and one straight command (forward or backward),
the pair chosen to take the least time; the turn's duration and the straight
command's duration are solved so that the predicted arc ends on the waypoint.

Past the paper: the paper steers by hand. Between command switches the plate modes
go through transients the calibration does not know, and the measured heading drift
is random; :func:`run_plan` shows how much both cost by simulating the schedule.

Angles: every heading, turn and turn rate a caller passes or gets back is in degree
(degree s-1), as in :mod:`study.scenes.planar_model`; the arc geometry inside works in radians
(the private helpers ``_arc``, ``_rate``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from study.model.disk import Disk
from study.model.inputs import as_real_array, bounded_integer, bounded_number, instance_of
from study.model.status import Status
from study.model.units import METRE, SECOND
from study.scenes.planar_model import periodic_motion, rest_state
from study.solvers.integrator import IntegratorSettings, Schedule
from study.solvers.planar import POSE_STATE, SLAVING, PlanarTrajectory, simulate_planar
from study.solvers.planar_periodic import PeriodicMotion

__all__ = [
    "COMMANDS",
    "MAX_PLAN_ITERATIONS",
    "STRATEGIES",
    "Command",
    "Leg",
    "PlanError",
    "PlanRun",
    "arc_displacement",
    "calibrate_commands",
    "check_commands",
    "plan_leg",
    "plan_route",
    "refined_legs",
    "refined_route",
    "run_plan",
]

#: Command names: the two straight commands and the two turns.
COMMANDS = ("forward", "backward", "left", "right")


@dataclass(frozen=True)
class Command:
    """One drive command and the steady motion it produces.

    Attributes
    ----------
    name : str
    frequency : float
        Drive frequency [Hz].
    acceleration : float
        Drive acceleration amplitude [m s-2].
    forward_speed, lateral_speed : float
        Steady body-frame velocity [m s-1].
    turn_rate : float
        Steady angular velocity, counterclockwise positive [degree s-1].
    """

    name: str
    frequency: float
    acceleration: float
    forward_speed: float
    lateral_speed: float
    turn_rate: float


@dataclass(frozen=True)
class Leg:
    """A planned leg: a turn then a straight command (durations [s]), and the predicted
    pose ``(x [m], y [m], heading [degree])`` after it."""

    turn: str
    turn_duration: float
    straight: str
    straight_duration: float
    predicted_pose: tuple[float, float, float]


class PlanError(ValueError):
    """The commands cannot reach a waypoint (e.g. a command does not move the disk)."""


#: Iterations of :func:`plan_leg`'s search of one turn at most (its default is 100).
MAX_PLAN_ITERATIONS = 100_000


def _point(name: str, values: object, size: int) -> tuple[float, ...]:
    """``values`` as ``size`` finite floats, else an error naming ``name``."""
    array = as_real_array(name, values)
    if array.shape != (size,) or not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be {size} finite numbers, got {_shown(values)}")
    return tuple(float(v) for v in array)


def _shown(values: object) -> str:
    text = repr(values)
    return text if len(text) <= 80 else text[:77] + "..."


def check_commands(commands: object) -> dict[str, Command]:
    """``commands`` if it maps every name of :data:`COMMANDS` to a :class:`Command`,
    else an error naming the argument and what is missing."""
    instance_of("commands", commands, Mapping, "a dict of study.scenes.planner.Command")
    missing = [name for name in COMMANDS if name not in commands]  # type: ignore[operator]
    if missing:
        raise ValueError(f"commands must hold {', '.join(COMMANDS)}; missing: "
                         f"{', '.join(missing)}")
    for name in COMMANDS:
        instance_of(f"commands[{name!r}]", commands[name],  # type: ignore[index]
                    Command, "a study.scenes.planner.Command")
    return dict(commands)  # type: ignore[call-overload]


def calibrate_commands(disk: Disk, frequencies: dict[str, float], acceleration: float,
                       settings: IntegratorSettings | None = None,
                       slaving: float = SLAVING) -> dict[str, Command]:
    """Steady motion of each command from the model.

    :func:`study.scenes.planar_model.periodic_motion` gives each.

    Raises
    ------
    PlanError
        If a command's point is outside the model (lift-off, no periodic orbit) or
        does not do its job (a straight command that does not translate, a turn that
        does not turn, two turns the same way).
    """
    commands = {}
    for name in COMMANDS:
        if name not in frequencies:
            raise PlanError(f"no frequency for command {name!r}; commands: {COMMANDS}")
        motion: PeriodicMotion = periodic_motion(disk, frequencies[name], acceleration,
                                                 settings=settings, slaving=slaving)
        if motion.status not in (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING):
            raise PlanError(
                f"command {name!r} ({frequencies[name]} Hz, {acceleration} m s-2) does not "
                f"move the disk: status {Status(motion.status).name}"
            )
        commands[name] = Command(name, float(frequencies[name]), float(acceleration),
                                 motion.forward_speed, motion.lateral_speed, motion.turn_rate)
    if commands["forward"].forward_speed <= 0.0 or commands["backward"].forward_speed >= 0.0:
        raise PlanError(
            "the forward command must move the disk forward and the backward command "
            f"backward; calibrated speeds {commands['forward'].forward_speed:.3g} and "
            f"{commands['backward'].forward_speed:.3g} m s-1"
        )
    if commands["left"].turn_rate <= 0.0 or commands["right"].turn_rate >= 0.0:
        raise PlanError(
            "the left command must turn the disk counterclockwise and the right command "
            f"clockwise; calibrated turn rates {commands['left'].turn_rate:.3g} and "
            f"{commands['right'].turn_rate:.3g} degree s-1"
        )
    return commands


def _rate(command: Command) -> float:
    """The command's turn rate [rad s-1]."""
    return math.radians(command.turn_rate)


def arc_displacement(command: Command, duration: float) -> tuple[float, float, float]:
    """Body-frame displacement ``(forward [m], left [m], turn [degree])`` after holding a
    command for ``duration`` [s] (a circular arc at constant body-frame velocity)."""
    instance_of("command", command, Command, "a study.scenes.planner.Command")
    duration = bounded_number("duration", duration, SECOND, lower=0.0)
    forward, left, turn = _arc(command, duration)
    return forward, left, math.degrees(turn)


def _arc(command: Command, duration: float) -> tuple[float, float, float]:
    """:func:`arc_displacement` with the turn in rad."""
    turn = _rate(command) * duration
    u, v = command.forward_speed, command.lateral_speed
    if abs(turn) < 1e-9:
        # Series of the arc for a tiny turn (avoids 0/0).
        return (duration * (u - v * turn / 2.0), duration * (v + u * turn / 2.0), turn)
    s, c = math.sin(turn), 1.0 - math.cos(turn)
    w = _rate(command)
    return ((u * s - v * c) / w, (u * c + v * s) / w, turn)


def _advance(pose: tuple[float, float, float], command: Command, duration: float
             ) -> tuple[float, float, float]:
    """Pose ``(x, y, heading [rad])`` after holding ``command`` from ``pose`` (rad)."""
    forward, left, turn = _arc(command, duration)
    x, y, heading = pose
    c, s = math.cos(heading), math.sin(heading)
    return (x + c * forward - s * left, y + s * forward + c * left, heading + turn)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _straight_time(command: Command, distance: float) -> float:
    """Time for the command's arc to reach ``distance`` from its start [s]."""
    speed = math.hypot(command.forward_speed, command.lateral_speed)
    guess = distance / speed
    rate = abs(_rate(command))
    if rate < 1e-12:
        return guess
    # The chord 2 (speed / w) |sin(w t / 2)| grows with t up to half a circle.
    ratio = distance * rate / (2.0 * speed)
    if ratio >= 1.0:
        raise PlanError(
            f"the {command.name!r} command veers on a circle of diameter "
            f"{2 * speed / rate:.3g} m and cannot reach {distance:.3g} m"
        )
    return 2.0 * math.asin(ratio) / rate


def _single_leg(pose: tuple[float, float, float], target: tuple[float, float],
                commands: dict[str, Command], iterations: int) -> Leg | None:
    """The fastest turn-then-straight pair from ``pose`` (heading in rad) to ``target``
    (None if no straight command's arc reaches it); its predicted pose in rad."""
    best: Leg | None = None
    best_time = math.inf
    for straight in ("forward", "backward"):
        command = commands[straight]
        turn_name, turn_duration = "left", 0.0
        start = pose
        try:
            # Fixed point: the turn moves the disk, which moves the heading needed.
            for _ in range(iterations):
                dx, dy = target[0] - start[0], target[1] - start[1]
                forward, left, _ = _arc(
                    command, _straight_time(command, math.hypot(dx, dy)))
                # Heading at which the arc from `start` ends on the target.
                change = _wrap(math.atan2(dy, dx) - math.atan2(left, forward) - pose[2])
                turn_name = "left" if change >= 0.0 else "right"
                previous, turn_duration = turn_duration, change / _rate(commands[turn_name])
                start = _advance(pose, commands[turn_name], turn_duration)
                if abs(turn_duration - previous) <= 1e-13 * (1.0 + abs(turn_duration)):
                    break
            duration = _straight_time(command, math.hypot(target[0] - start[0],
                                                          target[1] - start[1]))
        except PlanError:
            continue
        total = turn_duration + duration
        if total < best_time:
            best_time = total
            best = Leg(turn_name, turn_duration, straight, duration,
                       _advance(start, command, duration))
    return best


def plan_leg(pose: tuple[float, float, float], target: tuple[float, float],
             commands: dict[str, Command], iterations: int = 100) -> list[Leg]:
    """Turn-then-straight pairs from ``pose`` ``(x [m], y [m], heading [degree])`` to
    ``target`` ``(x [m], y [m])`` under the calibration.

    A straight command veers (the plates are not perfectly aligned in their effect):
    its path is an arc of a circle, so a target farther than a third of that circle's
    diameter is approached through intermediate points on the line to it, each
    reached by its own fastest pair.

    Raises
    ------
    ValueError, TypeError
        For a ``pose`` or ``target`` that is not finite numbers, ``commands`` without
        every command of :data:`COMMANDS`, ``iterations`` not an integer >= 1;
        :class:`PlanError` when no command reaches a point.
    """
    pose = _point("pose", pose, 3)
    target = _point("target", target, 2)
    commands = check_commands(commands)
    iterations = bounded_integer("iterations", iterations, 1, MAX_PLAN_ITERATIONS)
    forward = commands["forward"]
    diameter = 2.0 * math.hypot(forward.forward_speed, forward.lateral_speed) / max(
        abs(_rate(forward)), 1e-300)
    reach = diameter / 3.0
    legs: list[Leg] = []
    pose = (pose[0], pose[1], math.radians(pose[2]))  # rad inside
    for _ in range(10_000):
        dx, dy = target[0] - pose[0], target[1] - pose[1]
        distance = math.hypot(dx, dy)
        step = min(1.0, reach / distance) if distance > 0.0 else 1.0
        point = (pose[0] + step * dx, pose[1] + step * dy)
        leg = _single_leg(pose, point, commands, iterations)
        if leg is None:
            raise PlanError(f"no command reaches {point} from {pose[:2]}")
        pose = leg.predicted_pose
        legs.append(replace(leg, predicted_pose=(pose[0], pose[1], math.degrees(pose[2]))))
        if step == 1.0:
            return legs
    raise PlanError(f"target {target} not reached in 10000 legs")


def plan_route(start: tuple[float, float, float], waypoints: NDArray[np.float64],
               commands: dict[str, Command]) -> list[list[Leg]]:
    """Legs to every waypoint in turn, each planned from the previous prediction
    (``start`` and the predicted poses: ``(x [m], y [m], heading [degree])``)."""
    pose = _point("start", start, 3)
    commands = check_commands(commands)
    targets = as_real_array("waypoints", waypoints, METRE)
    if targets.ndim != 2 or targets.shape[1] != 2:
        raise ValueError(f"waypoints must be an (n, 2) array of (x, y) [m], got shape "
                         f"{targets.shape}")
    route = []
    for target in targets:
        legs = plan_leg(pose, (float(target[0]), float(target[1])), commands)
        route.append(legs)
        pose = legs[-1].predicted_pose
    return route


def _schedule(legs: list[Leg], commands: dict[str, Command], phase: float = 0.0
              ) -> tuple[Schedule | None, list[str]]:
    """The legs as a drive schedule starting at drive ``phase`` (None if all are
    shorter than :data:`_SHORTEST`), and the command of each segment."""
    frequency, acceleration, duration, labels = [], [], [], []
    for leg in legs:
        for name, span in ((leg.turn, leg.turn_duration), (leg.straight, leg.straight_duration)):
            if span <= _SHORTEST:
                continue
            frequency.append(commands[name].frequency)
            acceleration.append(commands[name].acceleration)
            duration.append(span)
            labels.append(name)
    if not labels:
        return None, labels
    return Schedule(np.array(frequency), np.array(acceleration), np.array(duration),
                    phase), labels


@dataclass(frozen=True)
class PlanRun:
    """A simulated plan: the path, where each leg ended (NaN for legs never flown: the
    run stopped, see ``outcome``), the distance missed and the schedule flown."""

    time: NDArray[np.float64]  # [s]
    x: NDArray[np.float64]  # [m]
    y: NDArray[np.float64]  # [m]
    heading: NDArray[np.float64]  # counterclockwise from the x axis, unwrapped [degree]
    leg_end: NDArray[np.float64]  # (waypoint, 2) position at each leg's end [m]
    miss_distance: NDArray[np.float64]  # (waypoint,) [m]
    schedule: Schedule | None
    labels: list[str]
    outcome: str


STRATEGIES = ("calibration", "open_loop", "closed_loop")

#: Below this a planned segment is dropped [s].
_SHORTEST = 1e-6


@dataclass(frozen=True)
class _Flight:
    """Legs flown from a state: the run (None if there was nothing to fly), the state
    and drive phase it ends at, and its schedule and commands."""

    run: PlanarTrajectory | None
    state: NDArray[np.float64]
    phase: float
    schedule: Schedule | None
    labels: list[str]


def _fly(disk: Disk, state: NDArray[np.float64], phase: float, legs: list[Leg],
         commands: dict[str, Command], settings: IntegratorSettings | None, slaving: float,
         *, sample_interval: float | None = None, heading_noise: float = 0.0,
         rng: np.random.Generator | None = None) -> _Flight:
    """Simulate ``legs`` from ``state`` at drive ``phase``; the table's phase and the
    plate modes carry over from leg to leg."""
    schedule, labels = _schedule(legs, commands, phase)
    if schedule is None:
        return _Flight(None, state, phase, None, labels)
    end = float(schedule.ends[-1])
    out_t = [end] if sample_interval is None else np.append(
        np.arange(0.0, end, sample_interval), end)
    run = simulate_planar(disk, schedule, initial_state=state, output_times=out_t,
                          settings=settings, heading_noise=heading_noise, rng=rng,
                          slaving=slaving)
    after = run.final_state.copy()
    after[len(POSE_STATE) - 1] = 0.0  # the path length counts per flight
    phase = float(schedule.start_phases[-1]
                  + 360.0 * schedule.frequency[-1] * schedule.duration[-1])
    return _Flight(run, after, phase, schedule, labels)


def refined_legs(disk: Disk, state: NDArray[np.float64], phase: float,
                 target: tuple[float, float], commands: dict[str, Command],
                 settings: IntegratorSettings | None = None, iterations: int = 5,
                 tolerance: float = 1e-4, slaving: float = SLAVING) -> list[Leg]:
    """Legs to ``target`` corrected by simulating the model itself (``state``: a
    :mod:`study.solvers.planar` state vector, heading in degree; ``phase``: the
    drive's [degree]).

    The calibration knows only steady motion; after a command switch the plate modes
    ring (beating at ``|f - f0|``, decaying over ``2 Q / w0``) and the disk moves
    differently. Each iteration flies the legs in the noise-free model from ``state``
    and moves the aim point by the miss, until the miss is below ``tolerance`` [m].
    """
    pose = (float(state[0]), float(state[1]), float(state[2]))
    aim = np.array(target, dtype=float)
    iterations = bounded_integer("iterations", iterations, 1, MAX_PLAN_ITERATIONS)
    tolerance = bounded_number("tolerance", tolerance, METRE, lower=0.0)
    legs = plan_leg(pose, (aim[0], aim[1]), commands)
    for _ in range(iterations):
        flight = _fly(disk, state, phase, legs, commands, settings, slaving)
        if flight.run is None or flight.run.outcome != "completed":
            break
        miss = flight.state[:2] - np.asarray(target)
        if math.hypot(miss[0], miss[1]) <= tolerance:
            break
        aim = aim - miss
        legs = plan_leg(pose, (aim[0], aim[1]), commands)
    return legs


def refined_route(disk: Disk, start: tuple[float, float, float],
                  waypoints: NDArray[np.float64], commands: dict[str, Command],
                  settings: IntegratorSettings | None = None, iterations: int = 5,
                  slaving: float = SLAVING) -> list[list[Leg]]:
    """Legs to every waypoint in turn, each corrected (:func:`refined_legs`) from the
    state the noise-free model reaches at the previous one (``start``: ``(x [m], y [m],
    heading [degree])``)."""
    state, phase = rest_state(disk, start), 0.0
    route = []
    for target in np.asarray(waypoints, dtype=float):
        legs = refined_legs(disk, state, phase, (target[0], target[1]), commands, settings,
                            iterations, slaving=slaving)
        route.append(legs)
        flight = _fly(disk, state, phase, legs, commands, settings, slaving)
        state, phase = flight.state, flight.phase
    return route


def run_plan(disk: Disk, start: tuple[float, float, float], waypoints: NDArray[np.float64],
             commands: dict[str, Command], *, strategy: str = "closed_loop",
             heading_noise: float = 0.0, seed: int | None = None,
             settings: IntegratorSettings | None = None, sample_interval: float = 0.05,
             iterations: int = 5, slaving: float = SLAVING,
             route: list[list[Leg]] | None = None) -> PlanRun:
    """Simulate a route flown by one of three strategies.

    Its twelve parameters are a public signature (scene specs, the API): the disk, the
    route and the strategy, then keyword-only options with defaults, each read by name.

    ``"calibration"``: the legs planned from the calibration alone
    (:func:`plan_route`), flown blind. ``"open_loop"``: the legs corrected in the
    noise-free model (:func:`refined_route`), flown blind. ``"closed_loop"``: each leg
    planned and corrected from the pose actually reached at the previous waypoint (an
    operator who looks at the disk between legs).

    Parameters
    ----------
    start : tuple of float
        ``(x [m], y [m], heading [degree])``, the disk at rest.
    heading_noise : float
        Heading diffusion of the flown run [degree m^-1/2] (see
        :func:`study.solvers.planar.simulate_planar`); the planner's own simulations are
        noise-free.
    sample_interval : float
        Spacing of the returned path samples [s].
    iterations : int
        Correction iterations of :func:`refined_legs`.
    route : list of list of Leg, optional
        The blind strategies' legs, if already planned (they do not depend on the
        noise, so several noisy runs can share them).
    """
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy {strategy!r} unknown; allowed: {', '.join(STRATEGIES)}")
    waypoints = np.asarray(waypoints, dtype=float)
    rng = np.random.default_rng(seed)
    pose = tuple(float(v) for v in start)
    if route is None and strategy == "calibration":
        route = plan_route(pose, waypoints, commands)
    elif route is None and strategy == "open_loop":
        route = refined_route(disk, pose, waypoints, commands, settings, iterations, slaving)
    state, phase = rest_state(disk, pose), 0.0
    time_offset = 0.0
    times, xs, ys, headings = [np.zeros(1)], [np.array([pose[0]])], [np.array([pose[1]])], \
        [np.array([pose[2]])]
    leg_end = np.full((len(waypoints), 2), np.nan)
    frequencies, accelerations, durations, labels = [], [], [], []
    outcome = "completed"
    for i, target in enumerate(waypoints):
        if strategy == "closed_loop":
            legs = refined_legs(disk, state, phase, (target[0], target[1]), commands, settings,
                                iterations, slaving=slaving)
        else:
            legs = route[i]
        flight = _fly(disk, state, phase, legs, commands, settings, slaving,
                      sample_interval=sample_interval, heading_noise=heading_noise, rng=rng)
        state, phase, run = flight.state, flight.phase, flight.run
        if run is None:  # already there
            leg_end[i] = state[:2]
            continue
        times.append(time_offset + run.time[1:])
        xs.append(run.x[1:])
        ys.append(run.y[1:])
        headings.append(run.heading[1:])
        time_offset += run.end_time
        frequencies += list(flight.schedule.frequency)
        accelerations += list(flight.schedule.acceleration)
        durations += list(flight.schedule.duration)
        labels += flight.labels
        if run.outcome != "completed":
            outcome = run.outcome
            break
        leg_end[i] = state[:2]
    miss = np.hypot(leg_end[:, 0] - waypoints[:, 0], leg_end[:, 1] - waypoints[:, 1])
    flown = Schedule(np.array(frequencies), np.array(accelerations),
                     np.array(durations)) if labels else None
    return PlanRun(np.concatenate(times), np.concatenate(xs), np.concatenate(ys),
                   np.concatenate(headings), leg_end, miss, flown, labels, outcome)
