"""Public exact steady-state solvers: validate, allocate, call the numba kernels.

:func:`steady_state` and :func:`steady_velocity` check their arguments
(:mod:`study.solvers.settings`), flatten and allocate the arrays, pack the kernel's
named arguments (:class:`study.kernels.budget.Budget`, the structure vector of
:mod:`study.solvers.structure_constants`, the one-way kernel's named tuples) and call
the kernel's driver, which loops over the points (:mod:`study.kernels.one_way` for the
one-way coupling, :mod:`study.kernels.two_way.points` for the orbit with the mode as a
state). Results are read from the kernels' output tables by the names they declare
(:mod:`study.solvers.steady`). The attractors of a fixed set of starts and the phase-0
section have their own modules (:mod:`study.solvers.attractors`,
:mod:`study.solvers.section`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels import one_way as one_way_kernel
from study.kernels import one_way_velocity as velocity_kernel
from study.kernels.two_way import points as orbit_kernel
from study.model import (
    lift_off_acceleration,
    release_amplitudes,
    slip_amplitudes,
)
from study.model.contact import (
    DEFAULT_COUPLING,
    DEFAULT_FRICTION,
    Friction,
    check_friction,
)
from study.model.starts import (
    Drop,
)
from study.model.status import Status
from study.model.structure import Structure, check_structure
from study.solvers.settings import (
    SolverSettings,
    check_coupling,
    check_flight,
    check_settings,
    check_start,
    flat_drive,
    kernel_budget,
    kernel_start,
)
from study.solvers.steady import SteadyState, shaped, steady_fields
from study.solvers.structure_constants import (
    friction_levels,
    kept_constants,
    past_lift_off,
    structure_vector,
)

__all__ = [
    "PARALLEL_THRESHOLD",
    "SOLVER_VERSION",
    "orbit_steady_state",
    "steady_state",
    "steady_state_from_rows",
    "steady_velocity",
]


#: Version of the steady-state algorithm; changes whenever its results may change.
SOLVER_VERSION = "9"

#: Inputs with at least this many points are solved by the parallel kernel.
PARALLEL_THRESHOLD = 2048


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


def orbit_steady_state(
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
        kept = kept_constants(structure)
        if velocity_kernel.steady_points_small(f_flat, a_flat, kept.force, kept.levels,
                                              tuple(kernel_budget(settings)), out):
            # Points within 1e-13 of the lift-off threshold: solved the long way, where
            # numpy decides their lift-off.
            undecided = np.flatnonzero(
                out[:, one_way_kernel.OUT_STATUS] == velocity_kernel.LIFT_UNDECIDED)
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
           friction_levels(structure), kernel_budget(settings), out)


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
        return orbit_steady_state(structure, f_flat, a_flat, shape, coupling, settings,
                                   parallel, flight)
    return _one_way_steady_state(structure, f_flat, a_flat, shape, settings, parallel)


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
        return shaped(velocity, shape), shaped(status, shape)
    if f_flat.size == 0:  # nothing to solve
        return np.empty(shape), np.empty(shape, dtype=np.int8)
    velocity, status = _velocity_only(structure, f_flat, a_flat, settings)
    return shaped(velocity, shape), shaped(status, shape)


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
    out = velocity_kernel.VelocityOutputs(np.empty(n), np.empty(n, dtype=np.int8))
    constants, levels, _ = kept_constants(structure)
    budget = kernel_budget(settings)
    if n >= PARALLEL_THRESHOLD:
        velocity_kernel.velocity_points(f, a, velocity_kernel.ForceConstants(*constants),
                                        one_way_kernel.FrictionLevels(*levels), budget, out)
        undecided = np.flatnonzero(out.status == velocity_kernel.LIFT_UNDECIDED)
    elif velocity_kernel.velocity_points_small(f, a, constants, levels, tuple(budget), *out):
        undecided = np.flatnonzero(out.status == velocity_kernel.LIFT_UNDECIDED)
    else:  # the small kernel counted no undecided point: no scan of the status
        undecided = np.empty(0, dtype=np.intp)
    # Points within 1e-13 of the lift-off threshold: numpy's rounding of |z| decides,
    # as in steady_state.
    if undecided.size:
        f_u, a_u = f[undecided], a[undecided]
        out_u = velocity_kernel.VelocityOutputs(np.empty(undecided.size),
                                                np.empty(undecided.size, dtype=np.int8))
        velocity_kernel.velocity_points_given(
            f_u, a_u, a_u > lift_off_acceleration(structure, f_u),
            velocity_kernel.ForceConstants(*constants), one_way_kernel.FrictionLevels(*levels),
            budget, out_u)
        out.velocity[undecided] = out_u.velocity
        out.status[undecided] = out_u.status
    return out.velocity, out.status
