"""Analyses on top of the solver: the zero-velocity frontier f*(a) and threshold minima.

Everything here works from the physics and the solver (never by contouring a
picture): frontier points are roots of the steady velocity in ``f``, bracketed on a
grid and refined by bisection on the exact solver to a set tolerance.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from study.physics import as_acceleration, as_frequency, thresholds
from study.solver import (
    DEFAULT_COUPLING,
    SolverSettings,
    SteadyState,
    check_coupling,
    check_structure,
    steady_state,
)
from study.status import Status
from study.structure import Structure
from study.units import DIMENSIONLESS, HERTZ, METRE_PER_SECOND_SQUARED
from study.variables import VARIABLES

__all__ = [
    "FRONTIER_CROSSING",
    "FRONTIER_JUMP",
    "Frontier",
    "collapse_variable",
    "frontier",
    "frontier_from_grid",
    "lowest_threshold",
    "minimum_threshold",
    "resonance_threshold",
]

#: Frontier point where the velocity passes continuously through zero.
FRONTIER_CROSSING = 1
#: Frontier point where the velocity jumps across zero (a regime boundary).
FRONTIER_JUMP = 2

_MOVING = (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING)


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
        Bracket width at which bisection stops [Hz].
    settings : SolverSettings, optional
        Solver budgets for the refinement.
    solve : callable, optional
        ``solve(structure, f, a) -> SteadyState`` used for the refinement instead of the
        exact solver (e.g. the time integrator with two-way coupling): it must be the
        solver that computed ``velocity``.

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
    if not tolerance > 0:
        raise ValueError(f"tolerance must be > 0 Hz, got {tolerance!r}")
    moving = np.isin(status, _MOVING) & (velocity != 0)
    sign = np.sign(velocity)
    change = moving[:-1] & moving[1:] & (sign[:-1] * sign[1:] < 0)
    i_f, i_a = np.nonzero(change)
    lo = f[i_f].copy()
    hi = f[i_f + 1].copy()
    v_lo = velocity[i_f, i_a].copy()
    v_hi = velocity[i_f + 1, i_a].copy()
    scale = np.maximum(np.abs(v_lo), np.abs(v_hi))
    a_points = a[i_a]
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
    point = 0.5 * (lo + hi)
    jump = np.abs(v_hi - v_lo) > 1e-6 * scale
    direction = np.sign(v_hi).astype(np.int8)
    counts = np.bincount(i_a, minlength=a.size)
    n_branch = max(1, int(counts.max(initial=0)))
    frequency = np.full((a.size, n_branch), np.nan)
    kind = np.zeros((a.size, n_branch), dtype=np.int8)
    width = np.full((a.size, n_branch), np.nan)
    directions = np.zeros((a.size, n_branch), dtype=np.int8)
    order = np.lexsort((point, i_a))
    slot = np.zeros(a.size, dtype=int)
    for k in order:
        j = i_a[k]
        frequency[j, slot[j]] = point[k]
        kind[j, slot[j]] = FRONTIER_JUMP if jump[k] else FRONTIER_CROSSING
        width[j, slot[j]] = hi[k] - lo[k]
        directions[j, slot[j]] = direction[k]
        slot[j] += 1
    return Frontier(frequency, kind, width, directions)


def frontier(
    structure: Structure,
    a: ArrayLike,
    f_range: tuple[float, float],
    *,
    num: int = 2001,
    tolerance: float = 1e-9,
    settings: SolverSettings | None = None,
    coupling: str = DEFAULT_COUPLING,
) -> xr.Dataset:
    """Zero-velocity frontier f*(a): every frequency where the velocity changes sign.

    The velocity is solved on ``num`` frequencies spanning ``f_range``; each sign
    change between neighbouring moving points is refined by bisection on the exact
    solver of the same coupling until its bracket is narrower than ``tolerance``. The
    refinement is the one a study's ``frontier`` observable makes (the
    ``frontier`` and ``frontier-two-way`` workflows): on the same scan grid the
    frontier frequencies are the same, bit for bit.

    Parameters
    ----------
    structure : Structure
        The structure.
    a : array_like
        Drive accelerations [m s-2], a scalar or 1-D, finite, >= 0.
    f_range : (float, float)
        Frequency interval searched [Hz], ``0 < f_min < f_max``.
    num : int, default 2001
        Frequencies of the scanning grid [1], >= 2 (``numpy.linspace(*f_range, num)``).
    tolerance : float, default 1e-9
        Location accuracy of every root [Hz], > 0.
    settings : SolverSettings, optional
        Solver budgets.
    coupling : {"one-way", "two-way"}, default "one-way"
        The paper's model or the mode also forced by the sliding base
        (:data:`study.solver.DEFAULT_COUPLING`).

    Returns
    -------
    xarray.Dataset
        ``frontier_frequency`` [Hz], ``frontier_kind`` (flags ``none``, ``crossing``,
        ``jump``), ``frontier_direction`` [1] and ``frontier_bracket`` [Hz] over dims
        ``(a, branch)``, NaN-padded (kind 0) where an acceleration has fewer branches;
        attributes and variables as in a study file. Global attributes:
        ``study_coupling``, ``structure``, ``f_range`` [Hz], ``scan_points``,
        ``tolerance_Hz``.

    Raises
    ------
    ValueError
        For an empty or reversed ``f_range``, ``num < 2``, a bad ``coupling``.
    TypeError
        For a structure that is not a :class:`study.Structure`, or ``a`` not real
        numbers.
    """
    structure = check_structure(structure)
    coupling = check_coupling(coupling)
    f_min, f_max = (float(x) for x in f_range)
    if not f_min < f_max:
        raise ValueError(f"f_range must be (f_min, f_max) with f_min < f_max, got {f_range!r}")
    if num < 2:
        raise ValueError(f"num must be >= 2, got {num!r}")
    a = np.atleast_1d(as_acceleration(a))
    f = np.linspace(f_min, f_max, num)

    def two_way(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64]
                ) -> SteadyState:
        # As the study's frontier observable solves (Method.solve).
        return steady_state(structure, f, a, settings, coupling=coupling, parallel=False)

    result = steady_state(structure, f[:, None], a[None, :], settings, coupling=coupling)
    found = frontier_from_grid(structure, f, a, result.velocity, result.status,
                               tolerance=tolerance, settings=settings,
                               solve=two_way if coupling == "two-way" else None)
    return frontier_dataset(found, a, structure, (f_min, f_max), num, tolerance, coupling)


def frontier_dataset(found: Frontier, a, structure: Structure, f_range, num, tolerance,
                     coupling: str = DEFAULT_COUPLING) -> xr.Dataset:
    """Frontier points as a labelled dataset (dims ``a``, ``branch``)."""
    from study.provenance import code_sha256, package_version, utc_now

    dims = ("a", "branch")
    values = {
        "frontier_frequency": found.frequency,
        "frontier_kind": found.kind,
        "frontier_direction": found.direction,
        "frontier_bracket": found.width,
    }
    dataset = xr.Dataset(
        {name: (dims, values[name], VARIABLES[name].attrs()) for name in values},
        coords={"a": ("a", np.asarray(a, dtype=np.float64),
                      {"units": METRE_PER_SECOND_SQUARED,
                       "long_name": "drive acceleration amplitude"})},
    )
    dataset.attrs.update({
        "title": f"Zero-velocity frontier f*(a), {coupling} coupling",
        "study_coupling": coupling,
        "structure": repr(structure),
        "f_range": np.asarray(f_range, dtype=np.float64),
        "scan_points": int(num),
        "tolerance_Hz": float(tolerance),
        "study_version": package_version(),
        "study_code_sha256": code_sha256(),
        "date_created": utc_now(),
    })
    return dataset


def resonance_threshold(structure: Structure) -> tuple[float, float]:
    """Thresholds ``(a*_+, a*_-)`` at ``f = f0`` in closed form [m s-2].

    At resonance ``w^2 G = -i Q``, so
    ``a*_pm = g / |1 - i Q M cos(alpha) (cos(alpha) +- sin(alpha)/cs)|``
    ``= g / sqrt(1 + x_pm^2)`` with ``x_pm = Q M cos(alpha) (cos(alpha) +- sin(alpha)/cs)``:
    the paper's ``Q m1 ~ m`` scaling, ``a* ~ g / (Q M ...)`` once ``x >> 1``.
    """
    x_plus, x_minus = collapse_variable(structure)
    g = structure.g
    return g / np.hypot(1.0, x_plus), g / np.hypot(1.0, x_minus)


def collapse_variable(structure: Structure) -> tuple[float, float]:
    """``x_pm = Q M cos(alpha) (cos(alpha) +- sin(alpha)/cs)`` [1].

    See :func:`resonance_threshold`.
    """
    alpha = np.radians(structure.alpha)
    base = structure.Q * structure.M * np.cos(alpha)
    return (base * (np.cos(alpha) + np.sin(alpha) / structure.cs),
            base * (np.cos(alpha) - np.sin(alpha) / structure.cs))


def lowest_threshold(structure: Structure, f_range: tuple[float, float] | None = None,
                     *, tolerance: float = 1e-10) -> tuple[float, float]:
    """Lowest motion threshold ``min_f min(a*_+, a*_-)`` [m s-2] and its frequency [Hz].

    The numbers of :func:`minimum_threshold`, as a plain ``(a_min, f_min)`` pair of
    floats: golden-section search on the closed-form thresholds around their minimum
    on a 4001-point scanning grid of ``f_range`` (default ``0.5 f0 .. 2 f0``), to a
    bracket of ``tolerance`` [Hz].
    """
    lo, hi = f_range if f_range is not None else (0.5 * structure.f0, 2.0 * structure.f0)

    def lower(f):
        a_plus, a_minus = thresholds(structure, f)
        return np.minimum(a_plus, a_minus)

    grid = np.linspace(lo, hi, 4001)
    i = int(np.argmin(lower(grid)))
    left, right = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    while right - left > tolerance:
        x1 = right - ratio * (right - left)
        x2 = left + ratio * (right - left)
        if lower(x1) < lower(x2):
            right = x2
        else:
            left = x1
    f_best = 0.5 * (left + right)
    return float(lower(f_best)), float(f_best)


def minimum_threshold(structure: Structure, f_range: tuple[float, float] | None = None,
                      *, tolerance: float = 1e-10, coupling: str = DEFAULT_COUPLING
                      ) -> xr.Dataset:
    """Lowest motion threshold ``min_f min(a*_+, a*_-)`` and the frequency where it is.

    Below its motion thresholds the structure sticks to the table, so the sliding base
    forces nothing: the thresholds (paper eq. 5, closed form) are the same with either
    coupling, and so is this minimum. ``coupling`` only names the model in the result.

    Parameters
    ----------
    structure : Structure
        The structure.
    f_range : (float, float), optional
        Frequencies searched [Hz]; default ``(0.5 f0, 2 f0)``.
    tolerance : float, default 1e-10
        Bracket of the minimum's frequency at which the golden-section search stops
        [Hz].
    coupling : {"one-way", "two-way"}, default "one-way"
        The model named in the result (:data:`study.solver.DEFAULT_COUPLING`).

    Returns
    -------
    xarray.Dataset
        Scalars ``a_min`` (the lowest threshold [m s-2]), ``f_min`` (its frequency
        [Hz]), ``a_star_plus`` and ``a_star_minus`` (both thresholds at ``f_min``
        [m s-2]), with ``units`` and ``long_name``; global attributes
        ``study_coupling``, ``structure``, ``f_range`` [Hz], ``tolerance_Hz``.
        ``float(ds["a_min"])`` is the number.

    See Also
    --------
    lowest_threshold : the same two numbers as a tuple of floats.
    thresholds : ``a*_+`` and ``a*_-`` at any frequency.
    """
    structure = check_structure(structure)
    coupling = check_coupling(coupling)
    lo, hi = f_range if f_range is not None else (0.5 * structure.f0, 2.0 * structure.f0)
    a_min, f_min = lowest_threshold(structure, (lo, hi), tolerance=tolerance)
    plus, minus = thresholds(structure, f_min)
    return xr.Dataset(
        {
            "a_min": ((), a_min, {"units": METRE_PER_SECOND_SQUARED,
                                  "long_name": "lowest motion threshold "
                                  "min over f of min(a*_+, a*_-) (paper eq. 5)"}),
            "f_min": ((), f_min, {"units": HERTZ, "long_name": "drive frequency of the "
                                  "lowest motion threshold"}),
            "a_star_plus": ((), float(plus), VARIABLES["a_star_plus"].attrs()),
            "a_star_minus": ((), float(minus), VARIABLES["a_star_minus"].attrs()),
        },
        attrs={
            "title": f"Lowest motion threshold, {coupling} coupling",
            "study_coupling": coupling,
            "structure": repr(structure),
            "f_range": np.asarray((lo, hi), dtype=np.float64),
            "tolerance_Hz": float(tolerance),
        },
    )


def coupling_effect(dataset: xr.Dataset, threshold: float = 0.1) -> xr.Dataset:
    """How far two-way coupling moves the steady velocity from the paper's one-way model.

    Parameters
    ----------
    dataset : xarray.Dataset
        A two-way study holding ``velocity``/``status`` and the ``paper_model``
        observable (``velocity_one_way``/``status_one_way``) over ``(..., f, a)``.
    threshold : float
        Relative change [1] above which a point counts as changed.

    Returns
    -------
    xarray.Dataset
        Over the structure axes (the drive axes reduced), each a fraction [1] of the
        points where the one-way model moves (stick-slip or continuous sliding):
        ``changed`` (two-way also moves and ``|v2 - v1| > threshold |v1|``),
        ``reversed`` (opposite direction), ``lifted`` (two-way leaves the table),
        ``paradox`` (two-way friction paradox), and ``median_change`` (median
        ``|v2 - v1| / |v1|`` over the points where both move) and ``moving_points``.
    """
    missing = [v for v in ("velocity", "status", "velocity_one_way", "status_one_way")
               if v not in dataset]
    if missing:
        raise ValueError(
            f"coupling_effect needs {', '.join(missing)}: a two-way study with the "
            "'paper_model' observable"
        )
    v1 = dataset["velocity_one_way"]
    v2 = dataset["velocity"]
    moving1 = dataset["status_one_way"].isin(list(_MOVING)) & (v1 != 0)
    moving2 = dataset["status"].isin([*_MOVING, Status.STATIC])
    both = moving1 & moving2
    relative = (abs(v2 - v1) / abs(v1)).where(both)
    drive = [d for d in ("f", "a") if d in dataset.dims]
    count = moving1.sum(drive)
    safe = count.where(count > 0)

    def share(mask: xr.DataArray) -> xr.DataArray:
        return (mask & moving1).sum(drive) / safe

    out = xr.Dataset(
        {
            "changed": share(both & (relative > threshold)),
            "reversed": share(both & (np.sign(v2) * np.sign(v1) < 0)),
            "lifted": share(dataset["status"] == Status.LIFT_OFF),
            "paradox": share(dataset["status"] == Status.FRICTION_PARADOX),
            "median_change": relative.median(drive),
            "moving_points": count,
        }
    )
    for name in ("changed", "reversed", "lifted", "paradox", "median_change"):
        out[name].attrs["units"] = DIMENSIONLESS
    out["moving_points"].attrs["units"] = DIMENSIONLESS
    out.attrs["threshold"] = threshold
    return out
