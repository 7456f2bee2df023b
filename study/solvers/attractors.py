"""Every attractor reached from a fixed set of starts at each drive point (the exact
two-way orbit solver from each start; :func:`attractors`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels.two_way import attractors as attractor_kernel
from study.model import (
    lift_off_acceleration,
)
from study.model.contact import (
    DEFAULT_COUPLING,
)
from study.model.structure import Structure, check_structure
from study.solvers.settings import (
    SolverSettings,
    check_coupling,
    check_flight,
    check_settings,
    flat_drive,
    kernel_budget,
)
from study.solvers.steady import scalar_if_0d
from study.solvers.structure_constants import structure_vector

__all__ = [
    "ATTRACTOR_DROPS",
    "ATTRACTOR_STARTS",
    "Attractors",
    "attractors",
]


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
