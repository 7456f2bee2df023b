"""A run of the orbit over events: the state followed from one time to another.

Each piece is closed form in its contact mode (:mod:`~study.kernels.two_way.propagation`)
up to its first event (:mod:`~study.kernels.two_way.event_search`); at the event the
next mode is decided and the flow's Jacobian is multiplied by the saltation matrix.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from study.kernels.one_way import sin_minus_x
from study.kernels.structure_vector import (
    COS_ALPHA,
    DAMPING,
    GRAVITY,
    KINETIC_FRICTION,
    MASS_RATIO,
    SIN_ALPHA,
    STATIC_FRICTION,
    STIFFNESS,
)
from study.kernels.two_way.event_search import (
    EV_LIFT_OFF,
    EV_RELEASE_BACKWARD,
    EV_RELEASE_FORWARD,
    EV_SLIP_END,
    NUDGE,
    PieceStart,
    SearchLimits,
    search,
)
from study.kernels.two_way.modes import M_D, M_K, M_SIGN, TWO_PI
from study.kernels.two_way.propagation import (
    homogeneous,
    mode_acceleration,
    one_minus_cos,
    particular,
    slip_acceleration,
    stick_releases,
)

# Outcome of a stretch of the orbit.
RUN_OK = 0
RUN_LIFT_OFF = 1
RUN_PARADOX = 2
RUN_BUDGET = 3

# A slip shorter than this fraction of the orbit's span is a sliver (see newton).
SLIVER = 1e-6

# Accumulator slots of a stretch.
A_DISPLACEMENT = 0
A_SLIPS = 1
A_FORWARD = 2
A_BACKWARD = 3
A_STICK = 4
A_EVENTS = 5
A_STEPS = 6
A_SHORTEST = 7  # shortest slip of the stretch that is not cut by its ends [s]
A_START_SLIVER = 8  # 1: the stretch starts in a slip that is a sliver
A_LIFTED = 9  # 1: the normal force fell below -lift_margin (a run that notes lift-off)
N_ACC = 10

#: What a run records: ``acc`` (``N_ACC`` accumulators, the ``A_*`` slots), ``jac``
#: (3x3, multiplied on the left by the flow's Jacobian), ``grad`` (3x3, rows: the
#: gradients of the displacement and of the forward and backward slip times with
#: respect to the state ``jac`` started from) and ``passes`` (2: the runs made with
#: this record, with the Jacobian and without: the work a point took).
PassRecord = namedtuple("PassRecord", ("acc", "jac", "grad", "passes"))
# The state at an event: cosine and sine of the drive phase, delta [m], delta' [m s-1].
EventState = namedtuple("EventState", ("cw", "sw", "dl", "dld"))


@njit(cache=True, nogil=True, error_model="numpy")
def _mat_left(jac, r00, r01, r02, r10, r11, r12, r20, r21, r22):
    """``jac <- R jac`` for the 3x3 matrix ``R`` given by rows."""
    for col in range(3):
        x0 = jac[0, col]
        x1 = jac[1, col]
        x2 = jac[2, col]
        jac[0, col] = r00 * x0 + r01 * x1 + r02 * x2
        jac[1, col] = r10 * x0 + r11 * x1 + r12 * x2
        jac[2, col] = r20 * x0 + r21 * x1 + r22 * x2


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _initial_mode(structure, omega, a, t, z):
    """Contact mode of state ``z`` at ``t``: the sign of ``v``, or the stick test."""
    if z[2] > 0.0:
        return 1
    if z[2] < 0.0:
        return -1
    r_p, r_m, _ = stick_releases(structure, a, math.cos(omega * t), z[0], z[1])
    # Both positive only off the table (n < 0): the larger wins, as the mirror image
    # alpha -> -alpha swaps them.
    if r_p > 0.0 and r_p >= r_m:
        return 1
    if r_m > 0.0:
        return -1
    return 0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _release_saltation(structure, rown, omega, a, event, acc0, jac, ds):
    """A release from a stick into the slip of ``rown`` (its mode table row) at the
    :data:`EventState` ``event``, the stick's ``delta'' = acc0`` [m s-2]: ``jac`` is
    multiplied on the left by the saltation matrix. Returns the gradient of the slip's
    start time with respect to the state ``jac`` started from (``ds`` as given when the
    release function does not rise)."""
    new = rown[M_SIGN]
    cwe, swe, dl, dld = event
    ds0, ds1, ds2 = ds
    accn = mode_acceleration(structure, rown, cwe, dl, dld)
    vdot = slip_acceleration(structure, rown, a, cwe, accn)
    m = structure[MASS_RATIO]
    kap = -m * (new * structure[SIN_ALPHA]
                + structure[STATIC_FRICTION] * structure[COS_ALPHA])
    # Gradient of s tau - cs n in (delta, delta'); time rate along the stick.
    g_d = -kap * structure[STIFFNESS]
    g_dd = -kap * structure[DAMPING]
    ddd_rate = (-a * omega * swe * structure[COS_ALPHA]
                - structure[DAMPING] * acc0 - structure[STIFFNESS] * dld)
    rate = kap * ddd_rate - structure[STATIC_FRICTION] * a * omega * swe
    if rate > 0.0:
        q = 1.0 / rate
        ds0 = -(g_d * jac[0, 0] + g_dd * jac[1, 0]) * q
        ds1 = -(g_d * jac[0, 1] + g_dd * jac[1, 1]) * q
        ds2 = -(g_d * jac[0, 2] + g_dd * jac[1, 2]) * q
        jump = accn - acc0
        _mat_left(jac, 1.0, 0.0, 0.0,
                  jump * g_d * q, 1.0 + jump * g_dd * q, 0.0,
                  vdot * g_d * q, vdot * g_dd * q, 1.0)
    return ds0, ds1, ds2


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _slip_tangent(structure, row, a, kind, tau, propagator, event, jac, grad, ds):
    """``jac`` and ``grad`` (of :data:`PassRecord`) over a slip piece of ``tau`` [s] in
    the mode of ``row`` ending at the :data:`EventState` ``event`` (event ``kind``),
    ``propagator`` its ``(e11, e12, e21, e22)`` and ``ds`` the gradient of the slip's
    start time. Returns the gradient of the next slip's start time: this slip's end
    time when it ends at rest (a reversal may follow), else 0."""
    e11, e12, e21, e22 = propagator
    cwe, _, dl, dld = event
    ds0, ds1, ds2 = ds
    s = row[M_SIGN]
    kk = row[M_K]
    # The displacement's gradient at fixed ends (v = 0 at event ends).
    gx0 = -kk * (e11 - 1.0)
    gx1 = -kk * (e12 - tau)
    for col in range(3):
        grad[0, col] += gx0 * jac[0, col] + gx1 * jac[1, col] + tau * jac[2, col]
    _mat_left(jac, e11, e12, 0.0, e21, e22, 0.0,
              -kk * e21, -kk * (e22 - 1.0), 1.0)
    # The slip time's gradient: end time minus start time.
    which = 1 if s > 0 else 2
    grad[which, 0] -= ds0
    grad[which, 1] -= ds1
    grad[which, 2] -= ds2
    ds0 = 0.0
    ds1 = 0.0
    ds2 = 0.0
    if kind == EV_SLIP_END:
        v_rate = slip_acceleration(
            structure, row, a, cwe,
            mode_acceleration(structure, row, cwe, dl, dld))
        if v_rate != 0.0:
            ds0 = -jac[2, 0] / v_rate
            ds1 = -jac[2, 1] / v_rate
            ds2 = -jac[2, 2] / v_rate
        grad[which, 0] += ds0
        grad[which, 1] += ds1
        grad[which, 2] += ds2
    return ds0, ds1, ds2


@njit(cache=True, nogil=True, error_model="numpy")
def run(point, z, t_begin, t_stop, record, want_jac, lift_margin, max_events,
        note_lift_off=False):
    """Follow the state ``z`` (in place) at the drive point ``point`` (a
    :data:`~study.kernels.two_way.modes.DrivePoint`) from ``t_begin`` to ``t_stop`` [s].

    ``record`` (a :data:`PassRecord`): ``acc`` receives the displacement [m], slips,
    forward/backward slip and stick time [s] and events; ``jac`` is multiplied on the
    left by the flow's Jacobian when ``want_jac``, and the rows of ``grad`` receive the
    gradients of the displacement and of the forward and backward slip times. Lift-off
    is watched when ``lift_margin >= 0``: ``n < -lift_margin`` [m s-2] ends the
    stretch, or, when ``note_lift_off``, sets ``acc[A_LIFTED]`` and the stretch goes on
    as the contact model (Newton's method continued along a sweep wants the whole pass
    and its residual: how near the orbit the state that lifted off was). At most
    ``max_events`` events are followed.

    One loop over the pieces, kept whole: a piece's end state, its statistics and the
    event's decision share the piece's start, propagator and drive phase (the saltations
    and the slip's tangent are split out).

    Returns
    -------
    int
        ``RUN_OK``, ``RUN_LIFT_OFF``, ``RUN_PARADOX`` or ``RUN_BUDGET``.
    """
    structure = point.structure
    table = point.table
    omega = point.omega
    a = point.a
    acc = record.acc
    jac = record.jac
    grad = record.grad
    record.passes[0 if want_jac else 1] += 1.0
    horizon = max(abs(t_stop), TWO_PI / omega)
    t = t_begin
    mode = _initial_mode(structure, omega, a, t, z)
    if mode != 0:
        if table[1 if mode > 0 else 2, M_D] <= 0.0:
            return RUN_PARADOX
        if z[2] == 0.0:
            acc[A_SLIPS] += 1.0
    events = 0
    # Where the next search starts looking (after a slip that could not move).
    t_from = t
    # Cosine and sine of the drive phase at t_trig (reused at the next piece's start).
    t_trig = np.nan
    cw = 1.0
    sw = 0.0
    # Gradient of the current slip's start time with respect to the initial state.
    ds0 = 0.0
    ds1 = 0.0
    ds2 = 0.0
    while t < t_stop:
        events += 1
        if events > max_events:
            acc[A_EVENTS] += events
            return RUN_BUDGET
        j = 0 if mode == 0 else (1 if mode > 0 else 2)
        row = table[j]
        if t != t_trig:
            cw = math.cos(omega * t)
            sw = math.sin(omega * t)
        dp, dpd, _, _ = particular(row, omega, cw, sw)
        h0 = z[0] - dp
        hd0 = z[1] - dpd
        v0 = z[2]
        dd0 = z[1]
        if mode == 0:
            mask = EV_RELEASE_FORWARD | EV_RELEASE_BACKWARD
        else:
            mask = EV_SLIP_END
        if lift_margin >= 0.0:
            mask |= EV_LIFT_OFF
        kind, te, steps = search(
            structure, row, omega, a, PieceStart(t, sw, h0, hd0, v0, dd0), mask,
            SearchLimits(max(t, t_from), t_stop, horizon,
                         structure[GRAVITY] + max(lift_margin, 0.0)))
        acc[A_STEPS] += steps
        if kind < 0:
            acc[A_EVENTS] += events
            return RUN_BUDGET
        if kind == EV_LIFT_OFF:
            if not note_lift_off:
                acc[A_EVENTS] += events
                return RUN_LIFT_OFF
            # Noted; the piece is searched on from te for its own events (none came
            # before te), lift-off no longer watched.
            acc[A_LIFTED] = 1.0
            lift_margin = -1.0
            t_from = te
            events -= 1
            continue
        tau = te - t
        h, hd, e11, e12, e21, e22 = homogeneous(row, tau, h0, hd0)
        ph = omega * te
        cwe = math.cos(ph)
        swe = math.sin(ph)
        dpe, dpde, _, _ = particular(row, omega, cwe, swe)
        dl = dpe + h
        dld = dpde + hd
        if mode == 0:
            acc[A_STICK] += tau
            z[0] = dl
            z[1] = dld
            z[2] = 0.0
            if want_jac:
                _mat_left(jac, e11, e12, 0.0, e21, e22, 0.0, 0.0, 0.0, 0.0)
        else:
            s = row[M_SIGN]
            kk = row[M_K]
            ck = structure[KINETIC_FRICTION]
            g = structure[GRAVITY]
            tw = omega * tau
            # v and the displacement over the slip, cancellation-free in tau.
            dsin = (cw * math.sin(tw) - sw * one_minus_cos(tw)) / omega
            v_end = v0 - kk * (dld - dd0) - s * ck * g * tau + s * ck * a * dsin
            # integral of (sin wt - sin wt0) / w dt = [cw0 (1 - cos) + sw0 (sin - tw)] / w^2
            iint = (cw * one_minus_cos(tw) + sw * sin_minus_x(tw, math.sin(tw))) / (omega * omega)
            dp_full = (dpe - dp) - dpd * tau  # particular: delta1 - delta0 - delta0' tau
            dh_full = (h - h0) - hd0 * tau
            displacement = (v0 * tau - kk * (dp_full + dh_full) - 0.5 * s * ck * g * tau * tau
                            + s * ck * a * iint)
            acc[A_DISPLACEMENT] += displacement
            if kind == EV_SLIP_END and (tau < acc[A_SHORTEST] or acc[A_SHORTEST] == 0.0):
                acc[A_SHORTEST] = tau
            if kind == EV_SLIP_END and v0 != 0.0 and t == t_begin and (
                    tau < SLIVER * (t_stop - t_begin)):
                acc[A_START_SLIVER] = 1.0
            if s > 0:
                acc[A_FORWARD] += tau
            else:
                acc[A_BACKWARD] += tau
            z[0] = dl
            z[1] = dld
            z[2] = 0.0 if kind == EV_SLIP_END else v_end
            if want_jac:
                ds0, ds1, ds2 = _slip_tangent(
                    structure, row, a, kind, tau, (e11, e12, e21, e22),
                    EventState(cwe, swe, dl, dld), jac, grad, (ds0, ds1, ds2))
        t = te
        t_trig = te
        cw = cwe
        sw = swe
        if kind == 0:
            break
        # An event at te: decide the next contact mode and apply the saltation.
        r_p, r_m, acc0 = stick_releases(structure, a, cwe, dl, dld)
        if mode == 0:
            new = 1 if kind == EV_RELEASE_FORWARD else -1
            jn = 1 if new > 0 else 2
            if table[jn, M_D] <= 0.0:
                acc[A_EVENTS] += events
                return RUN_PARADOX
            acc[A_SLIPS] += 1.0
            if want_jac:
                ds0, ds1, ds2 = _release_saltation(
                    structure, table[jn], omega, a, EventState(cwe, swe, dl, dld), acc0, jac,
                    (ds0, ds1, ds2))
            mode = new
        else:
            s = int(row[M_SIGN])
            accm = mode_acceleration(structure, row, cwe, dl, dld)
            vdot_minus = slip_acceleration(structure, row, a, cwe, accm)
            if (s > 0 and r_m > 0.0) or (s < 0 and r_p > 0.0):
                new = -s
            else:
                new = 0
            if new != 0:
                jn = 1 if new > 0 else 2
                if table[jn, M_D] <= 0.0:
                    acc[A_EVENTS] += events
                    return RUN_PARADOX
                acc[A_SLIPS] += 1.0
                rown = table[jn]
                accp = mode_acceleration(structure, rown, cwe, dl, dld)
                vdot_plus = slip_acceleration(structure, rown, a, cwe, accp)
            else:
                accp = acc0
                vdot_plus = 0.0
            if want_jac and vdot_minus != 0.0:
                q = 1.0 / vdot_minus
                _mat_left(jac, 1.0, 0.0, 0.0,
                          0.0, 1.0, (accp - accm) * q,
                          0.0, 0.0, vdot_plus * q)
            if new == 0 and tau == 0.0:
                # The slip could not move: do not release it again at once.
                t_from = te + NUDGE * TWO_PI / omega
            mode = new
    acc[A_EVENTS] += events
    return RUN_OK
