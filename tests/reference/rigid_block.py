"""Closed form of the ``M -> 0`` limit with flight: a rigid block on a shaken table.

Plain Python, :mod:`math` and :func:`scipy.optimize.brentq`; nothing from ``study``.
With the plate massless the base is a rigid block: no horizontal force acts on it (its
mean velocity is 0), the normal force per unit mass is ``n = g - A``, ``A = a cos(phi)``,
``phi = w t`` the drive phase, and the landings are plastic.

* **Take-off** where ``n`` falls through 0: ``a cos(phi) = g`` with ``sin(phi) < 0``,
  ``phi_0 = -arccos(g / a)`` (mod ``2 pi``); there is none when ``a <= g``.
* **Flight** (``tau`` the time since take-off): the gap above the table is::

      h(tau) = -g tau^2 / 2 + (a / w^2) (cos(phi_0) - cos(phi_0 + w tau)) - (a / w) sin(phi_0) tau

  (``h = h' = h'' = 0`` at ``tau = 0``, ``h''' = -a w sin(phi_0) > 0``).
* **Landing** at the first root ``tau_L > 0`` of ``h``. The search starts past the triple
  zero at ``tau_s = 2 |sin(phi_0)| / w``: since ``|h''''| <= a w^2``,
  ``h >= h''' tau^3 / 6 - a w^2 tau^4 / 24 > 0`` on ``(0, 4 |sin(phi_0)| / w)``. From
  ``tau_s`` the interval up to ``tau_max`` (where ``-g tau^2 / 2 + 2 a / w^2 +
  (a / w) |sin(phi_0)| tau`` turns negative, so ``h < 0``) is cut into pieces; a piece is
  excluded when the lower bound ``h(t_i) + min(0, h'(t_i)) d - (g + a) d^2 / 2`` stays
  positive (``|h''| <= g + a``), else halved; the first piece with a sign change is
  solved by ``brentq`` (the landing time is the root of the transcendental equation
  ``h(tau) = 0`` above). Halving stops at ``1e-13`` of a period: a piece that small
  with no sign change is a grazing touch, not a landing.
* **After the landing** the block rides the table when ``n >= 0`` there
  (``a cos(phi_L) <= g``) until the next take-off phase ``phi_0 + 2 pi N`` (the first
  past ``phi_L``): the motion is periodic with period ``N`` drive periods, one flight
  and one impact per orbit. When it lands where ``n < 0`` (inside the take-off window)
  it leaves again at once, from another phase: the flights no longer start at
  ``phi_0``, which is where the closed form stops (status ``"beyond"``; for the
  completely inelastic block this first happens when the flight lasts exactly one
  period: the period-doubling cascade of the bouncing block starts there, at
  ``a = g sqrt(1 + pi^2)``, :func:`one_period_amplitude`).
* **Largest hop**: the largest ``h`` at a root of ``h'`` in ``(0, tau_L)`` (roots bracketed
  the same way, ``|h'''| <= a w``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy.optimize import brentq

__all__ = [
    "RigidBlock",
    "gap",
    "gap_rate",
    "landing_time",
    "one_period_amplitude",
    "rigid_block",
]

#: Smallest piece of the bracketing search [drive periods].
_MIN_PIECE = 1e-13
#: Initial pieces per drive period.
_PIECES = 64


def gap(tau: float, phi0: float, g: float, a: float, w: float) -> float:
    """Gap ``h`` [m] at ``tau`` [s] after a take-off at phase ``phi0`` [rad] with ``h = h' = 0``."""
    return (-0.5 * g * tau * tau + (a / w**2) * (math.cos(phi0) - math.cos(phi0 + w * tau))
            - (a / w) * math.sin(phi0) * tau)


def gap_rate(tau: float, phi0: float, g: float, a: float, w: float) -> float:
    """``h'`` [m s-1] of :func:`gap`."""
    return -g * tau + (a / w) * (math.sin(phi0 + w * tau) - math.sin(phi0))


def _first_root(fn, dfn, bound2: float, lo: float, hi: float, period: float) -> float | None:
    """First root of ``fn`` in ``(lo, hi]`` with ``fn(lo) > 0``, ``|fn''| <= bound2``."""
    step = period / _PIECES
    n = max(1, math.ceil((hi - lo) / step))
    pieces = [(lo + (hi - lo) * i / n, lo + (hi - lo) * (i + 1) / n) for i in range(n)]
    stack = list(reversed(pieces))
    while stack:
        t0, t1 = stack.pop()
        f0, f1 = fn(t0), fn(t1)
        if f0 > 0.0 >= f1:
            return brentq(fn, t0, t1, xtol=1e-300, rtol=4 * 2.220446049250313e-16)
        if f0 <= 0.0:  # only at a grazing zero left behind
            continue
        d = t1 - t0
        if f0 + min(0.0, dfn(t0)) * d - 0.5 * bound2 * d * d > 0.0:
            continue
        if d < _MIN_PIECE * period:
            continue
        mid = 0.5 * (t0 + t1)
        stack.append((mid, t1))
        stack.append((t0, mid))
    return None


def landing_time(phi0: float, g: float, a: float, w: float) -> float:
    """Flight time ``tau_L`` [s] after a take-off at ``phi0`` [rad] from rest on the table.

    Parameters
    ----------
    phi0 : float
        Take-off phase [rad]: ``a cos(phi0) = g``, ``sin(phi0) < 0``.
    g, a : float
        Gravity and drive amplitude [m s-2].
    w : float
        Drive angular frequency [rad s-1].

    Returns
    -------
    float
        The first root of :func:`gap` past ``tau = 0``.
    """
    period = 2 * math.pi / w
    s0 = abs(math.sin(phi0))
    lo = 2.0 * s0 / w
    b = (a / w) * s0
    hi = (b + math.sqrt(b * b + 4 * g * a / w**2)) / g * 1.0000001 + lo
    found = _first_root(
        lambda t: gap(t, phi0, g, a, w), lambda t: gap_rate(t, phi0, g, a, w),
        g + a, lo, hi, period,
    )
    if found is None:
        raise RuntimeError("no landing found (cannot happen: h < 0 at tau_max)")
    return found


@dataclass(frozen=True)
class RigidBlock:
    """Steady motion of the rigid block (plastic landings).

    Attributes
    ----------
    status : str
        ``"static"`` (``a <= g``: never leaves), ``"bouncing"`` (closed form), or
        ``"beyond"`` (lands inside the take-off window: the closed form stops).
    take_off_phase, landing_phase : float
        ``phi_0`` in ``(-pi, 0]`` and ``phi_L = phi_0 + w tau_L`` [rad].
    flight_time : float
        ``tau_L`` [s].
    period : int
        Orbit period [drive periods].
    airborne_fraction : float
        ``tau_L / (period T)`` [1].
    largest_hop : float
        Largest gap [m].
    impacts_per_period : float
        ``1 / period`` [1].
    velocity : float
        Mean velocity [m s-1]: 0 (no horizontal force on the block).
    """

    status: str
    take_off_phase: float
    landing_phase: float
    flight_time: float
    period: int
    airborne_fraction: float
    largest_hop: float
    impacts_per_period: float
    velocity: float = 0.0


def rigid_block(f: float, a: float, g: float = 9.8) -> RigidBlock:
    """Closed-form steady motion of a rigid block on a table shaken by ``a cos(2 pi f t)``.

    Parameters
    ----------
    f : float
        Drive frequency [Hz].
    a : float
        Drive acceleration amplitude [m s-2].
    g : float
        Gravitational acceleration [m s-2].

    Returns
    -------
    RigidBlock
    """
    w = 2 * math.pi * f
    nan = float("nan")
    if a <= g:
        return RigidBlock("static", nan, nan, 0.0, 1, 0.0, 0.0, 0.0)
    phi0 = -math.acos(g / a)
    tau = landing_time(phi0, g, a, w)
    phi_l = phi0 + w * tau
    # apexes: roots of h' in (0, tau); h' > 0 just after take-off, |h'''| <= a w
    hop = 0.0
    lo = 2.0 * abs(math.sin(phi0)) / w  # h' >= h''' t^2/2 - a w^2 t^3/6 > 0 before 3|s0|/w
    rate = lambda t: gap_rate(t, phi0, g, a, w)  # noqa: E731
    accel = lambda t: -g + a * math.cos(phi0 + w * t)  # noqa: E731
    while lo < tau:
        root = _first_root(rate, accel, a * w, lo, tau, 2 * math.pi / w)
        if root is None:
            break
        hop = max(hop, gap(root, phi0, g, a, w))
        # skip past the local extremum: h' turns back positive only after its minimum
        nxt = _first_root(lambda t: -rate(t), lambda t: -accel(t), a * w,
                          root + 1e-12 * tau, tau, 2 * math.pi / w)
        if nxt is None:
            break
        lo = nxt + 1e-12 * tau
    if a * math.cos(phi_l) > g:
        return RigidBlock("beyond", phi0, phi_l, tau, 0, nan, hop, nan)
    n_periods = math.floor((phi_l - phi0) / (2 * math.pi)) + 1
    return RigidBlock("bouncing", phi0, phi_l, tau, n_periods,
                      tau * f / n_periods, hop, 1.0 / n_periods)


def one_period_amplitude(g: float = 9.8) -> float:
    """Drive amplitude [m s-2] at which the flight lasts exactly one drive period.

    Landing at ``tau = T`` (``w T = 2 pi``) in :func:`gap` leaves
    ``-g T^2 / 2 - (a / w) sin(phi_0) T = 0``, so ``sin(phi_0) = -pi g / a``; with
    ``cos(phi_0) = g / a``, ``a = g sqrt(1 + pi^2)`` (``3.2969 g``), for every frequency.
    Above it the block lands inside the take-off window and the closed form stops
    (:func:`rigid_block` returns ``"beyond"``) until the flight is long enough to land
    past the window, in a later period.

    Parameters
    ----------
    g : float
        Gravitational acceleration [m s-2].
    """
    return g * math.sqrt(1.0 + math.pi**2)
