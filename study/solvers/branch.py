"""Branches of periodic orbits: a motion continued in one drive parameter through its
folds, with its bifurcations located.

:func:`trace` is the validating wrapper of :func:`study.kernels.two_way.bifurcations.
trace_branch`: it finds the orbit the start reaches at ``(f, a)`` (or polishes a state
given), traces its branch along ``f`` or ``a`` towards ``to`` on the exact period map
and returns the raw :class:`Trace` (the kernel's named columns); the labelled
``xarray.Dataset`` is :func:`study.analyses.branches.branch`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels.two_way import bifurcations as trace_kernel
from study.kernels.two_way import branch as branch_kernel
from study.model import as_acceleration, as_frequency
from study.model.bifurcations import KINDS, LOCATED, NOT_CONVERGED
from study.model.codes import (
    BIFURCATION_FOLD,
    BIFURCATION_PERIOD_DOUBLING,
    BIFURCATION_TORUS,
)
from study.model.starts import START_ALLOWED, START_TYPES, Drop, start_label
from study.model.status import Status
from study.model.structure import Structure, check_structure
from study.solvers.exact import steady_state
from study.solvers.integrator import steady_mode_state
from study.solvers.settings import (
    SolverSettings,
    check_coupling,
    check_flight,
    check_settings,
    check_start,
    kernel_budget,
)
from study.solvers.structure_constants import structure_vector

#: The drive parameters a branch is continued in: frequency [Hz] or acceleration [m s-2].
BRANCH_AXES = ("f", "a")
#: Steps of a branch by default, and the longest step (in the scaled space of the state
#: in its natural sizes and the drive, the whole way to ``to`` being 1).
DEFAULT_MAX_STEPS = 400
DEFAULT_MAX_STEP = 0.02
#: Bifurcations recorded on a branch at most.
MAX_BIFURCATIONS = 256
#: The largest test-function value of a located smooth bifurcation (fold, period
#: doubling, torus): 100 times the tracer's own tolerance, whose regula falsi may also
#: stop on a bracket already within 1e-10 of the drive.
LOCATION_TEST_TOLERANCE = 100.0 * trace_kernel.TEST_TOLERANCE
_SMOOTH = (BIFURCATION_FOLD, BIFURCATION_PERIOD_DOUBLING, BIFURCATION_TORUS)
#: The statuses whose motion is a periodic orbit (or the static point) to continue.
_ORBITS = (Status.STATIC, Status.STICK_SLIP, Status.CONTINUOUS_SLIDING, Status.BOUNCING)


@dataclass(frozen=True)
class Trace:
    """A traced branch, as the kernel wrote it.

    Attributes
    ----------
    steps : numpy.ndarray
        One row a step, :data:`study.kernels.two_way.bifurcations.STEP_COLUMNS`.
    multipliers : numpy.ndarray of complex
        The Floquet multipliers of each step (steps x the state's dimension).
    bifurcations : numpy.ndarray
        One row a located bifurcation,
        :data:`study.kernels.two_way.bifurcations.BIFURCATION_COLUMNS`.
    jacobians : numpy.ndarray
        The Jacobian of ``P^periods`` at each bifurcation (on its section).
    end : int
        Why the trace ended (``study.model.codes.BRANCH_*``).
    omega0, a0, omega1, a1 : float
        The segment traced along: ``t`` from ``(omega0, a0)`` to ``(omega1, a1)``
        [rad s-1, m s-2].
    periods : int
        The orbit's period in drive periods.
    newton_passes, map_passes : float
        Passes of the period map with and without its Jacobian.
    flight : bool
        Whether the base may fly.
    """

    steps: NDArray[np.float64]
    multipliers: NDArray[np.complex128]
    bifurcations: NDArray[np.float64]
    jacobians: NDArray[np.float64]
    end: int
    omega0: float
    a0: float
    omega1: float
    a1: float
    periods: int
    newton_passes: float
    map_passes: float
    flight: bool
    reference: NDArray[np.float64]

    def column(self, name: str) -> NDArray[np.float64]:
        """The step column ``name`` (:data:`~study.kernels.two_way.bifurcations.
        STEP_COLUMNS`)."""
        return self.steps[:, _index(trace_kernel.STEP_COLUMNS, name)]

    def bifurcation_column(self, name: str) -> NDArray[np.float64]:
        """The bifurcation column ``name``."""
        return self.bifurcations[:, _index(trace_kernel.BIFURCATION_COLUMNS, name)]

    def bifurcation_locations(self) -> NDArray[np.int8]:
        """How each bifurcation was placed
        (:data:`study.model.bifurcations.LOCATION_FLAGS`): ``located`` where its
        crossing multiplier is known and, for a smooth kind (fold, period doubling,
        torus), its test function is within :data:`LOCATION_TEST_TOLERANCE`;
        ``not_converged`` otherwise."""
        kind = self.bifurcation_column("kind").astype(int)
        smooth = np.isin(kind, _SMOOTH)
        known = np.isfinite(self.bifurcation_column("multiplier_real"))
        near = np.abs(self.bifurcation_column("test")) <= LOCATION_TEST_TOLERANCE
        return np.where(known & (near | ~smooth), LOCATED, NOT_CONVERGED).astype(np.int8)

    def states(self) -> NDArray[np.float64]:
        """The orbit's state on the section at each step (steps x the state's
        dimension) [m, m s-1, m s-1, m, m s-1]."""
        n = self.multipliers.shape[1]
        return self.steps[:, trace_kernel.S_STATE:trace_kernel.S_STATE + n]

    def bifurcation_states(self) -> NDArray[np.float64]:
        """The orbit's state on the section at each located bifurcation."""
        n = self.jacobians.shape[1]
        return self.bifurcations[:, trace_kernel.B_STATE:trace_kernel.B_STATE + n]

    @classmethod
    def of_bifurcations(cls, *, kind: ArrayLike, t: ArrayLike, section: ArrayLike,
                        state: ArrayLike, step: ArrayLike, jacobians: ArrayLike,
                        omega0: float, a0: float, omega1: float, a1: float, periods: int,
                        flight: bool, reference: ArrayLike) -> Trace:
        """A trace that holds only located bifurcations (as a result file keeps them):
        enough to start a branch from one, as :func:`doubled_trace` does."""
        state = np.asarray(state, dtype=float)
        n = state.shape[1]
        rows = np.full((state.shape[0], trace_kernel.N_BIFURCATION), np.nan)
        rows[:, trace_kernel.B_KIND] = kind
        rows[:, trace_kernel.B_T] = t
        rows[:, trace_kernel.B_SECTION] = section
        rows[:, trace_kernel.B_STATE:trace_kernel.B_STATE + n] = state
        rows[:, trace_kernel.B_STEP] = step
        return cls(steps=np.zeros((0, trace_kernel.N_STEP)),
                   multipliers=np.zeros((0, n), complex), bifurcations=rows,
                   jacobians=np.asarray(jacobians, dtype=float), end=0, omega0=omega0,
                   a0=a0, omega1=omega1, a1=a1, periods=periods, newton_passes=0.0,
                   map_passes=0.0, flight=flight,
                   reference=np.asarray(reference, dtype=float))

    def drive(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(f, a)`` [Hz, m s-2] at the segment's ``t``."""
        t = np.asarray(t, dtype=float)
        omega = self.omega0 + t * (self.omega1 - self.omega0)
        return omega / (2.0 * np.pi), self.a0 + t * (self.a1 - self.a0)


def _index(columns: tuple[tuple[str, str, str], ...], name: str) -> int:
    names = [column[0] for column in columns]
    if name not in names:
        raise KeyError(f"no column {name!r}; allowed: {', '.join(names)}")
    return names.index(name)


def check_along(along: object) -> str:
    """``along`` if it is one of :data:`BRANCH_AXES`, else a ValueError naming them."""
    if not isinstance(along, str) or along not in BRANCH_AXES:
        raise ValueError(f"branch: 'along' must be one of {list(BRANCH_AXES)}, got "
                         f"{along!r}")
    return str(along)


def _drive_value(name: str, value: object, check: object) -> float:
    """A drive value, one number checked by ``check`` (``as_frequency`` or
    ``as_acceleration``), its refusal naming the argument ``name``."""
    if np.ndim(value) != 0:
        raise ValueError(f"branch: {name!r} must be one number, got {value!r}")
    try:
        return float(check(value))
    except (TypeError, ValueError) as err:
        raise ValueError(f"branch: {name!r}: {err}") from None


def _check_count(name: str, value: object, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer
                                                 | np.floating):
        raise ValueError(f"branch: {name!r} must be a number in [{low:g}, {high:g}], got "
                         f"{value!r}")
    value = float(value)
    if not low <= value <= high:
        raise ValueError(f"branch: {name!r} must be in [{low:g}, {high:g}], got {value!r}")
    return value


def start_orbit(structure: Structure, f: float, a: float, start: str | Drop | ArrayLike,
                flight: bool, settings: SolverSettings,
                periods: int | None) -> tuple[NDArray[np.float64], int, str]:
    """The state at phase 0 ``(delta, delta', v, h, h')`` [m, m s-1, m s-1, m, m s-1] of
    the orbit to continue, its period [drive periods] and the start's label: the motion
    the named ``start`` reaches at ``(f, a)`` [Hz, m s-2] (an orbit, or the static
    point's steady stick response), or a state given (an array of 5, or 3 without
    flight), with ``periods`` (default 1), polished by Newton's method."""
    if isinstance(start, START_TYPES):
        settings = check_start(settings, start, "two-way", flight)
        orbit = steady_state(structure, f, a, settings, coupling="two-way", flight=flight)
        status = Status(int(orbit.status))
        if status not in _ORBITS:
            raise ValueError(
                f"branch: the motion the start {start_label(settings.start)!r} reaches at "
                f"f = {f:g} Hz, a = {a:g} m s-2 is {status.name.lower()}, not a periodic "
                "orbit to continue; start elsewhere, or give the orbit's state at phase "
                "0 as start=")
        if status == Status.STATIC:
            state = np.zeros(5)
            state[:2] = steady_mode_state(structure, f, a)[:2]
            return state, 1, start_label(settings.start)
        state = np.array(orbit.phase_state, dtype=float).reshape(5)
        state[~np.isfinite(state)] = 0.0
        return state, int(orbit.orbit_period), start_label(settings.start)
    try:
        state = np.asarray(start, dtype=float).ravel()
    except (TypeError, ValueError):
        state = np.zeros(0)
    if state.size not in (3, 5) or not np.all(np.isfinite(state)):
        raise ValueError(f"branch: start must be {START_ALLOWED}, or the "
                         "orbit's state at phase 0, (delta, delta', v[, h, h']) [m, m s-1, "
                         f"m s-1, m, m s-1], finite; got {start!r}")
    full = np.zeros(5)
    full[:state.size] = state
    count = 1 if periods is None else int(periods)
    if count < 1 or count > 64:
        raise ValueError(f"branch: 'periods' must be an integer in [1, 64], got {periods!r}")
    vector = structure_vector(structure, "two-way", flight)
    work = branch_kernel.new_branch_work(vector)
    omega = 2.0 * np.pi * f
    if not branch_kernel.polish_orbit(vector, omega, a, full, count, work,
                                      int(settings.max_events)):
        raise ValueError(
            f"branch: Newton's method from the state given does not reach an orbit of "
            f"{count} period(s) at f = {f:g} Hz, a = {a:g} m s-2")
    return full, count, "a state given"


def trace(structure: Structure, f: float, a: float, *, along: str, to: float,
          start: str | Drop | ArrayLike = "release", coupling: str = "two-way",
          flight: bool = False, settings: SolverSettings | None = None,
          periods: int | None = None, max_steps: int = DEFAULT_MAX_STEPS,
          max_step: float = DEFAULT_MAX_STEP) -> tuple[Trace, str]:
    """The branch of the periodic orbit reached from ``start`` at ``(f, a)`` [Hz,
    m s-2], traced along ``along`` towards ``to`` [Hz or m s-2]; see
    :func:`study.analyses.branches.branch`. Returns the raw :class:`Trace` and the
    start's label."""
    structure = check_structure(structure)
    coupling = check_coupling(coupling)
    if coupling != "two-way":
        raise ValueError(f"branch: coupling must be 'two-way' (the period map of the "
                         f"exact two-way solver is continued), got {coupling!r}")
    flight = check_flight(flight, coupling, structure)
    settings = check_settings(settings, coupling)
    along = check_along(along)
    f = _drive_value("f", f, as_frequency)
    a = _drive_value("a", a, as_acceleration)
    to = _drive_value("to", to, as_frequency if along == "f" else as_acceleration)
    here = f if along == "f" else a
    if to == here:
        raise ValueError(f"branch: 'to' must differ from the start's {along} = {here:g}")
    count = int(_check_count("max_steps", max_steps, 2, 1e6))
    longest = _check_count("max_step", max_step, 1e-6, 1.0)
    state, orbit_periods, label = start_orbit(structure, f, a, start, flight, settings,
                                              periods)
    omega0 = 2.0 * np.pi * f
    segment = branch_kernel.Segment(omega0, a, 2.0 * np.pi * to if along == "f" else omega0,
                                    a if along == "f" else to)
    return _run(structure, segment, state, orbit_periods, np.zeros(trace_kernel.N_EXTENDED),
                -1.0, flight, settings, count, longest), label


def trace_from_section(structure: Structure, f: float, a: float, *, along: str,
                       to: float, state: ArrayLike, section: float, periods: int,
                       flight: bool, settings: SolverSettings | None = None,
                       max_steps: int = DEFAULT_MAX_STEPS,
                       max_step: float = DEFAULT_MAX_STEP, sought: int = 0) -> Trace:
    """The branch through the orbit near ``state`` on the section at ``section`` (a
    fraction of the period of ``periods`` drive periods from phase 0) at ``(f, a)``
    [Hz, m s-2], traced along ``along`` towards ``to``: a neighbour's orbit (the same
    section, a nearby drive) corrected by Newton's method there, then continued. The
    trace's ``end`` is ``BRANCH_LOST`` where the correction does not converge.

    ``sought`` (a ``study.model.codes.BIFURCATION_*`` code) locates that kind of
    bifurcation only and ends the trace on the step past the first one
    (``BRANCH_STOPPED``); 0, the default, locates every kind and runs on."""
    structure = check_structure(structure)
    settings = check_settings(settings, "two-way")
    along = check_along(along)
    count = int(_check_count("max_steps", max_steps, 2, 1e6))
    longest = _check_count("max_step", max_step, 1e-6, 1.0)
    f = _drive_value("f", f, as_frequency)
    a = _drive_value("a", a, as_acceleration)
    to = _drive_value("to", to, as_frequency if along == "f" else as_acceleration)
    full = np.zeros(5)
    given = np.asarray(state, dtype=float).ravel()
    full[:given.size] = given
    omega0 = 2.0 * np.pi * f
    segment = branch_kernel.Segment(omega0, a, 2.0 * np.pi * to if along == "f" else omega0,
                                    a if along == "f" else to)
    if sought not in (0, *(kind.code for kind in KINDS)):
        raise ValueError(f"trace_from_section: 'sought' must be 0 or a bifurcation's "
                         f"code {[kind.code for kind in KINDS]}, got {sought!r}")
    return _run(structure, segment, full, int(periods), np.zeros(trace_kernel.N_EXTENDED),
                float(section), bool(flight), settings, count, longest, int(sought))


def _run(structure: Structure, segment: object, state: NDArray[np.float64], periods: int,
         start_tangent: NDArray[np.float64], section: float, flight: bool,
         settings: SolverSettings, max_steps: int, max_step: float,
         sought: int = 0) -> Trace:
    """Allocate and call the kernel."""
    vector = structure_vector(structure, "two-way", flight)
    steps = np.full((max_steps, trace_kernel.N_STEP), np.nan)
    real = np.full((max_steps, 5), np.nan)
    imag = np.full((max_steps, 5), np.nan)
    bifurcations = np.full((MAX_BIFURCATIONS, trace_kernel.N_BIFURCATION), np.nan)
    jacobians = np.zeros((MAX_BIFURCATIONS, 5, 5))
    work = branch_kernel.new_branch_work(vector)
    n_steps, n_bifurcations, end, newton, mapped = trace_kernel.trace_branch(
        vector, segment, np.ascontiguousarray(state, dtype=float), periods,
        np.ascontiguousarray(start_tangent, dtype=float), section, work,
        trace_kernel.new_trace_work(), int(kernel_budget(settings).max_events), max_steps,
        max_step, sought, steps, real, imag, bifurcations, jacobians)
    n = 5 if flight else 3
    order = np.argsort(bifurcations[:n_bifurcations, trace_kernel.B_STEP], kind="stable")
    return Trace(steps=steps[:n_steps],
                 multipliers=(real[:n_steps, :n] + 1j * imag[:n_steps, :n]),
                 bifurcations=bifurcations[:n_bifurcations][order],
                 jacobians=jacobians[:n_bifurcations][order][:, :n, :n], end=int(end),
                 omega0=float(segment.omega0), a0=float(segment.a0),
                 omega1=float(segment.omega1), a1=float(segment.a1), periods=int(periods),
                 newton_passes=float(newton), map_passes=float(mapped), flight=flight,
                 reference=np.array(work.reference[:n]))


def doubled_trace(structure: Structure, parent: Trace, index: int, *, to: float | None,
                  settings: SolverSettings | None = None,
                  max_steps: int = DEFAULT_MAX_STEPS,
                  max_step: float = DEFAULT_MAX_STEP) -> Trace:
    """The branch of the orbit of twice the period born at the period doubling
    ``index`` of ``parent``'s bifurcations, traced towards ``to`` (default: the end of
    the parent's segment): it leaves the parent's orbit along the eigenvector of the
    multiplier -1, with the drive stationary there."""
    structure = check_structure(structure)
    settings = check_settings(settings, "two-way")
    count = int(_check_count("max_steps", max_steps, 2, 1e6))
    longest = _check_count("max_step", max_step, 1e-6, 1.0)
    kinds = parent.bifurcation_column("kind")
    if not 0 <= index < kinds.size or int(kinds[index]) != BIFURCATION_PERIOD_DOUBLING:
        doublings = [i for i in range(kinds.size)
                     if int(kinds[i]) == BIFURCATION_PERIOD_DOUBLING]
        raise ValueError(f"branch: bifurcation {index!r} is not a period doubling of the "
                         f"branch; its period doublings: {doublings}")
    row = parent.bifurcations[index]
    n = 5 if parent.flight else 3
    values, vectors = np.linalg.eig(parent.jacobians[index])
    vector = np.real(vectors[:, int(np.argmin(np.abs(values + 1.0)))])
    tangent = np.zeros(trace_kernel.N_EXTENDED)
    tangent[:n] = vector
    state = np.zeros(5)
    state[:n] = row[trace_kernel.B_STATE:trace_kernel.B_STATE + n]
    t = row[trace_kernel.B_T]
    f_here, a_here = parent.drive(t)
    f_end, a_end = parent.drive(1.0)
    if to is not None:
        if parent.omega1 != parent.omega0:
            f_end = float(as_frequency(to))
        else:
            a_end = float(as_acceleration(to))
    segment = branch_kernel.Segment(2.0 * np.pi * float(f_here), float(a_here),
                                    2.0 * np.pi * float(f_end), float(a_end))
    # The section's time is the same: half the fraction of the doubled period.
    return _run(structure, segment, state, 2 * parent.periods, tangent,
                0.5 * float(row[trace_kernel.B_SECTION]), parent.flight, settings, count,
                longest)
