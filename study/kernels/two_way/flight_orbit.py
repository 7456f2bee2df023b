"""The periodic orbit with flight: Newton on the period map of the 5-state, then a
search of the map's iterates for a cycle of up to ``MAX_PERIOD`` drive periods, and
one drive point's output row.

The same method as :mod:`~study.kernels.two_way.newton` and
:mod:`~study.kernels.two_way.cycles` on the state ``(delta, delta', v, h, h')`` with
the run of :mod:`~study.kernels.two_way.flight`: Newton's method on ``P^N(z) - z`` with
the exact Jacobian (flows, contact saltations, the identity at take-off and the
impacts' saltation matrices), stopped on a pass whose residual is at the map's
rounding floor, so that the statistics (mean velocity, airborne fraction, largest hop,
impacts) are those of a pass around the fixed point itself.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from study.kernels.eigenvalues import spectral_radius
from study.kernels.structure_vector import GRAVITY, STIFFNESS
from study.kernels.time_average import (
    CHAOTIC_DETECTION,
    DEFERRED_TRIES,
    DISCARDED_PERIODS,
    S_AIRBORNE,
    S_BACKWARD,
    S_EXPONENT,
    S_EXPONENT_ERROR,
    S_FORWARD,
    S_HOP,
    S_IMPACTS,
    S_PERIODS,
    S_SLIPS,
    S_STATE,
    S_VELOCITY,
    S_VELOCITY_ERROR,
    examine,
    examined,
    looks_chaotic,
    new_irregular,
    out_of_reach,
    record_period,
    settles,
    tangent_growth,
)
from study.kernels.two_way.cycles import (
    CYCLE_DETECTION,
    CYCLE_REACH,
    MAX_PERIOD,
    SAME_FIXED_POINT,
    contracts_onto,
    state_distance,
)
from study.kernels.two_way.flight import (
    A_AIRBORNE,
    A_EVENT_COUNT,
    A_FIRST_EVENT,
    A_HOP,
    A_IMPACTS,
    A_LAST_EVENT,
    A_QUIET_GAP,
    A_QUIET_MID,
    N_FLIGHT_ACC,
    N_STATE,
    Z_GAP,
    Z_GAP_RATE,
    FlightRecord,
    fly,
)
from study.kernels.two_way.modes import M_PIM, M_PRE, TWO_PI, DrivePoint
from study.kernels.two_way.orbit import (
    A_BACKWARD,
    A_DISPLACEMENT,
    A_EVENTS,
    A_FORWARD,
    A_SHORTEST,
    A_SLIPS,
    A_START_SLIVER,
    A_STICK,
    RUN_OK,
    RUN_PARADOX,
    SLIVER,
)
from study.model.codes import (
    BOUNCING,
    CHAOTIC,
    CONTINUOUS_SLIDING,
    FRICTION_PARADOX,
    NOT_CONVERGED,
    QUASI_PERIODIC,
    REASON_AVERAGE_BUDGET,
    REASON_EVENT_BUDGET,
    REASON_NO_PERIODIC_ORBIT,
    REASON_NONE,
    STATIC,
    STICK_SLIP,
)

# Newton iterations on the period map before falling back to the map's iteration.
MAX_NEWTON = 30
# Newton iterations for a cycle that the map's iterates close on (to CYCLE_DETECTION):
# from so near, the 475 cycles found on the M = 0.99 flight map took at most 13, while
# the attempts that fail (on chaotic motions, mostly) ran to MAX_NEWTON, with passes
# of up to MAX_PERIOD periods: half the time of a chaotic point. (On every flight
# workflow one cycle took more; it is found from a later iterate, 80 ulps of a/w off.)
MAX_CYCLE_NEWTON = 15
# A pass is at the fixed point when its scaled residual is below this, or below
# LOOSE_TOLERANCE after a step below NEWTON_STEP with the same events as the pass
# before (the rounding floor of the map).
NEWTON_TOLERANCE = 1e-12
LOOSE_TOLERANCE = 1e-9
NEWTON_STEP = 1e-7
# A Newton pass after a step below this (scaled) also seeks the largest gap: it is
# likely the last one, whose gap the orbit reports (else a pass of its own after it).
HOP_STEP = 1e-6
# An orbit is stable when its largest Floquet multiplier is below 1 + this.
STABILITY_MARGIN = 1e-6
# Periods of the map followed from the start before Newton's method: the first take-off
# from rest is often a large hop that the orbit does not repeat, and a section chosen
# on it lies where the orbit has an event.
FIRST_PERIODS = 2

#: An irregular motion's largest hop is the largest over every this-many-th averaged
#: period (at least 16 of them: 256 periods are averaged at least).
HOP_STRIDE = 16
#: Length of :func:`find_flight_orbit`'s ``stats``: the averages' slots
#: (:mod:`study.kernels.time_average`'s ``S_*``) and the last iterate's state.
N_STATS = S_STATE + N_STATE


@njit(cache=True, nogil=True, error_model="numpy")
def flight_scales(point):
    """Natural sizes of ``(delta, delta', v, h, h')`` [m, m s-1, m s-1, m, m s-1]."""
    table = point.table
    omega = point.omega
    a = point.a
    amp = math.hypot(table[0, M_PRE], table[0, M_PIM])
    k = point.structure[STIFFNESS]
    size = max(amp, a / (k + omega * omega), 1e-300)
    lift = (point.structure[GRAVITY] + a) / omega
    scales = np.empty(N_STATE)
    scales[0] = size
    scales[1] = size * max(omega, math.sqrt(k))
    scales[2] = max(a / omega, 1e-300)
    scales[3] = lift / omega
    scales[4] = lift
    return scales


@njit(cache=True, nogil=True, error_model="numpy")
def solve_linear(m, r, out):
    """Solve ``m x = r`` (n x n, partial pivoting) into ``out``; False when singular."""
    n = r.shape[0]
    a = m.copy()
    b = r.copy()
    for col in range(n):
        piv = col
        for i in range(col + 1, n):
            if abs(a[i, col]) > abs(a[piv, col]):
                piv = i
        if a[piv, col] == 0.0 or not math.isfinite(a[piv, col]):
            return False
        if piv != col:
            for jj in range(n):
                a[col, jj], a[piv, jj] = a[piv, jj], a[col, jj]
            b[col], b[piv] = b[piv], b[col]
        for i in range(col + 1, n):
            f = a[i, col] / a[col, col]
            for jj in range(col, n):
                a[i, jj] -= f * a[col, jj]
            b[i] -= f * b[col]
    for i in range(n - 1, -1, -1):
        x = b[i]
        for jj in range(i + 1, n):
            x -= a[i, jj] * out[jj]
        out[i] = x / a[i, i]
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _pass(point, z, work, section, span, record, want_jac, want_hop, max_events):
    """One run from ``z`` (copied to ``work``) over ``span`` [s] from ``section``."""
    acc = record.acc
    jac = record.jac
    for i in range(N_STATE):
        work[i] = z[i]
        for jj in range(N_STATE):
            jac[i, jj] = 1.0 if i == jj else 0.0
    acc[:] = 0.0
    record.passes[0 if want_jac else 1] += 1.0
    return fly(point, work, section, section + span, record, want_jac, want_hop, max_events)


@njit(cache=True, nogil=True, error_model="numpy")
def flight_newton(point, z, periods, section, scales, max_events, record, work,
                  max_passes):
    """Newton's method on ``P^periods(z) - z`` for the 5-state ``z`` (updated in place) on
    the section at ``section`` [s], at most ``max_passes`` passes (arguments otherwise as
    :func:`~study.kernels.two_way.newton.newton`).

    Returns
    -------
    flag, converged
        The last run's flag and whether ``z`` is the fixed point; ``record`` then holds
        the pass around it: the Jacobian of ``P^periods`` and the statistics, with the
        largest gap.
    """
    acc = record.acc
    jac = record.jac
    span = periods * TWO_PI / point.omega
    previous = np.inf
    last_events = -1.0
    last_slips = -1.0
    last_impacts = -1.0
    small_step = False
    step = np.empty(N_STATE)
    residual = np.empty(N_STATE)
    # This pass also seeks the largest gap: the last step was small enough that it is
    # likely the last pass (the gap of a run does not depend on its Jacobian).
    with_hop = False
    for _ in range(max_passes):
        flag = _pass(point, z, work, section, span, record, True, with_hop, max_events)
        if flag != RUN_OK:
            return flag, False
        res = 0.0
        for i in range(N_STATE):
            residual[i] = z[i] - work[i]
            res = max(res, abs(residual[i]) / scales[i])
        sliver = 0.0 < acc[A_SHORTEST] < SLIVER * span
        same_events = (acc[A_EVENTS] == last_events and acc[A_SLIPS] == last_slips
                       and acc[A_IMPACTS] == last_impacts and not sliver)
        if res <= NEWTON_TOLERANCE or (small_step and same_events
                                       and res <= LOOSE_TOLERANCE):
            if not with_hop:
                # The largest gap of this pass, by a pass of its own (the closed form's
                # maxima cost more than the pass): the same run from the same z.
                spare = FlightRecord(np.zeros(N_FLIGHT_ACC), np.eye(N_STATE),
                                     np.empty((N_STATE, N_STATE)),
                                     np.empty((N_STATE, N_STATE)), record.passes)
                _pass(point, z, work, section, span, spare, False, True, max_events)
                acc[A_HOP] = spare.acc[A_HOP]
            return RUN_OK, True
        with_hop = False
        last_events = acc[A_EVENTS]
        last_slips = acc[A_SLIPS]
        last_impacts = acc[A_IMPACTS]
        if res > previous:
            # Diverging (an event appeared or vanished): take the map's step instead.
            for i in range(N_STATE):
                z[i] = work[i]
            previous = np.inf
            small_step = False
            last_events = -1.0
            continue
        for i in range(N_STATE):
            jac[i, i] -= 1.0
        solved = solve_linear(jac, residual, step)
        for i in range(N_STATE):
            jac[i, i] += 1.0
        if not solved:
            for i in range(N_STATE):
                z[i] = work[i]
            small_step = False
            last_events = -1.0
            continue
        size = 0.0
        for i in range(N_STATE):
            size = max(size, abs(step[i]) / scales[i])
        if z[Z_GAP] + step[Z_GAP] < 0.0:
            # Below the table: no state of the model; the map's step instead.
            for i in range(N_STATE):
                z[i] = work[i]
            previous = np.inf
            small_step = False
            last_events = -1.0
            continue
        for i in range(N_STATE):
            z[i] += step[i]
        if acc[A_START_SLIVER] != 0.0:
            # The orbit sticks across the section (see newton): stick.
            z[2] = 0.0
        small_step = size <= NEWTON_STEP
        with_hop = size <= HOP_STEP
        previous = res
    return RUN_OK, False


@njit(cache=True, nogil=True, error_model="numpy")
def quiet_section(acc, t_begin, t_stop):
    """The middle [s] of the longest stretch without events of the pass from ``t_begin``
    to ``t_stop`` [s] whose event times ``acc`` holds (the stretch across the ends joined,
    the pass being a period of the map), in ``[t_begin, t_stop)``; ``t_begin`` when the
    pass had no event."""
    if acc[A_EVENT_COUNT] == 0.0:
        return t_begin
    span = t_stop - t_begin
    best = acc[A_QUIET_GAP]
    middle = acc[A_QUIET_MID]
    wrap = (acc[A_FIRST_EVENT] - t_begin) + (t_stop - acc[A_LAST_EVENT])
    if wrap > best or acc[A_EVENT_COUNT] == 1.0:
        middle = acc[A_LAST_EVENT] + 0.5 * wrap
        if middle >= t_stop:
            middle -= span
    return min(max(middle, t_begin), t_stop)


@njit(cache=True, nogil=True, error_model="numpy")
def _quiet_newton(point, z, periods, scales, max_events, record, work, max_passes):
    """Newton's method for an orbit of ``periods`` drive periods from ``z``, the state at
    phase 0 (updated in place to the orbit's state at phase 0), on a section in the
    middle of the longest stretch without events of a first pass, in at most
    ``max_passes`` Newton passes: a section at an event (a take-off just at phase 0,
    say) puts a kink of the period map at its fixed point.

    Returns
    -------
    flag, converged
        As :func:`flight_newton`; ``record`` then holds a pass around the orbit from the
        section (its Jacobian and statistics).
    """
    span = periods * TWO_PI / point.omega
    flag = _pass(point, z, work, 0.0, span, record, False, False, max_events)
    if flag != RUN_OK:
        return flag, False
    section = quiet_section(record.acc, 0.0, span)
    spare = FlightRecord(np.zeros(N_FLIGHT_ACC), np.empty((N_STATE, N_STATE)),
                         np.empty((N_STATE, N_STATE)), np.empty((N_STATE, N_STATE)),
                         np.zeros(2))
    # From the pass's end (phase 0 again) to the section.
    for i in range(N_STATE):
        z[i] = work[i]
    if section > 0.0:
        flag = fly(point, z, 0.0, section, spare, False, False, max_events)
        if flag != RUN_OK:
            return flag, False
    flag, converged = flight_newton(point, z, periods, section, scales, max_events, record,
                                    work, max_passes)
    if not converged:
        return flag, False
    # The orbit's state at phase 0 (the end of its period from the section).
    if section > 0.0:
        spare.acc[:] = 0.0
        fly(point, z, section, span, spare, False, False, max_events)
    return flag, True


@njit(cache=True, nogil=True, error_model="numpy")
def _flight_cycle(point, z, periods, scales, max_events, record, work):
    """A stable cycle of ``periods`` drive periods from ``z`` at phase 0 (as
    :func:`~study.kernels.two_way.cycles`'s): its minimal period, 0 when not found or
    farther than :data:`~study.kernels.two_way.cycles.CYCLE_REACH` from ``z``, -1 on
    the paradox."""
    guess = z.copy()
    flag, converged = _quiet_newton(point, z, periods, scales, max_events, record, work,
                                    MAX_CYCLE_NEWTON)
    if flag == RUN_PARADOX:
        return -1
    reach = state_distance(z, guess, scales)
    if (not converged or spectral_radius(record.jac) >= 1.0 + STABILITY_MARGIN
            or reach > CYCLE_REACH):
        for i in range(N_STATE):
            z[i] = guess[i]
        return 0
    period = TWO_PI / point.omega
    for shorter in range(1, periods):
        if periods % shorter:
            continue
        flag = _pass(point, z, work, 0.0, shorter * period, record, False, False,
                     max_events)
        gap = state_distance(work, z, scales)
        if flag == RUN_OK and gap <= CYCLE_DETECTION * 1e-6:
            flag, converged = _quiet_newton(point, z, shorter, scales, max_events, record,
                                            work, MAX_CYCLE_NEWTON)
            if converged:
                return shorter
    flag, converged = _quiet_newton(point, z, periods, scales, max_events, record, work,
                                    MAX_CYCLE_NEWTON)
    return periods if converged else 0


@njit(cache=True, nogil=True, error_model="numpy")
def find_flight_orbit(point, z, t_start, scales, budget, record, work, history, stats):
    """Periodic orbit with flight reached from the 5-state ``z`` at ``t_start`` [s] (in
    the first period), as :func:`~study.kernels.two_way.cycles.find_orbit`: Newton's
    method from the state two periods later, then the map's iterates from that state,
    searched for a cycle of up to ``MAX_PERIOD`` periods; where none is found, the time
    averages of the motion the iterates follow (:mod:`study.kernels.time_average`).

    A stable fixed point found by Newton's method is reported only once verified
    reached: an iterate's pass has the orbit's events and shows the map contracting
    onto it (:func:`~study.kernels.two_way.cycles.contracts_onto`), or the cycle search
    finds it again from a near return of the iterates. Until then the iterates are
    followed as without it, and what they reach (another cycle, an irregular motion)
    is reported instead.

    After :data:`DISCARDED_PERIODS` iterates each period's velocity and the log-growth
    of a tangent vector carried through the map's Jacobian are recorded. Every
    :data:`AVERAGE_CHECK` periods (at least :data:`MIN_AVERAGED` recorded) the
    averages are examined: once the exponent is clearly positive no more cycles are
    tried (the motion is chaotic); once the velocity's 95 % half-width is within
    ``budget.velocity_tolerance * a / omega`` the motion is reported as its exponent
    says (:func:`~study.kernels.time_average.settles`): chaotic (clearly positive) or
    quasi-periodic (clearly below a small bound), an ambiguous exponent averaged on;
    with an exponent clearly negative the cycle search goes on to
    ``budget.max_map_iterations`` (a stable cycle the iterates approach). After
    ``budget.max_average_periods`` recorded periods the point is not converged
    (``AVERAGE_BUDGET``), its averages kept, unless its mean is within the tolerance.

    Returns
    -------
    status, reason, periods, radius
        ``periods`` > 0 and ``z`` the orbit's state at phase 0 when found (``record``
        then belongs to one pass around it); status STICK_SLIP for any orbit found (the
        caller names it from its statistics), CHAOTIC or QUASI_PERIODIC (``stats``
        filled, see ``S_*``), FRICTION_PARADOX or NOT_CONVERGED (with
        ``AVERAGE_BUDGET``, ``stats`` filled too); ``radius`` the largest Floquet
        multiplier of ``record.jac`` when it was computed (so that it is not computed
        twice), else NaN.
    """
    max_events = budget.max_events
    period = TWO_PI / point.omega
    record.acc[:] = 0.0
    flag = RUN_OK
    if t_start != 0.0:
        flag = fly(point, z, t_start, period, record, False, False, max_events)
    if flag == RUN_PARADOX:
        return FRICTION_PARADOX, REASON_NONE, 0, np.nan
    for _ in range(FIRST_PERIODS):
        if flag != RUN_OK:
            break
        flag = fly(point, z, 0.0, period, record, False, False, max_events)
    if flag == RUN_PARADOX:
        return FRICTION_PARADOX, REASON_NONE, 0, np.nan
    if flag != RUN_OK:
        return NOT_CONVERGED, REASON_EVENT_BUDGET, 0, np.nan
    guess = z.copy()
    flag, converged = _quiet_newton(point, z, 1, scales, max_events, record, work,
                                    MAX_NEWTON)
    # A stable fixed point found from the start is kept aside (its state, its pass's
    # statistics and Jacobian) until an iterate of the map from the start is verified to
    # lie where the map contracts onto it (contracts_onto, the pass with the orbit's
    # events); the cycle search below follows the same iterates meanwhile and reports
    # whatever they reach instead, where that is not the fixed point.
    pending = False
    pending_radius = np.nan
    pending_z = np.empty(N_STATE)
    pending_acc = np.empty(N_FLIGHT_ACC)
    pending_jac = np.empty((N_STATE, N_STATE))
    if converged:
        radius = spectral_radius(record.jac)
        if radius < 1.0 + STABILITY_MARGIN:
            pending = True
            pending_radius = radius
            pending_z[:] = z
            pending_acc[:] = record.acc
            pending_jac[:, :] = record.jac
    if flag == RUN_PARADOX:
        return FRICTION_PARADOX, REASON_NONE, 0, np.nan
    for i in range(N_STATE):
        z[i] = guess[i]
    tried = np.full(MAX_PERIOD + 1, np.inf)
    candidate = np.empty(N_STATE)
    irregular = new_irregular(scales, budget.max_average_periods)
    tolerance = budget.velocity_tolerance * point.a / point.omega
    chaotic = False
    deferred = np.empty((DEFERRED_TRIES, N_STATE))
    deferred_periods = np.zeros(DEFERRED_TRIES, dtype=np.int64)
    waiting = 0
    last = DISCARDED_PERIODS + budget.max_average_periods
    for iteration in range(max(budget.max_map_iterations, last)):
        slot = iteration % MAX_PERIOD
        for i in range(N_STATE):
            history[slot, i] = z[i]
        recorded = iteration - DISCARDED_PERIODS
        for i in range(N_STATE):
            for j in range(N_STATE):
                record.jac[i, j] = 1.0 if i == j else 0.0
        record.acc[:] = 0.0
        record.passes[0] += 1.0
        # The largest hop is sought in every HOP_STRIDE-th averaged period only: its
        # closed form's maxima cost about as much as the pass itself.
        flag = fly(point, z, 0.0, period, record, True,
                   recorded >= 0 and recorded % HOP_STRIDE == 0, max_events)
        if flag == RUN_PARADOX:
            return FRICTION_PARADOX, REASON_NONE, 0, np.nan
        if flag != RUN_OK:
            return NOT_CONVERGED, REASON_EVENT_BUDGET, 0, np.nan
        if pending and record.acc[A_EVENT_COUNT] == pending_acc[A_EVENT_COUNT] and (
                contracts_onto(history[slot], z, record.jac, pending_z, pending_radius,
                               scales)):
            return _pending_orbit(z, record, pending_z, pending_acc, pending_jac,
                                  pending_radius)
        if iteration < last:
            irregular.growths[iteration] = tangent_growth(record.jac, scales, irregular)
        if recorded < 0:
            chaotic = chaotic or looks_chaotic(irregular, iteration)
        elif recorded < budget.max_average_periods:
            acc = record.acc
            record_period(irregular, recorded, acc[A_DISPLACEMENT], period, acc[A_SLIPS],
                          acc[A_FORWARD], acc[A_BACKWARD], acc[A_AIRBORNE], acc[A_IMPACTS],
                          acc[A_HOP])
            averaged = recorded + 1
            if examined(averaged, budget.max_average_periods):
                within, chaotic, negative, bounded = examine(irregular, averaged, tolerance,
                                                             stats)
                for i in range(N_STATE):  # the last iterate, for whatever is reported
                    stats[S_STATE + i] = z[i]
                if settles(averaged, budget.max_average_periods, iteration,
                           budget.max_map_iterations, within, chaotic, negative,
                           bounded):
                    return (CHAOTIC if chaotic else QUASI_PERIODIC), REASON_NONE, 0, np.nan
                if averaged == budget.max_average_periods or (
                        iteration + 1 >= budget.max_map_iterations and out_of_reach(
                            averaged, budget.max_average_periods, stats, tolerance)):
                    found = _deferred_cycle(point, deferred, deferred_periods, waiting,
                                            scales, max_events, record, work, candidate)
                    waiting = 0
                    if found != 0:
                        return _found(found, z, candidate)
                    return NOT_CONVERGED, REASON_AVERAGE_BUDGET, 0, np.nan
        if iteration >= budget.max_map_iterations:
            continue  # the cycle search's budget is spent
        for periods in range(1, min(iteration + 1, MAX_PERIOD) + 1):
            back = (iteration - periods + 1) % MAX_PERIOD
            gap = state_distance(z, history[back], scales)
            if gap < CYCLE_DETECTION and gap < 0.5 * tried[periods]:
                tried[periods] = gap
                for i in range(N_STATE):
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
    return NOT_CONVERGED, REASON_NO_PERIODIC_ORBIT, 0, np.nan


@njit(cache=True, nogil=True, error_model="numpy")
def _deferred_cycle(point, deferred, deferred_periods, waiting, scales, max_events, record,
                    work, candidate):
    """Try the ``waiting`` near returns kept in ``deferred`` (states at phase 0) for
    cycles of ``deferred_periods`` periods, in the order they came: the first cycle
    found (:func:`_flight_cycle`'s answer, ``candidate`` its state), 0 if none, -1 on
    the paradox."""
    for k in range(waiting):
        for i in range(N_STATE):
            candidate[i] = deferred[k, i]
        found = _flight_cycle(point, candidate, deferred_periods[k], scales, max_events,
                              record, work)
        if found != 0:
            return found
    return 0


@njit(cache=True, nogil=True, error_model="numpy")
def _pending_orbit(z, record, pending_z, pending_acc, pending_jac, radius):
    """:func:`find_flight_orbit`'s answer for the fixed point found from the start once
    verified: ``z`` and ``record`` take its state and its pass's statistics and
    Jacobian again."""
    z[:] = pending_z
    record.acc[:] = pending_acc
    record.jac[:, :] = pending_jac
    return STICK_SLIP, REASON_NONE, 1, radius


@njit(cache=True, nogil=True, error_model="numpy")
def _found(found, z, candidate):
    """:func:`find_flight_orbit`'s answer for :func:`_deferred_cycle`'s ``found``
    (``z`` takes the cycle's state)."""
    if found < 0:
        return FRICTION_PARADOX, REASON_NONE, 0, np.nan
    for i in range(N_STATE):
        z[i] = candidate[i]
    return STICK_SLIP, REASON_NONE, found, np.nan


@njit(cache=True, nogil=True, error_model="numpy")
def orbit_exponent(out, c_multiplier, c_period, c_velocity_error, c_averaged, c_exponent,
                   c_exponent_error):
    """Complete the row ``out`` of an orbit (or a static point) whose multiplier and
    period it holds: its velocity is exact (error 0, no period averaged) and its
    largest Lyapunov exponent per drive period is the log of its largest Floquet
    multiplier over its period (a static point's period being one drive period)."""
    out[c_velocity_error] = 0.0
    out[c_averaged] = 0.0
    out[c_exponent] = math.log(out[c_multiplier]) / max(out[c_period], 1.0)
    out[c_exponent_error] = 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def irregular_row(stats, omega, status, out, columns):
    """Write a motion averaged on the period map (``stats``, the ``S_*`` slots of
    :mod:`study.kernels.time_average`, the last iterate's state from ``S_STATE``) into
    ``out`` at ``columns`` (as :func:`solve_flight`'s): its averages, no multiplier,
    period 0 and its last iterate as the state at phase 0; a point not converged keeps
    no velocity, only its partial mean, error, periods and exponent. A contact motion's
    averages hold no flight (0 in the air, no impact, no hop)."""
    (_, _, c_velocity, c_slips, c_forward, c_backward, c_period, c_multiplier, c_delta,
     c_rate, c_speed, c_airborne, c_hop, c_impacts, c_averaged_velocity, c_velocity_error,
     c_averaged, c_exponent, c_exponent_error, c_gap, c_gap_rate) = columns
    out[c_averaged] = stats[S_PERIODS]
    out[c_averaged_velocity] = stats[S_VELOCITY]
    out[c_velocity_error] = stats[S_VELOCITY_ERROR]
    out[c_exponent] = stats[S_EXPONENT]
    out[c_exponent_error] = stats[S_EXPONENT_ERROR]
    if status == NOT_CONVERGED:
        return
    period = TWO_PI / omega
    out[c_velocity] = stats[S_VELOCITY]
    out[c_slips] = stats[S_SLIPS]
    out[c_forward] = stats[S_FORWARD] / period
    out[c_backward] = stats[S_BACKWARD] / period
    out[c_period] = 0.0
    out[c_multiplier] = np.nan
    out[c_delta] = stats[S_STATE]
    out[c_rate] = stats[S_STATE + 1]
    out[c_speed] = stats[S_STATE + 2]
    flying = stats.shape[0] > S_STATE + Z_GAP_RATE  # a contact motion's: 3 states
    out[c_gap] = stats[S_STATE + Z_GAP] if flying else 0.0
    out[c_gap_rate] = stats[S_STATE + Z_GAP_RATE] if flying else 0.0
    out[c_airborne] = stats[S_AIRBORNE] / period
    out[c_hop] = stats[S_HOP]
    out[c_impacts] = stats[S_IMPACTS]


@njit(cache=True, nogil=True, error_model="numpy")
def solve_flight(structure, table, omega, a, budget, z, t_start, out, columns):
    """The motion with flight reached from the 5-state ``z`` at ``t_start`` [s], written
    into ``out`` at the positions ``columns`` (status, reason, velocity, slips, forward,
    backward, period, multiplier, delta, delta_rate, speed, airborne, hop, impacts,
    averaged_velocity, velocity_error, averaged_periods, exponent, exponent_error, gap,
    gap_rate);
    ``table`` holds the contact rows and the flight row. An irregular motion
    (``CHAOTIC``, ``QUASI_PERIODIC``) gets its time averages, no multiplier and period
    0, and its last iterate as the state at phase 0; a point not converged after
    averaging (``AVERAGE_BUDGET``) keeps no velocity but its partial mean (as
    averaged_velocity), its error, periods and exponent.

    Returns
    -------
    float, float, float
        The passes over the period map with its Jacobian (Newton's, and the averaged
        periods') and without it (the map's iterates, the cycle checks): the work the
        point took; 1.0 where the orbit is the fixed point that Newton's method found
        from the state two periods after the start (verified reached), else 0.0.
    """
    point = DrivePoint(structure, table, omega, a)
    scales = flight_scales(point)
    record = FlightRecord(np.zeros(N_FLIGHT_ACC), np.empty((N_STATE, N_STATE)),
                          np.empty((N_STATE, N_STATE)), np.empty((N_STATE, N_STATE)),
                          np.zeros(2))
    work = np.empty(N_STATE)
    history = np.empty((MAX_PERIOD, N_STATE))
    stats = np.full(N_STATS, np.nan)
    status, reason, periods, radius = find_flight_orbit(point, z, t_start, scales, budget,
                                                        record, work, history, stats)
    # Only the fixed point found by Newton's method from the start comes with its radius.
    from_start = 0.0 if math.isnan(radius) else 1.0
    passes = record.passes
    (c_status, c_reason, c_velocity, c_slips, c_forward, c_backward, c_period, c_multiplier,
     c_delta, c_rate, c_speed, c_airborne, c_hop, c_impacts, _,
     c_velocity_error, c_averaged, c_exponent, c_exponent_error, c_gap, c_gap_rate) = columns
    out[c_status] = status
    out[c_reason] = reason
    if status == CHAOTIC or status == QUASI_PERIODIC or reason == REASON_AVERAGE_BUDGET:
        irregular_row(stats, omega, status, out, columns)
        return passes[0], passes[1], from_start
    if math.isnan(radius):
        radius = spectral_radius(record.jac)
    if periods == 0:
        return passes[0], passes[1], from_start
    acc = record.acc
    span = periods * TWO_PI / omega
    if acc[A_AIRBORNE] > 0.0:
        out[c_status] = BOUNCING
    elif acc[A_SLIPS] == 0.0:
        # Landed for good: a permanent stick is the static outcome (no orbit period), as
        # a start in contact below the thresholds reports it.
        out[c_status] = STATIC
        out[c_velocity] = 0.0
        out[c_slips] = 0.0
        out[c_forward] = 0.0
        out[c_backward] = 0.0
        out[c_period] = 0.0
        out[c_multiplier] = radius
        out[c_airborne] = 0.0
        out[c_hop] = acc[A_HOP]
        out[c_impacts] = 0.0
        orbit_exponent(out, c_multiplier, c_period, c_velocity_error, c_averaged,
                       c_exponent, c_exponent_error)
        return passes[0], passes[1], from_start
    else:
        out[c_status] = STICK_SLIP if acc[A_STICK] > 0.0 else CONTINUOUS_SLIDING
    out[c_velocity] = acc[A_DISPLACEMENT] / span
    out[c_slips] = acc[A_SLIPS] / periods
    out[c_forward] = acc[A_FORWARD] / span
    out[c_backward] = acc[A_BACKWARD] / span
    out[c_period] = periods
    out[c_multiplier] = radius
    out[c_delta] = z[0]
    out[c_rate] = z[1]
    out[c_speed] = z[2]
    out[c_gap] = z[Z_GAP]
    out[c_gap_rate] = z[Z_GAP_RATE]
    out[c_airborne] = acc[A_AIRBORNE] / span
    out[c_hop] = acc[A_HOP]
    out[c_impacts] = acc[A_IMPACTS] / periods
    orbit_exponent(out, c_multiplier, c_period, c_velocity_error, c_averaged, c_exponent,
                   c_exponent_error)
    return passes[0], passes[1], from_start
