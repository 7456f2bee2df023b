"""Event-driven Dormand-Prince 5(4) time integrator of the full single-plate model.

State ``y = (delta, d delta/dt, x, v)`` and a discrete contact mode: ``STICK`` (0),
forward slip (+1) or backward slip (-1). Per unit total mass, table frame::

    A(t)   = a cos(phi(t))                     drive; phi continuous across segments
    F      = A cos(alpha) - (w0/Q) delta' - w0^2 delta
    stick:             delta'' = F,                         x'' = 0
    slip s, one-way:   delta'' = F,                         x'' = tau - s ck n
    slip s, two-way:   delta'' = F - x'' sin(alpha),        x'' = tau - s ck n
    n = g - A + M cos(alpha) delta'',   tau = -M sin(alpha) delta''

Flight (the lift-off law ``flight``, two-way coupling only): the state gains the gap
``h`` between base and table and its rate ``h'`` (:data:`FLIGHT_STATE_SIZE` entries)
and the mode ``FLIGHT`` (2). Where ``n`` turns negative the base takes off
(``EVENT_LIFT_OFF``) with ``h = h' = 0``; in flight, per unit total mass::

    (1 - M) delta'' = g cos(alpha) - (w0/Q) delta' - w0^2 delta
    v'  = -M sin(alpha) delta''
    h'' = A - g - M cos(alpha) delta''

The event functions in flight are ``h'`` (the apex, where the hop's height is read) and
``h`` (the impact, ``EVENT_IMPACT``). At take-off ``h = h' = h'' = 0`` and the third
derivative of ``h`` is ``-n' > 0``: ``h'' = -n`` in flight is the contact's normal force
times ``D_s / (1 - M) > 0`` and the take-off is located where ``n < 0``, so ``h`` starts
convex upward and cannot cross zero at once; the first step after a take-off is short
(:data:`study.kernels.event_loop.TAKE_OFF_STEP`), so that the short hops near a grazing
take-off are resolved (down to about 1e-19 m). A grazing impact (``h`` dipping below
zero between two samples) is caught by the watch of its minima (where ``h'`` changes
sign). The impact law is :func:`study.kernels.impact.impact` (an impact without a
solution stops the run with ``RUN_PARADOX``); a rebound slower than
:data:`CHATTER_SPEED` ``g / w0`` lands plastically (the accumulation of ever shorter
hops of chattering ends there), and the base continues in contact by the rules below,
or takes off again at once where ``n < 0`` -- unless it landed slower than the cut-off:
that hop was below the integrator's resolution, and the base stays on the table until
``n`` crosses zero again (a grazing contact, :func:`_land`).

Two-way coupling (the sliding base's acceleration also forces the mode) solved for
the two accelerations gives ``x'' = (-M sin(alpha) F - s ck (g - A + M cos(alpha) F))
/ D_s`` with ``D_s = 1 - M sin(alpha) (sin(alpha) + s ck cos(alpha))``. ``D_s <= 0``
is Painleve's paradox (the sliding equations have no unique solution): such a slip
stops the run with status ``FRICTION_PARADOX``.

Events (stick release ``s tau > cs n``, slip end ``v = 0``, lift-off ``n < 0``) are
located on the step's dense output (Shampine's 4th-order continuous extension, as
in Hairer's DOPRI5), never by step-end sign tests alone: each event function is
sampled at ``samples`` points per step *and* watched at its minima (where its
derivative, computed from the model, changes sign), then bracketed and refined by
the Illinois method to the event tolerance (:mod:`study.kernels.events`). The
Dormand-Prince step, its error norm and dense output are :mod:`study.kernels.dopri`'s.

The loop itself is :func:`study.kernels.event_loop.make_loop`; this module gives it the
single-plate model as hooks. The kinetic coefficient is the chosen friction law's
(:func:`study.kernels.friction.kinetic_coefficient`, Coulomb's ``ck`` by default);
with a speed-dependent law the force rates that watch for dips between event samples
leave out the coefficient's own rate, and Painleve's paradox is checked with the
coefficient at the slip's speed where the slip (re)starts.

:mod:`study.solvers.integrator` validates, allocates and calls :func:`integrate`,
:func:`periodic_points` and :func:`periodic_points_serial`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit, prange

from study.kernels.dopri import dense_output, step, table_drive
from study.kernels.event_loop import (
    EventLog,
    Hooks,
    Samples,
    Segments,
    State,
    StepControl,
    make_loop,
)
from study.kernels.events import record
from study.kernels.friction import kinetic_coefficient
from study.kernels.impact import (
    IMPACT_DELTA_RATE,
    IMPACT_GAP_RATE,
    IMPACT_SIZE,
    IMPACT_VELOCITY,
    impact,
)
from study.kernels.structure_vector import (
    COS_ALPHA,
    DAMPING,
    GRAVITY,
    LIFT_OFF_LAW,
    MASS_RATIO,
    SIN_ALPHA,
    STATIC_FRICTION,
    STIFFNESS,
    TWO_WAY,
)
from study.model.codes import (
    BOUNCING,
    CONTINUOUS_SLIDING,
    EVENT_IMPACT,
    EVENT_LIFT_OFF,
    EVENT_PARADOX,
    EVENT_RELEASE_BACKWARD,
    EVENT_RELEASE_FORWARD,
    EVENT_SLIP_END,
    FRICTION_PARADOX,
    IMPACT_PARADOX,
    IMPACT_SLIP,
    IMPACT_STICK,
    LIFT_OFF,
    NOT_CONVERGED,
    REASON_EVENT_BUDGET,
    REASON_NO_PERIODIC_ORBIT,
    RUN_DONE,
    RUN_LIFT_OFF,
    RUN_PARADOX,
    STATIC,
    STICK,
    STICK_SLIP,
)

# State layout: deflection [m], its rate [m s-1], base position [m] and velocity [m s-1];
# with flight also the gap between base and table [m] and its rate [m s-1].
DELTA = 0
DELTA_RATE = 1
X = 2
V = 3
GAP = 4
GAP_RATE = 5
STATE_SIZE = 4
FLIGHT_STATE_SIZE = 6

# Modes besides STICK and the slips +1 / -1: the base in the air, and an impact without
# a solution (the run stops with RUN_PARADOX at the restart after it).
FLIGHT = 2
FAILED_IMPACT = 3

# Event functions: forward release (stick), slip end (slip) or apex (flight); backward
# release (stick) or impact (flight); lift-off (in contact).
EVENTS = 3
RELEASE_OR_SLIP_END = 0
APEX = 0
IMPACT = 1
LIFT = 2

#: A rebound slower than this, in units of g / w0, lands plastically: chattering's
#: accumulation of ever shorter hops (the k-th rebound about e^k times the first) ends
#: there, after about log(CHATTER_SPEED g / (w0 u1)) / log(e) rebounds from a first one
#: of u1 (about 30 at e = 0.5, 200 at e = 0.9). The cut-off hop is below
#: (CHATTER_SPEED g / w0)^2 / (2 g), about 1e-21 m at the paper's f0, and the landing's
#: tangential impulse differs from that of the whole sequence by at most about ck times
#: the rebound speed, 1e-10 m s-1 (the mean velocity by less).
CHATTER_SPEED = 1e-9

# sqrt(FLIGHT_STATE_SIZE / STATE_SIZE): turns the error norm over the flight state of a
# run on the table into the norm over its contact state.
CONTACT_NORM = math.sqrt(FLIGHT_STATE_SIZE / STATE_SIZE)

# Entries of the run statistics.
STEPS = 0
REJECTED = 1
SLIPS = 2
STUCK_TIME = 3
FORWARD_TIME = 4
BACKWARD_TIME = 5
AIRBORNE_TIME = 6
IMPACTS = 7
LARGEST_HOP = 8
TAKE_OFFS = 9
GRAZINGS = 10
GRAZED_AT = 11
STATS_SIZE = 12

# Entries of a periodic point's result.
R_STATUS = 0
R_REASON = 1
R_VELOCITY = 2
R_SLIPS = 3
R_FORWARD = 4
R_BACKWARD = 5
R_ORBIT_PERIOD = 6
R_PERIODS = 7
R_STEPS = 8
R_AIRBORNE = 9
R_HOP = 10
R_IMPACTS = 11
RESULT_SIZE = 12


@njit(cache=True, nogil=True)
def _accelerations(p, mode, drive, y):
    """``(delta'', x'')`` in contact mode ``mode`` (or in flight) with drive acceleration
    ``drive``."""
    if mode == FLIGHT:
        m = p[MASS_RATIO]
        free = (p[GRAVITY] * p[COS_ALPHA] - p[DAMPING] * y[DELTA_RATE]
                - p[STIFFNESS] * y[DELTA]) / (1.0 - m)
        return free, -m * p[SIN_ALPHA] * free
    forcing = drive * p[COS_ALPHA] - p[DAMPING] * y[DELTA_RATE] - p[STIFFNESS] * y[DELTA]
    if mode == STICK:
        return forcing, 0.0
    s = float(mode)
    m = p[MASS_RATIO]
    ca = p[COS_ALPHA]
    sa = p[SIN_ALPHA]
    ck = kinetic_coefficient(p, y, V)
    if p[TWO_WAY] != 0.0:
        denominator = 1.0 - m * sa * (sa + s * ck * ca)
        xdd = (-m * sa * forcing - s * ck * (p[GRAVITY] - drive + m * ca * forcing)) / denominator
        return forcing - sa * xdd, xdd
    xdd = -m * sa * forcing - s * ck * (p[GRAVITY] - drive + m * ca * forcing)
    return forcing, xdd


@njit(cache=True, nogil=True)
def _rhs(p, mode, drive, y, out):
    ddd, xdd = _accelerations(p, mode, drive, y)
    out[DELTA] = y[DELTA_RATE]
    out[DELTA_RATE] = ddd
    out[X] = y[V]
    out[V] = xdd
    if y.shape[0] > STATE_SIZE:
        if mode == FLIGHT:
            out[GAP] = y[GAP_RATE]
            out[GAP_RATE] = drive - p[GRAVITY] - p[MASS_RATIO] * p[COS_ALPHA] * ddd
        else:
            out[GAP] = 0.0
            out[GAP_RATE] = 0.0


@njit(cache=True, nogil=True)
def _forces(p, mode, drive, drive_rate_neg, y):
    """Normal and tangential force per unit mass and their time derivatives.

    ``drive_rate_neg`` is ``a w sin(phi) = -dA/dt``.
    """
    ddd, xdd = _accelerations(p, mode, drive, y)
    ca = p[COS_ALPHA]
    sa = p[SIN_ALPHA]
    m = p[MASS_RATIO]
    forcing_rate = -drive_rate_neg * ca - p[DAMPING] * ddd - p[STIFFNESS] * y[DELTA_RATE]
    dddd = forcing_rate
    if mode != STICK and p[TWO_WAY] != 0.0:
        s = float(mode)
        ck = kinetic_coefficient(p, y, V)
        denominator = 1.0 - m * sa * (sa + s * ck * ca)
        dddd = (forcing_rate + s * ck * sa * drive_rate_neg) / denominator
    n = p[GRAVITY] - drive + m * ca * ddd
    tau = -m * sa * ddd
    n_rate = drive_rate_neg + m * ca * dddd
    tau_rate = -m * sa * dddd
    return n, tau, n_rate, tau_rate, xdd


@njit(cache=True, nogil=True)
def _event_values(p, mode, drive, drive_rate_neg, y, values, rates):
    """Event functions of the current mode, each positive while nothing happens.

    stick: ``cs n - tau`` (forward release), ``cs n + tau`` (backward release);
    slip s: ``s v`` (slip end); in contact: ``n`` (lift-off); flight: ``h'`` (apex),
    ``h`` (impact).
    """
    if mode == FLIGHT:
        ddd, _ = _accelerations(p, mode, drive, y)
        values[APEX] = y[GAP_RATE]
        rates[APEX] = drive - p[GRAVITY] - p[MASS_RATIO] * p[COS_ALPHA] * ddd
        values[IMPACT] = y[GAP]
        rates[IMPACT] = y[GAP_RATE]
        values[LIFT] = 1.0
        rates[LIFT] = 0.0
        return
    n, tau, n_rate, tau_rate, xdd = _forces(p, mode, drive, drive_rate_neg, y)
    cs = p[STATIC_FRICTION]
    if mode == STICK:
        values[0] = cs * n - tau
        rates[0] = cs * n_rate - tau_rate
        values[1] = cs * n + tau
        rates[1] = cs * n_rate + tau_rate
    else:
        s = float(mode)
        values[0] = s * y[V]
        rates[0] = s * xdd
        values[1] = 1.0
        rates[1] = 0.0
    values[LIFT] = n
    rates[LIFT] = n_rate


@njit(cache=True, nogil=True)
def _step(p, mode, t, h, y, k, drive_args, y_new, err, dense, tmp):
    """One Dormand-Prince step from ``(t, y)`` with ``k[0] = f(t, y)`` (FSAL).

    Fills ``k[1..6]``, the 5th-order solution ``y_new``, the error estimate ``err``
    and the dense-output coefficients.
    """
    step(_rhs, p, mode, t, h, y, k, drive_args, y_new, err, dense, tmp)
    if mode == STICK:
        # x and v are exactly constant while stuck.
        y_new[X] = y[X]
        y_new[V] = 0.0
        err[X] = 0.0
        err[V] = 0.0
    if y.shape[0] > STATE_SIZE and mode != FLIGHT:
        # On the table the gap and its rate are exactly 0: the error norm (an RMS over
        # the state) is taken as over the contact state, as without flight.
        for i in range(STATE_SIZE):
            err[i] *= CONTACT_NORM


@njit(cache=True, nogil=True)
def _values_at(theta, p, mode, t, h, dense, drive_args, ystate, values, rates):
    seg, seg_t0, seg_omega, seg_a, seg_phase0 = drive_args
    dense_output(theta, h, dense, ystate)
    if mode == STICK:
        ystate[V] = 0.0
    drive, rate = table_drive(t + theta * h, seg, seg_t0, seg_omega, seg_a, seg_phase0)
    _event_values(p, mode, drive, rate, ystate, values, rates)


@njit(cache=True, nogil=True)
def _mode_after_rest(p, drive, y):
    """Contact mode at an instant of rest (``v = 0``) from the stick forces.

    Returns +1/-1 when ``|tau| > cs n`` (slip in the direction of ``tau``), else 0.
    """
    n, tau, _, _, _ = _forces(p, STICK, drive, 0.0, y)
    limit = p[STATIC_FRICTION] * n
    if tau > limit:
        return 1
    if -tau > limit:
        return -1
    return STICK


@njit(cache=True, nogil=True)
def _paradox(p, mode, y):
    if mode == STICK or mode == FLIGHT or p[TWO_WAY] == 0.0:
        return False
    s = float(mode)
    sa = p[SIN_ALPHA]
    ck = kinetic_coefficient(p, y, V)
    return 1.0 - p[MASS_RATIO] * sa * (sa + s * ck * p[COS_ALPHA]) <= 0.0


@njit(cache=True, nogil=True)
def _release_event(mode):
    return EVENT_RELEASE_FORWARD if mode > 0 else EVENT_RELEASE_BACKWARD


@njit(cache=True, nogil=True)
def _restart(p, mode, fresh, t, drive, rate, y, k0, values, rates, events, stats):
    """The event loop's ``restart`` hook (:data:`study.kernels.event_loop.Hooks`)."""
    if mode == FAILED_IMPACT:
        return mode, fresh, RUN_PARADOX
    if mode == STICK:
        y[V] = 0.0
        new_mode = _mode_after_rest(p, drive, y)
        if new_mode != STICK:
            mode = new_mode
            fresh = True
            stats[SLIPS] += 1.0
            record(events, t, _release_event(mode), y)
    if _paradox(p, mode, y):
        record(events, t, EVENT_PARADOX, y)
        return mode, fresh, RUN_PARADOX
    _event_values(p, mode, drive, rate, y, values, rates)
    _rhs(p, mode, drive, y, k0)
    return mode, fresh, RUN_DONE


@njit(cache=True, nogil=True)
def _prepare(p, mode, t, drive_args, y, k0, events):
    """The ``prepare`` hook: nothing to do before a step."""
    return RUN_DONE


@njit(cache=True, nogil=True)
def _hold(p, mode, before, state):
    """The ``hold`` hook: x and v are constant while stuck."""
    if mode == STICK:
        state[V] = 0.0
        state[X] = before[X]


@njit(cache=True, nogil=True)
def _account(mode, duration, stats):
    if mode == FLIGHT:
        stats[AIRBORNE_TIME] += duration
    elif mode == STICK:
        stats[STUCK_TIME] += duration
    elif mode > 0:
        stats[FORWARD_TIME] += duration
    else:
        stats[BACKWARD_TIME] += duration


@njit(cache=True, nogil=True)
def _accepted(p, mode, y):
    return mode


@njit(cache=True, nogil=True)
def _transition(p, mode, which, t, drive, y, events, stats):
    """The ``transition`` hook: a release starts a slip; a slip end sticks, or reverses
    the slip when the stick forces already exceed the static limit the other way. In
    flight: the apex records the hop; an impact lands (:func:`_land`)."""
    if mode == FLIGHT:
        if which == APEX:
            stats[LARGEST_HOP] = max(stats[LARGEST_HOP], y[GAP])
            return FLIGHT, False
        return _land(p, t, drive, y, events, stats)
    if mode == STICK:
        mode = 1 if which == RELEASE_OR_SLIP_END else -1
        stats[SLIPS] += 1.0
        record(events, t, _release_event(mode), y)
        return mode, True
    y[V] = 0.0
    record(events, t, EVENT_SLIP_END, y)
    after = _mode_after_rest(p, drive, y)
    if after == -mode:
        stats[SLIPS] += 1.0
        record(events, t, _release_event(after), y)
    # A reversal starts a fresh slip; a tangential touch continues the old one.
    return after, after == -mode


@njit(cache=True, nogil=True)
def _land(p, t, drive, y, events, stats):
    """An impact at ``t`` (``h`` reached 0 with ``h' < 0``): the impact law on
    ``(delta', v, h')``, then flight again (a rebound faster than :data:`CHATTER_SPEED`)
    or contact, in the slip of ``v``'s sign or stuck. Returns ``(mode, fresh)``.

    A landing slower than the cut-off where ``n < 0`` (the base would take off again at
    once) is a grazing contact: a hop below the integrator's resolution, whose take-off
    and landing would otherwise repeat at the rounding of ``t``. It is counted
    (``GRAZINGS``) and the base stays on the table, in the mode it lands in, until ``n``
    crosses zero again (:func:`_take_off` refuses the take-off at ``t``)."""
    stats[IMPACTS] += 1.0
    speed = -y[GAP_RATE]
    y[GAP] = 0.0
    ended = IMPACT_STICK if y[V] == 0.0 else IMPACT_SLIP
    if y[GAP_RATE] < 0.0:
        out = np.empty(IMPACT_SIZE)
        ended = impact(p, y[DELTA_RATE], y[V], y[GAP_RATE], out)
        if ended == IMPACT_PARADOX:
            record(events, t, EVENT_PARADOX, y)
            return FAILED_IMPACT, False
        y[DELTA_RATE] = out[IMPACT_DELTA_RATE]
        y[V] = out[IMPACT_VELOCITY]
        y[GAP_RATE] = out[IMPACT_GAP_RATE]
    if y[GAP_RATE] > CHATTER_SPEED * p[GRAVITY] / math.sqrt(p[STIFFNESS]):
        record(events, t, EVENT_IMPACT, y)
        return FLIGHT, False
    y[GAP_RATE] = 0.0
    if ended == IMPACT_STICK:
        y[V] = 0.0
    record(events, t, EVENT_IMPACT, y)
    mode = STICK
    if y[V] > 0.0:
        mode = 1
    elif y[V] < 0.0:
        mode = -1
    if speed < CHATTER_SPEED * p[GRAVITY] / math.sqrt(p[STIFFNESS]):
        n, _, _, _, _ = _forces(p, mode, drive, 0.0, y)
        if n < 0.0:
            stats[GRAZINGS] += 1.0
            stats[GRAZED_AT] = t
    return mode, False


@njit(cache=True, nogil=True)
def _take_off(p, mode, t, drive, y, events, stats):
    """The ``take_off`` hook: with the lift-off law ``stop`` the run ends with
    ``RUN_LIFT_OFF``; with ``flight`` the base leaves the table (``h = h' = 0``), unless
    it has just made a grazing landing at ``t`` (:func:`_land`)."""
    if p[LIFT_OFF_LAW] == 0.0 or y.shape[0] < FLIGHT_STATE_SIZE:
        record(events, t, EVENT_LIFT_OFF, y)
        return mode, False, RUN_LIFT_OFF
    if stats[GRAZINGS] > 0.0 and t == stats[GRAZED_AT]:
        return mode, mode != STICK and y[V] == 0.0, RUN_DONE
    record(events, t, EVENT_LIFT_OFF, y)
    if mode == STICK:
        y[V] = 0.0
    y[GAP] = 0.0
    y[GAP_RATE] = 0.0
    stats[TAKE_OFFS] += 1.0
    # Fresh: the apex function h' starts at 0 and rises.
    return FLIGHT, True, RUN_DONE


@njit(cache=True, nogil=True)
def _at_rest(y):
    if y.shape[0] > STATE_SIZE and (y[GAP] != 0.0 or y[GAP_RATE] != 0.0):
        return False
    return y[V] == 0.0


_loop = make_loop(Hooks(_restart, _prepare, _step, _values_at, _hold, _account, _accepted,
                        _transition, _at_rest, EVENTS, LIFT, _take_off))


@njit(cache=True, nogil=True)
def integrate(p, segments, state, t_stop, control, samples, events, stats):
    """Integrate the single-plate model with structure vector ``p`` from
    ``state.clock[0]`` to ``t_stop``, in place (:func:`study.kernels.event_loop.make_loop`).

    ``state.y`` has :data:`STATE_SIZE` entries, or :data:`FLIGHT_STATE_SIZE` with the
    lift-off law ``flight`` (``p[LIFT_OFF_LAW] = 1``). ``stats`` (:data:`STATS_SIZE`
    entries) accumulates steps, rejected steps, slips, the time stuck, slipping forward
    and slipping backward [s], and with flight the time airborne [s], impacts, the
    largest hop [m] (the highest apex) and take-offs. Returns a ``RUN_*`` code.
    """
    return _loop(p, segments, state, t_stop, control, samples, events, stats)


#: The points of :func:`periodic_points`, one entry (or row) each: drive ``omega``
#: [rad s-1] and ``amplitude`` [m s-2], start state ``y0`` (rows), tolerance ``scale``
#: (rows), ``fixed_step``, ``max_step`` and ``xtol_time`` [s].
Points = namedtuple("Points", "omega amplitude y0 scale fixed_step max_step xtol_time")

#: Settings shared by every point: tolerances ``rtol``, ``atol`` [1], event ``samples``
#: per step, ``max_steps`` per period, ``max_periods``, ``max_orbit`` (longest orbit
#: period looked for [periods]) and ``period_tolerance`` [1].
PeriodicSearch = namedtuple(
    "PeriodicSearch", "rtol atol samples max_steps max_periods max_orbit period_tolerance")


@njit(cache=True, nogil=True)
def _periodic_point(p, omega, amplitude, y0, scale, fixed_step, max_step, xtol_time, search,
                    result):
    """Integrate whole drive periods until the state repeats; mean velocity of the orbit.

    The state at each period boundary (``delta``, ``delta'``, ``v``, with flight (``y0``
    of :data:`FLIGHT_STATE_SIZE` entries) also ``h`` and ``h'``, and the mode) and
    the displacement over the period are kept for the last ``max_orbit`` periods; the
    orbit is periodic with period ``q`` once the boundary state and the displacement
    repeat after ``q`` periods within ``period_tolerance`` (in units of ``scale``).
    Time restarts at zero each period (phase ``2 pi k`` is phase 0), so the phase
    keeps full precision however many periods are needed.

    ``result`` (:data:`RESULT_SIZE` entries, named ``R_*``) receives ``[status, reason,
    velocity, slips per period, forward fraction, backward fraction, orbit period,
    periods integrated, steps, airborne fraction, largest hop [m], impacts per period]``
    (the last three 0 without flight). An orbit with flight is ``BOUNCING``.
    """
    period = 2.0 * math.pi / omega
    segments = Segments(np.zeros(1), np.full(1, omega), np.full(1, amplitude), np.zeros(1),
                        np.full(1, np.inf))
    n = y0.shape[0]
    compared = 5 if n > STATE_SIZE else 3
    y = y0.copy()
    mode_box = np.zeros(1, dtype=np.int64)
    if n > STATE_SIZE and (y[GAP] > 0.0 or y[GAP_RATE] != 0.0):
        mode_box[0] = FLIGHT
    elif y[V] > 0.0:
        mode_box[0] = 1
    elif y[V] < 0.0:
        mode_box[0] = -1
    state = State(y, mode_box, np.array([0.0, max_step]))
    control = StepControl(search.rtol, search.atol, scale, fixed_step, max_step, xtol_time,
                          search.samples, search.max_steps)
    samples = Samples(np.empty(0), np.empty((0, n)), np.empty(0, dtype=np.int64),
                      np.zeros(1, dtype=np.int64))
    events = EventLog(np.empty(0), np.empty(0, dtype=np.int64), np.empty((0, n)),
                      np.zeros(1, dtype=np.int64))
    max_orbit = search.max_orbit
    ring = max_orbit + 1
    hist_state = np.empty((ring, compared))
    hist_mode = np.empty(ring, dtype=np.int64)
    hist_disp = np.empty(ring)
    hist_stats = np.empty((ring, STATS_SIZE))
    stats = np.zeros(STATS_SIZE)
    steps_total = 0.0
    for i in range(RESULT_SIZE):
        result[i] = 0.0
    for k in range(search.max_periods):
        y[X] = 0.0
        state.clock[0] = 0.0
        for i in range(STATS_SIZE):
            stats[i] = 0.0
        code = integrate(p, segments, state, period, control, samples, events, stats)
        steps_total += stats[STEPS]
        result[R_PERIODS] = k + 1
        result[R_STEPS] = steps_total
        if code != RUN_DONE:
            result[R_VELOCITY] = np.nan
            result[R_SLIPS] = np.nan
            result[R_FORWARD] = np.nan
            result[R_BACKWARD] = np.nan
            result[R_AIRBORNE] = np.nan
            result[R_HOP] = np.nan
            result[R_IMPACTS] = np.nan
            if code == RUN_LIFT_OFF:
                result[R_STATUS] = LIFT_OFF
            elif code == RUN_PARADOX:
                result[R_STATUS] = FRICTION_PARADOX
            else:
                result[R_STATUS] = NOT_CONVERGED
                result[R_REASON] = REASON_EVENT_BUDGET
            return
        slot = k % ring
        hist_state[slot, 0] = y[DELTA]
        hist_state[slot, 1] = y[DELTA_RATE]
        hist_state[slot, 2] = y[V]
        if compared > 3:
            hist_state[slot, 3] = y[GAP]
            hist_state[slot, 4] = y[GAP_RATE]
        hist_mode[slot] = mode_box[0]
        hist_disp[slot] = y[X]
        for i in range(STATS_SIZE):
            hist_stats[slot, i] = stats[i]
        for q in range(1, max_orbit + 1):
            if k < q:
                break
            other = (k - q) % ring
            if hist_mode[other] != hist_mode[slot]:
                continue
            gap = max(
                abs(hist_state[slot, 0] - hist_state[other, 0]) / scale[DELTA],
                abs(hist_state[slot, 1] - hist_state[other, 1]) / scale[DELTA_RATE],
                abs(hist_state[slot, 2] - hist_state[other, 2]) / scale[V],
                abs(hist_disp[slot] - hist_disp[other]) / scale[X],
            )
            if compared > 3:
                gap = max(gap,
                          abs(hist_state[slot, 3] - hist_state[other, 3]) / scale[GAP],
                          abs(hist_state[slot, 4] - hist_state[other, 4]) / scale[GAP_RATE])
            if not gap <= search.period_tolerance:
                continue
            distance = 0.0
            slips = 0.0
            stuck = 0.0
            forward = 0.0
            backward = 0.0
            airborne = 0.0
            hop = 0.0
            impacts = 0.0
            for back in range(q):
                r = (k - back) % ring
                distance += hist_disp[r]
                slips += hist_stats[r, SLIPS]
                stuck += hist_stats[r, STUCK_TIME]
                forward += hist_stats[r, FORWARD_TIME]
                backward += hist_stats[r, BACKWARD_TIME]
                airborne += hist_stats[r, AIRBORNE_TIME]
                hop = max(hop, hist_stats[r, LARGEST_HOP])
                impacts += hist_stats[r, IMPACTS]
            span = q * period
            if airborne > 0.0:
                result[R_STATUS] = BOUNCING
                result[R_VELOCITY] = distance / span
            elif slips == 0.0 and forward == 0.0 and backward == 0.0:
                result[R_STATUS] = STATIC
                result[R_VELOCITY] = 0.0
            else:
                # A stick counts when it lasts longer than the event tolerance.
                result[R_STATUS] = STICK_SLIP if stuck > q * xtol_time else CONTINUOUS_SLIDING
                result[R_VELOCITY] = distance / span
            result[R_SLIPS] = slips / q
            result[R_FORWARD] = forward / span
            result[R_BACKWARD] = backward / span
            result[R_AIRBORNE] = airborne / span
            result[R_HOP] = hop
            result[R_IMPACTS] = impacts / q
            result[R_ORBIT_PERIOD] = q
            return
    result[R_STATUS] = NOT_CONVERGED
    result[R_REASON] = REASON_NO_PERIODIC_ORBIT
    result[R_VELOCITY] = np.nan
    result[R_SLIPS] = np.nan
    result[R_FORWARD] = np.nan
    result[R_BACKWARD] = np.nan
    result[R_AIRBORNE] = np.nan
    result[R_HOP] = np.nan
    result[R_IMPACTS] = np.nan


@njit(cache=True, nogil=True, parallel=True)
def periodic_points(p, points, search, results):
    """:func:`_periodic_point` for every point of ``points`` (:data:`Points`), in
    parallel (interleaved lanes); ``results`` has one row per point."""
    n = points.omega.shape[0]
    lanes = min(n, 256)
    for lane in prange(lanes):
        for i in range(lane, n, lanes):
            _periodic_point(
                p, points.omega[i], points.amplitude[i], points.y0[i], points.scale[i],
                points.fixed_step[i], points.max_step[i], points.xtol_time[i], search,
                results[i],
            )


@njit(cache=True, nogil=True)
def periodic_points_serial(p, points, search, results):
    """Same as :func:`periodic_points` on the calling thread."""
    for i in range(points.omega.shape[0]):
        _periodic_point(
            p, points.omega[i], points.amplitude[i], points.y0[i], points.scale[i],
            points.fixed_step[i], points.max_step[i], points.xtol_time[i], search,
            results[i],
        )
