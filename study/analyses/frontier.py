"""The zero-velocity frontier f*(a) of a structure, as a labelled dataset.

The velocity is solved on a frequency grid and every sign change refined by bisection
(:func:`study.solvers.frontier.frontier_from_grid`, the refinement a study's
``frontier`` observable makes); the result carries the variables, units and flags of a
study file.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from study.model import as_acceleration
from study.model.contact import DEFAULT_COUPLING
from study.model.inputs import bounded_integer
from study.model.structure import Structure, check_structure
from study.model.units import METRE_PER_SECOND_SQUARED
from study.solvers.exact import steady_state
from study.solvers.frontier import (
    MAX_SCAN_POINTS,
    Frontier,
    check_f_range,
    check_tolerance,
    frontier_from_grid,
)
from study.solvers.settings import SolverSettings, check_coupling, check_settings
from study.solvers.steady import SteadyState
from study.studies.variables import VARIABLES

__all__ = ["frontier", "frontier_dataset"]


def frontier(
    structure: Structure,
    a: ArrayLike,
    f_range: tuple[float, float],
    *,
    num: int = 2001,
    tolerance: float = 1e-9,
    settings: SolverSettings | None = None,
    coupling: str = DEFAULT_COUPLING,
    flight: bool = False,
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
        Frequencies of the scanning grid [1], >= 2 (``numpy.linspace(*f_range, num)``);
        ``num`` times the accelerations at most :data:`MAX_SCAN_POINTS`.
    tolerance : float, default 1e-9
        Location accuracy of every root [Hz], finite and at least
        :func:`finest_tolerance` of ``f_max`` (4 spacings of doubles: 1.4e-14 Hz near
        14 Hz), the finest a bisection can reach.
    settings : SolverSettings, optional
        Solver budgets.
    coupling : {"one-way", "two-way"}, default "one-way"
        The paper's model or the mode also forced by the sliding base
        (:data:`study.solvers.exact.DEFAULT_COUPLING`).
    flight : bool, default False
        Past lift-off the base flies and lands by impacts (two-way coupling, ``M < 1``):
        bouncing points have a velocity, so the frontier runs on through the bouncing
        region; default: lift-off points have none and a frontier stops at them.

    Returns
    -------
    xarray.Dataset
        ``frontier_frequency`` [Hz], ``frontier_kind`` (flags ``none``, ``crossing``,
        ``jump``), ``frontier_direction`` [1] and ``frontier_bracket`` [Hz] over dims
        ``(a, branch)``, NaN-padded (kind 0) where an acceleration has fewer branches;
        attributes and variables as in a study file. Global attributes:
        ``study_coupling``, ``structure``, ``f_range`` [Hz], ``scan_points``,
        ``tolerance_Hz`` (with flight also ``study_lift_off = "flight"``).

    Raises
    ------
    ValueError
        For an empty, reversed or non-positive ``f_range``, ``num`` out of range, a
        ``tolerance`` finer than doubles resolve, a bad ``coupling``; each names the
        argument and what is allowed; ``flight`` with one-way coupling or ``M = 1``
        (the solver's message).
    TypeError
        For a structure that is not a :class:`study.Structure`, settings that are not
        :class:`study.SolverSettings`, or ``a``, ``f_range``, ``num``, ``tolerance``
        not real numbers (:class:`study.model.inputs.InputTypeError`, also a ValueError).
    """
    structure = check_structure(structure)
    coupling = check_coupling(coupling)
    settings = check_settings(settings)
    f_min, f_max = check_f_range(f_range)
    num = bounded_integer("num", num, 2, MAX_SCAN_POINTS)
    tolerance = check_tolerance(tolerance, f_max)
    a = np.atleast_1d(as_acceleration(a))
    if a.ndim != 1:
        raise ValueError(f"a must be a scalar or 1-D, got shape {a.shape}")
    if num * a.size > MAX_SCAN_POINTS:
        raise ValueError(f"num x a = {num} x {a.size} scanning points is too many; allowed: "
                         f"at most {MAX_SCAN_POINTS:.3g}")
    f = np.linspace(f_min, f_max, num)

    def two_way(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64]
                ) -> SteadyState:
        # As the study's frontier observable solves (Method.solve).
        return steady_state(structure, f, a, settings, coupling=coupling, parallel=False,
                            **flying)

    # The solver's default unless flying: its call stays the one before flight existed.
    flying = {"flight": True} if flight else {}
    result = steady_state(structure, f[:, None], a[None, :], settings, coupling=coupling,
                          **flying)
    found = frontier_from_grid(structure, f, a, result.velocity, result.status,
                               tolerance=tolerance, settings=settings,
                               solve=two_way if coupling == "two-way" else None)
    return frontier_dataset(found, a, structure, (f_min, f_max), num, tolerance, coupling,
                            flight)


def frontier_dataset(found: Frontier, a, structure: Structure, f_range, num, tolerance,
                     coupling: str = DEFAULT_COUPLING, flight: bool = False) -> xr.Dataset:
    """Frontier points as a labelled dataset (dims ``a``, ``branch``)."""
    from study.engine.provenance import code_sha256, package_version, utc_now

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
        "title": f"Zero-velocity frontier f*(a), {coupling} coupling"
                 + (", flight" if flight else ""),
        "study_coupling": coupling,
        **({"study_lift_off": "flight"} if flight else {}),
        "structure": repr(structure),
        "f_range": np.asarray(f_range, dtype=np.float64),
        "scan_points": int(num),
        "tolerance_Hz": float(tolerance),
        "study_version": package_version(),
        "study_code_sha256": code_sha256(),
        "date_created": utc_now(),
    })
    return dataset
