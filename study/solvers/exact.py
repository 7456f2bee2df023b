"""Public exact steady-state solvers: validate, allocate, call the numba kernels.

Each function here checks its arguments, flattens and allocates the arrays, packs the
kernel's named arguments (:class:`study.kernels.budget.Budget`, the structure vector,
the one-way kernel's named tuples) and calls the kernel's driver, which loops over the
points (:mod:`study.kernels.one_way` for the one-way coupling,
:mod:`study.kernels.two_way.points` and :mod:`study.kernels.two_way.attractors` for the
orbit with the mode as a state). Results are read from the kernels' outputs by the
names they declare.
"""

from __future__ import annotations

import dataclasses
import functools
import operator
import struct
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels import one_way as one_way_kernel
from study.kernels.budget import Budget
from study.kernels.start import Start
from study.kernels.two_way import attractors as attractor_kernel
from study.kernels.two_way import points as orbit_kernel
from study.kernels.two_way import section as section_kernel
from study.model import (
    as_acceleration,
    as_frequency,
    lift_off_acceleration,
    release_amplitudes,
    slip_amplitudes,
)
from study.model.contact import (
    COUPLINGS,
    DEFAULT_COUPLING,
    DEFAULT_FRICTION,
    DEFAULT_LIFT_OFF,
    Friction,
    check_friction,
)
from study.model.inputs import InputTypeError, instance_of
from study.model.starts import (
    DEFAULT_START,
    START_NAMES,
    Drop,
    as_start,
    canonical,
    kernel_fields,
    refusal,
)
from study.model.status import Status
from study.model.structure import Structure, check_structure
from study.solvers.packing import structure_entries, with_laws

__all__ = [
    "COUPLINGS",
    "DEFAULT_COUPLING",
    "MAX_SOLVER_BUDGET",
    "SECTION_PERIODS",
    "START_NAMES",
    "Attractors",
    "Drop",
    "PhaseSection",
    "SolverSettings",
    "SteadyState",
    "attractors",
    "check_coupling",
    "check_flight",
    "check_settings",
    "check_start",
    "phase_section",
    "steady_state",
    "steady_velocity",
]

#: Version of the steady-state algorithm; changes whenever its results may change.
SOLVER_VERSION = "9"

#: Largest budget of each :class:`SolverSettings` field: 100 times the default slip
#: events (a budget only bounds pathological points; at about 1 us an event, 1e6 events
#: and 1e6 circle-map iterations of 1e6 events each bound a point's work), and far
#: below the int64 the kernels take (2**63 wrapped to a negative budget and answered
#: NOT_CONVERGED). The spec schema's ``[solver]`` maxima are exported from it.
MAX_SOLVER_BUDGET = {"max_events": 1_000_000, "max_map_iterations": 1_000_000,
                     "max_average_periods": 1_000_000}
#: Smallest budget of each :class:`SolverSettings` field (1 but for the averaged
#: periods: an irregular motion's averages are first examined after 256 periods).
MIN_SOLVER_BUDGET = {"max_events": 1, "max_map_iterations": 1, "max_average_periods": 256}
#: The settings of the averaging of irregular motions.
AVERAGING_SETTINGS = ("velocity_tolerance", "max_average_periods")
#: Range of :attr:`SolverSettings.velocity_tolerance` [1], open below.
VELOCITY_TOLERANCE_RANGE = (0.0, 1.0)

#: Inputs with at least this many points are solved by the parallel kernel.
PARALLEL_THRESHOLD = 2048

def kernel_start(start: str | Drop) -> Any:
    """The kernels' :data:`~study.kernels.start.Start` of a checked ``start`` (its
    declared :func:`~study.model.starts.kernel_fields`)."""
    return Start(*kernel_fields(start))


@dataclass(frozen=True)
class SolverSettings:
    """Budgets of the exact steady-state solver, and whether two-way orbits are continued
    along a sweep.

    Parameters
    ----------
    max_events : int
        Slip events followed from rest before a point is declared not converged
        (``NonConvergence.EVENT_BUDGET``), 1 to 1e6 (:data:`MAX_SOLVER_BUDGET`). An
        orbit with a stick closes after a few events; the budget only bounds
        pathological points.
    max_map_iterations : int
        Iterations of the continuous-sliding circle map searched for an attracting
        cycle before ``NonConvergence.NO_PERIODIC_ORBIT``, 1 to 1e6.
    velocity_tolerance : float
        An irregular motion (no stable cycle within reach: ``CHAOTIC`` or
        ``QUASI_PERIODIC``) is averaged over the period map's iterates (one-way: the
        continuous-sliding circle map's) until the 95 % confidence half-width of its
        mean velocity is within this fraction of ``a / (2 pi f)`` [1], in (0, 1].
        Default 1e-3 (about 1100 periods of a chaotic bouncing motion).
    max_average_periods : int
        Periods an irregular motion is averaged over at most (one-way: circle-map
        iterates), 256 to 1e6; a motion whose mean is still outside the tolerance then is
        ``NOT_CONVERGED`` (``NonConvergence.AVERAGE_BUDGET``), its partial averages'
        error, periods and exponent kept. Default 20 000.
    continuation : bool
        Two-way coupling only: start each orbit's Newton search from the fixed points of
        the points before it along its line of the sweep (a column of accelerations at
        one frequency, or a row of frequencies at one acceleration) instead of from rest.
        Two to four times faster on a fine map, the same orbit as from rest wherever only
        one is stable; where several are, the continued orbit follows its neighbours'
        branch, as a slowly swept drive would (docs/theory/two-way.md), and a point's
        value depends on the grid it is part of. Default False: every point from rest.
        Not with a ``start`` other than ``"release"``: a start is a protocol for each
        point, which continuing from the neighbours would replace.
    start : str or Drop
        Two-way coupling only: the state each point's motion starts from, a physical
        protocol (docs/theory/starts.md): ``"release"`` (default: the base at rest on the
        table at drive phase 0, the mode on its steady stick response, as if held down
        while the table shakes, then let go), ``"switch-on"`` (the base at rest on the
        table, the mode at rest at ``delta = delta' = 0``, the drive switched on at phase
        0), or a :class:`Drop` (the base held at rest above the table, mode at rest at
        0, let go at a drive phase; needs ``flight=True``). A mapping ``{"drop": height,
        "phase": phase}`` is taken for a :class:`Drop`. Where several motions are
        stable, the start decides which one the point reports.

    Raises
    ------
    ValueError
        A budget that is not an integer (:class:`study.model.inputs.InputTypeError`, also
        a TypeError) or is outside its range, naming the field; ``continuation`` not a
        bool (an InputTypeError); a ``start`` that is none of the allowed values, or
        other than ``"release"`` with ``continuation``.
    """

    max_events: int = 10_000
    max_map_iterations: int = 5_000
    continuation: bool = False
    velocity_tolerance: float = 1e-3
    max_average_periods: int = 20_000
    start: str | Drop = DEFAULT_START

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", as_start(self.start))
        if not isinstance(self.continuation, bool | np.bool_):
            raise InputTypeError(
                f"solver setting 'continuation' must be True or False, got "
                f"{type(self.continuation).__name__}: {self.continuation!r}")
        object.__setattr__(self, "continuation", bool(self.continuation))
        for name, largest in MAX_SOLVER_BUDGET.items():
            value = getattr(self, name)
            smallest = MIN_SOLVER_BUDGET[name]
            if isinstance(value, bool | np.timedelta64) or not isinstance(
                    value, int | np.integer):
                raise InputTypeError(
                    f"solver setting {name!r} must be an integer >= {smallest} and <= "
                    f"{largest}, got {value!r}")
            if not smallest <= value <= largest:
                raise ValueError(
                    f"solver setting {name!r} must be an integer >= {smallest} and <= "
                    f"{largest}, got {value!r}")
        tolerance = self.velocity_tolerance
        low, high = VELOCITY_TOLERANCE_RANGE
        if isinstance(tolerance, bool) or not isinstance(tolerance, int | float | np.floating
                                                          | np.integer):
            raise InputTypeError(
                f"solver setting 'velocity_tolerance' must be a number in ({low:g}, "
                f"{high:g}], got {tolerance!r}")
        if not low < float(tolerance) <= high:
            raise ValueError(
                f"solver setting 'velocity_tolerance' must be in ({low:g}, {high:g}] (a "
                f"fraction of a / (2 pi f)), got {tolerance!r}")
        object.__setattr__(self, "velocity_tolerance", float(tolerance))
        if self.continuation and self.start != "release":
            raise ValueError(_CONTINUED_START.format(start=self.start))

    def averaging_changes(self) -> dict[str, float | int]:
        """The averaging settings of irregular motions (``velocity_tolerance``,
        ``max_average_periods``) that differ from their defaults: canonical specs and
        cache keys name them only then, so that those written before them keep their
        fingerprints."""
        return {name: getattr(self, name) for name in AVERAGING_SETTINGS
                if getattr(self, name) != getattr(DEFAULT_SETTINGS, name)}

    def start_changes(self) -> dict[str, str | dict[str, float]]:
        """``{"start": ...}`` (the name, or a drop's ``{"drop": height, "phase":
        phase}``) when the start is not the release, else nothing: canonical specs and
        cache keys name it only then, so that those written before starts were named
        keep their fingerprints."""
        if self.start == DEFAULT_START:
            return {}
        return {"start": canonical(self.start)}


#: Why continuation and a start other than the release exclude each other.
_CONTINUED_START = (
    "solver setting 'start' = {start!r} with continuation = True: a start is the protocol "
    "each point's motion begins with, and continuing from the neighbours' orbits would "
    "replace it; allowed: start = \"release\" with continuation, or continuation = False")


#: The settings of ``settings=None``: frozen, so one instance serves every call.
DEFAULT_SETTINGS = SolverSettings()


@dataclass(frozen=True)
class SteadyState:
    """Steady periodic orbit at each drive point, arrays of the broadcast shape.

    Every attribute has the broadcast shape of the ``f`` and ``a`` given, or is a numpy
    scalar of the same dtype when both were scalars (as numpy's ufuncs return).

    Attributes
    ----------
    velocity : numpy.ndarray of float64
        Mean velocity over the periodic orbit [m s-1]; exactly 0 for ``STATIC``,
        NaN for ``LIFT_OFF``, ``NOT_CONVERGED`` and ``FRICTION_PARADOX``.
    status : numpy.ndarray of int8
        :class:`~study.model.status.Status` codes [1] (``study.Status(code)`` names one).
    reason : numpy.ndarray of int8
        :class:`~study.model.status.NonConvergence` codes [1].
    slips_per_period : numpy.ndarray
        Slip events per drive period [1].
    forward_fraction, backward_fraction : numpy.ndarray
        Fractions of the drive period spent slipping forward and backward [1].
    orbit_period : numpy.ndarray of int32
        Period of the orbit in drive periods (0 when there is no orbit).
    floquet_multiplier : numpy.ndarray or None
        Largest modulus of the orbit's Floquet multipliers on the state
        ``(delta, delta', v)`` [1] (< 1: the orbit attracts its neighbours; for
        ``STATIC`` the mode's free decay over a period; NaN without an orbit). Good to
        about 1e-7 relative (taken within the last Newton step of the orbit).
        Computed by the two-way solver; ``None`` from solvers that do not compute it.
        With ``flight=True`` the Jacobian includes the flight's flow and the impacts'
        saltation matrices, on the state ``(delta, delta', v, h, h')``.
    airborne_fraction : numpy.ndarray or None
        Fraction of the orbit's period the base spends off the table [1] (0 for an
        orbit that never leaves it; NaN without an orbit). ``None`` unless
        ``flight=True``.
    largest_hop : numpy.ndarray or None
        Largest gap between the base and the table over the orbit [m] (0 without a
        flight; NaN without an orbit; the hops of a grazing take-off below the closed
        form's rounding, ~1e-19 m, read 0). ``None`` unless ``flight=True``.
    impacts_per_period : numpy.ndarray or None
        Landings of the base on the table per drive period [1], each rebound of a
        chatter counted (rebounds below the chattering cut-off end it plastically; a
        touch-down without speed counts as one); NaN without an orbit. ``None``
        unless ``flight=True``.
    averaged_velocity : numpy.ndarray or None
        Time-averaged velocity [m s-1] of a motion followed on the period map:
        ``velocity`` for ``CHAOTIC`` and ``QUASI_PERIODIC``, the partial mean for
        ``NOT_CONVERGED`` with ``AVERAGE_BUDGET`` (whose ``velocity`` is NaN), NaN
        elsewhere. One-way: the same for continuous sliding whose circle map has no
        cycle within reach (the time average over its iterates).
    velocity_error : numpy.ndarray or None
        Standard error of ``velocity`` [m s-1]: 0 for an orbit or a static point (exact),
        the batch-means error of the time average for ``CHAOTIC`` and
        ``QUASI_PERIODIC`` and for ``NOT_CONVERGED`` with ``AVERAGE_BUDGET`` (whose
        velocity is NaN), NaN elsewhere; the same from the one-way solver.
    averaged_periods : numpy.ndarray of int32 or None
        Drive periods an irregular motion was averaged over [1] (0 for an orbit).
        One-way: the drive periods its averaged circle-map iterates span, rounded.
    lyapunov_exponent, lyapunov_error : numpy.ndarray or None
        Largest Lyapunov exponent per drive period [1] and its standard error: for an
        irregular motion from a tangent vector carried through the period map's exact
        Jacobians (saltation matrices included), renormalised every period; for an
        orbit ``log(floquet_multiplier) / orbit_period`` with error 0; NaN where
        neither applies. One-way (the phase of continuous sliding is its only state): a
        continuous-sliding cycle's ``log|multiplier| / orbit_period``, the multiplier
        the circle map's derivative over the cycle, error 0; an averaged motion's mean
        of ``log|d theta_end / d theta_start|`` per drive period with its batch-means
        error; NaN for stick-slip, static and lift-off points (a stick forgets the
        phase: no multiplier) and where not converged but for ``AVERAGE_BUDGET``.
    phase_state : numpy.ndarray or None
        Shape ``(*shape, 5)``: the state at drive phase 0 the motion is reported at,
        ``(delta [m], delta' [m s-1], v [m s-1], h [m], h' [m s-1])`` (the mode's
        deflection and its rate, the sliding speed, the base's height above the table
        and its rate; ``h = h' = 0`` on the table): an orbit's fixed point, an irregular
        motion's last iterate; NaN for statuses without a mean velocity and for static
        points. What :func:`phase_section` follows. ``None`` from the one-way solver.

    Notes
    -----
    With ``flight=True`` an orbit with a flight in it has the status
    :attr:`~study.model.status.Status.BOUNCING` and its mean velocity;
    ``STICK_SLIP`` and ``CONTINUOUS_SLIDING`` keep their meaning for orbits that stay
    on the table. Where no stable cycle is within reach of the start the two-way solver
    follows the motion and reports it ``CHAOTIC`` or ``QUASI_PERIODIC`` with its time
    averages (:class:`SolverSettings` ``velocity_tolerance``, ``max_average_periods``).
    """

    velocity: NDArray[np.float64]
    status: NDArray[np.int8]
    reason: NDArray[np.int8]
    slips_per_period: NDArray[np.float64]
    forward_fraction: NDArray[np.float64]
    backward_fraction: NDArray[np.float64]
    orbit_period: NDArray[np.int32]
    floquet_multiplier: NDArray[np.float64] | None = None
    airborne_fraction: NDArray[np.float64] | None = None
    largest_hop: NDArray[np.float64] | None = None
    impacts_per_period: NDArray[np.float64] | None = None
    averaged_velocity: NDArray[np.float64] | None = None
    velocity_error: NDArray[np.float64] | None = None
    averaged_periods: NDArray[np.int32] | None = None
    lyapunov_exponent: NDArray[np.float64] | None = None
    lyapunov_error: NDArray[np.float64] | None = None
    phase_state: NDArray[np.float64] | None = None


def scalar_if_0d(values: NDArray[Any]) -> Any:
    """``values`` as is, or its numpy scalar when it is 0-d: the array functions return
    numpy scalars for scalar inputs, as numpy's ufuncs and scipy's functions do."""
    return values[()]


def _shaped(values: NDArray[Any], shape: tuple[int, ...]) -> Any:
    """The flat ``values`` in ``shape``, as :func:`scalar_if_0d` returns them: the one
    value's numpy scalar for ``shape == ()`` (read directly: a 0-d view costs a small
    call about 0.4 us a variable)."""
    return values[0] if shape == () else scalar_if_0d(values.reshape(shape))


def check_settings(settings: object, coupling: str | None = None) -> SolverSettings:
    """``settings``, or the defaults for None; a TypeError naming the argument for
    anything but a :class:`SolverSettings`, and a ValueError for ``continuation`` with
    a ``coupling`` other than two-way (the one-way solver has no orbit to continue)."""
    if settings is None:
        return DEFAULT_SETTINGS
    settings = instance_of("settings", settings, SolverSettings, "a study.SolverSettings")
    if settings.continuation and coupling is not None and coupling != "two-way":
        raise ValueError(
            f"SolverSettings(continuation=True) needs coupling='two-way', got "
            f"coupling={coupling!r}: the one-way solver has no orbit to continue")
    return settings


def check_start(settings: SolverSettings, start: object, coupling: str,
                flight: bool) -> SolverSettings:
    """``settings`` with the ``start`` keyword (None: ``settings.start``) checked against
    the model: a start other than the release needs ``coupling="two-way"`` (the one-way
    model has no state of the mode to start: its transient decays on its own), a drop
    needs ``flight=True`` (the base starts off the table); the keyword and a
    ``settings.start`` other than the release must agree. ValueErrors name ``start``,
    the value and the allowed values."""
    if start is not None:
        start = as_start(start)
        if settings.start != "release" and start != settings.start:
            raise ValueError(
                f"start={start!r} and settings.start={settings.start!r} differ: give the "
                "start once (the keyword overrides the default of the settings, not "
                "another start)")
        if start != settings.start:
            if settings.continuation and start != "release":
                raise ValueError(_CONTINUED_START.format(start=start))
            settings = dataclasses.replace(settings, start=start)
    problem = refusal(settings.start, coupling=coupling, flight=flight)
    if problem is not None:
        raise ValueError(problem)
    return settings


def check_coupling(coupling: object) -> str:
    """``coupling`` if it is one of :data:`COUPLINGS`, else a ValueError naming them."""
    if not isinstance(coupling, str) or coupling not in COUPLINGS:
        raise ValueError(f"coupling must be one of {', '.join(map(repr, COUPLINGS))}; "
                         f"got {coupling!r}")
    return str(coupling)


def check_flight(flight: object, coupling: str, structure: Structure) -> bool:
    """``flight`` as a bool, where the exact solver can follow a flight.

    Raises
    ------
    TypeError
        ``flight`` is not a bool (:class:`study.model.inputs.InputTypeError`, also a
        ValueError).
    ValueError
        ``flight=True`` with ``coupling="one-way"`` (the one-way model's mode is driven
        by the table alone, which no longer holds once the base leaves the table) or
        with ``M = 1`` (a massless base: the impact's mass matrix
        ``W = I + M/(1 - M) e e^T`` is unbounded).
    """
    if not isinstance(flight, bool | np.bool_):
        raise InputTypeError(f"flight must be True or False, got {type(flight).__name__}: "
                             f"{flight!r}")
    flight = bool(flight)
    if flight and coupling != "two-way":
        raise ValueError(
            f"flight=True needs coupling='two-way', got coupling={coupling!r}: the "
            "one-way model's mode is driven by the table alone, which does not hold once "
            "the base leaves the table")
    if flight and not structure.M < 1.0:
        raise ValueError(
            f"flight=True needs a mass ratio M < 1, got M={structure.M!r}: at M = 1 the "
            "base is massless and the impact's mass matrix W = I + M/(1 - M) e e^T is "
            "unbounded (use M <= 0.999)")
    return flight


#: Structures whose kernel constants are kept between calls, each a few hundred bytes:
#: a fit or a design evaluates a few structures in turn, a bisection one.
STRUCTURES_KEPT = 32

# A structure's parameters in declaration order, packed as float64 bytes.
_PARAMETERS = operator.attrgetter(*(field.name for field in dataclasses.fields(Structure)))
_PACKED = struct.Struct(f"<{len(dataclasses.fields(Structure))}d")


class _Kept(NamedTuple):
    """What the kernels read of one structure, computed once and kept."""

    #: The fields of :data:`~study.kernels.one_way.ForceConstants` (plain tuples are
    #: what the small-call kernels take).
    force: tuple[float, ...]
    #: The fields of :data:`~study.kernels.one_way.FrictionLevels`.
    levels: tuple[float, ...]
    #: The structure vector but its coupling and lift-off entries (0); read-only.
    vector: NDArray[np.float64]


# The structure of the last call and what is kept of it, as one tuple (replaced whole,
# so that a thread never reads one structure's constants with another's): a loop over
# the points of one structure finds them by identity, without hashing.
_LAST_KEPT: list[tuple[Structure | None, _Kept | None]] = [(None, None)]


def _kept(structure: Structure) -> _Kept:
    """The kernels' constants of ``structure``: those of the last call's structure if it
    is the same object (a frozen Structure never changes), else those kept for its
    parameters bit for bit (:data:`STRUCTURES_KEPT`)."""
    last, kept = _LAST_KEPT[0]
    if last is not structure or kept is None:
        kept = _kept_by_value(structure, _PACKED.pack(*_PARAMETERS(structure)))
        _LAST_KEPT[0] = (structure, kept)
    return kept


@functools.lru_cache(maxsize=STRUCTURES_KEPT)
def _kept_by_value(structure: Structure, exact: bytes) -> _Kept:
    """:func:`_kept`, computed once per key. ``exact`` is the parameters' bytes: equal
    structures may differ in the sign of a zero (``alpha=-0.0 == 0.0``, and they hash
    alike), which the constants keep (``np.sin(-0.0)`` is -0.0)."""
    vector = structure_entries(structure)
    vector.flags.writeable = False
    return _Kept(tuple(_force_constants(structure)), tuple(_friction_levels(structure)),
                 vector)


def structure_vector(structure: Structure, coupling: str,
                     flight: bool = False) -> NDArray[np.float64]:
    """The orbit kernel's structure vector (SI) for ``structure``, ``coupling`` and the
    lift-off law (``flight``: 1, else 0, stop with LIFT_OFF): a new array each call,
    from the entries kept for the structure (a writable copy: numba would compile a
    kernel again for a read-only array)."""
    return with_laws(_kept(structure).vector.copy(),
                     two_way=check_coupling(coupling) == "two-way",
                     lift_off="flight" if flight else DEFAULT_LIFT_OFF)


@functools.lru_cache(maxsize=64)
def kernel_budget(settings: SolverSettings) -> Budget:
    """The kernels' :class:`~study.kernels.budget.Budget` of ``settings`` (frozen and
    hashable: a call with the same settings reuses it)."""
    return Budget(int(settings.max_events), int(settings.max_map_iterations),
                  float(settings.velocity_tolerance), int(settings.max_average_periods))


def _force_constants(structure: Structure) -> Any:
    """The one-way kernel's :data:`~study.kernels.one_way.ForceConstants`."""
    return one_way_kernel.ForceConstants(
        float(structure.omega0), 1.0 / structure.Q, float(structure.M),
        float(np.cos(structure.alpha_rad)), float(np.sin(structure.alpha_rad)),
        float(structure.cs), float(structure.ck), float(structure.g),
    )


def past_lift_off(
    structure: Structure, f_flat: NDArray[np.float64], a_flat: NDArray[np.float64],
) -> NDArray[np.bool_]:
    """``a > lift_off_acceleration(structure, f)`` on flat arrays: decided by the kernel
    (the same operations, without numpy's temporaries, which cost a small call more
    than its solve), and by numpy where it is within 1e-13 of the threshold."""
    constants = _kept(structure).force
    lifted = np.empty(f_flat.size, dtype=np.bool_)
    if one_way_kernel.lift_off_small(f_flat, a_flat, constants, lifted):
        decisions = np.empty(f_flat.size, dtype=np.int8)
        one_way_kernel.lift_off_decisions(f_flat, a_flat,
                                          one_way_kernel.ForceConstants(*constants), decisions)
        undecided = np.flatnonzero(decisions == one_way_kernel.LIFT_UNDECIDED)
        lifted[undecided] = a_flat[undecided] > lift_off_acceleration(structure,
                                                                      f_flat[undecided])
    return lifted


def _orbit_table(
    structure: Structure,
    f_flat: NDArray[np.float64],
    a_flat: NDArray[np.float64],
    coupling: str,
    settings: SolverSettings,
    parallel: bool | None,
    flight: bool = False,
) -> NDArray[np.float64]:
    """Rows of the orbit kernel (:data:`study.kernels.two_way.points.OUTPUT_COLUMNS`)
    at each point; ``flight`` follows the base off the table (else LIFT_OFF)."""
    lifted = past_lift_off(structure, f_flat, a_flat)
    omega = 2.0 * np.pi * f_flat
    out = np.empty((f_flat.size, orbit_kernel.N_OUT))
    if parallel is None:
        parallel = f_flat.size >= PARALLEL_THRESHOLD // 8
    kernel = orbit_kernel.solve_points if parallel else orbit_kernel.solve_points_serial
    kernel(structure_vector(structure, coupling, flight), omega, a_flat, lifted,
           kernel_budget(settings), settings.continuation, kernel_start(settings.start), out)
    return out


def _orbit_velocity(
    structure: Structure,
    f_flat: NDArray[np.float64],
    a_flat: NDArray[np.float64],
    coupling: str,
    settings: SolverSettings,
    flight: bool,
) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Velocity and status of :func:`_orbit_table` on flat ``f``, ``a``, from the orbit
    kernel's velocity-only drivers."""
    lifted = past_lift_off(structure, f_flat, a_flat)
    velocity = np.empty(f_flat.size)
    status = np.empty(f_flat.size, dtype=np.int8)
    parallel = f_flat.size >= PARALLEL_THRESHOLD // 8
    kernel = orbit_kernel.velocity_points if parallel else orbit_kernel.velocity_points_serial
    kernel(structure_vector(structure, coupling, flight), 2.0 * np.pi * f_flat, a_flat,
           lifted, kernel_budget(settings), settings.continuation,
           kernel_start(settings.start), velocity, status)
    return velocity, status


def _orbit_steady_state(
    structure: Structure,
    f_flat: NDArray[np.float64],
    a_flat: NDArray[np.float64],
    shape: tuple[int, ...],
    coupling: str,
    settings: SolverSettings,
    parallel: bool | None,
    flight: bool = False,
) -> SteadyState:
    """:func:`steady_state` by the orbit kernel (the mode as a state) on flat ``f``, ``a``."""
    out = _orbit_table(structure, f_flat, a_flat, coupling, settings, parallel, flight)
    return steady_state_from_rows(out, shape, flight)


#: Each :class:`SteadyState` field a kernel's output table holds: the column's name (in
#: the kernel's ``OUTPUT_COLUMNS``) and the field's dtype (None: float64 as stored). A
#: kernel without a column leaves the field None; the flight columns are read only
#: with flight.
STEADY_FIELDS = {
    "velocity": ("velocity", None),
    "status": ("status", np.int8),
    "reason": ("reason", np.int8),
    "slips_per_period": ("slips", None),
    "forward_fraction": ("forward", None),
    "backward_fraction": ("backward", None),
    "orbit_period": ("period", np.int32),
    "floquet_multiplier": ("multiplier", None),
    "airborne_fraction": ("airborne", None),
    "largest_hop": ("hop", None),
    "impacts_per_period": ("impacts", None),
    "averaged_velocity": ("averaged_velocity", None),
    "velocity_error": ("velocity_error", None),
    "averaged_periods": ("averaged_periods", np.int32),
    "lyapunov_exponent": ("exponent", None),
    "lyapunov_error": ("exponent_error", None),
}
#: The fields of a flight (read only with ``flight=True``).
FLIGHT_FIELDS = ("airborne_fraction", "largest_hop", "impacts_per_period")


def steady_fields(out: NDArray[np.float64], columns: tuple[tuple[str, str, str], ...],
                  shape: tuple[int, ...], flight: bool) -> dict[str, Any]:
    """The :class:`SteadyState` fields of a kernel's rows ``out`` (one a point, the
    kernel's ``columns``), each shaped ``shape``, read by name (:data:`STEADY_FIELDS`)."""
    names = [name for name, _, _ in columns]
    fields = {}
    for field, (name, dtype) in STEADY_FIELDS.items():
        if name not in names or (field in FLIGHT_FIELDS and not flight):
            continue
        values = out[:, names.index(name)]
        fields[field] = _shaped(values if dtype is None else values.astype(dtype), shape)
    return fields


def steady_state_from_rows(out: NDArray[np.float64], shape: tuple[int, ...],
                           flight: bool) -> SteadyState:
    """The :class:`SteadyState` of the orbit kernel's rows ``out``
    (:data:`study.kernels.two_way.points.OUTPUT_COLUMNS`, one a point), each field
    shaped ``shape``; the flight fields only with ``flight``."""
    return SteadyState(**steady_fields(out, orbit_kernel.OUTPUT_COLUMNS, shape, flight),
                       phase_state=_phase_state(out, shape))


#: The output columns of the state at phase 0, in :attr:`SteadyState.phase_state`'s
#: order.
_PHASE_STATE_COLUMNS = (orbit_kernel.OUT_DELTA, orbit_kernel.OUT_DELTA_RATE,
                        orbit_kernel.OUT_SPEED, orbit_kernel.OUT_GAP,
                        orbit_kernel.OUT_GAP_RATE)
#: Statuses whose motion has a state to follow: a mean velocity (orbits, irregular).
_MOVING = np.array([s for s in Status if s.velocity == "mean"], dtype=np.int8)


def _phase_state(out: NDArray[np.float64], shape: tuple[int, ...]) -> NDArray[np.float64]:
    """:attr:`SteadyState.phase_state` from the orbit kernel's rows ``out``."""
    state = out[:, _PHASE_STATE_COLUMNS].copy()
    state[~np.isin(out[:, orbit_kernel.OUT_STATUS].astype(np.int8), _MOVING)] = np.nan
    return state.reshape(*shape, len(_PHASE_STATE_COLUMNS))


def _friction_levels(structure: Structure) -> Any:
    """The one-way kernel's :data:`~study.kernels.one_way.FrictionLevels`."""
    return one_way_kernel.FrictionLevels(structure.cs * structure.g,
                                         structure.ck * structure.g)


def _one_way_steady_state(
    structure: Structure,
    f_flat: NDArray[np.float64],
    a_flat: NDArray[np.float64],
    shape: tuple[int, ...],
    settings: SolverSettings,
    parallel: bool | None,
) -> SteadyState:
    """:func:`steady_state` by the one-way kernel on flat ``f``, ``a``."""
    n = f_flat.size
    out = np.empty((n, one_way_kernel.N_OUTPUTS))
    # Launching the thread pool costs milliseconds: small inputs run on this thread.
    if parallel is None:
        parallel = n >= PARALLEL_THRESHOLD
    if parallel or n >= PARALLEL_THRESHOLD:
        _solve_one_way(structure, f_flat, a_flat, settings, parallel, out)
    else:
        # The kernel evaluates the forces point by point, bit-identical to numpy's
        # arrays, whose temporaries cost a small call ten times its solve.
        kept = _kept(structure)
        if one_way_kernel.steady_points_small(f_flat, a_flat, kept.force, kept.levels,
                                              tuple(kernel_budget(settings)), out):
            # Points within 1e-13 of the lift-off threshold: solved the long way, where
            # numpy decides their lift-off.
            undecided = np.flatnonzero(
                out[:, one_way_kernel.OUT_STATUS] == one_way_kernel.LIFT_UNDECIDED)
            rows = np.empty((undecided.size, one_way_kernel.N_OUTPUTS))
            _solve_one_way(structure, f_flat[undecided], a_flat[undecided], settings,
                           False, rows)
            out[undecided] = rows
    return SteadyState(**steady_fields(out, one_way_kernel.OUTPUT_COLUMNS, shape, False))


def _solve_one_way(
    structure: Structure,
    f_flat: NDArray[np.float64],
    a_flat: NDArray[np.float64],
    settings: SolverSettings,
    parallel: bool,
    out: NDArray[np.float64],
) -> None:
    """The one-way kernel at flat ``f``, ``a`` into ``out`` (one row of
    :data:`study.kernels.one_way.OUTPUT_COLUMNS` a point), the forces and the lift-off
    decisions computed by ``study.model`` (numpy)."""
    a_plus, a_minus, b_plus, b_minus = (
        *release_amplitudes(structure, f_flat, a_flat),
        *slip_amplitudes(structure, f_flat, a_flat))
    lifted = a_flat > lift_off_acceleration(structure, f_flat)
    omega = 2.0 * np.pi * f_flat
    amplitudes = one_way_kernel.Amplitudes(
        *(np.ascontiguousarray(x, dtype=np.complex128)
          for x in (a_plus, a_minus, b_plus, b_minus)))
    kernel = (one_way_kernel.solve_points_averaged if parallel
              else one_way_kernel.solve_points_averaged_serial)
    kernel(amplitudes, np.ascontiguousarray(a_flat, dtype=np.float64), lifted, omega,
           _friction_levels(structure), kernel_budget(settings), out)


def steady_state(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    settings: SolverSettings | None = None,
    *,
    coupling: str = DEFAULT_COUPLING,
    friction: str | Friction = DEFAULT_FRICTION,
    parallel: bool | None = None,
    flight: bool = False,
    start: str | Drop | None = None,
) -> SteadyState:
    """Exact steady periodic orbit of the stick-slip motion at each ``(f, a)``.

    Event-driven and closed form between events (docs/theory/exact-solvers.md); no time
    step. The orbit is the one reached from the ``start`` (by default the release: rest
    at drive phase 0 with the mode on its steady response). Runs in parallel over points
    and releases the GIL.

    With ``coupling="two-way"`` the base's sliding acceleration also forces the mode,
    which becomes a state of the orbit: the orbit is the fixed point of the period map,
    found by Newton's method with the exact Jacobian (docs/theory/two-way.md), and its
    largest Floquet multiplier is returned.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0. Broadcast against ``a``.
    a : array_like
        Drive acceleration amplitude [m s-2], >= 0.
    settings : SolverSettings, optional
        Solver budgets, and whether two-way orbits are continued along the sweep
        (``continuation``: faster; where several motions are stable it follows its
        neighbours' branch, so a point's value depends on the grid); defaults to
        ``SolverSettings()``, every point from rest.
    coupling : {"one-way", "two-way"}, default "one-way"
        The paper's model (mode driven by the table only) or the physical one
        (:data:`DEFAULT_COUPLING` is the default).
    friction : str or Friction, default "coulomb"
        The friction law (:data:`study.model.contact.LAWS`); this solver implements
        Coulomb friction only and refuses any other law, naming the allowed ones.
    parallel : bool, optional
        Spread points over all cores (numba threads). By default only inputs of
        at least ``PARALLEL_THRESHOLD`` points do; pass ``False`` when the caller
        already runs one call per core (as the dask fan-out does).
    flight : bool, default False
        What happens where the normal force vanishes: ``False`` ends the orbit there
        with ``LIFT_OFF`` (the contact model's limit); ``True`` lets the base take off,
        fly and land by an impact (restitution ``structure.restitution``), and reports
        a bouncing orbit with ``BOUNCING`` and its velocity, airborne fraction, largest
        hop and impacts per period (docs/theory/flight.md). Needs
        ``coupling="two-way"`` and ``M < 1``.
    start : {"release", "switch-on"} or Drop, optional
        The state each point's motion starts from (:class:`SolverSettings` ``start``,
        docs/theory/starts.md); overrides ``settings.start`` (which must then be the
        release or the same). Other than ``"release"`` needs ``coupling="two-way"``, a
        :class:`Drop` ``flight=True``.

    Returns
    -------
    SteadyState
        Velocity, status and diagnostics, each a numpy array of the broadcast shape of
        ``f`` and ``a`` (a numpy scalar when both are scalars).

    Raises
    ------
    TypeError
        ``structure`` is not a :class:`study.Structure`; ``f`` or ``a`` are not real
        numbers (strings, booleans, complex numbers, dates).
    ValueError
        ``f`` or ``a`` out of range or not finite (the message names the first offending
        value and its index), shapes that do not broadcast, an unknown coupling,
        ``flight=True`` with one-way coupling or ``M = 1`` (:func:`check_flight`),
        continuation with one-way coupling, or a ``start`` the model cannot take
        (:func:`check_start`).

    See Also
    --------
    compute_map : the same over a grid, as a labelled dataset.
    """
    structure = check_structure(structure)
    coupling = check_coupling(coupling)
    flight = check_flight(flight, coupling, structure)
    check_friction(friction, "exact")
    settings = check_start(check_settings(settings, coupling), start, coupling, flight)
    shape, f_flat, a_flat = flat_drive(f, a)
    if coupling == "two-way":
        return _orbit_steady_state(structure, f_flat, a_flat, shape, coupling, settings,
                                   parallel, flight)
    return _one_way_steady_state(structure, f_flat, a_flat, shape, settings, parallel)


@dataclass(frozen=True)
class Attractors:
    """Stable periodic orbits reached from several starting states, per drive point.

    Attributes
    ----------
    count : numpy.ndarray of int32
        Distinct outcomes found [1]: stable orbits told apart by period and mean
        velocity, plus one for lift-off and one for the friction paradox when some
        start ends there. 1 for ``STATIC`` points; > 1 flags multistability.
    velocity_spread : numpy.ndarray
        Largest minus smallest mean velocity among the orbits found [m s-1].
    starts_converged : numpy.ndarray of int32
        Starting states (of :data:`ATTRACTOR_STARTS`) that reached an outcome [1].
    """

    count: NDArray[np.int32]
    velocity_spread: NDArray[np.float64]
    starts_converged: NDArray[np.int32]


#: Starting states of :func:`attractors`: rest at each drive phase [periods], with the
#: mode on each multiple of its steady response.
ATTRACTOR_STARTS = {"phases": attractor_kernel.START_PHASES,
                    "mode_factors": attractor_kernel.START_FACTORS}
#: Further starts of :func:`attractors` with ``flight=True``: the base released at rest
#: relative to the table from each height [m] at each drive phase [periods], the mode on
#: its steady stick response.
ATTRACTOR_DROPS = {"heights": attractor_kernel.DROP_HEIGHTS,
                   "phases": attractor_kernel.DROP_PHASES}


def attractors(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    settings: SolverSettings | None = None,
    *,
    coupling: str = DEFAULT_COUPLING,
    parallel: bool | None = None,
    flight: bool = False,
) -> Attractors:
    """Multistability check: the distinct stable orbits reached from several starts.

    From rest at four drive phases, with the mode at 0, 1 and 2 times its steady
    response (:data:`ATTRACTOR_STARTS`), the exact orbit solver (docs/theory/two-way.md)
    finds the attracting periodic orbit each start leads to; orbits are the same when
    their periods agree and their mean velocities agree to ``1e-9 a / w``. Costs twelve
    solves per point.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0.
    a : array_like
        Drive acceleration amplitude [m s-2], >= 0.
    settings : SolverSettings, optional
        Solver budgets (``continuation`` does not apply: every start is solved from its
        own state, which is what the check is for).
    coupling : {"one-way", "two-way"}, default "one-way"
        The model; with ``"one-way"`` the mode's transient decays on its own and the
        starts differ in the phase of the first release.
    parallel : bool, optional
        Spread points over all cores.
    flight : bool, default False
        Follow the base off the table (see :func:`steady_state`); the starts then also
        include drops (:data:`ATTRACTOR_DROPS`), and bouncing orbits count as orbits.

    Returns
    -------
    Attractors
        Arrays of the broadcast shape of ``f`` and ``a`` (numpy scalars for scalars).

    Raises
    ------
    TypeError, ValueError
        As :func:`steady_state`.
    """
    structure = check_structure(structure)
    coupling = check_coupling(coupling)
    flight = check_flight(flight, coupling, structure)
    settings = check_settings(settings)
    shape, f_flat, a_flat = flat_drive(f, a)
    lifted = a_flat > lift_off_acceleration(structure, f_flat)
    out = np.empty((f_flat.size, attractor_kernel.N_ATTRACTOR_OUT))
    if parallel is None:
        parallel = f_flat.size >= 16
    vector = structure_vector(structure, coupling, flight)
    omega = 2.0 * np.pi * f_flat
    kernel = (attractor_kernel.attractors_points if parallel
              else attractor_kernel.attractors_points_serial)
    kernel(vector, omega, a_flat, lifted, kernel_budget(settings), out)
    return Attractors(
        count=scalar_if_0d(out[:, attractor_kernel.OUT_COUNT].astype(np.int32).reshape(shape)),
        velocity_spread=scalar_if_0d(out[:, attractor_kernel.OUT_SPREAD].reshape(shape)),
        starts_converged=scalar_if_0d(
            out[:, attractor_kernel.OUT_STARTS_CONVERGED].astype(np.int32).reshape(shape)),
    )


#: Drive periods a phase section holds by default (:func:`phase_section`): enough for a
#: cycle's points to repeat several times over and a chaotic motion's to spread.
SECTION_PERIODS = 64


@dataclass(frozen=True)
class PhaseSection:
    """The phase-0 Poincare section of the motion at each drive point.

    Each attribute has the shape ``(*shape, periods)``: the drive point's shape, then
    consecutive drive periods of the motion the point reports (an orbit from its fixed
    point, an irregular motion from its last averaged iterate), at phase 0 of each. An
    orbit of period ``p`` repeats every ``p`` entries; NaN where the point has no
    motion (static, lift-off, not converged, the friction paradox).

    Attributes
    ----------
    delta : numpy.ndarray
        The mode's deflection [m].
    delta_rate : numpy.ndarray
        Its rate [m s-1].
    speed : numpy.ndarray
        The base's sliding speed [m s-1].
    gap : numpy.ndarray
        The base's height above the table [m] (0 on it).
    """

    delta: NDArray[np.float64]
    delta_rate: NDArray[np.float64]
    speed: NDArray[np.float64]
    gap: NDArray[np.float64]


def phase_section(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    settings: SolverSettings | None = None,
    *,
    flight: bool = False,
    periods: int = SECTION_PERIODS,
    solution: SteadyState | None = None,
) -> PhaseSection:
    """The states at drive phase 0 of ``periods`` consecutive periods of the motion the
    two-way solver reports at each ``(f, a)``: what a bifurcation diagram plots.

    From :attr:`SteadyState.phase_state` (an orbit's fixed point, an irregular motion's
    last iterate) the exact period map is followed ``periods - 1`` periods without its
    Jacobian. On an attractor these periods are as good as the ones before: one point
    per period for an orbit of period 1, ``p`` repeating points for a cycle of ``p``
    periods, a curve's worth for a quasi-periodic motion, a cloud for a chaotic one.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0. Broadcast against ``a``.
    a : array_like
        Drive acceleration amplitude [m s-2], >= 0.
    settings : SolverSettings, optional
        Solver budgets (as :func:`steady_state`'s).
    flight : bool, default False
        Follow the base off the table (as :func:`steady_state`'s).
    periods : int, default SECTION_PERIODS
        Drive periods in the section [1], at least 1.
    solution : SteadyState, optional
        The two-way :func:`steady_state` of the same arguments, if already computed
        (its ``phase_state`` is followed; the points are not solved again).

    Returns
    -------
    PhaseSection
        Arrays ``(*shape, periods)``.

    Raises
    ------
    TypeError, ValueError
        As :func:`steady_state`; ``periods`` not a positive integer; a ``solution``
        without a phase state (one-way) or of another shape.
    """
    structure = check_structure(structure)
    flight = check_flight(flight, "two-way", structure)
    settings = check_start(check_settings(settings, "two-way"), None, "two-way", flight)
    if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or periods < 1:
        raise ValueError(f"periods must be a positive integer, got {periods!r}")
    shape, f_flat, a_flat = flat_drive(f, a)
    if solution is None:
        solution = _orbit_steady_state(structure, f_flat, a_flat, shape, "two-way",
                                       settings, None, flight)
    if solution.phase_state is None or np.shape(solution.phase_state) != (*shape, 5):
        raise ValueError("solution must be the two-way steady_state of the same f and a "
                         f"(a phase_state of shape {(*shape, 5)})")
    states = np.ascontiguousarray(np.reshape(solution.phase_state, (-1, 5)))
    out = np.empty((f_flat.size, int(periods), 5))
    section_kernel.follow_sections(structure_vector(structure, "two-way", flight),
                                   2.0 * np.pi * f_flat, a_flat, states,
                                   settings.max_events, out)
    out = out.reshape(*shape, int(periods), 5)
    return PhaseSection(delta=out[..., 0], delta_rate=out[..., 1], speed=out[..., 2],
                        gap=out[..., 3])


def steady_velocity(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    settings: SolverSettings | None = None,
    *,
    coupling: str = DEFAULT_COUPLING,
    flight: bool = False,
    start: str | Drop | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Mean steady velocity and status at each ``(f, a)``.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0.
    a : array_like
        Drive acceleration amplitude [m s-2], >= 0.
    settings : SolverSettings, optional
        Solver budgets and continuation, as :func:`steady_state`.
    coupling : {"one-way", "two-way"}, default "one-way"
        See :func:`steady_state`.
    flight : bool, default False
        Follow the base off the table (see :func:`steady_state`): bouncing orbits get
        the status ``BOUNCING`` and their velocity.
    start : {"release", "switch-on"} or Drop, optional
        The state each point's motion starts from (see :func:`steady_state`).

    Returns
    -------
    velocity : numpy.ndarray of float64
        Mean velocity [m s-1], positive forward, of the broadcast shape of ``f`` and
        ``a``; exactly 0 where static, NaN exactly where the status is ``LIFT_OFF``,
        ``NOT_CONVERGED`` or ``FRICTION_PARADOX`` (a ``BOUNCING`` orbit has its
        velocity). A ``numpy.float64`` when ``f`` and ``a`` are both scalars.
    status : numpy.ndarray of int8
        :class:`~study.model.status.Status` codes [1], same shape (a ``numpy.int8`` for
        scalars); ``study.Status(int(code))`` names one, ``status ==
        study.Status.STICK_SLIP`` compares.

    Raises
    ------
    TypeError, ValueError
        As :func:`steady_state`.

    See Also
    --------
    steady_state : the same with diagnostics.
    compute_map : velocities over a grid, as a labelled dataset.

    Examples
    --------
    >>> import numpy as np, study
    >>> s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    >>> v, status = study.steady_velocity(s, 14.0, 8.0)
    >>> type(v).__name__, study.Status(int(status)).name
    ('float64', 'STICK_SLIP')
    >>> v, status = study.steady_velocity(s, np.array([13.0, 14.0, 15.0])[:, None], [6.0, 8.0])
    >>> v.shape, status.dtype
    ((3, 2), dtype('int8'))
    """
    coupling = check_coupling(coupling)
    structure = check_structure(structure)
    flight = check_flight(flight, coupling, structure)
    settings = check_start(check_settings(settings, coupling), start, coupling, flight)
    shape, f_flat, a_flat = flat_drive(f, a)
    if coupling != "one-way":
        # The orbit kernel's velocity and status only (those of steady_state, bit for
        # bit), without its table of every column.
        velocity, status = _orbit_velocity(structure, f_flat, a_flat, coupling, settings,
                                           flight)
        return _shaped(velocity, shape), _shaped(status, shape)
    if f_flat.size == 0:  # nothing to solve
        return np.empty(shape), np.empty(shape, dtype=np.int8)
    velocity, status = _velocity_only(structure, f_flat, a_flat, settings)
    return _shaped(velocity, shape), _shaped(status, shape)


def _velocity_only(
    structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
    settings: SolverSettings,
) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """The orbits of :func:`steady_state` on flat ``f``, ``a``, velocity and status only.

    The kernel evaluates the force amplitudes of ``study.model`` point by point
    (bit-identical to the arrays :func:`steady_state` computes) and keeps no
    diagnostics: the same velocity and status, bit for bit, without the temporaries.
    """
    n = f.size
    out = one_way_kernel.VelocityOutputs(np.empty(n), np.empty(n, dtype=np.int8))
    constants, levels, _ = _kept(structure)
    budget = kernel_budget(settings)
    if n >= PARALLEL_THRESHOLD:
        one_way_kernel.velocity_points(f, a, one_way_kernel.ForceConstants(*constants),
                                       one_way_kernel.FrictionLevels(*levels), budget, out)
        undecided = np.flatnonzero(out.status == one_way_kernel.LIFT_UNDECIDED)
    elif one_way_kernel.velocity_points_small(f, a, constants, levels, tuple(budget), *out):
        undecided = np.flatnonzero(out.status == one_way_kernel.LIFT_UNDECIDED)
    else:  # the small kernel counted no undecided point: no scan of the status
        undecided = np.empty(0, dtype=np.intp)
    # Points within 1e-13 of the lift-off threshold: numpy's rounding of |z| decides,
    # as in steady_state.
    if undecided.size:
        f_u, a_u = f[undecided], a[undecided]
        out_u = one_way_kernel.VelocityOutputs(np.empty(undecided.size),
                                               np.empty(undecided.size, dtype=np.int8))
        one_way_kernel.velocity_points_given(
            f_u, a_u, a_u > lift_off_acceleration(structure, f_u),
            one_way_kernel.ForceConstants(*constants), one_way_kernel.FrictionLevels(*levels),
            budget, out_u)
        out.velocity[undecided] = out_u.velocity
        out.status[undecided] = out_u.status
    return out.velocity, out.status


def flat_drive(
    f: ArrayLike, a: ArrayLike,
) -> tuple[tuple[int, ...], NDArray[np.float64], NDArray[np.float64]]:
    """The broadcast shape of the checked drive ``f``, ``a`` and both flattened
    (float64, contiguous); a ValueError for shapes that do not broadcast."""
    f_arr, a_arr = as_frequency(f), as_acceleration(a)
    # Arrays of one shape (two scalars, a fit's rows) need no broadcast, whose views
    # cost a small call more than its checks. Broadcast ones are copied: numba reading
    # the flags of a broadcast view gets numpy's FutureWarning about its writeability.
    if f_arr.shape != a_arr.shape:
        f_arr, a_arr = (np.array(x, dtype=float) for x in np.broadcast_arrays(f_arr, a_arr))
    return (f_arr.shape, np.ascontiguousarray(f_arr, dtype=float).ravel(),
            np.ascontiguousarray(a_arr, dtype=float).ravel())
