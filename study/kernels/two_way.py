"""Exact event-driven periodic orbits with the mode as a state: either coupling.

State ``z = (delta, d delta/dt, v)`` at time ``t`` and a contact mode: stick (0),
forward slip (+1), backward slip (-1). Per unit total mass, table frame, drive
``A = a cos(w t)``; ``c = w0/Q``, ``k = w0^2``. In every contact mode the mode obeys a
linear ODE with constant coefficients and harmonic forcing (docs/theory/two-way.md)::

    stick:         delta'' + c delta' + k delta = A cos(alpha)
    slip s:   D_s delta'' + c delta' + k delta = A (cos(alpha) - s ck sin(alpha))
                                                 + s ck g sin(alpha)
    D_s = 1 - M sin(alpha) (sin(alpha) + s ck cos(alpha))        (two-way)
    D_s = 1 and the stick's forcing                               (one-way)

    slip s:   v' = -K_s delta'' - s ck g + s ck A,    K_s = M (sin(alpha) + s ck cos(alpha))

so between events ``delta`` is a particular harmonic (plus a constant) plus a damped
homogeneous part ``h = E(t - t0) h0`` (closed form, any damping), and ``v`` is
``v0 - K_s (delta' - delta'_0)`` plus a sinusoid and a linear term.

Events are the first zero of a function ``phi(t) < 0`` (release ``s tau - cs n``
in a stick, ``-s v`` in a slip, ``-n`` for lift-off). ``phi`` is a sinusoid plus a
linear part plus a functional of ``h``; its second derivative is bounded on the
rest of the piece by ``|sinusoid| w^2 + ||l A^2|| sqrt(k h^2 + D h'^2)`` (the energy
of a damped oscillator never grows). From ``t`` no zero can occur before the first
root of ``phi + phi' s + bound s^2 / 2``: stepping by that amount never skips an event
(grazing contacts included) and converges quadratically onto a simple root.

The steady orbit is the fixed point of the period map ``z(0) -> z(N T)``, found by
Newton's method on ``P^N(z) - z`` with the exact Jacobian: the flow's matrix
exponential between events and a saltation matrix at each event. The Floquet
multipliers are the eigenvalues of that Jacobian at the fixed point.

Everything here is private: :mod:`study.solvers.exact` validates, allocates and calls.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from study.kernels.one_way import sin_minus_x
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
    FRICTION_PARADOX,
    LIFT_OFF,
    NOT_CONVERGED,
    REASON_EVENT_BUDGET,
    REASON_NO_PERIODIC_ORBIT,
    REASON_NONE,
    STATIC,
    STICK_SLIP,
)

TWO_PI = 2.0 * math.pi
EPS = 2.220446049250313e-16


# Columns of the per-point mode table (rows: stick, forward slip, backward slip).
M_D = 0  # D (1 in a stick)
M_SIGMA = 1  # c / (2 D)
M_NU2 = 2  # k / D - sigma^2
M_KD = 3  # k / D
M_CD = 4  # c / D
M_PRE = 5  # particular response Re
M_PIM = 6  # particular response Im
M_OFFSET = 7  # constant part of the particular solution, G / k [m]
M_K = 8  # K_s = M (sin + s ck cos) (0 for the stick)
M_SIGN = 9
M_FORCE = 10  # forcing amplitude F [m s-2]
M_GCONST = 11  # constant forcing G [m s-2]
# Bounds of the event functions of this mode (per point constants): the sinusoid's
# amplitude times w^2, the dual energy norms of the homogeneous functional and of its
# second and third derivatives, and the sinusoid's amplitude and phase (for the arcs).
M_SIN_P = 12
M_HOM0_P = 13
M_HOM2_P = 14
M_HOM3_P = 15
M_AMP_P = 16
M_ARG_P = 17
M_SIN_M = 18
M_HOM0_M = 19
M_HOM2_M = 20
M_HOM3_M = 21
M_AMP_M = 22
M_ARG_M = 23
M_SIN_V = 24
M_HOM2_V = 25
M_HOM3_V = 26
M_SIN_N = 27
M_HOM0_N = 28
M_HOM2_N = 29
M_HOM3_N = 30
M_AMP_N = 31
M_ARG_N = 32
N_MODE = 33

# Event functions, as bits of a mask.
EV_RELEASE_FORWARD = 1
EV_RELEASE_BACKWARD = 2
EV_SLIP_END = 4
EV_LIFT_OFF = 8

# Outcome of a stretch of the orbit.
RUN_OK = 0
RUN_LIFT_OFF = 1
RUN_PARADOX = 2
RUN_BUDGET = 3

# Steps of the event search before a stretch is abandoned (EVENT_BUDGET).
MAX_SEARCH_STEPS = 100_000
# Newton iterations on the period map before falling back to the map's iteration.
MAX_NEWTON = 24
# A Newton iterate is a fixed point when the scaled residual is below this, or below
# LOOSE_TOLERANCE and no longer decreasing (the rounding floor of the map).
NEWTON_TOLERANCE = 1e-13
LOOSE_TOLERANCE = 1e-11
# A Newton step this small (scaled) ends the iteration: its own error is ~ its square.
NEWTON_STEP = 1e-7
# A slip shorter than this fraction of the orbit's span is a sliver (see _newton).
SLIVER = 1e-6
# Newton iterates after a step and residual below this (scaled), with the events of the
# pass unchanged, are watched for lift-off.
LIFT_WATCH = 1e-3
# Period-map iterates closing to this (scaled) start a Newton search for that period.
CYCLE_DETECTION = 1e-3
# Periods of the map's iteration before its iterates are watched for lift-off.
BURN_IN = 8
# Longest orbit searched for, in drive periods.
MAX_PERIOD = 16
# Where the second Poincare section lies, in drive periods after phase 0 (1 - 1/golden
# ratio: no simple fraction, so an orbit's events do not sit on both sections).
SECTION_SHIFT = 0.3819660112501051
# An orbit is stable when its largest Floquet multiplier is below 1 + this.
STABILITY_MARGIN = 1e-6
# A slip starting with s v' below this fraction of its acceleration scale has no
# first-order start (rounding of a release where ck = cs): its start is nudged.
START_SLOPE = 1e-9
# Nudge [drive periods] past a slip start that does not accelerate at first order.
NUDGE = 1e-6

# Accumulator slots of a stretch.
A_DISPLACEMENT = 0
A_SLIPS = 1
A_FORWARD = 2
A_BACKWARD = 3
A_STICK = 4
A_EVENTS = 5
A_STEPS = 6
A_SHORTEST = 7  # shortest slip of the stretch that is not cut by its ends [s]
A_START_SLIVER = 8  # 1: the stretch starts in a slip that is a sliver
N_ACC = 9


@njit(cache=True, nogil=True, error_model="numpy")
def mode_table(structure, omega, a, table):
    """Fill ``table`` (3 x N_MODE) for drive ``omega`` [rad s-1], ``a`` [m s-2].

    Returns
    -------
    bool
        False when a slip's ``D_s <= 0`` (Painleve's paradox) for that sign; its
        row is then left with ``D = 0``.
    """
    for row in range(3):
        mode_row(structure, omega, a, table, row)
    return table[1, M_D] > 0.0, table[2, M_D] > 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def mode_row(structure, omega, a, table, row):
    """Fill one row of :func:`mode_table`: the stick (0), forward (1) or backward (2)."""
    c = structure[DAMPING]
    k = structure[STIFFNESS]
    ca = structure[COS_ALPHA]
    sa = structure[SIN_ALPHA]
    m = structure[MASS_RATIO]
    ck = structure[KINETIC_FRICTION]
    g = structure[GRAVITY]
    coupled = structure[TWO_WAY] != 0.0
    s = 0.0 if row == 0 else (1.0 if row == 1 else -1.0)
    if row == 0 or not coupled:
        d = 1.0
        force = a * ca
        gconst = 0.0
    else:
        d = 1.0 - m * sa * (sa + s * ck * ca)
        force = a * (ca - s * ck * sa)
        gconst = s * ck * g * sa
    table[row, M_SIGN] = s
    table[row, M_K] = 0.0 if row == 0 else m * (sa + s * ck * ca)
    table[row, M_D] = d
    table[row, M_FORCE] = force
    table[row, M_GCONST] = gconst
    if d <= 0.0:
        table[row, M_D] = 0.0
        return
    sigma = 0.5 * c / d
    table[row, M_SIGMA] = sigma
    table[row, M_KD] = k / d
    table[row, M_CD] = c / d
    table[row, M_NU2] = k / d - sigma * sigma
    re = k - d * omega * omega
    im = c * omega
    den = re * re + im * im
    table[row, M_PRE] = force * re / den
    table[row, M_PIM] = -force * im / den
    table[row, M_OFFSET] = gconst / k
    _event_bounds(structure, table[row], omega, a)


@njit(cache=True, nogil=True, error_model="numpy")
def _event_bounds(structure, row, omega, a):
    """Fill the bound columns of one mode's row (see ``M_SIN_P``...)."""
    k = structure[STIFFNESS]
    ca = structure[COS_ALPHA]
    sa = structure[SIN_ALPHA]
    m = structure[MASS_RATIO]
    cs = structure[STATIC_FRICTION]
    ck = structure[KINETIC_FRICTION]
    kd = row[M_KD]
    cd = row[M_CD]
    s = row[M_SIGN]
    kk = row[M_K]
    pr = row[M_PRE]
    pi = row[M_PIM]
    w2 = omega * omega
    for sign, col in ((1.0, M_SIN_P), (-1.0, M_SIN_M)):
        # Release s tau - cs n = kappa delta'' - cs g + cs A (a stick's delta'').
        kappa = -m * (sign * sa + cs * ca)
        cr = -kappa * w2 * pr + cs * a
        ci = -kappa * w2 * pi
        row[col] = w2 * math.hypot(cr, ci)
        row[col + 1] = abs(kappa) * _functional_bound(row, -kd, -cd, k, 0)
        row[col + 2] = abs(kappa) * _functional_bound(row, -kd, -cd, k, 2)
        row[col + 3] = abs(kappa) * _functional_bound(row, -kd, -cd, k, 3)
        row[col + 4] = math.hypot(cr, ci)
        row[col + 5] = math.atan2(ci, cr)
    # s v: sinusoid -s K delta_p' + ck a sin(wt) / w; homogeneous -s K h'.
    row[M_SIN_V] = w2 * math.hypot(kk * omega * pi, kk * omega * pr + s * ck * a / omega)
    row[M_HOM2_V] = _functional_bound(row, 0.0, kk, k, 2)
    row[M_HOM3_V] = _functional_bound(row, 0.0, kk, k, 3)
    # -n = A - g - M cos(alpha) delta''.
    cr = a + m * ca * w2 * pr
    ci = m * ca * w2 * pi
    row[M_SIN_N] = w2 * math.hypot(cr, ci)
    row[M_HOM0_N] = m * ca * _functional_bound(row, kd, cd, k, 0)
    row[M_HOM2_N] = m * ca * _functional_bound(row, kd, cd, k, 2)
    row[M_HOM3_N] = m * ca * _functional_bound(row, kd, cd, k, 3)
    row[M_AMP_N] = math.hypot(cr, ci)
    row[M_ARG_N] = math.atan2(ci, cr)


@njit(cache=True, nogil=True, error_model="numpy")
def _propagator(sigma, nu2, tau):
    """``exp(A tau) = e^{-sigma tau} (C I + S (A + sigma I))``: returns ``e C``, ``e S``.

    ``C = cos(nu tau)``, ``S = sin(nu tau) / nu`` (``cosh``/``sinh`` when overdamped,
    series near critical damping, exponentials combined when ``e^{-sigma tau}`` and
    ``cosh`` would overflow).
    """
    z = nu2 * tau * tau
    if abs(z) < 1e-2:
        c = 1.0 + z * (-0.5 + z * (1.0 / 24.0 + z * (-1.0 / 720.0 + z / 40320.0)))
        s = tau * (1.0 + z * (-1.0 / 6.0 + z * (1.0 / 120.0 + z * (-1.0 / 5040.0
                                                                  + z / 362880.0))))
        e = math.exp(-sigma * tau)
        return e * c, e * s
    if z > 0.0:
        nu = math.sqrt(nu2)
        e = math.exp(-sigma * tau)
        return e * math.cos(nu * tau), e * math.sin(nu * tau) / nu
    mu = math.sqrt(-nu2)
    # mu - sigma = -(k/D) / (sigma + mu), without cancellation.
    slow = math.exp(-((sigma * sigma + nu2) / (sigma + mu)) * tau)
    fast = math.exp(-(sigma + mu) * tau)
    return 0.5 * (slow + fast), 0.5 * (slow - fast) / mu


@njit(cache=True, nogil=True, error_model="numpy")
def _homogeneous(row, tau, h0, hd0):
    """``(h, h')`` after ``tau`` [s] from ``(h0, hd0)`` in the mode of ``row``,
    and the 2x2 propagator ``(e11, e12, e21, e22)``."""
    sigma = row[M_SIGMA]
    ec, es = _propagator(sigma, row[M_NU2], tau)
    e11 = ec + es * sigma
    e12 = es
    e21 = -es * row[M_KD]
    e22 = ec - es * sigma
    return e11 * h0 + e12 * hd0, e21 * h0 + e22 * hd0, e11, e12, e21, e22


@njit(cache=True, nogil=True, error_model="numpy")
def _particular(row, omega, cw, sw):
    """Particular solution ``(delta, delta', delta'', delta''')`` of a mode at phase
    with ``cos = cw``, ``sin = sw``."""
    pr = row[M_PRE]
    pi = row[M_PIM]
    re = pr * cw - pi * sw
    im = pr * sw + pi * cw
    w2 = omega * omega
    return re + row[M_OFFSET], -omega * im, -w2 * re, w2 * omega * im


@njit(cache=True, nogil=True, error_model="numpy")
def _one_minus_cos(d):
    half = math.sin(0.5 * d)
    return 2.0 * half * half


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


@njit(cache=True, nogil=True, error_model="numpy")
def _dual_norm(row, l1, l2, k):
    """``max |l1 h + l2 h'|`` over states of unit energy ``k h^2 + D h'^2``."""
    return math.sqrt(l1 * l1 / k + l2 * l2 / row[M_D])


@njit(cache=True, nogil=True, error_model="numpy")
def _functional_bound(row, l1, l2, k, power):
    """``||l A^power||`` in the dual of the energy norm ``sqrt(k h^2 + D h'^2)``:
    bounds the ``power``-th derivative of ``l . (h, h')`` per unit energy norm."""
    kd = row[M_KD]
    cd = row[M_CD]
    for _ in range(power):
        # (l1, l2) A with A = [[0, 1], [-kd, -cd]]
        l1, l2 = -kd * l2, l1 - cd * l2
    return math.sqrt(l1 * l1 / k + l2 * l2 / row[M_D])


@njit(cache=True, nogil=True, error_model="numpy")
def _search(structure, table, j, omega, a, t0, sin_w0, h0, hd0, v0, dd0, t_from, t_end,
            mask, horizon, lift_level):
    """First event of the functions in ``mask`` in ``(t0, t_end]`` for a stretch in
    contact mode ``j`` (row of ``table``) starting at ``t0`` [s] with homogeneous state
    ``(h0, hd0)``, speed ``v0`` and ``delta'(t0) = dd0``, looking from ``t_from``;
    ``sin_w0 = sin(w t0)``.
    Lift-off is ``n < g - lift_level`` [m s-2] (``lift_level = g``: ``n < 0``).

    Returns
    -------
    kind, t
        The event's bit (0: none before ``t_end``, -1: step budget) and its time [s].
    """
    row = table[j]
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
    kd = row[M_KD]
    cd = row[M_CD]
    w2 = omega * omega
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
    sin_n = row[M_SIN_N]
    hom_n = row[M_HOM2_N]
    hom3_n = row[M_HOM3_N]
    t = t_from
    first = t_from == t0
    # Functions made of a sinusoid, a constant and a functional of h cannot reach 0
    # before the sinusoid reaches -(constant + bound of the functional): with the energy
    # non-increasing, that arc's entry is a safe first look (one step over a stick).
    energy0 = math.sqrt(max(k * h0 * h0 + d * hd0 * hd0, 0.0))
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
        tau = t - t0
        h, hd, _, _, _, _ = _homogeneous(row, tau, h0, hd0)
        ph = omega * t
        cw = math.cos(ph)
        sw = math.sin(ph)
        dp, dpd, dpdd, dpddd = _particular(row, omega, cw, sw)
        hdd = -(kd * h + cd * hd)
        hddd = -(kd * hd + cd * hdd)
        dd = dpd + hd
        ddd = dpdd + hdd  # delta'' in this mode
        dddd = dpddd + hddd
        # delta = w^4 Re[P e^{iwt}] + h
        ddddd = w2 * w2 * (dp - row[M_OFFSET]) - (kd * hdd + cd * hddd)
        energy = math.sqrt(max(k * h * h + d * hd * hd, 0.0))
        step = np.inf
        kind = 0
        drive = a * cw
        ddrive = -a * omega * sw
        if mask & (EV_RELEASE_FORWARD | EV_RELEASE_BACKWARD):
            # Stick only: delta'' is the stick's.
            for bit in (EV_RELEASE_FORWARD, EV_RELEASE_BACKWARD):
                if not mask & bit:
                    continue
                if bit == EV_RELEASE_FORWARD:
                    kappa = kappa_p
                    bound = sin_p + hom_p * energy
                    if t >= exit_p:
                        entry_p, exit_p = _arc_window(t, omega, row[M_AMP_P], row[M_ARG_P],
                                                      level_p)
                    wait = entry_p
                else:
                    kappa = kappa_m
                    bound = sin_m + hom_m * energy
                    if t >= exit_m:
                        entry_m, exit_m = _arc_window(t, omega, row[M_AMP_M], row[M_ARG_M],
                                                      level_m)
                    wait = entry_m
                if wait > t:
                    if wait - t < step:
                        step = wait - t
                        kind = 0
                    continue
                phi = kappa * ddd - cs * g + cs * drive
                dphi = kappa * dddd + cs * ddrive
                if phi > 0.0 or (phi == 0.0 and dphi > 0.0):
                    return bit, t, steps
                h_step = _safe_step(phi, dphi, bound)
                d2phi = kappa * ddddd - cs * drive * w2
                bound3 = omega * (sin_p if bit == EV_RELEASE_FORWARD else sin_m) + (
                    hom3_p if bit == EV_RELEASE_FORWARD else hom3_m) * energy
                if bound3 > 0.0:
                    h_step = max(h_step, _cubic_step(phi, dphi, d2phi, bound3))
                if h_step < step:
                    step = h_step
                    kind = bit
        if mask & EV_SLIP_END:
            # s v = s v0 - s K (delta' - delta'_0) - ck g tau + ck a (sin wt - sin wt0) / w
            sv = (s * v0 - s * kk * (dd - dd0) - ck * g * tau
                  + ck * a * (sw - sin_w0) / omega)
            dsv = -s * kk * ddd - ck * g + ck * drive
            phi = -sv
            dphi = -dsv
            bound = sin_v + hom_v * energy
            if first and v0 == 0.0:
                phi = 0.0
                if dphi >= -START_SLOPE * (ck * (g + a) + abs(kk * ddd)):
                    # No first-order start (a release where ck = cs): the slip moves
                    # only if s v > 0 just after. A slip ending within the nudge would
                    # move by O(nudge^3) of the amplitude.
                    nudge = NUDGE * TWO_PI / omega
                    tn = t + nudge
                    _, hdn, _, _, _, _ = _homogeneous(row, tn - t0, h0, hd0)
                    _, dpdn, _, _ = _particular(row, omega, math.cos(omega * tn),
                                                math.sin(omega * tn))
                    svn = (-s * kk * (dpdn + hdn - dd0) - ck * g * (tn - t0)
                           + ck * a * (math.sin(omega * tn) - sin_w0) / omega)
                    if svn <= 0.0 or tn >= t_end:
                        return EV_SLIP_END, t, steps
                    t = tn
                    first = False
                    continue
            if phi > 0.0 or (phi == 0.0 and dphi > 0.0):
                return EV_SLIP_END, t, steps
            h_step = _safe_step(phi, dphi, bound)
            d2phi = s * kk * dddd + ck * a * omega * sw
            bound3 = omega * sin_v + hom3_v * energy
            if bound3 > 0.0:
                h_step = max(h_step, _cubic_step(phi, dphi, d2phi, bound3))
            if h_step < step:
                step = h_step
                kind = EV_SLIP_END
        if mask & EV_LIFT_OFF and t >= exit_n:
            entry_n, exit_n = _arc_window(t, omega, row[M_AMP_N], row[M_ARG_N], level_n)
        if mask & EV_LIFT_OFF and entry_n > t:
            if entry_n - t < step:
                step = entry_n - t
                kind = 0
        elif mask & EV_LIFT_OFF:
            phi = -(lift_level - drive + m * ca * ddd)
            dphi = -(-ddrive + m * ca * dddd)
            bound = sin_n + hom_n * energy
            if phi > 0.0:
                return EV_LIFT_OFF, t, steps
            h_step = _safe_step(phi, dphi, bound)
            d2phi = -(drive * w2 + m * ca * ddddd)
            bound3 = omega * sin_n + hom3_n * energy
            if bound3 > 0.0:
                h_step = max(h_step, _cubic_step(phi, dphi, d2phi, bound3))
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


@njit(cache=True, nogil=True, error_model="numpy")
def _stick_releases(structure, a, cw, dl, dld):
    """Release functions ``s tau - cs n`` (stick forces) at state ``(dl, dld)`` and drive
    phase with cosine ``cw``."""
    ca = structure[COS_ALPHA]
    sa = structure[SIN_ALPHA]
    m = structure[MASS_RATIO]
    cs = structure[STATIC_FRICTION]
    g = structure[GRAVITY]
    drive = a * cw
    ddd0 = drive * ca - structure[DAMPING] * dld - structure[STIFFNESS] * dl
    base = -cs * g + cs * drive
    return -m * (sa + cs * ca) * ddd0 + base, -m * (-sa + cs * ca) * ddd0 + base, ddd0


@njit(cache=True, nogil=True, error_model="numpy")
def _mode_acceleration(structure, row, cw, dl, dld):
    """``delta''`` in the mode of ``row`` at state ``(dl, dld)``, drive phase cosine ``cw``."""
    return (row[M_FORCE] * cw + row[M_GCONST] - structure[DAMPING] * dld
            - structure[STIFFNESS] * dl) / row[M_D]


@njit(cache=True, nogil=True, error_model="numpy")
def _slip_acceleration(structure, row, a, cw, ddd):
    """``v'`` in the slip of ``row`` with mode acceleration ``ddd``."""
    s = row[M_SIGN]
    ck = structure[KINETIC_FRICTION]
    return -row[M_K] * ddd - s * ck * structure[GRAVITY] + s * ck * a * cw


@njit(cache=True, nogil=True, error_model="numpy")
def _mat_left(jac, r00, r01, r02, r10, r11, r12, r20, r21, r22):
    """``jac <- R jac`` for the 3x3 matrix ``R`` given by rows."""
    for col in range(3):
        x0 = jac[0, col]
        x1 = jac[1, col]
        x2 = jac[2, col]
        jac[0, col] = r00 * x0 + r01 * x1 + r02 * x2
        jac[1, col] = r10 * x0 + r11 * x1 + r12 * x2
        jac[2, col] = r20 * x0 + r21 * x1 + r22 * x2


@njit(cache=True, nogil=True, error_model="numpy")
def _initial_mode(structure, table, omega, a, t, z):
    """Contact mode of state ``z`` at ``t``: the sign of ``v``, or the stick test."""
    if z[2] > 0.0:
        return 1
    if z[2] < 0.0:
        return -1
    r_p, r_m, _ = _stick_releases(structure, a, math.cos(omega * t), z[0], z[1])
    # Both positive only off the table (n < 0): the larger wins, as the mirror image
    # alpha -> -alpha swaps them.
    if r_p > 0.0 and r_p >= r_m:
        return 1
    if r_m > 0.0:
        return -1
    return 0


@njit(cache=True, nogil=True, error_model="numpy")
def run(structure, table, omega, a, z, t_begin, t_stop, jac, want_jac, lift_margin,
        max_events, acc, grad):
    """Follow the state ``z`` (in place) from ``t_begin`` to ``t_stop`` [s].

    ``acc`` receives the displacement [m], slips, forward/backward slip and stick
    time [s] and events; ``jac`` (3x3) is multiplied on the left by the flow's
    Jacobian when ``want_jac``, and the rows of ``grad`` (3x3) receive the gradients
    of the displacement and of the forward and backward slip times with respect to
    the state the Jacobian started from. Lift-off is watched when ``lift_margin >= 0``:
    ``n < -lift_margin`` [m s-2] ends the stretch.

    Returns
    -------
    int
        ``RUN_OK``, ``RUN_LIFT_OFF``, ``RUN_PARADOX`` or ``RUN_BUDGET``.
    """
    horizon = max(abs(t_stop), TWO_PI / omega)
    t = t_begin
    mode = _initial_mode(structure, table, omega, a, t, z)
    if mode != 0:
        if table[1 if mode > 0 else 2, M_D] <= 0.0:
            return RUN_PARADOX
        if z[2] == 0.0:
            acc[A_SLIPS] += 1.0
    events = 0
    # Where the next search starts looking (after a slip that could not move).
    t_from = t
    # Cosine and sine of the drive phase at t_trig (reused at the next piece's start).
    t_trig = np.nan
    cw = 1.0
    sw = 0.0
    # Gradient of the current slip's start time with respect to the initial state.
    ds0 = 0.0
    ds1 = 0.0
    ds2 = 0.0
    while t < t_stop:
        events += 1
        if events > max_events:
            acc[A_EVENTS] += events
            return RUN_BUDGET
        j = 0 if mode == 0 else (1 if mode > 0 else 2)
        row = table[j]
        if t != t_trig:
            cw = math.cos(omega * t)
            sw = math.sin(omega * t)
        dp, dpd, _, _ = _particular(row, omega, cw, sw)
        h0 = z[0] - dp
        hd0 = z[1] - dpd
        v0 = z[2]
        dd0 = z[1]
        if mode == 0:
            mask = EV_RELEASE_FORWARD | EV_RELEASE_BACKWARD
        else:
            mask = EV_SLIP_END
        if lift_margin >= 0.0:
            mask |= EV_LIFT_OFF
        kind, te, steps = _search(structure, table, j, omega, a, t, sw, h0, hd0, v0, dd0,
                           max(t, t_from), t_stop, mask, horizon,
                           structure[GRAVITY] + max(lift_margin, 0.0))
        acc[A_STEPS] += steps
        if kind < 0:
            acc[A_EVENTS] += events
            return RUN_BUDGET
        if kind == EV_LIFT_OFF:
            acc[A_EVENTS] += events
            return RUN_LIFT_OFF
        tau = te - t
        h, hd, e11, e12, e21, e22 = _homogeneous(row, tau, h0, hd0)
        ph = omega * te
        cwe = math.cos(ph)
        swe = math.sin(ph)
        dpe, dpde, _, _ = _particular(row, omega, cwe, swe)
        dl = dpe + h
        dld = dpde + hd
        if mode == 0:
            acc[A_STICK] += tau
            z[0] = dl
            z[1] = dld
            z[2] = 0.0
            if want_jac:
                _mat_left(jac, e11, e12, 0.0, e21, e22, 0.0, 0.0, 0.0, 0.0)
        else:
            s = row[M_SIGN]
            kk = row[M_K]
            ck = structure[KINETIC_FRICTION]
            g = structure[GRAVITY]
            tw = omega * tau
            # v and the displacement over the slip, cancellation-free in tau.
            dsin = (cw * math.sin(tw) - sw * _one_minus_cos(tw)) / omega
            v_end = v0 - kk * (dld - dd0) - s * ck * g * tau + s * ck * a * dsin
            # integral of (sin wt - sin wt0) / w dt = [cw0 (1 - cos) + sw0 (sin - tw)] / w^2
            iint = (cw * _one_minus_cos(tw) + sw * sin_minus_x(tw, math.sin(tw))) / (omega * omega)
            dp_full = (dpe - dp) - dpd * tau  # particular: delta1 - delta0 - delta0' tau
            dh_full = (h - h0) - hd0 * tau
            displacement = (v0 * tau - kk * (dp_full + dh_full) - 0.5 * s * ck * g * tau * tau
                            + s * ck * a * iint)
            acc[A_DISPLACEMENT] += displacement
            if kind == EV_SLIP_END and (tau < acc[A_SHORTEST] or acc[A_SHORTEST] == 0.0):
                acc[A_SHORTEST] = tau
            if kind == EV_SLIP_END and v0 != 0.0 and t == t_begin and (
                    tau < SLIVER * (t_stop - t_begin)):
                acc[A_START_SLIVER] = 1.0
            if s > 0:
                acc[A_FORWARD] += tau
            else:
                acc[A_BACKWARD] += tau
            z[0] = dl
            z[1] = dld
            z[2] = 0.0 if kind == EV_SLIP_END else v_end
            if want_jac:
                # The displacement's gradient at fixed ends (v = 0 at event ends).
                gx0 = -kk * (e11 - 1.0)
                gx1 = -kk * (e12 - tau)
                for col in range(3):
                    grad[0, col] += gx0 * jac[0, col] + gx1 * jac[1, col] + tau * jac[2, col]
                _mat_left(jac, e11, e12, 0.0, e21, e22, 0.0,
                          -kk * e21, -kk * (e22 - 1.0), 1.0)
                # The slip time's gradient: end time minus start time.
                which = 1 if s > 0 else 2
                grad[which, 0] -= ds0
                grad[which, 1] -= ds1
                grad[which, 2] -= ds2
                ds0 = 0.0
                ds1 = 0.0
                ds2 = 0.0
                if kind == EV_SLIP_END:
                    v_rate = _slip_acceleration(
                        structure, row, a, cwe,
                        _mode_acceleration(structure, row, cwe, dl, dld))
                    if v_rate != 0.0:
                        ds0 = -jac[2, 0] / v_rate
                        ds1 = -jac[2, 1] / v_rate
                        ds2 = -jac[2, 2] / v_rate
                    grad[which, 0] += ds0
                    grad[which, 1] += ds1
                    grad[which, 2] += ds2
        t = te
        t_trig = te
        cw = cwe
        sw = swe
        if kind == 0:
            break
        # An event at te: decide the next contact mode and apply the saltation.
        r_p, r_m, acc0 = _stick_releases(structure, a, cwe, dl, dld)
        if mode == 0:
            new = 1 if kind == EV_RELEASE_FORWARD else -1
            jn = 1 if new > 0 else 2
            if table[jn, M_D] <= 0.0:
                acc[A_EVENTS] += events
                return RUN_PARADOX
            acc[A_SLIPS] += 1.0
            if want_jac:
                rown = table[jn]
                accn = _mode_acceleration(structure, rown, cwe, dl, dld)
                vdot = _slip_acceleration(structure, rown, a, cwe, accn)
                m = structure[MASS_RATIO]
                kap = -m * (new * structure[SIN_ALPHA]
                            + structure[STATIC_FRICTION] * structure[COS_ALPHA])
                # Gradient of s tau - cs n in (delta, delta'); time rate along the stick.
                g_d = -kap * structure[STIFFNESS]
                g_dd = -kap * structure[DAMPING]
                swe2 = swe
                ddd_rate = (-a * omega * swe2 * structure[COS_ALPHA]
                            - structure[DAMPING] * acc0 - structure[STIFFNESS] * dld)
                rate = kap * ddd_rate - structure[STATIC_FRICTION] * a * omega * swe2
                if rate > 0.0:
                    q = 1.0 / rate
                    ds0 = -(g_d * jac[0, 0] + g_dd * jac[1, 0]) * q
                    ds1 = -(g_d * jac[0, 1] + g_dd * jac[1, 1]) * q
                    ds2 = -(g_d * jac[0, 2] + g_dd * jac[1, 2]) * q
                    jump = accn - acc0
                    _mat_left(jac, 1.0, 0.0, 0.0,
                              jump * g_d * q, 1.0 + jump * g_dd * q, 0.0,
                              vdot * g_d * q, vdot * g_dd * q, 1.0)
            mode = new
        else:
            s = int(row[M_SIGN])
            accm = _mode_acceleration(structure, row, cwe, dl, dld)
            vdot_minus = _slip_acceleration(structure, row, a, cwe, accm)
            if (s > 0 and r_m > 0.0) or (s < 0 and r_p > 0.0):
                new = -s
            else:
                new = 0
            if new != 0:
                jn = 1 if new > 0 else 2
                if table[jn, M_D] <= 0.0:
                    acc[A_EVENTS] += events
                    return RUN_PARADOX
                acc[A_SLIPS] += 1.0
                rown = table[jn]
                accp = _mode_acceleration(structure, rown, cwe, dl, dld)
                vdot_plus = _slip_acceleration(structure, rown, a, cwe, accp)
            else:
                accp = acc0
                vdot_plus = 0.0
            if want_jac and vdot_minus != 0.0:
                q = 1.0 / vdot_minus
                _mat_left(jac, 1.0, 0.0, 0.0,
                          0.0, 1.0, (accp - accm) * q,
                          0.0, 0.0, vdot_plus * q)
            if new == 0 and tau == 0.0:
                # The slip could not move: do not release it again at once.
                t_from = te + NUDGE * TWO_PI / omega
            mode = new
    acc[A_EVENTS] += events
    return RUN_OK


@njit(cache=True, nogil=True, error_model="numpy")
def _solve3(m, r, out):
    """Solve ``m x = r`` (3x3, partial pivoting) into ``out``; False when singular."""
    a = m.copy()
    b = r.copy()
    for col in range(3):
        piv = col
        for i in range(col + 1, 3):
            if abs(a[i, col]) > abs(a[piv, col]):
                piv = i
        if a[piv, col] == 0.0 or not math.isfinite(a[piv, col]):
            return False
        if piv != col:
            for jj in range(3):
                a[col, jj], a[piv, jj] = a[piv, jj], a[col, jj]
            b[col], b[piv] = b[piv], b[col]
        for i in range(col + 1, 3):
            f = a[i, col] / a[col, col]
            for jj in range(col, 3):
                a[i, jj] -= f * a[col, jj]
            b[i] -= f * b[col]
    for i in range(2, -1, -1):
        x = b[i]
        for jj in range(i + 1, 3):
            x -= a[i, jj] * out[jj]
        out[i] = x / a[i, i]
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def spectral_radius(jac):
    """Largest modulus of the eigenvalues of the 3x3 ``jac`` (the Floquet multipliers)."""
    if not np.all(np.isfinite(jac)):
        return np.inf
    if jac[2, 0] == 0.0 and jac[2, 1] == 0.0:
        # A stick on the orbit: v is reset, one multiplier is jac[2, 2] (0).
        half = 0.5 * (jac[0, 0] + jac[1, 1])
        det = jac[0, 0] * jac[1, 1] - jac[0, 1] * jac[1, 0]
        disc = half * half - det
        if disc < 0.0:
            rho = math.sqrt(max(det, 0.0))
        else:
            root = math.sqrt(disc)
            rho = max(abs(half + root), abs(half - root))
        return max(rho, abs(jac[2, 2]))
    values = np.linalg.eigvals(jac.astype(np.complex128))
    return np.max(np.abs(values))


@njit(cache=True, nogil=True, error_model="numpy")
def _newton(structure, table, omega, a, z, periods, scales, max_events, jac, acc, work,
            grad, section):
    """Newton's method on ``P^periods(z) - z`` from ``z`` (updated in place), ``P`` the
    period map of the Poincare section at time ``section`` [s] (``z`` is the state there).

    Iterates within ~1e-6 of the orbit (their previous Newton step and residual were
    below ``LIFT_WATCH`` with an unchanged sequence of events; Newton converges
    quadratically) are watched for lift-off.

    Returns
    -------
    flag, converged
        ``RUN_LIFT_OFF`` when a watched iterate leaves the table; else the last
        stretch's flag and whether ``z`` is the fixed point. ``jac`` then holds the
        Jacobian of ``P^periods`` at the last iterate and ``acc`` the orbit's
        statistics, moved to the fixed point along their gradients (``grad``) by the
        last Newton step: what is left is of the order of the step's square.
    """
    span = periods * TWO_PI / omega
    previous = np.inf
    # Watch the next pass for lift-off: the last step and residual were small and the
    # events unchanged, so the iterate is within ~1e-6 of the orbit.
    watch = False
    # Events and slips of the previous pass: a step is only trusted as the last one
    # when the pass it came from has the same sequence of events.
    last_events = -1.0
    last_slips = -1.0
    step = np.empty(3)
    residual = np.empty(3)
    for _ in range(MAX_NEWTON):
        for i in range(3):
            work[i] = z[i]
            for jj in range(3):
                jac[i, jj] = 1.0 if i == jj else 0.0
                grad[i, jj] = 0.0
        acc[:] = 0.0
        margin = 0.0 if watch else -1.0
        flag = run(structure, table, omega, a, work, section, section + span, jac, True,
                   margin, max_events, acc, grad)
        if flag == RUN_LIFT_OFF:
            return RUN_LIFT_OFF, False
        if flag != RUN_OK:
            return flag, False
        res = 0.0
        for i in range(3):
            residual[i] = z[i] - work[i]
            res = max(res, abs(residual[i]) / scales[i])
        if res > previous and res > NEWTON_TOLERANCE:
            # Diverging (an event appeared or vanished): take the map's step instead.
            for i in range(3):
                z[i] = work[i]
            previous = np.inf
            watch = False
            last_events = -1.0
            continue
        for i in range(3):
            jac[i, i] -= 1.0
        solved = _solve3(jac, residual, step)
        for i in range(3):
            jac[i, i] += 1.0
        if not solved:
            for i in range(3):
                z[i] = work[i]
            watch = False
            last_events = -1.0
            continue
        size = 0.0
        for i in range(3):
            size = max(size, abs(step[i]) / scales[i])
        # A sliver of slip (far shorter than a period) means a kink of the map is near:
        # its linearization does not reach across, so no step is trusted as the last.
        sliver = 0.0 < acc[A_SHORTEST] < SLIVER * span
        same_events = (acc[A_EVENTS] == last_events and acc[A_SLIPS] == last_slips
                       and not sliver)
        last_events = acc[A_EVENTS]
        last_slips = acc[A_SLIPS]
        done = res <= NEWTON_TOLERANCE or (
            same_events and (size <= NEWTON_STEP
                             or (res <= LOOSE_TOLERANCE and res >= 0.5 * previous)))
        again = done and margin < 0.0
        if again:
            # Converged before any pass was watched for lift-off: one more.
            done = False
        for i in range(3):
            z[i] += step[i]
        if acc[A_START_SLIVER] != 0.0 and not done:
            # The pass began with a sliver of slip: the orbit sticks across phase 0 and
            # Newton approaches it through states just off the stick (the map has a
            # kink at v = 0, which its linearization does not reach across): stick.
            z[2] = 0.0
        if done:
            # Move the statistics to the fixed point along their gradients.
            for i in range(3):
                acc[A_DISPLACEMENT] += grad[0, i] * step[i]
                acc[A_FORWARD] += grad[1, i] * step[i]
                acc[A_BACKWARD] += grad[2, i] * step[i]
            return RUN_OK, True
        previous = res
        watch = again or (same_events and size <= LIFT_WATCH and res <= LIFT_WATCH)
    return RUN_OK, False


@njit(cache=True, nogil=True, error_model="numpy")
def _scales(structure, table, omega, a):
    """Natural sizes of ``(delta, delta', v)`` for residuals [m, m s-1, m s-1]."""
    amp = math.hypot(table[0, M_PRE], table[0, M_PIM])
    k = structure[STIFFNESS]
    size = max(amp, a / (k + omega * omega), 1e-300)
    return size, size * max(omega, math.sqrt(k)), max(a / omega, 1e-300)


@njit(cache=True, nogil=True, error_model="numpy")
def _start(table, omega, t, z, factor):
    """Rest at ``t`` with the mode on ``factor`` times its steady stick response."""
    cw = math.cos(omega * t)
    sw = math.sin(omega * t)
    dp, dpd, _, _ = _particular(table[0], omega, cw, sw)
    z[0] = factor * dp
    z[1] = factor * dpd
    z[2] = 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def _is_static(structure, table, omega, a):
    """Neither release can happen with the mode on its steady response."""
    w2 = omega * omega
    m = structure[MASS_RATIO]
    ca = structure[COS_ALPHA]
    sa = structure[SIN_ALPHA]
    cs = structure[STATIC_FRICTION]
    pr = table[0, M_PRE]
    pi = table[0, M_PIM]
    level = cs * structure[GRAVITY] * (1.0 + 8.0 * EPS)
    for sign in (1.0, -1.0):
        kappa = -m * (sign * sa + cs * ca)
        if math.hypot(-kappa * w2 * pr + cs * a, -kappa * w2 * pi) > level:
            return False
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _cycle(structure, table, omega, a, z, periods, section, scales, max_events, jac, acc,
           work, grad):
    """Newton's method for a stable cycle of ``periods`` drive periods from ``z``, the state
    at time ``section`` [s], with the cycle's own (minimal) period.

    Returns
    -------
    int
        The cycle's minimal period when it is found (``z`` its state at ``section``,
        ``jac`` and ``acc`` of one pass around it); 0 when not; -1 when an iterate near
        it leaves the table (lift-off).
    """
    flag, converged = _newton(structure, table, omega, a, z, periods, scales, max_events,
                              jac, acc, work, grad, section)
    if flag == RUN_LIFT_OFF:
        return -1
    if not converged or spectral_radius(jac) >= 1.0 + STABILITY_MARGIN:
        return 0
    period = TWO_PI / omega
    # Report the orbit's own period, not a multiple that closed first.
    for shorter in range(1, periods):
        if periods % shorter:
            continue
        for i in range(3):
            work[i] = z[i]
        flag = run(structure, table, omega, a, work, section, section + shorter * period,
                   jac, False, -1.0, max_events, acc, grad)
        gap = 0.0
        for i in range(3):
            gap = max(gap, abs(work[i] - z[i]) / scales[i])
        if flag == RUN_OK and gap <= CYCLE_DETECTION * 1e-6:
            flag, converged = _newton(structure, table, omega, a, z, shorter, scales,
                                      max_events, jac, acc, work, grad, section)
            if flag == RUN_LIFT_OFF:
                return -1
            if converged:
                return shorter
    # Statistics of the full cycle (the checks above overwrote them).
    flag, converged = _newton(structure, table, omega, a, z, periods, scales, max_events,
                              jac, acc, work, grad, section)
    if flag == RUN_LIFT_OFF:
        return -1
    return periods


@njit(cache=True, nogil=True, error_model="numpy")
def _orbit(structure, table, omega, a, z, t_start, max_events, max_iterations, scales,
           jac, acc, work, history, grad):
    """Periodic orbit reached from state ``z`` at ``t_start`` (in the first period).

    Returns
    -------
    status, reason, periods
        ``periods`` > 0 and ``z`` the orbit's state at phase 0 when found; ``jac``
        and ``acc`` then belong to one pass around it.
    """
    period = TWO_PI / omega
    acc[:] = 0.0
    flag = RUN_OK
    if t_start != 0.0:
        flag = run(structure, table, omega, a, z, t_start, period, jac, False, -1.0,
                   max_events, acc, grad)
    if flag == RUN_PARADOX:
        return FRICTION_PARADOX, REASON_NONE, 0
    if flag == RUN_BUDGET:
        return NOT_CONVERGED, REASON_EVENT_BUDGET, 0
    guess = z.copy()
    flag, converged = _newton(structure, table, omega, a, z, 1, scales, max_events, jac,
                              acc, work, grad, 0.0)
    if flag == RUN_LIFT_OFF:
        return LIFT_OFF, REASON_NONE, 0
    if converged and spectral_radius(jac) < 1.0 + STABILITY_MARGIN:
        return STICK_SLIP, REASON_NONE, 1
    if flag == RUN_PARADOX:
        return FRICTION_PARADOX, REASON_NONE, 0
    # No stable fixed point near: iterate the map from the start and look for a cycle
    # of up to MAX_PERIOD periods, then solve for it by Newton.
    for i in range(3):
        z[i] = guess[i]
    tried = np.full(MAX_PERIOD + 1, np.inf)
    candidate = np.empty(3)
    for iteration in range(max_iterations):
        slot = iteration % MAX_PERIOD
        for i in range(3):
            history[slot, i] = z[i]
        # Past a burn-in the iterates trace the attractor: one that leaves the table is
        # outside the model (LIFT_OFF), converged or not.
        flag = run(structure, table, omega, a, z, 0.0, period, jac, False,
                   0.0 if iteration >= BURN_IN else -1.0, max_events, acc, grad)
        if flag == RUN_PARADOX:
            return FRICTION_PARADOX, REASON_NONE, 0
        if flag == RUN_LIFT_OFF:
            return LIFT_OFF, REASON_NONE, 0
        if flag != RUN_OK:
            return NOT_CONVERGED, REASON_EVENT_BUDGET, 0
        for periods in range(1, min(iteration + 1, MAX_PERIOD) + 1):
            back = (iteration - periods + 1) % MAX_PERIOD
            gap = 0.0
            for i in range(3):
                gap = max(gap, abs(z[i] - history[back, i]) / scales[i])
            if gap < CYCLE_DETECTION and gap < 0.5 * tried[periods]:
                tried[periods] = gap
                for shifted in range(2):
                    for i in range(3):
                        candidate[i] = history[back, i]
                    section = 0.0
                    if shifted:
                        # An orbit can cross phase 0 in a sliver of slip: the phase-0 map
                        # then has a kink at the fixed point, which Newton cannot cross (it
                        # takes the sliver for an approach to a stick). Another section of
                        # the same orbit has no such kink.
                        section = SECTION_SHIFT * period
                        flag = run(structure, table, omega, a, candidate, 0.0, section, jac,
                                   False, -1.0, max_events, acc, grad)
                        if flag != RUN_OK:
                            break
                    found = _cycle(structure, table, omega, a, candidate, periods, section,
                                   scales, max_events, jac, acc, work, grad)
                    if found < 0:
                        return LIFT_OFF, REASON_NONE, 0
                    if found > 0:
                        if section != 0.0:
                            # The orbit's state at phase 0, what is reported (the statistics
                            # of a whole number of periods do not depend on the section).
                            spare = np.zeros(N_ACC)
                            run(structure, table, omega, a, candidate, section, period, jac,
                                False, -1.0, max_events, spare, grad)
                        for i in range(3):
                            z[i] = candidate[i]
                        return STICK_SLIP, REASON_NONE, found
                break
    return NOT_CONVERGED, REASON_NO_PERIODIC_ORBIT, 0


@njit(cache=True, nogil=True, error_model="numpy")
def solve_point(structure, omega, a, lifted, max_events, max_iterations, t_start, factor,
                out):
    """Steady orbit at one drive point; ``out`` receives
    ``(status, reason, velocity, slips, forward, backward, period, multiplier, z0, z1, z2)``.

    ``t_start`` [s] and ``factor`` choose the starting state (rest, mode on ``factor``
    times its steady response).
    """
    table = np.zeros((3, N_MODE))
    # The stick's row decides a static point; the slips' rows are needed only beyond.
    mode_row(structure, omega, a, table, 0)
    out[:] = np.nan
    out[1] = REASON_NONE
    out[6] = 0.0
    if _is_static(structure, table, omega, a):
        out[0] = LIFT_OFF if lifted else STATIC
        if not lifted:
            out[2] = 0.0
            out[3] = 0.0
            out[4] = 0.0
            out[5] = 0.0
            # The orbit is the mode's steady response: perturbations decay with it.
            _, _, e11, e12, e21, e22 = _homogeneous(table[0], TWO_PI / omega, 0.0, 0.0)
            free = np.zeros((3, 3))
            free[0, 0] = e11
            free[0, 1] = e12
            free[1, 0] = e21
            free[1, 1] = e22
            out[7] = spectral_radius(free)
        return
    mode_row(structure, omega, a, table, 1)
    mode_row(structure, omega, a, table, 2)
    scales = np.empty(3)
    scales[0], scales[1], scales[2] = _scales(structure, table, omega, a)
    z = np.empty(3)
    _start(table, omega, t_start, z, factor)
    jac = np.empty((3, 3))
    grad = np.empty((3, 3))
    acc = np.zeros(N_ACC)
    work = np.empty(3)
    history = np.empty((MAX_PERIOD, 3))
    status, reason, periods = _orbit(structure, table, omega, a, z, t_start, max_events,
                                     max_iterations, scales, jac, acc, work, history, grad)
    out[0] = status
    out[1] = reason
    if periods == 0:
        return
    span = periods * TWO_PI / omega
    out[0] = STICK_SLIP if acc[A_STICK] > 0.0 else CONTINUOUS_SLIDING
    out[2] = acc[A_DISPLACEMENT] / span
    out[3] = acc[A_SLIPS] / periods
    out[4] = acc[A_FORWARD] / span
    out[5] = acc[A_BACKWARD] / span
    out[6] = periods
    out[7] = spectral_radius(jac)
    out[8] = z[0]
    out[9] = z[1]
    out[10] = z[2]


N_OUT = 11


@njit(cache=True, nogil=True, error_model="numpy")
def _solve_into(i, structure, omega, a, lifted, max_events, max_iterations, out):
    solve_point(structure, omega[i], a[i], lifted[i], max_events, max_iterations, 0.0, 1.0,
                out[i])


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _solve_points(structure, omega, a, lifted, max_events, max_iterations, out):
    """Fill ``out`` (n x N_OUT) in parallel over points, interleaved (see steady.py)."""
    n = omega.shape[0]
    lanes = min(n, 256)
    for lane in prange(lanes):
        for i in range(lane, n, lanes):
            _solve_into(i, structure, omega, a, lifted, max_events, max_iterations, out)


@njit(cache=True, nogil=True, error_model="numpy")
def _solve_points_serial(structure, omega, a, lifted, max_events, max_iterations, out):
    """Same as :func:`_solve_points` on one thread."""
    for i in range(omega.shape[0]):
        _solve_into(i, structure, omega, a, lifted, max_events, max_iterations, out)


# Starting states of the multistability check: rest at these drive phases [periods]
# with the mode on these multiples of its steady response.
START_PHASES = (0.0, 0.25, 0.5, 0.75)
START_FACTORS = (1.0, 0.0, 2.0)
# Two orbits are the same attractor when their periods agree and their mean velocities
# agree to this fraction of the velocity scale a / w.
SAME_ORBIT = 1e-9


@njit(cache=True, nogil=True, error_model="numpy")
def attractors_point(structure, omega, a, lifted, max_events, max_iterations, out):
    """Distinct stable orbits reached from the starting states above.

    ``out`` receives ``(count, spread, starts_converged)``: the number of distinct
    orbits (LIFT_OFF or FRICTION_PARADOX outcomes count as one outcome each), the
    spread of their mean velocities [m s-1], and how many starts reached an outcome.
    Starts off the table (``n < 0``) are skipped.
    """
    row = np.empty(N_OUT)
    n_starts = len(START_PHASES) * len(START_FACTORS)
    velocities = np.empty(n_starts)
    periods = np.empty(n_starts)
    count = 0
    converged = 0
    others = 0  # bit 1: lift-off seen, bit 2: paradox seen
    scale = a / omega
    table = np.zeros((3, N_MODE))
    mode_table(structure, omega, a, table)
    start = np.empty(3)
    for phase in START_PHASES:
        for factor in START_FACTORS:
            t_start = phase * TWO_PI / omega
            _start(table, omega, t_start, start, factor)
            _, _, acc0 = _stick_releases(structure, a, math.cos(omega * t_start), start[0],
                                         start[1])
            if (structure[GRAVITY] - a * math.cos(omega * t_start)
                    + structure[MASS_RATIO] * structure[COS_ALPHA] * acc0) < 0.0:
                # A start off the table is no state of the model.
                continue
            solve_point(structure, omega, a, lifted, max_events, max_iterations,
                        t_start, factor, row)
            status = int(row[0])
            if status == STATIC:
                out[0] = 1.0
                out[1] = 0.0
                out[2] = n_starts
                return
            if status == NOT_CONVERGED:
                continue
            converged += 1
            if status == LIFT_OFF:
                others |= 1
                continue
            if status == FRICTION_PARADOX:
                others |= 2
                continue
            new = True
            for i in range(count):
                if periods[i] == row[6] and abs(velocities[i] - row[2]) <= SAME_ORBIT * scale:
                    new = False
                    break
            if new:
                velocities[count] = row[2]
                periods[count] = row[6]
                count += 1
    spread = 0.0
    if count > 0:
        spread = np.max(velocities[:count]) - np.min(velocities[:count])
    out[0] = count + (others & 1) + ((others >> 1) & 1)
    out[1] = spread
    out[2] = converged


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _attractors_points(structure, omega, a, lifted, max_events, max_iterations, out):
    """Fill ``out`` (n x 3) in parallel over points."""
    n = omega.shape[0]
    lanes = min(n, 256)
    for lane in prange(lanes):
        for i in range(lane, n, lanes):
            attractors_point(structure, omega[i], a[i], lifted[i], max_events,
                             max_iterations, out[i])


@njit(cache=True, nogil=True, error_model="numpy")
def _attractors_points_serial(structure, omega, a, lifted, max_events, max_iterations, out):
    """Same as :func:`_attractors_points` on one thread."""
    for i in range(omega.shape[0]):
        attractors_point(structure, omega[i], a[i], lifted[i], max_events, max_iterations,
                         out[i])
