"""Unit strings, declared once, in their CF/UDUNITS spelling.

Every ``units`` attribute that ``study`` writes, and every unit that a parameter,
column or variable declares, is one of these (a test checks the package for others):
``degree``, never ``deg``; ``m s-1``, never ``m/s``; ``1`` for a dimensionless value,
and only as an attribute: a message leaves it out (:func:`spoken`). SI units inside,
angles in degree at every interface.
"""

from __future__ import annotations

__all__ = [
    "DEGREE",
    "DEGREE_PER_SECOND",
    "DIMENSIONLESS",
    "HERTZ",
    "KILOGRAM",
    "METRE",
    "METRE_PER_SECOND",
    "METRE_PER_SECOND_SQUARED",
    "RADIAN",
    "SECOND",
    "UNITS",
    "spoken",
]

HERTZ = "Hz"
SECOND = "s"
METRE = "m"
METRE_PER_SECOND = "m s-1"
METRE_PER_SECOND_SQUARED = "m s-2"
KILOGRAM = "kg"
DEGREE = "degree"
DEGREE_PER_SECOND = "degree s-1"
#: The argument of a complex number (a Floquet multiplier's).
RADIAN = "rad"
#: A ratio, a count, a coefficient, a flag (CF's ``1``).
DIMENSIONLESS = "1"

#: Every unit string the package writes or declares.
UNITS = frozenset({HERTZ, SECOND, METRE, METRE_PER_SECOND, METRE_PER_SECOND_SQUARED,
                   KILOGRAM, DEGREE, DEGREE_PER_SECOND, RADIAN, DIMENSIONLESS})


def spoken(units: str) -> str:
    """``units`` as it follows a number in a message: ``" Hz"``; ``""`` when dimensionless.

    Parameters
    ----------
    units : str
        One of :data:`UNITS`.

    Returns
    -------
    str
        A space and the units, or nothing for :data:`DIMENSIONLESS`.
    """
    return "" if units == DIMENSIONLESS else f" {units}"
