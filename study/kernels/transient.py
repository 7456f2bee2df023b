"""Event-driven Dormand-Prince 5(4) time integrator of the full single-plate model.

State ``y = (delta, d delta/dt, x, v)`` and a discrete contact mode: ``STICK`` (0),
forward slip (+1) or backward slip (-1). Per unit total mass, table frame::

    A(t)   = a cos(phi(t))                     drive; phi continuous across segments
    F      = A cos(alpha) - (w0/Q) delta' - w0^2 delta
    stick:             delta'' = F,                         x'' = 0
    slip s, one-way:   delta'' = F,                         x'' = tau - s ck n
    slip s, two-way:   delta'' = F - x'' sin(alpha),        x'' = tau - s ck n
    n = g - A + M cos(alpha) delta'',   tau = -M sin(alpha) delta''

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
the Illinois method to the event tolerance.

Everything here is private: :mod:`study.transient` validates, allocates and calls.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

# Contact modes.
STICK = 0

# Run outcomes (``_integrate`` return codes).
RUN_DONE = 0
RUN_LIFT_OFF = 1
RUN_BUDGET = 2
RUN_PARADOX = 3

# Event kinds recorded in trajectories.
EVENT_RELEASE_FORWARD = 1
EVENT_RELEASE_BACKWARD = 2
EVENT_SLIP_END = 3
EVENT_LIFT_OFF = 4
EVENT_PARADOX = 5

# Status codes, mirrored by study.status.Status (tested to agree).
STATIC = 0
STICK_SLIP = 1
CONTINUOUS_SLIDING = 2
LIFT_OFF = 3
NOT_CONVERGED = 4
FRICTION_PARADOX = 5
REASON_NONE = 0
REASON_NO_PERIODIC_ORBIT = 1
REASON_EVENT_BUDGET = 2

# Indices of the model parameter vector ``p``.
P_DAMPING = 0  # w0 / Q [s^-1]
P_STIFFNESS = 1  # w0^2 [s^-2]
P_COS = 2
P_SIN = 3
P_MASS = 4  # M
P_CS = 5
P_CK = 6
P_G = 7
P_TWO_WAY = 8  # 1.0 for two-way coupling
N_PARAMETERS = 9

# Dormand-Prince 5(4) tableau (Dormand & Prince 1980) with Shampine's (1986)
# continuous extension in Hairer's form.
C2, C3, C4, C5 = 0.2, 0.3, 0.8, 8.0 / 9.0
A21 = 0.2
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (
    9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0
)
B1, B3, B4, B5, B6 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
E1, E3, E4, E5, E6, E7 = (
    71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0, -1.0 / 40.0
)
D1 = -12715105075.0 / 11282082432.0
D3 = 87487479700.0 / 32700410799.0
D4 = -10690763975.0 / 1880347072.0
D5 = 701980252875.0 / 199316789632.0
D6 = -1453857185.0 / 822651844.0
D7 = 69997945.0 / 29380423.0

# The stages' coefficients as tables, for the loops shared by every kernel's step.
STAGE_NODES = np.array([0.0, C2, C3, C4, C5, 1.0])
STAGE_WEIGHTS = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [A21, 0.0, 0.0, 0.0, 0.0],
    [A31, A32, 0.0, 0.0, 0.0],
    [A41, A42, A43, 0.0, 0.0],
    [A51, A52, A53, A54, 0.0],
    [A61, A62, A63, A64, A65],
])

# Step-size controller (standard for a 5th-order pair with local extrapolation).
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 5.0
# Bisection-safeguarded Illinois iterations per event (each halves the bracket at worst
# every other step): enough for any tolerance down to the rounding of t.
MAX_ROOT_ITERATIONS = 200


@njit(cache=True, nogil=True, inline="always")
def table_drive(t, seg, seg_t0, seg_omega, seg_a, seg_phase0):
    phase = seg_phase0[seg] + seg_omega[seg] * (t - seg_t0[seg])
    return seg_a[seg] * math.cos(phase), seg_a[seg] * seg_omega[seg] * math.sin(phase)


@njit(cache=True, nogil=True)
def _accelerations(p, mode, drive, y):
    """``(delta'', x'')`` in contact mode ``mode`` with drive acceleration ``drive``."""
    forcing = drive * p[P_COS] - p[P_DAMPING] * y[1] - p[P_STIFFNESS] * y[0]
    if mode == STICK:
        return forcing, 0.0
    s = float(mode)
    m = p[P_MASS]
    ca = p[P_COS]
    sa = p[P_SIN]
    ck = p[P_CK]
    if p[P_TWO_WAY] != 0.0:
        denominator = 1.0 - m * sa * (sa + s * ck * ca)
        xdd = (-m * sa * forcing - s * ck * (p[P_G] - drive + m * ca * forcing)) / denominator
        return forcing - sa * xdd, xdd
    xdd = -m * sa * forcing - s * ck * (p[P_G] - drive + m * ca * forcing)
    return forcing, xdd


@njit(cache=True, nogil=True)
def _rhs(p, mode, drive, y, out):
    ddd, xdd = _accelerations(p, mode, drive, y)
    out[0] = y[1]
    out[1] = ddd
    out[2] = y[3]
    out[3] = xdd


@njit(cache=True, nogil=True)
def _forces(p, mode, drive, drive_rate_neg, y):
    """Normal and tangential force per unit mass and their time derivatives.

    ``drive_rate_neg`` is ``a w sin(phi) = -dA/dt``.
    """
    ddd, xdd = _accelerations(p, mode, drive, y)
    ca = p[P_COS]
    sa = p[P_SIN]
    m = p[P_MASS]
    forcing_rate = -drive_rate_neg * ca - p[P_DAMPING] * ddd - p[P_STIFFNESS] * y[1]
    dddd = forcing_rate
    if mode != STICK and p[P_TWO_WAY] != 0.0:
        s = float(mode)
        ck = p[P_CK]
        denominator = 1.0 - m * sa * (sa + s * ck * ca)
        dddd = (forcing_rate + s * ck * sa * drive_rate_neg) / denominator
    n = p[P_G] - drive + m * ca * ddd
    tau = -m * sa * ddd
    n_rate = drive_rate_neg + m * ca * dddd
    tau_rate = -m * sa * dddd
    return n, tau, n_rate, tau_rate, xdd


@njit(cache=True, nogil=True)
def _event_values(p, mode, drive, drive_rate_neg, y, values, rates):
    """Event functions of the current mode, each positive while nothing happens.

    stick: ``cs n - tau`` (forward release), ``cs n + tau`` (backward release);
    slip s: ``s v`` (slip end); always: ``n`` (lift-off).
    """
    n, tau, n_rate, tau_rate, xdd = _forces(p, mode, drive, drive_rate_neg, y)
    cs = p[P_CS]
    if mode == STICK:
        values[0] = cs * n - tau
        rates[0] = cs * n_rate - tau_rate
        values[1] = cs * n + tau
        rates[1] = cs * n_rate + tau_rate
    else:
        s = float(mode)
        values[0] = s * y[3]
        rates[0] = s * xdd
        values[1] = 1.0
        rates[1] = 0.0
    values[2] = n
    rates[2] = n_rate


@njit(cache=True, nogil=True)
def dense_output(theta, h, dense, out):
    """State at ``t0 + theta h`` from the step's continuous extension."""
    one_minus = 1.0 - theta
    for i in range(out.shape[0]):
        out[i] = dense[0, i] + theta * (
            dense[1, i]
            + one_minus * (dense[2, i] + theta * (dense[3, i] + one_minus * dense[4, i]))
        )


@njit(cache=True, nogil=True)
def stage_state(stage, y, h, k, out):
    """``out = y + h sum_l a_{stage, l} k[l]``: the state at which stage ``stage`` (1-5)
    of a Dormand-Prince step evaluates the right-hand side."""
    for i in range(y.shape[0]):
        total = STAGE_WEIGHTS[stage, 0] * k[0, i]
        for j in range(1, stage):
            total += STAGE_WEIGHTS[stage, j] * k[j, i]
        out[i] = y[i] + h * total


@njit(cache=True, nogil=True)
def solution_step(y, h, k, y_new):
    """The step's 5th-order solution from the stages ``k[0..5]``."""
    for i in range(y.shape[0]):
        y_new[i] = y[i] + h * (
            B1 * k[0, i] + B3 * k[2, i] + B4 * k[3, i] + B5 * k[4, i] + B6 * k[5, i]
        )


@njit(cache=True, nogil=True)
def error_and_dense(y, h, k, y_new, err, dense):
    """Embedded error estimate and Shampine's dense-output coefficients (needs the FSAL
    stage ``k[6] = f(t + h, y_new)``)."""
    for i in range(y.shape[0]):
        err[i] = h * (
            E1 * k[0, i] + E3 * k[2, i] + E4 * k[3, i] + E5 * k[4, i] + E6 * k[5, i]
            + E7 * k[6, i]
        )
        dense[0, i] = y[i]
        rise = y_new[i] - y[i]
        dense[1, i] = rise
        slope_gap = h * k[0, i] - rise
        dense[2, i] = slope_gap
        dense[3, i] = rise - h * k[6, i] - slope_gap
        dense[4, i] = h * (
            D1 * k[0, i] + D3 * k[2, i] + D4 * k[3, i] + D5 * k[4, i] + D6 * k[5, i]
            + D7 * k[6, i]
        )


@njit(cache=True, nogil=True)
def _step(p, mode, t, h, y, k, drive_args, y_new, err, dense, tmp):
    """One Dormand-Prince step from ``(t, y)`` with ``k[0] = f(t, y)`` (FSAL).

    Fills ``k[1..6]``, the 5th-order solution ``y_new``, the error estimate ``err``
    and the dense-output coefficients.
    """
    seg, seg_t0, seg_omega, seg_a, seg_phase0 = drive_args
    for stage in range(1, 6):
        stage_state(stage, y, h, k, tmp)
        drive, _ = table_drive(t + STAGE_NODES[stage] * h, seg, seg_t0, seg_omega, seg_a,
                          seg_phase0)
        _rhs(p, mode, drive, tmp, k[stage])
    solution_step(y, h, k, y_new)
    _rhs(p, mode, drive, y_new, k[6])
    error_and_dense(y, h, k, y_new, err, dense)
    if mode == STICK:
        # x and v are exactly constant while stuck.
        y_new[2] = y[2]
        y_new[3] = 0.0
        err[2] = 0.0
        err[3] = 0.0


@njit(cache=True, nogil=True)
def error_norm(err, y, y_new, scale, rtol, atol):
    total = 0.0
    for i in range(err.shape[0]):
        size = atol * scale[i] + rtol * max(abs(y[i]), abs(y_new[i]))
        r = err[i] / size
        total += r * r
    return math.sqrt(total / err.shape[0])


@njit(cache=True, nogil=True)
def _values_at(theta, p, mode, t, h, dense, drive_args, ystate, values, rates):
    seg, seg_t0, seg_omega, seg_a, seg_phase0 = drive_args
    dense_output(theta, h, dense, ystate)
    if mode == STICK:
        ystate[3] = 0.0
    drive, rate = table_drive(t + theta * h, seg, seg_t0, seg_omega, seg_a, seg_phase0)
    _event_values(p, mode, drive, rate, ystate, values, rates)


@njit(cache=True, nogil=True)
def _refine(which, lo, hi, p, mode, t, h, dense, drive_args, ystate, values, rates, xtol):
    """Illinois iteration on event ``which`` over ``[lo, hi]`` (positive at ``lo``,
    triggered at ``hi``); returns the triggered end of a bracket narrower than ``xtol``.
    """
    _values_at(lo, p, mode, t, h, dense, drive_args, ystate, values, rates)
    f_lo = values[which]
    _values_at(hi, p, mode, t, h, dense, drive_args, ystate, values, rates)
    f_hi = values[which]
    side = 0
    for _ in range(MAX_ROOT_ITERATIONS):
        if hi - lo <= xtol:
            break
        if f_lo - f_hi > 0.0 and math.isfinite(f_lo - f_hi):
            mid = lo + (hi - lo) * f_lo / (f_lo - f_hi)
        else:
            mid = 0.5 * (lo + hi)
        # Keep the iterate inside the bracket and away from its ends.
        width = hi - lo
        mid = min(max(mid, lo + 0.01 * width), hi - 0.01 * width)
        _values_at(mid, p, mode, t, h, dense, drive_args, ystate, values, rates)
        f_mid = values[which]
        triggered = f_mid <= 0.0 if which == 0 and mode != STICK else f_mid < 0.0
        if triggered:
            hi = mid
            f_hi = f_mid
            if side == -1:
                f_lo *= 0.5
            side = -1
        else:
            lo = mid
            f_lo = f_mid
            if side == 1:
                f_hi *= 0.5
            side = 1
    return hi


@njit(cache=True, nogil=True)
def _minimum(which, lo, hi, p, mode, t, h, dense, drive_args, ystate, values, rates, xtol):
    """Bisection for the zero of event ``which``'s rate (negative at ``lo``, positive at
    ``hi``): the position of the event function's minimum on ``[lo, hi]``."""
    for _ in range(MAX_ROOT_ITERATIONS):
        if hi - lo <= xtol:
            break
        mid = 0.5 * (lo + hi)
        _values_at(mid, p, mode, t, h, dense, drive_args, ystate, values, rates)
        if rates[which] < 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@njit(cache=True, nogil=True)
def _first_event(
    p, mode, t, h, dense, drive_args, samples, xtol, fresh, ystate, values, rates,
    prev_values, prev_rates,
):
    """Earliest event in the step: ``(which, theta)`` or ``(-1, 1.0)``.

    ``which`` is 0 or 1 (release forward/backward, or slip end) or 2 (lift-off).
    The slip-end function ``s v`` is zero at the start of a slip, where it rises
    (``s dv/dt >= 0`` there): at a ``fresh`` slip's start it counts as clear, so a slip
    shorter than one sample interval still ends. After a tangential touch (a slip end
    followed by a slip the same way) the first interval is not watched, which stops
    a rounding-level root from repeating.
    """
    best_which = -1
    best_theta = 2.0
    _values_at(0.0, p, mode, t, h, dense, drive_args, ystate, prev_values, prev_rates)
    theta_prev = 0.0
    for j in range(1, samples + 1):
        theta = j / samples
        _values_at(theta, p, mode, t, h, dense, drive_args, ystate, values, rates)
        for which in range(3):
            if which == 1 and mode != STICK:
                continue
            before = prev_values[which]
            after = values[which]
            slip_end = which == 0 and mode != STICK
            now_triggered = after <= 0.0 if slip_end else after < 0.0
            was_clear = before > 0.0 if slip_end else before >= 0.0
            if slip_end and j == 1 and fresh:
                was_clear = True
            root_hi = -1.0
            if was_clear and now_triggered:
                root_hi = theta
            elif was_clear and prev_rates[which] < 0.0 and rates[which] > 0.0:
                # Both ends clear but the function dips in between: look at its minimum.
                theta_min = _minimum(
                    which, theta_prev, theta, p, mode, t, h, dense, drive_args, ystate,
                    values, rates, xtol,
                )
                _values_at(theta_min, p, mode, t, h, dense, drive_args, ystate, values, rates)
                dip = values[which]
                if (dip <= 0.0) if slip_end else (dip < 0.0):
                    root_hi = theta_min
                # Restore the sample at theta for the next sub-interval.
                _values_at(theta, p, mode, t, h, dense, drive_args, ystate, values, rates)
            if root_hi >= 0.0:
                root = _refine(
                    which, theta_prev, root_hi, p, mode, t, h, dense, drive_args, ystate,
                    values, rates, xtol,
                )
                if root < best_theta:
                    best_theta = root
                    best_which = which
                _values_at(theta, p, mode, t, h, dense, drive_args, ystate, values, rates)
        if best_which >= 0:
            return best_which, best_theta
        for which in range(3):
            prev_values[which] = values[which]
            prev_rates[which] = rates[which]
        theta_prev = theta
    return -1, 1.0


@njit(cache=True, nogil=True)
def _mode_after_rest(p, drive, y):
    """Contact mode at an instant of rest (``v = 0``) from the stick forces.

    Returns +1/-1 when ``|tau| > cs n`` (slip in the direction of ``tau``), else 0.
    """
    n, tau, _, _, _ = _forces(p, STICK, drive, 0.0, y)
    limit = p[P_CS] * n
    if tau > limit:
        return 1
    if -tau > limit:
        return -1
    return STICK


@njit(cache=True, nogil=True)
def _paradox(p, mode):
    if mode == STICK or p[P_TWO_WAY] == 0.0:
        return False
    s = float(mode)
    sa = p[P_SIN]
    return 1.0 - p[P_MASS] * sa * (sa + s * p[P_CK] * p[P_COS]) <= 0.0


@njit(cache=True, nogil=True)
def _integrate(
    p, seg_t0, seg_omega, seg_a, seg_phase0, seg_end,
    y, mode_box, t_box, t_stop,
    rtol, atol, scale, fixed_step, max_step, xtol_time, samples, max_steps,
    out_t, out_y, out_mode, out_box,
    ev_t, ev_kind, ev_y, ev_box,
    stats,
):
    """Integrate from ``t_box[0]`` to ``t_stop`` (within the segments), in place.

    With ``fixed_step > 0`` steps end on the grid ``t_box[0] + k fixed_step`` (and at
    events); otherwise the step is adapted to ``rtol``/``atol``.

    ``y``, ``mode_box[0]``, ``t_box[0]`` carry the state in and out; ``t_box[1]`` is the
    step size to try first (updated). Output samples at ``out_t`` (sorted) are written
    from index ``out_box[0]`` on; events are recorded in ``ev_*`` while ``ev_box[0]``
    is below their capacity. ``stats`` accumulates ``[steps, rejected, slips,
    stuck time, forward slip time, backward slip time]``.

    Returns a ``RUN_*`` code.
    """
    n = y.shape[0]
    k = np.empty((7, n))
    y_new = np.empty(n)
    err = np.empty(n)
    dense = np.empty((5, n))
    tmp = np.empty(n)
    ystate = np.empty(n)
    values = np.empty(3)
    rates = np.empty(3)
    prev_values = np.empty(3)
    prev_rates = np.empty(3)
    mode = mode_box[0]
    t = t_box[0]
    t_origin = t
    h = t_box[1]
    seg = 0
    while seg < seg_end.shape[0] - 1 and t >= seg_end[seg]:
        seg += 1
    need_rhs = True
    fresh = mode != STICK and y[3] == 0.0
    steps = 0
    while t < t_stop:
        if steps >= max_steps:
            mode_box[0] = mode
            t_box[0] = t
            return RUN_BUDGET
        while seg < seg_end.shape[0] - 1 and t >= seg_end[seg]:
            seg += 1
            need_rhs = True
        drive_args = (seg, seg_t0, seg_omega, seg_a, seg_phase0)
        if need_rhs:
            drive, rate = table_drive(t, seg, seg_t0, seg_omega, seg_a, seg_phase0)
            if mode == STICK:
                y[3] = 0.0
                new_mode = _mode_after_rest(p, drive, y)
                if new_mode != STICK:
                    mode = new_mode
                    fresh = True
                    stats[2] += 1.0
                    _record(ev_t, ev_kind, ev_y, ev_box, t,
                            EVENT_RELEASE_FORWARD if mode > 0 else EVENT_RELEASE_BACKWARD, y)
            if _paradox(p, mode):
                _record(ev_t, ev_kind, ev_y, ev_box, t, EVENT_PARADOX, y)
                mode_box[0] = mode
                t_box[0] = t
                return RUN_PARADOX
            _event_values(p, mode, drive, rate, y, values, rates)
            if values[2] < 0.0:
                _record(ev_t, ev_kind, ev_y, ev_box, t, EVENT_LIFT_OFF, y)
                mode_box[0] = mode
                t_box[0] = t
                return RUN_LIFT_OFF
            _rhs(p, mode, drive, y, k[0])
            need_rhs = False
        # Steps end on segment ends, the stop time and never exceed the cap.
        limit = min(t_stop, seg_end[seg])
        if fixed_step > 0.0:
            # Fixed steps stay on a grid anchored at the call's start time: after an
            # event the step ends on the next grid point, so every drive period is cut
            # the same way and a periodic orbit repeats exactly.
            grid = math.floor((t - t_origin) / fixed_step * (1.0 + 1e-12)) + 1.0
            h = t_origin + grid * fixed_step - t
            if h < 1e-9 * fixed_step:
                h += fixed_step
        h = min(h, max_step)
        last = False
        if t + 1.01 * h >= limit:
            h = limit - t
            last = True
        if h <= 0.0:
            t = limit
            continue
        _step(p, mode, t, h, y, k, drive_args, y_new, err, dense, tmp)
        steps += 1
        stats[0] += 1.0
        if fixed_step <= 0.0:
            norm = error_norm(err, y, y_new, scale, rtol, atol)
            if not norm <= 1.0:
                stats[1] += 1.0
                factor = MIN_FACTOR if not math.isfinite(norm) else max(
                    MIN_FACTOR, SAFETY * norm ** -0.2
                )
                h *= factor
                if h < 1e-14 * max(abs(t), max_step):
                    mode_box[0] = mode
                    t_box[0] = t
                    return RUN_BUDGET
                continue
            factor = MAX_FACTOR if norm == 0.0 else min(MAX_FACTOR, SAFETY * norm ** -0.2)
        else:
            factor = 1.0
        which, theta = _first_event(
            p, mode, t, h, dense, drive_args, samples, xtol_time / h, fresh, ystate,
            values, rates, prev_values, prev_rates,
        )
        t_end = t + theta * h if which >= 0 else t + h
        if last and which < 0:
            t_end = limit
        # Output samples inside the accepted part of the step.
        while out_box[0] < out_t.shape[0] and out_t[out_box[0]] <= t_end:
            j = out_box[0]
            dense_output((out_t[j] - t) / h, h, dense, ystate)
            if mode == STICK:
                ystate[3] = 0.0
                ystate[2] = y[2]
            for i in range(n):
                out_y[j, i] = ystate[i]
            out_mode[j] = mode
            out_box[0] += 1
        duration = t_end - t
        if mode == STICK:
            stats[3] += duration
        elif mode > 0:
            stats[4] += duration
        else:
            stats[5] += duration
        if which < 0:
            for i in range(n):
                y[i] = y_new[i]
                k[0, i] = k[6, i]
            t = t_end
            h *= factor
            fresh = False
            continue
        dense_output(theta, h, dense, ystate)
        for i in range(n):
            y[i] = ystate[i]
        if mode == STICK:
            y[3] = 0.0
        t = t_end
        need_rhs = True
        drive, rate = table_drive(t, seg, seg_t0, seg_omega, seg_a, seg_phase0)
        if which == 2:
            _record(ev_t, ev_kind, ev_y, ev_box, t, EVENT_LIFT_OFF, y)
            mode_box[0] = mode
            t_box[0] = t
            return RUN_LIFT_OFF
        if mode == STICK:
            mode = 1 if which == 0 else -1
            fresh = True
            stats[2] += 1.0
            _record(ev_t, ev_kind, ev_y, ev_box, t,
                    EVENT_RELEASE_FORWARD if mode > 0 else EVENT_RELEASE_BACKWARD, y)
        else:
            y[3] = 0.0
            _record(ev_t, ev_kind, ev_y, ev_box, t, EVENT_SLIP_END, y)
            after = _mode_after_rest(p, drive, y)
            if after == -mode:
                stats[2] += 1.0
                _record(ev_t, ev_kind, ev_y, ev_box, t,
                        EVENT_RELEASE_FORWARD if after > 0 else EVENT_RELEASE_BACKWARD, y)
            # A reversal starts a fresh slip; a tangential touch continues the old one.
            fresh = after == -mode
            mode = after
    mode_box[0] = mode
    t_box[0] = t
    t_box[1] = h
    return RUN_DONE


@njit(cache=True, nogil=True)
def _record(ev_t, ev_kind, ev_y, ev_box, t, kind, y):
    j = ev_box[0]
    if j < ev_t.shape[0]:
        ev_t[j] = t
        ev_kind[j] = kind
        for i in range(y.shape[0]):
            ev_y[j, i] = y[i]
    ev_box[0] = j + 1


@njit(cache=True, nogil=True)
def _periodic_point(
    p, omega, amplitude, y0, rtol, atol, scale, fixed_step, max_step, xtol_time, samples,
    max_steps, max_periods, max_orbit, period_tolerance, result,
):
    """Integrate whole drive periods until the state repeats; mean velocity of the orbit.

    The state at each period boundary (``delta``, ``delta'``, ``v``, contact mode) and
    the displacement over the period are kept for the last ``max_orbit`` periods; the
    orbit is periodic with period ``q`` once the boundary state and the displacement
    repeat after ``q`` periods within ``period_tolerance`` (in units of ``scale``).
    Time restarts at zero each period (phase ``2 pi k`` is phase 0), so the phase
    keeps full precision however many periods are needed.

    ``result`` receives ``[status, reason, velocity, slips per period, forward
    fraction, backward fraction, orbit period, periods integrated, steps]``.
    """
    period = 2.0 * math.pi / omega
    seg_t0 = np.zeros(1)
    seg_omega = np.full(1, omega)
    seg_a = np.full(1, amplitude)
    seg_phase0 = np.zeros(1)
    seg_end = np.full(1, np.inf)
    n = y0.shape[0]
    y = y0.copy()
    mode_box = np.zeros(1, dtype=np.int64)
    if y[3] > 0.0:
        mode_box[0] = 1
    elif y[3] < 0.0:
        mode_box[0] = -1
    t_box = np.array([0.0, max_step])
    out_t = np.empty(0)
    out_y = np.empty((0, n))
    out_mode = np.empty(0, dtype=np.int64)
    out_box = np.zeros(1, dtype=np.int64)
    ev_t = np.empty(0)
    ev_kind = np.empty(0, dtype=np.int64)
    ev_y = np.empty((0, n))
    ev_box = np.zeros(1, dtype=np.int64)
    ring = max_orbit + 1
    hist_state = np.empty((ring, 3))
    hist_mode = np.empty(ring, dtype=np.int64)
    hist_disp = np.empty(ring)
    hist_stats = np.empty((ring, 6))
    stats = np.zeros(6)
    steps_total = 0.0
    for i in range(9):
        result[i] = 0.0
    for k in range(max_periods):
        y[2] = 0.0
        t_box[0] = 0.0
        for i in range(6):
            stats[i] = 0.0
        code = _integrate(
            p, seg_t0, seg_omega, seg_a, seg_phase0, seg_end, y, mode_box, t_box, period,
            rtol, atol, scale, fixed_step, max_step, xtol_time, samples, max_steps,
            out_t, out_y, out_mode, out_box, ev_t, ev_kind, ev_y, ev_box, stats,
        )
        steps_total += stats[0]
        result[7] = k + 1
        result[8] = steps_total
        if code != RUN_DONE:
            result[2] = np.nan
            result[3] = np.nan
            result[4] = np.nan
            result[5] = np.nan
            if code == RUN_LIFT_OFF:
                result[0] = LIFT_OFF
            elif code == RUN_PARADOX:
                result[0] = FRICTION_PARADOX
            else:
                result[0] = NOT_CONVERGED
                result[1] = REASON_EVENT_BUDGET
            return
        slot = k % ring
        hist_state[slot, 0] = y[0]
        hist_state[slot, 1] = y[1]
        hist_state[slot, 2] = y[3]
        hist_mode[slot] = mode_box[0]
        hist_disp[slot] = y[2]
        for i in range(6):
            hist_stats[slot, i] = stats[i]
        for q in range(1, max_orbit + 1):
            if k < q:
                break
            other = (k - q) % ring
            if hist_mode[other] != hist_mode[slot]:
                continue
            gap = max(
                abs(hist_state[slot, 0] - hist_state[other, 0]) / scale[0],
                abs(hist_state[slot, 1] - hist_state[other, 1]) / scale[1],
                abs(hist_state[slot, 2] - hist_state[other, 2]) / scale[3],
                abs(hist_disp[slot] - hist_disp[other]) / scale[2],
            )
            if not gap <= period_tolerance:
                continue
            distance = 0.0
            slips = 0.0
            stuck = 0.0
            forward = 0.0
            backward = 0.0
            for back in range(q):
                r = (k - back) % ring
                distance += hist_disp[r]
                slips += hist_stats[r, 2]
                stuck += hist_stats[r, 3]
                forward += hist_stats[r, 4]
                backward += hist_stats[r, 5]
            span = q * period
            if slips == 0.0 and forward == 0.0 and backward == 0.0:
                result[0] = STATIC
                result[2] = 0.0
            else:
                # A stick counts when it lasts longer than the event tolerance.
                result[0] = STICK_SLIP if stuck > q * xtol_time else CONTINUOUS_SLIDING
                result[2] = distance / span
            result[3] = slips / q
            result[4] = forward / span
            result[5] = backward / span
            result[6] = q
            return
    result[0] = NOT_CONVERGED
    result[1] = REASON_NO_PERIODIC_ORBIT
    result[2] = np.nan
    result[3] = np.nan
    result[4] = np.nan
    result[5] = np.nan


@njit(cache=True, nogil=True, parallel=True)
def _periodic_points(
    p, omega, amplitude, y0, rtol, atol, scale, fixed_step, max_step, xtol_time, samples,
    max_steps, max_periods, max_orbit, period_tolerance, results,
):
    """:func:`_periodic_point` for every point, in parallel (interleaved lanes).

    Per-point arrays: ``omega``, ``amplitude``, ``y0`` (rows), ``scale`` (rows),
    ``fixed_step``, ``max_step``, ``xtol_time``; ``results`` has one row per point.
    """
    n = omega.shape[0]
    lanes = min(n, 256)
    for lane in prange(lanes):
        for i in range(lane, n, lanes):
            _periodic_point(
                p, omega[i], amplitude[i], y0[i], rtol, atol, scale[i], fixed_step[i],
                max_step[i], xtol_time[i], samples, max_steps, max_periods, max_orbit,
                period_tolerance, results[i],
            )


@njit(cache=True, nogil=True)
def _periodic_points_serial(
    p, omega, amplitude, y0, rtol, atol, scale, fixed_step, max_step, xtol_time, samples,
    max_steps, max_periods, max_orbit, period_tolerance, results,
):
    """Same as :func:`_periodic_points` on the calling thread."""
    for i in range(omega.shape[0]):
        _periodic_point(
            p, omega[i], amplitude[i], y0[i], rtol, atol, scale[i], fixed_step[i],
            max_step[i], xtol_time[i], samples, max_steps, max_periods, max_orbit,
            period_tolerance, results[i],
        )
