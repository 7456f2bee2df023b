"""What the exact steady-state solver returns: :class:`SteadyState`, read by name from
a kernel's output table (:data:`STEADY_FIELDS`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.kernels import one_way as one_way_kernel
from study.kernels.two_way import points as orbit_kernel

__all__ = [
    "FIELD_DTYPES",
    "FIELD_UNITS",
    "FLIGHT_FIELDS",
    "STEADY_FIELDS",
    "SteadyState",
    "declared_units",
    "scalar_if_0d",
    "shaped",
    "steady_fields",
]


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


def shaped(values: NDArray[Any], shape: tuple[int, ...]) -> Any:
    """The flat ``values`` in ``shape``, as :func:`scalar_if_0d` returns them: the one
    value's numpy scalar for ``shape == ()`` (read directly: a 0-d view costs a small
    call about 0.4 us a variable)."""
    return values[0] if shape == () else scalar_if_0d(values.reshape(shape))


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


def declared_units(fields: dict[str, tuple[str, Any]],
                   tables: tuple[tuple[tuple[str, str, str], ...], ...]) -> dict[str, str]:
    """The units of each of ``fields`` (field: ``(column, dtype)``, as
    :data:`STEADY_FIELDS`) as the kernels' output ``tables`` (rows ``(name, units,
    meaning)``) declare its column.

    Raises
    ------
    ValueError
        Naming the field, where no table or tables with different units declare its
        column: a disagreement between the kernels' declarations.
    """
    units: dict[str, str] = {}
    for field, (column, _) in fields.items():
        declared = {u for table in tables for name, u, _ in table if name == column}
        if len(declared) != 1:
            raise ValueError(f"SteadyState field {field!r}: its column {column!r} is declared "
                             f"with units {sorted(declared)} by the kernels' OUTPUT_COLUMNS; "
                             "exactly one is needed")
        units[field] = declared.pop()
    return units


#: The units of each :class:`SteadyState` field, read from its kernel column's
#: declaration: the result variables that hold a field take theirs from here
#: (:func:`study.studies.variables.solver_output`).
FIELD_UNITS = declared_units(STEADY_FIELDS, (one_way_kernel.OUTPUT_COLUMNS,
                                             orbit_kernel.OUTPUT_COLUMNS))
#: The numpy dtype name of each field as :func:`steady_fields` returns it.
FIELD_DTYPES = {field: np.dtype(dtype or np.float64).name
                for field, (_, dtype) in STEADY_FIELDS.items()}


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
        fields[field] = shaped(values if dtype is None else values.astype(dtype), shape)
    return fields
