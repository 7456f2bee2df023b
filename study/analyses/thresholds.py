"""The lowest motion threshold of a structure and its closed-form scaling at resonance."""

from __future__ import annotations

import numpy as np
import xarray as xr

from study.model import thresholds
from study.model.contact import DEFAULT_COUPLING
from study.model.structure import Structure, check_structure
from study.model.units import HERTZ, METRE_PER_SECOND_SQUARED
from study.solvers.frontier import check_f_range, check_tolerance
from study.solvers.settings import check_coupling
from study.studies.variables import VARIABLES

__all__ = ["collapse_variable", "lowest_threshold", "minimum_threshold",
           "resonance_threshold"]


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
    structure = check_structure(structure)
    lo, hi = check_f_range(
        f_range if f_range is not None else (0.5 * structure.f0, 2.0 * structure.f0))
    tolerance = check_tolerance(tolerance, hi)

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
        [Hz], finite and at least :func:`finest_tolerance` of the upper end of
        ``f_range`` (the finest the search can reach).
    coupling : {"one-way", "two-way"}, default "one-way"
        The model named in the result (:data:`study.solvers.exact.DEFAULT_COUPLING`).

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

    Raises
    ------
    ValueError
        For an empty, reversed or non-positive ``f_range``, a ``tolerance`` finer than
        doubles resolve (or not finite), a bad ``coupling``, naming the argument.
    TypeError
        For a structure that is not a :class:`study.Structure`, or ``f_range`` or
        ``tolerance`` not real numbers.
    """
    structure = check_structure(structure)
    coupling = check_coupling(coupling)
    lo, hi = check_f_range(
        f_range if f_range is not None else (0.5 * structure.f0, 2.0 * structure.f0))
    tolerance = check_tolerance(tolerance, hi)
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
