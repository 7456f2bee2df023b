"""Time integration of the full single-plate model: transients, schedules, two-way coupling.

The exact solver (:mod:`study.solvers.exact`) gives the steady orbit only, under either
coupling (docs/theory/two-way.md). This module integrates the whole
model in time with an event-driven Dormand-Prince 5(4) scheme
(:mod:`study.kernels.integrator`): any initial state, a drive given as a schedule of
segments with continuous phase, and optionally the two-way coupling in which the
sliding base's acceleration also forces the mode (``-x'' sin(alpha)``). The
friction law is chosen by name (``friction=``, :mod:`study.model.contact`): Coulomb
friction, the exact solver's, or velocity-weakening Stribeck friction, which only this
solver implements. Where the normal force vanishes a run stops with ``lift_off`` (the
lift-off law ``stop``), or with ``flight=True`` (two-way coupling, ``M < 1``) the base
takes off, flies and lands by an impact (:mod:`study.kernels.impact`): the state gains
the gap ``h`` and its rate, and a steady orbit with flight is ``BOUNCING``.

Two entry points:

* :func:`simulate` follows one structure through a :class:`Schedule` and returns a
  :class:`Trajectory` (samples at requested times and every contact event);
* :func:`integrated_steady_state` integrates whole drive periods from the canonical
  start until the orbit repeats and returns the same :class:`~study.solvers.steady.SteadyState`
  as the exact solver.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels import integrator as _kernel
from study.kernels import structure_vector as sv
from study.kernels.event_loop import EventLog, Samples, Segments, State, StepControl
from study.model import as_acceleration, as_frequency, codes, mode_response
from study.model.contact import DEFAULT_COUPLING, DEFAULT_FRICTION, LAWS, Friction, check_friction
from study.model.inputs import as_real_array, bounded_integer, instance_of, real_number
from study.model.starts import START_ALLOWED, Drop, as_start, kernel_fields, start_label
from study.model.structure import Structure, check_structure
from study.model.units import DEGREE, SECOND
from study.solvers.exact import PARALLEL_THRESHOLD
from study.solvers.packing import structure_entries, with_laws
from study.solvers.settings import DEFAULT_SETTINGS, check_coupling, check_flight, check_start
from study.solvers.steady import SteadyState, scalar_if_0d

__all__ = [
    "EVENT_KINDS",
    "INTEGRATOR_VERSION",
    "MAX_INTEGRATOR_BUDGET",
    "MAX_INTEGRATOR_STEPS",
    "MAX_OUTPUT_SAMPLES",
    "MAX_RECORDED_EVENTS",
    "OUTCOMES",
    "IntegratorSettings",
    "Schedule",
    "Trajectory",
    "check_integrator_settings",
    "check_samples",
    "integrated_steady_state",
    "integrator_budget_maxima",
    "model_parameters",
    "simulate",
    "steady_mode_state",
]

#: Version of the integrator's algorithm; changes whenever its results may change.
INTEGRATOR_VERSION = "1"


#: Contact event kinds in a :class:`Trajectory`, by code.
EVENT_KINDS = {
    codes.EVENT_RELEASE_FORWARD: "release_forward",
    codes.EVENT_RELEASE_BACKWARD: "release_backward",
    codes.EVENT_SLIP_END: "slip_end",
    codes.EVENT_LIFT_OFF: "lift_off",
    codes.EVENT_PARADOX: "friction_paradox",
    codes.EVENT_IMPACT: "impact",
}

#: How a :func:`simulate` run ended, by kernel return code.
OUTCOMES = {
    codes.RUN_DONE: "completed",
    codes.RUN_LIFT_OFF: "lift_off",
    codes.RUN_BUDGET: "step_budget",
    codes.RUN_PARADOX: "friction_paradox",
}


#: Steps of one integrator call at most (``IntegratorSettings.max_steps``, default
#: 1e7): about 1 us each, so a call that never ends a period stops within about 20
#: minutes of one core.
MAX_INTEGRATOR_STEPS = 1_000_000_000

#: The largest value of the integer budgets of :class:`IntegratorSettings` a study spec
#: may set (its ``[solver]`` table; the spec schema takes these maxima from here): steps
#: of 1e-4 drive periods at the finest, 1e5 periods to reach a steady state, orbits of up
#: to 1e3 drive periods.
MAX_INTEGRATOR_BUDGET = {"steps_per_period": 10_000, "max_periods": 100_000,
                         "max_orbit_period": 1_000}


def integrator_budget_maxima() -> dict[str, int]:
    """The largest value of each integer budget of :class:`IntegratorSettings`."""
    return {**MAX_INTEGRATOR_BUDGET, "max_steps": MAX_INTEGRATOR_STEPS}


#: Events :func:`simulate` (and :func:`study.solvers.planar.simulate_planar`) record at most:
#: the arrays are allocated up front (about 50 bytes an event for the single plate).
MAX_RECORDED_EVENTS = 10_000_000


#: Samples a run returns at most (the trajectory arrays are allocated up front, about 60
#: bytes a sample): a 1e12 s schedule's default grid asked for 6 PiB.
MAX_OUTPUT_SAMPLES = 10_000_000


def check_samples(count: int, what: str) -> None:
    """Refuse a run of more than :data:`MAX_OUTPUT_SAMPLES` samples, naming ``what``."""
    if count > MAX_OUTPUT_SAMPLES:
        raise ValueError(f"{what}: {count:.3g} samples; allowed at most "
                         f"{MAX_OUTPUT_SAMPLES:.3g} (give fewer output_times or a shorter "
                         "schedule duration)")


def check_integrator_settings(settings: object) -> IntegratorSettings:
    """``settings``, or the defaults for None; a TypeError naming the argument for
    anything but an :class:`IntegratorSettings`."""
    if settings is None:
        return IntegratorSettings()
    return instance_of("settings", settings, IntegratorSettings,
                       "a study.solvers.integrator.IntegratorSettings")


def _positive_int(name: str, value: object) -> int:
    if (isinstance(value, bool | np.timedelta64) or not isinstance(value, int | np.integer)
            or value < 1):
        raise ValueError(f"integrator setting {name!r} must be an integer >= 1, got {value!r}")
    return int(value)


def _positive_float(name: str, value: object, upper: float = math.inf) -> float:
    if isinstance(value, bool | np.timedelta64) or not isinstance(
            value, int | float | np.floating | np.integer):
        raise ValueError(f"integrator setting {name!r} must be a number, got {value!r}")
    number = float(value)
    if not (0.0 < number < upper):
        raise ValueError(
            f"integrator setting {name!r} = {value!r} is out of range; allowed: 0 < {name} < "
            f"{upper}"
        )
    return number


@dataclass(frozen=True)
class IntegratorSettings:
    """Accuracy and budgets of the time integrator.

    Parameters
    ----------
    tolerance : float
        Relative and absolute local error tolerance of the adaptive steps [1]. The
        absolute part is scaled per component by the drive's natural units
        (``g / W^2`` for ``delta``, ``g / W`` for its rate, ``W = max(w, w0)``;
        ``g / w^2`` for ``x`` and, with flight, the gap ``h``, ``g / w`` for ``v`` and
        ``h'``). Ignored with ``steps_per_period``.
    steps_per_period : int, optional
        Fixed step of ``1 / steps_per_period`` drive periods (no error control);
        steps still end exactly at events.
    event_tolerance : float
        Width to which every event time is bracketed [drive periods].
    samples_per_step : int
        Points of the dense output at which event functions are sampled in each step
        (their minima between samples are watched as well).
    max_step : float
        Largest step [drive periods].
    max_steps : int
        Step budget of one call (of one drive period in :func:`integrated_steady_state`).
    max_periods : int
        Drive periods integrated by :func:`integrated_steady_state` before a point is
        declared ``NOT_CONVERGED`` (``NO_PERIODIC_ORBIT``).
    max_orbit_period : int
        Longest orbit period looked for [drive periods].
    period_tolerance : float, optional
        The orbit is periodic once the state at the period boundaries repeats within
        this, in the units above [1]. Default ``max(100 * tolerance, 1e-12)``
        (``1e-9`` with fixed steps): integration noise must not hide the repetition.
    """

    tolerance: float = 1e-10
    steps_per_period: int | None = None
    event_tolerance: float = 1e-12
    samples_per_step: int = 4
    max_step: float = 0.125
    max_steps: int = 10_000_000
    max_periods: int = 20_000
    max_orbit_period: int = 8
    period_tolerance: float | None = None

    def __post_init__(self) -> None:
        _positive_float("tolerance", self.tolerance, 1.0)
        if self.steps_per_period is not None:
            _positive_int("steps_per_period", self.steps_per_period)
        _positive_float("event_tolerance", self.event_tolerance, 1e-3)
        _positive_int("samples_per_step", self.samples_per_step)
        _positive_float("max_step", self.max_step, 1.0 + 1e-12)
        _positive_int("max_steps", self.max_steps)
        _positive_int("max_periods", self.max_periods)
        _positive_int("max_orbit_period", self.max_orbit_period)
        if self.period_tolerance is not None:
            _positive_float("period_tolerance", self.period_tolerance, 1.0)
        for name, largest in integrator_budget_maxima().items():
            value = getattr(self, name)
            if value is not None and value > largest:
                raise ValueError(f"integrator setting {name!r} = {value!r} is out of range; "
                                 f"allowed: an integer >= 1 and <= {largest}")

    @property
    def resolved_period_tolerance(self) -> float:
        """The periodicity tolerance in use [1]."""
        if self.period_tolerance is not None:
            return float(self.period_tolerance)
        if self.steps_per_period is not None:
            return 1e-9
        return max(100.0 * self.tolerance, 1e-12)


@dataclass(frozen=True)
class Schedule:
    """Drive schedule: consecutive segments of constant frequency and amplitude.

    The drive acceleration is ``a_j cos(phi(t))`` in segment ``j`` with the phase
    ``phi`` continuous across segment boundaries (a frequency switch does not jump
    the table's phase) and ``phi(0) = phase`` [degree] (angles are in degrees at every
    public boundary; the kernels take :attr:`start_phases_rad`).

    Parameters
    ----------
    frequency : array_like
        Drive frequency of each segment [Hz], > 0.
    acceleration : array_like
        Drive acceleration amplitude of each segment [m s-2], >= 0.
    duration : array_like
        Duration of each segment [s], > 0.
    phase : float
        Drive phase at ``t = 0`` [degree].
    """

    frequency: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    duration: NDArray[np.float64]
    phase: float = 0.0

    def __post_init__(self) -> None:
        f = np.atleast_1d(as_frequency(self.frequency)).astype(float)
        a = np.atleast_1d(as_acceleration(self.acceleration)).astype(float)
        d = np.atleast_1d(as_real_array("Schedule: duration", self.duration, SECOND))
        if f.ndim != 1 or a.shape != f.shape or d.shape != f.shape:
            raise ValueError(
                "Schedule: frequency, acceleration and duration must be 1-D of one length, "
                f"got shapes {f.shape}, {a.shape}, {d.shape}"
            )
        if f.size == 0:
            raise ValueError("Schedule: at least one segment is needed")
        if not np.all(np.isfinite(d)) or np.any(d <= 0.0):
            raise ValueError(f"Schedule: every duration must be finite and > 0 [s], got {d}")
        if not math.isfinite(real_number("Schedule: phase", self.phase, DEGREE)):
            raise ValueError(f"Schedule: phase must be finite [degree], got {self.phase!r}")
        for name, value in (("frequency", f), ("acceleration", a), ("duration", d)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "phase", float(self.phase))

    @classmethod
    def constant(cls, f: float, a: float, duration: float, phase: float = 0.0) -> Schedule:
        """A single segment: drive ``a cos(2 pi f t + phase)`` for ``duration`` [s]
        (``phase`` in degree)."""
        return cls(np.array([f]), np.array([a]), np.array([duration]), phase)

    @property
    def starts(self) -> NDArray[np.float64]:
        """Start time of each segment [s]."""
        return np.concatenate(([0.0], np.cumsum(self.duration)[:-1]))

    @property
    def ends(self) -> NDArray[np.float64]:
        """End time of each segment [s]."""
        return np.cumsum(self.duration)

    @property
    def start_phases(self) -> NDArray[np.float64]:
        """Drive phase at the start of each segment [degree]."""
        advance = 360.0 * self.frequency * self.duration
        return self.phase + np.concatenate(([0.0], np.cumsum(advance)[:-1]))

    @property
    def start_phases_rad(self) -> NDArray[np.float64]:
        """Drive phase at the start of each segment [rad], the kernels' unit."""
        advance = 2.0 * np.pi * self.frequency * self.duration
        return math.radians(self.phase) + np.concatenate(([0.0], np.cumsum(advance)[:-1]))


@dataclass(frozen=True)
class Trajectory:
    """A simulated run: samples at the requested times and every contact event.

    Attributes
    ----------
    time : numpy.ndarray
        Sample times [s] (those reached before the run ended).
    delta, delta_rate, x, v : numpy.ndarray
        Plate deflection [m], its rate [m s-1], base position [m] and velocity
        [m s-1] at the sample times.
    mode : numpy.ndarray of int8
        Contact mode at the sample times: 0 stick, +1 forward slip, -1 backward slip,
        2 flight.
    event_time : numpy.ndarray
        Event times [s].
    event_kind : numpy.ndarray of int8
        Event codes, named by :data:`EVENT_KINDS`.
    event_state : numpy.ndarray
        State ``(delta, delta', x, v)`` at each event, shape ``(events, 4)``; with
        flight ``(delta, delta', x, v, h, h')``, shape ``(events, 6)``, after the event
        (an impact's state is the one it leaves, ``h' = 0`` on landing).
    outcome : str
        How the run ended: one of :data:`OUTCOMES` values. ``lift_off`` (without
        flight) and ``friction_paradox`` stop the run where the model stops holding.
    end_time : float
        Time the run reached [s].
    steps, rejected_steps : int
        Accepted and rejected steps.
    events_dropped : int
        Events beyond ``max_events`` that were not recorded.
    gap, gap_rate : numpy.ndarray or None
        With flight: the gap between base and table [m] and its rate [m s-1] at the
        sample times (0 in contact); None without.
    airborne_time : float
        Time spent in the air [s] (0 without flight).
    largest_hop : float
        Highest gap reached [m] (the highest apex, or the starting gap; 0 without
        flight).
    impacts : int
        Impacts on the table, rebounds included (0 without flight).
    """

    time: NDArray[np.float64]
    delta: NDArray[np.float64]
    delta_rate: NDArray[np.float64]
    x: NDArray[np.float64]
    v: NDArray[np.float64]
    mode: NDArray[np.int8]
    event_time: NDArray[np.float64]
    event_kind: NDArray[np.int8]
    event_state: NDArray[np.float64]
    outcome: str
    end_time: float
    steps: int
    rejected_steps: int
    events_dropped: int = field(default=0)
    gap: NDArray[np.float64] | None = None
    gap_rate: NDArray[np.float64] | None = None
    airborne_time: float = 0.0
    largest_hop: float = 0.0
    impacts: int = 0


def model_parameters(structure: Structure, coupling: str = DEFAULT_COUPLING,
                     friction: str | Friction = DEFAULT_FRICTION,
                     flight: bool = False) -> NDArray[np.float64]:
    """Parameter vector of the integrator kernel for ``structure``, ``coupling``,
    ``friction`` and the lift-off law (``flight``, :func:`study.solvers.settings.check_flight`:
    two-way coupling and ``M < 1`` only)
    (:mod:`study.kernels.structure_vector`)."""
    structure = check_structure(structure)
    coupling = check_coupling(coupling)
    two_way = coupling == "two-way"
    flight = check_flight(flight, coupling, structure)
    friction = check_friction(friction, "integrator")
    return with_laws(structure_entries(structure), two_way=two_way,
                     lift_off="flight" if flight else "stop", friction=friction)


def _scales(structure: Structure, omega: NDArray[np.float64],
            flight: bool = False) -> NDArray[np.float64]:
    """Per-component scales of the absolute tolerance, one row per drive frequency (with
    flight also those of the gap and its rate, as of ``x`` and ``v``)."""
    fastest = np.maximum(omega, structure.omega0)
    g = structure.g
    columns = [g / fastest**2, g / fastest, g / omega**2, g / omega]
    if flight:
        columns += [g / omega**2, g / omega]
    return np.stack(columns, axis=-1).astype(float)


def _state_size(flight: bool) -> int:
    return _kernel.FLIGHT_STATE_SIZE if flight else _kernel.STATE_SIZE


def simulate(
    structure: Structure,
    schedule: Schedule,
    *,
    coupling: str = DEFAULT_COUPLING,
    friction: str | Friction = DEFAULT_FRICTION,
    initial_state: ArrayLike | None = None,
    output_times: ArrayLike | None = None,
    settings: IntegratorSettings | None = None,
    max_events: int = 100_000,
    flight: bool = False,
) -> Trajectory:
    """Integrate the full model through a drive schedule.

    Parameters
    ----------
    structure : Structure
        The structure.
    schedule : Schedule
        The drive; the run ends at the end of its last segment.
    coupling : {"one-way", "two-way"}
        ``"one-way"`` is the paper's model (the mode does not feel the sliding);
        ``"two-way"`` adds the base's acceleration to the mode's forcing.
    friction : str or Friction
        The friction law (:data:`study.model.contact.LAWS`): ``"coulomb"`` (the
        default) or a :class:`study.model.contact.Friction` with its parameters, e.g.
        ``Friction("stribeck", stribeck_speed=1e-3)`` (speed in m s-1).
    initial_state : array_like, optional
        ``(delta [m], delta' [m s-1], x [m], v [m s-1])`` at ``t = 0``; default all
        zero (at rest on the table, the mode at rest). With ``v != 0`` the run starts
        sliding that way; with ``v = 0`` it sticks unless the forces already exceed the
        static friction. With flight, optionally two more, the gap ``h >= 0`` [m] and its
        rate [m s-1] (a run from a drop: ``h > 0``); the run starts in the air when
        either is not 0.
    output_times : array_like, optional
        Times at which to sample the state [s], sorted, within the schedule; default
        64 per shortest drive period of the schedule, from start to end.
    settings : IntegratorSettings, optional
        Accuracy and budgets. ``steps_per_period`` and the step limits refer to the
        shortest drive period of the schedule.
    max_events : int
        Events recorded (later ones are counted in ``events_dropped``), 0 to
        :data:`MAX_RECORDED_EVENTS`.
    flight : bool
        The lift-off law: False (default) stops the run with outcome ``lift_off`` where
        the normal force would turn negative; True (two-way coupling, ``M < 1``) lets
        the base take off, fly and land by an impact (restitution
        ``structure.restitution``), events ``lift_off`` and ``impact``.

    Returns
    -------
    Trajectory
    """
    structure = check_structure(structure)
    if not isinstance(schedule, Schedule):
        raise TypeError("schedule must be a study.solvers.integrator.Schedule, "
                        f"got {type(schedule)}")
    settings = check_integrator_settings(settings)
    max_events = bounded_integer("max_events", max_events, 0, MAX_RECORDED_EVENTS)
    p = model_parameters(structure, coupling, friction, flight)
    flight = bool(p[sv.LIFT_OFF_LAW] == LAWS["lift_off"]["flight"].code)
    size = _state_size(flight)
    y = np.zeros(size) if initial_state is None else np.array(initial_state, dtype=float)
    if flight and y.shape == (_kernel.STATE_SIZE,):
        y = np.concatenate((y, np.zeros(2)))
    if y.shape != (size,) or not np.all(np.isfinite(y)):
        raise ValueError(
            "initial_state must be 4 finite numbers (delta [m], delta' [m s-1], x [m], "
            "v [m s-1])" + (", or 6 with flight (and the gap h [m] >= 0 and its rate "
                            "[m s-1])" if flight else "") + f", got {initial_state!r}"
        )
    if flight and y[_kernel.GAP] < 0.0:
        raise ValueError(f"initial_state: the gap h = {float(y[_kernel.GAP])!r} m must be >= 0 "
                         "(the base cannot start below the table)")
    end = float(schedule.ends[-1])
    shortest = float(1.0 / np.max(schedule.frequency))
    if output_times is None:
        count = max(2, math.ceil(end / shortest * 64) + 1)
        check_samples(count, "the default output_times (64 a period of the schedule)")
        out_t = np.linspace(0.0, end, count)
    else:
        out_t = as_real_array("output_times", output_times, SECOND).ravel()
        check_samples(out_t.size, "output_times")
        if np.any(~np.isfinite(out_t)) or np.any(out_t < 0) or np.any(out_t > end):
            raise ValueError(f"output_times must lie within the schedule [0, {end}] s")
        if np.any(np.diff(out_t) < 0):
            raise ValueError("output_times must be sorted")
    omega = 2.0 * np.pi * schedule.frequency
    scale = _scales(structure, np.array([np.max(omega)]), flight)[0]
    fixed = shortest / settings.steps_per_period if settings.steps_per_period else 0.0
    airborne = flight and (y[_kernel.GAP] != 0.0 or y[_kernel.GAP_RATE] != 0.0)
    mode = _kernel.FLIGHT if airborne else int(np.sign(y[_kernel.V]))
    state = State(y, np.array([mode], dtype=np.int64),
                  np.array([0.0, settings.max_step * shortest]))
    # A writable copy: Schedule's arrays are read-only, and a read-only array is another
    # signature to numba (the integrator compiled twice, once for the kernels' own
    # calls).
    segments = Segments(schedule.starts, omega, np.array(schedule.acceleration),
                        schedule.start_phases_rad, schedule.ends)
    control = StepControl(settings.tolerance, settings.tolerance, scale, fixed,
                          settings.max_step * shortest, settings.event_tolerance * shortest,
                          settings.samples_per_step, settings.max_steps)
    start_gap = float(y[_kernel.GAP]) if flight else 0.0
    samples = Samples(out_t, np.empty((out_t.size, size)), np.empty(out_t.size, dtype=np.int64),
                      np.zeros(1, dtype=np.int64))
    events = EventLog(np.empty(max_events), np.empty(max_events, dtype=np.int64),
                      np.empty((max_events, size)), np.zeros(1, dtype=np.int64))
    stats = np.zeros(_kernel.STATS_SIZE)
    code = _kernel.integrate(p, segments, state, end, control, samples, events, stats)
    m = int(samples.count[0])
    e = min(int(events.count[0]), max_events)
    out_y = samples.y
    return Trajectory(
        time=out_t[:m],
        delta=out_y[:m, _kernel.DELTA].copy(),
        delta_rate=out_y[:m, _kernel.DELTA_RATE].copy(),
        x=out_y[:m, _kernel.X].copy(),
        v=out_y[:m, _kernel.V].copy(),
        mode=samples.mode[:m].astype(np.int8),
        event_time=events.t[:e].copy(),
        event_kind=events.kind[:e].astype(np.int8),
        event_state=events.y[:e].copy(),
        outcome=OUTCOMES[int(code)],
        end_time=float(state.clock[0]),
        steps=int(stats[_kernel.STEPS]),
        rejected_steps=int(stats[_kernel.REJECTED]),
        events_dropped=int(events.count[0]) - e,
        gap=out_y[:m, _kernel.GAP].copy() if flight else None,
        gap_rate=out_y[:m, _kernel.GAP_RATE].copy() if flight else None,
        airborne_time=float(stats[_kernel.AIRBORNE_TIME]),
        largest_hop=max(float(stats[_kernel.LARGEST_HOP]), start_gap),
        impacts=int(stats[_kernel.IMPACTS]),
    )


def steady_mode_state(structure: Structure, f: ArrayLike, a: ArrayLike) -> NDArray[np.float64]:
    """Canonical start of a steady orbit: at rest, drive phase 0, mode on its steady response.

    Returns
    -------
    numpy.ndarray
        ``(..., 4)`` states ``(delta [m], delta' [m s-1], 0, 0)``; the exact solver's
        orbit starts from the same state.
    """
    structure = check_structure(structure)
    f_arr, a_arr = np.broadcast_arrays(as_frequency(f), as_acceleration(a))
    amplitude = a_arr * math.cos(structure.alpha_rad) * mode_response(structure, f_arr)
    omega = 2.0 * np.pi * f_arr
    state = np.zeros((*f_arr.shape, 4))
    state[..., 0] = amplitude.real
    state[..., 1] = (1j * omega * amplitude).real
    return state


def _to_phase_zero(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
                   y0: NDArray[np.float64], phase: float, coupling: str,
                   friction: str | Friction, settings: IntegratorSettings
                   ) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """The states ``y0`` (rows, with flight) at drive phase ``phase`` [periods] carried
    by :func:`simulate` to the next phase 0 (the base's position dropped): where
    :func:`integrated_steady_state`'s whole periods begin. Also each row's status where
    that run did not complete (``FRICTION_PARADOX``, else ``NOT_CONVERGED``; -1 where it
    did), its state then left at 0."""
    carried = np.zeros_like(y0)
    failed = np.full(f.size, -1, dtype=np.int8)
    for i in range(f.size):
        duration = (1.0 - phase) / f[i]
        run = simulate(structure, Schedule.constant(f[i], a[i], duration, 360.0 * phase),
                       coupling=coupling, friction=friction, initial_state=y0[i],
                       output_times=[duration], settings=settings, max_events=0,
                       flight=True)
        if run.outcome != "completed" or run.gap is None or run.gap_rate is None:
            failed[i] = (codes.FRICTION_PARADOX if run.outcome == "friction_paradox"
                         else codes.NOT_CONVERGED)
            continue
        carried[i] = (run.delta[-1], run.delta_rate[-1], 0.0, run.v[-1], run.gap[-1],
                      run.gap_rate[-1])
    return carried, failed


def integrated_steady_state(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    *,
    coupling: str = DEFAULT_COUPLING,
    friction: str | Friction = DEFAULT_FRICTION,
    settings: IntegratorSettings | None = None,
    parallel: bool | None = None,
    flight: bool = False,
    start: str | Drop = "release",
) -> SteadyState:
    """Steady orbit at each ``(f, a)`` by time integration until the motion repeats.

    Starts from the ``start`` (by default :func:`steady_mode_state`, the exact solver's
    release) and integrates whole drive periods until the state at the period boundaries and the
    displacement per period repeat (see :class:`IntegratorSettings`). With two-way
    coupling the mode's transient must decay first: about ``Q / pi`` periods per
    factor ``e``.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0. Broadcast against ``a``.
    a : array_like
        Drive acceleration amplitude [m s-2], >= 0.
    coupling : {"one-way", "two-way"}
        See :func:`simulate`.
    friction : str or Friction
        The friction law; see :func:`simulate`.
    settings : IntegratorSettings, optional
        Accuracy and budgets.
    parallel : bool, optional
        Spread points over all cores; default for inputs of at least
        ``PARALLEL_THRESHOLD`` points.
    flight : bool
        The lift-off law (see :func:`simulate`): with True (two-way coupling, ``M < 1``)
        an orbit with flight is ``BOUNCING``, with its velocity.
    start : {"release", "switch-on"} or Drop, default "release"
        The state the motion starts from, as the exact solver's ``start``
        (:class:`study.solvers.settings.SolverSettings`, docs/theory/starts.md): the same
        states, so that the integrator checks the exact solver from each.
        ``"switch-on"``: every state 0 at phase 0; a :class:`~study.model.starts.Drop`
        (needs ``flight=True``): at rest at its height, the mode at rest, at its phase
        (a drop at a phase other than 0 is first integrated by :func:`simulate` to the
        next phase 0, one point at a time). Other than ``"release"`` needs two-way
        coupling.

    Returns
    -------
    SteadyState
        As :func:`study.solvers.exact.steady_state`; ``LIFT_OFF`` when ``n < 0`` is met on the
        way without flight (with two-way coupling it can come from the sliding itself),
        ``FRICTION_PARADOX`` when a two-way slip (or an impact) has no unique solution.
        With flight also ``airborne_fraction`` [1], ``largest_hop`` [m] (the highest
        apex of the orbit) and ``impacts_per_period`` [1] (rebounds included).
    """
    structure = check_structure(structure)
    settings = check_integrator_settings(settings)
    p = model_parameters(structure, coupling, friction, flight)
    flight = bool(p[sv.LIFT_OFF_LAW] == LAWS["lift_off"]["flight"].code)
    size = _state_size(flight)
    f_arr, a_arr = np.broadcast_arrays(as_frequency(f), as_acceleration(a))
    shape = f_arr.shape
    # Copies: numba is never handed a broadcast view (numpy warns of its write flag).
    f_flat = np.array(f_arr, dtype=float).ravel()
    a_flat = np.array(a_arr, dtype=float).ravel()
    n = f_flat.size
    omega = 2.0 * np.pi * f_flat
    period = 1.0 / f_flat  # f > 0, checked by as_frequency
    start = check_start(DEFAULT_SETTINGS, as_start(start), check_coupling(coupling),
                        flight).start
    y0 = np.zeros((n, size))
    failed = np.full(n, -1, dtype=np.int8)
    # The declared initial state (study.model.starts), as the exact solver's kernels
    # read it: the mode on a multiple of its steady stick response, the base at a
    # height, at a drive phase.
    phase, factor, height = kernel_fields(start)
    if factor != 0.0:
        if phase != 0.0:
            raise ValueError(
                f"start {start_label(start)!r}: the integrator starts the mode on its "
                "steady stick response at drive phase 0 only; allowed: "
                f"{START_ALLOWED}")
        mode = steady_mode_state(structure, f_flat, a_flat).reshape(n, 4)
        y0[:, :_kernel.STATE_SIZE] = mode if factor == 1.0 else factor * mode
    if height != 0.0:
        y0[:, _kernel.GAP] = height
    if phase != 0.0:
        y0, failed = _to_phase_zero(structure, f_flat, a_flat, y0, phase, coupling,
                                    friction, settings)
    scale = np.ascontiguousarray(_scales(structure, omega, flight).reshape(n, size))
    if settings.steps_per_period:
        fixed = period / settings.steps_per_period
    else:
        fixed = np.zeros(n)
    results = np.zeros((n, _kernel.RESULT_SIZE))
    if parallel is None:
        parallel = n >= PARALLEL_THRESHOLD // 64
    points = _kernel.Points(omega, a_flat, y0, scale, np.ascontiguousarray(fixed),
                            settings.max_step * period, settings.event_tolerance * period)
    search = _kernel.PeriodicSearch(
        settings.tolerance, settings.tolerance, settings.samples_per_step, settings.max_steps,
        settings.max_periods, settings.max_orbit_period, settings.resolved_period_tolerance)
    kernel = _kernel.periodic_points if parallel else _kernel.periodic_points_serial
    kernel(p, points, search, results)
    # A drop whose run to phase 0 did not complete has no motion to report.
    lost = failed >= 0
    if np.any(lost):
        results[lost] = 0.0
        results[lost, _kernel.R_STATUS] = failed[lost]
        results[lost, _kernel.R_REASON] = np.where(failed[lost] == codes.NOT_CONVERGED,
                                                   codes.REASON_EVENT_BUDGET, codes.REASON_NONE)
        for name in ("VELOCITY", "SLIPS", "FORWARD", "BACKWARD", "AIRBORNE", "HOP",
                     "IMPACTS"):
            results[lost, getattr(_kernel, "R_" + name)] = np.nan
    column = {name: results[:, getattr(_kernel, "R_" + name.upper())]
              for name in ("status", "reason", "velocity", "slips", "forward", "backward",
                           "orbit_period", "airborne", "hop", "impacts")}
    flown = {
        "airborne_fraction": scalar_if_0d(column["airborne"].reshape(shape)),
        "largest_hop": scalar_if_0d(column["hop"].reshape(shape)),
        "impacts_per_period": scalar_if_0d(column["impacts"].reshape(shape)),
    } if flight else {}
    return SteadyState(
        velocity=scalar_if_0d(column["velocity"].reshape(shape)),
        status=scalar_if_0d(column["status"].astype(np.int8).reshape(shape)),
        reason=scalar_if_0d(column["reason"].astype(np.int8).reshape(shape)),
        slips_per_period=scalar_if_0d(column["slips"].reshape(shape)),
        forward_fraction=scalar_if_0d(column["forward"].reshape(shape)),
        backward_fraction=scalar_if_0d(column["backward"].reshape(shape)),
        orbit_period=scalar_if_0d(column["orbit_period"].astype(np.int32).reshape(shape)),
        **flown,
    )
