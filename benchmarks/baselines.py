"""Baselines of the work-precision benchmark: how a typical user would compute the velocity.

Two time integrators of the paper's one-way stick-slip model (docs/theory/exact-solvers.md),
written independently of :mod:`study`'s kernels (only :class:`study.Structure`, the
input checks and the :class:`study.Status` codes are shared):

* :func:`naive_velocity`: fixed-step classic RK4 in numba, contact-mode switches
  decided by sign tests at step ends only;
* :func:`solve_ivp_velocity`: :func:`scipy.integrate.solve_ivp` with terminal
  events, restarted at every contact event; it also integrates the two-way coupled
  model (``coupling="two-way"``: docs/theory/exact-solvers.md, "Time integration").

Both start where the exact solver starts (at rest, drive phase 0, mode on its steady
one-way response), integrate ``transient_periods`` drive periods, then return the
mean velocity over the next ``average_periods`` periods:
``(x(t_end) - x(t_start)) / (average_periods T)``. No periodicity detection: with
one-way coupling the mode is already steady and an orbit with a stick in every cycle
is reached after a few events, so a fixed window is what a user would write; it
is exact for orbits whose period divides ``average_periods``. With two-way coupling
the mode's transient decays only with the orbit's Floquet multiplier:
:func:`solve_ivp_velocity` then integrates whole periods until the orbit repeats.

Both return ``(velocity, status)`` arrays of the broadcast shape of ``f`` and ``a``:
velocity in m s^-1 (positive forward, NaN unless the status is ``STATIC``,
``STICK_SLIP`` or ``CONTINUOUS_SLIDING``), status as int8
:class:`study.model.status.Status` codes, so they compare directly with
:func:`study.solvers.exact.steady_velocity`:

* ``STATIC`` (0): no slip in the averaging window (velocity exactly 0);
* ``STICK_SLIP`` (1): slipped, and stuck at some time in the averaging window;
* ``CONTINUOUS_SLIDING`` (2): slipped, never stuck in the averaging window;
* ``LIFT_OFF`` (3): ``n < 0`` was seen (velocity NaN);
* ``NOT_CONVERGED`` (4): :func:`solve_ivp_velocity` only, the integrator failed or
  made no progress, or (two-way) no orbit repeated within the period budget
  (velocity NaN);
* ``FRICTION_PARADOX`` (5): two-way :func:`solve_ivp_velocity` only, a slip started
  with ``D_s <= 0`` (velocity NaN).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from study.model import as_acceleration, as_frequency
from study.model.status import Status
from study.model.structure import Structure

__all__ = ["naive_velocity", "solve_ivp_velocity"]

_STATIC = int(Status.STATIC)
_STICK_SLIP = int(Status.STICK_SLIP)
_SLIDING = int(Status.CONTINUOUS_SLIDING)
_LIFT_OFF = int(Status.LIFT_OFF)
_NOT_CONVERGED = int(Status.NOT_CONVERGED)
_PARADOX = int(Status.FRICTION_PARADOX)


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
        :class:`study.model.status.Status` codes (see the module docstring).
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


class _Contact:
    """Right-hand sides, forces and event functions of one drive point, per contact mode.

    One-way: the mode obeys ``delta'' = A ca - c delta' - k delta`` in every contact
    mode. Two-way (docs/theory/exact-solvers.md, "Time integration"): in a slip ``s``
    the base's acceleration ``x''`` also forces the mode, ``delta'' = F - sa x''`` with
    ``F = A ca - c delta' - k delta``, and eliminating ``delta''`` gives
    ``x'' = (tau_F - s ck n_F) / D_s``, ``D_s = 1 - M sa (sa + s ck ca)``, with
    ``tau_F, n_F`` the forces of ``delta'' = F``.
    """

    def __init__(self, p, f, a, two_way):
        c, k, ca, sa, M, cs, ck, g = (float(value) for value in p)
        self.cs = cs
        self.two_way = two_way
        w = 2.0 * math.pi * f
        self.denominator = {s: 1.0 - M * sa * (sa + s * ck * ca) for s in (1, -1)}

        def forces(t, y, mode=0):
            """``(delta'', x'', n, tau)`` in contact ``mode``."""
            drive = a * math.cos(w * t)
            acc = drive * ca - c * y[1] - k * y[0]
            n = g - drive + M * acc * ca
            tau = -M * acc * sa
            if mode == 0:
                return acc, 0.0, n, tau
            xdd = tau - mode * ck * n
            if not two_way:
                return acc, xdd, n, tau
            xdd /= self.denominator[mode]
            acc -= sa * xdd
            return acc, xdd, g - drive + M * acc * ca, -M * acc * sa

        self.forces = forces

        def make_rhs(mode):
            def rhs(t, y):
                acc, xdd, _, _ = forces(t, y, mode)
                return [y[1], acc, y[3], xdd]
            return rhs

        def make_lift_off(mode):
            def lift_off(t, y):
                return forces(t, y, mode)[2]
            lift_off.terminal, lift_off.direction = True, -1.0
            return lift_off

        def release_forward(t, y):
            _, _, n, tau = forces(t, y)
            return tau - cs * n

        def release_backward(t, y):
            _, _, n, tau = forces(t, y)
            return -tau - cs * n

        # One slip-end function per slip sign: the direction is an attribute of the function.
        def slip_end_forward(t, y):
            return y[3]

        def slip_end_backward(t, y):
            return y[3]

        release_forward.terminal, release_forward.direction = True, 1.0
        release_backward.terminal, release_backward.direction = True, 1.0
        slip_end_forward.terminal, slip_end_forward.direction = True, -1.0
        slip_end_backward.terminal, slip_end_backward.direction = True, 1.0
        self.rhs = {mode: make_rhs(mode) for mode in (0, 1, -1)}
        self.events = {
            0: [make_lift_off(0), release_forward, release_backward],
            1: [make_lift_off(1), slip_end_forward],
            -1: [make_lift_off(-1), slip_end_backward],
        }

    def paradox(self, mode):
        """A two-way slip of sign ``mode`` has no unique solution (``D_s <= 0``)."""
        return self.two_way and mode != 0 and self.denominator[mode] <= 0.0


def _advance(model, t, y, mode, target, rtol, atol, method, max_step, budget, seen):
    """Integrate from ``t`` to ``target`` through contact events, one ``solve_ivp`` call
    per contact segment.

    ``budget[0]`` counts segments (against ``budget[1]``); ``seen[0]``, ``seen[1]`` are
    set when a segment is spent stuck, slipping (``seen`` None: not recorded).
    Returns ``(t, y, mode, code)``, ``code`` None once ``target`` is reached, else the
    status code that stopped the point.
    """
    period_scale = max_step
    while t < target:
        budget[0] += 1
        if budget[0] > budget[1]:
            return t, y, mode, _NOT_CONVERGED
        if seen is not None:
            if mode == 0:
                seen[0] = True
            else:
                seen[1] = True
        # A slip starts with v = 0 on its own event function: if the first step is so
        # long that v goes out and back, Brent's method returns the segment start and
        # the loop would stall. Then retry with ever smaller first steps.
        first_step = None
        while True:
            sol = solve_ivp(model.rhs[mode], (t, target), y, method=method, rtol=rtol,
                            atol=atol, max_step=max_step, first_step=first_step,
                            events=model.events[mode])
            if sol.status < 0:
                return t, y, mode, _NOT_CONVERGED
            if sol.status == 0:
                break
            # A terminal event: the earliest one recorded.
            fired = [(te[0], i) for i, te in enumerate(sol.t_events) if te.size]
            t_event, index = min(fired)
            if t_event > t or index == 0:
                break
            first_step = (period_scale if first_step is None else first_step) / 100.0
            if first_step < 1e-15 * period_scale:
                return t, y, mode, _NOT_CONVERGED
        if sol.status == 0:
            return target, sol.y[:, -1].copy(), mode, None
        y = sol.y_events[index][0].copy()
        t = float(t_event)
        if index == 0:
            return t, y, mode, _LIFT_OFF
        y[3] = 0.0
        _, _, n, tau = model.forces(t, y)
        if mode == 0:
            mode = 1 if index == 1 else -1
        else:
            s = mode
            if -s * tau > model.cs * n:
                mode = -s
            elif s * tau > model.cs * n:
                mode = s
            else:
                mode = 0
        if model.paradox(mode):
            return t, y, mode, _PARADOX
    return t, y, mode, None


def _initial_mode(model, y):
    """Contact test at ``t = 0``: ``(mode, code)``."""
    _, _, n, tau = model.forces(0.0, y)
    if n < 0.0:
        return 0, _LIFT_OFF
    mode = 0
    if abs(tau) > model.cs * n:
        mode = 1 if tau > 0.0 else -1
    if model.paradox(mode):
        return mode, _PARADOX
    return mode, None


def _solve_ivp_point(p, f, a, delta0, rate0, rtol, method, transient, average,
                     max_step_periods, max_segments):
    """One-way: a fixed transient, then the mean velocity over a fixed window."""
    model = _Contact(p, f, a, two_way=False)
    period = 1.0 / f
    atol = rtol * _natural_units(p, f)
    y = np.array([delta0, rate0, 0.0, 0.0])
    mode, code = _initial_mode(model, y)
    if code is not None:
        return math.nan, code
    t = 0.0
    seen = [False, False]
    budget = [0, max_segments]
    x_start = 0.0
    for target, in_window in ((transient * period, False),
                              ((transient + average) * period, True)):
        if in_window:
            x_start = y[2]
        t, y, mode, code = _advance(model, t, y, mode, target, rtol, atol, method,
                                    max_step_periods * period, budget,
                                    seen if in_window else None)
        if code is not None:
            return math.nan, code
    velocity = (y[2] - x_start) / (average * period)
    if not seen[1]:
        return velocity, _STATIC
    if seen[0]:
        return velocity, _STICK_SLIP
    return velocity, _SLIDING


def _solve_ivp_orbit(p, f, a, delta0, rate0, rtol, method, max_step_periods, max_segments,
                     max_periods, max_orbit_period, period_tolerance):
    """Two-way: whole drive periods until the state at the period boundaries repeats.

    Returns ``(velocity, status, periods integrated, orbit period)``.
    """
    model = _Contact(p, f, a, two_way=True)
    period = 1.0 / f
    units = _natural_units(p, f)
    atol = rtol * units
    y = np.array([delta0, rate0, 0.0, 0.0])
    mode, code = _initial_mode(model, y)
    if code is not None:
        return math.nan, code, 0, 0
    budget = [0, max_segments]
    history = []  # per period: (delta, delta', v, mode, displacement, stuck, slipped)
    for k in range(max_periods):
        # The drive is periodic: each period restarts at t = 0 (full phase precision).
        y[2] = 0.0
        seen = [False, False]
        _, y, mode, code = _advance(model, 0.0, y, mode, period, rtol, atol, method,
                                    max_step_periods * period, budget, seen)
        if code is not None:
            return math.nan, code, k + 1, 0
        history.append((y[0], y[1], y[3], mode, y[2], seen[0], seen[1]))
        del history[:-(max_orbit_period + 1)]
        last = history[-1]
        for q in range(1, min(max_orbit_period, len(history) - 1) + 1):
            other = history[-1 - q]
            if other[3] != last[3]:
                continue
            gap = max(abs(last[0] - other[0]) / units[0], abs(last[1] - other[1]) / units[1],
                      abs(last[2] - other[2]) / units[3], abs(last[4] - other[4]) / units[2])
            if not gap <= period_tolerance:
                continue
            orbit = history[-q:]
            velocity = sum(entry[4] for entry in orbit) / (q * period)
            if not any(entry[6] for entry in orbit):
                return 0.0, _STATIC, k + 1, q
            if any(entry[5] for entry in orbit):
                return velocity, _STICK_SLIP, k + 1, q
            return velocity, _SLIDING, k + 1, q
    return math.nan, _NOT_CONVERGED, max_periods, 0


def _natural_units(p, f):
    """``(g/W^2, g/W, g/w^2, g/w)``, ``W = max(w, w0)``: the absolute tolerance's scales."""
    w = 2.0 * math.pi * f
    g = float(p[7])
    fastest = max(w, math.sqrt(float(p[1])))
    return np.array([g / fastest**2, g / fastest, g / w**2, g / w])


def solve_ivp_velocity(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    rtol: float,
    method: str = "RK45",
    *,
    coupling: str = "one-way",
    transient_periods: int = 20,
    average_periods: int = 10,
    max_step_periods: float = 0.125,
    max_segments: int = 100_000,
    max_periods: int = 5_000,
    max_orbit_period: int = 8,
    period_tolerance: float | None = None,
    periods: NDArray[np.int64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Mean steady velocity by :func:`scipy.integrate.solve_ivp` with terminal events.

    Algorithm: the careful user's event-driven integration. Each contact mode is one
    ``solve_ivp`` call on ``(delta, delta', x, v)`` with terminal ``events``: in stick,
    forward release ``tau - cs n`` and backward release ``-tau - cs n`` crossing zero
    upwards; in a slip ``s``, slip end ``v`` crossing zero in direction ``-s``; in every
    mode lift-off, ``n`` crossing zero downwards (the point is then ``LIFT_OFF``, NaN).
    At each event ``solve_ivp`` is restarted from the located event state with the new
    mode: a release starts a slip in its sign; at a slip end ``v`` is set to 0 and the
    slip reverses if ``-s tau > cs n``, continues if ``s tau > cs n``, otherwise sticks
    (``tau``, ``n`` of the stuck mode).
    ``rtol`` as given, ``atol = rtol * (g/W^2, g/W, g/w^2, g/w)`` per component
    (``W = max(w, w0)``), ``max_step = max_step_periods * T``. Pure Python right-hand
    side and events, points in a Python loop: slow by design.

    ``coupling="one-way"`` (the paper's model): same start and velocity window as
    :func:`naive_velocity`; the end of the transient is a segment boundary.

    ``coupling="two-way"``: the base's slip acceleration forces the mode too
    (:class:`_Contact`), so the mode's transient decays only with the orbit's Floquet
    multiplier and no fixed window is safe. From the same start, whole drive periods
    are integrated (each a segment boundary, time restarted at 0: the drive is
    periodic) until the state at the period boundaries (``delta``, ``delta'``, ``v``,
    mode) and the displacement over a period repeat after ``q <= max_orbit_period``
    periods within ``period_tolerance`` in the units above (default
    ``max(100 rtol, 1e-12)``, the rule of :func:`study.solvers.integrator.integrated_steady_state`);
    the velocity is then the displacement over those ``q`` periods divided by
    ``q T``. ``NOT_CONVERGED`` after ``max_periods`` periods; a slip with
    ``D_s <= 0`` is ``FRICTION_PARADOX``.

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
    coupling : {"one-way", "two-way"}
        The model.
    transient_periods, average_periods : int
        One-way: periods integrated before averaging, and averaged over.
    max_step_periods : float
        Largest step [drive periods].
    max_segments : int
        Budget of ``solve_ivp`` calls (contact segments) per point, then
        ``NOT_CONVERGED``.
    max_periods, max_orbit_period : int
        Two-way: periods integrated before ``NOT_CONVERGED``; longest orbit looked for.
    period_tolerance : float, optional
        Two-way: the periodicity tolerance (see above).
    periods : numpy.ndarray of int64, optional
        Two-way: receives the drive periods integrated at each point (flat).

    Returns
    -------
    velocity : numpy.ndarray of float64
        Mean velocity [m s^-1], positive forward; NaN for ``LIFT_OFF``,
        ``NOT_CONVERGED`` and ``FRICTION_PARADOX``.
    status : numpy.ndarray of int8
        :class:`study.model.status.Status` codes (see the module docstring).
    """
    p = _parameters(structure)
    if not (isinstance(rtol, int | float | np.floating) and 0.0 < float(rtol) < 1.0):
        raise ValueError(f"rtol must be a number in (0, 1), got {rtol!r}")
    if coupling not in ("one-way", "two-way"):
        raise ValueError(f"coupling must be 'one-way' or 'two-way', got {coupling!r}")
    _check_periods(transient_periods, average_periods)
    _check_periods(max_periods, max_orbit_period)
    tolerance = (max(100.0 * float(rtol), 1e-12) if period_tolerance is None
                 else float(period_tolerance))
    f_arr, a_arr = _points(f, a)
    shape = f_arr.shape
    f_flat = np.ascontiguousarray(f_arr, dtype=float).ravel()
    a_flat = np.ascontiguousarray(a_arr, dtype=float).ravel()
    delta0, rate0 = _steady_mode_start(p, f_flat, a_flat)
    velocity = np.empty(f_flat.size)
    status = np.empty(f_flat.size, dtype=np.int8)
    for j in range(f_flat.size):
        if coupling == "one-way":
            velocity[j], status[j] = _solve_ivp_point(
                p, float(f_flat[j]), float(a_flat[j]), float(delta0[j]), float(rate0[j]),
                float(rtol), method, int(transient_periods), int(average_periods),
                float(max_step_periods), int(max_segments),
            )
            continue
        velocity[j], status[j], spent, _ = _solve_ivp_orbit(
            p, float(f_flat[j]), float(a_flat[j]), float(delta0[j]), float(rate0[j]),
            float(rtol), method, float(max_step_periods), int(max_segments),
            int(max_periods), int(max_orbit_period), tolerance,
        )
        if periods is not None:
            periods[j] = spent
    return velocity.reshape(shape), status.reshape(shape)
