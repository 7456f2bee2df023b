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
the Illinois method to the event tolerance (:mod:`study.kernels.events`). The
Dormand-Prince step, its error norm and dense output are :mod:`study.kernels.dopri`'s.

Everything here is private: :mod:`study.solvers.integrator` validates, allocates and calls.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from study.kernels.dopri import (
    dense_output,
    error_norm,
    growth_factor,
    shrink_factor,
    step,
    table_drive,
)
from study.kernels.dopri import workspace as step_workspace
from study.kernels.events import first_event, record
from study.kernels.events import workspace as event_workspace
from study.kernels.structure_vector import (
    COS_ALPHA,
    DAMPING,
    GRAVITY,
    KINETIC_FRICTION,
    MASS_RATIO,
    SIN_ALPHA,
    STATIC_FRICTION,
    STIFFNESS,
    TWO_WAY,
)
from study.model.codes import (
    CONTINUOUS_SLIDING,
    EVENT_LIFT_OFF,
    EVENT_PARADOX,
    EVENT_RELEASE_BACKWARD,
    EVENT_RELEASE_FORWARD,
    EVENT_SLIP_END,
    FRICTION_PARADOX,
    LIFT_OFF,
    NOT_CONVERGED,
    REASON_EVENT_BUDGET,
    REASON_NO_PERIODIC_ORBIT,
    RUN_BUDGET,
    RUN_DONE,
    RUN_LIFT_OFF,
    RUN_PARADOX,
    STATIC,
    STICK,
    STICK_SLIP,
)


@njit(cache=True, nogil=True)
def _accelerations(p, mode, drive, y):
    """``(delta'', x'')`` in contact mode ``mode`` with drive acceleration ``drive``."""
    forcing = drive * p[COS_ALPHA] - p[DAMPING] * y[1] - p[STIFFNESS] * y[0]
    if mode == STICK:
        return forcing, 0.0
    s = float(mode)
    m = p[MASS_RATIO]
    ca = p[COS_ALPHA]
    sa = p[SIN_ALPHA]
    ck = p[KINETIC_FRICTION]
    if p[TWO_WAY] != 0.0:
        denominator = 1.0 - m * sa * (sa + s * ck * ca)
        xdd = (-m * sa * forcing - s * ck * (p[GRAVITY] - drive + m * ca * forcing)) / denominator
        return forcing - sa * xdd, xdd
    xdd = -m * sa * forcing - s * ck * (p[GRAVITY] - drive + m * ca * forcing)
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
    ca = p[COS_ALPHA]
    sa = p[SIN_ALPHA]
    m = p[MASS_RATIO]
    forcing_rate = -drive_rate_neg * ca - p[DAMPING] * ddd - p[STIFFNESS] * y[1]
    dddd = forcing_rate
    if mode != STICK and p[TWO_WAY] != 0.0:
        s = float(mode)
        ck = p[KINETIC_FRICTION]
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
    slip s: ``s v`` (slip end); always: ``n`` (lift-off).
    """
    n, tau, n_rate, tau_rate, xdd = _forces(p, mode, drive, drive_rate_neg, y)
    cs = p[STATIC_FRICTION]
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
def _step(p, mode, t, h, y, k, drive_args, y_new, err, dense, tmp):
    """One Dormand-Prince step from ``(t, y)`` with ``k[0] = f(t, y)`` (FSAL).

    Fills ``k[1..6]``, the 5th-order solution ``y_new``, the error estimate ``err``
    and the dense-output coefficients.
    """
    step(_rhs, p, mode, t, h, y, k, drive_args, y_new, err, dense, tmp)
    if mode == STICK:
        # x and v are exactly constant while stuck.
        y_new[2] = y[2]
        y_new[3] = 0.0
        err[2] = 0.0
        err[3] = 0.0


@njit(cache=True, nogil=True)
def _values_at(theta, p, mode, t, h, dense, drive_args, ystate, values, rates):
    seg, seg_t0, seg_omega, seg_a, seg_phase0 = drive_args
    dense_output(theta, h, dense, ystate)
    if mode == STICK:
        ystate[3] = 0.0
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
def _paradox(p, mode):
    if mode == STICK or p[TWO_WAY] == 0.0:
        return False
    s = float(mode)
    sa = p[SIN_ALPHA]
    return 1.0 - p[MASS_RATIO] * sa * (sa + s * p[KINETIC_FRICTION] * p[COS_ALPHA]) <= 0.0


@njit(cache=True, nogil=True)
def integrate(
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
    k, y_new, err, dense, tmp, ystate = step_workspace(n)
    values, rates, prev_values, prev_rates = event_workspace(3)
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
                    record(ev_t, ev_kind, ev_y, ev_box, t,
                            EVENT_RELEASE_FORWARD if mode > 0 else EVENT_RELEASE_BACKWARD, y)
            if _paradox(p, mode):
                record(ev_t, ev_kind, ev_y, ev_box, t, EVENT_PARADOX, y)
                mode_box[0] = mode
                t_box[0] = t
                return RUN_PARADOX
            _event_values(p, mode, drive, rate, y, values, rates)
            if values[2] < 0.0:
                record(ev_t, ev_kind, ev_y, ev_box, t, EVENT_LIFT_OFF, y)
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
                h *= shrink_factor(norm)
                if h < 1e-14 * max(abs(t), max_step):
                    mode_box[0] = mode
                    t_box[0] = t
                    return RUN_BUDGET
                continue
            factor = growth_factor(norm)
        else:
            factor = 1.0
        which, theta = first_event(
            _values_at, p, mode, t, h, dense, drive_args, samples, xtol_time / h, fresh,
            ystate, values, rates, prev_values, prev_rates,
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
            record(ev_t, ev_kind, ev_y, ev_box, t, EVENT_LIFT_OFF, y)
            mode_box[0] = mode
            t_box[0] = t
            return RUN_LIFT_OFF
        if mode == STICK:
            mode = 1 if which == 0 else -1
            fresh = True
            stats[2] += 1.0
            record(ev_t, ev_kind, ev_y, ev_box, t,
                    EVENT_RELEASE_FORWARD if mode > 0 else EVENT_RELEASE_BACKWARD, y)
        else:
            y[3] = 0.0
            record(ev_t, ev_kind, ev_y, ev_box, t, EVENT_SLIP_END, y)
            after = _mode_after_rest(p, drive, y)
            if after == -mode:
                stats[2] += 1.0
                record(ev_t, ev_kind, ev_y, ev_box, t,
                        EVENT_RELEASE_FORWARD if after > 0 else EVENT_RELEASE_BACKWARD, y)
            # A reversal starts a fresh slip; a tangential touch continues the old one.
            fresh = after == -mode
            mode = after
    mode_box[0] = mode
    t_box[0] = t
    t_box[1] = h
    return RUN_DONE


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
        code = integrate(
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
def periodic_points(
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
def periodic_points_serial(
    p, omega, amplitude, y0, rtol, atol, scale, fixed_step, max_step, xtol_time, samples,
    max_steps, max_periods, max_orbit, period_tolerance, results,
):
    """Same as :func:`periodic_points` on the calling thread."""
    for i in range(omega.shape[0]):
        _periodic_point(
            p, omega[i], amplitude[i], y0[i], rtol, atol, scale[i], fixed_step[i],
            max_step[i], xtol_time[i], samples, max_steps, max_periods, max_orbit,
            period_tolerance, results[i],
        )
