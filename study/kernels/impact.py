"""The impact law of the base on the table, in closed form (docs/theory/flight.md).

Per unit total mass, base velocity ``V = (v, h')`` (horizontal, and vertical relative to
the table, whose velocity does not jump), mode velocity ``delta'`` along
``e = (sin(alpha), cos(alpha))``. The contact impulse ``P = (Px, Pz)`` acts on the base
only; the mode's generalized momentum ``M (e.V + delta')`` is continuous, so::

    dV = W P,   W = I + mu e e^T,   mu = M / (1 - M),   d(delta') = -e.dV

Friction follows Darboux-Keller along the normal impulse ``p = Pz >= 0``. While the base
slides with sign ``s``, ``dPx/dp = -s ck`` and::

    dv/dp  = W_xz - s ck W_xx = (M sa ca - s ck (1 - M ca^2)) / (1 - M)
    dh'/dp = W_zz - s ck W_xz = D_s / (1 - M),   D_s = 1 - M sa (sa + s ck ca)

(``sa``, ``ca`` the sine and cosine of alpha). ``D_s <= 0`` is Painleve's paradox: the
normal velocity does not grow with the normal impulse, the impact has no solution
(:data:`~study.model.codes.IMPACT_PARADOX`). Once ``v = 0`` (from the start or when a
slide stops) the base stays stuck if ``|W_xz| <= cs W_xx``; then ``dPx/dp =
-W_xz / W_xx = -M sa ca / (1 - M ca^2)`` and ``dh'/dp = det W / W_xx = 1 / (1 - M ca^2)
> 0``. Otherwise it slides on with ``s' = sign(W_xz)`` (which is ``-s`` after a stop:
a slide that stops cannot restart forwards, since ``s W_xz < ck W_xx <= cs W_xx``).
The impulse path is therefore piecewise linear with at most one switch, and the impact
ends when ``h' = -e h'_minus`` (Newton's law; ``e`` the restitution, 0 plastic).

Every rate is written with the factor ``1 - M`` taken out, so nothing grows like
``1 / (1 - M)`` near ``M = 1`` except the impulses' own scale: the normal impulse of a
plastic impact is about ``(1 - M) |h'_minus|`` there (the base's own mass).
"""

from __future__ import annotations

from numba import njit

from study.kernels.structure_vector import (
    COS_ALPHA,
    KINETIC_FRICTION,
    MASS_RATIO,
    RESTITUTION,
    SIN_ALPHA,
    STATIC_FRICTION,
)
from study.model.codes import IMPACT_PARADOX, IMPACT_SLIP, IMPACT_STICK

#: The slots of an impact's ``out`` array, in order, with their units.
IMPACT_ENTRIES = (
    ("delta_rate", "m s-1", "mode velocity delta' after the impact"),
    ("velocity", "m s-1", "base's horizontal velocity v after the impact"),
    ("gap_rate", "m s-1", "base's vertical velocity relative to the table h' after"),
    ("normal_impulse", "m s-1", "normal impulse Pz per unit total mass"),
    ("tangential_impulse", "m s-1", "tangential impulse Px per unit total mass"),
    ("stop_impulse", "m s-1",
     "normal impulse at which the base came to rest tangentially (NaN if it never did)"),
    ("outcome", "1", "IMPACT_STICK, IMPACT_SLIP or IMPACT_PARADOX (study.model.codes)"),
)
_SLOTS = tuple(name for name, _, _ in IMPACT_ENTRIES)

# Numba reads module-level integers as compile-time constants.
IMPACT_DELTA_RATE = _SLOTS.index("delta_rate")
IMPACT_VELOCITY = _SLOTS.index("velocity")
IMPACT_GAP_RATE = _SLOTS.index("gap_rate")
IMPACT_NORMAL_IMPULSE = _SLOTS.index("normal_impulse")
IMPACT_TANGENTIAL_IMPULSE = _SLOTS.index("tangential_impulse")
IMPACT_STOP_IMPULSE = _SLOTS.index("stop_impulse")
IMPACT_OUTCOME = _SLOTS.index("outcome")
#: Length of an impact's ``out`` array.
IMPACT_SIZE = len(IMPACT_ENTRIES)

#: Rows and columns of :func:`impact_jacobian`'s 3x3 matrix: (delta', v, h').
JACOBIAN_DELTA_RATE = 0
JACOBIAN_VELOCITY = 1
JACOBIAN_GAP_RATE = 2


@njit(cache=True, nogil=True, error_model="numpy")
def impulse_path(structure, velocity, gap_rate):
    """The piecewise linear impulse path of an impact (Darboux-Keller, closed form).

    Parameters
    ----------
    structure : ndarray
        The structure vector (:mod:`study.kernels.structure_vector`), ``M < 1``.
    velocity : float
        Base's horizontal velocity before the impact [m s-1].
    gap_rate : float
        Base's vertical velocity relative to the table before the impact [m s-1], ``<= 0``.

    Returns
    -------
    tuple
        ``(code, stopped, p_stop, p_end, rate_x1, rate_v1, rate_h1, rate_x2, rate_v2,
        rate_h2)``: the impact's outcome code; whether the base is at rest
        tangentially at ``p_stop`` (from the start, or its slide stopped there); the
        normal impulse [m s-1] where the first phase ends (``p_end`` when the base
        slides throughout) and where the impact ends; the
        rates ``dPx/dp`` [1], ``dv/dp`` [1], ``dh'/dp`` [1] of the first phase and of
        the second. The first phase is a slide (empty when the base starts at rest);
        the second, if any, starts at ``v = 0`` and is a stick (code IMPACT_STICK) or a
        slide the other way. On IMPACT_PARADOX the impulses are NaN.
    """
    m = structure[MASS_RATIO]
    sa = structure[SIN_ALPHA]
    ca = structure[COS_ALPHA]
    cs = structure[STATIC_FRICTION]
    ck = structure[KINETIC_FRICTION]
    restitution = structure[RESTITUTION]
    one_m = 1.0 - m
    # (1 - M) W: the entries of the impact matrix with the factor 1 / (1 - M) taken out.
    dxx = 1.0 - m * ca * ca
    dxz = m * sa * ca
    nan = float("nan")
    depth = -(1.0 + restitution) * gap_rate  # the rise of h' the impact must make
    p_stop = 0.0
    rate_x1 = 0.0
    rate_v1 = 0.0
    rate_h1 = 1.0
    if velocity != 0.0:
        s = 1.0 if velocity > 0.0 else -1.0
        d1 = 1.0 - m * sa * (sa + s * ck * ca)  # D_s as the contact modes write it
        if d1 <= 0.0:
            return IMPACT_PARADOX, False, nan, nan, nan, nan, nan, nan, nan, nan
        rate_x1 = -s * ck
        rate_v1 = (dxz - s * ck * dxx) / one_m
        rate_h1 = d1 / one_m
        p_end1 = depth * one_m / d1
        p_stop = p_end1
        if s * rate_v1 < 0.0:
            p_stop = -velocity / rate_v1
        if p_stop >= p_end1:  # slides throughout, ends sliding
            return (IMPACT_SLIP, False, p_end1, p_end1, rate_x1, rate_v1, rate_h1, 0.0, 0.0,
                    0.0)
    # At rest tangentially from p_stop on, with the rise depth - rate_h1 p_stop left.
    left = depth - rate_h1 * p_stop
    if abs(dxz) <= cs * dxx:
        rate_h2 = 1.0 / dxx
        return (IMPACT_STICK, True, p_stop, p_stop + left * dxx, rate_x1, rate_v1, rate_h1,
                -dxz / dxx, 0.0, rate_h2)
    s2 = 1.0 if dxz > 0.0 else -1.0
    d2 = 1.0 - m * sa * (sa + s2 * ck * ca)
    if d2 <= 0.0:
        return IMPACT_PARADOX, True, nan, nan, nan, nan, nan, nan, nan, nan
    return (IMPACT_SLIP, True, p_stop, p_stop + left * one_m / d2, rate_x1, rate_v1, rate_h1,
            -s2 * ck, (dxz - s2 * ck * dxx) / one_m, d2 / one_m)


@njit(cache=True, nogil=True, error_model="numpy")
def impact(structure, delta_rate, velocity, gap_rate, out):
    """Apply the impact law to one state just before an impact.

    Parameters
    ----------
    structure : ndarray
        The structure vector (:mod:`study.kernels.structure_vector`), ``M < 1``.
    delta_rate : float
        Mode velocity delta' before the impact [m s-1].
    velocity : float
        Base's horizontal velocity v before the impact [m s-1].
    gap_rate : float
        Base's vertical velocity relative to the table h' before the impact [m s-1];
        ``< 0`` for an impact (0 gives no impulse).
    out : ndarray
        Float64 array of :data:`IMPACT_SIZE`, filled by slot (:data:`IMPACT_ENTRIES`):
        the state after the impact, the impulses and the outcome; NaN (but the
        outcome) on IMPACT_PARADOX.

    Returns
    -------
    int
        IMPACT_STICK when the base ends at rest tangentially, IMPACT_SLIP when it ends
        sliding, IMPACT_PARADOX when a slide that arises has ``D_s <= 0``.
    """
    (code, stopped, p_stop, p_end, rate_x1, rate_v1, _rate_h1, rate_x2, rate_v2,
     _rate_h2) = impulse_path(structure, velocity, gap_rate)
    out[IMPACT_OUTCOME] = code
    if code == IMPACT_PARADOX:
        for slot in range(IMPACT_OUTCOME):
            out[slot] = float("nan")
        return code
    p2 = p_end - p_stop
    if stopped:
        v_after = rate_v2 * p2  # from v = 0 at p_stop (0 when it stays stuck)
        out[IMPACT_STOP_IMPULSE] = p_stop
    else:
        v_after = velocity + rate_v1 * p_end
        out[IMPACT_STOP_IMPULSE] = float("nan")
    gap_after = -structure[RESTITUTION] * gap_rate
    dv = v_after - velocity
    dh = gap_after - gap_rate
    out[IMPACT_DELTA_RATE] = delta_rate - (structure[SIN_ALPHA] * dv + structure[COS_ALPHA] * dh)
    out[IMPACT_VELOCITY] = v_after
    out[IMPACT_GAP_RATE] = gap_after
    out[IMPACT_NORMAL_IMPULSE] = p_end
    out[IMPACT_TANGENTIAL_IMPULSE] = rate_x1 * p_stop + rate_x2 * p2
    return code


@njit(cache=True, nogil=True, error_model="numpy")
def impact_jacobian(structure, delta_rate, velocity, gap_rate, jac):
    """The 3x3 Jacobian of ``(delta', v, h')`` after an impact with respect to
    ``(delta', v, h')`` before it, on the branch of the impulse path the state takes.

    The law is linear on each branch (the impulse path's phases fixed), so this is the
    impact's part of a saltation matrix; the impact's time and the flows before and
    after are the caller's. Rows and columns are :data:`JACOBIAN_DELTA_RATE`,
    :data:`JACOBIAN_VELOCITY`, :data:`JACOBIAN_GAP_RATE`. A base at rest before the
    impact takes the branch it stays on (the stick's, or the slide's from rest).

    Parameters
    ----------
    structure : ndarray
        The structure vector (:mod:`study.kernels.structure_vector`), ``M < 1``.
    delta_rate, velocity, gap_rate : float
        delta', v and h' before the impact [m s-1] (as :func:`impact`).
    jac : ndarray
        Float64 3x3 array, filled with the Jacobian [1]; NaN on IMPACT_PARADOX.

    Returns
    -------
    int
        The impact's outcome, as :func:`impact` returns it.
    """
    (code, stopped, _p_stop, _p_end, _rate_x1, rate_v1, rate_h1, _rate_x2, rate_v2,
     rate_h2) = impulse_path(structure, velocity, gap_rate)
    if code == IMPACT_PARADOX:
        for row in range(3):
            for column in range(3):
                jac[row, column] = float("nan")
        return code
    restitution = structure[RESTITUTION]
    sa = structure[SIN_ALPHA]
    ca = structure[COS_ALPHA]
    # v_after = dv_dv v + dv_dh h' (linear on the branch); h'_after = -e h'.
    if not stopped:  # slides throughout: v + rate_v1 (1 + e) (-h') / rate_h1
        dv_dv = 1.0
        dv_dh = -(1.0 + restitution) * rate_v1 / rate_h1
    elif code == IMPACT_STICK:
        dv_dv = 0.0
        dv_dh = 0.0
    elif velocity != 0.0:  # slide, stop at p_stop = -v / rate_v1, slide back
        dv_dv = rate_v2 * rate_h1 / (rate_h2 * rate_v1)
        dv_dh = -(1.0 + restitution) * rate_v2 / rate_h2
    else:  # slides from rest throughout: rate_v2 (1 + e) (-h') / rate_h2
        dv_dv = 1.0
        dv_dh = -(1.0 + restitution) * rate_v2 / rate_h2
    # delta'_after = delta' - sa (v_after - v) - ca (h'_after - h')
    jac[JACOBIAN_DELTA_RATE, JACOBIAN_DELTA_RATE] = 1.0
    jac[JACOBIAN_DELTA_RATE, JACOBIAN_VELOCITY] = -sa * (dv_dv - 1.0)
    jac[JACOBIAN_DELTA_RATE, JACOBIAN_GAP_RATE] = -sa * dv_dh + ca * (1.0 + restitution)
    jac[JACOBIAN_VELOCITY, JACOBIAN_DELTA_RATE] = 0.0
    jac[JACOBIAN_VELOCITY, JACOBIAN_VELOCITY] = dv_dv
    jac[JACOBIAN_VELOCITY, JACOBIAN_GAP_RATE] = dv_dh
    jac[JACOBIAN_GAP_RATE, JACOBIAN_DELTA_RATE] = 0.0
    jac[JACOBIAN_GAP_RATE, JACOBIAN_VELOCITY] = 0.0
    jac[JACOBIAN_GAP_RATE, JACOBIAN_GAP_RATE] = -restitution
    return code


@njit(cache=True, nogil=True, error_model="numpy")
def impact_rows(structure, delta_rate, velocity, gap_rate, out):
    """:func:`impact` on flat arrays of states: row ``i`` of ``out`` (n x
    :data:`IMPACT_SIZE`) receives the impact of state ``i`` (units as :func:`impact`)."""
    for i in range(delta_rate.size):
        impact(structure, delta_rate[i], velocity[i], gap_rate[i], out[i])
