"""The structure vector's entries of a structure, packed in one place.

Every solver that hands a structure to a kernel as the float64 vector of
:mod:`study.kernels.structure_vector` starts from :func:`structure_entries`: the
structure's own entries (damping, stiffness, tilt, mass ratio, friction coefficients,
gravity, restitution), computed the same way for every kernel, and the laws' entries
(coupling, lift-off law, friction law and its parameters) left 0 for the solver to set
from its chosen laws (:func:`with_laws`). A plate's mode (:func:`mode_entries`), the
friction and gravity (:func:`contact_entries`) and the coupling (:func:`coupling_entry`)
are computed here for the planar disk's vectors too
(:func:`study.solvers.planar.disk_parameters`), whose entries of the same names mean
the same.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from study.kernels import structure_vector as sv
from study.model.contact import LAWS, Friction
from study.model.structure import Structure

__all__ = ["contact_entries", "coupling_entry", "mode_entries", "structure_entries",
           "with_laws"]


def mode_entries(omega0: float, Q: float, M: float, cos_alpha: float, sin_alpha: float
                 ) -> dict[str, float]:
    """A plate's first mode as structure-vector entries, by name.

    Parameters
    ----------
    omega0 : float
        Angular resonance frequency ``w0`` of the mode [rad s-1].
    Q : float
        Quality factor [1].
    M : float
        Modal mass over the whole structure's mass [1].
    cos_alpha, sin_alpha : float
        Cosine and sine of the mode's tilt from the horizontal [1], computed by the
        caller (each solver keeps its own trigonometry, so its numbers stay bit for bit
        as they were).

    Returns
    -------
    dict of str to float
        ``damping`` ``w0 / Q`` [s-1], ``stiffness`` ``w0^2`` [s-2], ``cos_alpha``,
        ``sin_alpha`` and ``mass_ratio`` [1].
    """
    return {"damping": omega0 / Q, "stiffness": omega0 * omega0, "cos_alpha": cos_alpha,
            "sin_alpha": sin_alpha, "mass_ratio": M}


def contact_entries(cs: float, ck: float, g: float) -> dict[str, float]:
    """The contact's structure-vector entries, by name: ``static_friction`` ``cs`` and
    ``kinetic_friction`` ``ck`` [1], ``gravity`` ``g`` [m s-2]."""
    return {"static_friction": cs, "kinetic_friction": ck, "gravity": g}


def coupling_entry(two_way: bool) -> float:
    """The ``two_way`` entry [1]: 1.0 for two-way coupling, 0.0 for one-way."""
    return 1.0 if two_way else 0.0


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
    entries = {
        **mode_entries(structure.omega0, structure.Q, structure.M,
                       np.cos(structure.alpha_rad), np.sin(structure.alpha_rad)),
        **contact_entries(structure.cs, structure.ck, structure.g),
        "restitution": structure.restitution,
    }
    for name, value in entries.items():
        vector[sv.index(name)] = value
    return vector


def with_laws(vector: NDArray[np.float64], *, two_way: bool, lift_off: str,
              friction: Friction | None = None) -> NDArray[np.float64]:
    """``vector`` with the laws' entries set in place and returned: the coupling
    (``two_way``), the lift-off law's code (``"stop"`` or ``"flight"``) and, where a
    ``friction`` law is given, its code and parameters, the parameters of the laws not
    chosen NaN (never read)."""
    vector[sv.TWO_WAY] = coupling_entry(two_way)
    vector[sv.LIFT_OFF_LAW] = float(LAWS["lift_off"][lift_off].code)
    if friction is not None:
        vector[sv.FRICTION_LAW + 1:] = np.nan
        for name, value in friction.vector_entries().items():
            vector[sv.index(name)] = value
    return vector
