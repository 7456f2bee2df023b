"""Flight, take-off and impact: a run of the orbit with the base free to leave the table.

State ``z = (delta, delta', v, h, h')`` (``h`` the gap between base and table, 0 with
``h' = 0`` in contact). In flight (no contact force) the mode is a free damped
oscillator of the two bodies, the flight row of the mode table (:func:`flight_row`)::

    (1 - M) delta'' + c delta' + k delta = g cos(alpha)
    v = v0 - M sin(alpha) (delta' - delta'_0)
    h' = h'_0 - g tau + (a/w) (sin wt - sin wt0) - M cos(alpha) (delta' - delta'_0)
    h  = h_0 + h'_0 tau - g tau^2/2 + (a/w^2) (cos wt0 - cos wt) - (a/w) sin(wt0) tau
         - M cos(alpha) (delta - delta_0 - delta'_0 tau)

all closed form. Take-off is the contact modes' lift-off event (``n`` reaching 0); there
``h = h' = h'' = 0`` and ``h''' = -n' >= 0``, so no impact can come before the first
root of the quartic lower bound ``h'' tau^2/2 + h''' tau^3/6 - B4 tau^4/24`` (``B4``
bounds ``|h''''|`` for the rest of the flight: the oscillator's energy never grows),
from where the impact (the first zero of ``h``) is sought by the bound stepping of
:mod:`~study.kernels.two_way.event_search` on ``-h``. An impact applies the impact law
(:mod:`study.kernels.impact`); the base then lands in the contact mode the existing
rules choose (or takes off again at once where that mode's ``n < 0``), or flies again
when it rebounds (restitution ``e > 0``) faster than ``CHATTER max(1 - e, 0.01)`` of
its natural speed ``(g + a) / w`` and not within ``CHATTER_TIME`` periods of its last
rebound; otherwise the impact is redone plastically (the cut-off of chattering, see
:data:`CHATTER`).

The run's Jacobian is the product of 5x5 flow matrices (the contact modes' with the
gap rows zero, the flight's propagator with the linear maps of ``v``, ``h``, ``h'``),
the contact events' saltation matrices, the identity at take-off (the contact force
vanishes there: the vector field is continuous) and the impact's saltation
``S = Dg + (f+ - Dg f-) e_h^T / h'_-`` with ``Dg`` from
:func:`study.kernels.impact.impact_jacobian`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from study.kernels.impact import (
    IMPACT_DELTA_RATE,
    IMPACT_GAP_RATE,
    IMPACT_SIZE,
    IMPACT_VELOCITY,
    impact,
    impact_jacobian,
)
from study.kernels.one_way import sin_minus_x
from study.kernels.structure_vector import (
    COS_ALPHA,
    DAMPING,
    GRAVITY,
    KINETIC_FRICTION,
    MASS_RATIO,
    RESTITUTION,
    SIN_ALPHA,
    STATIC_FRICTION,
    STIFFNESS,
)
from study.kernels.two_way.event_search import (
    EV_LIFT_OFF,
    EV_RELEASE_BACKWARD,
    EV_RELEASE_FORWARD,
    EV_SLIP_END,
    MAX_SEARCH_STEPS,
    NUDGE,
    PieceStart,
    SearchLimits,
    bounded_step,
    search,
)
from study.kernels.two_way.modes import (
    EPS,
    M_CD,
    M_D,
    M_FORCE,
    M_GCONST,
    M_K,
    M_KD,
    M_NU2,
    M_OFFSET,
    M_PIM,
    M_PRE,
    M_SIGMA,
    M_SIGN,
    TWO_PI,
    functional_bound,
)
from study.kernels.two_way.orbit import (
    A_BACKWARD,
    A_DISPLACEMENT,
    A_EVENTS,
    A_FORWARD,
    A_SHORTEST,
    A_SLIPS,
    A_START_SLIVER,
    A_STEPS,
    A_STICK,
    N_ACC,
    RUN_BUDGET,
    RUN_OK,
    RUN_PARADOX,
    SLIVER,
)
from study.kernels.two_way.propagation import (
    homogeneous,
    mode_acceleration,
    one_minus_cos,
    particular,
    slip_acceleration,
    stick_releases,
)
from study.model.codes import IMPACT_PARADOX, IMPACT_STICK

#: Row of the flight mode in a mode table of :data:`N_ROWS` rows (after stick, forward
#: and backward slip).
FLIGHT_ROW = 3
N_ROWS = 4
#: The flight's contact mode code beside stick (0) and slip (+1, -1).
FLY = 2
#: Size of the state ``(delta, delta', v, h, h')`` and the gap's slots in it.
N_STATE = 5
Z_GAP = 3
Z_GAP_RATE = 4
# Columns of the flight row holding the bounds of the mode's 2nd, 3rd and 4th
# derivatives per unit energy norm, times M |cos(alpha)| (the gap's share). The flight
# row has no event functions of the contact modes: their bound columns are free.
F_HOM2 = 12
F_HOM3 = 13
F_HOM4 = 14
# Rebounds slower than CHATTER max(1 - e, 0.01) (g + a) / w land plastically (the impact
# is redone with e = 0, friction included): the cut-off of
# chattering (the impacts of a rebounding base accumulate in finite time, like a
# bouncing ball's). The bounces cut off would have lasted about 2 u / (g_eff (1 - e))
# for a rebound speed u, at most ~2 CHATTER (g + a) / (w g_eff), 1e-7 of a period for
# g_eff ~ g: over that time the base is on the table within the rebounds' heights
# (~u^2 / g), so landing at once moves the orbit by about that fraction. The number of
# impacts of one chatter grows like log(CHATTER (1 - e)) / log(e) (e = 0.5: ~25,
# e = 0.9: ~170).
CHATTER = 1e-7
# A rebound that lands again within this fraction of a drive period lands plastically
# too: with friction, Newton's restitution law can feed a chatter (each rebound as fast
# as the last, flights of ~1e-9 periods at M = 0.6, e = 0.9) whose impacts never reach
# the speed cut-off; its hops are ~1e-19 m, the base is on the table.
CHATTER_TIME = 1e-8

# Accumulator slots of a run with flight, after those of orbit.run.
A_AIRBORNE = N_ACC  # time in flight [s]
A_IMPACTS = N_ACC + 1
A_HOP = N_ACC + 2  # largest gap [m] (only when asked)
# The events' times: how many, the first and the last [s], and the longest stretch
# between two of them [s] with its midpoint [s] (see flight_orbit.quiet_section).
A_EVENT_COUNT = N_ACC + 3
A_FIRST_EVENT = N_ACC + 4
A_LAST_EVENT = N_ACC + 5
A_QUIET_GAP = N_ACC + 6
A_QUIET_MID = N_ACC + 7
N_FLIGHT_ACC = N_ACC + 8

#: What a run with flight records: ``acc`` (``N_FLIGHT_ACC`` accumulators), ``jac``
#: (5x5, multiplied on the left by the flow's Jacobian), ``step`` and ``scratch`` (5x5
#: work space), ``passes`` (2: the orbit search's passes with the Jacobian and without,
#: counted by :mod:`~study.kernels.two_way.flight_orbit`).
FlightRecord = namedtuple("FlightRecord", ("acc", "jac", "step", "scratch", "passes"))

#: The start of a flight piece: time ``t0`` [s], cosine and sine of the drive phase,
#: the mode's homogeneous state ``(h0, hd0)`` [m, m s-1] about its offset, ``delta'``
#: [m s-1], the gap and its rate [m, m s-1] and ``v`` [m s-1].
FlightStart = namedtuple("FlightStart",
                         ("t0", "cw0", "sw0", "h0", "hd0", "dd0", "gap0", "gap_rate0", "v0"))


@njit(cache=True, nogil=True, error_model="numpy")
def flight_row(structure, table):
    """Fill row :data:`FLIGHT_ROW` of ``table``: the free oscillator of the two bodies,
    ``(1 - M) delta'' + c delta' + k delta = g cos(alpha)`` (``M < 1``), with
    ``K = M sin(alpha)`` (``v' = -K delta''``) and the bounds of the gap's derivatives."""
    row = table[FLIGHT_ROW]
    c = structure[DAMPING]
    k = structure[STIFFNESS]
    m = structure[MASS_RATIO]
    ca = structure[COS_ALPHA]
    d = 1.0 - m
    sigma = 0.5 * c / d
    row[:] = 0.0
    row[M_D] = d
    row[M_SIGMA] = sigma
    row[M_KD] = k / d
    row[M_CD] = c / d
    row[M_NU2] = k / d - sigma * sigma
    row[M_PRE] = 0.0
    row[M_PIM] = 0.0
    row[M_GCONST] = structure[GRAVITY] * ca
    row[M_FORCE] = 0.0
    row[M_OFFSET] = row[M_GCONST] / k
    row[M_K] = m * structure[SIN_ALPHA]
    row[M_SIGN] = 0.0
    share = m * abs(ca)
    row[F_HOM2] = share * functional_bound(row, 1.0, 0.0, k, 2)
    row[F_HOM3] = share * functional_bound(row, 1.0, 0.0, k, 3)
    row[F_HOM4] = share * functional_bound(row, 1.0, 0.0, k, 4)


@njit(cache=True, nogil=True, error_model="numpy")
def flight_at(structure, row, omega, a, start, t):
    """The flight piece from ``start`` (:data:`FlightStart`) at ``t`` [s]: ``(tau, cw,
    sw, h, hd, e11, e12, e21, e22, gap, gap_rate, gap_acc, gap_jerk, energy)``: the
    homogeneous mode state and its propagator, the gap and its first three derivatives
    [m, m s-1, m s-2, m s-3] and the mode's energy norm."""
    m = structure[MASS_RATIO]
    ca = structure[COS_ALPHA]
    g = structure[GRAVITY]
    k = structure[STIFFNESS]
    tau = t - start.t0
    h, hd, e11, e12, e21, e22 = homogeneous(row, tau, start.h0, start.hd0)
    x = omega * tau
    sx = math.sin(x)
    omc = one_minus_cos(x)
    cw0 = start.cw0
    sw0 = start.sw0
    cw = cw0 * math.cos(x) - sw0 * sx
    sw = sw0 * math.cos(x) + cw0 * sx
    w2 = omega * omega
    # cos wt0 - cos wt - sin(wt0) x = cw0 (1 - cos x) + sw0 (sin x - x), cancellation-free
    # (the gap starts as tau^3 after a take-off).
    drive_gap = (a / w2) * (cw0 * omc + sw0 * sin_minus_x(x, sx))
    drive_rate = (a / omega) * (cw0 * sx - sw0 * omc)
    mode_gap = (e11 - 1.0) * start.h0 + (e12 - tau) * start.hd0
    gap = (start.gap0 + start.gap_rate0 * tau - 0.5 * g * tau * tau + drive_gap
           - m * ca * mode_gap)
    gap_rate = start.gap_rate0 - g * tau + drive_rate - m * ca * (hd - start.hd0)
    hdd = -(row[M_KD] * h + row[M_CD] * hd)
    hddd = -(row[M_KD] * hd + row[M_CD] * hdd)
    gap_acc = -g + a * cw - m * ca * hdd
    gap_jerk = -a * omega * sw - m * ca * hddd
    energy = math.sqrt(max(k * h * h + row[M_D] * hd * hd, 0.0))
    return (tau, cw, sw, h, hd, e11, e12, e21, e22, gap, gap_rate, gap_acc, gap_jerk,
            energy)


@njit(cache=True, nogil=True, error_model="numpy")
def safe_start(structure, row, omega, a, start):
    """Time [s] after a take-off (``h = h' = 0`` at ``start``) before which no impact
    can occur: the first positive root of ``h'' tau^2/2 + h''' tau^3/6 - B4 tau^4/24``
    (0 when neither ``h''`` nor ``h'''`` is positive: the base does not leave)."""
    out = flight_at(structure, row, omega, a, start, start.t0)
    h2 = max(out[11], 0.0)
    h3 = out[12]
    energy = out[13]
    b4 = a * omega * omega + row[F_HOM4] * energy
    if b4 <= 0.0:
        return np.inf if (h2 > 0.0 or h3 > 0.0) else 0.0
    q = h3 / 6.0
    disc = q * q + b4 * h2 / 12.0
    if disc <= 0.0:
        return 0.0
    root = (q + math.sqrt(disc)) / (b4 / 12.0)
    return max(root, 0.0)


@njit(cache=True, nogil=True, error_model="numpy")
def impact_search(structure, row, omega, a, start, t_from, t_end, horizon, launched):
    """First zero of the gap ``h`` (an impact) in ``[t_from, t_end]`` on the flight piece
    from ``start``: ``(kind, t, steps)``, kind 1 for an impact, 0 for none before
    ``t_end``, -1 when the step budget is spent.

    ``-h`` is stepped by the larger of the quadratic and cubic bound steps: its second
    and third derivatives are bounded on the rest of the piece by ``g + a + ...`` and
    ``a w + ...`` plus the mode's share times its (non-increasing) energy norm.
    ``launched``: ``t_from`` is the safe start of a take-off, where the gap is not
    negative (a rounding of it below zero is no impact)."""
    g = structure[GRAVITY]
    t = t_from
    for steps in range(MAX_SEARCH_STEPS):
        out = flight_at(structure, row, omega, a, start, t)
        gap = out[9]
        gap_rate = out[10]
        energy = out[13]
        phi = -gap
        dphi = -gap_rate
        if launched and steps == 0:
            phi = min(phi, 0.0)
        if phi > 0.0 or (phi == 0.0 and dphi > 0.0):
            return 1, t, steps
        step = bounded_step(phi, dphi, -out[11], g + a + row[F_HOM2] * energy,
                            a * omega + row[F_HOM3] * energy)
        if t + step >= t_end:
            return 0, t_end, steps
        if step <= 4.0 * EPS * horizon:
            return 1, t + step, steps
        t = t + step
    return -1, t, MAX_SEARCH_STEPS


@njit(cache=True, nogil=True, error_model="numpy")
def largest_gap(structure, row, omega, a, start, t_end):
    """Largest gap [m] on the flight piece from ``start`` to ``t_end`` [s]: the largest
    of the ends and of the maxima of the closed form where ``h'`` turns from positive to
    negative between samples (at least 16, and 8 per period of the flight oscillator),
    each refined by safeguarded Newton on ``h'``."""
    tau_end = t_end - start.t0
    best = max(start.gap0, flight_at(structure, row, omega, a, start, t_end)[9])
    if tau_end <= 0.0:
        return best
    # Samples: 8 per drive period, and 8 per period of the mode while its part of the
    # gap has not decayed (5 decay times).
    nu = math.sqrt(max(row[M_NU2], 0.0))
    sigma = row[M_SIGMA]
    ringing = tau_end if sigma <= 0.0 else min(tau_end, 5.0 / sigma)
    pieces = 16 + math.ceil(8.0 * (tau_end * omega + ringing * nu) / TWO_PI)
    pieces = min(pieces, 4096)
    dt = tau_end / pieces
    left = start.t0
    rate_left = start.gap_rate0
    for i in range(1, pieces + 1):
        right = start.t0 + i * dt if i < pieces else t_end
        out = flight_at(structure, row, omega, a, start, right)
        rate_right = out[10]
        if rate_left > 0.0 and rate_right <= 0.0:
            lo = left
            hi = right
            x = 0.5 * (lo + hi)
            for _ in range(60):
                o = flight_at(structure, row, omega, a, start, x)
                if o[10] > 0.0:
                    lo = x
                else:
                    hi = x
                nx = x - o[10] / o[11] if o[11] != 0.0 else 0.5 * (lo + hi)
                if not lo < nx < hi:
                    nx = 0.5 * (lo + hi)
                if abs(nx - x) <= 1e-14 * max(abs(x), 1.0) or hi - lo <= 4.0 * EPS * hi:
                    x = nx
                    break
                x = nx
            best = max(best, flight_at(structure, row, omega, a, start, x)[9])
        left = right
        rate_left = rate_right
    return best


@njit(cache=True, nogil=True, error_model="numpy")
def gap_below(structure, row, a, start, tau_end, level):
    """Whether the gap [m] stays below ``level`` [m] on the flight piece from ``start``
    over ``tau_end`` [s], by a bound: ``h'' <= -g + a + B2 E`` (``B2 E`` bounds the mode's
    share, its energy norm ``E`` never grows), so ``h`` lies below the parabola from
    ``(h_0, h'_0)``. With a margin far above the rounding of the closed form's terms, a
    piece found below the largest gap so far cannot raise it: :func:`largest_gap`, which
    costs tens of samples per piece, is skipped on the short rebounds of a chatter."""
    if not level > 0.0:
        return False
    k = structure[STIFFNESS]
    energy = math.sqrt(max(k * start.h0 * start.h0 + row[M_D] * start.hd0 * start.hd0, 0.0))
    curve = -structure[GRAVITY] + a + row[F_HOM2] * energy
    h0 = start.gap0
    v0 = start.gap_rate0
    top = max(h0, h0 + v0 * tau_end + 0.5 * curve * tau_end * tau_end)
    if curve < 0.0:
        vertex = -v0 / curve
        if 0.0 < vertex < tau_end:
            top = max(top, h0 - 0.5 * v0 * v0 / curve)
    size = (abs(h0) + abs(v0) * tau_end
            + 0.5 * (structure[GRAVITY] + a + row[F_HOM2] * energy) * tau_end * tau_end)
    return top + 1e-9 * size < level


@njit(cache=True, nogil=True, error_model="numpy")
def _note_event(acc, te):
    """Record an event at ``te`` [s] in the event-time slots of ``acc``."""
    if acc[A_EVENT_COUNT] == 0.0:
        acc[A_FIRST_EVENT] = te
    else:
        gap = te - acc[A_LAST_EVENT]
        if gap > acc[A_QUIET_GAP]:
            acc[A_QUIET_GAP] = gap
            acc[A_QUIET_MID] = acc[A_LAST_EVENT] + 0.5 * gap
    acc[A_LAST_EVENT] = te
    acc[A_EVENT_COUNT] += 1.0


@njit(cache=True, nogil=True, error_model="numpy")
def _left(jac, r, scratch):
    """``jac <- r jac`` (5x5)."""
    for i in range(N_STATE):
        for j in range(N_STATE):
            total = 0.0
            for q in range(N_STATE):
                total += r[i, q] * jac[q, j]
            scratch[i, j] = total
    jac[:, :] = scratch


@njit(cache=True, nogil=True, error_model="numpy")
def _identity(r):
    for i in range(N_STATE):
        for j in range(N_STATE):
            r[i, j] = 1.0 if i == j else 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def _row_index(mode):
    if mode == FLY:
        return FLIGHT_ROW
    return 0 if mode == 0 else (1 if mode > 0 else 2)


@njit(cache=True, nogil=True, error_model="numpy")
def contact_normal(structure, row, a, cw, dl, dld):
    """The normal force ``n = g - A + M cos(alpha) delta''`` [m s-2] in the contact mode of
    ``row`` at state ``(dl, dld)``, drive phase cosine ``cw``."""
    ddd = mode_acceleration(structure, row, cw, dl, dld)
    return structure[GRAVITY] - a * cw + structure[MASS_RATIO] * structure[COS_ALPHA] * ddd


@njit(cache=True, nogil=True, error_model="numpy")
def landing_mode(structure, table, a, cw, z):
    """Contact mode of a base on the table (``h = h' = 0``) at state ``z`` and drive phase
    cosine ``cw``: the sign of ``v`` or the stick test (as a run starts), or
    :data:`FLY` when that mode's normal force is negative (it takes off at once);
    -3 when the slip it starts has ``D_s <= 0`` (the paradox)."""
    if z[2] > 0.0:
        mode = 1
    elif z[2] < 0.0:
        mode = -1
    else:
        r_p, r_m, _ = stick_releases(structure, a, cw, z[0], z[1])
        mode = 0
        if r_p > 0.0 and r_p >= r_m:
            mode = 1
        elif r_m > 0.0:
            mode = -1
    row = table[_row_index(mode)]
    if row[M_D] <= 0.0:
        return -3
    if contact_normal(structure, row, a, cw, z[0], z[1]) < 0.0:
        return FLY
    return mode


@njit(cache=True, nogil=True, error_model="numpy")
def _field(structure, table, a, cw, mode, z, f):
    """The vector field ``f`` (5) of ``mode`` at state ``z``, drive phase cosine ``cw``."""
    row = table[_row_index(mode)]
    ddd = mode_acceleration(structure, row, cw, z[0], z[1])
    f[0] = z[1]
    f[1] = ddd
    if mode == FLY:
        f[2] = -row[M_K] * ddd
        f[3] = z[4]
        f[4] = (-structure[GRAVITY] + a * cw
                - structure[MASS_RATIO] * structure[COS_ALPHA] * ddd)
    else:
        f[2] = 0.0 if mode == 0 else slip_acceleration(structure, row, a, cw, ddd)
        f[3] = 0.0
        f[4] = 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def fly(point, z, t_begin, t_stop, record, want_jac, want_hop, max_events):
    """Follow the state ``z`` (5, in place) at the drive point ``point`` (a
    :data:`~study.kernels.two_way.modes.DrivePoint` whose table has :data:`N_ROWS` rows)
    from ``t_begin`` to ``t_stop`` [s], the base free to leave the table.

    ``record`` (a :data:`FlightRecord`): ``acc`` receives the statistics of
    :func:`~study.kernels.two_way.orbit.run` (displacement, slips, slip and stick
    times, events, steps, shortest slip) and the time in flight [s], the impacts and,
    when ``want_hop``, the largest gap [m]; ``jac`` is multiplied on the left by the
    flow's Jacobian when ``want_jac``. At most ``max_events`` pieces are followed.

    Returns
    -------
    int
        ``RUN_OK``, ``RUN_PARADOX`` (a slip or an impact with ``D_s <= 0``) or
        ``RUN_BUDGET``.
    """
    structure = point.structure
    table = point.table
    omega = point.omega
    a = point.a
    acc = record.acc
    jac = record.jac
    r = record.step
    scratch = record.scratch
    m = structure[MASS_RATIO]
    ca = structure[COS_ALPHA]
    g = structure[GRAVITY]
    ck = structure[KINETIC_FRICTION]
    frow = table[FLIGHT_ROW]
    horizon = max(abs(t_stop), TWO_PI / omega)
    chatter = CHATTER * max(1.0 - structure[RESTITUTION], 0.01) * (g + a) / omega
    impact_out = np.empty(IMPACT_SIZE)
    # The structure with a plastic impact law: a rebound below the cut-offs is redone
    # with e = 0 (the whole impact, friction included).
    plastic = structure.copy()
    plastic[RESTITUTION] = 0.0
    j3 = np.empty((3, 3))
    f_minus = np.empty(N_STATE)
    f_plus = np.empty(N_STATE)
    t = t_begin
    cw = math.cos(omega * t)
    sw = math.sin(omega * t)
    # Where a piece's search starts looking: after a safe start of a flight, or past a
    # slip that could not move.
    t_from = t
    # The time of the last rebound (for CHATTER_TIME).
    last_rebound = -np.inf
    if z[Z_GAP] != 0.0 or z[Z_GAP_RATE] != 0.0:
        mode = FLY
    else:
        mode = landing_mode(structure, table, a, cw, z)
        if mode == -3:
            return RUN_PARADOX
        if mode == 1 or mode == -1:
            if z[2] == 0.0:
                acc[A_SLIPS] += 1.0
        if mode == FLY:
            t_from = t + safe_start(structure, frow, omega, a, FlightStart(
                t, cw, sw, z[0] - frow[M_OFFSET], z[1], z[1], 0.0, 0.0, z[2]))
    events = 0
    while t < t_stop:
        events += 1
        if events > max_events:
            acc[A_EVENTS] += events
            return RUN_BUDGET
        if mode == FLY:
            fstart = FlightStart(t, cw, sw, z[0] - frow[M_OFFSET], z[1], z[1], z[Z_GAP],
                                 z[Z_GAP_RATE], z[2])
            kind, te, steps = impact_search(structure, frow, omega, a, fstart,
                                            min(max(t, t_from), t_stop), t_stop, horizon,
                                            t_from > t)
            acc[A_STEPS] += steps
            if kind < 0:
                acc[A_EVENTS] += events
                return RUN_BUDGET
            (tau, cwe, swe, h, hd, e11, e12, e21, e22, gap, gap_rate, _, _,
             _) = flight_at(structure, frow, omega, a, fstart, te)
            if want_hop and not gap_below(structure, frow, a, fstart, tau, acc[A_HOP]):
                acc[A_HOP] = max(acc[A_HOP], largest_gap(structure, frow, omega, a, fstart,
                                                         te))
            kk = frow[M_K]
            dl = frow[M_OFFSET] + h
            v_end = z[2] - kk * (hd - z[1])
            acc[A_DISPLACEMENT] += z[2] * tau - kk * ((e11 - 1.0) * fstart.h0
                                                      + (e12 - tau) * fstart.hd0)
            acc[A_AIRBORNE] += tau
            if want_jac:
                _identity(r)
                r[0, 0] = e11
                r[0, 1] = e12
                r[1, 0] = e21
                r[1, 1] = e22
                r[2, 0] = -kk * e21
                r[2, 1] = -kk * (e22 - 1.0)
                r[3, 0] = -m * ca * (e11 - 1.0)
                r[3, 1] = -m * ca * (e12 - tau)
                r[3, 4] = tau
                r[4, 0] = -m * ca * e21
                r[4, 1] = -m * ca * (e22 - 1.0)
                _left(jac, r, scratch)
            z[0] = dl
            z[1] = hd
            z[2] = v_end
            z[Z_GAP] = gap
            z[Z_GAP_RATE] = gap_rate
            t = te
            cw = cwe
            sw = swe
            if kind == 0:
                break
            _note_event(acc, te)
            # The impact.
            z[Z_GAP] = 0.0
            gap_minus = min(gap_rate, 0.0)
            _field(structure, table, a, cw, FLY, z, f_minus)
            f_minus[3] = gap_minus
            if gap_minus < 0.0:
                law = structure
                code = impact(law, z[1], z[2], gap_minus, impact_out)
                rebound = impact_out[IMPACT_GAP_RATE]
                if code != IMPACT_PARADOX and not (
                        rebound > chatter
                        and t - last_rebound > CHATTER_TIME * TWO_PI / omega):
                    law = plastic
                    code = impact(law, z[1], z[2], gap_minus, impact_out)
                    rebound = 0.0
                if code == IMPACT_PARADOX:
                    acc[A_EVENTS] += events
                    return RUN_PARADOX
                acc[A_IMPACTS] += 1.0
                if want_jac:
                    impact_jacobian(law, z[1], z[2], gap_minus, j3)
                z[1] = impact_out[IMPACT_DELTA_RATE]
                z[2] = 0.0 if code == IMPACT_STICK else impact_out[IMPACT_VELOCITY]
            else:
                # Touching down with no speed (grazing): a landing without impulse.
                acc[A_IMPACTS] += 1.0
                rebound = 0.0
                if want_jac:
                    for i in range(3):
                        for j in range(3):
                            j3[i, j] = 1.0 if i == j else 0.0
            if rebound > 0.0:
                last_rebound = t
                new = FLY
                z[Z_GAP_RATE] = rebound
            else:
                z[Z_GAP_RATE] = 0.0
                new = landing_mode(structure, table, a, cw, z)
                if new == -3:
                    acc[A_EVENTS] += events
                    return RUN_PARADOX
                if (new == 1 or new == -1) and z[2] == 0.0:
                    acc[A_SLIPS] += 1.0
            if want_jac:
                _field(structure, table, a, cw, new, z, f_plus)
                # Dg: identity but on (delta', v, h').
                _identity(r)
                slots = (1, 2, 4)
                for i in range(3):
                    for j in range(3):
                        r[slots[i], slots[j]] = j3[i, j]
                if gap_minus < 0.0:
                    q = 1.0 / gap_minus
                    for i in range(N_STATE):
                        dgf = 0.0
                        for j in range(N_STATE):
                            dgf += r[i, j] * f_minus[j]
                        r[i, Z_GAP] += (f_plus[i] - dgf) * q
                _left(jac, r, scratch)
            mode = new
            t_from = t
            if gap_minus == 0.0 and mode != FLY:
                # A grazing touch-down (no speed): the contact search starts a nudge
                # later, so a normal force just at 0 does not take off again at once.
                t_from = t + NUDGE * TWO_PI / omega
            if mode == FLY and z[Z_GAP_RATE] == 0.0:
                t_from = t + safe_start(structure, frow, omega, a, FlightStart(
                    t, cw, sw, z[0] - frow[M_OFFSET], z[1], z[1], 0.0, 0.0, z[2]))
            continue
        # A contact piece (orbit.run's, with lift-off always watched).
        j = _row_index(mode)
        row = table[j]
        dp, dpd, _, _ = particular(row, omega, cw, sw)
        h0 = z[0] - dp
        hd0 = z[1] - dpd
        v0 = z[2]
        dd0 = z[1]
        if mode == 0:
            mask = EV_RELEASE_FORWARD | EV_RELEASE_BACKWARD | EV_LIFT_OFF
        else:
            mask = EV_SLIP_END | EV_LIFT_OFF
        kind, te, steps = search(
            structure, row, omega, a, PieceStart(t, sw, h0, hd0, v0, dd0), mask,
            SearchLimits(max(t, t_from), t_stop, horizon, g))
        acc[A_STEPS] += steps
        if kind < 0:
            acc[A_EVENTS] += events
            return RUN_BUDGET
        tau = te - t
        h, hd, e11, e12, e21, e22 = homogeneous(row, tau, h0, hd0)
        ph = omega * te
        cwe = math.cos(ph)
        swe = math.sin(ph)
        dpe, dpde, _, _ = particular(row, omega, cwe, swe)
        dl = dpe + h
        dld = dpde + hd
        if want_jac:
            _identity(r)
            r[0, 0] = e11
            r[0, 1] = e12
            r[1, 0] = e21
            r[1, 1] = e22
            r[3, 3] = 0.0
            r[4, 4] = 0.0
        if mode == 0:
            acc[A_STICK] += tau
            z[0] = dl
            z[1] = dld
            z[2] = 0.0
            if want_jac:
                r[2, 2] = 0.0
                _left(jac, r, scratch)
        else:
            s = row[M_SIGN]
            kk = row[M_K]
            tw = omega * tau
            dsin = (cw * math.sin(tw) - sw * one_minus_cos(tw)) / omega
            v_end = v0 - kk * (dld - dd0) - s * ck * g * tau + s * ck * a * dsin
            iint = (cw * one_minus_cos(tw) + sw * sin_minus_x(tw, math.sin(tw))) / (omega * omega)
            dp_full = (dpe - dp) - dpd * tau
            dh_full = (h - h0) - hd0 * tau
            acc[A_DISPLACEMENT] += (v0 * tau - kk * (dp_full + dh_full)
                                    - 0.5 * s * ck * g * tau * tau + s * ck * a * iint)
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
                r[2, 0] = -kk * e21
                r[2, 1] = -kk * (e22 - 1.0)
                _left(jac, r, scratch)
        z[Z_GAP] = 0.0
        z[Z_GAP_RATE] = 0.0
        t = te
        cw = cwe
        sw = swe
        if kind == 0:
            break
        _note_event(acc, te)
        t_from = t
        if kind == EV_LIFT_OFF:
            # Take-off: the contact force vanishes, the vector field is continuous
            # (identity saltation); no impact before the safe start.
            mode = FLY
            t_from = t + safe_start(structure, frow, omega, a, FlightStart(
                t, cw, sw, z[0] - frow[M_OFFSET], z[1], z[1], 0.0, 0.0, z[2]))
            continue
        r_p, r_m, acc0 = stick_releases(structure, a, cwe, dl, dld)
        if mode == 0:
            new = 1 if kind == EV_RELEASE_FORWARD else -1
            jn = 1 if new > 0 else 2
            if table[jn, M_D] <= 0.0:
                acc[A_EVENTS] += events
                return RUN_PARADOX
            acc[A_SLIPS] += 1.0
            if want_jac:
                _release(structure, table[jn], omega, a, cwe, swe, dl, dld, acc0, jac, r,
                         scratch)
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
                _identity(r)
                r[1, 2] = (accp - accm) * q
                r[2, 2] = vdot_plus * q
                _left(jac, r, scratch)
            if new == 0 and tau == 0.0:
                t_from = te + NUDGE * TWO_PI / omega
            mode = new
    acc[A_EVENTS] += events
    return RUN_OK


@njit(cache=True, nogil=True, error_model="numpy")
def _release(structure, rown, omega, a, cwe, swe, dl, dld, acc0, jac, r, scratch):
    """Saltation of a release from a stick into the slip of ``rown`` (as
    :mod:`~study.kernels.two_way.orbit`'s, on the 5-state)."""
    accn = mode_acceleration(structure, rown, cwe, dl, dld)
    vdot = slip_acceleration(structure, rown, a, cwe, accn)
    m = structure[MASS_RATIO]
    kap = -m * (rown[M_SIGN] * structure[SIN_ALPHA]
                + structure[STATIC_FRICTION] * structure[COS_ALPHA])
    g_d = -kap * structure[STIFFNESS]
    g_dd = -kap * structure[DAMPING]
    ddd_rate = (-a * omega * swe * structure[COS_ALPHA]
                - structure[DAMPING] * acc0 - structure[STIFFNESS] * dld)
    rate = kap * ddd_rate - structure[STATIC_FRICTION] * a * omega * swe
    if rate > 0.0:
        q = 1.0 / rate
        jump = accn - acc0
        _identity(r)
        r[1, 0] = jump * g_d * q
        r[1, 1] = 1.0 + jump * g_dd * q
        r[2, 0] = vdot * g_d * q
        r[2, 1] = vdot * g_dd * q
        _left(jac, r, scratch)
