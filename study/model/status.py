"""Status codes stored with every solved point (a CF flag variable on disk).

The values are :mod:`study.model.codes`' (the kernels return them as plain integers).
"""

from __future__ import annotations

from enum import IntEnum

from study.model import codes

__all__ = ["INVALID_STATUSES", "NonConvergence", "Status"]


class Status(IntEnum):
    """Outcome of the steady-state solver at one drive point.

    Attributes
    ----------
    STATIC
        Below both motion thresholds: the structure never slips, ``v = 0`` exactly.
    STICK_SLIP
        Periodic orbit with at least one stick phase in every period.
    CONTINUOUS_SLIDING
        Periodic orbit without any stick: slips reverse at ``v = 0`` (seen as ``M -> 1``).
    LIFT_OFF
        ``n(t) < 0`` during the cycle: the structure leaves the table, the model does
        not apply and no velocity is given (NaN).
    NOT_CONVERGED
        No periodic orbit was found within the solver's budget; the reason is in
        :class:`NonConvergence`. No velocity is given (NaN).
    FRICTION_PARADOX
        Two-way coupling only: a slip's equations have no unique solution (Painleve's
        paradox, ``1 - M sin(alpha) (sin(alpha) + s ck cos(alpha)) <= 0``), as can happen
        for ``M`` close to 1 at steep tilt. Outside the model; no velocity (NaN).
    BOUNCING
        With flight only: a periodic orbit that leaves the table and lands again in every
        period (flight phases and impacts); its mean velocity is given.
    """

    STATIC = codes.STATIC
    STICK_SLIP = codes.STICK_SLIP
    CONTINUOUS_SLIDING = codes.CONTINUOUS_SLIDING
    LIFT_OFF = codes.LIFT_OFF
    NOT_CONVERGED = codes.NOT_CONVERGED
    FRICTION_PARADOX = codes.FRICTION_PARADOX
    BOUNCING = codes.BOUNCING


class NonConvergence(IntEnum):
    """Why a point has status ``NOT_CONVERGED`` (``NONE`` for every other status).

    Attributes
    ----------
    NONE
        The point converged (or did not need to).
    NO_PERIODIC_ORBIT
        The continuous-sliding circle map did not lock onto a stable periodic orbit
        within the budget of map iterations (quasi-periodic, chaotic, or too slowly
        attracting for the budget).
    EVENT_BUDGET
        The event loop exhausted its budget without closing an orbit.
    """

    NONE = codes.REASON_NONE
    NO_PERIODIC_ORBIT = codes.REASON_NO_PERIODIC_ORBIT
    EVENT_BUDGET = codes.REASON_EVENT_BUDGET


#: Statuses outside the model's validity or without a solution: no velocity (NaN).
INVALID_STATUSES = (Status.LIFT_OFF, Status.NOT_CONVERGED, Status.FRICTION_PARADOX)
