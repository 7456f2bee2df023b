"""What the kernels read of a structure, computed once and kept: the one-way kernel's
force constants and friction levels, the structure vector, the lift-off decision."""

from __future__ import annotations

import dataclasses
import functools
import operator
import struct
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from study.kernels import one_way as one_way_kernel
from study.kernels import one_way_velocity as velocity_kernel
from study.model import (
    lift_off_acceleration,
)
from study.model.contact import (
    DEFAULT_LIFT_OFF,
)
from study.model.structure import Structure
from study.solvers.packing import structure_entries, with_laws
from study.solvers.settings import check_coupling

__all__ = [
    "STRUCTURES_KEPT",
    "Kept",
    "force_constants",
    "friction_levels",
    "kept_constants",
    "past_lift_off",
    "structure_vector",
]


#: Structures whose kernel constants are kept between calls, each a few hundred bytes:
#: a fit or a design evaluates a few structures in turn, a bisection one.
STRUCTURES_KEPT = 32

# A structure's parameters in declaration order, packed as float64 bytes.
_PARAMETERS = operator.attrgetter(*(field.name for field in dataclasses.fields(Structure)))
_PACKED = struct.Struct(f"<{len(dataclasses.fields(Structure))}d")


class Kept(NamedTuple):
    """What the kernels read of one structure, computed once and kept."""

    #: The fields of :data:`~study.kernels.one_way_velocity.ForceConstants` (plain tuples are
    #: what the small-call kernels take).
    force: tuple[float, ...]
    #: The fields of :data:`~study.kernels.one_way.FrictionLevels`.
    levels: tuple[float, ...]
    #: The structure vector but its coupling and lift-off entries (0); read-only.
    vector: NDArray[np.float64]


# The structure of the last call and what is kept of it, as one tuple (replaced whole,
# so that a thread never reads one structure's constants with another's): a loop over
# the points of one structure finds them by identity, without hashing.
_LAST_KEPT: list[tuple[Structure | None, Kept | None]] = [(None, None)]


def kept_constants(structure: Structure) -> Kept:
    """The kernels' constants of ``structure``: those of the last call's structure if it
    is the same object (a frozen Structure never changes), else those kept for its
    parameters bit for bit (:data:`STRUCTURES_KEPT`)."""
    last, kept = _LAST_KEPT[0]
    if last is not structure or kept is None:
        kept = _kept_by_value(structure, _PACKED.pack(*_PARAMETERS(structure)))
        _LAST_KEPT[0] = (structure, kept)
    return kept


@functools.lru_cache(maxsize=STRUCTURES_KEPT)
def _kept_by_value(structure: Structure, exact: bytes) -> Kept:
    """:func:`kept_constants`, computed once per key. ``exact`` is the parameters' bytes: equal
    structures may differ in the sign of a zero (``alpha=-0.0 == 0.0``, and they hash
    alike), which the constants keep (``np.sin(-0.0)`` is -0.0)."""
    vector = structure_entries(structure)
    vector.flags.writeable = False
    return Kept(tuple(force_constants(structure)), tuple(friction_levels(structure)),
                 vector)


def structure_vector(structure: Structure, coupling: str,
                     flight: bool = False) -> NDArray[np.float64]:
    """The orbit kernel's structure vector (SI) for ``structure``, ``coupling`` and the
    lift-off law (``flight``: 1, else 0, stop with LIFT_OFF): a new array each call,
    from the entries kept for the structure (a writable copy: numba would compile a
    kernel again for a read-only array)."""
    return with_laws(kept_constants(structure).vector.copy(),
                     two_way=check_coupling(coupling) == "two-way",
                     lift_off="flight" if flight else DEFAULT_LIFT_OFF)


def force_constants(structure: Structure) -> Any:
    """The one-way kernel's :data:`~study.kernels.one_way_velocity.ForceConstants`."""
    return velocity_kernel.ForceConstants(
        float(structure.omega0), 1.0 / structure.Q, float(structure.M),
        float(np.cos(structure.alpha_rad)), float(np.sin(structure.alpha_rad)),
        float(structure.cs), float(structure.ck), float(structure.g),
    )


def past_lift_off(
    structure: Structure, f_flat: NDArray[np.float64], a_flat: NDArray[np.float64],
) -> NDArray[np.bool_]:
    """``a > lift_off_acceleration(structure, f)`` on flat arrays: decided by the kernel
    (the same operations, without numpy's temporaries, which cost a small call more
    than its solve), and by numpy where it is within 1e-13 of the threshold."""
    constants = kept_constants(structure).force
    lifted = np.empty(f_flat.size, dtype=np.bool_)
    if velocity_kernel.lift_off_small(f_flat, a_flat, constants, lifted):
        decisions = np.empty(f_flat.size, dtype=np.int8)
        velocity_kernel.lift_off_decisions(f_flat, a_flat,
                                           velocity_kernel.ForceConstants(*constants), decisions)
        undecided = np.flatnonzero(decisions == velocity_kernel.LIFT_UNDECIDED)
        lifted[undecided] = a_flat[undecided] > lift_off_acceleration(structure,
                                                                      f_flat[undecided])
    return lifted


def friction_levels(structure: Structure) -> Any:
    """The one-way kernel's :data:`~study.kernels.one_way.FrictionLevels`."""
    return one_way_kernel.FrictionLevels(structure.cs * structure.g,
                                         structure.ck * structure.g)
