"""The impact law of the base on the table, on arrays: validate, allocate, call the kernel.

The law itself (Darboux-Keller friction along the normal impulse, Newton's restitution,
the impact matrix ``W = I + M/(1 - M) e e^T``) is :mod:`study.kernels.impact`; the flight
solvers call that kernel directly at each landing. This wrapper is for users and tests:
what an impact does to given velocities.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels import impact as impact_kernel
from study.model.inputs import as_real_array
from study.model.structure import Structure, check_structure
from study.model.units import METRE_PER_SECOND
from study.solvers.steady import scalar_if_0d
from study.solvers.structure_constants import structure_vector

__all__ = ["Impact", "impact"]


@dataclass(frozen=True)
class Impact:
    """What an impact of the base on the table does, arrays of the broadcast shape.

    Every attribute has the broadcast shape of the velocities given, or is a numpy scalar
    when all were scalars. Impulses are per unit total mass, so in m s-1. On
    ``IMPACT_PARADOX`` every float is NaN.

    Attributes
    ----------
    delta_rate : numpy.ndarray of float64
        Mode velocity delta' after the impact [m s-1].
    velocity : numpy.ndarray of float64
        Base's horizontal velocity v after the impact [m s-1] (relative to the table,
        which moves vertically only).
    gap_rate : numpy.ndarray of float64
        Base's vertical velocity relative to the table h' after the impact [m s-1]:
        ``-restitution`` times the one before.
    normal_impulse : numpy.ndarray of float64
        Normal impulse Pz of the table on the base per unit total mass [m s-1], ``> 0``.
    tangential_impulse : numpy.ndarray of float64
        Tangential (horizontal) impulse Px of the table on the base per unit total mass
        [m s-1].
    outcome : numpy.ndarray of int8
        ``study.model.codes`` IMPACT_STICK (0: the base ends at rest tangentially),
        IMPACT_SLIP (1: it ends sliding) or IMPACT_PARADOX (2: a slide that arises has
        ``D_s <= 0``, Painleve's paradox: no impact law) [1].
    """

    delta_rate: NDArray[np.float64]
    velocity: NDArray[np.float64]
    gap_rate: NDArray[np.float64]
    normal_impulse: NDArray[np.float64]
    tangential_impulse: NDArray[np.float64]
    outcome: NDArray[np.int8]


def impact(
    structure: Structure,
    delta_rate: ArrayLike,
    velocity: ArrayLike,
    gap_rate: ArrayLike,
) -> Impact:
    """Velocities just after an impact of the base on the table, from those just before.

    The table's contact impulse acts on the base only; the plate's velocity along the
    mode direction ``e = (sin(alpha), cos(alpha))`` is continuous (the mode's generalized
    momentum), the base's velocity jumps by ``W P`` with ``W = I + M/(1 - M) e e^T``.
    Coulomb friction acts along the normal impulse (Darboux-Keller: the base slides,
    may stop and then stays stuck when ``|W_xz / W_xx| <= cs`` or slides back); the
    impact ends when ``h' = -restitution h'_before`` (Newton).

    Parameters
    ----------
    structure : study.Structure
        The structure; its ``M`` must be below 1 (the law is singular at ``M = 1``)
        and its ``restitution`` is the normal restitution.
    delta_rate : array_like
        Mode velocity delta' before the impact [m s-1].
    velocity : array_like
        Base's horizontal velocity v before the impact [m s-1].
    gap_rate : array_like
        Base's vertical velocity relative to the table h' before the impact [m s-1];
        every value ``< 0`` (the base approaches the table).

    Returns
    -------
    Impact
        The velocities after, the impulses [m s-1] and the outcome codes.

    Raises
    ------
    study.model.inputs.InputTypeError
        If ``structure`` is not a :class:`study.Structure` or a velocity is not real
        numbers.
    ValueError
        If the velocities do not broadcast together, are not finite, a ``gap_rate`` is
        not negative, or ``structure.M`` is 1.
    """
    structure = check_structure(structure)
    if not structure.M < 1.0:
        raise ValueError(
            f"structure.M = {structure.M!r} is out of range for an impact; allowed: M < 1 "
            "(M = 1 is a massless base: the impact matrix W = I + M/(1 - M) e e^T is "
            "unbounded)")
    given = {name: as_real_array(name, values, METRE_PER_SECOND) for name, values in
             (("delta_rate", delta_rate), ("velocity", velocity), ("gap_rate", gap_rate))}
    try:
        arrays = np.broadcast_arrays(*given.values())
    except ValueError:
        shapes = ", ".join(f"{name} {array.shape}" for name, array in given.items())
        raise ValueError(f"delta_rate, velocity and gap_rate must broadcast together; got "
                         f"shapes {shapes}") from None
    for name, array in zip(given, arrays, strict=True):
        if not np.all(np.isfinite(array)):
            raise ValueError(f"{name} must be finite [{METRE_PER_SECOND}]; got "
                             f"{float(array[~np.isfinite(array)].flat[0])!r}")
    gap = arrays[2]
    if np.any(gap >= 0.0):
        raise ValueError(
            f"gap_rate = {float(gap[gap >= 0.0].flat[0])!r} is out of range; allowed: < 0 "
            f"{METRE_PER_SECOND} (an impact needs the base approaching the table)")
    shape = arrays[0].shape
    flat = [np.ascontiguousarray(array, dtype=np.float64).ravel() for array in arrays]
    out = np.empty((flat[0].size, impact_kernel.IMPACT_SIZE))
    impact_kernel.impact_rows(structure_vector(structure, "two-way"), *flat, out)

    def column(slot: int) -> NDArray[np.float64]:
        return scalar_if_0d(out[:, slot].reshape(shape))

    return Impact(
        delta_rate=column(impact_kernel.IMPACT_DELTA_RATE),
        velocity=column(impact_kernel.IMPACT_VELOCITY),
        gap_rate=column(impact_kernel.IMPACT_GAP_RATE),
        normal_impulse=column(impact_kernel.IMPACT_NORMAL_IMPULSE),
        tangential_impulse=column(impact_kernel.IMPACT_TANGENTIAL_IMPULSE),
        outcome=scalar_if_0d(
            out[:, impact_kernel.IMPACT_OUTCOME].astype(np.int8).reshape(shape)),
    )
