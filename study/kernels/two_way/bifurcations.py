"""A periodic orbit's branch traced over a segment of the drive plane, through its folds,
with each bifurcation on it located.

:func:`trace_branch` continues a fixed point of ``P^N`` by the pseudo-arclength steps of
:mod:`~study.kernels.two_way.branch` (its tangent, its bordered corrector, its step
control near folds and kinks, its quiet sections), recording each accepted step
(:data:`STEP_COLUMNS`, the Floquet multipliers beside), and goes on through folds onto
the unstable part of the branch. Between two accepted steps it watches a test function
for each smooth bifurcation and the orbit's sequence of events for the non-smooth ones:

- the tangent's drive component changes sign: a **fold** (a real multiplier through +1);
- the number of real multipliers below -1 changes: a **period doubling**;
- the number of complex pairs outside the unit circle changes: a **torus**;
- the sequence of events of a period changes (its slips, impacts, sticks or flights):
  a **grazing** (a flight touches the table, a stick or slip phase shrinks to zero), or
  a **slip onset** where a stick first slips (the static orbit's end);
- a real multiplier reaches +1 without the tangent turning: a **branch point**.

Each is then located on the step by the arclength corrector from the step's start along
its tangent: the smooth ones by the Illinois regula falsi on their test function (the
tangent's drive component, ``mu + 1``, ``|mu| - 1``) until the drive is known to
:data:`DRIVE_TOLERANCE` relative and the test function vanishes to
:data:`TEST_TOLERANCE`, the non-smooth ones by bisection on the sequence of events to
:data:`DRIVE_TOLERANCE`. Without flight a branch that cannot be followed on because its
orbit leaves the table ends in a located **lift-off**.

The kinds and the ends are the codes of :mod:`study.model.codes` (``BIFURCATION_*``,
``BRANCH_*``), named in :mod:`study.model.bifurcations`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from study.kernels.structure_vector import LIFT_OFF_LAW
from study.kernels.two_way.branch import (
    KINK_STEP,
    MOST_MULTIPLIER_CHANGE,
    MOST_TURN,
    N_EXTENDED,
    STEP_CORRECTION,
    arclength_step,
    branch_tangent,
    contact_section,
    crowded_section,
    drive_at,
    fixed_point,
    flow,
    moved_tangent,
    multiplier_signature,
    parameter_derivative,
    period_pass,
)
from study.kernels.two_way.flight import (
    A_AIRBORNE,
    A_HOP,
    A_IMPACTS,
    N_STATE,
    fly,
)
from study.kernels.two_way.flight_orbit import quiet_section
from study.kernels.two_way.modes import TWO_PI
from study.kernels.two_way.orbit import (
    A_DISPLACEMENT,
    A_EVENTS,
    A_SLIPS,
    A_STICK,
    RUN_LIFT_OFF,
    RUN_OK,
    run,
)
from study.kernels.two_way.trace_columns import (  # noqa: F401 (the columns, named here too)
    B_IMAG,
    B_KIND,
    B_MAP_PASSES,
    B_NEWTON_PASSES,
    B_REAL,
    B_SECTION,
    B_STATE,
    B_STEP,
    B_T,
    B_TEST,
    B_VELOCITY,
    BIFURCATION_COLUMNS,
    N_BIFURCATION,
    N_STEP,
    S_AIRBORNE,
    S_EVENTS,
    S_HOP,
    S_IMPACTS,
    S_RADIUS,
    S_SECTION,
    S_SLIPS,
    S_STATE,
    S_STICK,
    S_T,
    S_TANGENT,
    S_VELOCITY,
    STEP_COLUMNS,
)
from study.model.codes import (
    BIFURCATION_BRANCH_POINT,
    BIFURCATION_FOLD,
    BIFURCATION_GRAZING,
    BIFURCATION_LIFT_OFF,
    BIFURCATION_PERIOD_DOUBLING,
    BIFURCATION_SLIP_ONSET,
    BIFURCATION_TORUS,
    BRANCH_BUDGET,
    BRANCH_ENDED,
    BRANCH_LEFT,
    BRANCH_LOST,
    BRANCH_REACHED,
    BRANCH_STOPPED,
)

#: A bifurcation's drive is located to this fraction of its value (or of the drive's
#: natural scale where the value is near 0: the segment's length).
DRIVE_TOLERANCE = 1e-10
#: ... and a smooth one's test function to this.
TEST_TOLERANCE = 1e-11
#: Evaluations of the corrector a location takes at most.
MAX_LOCATE = 80
#: The shortest step of a traced branch: its end (a lift-off, a non-smooth end) is
#: located to it.
SMALLEST_TRACE_STEP = 2.0 ** -36

#: The scratch of a trace beside the branch's: the accepted point (scaled ``(z /
#: reference, t)``), its tangent and the map's parameter derivative there, and the
#: same of the new point, with their sections' phases, and a step row kept aside.
TraceWork = namedtuple("TraceWork", ("point", "tangent", "derivative", "new_point",
                                     "new_tangent", "new_derivative", "row", "other"))


@njit(cache=True, nogil=True, error_model="numpy")
def new_trace_work():
    """A fresh :data:`TraceWork`."""
    return TraceWork(np.zeros(N_EXTENDED), np.zeros(N_EXTENDED), np.zeros(N_STATE),
                     np.zeros(N_EXTENDED), np.zeros(N_EXTENDED), np.zeros(N_STATE),
                     np.zeros(N_STEP), np.zeros(N_STEP))


@njit(cache=True, nogil=True, error_model="numpy")
def _orbit_row(point, z, section, periods, phase, work, flying, max_events, row):
    """The statistics of the orbit through ``z`` on ``section`` [s] into ``row`` (a
    step's, its ``t`` and tangent left to the caller), from a pass without the Jacobian
    (with the largest gap, with flight). False where the pass stopped."""
    span = periods * TWO_PI / point.omega
    end = work.work
    for i in range(N_STATE):
        end[i] = z[i]
    if flying:
        record = work.flight
        record.acc[:] = 0.0
        record.passes[1] += 1.0
        flag = fly(point, end, section, section + span, record, False, True, max_events)
        acc = record.acc
        row[S_IMPACTS] = acc[A_IMPACTS] / periods
        row[S_AIRBORNE] = acc[A_AIRBORNE] / span
        row[S_HOP] = acc[A_HOP]
    else:
        record = work.contact
        record.acc[:] = 0.0
        flag = run(point, end, section, section + span, record, False, 0.0, max_events)
        acc = record.acc
        row[S_IMPACTS] = 0.0
        row[S_AIRBORNE] = 0.0
        row[S_HOP] = 0.0
    row[S_VELOCITY] = acc[A_DISPLACEMENT] / span
    row[S_EVENTS] = acc[A_EVENTS]
    row[S_SLIPS] = acc[A_SLIPS] / periods
    row[S_STICK] = acc[A_STICK] / span
    row[S_SECTION] = phase
    for i in range(N_STATE):
        row[S_STATE + i] = z[i]
    return flag == RUN_OK


@njit(cache=True, nogil=True, inline="always")
def _same_events(one, other):
    """Two step rows' orbits have one sequence of events (their counts, and whether they
    stick and fly)."""
    return (one[S_EVENTS] == other[S_EVENTS] and one[S_SLIPS] == other[S_SLIPS]
            and one[S_IMPACTS] == other[S_IMPACTS]
            and (one[S_STICK] > 0.0) == (other[S_STICK] > 0.0)
            and (one[S_AIRBORNE] > 0.0) == (other[S_AIRBORNE] > 0.0))


@njit(cache=True, nogil=True, error_model="numpy")
def _nearest(work, n, target, real_only):
    """``(real, imag)`` of the multiplier (of the last :func:`multiplier_signature`)
    nearest ``target``: among the real ones, or among the complex ones by modulus
    (``target`` is then the modulus); ``(nan, nan)`` where there is none."""
    best = np.inf
    re = np.nan
    im = np.nan
    for i in range(n):
        r = work.real[i]
        c = work.imag[i]
        if real_only:
            if c != 0.0:
                continue
            distance = abs(r - target)
        else:
            if c <= 0.0:
                continue
            distance = abs(math.hypot(r, c) - target)
        if distance < best:
            best = distance
            re = r
            im = c
    return re, im


@njit(cache=True, nogil=True, error_model="numpy")
def _test_value(kind, work, n, tangent_t):
    """The test function of a smooth bifurcation ``kind`` at the last corrected point."""
    if kind == BIFURCATION_FOLD:
        return tangent_t
    if kind == BIFURCATION_PERIOD_DOUBLING:
        re, _ = _nearest(work, n, -1.0, True)
        return re + 1.0
    if kind == BIFURCATION_TORUS:
        re, im = _nearest(work, n, 1.0, False)
        return math.hypot(re, im) - 1.0
    re, _ = _nearest(work, n, 1.0, True)
    return re - 1.0


@njit(cache=True, nogil=True, error_model="numpy")
def _evaluate(structure, work, trace, segment, phase, periods, flying, max_events, s,
              want_tangent, row):
    """The branch's point at arclength ``s`` from the accepted point (``trace.point``)
    along its tangent (``trace.tangent``): the corrector from there, bordered by that
    tangent, into ``work.point`` (``work.jac`` its Jacobian; with ``want_tangent`` the
    branch's tangent there in ``work.turned``) and its orbit's statistics into ``row``.
    False where it does not converge."""
    n = N_STATE if flying else 3
    for i in range(N_EXTENDED):
        work.tangent[i] = trace.tangent[i]
        work.predicted[i] = trace.point[i] + s * trace.tangent[i]
    for i in range(N_STATE):
        work.derivative[i] = trace.derivative[i]
    ok, _ = arclength_step(structure, work, segment, phase, periods, flying, max_events,
                           s, True)
    if not ok:
        return False
    t = work.point[N_STATE]
    point = drive_at(structure, work, segment, t, flying)
    span = periods * TWO_PI / point.omega
    multiplier_signature(work, flying)
    if want_tangent:
        if not parameter_derivative(structure, work, segment, t, work.z, phase, periods,
                                    flying, max_events):
            return False
        if not branch_tangent(work, n, work.turned):
            return False
        row[S_TANGENT] = work.turned[N_STATE]
    row[S_T] = t
    return _orbit_row(point, work.z, phase * span, periods, phase, work, flying,
                      max_events, row)


@njit(cache=True, nogil=True, error_model="numpy")
def _drive_tolerance(segment, t):
    """The tolerance on the segment's ``t`` that puts the drive to
    :data:`DRIVE_TOLERANCE` of its value at ``t``."""
    d_omega = abs(segment.omega1 - segment.omega0)
    d_a = abs(segment.a1 - segment.a0)
    if d_omega >= d_a * 1e-12 and d_omega > 0.0:
        value = abs(segment.omega0 + t * (segment.omega1 - segment.omega0))
        return DRIVE_TOLERANCE * max(value, d_omega) / d_omega
    value = abs(segment.a0 + t * (segment.a1 - segment.a0))
    return DRIVE_TOLERANCE * max(value, d_a) / max(d_a, 1e-300)


@njit(cache=True, nogil=True, error_model="numpy")
def _record(out, kind, t, row, test, re, im, step, work, flying, jac_out):
    """A located bifurcation's row into ``out`` and its Jacobian into ``jac_out``."""
    n = N_STATE if flying else 3
    out[B_KIND] = kind
    out[B_T] = t
    out[B_VELOCITY] = row[S_VELOCITY]
    out[B_TEST] = test
    out[B_REAL] = re
    out[B_IMAG] = im
    out[B_STEP] = step
    out[B_SECTION] = row[S_SECTION]
    for i in range(N_STATE):
        out[B_STATE + i] = row[S_STATE + i]
    for i in range(N_STATE):
        for j in range(N_STATE):
            jac_out[i, j] = work.jac[i, j] if i < n and j < n else 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def _locate_smooth(structure, work, trace, segment, phase, periods, flying, max_events,
                   kind, length, g0, g1, step, out, jac_out):
    """Locate the smooth bifurcation ``kind`` whose test function is ``g0`` at the
    accepted point and ``g1`` at arclength ``length`` along its tangent, by the
    Illinois regula falsi; its row into ``out``. False where the corrector failed
    throughout (nothing recorded)."""
    n = N_STATE if flying else 3
    row = trace.row
    lo, hi = 0.0, length
    g_lo, g_hi = g0, g1
    t_lo = trace.point[N_STATE]
    t_hi = trace.new_point[N_STATE]
    side = 0
    best = np.inf
    found = False
    for _ in range(MAX_LOCATE):
        if g_hi != g_lo:
            s = hi - g_hi * (hi - lo) / (g_hi - g_lo)
        else:
            s = 0.5 * (lo + hi)
        if not (lo < s < hi):
            s = 0.5 * (lo + hi)
        if not _evaluate(structure, work, trace, segment, phase, periods, flying,
                         max_events, s, kind == BIFURCATION_FOLD, row):
            # Off the corrector's reach: bisect instead.
            s = 0.5 * (lo + hi)
            if not _evaluate(structure, work, trace, segment, phase, periods, flying,
                             max_events, s, kind == BIFURCATION_FOLD, row):
                break
        g = _test_value(kind, work, n, row[S_TANGENT])
        if kind == BIFURCATION_PERIOD_DOUBLING:
            re, im = _nearest(work, n, -1.0, True)
        elif kind == BIFURCATION_TORUS:
            re, im = _nearest(work, n, 1.0, False)
        else:
            re, im = _nearest(work, n, 1.0, True)
        t = row[S_T]
        if abs(g) <= best:
            best = abs(g)
            found = True
            _record(out, kind, t, row, g, re, im, step, work, flying, jac_out)
        if (g > 0.0) == (g_lo > 0.0):
            lo, g_lo, t_lo = s, g, t
            if side == -1:
                g_hi *= 0.5
            side = -1
        else:
            hi, g_hi, t_hi = s, g, t
            if side == 1:
                g_lo *= 0.5
            side = 1
        if abs(g) <= TEST_TOLERANCE and abs(t_hi - t_lo) <= _drive_tolerance(segment, t):
            break
        if hi - lo <= 1e-15 * length:
            break
    return found


@njit(cache=True, nogil=True, error_model="numpy")
def _largest(work, n):
    """``(real, imag)`` of the largest multiplier (by modulus) of the last
    :func:`multiplier_signature`."""
    best = -1.0
    re = np.nan
    im = np.nan
    for i in range(n):
        modulus = math.hypot(work.real[i], work.imag[i])
        if modulus > best:
            best = modulus
            re = work.real[i]
            im = work.imag[i]
    return re, im


@njit(cache=True, nogil=True, error_model="numpy")
def _locate_events(structure, work, trace, segment, phase, periods, flying, max_events,
                   length, step, before_row, after_row, out, jac_out):
    """Locate where the sequence of events changes on the step of arclength ``length``
    from the accepted point (whose row is ``before_row``; ``after_row`` the new
    point's) by bisection, to :data:`DRIVE_TOLERANCE` in the drive; its row into
    ``out`` (the last point found with the accepted point's sequence): a slip onset
    where, on the table, a stick starts or stops slipping, a grazing otherwise."""
    n = N_STATE if flying else 3
    row = trace.row
    other = trace.other
    for i in range(N_STEP):
        other[i] = after_row[i]
    lo, hi = 0.0, length
    t_lo = trace.point[N_STATE]
    t_hi = trace.new_point[N_STATE]
    found = False
    for _ in range(MAX_LOCATE):
        if abs(t_hi - t_lo) <= _drive_tolerance(segment, t_lo) or hi - lo <= 1e-15 * length:
            break
        s = 0.5 * (lo + hi)
        if not _evaluate(structure, work, trace, segment, phase, periods, flying,
                         max_events, s, False, row):
            break
        if _same_events(row, before_row):
            lo, t_lo = s, row[S_T]
            re, im = _largest(work, n)
            _record(out, BIFURCATION_GRAZING, t_lo, row, 0.0, re, im, step, work, flying,
                    jac_out)
            found = True
        else:
            hi, t_hi = s, row[S_T]
            for i in range(N_STEP):
                other[i] = row[i]
    if not found:
        # The accepted point itself is the last found with its sequence.
        _record(out, BIFURCATION_GRAZING, t_lo, before_row, 0.0, np.nan, np.nan, step,
                work, flying, jac_out)
    if (before_row[S_AIRBORNE] == 0.0 and other[S_AIRBORNE] == 0.0
            and (before_row[S_SLIPS] == 0.0) != (other[S_SLIPS] == 0.0)):
        out[B_KIND] = BIFURCATION_SLIP_ONSET
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _locate_lift_off(structure, work, trace, segment, phase, periods, max_events, step,
                     before_row, out, jac_out):
    """Locate, without flight, where the branch's orbit leaves the table beyond the
    accepted point (``before_row`` its row): along the tangent, the first arclength
    whose corrector is refused by a lift-off is found by doubling from
    :data:`SMALLEST_TRACE_STEP`, then the last orbit that keeps contact by bisection, to
    :data:`DRIVE_TOLERANCE` in the drive; its row into ``out``. False (nothing recorded)
    where the branch ends otherwise: a refusal of another kind, or no lift-off within
    reach."""
    row = trace.row
    last = trace.other
    for i in range(N_STEP):
        last[i] = before_row[i]
    t0 = trace.point[N_STATE]
    rate = abs(trace.tangent[N_STATE])
    lo, hi = 0.0, -1.0
    s = SMALLEST_TRACE_STEP
    for _ in range(64):
        if _evaluate(structure, work, trace, segment, phase, periods, False, max_events,
                     s, False, row):
            lo = s
            for i in range(N_STEP):
                last[i] = row[i]
            s *= 2.0
        elif work.flags[0] == RUN_LIFT_OFF:
            hi = s
            break
        else:
            return False
    if hi < 0.0:
        return False
    # Bisection: the drive changes by at most |dt/ds| (hi - lo) between the two.
    while (hi - lo) * max(rate, 1e-300) > _drive_tolerance(segment, last[S_T]) and (
            hi - lo > 1e-15 * hi):
        s = 0.5 * (lo + hi)
        if _evaluate(structure, work, trace, segment, phase, periods, False, max_events,
                     s, False, row):
            lo = s
            for i in range(N_STEP):
                last[i] = row[i]
        elif work.flags[0] == RUN_LIFT_OFF:
            hi = s
        else:
            break
    # The last orbit in contact once more, for its multipliers and Jacobian.
    if lo > 0.0 and _evaluate(structure, work, trace, segment, phase, periods, False,
                              max_events, lo, False, row):
        re, im = _largest(work, 3)
        t = row[S_T]
    else:
        re, im = np.nan, np.nan
        t = t0
        for i in range(N_STATE):
            for j in range(N_STATE):
                work.jac[i, j] = 0.0
    _record(out, BIFURCATION_LIFT_OFF, t, last, 0.0, re, im, step, work, False, jac_out)
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def trace_branch(structure, segment, z0, periods, start_tangent, section, work, trace,
                 max_events, max_steps, max_step, sought, steps_out, real_out, imag_out,
                 bifurcations_out, jacobians_out):
    """Trace the branch of the fixed point ``z0`` (``N_STATE`` at phase 0) of
    ``P^periods`` from the start of ``segment`` towards its end (``t`` from 0 to 1), the
    steps at most ``max_step`` long in the scaled space of state and ``t``.

    ``start_tangent`` (``N_EXTENDED``, the state's part in SI units) is the direction
    to start in: zeros for
    the branch's own tangent towards the segment's end; else (a period doubling's
    doubled orbit, whose branch leaves the period's orbit along the eigenvector of the
    multiplier -1 with the drive stationary) the first step is taken along it.

    ``sought`` (a ``BIFURCATION_*`` code, or 0 for every kind) restricts the
    bifurcations located to that kind and ends the trace on the step past the first one
    (``BRANCH_STOPPED``): a curve's search for its next point needs no other kind and
    nothing of the branch beyond it.

    Each accepted step's row goes to ``steps_out`` (:data:`STEP_COLUMNS`; at most
    ``max_steps`` rows), its multipliers to ``real_out`` and ``imag_out``; each located
    bifurcation's row to ``bifurcations_out`` (:data:`BIFURCATION_COLUMNS`) and its
    Jacobian to ``jacobians_out``.

    Returns
    -------
    steps, bifurcations, end, newton_passes, map_passes
        The rows written, the ``BRANCH_*`` code of why the trace ended (``t`` reached 1,
        a non-smooth end, the budget of steps, ``t`` back below 0, not followed at all,
        stopped past the bifurcation asked for), and the passes of the period map it took.
    """
    flying = structure[LIFT_OFF_LAW] != 0.0
    n = N_STATE if flying else 3
    max_bifurcations = bifurcations_out.shape[0]
    passes = work.flight.passes if flying else work.contact.passes
    start_newton = passes[0]
    start_map = passes[1]
    z = work.z
    for i in range(N_STATE):
        z[i] = z0[i] if i < n else 0.0
    point = drive_at(structure, work, segment, 0.0, flying)
    span = periods * TWO_PI / point.omega
    reference = work.reference
    for i in range(N_STATE):
        reference[i] = work.scales[i]
    phase = 0.0
    if section >= 0.0:
        phase = section
    elif flying:
        flag, _, _ = period_pass(point, z, 0.0, periods, work, flying, False, max_events)
        if flag == RUN_OK:
            phase = quiet_section(work.flight.acc, 0.0, span) / span
        flow(point, z, 0.0, phase * span, work, flying, max_events)
    else:
        phase, _ = contact_section(point, z, 0.0, periods, work, max_events)
        flow(point, z, 0.0, phase * span, work, flying, max_events)
    switching = False
    for i in range(N_EXTENDED):
        if start_tangent[i] != 0.0:
            switching = True
    if not switching:
        converged, _, _ = fixed_point(point, z, phase * span, periods, work, flying,
                                      max_events, 1e-3)
        if not converged:
            return 0, 0, BRANCH_LOST, passes[0] - start_newton, passes[1] - start_map
    else:
        # The fixed point of the orbit of half the period: its Jacobian here.
        period_pass(point, z, phase * span, periods, work, flying, True, max_events)
    if not parameter_derivative(structure, work, segment, 0.0, z, phase, periods, flying,
                                max_events):
        return 0, 0, BRANCH_LOST, passes[0] - start_newton, passes[1] - start_map
    _, below, outside, radius = multiplier_signature(work, flying)
    tangent = trace.tangent
    if switching:
        # The direction given in SI units of the state: scaled and normalised.
        norm = 0.0
        for i in range(N_EXTENDED):
            tangent[i] = start_tangent[i] / reference[i] if i < n else (
                start_tangent[i] if i == N_STATE else 0.0)
            norm += tangent[i] * tangent[i]
        for i in range(N_EXTENDED):
            tangent[i] /= math.sqrt(norm)
    else:
        for i in range(N_EXTENDED):
            work.tangent[i] = 0.0
        work.tangent[N_STATE] = 1.0
        if not branch_tangent(work, n, work.turned):
            return 0, 0, BRANCH_LOST, passes[0] - start_newton, passes[1] - start_map
        for i in range(N_EXTENDED):
            tangent[i] = work.turned[i]
    accepted = trace.point
    for i in range(N_EXTENDED):
        accepted[i] = 0.0
    for i in range(n):
        accepted[i] = z[i] / reference[i]
    for i in range(N_STATE):
        trace.derivative[i] = work.derivative[i]
    steps = 0
    bifurcations = 0
    row = steps_out[0]
    _orbit_row(point, z, phase * span, periods, phase, work, flying, max_events, row)
    row[S_T] = 0.0
    row[S_RADIUS] = radius
    row[S_TANGENT] = tangent[N_STATE]
    for i in range(N_STATE):
        real_out[0, i] = work.real[i] if i < n else np.nan
        imag_out[0, i] = work.imag[i] if i < n else np.nan
    steps = 1
    h = max_step
    bracketed = False
    end = BRANCH_BUDGET
    t_new = 0.0
    next_below = below
    next_outside = outside
    next_radius = radius
    while steps < max_steps:
        kink = h <= KINK_STEP
        to_end = ((1.0 - accepted[N_STATE]) / tangent[N_STATE] if tangent[N_STATE] > 0.0
                  else np.inf)
        if h >= to_end and not (switching and steps == 1):
            # The segment's end within reach: the fixed point at t = 1 exactly, from the
            # tangent's prediction there.
            length = to_end
            for i in range(n):
                z[i] = (accepted[i] + to_end * tangent[i]) * reference[i]
            point = drive_at(structure, work, segment, 1.0, flying)
            span = periods * TWO_PI / point.omega
            ok, _, _ = fixed_point(point, z, phase * span, periods, work, flying,
                                   max_events, np.inf if kink else STEP_CORRECTION * to_end)
            if ok:
                for i in range(n):
                    work.point[i] = z[i] / reference[i]
                work.point[N_STATE] = 1.0
        else:
            # The step, bordered by the accepted point's tangent, the map's parameter
            # derivative held at the accepted point's; the first step from a branch
            # point (a doubled orbit's start) takes it anew at each iterate.
            length = h
            for i in range(N_EXTENDED):
                work.tangent[i] = tangent[i]
                work.predicted[i] = accepted[i] + h * tangent[i]
            for i in range(N_STATE):
                work.derivative[i] = trace.derivative[i]
            ok, _ = arclength_step(structure, work, segment, phase, periods, flying,
                                   max_events, h, kink, switching and steps == 1)
        moved = False
        if ok:
            t_new = work.point[N_STATE]
            point = drive_at(structure, work, segment, t_new, flying)
            span = periods * TWO_PI / point.omega
            next_above, next_below, next_outside, next_radius = multiplier_signature(
                work, flying)
            ok = next_above >= 0
            # The multipliers' change bounds a step so that no crossing of the unit
            # circle is stepped over; a search for a fold alone (its test is the
            # tangent's, bounded by the turn below) needs no such bound.
            moved = ok and not kink and sought != BIFURCATION_FOLD and (
                abs(next_radius - radius) > MOST_MULTIPLIER_CHANGE)
        if ok and not moved:
            for i in range(N_EXTENDED):
                work.tangent[i] = tangent[i]
            ok = parameter_derivative(structure, work, segment, t_new, work.z, phase,
                                      periods, flying, max_events) and branch_tangent(
                                          work, n, work.turned)
            if ok:
                cosine = 0.0
                for i in range(N_EXTENDED):
                    cosine += work.turned[i] * tangent[i]
                moved = not kink and cosine < math.cos(MOST_TURN)
        if not ok or moved:
            h *= 0.5
            bracketed = bracketed or moved
            if h < SMALLEST_TRACE_STEP:
                end = BRANCH_ENDED
                newton_before, map_before = passes[0], passes[1]
                if not flying and bifurcations < max_bifurcations and sought in (
                        0, BIFURCATION_LIFT_OFF) and (
                        _locate_lift_off(structure, work, trace, segment, phase, periods,
                                         max_events, steps - 1, steps_out[steps - 1],
                                         bifurcations_out[bifurcations],
                                         jacobians_out[bifurcations])):
                    # The orbit leaves the table: the branch ends there.
                    bifurcations_out[bifurcations, B_NEWTON_PASSES] = (
                        passes[0] - newton_before)
                    bifurcations_out[bifurcations, B_MAP_PASSES] = passes[1] - map_before
                    bifurcations += 1
                break
            continue
        # Accepted: the new point, its tangent and derivative kept aside.
        new_row = steps_out[steps]
        for i in range(N_EXTENDED):
            trace.new_point[i] = work.point[i]
            trace.new_tangent[i] = work.turned[i]
        for i in range(N_STATE):
            trace.new_derivative[i] = work.derivative[i]
        z_new = work.z
        _orbit_row(point, z_new, phase * span, periods, phase, work, flying, max_events,
                   new_row)
        new_row[S_T] = t_new
        new_row[S_RADIUS] = next_radius
        new_row[S_TANGENT] = trace.new_tangent[N_STATE]
        for i in range(N_STATE):
            real_out[steps, i] = work.real[i] if i < n else np.nan
            imag_out[steps, i] = work.imag[i] if i < n else np.nan
        old_row = steps_out[steps - 1]
        # The bifurcations on the step, each located from the accepted point.
        g_fold = tangent[N_STATE] * trace.new_tangent[N_STATE]
        first_here = bifurcations
        events_changed = not _same_events(old_row, new_row)
        for kind in (BIFURCATION_FOLD, BIFURCATION_PERIOD_DOUBLING, BIFURCATION_TORUS,
                     BIFURCATION_GRAZING):
            if bifurcations >= max_bifurcations:
                break
            newton_before, map_before = passes[0], passes[1]
            if sought > 0 and kind != sought and not (
                    kind == BIFURCATION_GRAZING and sought == BIFURCATION_SLIP_ONSET):
                # (the event sequence's locator finds slip onsets and grazings both)
                continue
            if kind == BIFURCATION_FOLD and g_fold < 0.0:
                found = _locate_smooth(structure, work, trace, segment, phase, periods,
                                       flying, max_events, kind, length, tangent[N_STATE],
                                       trace.new_tangent[N_STATE], steps - 1,
                                       bifurcations_out[bifurcations],
                                       jacobians_out[bifurcations])
            elif kind == BIFURCATION_PERIOD_DOUBLING and next_below != below and not (
                    events_changed):
                found = _locate_smooth(structure, work, trace, segment, phase, periods,
                                       flying, max_events, kind, length,
                                       _edge_value(real_out[steps - 1],
                                                   imag_out[steps - 1], n, kind),
                                       _edge_value(real_out[steps],
                                                   imag_out[steps], n, kind),
                                       steps - 1, bifurcations_out[bifurcations],
                                       jacobians_out[bifurcations])
            elif kind == BIFURCATION_TORUS and next_outside != outside and not (
                    events_changed):
                found = _locate_smooth(structure, work, trace, segment, phase, periods,
                                       flying, max_events, kind, length,
                                       _edge_value(real_out[steps - 1],
                                                   imag_out[steps - 1], n, kind),
                                       _edge_value(real_out[steps],
                                                   imag_out[steps], n, kind),
                                       steps - 1, bifurcations_out[bifurcations],
                                       jacobians_out[bifurcations])
            elif kind == BIFURCATION_GRAZING and events_changed:
                found = _locate_events(structure, work, trace, segment, phase, periods,
                                       flying, max_events, length, steps - 1, old_row,
                                       new_row, bifurcations_out[bifurcations],
                                       jacobians_out[bifurcations])
            else:
                continue
            if not found and kind != BIFURCATION_GRAZING:
                # The corrector did not converge on the step: the bifurcation is recorded
                # at the step's end, its test function's value there saying how near.
                g = (trace.new_tangent[N_STATE] if kind == BIFURCATION_FOLD
                     else _edge_value(real_out[steps], imag_out[steps], n, kind))
                _record(bifurcations_out[bifurcations], kind, t_new, new_row, g, np.nan,
                        np.nan, steps - 1, work, flying, jacobians_out[bifurcations])
                found = True
            if found:
                bifurcations_out[bifurcations, B_NEWTON_PASSES] = passes[0] - newton_before
                bifurcations_out[bifurcations, B_MAP_PASSES] = passes[1] - map_before
                bifurcations += 1
        if (bifurcations < max_bifurcations and g_fold >= 0.0 and not events_changed
                and sought in (0, BIFURCATION_BRANCH_POINT)
                and _crosses_one(real_out[steps - 1], imag_out[steps - 1], real_out[steps],
                                 imag_out[steps], n)):
            # A real multiplier through +1 while the tangent keeps its way: another
            # branch crosses this one.
            newton_before, map_before = passes[0], passes[1]
            if _locate_smooth(structure, work, trace, segment, phase, periods, flying,
                              max_events, BIFURCATION_BRANCH_POINT, length,
                              _edge_value(real_out[steps - 1], imag_out[steps - 1],
                                          n, BIFURCATION_BRANCH_POINT),
                              _edge_value(real_out[steps], imag_out[steps], n,
                                          BIFURCATION_BRANCH_POINT),
                              steps - 1, bifurcations_out[bifurcations],
                              jacobians_out[bifurcations]):
                bifurcations_out[bifurcations, B_NEWTON_PASSES] = passes[0] - newton_before
                bifurcations_out[bifurcations, B_MAP_PASSES] = passes[1] - map_before
                bifurcations += 1
        # The new point accepted (the locations moved the work's arrays).
        for i in range(N_EXTENDED):
            accepted[i] = trace.new_point[i]
            tangent[i] = trace.new_tangent[i]
        for i in range(N_STATE):
            trace.derivative[i] = trace.new_derivative[i]
        below, outside, radius = next_below, next_outside, next_radius
        steps += 1
        stopped = False
        for j in range(first_here, bifurcations):
            stopped = stopped or (sought > 0 and bifurcations_out[j, B_KIND] == sought)
        if stopped:
            end = BRANCH_STOPPED
            break
        if accepted[N_STATE] >= 1.0:
            end = BRANCH_REACHED
            break
        if accepted[N_STATE] < 0.0:
            end = BRANCH_LEFT
            break
        if bracketed and not kink:
            h = max(0.5 * length, KINK_STEP)
        else:
            bracketed = False
            h = min(2.0 * length, max_step)
        point = drive_at(structure, work, segment, accepted[N_STATE], flying)
        span = periods * TWO_PI / point.omega
        for i in range(n):
            z[i] = accepted[i] * reference[i]
        if flying:
            period_pass(point, z, phase * span, periods, work, flying, False, max_events)
            crowded = crowded_section(work, phase * span, span)
            moved_to = quiet_section(work.flight.acc, phase * span,
                                     phase * span + span) / span
        else:
            moved_to, crowded = contact_section(point, z, phase * span, periods, work,
                                                max_events)
        if crowded:
            # An event came near the section: moved to the middle of the orbit's
            # longest stretch without events, the state followed there on the orbit.
            if moved_to >= 1.0:
                moved_to -= 1.0
            start = phase * span
            if moved_to * span < start:
                flow(point, z, start, span, work, flying, max_events)
                start = 0.0
            flow(point, z, start, moved_to * span, work, flying, max_events)
            phase = moved_to
            converged, _, _ = fixed_point(point, z, phase * span, periods, work, flying,
                                          max_events, 1e-3)
            if not converged or not parameter_derivative(
                    structure, work, segment, accepted[N_STATE], z, phase, periods, flying,
                    max_events):
                end = BRANCH_LOST
                break
            if not moved_tangent(work, n, tangent, work.turned):
                end = BRANCH_LOST
                break
            for i in range(N_EXTENDED):
                tangent[i] = work.turned[i]
            for i in range(n):
                accepted[i] = z[i] / reference[i]
            for i in range(N_STATE):
                trace.derivative[i] = work.derivative[i]
    return steps, bifurcations, end, passes[0] - start_newton, passes[1] - start_map


@njit(cache=True, nogil=True, error_model="numpy")
def _edge_value(real, imag, n, kind):
    """A smooth test function at a recorded step (its multipliers ``real``,
    ``imag``)."""
    best = np.inf
    value = np.nan
    for i in range(n):
        r = real[i]
        c = imag[i]
        if kind == BIFURCATION_TORUS:
            if c <= 0.0:
                continue
            candidate = math.hypot(r, c) - 1.0
        elif c != 0.0:
            continue
        elif kind == BIFURCATION_PERIOD_DOUBLING:
            candidate = r + 1.0
        else:
            candidate = r - 1.0
        if abs(candidate) < best:
            best = abs(candidate)
            value = candidate
    return value


@njit(cache=True, nogil=True, error_model="numpy")
def _crosses_one(real0, imag0, real1, imag1, n):
    """The number of real multipliers above +1 differs between two steps."""
    above0 = 0
    above1 = 0
    for i in range(n):
        if imag0[i] == 0.0 and real0[i] > 1.0:
            above0 += 1
        if imag1[i] == 0.0 and real1[i] > 1.0:
            above1 += 1
    return above0 != above1
