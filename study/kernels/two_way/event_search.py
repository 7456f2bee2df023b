"""The first event of a piece in one contact mode, never skipped.

Each event function (the stick's two releases, the slip's end, lift-off) is a
sinusoid, a linear part and a functional of the damped homogeneous state; bounds of its
second and third derivatives (per point, in the mode table) give the longest step over
which it cannot reach zero. Stepping by that never skips an event, grazing ones
included, and converges quadratically onto a simple root.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from study.kernels.structure_vector import (
    COS_ALPHA,
    GRAVITY,
    KINETIC_FRICTION,
    MASS_RATIO,
    SIN_ALPHA,
    STATIC_FRICTION,
    STIFFNESS,
)
from study.kernels.two_way.modes import (
    EPS,
    M_AMP_M,
    M_AMP_N,
    M_AMP_P,
    M_ARG_M,
    M_ARG_N,
    M_ARG_P,
    M_CD,
    M_D,
    M_HOM0_M,
    M_HOM0_N,
    M_HOM0_P,
    M_HOM2_M,
    M_HOM2_N,
    M_HOM2_P,
    M_HOM2_V,
    M_HOM3_M,
    M_HOM3_N,
    M_HOM3_P,
    M_HOM3_V,
    M_K,
    M_KD,
    M_OFFSET,
    M_SIGN,
    M_SIN_M,
    M_SIN_N,
    M_SIN_P,
    M_SIN_V,
    TWO_PI,
)
from study.kernels.two_way.propagation import homogeneous, particular

# Event functions, as bits of a mask.
EV_RELEASE_FORWARD = 1
EV_RELEASE_BACKWARD = 2
EV_SLIP_END = 4
EV_LIFT_OFF = 8

# Steps of the event search before a stretch is abandoned (EVENT_BUDGET).
MAX_SEARCH_STEPS = 100_000
# A slip starting with s v' below this fraction of its acceleration scale has no
# first-order start (rounding of a release where ck = cs): its start is nudged.
START_SLOPE = 1e-9
# Nudge [drive periods] past a slip start that does not accelerate at first order.
NUDGE = 1e-6

#: Where a search looks: from ``t_from`` to ``t_end`` [s]; ``horizon`` [s] scales the
#: smallest step taken; lift-off is ``n < g - lift_level`` [m s-2] (``lift_level = g``:
#: ``n < 0``).
SearchLimits = namedtuple("SearchLimits", ("t_from", "t_end", "horizon", "lift_level"))

#: The start of a piece in one contact mode: its time ``t0`` [s], ``sin(w t0)`` [1],
#: the homogeneous state ``(h0, hd0)`` [m, m s-1], the speed ``v0`` [m s-1] and
#: ``delta'(t0) = dd0`` [m s-1].
PieceStart = namedtuple("PieceStart", ("t0", "sin_w0", "h0", "hd0", "v0", "dd0"))

# The mode at time t of a piece: tau = t - t0 [s], cos and sin of the drive phase,
# delta' to delta''''' (particular plus homogeneous) and the homogeneous part's energy
# norm sqrt(k h^2 + D h'^2).
Jet = namedtuple("Jet", ("tau", "cw", "sw", "dd", "ddd", "dddd", "ddddd", "energy"))


@njit(cache=True, nogil=True, error_model="numpy")
def _safe_step(phi, dphi, bound):
    """Longest step over which ``phi`` (< 0, or 0 and decreasing) cannot reach 0,
    given ``|phi''| <= bound``."""
    if bound <= 0.0:
        if dphi > 0.0:
            return -phi / dphi
        return np.inf
    disc = math.sqrt(dphi * dphi - 2.0 * bound * phi)
    if dphi > 0.0:
        return -2.0 * phi / (dphi + disc)
    return (disc - dphi) / bound


@njit(cache=True, nogil=True, error_model="numpy")
def _cubic(phi, d1, d2, m3, h):
    return phi + h * (d1 + h * (0.5 * d2 + h * m3 / 6.0))


@njit(cache=True, nogil=True, error_model="numpy")
def _cubic_step(phi, d1, d2, m3):
    """First root ``h > 0`` of ``p(h) = phi + d1 h + d2 h^2/2 + m3 h^3/6`` (``phi <= 0``,
    ``m3 > 0``), from below.

    With ``m3`` a bound of the third derivative of ``phi`` this cubic bounds
    ``phi(t + h)`` from above, so no zero of ``phi`` comes sooner. ``p`` rises up to
    its first critical point (concave there: Newton from the left stays left of the
    root), falls to the second, and rises convex beyond it (Newton from the right
    stays right; the result is then stepped back by a relative 1e-12).
    """
    disc = d2 * d2 - 2.0 * m3 * d1
    lo = 0.0
    if disc > 0.0:
        root = math.sqrt(disc)
        c1 = (-d2 - root) / m3
        c2 = (-d2 + root) / m3
        if c1 > 0.0 and _cubic(phi, d1, d2, m3, c1) >= 0.0:
            return _newton_left(phi, d1, d2, m3)
        if c2 > 0.0:
            lo = c2
    else:
        # p rises everywhere, concave up to its inflection point.
        inflection = -d2 / m3
        if inflection > 0.0:
            if _cubic(phi, d1, d2, m3, inflection) >= 0.0:
                return _newton_left(phi, d1, d2, m3)
            lo = inflection
    # Beyond lo, p rises and is convex: p(lo + x) >= p(lo) + m3 x^3 / 6.
    base = _cubic(phi, d1, d2, m3, lo)
    if base >= 0.0:
        return lo
    x = lo + math.exp(math.log(-6.0 * base / m3) / 3.0)
    for _ in range(60):
        value = _cubic(phi, d1, d2, m3, x)
        slope = d1 + x * (d2 + 0.5 * m3 * x)
        if slope <= 0.0:
            break
        step = value / slope
        x -= step
        if step <= 1e-13 * x:
            break
    return max(lo, x * (1.0 - 1e-12))


@njit(cache=True, nogil=True, error_model="numpy")
def _newton_left(phi, d1, d2, m3):
    """Root of the cubic on its rising concave stretch from 0, approached from the left."""
    x = 0.0
    for _ in range(60):
        value = _cubic(phi, d1, d2, m3, x)
        slope = d1 + x * (d2 + 0.5 * m3 * x)
        if value >= 0.0 or slope <= 0.0:
            break
        step = -value / slope
        x += step
        if step <= 1e-13 * x:
            break
    return x


@njit(cache=True, nogil=True, error_model="numpy")
def _arc_window(t, omega, amplitude, arg, level):
    """The current or next stretch of time from ``t`` [s] on which
    ``amplitude cos(w t + arg) >= level``: ``(entry, exit)`` (``inf`` if never)."""
    if level > amplitude:
        return np.inf, np.inf
    if level <= -amplitude:
        return t, np.inf
    beta = math.acos(level / amplitude)
    psi = omega * t + arg
    psi -= TWO_PI * math.floor(psi / TWO_PI)
    if psi <= beta:
        return t, t + (beta - psi) / omega
    if psi >= TWO_PI - beta:
        return t, t + (TWO_PI + beta - psi) / omega
    entry = t + (TWO_PI - beta - psi) / omega
    return entry, entry + 2.0 * beta / omega


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _jet(row, omega, k, t, start):
    """The :data:`Jet` of the mode of ``row`` at ``t`` [s] on the piece from ``start``."""
    tau = t - start.t0
    h, hd, _, _, _, _ = homogeneous(row, tau, start.h0, start.hd0)
    ph = omega * t
    cw = math.cos(ph)
    sw = math.sin(ph)
    dp, dpd, dpdd, dpddd = particular(row, omega, cw, sw)
    kd = row[M_KD]
    cd = row[M_CD]
    w2 = omega * omega
    hdd = -(kd * h + cd * hd)
    hddd = -(kd * hd + cd * hdd)
    dd = dpd + hd
    ddd = dpdd + hdd  # delta'' in this mode
    dddd = dpddd + hddd
    # delta = w^4 Re[P e^{iwt}] + h
    ddddd = w2 * w2 * (dp - row[M_OFFSET]) - (kd * hdd + cd * hddd)
    energy = math.sqrt(max(k * h * h + row[M_D] * hd * hd, 0.0))
    return Jet(tau, cw, sw, dd, ddd, dddd, ddddd, energy)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def bounded_step(phi, dphi, d2phi, bound, bound3):
    """Longest safe step of an event function ``phi < 0`` with derivatives ``dphi``,
    ``d2phi``, given bounds ``bound`` and ``bound3`` of its second and third derivatives
    on the rest of the piece: the larger of the quadratic's and the cubic's."""
    h_step = _safe_step(phi, dphi, bound)
    if bound3 > 0.0:
        h_step = max(h_step, _cubic_step(phi, dphi, d2phi, bound3))
    return h_step


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _release_look(jet, kappa, cs, g, a, omega, bound, bound3):
    """A release function ``s tau - cs n = kappa delta'' - cs g + cs A`` (a stick's
    ``delta''``) at ``jet``: ``(fired, step)``, fired when it is positive (or zero and
    rising), else the longest step [s] over which it cannot reach zero."""
    drive = a * jet.cw
    ddrive = -a * omega * jet.sw
    phi = kappa * jet.ddd - cs * g + cs * drive
    dphi = kappa * jet.dddd + cs * ddrive
    if phi > 0.0 or (phi == 0.0 and dphi > 0.0):
        return True, 0.0
    d2phi = kappa * jet.ddddd - cs * drive * (omega * omega)
    return False, bounded_step(phi, dphi, d2phi, bound, bound3)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _lift_off_look(jet, row, structure, a, omega, lift_level):
    """The lift-off function ``-(lift_level - A + M cos(alpha) delta'')`` at ``jet``:
    ``(fired, step)`` as :func:`_release_look`."""
    m = structure[MASS_RATIO]
    ca = structure[COS_ALPHA]
    drive = a * jet.cw
    ddrive = -a * omega * jet.sw
    phi = -(lift_level - drive + m * ca * jet.ddd)
    dphi = -(-ddrive + m * ca * jet.dddd)
    if phi > 0.0:
        return True, 0.0
    d2phi = -(drive * (omega * omega) + m * ca * jet.ddddd)
    bound = row[M_SIN_N] + row[M_HOM2_N] * jet.energy
    bound3 = omega * row[M_SIN_N] + row[M_HOM3_N] * jet.energy
    return False, bounded_step(phi, dphi, d2phi, bound, bound3)


@njit(cache=True, nogil=True, error_model="numpy")
def _nudged_slip_speed(row, structure, a, omega, start, t):
    """A slip from rest without a first-order start (a release where ck = cs) moves only
    if ``s v > 0`` just after: ``(tn, s v(tn))`` with ``tn`` [s] the nudged time."""
    s = row[M_SIGN]
    kk = row[M_K]
    ck = structure[KINETIC_FRICTION]
    g = structure[GRAVITY]
    t0 = start.t0
    tn = t + NUDGE * TWO_PI / omega
    _, hdn, _, _, _, _ = homogeneous(row, tn - t0, start.h0, start.hd0)
    _, dpdn, _, _ = particular(row, omega, math.cos(omega * tn), math.sin(omega * tn))
    svn = (-s * kk * (dpdn + hdn - start.dd0) - ck * g * (tn - t0)
           + ck * a * (math.sin(omega * tn) - start.sin_w0) / omega)
    return tn, svn


@njit(cache=True, nogil=True, error_model="numpy")
def search(structure, row, omega, a, start, mask, limits):
    """First event of the functions in ``mask`` in ``(t0, t_end]`` for a piece in the
    contact mode of ``row`` (a row of the mode table) from ``start`` (a
    :data:`PieceStart`) within ``limits`` (:data:`SearchLimits`), for the structure
    vector ``structure`` and the drive ``omega`` [rad s-1], ``a`` [m s-2].

    The arrays are passed apart, not in a :data:`~study.kernels.two_way.modes.DrivePoint`:
    this is the innermost call of the orbit, and taking arrays out of a tuple costs
    reference counts on every call (a pass of the orbit was 3 % slower). One loop over
    the steps, kept whole: the arc windows, the nudge of a slip's start and the nearest
    event carry from step to step; the mode's derivatives (:func:`_jet`) and each event
    function's look are split out.

    Returns
    -------
    kind, t, steps
        The event's bit (0: none before ``t_end``, -1: step budget), its time [s] and
        the steps taken.
    """
    t_end = limits.t_end
    horizon = limits.horizon
    lift_level = limits.lift_level
    k = structure[STIFFNESS]
    ca = structure[COS_ALPHA]
    sa = structure[SIN_ALPHA]
    m = structure[MASS_RATIO]
    cs = structure[STATIC_FRICTION]
    ck = structure[KINETIC_FRICTION]
    g = structure[GRAVITY]
    d = row[M_D]
    s = row[M_SIGN]
    kk = row[M_K]
    kappa_p = -m * (sa + cs * ca)
    kappa_m = -m * (-sa + cs * ca)
    sin_p = row[M_SIN_P]
    hom_p = row[M_HOM2_P]
    hom3_p = row[M_HOM3_P]
    sin_m = row[M_SIN_M]
    hom_m = row[M_HOM2_M]
    hom3_m = row[M_HOM3_M]
    sin_v = row[M_SIN_V]
    hom_v = row[M_HOM2_V]
    hom3_v = row[M_HOM3_V]
    amp_p = row[M_AMP_P]
    arg_p = row[M_ARG_P]
    amp_m = row[M_AMP_M]
    arg_m = row[M_ARG_M]
    amp_n = row[M_AMP_N]
    arg_n = row[M_ARG_N]
    t0 = start.t0
    v0 = start.v0
    t = limits.t_from
    first = t == t0
    # Functions made of a sinusoid, a constant and a functional of h cannot reach 0
    # before the sinusoid reaches -(constant + bound of the functional): with the energy
    # non-increasing, that arc's entry is a safe first look (one step over a stick).
    energy0 = math.sqrt(max(k * start.h0 * start.h0 + d * start.hd0 * start.hd0, 0.0))
    entry_p = np.inf
    exit_p = np.inf
    entry_m = np.inf
    exit_m = np.inf
    entry_n = np.inf
    exit_n = np.inf
    level_p = cs * g - row[M_HOM0_P] * energy0
    level_m = cs * g - row[M_HOM0_M] * energy0
    level_n = lift_level - row[M_HOM0_N] * energy0
    if mask & EV_RELEASE_FORWARD:
        entry_p, exit_p = _arc_window(t, omega, row[M_AMP_P], row[M_ARG_P], level_p)
    if mask & EV_RELEASE_BACKWARD:
        entry_m, exit_m = _arc_window(t, omega, row[M_AMP_M], row[M_ARG_M], level_m)
    if mask & EV_LIFT_OFF:
        entry_n, exit_n = _arc_window(t, omega, row[M_AMP_N], row[M_ARG_N], level_n)
    for steps in range(MAX_SEARCH_STEPS):
        jet = _jet(row, omega, k, t, start)
        energy = jet.energy
        step = np.inf
        kind = 0
        # The releases (stick only: delta'' is the stick's) are looked at from the
        # entry of the arc on which they can be positive.
        if mask & EV_RELEASE_FORWARD:
            if t >= exit_p:
                entry_p, exit_p = _arc_window(t, omega, amp_p, arg_p, level_p)
            if entry_p > t:
                if entry_p - t < step:
                    step = entry_p - t
                    kind = 0
            else:
                fired, h_step = _release_look(
                    jet, kappa_p, cs, g, a, omega, sin_p + hom_p * energy,
                    omega * sin_p + hom3_p * energy)
                if fired:
                    return EV_RELEASE_FORWARD, t, steps
                if h_step < step:
                    step = h_step
                    kind = EV_RELEASE_FORWARD
        if mask & EV_RELEASE_BACKWARD:
            if t >= exit_m:
                entry_m, exit_m = _arc_window(t, omega, amp_m, arg_m, level_m)
            if entry_m > t:
                if entry_m - t < step:
                    step = entry_m - t
                    kind = 0
            else:
                fired, h_step = _release_look(
                    jet, kappa_m, cs, g, a, omega, sin_m + hom_m * energy,
                    omega * sin_m + hom3_m * energy)
                if fired:
                    return EV_RELEASE_BACKWARD, t, steps
                if h_step < step:
                    step = h_step
                    kind = EV_RELEASE_BACKWARD
        if mask & EV_SLIP_END:
            # s v = s v0 - s K (delta' - delta'_0) - ck g tau + ck a (sin wt - sin wt0) / w
            tau = jet.tau
            sv = (s * v0 - s * kk * (jet.dd - start.dd0) - ck * g * tau
                  + ck * a * (jet.sw - start.sin_w0) / omega)
            dsv = -s * kk * jet.ddd - ck * g + ck * (a * jet.cw)
            phi = -sv
            dphi = -dsv
            if first and v0 == 0.0:
                phi = 0.0
                if dphi >= -START_SLOPE * (ck * (g + a) + abs(kk * jet.ddd)):
                    # No first-order start: a slip ending within the nudge would move
                    # by O(nudge^3) of the amplitude.
                    tn, svn = _nudged_slip_speed(row, structure, a, omega, start, t)
                    if svn <= 0.0 or tn >= t_end:
                        return EV_SLIP_END, t, steps
                    t = tn
                    first = False
                    continue
            if phi > 0.0 or (phi == 0.0 and dphi > 0.0):
                return EV_SLIP_END, t, steps
            d2phi = s * kk * jet.dddd + ck * a * omega * jet.sw
            h_step = bounded_step(phi, dphi, d2phi, sin_v + hom_v * energy,
                                   omega * sin_v + hom3_v * energy)
            if h_step < step:
                step = h_step
                kind = EV_SLIP_END
        if mask & EV_LIFT_OFF and t >= exit_n:
            entry_n, exit_n = _arc_window(t, omega, amp_n, arg_n, level_n)
        if mask & EV_LIFT_OFF and entry_n > t:
            if entry_n - t < step:
                step = entry_n - t
                kind = 0
        elif mask & EV_LIFT_OFF:
            fired, h_step = _lift_off_look(jet, row, structure, a, omega, lift_level)
            if fired:
                return EV_LIFT_OFF, t, steps
            if h_step < step:
                step = h_step
                kind = EV_LIFT_OFF
        first = False
        if t + step >= t_end:
            return 0, t_end, steps
        if kind != 0 and step <= 4.0 * EPS * horizon:
            return kind, t + step, steps
        t = t + step
    return -1, t, MAX_SEARCH_STEPS
