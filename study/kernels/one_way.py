"""Event-driven, closed-form steady-state stick-slip kernel (docs/theory/exact-solvers.md).

Time is measured by the drive phase ``theta = w t``. In a slip of sign ``s``
started at rest at ``theta0``, the scaled speed ``U = s w v`` obeys::

    dU/dtheta = -c + h cos(theta + phi)          c = ck g,  h e^{i phi} = B_s

so ``U(D) = -c D + h [sin(psi0 + D) - sin(psi0)]`` with ``D = theta - theta0`` and
``psi0 = theta0 + phi``. The extrema of ``U`` are at ``cos(psi) = c / h``: the slip
end ``U = 0`` always lies on the single decreasing stretch that follows the first
maximum, so it is bracketed on an interval where ``U`` is monotone and found by
safeguarded Newton iteration. Stick releases are closed form (an arc of phase on
which ``s tau - cs n > 0``).

:mod:`study.solvers.exact` validates, allocates and calls the driver
:func:`solve_points_averaged` (all diagnostics), with its arguments grouped in the named
tuples below; :func:`solve_point` solves one point and is shared with the velocity path
and the small calls of :mod:`study.kernels.one_way_velocity`. The outputs of every orbit
are one row of :data:`OUTPUT_COLUMNS` a point, written and read by column name.
Continuous sliding whose circle map has no cycle within reach is followed and
time-averaged (:func:`_average_sliding`: ``QUASI_PERIODIC`` or ``CHAOTIC``,
docs/theory/irregular.md). :func:`sin_minus_x` is shared with the orbit kernel.
Results are written to ``out`` arrays; nothing is allocated per point on the common
(stick-slip) path.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit, prange

from study.kernels.time_average import (
    DISCARDED_PERIODS,
    EXPONENT_SIGMAS,
    EXPONENT_ZERO,
    S_STATE,
    S_VELOCITY_ERROR,
    Z_95,
    examined,
    mean_and_error,
    out_of_reach,
    settles,
)
from study.model.codes import (
    CHAOTIC,
    CONTINUOUS_SLIDING,
    LIFT_OFF,
    NOT_CONVERGED,
    QUASI_PERIODIC,
    REASON_AVERAGE_BUDGET,
    REASON_EVENT_BUDGET,
    REASON_NO_PERIODIC_ORBIT,
    REASON_NONE,
    STATIC,
    STICK_SLIP,
)

TWO_PI = 2.0 * math.pi

# A release that would start this close before the end of its arc (in phase, rad)
# is a rounding artefact of a slip that ended exactly on the arc's edge: its slip
# would last < 1e-12 rad and move < 1e-24 of the amplitude.
EXIT_TOLERANCE = 1e-12
# Consecutive slips without a stick after which the reversal phases are treated
# as a circle map (continuous sliding).
CIRCLE_MAP_AFTER = 4
# Longest cycle of the circle map searched for, in map iterations.
MAX_MAP_PERIOD = 16
# A cycle candidate is refined by Newton iteration once it closes to this phase
# [rad]; a failed refinement is retried only once the gap has halved. Newton steps
# make slowly attracting cycles (multiplier near 1) cheap to find.
CYCLE_DETECTION = 1e-2
# Newton refinement of a cycle stops once the cycle closes to this phase [rad].
CYCLE_TOLERANCE = 1e-12

EPS = 2.220446049250313e-16
# A release needs |A_s| > cs g times this (see _constants).
RELEASE_MARGIN = 1.0 + 8.0 * EPS
# A slip end is found once the slip speed there is below this many ulps of the sum of
# the absolute values of its terms (its rounding error), or once the Newton correction
# or the bracket is below this many ulps of the phase (see _slip).
SLIP_END_ULPS = 4.0

#: The release and slip amplitudes ``A_+, A_-, B_+, B_-`` [m s-2] of
#: ``study.model.forces`` at each point (complex128 arrays).
Amplitudes = namedtuple("Amplitudes", ("a_plus", "a_minus", "b_plus", "b_minus"))
#: The friction levels ``cs g`` (``static``) and ``ck g`` (``kinetic``) [m s-2].
FrictionLevels = namedtuple("FrictionLevels", ("static", "kinetic"))
#: The outputs of :func:`solve_points_averaged`, one row a point and one column each,
#: ``(name, units, meaning)``, read by name (``OUT_<NAME>``) by the wrapper. Integer
#: codes and counts are stored exactly in the float64 table. The names are those of the
#: two-way orbit kernel's columns (:data:`study.kernels.two_way.points.OUTPUT_COLUMNS`)
#: that mean the same.
OUTPUT_COLUMNS = (
    ("status", "1", "study.model.status.Status code"),
    ("reason", "1", "study.model.status.NonConvergence code"),
    ("velocity", "m s-1", "mean velocity over the orbit (NaN where not converged)"),
    ("slips", "1", "slip events per drive period"),
    ("forward", "1", "fraction of the drive period spent slipping forward"),
    ("backward", "1", "fraction of the drive period spent slipping backward"),
    ("period", "1", "the orbit's period in drive periods (0: no orbit)"),
    ("averaged_velocity", "m s-1",
     "time-averaged velocity of continuous sliding without a cycle within reach "
     "(QUASI_PERIODIC, CHAOTIC; the partial mean of NOT_CONVERGED with AVERAGE_BUDGET; "
     "NaN elsewhere)"),
    ("velocity_error", "m s-1",
     "its standard error (0 for an orbit or a static point, NaN where nothing was "
     "averaged and there is no orbit)"),
    ("averaged_periods", "1", "drive periods averaged (0 for an orbit)"),
    ("exponent", "1",
     "Lyapunov exponent per drive period (a continuous-sliding cycle: log|multiplier| / "
     "period; NaN for stick-slip, static and lift-off points, which have no multiplier)"),
    ("exponent_error", "1", "its error (0 for a cycle)"),
)
_NAMES = tuple(name for name, _, _ in OUTPUT_COLUMNS)
#: Columns of :data:`OUTPUT_COLUMNS`.
N_OUTPUTS = len(OUTPUT_COLUMNS)
OUT_STATUS = _NAMES.index("status")
OUT_REASON = _NAMES.index("reason")
OUT_VELOCITY = _NAMES.index("velocity")
OUT_SLIPS = _NAMES.index("slips")
OUT_FORWARD = _NAMES.index("forward")
OUT_BACKWARD = _NAMES.index("backward")
OUT_PERIOD = _NAMES.index("period")
OUT_AVERAGED_VELOCITY = _NAMES.index("averaged_velocity")
OUT_VELOCITY_ERROR = _NAMES.index("velocity_error")
OUT_AVERAGED_PERIODS = _NAMES.index("averaged_periods")
OUT_EXPONENT = _NAMES.index("exponent")
OUT_EXPONENT_ERROR = _NAMES.index("exponent_error")
# Per-point constants of the slips and releases (see _constants): the slip's friction
# level c = ck g, the slip amplitudes h, phases phi and half-widths gamma of the
# increasing stretch for each sign, whether each release happens, and its arc's entry
# and width [rad].
SlipConstants = namedtuple(
    "SlipConstants",
    ("c", "h_p", "phi_p", "gamma_p", "h_m", "phi_m", "gamma_m",
     "ok_p", "entry_p", "width_p", "ok_m", "entry_m", "width_m"))

# Round-trip status of a sequence of slips.
_ROUND_OK = 0
_ROUND_STUCK = 1
_ROUND_BUDGET = 2
# The circle map's search ran its iterations without finding a cycle (_circle_map).
_ROUND_NO_CYCLE = 3


@njit(cache=True, nogil=True)
def _mod_two_pi(x):
    r = x - TWO_PI * math.floor(x / TWO_PI)
    if r >= TWO_PI:
        r -= TWO_PI
    return r


@njit(cache=True, nogil=True)
def sin_minus_x(d, sin_d):
    """``sin(d) - d`` without cancellation for small ``d``."""
    if abs(d) >= 1.0:
        return sin_d - d
    x2 = d * d
    series = 1.0 - x2 / 342.0
    series = 1.0 - x2 / 272.0 * series
    series = 1.0 - x2 / 210.0 * series
    series = 1.0 - x2 / 156.0 * series
    series = 1.0 - x2 / 110.0 * series
    series = 1.0 - x2 / 72.0 * series
    series = 1.0 - x2 / 42.0 * series
    series = 1.0 - x2 / 20.0 * series
    return -d * x2 / 6.0 * series


@njit(cache=True, nogil=True)
def _one_minus_cos_minus_half_square(d, one_minus_cos):
    """``1 - cos(d) - d^2/2`` without cancellation for small ``d``."""
    if abs(d) >= 1.0:
        return one_minus_cos - 0.5 * d * d
    x2 = d * d
    series = 1.0 - x2 / 380.0
    series = 1.0 - x2 / 306.0 * series
    series = 1.0 - x2 / 240.0 * series
    series = 1.0 - x2 / 182.0 * series
    series = 1.0 - x2 / 132.0 * series
    series = 1.0 - x2 / 90.0 * series
    series = 1.0 - x2 / 56.0 * series
    series = 1.0 - x2 / 30.0 * series
    return -x2 * x2 / 24.0 * series


@njit(cache=True, nogil=True)
def _slip_speed(d, slope0, h, cos0, sin0):
    """``U(d)`` and ``dU/dd`` of a slip started at rest (see module docstring)."""
    sin_d = math.sin(d)
    half = math.sin(0.5 * d)
    one_minus_cos = 2.0 * half * half
    speed = slope0 * d + h * (cos0 * sin_minus_x(d, sin_d) - sin0 * one_minus_cos)
    accel = slope0 - h * (cos0 * one_minus_cos + sin0 * sin_d)
    return speed, accel


@njit(cache=True, nogil=True)
def _slip(psi0, c, h, gamma):
    """Follow one slip that starts at rest at phase ``psi0`` (relative to ``phi``).

    Returns
    -------
    duration, distance, slope_start, slope_end, moved
        Phase length of the slip [rad], ``integral of U dD`` over it, ``dU/dD`` at
        its start and end, and whether it moved at all (``False`` for a slip that
        ends as soon as it starts, e.g. released exactly at the end of its arc).
    """
    if gamma < 0.0:
        return 0.0, 0.0, 0.0, 0.0, False
    cos0 = math.cos(psi0)
    sin0 = math.sin(psi0)
    slope0 = h * cos0 - c
    # U increases while the phase is in (-gamma, gamma); the first maximum is at +gamma.
    offset = _mod_two_pi(_mod_two_pi(psi0) + gamma)
    if offset > TWO_PI - EXIT_TOLERANCE:
        # Released where dU/dD = 0 (ck = cs, release at the arc's entry): rounding
        # put the start just before the increasing stretch that physically follows.
        offset = 0.0
    if offset > 2.0 * gamma:
        return 0.0, 0.0, slope0, slope0, False
    lo = 2.0 * gamma - offset
    speed_lo, _ = _slip_speed(lo, slope0, h, cos0, sin0)
    if speed_lo <= 0.0:
        return 0.0, 0.0, slope0, slope0, False
    hi = lo + TWO_PI - 2.0 * gamma
    speed_hi, _ = _slip_speed(hi, slope0, h, cos0, sin0)
    # U is monotone decreasing on [lo, hi], U(lo) > 0 > U(hi): start from regula falsi,
    # then Newton, bisecting whenever a step would leave the bracket.
    d = lo + (hi - lo) * speed_lo / (speed_lo - speed_hi)
    for iteration in range(200):
        sin_d = math.sin(d)
        half = math.sin(0.5 * d)
        one_minus_cos = 2.0 * half * half
        sin_minus_d = sin_minus_x(d, sin_d)
        speed = slope0 * d + h * (cos0 * sin_minus_d - sin0 * one_minus_cos)
        accel = slope0 - h * (cos0 * one_minus_cos + sin0 * sin_d)
        # The root is as accurate as the evaluation of U allows once |U(d)| is below
        # the rounding error of that evaluation: a few ulps of the sum of the absolute
        # values of its terms (for d >= 1, sin(d) - d is a difference of its terms).
        size = abs(sin_minus_d) if d < 1.0 else abs(sin_d) + d
        noise = SLIP_END_ULPS * EPS * (abs(slope0) * d + h * (abs(cos0) * size
                                                              + abs(sin0) * one_minus_cos))
        if abs(speed) <= noise or iteration == 199:
            break
        if speed > 0.0:
            lo = d
        else:
            hi = d
        step_ok = accel < 0.0
        if step_ok:
            d_new = d - speed / accel
            step_ok = lo < d_new < hi
        if not step_ok:
            d_new = 0.5 * (lo + hi)
        # A correction or a bracket of a few ulps of d: d is the root to rounding.
        if abs(d_new - d) <= SLIP_END_ULPS * EPS * d or hi - lo <= SLIP_END_ULPS * EPS * hi:
            break
        d = d_new
    # d is the last point evaluated: its sines give the distance and the end slope.
    distance = 0.5 * slope0 * d * d + h * (
        cos0 * _one_minus_cos_minus_half_square(d, one_minus_cos) + sin0 * sin_minus_d
    )
    return d, distance, slope0, accel, True


@njit(cache=True, nogil=True)
def _next_release(theta, excluded, k):
    """Phase to wait from ``theta`` (at rest) until a slip starts, and its sign.

    ``excluded`` (``+1``, ``-1`` or ``0``) forbids an immediate release of that sign,
    used after a slip of that sign that could not move.
    """
    best_wait = np.inf
    best_sign = 0
    if k.ok_p:
        d = _mod_two_pi(theta - k.entry_p)
        if d < k.width_p - EXIT_TOLERANCE and excluded != 1:
            wait = 0.0
        else:
            wait = TWO_PI - d
        best_wait = wait
        best_sign = 1
    if k.ok_m:
        d = _mod_two_pi(theta - k.entry_m)
        if d < k.width_m - EXIT_TOLERANCE and excluded != -1:
            wait = 0.0
        else:
            wait = TWO_PI - d
        if wait < best_wait:
            best_wait = wait
            best_sign = -1
    return best_wait, best_sign


@njit(cache=True, nogil=True)
def _advance(theta, sign, k):
    """One slip of ``sign`` from rest at ``theta``, then the decision at its end.

    Returns
    -------
    theta_next, sign_next, wait, duration, distance, derivative
        The next slip starts at ``theta_next`` with ``sign_next`` after a stick of
        phase length ``wait`` (0: immediate reversal or continuation). ``distance``
        is ``integral of U`` over the slip (positive), ``derivative`` is
        ``d theta_end / d theta_start`` for the circle map.
    """
    if sign > 0:
        duration, distance, slope0, slope1, moved = _slip(theta + k.phi_p, k.c, k.h_p,
                                                          k.gamma_p)
    else:
        duration, distance, slope0, slope1, moved = _slip(theta + k.phi_m, k.c, k.h_m,
                                                          k.gamma_m)
    if moved:
        theta_end = theta + duration
        wait, sign_next = _next_release(theta_end, 0, k)
        derivative = slope0 / slope1
    else:
        theta_end = theta
        wait, sign_next = _next_release(theta_end, sign, k)
        derivative = 1.0
    return theta_end + wait, sign_next, wait, duration, distance, derivative


@njit(cache=True, nogil=True)
def _rounds(theta, count, k, max_events):
    """From a forward slip starting at rest at ``theta``, run until ``count`` more
    forward slips have started by immediate reversal.

    Returns
    -------
    flag, theta_end, sign_end, derivative, distance, forward, backward, slips
        ``flag`` is ``_ROUND_OK``, ``_ROUND_STUCK`` (a stick interrupted the
        sequence: ``theta_end, sign_end`` is its release) or ``_ROUND_BUDGET``.
        ``distance`` is the signed integral of ``w v`` over phase; ``forward`` and
        ``backward`` are the phase lengths of forward and backward slips.
    """
    sign = 1
    derivative = 1.0
    distance = 0.0
    forward = 0.0
    backward = 0.0
    slips = 0
    done = 0
    for _ in range(max_events):
        theta_next, sign_next, wait, duration, moved, factor = _advance(theta, sign, k)
        if duration > 0.0:
            slips += 1
        if sign > 0:
            distance += moved
            forward += duration
        else:
            distance -= moved
            backward += duration
        derivative *= factor
        theta = theta_next
        sign = sign_next
        if wait > 0.0:
            return _ROUND_STUCK, theta, sign, 0.0, distance, forward, backward, slips
        if sign > 0:
            done += 1
            if done == count:
                return _ROUND_OK, theta, sign, derivative, distance, forward, backward, slips
    return _ROUND_BUDGET, theta, sign, derivative, distance, forward, backward, slips


@njit(cache=True, nogil=True)
def _refine_cycle(p, period, turns, k, max_events):
    """Newton iteration for a cycle of the reversal circle map.

    Solves ``R^period(p) = p + 2 pi turns`` from ``p``, with the analytic
    derivative of the map. A cycle is accepted when it closes to within
    ``CYCLE_TOLERANCE`` (a backward error: the exact cycle of a map perturbed by
    that much; near multiplier 1 the phase itself is ill-conditioned, by
    ``1 / |1 - multiplier|``) and it is attracting (|multiplier| < 1).

    Returns
    -------
    converged, p, end, sign, distance, forward, backward, slips, multiplier
        The cycle's phase ``p``, statistics of ``period`` map iterations along it and
        the product of the map's derivatives over them (its multiplier).
    """
    found = False
    polish = 0
    best = (np.inf, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0, 1.0)
    for _ in range(40):
        p = _mod_two_pi(p)
        flag, end, sign, deriv, distance, forward, backward, slips = _rounds(
            p, period, k, max_events
        )
        if flag != _ROUND_OK or deriv == 1.0:
            break
        residual = end - p - TWO_PI * turns
        if found:
            # Polish down to the rounding floor: near multiplier 1 the phase error is
            # the residual / (1 - multiplier), so every halving of it counts.
            if abs(residual) >= best[0]:
                break
            polish += 1
        elif abs(residual) <= CYCLE_TOLERANCE:
            if abs(deriv) >= 1.0:
                break
            found = True
        if found:
            best = (abs(residual), p, end, sign, distance, forward, backward, slips, deriv)
            if polish >= 4:
                break
        p -= residual / (deriv - 1.0)
    if found:
        _, p, end, sign, distance, forward, backward, slips, deriv = best
        return True, p, end, sign, distance, forward, backward, slips, deriv
    return False, p, 0.0, 0, 0.0, 0.0, 0.0, 0, 1.0


@njit(cache=True, nogil=True)
def _circle_map(theta, k, max_rounds, max_events):
    """Continuous sliding: find the attracting cycle of the reversal phases.

    ``theta`` is the start of a forward slip by immediate reversal.

    Returns
    -------
    flag, theta, sign, mean, slips, forward, backward, period, multiplier
        ``flag``: ``_ROUND_OK`` (cycle found; statistics per drive period follow, and
        the product of the map's derivatives over the cycle), ``_ROUND_STUCK`` (a stick
        appeared: resume stick-slip from ``theta, sign``), ``_ROUND_BUDGET`` (the events
        of an iteration ran out) or ``_ROUND_NO_CYCLE`` (no cycle within ``max_rounds``
        iterations: ``theta`` is the next iterate, for :func:`_average_sliding`).
    """
    # Ring buffers over the last iterations: start phase, unwrapped phase advance
    # and derivative of the map.
    starts = np.empty(MAX_MAP_PERIOD)
    advances = np.empty(MAX_MAP_PERIOD)
    derivatives = np.empty(MAX_MAP_PERIOD)
    tried = np.full(MAX_MAP_PERIOD + 1, np.inf)
    p = _mod_two_pi(theta)
    for iteration in range(max_rounds):
        flag, end, sign, deriv, _, _, _, _ = _rounds(p, 1, k, max_events)
        if flag == _ROUND_STUCK:
            return _ROUND_STUCK, end, sign, 0.0, 0.0, 0.0, 0.0, 0, 1.0
        if flag == _ROUND_BUDGET:
            return _ROUND_BUDGET, end, sign, 0.0, 0.0, 0.0, 0.0, 0, 1.0
        slot = iteration % MAX_MAP_PERIOD
        starts[slot] = p
        advances[slot] = end - p
        derivatives[slot] = deriv
        p = _mod_two_pi(end)
        total = 0.0
        product = 1.0
        for period in range(1, min(iteration + 1, MAX_MAP_PERIOD) + 1):
            slot = (iteration - period + 1) % MAX_MAP_PERIOD
            total += advances[slot]
            product *= derivatives[slot]
            turns = round(total / TWO_PI)
            gap = abs(total - TWO_PI * turns)
            if turns >= 1 and gap < CYCLE_DETECTION and gap < 0.5 * tried[period]:
                tried[period] = gap
                # First Newton step from the iterates already computed.
                guess = starts[slot]
                if product != 1.0:
                    guess -= (total - TWO_PI * turns) / (product - 1.0)
                (converged, p_star, end, sign, distance, forward, backward, slips,
                 multiplier) = _refine_cycle(guess, period, turns, k, max_events)
                if converged:
                    # Report the cycle's own period, not a multiple that closed first.
                    for shorter in range(1, period):
                        if period % shorter or (turns * shorter) % period:
                            continue
                        turns_short = turns * shorter // period
                        short = _rounds(p_star, shorter, k, max_events)
                        if short[0] == _ROUND_OK and abs(
                            short[1] - p_star - TWO_PI * turns_short
                        ) <= 1e3 * CYCLE_TOLERANCE:
                            _, end, sign, multiplier, distance, forward, backward, slips = short
                            turns = turns_short
                            break
                    span = TWO_PI * turns
                    return (
                        _ROUND_OK,
                        end,
                        sign,
                        distance / span,
                        slips / turns,
                        forward / span,
                        backward / span,
                        int(turns),
                        multiplier,
                    )
                break
    return _ROUND_NO_CYCLE, p, 1, 0.0, 0.0, 0.0, 0.0, 0, 1.0


@njit(cache=True, nogil=True)
def _average_sliding(p, k, budget, natural, spent):
    """Continuous sliding without a cycle within reach: the time averages of the circle
    map's iterates from ``p`` (the start of a forward slip by immediate reversal), after
    ``spent`` iterations of the cycle search, within ``budget`` (a
    :data:`~study.kernels.budget.Budget`); ``natural`` [m s-2] is the drive acceleration
    ``a``, whose ``velocity_tolerance`` is the tolerance of the mean of ``w v``.

    The search found no cycle: its iterates follow a slow approach to a cycle the search
    did not reach within its budget (exponent below 0), or an invariant circle of an
    irrational rotation number (exponent 0). The latter is not expected of this model: a
    forward slip starts only where it accelerates (``|psi0| < gamma <= pi / 2``), so the
    iterates stay on an arc of at most half the circle, and the map's derivative (a
    product of two negative slope ratios) is positive; an increasing map of an arc into
    itself has every orbit converge to a fixed point. A seeded search of ~28 million
    drive points found every continuous sliding a cycle of period 1.

    The iterations the search has spent count towards the transient of
    :data:`~study.kernels.time_average.DISCARDED_PERIODS` iterations (the rest is
    discarded here); then each iterate ``i`` (one forward and one backward slip, a round
    of ``t_i`` = its phase advance, not a whole number of drive periods) records its
    displacement ``x_i`` (the integral of ``w v`` over the round) and ``g_i = log|d
    theta_end / d theta_start|``. The mean is the time average ``V = sum x / sum t`` (a
    mean of ``w v`` [m s-2]); its standard error is the batch means'
    (:func:`~study.kernels.time_average.mean_and_error`) of ``(x_i - V t_i) / mean(t)``:
    the per-iterate velocities ``x_i / t_i`` weighted by their rounds' durations
    relative to the mean round, centred on ``V`` (the ratio estimator's linearised
    error, so a long round weighs as the time it lasts). The Lyapunov exponent per drive
    period is ``2 pi sum g / sum t``, its error the same way. The averages are examined
    and the motion classified as the two-way's
    (:func:`~study.kernels.time_average.examined`, ``settles``, ``out_of_reach``),
    ``max_average_periods`` counting iterates.

    Returns
    -------
    flag, theta, sign, status, reason, mean, slips, forward, backward, error, turns,
    exponent, exponent_error
        ``flag``: ``_ROUND_OK`` (averaged: ``status`` ``QUASI_PERIODIC`` or ``CHAOTIC``,
        or ``NOT_CONVERGED`` with ``REASON_AVERAGE_BUDGET`` and its partial averages),
        ``_ROUND_STUCK`` (a stick appeared: resume stick-slip from ``theta, sign``) or
        ``_ROUND_BUDGET`` (the events of an iteration ran out). ``mean`` and ``error``
        [m s-2] are of ``w v``; ``slips`` per drive period, ``forward`` and ``backward``
        the fractions of the time slipping each way; ``turns`` the drive periods the
        averaged iterates span; the exponent and its error per drive period.
    """
    max_events = budget.max_events
    n_max = budget.max_average_periods
    tolerance = budget.velocity_tolerance * natural
    discard = max(DISCARDED_PERIODS - spent, 0)
    distances = np.empty(n_max)
    advances = np.empty(n_max)
    growths = np.empty(n_max)
    values = np.empty(n_max)
    stats = np.zeros(S_STATE)
    total_distance = 0.0
    total_advance = 0.0
    total_growth = 0.0
    forward = 0.0
    backward = 0.0
    slips = 0
    for iteration in range(discard + n_max):
        flag, end, sign, deriv, distance, fwd, bwd, count = _rounds(p, 1, k, max_events)
        if flag != _ROUND_OK:
            return (flag, end, sign, NOT_CONVERGED, REASON_NO_PERIODIC_ORBIT, np.nan, 0.0,
                    0.0, 0.0, np.nan, 0.0, np.nan, np.nan)
        advance = end - p
        p = _mod_two_pi(end)
        recorded = iteration - discard
        if recorded < 0:
            continue
        growth = np.log(abs(deriv))
        distances[recorded] = distance
        advances[recorded] = advance
        growths[recorded] = growth
        total_distance += distance
        total_advance += advance
        total_growth += growth
        forward += fwd
        backward += bwd
        slips += count
        averaged = recorded + 1
        if not examined(averaged, n_max):
            continue
        mean = total_distance / total_advance
        step = total_advance / averaged
        for i in range(averaged):
            values[i] = (distances[i] - mean * advances[i]) / step
        _, error, _ = mean_and_error(values, averaged)
        rate = total_growth / total_advance
        for i in range(averaged):
            values[i] = (growths[i] - rate * advances[i]) * (TWO_PI / step)
        _, exponent_error, _ = mean_and_error(values, averaged)
        exponent = TWO_PI * rate
        within = Z_95 * error <= tolerance
        positive = exponent - EXPONENT_SIGMAS * exponent_error > 0.0
        negative = not exponent + EXPONENT_SIGMAS * exponent_error >= 0.0
        bounded = exponent + EXPONENT_SIGMAS * exponent_error < EXPONENT_ZERO
        # The cycle search has run its budget: settled once within the tolerance.
        if settles(averaged, n_max, spent, spent, within, positive, negative, bounded):
            status = CHAOTIC if positive else QUASI_PERIODIC
            reason = REASON_NONE
        else:
            stats[S_VELOCITY_ERROR] = error
            if averaged < n_max and not out_of_reach(averaged, n_max, stats, tolerance):
                continue
            status = NOT_CONVERGED
            reason = REASON_AVERAGE_BUDGET
        turns = total_advance / TWO_PI
        return (_ROUND_OK, p, 1, status, reason, mean, slips / turns,
                forward / total_advance, backward / total_advance, error, turns, exponent,
                exponent_error)
    # Not reached: the last iterate is examined (averaged == n_max).
    return (_ROUND_BUDGET, p, 1, NOT_CONVERGED, REASON_NO_PERIODIC_ORBIT, np.nan, 0.0, 0.0,
            0.0, np.nan, 0.0, np.nan, np.nan)


@njit(cache=True, nogil=True)
def _constants(a_plus, a_minus, b_plus, b_minus, cs_g, ck_g):
    """Per-point :data:`SlipConstants`: slip dynamics and release arcs for both signs."""
    c = ck_g
    h_p = abs(b_plus)
    h_m = abs(b_minus)
    phi_p = math.atan2(b_plus.imag, b_plus.real)
    phi_m = math.atan2(b_minus.imag, b_minus.real)
    gamma_p = math.atan2(math.sqrt((h_p - c) * (h_p + c)), c) if h_p > c else -1.0
    gamma_m = math.atan2(math.sqrt((h_m - c) * (h_m + c)), c) if h_m > c else -1.0
    r_p = abs(a_plus)
    r_m = abs(a_minus)
    # A release needs |A_s| > cs g. Within a few ulps the comparison is rounding, and
    # at alpha = 0, a = a_lift it is exactly the lift-off touch (tau = 0, n = 0): no slip.
    release_level = cs_g * RELEASE_MARGIN
    ok_p = r_p > release_level
    ok_m = r_m > release_level
    entry_p = 0.0
    width_p = 0.0
    entry_m = 0.0
    width_m = 0.0
    if ok_p:
        beta = math.atan2(math.sqrt((r_p - cs_g) * (r_p + cs_g)), cs_g)
        entry_p = _mod_two_pi(-beta - math.atan2(a_plus.imag, a_plus.real))
        width_p = 2.0 * beta
    if ok_m:
        beta = math.atan2(math.sqrt((r_m - cs_g) * (r_m + cs_g)), cs_g)
        entry_m = _mod_two_pi(-beta - math.atan2(a_minus.imag, a_minus.real))
        width_m = 2.0 * beta
    return SlipConstants(c, h_p, phi_p, gamma_p, h_m, phi_m, gamma_m,
                         ok_p, entry_p, width_p, ok_m, entry_m, width_m)


@njit(cache=True, nogil=True)
def solve_point(a_plus, a_minus, b_plus, b_minus, levels, budget, natural, omega, row):
    """Periodic orbit reached from rest at phase 0, for one drive point of amplitudes
    ``a_plus`` ... ``b_minus`` [m s-2], friction ``levels`` (:data:`FrictionLevels`),
    within ``budget`` (a :data:`~study.kernels.budget.Budget`), written into ``row`` (one
    row of :data:`OUTPUT_COLUMNS`) at angular frequency ``omega`` [rad s-1]; continuous
    sliding without a cycle within reach is averaged (:func:`_average_sliding`) with the
    tolerance ``velocity_tolerance * natural``, ``natural`` the drive acceleration ``a``
    [m s-2] (NaN: not averaged, ``NO_PERIODIC_ORBIT`` as without averaging).

    Each way out writes the columns it knows by name, over the defaults of an orbit
    (no average, no exponent); a point averaged to the budget (``NOT_CONVERGED``,
    ``AVERAGE_BUDGET``) keeps its partial mean in ``averaged_velocity``.
    """
    row[OUT_REASON] = REASON_NONE
    row[OUT_PERIOD] = 0
    row[OUT_AVERAGED_VELOCITY] = np.nan
    row[OUT_VELOCITY_ERROR] = 0.0
    row[OUT_AVERAGED_PERIODS] = 0
    row[OUT_EXPONENT] = np.nan
    row[OUT_EXPONENT_ERROR] = np.nan
    max_events = budget.max_events
    k = _constants(a_plus, a_minus, b_plus, b_minus, levels.static, levels.kinetic)
    if not k.ok_p and not k.ok_m:
        row[OUT_STATUS] = STATIC
        _write_slipping(row, 0.0, 0.0, 0.0, 0.0, omega)
        return
    wait, sign = _next_release(0.0, 0, k)
    theta = wait
    # State at the two possible releases after a stick: (phase, distance, fwd, bwd, slips).
    seen_p = False
    seen_m = False
    rec_p = (0.0, 0.0, 0.0, 0.0, 0)
    rec_m = (0.0, 0.0, 0.0, 0.0, 0)
    distance = 0.0
    forward = 0.0
    backward = 0.0
    slips = 0
    since_stick = 0
    genuine = wait > 0.0
    for _ in range(max_events):
        if genuine:
            since_stick = 0
            now = (theta, distance, forward, backward, slips)
            previous = rec_p if sign > 0 else rec_m
            seen = seen_p if sign > 0 else seen_m
            turns = round((theta - previous[0]) / TWO_PI)
            if seen and turns >= 1:
                span = TWO_PI * turns
                row[OUT_STATUS] = STICK_SLIP
                _write_slipping(row, (distance - previous[1]) / span,
                                (slips - previous[4]) / turns,
                                (forward - previous[2]) / span,
                                (backward - previous[3]) / span, omega)
                row[OUT_PERIOD] = int(turns)
                return
            if sign > 0:
                seen_p = True
                rec_p = now
            else:
                seen_m = True
                rec_m = now
        elif since_stick >= CIRCLE_MAP_AFTER and sign > 0:
            flag, theta_c, sign_c, mean, per, fwd, bwd, period, multiplier = _circle_map(
                theta, k, budget.max_map_iterations, max_events
            )
            if flag == _ROUND_OK:
                row[OUT_STATUS] = CONTINUOUS_SLIDING
                _write_slipping(row, mean, per, fwd, bwd, omega)
                row[OUT_PERIOD] = period
                row[OUT_EXPONENT] = np.log(abs(multiplier)) / period
                row[OUT_EXPONENT_ERROR] = 0.0
                return
            if flag == _ROUND_NO_CYCLE and natural > 0.0:
                (flag, theta_c, sign_c, st, why, mean, per, fwd, bwd, error, turns,
                 exponent, exponent_error) = _average_sliding(
                    theta_c, k, budget, natural, budget.max_map_iterations)
                if flag == _ROUND_OK:
                    row[OUT_STATUS] = st
                    row[OUT_REASON] = why
                    if st == NOT_CONVERGED:
                        _write_not_converged(row)
                    else:
                        _write_slipping(row, mean, per, fwd, bwd, omega)
                    row[OUT_AVERAGED_VELOCITY] = mean / omega
                    row[OUT_VELOCITY_ERROR] = error / omega
                    row[OUT_AVERAGED_PERIODS] = round(turns)
                    row[OUT_EXPONENT] = exponent
                    row[OUT_EXPONENT_ERROR] = exponent_error
                    return
            if flag == _ROUND_BUDGET or flag == _ROUND_NO_CYCLE:
                row[OUT_STATUS] = NOT_CONVERGED
                row[OUT_REASON] = REASON_NO_PERIODIC_ORBIT
                _write_not_converged(row)
                row[OUT_VELOCITY_ERROR] = np.nan
                return
            # A stick ended the sliding transient: restart the bookkeeping there.
            theta = theta_c
            sign = sign_c
            seen_p = False
            seen_m = False
            genuine = True
            continue
        theta_next, sign_next, wait, duration, moved, _ = _advance(theta, sign, k)
        if duration > 0.0:
            slips += 1
        if sign > 0:
            distance += moved
            forward += duration
        else:
            distance -= moved
            backward += duration
        theta = theta_next
        sign = sign_next
        genuine = wait > 0.0
        since_stick += 1
    row[OUT_STATUS] = NOT_CONVERGED
    row[OUT_REASON] = REASON_EVENT_BUDGET
    _write_not_converged(row)
    row[OUT_VELOCITY_ERROR] = np.nan


@njit(cache=True, nogil=True, inline="always")
def _write_slipping(row, mean, slips, forward, backward, omega):
    """The motion's columns of ``row``: its mean of ``w v`` [m s-2] as the velocity
    (over ``omega`` [rad s-1]), slips per period and the slipping fractions."""
    row[OUT_VELOCITY] = mean / omega
    row[OUT_SLIPS] = slips
    row[OUT_FORWARD] = forward
    row[OUT_BACKWARD] = backward


@njit(cache=True, nogil=True, inline="always")
def _write_not_converged(row):
    """The motion's columns of ``row`` where no motion was found: NaN."""
    row[OUT_VELOCITY] = np.nan
    row[OUT_SLIPS] = np.nan
    row[OUT_FORWARD] = np.nan
    row[OUT_BACKWARD] = np.nan


@njit(cache=True, nogil=True)
def write_lifted(row):
    """``row`` of a point past lift-off: no motion, no average."""
    row[OUT_STATUS] = LIFT_OFF
    row[OUT_REASON] = REASON_NONE
    _write_not_converged(row)
    row[OUT_PERIOD] = 0
    row[OUT_AVERAGED_VELOCITY] = np.nan
    row[OUT_VELOCITY_ERROR] = np.nan
    row[OUT_AVERAGED_PERIODS] = 0
    row[OUT_EXPONENT] = np.nan
    row[OUT_EXPONENT_ERROR] = np.nan


@njit(cache=True, nogil=True)
def _solve_averaged_into(i, amplitudes, a, lifted, omega, levels, budget, out):
    """Solve point ``i`` of drive acceleration ``a[i]`` [m s-2] into row ``i`` of ``out``
    (:data:`OUTPUT_COLUMNS`)."""
    if lifted[i]:
        write_lifted(out[i])
        return
    solve_point(amplitudes.a_plus[i], amplitudes.a_minus[i], amplitudes.b_plus[i],
                 amplitudes.b_minus[i], levels, budget, a[i], omega[i], out[i])


#: Points a thread takes at a time in the parallel kernels: whole cache lines of every
#: output array (8 doubles a line).
POINT_BLOCK = 64


@njit(cache=True, nogil=True, parallel=True)
def solve_points_averaged(amplitudes, a, lifted, omega, levels, budget, out):
    """Fill ``out`` (one row of :data:`OUTPUT_COLUMNS` a point) at points of
    :data:`Amplitudes` ``amplitudes``, drive accelerations ``a`` [m s-2], ``lifted``
    (past lift-off) and ``omega`` [rad s-1], friction ``levels`` (:data:`FrictionLevels`),
    within ``budget`` (a :data:`~study.kernels.budget.Budget`), in parallel over points
    (threads, GIL released). Continuous sliding without a cycle within reach is averaged
    (:func:`_average_sliding`, the tolerance ``velocity_tolerance * a``).

    Points are dealt to threads in blocks of :data:`POINT_BLOCK` consecutive points,
    the blocks interleaved over the lanes: the cost of a point depends on its regime,
    and neighbouring points share a regime, so one contiguous half each would leave
    one thread with all the slipping points of a map; single points interleaved
    would make every write miss the cache (a lane touches one value of each cache
    line, which is evicted before the next lane comes to it).
    """
    n = omega.shape[0]
    blocks = (n + POINT_BLOCK - 1) // POINT_BLOCK
    lanes = min(blocks, 256)
    for lane in prange(lanes):
        for block in range(lane, blocks, lanes):
            for i in range(block * POINT_BLOCK, min(n, (block + 1) * POINT_BLOCK)):
                _solve_averaged_into(i, amplitudes, a, lifted, omega, levels, budget, out)


@njit(cache=True, nogil=True)
def solve_points_averaged_serial(amplitudes, a, lifted, omega, levels, budget, out):
    """Same as :func:`solve_points_averaged` on one thread."""
    for i in range(omega.shape[0]):
        _solve_averaged_into(i, amplitudes, a, lifted, omega, levels, budget, out)
