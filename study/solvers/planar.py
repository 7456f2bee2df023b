"""Time integration of the planar disk through a drive schedule: its kernel's wrapper.

The wrapper of :mod:`study.kernels.planar_integrator` (the equations are there; the
choices in docs/user-guide/steering.md). It packs a :class:`study.model.disk.Disk` as
the kernel's plate table and disk vector (:func:`disk_parameters`, by the entries the
kernel declares, the mode's and the contact's as the single plate's packing computes
them), declares the state vector (:data:`POSE_STATE`, :func:`state_names`) and the
integrator's tolerance scales (:func:`tolerance_scales`), and runs the disk:
:func:`simulate_planar` follows it through a drive schedule and returns a
:class:`PlanarTrajectory` (samples, events, how the run ended). The steady motion
under a constant drive is :mod:`study.solvers.planar_periodic`'s.

Per unit total mass, SI units: lengths in m; every angle a caller passes or gets back
is in degrees (headings, spins and turn rates in degree and degree s-1; the heading
noise in degree m^-1/2), including the heading and spin of the state vectors
(``initial_state``, ``final_state``). The kernel works in radians; the conversion is
made here, at the boundary (:func:`_to_kernel`, :func:`_from_kernel`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels import planar_integrator as _kernel
from study.kernels.event_loop import EventLog, Samples, Segments, State, StepControl
from study.model import codes
from study.model.disk import Disk, check_disk
from study.model.inputs import as_real_array, bounded_integer
from study.model.structure import require_finite
from study.model.units import (
    DEGREE,
    DEGREE_PER_SECOND,
    METRE,
    METRE_PER_SECOND,
    SECOND,
)
from study.solvers.integrator import (
    MAX_RECORDED_EVENTS,
    IntegratorSettings,
    Schedule,
    check_integrator_settings,
    check_samples,
)
from study.solvers.packing import contact_entries, coupling_entry, mode_entries

__all__ = [
    "EVENT_KINDS",
    "MIN_DISK_FREQUENCY",
    "OUTCOMES",
    "PLANAR_VERSION",
    "POSE_STATE",
    "POSE_UNITS",
    "SLAVING",
    "PlanarTrajectory",
    "check_slaving",
    "disk_parameters",
    "simulate_planar",
    "state_names",
    "tolerance_scales",
]

#: Bumped whenever the planar model or its numerics change the numbers it returns
#: (2: headings, spins and turn rates in degree, no longer rad).
PLANAR_VERSION = "2"

#: How a run ended, by kernel return code.
OUTCOMES = {
    codes.RUN_DONE: "completed",
    codes.RUN_LIFT_OFF: "lift_off",
    codes.RUN_BUDGET: "step_budget",
    codes.RUN_PARADOX: "friction_paradox",
}

#: Event kinds recorded in trajectories.
EVENT_KINDS = {
    codes.EVENT_RELEASE: "release",
    codes.EVENT_SLIP_END: "slip_end",
    codes.EVENT_LIFT_OFF: "lift_off",
    codes.EVENT_PARADOX: "friction_paradox",
}

#: Default slaving threshold of a slip's onset, in units of ``ck g / w`` [1].
SLAVING = 1e-4

#: Names of the state components (``delta_i``, ``delta_i'`` follow, plate by plate).
POSE_STATE = ("x", "y", "heading", "vx", "vy", "spin", "path")

#: Units of the state components a caller sees (the kernel's heading and spin are in
#: rad and rad s-1).
POSE_UNITS = (METRE, METRE, DEGREE, METRE_PER_SECOND, METRE_PER_SECOND, DEGREE_PER_SECOND, METRE)


def _to_kernel(state: NDArray[np.float64]) -> NDArray[np.float64]:
    """A state vector in the caller's units (heading [degree], spin [degree s-1]) as
    the kernel's (rad, rad s-1); a copy."""
    out = np.array(state, dtype=float)
    out[[_kernel.HEADING, _kernel.SPIN]] = np.radians(out[[_kernel.HEADING, _kernel.SPIN]])
    return out


def _from_kernel(state: NDArray[np.float64]) -> NDArray[np.float64]:
    """A kernel state vector (rad, rad s-1) in the caller's units (degree, degree
    s-1); a copy."""
    out = np.array(state, dtype=float)
    out[[_kernel.HEADING, _kernel.SPIN]] = np.degrees(out[[_kernel.HEADING, _kernel.SPIN]])
    return out


#: Lowest drive frequency of a disk [Hz]: the integrator's scales go as
#: ``g / (2 pi f)^2``, which overflows near 1e-154 Hz (1e-300 Hz ended in a
#: ZeroDivisionError); 1e-100 Hz keeps them finite with a wide margin. Far below any
#: drive: a scene's work budget refuses frequencies long before (1e-30 Hz).
MIN_DISK_FREQUENCY = 1e-100


def disk_parameters(disk: Disk) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The kernel's plate table and disk vector of ``disk``.

    Each plate's mode and the disk's friction, gravity and coupling are the single
    plate's entries of the same names, computed by :mod:`study.solvers.packing`; the
    entries are laid out as :data:`study.kernels.planar_integrator.PLATE_ENTRIES` and
    :data:`~study.kernels.planar_integrator.DISK_ENTRIES` declare them.

    Parameters
    ----------
    disk : Disk

    Returns
    -------
    plates : numpy.ndarray
        ``(P, 9)`` float64, a row a plate: ``w0 / Q`` [s-1], ``w0^2`` [s-2], ``cos`` and
        ``sin`` of the tilt, ``M`` [1], the body-frame direction ``e`` (forward, left)
        [1], the lever ``r x e`` and the reach ``r . e`` [m].
    vector : numpy.ndarray
        ``(7,)`` float64: ``cs``, ``ck`` [1], ``g`` [m s-2], the friction length ``c``
        [m], the gyration radius squared [m2], the slaving twist (0 here: the run sets
        it) [m s-1] and the coupling (1.0 two-way, 0.0 one-way).
    """
    check_disk(disk)
    plates = np.empty((len(disk.plates), _kernel.N_PLATE_PARAMETERS))
    for i, plate in enumerate(disk.plates):
        alpha = math.radians(plate.alpha)
        ex, ey = plate.unit_direction
        row = {
            **mode_entries(plate.omega0, plate.Q, plate.M, math.cos(alpha), math.sin(alpha)),
            "direction_forward": ex,
            "direction_left": ey,
            "lever": plate.lever,
            "reach": plate.attachment[0] * ex + plate.attachment[1] * ey,
        }
        plates[i] = [row[name] for name, _, _ in _kernel.PLATE_ENTRIES]
    entries = {
        **contact_entries(disk.cs, disk.ck, disk.g),
        "friction_length": disk.friction_length,
        "gyration_radius_squared": disk.gyration_radius**2,
        "slaved_twist": 0.0,
        "two_way": coupling_entry(disk.coupling == "two-way"),
    }
    vector = np.array([entries[name] for name, _, _ in _kernel.DISK_ENTRIES], dtype=float)
    return plates, vector


def tolerance_scales(disk: Disk, omega: float) -> NDArray[np.float64]:
    """Absolute-tolerance scale of each state component at drive pulsation ``omega``.

    Parameters
    ----------
    disk : Disk
        A checked disk.
    omega : float
        The drive's (fastest) angular frequency [rad s-1], > 0.

    Returns
    -------
    numpy.ndarray
        One scale a component of the kernel's state vector (:func:`state_names`, in
        the kernel's units): ``g / w^2`` [m] for x, y and the path, ``g / w^2 / R``
        [rad] for the heading, ``g / w`` [m s-1] for the velocity, ``g / w / R``
        [rad s-1] for the spin, and for each plate ``g / W^2`` [m] and ``g / W``
        [m s-1], ``W`` the larger of ``w`` and the plate's ``omega0``.
    """
    g = disk.g
    size = g / omega**2
    scale = [size, size, size / disk.radius, g / omega, g / omega, g / omega / disk.radius,
             size]
    for plate in disk.plates:
        fastest = max(omega, plate.omega0)
        scale += [g / fastest**2, g / fastest]
    return np.array(scale)


@dataclass(frozen=True)
class PlanarTrajectory:
    """A planar run: samples, events and how it ended.

    Attributes
    ----------
    time : numpy.ndarray
        Sample times [s].
    x, y : numpy.ndarray
        Position of the disk's centre [m].
    heading : numpy.ndarray
        Heading, counterclockwise from the x axis, unwrapped [degree].
    vx, vy : numpy.ndarray
        Velocity [m s-1].
    spin : numpy.ndarray
        Angular velocity, counterclockwise positive [degree s-1].
    path : numpy.ndarray
        Distance slid since the start [m].
    plate_states : numpy.ndarray
        ``(time, plate, 2)``: each plate's ``delta`` [m] and ``delta'`` [m s-1].
    slipping : numpy.ndarray
        True where the disk slides at the sample.
    event_time, event_kind : numpy.ndarray
        Recorded events (kinds in :data:`EVENT_KINDS`).
    outcome : str
        One of :data:`OUTCOMES`' values; ``"lift_off"`` means the normal force fell
        below zero at ``end_time`` (the model stops holding there).
    end_time : float
        Time the run reached [s].
    steps, rejected_steps, slips : int
        Work done.
    final_state : numpy.ndarray
        State vector at ``end_time`` (see :func:`state_names`; heading [degree], spin
        [degree s-1]), to continue a run from.
    heading_kicks : numpy.ndarray
        Heading noise added at the end of each drive period [degree] (zeros without
        noise).
    """

    time: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    heading: NDArray[np.float64]
    vx: NDArray[np.float64]
    vy: NDArray[np.float64]
    spin: NDArray[np.float64]
    path: NDArray[np.float64]
    plate_states: NDArray[np.float64] = field(repr=False)
    slipping: NDArray[np.bool_] = field(repr=False)
    event_time: NDArray[np.float64] = field(repr=False)
    event_kind: NDArray[np.int8] = field(repr=False)
    outcome: str
    end_time: float
    steps: int
    rejected_steps: int
    slips: int
    final_state: NDArray[np.float64] = field(repr=False)
    heading_kicks: NDArray[np.float64] = field(repr=False)


def check_slaving(slaving: float) -> float:
    """The slaving threshold of a slip's onset as a float, in ``(0, 0.1]`` [1] (in
    units of ``ck g / w``, see :func:`simulate_planar`); else a ValueError naming it."""
    # Without slaving (0) a slip's onset is stiff for the explicit integrator: tiny
    # steps until the budget runs out.
    value = require_finite("slaving", slaving)
    if not 0.0 < value <= 0.1:
        raise ValueError(f"slaving = {slaving!r} [1] is out of range; allowed: (0, 0.1]")
    return value


def _kick_times(schedule: Schedule) -> NDArray[np.float64]:
    """End of every whole drive period of every segment (and each segment's end)."""
    times = []
    for start, end, f in zip(schedule.starts, schedule.ends, schedule.frequency, strict=True):
        count = math.floor((end - start) * f * (1.0 + 1e-12))
        times.append(start + np.arange(1, count + 1) / f)
        times.append([end])
    merged = np.unique(np.concatenate(times))
    return merged[merged <= schedule.ends[-1]]


def simulate_planar(
    disk: Disk,
    schedule: Schedule,
    *,
    initial_state: ArrayLike | None = None,
    output_times: ArrayLike | None = None,
    settings: IntegratorSettings | None = None,
    heading_noise: float = 0.0,
    rng: np.random.Generator | int | None = None,
    max_events: int = 0,
    slaving: float = SLAVING,
    on_progress: Callable[[float], None] | None = None,
) -> PlanarTrajectory:
    """Integrate the planar model through a drive schedule.

    Parameters
    ----------
    disk : Disk
        The disk and its plates.
    schedule : study.solvers.integrator.Schedule
        The drive; the run ends at the end of its last segment (or at lift-off).
    initial_state : array_like, optional
        ``(x [m], y [m], heading [degree], vx [m s-1], vy [m s-1], spin [degree s-1],
        path [m], delta_1 [m], delta_1' [m s-1], ...)`` at ``t = 0``; default all
        zero (at rest, plates at rest). With a non-zero twist the run starts sliding.
    output_times : array_like, optional
        Sorted sample times within the schedule [s]; default 16 per shortest drive
        period.
    settings : IntegratorSettings, optional
        ``tolerance``, ``event_tolerance``, ``samples_per_step``, ``max_step`` and
        ``max_steps`` apply (periods are the schedule's shortest); fixed steps are not
        offered here.
    heading_noise : float
        Phenomenological heading diffusion [degree m^-1/2]: at the end of every drive
        period the heading gets a Gaussian kick of variance ``heading_noise^2 * s``,
        ``s`` the distance slid in that period. ``5.73 / sqrt(diameter)`` gives the
        paper's measured drift of 0.1 rad (5.73 degree) per diameter travelled.
    rng : numpy.random.Generator or int, optional
        Source (or seed) of the heading kicks.
    max_events : int
        Events to record (0: none).
    slaving : float
        A slip that starts from rest moves along its slaved direction until its twist
        exceeds ``slaving * ck * g / (2 pi f_max)`` [1]: this removes the stiffness of
        the direction's relaxation (rate ``ck n / |u|``) at the cost of an error of
        order ``slaving^2`` relative (measured; see docs/user-guide/steering.md). Exact
        for motion along one axis.
    on_progress : callable, optional
        Called with the drive time reached [s] each time the integration stops (at every
        heading kick with noise, else at the end); the integration is the same with or
        without it.

    Returns
    -------
    PlanarTrajectory
    """
    plates, disk_vector = disk_parameters(disk)
    if not isinstance(schedule, Schedule):
        raise TypeError("schedule must be a study.solvers.integrator.Schedule, "
                        f"got {type(schedule)}")
    settings = check_integrator_settings(settings)
    if settings.steps_per_period is not None:
        raise ValueError("simulate_planar: fixed steps (steps_per_period) are not offered; "
                         "set tolerance instead")
    noise = require_finite("heading_noise", heading_noise)
    if noise < 0.0:
        raise ValueError(f"heading_noise = {noise!r} [degree m^-1/2] must be >= 0")
    noise = math.radians(noise)  # the kernel's heading is in rad
    names = state_names(disk)
    size = len(names)
    y = np.zeros(size) if initial_state is None else np.array(initial_state, dtype=float)
    if y.shape != (size,) or not np.all(np.isfinite(y)):
        raise ValueError(
            f"initial_state must be {size} finite numbers ({', '.join(names)}; heading "
            f"[degree], spin [degree s-1]), got {initial_state!r}"
        )
    y = _to_kernel(y)
    end = float(schedule.ends[-1])
    shortest = float(1.0 / np.max(schedule.frequency))
    out_t = _output_times(output_times, end, shortest)
    omega = 2.0 * np.pi * schedule.frequency
    scale = tolerance_scales(disk, float(np.max(omega)))
    disk_vector[_kernel.DK_SLAVED] = check_slaving(slaving) * disk.ck * disk.g / float(
        np.max(omega))
    moving = bool(np.any(y[[_kernel.VX, _kernel.VY, _kernel.SPIN]] != 0.0))
    state = State(y, np.array([_kernel.SLIP if moving else _kernel.STICK], dtype=np.int64),
                  np.array([0.0, settings.max_step * shortest]))
    # Writable (Schedule's arrays are read-only: another numba signature).
    segments = Segments(schedule.starts, omega, np.array(schedule.acceleration),
                        schedule.start_phases_rad, schedule.ends)
    control = StepControl(settings.tolerance, settings.tolerance, scale, 0.0,
                          settings.max_step * shortest, settings.event_tolerance * shortest,
                          settings.samples_per_step, settings.max_steps)
    samples = Samples(out_t, np.empty((out_t.size, size)), np.empty(out_t.size, dtype=np.int64),
                      np.zeros(1, dtype=np.int64))
    capacity = bounded_integer("max_events", max_events, 0, MAX_RECORDED_EVENTS)
    events = EventLog(np.empty(capacity), np.empty(capacity, dtype=np.int64),
                      np.empty((capacity, size)), np.zeros(1, dtype=np.int64))
    stats = np.zeros(_kernel.STATS_SIZE)
    stops = _kick_times(schedule) if noise > 0.0 else np.array([end])
    kicks = np.zeros(stops.size)
    generator = np.random.default_rng(rng) if noise > 0.0 else None
    code = codes.RUN_DONE
    for j, stop in enumerate(stops):
        path_before = y[_kernel.PATH]
        code = _kernel.integrate(plates, disk_vector, segments, state, float(stop), control,
                                 samples, events, stats)
        if on_progress is not None:
            on_progress(float(state.clock[0]))
        if code != codes.RUN_DONE:
            break
        if generator is not None:
            slid = y[_kernel.PATH] - path_before
            kicks[j] = noise * math.sqrt(slid) * generator.standard_normal()
            y[_kernel.HEADING] += kicks[j]
    return _trajectory(disk, samples, events, capacity, stats, code, state, kicks)


def _output_times(output_times: ArrayLike | None, end: float, shortest: float
                  ) -> NDArray[np.float64]:
    """The sampling times [s]: ``output_times`` checked, or 16 a shortest drive period."""
    if output_times is None:
        count = max(2, math.ceil(end / shortest * 16) + 1)
        check_samples(count, "the default output_times (16 a period of the schedule)")
        return np.linspace(0.0, end, count)
    out_t = as_real_array("output_times", output_times, SECOND).ravel()
    check_samples(out_t.size, "output_times")
    if np.any(~np.isfinite(out_t)) or np.any(out_t < 0) or np.any(out_t > end):
        raise ValueError(f"output_times must lie within the schedule [0, {end}] s")
    if np.any(np.diff(out_t) < 0):
        raise ValueError("output_times must be sorted")
    return out_t


def _trajectory(disk: Disk, samples: Samples, events: EventLog, capacity: int,
                stats: NDArray[np.float64], code: int, state: State,
                kicks: NDArray[np.float64]) -> PlanarTrajectory:
    """The run's samples and events as a :class:`PlanarTrajectory` (angles in degree)."""
    out_t = samples.t
    y = state.y
    m = int(samples.count[0])
    e = min(int(events.count[0]), capacity)
    states = samples.y[:m]
    angles = [_kernel.HEADING, _kernel.SPIN]
    states[:, angles] = np.degrees(states[:, angles])
    return PlanarTrajectory(
        time=out_t[:m].copy(),
        x=states[:, _kernel.X].copy(),
        y=states[:, _kernel.Y].copy(),
        heading=states[:, _kernel.HEADING].copy(),
        vx=states[:, _kernel.VX].copy(),
        vy=states[:, _kernel.VY].copy(),
        spin=states[:, _kernel.SPIN].copy(),
        path=states[:, _kernel.PATH].copy(),
        plate_states=states[:, _kernel.MODES:].reshape(m, len(disk.plates), 2).copy(),
        slipping=samples.mode[:m] != _kernel.STICK,
        event_time=events.t[:e].copy(),
        event_kind=events.kind[:e].astype(np.int8),
        outcome=OUTCOMES[int(code)],
        end_time=float(state.clock[0]),
        steps=int(stats[_kernel.STEPS]),
        rejected_steps=int(stats[_kernel.REJECTED]),
        slips=int(stats[_kernel.SLIPS]),
        final_state=_from_kernel(y),
        heading_kicks=np.degrees(kicks),
    )


def state_names(disk: Disk) -> tuple[str, ...]:
    """Names of the components of a planar state vector (units: :data:`POSE_UNITS`,
    then each plate's ``delta`` [m] and ``delta'`` [m s-1])."""
    check_disk(disk)
    names: list[str] = list(POSE_STATE)
    for plate in disk.plates:
        names += [f"delta_{plate.name}", f"delta_rate_{plate.name}"]
    return tuple(names)
