"""Slow, high-accuracy reference integrator for the single-plate stick-slip model.

This module is an *independent* check of the fast closed-form velocity solver in
the ``study`` package. It deliberately imports nothing from ``study`` and uses no
closed-form solution of the sliding motion: the hybrid (stick / slip) system is
integrated numerically with :func:`scipy.integrate.solve_ivp` (``DOP853``) and
terminal event location, restarting at every event with the updated discrete
mode. The only closed form used is the steady harmonic response of the plate
mode, to set its initial state.

Model (per unit total mass, table frame, SI units; see the README, "How the solver works")
---------------------------------------------------------------------------
State ``y = (delta, ddelta_dt, x, v)``; drive acceleration ``a cos(w t)``.

* mode: ``delta'' + (w0/Q) delta' + w0^2 delta = a cos(w t) cos(alpha)``
  (one-way coupling: the mode does not feel the sliding);
* normal force ``n = g - a cos(w t) + M delta'' cos(alpha)``;
* tangential force ``tau = -M delta'' sin(alpha)``;
* stick (``v = 0``, ``x`` constant) while ``|tau| <= cs n``;
* slip of sign ``s``: ``dv/dt = tau - ck n s``, ``dx/dt = v``.

Two-way coupling (``coupling="two-way"``)
-----------------------------------------
While the base slides, its horizontal acceleration ``x''`` also forces the mode:

* mode: ``delta'' + (w0/Q) delta' + w0^2 delta = a cos(w t) cos(alpha) - x'' sin(alpha)``;
* ``x'' = tau - s ck n`` with ``tau`` and ``n`` as above (functions of ``delta''``).

In a slip the pair ``(delta'', x'')`` is the solution of a 2x2 linear system, solved
numerically (Cramer's rule on the matrix built from the two equations as written) at
every right-hand-side call; no eliminated closed form is used. Its determinant
``1 - M sin(alpha) (sin(alpha) + s ck cos(alpha))`` must be positive for the slip
direction entered, else the status is ``"friction_paradox"`` (Painleve). In stick
``x'' = 0`` and everything is as in the one-way model; the transitions below are
unchanged (at ``v = 0`` they use the stick forces).

Transitions
-----------
* stick -> slip ``+1`` when ``tau - cs n`` crosses zero upwards, slip ``-1``
  when ``-tau - cs n`` crosses zero upwards (immediately if already positive
  at the start of the stick phase);
* in slip of sign ``s``, at ``v = 0`` (crossing in direction ``-s``): reverse if
  ``-s tau - cs n > 0``; else continue with sign ``s`` if ``s tau - cs n > 0``
  (tangential touch); else stick.

Run this file directly for a small demonstration on paper parameters.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

__all__ = ["ReferenceModelInvalid", "reference_slide_to_rest", "reference_velocity"]

#: Statuses returned by :func:`reference_velocity`.
STATUSES = (
    "static",
    "stick_slip",
    "continuous_sliding",
    "lift_off",
    "not_converged",
    "friction_paradox",
)

#: Accepted values of the ``coupling`` keyword.
COUPLINGS = ("one-way", "two-way")

_STICK = 0
_EPS = float(np.finfo(float).eps)
_MAX_K = 8  # longest orbit period (in drive periods) that is looked for
_GUARD = 1e-8  # event-suppression window after a slip start, in drive periods
_STICK_MIN = 1e-10  # stick phases shorter than this (in drive periods) do not count
_STEPS_PER_PERIOD = 64  # max_step = T / _STEPS_PER_PERIOD
_N_SAMPLES = 4096  # samples of n(t) over one period for the lift-off test
_MAX_SEGMENTS_PER_PERIOD = 10_000
_MAX_PERIODS = {"one-way": 400, "two-way": 2000}  # default max_periods
_PERIOD_TOL = {"one-way": 1e-13, "two-way": 1e-9}  # default period_tol


class _LiftOff(Exception):
    """Raised internally when the normal force becomes negative."""


class _FrictionParadox(Exception):
    """Raised internally when a two-way slip with a non-positive determinant starts."""


class ReferenceModelInvalid(ValueError):
    """The model is invalid along the computed motion.

    Attributes
    ----------
    status : str
        ``"lift_off"`` or ``"friction_paradox"``.
    """

    def __init__(self, status, message):
        super().__init__(f"{status}: {message}")
        self.status = status


class System:
    """Right-hand sides and event functions of the hybrid system.

    Parameters
    ----------
    f0, Q, alpha_deg, M, cs, ck, g, f, a : float
        Model parameters, see :func:`reference_velocity`.
    two_way : bool, optional
        Two-way coupling: in slip, ``x''`` forces the mode. Only the methods
        named ``*_slip2`` (and :meth:`slip_accels`, :meth:`apex_lift`) serve
        it; the one-way methods are unchanged.
    """

    def __init__(self, f0, Q, alpha_deg, M, cs, ck, g, f, a, two_way=False):
        self.w0 = 2.0 * math.pi * f0
        self.w = 2.0 * math.pi * f
        self.c = self.w0 / Q
        self.k = self.w0 * self.w0
        alpha = math.radians(alpha_deg)
        self.ca = math.cos(alpha)
        self.sa = math.sin(alpha)
        self.M = M
        self.cs = cs
        self.ck = ck
        self.g = g
        self.a = a
        self.A = a * self.ca  # mode forcing amplitude
        self.two_way = two_way
        # Two-way slip of sign s: unknowns u = (delta'', x''),
        #   delta'' + sin(alpha) x''                         = F
        #   M (sin(alpha) + s ck cos(alpha)) delta'' + x''   = -s ck (g - a cos(w t))
        # with F = a cos(alpha) cos(w t) - (w0/Q) delta' - w0^2 delta. The rows are
        # the mode equation and x'' = tau - s ck n with tau, n written out.
        self.mat = {}
        self.det = {}
        for s in (+1, -1):
            m11, m12 = 1.0, self.sa
            m21, m22 = M * (self.sa + s * ck * self.ca), 1.0
            self.mat[s] = (m11, m12, m21, m22)
            self.det[s] = m11 * m22 - m12 * m21

    # -- two-way slip: the 2x2 linear system --------------------------------------
    def _solve2(self, s, b1, b2):
        """Solve the slip system of sign ``s`` for right-hand side ``(b1, b2)``.

        Cramer's rule on the 2x2 matrix ``self.mat[s]``; returns ``(u1, u2)``.
        """
        m11, m12, m21, m22 = self.mat[s]
        det = self.det[s]
        return (b1 * m22 - m12 * b2) / det, (m11 * b2 - m21 * b1) / det

    def slip_accels(self, t, y, s):
        """Return ``(delta'', x'')`` in a two-way slip of sign ``s``."""
        cwt = math.cos(self.w * t)
        b1 = self.A * cwt - self.c * y[1] - self.k * y[0]
        b2 = -s * self.ck * (self.g - self.a * cwt)
        return self._solve2(s, b1, b2)

    def forces_slip2(self, s):
        """Return ``(t, y) -> (tau, n)`` in a two-way slip of sign ``s``."""

        def forces(t, y):
            acc, _ = self.slip_accels(t, y, s)
            n = self.g - self.a * math.cos(self.w * t) + self.M * acc * self.ca
            tau = -self.M * acc * self.sa
            return tau, n

        return forces

    def rhs_slip2(self, s):
        """Right-hand side of a two-way slip of sign ``s``."""

        def rhs(t, y):
            acc, xacc = self.slip_accels(t, y, s)
            return [y[1], acc, y[3], xacc]

        return rhs

    def normal_rate_slip2(self, t, y, s):
        """``dn/dt`` in a two-way slip of sign ``s``.

        Differentiating the slip system in time gives the same matrix acting on
        the rates of ``(delta'', x'')``; then
        ``dn/dt = a w sin(w t) + M cos(alpha) d(delta'')/dt``.
        """
        swt = math.sin(self.w * t)
        acc, _ = self.slip_accels(t, y, s)
        db1 = -self.A * self.w * swt - self.c * acc - self.k * y[1]
        db2 = -s * self.ck * self.a * self.w * swt
        dacc, _ = self._solve2(s, db1, db2)
        return self.a * self.w * swt + self.M * dacc * self.ca

    # -- forces -----------------------------------------------------------------
    def forces(self, t, y):
        """Return ``(tau, n)`` at local time ``t`` and state ``y``."""
        cwt = math.cos(self.w * t)
        acc = self.A * cwt - self.c * y[1] - self.k * y[0]
        n = self.g - self.a * cwt + self.M * acc * self.ca
        tau = -self.M * acc * self.sa
        return tau, n

    # -- right-hand sides ---------------------------------------------------------
    def rhs_stick(self, t, y):
        """Right-hand side in stick: ``x`` and ``v`` frozen."""
        acc = self.A * math.cos(self.w * t) - self.c * y[1] - self.k * y[0]
        return [y[1], acc, 0.0, 0.0]

    def rhs_slip(self, s):
        """Return the right-hand side of a slip of sign ``s``."""
        A, w, c, k, M, ca, sa, g, a = (
            self.A,
            self.w,
            self.c,
            self.k,
            self.M,
            self.ca,
            self.sa,
            self.g,
            self.a,
        )
        cks = self.ck * s

        def rhs(t, y):
            cwt = math.cos(w * t)
            acc = A * cwt - c * y[1] - k * y[0]
            n = g - a * cwt + M * acc * ca
            tau = -M * acc * sa
            return [y[1], acc, y[3], tau - cks * n]

        return rhs

    # -- events ---------------------------------------------------------------------
    def ev_release(self, s):
        """Event ``s tau - cs n = 0`` crossed upwards (release in direction ``s``)."""

        def ev(t, y):
            tau, n = self.forces(t, y)
            return s * tau - self.cs * n

        ev.terminal = True
        ev.direction = 1
        return ev

    def ev_stop(self, s):
        """Event ``v = 0`` crossed in direction ``-s`` (end of a slip of sign ``s``)."""

        def ev(t, y):
            return y[3]

        ev.terminal = True
        ev.direction = -s
        return ev

    def force_rates(self, t, y):
        """Return ``(dtau/dt, dn/dt)`` at local time ``t`` and state ``y``."""
        wt = self.w * t
        acc = self.A * math.cos(wt) - self.c * y[1] - self.k * y[0]
        dacc = -self.A * self.w * math.sin(wt) - self.c * acc - self.k * y[1]
        dn = self.a * self.w * math.sin(wt) + self.M * dacc * self.ca
        dtau = -self.M * dacc * self.sa
        return dtau, dn

    def apex_release(self, s):
        """Non-terminal event: maximum of ``s tau - cs n`` (its rate crosses down)."""

        def ev(t, y):
            dtau, dn = self.force_rates(t, y)
            return s * dtau - self.cs * dn

        ev.terminal = False
        ev.direction = -1
        return ev

    def apex_stop(self, s):
        """Non-terminal event: maximum of ``-s v`` in a slip of sign ``s``.

        ``d(-s v)/dt = -s tau + ck n`` crosses zero downwards.
        """

        def ev(t, y):
            tau, n = self.forces(t, y)
            return -s * tau + self.ck * n

        ev.terminal = False
        ev.direction = -1
        return ev

    def ev_lift(self):
        """Event ``n = 0`` crossed downwards (lift-off)."""

        def ev(t, y):
            return self.forces(t, y)[1]

        ev.terminal = True
        ev.direction = -1
        return ev

    def apex_lift(self):
        """Non-terminal event: minimum of ``n`` in stick (two-way only)."""

        def ev(t, y):
            return -self.force_rates(t, y)[1]

        ev.terminal = False
        ev.direction = -1
        return ev

    def apex_stop_slip2(self, s):
        """Non-terminal event: maximum of ``-s v`` in a two-way slip of sign ``s``."""

        def ev(t, y):
            return -s * self.slip_accels(t, y, s)[1]

        ev.terminal = False
        ev.direction = -1
        return ev

    def ev_lift_slip2(self, s):
        """Event ``n = 0`` crossed downwards in a two-way slip of sign ``s``."""
        forces = self.forces_slip2(s)

        def ev(t, y):
            return forces(t, y)[1]

        ev.terminal = True
        ev.direction = -1
        return ev

    def apex_lift_slip2(self, s):
        """Non-terminal event: minimum of ``n`` in a two-way slip of sign ``s``."""

        def ev(t, y):
            return -self.normal_rate_slip2(t, y, s)

        ev.terminal = False
        ev.direction = -1
        return ev


def _initial_mode_state(sys_):
    """Steady harmonic state of the mode at ``t = 0`` (the only closed form used)."""
    w, w0 = sys_.w, sys_.w0
    G = 1.0 / (w0 * w0 - w * w + 1j * sys_.c * w)  # c = w0 / Q
    d0 = (sys_.A * G).real
    dd0 = (1j * w * sys_.A * G).real
    return d0, dd0


def _min_normal_force(sys_, y_mode, T, rtol, atol, max_step):
    """Minimum of ``n(t)`` over one period, sampled on a fine grid.

    The mode ODE alone is integrated over one drive period from ``y_mode``;
    the normal force is evaluated on ``_N_SAMPLES`` equally spaced instants.
    """
    t_eval = np.linspace(0.0, T, _N_SAMPLES + 1)
    sol = solve_ivp(
        lambda t, y: sys_.rhs_stick(t, [y[0], y[1]])[:2],
        (0.0, T),
        list(y_mode),
        method="DOP853",
        t_eval=t_eval,
        rtol=rtol,
        atol=atol,
        max_step=max_step,
    )
    if sol.status != 0:  # pragma: no cover - defensive
        raise RuntimeError(f"mode integration failed: {sol.message}")
    cwt = np.cos(sys_.w * sol.t)
    acc = sys_.A * cwt - sys_.c * sol.y[1] - sys_.k * sol.y[0]
    n = sys_.g - sys_.a * cwt + sys_.M * acc * sys_.ca
    return float(n.min())


class Integrator:
    """Piecewise integration of the hybrid system over one drive period.

    Local time runs over ``[0, T]`` in every period (the drive is T-periodic), so
    the drive phase is exact for every period and ``x`` is reset to 0 at each
    period start; the displacement of the period is the final ``x``.
    """

    def __init__(self, sys_, T, rtol, atol, max_step):
        self.sys = sys_
        self.T = T
        self.opts = dict(method="DOP853", rtol=rtol, atol=atol, max_step=max_step)
        lift = sys_.ev_lift()
        # Terminal events, and for the crossing events the apex watchers
        # (non-terminal events at the maxima of the oriented event function)
        # as (apex event, index of the terminal event it watches).
        self.stick_events = [sys_.ev_release(+1), sys_.ev_release(-1), lift]
        self.stick_apexes = [(sys_.apex_release(+1), 0), (sys_.apex_release(-1), 1)]
        self.two_way = sys_.two_way
        if not self.two_way:
            self.slip_rhs = {+1: sys_.rhs_slip(+1), -1: sys_.rhs_slip(-1)}
            self.slip_events = {s: [sys_.ev_stop(s), lift] for s in (+1, -1)}
            self.slip_apexes = {s: [(sys_.apex_stop(s), 0)] for s in (+1, -1)}
            self.slip_noevent = {s: [lift] for s in (+1, -1)}
        else:
            # Two-way: n is not the same function of the state in stick and in slip,
            # and the mode leaves its steady response, so lift-off cannot be excluded
            # by sampling one period: every n = 0 event is watched by an apex too.
            self.stick_apexes.append((sys_.apex_lift(), 2))
            self.slip_rhs = {s: sys_.rhs_slip2(s) for s in (+1, -1)}
            self.slip_events = {s: [sys_.ev_stop(s), sys_.ev_lift_slip2(s)] for s in (+1, -1)}
            self.slip_apexes = {
                s: [(sys_.apex_stop_slip2(s), 0), (sys_.apex_lift_slip2(s), 1)] for s in (+1, -1)
            }
            self.slip_noevent = {s: [self.slip_events[s][1]] for s in (+1, -1)}
        self.guard = _GUARD * T

    def _solve(self, rhs, t0, t1, y0, events, apexes=(), keep=None):
        """Integrate until the first terminal event or ``t1``.

        Parameters
        ----------
        rhs : callable
            Right-hand side of the current discrete mode.
        t0, t1 : float
            Local time interval.
        y0 : list of float
            Initial state.
        events : list of callable
            Terminal events (each with ``direction`` set).
        apexes : sequence of (callable, int)
            Non-terminal events at the maxima of ``direction * event`` for the
            terminal event of the given index. ``solve_ivp`` only sees sign
            changes between step ends, so an event function that crosses zero
            and comes back within one step is missed; at such a maximum the
            oriented function is then positive, and the missed crossing is
            located on the dense output between the step start and the maximum.
        keep : list, optional
            If given, dense output is switched on and ``(t0, t_end, sol.sol)`` is
            appended to it (the piece of trajectory actually used).

        Returns
        -------
        t_end : float
            End time (event time, or ``t1``).
        y_end : list of float
            State at ``t_end``.
        fired : int or None
            Index in ``events`` of the event that stopped the integration.
        """
        all_events = list(events) + [ev for ev, _ in apexes]
        dense = bool(apexes) or keep is not None
        sol = solve_ivp(rhs, (t0, t1), y0, events=all_events, dense_output=dense, **self.opts)
        if sol.status == -1:  # pragma: no cover - defensive
            raise RuntimeError(f"integration failed: {sol.message}")
        t_end = float(sol.t[-1])
        y_end = [float(v) for v in sol.y[:, -1]]
        fired = None
        if sol.status == 1:
            for i in range(len(events)):
                te = sol.t_events[i]
                if len(te) and te[-1] == sol.t[-1]:
                    fired = i
                    break
        missed = None
        for j, (_, idx) in enumerate(apexes):
            ev = events[idx]
            d = ev.direction

            def oriented(t, ev=ev, d=d):
                return d * ev(t, sol.sol(t))

            for tm in sol.t_events[len(events) + j]:
                if oriented(tm) <= 0.0:
                    continue
                # Missed crossing before tm: bracket it in the step ending past tm.
                k = int(np.searchsorted(sol.t, tm, side="left")) - 1
                ta = float(sol.t[max(k, 0)])
                if ta < tm and oriented(ta) < 0.0:
                    root = brentq(oriented, ta, tm, xtol=4 * _EPS, rtol=4 * _EPS)
                else:
                    root = ta
                if missed is None or root < missed[0]:
                    missed = (root, idx)
                break
        if missed is not None and missed[0] < t_end:
            t_end, fired = missed
            y_end = [float(v) for v in sol.sol(t_end)]
        if keep is not None:
            keep.append((t0, t_end, sol.sol))
        return t_end, y_end, fired

    def release_direction(self, t, y):
        """Direction of an immediate release from stick (0 if none)."""
        tau, n = self.sys.forces(t, y)
        cs = self.sys.cs
        if tau - cs * n > 0.0:
            return +1
        if -tau - cs * n > 0.0:
            return -1
        return _STICK

    def after_stop(self, t, y, s):
        """Discrete mode after a ``v = 0`` instant ending a slip of sign ``s``."""
        tau, n = self.sys.forces(t, y)
        cs = self.sys.cs
        if -s * tau - cs * n > 0.0:
            return -s  # reversal
        if s * tau - cs * n > 0.0:
            return s  # tangential touch: slip continues
        return _STICK

    def period(self, y, mode, fresh):
        """Integrate one drive period.

        Parameters
        ----------
        y : list of float
            State ``(delta, ddelta_dt, x, v)`` at the period start; ``x`` must be 0.
        mode : int
            Discrete mode at the start: 0 (stick) or the slip sign +1 / -1.
        fresh : bool
            True if a slip starting at this instant has just begun from ``v = 0``.

        Returns
        -------
        y, mode, fresh : the state at the period end.
        stats : dict
            ``stick_time`` (s), ``slipped`` (bool), ``events`` (int).
        """
        T = self.T
        t = 0.0
        stick_time = 0.0
        slipped = mode != _STICK
        n_events = 0
        for _ in range(_MAX_SEGMENTS_PER_PERIOD):
            if t >= T:
                break
            if mode == _STICK:
                t1, y1, fired = self._solve(
                    self.sys.rhs_stick, t, T, y, self.stick_events, self.stick_apexes
                )
                stick_time += t1 - t
                t, y = t1, y1
                if fired is None:
                    continue
                n_events += 1
                if fired == 2:
                    raise _LiftOff
                mode = +1 if fired == 0 else -1
                y[3] = 0.0
                fresh = True
                slipped = True
                continue

            s = mode
            if self.two_way and not self.sys.det[s] > 0.0:
                raise _FrictionParadox
            rhs = self.slip_rhs[s]
            t1, y1, fired = self._solve(rhs, t, T, y, self.slip_events[s], self.slip_apexes[s])
            if fired == 0 and fresh and t1 - t < self.guard:
                # The slip would end as soon as it starts: v = 0 at the start makes
                # the root finder return the start instant when v comes back to 0
                # within the first step (or when the release was located a hair
                # early). Integrate a tiny window with the v = 0 event masked (same
                # ODE), then re-arm the event.
                t_w = min(t + self.guard, T)
                t1, y1, fired = self._solve(rhs, t, t_w, y, self.slip_noevent[s])
                if fired is not None:
                    raise _LiftOff
                t, y = t1, y1
                fresh = False
                if s * y[3] <= 0.0:
                    # The slip did not establish: it ends here.
                    y[3] = 0.0
                    n_events += 1
                    mode = self.after_stop(t, y, s)
                    fresh = mode != _STICK
                continue
            t, y = t1, y1
            fresh = False
            if fired is None:
                continue
            n_events += 1
            if fired == 1:
                raise _LiftOff
            y[3] = 0.0
            mode = self.after_stop(t, y, s)
            fresh = mode != _STICK
        else:  # pragma: no cover - defensive
            raise RuntimeError("too many events in one drive period")
        stats = dict(stick_time=stick_time, slipped=slipped, events=n_events)
        return y, mode, fresh, stats


def reference_velocity(
    f0,
    Q,
    alpha_deg,
    M,
    cs,
    f,
    a,
    ck=None,
    g=9.8,
    rtol=1e-12,
    atol=1e-14,
    max_periods=None,
    period_tol=None,
    coupling="one-way",
):
    """Mean sliding velocity of the periodic steady orbit, by direct integration.

    The hybrid stick/slip system of the single-plate model is integrated period
    by period with ``solve_ivp(method="DOP853")`` and terminal event location,
    from the canonical start: ``t = 0``, ``x = v = 0``, body in stick (released at
    once if a release condition already holds), mode on its steady harmonic
    response ``delta(0) = Re[a cos(alpha) G]``,
    ``delta'(0) = Re[i w a cos(alpha) G]``,
    ``G = 1 / (w0^2 - w^2 + i w0 w / Q)``.

    Parameters
    ----------
    f0 : float
        Resonance frequency of the plate mode [Hz].
    Q : float
        Quality factor of the mode.
    alpha_deg : float
        Tilt of the plate from the horizontal [degree].
    M : float
        Mass ratio ``m1 / m``.
    cs : float
        Static friction coefficient.
    f : float
        Drive frequency [Hz].
    a : float
        Drive (table) acceleration amplitude [m s-2].
    ck : float, optional
        Kinetic friction coefficient, ``ck <= cs``; defaults to ``cs``.
    g : float, optional
        Gravity [m s-2].
    rtol, atol : float, optional
        Tolerances of ``solve_ivp`` (``rtol`` must be >= ``100 * eps``, about
        2.3e-14, or scipy warns). The state components are
        ``(delta [m], ddelta/dt [m s-1], x [m], v [m s-1])``.
    max_periods : int, optional
        Maximum number of drive periods integrated; default 400 (one-way) or
        2000 (two-way: the mode transient decays by a factor e in about
        ``Q / pi`` periods).
    period_tol : float, optional
        Relative tolerance of the periodicity test on the displacement (an
        absolute floor of 1e-15 m is also accepted); the velocity at the
        period boundary must agree to the same relative tolerance (floor
        ``1e-15 m / T``). With two-way coupling ``delta`` and ``delta'`` at the
        boundary must agree too, relative to their natural scales
        ``max(|a cos(alpha) G|, |delta|)`` and ``max(w |a cos(alpha) G|, |delta'|)``
        (floors ``1e-15 m`` and ``1e-15 m / T``). Default 1e-13 (one-way) or
        1e-9 (two-way).
    coupling : {"one-way", "two-way"}, optional
        ``"one-way"`` (default): the mode does not feel the sliding. ``"two-way"``:
        in slip the base acceleration ``x''`` forces the mode (module docstring);
        the one-way lift-off pre-check by sampling is then skipped (the mode is no
        longer on its steady response) and every ``n = 0`` event is watched by an
        apex event instead.

    Returns
    -------
    velocity : float
        Mean horizontal velocity [m s-1] of the periodic orbit: displacement over
        its ``k`` drive periods divided by ``k T``. ``0.0`` when static, ``nan``
        at lift-off. When not converged, the mean velocity over the second half
        of the integrated periods (a best estimate only).
    status : str
        ``"static"`` (never left stick), ``"stick_slip"`` (the periodic orbit has
        a stick phase of positive duration), ``"continuous_sliding"`` (periodic
        orbit without stick), ``"lift_off"`` (``n(t) < 0`` somewhere: model
        invalid), ``"not_converged"`` (no periodic orbit of period <= 8 drive
        periods found within ``max_periods``) or, two-way only,
        ``"friction_paradox"`` (a slip of a sign whose 2x2 determinant
        ``1 - M sin(alpha) (sin(alpha) + s ck cos(alpha))`` is <= 0 would start;
        velocity ``nan``).
    n_periods : int
        Number of drive periods of the hybrid system integrated (0 when lift-off
        is detected by sampling ``n`` before the integration).

    Notes
    -----
    Convergence is declared after period ``j`` for the smallest ``k`` in
    ``1..8`` such that the discrete mode and the velocity at the boundaries
    ``j`` and ``j - k`` agree and the displacement over periods
    ``j-k+1..j`` equals that over ``j-2k+1..j-k``. The mode phase is the same at
    every boundary, so this identifies a ``k``-periodic orbit. With two-way
    coupling the mode state ``(delta, delta')`` at the boundaries ``j`` and
    ``j - k`` must agree as well (one-way, it is the steady response at every
    boundary).

    Events are located by ``solve_ivp`` (Brent's method on the dense output);
    at every event the integration restarts with the new discrete mode and
    ``v`` set exactly to 0. ``max_step`` is ``T / 64``. ``solve_ivp`` only
    sees sign changes between step ends, so a short excursion of an event
    function across zero inside one step (a brief release, a slip that
    barely stops) would be missed; every crossing event is therefore watched
    by a non-terminal event at the maxima of its oriented function (one per
    period: these functions are sinusoids plus constants), and a positive
    maximum triggers a root search on the dense output.

    A slip starts from ``v = 0`` exactly, so the ``v = 0`` event function is
    zero at the start; if the slip also ends within the first step, or the
    release was located a hair before the threshold, the root finder returns
    the start instant. A slip ending within ``1e-8 T`` of its start is therefore
    integrated past that window with the ``v = 0`` event suppressed (the ODE is
    unchanged; only the event is masked), then the event is re-armed; if ``v``
    has not taken the slip's sign by then, the slip ends there.
    """
    if ck is None:
        ck = cs
    if not (0.0 <= ck <= cs):
        raise ValueError(f"need 0 <= ck <= cs, got ck={ck}, cs={cs}")
    if f <= 0 or f0 <= 0 or Q <= 0:
        raise ValueError("f, f0 and Q must be positive")
    if coupling not in COUPLINGS:
        raise ValueError(f"coupling must be one of {COUPLINGS}, got {coupling!r}")
    if max_periods is None:
        max_periods = _MAX_PERIODS[coupling]
    if period_tol is None:
        period_tol = _PERIOD_TOL[coupling]
    if max_periods < 2:
        raise ValueError("max_periods must be >= 2")
    return _reference_velocity(
        f0,
        Q,
        alpha_deg,
        M,
        cs,
        f,
        a,
        ck,
        g,
        rtol,
        atol,
        max_periods,
        period_tol,
        _STEPS_PER_PERIOD,
        coupling=coupling,
    )


class _Trajectory:
    """Dense output of :func:`reference_slide_to_rest` (piecewise ``OdeSolution``).

    Call with a time (scalar or 1-D array, inside ``[0, t_end]``) to get the state
    ``(delta, ddelta_dt, x, v)`` (shape ``(4,)`` or ``(4, len(t))``).

    Attributes
    ----------
    t_end : float
        End of the trajectory (the stop time).
    breakpoints : numpy.ndarray
        Sorted step ends of the integrator in ``[0, t_end]``, both ends included:
        on each interval between two of them the state is a polynomial (DOP853
        dense output, degree 7), so Gauss-Legendre quadrature of any polynomial
        function of the state is exact there up to round-off.
    """

    def __init__(self, pieces):
        self._pieces = pieces
        self._starts = np.array([p[0] for p in pieces])
        self.t_end = float(pieces[-1][1])
        pts = [np.asarray([pieces[0][0]])]
        for t0, t1, sol in pieces:
            ts = np.asarray(sol.ts)
            pts.append(ts[(ts > t0) & (ts < t1)])
            pts.append(np.asarray([t1]))
        self.breakpoints = np.unique(np.concatenate(pts))

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        scalar = t.ndim == 0
        tt = np.atleast_1d(t)
        idx = np.clip(np.searchsorted(self._starts, tt, side="right") - 1, 0, None)
        out = np.empty((4, tt.size))
        for i in np.unique(idx):
            sel = idx == i
            out[:, sel] = self._pieces[i][2](tt[sel])
        return out[:, 0] if scalar else out


def reference_slide_to_rest(
    f0,
    Q,
    alpha_deg,
    M,
    cs,
    v0,
    ck=None,
    g=9.8,
    coupling="one-way",
    mode0=(0.0, 0.0),
    rtol=1e-12,
    atol=1e-14,
    max_time=None,
    return_trajectory=False,
):
    """Free slide without drive (``a = 0``) from velocity ``v0`` until ``v = 0``.

    The slip of sign ``s = sign(v0)`` is integrated with ``solve_ivp`` (DOP853,
    ``max_step = 1 / (64 f0)``) from ``t = 0``, ``x = 0``, ``v = v0`` and the
    mode state ``mode0 = (delta, ddelta_dt)``, with the same right-hand sides
    and event handling as :func:`reference_velocity` (including the watch for a
    ``v = 0`` touch missed inside one step), up to the first instant where
    ``v`` returns to 0. What would follow (stick, re-release) is not computed.

    Parameters
    ----------
    f0, Q, alpha_deg, M, cs, ck, g : float
        Structure, as in :func:`reference_velocity` (``ck`` defaults to ``cs``
        and must be > 0).
    v0 : float
        Initial sliding velocity [m s-1], nonzero.
    coupling : {"one-way", "two-way"}, optional
        As in :func:`reference_velocity`.
    mode0 : (float, float), optional
        Initial ``(delta [m], ddelta/dt [m s-1])``; default at rest.
    rtol, atol : float, optional
        Tolerances of ``solve_ivp``.
    max_time : float, optional
        Integration horizon [s]; default ``10 |v0| / (ck g) + 10 / f0``.
    return_trajectory : bool, optional
        Also return the dense trajectory.

    Returns
    -------
    t_stop : float
        Time [s] at which ``v`` first returns to 0.
    distance : float
        ``x(t_stop)`` [m] (signed).
    trajectory : _Trajectory
        Only if ``return_trajectory``: callable ``t -> (delta, ddelta_dt, x, v)``
        on ``[0, t_stop]`` with attribute ``breakpoints``.

    Raises
    ------
    ReferenceModelInvalid
        ``status == "friction_paradox"`` (two-way, non-positive determinant of
        the slip system for ``sign(v0)``) or ``"lift_off"`` (``n`` reached 0).
    RuntimeError
        ``v`` did not return to 0 within ``max_time``.
    """
    if ck is None:
        ck = cs
    if not (0.0 < ck <= cs):
        raise ValueError(f"need 0 < ck <= cs, got ck={ck}, cs={cs}")
    if f0 <= 0 or Q <= 0:
        raise ValueError("f0 and Q must be positive")
    if coupling not in COUPLINGS:
        raise ValueError(f"coupling must be one of {COUPLINGS}, got {coupling!r}")
    if not (v0 != 0.0 and math.isfinite(v0)):
        raise ValueError(f"v0 must be finite and nonzero, got {v0}")
    s = 1 if v0 > 0.0 else -1
    two_way = coupling == "two-way"
    # No drive: a = 0, so the drive frequency only enters through cos(w t) * 0.
    sys_ = System(f0, Q, alpha_deg, M, cs, ck, g, f0, 0.0, two_way=two_way)
    if two_way and not sys_.det[s] > 0.0:
        raise ReferenceModelInvalid(
            "friction_paradox", f"determinant {sys_.det[s]:.3g} <= 0 for slip sign {s:+d}"
        )
    T0 = 1.0 / f0
    if max_time is None:
        max_time = 10.0 * abs(v0) / (ck * g) + 10.0 * T0
    integ = Integrator(sys_, T0, rtol, atol, T0 / _STEPS_PER_PERIOD)
    y = [float(mode0[0]), float(mode0[1]), 0.0, float(v0)]
    pieces = []
    t1, y1, fired = integ._solve(
        integ.slip_rhs[s], 0.0, max_time, y, integ.slip_events[s], integ.slip_apexes[s], pieces
    )
    if fired == 1:
        raise ReferenceModelInvalid("lift_off", f"n = 0 at t = {t1:.6g} s")
    if fired is None:
        raise RuntimeError(f"v did not return to 0 within max_time = {max_time:.6g} s")
    if return_trajectory:
        return t1, y1[2], _Trajectory(pieces)
    return t1, y1[2]


def _reference_velocity(
    f0,
    Q,
    alpha_deg,
    M,
    cs,
    f,
    a,
    ck,
    g,
    rtol,
    atol,
    max_periods,
    period_tol,
    steps_per_period,
    coupling="one-way",
):
    """Body of :func:`reference_velocity` with ``max_step = T / steps_per_period``.

    Exposed separately only so that the demo can show convergence in the step
    size; arguments are as in :func:`reference_velocity` (``ck``, ``max_periods``
    and ``period_tol`` not None).
    """
    two_way = coupling == "two-way"
    T = 1.0 / f
    max_step = T / steps_per_period
    sys_ = System(f0, Q, alpha_deg, M, cs, ck, g, f, a, two_way=two_way)
    d0, dd0 = _initial_mode_state(sys_)

    # Lift-off: the mode is on its steady response, so one period of n(t) is
    # representative of all of them (one-way only). The n = 0 event is also
    # armed below.
    if not two_way and _min_normal_force(sys_, (d0, dd0), T, rtol, atol, max_step) < 0.0:
        return math.nan, "lift_off", 0
    # Natural scales of the mode state (steady one-way response amplitude).
    amp_d = abs(sys_.A / complex(sys_.k - sys_.w * sys_.w, sys_.c * sys_.w))  # |a cos(alpha) G|
    amp_dd = sys_.w * amp_d

    integ = Integrator(sys_, T, rtol, atol, max_step)
    y = [d0, dd0, 0.0, 0.0]
    mode = integ.release_direction(0.0, y)
    fresh = mode != _STICK

    dx, v_end, mode_end, stick_t, slipped = [], [], [], [], []
    d_end, dd_end = [], []
    for j in range(1, max_periods + 1):
        try:
            y, mode, fresh, st = integ.period(y, mode, fresh)
        except _LiftOff:
            return math.nan, "lift_off", j
        except _FrictionParadox:
            return math.nan, "friction_paradox", j
        dx.append(y[2])
        y[2] = 0.0
        v_end.append(y[3])
        d_end.append(y[0])
        dd_end.append(y[1])
        mode_end.append(mode)
        stick_t.append(st["stick_time"])
        slipped.append(st["slipped"])

        for k in range(1, _MAX_K + 1):
            if j < 2 * k:
                break
            if mode_end[-1] != mode_end[-1 - k]:
                continue
            v1, v0 = v_end[-1], v_end[-1 - k]
            if abs(v1 - v0) > max(period_tol * max(abs(v1), abs(v0)), 1e-15 / T):
                continue
            D1 = math.fsum(dx[-k:])
            D0 = math.fsum(dx[-2 * k : -k])
            if abs(D1 - D0) > max(period_tol * max(abs(D1), abs(D0)), 1e-15):
                continue
            if two_way:
                p1, p0 = d_end[-1], d_end[-1 - k]
                if abs(p1 - p0) > max(period_tol * max(amp_d, abs(p1), abs(p0)), 1e-15):
                    continue
                q1, q0 = dd_end[-1], dd_end[-1 - k]
                if abs(q1 - q0) > max(period_tol * max(amp_dd, abs(q1), abs(q0)), 1e-15 / T):
                    continue
            if not any(slipped):
                return 0.0, "static", j
            if sum(stick_t[-k:]) > _STICK_MIN * T:
                status = "stick_slip"
            else:
                status = "continuous_sliding"
            return D1 / (k * T), status, j

    half = max(1, max_periods // 2)
    return math.fsum(dx[-half:]) / (half * T), "not_converged", max_periods


def _demo():
    """Print reference velocities on paper parameters.

    Each point is computed three times: ``rtol = 1e-12`` and ``1e-13`` with the
    default ``max_step = T / 64`` (``atol = rtol / 100``), then ``rtol = 1e-13``
    with ``max_step = T / 256``. At these tolerances DOP853's own step is
    about ``T / 30 .. T / 50``, so the ``T / 64`` cap usually binds and the
    first two runs often agree bit for bit; the third run shows the
    convergence in the step size.
    """
    base = dict(f0=14.44, Q=17.5, alpha_deg=64.0, cs=0.25, ck=0.25, g=9.8)
    points = [
        (0.08, 13.0, 5.0, "S: v = 0"),
        (0.08, 13.0, 8.5, "P: v > 0"),
        (0.08, 16.5, 8.5, "N: v < 0"),
        (0.08, 14.5, 6.0, "v > 0"),
        (0.08, 14.5, 9.0, "v < 0"),
        (0.08, 14.6, 7.0, "PN"),
        (1.0, 14.44, 5.0, "M -> 1"),
        (0.9, 13.0, 6.0, "M -> 1"),
        (1.0, 14.44, 2.0, "M -> 1"),
        (0.9, 13.0, 4.0, "M -> 1"),
        (1.0, 15.0, 6.0, "M -> 1"),
    ]
    runs = [(1e-12, _STEPS_PER_PERIOD), (1e-13, _STEPS_PER_PERIOD), (1e-13, 256)]
    print(
        f"{'M':>5} {'f':>6} {'a':>5} {'rtol':>6} {'T/h':>4} {'v [m s-1]':>24}"
        f" {'status':>19} {'periods':>7} {'time[s]':>7} {'rel.diff':>9}  expected"
    )
    t_all = time.perf_counter()
    for M, f, a, note in points:
        prev = None
        for rtol, steps in runs:
            t0 = time.perf_counter()
            v, status, n = _reference_velocity(
                M=M,
                f=f,
                a=a,
                rtol=rtol,
                atol=rtol * 1e-2,
                max_periods=400,
                period_tol=1e-13,
                steps_per_period=steps,
                **base,
            )
            dt = time.perf_counter() - t0
            rd = ""
            if prev is not None and math.isfinite(v):
                scale = max(abs(v), abs(prev))
                rd = f"{(abs(v - prev) / scale if scale > 0 else 0.0):9.2e}"
            prev = v
            print(
                f"{M:5.2f} {f:6.2f} {a:5.2f} {rtol:6.0e} {steps:4d} {v:24.16e}"
                f" {status:>19} {n:7d} {dt:7.2f} {rd:>9}  {note}",
                flush=True,
            )
    print(
        f"total wall time {time.perf_counter() - t_all:.1f} s "
        "(rel.diff: relative to the run on the line above)"
    )


if __name__ == "__main__":
    _demo()
