"""The zero-velocity frontier f*(a) as roots of the steady velocity in ``f``.

Frontier points are found from the solver, never by contouring a picture: each sign
change of the velocity between neighbouring moving points of a frequency grid is
refined by bisection on the exact solver to a set tolerance.
:func:`study.analyses.frontier.frontier` returns them as a labelled dataset; a study's
``frontier`` observable calls :func:`frontier_from_grid` on its own grid.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.model import as_acceleration, as_frequency
from study.model.inputs import InputTypeError, bounded_number, real_number
from study.model.status import INVALID_STATUSES, Status
from study.model.structure import Structure
from study.model.units import HERTZ
from study.solvers.exact import steady_state
from study.solvers.settings import SolverSettings, check_settings
from study.solvers.steady import SteadyState

__all__ = [
    "FRONTIER_CROSSING",
    "FRONTIER_JUMP",
    "MAX_SCAN_POINTS",
    "TOLERANCE_SPACINGS",
    "Frontier",
    "check_f_range",
    "check_tolerance",
    "finest_tolerance",
    "frontier_branches",
    "frontier_from_grid",
    "frontier_work",
]

#: Frontier point where the velocity passes continuously through zero.
FRONTIER_CROSSING = 1
#: Frontier point where the velocity jumps across zero (a regime boundary).
FRONTIER_JUMP = 2

#: Statuses of a structure that moves: every status with a velocity but STATIC (with
#: flight BOUNCING too, so that a frontier runs on through the bouncing region).
_MOVING = tuple(s for s in Status if s not in INVALID_STATUSES and s != Status.STATIC)

#: The bisection of :func:`frontier` and the golden-section search of
#: :func:`minimum_threshold` shrink a bracket of frequencies until it is narrower than
#: their tolerance. Near a frequency ``f`` doubles are ``numpy.spacing(f)`` apart: a
#: bracket a few spacings wide stops shrinking (its midpoint rounds to an end), so a
#: tolerance below that is never reached and the loop never ends (1e-15 Hz near 14 Hz
#: hung). The finest tolerance allowed is this many spacings at the bracket's upper end.
TOLERANCE_SPACINGS = 4

#: Points of the scanning grid of :func:`frontier` at most (``num`` times the
#: accelerations): solved in one call, about 60 bytes each (6e8 bytes at most).
MAX_SCAN_POINTS = 10_000_000


def finest_tolerance(f_max: float) -> float:
    """The finest tolerance [Hz] a search for frequencies up to ``f_max`` [Hz] can reach:
    :data:`TOLERANCE_SPACINGS` spacings of doubles near ``f_max``."""
    return TOLERANCE_SPACINGS * float(np.spacing(abs(float(f_max))))


def check_tolerance(tolerance: object, f_max: float) -> float:
    """``tolerance`` [Hz] as a float if it is finite and at least
    :func:`finest_tolerance` of ``f_max``; else an error naming it and the smallest
    value allowed."""
    value = real_number("tolerance", tolerance, HERTZ)
    finest = finest_tolerance(f_max)
    if not (np.isfinite(value) and value >= finest):
        raise ValueError(
            f"tolerance = {tolerance!r} Hz is out of range; allowed: finite and >= {finest:.3g} "
            f"Hz ({TOLERANCE_SPACINGS} spacings of doubles near the highest frequency "
            f"searched, {float(f_max):g} Hz: a narrower bracket can never be reached)")
    return value


def check_f_range(f_range: object, name: str = "f_range") -> tuple[float, float]:
    """``f_range`` as ``(f_min, f_max)`` [Hz] if it is two real numbers with
    ``0 < f_min < f_max``, both finite; else an error naming the argument."""
    try:
        pair = tuple(f_range)  # type: ignore[arg-type]
    except TypeError:
        raise InputTypeError(f"{name} must be (f_min, f_max) [Hz], got {f_range!r}") from None
    if len(pair) != 2:
        raise ValueError(f"{name} must be (f_min, f_max) [Hz], two numbers; got {f_range!r}")
    f_min, f_max = (bounded_number(f"{name}[{i}]", x, HERTZ, lower=0.0, lower_open=True)
                    for i, x in enumerate(pair))
    if not f_min < f_max:
        raise ValueError(f"{name} must be (f_min, f_max) with f_min < f_max, got {f_range!r}")
    return f_min, f_max


@dataclass(frozen=True)
class Frontier:
    """Zero-velocity frontier points for a set of accelerations.

    Attributes
    ----------
    frequency : numpy.ndarray
        ``(n_a, n_branch)`` frontier frequencies f* [Hz], ascending along a row,
        NaN-padded where an acceleration has fewer branches.
    kind : numpy.ndarray of int8
        ``(n_a, n_branch)``: :data:`FRONTIER_CROSSING`, :data:`FRONTIER_JUMP`, 0 for padding.
    width : numpy.ndarray
        ``(n_a, n_branch)`` width of the final bracket [Hz] (<= the tolerance).
    direction : numpy.ndarray of int8
        ``(n_a, n_branch)``: +1 where v goes from negative to positive with rising f,
        -1 the other way, 0 for padding.
    """

    frequency: NDArray[np.float64]
    kind: NDArray[np.int8]
    width: NDArray[np.float64]
    direction: NDArray[np.int8]


def frontier_from_grid(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    velocity: ArrayLike,
    status: ArrayLike,
    *,
    tolerance: float = 1e-9,
    settings: SolverSettings | None = None,
    solve: Callable[[Structure, NDArray[np.float64], NDArray[np.float64]], SteadyState]
    | None = None,
    progress: Callable[[int], None] | None = None,
) -> Frontier:
    """Refine every sign change of the velocity along ``f`` into a frontier point.

    Parameters
    ----------
    structure : Structure
        The structure the velocities belong to.
    f : array_like
        ``(n_f,)`` ascending drive frequencies [Hz] of the grid.
    a : array_like
        ``(n_a,)`` drive accelerations [m s-2].
    velocity, status : array_like
        ``(n_f, n_a)`` steady velocity [m s-1] and status on the grid.
    tolerance : float
        Bracket width at which bisection stops [Hz], finite and at least
        :func:`finest_tolerance` of the largest ``f``.
    settings : SolverSettings, optional
        Solver budgets for the refinement.
    solve : callable, optional
        ``solve(structure, f, a) -> SteadyState`` used for the refinement instead of the
        exact solver (e.g. the time integrator with two-way coupling): it must be the
        solver that computed ``velocity``.
    progress : callable, optional
        ``progress(solves)`` after each bisection step, with the number of points it
        solved (:func:`frontier_work` counts them all beforehand).

    Returns
    -------
    Frontier
        Every branch: each pair of neighbouring moving grid points with opposite
        velocity signs holds one frontier point (a sign change finer than the grid
        is not seen; use a finer grid to find it).
    """
    f = as_frequency(f)
    a = as_acceleration(a)
    velocity = np.asarray(velocity, dtype=np.float64)
    status = np.asarray(status)
    if velocity.shape != (f.size, a.size) or status.shape != velocity.shape:
        raise ValueError(
            f"velocity and status must have shape (n_f, n_a) = {(f.size, a.size)}, got "
            f"{velocity.shape} and {status.shape}"
        )
    settings = check_settings(settings)
    tolerance = check_tolerance(tolerance, float(np.max(f, initial=0.0)))
    i_f, i_a = _sign_changes(velocity, status)
    lo = f[i_f].copy()
    hi = f[i_f + 1].copy()
    v_lo = velocity[i_f, i_a].copy()
    v_hi = velocity[i_f + 1, i_a].copy()
    scale = np.maximum(np.abs(v_lo), np.abs(v_hi))
    lo, hi, v_lo, v_hi = _bisect(structure, (lo, hi, v_lo, v_hi), a[i_a], tolerance, settings,
                                 solve, progress)
    point = 0.5 * (lo + hi)
    jump = np.abs(v_hi - v_lo) > 1e-6 * scale
    direction = np.sign(v_hi).astype(np.int8)
    return _by_acceleration(a.size, i_a, point, jump, hi - lo, direction)


def _bisect(
    structure: Structure,
    bracket: tuple[NDArray[np.float64], ...],
    a_points: NDArray[np.float64],
    tolerance: float,
    settings: SolverSettings,
    solve: Callable[[Structure, NDArray[np.float64], NDArray[np.float64]], SteadyState]
    | None,
    progress: Callable[[int], None] | None = None,
) -> tuple[NDArray[np.float64], ...]:
    """Bisect every bracket ``bracket = (lo, hi, v_lo, v_hi)`` of a sign change of the
    velocity (ends ``[lo, hi]`` [Hz], velocities there [m s-1], at ``a_points``
    [m s-2]) together, until all are narrower than ``tolerance`` [Hz]; returns the
    final ``lo, hi, v_lo, v_hi``."""
    lo, hi, v_lo, v_hi = bracket
    while lo.size and np.max(hi - lo) > tolerance:
        mid = 0.5 * (lo + hi)
        if solve is None:
            result = steady_state(structure, mid, a_points, settings)
        else:
            result = solve(structure, mid, a_points)
        v_mid = result.velocity
        valid = np.isin(result.status, _MOVING) & (v_mid != 0)
        take_lo = valid & (np.sign(v_mid) == np.sign(v_lo))
        # A midpoint that does not move (static, lift-off) marks a jump: keep bisecting
        # towards the side that changes sign with the lower end.
        take_hi = ~take_lo
        lo = np.where(take_lo, mid, lo)
        v_lo = np.where(take_lo, v_mid, v_lo)
        hi = np.where(take_hi, mid, hi)
        v_hi = np.where(take_hi, np.where(valid, v_mid, v_hi), v_hi)
        if progress is not None:
            progress(int(mid.size))
    return lo, hi, v_lo, v_hi


def _sign_changes(velocity: NDArray[np.float64], status: NDArray[Any]
                  ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """``(i_f, i_a)`` of every pair of neighbouring moving grid points along ``f`` whose
    velocities have opposite signs (the lower point's indices)."""
    moving = np.isin(status, _MOVING) & (velocity != 0)
    sign = np.sign(velocity)
    change = moving[:-1] & moving[1:] & (sign[:-1] * sign[1:] < 0)
    return np.nonzero(change)


def frontier_branches(velocity: ArrayLike, status: ArrayLike) -> int:
    """How many branches (columns) :func:`frontier_from_grid` returns for this map: the
    most sign changes at one acceleration, at least 1."""
    _, i_a = _sign_changes(np.asarray(velocity, dtype=np.float64), np.asarray(status))
    velocity = np.asarray(velocity)
    counts = np.bincount(i_a, minlength=velocity.shape[1] if velocity.ndim == 2 else 0)
    return max(1, int(counts.max(initial=0)))


def frontier_work(f: ArrayLike, velocity: ArrayLike, status: ArrayLike,
                  tolerance: float) -> int:
    """How many points :func:`frontier_from_grid` will solve: brackets x bisection steps
    (every bracket is bisected until the widest is narrower than ``tolerance``).

    Parameters
    ----------
    f : array_like
        ``(n_f,)`` ascending drive frequencies [Hz] of the grid.
    velocity, status : array_like
        ``(n_f, n_a)`` steady velocity [m s-1] and status on the grid.
    tolerance : float
        Bracket width at which bisection stops [Hz].
    """
    f = np.asarray(f, dtype=np.float64)
    i_f, _ = _sign_changes(np.asarray(velocity, dtype=np.float64), np.asarray(status))
    if not i_f.size:
        return 0
    width = float(np.max(f[i_f + 1] - f[i_f]))
    steps = 0
    while width > tolerance:
        width *= 0.5
        steps += 1
    return int(i_f.size) * steps


def _by_acceleration(
    n_a: int,
    i_a: NDArray[np.intp],
    point: NDArray[np.float64],
    jump: NDArray[np.bool_],
    width: NDArray[np.float64],
    direction: NDArray[np.int8],
) -> Frontier:
    """The frontier points (acceleration index ``i_a`` of each) as a :class:`Frontier`:
    one row per acceleration, its branches ascending in frequency, NaN/0 padded."""
    counts = np.bincount(i_a, minlength=n_a)
    n_branch = max(1, int(counts.max(initial=0)))
    frequency = np.full((n_a, n_branch), np.nan)
    kind = np.zeros((n_a, n_branch), dtype=np.int8)
    widths = np.full((n_a, n_branch), np.nan)
    directions = np.zeros((n_a, n_branch), dtype=np.int8)
    order = np.lexsort((point, i_a))
    slot = np.zeros(n_a, dtype=int)
    for k in order:
        j = i_a[k]
        frequency[j, slot[j]] = point[k]
        kind[j, slot[j]] = FRONTIER_JUMP if jump[k] else FRONTIER_CROSSING
        widths[j, slot[j]] = width[k]
        directions[j, slot[j]] = direction[k]
        slot[j] += 1
    return Frontier(frequency, kind, widths, directions)
