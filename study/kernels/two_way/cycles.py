"""The periodic orbit reached from a state: Newton on the period map, then a search
of the map's iterates for a cycle of up to ``MAX_PERIOD`` drive periods."""

from __future__ import annotations

import numpy as np
from numba import njit

from study.kernels.time_average import (
    CHAOTIC_DETECTION,
    DEFERRED_TRIES,
    DISCARDED_PERIODS,
    S_STATE,
    examine,
    examined,
    looks_chaotic,
    new_irregular,
    out_of_reach,
    record_period,
    settles,
    tangent_growth,
)
from study.kernels.two_way.modes import TWO_PI
from study.kernels.two_way.newton import newton, spectral_radius
from study.kernels.two_way.orbit import (
    A_BACKWARD,
    A_DISPLACEMENT,
    A_EVENTS,
    A_FORWARD,
    A_SLIPS,
    N_ACC,
    RUN_BUDGET,
    RUN_LIFT_OFF,
    RUN_OK,
    RUN_PARADOX,
    PassRecord,
    run,
)
from study.model.codes import (
    CHAOTIC,
    FRICTION_PARADOX,
    LIFT_OFF,
    NOT_CONVERGED,
    QUASI_PERIODIC,
    REASON_AVERAGE_BUDGET,
    REASON_EVENT_BUDGET,
    REASON_NO_PERIODIC_ORBIT,
    REASON_NONE,
    STICK_SLIP,
)

# Period-map iterates closing to this (scaled) start a Newton search for that period.
CYCLE_DETECTION = 1e-3
# The cycle that search finds is the motion's only when it lies within this (scaled)
# distance of the iterate it started from. From an iterate of a chaotic motion that
# nearly closes, Newton's method can converge to a distant stable orbit that the
# iterates never approach (with flight, a big-hop orbit 1.3 natural sizes away from a
# small-hop chaotic motion); a cycle the iterates do approach is found again from a
# later, closer iterate.
CYCLE_REACH = 1e-2
# Periods of the map's iteration before its iterates are watched for lift-off.
BURN_IN = 8
# Longest orbit searched for, in drive periods.
MAX_PERIOD = 16
# Where the second Poincare section lies, in drive periods after phase 0 (1 - 1/golden
# ratio: no simple fraction, so an orbit's events do not sit on both sections).
SECTION_SHIFT = 0.3819660112501051
# An orbit is stable when its largest Floquet multiplier is below 1 + this.
STABILITY_MARGIN = 1e-6
# A fixed point that Newton's method finds from the start is the motion's only once an
# iterate of the map from the start is measurably in its basin: the pass from that
# iterate has the orbit's events, and the map between the iterate and the fixed point is
# linear to within this fraction of the orbit's contraction margin 1 - rho (rho its
# largest multiplier), so that the iterates contract onto it at about the rate rho
# predicts. Measured on the M = 0.99 flight map: 0.1 (not scaled by 1 - rho) accepted an
# orbit with rho = 0.986 that the motion leaves; 0.5 (1 - rho) accepted none such.
VERIFIED_LINEARITY = 0.5
# ... and the iterate must lie within this scaled distance of the fixed point: with
# flight the period map is close to affine over whole regions of one sequence of events,
# which need not reach the fixed point (six points of that map, M = 0.99 near 14.3 Hz
# and 9 m s-2, passed the linearity test from farther away, and the motion settles on
# another orbit; with this bound none of its 15 024 bouncing points does).
VERIFIED_REACH = 1.0
# A cycle of one period that the cycle search finds within this scaled distance of the
# fixed point found from the start is that fixed point, reached by the iterates.
SAME_FIXED_POINT = 1e-6


@njit(cache=True, nogil=True, error_model="numpy")
def contracts_onto(before, after, jac, fixed, radius, scales):
    """Whether the pass of the period map from the iterate ``before`` to ``after``, with
    the Jacobian ``jac`` at ``before``, shows ``before`` in the neighbourhood of the
    stable fixed point ``fixed`` (largest multiplier ``radius``) where the map contracts
    onto it: the linear prediction ``fixed + jac (before - fixed)`` of ``after`` is right
    to :data:`VERIFIED_LINEARITY` ``(1 - radius)`` times the iterate's distance from the
    fixed point (distances scaled by ``scales``, as :func:`state_distance`), which is at
    most :data:`VERIFIED_REACH`. The caller checks that the pass has the orbit's
    events."""
    distance = state_distance(before, fixed, scales)
    if distance == 0.0:
        return True
    if distance > VERIFIED_REACH:
        return False
    worst = 0.0
    for i in range(scales.shape[0]):
        remainder = after[i] - fixed[i]
        for j in range(scales.shape[0]):
            remainder -= jac[i, j] * (before[j] - fixed[j])
        worst = max(worst, abs(remainder) / scales[i])
    return worst <= VERIFIED_LINEARITY * (1.0 - radius) * distance


@njit(cache=True, nogil=True, error_model="numpy")
def state_distance(z, other, scales):
    """The distance of two states in the max-norm scaled by ``scales`` (their natural
    sizes): how far a cycle is from the iterate it was found from, or how near an
    iterate closes on an earlier one."""
    distance = 0.0
    for i in range(scales.shape[0]):
        distance = max(distance, abs(z[i] - other[i]) / scales[i])
    return distance


@njit(cache=True, nogil=True, error_model="numpy")
def _cycle(point, z, periods, section, scales, max_events, record, work):
    """Newton's method for a stable cycle of ``periods`` drive periods from ``z``, the state
    at time ``section`` [s], with the cycle's own (minimal) period (arguments as
    :func:`~study.kernels.two_way.newton.newton`).

    Returns
    -------
    int
        The cycle's minimal period when it is found (``z`` its state at ``section``,
        ``record`` of one pass around it); 0 when not, or when the cycle Newton finds is
        farther than :data:`CYCLE_REACH` from ``z`` (not the one the iterates approach);
        -1 when an iterate near it leaves the table (lift-off).
    """
    guess = z.copy()
    flag, converged = newton(point, z, periods, section, scales, max_events, record, work)
    if flag == RUN_LIFT_OFF:
        return -1
    reach = state_distance(z, guess, scales)
    if (not converged or spectral_radius(record.jac) >= 1.0 + STABILITY_MARGIN
            or reach > CYCLE_REACH):
        return 0
    period = TWO_PI / point.omega
    # Report the orbit's own period, not a multiple that closed first.
    for shorter in range(1, periods):
        if periods % shorter:
            continue
        for i in range(3):
            work[i] = z[i]
        flag = run(point, work, section, section + shorter * period, record, False, -1.0,
                   max_events)
        gap = state_distance(work, z, scales)
        if flag == RUN_OK and gap <= CYCLE_DETECTION * 1e-6:
            flag, converged = newton(point, z, shorter, section, scales, max_events, record,
                                     work)
            if flag == RUN_LIFT_OFF:
                return -1
            if converged:
                return shorter
    # Statistics of the full cycle (the checks above overwrote them).
    flag, converged = newton(point, z, periods, section, scales, max_events, record, work)
    if flag == RUN_LIFT_OFF:
        return -1
    return periods


@njit(cache=True, nogil=True, error_model="numpy")
def find_orbit(point, z, t_start, scales, budget, record, work, history, stats):
    """Periodic orbit reached from state ``z`` at ``t_start`` [s] (in the first period) at
    the drive point ``point``, within ``budget`` (a :data:`~study.kernels.budget.Budget`);
    ``scales`` the natural sizes of the state, ``work`` (3) and ``history``
    (``MAX_PERIOD`` x 3) scratch space. Where no cycle is found the motion is averaged
    as :func:`~study.kernels.two_way.flight_orbit.find_flight_orbit` does, into
    ``stats`` (the ``S_*`` slots of :mod:`study.kernels.time_average`, the last
    iterate's state from ``S_STATE``). A stable fixed point found by Newton's method from
    the start is reported only once the iterates from the start are verified to reach
    it (:func:`contracts_onto` on a pass with the orbit's events, or the cycle search
    finding it again); until then the iterates are followed as without it.

    Returns
    -------
    status, reason, periods, newton_found, radius
        ``periods`` > 0 and ``z`` the orbit's state at phase 0 when found; ``record``
        then belongs to one pass around it. ``CHAOTIC`` or ``QUASI_PERIODIC`` (and
        ``NOT_CONVERGED`` with ``AVERAGE_BUDGET``): ``stats`` holds the averages.
        ``newton_found``: the outcome came from Newton's method from the start, so
        ``z`` is the orbit's fixed point at phase 0 (``STICK_SLIP``) or the iterate
        near the orbit that left the table
        (``LIFT_OFF``): a state to continue the next point of a sweep from. ``radius``
        the largest Floquet multiplier of ``record.jac`` when it was computed (so that
        it is not computed twice), else NaN.
    """
    max_events = budget.max_events
    period = TWO_PI / point.omega
    record.acc[:] = 0.0
    flag = RUN_OK
    if t_start != 0.0:
        flag = run(point, z, t_start, period, record, False, -1.0, max_events)
    if flag == RUN_PARADOX:
        return FRICTION_PARADOX, REASON_NONE, 0, False, np.nan
    if flag == RUN_BUDGET:
        return NOT_CONVERGED, REASON_EVENT_BUDGET, 0, False, np.nan
    guess = z.copy()
    flag, converged = newton(point, z, 1, 0.0, scales, max_events, record, work)
    if flag == RUN_LIFT_OFF:
        return LIFT_OFF, REASON_NONE, 0, True, np.nan
    # A stable fixed point found from the start is reported once an iterate of the map
    # from the start is verified to lie where the map contracts onto it (as
    # flight_orbit.find_flight_orbit does; contracts_onto); meanwhile the cycle search
    # follows the same iterates and reports what they reach instead.
    pending = False
    pending_radius = np.nan
    pending_z = np.empty(3)
    pending_acc = np.empty(record.acc.shape[0])
    pending_jac = np.empty((3, 3))
    if converged:
        radius = spectral_radius(record.jac)
        if radius < 1.0 + STABILITY_MARGIN:
            pending = True
            pending_radius = radius
            pending_z[:] = z
            pending_acc[:] = record.acc
            pending_jac[:, :] = record.jac
    if flag == RUN_PARADOX:
        return FRICTION_PARADOX, REASON_NONE, 0, False, np.nan
    # No stable fixed point near: iterate the map from the start and look for a cycle
    # of up to MAX_PERIOD periods, then solve for it by Newton; where none is found,
    # the motion the iterates follow is averaged (study.kernels.time_average), a
    # tangent vector carried through each period's Jacobian for its exponent.
    for i in range(3):
        z[i] = guess[i]
    tried = np.full(MAX_PERIOD + 1, np.inf)
    candidate = np.empty(3)
    irregular = new_irregular(scales, budget.max_average_periods)
    tolerance = budget.velocity_tolerance * point.a / point.omega
    chaotic = False
    deferred = np.empty((DEFERRED_TRIES, 3))
    deferred_periods = np.zeros(DEFERRED_TRIES, dtype=np.int64)
    waiting = 0
    last = DISCARDED_PERIODS + budget.max_average_periods
    jac = record.jac
    grad = record.grad
    for iteration in range(max(budget.max_map_iterations, last)):
        slot = iteration % MAX_PERIOD
        for i in range(3):
            history[slot, i] = z[i]
            for j in range(3):
                jac[i, j] = 1.0 if i == j else 0.0
                grad[i, j] = 0.0
        recorded = iteration - DISCARDED_PERIODS
        if recorded >= 0:
            record.acc[:] = 0.0
        events_before = record.acc[A_EVENTS]
        # Past a burn-in the iterates trace the attractor: one that leaves the table is
        # outside the model (LIFT_OFF), converged or not.
        flag = run(point, z, 0.0, period, record, True,
                   0.0 if iteration >= BURN_IN else -1.0, max_events)
        if flag == RUN_PARADOX:
            return FRICTION_PARADOX, REASON_NONE, 0, False, np.nan
        if flag == RUN_LIFT_OFF:
            return LIFT_OFF, REASON_NONE, 0, False, np.nan
        if flag != RUN_OK:
            return NOT_CONVERGED, REASON_EVENT_BUDGET, 0, False, np.nan
        if pending and record.acc[A_EVENTS] - events_before == pending_acc[A_EVENTS] and (
                contracts_onto(history[slot], z, jac, pending_z, pending_radius, scales)):
            return _pending_orbit(z, record, pending_z, pending_acc, pending_jac,
                                  pending_radius)
        if iteration < last:
            irregular.growths[iteration] = tangent_growth(jac, scales, irregular)
        if recorded < 0:
            chaotic = chaotic or looks_chaotic(irregular, iteration)
        elif recorded < budget.max_average_periods:
            acc = record.acc
            record_period(irregular, recorded, acc[A_DISPLACEMENT], period, acc[A_SLIPS],
                          acc[A_FORWARD], acc[A_BACKWARD], 0.0, 0.0, 0.0)
            averaged = recorded + 1
            if examined(averaged, budget.max_average_periods):
                within, chaotic, negative, bounded = examine(irregular, averaged, tolerance,
                                                             stats)
                for i in range(3):  # the last iterate, for whatever is reported
                    stats[S_STATE + i] = z[i]
                if settles(averaged, budget.max_average_periods, iteration,
                           budget.max_map_iterations, within, chaotic, negative,
                           bounded):
                    return ((CHAOTIC if chaotic else QUASI_PERIODIC), REASON_NONE, 0, False,
                            np.nan)
                if averaged == budget.max_average_periods or (
                        iteration + 1 >= budget.max_map_iterations and out_of_reach(
                            averaged, budget.max_average_periods, stats, tolerance)):
                    found = _deferred_cycle(point, deferred, deferred_periods, waiting,
                                            scales, max_events, record, work, candidate)
                    waiting = 0
                    if found != 0:
                        return _found(found, z, candidate)
                    return NOT_CONVERGED, REASON_AVERAGE_BUDGET, 0, False, np.nan
        if iteration >= budget.max_map_iterations:
            continue  # the cycle search's budget is spent
        for periods in range(1, min(iteration + 1, MAX_PERIOD) + 1):
            back = (iteration - periods + 1) % MAX_PERIOD
            gap = state_distance(z, history[back], scales)
            if gap < CYCLE_DETECTION and gap < 0.5 * tried[periods]:
                tried[periods] = gap
                for i in range(3):
                    deferred[waiting, i] = history[back, i]
                deferred_periods[waiting] = periods
                waiting += 1
                # On a chaotic motion a near return waits (most would be failing Newton
                # searches) until one is far nearer than the detection's: the iterates
                # converging onto a cycle after a chaotic transient.
                if not chaotic or gap < CHAOTIC_DETECTION or waiting == DEFERRED_TRIES:
                    found = _deferred_cycle(point, deferred, deferred_periods, waiting,
                                            scales, max_events, record, work, candidate)
                    waiting = 0
                    if pending and found == 1 and state_distance(
                            candidate, pending_z, scales) <= SAME_FIXED_POINT:
                        # The iterates closing on the fixed point found from the start:
                        # reached, and reported with the bits Newton gave it there.
                        return _pending_orbit(z, record, pending_z, pending_acc,
                                              pending_jac, pending_radius)
                    if found != 0:
                        return _found(found, z, candidate)
                break
    found = _deferred_cycle(point, deferred, deferred_periods, waiting, scales, max_events,
                            record, work, candidate)
    if found != 0:
        return _found(found, z, candidate)
    return NOT_CONVERGED, REASON_NO_PERIODIC_ORBIT, 0, False, np.nan


@njit(cache=True, nogil=True, error_model="numpy")
def _contact_cycle(point, candidate, periods, scales, max_events, record, work):
    """A stable cycle of ``periods`` drive periods from ``candidate`` at phase 0, sought
    on the phase-0 section and then on a shifted one: its minimal period with
    ``candidate`` its state at phase 0, 0 when not found, -1 when it leaves the table."""
    period = TWO_PI / point.omega
    start = candidate.copy()
    for shifted in range(2):
        for i in range(3):
            candidate[i] = start[i]
        section = 0.0
        if shifted:
            # An orbit can cross phase 0 in a sliver of slip: the phase-0 map then has a
            # kink at the fixed point, which Newton cannot cross (it takes the sliver for
            # an approach to a stick). Another section of the same orbit has no such kink.
            section = SECTION_SHIFT * period
            flag = run(point, candidate, 0.0, section, record, False, -1.0, max_events)
            if flag != RUN_OK:
                return 0
        found = _cycle(point, candidate, periods, section, scales, max_events, record, work)
        if found != 0:
            if found > 0 and section != 0.0:
                # The orbit's state at phase 0, what is reported (the statistics of a
                # whole number of periods do not depend on the section).
                spare = PassRecord(np.zeros(N_ACC), record.jac, record.grad, record.passes)
                run(point, candidate, section, period, spare, False, -1.0, max_events)
            return found
    return 0


@njit(cache=True, nogil=True, error_model="numpy")
def _deferred_cycle(point, deferred, deferred_periods, waiting, scales, max_events, record,
                    work, candidate):
    """Try the ``waiting`` near returns kept in ``deferred`` (states at phase 0) for
    cycles of ``deferred_periods`` periods, in the order they came: the first answer of
    :func:`_contact_cycle` that is not 0 (``candidate`` the cycle's state), else 0."""
    for k in range(waiting):
        for i in range(3):
            candidate[i] = deferred[k, i]
        found = _contact_cycle(point, candidate, deferred_periods[k], scales, max_events,
                               record, work)
        if found != 0:
            return found
    return 0


@njit(cache=True, nogil=True, error_model="numpy")
def _pending_orbit(z, record, pending_z, pending_acc, pending_jac, radius):
    """:func:`find_orbit`'s answer for the fixed point found from the start once
    verified: ``z`` and ``record`` take its state and its pass's statistics and
    Jacobian again (a fixed point of Newton's method from the start: ``newton_found``)."""
    z[:] = pending_z
    record.acc[:] = pending_acc
    record.jac[:, :] = pending_jac
    return STICK_SLIP, REASON_NONE, 1, True, radius


@njit(cache=True, nogil=True, error_model="numpy")
def _found(found, z, candidate):
    """:func:`find_orbit`'s answer for :func:`_deferred_cycle`'s ``found`` (``z``
    takes the cycle's state)."""
    if found < 0:
        return LIFT_OFF, REASON_NONE, 0, False, np.nan
    for i in range(3):
        z[i] = candidate[i]
    return STICK_SLIP, REASON_NONE, found, False, np.nan
