"""Continuation along a sweep: an orbit started from its neighbours' fixed points.

Along a line of a sweep (a column of accelerations at one frequency, or a row of
frequencies at one acceleration) neighbouring drive points have neighbouring orbits.
Newton's method started cold, from rest with the mode on its steady stick response, is
off by ``O(M sin^2 alpha)`` and needs four passes or more over the period map; started
from the neighbours' fixed points (the last one, or the secant through the last two
along the line) it is within the predictor's error and needs one or two.

A continued point must reach the same orbit as the cold start, so the continuation is
only trusted where nothing can have changed on the way: every pass has the sequence of
events (events and slips per period) of the neighbour's orbit, no slip is a sliver,
each residual falls below :data:`CONTRACTION` times the last, and the orbit found is
stable. Otherwise the point is solved cold (:func:`~study.kernels.two_way.cycles.
find_orbit`). Lift-off is decided as the cold start decides it: on a pass whose
state is near the orbit (its residual below :data:`LIFT_VERDICT`, the cold start's
watched iterates being within about ``1e-6`` of theirs); a pass farther away that
leaves the table is followed on as the contact model (:func:`~study.kernels.two_way.
orbit.run` with ``note_lift_off``) for its Newton step. So the contact orbit is
continued through a region that lifts off as well, where the cold start needs its
full Newton search to find the lift-off.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from study.kernels.two_way.modes import TWO_PI
from study.kernels.two_way.newton import LIFT_WATCH, NEWTON_TOLERANCE, solve3
from study.kernels.two_way.orbit import (
    A_BACKWARD,
    A_DISPLACEMENT,
    A_EVENTS,
    A_FORWARD,
    A_LIFTED,
    A_SHORTEST,
    A_SLIPS,
    A_START_SLIVER,
    RUN_LIFT_OFF,
    RUN_OK,
    SLIVER,
    run,
)

# Passes of Newton's method a continued point may take before it is solved cold.
MAX_PASSES = 6
# The first pass's residual (scaled) above which the prediction is not trusted.
FIRST_RESIDUAL = 1e-1
# Each pass's residual must be below this fraction of the last one's.
CONTRACTION = 0.25
# A Newton step this small (scaled) ends a continued search: what is left of the
# fixed point's error is of the order of its square, below the rounding.
STEP_TOLERANCE = 1e-9
# A pass that leaves the table with a residual (scaled) below this decides LIFT_OFF.
LIFT_VERDICT = 1e-6

# Outcomes of a continued search: found, or why the point is solved cold.
CONTINUED_ORBIT = 1
CONTINUED_LIFT_OFF = 2
FAILED_RUN = -1  # a pass ended in the friction paradox or on the event budget
FAILED_SLIVER = -2  # a slip far shorter than the period: a kink of the map is near
FAILED_EVENTS = -3  # the sequence of events changed
FAILED_CONTRACTION = -4  # a residual did not fall below CONTRACTION times the last
FAILED_SINGULAR = -5  # the Newton system is singular
FAILED_PASSES = -6  # not converged within MAX_PASSES passes
FAILED_UNSTABLE = -7  # the orbit found is unstable (set by the caller)

#: How many points before this one a sweep remembers.
DEPTH = 4

#: What a sweep remembers of the last :data:`DEPTH` points along its line (the last
#: one last): ``z`` (DEPTH x 3) their states at phase 0 (a fixed point, or the iterate
#: near the orbit that left the table), ``drive`` (DEPTH x 2) their ``(omega, a)``
#: [rad s-1, m s-2], ``signature`` (DEPTH x 2) the events and slips of a pass around
#: their orbit (-1: unknown), ``count`` (1) how many are held.
Neighbours = namedtuple("Neighbours", ("z", "drive", "signature", "count"))


@njit(cache=True, nogil=True, error_model="numpy")
def new_neighbours():
    """An empty :data:`Neighbours`."""
    return Neighbours(np.zeros((DEPTH, 3)), np.zeros((DEPTH, 2)), np.full((DEPTH, 2), -1.0),
                      np.zeros(1, dtype=np.int64))


@njit(cache=True, nogil=True, error_model="numpy")
def forget(neighbours):
    """Nothing to continue from (a static point, no orbit, a jump to another line)."""
    neighbours.count[0] = 0


@njit(cache=True, nogil=True, error_model="numpy")
def remember(neighbours, omega, a, z, events, slips):
    """Add the point ``(omega, a)`` with its state ``z`` and pass signature."""
    for j in range(DEPTH - 1):
        for i in range(3):
            neighbours.z[j, i] = neighbours.z[j + 1, i]
        for i in range(2):
            neighbours.drive[j, i] = neighbours.drive[j + 1, i]
            neighbours.signature[j, i] = neighbours.signature[j + 1, i]
    last = DEPTH - 1
    for i in range(3):
        neighbours.z[last, i] = z[i]
    neighbours.drive[last, 0] = omega
    neighbours.drive[last, 1] = a
    neighbours.signature[last, 0] = events
    neighbours.signature[last, 1] = slips
    neighbours.count[0] = min(neighbours.count[0] + 1, DEPTH)


@njit(cache=True, nogil=True, error_model="numpy")
def predict(neighbours, omega, a, z):
    """The predicted state ``z`` at phase 0 for ``(omega, a)``: the polynomial through
    the last points (up to :data:`DEPTH`) that lie with this one on one line of the
    sweep (one of ``omega``, ``a`` shared by all) with the last one's signature, else
    the last point's state. False when there is nothing to continue from.

    """
    count = neighbours.count[0]
    last = DEPTH - 1
    events = neighbours.signature[last, 0]
    slips = neighbours.signature[last, 1]
    if count == 0:
        return False
    for i in range(3):
        z[i] = neighbours.z[last, i]
    # The line: the shared coordinate, and the one that varies along it.
    if omega == neighbours.drive[last, 0]:
        shared = 0
    elif a == neighbours.drive[last, 1]:
        shared = 1
    else:
        return True
    x = a if shared == 0 else omega
    used = 1
    for j in range(last - 1, last - count, -1):
        if (neighbours.drive[j, shared] != neighbours.drive[last, shared]
                or neighbours.signature[j, 0] != events
                or neighbours.signature[j, 1] != slips):
            break
        used += 1
    if used < 2:
        return True
    # Lagrange's polynomial through the `used` last points, at x.
    first = DEPTH - used
    for i in range(3):
        z[i] = 0.0
    for j in range(first, DEPTH):
        xj = neighbours.drive[j, 1 - shared]
        weight = 1.0
        for m in range(first, DEPTH):
            if m != j:
                xm = neighbours.drive[m, 1 - shared]
                if xj == xm:
                    weight = np.nan
                weight *= (x - xm) / (xj - xm)
        if not np.isfinite(weight):
            for i in range(3):
                z[i] = neighbours.z[last, i]
            return True
        for i in range(3):
            z[i] += weight * neighbours.z[j, i]
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def continued_newton(point, z, scales, max_events, record, work, scratch):
    """Newton's method on the period map from the predicted state ``z`` (updated in
    place) at phase 0, every pass watched for lift-off and required to have the events
    and slips of the first; ``scratch`` (2 x 3) holds Newton's step and residual;
    arguments otherwise as :func:`~study.kernels.two_way.newton.newton`.

    A pass that leaves the table is followed to its end as the contact model, for its
    residual and Newton step, unless the step before it was one the cold start would
    watch (residual and step below ``LIFT_WATCH`` with the same events): then, as there,
    the lift-off decides at once.

    Returns
    -------
    outcome, events, slips
        :data:`CONTINUED_ORBIT` (``z`` the fixed point; ``record`` holds the last pass
        around it, its statistics moved to the fixed point along their gradients),
        :data:`CONTINUED_LIFT_OFF` (``z`` the iterate near the orbit) or why the point
        must be solved cold (one of the negative ``FAILED_*`` codes); the events and
        slips of the orbit's pass.
    """
    acc = record.acc
    jac = record.jac
    grad = record.grad
    span = TWO_PI / point.omega
    previous = FIRST_RESIDUAL / CONTRACTION
    step = scratch[0]
    residual = scratch[1]
    events = -1.0
    slips = -1.0
    watched = False
    for _ in range(MAX_PASSES):
        for i in range(3):
            work[i] = z[i]
            for jj in range(3):
                jac[i, jj] = 1.0 if i == jj else 0.0
                grad[i, jj] = 0.0
        acc[:] = 0.0
        flag = run(point, work, 0.0, span, record, True, 0.0, max_events, not watched)
        if flag == RUN_LIFT_OFF:
            return CONTINUED_LIFT_OFF, events, slips
        if flag != RUN_OK:
            return FAILED_RUN, events, slips
        if acc[A_START_SLIVER] != 0.0 or 0.0 < acc[A_SHORTEST] < SLIVER * span:
            # A kink of the map is near (see newton): the cold start's business.
            return FAILED_SLIVER, events, slips
        if events >= 0.0 and (acc[A_EVENTS] != events or acc[A_SLIPS] != slips):
            return FAILED_EVENTS, events, slips
        events = acc[A_EVENTS]
        slips = acc[A_SLIPS]
        res = 0.0
        for i in range(3):
            residual[i] = z[i] - work[i]
            res = max(res, abs(residual[i]) / scales[i])
        if not res < CONTRACTION * previous:
            return FAILED_CONTRACTION, events, slips
        for i in range(3):
            jac[i, i] -= 1.0
        solved = solve3(jac, residual, step)
        for i in range(3):
            jac[i, i] += 1.0
        if not solved:
            return FAILED_SINGULAR, events, slips
        size = 0.0
        for i in range(3):
            size = max(size, abs(step[i]) / scales[i])
            z[i] += step[i]
        lifted = acc[A_LIFTED] != 0.0
        if lifted and res <= LIFT_VERDICT:
            return CONTINUED_LIFT_OFF, events, slips
        if not lifted and (size <= STEP_TOLERANCE or res <= NEWTON_TOLERANCE):
            for i in range(3):
                acc[A_DISPLACEMENT] += grad[0, i] * step[i]
                acc[A_FORWARD] += grad[1, i] * step[i]
                acc[A_BACKWARD] += grad[2, i] * step[i]
            return CONTINUED_ORBIT, events, slips
        watched = lifted and size <= LIFT_WATCH and res <= LIFT_WATCH
        previous = res
    return FAILED_PASSES, events, slips
