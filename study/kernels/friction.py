"""Friction laws in the kernels' form: one function, one branch per declared law.

The laws, their codes and their parameters are declared in
:mod:`study.model.contact`; a law's parameters sit in the structure vector under their
declared names (:mod:`study.kernels.structure_vector`). Coulomb friction needs none
and is what every other law reduces to in its limit.
"""

from __future__ import annotations

import math

from numba import njit

from study.kernels.structure_vector import FRICTION_LAW, KINETIC_FRICTION, STATIC_FRICTION, index
from study.model.contact import LAWS

# Numba reads module-level integers as compile-time constants.
STRIBECK = LAWS["friction"]["stribeck"].code
STRIBECK_SPEED = index("stribeck_speed")


@njit(cache=True, nogil=True, inline="always")
def kinetic_coefficient(p, state, speed):
    """Kinetic friction coefficient [1] of a slip under the law ``p[FRICTION_LAW]``;
    ``state[speed]`` is the slip speed [m s-1].

    Coulomb: ``ck``. Stribeck: ``ck + (cs - ck) exp(-|v| / v_s)``, which falls from
    ``cs`` at rest to ``ck`` (the exponential of Armstrong-Helouvry's curve with
    exponent 1: one parameter, the slope at rest finite, ``ck = cs`` Coulomb exactly).

    The state is read only by the laws that need it: reading the speed in the Coulomb
    case made every step of the integrator about 15% slower (measured), while the
    branch on the law costs nothing measurable.
    """
    if p[FRICTION_LAW] == STRIBECK:
        excess = p[STATIC_FRICTION] - p[KINETIC_FRICTION]
        return p[KINETIC_FRICTION] + excess * math.exp(-abs(state[speed]) / p[STRIBECK_SPEED])
    return p[KINETIC_FRICTION]
