"""The structure vector's entries of a structure, packed in one place.

Every solver that hands a structure to a kernel as the float64 vector of
:mod:`study.kernels.structure_vector` starts from :func:`structure_entries`: the
structure's own entries (damping, stiffness, tilt, mass ratio, friction coefficients,
gravity, restitution), computed the same way for every kernel, and the laws' entries
(coupling, lift-off law, friction law and its parameters) left 0 for the solver to set
from its chosen laws (:func:`with_laws`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from study.kernels import structure_vector as sv
from study.model.contact import LAWS, Friction
from study.model.structure import Structure

__all__ = ["structure_entries", "with_laws"]


def structure_entries(structure: Structure) -> NDArray[np.float64]:
    """A new structure vector holding ``structure``'s own entries, the laws' entries 0.

    Parameters
    ----------
    structure : Structure
        A checked structure (SI inside: ``omega0`` [rad s-1], ``alpha_rad`` [rad],
        ``g`` [m s-2]).

    Returns
    -------
    numpy.ndarray
        ``(sv.SIZE,)`` float64: ``w0 / Q`` [s-1], ``w0^2`` [s-2], ``cos``/``sin`` of the
        tilt, ``M``, ``cs``, ``ck`` [1], ``g`` [m s-2] and the restitution [1]. The sign
        of a zero tilt is kept (``sin(-0.0)`` is -0.0).
    """
    vector = np.zeros(sv.SIZE)
    w0 = structure.omega0
    vector[sv.DAMPING] = w0 / structure.Q
    vector[sv.STIFFNESS] = w0 * w0
    vector[sv.COS_ALPHA] = np.cos(structure.alpha_rad)
    vector[sv.SIN_ALPHA] = np.sin(structure.alpha_rad)
    vector[sv.MASS_RATIO] = structure.M
    vector[sv.STATIC_FRICTION] = structure.cs
    vector[sv.KINETIC_FRICTION] = structure.ck
    vector[sv.GRAVITY] = structure.g
    vector[sv.RESTITUTION] = structure.restitution
    return vector


def with_laws(vector: NDArray[np.float64], *, two_way: bool, lift_off: str,
              friction: Friction | None = None) -> NDArray[np.float64]:
    """``vector`` with the laws' entries set in place and returned: the coupling
    (``two_way``), the lift-off law's code (``"stop"`` or ``"flight"``) and, where a
    ``friction`` law is given, its code and parameters, the parameters of the laws not
    chosen NaN (never read)."""
    vector[sv.TWO_WAY] = 1.0 if two_way else 0.0
    vector[sv.LIFT_OFF_LAW] = float(LAWS["lift_off"][lift_off].code)
    if friction is not None:
        vector[sv.FRICTION_LAW + 1:] = np.nan
        for name, value in friction.vector_entries().items():
            vector[sv.index(name)] = value
    return vector
