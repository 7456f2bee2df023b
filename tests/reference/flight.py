"""Event-driven reference for the TWO-WAY model with flight and impacts (issue 21).

Plain Python, numpy and :func:`scipy.integrate.solve_ivp` (``DOP853``, ``rtol = 1e-12``):
nothing from ``study``'s kernels, solvers or physics is used (only
:class:`study.model.structure.Structure` is accepted as a parameter holder). Slow and
accurate: it is the yardstick of the exact flight solver and of the flight integrator.

Model (per unit total mass, SI, the project's sign conventions)
---------------------------------------------------------------
Base at ``(X, Z)``, the plate's mass ``M`` on the mode coordinate ``delta`` along
``e = (sin(alpha), cos(alpha))``, measured from its static equilibrium in contact. The
table moves vertically with acceleration ``-A(t)``, ``A = a cos(w t)``; ``(Fx, Fz)`` is
the contact force on the base, ``c = w0 / Q``, ``k = w0^2``::

    X'' + M sa delta'' = Fx
    Z'' + M ca delta'' = Fz - g
    sa X'' + ca Z'' + delta'' = -c delta' - k delta

(the third row is ``delta'' + c delta' + k delta = -sa X'' - ca (Z'' + g) + g ca``). Each
phase adds two rows, and the five unknowns ``(X'', Z'', delta'', Fx, Fz)`` are solved
NUMERICALLY from the 5x5 system (its inverse is formed once per phase), so no eliminated
formula of the project is used:

* stick: ``X'' = 0``, ``Z'' = -A``;
* slip of sign ``s`` (base velocity ``v = X'``): ``Fx = -s ck Fz``, ``Z'' = -A``; the slip
  is Painleve's friction paradox when the determinant of its system has not the sign it
  has without friction (``ck = 0``);
* flight: ``Fx = Fz = 0``; the gap ``h = Z - Z_table`` obeys ``h'' = Z'' + A``.

State ``y = (delta, delta', x, v, h, h')`` (``x``: base displacement within the current
drive period; ``h = h' = 0`` in contact).

Events (``solve_ivp`` event functions with a direction, ``max_step`` a small fraction of
the shortest period so that no two roots share a step)
------------------------------------------------------------------------------------------
* stick: release forward when ``-Fx - cs Fz`` rises through 0, backward when
  ``Fx - cs Fz`` does; take-off when ``Fz`` falls through 0;
* slip ``s``: its end when ``s v`` falls through 0; take-off when ``Fz`` falls through 0;
* flight: impact when ``h`` falls through 0 (``h' < 0``); apex when ``h'`` does (for the
  largest hop).

**Crossings hidden inside a step.** A function that dips through 0 and back between two
step ends (a grazing take-off just above the lift-off threshold, a grazing impact, a
brief release) changes no sign at the step ends. Each crossing function is therefore
watched at its extrema too: a second, non-terminal event on its derivative (the
derivatives of the contact forces are linear in ``(delta', delta'', A')`` and solved
from the same systems) records every minimum (maximum) of it; one found beyond 0 is a
pair of crossings, and the first is located by ``brentq`` on the step's dense output
(the segment integrated again, step for step, with its interpolants). Only a pair of
extrema inside one step (``max_step`` below 1/32 of the fastest period) could still
hide a crossing. At 1e-7 m s-2 above the two-way lift-off threshold (M = 0.08, 14.5 Hz)
the reference finds the hop of 7e-19 m that the step ends miss.

**Zeros at a segment's start.** A segment often starts on a zero of its own event
function: a flight started at take-off has ``h = h' = h'' = 0`` and ``h''' = -n' > 0``
there (a triple zero), one started by a rebound ``h = 0 < h'``, a slip started by a
release ``v = v' = 0``. ``solve_ivp`` would report such a zero at once. The event
function is therefore ``g / tau^m`` (``tau`` the time since the segment's start, ``m`` the
order of the known zero: 3 after a take-off, 2 after a take-off at once on landing
(``h'' = -n > 0``), 1 after a rebound; 2 for ``s v`` after a release, 1 after a reversal,
0 otherwise), whose limit at ``tau -> 0`` is a positive number (``h'''/6``, ``h''/2``,
``h'+``): the root at the start is divided out analytically and the first root of ``h``
past it is the first sign change of the event function. The event function returns
``+1`` at ``tau = 0`` itself (only its sign is used there). The residual ``n`` left by
locating the take-off (``|n| ~ 1e-11 m s-2``) only matters for ``tau < 3 |n| / h'''``
(below ``1e-13 s`` at the drives used here), far inside ``solve_ivp``'s first step.

Impact (own law, integrated numerically)
----------------------------------------
At an impact the base velocity jumps by ``dV = W P``, ``W = I + mu e e^T``,
``mu = M / (1 - M)`` (the mode's generalized momentum ``M (e.V + delta')`` is continuous,
so ``d(delta') = -e.dV``). Darboux-Keller: the normal impulse ``p`` is the independent
variable and ``(v, h', Px)`` are integrated by ``solve_ivp`` along it; while the base
slides with sign ``s``, ``dPx/dp = -s ck``; while it is stuck, ``dPx/dp = -W_xz / W_xx``
(keeps ``v = 0``), allowed when ``|W_xz / W_xx| <= cs``, else it slides with sign
``sign(W_xz)``. The impact ends when ``h' = -e h'_minus`` (Newton's law). A sliding
impact with ``dh'/dp <= 0`` is the impact friction paradox.

After an impact: with a rebound ``h'+ >= CHATTER_SPEED * a / w`` the base flies again;
below it (and always when ``e = 0``) it lands plastically (the impact is redone with
``e = 0``, so the cut-off only shortens the impulse). **Chattering cut-off:** a rebound
of ``u = 1e-9 a / w`` would have been followed by an accumulation of bounces lasting about
``2 u / (g_eff (1 - e))``, ``1e-10`` of a drive period at the drives used here, so the
cut-off moves no reported quantity beyond the tolerance stated with it. After a plastic
landing the contact rules apply: slip in the sign of ``v`` when ``v != 0``, else the stick
test (stick when ``|Fx| <= cs Fz`` with the stick forces, else a slip against the needed
friction); and when that contact's ``Fz < 0`` the base takes off again at once.

Steady motion
-------------
:func:`steady_motion` follows the motion period by period from a start (``"rest"``: at
phase 0, ``v = 0``, in contact, the mode on its steady stick response
``delta = Re[a ca G e^{i w t}]``, ``G = 1 / (k - w^2 + i c w)``, the exact solver's
start; ``"still"``: everything at rest on the table, the mode at its contact equilibrium,
the drive switched on at phase 0; ``("drop", height)``: the base released at phase 0 at
rest at ``height`` above the table, the mode at rest at its flight equilibrium
``g ca / k``) until the state at phase 0 repeats after ``N = 1..8`` periods within
``tol`` (natural units), then measures the orbit over a whole number of its periods.
The period reported is the first ``N`` whose phase-0 states agree to ``LOOSE = 1e-5``
(a slowly decaying transient that turns by about ``2 pi / N`` per period would
otherwise pass the test at ``N`` first).

Accuracy: below lift-off the velocity agrees with the exact two-way solver to about
``1e-10`` relative; at ``M = 1e-10`` the airborne fraction and the largest hop agree with
the rigid block's closed form to ``1e-9``; rerunning with ``rtol = 1e-13`` and twice the
steps moves velocity, airborne fraction and hop by ``1e-11`` to ``1e-10`` (relative).

Run ``python -m tests.reference.make_flight_points`` to regenerate the cached points.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

__all__ = [
    "CHATTER_SPEED",
    "CODE_VERSION",
    "FLIGHT",
    "RTOL",
    "STICK",
    "FlightModel",
    "ImpactResult",
    "ModelBreakdown",
    "Simulation",
    "SteadyMotion",
    "impact",
    "simulate",
    "steady_motion",
]

#: Version of this reference's algorithm: bump whenever its results may change.
CODE_VERSION = "4"

#: Contact modes: stick, slip (+1 / -1: the sign of ``v``), flight.
STICK = 0
FLIGHT = 2
#: Relative tolerance of every ``solve_ivp`` call.
RTOL = 1e-12
#: A rebound slower than ``CHATTER_SPEED * a / w`` [m s-1] lands plastically.
CHATTER_SPEED = 1e-9
#: Steps per shortest period (drive, mode in contact, mode in flight) at most.
STEPS_PER_PERIOD = 32
#: Segments allowed in one drive period before the motion is declared not periodic.
MAX_SEGMENTS = 2000
#: Longest orbit looked for [drive periods].
MAX_ORBIT = 8
#: Drive periods averaged over when no orbit was found.
IRREGULAR_MEASURE = 64
#: Phase-0 states closer than this (natural units) belong to the same point of the orbit.
LOOSE = 1e-5

_EPS = float(np.finfo(float).eps)
_STATE_NAMES = ("delta", "delta_rate", "velocity", "gap", "gap_rate")


class ModelBreakdown(Exception):
    """The motion left the model (friction paradox) or exhausted a budget."""

    def __init__(self, status: str, where: str) -> None:
        super().__init__(f"{status}: {where}")
        self.status = status
        self.where = where


def _params(structure: Any, restitution: float | None) -> dict[str, float]:
    """Structure parameters as floats from a :class:`Structure` or a mapping."""
    names = ("f0", "Q", "alpha", "M", "cs", "ck", "g", "restitution")
    if isinstance(structure, Mapping):
        d = dict(structure)
    else:
        d = {name: getattr(structure, name, None) for name in names}
    if d.get("ck") is None:
        d["ck"] = d["cs"]
    if d.get("g") is None:
        d["g"] = 9.8
    if restitution is not None:
        d["restitution"] = restitution
    if d.get("restitution") is None:
        d["restitution"] = 0.0
    p = {name: float(d[name]) for name in names}
    if not 0.0 <= p["restitution"] <= 1.0:
        raise ValueError(f"restitution must be in [0, 1], got {p['restitution']}")
    if not 0.0 < p["M"] < 1.0:
        raise ValueError(f"M must be in (0, 1) with flight (M = 1: massless base), got {p['M']}")
    return p


class FlightModel:
    """Parameters, phase systems, right-hand sides and event functions.

    Parameters
    ----------
    structure : Structure or mapping
        ``f0 [Hz], Q [1], alpha [degree], M [1] (0 < M < 1), cs [1], ck [1] (None: cs),
        g [m s-2], restitution [1]``.
    f, a : float
        Drive frequency [Hz] and acceleration amplitude [m s-2].
    restitution : float, optional
        Overrides the structure's restitution [1].
    rtol : float
        Relative tolerance of the time integration [1]; the absolute tolerances are
        ``rtol`` times the natural scales ``g / W^2`` [m] and ``g / W`` [m s-1],
        ``W = max(w, w0 / sqrt(1 - M))``.
    steps_per_period : int
        Steps at least per period of the drive and of the mode in the current contact
        mode (``max_step``): no event function turns twice within a step.
    chatter_speed : float
        Rebounds slower than ``chatter_speed * a / w`` land plastically [1].
    """

    def __init__(self, structure: Any, f: float, a: float,
                 restitution: float | None = None, *, rtol: float = RTOL,
                 steps_per_period: int = STEPS_PER_PERIOD,
                 chatter_speed: float = CHATTER_SPEED) -> None:
        p = _params(structure, restitution)
        self.rtol = float(rtol)
        self.params = p
        self.f, self.a = float(f), float(a)
        self.w = 2.0 * math.pi * self.f
        self.T = 1.0 / self.f
        self.chatter_threshold = float(chatter_speed) * self.a / self.w
        self.w0 = 2.0 * math.pi * p["f0"]
        self.c = self.w0 / p["Q"]
        self.k = self.w0 * self.w0
        alpha = math.radians(p["alpha"])
        self.sa, self.ca = math.sin(alpha), math.cos(alpha)
        self.M, self.cs, self.ck, self.g = p["M"], p["cs"], p["ck"], p["g"]
        self.e = p["restitution"]
        self.mu = self.M / (1.0 - self.M)
        ev = np.array([self.sa, self.ca])
        self.W = np.eye(2) + self.mu * np.outer(ev, ev)
        big = max(self.w, self.w0 / math.sqrt(1.0 - self.M))
        # natural scales of (delta, delta', x, v, h, h')
        length, speed = self.g / big**2, self.g / big
        self.scale = np.array([length, speed, length, speed, length, speed])
        self.atol = self.rtol * self.scale
        self._coef = {}
        self.paradox = {}
        self.max_step = {}
        for mode in (STICK, 1, -1, FLIGHT):
            matrix = self._matrix(mode, self.ck)
            inv = np.linalg.inv(matrix)
            # unknowns u = inv @ b, b = (0, -g, -c delta' - k delta, 0, rhs5)
            self._coef[mode] = tuple(
                (-self.g * inv[i, 1], inv[i, 2], inv[i, 4]) for i in range(5)
            )
            # delta'' = ... + (1 / D) (-c delta' - k delta): the mode's frequency here
            rate = math.sqrt(self.k * abs(inv[2, 2]))
            self.max_step[mode] = 2.0 * math.pi / max(self.w, rate) / steps_per_period
            if mode in (1, -1):
                frictionless = np.linalg.det(self._matrix(mode, 0.0))
                self.paradox[mode] = np.linalg.det(matrix) * frictionless <= 0.0

    def _matrix(self, mode: int, ck: float) -> np.ndarray:
        M, sa, ca = self.M, self.sa, self.ca
        rows = [
            [1.0, 0.0, M * sa, -1.0, 0.0],  # X'' + M sa delta'' - Fx = 0
            [0.0, 1.0, M * ca, 0.0, -1.0],  # Z'' + M ca delta'' - Fz = -g
            [sa, ca, 1.0, 0.0, 0.0],  # sa X'' + ca Z'' + delta'' = -c delta' - k delta
        ]
        if mode == STICK:
            rows += [[1.0, 0, 0, 0, 0], [0, 1.0, 0, 0, 0]]  # X'' = 0, Z'' = -A
        elif mode == FLIGHT:
            rows += [[0, 0, 0, 1.0, 0], [0, 0, 0, 0, 1.0]]  # Fx = 0, Fz = 0
        else:
            rows += [[0, 0, 0, 1.0, mode * ck], [0, 1.0, 0, 0, 0]]  # Fx = -s ck Fz, Z'' = -A
        return np.array(rows, dtype=float)

    def drive(self, t: float) -> float:
        """``A(t) = a cos(w t)`` [m s-2] (``t``: time since phase 0)."""
        return self.a * math.cos(self.w * t)

    def unknowns(self, mode: int, t: float, delta: float, delta_rate: float) -> list[float]:
        """``[X'', Z'', delta'', Fx, Fz]`` in ``mode`` [m s-2]."""
        r3 = -self.c * delta_rate - self.k * delta
        r5 = 0.0 if mode == FLIGHT else -self.drive(t)
        return [c0 + c3 * r3 + c5 * r5 for c0, c3, c5 in self._coef[mode]]

    def unknown_rates(self, mode: int, t: float, delta: float,
                      delta_rate: float) -> list[float]:
        """Time derivatives of :meth:`unknowns` along the motion in ``mode`` [m s-3]."""
        accel = self.unknowns(mode, t, delta, delta_rate)[2]
        r3 = -self.c * accel - self.k * delta_rate
        r5 = 0.0 if mode == FLIGHT else self.a * self.w * math.sin(self.w * t)
        return [c3 * r3 + c5 * r5 for _, c3, c5 in self._coef[mode]]

    def unknown(self, mode: int, i: int, t: float, delta: float, delta_rate: float) -> float:
        """Entry ``i`` of :meth:`unknowns` alone (event functions)."""
        c0, c3, c5 = self._coef[mode][i]
        r5 = 0.0 if mode == FLIGHT else -self.a * math.cos(self.w * t)
        return c0 + c3 * (-self.c * delta_rate - self.k * delta) + c5 * r5

    def unknown_rate(self, mode: int, i: int, t: float, delta: float,
                     delta_rate: float) -> float:
        """Entry ``i`` of :meth:`unknown_rates` alone (event functions)."""
        accel = self.unknown(mode, 2, t, delta, delta_rate)
        _, c3, c5 = self._coef[mode][i]
        r5 = 0.0 if mode == FLIGHT else self.a * self.w * math.sin(self.w * t)
        return c3 * (-self.c * accel - self.k * delta_rate) + c5 * r5

    def rhs(self, mode: int):
        """``dy/dt`` of ``mode`` as a function of ``(t, y)``."""
        def f(t, y):
            u = self.unknowns(mode, t, y[0], y[1])
            if mode == FLIGHT:
                return [y[1], u[2], y[3], u[0], y[5], u[1] + self.drive(t)]
            acc = 0.0 if mode == STICK else u[0]
            return [y[1], u[2], y[3], acc, 0.0, 0.0]
        return f

    def stick_start(self) -> np.ndarray:
        """Rest at phase 0, mode on its steady stick response (the exact solver's start)."""
        gain = self.a * self.ca / complex(self.k - self.w**2, self.c * self.w)
        return np.array([gain.real, -self.w * gain.imag, 0.0, 0.0, 0.0, 0.0])


def _divided(fn, t0: float, order: int):
    """``fn / (t - t0)^order``, ``+1`` at ``t = t0`` (a known zero of ``fn`` divided out)."""
    if order == 0:
        return fn

    def g(t, y):
        tau = t - t0
        if tau <= 0.0:
            return 1.0
        return fn(t, y) / tau**order
    return g


def _event(fn, direction: float, terminal: bool):
    fn.direction = direction
    fn.terminal = terminal
    return fn


@dataclass
class _Watch:
    """A crossing event and the extrema of its function that could hide two crossings.

    ``crossing`` falls (``direction = -1``) or rises (``+1``) through 0; ``extremum`` is
    its derivative (divided by ``tau^(m-1)`` like the crossing by ``tau^m``) passing 0
    the other way: a minimum (a maximum) of the crossing function. An extremum beyond 0
    that no step end saw is a pair of crossings inside one step; the first is located
    on the step's dense output.
    """

    kind: str
    crossing: Any
    extremum: Any


def _watch(kind: str, fn, rate, direction: float, t0: float, order: int) -> _Watch:
    crossing = _event(_divided(fn, t0, order), direction, True)
    extremum = _event(_divided(rate, t0, max(order - 1, 0)), -direction, False)
    return _Watch(kind, crossing, extremum)


def _events(model: FlightModel, mode: int, t0: float, order: int) -> tuple[list, list]:
    """Crossing events (watched) and plain events (``(kind, function)``) of one segment."""
    cs = model.cs
    if mode == STICK:
        force, rate = model.unknown, model.unknown_rate

        def forward(t, y):
            return -force(STICK, 3, t, y[0], y[1]) - cs * force(STICK, 4, t, y[0], y[1])

        def forward_rate(t, y):
            return -rate(STICK, 3, t, y[0], y[1]) - cs * rate(STICK, 4, t, y[0], y[1])

        def backward(t, y):
            return force(STICK, 3, t, y[0], y[1]) - cs * force(STICK, 4, t, y[0], y[1])

        def backward_rate(t, y):
            return rate(STICK, 3, t, y[0], y[1]) - cs * rate(STICK, 4, t, y[0], y[1])

        def normal(t, y):
            return force(STICK, 4, t, y[0], y[1])

        def normal_rate(t, y):
            return rate(STICK, 4, t, y[0], y[1])
        return [
            _watch("release+", forward, forward_rate, 1.0, t0, 0),
            _watch("release-", backward, backward_rate, 1.0, t0, 0),
            _watch("take-off", normal, normal_rate, -1.0, t0, 0),
        ], []
    if mode == FLIGHT:
        def gap(t, y):
            return y[4]

        def gap_rate(t, y):
            return y[5]

        apex = _event(_divided(gap_rate, t0, max(order - 1, 0)), -1.0, False)
        return [_watch("impact", gap, gap_rate, -1.0, t0, order)], [("apex", apex)]
    s = mode

    def slip_velocity(t, y):
        return s * y[3]

    def slip_accel(t, y):
        return s * model.unknown(s, 0, t, y[0], y[1])

    def slip_normal(t, y):
        return model.unknown(s, 4, t, y[0], y[1])

    def slip_normal_rate(t, y):
        return model.unknown_rate(s, 4, t, y[0], y[1])
    return [
        _watch("slip-end", slip_velocity, slip_accel, -1.0, t0, order),
        _watch("take-off", slip_normal, slip_normal_rate, -1.0, t0, 0),
    ], []


def _hidden_crossing(watch: _Watch, t_ext: np.ndarray, y_ext: np.ndarray, steps: np.ndarray,
                     dense, t_start: float) -> tuple[float, np.ndarray] | None:
    """First crossing hidden inside a step (two crossings between step ends), if any.

    ``dense()`` returns the segment's dense output (computed only when needed).
    """
    direction = watch.crossing.direction
    for t_x, y_x in zip(t_ext, y_ext, strict=True):
        if t_x <= t_start:
            continue
        if direction * watch.crossing(t_x, y_x) <= 0.0:
            continue
        before = steps[steps < t_x]
        t_left = float(before[-1]) if before.size else t_start
        sol = dense()

        def fn(t, sol=sol):
            return watch.crossing(t, sol(t))
        if direction * fn(t_left) >= 0.0:  # cannot happen: no crossing seen at t_left
            continue
        root = brentq(fn, t_left, float(t_x), xtol=4 * _EPS * max(1.0, abs(t_x)),
                      rtol=4 * _EPS)
        return float(root), sol(root)
    return None


# --- impact -------------------------------------------------------------------------------


@dataclass(frozen=True)
class ImpactResult:
    """One impact, from the Darboux-Keller integration.

    Attributes
    ----------
    delta_rate, velocity, gap_rate : float
        Post-impact ``delta'``, ``v`` and ``h'`` [m s-1].
    normal_impulse, tangential_impulse : float
        ``Pz >= 0`` and ``Px`` per unit total mass [m s-1].
    ended : str
        ``"stick"`` (``v = 0`` at the end) or ``"slip"``.
    paradox : bool
        A sliding phase had ``dh'/dp <= 0`` (the impact friction paradox); the other
        fields are then NaN.
    """

    delta_rate: float
    velocity: float
    gap_rate: float
    normal_impulse: float
    tangential_impulse: float
    ended: str
    paradox: bool = False


def impact(model: FlightModel, delta_rate: float, velocity: float, gap_rate: float,
           restitution: float | None = None) -> ImpactResult:
    """Impact law by numerical Darboux-Keller integration along the normal impulse.

    Parameters
    ----------
    model : FlightModel
        Parameters (``M``, ``alpha``, ``cs``, ``ck``, restitution).
    delta_rate, velocity, gap_rate : float
        Pre-impact ``delta'``, ``v`` and ``h' < 0`` [m s-1].
    restitution : float, optional
        Newton's coefficient [1]; default the model's.

    Returns
    -------
    ImpactResult
    """
    e = model.e if restitution is None else float(restitution)
    if not gap_rate < 0.0:
        raise ValueError(f"an impact needs gap_rate < 0, got {gap_rate}")
    W = model.W
    wxx, wxz, wzz = W[0, 0], W[0, 1], W[1, 1]
    target = -e * gap_rate
    nan = float("nan")
    v, hr, px, p = float(velocity), float(gap_rate), 0.0, 0.0
    sliding = 0 if v == 0.0 else (1 if v > 0 else -1)
    for _ in range(4):
        if sliding == 0:
            ratio = wxz / wxx
            if abs(ratio) <= model.cs:
                slopes = (0.0, wzz - wxz * ratio, -ratio)
            else:
                sliding = 1 if wxz > 0 else -1
                continue
        else:
            s = sliding
            slopes = (wxz - s * model.ck * wxx, wzz - s * model.ck * wxz, -s * model.ck)
            if slopes[1] <= 0.0:
                return ImpactResult(nan, nan, nan, nan, nan, "slip", paradox=True)
        span = 2.0 * (target - hr) / slopes[1]

        def flow(_p, z, slopes=slopes):
            return slopes

        def done(_p, z):
            return z[1] - target
        done.terminal, done.direction = True, 1.0
        events = [done]
        if sliding != 0:
            def stop(_p, z, s=sliding):
                return s * z[0]
            stop.terminal, stop.direction = True, -1.0
            events.append(stop)
        # The flow is constant along p in each phase: one step covers the span, the
        # events are located on its (exact, linear) dense output.
        p_bound = p + span
        sol = solve_ivp(flow, (p, p_bound), [v, hr, px], method="DOP853", rtol=RTOL,
                        atol=RTOL * abs(gap_rate), events=events, first_step=p_bound - p)
        hit = [(sol.t_events[i][0], i) for i in range(len(events)) if sol.t_events[i].size]
        if not hit:  # cannot happen: the span reaches the target
            raise ModelBreakdown("not-periodic", "impact integration missed its end")
        p_end, which = min(hit)
        z = sol.y_events[which][0]
        v, hr, px, p = float(z[0]), float(z[1]), float(z[2]), float(p_end)
        if which == 0:
            hr = target
            break
        v = 0.0  # the base stopped sliding during the impact: stick test
        sliding = 0
    else:
        raise ModelBreakdown("not-periodic", "impact: too many phases")
    dv, dh = v - velocity, hr - gap_rate
    new_rate = delta_rate - (model.sa * dv + model.ca * dh)
    ended = "stick" if v == 0.0 else "slip"
    return ImpactResult(new_rate, v, hr, p, px, ended)


# --- simulation ---------------------------------------------------------------------------


@dataclass
class _Tally:
    """What happened over some time."""

    duration: float = 0.0
    airborne: float = 0.0
    stuck: float = 0.0
    slips: int = 0
    take_offs: int = 0
    impacts: int = 0
    largest_hop: float = 0.0
    displacement: float = 0.0
    hidden: int = 0

    def add(self, other: _Tally) -> None:
        self.duration += other.duration
        self.airborne += other.airborne
        self.stuck += other.stuck
        self.slips += other.slips
        self.take_offs += other.take_offs
        self.impacts += other.impacts
        self.largest_hop = max(self.largest_hop, other.largest_hop)
        self.displacement += other.displacement
        self.hidden += other.hidden


@dataclass
class _Motion:
    """The hybrid state: continuous ``y``, the mode, its segment's start and zero order."""

    y: np.ndarray
    mode: int
    start: float  # local time of the segment's start (may precede the period)
    order: int


class _Recorder:
    """Collects events and sampled states (for :func:`simulate`)."""

    def __init__(self) -> None:
        self.events: list[dict] = []
        self.t: list[np.ndarray] = []
        self.y: list[np.ndarray] = []
        self.modes: list[np.ndarray] = []


def _contact(model: FlightModel, t: float, y: np.ndarray) -> _Motion:
    """The motion that starts on the table with ``h = h' = 0`` (after a landing, at rest).

    The first consistent mode: with ``v != 0`` the slip in its sign when its ``Fz >= 0``;
    with ``v = 0`` stick when ``Fz >= 0`` and ``|Fx| <= cs Fz``, else a slip of sign ``s``
    with ``Fz >= 0`` that accelerates the base in its own direction (the one against the
    stick friction first); otherwise flight, which needs ``h'' > 0`` (a contact force
    with ``Fz < 0`` cannot simply be switched off: the stick friction that comes off with
    it moves the base too). No consistent mode: the friction paradox (Painleve).
    """
    y = y.copy()
    y[4] = y[5] = 0.0
    d, dr, v = y[0], y[1], y[3]
    if v != 0.0:
        s = 1 if v > 0 else -1
        if model.unknown(s, 4, t, d, dr) >= 0.0:
            if model.paradox[s]:
                raise ModelBreakdown("friction-paradox", f"slip {s:+d} at t = {t}")
            return _Motion(y, s, t, 0)
        order = 2
    else:
        fx, fz = model.unknown(STICK, 3, t, d, dr), model.unknown(STICK, 4, t, d, dr)
        if fz >= 0.0 and abs(fx) <= model.cs * fz:
            return _Motion(y, STICK, t, 0)
        for s in ((1, -1) if fx < 0.0 else (-1, 1)):
            if model.unknown(s, 4, t, d, dr) >= 0.0 and s * model.unknown(s, 0, t, d, dr) > 0.0:
                if model.paradox[s]:
                    raise ModelBreakdown("friction-paradox", f"slip {s:+d} at t = {t}")
                return _Motion(y, s, t, 1)
        order = 2
    if model.unknown(FLIGHT, 1, t, d, dr) + model.drive(t) > 0.0:
        return _Motion(y, FLIGHT, t, order)
    raise ModelBreakdown("friction-paradox", f"no consistent contact mode at t = {t}")


def _initial(model: FlightModel, t: float, state: Sequence[float]) -> _Motion:
    """Hybrid start from ``(delta, delta', v, h, h')`` at local time ``t``."""
    d, dr, v, h, hr = (float(x) for x in state)
    y = np.array([d, dr, 0.0, v, h, hr])
    if h < 0.0:
        raise ValueError(f"the gap h must be >= 0, got {h}")
    if h > 0.0 or hr > 0.0:
        return _Motion(y, FLIGHT, t, 0 if h > 0.0 else 1)
    if hr < 0.0:
        return _land(model, t, y, _Tally(), None)
    return _contact(model, t, y)


def _land(model: FlightModel, t: float, y: np.ndarray, tally: _Tally, rec,
          t_offset: float = 0.0) -> _Motion:
    """Impact at ``h = 0``, ``h' < 0``: the new motion."""
    tally.impacts += 1
    hit = impact(model, y[1], y[3], y[5])
    if hit.paradox:
        raise ModelBreakdown("friction-paradox", f"impact at t = {t}")
    threshold = model.chatter_threshold
    if model.e > 0.0 and hit.gap_rate < threshold:
        hit = impact(model, y[1], y[3], y[5], restitution=0.0)
    if rec is not None:
        rec.events.append({"t": t + t_offset, "kind": "impact", "gap_rate": y[5], "velocity": y[3],
                           "normal_impulse": hit.normal_impulse,
                           "tangential_impulse": hit.tangential_impulse,
                           "rebound": hit.gap_rate, "ended": hit.ended})
    y = y.copy()
    y[1], y[3], y[4], y[5] = hit.delta_rate, hit.velocity, 0.0, hit.gap_rate
    if hit.gap_rate > 0.0:
        return _Motion(y, FLIGHT, t, 1)
    return _contact(model, t, y)


def _advance(model: FlightModel, motion: _Motion, t_a: float, t_b: float,
             rec: _Recorder | None = None, t_offset: float = 0.0,
             reset_x: bool = True) -> tuple[_Motion, _Tally]:
    """Follow the motion from local time ``t_a`` to ``t_b`` (``x`` restarts at 0 if asked)."""
    tally = _Tally(duration=t_b - t_a)
    t = t_a
    y = motion.y.copy()
    if reset_x:
        y[2] = 0.0
    x_start = y[2]
    motion = _Motion(y, motion.mode, motion.start, motion.order)
    for _ in range(MAX_SEGMENTS):
        mode = motion.mode
        if t_b - t <= 0.0:
            break
        watches, plain = _events(model, mode, motion.start, motion.order)
        funcs = ([w.crossing for w in watches] + [w.extremum for w in watches]
                 + [fn for _, fn in plain])
        options = {"method": "DOP853", "rtol": model.rtol, "atol": model.atol,
                   "max_step": model.max_step[mode]}
        sol = solve_ivp(model.rhs(mode), (t, t_b), motion.y, events=funcs, **options)
        if sol.status < 0:
            raise ModelBreakdown("not-periodic", f"solve_ivp failed: {sol.message}")

        def dense(t=t, t_last=float(sol.t[-1]), y0=motion.y, mode=mode, options=options):
            # the same steps again, with their interpolants
            again = solve_ivp(model.rhs(mode), (t, t_last), y0, dense_output=True, **options)
            return again.sol
        n_watch = len(watches)
        found = []  # (time, kind, state)
        for j, w in enumerate(watches):
            if sol.t_events[j].size:
                found.append((float(sol.t_events[j][0]), w.kind, sol.y_events[j][0]))
            hidden = _hidden_crossing(w, sol.t_events[n_watch + j], sol.y_events[n_watch + j],
                                      sol.t, dense, t)
            if hidden is not None:
                found.append((hidden[0], w.kind, hidden[1]))
                tally.hidden += 1
        if found:
            t_end, kind, y = min(found, key=lambda item: item[0])
            y = np.array(y, dtype=float)
        else:
            t_end, kind, y = float(sol.t[-1]), "", sol.y[:, -1].copy()
        inside = sol.t <= t_end
        if rec is not None:
            rec.t.append(np.append(sol.t[inside], t_end) + t_offset)
            rec.y.append(np.vstack([sol.y[:, inside].T, y]))
            rec.modes.append(np.full(int(inside.sum()) + 1, mode))
        if mode == FLIGHT:
            tally.airborne += t_end - t
            hops = [float(np.max(sol.y[4][inside])), float(y[4])]
            k_apex = 2 * n_watch  # the plain 'apex' event
            hops += [float(ya[4]) for ta, ya in zip(sol.t_events[k_apex],
                                                   sol.y_events[k_apex], strict=True)
                     if ta <= t_end]
            tally.largest_hop = max(tally.largest_hop, *hops)
        elif mode == STICK:
            tally.stuck += t_end - t
        if not kind:
            motion = _Motion(y, mode, motion.start, motion.order)
            t = t_b
            break
        t = t_end
        if rec is not None and kind != "impact":
            rec.events.append({"t": t + t_offset, "kind": kind, "state": y.copy()})
        if kind in ("release+", "release-"):
            s = 1 if kind == "release+" else -1
            if model.paradox[s]:
                raise ModelBreakdown("friction-paradox", f"release {s:+d} at t = {t}")
            y[3] = 0.0
            tally.slips += 1
            motion = _Motion(y, s, t, 2)
        elif kind == "take-off":
            y[4] = y[5] = 0.0
            tally.take_offs += 1
            motion = _Motion(y, FLIGHT, t, 3)
        elif kind == "slip-end":
            y[3] = 0.0
            nxt = _contact(model, t, y)
            if nxt.mode == FLIGHT:
                tally.take_offs += 1
            elif nxt.mode != STICK:
                tally.slips += 1
                if nxt.mode == mode:
                    nxt.order = 2  # the slip touched v = 0 and goes on
            motion = nxt
        else:  # impact
            motion = _land(model, t, y, tally, rec, t_offset)
            if motion.mode == FLIGHT and motion.order == 2:
                tally.take_offs += 1
            elif motion.mode in (1, -1):
                tally.slips += 1
    else:
        raise ModelBreakdown("not-periodic", f"more than {MAX_SEGMENTS} segments in a period")
    tally.displacement = float(motion.y[2] - x_start)
    return motion, tally


@dataclass
class Simulation:
    """Result of :func:`simulate`.

    Attributes
    ----------
    events : list of dict
        In time order: ``t`` [s] and ``kind`` (``release+``, ``release-``, ``slip-end``,
        ``take-off``, ``impact``); impacts also carry ``gap_rate``, ``velocity``,
        ``normal_impulse``, ``tangential_impulse``, ``rebound`` [m s-1] and ``ended``.
    t : numpy.ndarray
        Sample times [s] (the integrator's steps), from 0.
    states : numpy.ndarray
        ``(n, 6)``: ``delta [m], delta' [m s-1], x [m] (from the start), v [m s-1],
        h [m], h' [m s-1]`` at ``t``.
    modes : numpy.ndarray
        Contact mode at ``t`` (0 stick, +1 / -1 slip, 2 flight).
    final : tuple of float
        ``(delta, delta', v, h, h')`` at ``t_end``.
    final_mode : int
    displacement : float
        ``x(t_end) - x(0)`` [m].
    airborne_time : float
        Time in flight [s].
    impacts : int
    status : str
        ``"ok"`` or ``"friction-paradox"``.
    """

    events: list
    t: np.ndarray
    states: np.ndarray
    modes: np.ndarray
    final: tuple
    final_mode: int
    displacement: float
    airborne_time: float
    impacts: int
    status: str = "ok"


def simulate(structure: Any, f: float, a: float, t_end: float, state0: Any,
             phase0: float = 0.0, restitution: float | None = None,
             **options: Any) -> Simulation:
    """Follow the two-way model with flight and impacts from a given state.

    Parameters
    ----------
    structure : Structure or mapping
        ``f0 [Hz], Q [1], alpha [degree], M [1] (0 < M < 1), cs, ck [1], g [m s-2]``
        and ``restitution [1]``.
    f, a : float
        Drive frequency [Hz] and amplitude [m s-2]: table acceleration
        ``-a cos(2 pi f t + phase0)``.
    t_end : float
        Duration [s].
    state0 : sequence or mapping
        ``(delta [m], delta' [m s-1], v [m s-1], h [m], h' [m s-1])`` or a mapping with
        the keys ``delta, delta_rate, velocity, gap, gap_rate``. ``h > 0`` or ``h' > 0``:
        in flight; ``h = h' = 0``: on the table (slip in the sign of ``v``, else the stick
        test; a negative normal force takes off at once); ``h = 0 > h'``: an impact.
    phase0 : float
        Drive phase at ``t = 0`` [rad].
    restitution : float, optional
        Overrides the structure's restitution [1].
    **options
        ``rtol``, ``steps_per_period``, ``chatter_speed`` of :class:`FlightModel`.

    Returns
    -------
    Simulation
    """
    model = FlightModel(structure, f, a, restitution, **options)
    if isinstance(state0, Mapping):
        state0 = [state0[name] for name in _STATE_NAMES]
    t_local = (float(phase0) % (2.0 * math.pi)) / model.w
    rec = _Recorder()
    motion = _initial(model, t_local, state0)
    offset = -t_local
    left = float(t_end)
    displacement = airborne = 0.0
    impacts = 0
    status = "ok"
    try:
        while left > 0.0:
            stop = min(model.T, t_local + left)
            motion, tally = _advance(model, motion, t_local, stop, rec, offset, reset_x=False)
            displacement += tally.displacement
            airborne += tally.airborne
            impacts += tally.impacts
            left -= stop - t_local
            offset += model.T
            motion.start -= model.T
            t_local = 0.0
            if left < 1e-12 * model.T:
                break
    except ModelBreakdown as stop:
        status = stop.status
    y = motion.y
    t = np.concatenate(rec.t) if rec.t else np.zeros(0)
    states = np.concatenate(rec.y) if rec.y else np.zeros((0, 6))
    modes = np.concatenate(rec.modes) if rec.modes else np.zeros(0, int)
    return Simulation(rec.events, t, states, modes,
                      (y[0], y[1], y[3], y[4], y[5]), motion.mode, displacement, airborne,
                      impacts, status)


# --- steady motion ------------------------------------------------------------------------


@dataclass(frozen=True)
class SteadyMotion:
    """Steady motion reached from a start.

    Attributes
    ----------
    velocity : float
        Mean velocity over the measured orbit [m s-1] (0 when static; NaN at a
        friction paradox). When not periodic, the mean over the ``IRREGULAR_MEASURE``
        (64) drive periods that follow ``max_periods``, like the other averages: for an
        irregular (chaotic) motion an estimate, not a converged number.
    period : int
        Orbit period [drive periods] (0 when not periodic).
    airborne_fraction : float
        Fraction of the time in flight [1].
    largest_hop : float
        Largest gap ``h`` over the orbit [m].
    impacts_per_period : float
        Impacts per drive period [1] (chattering rebounds above the cut-off counted).
    take_offs_per_period : float
        Take-offs per drive period [1].
    slips_per_period : float
        Slip starts per drive period [1].
    status : str
        ``"static"``, ``"stick-slip"``, ``"continuous"``, ``"bouncing"``,
        ``"not-periodic"`` or ``"friction-paradox"``.
    state : tuple of float
        ``(delta, delta', v, h, h')`` at phase 0 on the orbit, and ``mode``.
    residual : float
        Distance (natural units) between the phase-0 states ``period`` drive periods
        apart when the orbit was accepted.
    periods : int
        Drive periods followed before the measurement.
    detail : str
        Why no orbit was found, or where the motion left the model.
    """

    velocity: float
    period: int
    airborne_fraction: float
    largest_hop: float
    impacts_per_period: float
    take_offs_per_period: float
    slips_per_period: float
    status: str
    state: tuple
    residual: float
    periods: int
    detail: str = field(default="")


def _distance(model: FlightModel, m1: _Motion, m2: _Motion) -> float:
    if m1.mode != m2.mode:
        return math.inf
    idx = [0, 1, 3, 4, 5]
    return float(np.max(np.abs(m1.y[idx] - m2.y[idx]) / model.scale[idx]))


def _start(model: FlightModel, start: Any) -> _Motion:
    if start == "rest":
        return _contact(model, 0.0, model.stick_start())
    if start == "still":
        return _contact(model, 0.0, np.zeros(6))
    if isinstance(start, Sequence) and len(start) == 2 and start[0] == "drop":
        height = float(start[1])
        if not height > 0.0:
            raise ValueError(f"the drop height must be > 0 [m], got {height}")
        y = np.array([model.g * model.ca / model.k, 0.0, 0.0, 0.0, height, 0.0])
        return _Motion(y, FLIGHT, 0.0, 0)
    raise ValueError(f"start must be 'rest', 'still' or ('drop', height [m]), got {start!r}")


def steady_motion(structure: Any, f: float, a: float, *, start: Any = "rest",
                  periods_transient: int = 20, periods_measure: int = 8,
                  restitution: float | None = None, tol: float = 1e-10,
                  max_periods: int = 1500, **options: Any) -> SteadyMotion:
    """Steady motion of the two-way model with flight, reached from a start.

    Parameters
    ----------
    structure : Structure or mapping
        ``f0 [Hz], Q [1], alpha [degree], M [1] (0 < M < 1), cs, ck [1], g [m s-2]``,
        ``restitution [1]``.
    f, a : float
        Drive frequency [Hz] and amplitude [m s-2].
    start : "rest", "still" or ("drop", height)
        ``"rest"``: at phase 0 on the table, ``v = 0``, mode on its steady stick
        response (the exact solver's start); ``"still"``: at phase 0 on the table,
        ``v = 0``, the mode at rest at its contact equilibrium (``delta = delta' = 0``:
        the drive switched on at ``t = 0``); ``("drop", height [m])``: the base released
        at phase 0 at rest ``height`` above the table, mode at its flight equilibrium.
    periods_transient : int
        Drive periods followed at least before the orbit may be accepted.
    periods_measure : int
        Drive periods measured on the orbit (rounded up to a multiple of its period).
    restitution : float, optional
        Overrides the structure's restitution [1].
    tol : float
        Acceptance: the phase-0 state repeats after ``N = 1..8`` periods to ``tol``
        (each component over its natural scale, ``g / W^2`` or ``g / W`` with
        ``W = max(w, w0 / sqrt(1 - M))``) [1].
    max_periods : int
        Drive periods followed at most before ``"not-periodic"``.
    **options
        ``rtol``, ``steps_per_period``, ``chatter_speed`` of :class:`FlightModel`.

    Returns
    -------
    SteadyMotion
    """
    model = FlightModel(structure, f, a, restitution, **options)
    nan = float("nan")
    try:
        motion = _start(model, start)
        history = [motion]
        found = 0
        residual = nan
        for k in range(1, max_periods + 1):
            motion, _ = _advance(model, motion, 0.0, model.T)
            motion.start -= model.T
            history.append(motion)
            if k < periods_transient:
                continue
            # The orbit's period is the first N whose distance is below a loose bound:
            # a slowly decaying transient that turns by about 2 pi / N per period brings
            # the distance over N periods below tol before the distance over one.
            distances = [_distance(model, history[-1], history[-1 - n])
                         for n in range(1, min(MAX_ORBIT, len(history) - 1) + 1)]
            near = [n for n, d in enumerate(distances, 1) if d < LOOSE]
            if near and distances[near[0] - 1] < tol:
                found, residual = near[0], distances[near[0] - 1]
                break
        periods = k
        if found:
            n_measure = found * math.ceil(periods_measure / found)
        else:  # irregular motion (or a transient slower than max_periods): a long mean
            n_measure = max(periods_measure, IRREGULAR_MEASURE)
        total = _Tally()
        for _ in range(n_measure):
            motion, tally = _advance(model, motion, 0.0, model.T)
            motion.start -= model.T
            total.add(tally)
    except ModelBreakdown as stop:
        return SteadyMotion(nan, 0, nan, nan, nan, nan, nan, stop.status,
                            (nan,) * 5 + (0,), nan, 0, stop.where)
    duration = n_measure * model.T
    if not found:
        status = "not-periodic"
    elif total.take_offs or total.impacts or total.airborne > 0.0:
        status = "bouncing"
    elif total.slips == 0:
        status = "static"
    elif total.stuck > 0.0:
        status = "stick-slip"
    else:
        status = "continuous"
    velocity = 0.0 if status == "static" else total.displacement / duration
    y = history[-1].y
    return SteadyMotion(
        velocity=velocity,
        period=found,
        airborne_fraction=total.airborne / duration,
        largest_hop=total.largest_hop,
        impacts_per_period=total.impacts / n_measure,
        take_offs_per_period=total.take_offs / n_measure,
        slips_per_period=total.slips / n_measure,
        status=status,
        state=(float(y[0]), float(y[1]), float(y[3]), float(y[4]), float(y[5]),
               int(history[-1].mode)),
        residual=residual,
        periods=periods,
        detail="" if found else (
            f"the phase-0 state did not repeat within {tol} over 1..{MAX_ORBIT} periods "
            f"in {max_periods} periods"),
    )
