"""The paper's structure and its named drive points, in one place.

Barois, Boucherie, Tadrist & Kellay give one structure: f0 = 14.44 Hz, Q = 17.5,
alpha = 64 degree, M = 0.08 (the unloaded structure), a single friction coefficient
cs = ck = 0.25, g = 9.8 m s-2; and the drive points of Fig. 2's insets in its regions
S, P, N and PN. Figures draw those points, and the paper's statements, only for a file
whose structure is the paper's (:func:`is_paper_structure`): each parameter equal to
the paper's value to the digits the paper states it with (within half a unit of the
last stated digit: f0 within 0.005 Hz, Q within 0.05, alpha within 0.5 degree, M and
cs within 0.005), ``ck = cs`` and ``g = 9.8``. A structure of its own (f0 = 22 Hz,
Q = 30, say) is not the paper's, and no paper point is drawn on it.

Nothing here computes; the computing modules do not import it.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from study.model.parameters import STRUCTURE
from study.model.structure import Structure

__all__ = [
    "PAPER_POINTS",
    "PAPER_STRUCTURE",
    "PAPER_TOLERANCE",
    "is_paper_structure",
    "paper_structure",
]

#: The paper's structure: parameter -> value (SI, alpha in degrees); ck = cs, g = 9.8
#: (:attr:`study.model.parameters.Parameter.paper`).
PAPER_STRUCTURE: dict[str, float] = {
    name: p.paper_value for name, p in STRUCTURE.items() if p.paper_value is not None
}

#: How far a parameter may be from the paper's and still be the paper's: half a unit
#: of the last digit the paper states (``ck`` is compared with ``cs``, to a relative
#: 1e-9: the paper has a single coefficient).
PAPER_TOLERANCE: dict[str, float] = {
    name: p.paper_tolerance for name, p in STRUCTURE.items() if p.paper_tolerance is not None
}

#: The paper's points in its regions S, P, N and PN (Fig. 2 insets): name -> (f [Hz],
#: a [m s-2]).
PAPER_POINTS: dict[str, tuple[float, float]] = {
    "S": (13.0, 5.0),
    "P": (13.0, 8.5),
    "N": (16.5, 8.5),
    "PN": (14.6, 7.0),
}


def paper_structure(**changes: float) -> Structure:
    """The paper's structure, with optional changes (``paper_structure(M=0.066)``)."""
    return Structure(**{**PAPER_STRUCTURE, **changes})


def is_paper_structure(structure: Structure | Mapping[str, float],
                       ignore: Iterable[str] = ()) -> bool:
    """Whether a structure is the paper's to the digits the paper states.

    Parameters
    ----------
    structure : Structure or mapping
        The structure (a mapping may omit ``ck``, meaning ``ck = cs``, and ``g``).
    ignore : iterable of str
        Parameters not compared (``("M",)`` for a study of the paper's structure under
        on-board loads, whose ``M`` is swept).
    """
    params = structure.as_dict() if isinstance(structure, Structure) else dict(structure)
    params.setdefault("g", STRUCTURE["g"].default)
    if "cs" in params:
        params.setdefault("ck", params["cs"])
    skip = set(ignore)
    for name, value in PAPER_STRUCTURE.items():
        if name in skip:
            continue
        if name not in params or abs(float(params[name]) - value) > PAPER_TOLERANCE[name]:
            return False
    if "ck" not in skip and "cs" in params:
        cs, ck = float(params["cs"]), float(params["ck"])
        if abs(ck - cs) > 1e-9 * abs(cs):
            return False
    return True
