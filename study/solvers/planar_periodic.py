"""The planar disk's steady motion under a constant drive: periods until it repeats.

The plates start on their steady response and the disk at rest; whole drive periods
are integrated (:mod:`study.kernels.planar_integrator`, packed and scaled as
:mod:`study.solvers.planar` does) until the body-frame displacement per period and the
twist at the period's end repeat, possibly only after several periods, and the mean
motion over that orbit is returned (:class:`PeriodicMotion`). The drive is held to the
model's ranges here; :func:`study.scenes.planar_model.periodic_motion` holds it to the
scene spec's first.

SI units; turn rates in degree s-1 (the kernel works in radians).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.kernels import planar_integrator as _kernel
from study.kernels.event_loop import EventLog, Samples, Segments, State, StepControl
from study.model import codes
from study.model.disk import Disk, steady_plate_response
from study.model.drive import drive_maximum
from study.model.inputs import bounded_integer, bounded_number
from study.model.status import NonConvergence, Status
from study.model.units import HERTZ, METRE_PER_SECOND_SQUARED
from study.solvers.integrator import (
    IntegratorSettings,
    check_integrator_settings,
    integrator_budget_maxima,
)
from study.solvers.planar import (
    MIN_DISK_FREQUENCY,
    POSE_STATE,
    SLAVING,
    check_slaving,
    disk_parameters,
    tolerance_scales,
)

__all__ = ["PeriodicMotion", "integrated_periodic_motion"]


@dataclass(frozen=True)
class PeriodicMotion:
    """Steady motion of the disk under a constant drive, per drive period.

    The motion is periodic in the body frame (friction is isotropic and the plates
    turn with the disk), so the pose advances by the same body-frame displacement
    every period once the orbit is reached.

    Attributes
    ----------
    forward_speed, lateral_speed : float
        Mean velocity along the heading and to its left, in the body frame at the
        period's start [m s-1].
    turn_rate : float
        Mean angular velocity, counterclockwise positive [degree s-1].
    status : int
        A :class:`study.model.status.Status` code.
    reason : int
        A :class:`study.model.status.NonConvergence` code (why not converged).
    periods : int
        Drive periods integrated.
    slips_per_period : float
        Slips per drive period over the orbit.
    stuck_fraction : float
        Fraction of the orbit's time spent stuck [1].
    orbit_period : int
        Drive periods after which the motion repeats (0 if it does not).
    """

    forward_speed: float
    lateral_speed: float
    turn_rate: float
    status: int
    reason: int
    periods: int
    slips_per_period: float
    stuck_fraction: float
    orbit_period: int


def integrated_periodic_motion(
    disk: Disk,
    f: float,
    a: float,
    *,
    settings: IntegratorSettings | None = None,
    max_periods: int = 400,
    max_orbit_period: int = 8,
    repeat_tolerance: float | None = None,
    slaving: float = SLAVING,
) -> PeriodicMotion:
    """Steady forward, lateral and turning speed under the drive ``a cos(2 pi f t)``.

    The plates start on their steady response (no mode transient to wait for) and the
    disk at rest; whole periods are integrated until the body-frame displacement per
    period and the body-frame twist at the period's end repeat within
    ``repeat_tolerance`` (in units of ``g / w^2`` and ``g / w``), possibly only after
    several periods (an orbit of period up to ``max_orbit_period``).

    The drive is held to the model's ranges (:func:`study.model.drive.drive_maximum`,
    ``f >=`` :data:`MIN_DISK_FREQUENCY`) and ``max_periods`` to the integrator's budget;
    :func:`study.scenes.planar_model.periodic_motion` holds both to the narrower ranges
    of the scene spec and calls this.

    Parameters
    ----------
    disk : Disk
    f : float
        Drive frequency [Hz], ``1e-100 <= f <= 1e6``.
    a : float
        Drive acceleration amplitude [m s-2], ``0 <= a <= 1e6``.
    settings : IntegratorSettings, optional
        Integrator accuracy (default tolerance 1e-10).
    max_periods : int
        Budget; beyond it the status is ``NOT_CONVERGED``.
    max_orbit_period : int
        Longest orbit looked for [drive periods]; speeds are then means over the orbit.
    repeat_tolerance : float, optional
        Periodicity test [1]; default ``max(100 * tolerance, 1e-12)`` (integration
        noise must not hide the repetition).
    slaving : float
        See :func:`study.solvers.planar.simulate_planar`.

    Returns
    -------
    PeriodicMotion
    """
    plates, disk_vector = disk_parameters(disk)
    settings = check_integrator_settings(settings)
    f = bounded_number("f", f, HERTZ, lower=MIN_DISK_FREQUENCY, upper=drive_maximum("f"))
    a = bounded_number("a", a, METRE_PER_SECOND_SQUARED, lower=0.0,
                       upper=drive_maximum("a"))
    max_periods = bounded_integer("max_periods", max_periods, 1,
                                  integrator_budget_maxima()["max_periods"])
    max_orbit_period = bounded_integer("max_orbit_period", max_orbit_period, 1,
                                       integrator_budget_maxima()["max_orbit_period"])
    if repeat_tolerance is not None:
        repeat_tolerance = bounded_number("repeat_tolerance", repeat_tolerance, lower=0.0,
                                          lower_open=True)
    omega = 2.0 * math.pi * f
    period = 1.0 / f
    disk_vector[_kernel.DK_SLAVED] = check_slaving(slaving) * disk.ck * disk.g / omega
    scale = tolerance_scales(disk, omega)
    size = scale.size
    # At rest at the origin, the plates on their steady response at drive phase 0; the
    # heading and spin are 0, the same in the kernel's units (rad, rad s-1).
    y = np.zeros(len(POSE_STATE) + 2 * len(disk.plates))
    y[_kernel.MODES:] = steady_plate_response(disk, f, a, 0.0)
    segments = Segments(np.zeros(1), np.full(1, omega), np.full(1, float(a)), np.zeros(1),
                        np.full(1, np.inf))
    state = State(y, np.zeros(1, dtype=np.int64), np.array([0.0, settings.max_step * period]))
    control = StepControl(settings.tolerance, settings.tolerance, scale, 0.0,
                          settings.max_step * period, settings.event_tolerance * period,
                          settings.samples_per_step, settings.max_steps)
    # Nothing is sampled or recorded: one count serves both empty logs.
    count = np.zeros(1, dtype=np.int64)
    samples = Samples(np.empty(0), np.empty((0, size)), np.empty(0, dtype=np.int64), count)
    events = EventLog(np.empty(0), np.empty(0, dtype=np.int64), np.empty((0, size)), count)
    history: list[tuple[Any, ...]] = []
    if repeat_tolerance is None:
        repeat_tolerance = max(100.0 * settings.tolerance, 1e-12)
    length_unit = disk.g / omega**2
    speed_unit = disk.g / omega
    tolerance = repeat_tolerance * np.array([
        length_unit, length_unit, length_unit / disk.radius,
        speed_unit, speed_unit, speed_unit / disk.radius,
    ])
    for count in range(1, max_periods + 1):
        start = y.copy()
        stats = np.zeros(_kernel.STATS_SIZE)
        # Time restarts each period (phase 2 pi k is phase 0): no loss of precision.
        state.clock[0] = 0.0
        code = _kernel.integrate(plates, disk_vector, segments, state, period, control,
                                 samples, events, stats)
        if code != codes.RUN_DONE:
            return _ended_early(code, count)
        history.append((_body_frame_change(start, y), start[:3].copy(), y[:3].copy(),
                        stats.copy()))
        del history[:-2 * max_orbit_period]
        orbit = _orbit_period(history, tolerance, max_orbit_period)
        if orbit:
            return _motion_of_orbit(history[-orbit:], f, period, count)
    return PeriodicMotion(math.nan, math.nan, math.nan, int(Status.NOT_CONVERGED),
                          int(NonConvergence.NO_PERIODIC_ORBIT), max_periods, math.nan,
                          math.nan, 0)


def _ended_early(code: int, count: int) -> PeriodicMotion:
    """The motion of a search whose period ``count`` ended before its end: lift-off, a
    friction paradox, or the step budget spent."""
    if code == codes.RUN_LIFT_OFF:
        status, reason = Status.LIFT_OFF, NonConvergence.NONE
    elif code == codes.RUN_PARADOX:
        status, reason = Status.FRICTION_PARADOX, NonConvergence.NONE
    else:
        status, reason = Status.NOT_CONVERGED, NonConvergence.EVENT_BUDGET
    return PeriodicMotion(math.nan, math.nan, math.nan, int(status), int(reason), count,
                          math.nan, math.nan, 0)


def _body_frame_change(start: NDArray[np.float64], y: NDArray[np.float64]
                       ) -> NDArray[np.float64]:
    """One period's displacement, twist and end velocities in the body frame of its start
    (what repeats on a periodic orbit whatever the heading)."""
    heading = start[_kernel.HEADING]
    c, s = math.cos(heading), math.sin(heading)
    dx = y[_kernel.X] - start[_kernel.X]
    dy = y[_kernel.Y] - start[_kernel.Y]
    return np.array([
        c * dx + s * dy, -s * dx + c * dy, y[_kernel.HEADING] - heading,
        c * y[_kernel.VX] + s * y[_kernel.VY], -s * y[_kernel.VX] + c * y[_kernel.VY],
        y[_kernel.SPIN],
    ])


def _motion_of_orbit(window: list[tuple[Any, ...]], f: float, period: float, count: int
                     ) -> PeriodicMotion:
    """The mean motion over the periods of one orbit (``window``: each period's body-frame
    change, start and end pose, statistics)."""
    orbit = len(window)
    stuck = sum(h[3][3] for h in window) / (orbit * period)
    slips = sum(h[3][2] for h in window) / orbit
    first, last = window[0][1], window[-1][2]
    c, s = math.cos(first[2]), math.sin(first[2])
    dx, dy = last[0] - first[0], last[1] - first[1]
    rate = f / orbit
    if slips == 0 and dx == 0.0 and dy == 0.0 and last[2] == first[2]:
        status = Status.STATIC
    elif stuck > 0.0:
        status = Status.STICK_SLIP
    else:
        status = Status.CONTINUOUS_SLIDING
    return PeriodicMotion(
        float((c * dx + s * dy) * rate), float((-s * dx + c * dy) * rate),
        math.degrees((last[2] - first[2]) * rate), int(status), int(NonConvergence.NONE),
        count, float(slips), float(stuck), orbit,
    )


def _orbit_period(history: list[tuple[Any, ...]], tolerance: NDArray[np.float64],
                  longest: int) -> int:
    """Smallest ``q <= longest`` for which the last ``q`` periods repeat the ``q`` before
    (body-frame displacement and end twist within ``tolerance``), else 0."""
    for q in range(1, longest + 1):
        if len(history) < 2 * q:
            return 0
        if all(np.all(np.abs(history[-1 - j][0] - history[-1 - j - q][0]) <= tolerance)
               for j in range(q)):
            return q
    return 0
