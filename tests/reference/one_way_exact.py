"""High-precision reference for the steady mean velocity of the stick-slip model.

A slow but exact (to ``dps`` significant digits) event-driven solver of the
single-plate model described in the README ("How the solver works"), written with
:mod:`mpmath` only. It is deliberately independent of the ``study`` package: nothing
is imported from it, every formula is re-derived here, so that it can be used to check
that the fast float64 solver is accurate to machine precision.

Model (per unit total mass, table frame, drive phase ``theta = w t``)
-----------------------------------------------------------------------
With the mode on its steady response, ``G = 1 / (w0^2 - w^2 + i w0 w / Q)``::

    n(theta)   = g + Re[N e^{i theta}],   N = -a (1 + w^2 M cos^2(alpha) G)
    tau(theta) = Re[T e^{i theta}],       T = a w^2 M sin(alpha) cos(alpha) G

Stick (``v = 0``) while ``|tau| <= cs n``; a slip of sign ``s`` obeys
``d(s v)/dtheta = (s tau - ck n) / w``.

Closed forms used between events
--------------------------------
* Release of sign ``s`` from a stick: ``s tau - cs n = Re[A_s e^{i theta}] - cs g``
  with ``A_s = s T - cs N``. It crosses zero from below where
  ``theta + arg(A_s) = -acos(cs g / |A_s|)  (mod 2 pi)``.
* Slip of sign ``s`` started at ``theta0`` with ``v = 0``, ``B_s = s T - ck N``::

      w s v(theta) = F(theta) = -ck g (theta - theta0) + Im[B_s (e^{i theta} - e^{i theta0})]

  (differentiate: ``F' = Re[B_s e^{i theta}] - ck g = s tau - ck n``, and
  ``F(theta0) = 0``). The extrema of ``F`` are the zeros of ``F'``, in closed form
  ``theta + arg(B_s) = +-acos(ck g / |B_s|)``, so ``F`` is monotone between them and
  the end of the slip (first zero of ``F`` after ``theta0``) is bracketed exactly,
  without any sampling step. Over one period ``F`` decreases by ``2 pi ck g``, so the
  root lies within one period. It is refined with :func:`mpmath.findroot` (Anderson
  solver on the bracket, bisection as a fallback).
* Displacement of the slip, ``x = int v dt = int v dtheta / w``::

      w^2 s dx = -ck g D^2 / 2 - Re[B_s (e^{i theta1} - e^{i theta0})]
                 - Im[B_s e^{i theta0}] D,           D = theta1 - theta0.

Periodic orbit
--------------
A release that ends a stick through the crossing formula ("canonical" release) happens
at one of only two phases (one per sign), and what follows depends only on that
phase. The orbit is therefore closed as soon as a canonical release of the same sign
and phase (mod 2 pi) as an earlier one occurs; the mean velocity is the displacement
between the two releases divided by the elapsed time.

Run ``python -m tests.reference.one_way_exact`` for a demo on the paper's parameters.
"""

from __future__ import annotations

import sys
import time

import mpmath
from mpmath import mp, mpf

__all__ = ["exact_velocity"]

#: Events without any stick after which the point is declared continuous sliding.
MAX_SLIPS_WITHOUT_STICK = 200
#: Absolute safety budget on the total number of events.
MAX_EVENTS = 5000


def _to_mpf(x: float | int | str | mpf) -> mpf:
    """Convert a Python number exactly (``mpf(float)`` is exact) to :class:`mpmath.mpf`.

    Parameters
    ----------
    x : float, int, str or mpf
        Value to convert.

    Returns
    -------
    mpf
        The value at the current working precision.
    """
    return mpf(x)


def next_release(amp: mpmath.mpc, level: mpf, theta: mpf, tol: mpf) -> mpf | None:
    """First upward crossing of ``Re[amp e^{i t}] = level`` at or after ``theta``.

    Parameters
    ----------
    amp : mpc
        Complex amplitude ``A_s``.
    level : mpf
        Constant ``cs g`` (> 0).
    theta : mpf
        Current phase.
    tol : mpf
        Crossings up to ``tol`` before ``theta`` are accepted (round-off guard); the
        caller clips the result to ``theta``.

    Returns
    -------
    mpf or None
        Phase of the crossing, or None when ``|amp| <= level`` (never crossed; a
        tangency does not release).
    """
    mod = abs(amp)
    if mod <= level:
        return None
    psi = -mpmath.arg(amp) - mpmath.acos(level / mod)
    two_pi = 2 * mp.pi
    k = mpmath.ceil((theta - tol - psi) / two_pi)
    return psi + two_pi * k


def _bisect(func, lo: mpf, hi: mpf) -> mpf:
    """Plain bisection for a root of ``func`` with ``func(lo) > 0 >= func(hi)``.

    Parameters
    ----------
    func : callable
        Function of one mpf argument.
    lo, hi : mpf
        Bracket.

    Returns
    -------
    mpf
        Root to the working precision.
    """
    for _ in range(4 * mp.prec):
        mid = (lo + hi) / 2
        if mid in (lo, hi):
            break
        if func(mid) > 0:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


def end_of_slip(b: mpmath.mpc, kg: mpf, theta0: mpf, tol: mpf) -> mpf:
    """End of a slip: first zero after ``theta0`` of ``F`` (``w s v``).

    Parameters
    ----------
    b : mpc
        ``B_s = s T - ck N``.
    kg : mpf
        ``ck g``.
    theta0 : mpf
        Phase at which the slip started (``v = 0``).
    tol : mpf
        Critical points within ``tol`` of ``theta0`` are ignored.

    Returns
    -------
    mpf
        Phase ``theta1 >= theta0`` at which ``v`` returns to zero (``theta0`` itself
        for a degenerate slip that cannot start).
    """
    e0 = mpmath.expjpi(theta0 / mp.pi)
    im0 = mpmath.im(b * e0)

    def func(t: mpf) -> mpf:
        return -kg * (t - theta0) + mpmath.im(b * mpmath.expjpi(t / mp.pi)) - im0

    two_pi = 2 * mp.pi
    end = theta0 + two_pi
    nodes = [theta0]
    mod = abs(b)
    if mod > kg:
        beta = mpmath.arg(b)
        half = mpmath.acos(kg / mod)
        crit = []
        for c in (half - beta, -half - beta):
            k = mpmath.floor((c - theta0) / two_pi)
            c = c - two_pi * k  # in [theta0, theta0 + 2 pi)
            if c <= theta0 + tol:
                c += two_pi
            if c < end - tol:
                crit.append(c)
        nodes.extend(sorted(crit))
    nodes.append(end)
    # F is monotone between consecutive nodes; F(theta0) = 0 and F(end) < 0.
    values = [mpf(0)] + [func(t) for t in nodes[1:]]
    for k in range(1, len(nodes)):
        if values[k] <= 0:
            if k == 1:
                return theta0  # F never became positive: zero-length slip
            lo, hi = nodes[k - 1], nodes[k]
            if values[k] == 0:
                return hi
            break
    else:  # pragma: no cover - impossible since F(end) = -2 pi ck g < 0
        raise RuntimeError("slip end not bracketed")
    try:
        root = mpmath.findroot(func, (lo, hi), solver="anderson", tol=mpf(2) ** (-2 * mp.prec))
        if not (lo <= root <= hi):
            raise ValueError("root left the bracket")
    except (ValueError, ZeroDivisionError):
        root = _bisect(func, lo, hi)
    return root


def slip_displacement(b: mpmath.mpc, kg: mpf, theta0: mpf, theta1: mpf, w: mpf) -> mpf:
    """Signed-speed integral ``s * (x(theta1) - x(theta0))`` of a slip (closed form).

    Parameters
    ----------
    b : mpc
        ``B_s``.
    kg : mpf
        ``ck g``.
    theta0, theta1 : mpf
        Start and end phases of the slip.
    w : mpf
        Angular drive frequency.

    Returns
    -------
    mpf
        ``s dx`` in metres (positive for a genuine slip).
    """
    d = theta1 - theta0
    e0 = mpmath.expjpi(theta0 / mp.pi)
    e1 = mpmath.expjpi(theta1 / mp.pi)
    bracket = -kg * d * d / 2 - mpmath.re(b * (e1 - e0)) - mpmath.im(b * e0) * d
    return bracket / (w * w)


def exact_velocity(
    f0: float,
    Q: float,
    alpha_deg: float,
    M: float,
    cs: float,
    f: float,
    a: float,
    ck: float | None = None,
    g: float = 9.8,
    dps: int = 40,
) -> tuple[mpf, str, int]:
    """Steady mean velocity of the single-plate stick-slip model, to ``dps`` digits.

    Event-driven and exact in closed form between events (see the module docstring);
    the orbit is the one reached from rest at phase 0 (stick rule applied at
    ``theta = 0``). Inputs are converted exactly to :class:`mpmath.mpf` and all the
    arithmetic runs at ``dps`` significant digits.

    Parameters
    ----------
    f0 : float
        Plate resonance frequency [Hz].
    Q : float
        Quality factor of the plate mode.
    alpha_deg : float
        Plate tilt from the horizontal [degree].
    M : float
        Mass ratio ``m1 / m``.
    cs : float
        Static friction coefficient.
    f : float
        Drive frequency [Hz].
    a : float
        Drive acceleration amplitude [m s-2].
    ck : float, optional
        Kinetic friction coefficient (``<= cs``); defaults to ``cs``.
    g : float, optional
        Gravity [m s-2], default 9.8.
    dps : int, optional
        Working precision in decimal digits, default 40.

    Returns
    -------
    velocity : mpf
        Mean velocity [m s-1], positive forward; ``0`` when static, NaN for
        ``"lift_off"`` and for the unsupported / non-converged statuses.
    status : str
        ``"stick_slip"``, ``"static"``, ``"lift_off"``,
        ``"continuous_sliding_unsupported"`` (no stick within
        ``MAX_SLIPS_WITHOUT_STICK`` events) or ``"event_budget_exhausted"``.
    slips : int
        Number of slip events (a reversal counts as a new slip) in one period of the
        periodic orbit (which may span several drive periods); 0 unless stick-slip.
    """
    with mp.workdps(dps):
        f0_, q_, al_, m_, cs_, f_, a_, g_ = (_to_mpf(v) for v in (f0, Q, alpha_deg, M, cs, f, a, g))
        ck_ = cs_ if ck is None else _to_mpf(ck)
        if ck_ > cs_:
            raise ValueError("ck must not exceed cs")
        w = 2 * mp.pi * f_
        w0 = 2 * mp.pi * f0_
        alpha = mpmath.radians(al_)
        ca, sa = mpmath.cos(alpha), mpmath.sin(alpha)
        gain = 1 / mpmath.mpc(w0 * w0 - w * w, w0 * w / q_)
        n_amp = -a_ * (1 + w * w * m_ * ca * ca * gain)
        t_amp = a_ * w * w * m_ * sa * ca * gain
        nan = mpf("nan")

        # Lift-off: n(theta) = g + Re[N e^{i theta}] < 0 somewhere.
        if abs(n_amp) > g_:
            return +nan, "lift_off", 0

        sg = cs_ * g_
        kg = ck_ * g_
        a_s = {s: s * t_amp - cs_ * n_amp for s in (1, -1)}
        b_s = {s: s * t_amp - ck_ * n_amp for s in (1, -1)}
        if all(abs(a_s[s]) <= sg for s in (1, -1)):
            return mpf(0), "static", 0

        tol = mpf(10) ** (-(dps - 8))
        two_pi = 2 * mp.pi

        def release_value(s: int, t: mpf) -> mpf:
            return mpmath.re(a_s[s] * mpmath.expjpi(t / mp.pi)) - sg

        theta = mpf(0)
        x = mpf(0)
        slips = 0
        since_stick = 0
        mode = 0  # 0: stick, +-1: slip of that sign starting at theta with v = 0
        records: dict[int, tuple[mpf, mpf, int]] = {}

        for _ in range(MAX_EVENTS):
            if mode == 0:
                immediate = [s for s in (1, -1) if release_value(s, theta) > 0]
                if immediate:
                    mode = immediate[0]
                    continue
                candidates = []
                for s in (1, -1):
                    t = next_release(a_s[s], sg, theta, tol)
                    if t is not None:
                        candidates.append((t, s))
                t_rel, s = min(candidates)
                theta = max(theta, t_rel)
                mode = s
                # Canonical release: its phase is fixed by the closed form.
                if s in records:
                    theta_prev, x_prev, slips_prev = records[s]
                    shift = (theta - theta_prev) / two_pi
                    if abs(shift - mpmath.nint(shift)) < tol:
                        velocity = (x - x_prev) * w / (theta - theta_prev)
                        return velocity, "stick_slip", slips - slips_prev
                records[s] = (theta, x, slips)
                continue

            s = mode
            theta1 = end_of_slip(b_s[s], kg, theta, tol)
            x += s * slip_displacement(b_s[s], kg, theta, theta1, w)
            slips += 1
            since_stick += 1
            theta = theta1
            # v = 0: reverse if the opposite release is already active, else stick.
            if release_value(-s, theta) > 0:
                mode = -s
                if since_stick > MAX_SLIPS_WITHOUT_STICK:
                    return +nan, "continuous_sliding_unsupported", 0
            else:
                mode = 0
                since_stick = 0
        return +nan, "event_budget_exhausted", 0


def _digits_agreement(x: mpf, y: mpf) -> float:
    """Number of agreeing significant digits between two values.

    Parameters
    ----------
    x, y : mpf
        Values to compare (``y`` is the more precise one).

    Returns
    -------
    float
        ``-log10(|x - y| / |y|)``; ``inf`` when equal.
    """
    with mp.workdps(80):
        if x == y:
            return float("inf")
        if y == 0:
            return float(-mpmath.log10(abs(x)))
        return float(-mpmath.log10(abs(x - y) / abs(y)))


def _demo() -> int:
    """Print the reference velocities at a few paper points, with timings.

    Returns
    -------
    int
        Process exit code.
    """
    params = {"f0": 14.44, "Q": 17.5, "alpha_deg": 64.0, "M": 0.08, "cs": 0.25}
    points = [
        (13.0, 8.5, None, "P, ~ +2.195e-3"),
        (16.5, 8.5, None, "N, ~ -9.65e-4"),
        (14.6, 7.0, None, "PN, ~ -3.38e-3"),
        (14.5, 6.0, None, "~ +1.38e-3"),
        (14.5, 9.0, None, "~ -7.53e-3"),
        (13.0, 5.0, None, "S, static"),
        (14.0, 7.0, 0.2, "ck = 0.2"),
    ]
    print(
        f"{'f':>5} {'a':>4} {'ck':>5}  {'velocity [m s-1] (dps=40)':>27}  {'status':<11}"
        f" {'slips':>5}  {'t40 [s]':>7} {'t60 [s]':>7}  {'digits 40v60':>12}  expected"
    )
    for f, a, ck, note in points:
        t0 = time.perf_counter()
        v40, st40, n40 = exact_velocity(**params, f=f, a=a, ck=ck, dps=40)
        t1 = time.perf_counter()
        v60, st60, n60 = exact_velocity(**params, f=f, a=a, ck=ck, dps=60)
        t2 = time.perf_counter()
        assert (st40, n40) == (st60, n60), (st40, n40, st60, n60)
        agree = _digits_agreement(v40, v60)
        cks = "cs" if ck is None else f"{ck:g}"
        print(
            f"{f:5.1f} {a:4.1f} {cks:>5}  {mpmath.nstr(v40, 20, min_fixed=0, max_fixed=0):>27}"
            f"  {st40:<11} {n40:5d}  {t1 - t0:7.3f} {t2 - t1:7.3f}  {agree:12.1f}  {note}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(_demo())
