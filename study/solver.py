"""Public steady-state solver: validates, allocates, calls the numba kernel."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels import steady as _kernel
from study.physics import (
    as_acceleration,
    as_frequency,
    lift_off_acceleration,
    release_amplitudes,
    slip_amplitudes,
)
from study.structure import Structure

__all__ = ["SolverSettings", "SteadyState", "steady_state", "steady_velocity"]

#: Version of the steady-state algorithm; changes whenever its results may change.
SOLVER_VERSION = "2"

#: Inputs with at least this many points are solved by the parallel kernel.
PARALLEL_THRESHOLD = 2048


@dataclass(frozen=True)
class SolverSettings:
    """Budgets of the exact steady-state solver.

    Parameters
    ----------
    max_events : int
        Slip events followed from rest before a point is declared not converged
        (``NonConvergence.EVENT_BUDGET``). An orbit with a stick closes after a few
        events; the budget only bounds pathological points.
    max_map_iterations : int
        Iterations of the continuous-sliding circle map searched for an attracting
        cycle before ``NonConvergence.NO_PERIODIC_ORBIT``.
    """

    max_events: int = 10_000
    max_map_iterations: int = 5_000

    def __post_init__(self) -> None:
        for name in ("max_events", "max_map_iterations"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(
                    f"solver setting {name!r} must be an integer >= 1, got {value!r}"
                )


@dataclass(frozen=True)
class SteadyState:
    """Steady periodic orbit at each drive point, arrays of the broadcast shape.

    Attributes
    ----------
    velocity : numpy.ndarray
        Mean velocity over the periodic orbit [m s^-1]; exactly 0 for ``STATIC``,
        NaN for ``LIFT_OFF`` and ``NOT_CONVERGED``.
    status : numpy.ndarray of int8
        :class:`~study.status.Status` codes.
    reason : numpy.ndarray of int8
        :class:`~study.status.NonConvergence` codes.
    slips_per_period : numpy.ndarray
        Slip events per drive period [1].
    forward_fraction, backward_fraction : numpy.ndarray
        Fractions of the drive period spent slipping forward and backward [1].
    orbit_period : numpy.ndarray of int32
        Period of the orbit in drive periods (0 when there is no orbit).
    """

    velocity: NDArray[np.float64]
    status: NDArray[np.int8]
    reason: NDArray[np.int8]
    slips_per_period: NDArray[np.float64]
    forward_fraction: NDArray[np.float64]
    backward_fraction: NDArray[np.float64]
    orbit_period: NDArray[np.int32]


def check_structure(structure: object) -> Structure:
    if not isinstance(structure, Structure):
        raise TypeError(
            f"structure must be a study.Structure, got {type(structure).__name__}"
        )
    return structure


def steady_state(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    settings: SolverSettings | None = None,
    *,
    parallel: bool | None = None,
) -> SteadyState:
    """Exact steady periodic orbit of the stick-slip motion at each ``(f, a)``.

    Event-driven and closed form between events (README, "How the solver works"); no time
    step. The orbit is the one reached from rest at drive phase 0 with the mode on
    its steady response. Runs in parallel over points and releases the GIL.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0. Broadcast against ``a``.
    a : array_like
        Drive acceleration amplitude [m s^-2], >= 0.
    settings : SolverSettings, optional
        Solver budgets; defaults to ``SolverSettings()``.
    parallel : bool, optional
        Spread points over all cores (numba threads). By default only inputs of
        at least ``PARALLEL_THRESHOLD`` points do; pass ``False`` when the caller
        already runs one call per core (as the dask fan-out does).

    Returns
    -------
    SteadyState
        Velocity, status and diagnostics, each of the broadcast shape of ``f`` and ``a``.
    """
    structure = check_structure(structure)
    settings = SolverSettings() if settings is None else settings
    f_arr, a_arr = np.broadcast_arrays(as_frequency(f), as_acceleration(a))
    shape = f_arr.shape
    f_flat = np.ascontiguousarray(f_arr).ravel()
    a_flat = np.ascontiguousarray(a_arr).ravel()
    a_plus, a_minus = release_amplitudes(structure, f_flat, a_flat)
    b_plus, b_minus = slip_amplitudes(structure, f_flat, a_flat)
    lifted = a_flat > lift_off_acceleration(structure, f_flat)
    omega = 2.0 * np.pi * f_flat
    n = f_flat.size
    velocity = np.empty(n)
    status = np.empty(n, dtype=np.int8)
    reason = np.empty(n, dtype=np.int8)
    slips = np.empty(n)
    forward = np.empty(n)
    backward = np.empty(n)
    period = np.empty(n, dtype=np.int32)
    # Launching the thread pool costs milliseconds: small inputs run on this thread.
    if parallel is None:
        parallel = n >= PARALLEL_THRESHOLD
    kernel = _kernel._steady_state if parallel else _kernel._steady_state_serial
    kernel(
        np.ascontiguousarray(a_plus, dtype=np.complex128),
        np.ascontiguousarray(a_minus, dtype=np.complex128),
        np.ascontiguousarray(b_plus, dtype=np.complex128),
        np.ascontiguousarray(b_minus, dtype=np.complex128),
        lifted,
        omega,
        structure.cs * structure.g,
        structure.ck * structure.g,
        int(settings.max_events),
        int(settings.max_map_iterations),
        velocity,
        status,
        reason,
        slips,
        forward,
        backward,
        period,
    )
    return SteadyState(
        velocity=velocity.reshape(shape),
        status=status.reshape(shape),
        reason=reason.reshape(shape),
        slips_per_period=slips.reshape(shape),
        forward_fraction=forward.reshape(shape),
        backward_fraction=backward.reshape(shape),
        orbit_period=period.reshape(shape),
    )


def steady_velocity(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    settings: SolverSettings | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Mean steady velocity and status at each ``(f, a)``.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0.
    a : array_like
        Drive acceleration amplitude [m s^-2], >= 0.
    settings : SolverSettings, optional
        Solver budgets.

    Returns
    -------
    velocity : numpy.ndarray
        Mean velocity [m s^-1], positive forward; NaN exactly where the status is
        ``LIFT_OFF`` or ``NOT_CONVERGED``.
    status : numpy.ndarray of int8
        :class:`~study.status.Status` codes.

    See Also
    --------
    steady_state : the same with diagnostics.
    """
    result = steady_state(structure, f, a, settings)
    return result.velocity, result.status
