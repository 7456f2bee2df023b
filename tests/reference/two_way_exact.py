"""High-precision reference for the steady periodic orbit of the TWO-WAY coupled model.

Plain Python and :mod:`mpmath` (no numba, nothing from ``study``'s kernels or physics:
only :class:`study.model.structure.Structure` is accepted as a parameter holder). Slow,
exact to the working precision (``dps`` significant digits, default 40): it is the
yardstick of the fast double-precision two-way solver.

Model (per unit total mass, table frame; README, "Time integration and two-way coupling")
-----------------------------------------------------------------------------------------
Drive ``A(t) = a cos(w t)``, ``w = 2 pi f``; mode ``c = w0 / Q``, ``k = w0^2``::

    stick (v = 0):   delta'' + c delta' + k delta = A cos(alpha),            x'' = 0
    slip s = sign v: delta'' + c delta' + k delta = A cos(alpha) - x'' sin(alpha)
                     x'' = tau - s ck n,  tau = -M sin(alpha) delta'',
                     n = g - A + M cos(alpha) delta''

Eliminating ``x''`` from the slip equations (``x''`` appears linearly in both)::

    D_s delta'' + c delta' + k delta = A (cos(alpha) - s ck sin(alpha)) + s ck g sin(alpha)
    D_s = 1 - M sin(alpha) (sin(alpha) + s ck cos(alpha))
    v'  = x'' = -K_s delta'' - s ck g + s ck A,     K_s = M (sin(alpha) + s ck cos(alpha))

(``x'' = -M sa delta'' - s ck (g - A + M ca delta'')`` regroups to the last line), so in
a slip started at ``t0``::

    v(t) = v(t0) - K_s (delta'(t) - delta'(t0)) - s ck g (t - t0)
           + s ck a (sin(w t) - sin(w t0)) / w

With ``coupling="one-way"`` the slip's mode equation is the stick one (``D_s -> 1``, no
``-x'' sin(alpha)`` term) and ``v'`` keeps the same expression: that is the paper's
one-way model, written here with the mode as a state, which validates the machinery
against :func:`study.solvers.exact.steady_velocity`.

Closed forms between events
---------------------------
In every contact mode the mode equation is ``D delta'' + c delta' + k delta = F cos(w t)
+ F0``: ``delta = Re[H e^{i w t}] + F0 / k + u`` with ``H = F / (k - D w^2 + i c w)``
and the homogeneous part, with ``tau = t - t0``, ``sigma = c / (2 D)``,
``m2 = sigma^2 - k / D``::

    u(tau) = e^{-sigma tau} (p C(tau) + q S(tau)),    C' = m2 S,  S' = C,  C(0) = 1, S(0) = 0

(``C, S = cos(wd tau), sin(wd tau) / wd`` under-damped, ``cosh, sinh(mu tau) / mu``
over-damped, ``1, tau`` critically damped), so every quantity (``delta`` and its
derivatives, ``n``, ``tau``, ``v``, the release functions ``cs n -+ tau``) is
``c0 + c1 tau + Re[Z e^{i w tau}] + e^{-sigma tau} (p C + q S)``, a form closed under
differentiation; the slip's displacement integrates it in closed form (the homogeneous
part of ``delta'`` integrates to ``u``).

Events, located to the working precision
----------------------------------------
From a stick: release of sign ``s`` where ``cs n - s tau`` (stick ``delta''``) reaches
zero; in a slip of sign ``s``: its end where ``s v`` reaches zero; in any mode:
lift-off where ``n`` (that mode's ``delta''``) reaches zero. At ``v = 0`` (start, slip
end) the contact test decides: stick if ``|tau| <= cs n`` with the stick ``delta''``,
else a slip in the sign of ``tau``. A slip that starts with ``D_s <= 0`` is Painleve's
friction paradox.

The first zero of each event function is found rigorously: the search interval is cut
into pieces, each piece is excluded when a lower bound of the function (its Taylor
expansion with a bound of the second derivative, computed from the closed form on that
piece) stays positive, known to hold a single zero when the derivative cannot change
sign, and halved otherwise. Zeros are refined by bracketed Newton iteration. A
function starting at zero (``s v`` when a slip starts) is started after a bound of
its Taylor expansion to third order proves it positive.

Periodic orbit
--------------
The period map ``P`` acts on ``z = (delta, delta', v)`` at drive phase 0 (``v = 0``
meaning the contact test decides the mode). From the canonical start (rest, mode on
its steady stick response), ``P`` is iterated (at a lower precision), then Newton's
method solves ``P^N(z) = z`` for ``N = 1, 2, ...`` with a finite-difference Jacobian;
the first fixed point whose Floquet multipliers (eigenvalues of the Jacobian of ``P^N``)
all lie inside the unit circle is the orbit. When the orbit sticks at phase 0, ``v = 0``
there and the map acts on ``(delta, delta')`` only (the stick absorbs a perturbation of
``v``: its multiplier is 0).

Run ``python -m tests.reference.two_way_exact`` to regenerate the cached reference points.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mpmath
from mpmath import mp, mpc, mpf

__all__ = [
    "CACHE_PATH",
    "CODE_VERSION",
    "POINTS",
    "STATUSES",
    "ReferenceOrbit",
    "TwoWayModel",
    "generate_reference_points",
    "period_map",
    "reference_orbit",
    "reference_points",
    "segment_forms",
    "write_reference_points",
]

#: Version of this reference's algorithm: bump whenever its results may change.
CODE_VERSION = "1"

#: Statuses, named as :class:`study.model.status.Status`.
STATUSES = (
    "STATIC",
    "STICK_SLIP",
    "CONTINUOUS_SLIDING",
    "LIFT_OFF",
    "NOT_CONVERGED",
    "FRICTION_PARADOX",
)

#: Where :func:`reference_points` caches its points.
CACHE_PATH = Path(__file__).parent / "data" / "two_way_reference.json"

#: Events allowed in one drive period before the point is declared not converged.
MAX_EVENTS_PER_PERIOD = 500
#: Halvings of a search piece before a near-tangency is declared a grazing (no event).
MAX_DEPTH = 80
#: Initial search pieces per drive period (and per period of the free mode).
PIECES = 16
#: Iterations of the bracketed Newton refinement of an event time.
MAX_REFINE = 400
#: An orbit is accepted once the canonical start's iterate is this close to it (natural
#: units); otherwise the start is followed for more periods (up to ``ROUNDS`` times).
APPROACH_LIMIT = mpf("0.01")
ROUNDS = 4

STICK = 0


class _Stop(Exception):
    """The orbit left the model (lift-off, friction paradox) or exhausted a budget."""

    def __init__(self, status: str, where: str = "") -> None:
        super().__init__(status, where)
        self.status = status
        self.where = where


# --- model ------------------------------------------------------------------------------


def _params(structure: Any) -> dict[str, float]:
    """Structure parameters as floats from a :class:`Structure` or a mapping."""
    if isinstance(structure, Mapping):
        d = dict(structure)
    else:
        d = {
            name: getattr(structure, name)
            for name in ("f0", "Q", "alpha", "M", "cs", "ck", "g")
        }
    if d.get("ck") is None:
        d["ck"] = d["cs"]
    d.setdefault("g", 9.8)
    return {name: float(d[name]) for name in ("f0", "Q", "alpha", "M", "cs", "ck", "g")}


class TwoWayModel:
    """Parameters at the current mpmath precision (inputs converted exactly).

    Parameters
    ----------
    structure : Structure or mapping
        ``f0, Q, alpha [degree], M, cs, ck, g``.
    f, a : float
        Drive frequency [Hz] and acceleration amplitude [m s-2].
    coupling : {"two-way", "one-way"}
        ``"one-way"`` switches the coupling off (``D_s = 1``, no ``-x'' sin(alpha)``).
    """

    def __init__(self, structure: Any, f: float, a: float, coupling: str = "two-way") -> None:
        if coupling not in ("two-way", "one-way"):
            raise ValueError(f"coupling must be 'two-way' or 'one-way', got {coupling!r}")
        self.params = _params(structure)
        self.f_float, self.a_float = float(f), float(a)
        self.coupling = coupling
        p = {k: mpf(v) for k, v in self.params.items()}
        self.w0 = 2 * mp.pi * p["f0"]
        self.c = self.w0 / p["Q"]
        self.k = self.w0 * self.w0
        alpha = mpmath.radians(p["alpha"])
        self.ca, self.sa = mpmath.cos(alpha), mpmath.sin(alpha)
        self.M, self.cs, self.ck, self.g = p["M"], p["cs"], p["ck"], p["g"]
        self.f, self.a = mpf(self.f_float), mpf(self.a_float)
        self.w = 2 * mp.pi * self.f
        self.T = 1 / self.f
        big = max(self.w, self.w0)
        #: Natural scales of (delta, delta', v), for norms.
        self.scale = (self.g / (big * big), self.g / big, self.g / self.w)

    def mode_params(self, mode: int) -> tuple[mpf, mpf, mpf]:
        """``(D, F, F0)`` of the mode equation ``D delta'' + c delta' + k delta = F cos + F0``."""
        if mode == STICK or self.coupling == "one-way":
            return mpf(1), self.a * self.ca, mpf(0)
        s = mode
        d = 1 - self.M * self.sa * (self.sa + s * self.ck * self.ca)
        return d, self.a * (self.ca - s * self.ck * self.sa), s * self.ck * self.g * self.sa

    def denominator(self, s: int) -> mpf:
        """``D_s`` (1 with the coupling off)."""
        return self.mode_params(s)[0]

    def stick_state(self) -> tuple[mpf, mpf, mpf]:
        """Canonical start: rest at phase 0, mode on its steady stick response."""
        h = self.a * self.ca / mpc(self.k - self.w * self.w, self.c * self.w)
        return (h.real, -self.w * h.imag, mpf(0))

    def contact(self, t: mpf, d0: mpf, d1: mpf) -> int:
        """Contact test at ``v = 0``: 0 (stick) or the sign of the slip that starts."""
        drive = self.a * mpmath.cos(self.w * t)
        dd = drive * self.ca - self.c * d1 - self.k * d0
        n = self.g - drive + self.M * self.ca * dd
        tau = -self.M * self.sa * dd
        if n < 0:
            raise _Stop("LIFT_OFF", "contact test")
        if tau - self.cs * n > 0:
            return 1
        if -tau - self.cs * n > 0:
            return -1
        return STICK

    def accelerations(self, mode: int, t: mpf, d0: mpf, d1: mpf) -> tuple[mpf, mpf]:
        """``(delta'', x'')`` in ``mode`` (the eliminated form, for cross-checks)."""
        dm, fa, f0 = self.mode_params(mode)
        dd = (fa * mpmath.cos(self.w * t) + f0 - self.c * d1 - self.k * d0) / dm
        if mode == STICK:
            return dd, mpf(0)
        s = mode
        k_s = self.M * (self.sa + s * self.ck * self.ca)
        return dd, -k_s * dd - s * self.ck * self.g + s * self.ck * self.a * mpmath.cos(self.w * t)


# --- closed forms -----------------------------------------------------------------------
# A closed form is a 6-tuple (c0, c1, zr, zi, p, q):
#     c0 + c1 tau + zr cos(w tau) - zi sin(w tau) + e^{-sigma tau} (p C(tau) + q S(tau)).


def _comb(*terms: tuple[Any, tuple], const: Any = 0) -> tuple:
    out = [mpf(0)] * 6
    for weight, coef in terms:
        for i in range(6):
            out[i] += weight * coef[i]
    out[0] += const
    return tuple(out)


class _Segment:
    """Shared basis of the closed forms of one segment (one contact mode)."""

    def __init__(self, model: TwoWayModel, deff: mpf) -> None:
        self.w = model.w
        self.sigma = model.c / (2 * deff)
        self.m2 = self.sigma * self.sigma - model.k / deff
        self.mu = mpf(0)
        self.wd = mpf(0)
        if self.m2 < 0:
            self.kind = "under"
            self.wd = mpmath.sqrt(-self.m2)
        elif self.m2 > 0:
            self.kind = "over"
            self.mu = mpmath.sqrt(self.m2)
        else:
            self.kind = "critical"
        self._cache: dict[mpf, tuple] = {}

    def basis(self, tau: mpf) -> tuple:
        got = self._cache.get(tau)
        if got is not None:
            return got
        cw, sw = mpmath.cos(self.w * tau), mpmath.sin(self.w * tau)
        e = mpmath.exp(-self.sigma * tau)
        if self.kind == "under":
            x = self.wd * tau
            hc, hs = e * mpmath.cos(x), e * mpmath.sin(x) / self.wd
        elif self.kind == "over":
            x = self.mu * tau
            hc, hs = e * mpmath.cosh(x), e * mpmath.sinh(x) / self.mu
        else:
            hc, hs = e, e * tau
        got = (tau, cw, sw, hc, hs)
        self._cache[tau] = got
        return got

    def value(self, coef: tuple, tau: mpf) -> mpf:
        _, cw, sw, hc, hs = self.basis(tau)
        c0, c1, zr, zi, p, q = coef
        return c0 + c1 * tau + zr * cw - zi * sw + p * hc + q * hs

    def derive(self, coef: tuple) -> tuple:
        _, c1, zr, zi, p, q = coef
        w, sg = self.w, self.sigma
        return (c1, mpf(0), -w * zi, w * zr, q - sg * p, self.m2 * p - sg * q)

    def bound(self, coef: tuple, lo: mpf, hi: mpf) -> mpf:
        """Upper bound of ``|coef(tau)|`` for ``0 <= lo <= tau <= hi``."""
        c0, c1, zr, zi, p, q = coef
        decay = mpmath.exp(-(self.sigma - self.mu) * lo)
        smax = min(hi, 1 / self.wd) if self.kind == "under" else hi
        return (
            abs(c0) + abs(c1) * hi + mpmath.hypot(zr, zi) + decay * (abs(p) + abs(q) * smax)
        )

    def integral(self, coef: tuple, tau: mpf, hom: tuple) -> mpf:
        """``int_0^tau`` of a form whose homogeneous part is the derivative of ``hom``.

        ``hom = (p, q)`` of ``u``; the form's own ``(p, q)`` must be those of ``u'``.
        """
        c0, c1, zr, zi, _, _ = coef
        _, cw, sw, hc, hs = self.basis(tau)
        w = self.w
        u = hom[0] * hc + hom[1] * hs
        return c0 * tau + c1 * tau * tau / 2 + (zi * (cw - 1) + zr * sw) / w + (u - hom[0])


class _Fn:
    """An event function: a closed form and its first three derivatives."""

    def __init__(self, seg: _Segment, coef: tuple, name: str, starts_at_zero: bool = False):
        self.seg = seg
        self.name = name
        self.starts_at_zero = starts_at_zero
        self.d = [coef]
        for _ in range(3):
            self.d.append(seg.derive(self.d[-1]))

    def __call__(self, tau: mpf, order: int = 0) -> mpf:
        return self.seg.value(self.d[order], tau)

    def bound(self, order: int, lo: mpf, hi: mpf) -> mpf:
        return self.seg.bound(self.d[order], lo, hi)


def _refine(fn: _Fn, lo: mpf, hi: mpf, tol: mpf) -> mpf:
    """Zero of ``fn`` in ``[lo, hi]`` with ``fn(lo) > 0 >= fn(hi)``: bracketed Newton."""
    x = (lo + hi) / 2
    for _ in range(MAX_REFINE):
        fx = fn(x)
        if fx == 0:
            return x
        if fx > 0:
            lo = x
        else:
            hi = x
        dx = fn(x, 1)
        xn = x - fx / dx if dx != 0 else (lo + hi) / 2
        if not lo < xn < hi:
            xn = (lo + hi) / 2
        if abs(xn - x) <= tol or hi - lo <= tol:
            return xn
        x = xn
    raise _Stop("NOT_CONVERGED", "event refinement")  # pragma: no cover


class _Search:
    """First zero of one event function on a piece, by exclusion and halving."""

    def __init__(self, fn: _Fn, tol: mpf, stats: dict) -> None:
        self.fn = fn
        self.tol = tol
        self.stats = stats

    def first(self, l: mpf, r: mpf) -> mpf | None:
        fn = self.fn
        fl, fr = fn(l), fn(r)
        if fl <= 0:
            return l
        return self._run(l, r, fl, fn(l, 1), fr, fn(r, 1), 0)

    def _run(self, l, r, fl, dl, fr, dr, depth):
        fn = self.fn
        h = r - l
        l2 = fn.bound(2, l, r)
        monotone = abs(dl) > l2 * h or abs(dr) > l2 * h
        if fr <= 0:
            if monotone or depth >= MAX_DEPTH or h <= self.tol:
                return _refine(fn, l, r, self.tol)
        else:
            if monotone:
                return None
            if fl + dl * h - l2 * h * h / 2 > 0 or fr - dr * h - l2 * h * h / 2 > 0:
                return None
            if depth >= MAX_DEPTH or h <= self.tol:
                self.stats["grazing"] = self.stats.get("grazing", 0) + 1
                return None
        m = (l + r) / 2
        fm, dm = fn(m), fn(m, 1)
        if fm <= 0:
            return self._run(l, m, fl, dl, fm, dm, depth + 1)
        found = self._run(l, m, fl, dl, fm, dm, depth + 1)
        if found is not None:
            return found
        return self._run(m, r, fm, dm, fr, dr, depth + 1)


def _safe_start(fn: _Fn, tau_end: mpf) -> mpf | None:
    """A ``tau > 0`` up to which ``fn`` (zero at 0) is provably positive, or None."""
    zero = mpf(0)
    f1, f2 = fn(zero, 1), fn(zero, 2)
    l2, l3 = fn.bound(2, zero, tau_end), fn.bound(3, zero, tau_end)
    # A slip released where ck = cs starts with f1 = 0: its computed value is round-off.
    if abs(f1) <= mpf(2) ** (-mp.prec + 12) * fn.bound(1, zero, zero):
        f1 = zero
    h = mpf(0)
    if f1 > 0:  # f >= f1 tau - l2 tau^2 / 2 >= f1 tau / 2
        h = f1 / l2 if l2 > 0 else tau_end
    if f1 >= 0 and f2 > 0:  # f >= tau^2 (f2 / 2 - l3 tau / 6) >= f2 tau^2 / 4
        h = max(h, 3 * f2 / (2 * l3) if l3 > 0 else tau_end)
    if h <= 0:
        return None
    return min(h, tau_end)


def _first_event(seg: _Segment, fns: list[_Fn], tau_end: mpf, model: TwoWayModel,
                 stats: dict) -> tuple[mpf, int | None]:
    """Earliest zero in ``(0, tau_end]`` among ``fns``: ``(tau, index)``, or ``(tau_end, None)``."""
    tol = mpf(2) ** (-mp.prec + 6) * model.T
    starts = []
    for i, fn in enumerate(fns):
        if fn.starts_at_zero:
            h = _safe_start(fn, tau_end)
            if h is None:
                return mpf(0), i
            starts.append(h)
        else:
            if fn(mpf(0)) <= 0:
                return mpf(0), i
            starts.append(mpf(0))
    width = model.T / PIECES
    if seg.kind == "under":
        width = min(width, 2 * mp.pi / seg.wd / PIECES)
    searches = [_Search(fn, tol, stats) for fn in fns]
    l = mpf(0)
    while l < tau_end:
        r = min(l + width, tau_end)
        if tau_end - r < width / 1000:
            r = tau_end
        best: tuple[mpf, int] | None = None
        for i, search in enumerate(searches):
            lo = max(l, starts[i])
            if lo >= r:
                continue
            root = search.first(lo, r)
            if root is not None and (best is None or root < best[0]):
                best = (root, i)
        if best is not None:
            return best
        l = r
    return tau_end, None


def segment_forms(model: TwoWayModel, mode: int, t: mpf, state: tuple) -> tuple:
    """Closed forms (in ``tau = time - t``) of one segment in contact ``mode``.

    Parameters
    ----------
    model : TwoWayModel
    mode : int
        0 (stick) or the slip's sign.
    t : mpf
        Start time of the segment.
    state : tuple of mpf
        ``(delta, delta', v)`` at ``t``.

    Returns
    -------
    seg : _Segment
        The shared basis (``seg.value(form, tau)``, ``seg.derive(form)``).
    forms : dict
        ``delta``, ``rate`` (delta'), ``accel`` (delta''), ``n``, ``tau`` and, in a
        stick, ``release+`` / ``release-`` (``cs n -+ tau``); in a slip, ``v`` and
        ``v_hom`` (the homogeneous part of ``v``'s antiderivative, for the displacement).
    """
    d0, d1, v = state
    deff, fa, f0 = model.mode_params(mode)
    seg = _Segment(model, deff)
    wt0 = model.w * t
    cw0, sw0 = mpmath.cos(wt0), mpmath.sin(wt0)
    h = mpc(fa) / mpc(model.k - deff * model.w * model.w, model.c * model.w)
    zd = h * mpc(cw0, sw0)
    p = d0 - (zd.real + f0 / model.k)
    q = (d1 + model.w * zd.imag) + seg.sigma * p
    zero = mpf(0)
    delta = (f0 / model.k, zero, zd.real, zd.imag, p, q)
    rate = seg.derive(delta)
    accel = seg.derive(rate)
    drive = (zero, zero, model.a * cw0, model.a * sw0, zero, zero)
    n = _comb((-1, drive), (model.M * model.ca, accel), const=model.g)
    tau = _comb((-model.M * model.sa, accel))
    forms = {"delta": delta, "rate": rate, "accel": accel, "n": n, "tau": tau}
    if mode == STICK:
        forms["release+"] = _comb((model.cs, n), (-1, tau))
        forms["release-"] = _comb((model.cs, n), (1, tau))
    else:
        s = mode
        k_s = model.M * (model.sa + s * model.ck * model.ca)
        sck = s * model.ck
        # v = v0 - K_s (delta' - delta'(t0)) - s ck g tau + s ck a (sin(w t) - sin(w t0)) / w
        vel = _comb(
            (-k_s, rate),
            (sck * model.a / model.w, (zero, zero, sw0, -cw0, zero, zero)),
            const=v + k_s * seg.value(rate, zero) - sck * model.a * sw0 / model.w,
        )
        forms["v"] = (vel[0], -sck * model.g, *vel[2:])
        forms["v_hom"] = (-k_s * p, -k_s * q)  # v's homogeneous part is -K_s u'
    return seg, forms


# --- one drive period -------------------------------------------------------------------


@dataclass
class _PeriodResult:
    state: tuple[mpf, mpf, mpf]
    dx: mpf
    stick_time: mpf
    forward_time: mpf
    backward_time: mpf
    slips: int
    events: list


def _period(model: TwoWayModel, z: tuple, record: bool = False) -> _PeriodResult:
    """Advance ``z = (delta, delta', v)`` at phase 0 by one drive period."""
    d0, d1, v = z
    t = mpf(0)
    T = model.T
    mode: int | None = None if v == 0 else (1 if v > 0 else -1)
    x = mpf(0)
    times = {STICK: mpf(0), 1: mpf(0), -1: mpf(0)}
    slips = 0
    events: list = []
    stats: dict = {}
    for _ in range(MAX_EVENTS_PER_PERIOD):
        if mode is None:
            mode = model.contact(t, d0, d1)
            v = mpf(0)
        if mode != STICK and v == 0:
            slips += 1
        if model.denominator(mode) <= 0:
            raise _Stop("FRICTION_PARADOX", f"slip {mode:+d} at t = {t}")
        seg, forms = segment_forms(model, mode, t, (d0, d1, v))
        fns = []
        if mode == STICK:
            fns.append(_Fn(seg, forms["release+"], "release+"))
            fns.append(_Fn(seg, forms["release-"], "release-"))
        else:
            fns.append(_Fn(seg, _comb((mode, forms["v"])), "end", starts_at_zero=(v == 0)))
        fns.append(_Fn(seg, forms["n"], "lift"))
        tau_end = T - t
        dt, idx = _first_event(seg, fns, tau_end, model, stats)
        # State at t + dt.
        d0n, d1n = seg.value(forms["delta"], dt), seg.value(forms["rate"], dt)
        if mode != STICK:
            x += seg.integral(forms["v"], dt, forms["v_hom"])
            v = seg.value(forms["v"], dt)
        times[mode] += dt
        d0, d1 = d0n, d1n
        if idx is None:
            t = T
            if mode == STICK:
                v = mpf(0)
            break
        kind = fns[idx].name
        t = t + dt
        if record:
            events.append((kind, t))
        if kind == "lift":
            raise _Stop("LIFT_OFF", f"n = 0 at t = {t} (mode {mode:+d})")
        if kind == "release+":
            mode, v = 1, mpf(0)
        elif kind == "release-":
            mode, v = -1, mpf(0)
        else:
            mode, v = None, mpf(0)
    else:
        raise _Stop("NOT_CONVERGED", "event budget of one period")
    return _PeriodResult((d0, d1, v), x, times[STICK], times[1], times[-1], slips, events)


# --- period map, Newton, orbit -----------------------------------------------------------


@dataclass
class _MapResult:
    state: tuple[mpf, mpf, mpf]
    dx: mpf
    stick_time: mpf
    forward_time: mpf
    backward_time: mpf
    slips: int
    events: list


def period_map(model: TwoWayModel, z: tuple, periods: int = 1, record: bool = False) -> _MapResult:
    """``P^periods(z)`` with the displacement and the contact statistics on the way.

    Parameters
    ----------
    model : TwoWayModel
        Parameters (at the current precision).
    z : tuple of mpf
        ``(delta [m], delta' [m s-1], v [m s-1])`` at drive phase 0.
    periods : int
        Drive periods to advance.
    record : bool
        Keep the events ``(kind, period index, t)``.

    Raises
    ------
    _Stop
        With ``status`` ``"LIFT_OFF"``, ``"FRICTION_PARADOX"`` or ``"NOT_CONVERGED"``.
    """
    dx = stick = fwd = bwd = mpf(0)
    slips = 0
    events: list = []
    for k in range(periods):
        r = _period(model, z, record)
        z = r.state
        dx += r.dx
        stick += r.stick_time
        fwd += r.forward_time
        bwd += r.backward_time
        slips += r.slips
        events.extend((kind, k, t) for kind, t in r.events)
    return _MapResult(z, dx, stick, fwd, bwd, slips, events)


def _scaled_residual(model: TwoWayModel, z: tuple, periods: int) -> tuple[list, _MapResult]:
    r = period_map(model, z, periods)
    return [(r.state[i] - z[i]) / model.scale[i] for i in range(3)], r


def _jacobian(model: TwoWayModel, z: tuple, periods: int, dims: tuple, h: mpf,
              central: bool, base: list | None = None) -> mpmath.matrix:
    """Finite-difference Jacobian of ``P^periods`` in scaled variables, over ``dims``."""
    jac = mpmath.matrix(len(dims), len(dims))
    for j, dj in enumerate(dims):
        zp = list(z)
        zp[dj] += h * model.scale[dj]
        plus = period_map(model, tuple(zp), periods).state
        if central:
            zm = list(z)
            zm[dj] -= h * model.scale[dj]
            minus = period_map(model, tuple(zm), periods).state
            for i, di in enumerate(dims):
                jac[i, j] = (plus[di] - minus[di]) / (2 * h * model.scale[di])
        else:
            for i, di in enumerate(dims):
                jac[i, j] = (plus[di] - z[di]) / (h * model.scale[di]) - base[di] / h
    return jac


def _newton(model: TwoWayModel, z: tuple, periods: int, tol: mpf,
            max_iterations: int = 40) -> tuple[tuple, mpf] | None:
    """Solve ``P^periods(z) = z`` by damped Newton; None when it fails."""
    h = mpf(10) ** (-(mp.dps // 2))
    try:
        res, r = _scaled_residual(model, z, periods)
    except _Stop:
        return None
    for _ in range(max_iterations):
        if r.state[2] == 0 and z[2] != 0:  # the orbit sticks at phase 0: v = 0 there
            z = (z[0], z[1], mpf(0))
            try:
                res, r = _scaled_residual(model, z, periods)
            except _Stop:
                return None
        norm = max(abs(x) for x in res)
        if norm < tol:
            return z, norm
        dims = (0, 1) if z[2] == 0 else (0, 1, 2)
        try:
            # Jacobian of P^N (scaled); the residual's is that minus the identity.
            base = [(r.state[i] - z[i]) / model.scale[i] for i in range(3)]
            jac = _jacobian(model, z, periods, dims, h, central=False, base=base)
        except _Stop:
            return None
        g = mpmath.matrix([res[i] for i in dims])
        try:
            step = mpmath.lu_solve(jac - mpmath.eye(len(dims)), -g)
        except ZeroDivisionError:
            return None
        lam = mpf(1)
        for _ in range(20):
            zn = list(z)
            for j, dj in enumerate(dims):
                zn[dj] += lam * step[j] * model.scale[dj]
            zn = tuple(zn)
            try:
                rn, rr = _scaled_residual(model, zn, periods)
                nn = max(abs(x) for x in rn)
            except _Stop:
                nn = mpf("inf")
            if nn < norm:
                break
            lam /= 2
        else:
            return None
        z, res, r = zn, rn, rr
    return None


@dataclass(frozen=True)
class ReferenceOrbit:
    """The steady periodic orbit at one point.

    Attributes
    ----------
    velocity : mpf
        Mean velocity over the orbit [m s-1]; exactly 0 when ``STATIC``, NaN when
        the status is ``LIFT_OFF``, ``FRICTION_PARADOX`` or ``NOT_CONVERGED``.
    status : str
        One of :data:`STATUSES`.
    orbit_period : int
        Period of the orbit in drive periods (0 without an orbit).
    floquet : mpf
        Largest modulus of the Floquet multipliers (eigenvalues of the Jacobian of
        ``P^N`` at the fixed point; over ``(delta, delta')`` when the orbit sticks at
        phase 0); NaN without an orbit.
    state : tuple of mpf
        ``(delta, delta', v)`` at phase 0 on the orbit (NaN without an orbit).
    slips_per_period, forward_fraction, backward_fraction : mpf
        Slip starts per drive period; fractions of the time slipping forward, backward.
    residual : mpf
        ``max |P^N(z) - z|`` in natural units at the returned fixed point.
    multipliers : tuple of mpc
        The Floquet multipliers, largest modulus first.
    approach : mpf
        Distance (natural units) from the last pre-iterate of the canonical start to
        the orbit (nearest of its ``N`` phase-0 states): small when the start is
        attracted to this orbit.
    dps : int
        Working precision [decimal digits].
    detail : str
        Where the orbit left the model, or why it was not found.
    """

    velocity: mpf
    status: str
    orbit_period: int
    floquet: mpf
    state: tuple
    slips_per_period: mpf
    forward_fraction: mpf
    backward_fraction: mpf
    residual: mpf
    multipliers: tuple
    approach: mpf
    dps: int
    detail: str = ""


def _invalid(status: str, dps: int, detail: str = "") -> ReferenceOrbit:
    nan = mpf("nan")
    return ReferenceOrbit(
        nan, status, 0, nan, (nan, nan, nan), nan, nan, nan, nan, (), nan, dps, detail
    )


def _default_pre_iterations(params: dict, f: float) -> int:
    """About five e-folds of the mode's free decay (``Q f / (pi f0)`` periods each)."""
    return int(min(150, max(20, math.ceil(5 * params["Q"] * f / (math.pi * params["f0"])))))


def reference_orbit(
    structure: Any,
    f: float,
    a: float,
    *,
    coupling: str = "two-way",
    dps: int = 40,
    max_period: int = 8,
    pre_iterations: int | None = None,
    low_dps: int = 20,
) -> ReferenceOrbit:
    """Steady periodic orbit reached from the canonical start, to ``dps`` digits.

    Parameters
    ----------
    structure : Structure or mapping
        ``f0, Q, alpha [degree], M, cs, ck (None: cs), g``.
    f, a : float
        Drive frequency [Hz] and acceleration amplitude [m s-2].
    coupling : {"two-way", "one-way"}
        ``"one-way"`` switches the coupling off (the paper's model).
    dps : int
        Working precision of the Newton solve and of the orbit [decimal digits].
    max_period : int
        Longest orbit period looked for [drive periods].
    pre_iterations : int, optional
        Drive periods followed from the canonical start (at ``low_dps``) before Newton's
        method; default about five e-folds of the mode's decay, 20 to 150. When no
        stable orbit is found, or the one found is farther than ``APPROACH_LIMIT`` from
        the start's iterate, as many more periods are followed, up to ``ROUNDS`` times.
    low_dps : int
        Precision of those first periods.

    Returns
    -------
    ReferenceOrbit
        ``LIFT_OFF`` / ``FRICTION_PARADOX`` when met from the canonical start (within
        the pre-iterations) or on the orbit.
    """
    params = _params(structure)
    n_pre = _default_pre_iterations(params, f) if pre_iterations is None else pre_iterations
    with mp.workdps(low_dps):
        low = TwoWayModel(params, f, a, coupling)
        z_low = low.stick_state()
    found = None
    for _ in range(ROUNDS):
        with mp.workdps(low_dps):
            try:
                for _ in range(n_pre):
                    z_low = period_map(low, z_low).state
            except _Stop as stop:
                return _invalid(stop.status, dps, f"from the start: {stop.where}")
        with mp.workdps(dps):
            model = TwoWayModel(params, f, a, coupling)
            try:
                found = _find_orbit(model, tuple(mpf(x) for x in z_low), max_period)
            except _Stop as stop:
                return _invalid(stop.status, dps, f"on the orbit: {stop.where}")
        if found is not None and found.approach < APPROACH_LIMIT:
            return found
    if found is not None:
        return found
    return _invalid("NOT_CONVERGED", dps, f"no stable orbit of period <= {max_period}")


def _find_orbit(model: TwoWayModel, z: tuple, max_period: int) -> ReferenceOrbit | None:
    """The first stable fixed point of ``P^N``, ``N = 1, 2, ...``, found by Newton from ``z``."""
    dps = mp.dps
    tol = mpf(10) ** (-(dps - 6))
    for n in range(1, max_period + 1):
        found = _newton(model, z, n, tol)
        if found is None:
            continue
        zstar, residual = found
        dims = (0, 1) if zstar[2] == 0 else (0, 1, 2)
        try:
            jac = _jacobian(model, zstar, n, dims, mpf(10) ** (-(dps // 3)), central=True)
        except _Stop:
            continue
        multipliers = sorted(mpmath.eig(jac, left=False, right=False), key=lambda m: -abs(m))
        floquet = abs(multipliers[0])
        if floquet >= 1:
            continue
        orbit = period_map(model, zstar, n, record=True)  # _Stop: the orbit leaves the model
        duration = n * model.T
        if orbit.slips == 0:
            status, velocity = "STATIC", mpf(0)
        else:
            status = "STICK_SLIP" if orbit.stick_time > 0 else "CONTINUOUS_SLIDING"
            velocity = orbit.dx / duration
        scale = model.scale
        residual = max(abs(orbit.state[i] - zstar[i]) / scale[i] for i in range(3))
        phase_states = [zstar]
        for _ in range(n - 1):
            phase_states.append(period_map(model, phase_states[-1]).state)
        approach = min(
            max(abs(z[i] - y[i]) / scale[i] for i in range(3)) for y in phase_states
        )
        return ReferenceOrbit(
            velocity=velocity,
            status=status,
            orbit_period=n,
            floquet=floquet,
            state=zstar,
            slips_per_period=mpf(orbit.slips) / n,
            forward_fraction=orbit.forward_time / duration,
            backward_fraction=orbit.backward_time / duration,
            residual=residual,
            multipliers=tuple(multipliers),
            approach=approach,
            dps=dps,
        )
    return None


# --- cached reference points -------------------------------------------------------------

_PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25, "ck": 0.25, "g": 9.8}

#: ``(name, structure parameters, f [Hz], a [m s-2], note)`` of the cached points.
POINTS: tuple = (
    ("paper-13-8.5", _PAPER, 13.0, 8.5, "stick-slip, forward (one-way +2.195 mm/s)"),
    ("paper-14.5-9", _PAPER, 14.5, 9.0, "two slips per period; one-way goes backward"),
    ("paper-14.5-6", _PAPER, 14.5, 6.0, "two slips per period"),
    ("paper-16.5-8.5", _PAPER, 16.5, 8.5, "stick-slip, backward"),
    ("paper-14.6-7", _PAPER, 14.6, 7.0, "near a reversal: small velocity (one-way -3.38 mm/s)"),
    ("paper-static", _PAPER, 13.0, 5.0, "below the motion threshold"),
    # a = a*(1 + 1e-6), a* = 6.2382880...: the releases nearly graze the friction cone.
    ("near-grazing", _PAPER, 13.0, 6.238294287478854, "just above the motion threshold"),
    ("ck-below-cs", {**_PAPER, "ck": 0.15}, 14.6, 7.0, "kinetic friction below static"),
    ("high-Q", {**_PAPER, "Q": 1000.0}, 13.0, 8.0, "Q = 1e3"),
    ("sliding-forward", {**_PAPER, "alpha": 45.0, "M": 0.9}, 21.0, 4.5, "continuous sliding"),
    ("sliding-backward", {**_PAPER, "M": 0.6}, 20.0, 8.0, "continuous sliding, backward"),
    ("oscillatory-approach", {**_PAPER, "M": 0.9}, 13.0, 2.0,
     "period 1, Floquet multiplier -0.68 (iterates alternate)"),
    ("near-paradox", {**_PAPER, "alpha": 80.0, "M": 0.985}, 12.0, 4.0,
     "D_+ = 0.0026: stiff forward slips"),
    ("lift-off", _PAPER, 14.5, 9.8, "n < 0 while sliding"),
    ("friction-paradox", {**_PAPER, "alpha": 80.0, "M": 1.0}, 14.0, 2.0, "D_+ < 0"),
)

#: Precision of the cached points [decimal digits].
CACHE_DPS = 40
#: Significant digits written for each cached value.
_DIGITS = 34


def _entry(name: str, params: dict, f: float, a: float, note: str, dps: int) -> dict:
    r = reference_orbit(params, f, a, dps=dps)
    with mp.workdps(dps):
        def text(x: mpf) -> str:
            if not mpmath.isfinite(x):
                return "nan"
            return mpmath.nstr(x, _DIGITS, min_fixed=1, max_fixed=0)

        return {
            "name": name,
            "structure": dict(params),
            "f": f,
            "a": a,
            "note": note,
            "status": r.status,
            "velocity": text(r.velocity),
            "orbit_period": r.orbit_period,
            "floquet": text(r.floquet),
            "slips_per_period": text(r.slips_per_period),
            "forward_fraction": text(r.forward_fraction),
            "backward_fraction": text(r.backward_fraction),
            "state": [text(x) for x in r.state],
        }


def generate_reference_points(names: list[str] | None = None, dps: int = CACHE_DPS) -> list[dict]:
    """Compute the entries of :data:`POINTS` (all, or those named), as cached."""
    chosen = [p for p in POINTS if names is None or p[0] in names]
    return [_entry(*p, dps=dps) for p in chosen]


def write_reference_points(path: Path = CACHE_PATH) -> dict:
    """Regenerate every point and write the cache file; returns its content."""
    content = {
        "description": (
            "Steady periodic orbits of the single-plate two-way coupled model "
            "(README, 'Time integration and two-way coupling'), from "
            "tests/reference/two_way_exact.py; decimal strings exact to about dps - 5 digits"
        ),
        "generator": "tests/reference/two_way_exact.py",
        "code_version": CODE_VERSION,
        "dps": CACHE_DPS,
        "mpmath": mpmath.__version__,
        "coupling": "two-way",
        "points": generate_reference_points(),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(content, indent=1) + "\n")
    return content


def reference_points(path: Path = CACHE_PATH) -> list[dict]:
    """The cached reference points, without any mpmath computation.

    Returns
    -------
    list of dict
        Per point: ``name``, ``structure`` (a :class:`study.model.structure.Structure`),
        ``params`` (its parameters), ``f``, ``a``, ``status`` (a :data:`STATUSES`
        name), ``velocity`` (float; NaN for LIFT_OFF / FRICTION_PARADOX),
        ``velocity_text`` (the cached decimal string), ``orbit_period``, ``floquet``,
        ``slips_per_period``, ``forward_fraction``, ``backward_fraction`` (floats) and
        ``note``.

    Raises
    ------
    RuntimeError
        When the cache was written by another :data:`CODE_VERSION` (regenerate it with
        ``python -m tests.reference.two_way_exact``).
    """
    from study.model.structure import Structure

    content = json.loads(path.read_text())
    if content["code_version"] != CODE_VERSION:
        raise RuntimeError(
            f"{path} was written by reference version {content['code_version']!r}, this is "
            f"{CODE_VERSION!r}: run python -m tests.reference.two_way_exact"
        )
    out = []
    for e in content["points"]:
        out.append({
            "name": e["name"],
            "structure": Structure(**e["structure"]),
            "params": dict(e["structure"]),
            "f": e["f"],
            "a": e["a"],
            "status": e["status"],
            "velocity": float(e["velocity"]),
            "velocity_text": e["velocity"],
            "orbit_period": e["orbit_period"],
            "floquet": float(e["floquet"]),
            "slips_per_period": float(e["slips_per_period"]),
            "forward_fraction": float(e["forward_fraction"]),
            "backward_fraction": float(e["backward_fraction"]),
            "note": e["note"],
        })
    return out


def _main() -> int:
    """Regenerate the cache and print it."""
    import time

    start = time.perf_counter()
    content = write_reference_points()
    for e in content["points"]:
        print(
            f"{e['name']:<22} {e['status']:<19} N={e['orbit_period']}  v = {e['velocity']:<40}"
            f" floquet {float(e['floquet']):.4f}"
        )
    print(f"wrote {CACHE_PATH} in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(_main())
