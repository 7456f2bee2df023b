"""The phase-0 Poincare section of the two-way motion at each drive point
(:func:`phase_section`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels.two_way import section as section_kernel
from study.model.structure import Structure, check_structure
from study.solvers.exact import orbit_steady_state
from study.solvers.settings import (
    SolverSettings,
    check_flight,
    check_settings,
    check_start,
    flat_drive,
)
from study.solvers.steady import SteadyState
from study.solvers.structure_constants import structure_vector

__all__ = [
    "SECTION_PERIODS",
    "PhaseSection",
    "phase_section",
]


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
        solution = orbit_steady_state(structure, f_flat, a_flat, shape, "two-way",
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
