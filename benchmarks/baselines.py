"""Baselines of the work-precision benchmark: how a typical user would compute the velocity.

Two time integrators of the paper's one-way stick-slip model (README, "How the solver works"),
written independently of :mod:`study`'s kernels (only :class:`study.Structure`, the
input checks and the :class:`study.Status` codes are shared):

* :func:`naive_velocity`: fixed-step classic RK4 in numba, contact-mode switches
  decided by sign tests at step ends only;
* :func:`solve_ivp_velocity`: :func:`scipy.integrate.solve_ivp` with terminal
  events, restarted at every contact event.

Both start where the exact solver starts (at rest, drive phase 0, mode on its steady
one-way response), integrate ``transient_periods`` drive periods, then return the
mean velocity over the next ``average_periods`` periods:
``(x(t_end) - x(t_start)) / (average_periods T)``. No periodicity detection: with
one-way coupling the mode is already steady and an orbit with a stick in every cycle
is reached after a few events, so a fixed window is what a user would write; it
is exact for orbits whose period divides ``average_periods``.

Both return ``(velocity, status)`` arrays of the broadcast shape of ``f`` and ``a``:
velocity in m s^-1 (positive forward, NaN unless the status is ``STATIC``,
``STICK_SLIP`` or ``CONTINUOUS_SLIDING``), status as int8
:class:`study.status.Status` codes, so they compare directly with
:func:`study.solver.steady_velocity`:

* ``STATIC`` (0): no slip in the averaging window (velocity exactly 0);
* ``STICK_SLIP`` (1): slipped, and stuck at some time in the averaging window;
* ``CONTINUOUS_SLIDING`` (2): slipped, never stuck in the averaging window;
* ``LIFT_OFF`` (3): ``n < 0`` was seen (velocity NaN);
* ``NOT_CONVERGED`` (4): :func:`solve_ivp_velocity` only, the integrator failed or
  made no progress (velocity NaN).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from study.physics import as_acceleration, as_frequency
from study.status import Status
from study.structure import Structure

__all__ = ["naive_velocity", "solve_ivp_velocity"]

_STATIC = int(Status.STATIC)
_STICK_SLIP = int(Status.STICK_SLIP)
_SLIDING = int(Status.CONTINUOUS_SLIDING)
_LIFT_OFF = int(Status.LIFT_OFF)
_NOT_CONVERGED = int(Status.NOT_CONVERGED)


def _parameters(structure: Structure) -> NDArray[np.float64]:
    """``(w0/Q, w0^2, cos(alpha), sin(alpha), M, cs, ck, g)``."""
    if not isinstance(structure, Structure):
        raise TypeError(f"structure must be a study.Structure, got {type(structure).__name__}")
    w0 = structure.omega0
    return np.array(
        [
            w0 / structure.Q,
            w0 * w0,
            math.cos(structure.alpha_rad),
            math.sin(structure.alpha_rad),
            structure.M,
            structure.cs,
            structure.ck,
            structure.g,
        ]
    )


def _points(f: ArrayLike, a: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    f_arr, a_arr = np.broadcast_arrays(as_frequency(f), as_acceleration(a))
    return f_arr, a_arr


def _steady_mode_start(
    p: NDArray[np.float64], f: NDArray[np.float64], a: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``delta = Re[a cos(alpha) G]``, ``delta' = Re[i w a cos(alpha) G]`` at ``t = 0``."""
    w = 2.0 * np.pi * f
    G = 1.0 / (p[1] - w * w + 1j * p[0] * w)
    amplitude = a * p[2] * G
    return amplitude.real, (1j * w * amplitude).real


def _check_periods(transient_periods: int, average_periods: int) -> None:
    for name, value in (("transient_periods", transient_periods),
                        ("average_periods", average_periods)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")


# --------------------------------------------------------------------------------------
# Naive fixed-step RK4
# --------------------------------------------------------------------------------------


@njit(cache=True)
def _rhs(p, omega, a, t, y, mode, out):
    """Right-hand side of ``(delta, delta', x, v)`` in contact ``mode`` (0 stick, +-1 slip)."""
    drive = a * math.cos(omega * t)
    acc = drive * p[2] - p[0] * y[1] - p[1] * y[0]
    out[0] = y[1]
    out[1] = acc
    out[2] = y[3]
    if mode == 0:
        out[3] = 0.0
    else:
        n = p[7] - drive + p[4] * acc * p[2]
        tau = -p[4] * acc * p[3]
        out[3] = tau - mode * p[6] * n


@njit(cache=True)
def _naive_point(p, omega, a, delta0, rate0, steps_per_period, transient, average):
    """One drive point: ``(velocity, status)``."""
    period = 2.0 * math.pi / omega
    h = period / steps_per_period
    y = np.array([delta0, rate0, 0.0, 0.0])
    stage = np.empty(4)
    k1 = np.empty(4)
    k2 = np.empty(4)
    k3 = np.empty(4)
    k4 = np.empty(4)
    cs, g, M, ca, sa = p[5], p[7], p[4], p[2], p[3]
    # Contact at t = 0, decided like at every step end.
    acc = a * ca - p[0] * y[1] - p[1] * y[0]
    n = g - a + M * acc * ca
    tau = -M * acc * sa
    if n < 0.0:
        return math.nan, _LIFT_OFF
    mode = 0
    if abs(tau) > cs * n:
        mode = 1 if tau > 0.0 else -1
    stuck_in_window = False
    slipped_in_window = False
    start_step = transient * steps_per_period
    total = (transient + average) * steps_per_period
    x_start = 0.0
    for k in range(total):
        if k == start_step:
            x_start = y[2]
        if k >= start_step:  # the mode in effect during this step
            if mode == 0:
                stuck_in_window = True
            else:
                slipped_in_window = True
        t = k * h
        _rhs(p, omega, a, t, y, mode, k1)
        for i in range(4):
            stage[i] = y[i] + 0.5 * h * k1[i]
        _rhs(p, omega, a, t + 0.5 * h, stage, mode, k2)
        for i in range(4):
            stage[i] = y[i] + 0.5 * h * k2[i]
        _rhs(p, omega, a, t + 0.5 * h, stage, mode, k3)
        for i in range(4):
            stage[i] = y[i] + h * k3[i]
        _rhs(p, omega, a, t + h, stage, mode, k4)
        for i in range(4):
            y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        # Sign tests at the step end only.
        t_end = (k + 1) * h
        drive = a * math.cos(omega * t_end)
        acc = drive * ca - p[0] * y[1] - p[1] * y[0]
        n = g - drive + M * acc * ca
        tau = -M * acc * sa
        if n < 0.0:
            return math.nan, _LIFT_OFF
        if mode == 0:
            if abs(tau) > cs * n:
                mode = 1 if tau > 0.0 else -1
        elif mode * y[3] <= 0.0:
            y[3] = 0.0
            s = mode
            if -s * tau > cs * n:
                mode = -s
            elif s * tau > cs * n:
                mode = s
            else:
                mode = 0
    velocity = (y[2] - x_start) / (average * period)
    if not slipped_in_window:
        return velocity, _STATIC
    if stuck_in_window:
        return velocity, _STICK_SLIP
    return velocity, _SLIDING


@njit(cache=True)
def _naive_points(p, omega, a, delta0, rate0, steps_per_period, transient, average,
                  velocity, status):
    for j in range(omega.size):
        v, code = _naive_point(p, omega[j], a[j], delta0[j], rate0[j], steps_per_period,
                               transient, average)
        velocity[j] = v
        status[j] = code


def naive_velocity(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    steps_per_period: int,
    *,
    transient_periods: int = 20,
    average_periods: int = 10,
) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Mean steady velocity by fixed-step RK4 with step-end sign tests (the naive baseline).

    Algorithm: classic 4th-order Runge-Kutta with the fixed step
    ``h = T / steps_per_period`` on the state ``(delta, delta', x, v)`` of the one-way
    model, in the current contact mode (stick: ``v' = 0``; slip ``s = +-1``:
    ``v' = tau - s ck n``). The mode is changed only by sign tests at step ends, with
    no event location: in stick, if ``|tau| > cs n`` the slip starts in the sign of
    ``tau``; in a slip ``s``, once ``s v <= 0`` then ``v`` is set to 0 and the slip
    reverses if ``-s tau > cs n``, continues if ``s tau > cs n``, otherwise sticks.
    ``n < 0`` at a step end stops the point as ``LIFT_OFF``. Start at rest, drive
    phase 0, mode on its steady one-way response; after ``transient_periods``
    periods the velocity is the displacement over ``average_periods`` periods
    divided by their duration. Compiled with numba; points in a numba loop.

    Known weakness: every contact event is placed at the end of the step in which it
    happens, an ``O(h)`` error in the event time, and the right-hand side is
    discontinuous inside that step; the result is therefore only first order in
    ``h`` whatever the order of RK4 (plus the ``O(h)`` chance of missing a lift-off
    dip or a slip shorter than a step). The error is a staircase in ``h``: it stays
    put while an event keeps landing in the same step, then drops. Orbits with
    reversals (PN) show the first order plainly; a release from stick with
    ``ck = cs`` starts at zero acceleration, so a late release costs only ``O(h^2)``
    and single-slip orbits (P, N) converge faster than first order.

    Parameters
    ----------
    structure : study.Structure
        The structure.
    f, a : array_like
        Drive frequency [Hz] > 0 and acceleration amplitude [m s^-2] >= 0, broadcast.
    steps_per_period : int
        Fixed RK4 steps per drive period.
    transient_periods, average_periods : int
        Periods integrated before averaging, and averaged over.

    Returns
    -------
    velocity : numpy.ndarray of float64
        Mean velocity [m s^-1], positive forward; NaN for ``LIFT_OFF``.
    status : numpy.ndarray of int8
        :class:`study.status.Status` codes (see the module docstring).
    """
    p = _parameters(structure)
    if (isinstance(steps_per_period, bool) or not isinstance(steps_per_period, int | np.integer)
            or steps_per_period < 1):
        raise ValueError(f"steps_per_period must be an integer >= 1, got {steps_per_period!r}")
    _check_periods(transient_periods, average_periods)
    f_arr, a_arr = _points(f, a)
    shape = f_arr.shape
    f_flat = np.ascontiguousarray(f_arr, dtype=float).ravel()
    a_flat = np.ascontiguousarray(a_arr, dtype=float).ravel()
    delta0, rate0 = _steady_mode_start(p, f_flat, a_flat)
    velocity = np.empty(f_flat.size)
    status = np.empty(f_flat.size, dtype=np.int8)
    _naive_points(p, 2.0 * np.pi * f_flat, a_flat, np.ascontiguousarray(delta0),
                  np.ascontiguousarray(rate0), int(steps_per_period), int(transient_periods),
                  int(average_periods), velocity, status)
    return velocity.reshape(shape), status.reshape(shape)


# --------------------------------------------------------------------------------------
# scipy.integrate.solve_ivp with terminal events
# --------------------------------------------------------------------------------------


def _solve_ivp_point(p, f, a, delta0, rate0, rtol, method, transient, average,
                     max_step_periods, max_segments):
    c, k, ca, sa, M, cs, ck, g = (float(value) for value in p)
    w = 2.0 * math.pi * f
    period = 1.0 / f
    fastest = max(w, math.sqrt(k))
    atol = rtol * np.array([g / fastest**2, g / fastest, g / w**2, g / w])

    def forces(t, y):
        drive = a * math.cos(w * t)
        acc = drive * ca - c * y[1] - k * y[0]
        return acc, g - drive + M * acc * ca, -M * acc * sa

    def make_rhs(mode):
        def rhs(t, y):
            acc, n, tau = forces(t, y)
            vdot = 0.0 if mode == 0 else tau - mode * ck * n
            return [y[1], acc, y[3], vdot]
        return rhs

    def lift_off(t, y):
        return forces(t, y)[1]

    def release_forward(t, y):
        _, n, tau = forces(t, y)
        return tau - cs * n

    def release_backward(t, y):
        _, n, tau = forces(t, y)
        return -tau - cs * n

    # One slip-end function per slip sign: the direction is an attribute of the function.
    def slip_end_forward(t, y):
        return y[3]

    def slip_end_backward(t, y):
        return y[3]

    lift_off.terminal, lift_off.direction = True, -1.0
    release_forward.terminal, release_forward.direction = True, 1.0
    release_backward.terminal, release_backward.direction = True, 1.0

    slip_end_forward.terminal, slip_end_forward.direction = True, -1.0
    slip_end_backward.terminal, slip_end_backward.direction = True, 1.0
    rhs = {0: make_rhs(0), 1: make_rhs(1), -1: make_rhs(-1)}
    events = {
        0: [lift_off, release_forward, release_backward],
        1: [lift_off, slip_end_forward],
        -1: [lift_off, slip_end_backward],
    }

    t = 0.0
    y = np.array([delta0, rate0, 0.0, 0.0])
    _, n, tau = forces(t, y)
    if n < 0.0:
        return math.nan, _LIFT_OFF
    mode = 0
    if abs(tau) > cs * n:
        mode = 1 if tau > 0.0 else -1
    stuck_in_window = False
    slipped_in_window = False
    x_start = 0.0
    segments = 0
    for target, in_window in ((transient * period, False),
                              ((transient + average) * period, True)):
        if in_window:
            x_start = y[2]
        while t < target:
            segments += 1
            if segments > max_segments:
                return math.nan, _NOT_CONVERGED
            if in_window:
                if mode == 0:
                    stuck_in_window = True
                else:
                    slipped_in_window = True
            # A slip starts with v = 0 on its own event function: if the first step is so
            # long that v goes out and back, Brent's method returns the segment start and
            # the loop would stall. Then retry with ever smaller first steps.
            first_step = None
            while True:
                sol = solve_ivp(rhs[mode], (t, target), y, method=method, rtol=rtol,
                                atol=atol, max_step=max_step_periods * period,
                                first_step=first_step, events=events[mode])
                if sol.status < 0:
                    return math.nan, _NOT_CONVERGED
                if sol.status == 0:
                    break
                # A terminal event: the earliest one recorded.
                fired = [(te[0], i) for i, te in enumerate(sol.t_events) if te.size]
                t_event, index = min(fired)
                if t_event > t or index == 0:
                    break
                first_step = (max_step_periods * period if first_step is None
                              else first_step) / 100.0
                if first_step < 1e-15 * period:
                    return math.nan, _NOT_CONVERGED
            if sol.status == 0:
                t, y = target, sol.y[:, -1].copy()
                break
            y = sol.y_events[index][0].copy()
            t = float(t_event)
            if index == 0:
                return math.nan, _LIFT_OFF
            y[3] = 0.0
            _, n, tau = forces(t, y)
            if mode == 0:
                mode = 1 if index == 1 else -1
            else:
                s = mode
                if -s * tau > cs * n:
                    mode = -s
                elif s * tau > cs * n:
                    mode = s
                else:
                    mode = 0
    velocity = (y[2] - x_start) / (average * period)
    if not slipped_in_window:
        return velocity, _STATIC
    if stuck_in_window:
        return velocity, _STICK_SLIP
    return velocity, _SLIDING


def solve_ivp_velocity(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    rtol: float,
    method: str = "RK45",
    *,
    transient_periods: int = 20,
    average_periods: int = 10,
    max_step_periods: float = 0.125,
    max_segments: int = 100_000,
) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Mean steady velocity by :func:`scipy.integrate.solve_ivp` with terminal events.

    Algorithm: the careful user's event-driven integration. Each contact mode is one
    ``solve_ivp`` call on ``(delta, delta', x, v)`` with terminal ``events``: in stick,
    forward release ``tau - cs n`` and backward release ``-tau - cs n`` crossing zero
    upwards; in a slip ``s``, slip end ``v`` crossing zero in direction ``-s``; in every
    mode lift-off, ``n`` crossing zero downwards (the point is then ``LIFT_OFF``, NaN).
    At each event ``solve_ivp`` is restarted from the located event state with the new
    mode: a release starts a slip in its sign; at a slip end ``v`` is set to 0 and the
    slip reverses if ``-s tau > cs n``, continues if ``s tau > cs n``, otherwise sticks.
    ``rtol`` as given, ``atol = rtol * (g/W^2, g/W, g/w^2, g/w)`` per component
    (``W = max(w, w0)``), ``max_step = max_step_periods * T``. Same start and velocity
    window as :func:`naive_velocity`; the end of the transient is a segment boundary.
    Pure Python right-hand side and events, points in a Python loop: slow by design.

    Known weakness: ``solve_ivp`` looks for events only as sign changes of the event
    functions between consecutive accepted steps (then locates them by Brent's
    method): a slip, release window or lift-off dip shorter than a step in which the
    function goes out and back is missed, and an event function that starts at zero
    (``v = 0`` at a slip start) is only safe if it leaves zero in the expected
    direction (when it does not, Brent's method returns the segment start: the segment
    is then retried with first steps 100 times shorter each time). The error is
    controlled by ``rtol`` only through the step size.

    Parameters
    ----------
    structure : study.Structure
        The structure.
    f, a : array_like
        Drive frequency [Hz] > 0 and acceleration amplitude [m s^-2] >= 0, broadcast.
    rtol : float
        Relative tolerance of ``solve_ivp``.
    method : str
        ``solve_ivp`` method ("RK45", "DOP853", "Radau", ...).
    transient_periods, average_periods : int
        Periods integrated before averaging, and averaged over.
    max_step_periods : float
        Largest step [drive periods].
    max_segments : int
        Budget of ``solve_ivp`` calls (contact segments) per point, then
        ``NOT_CONVERGED``.

    Returns
    -------
    velocity : numpy.ndarray of float64
        Mean velocity [m s^-1], positive forward; NaN for ``LIFT_OFF`` and
        ``NOT_CONVERGED``.
    status : numpy.ndarray of int8
        :class:`study.status.Status` codes (see the module docstring).
    """
    p = _parameters(structure)
    if not (isinstance(rtol, int | float | np.floating) and 0.0 < float(rtol) < 1.0):
        raise ValueError(f"rtol must be a number in (0, 1), got {rtol!r}")
    _check_periods(transient_periods, average_periods)
    f_arr, a_arr = _points(f, a)
    shape = f_arr.shape
    f_flat = np.ascontiguousarray(f_arr, dtype=float).ravel()
    a_flat = np.ascontiguousarray(a_arr, dtype=float).ravel()
    delta0, rate0 = _steady_mode_start(p, f_flat, a_flat)
    velocity = np.empty(f_flat.size)
    status = np.empty(f_flat.size, dtype=np.int8)
    for j in range(f_flat.size):
        velocity[j], status[j] = _solve_ivp_point(
            p, float(f_flat[j]), float(a_flat[j]), float(delta0[j]), float(rate0[j]),
            float(rtol), method, int(transient_periods), int(average_periods),
            float(max_step_periods), int(max_segments),
        )
    return velocity.reshape(shape), status.reshape(shape)
