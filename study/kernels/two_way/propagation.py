"""The closed-form flow within one contact mode, and the forces at a state.

Between events the mode is a particular harmonic (plus a constant) and a damped
homogeneous part propagated by the 2x2 matrix exponential; the stick's release
functions and the modes' accelerations decide and linearize the events.
"""

from __future__ import annotations

import math

from numba import njit

from study.kernels.structure_vector import (
    COS_ALPHA,
    DAMPING,
    GRAVITY,
    KINETIC_FRICTION,
    MASS_RATIO,
    SIN_ALPHA,
    STATIC_FRICTION,
    STIFFNESS,
)
from study.kernels.two_way.modes import (
    M_D,
    M_FORCE,
    M_GCONST,
    M_K,
    M_KD,
    M_NU2,
    M_OFFSET,
    M_PIM,
    M_PRE,
    M_SIGMA,
    M_SIGN,
)


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
def homogeneous(row, tau, h0, hd0):
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
def stick_propagator(structure, tau):
    """The stick's 2x2 propagator ``(e11, e12, e21, e22)`` over ``tau`` [s], operation for
    operation as :func:`homogeneous` computes it from the stick's row of the mode table
    (``D = 1``), without the table."""
    d = 1.0
    c = structure[DAMPING]
    k = structure[STIFFNESS]
    sigma = 0.5 * c / d
    ec, es = _propagator(sigma, k / d - sigma * sigma, tau)
    return ec + es * sigma, es, -es * (k / d), ec - es * sigma


@njit(cache=True, nogil=True, error_model="numpy")
def particular(row, omega, cw, sw):
    """Particular solution ``(delta, delta', delta'', delta''')`` of a mode at phase
    with ``cos = cw``, ``sin = sw``."""
    pr = row[M_PRE]
    pi = row[M_PIM]
    re = pr * cw - pi * sw
    im = pr * sw + pi * cw
    w2 = omega * omega
    return re + row[M_OFFSET], -omega * im, -w2 * re, w2 * omega * im


@njit(cache=True, nogil=True, error_model="numpy")
def one_minus_cos(d):
    half = math.sin(0.5 * d)
    return 2.0 * half * half



@njit(cache=True, nogil=True, error_model="numpy")
def stick_releases(structure, a, cw, dl, dld):
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
def mode_acceleration(structure, row, cw, dl, dld):
    """``delta''`` in the mode of ``row`` at state ``(dl, dld)``, drive phase cosine ``cw``."""
    return (row[M_FORCE] * cw + row[M_GCONST] - structure[DAMPING] * dld
            - structure[STIFFNESS] * dl) / row[M_D]


@njit(cache=True, nogil=True, error_model="numpy")
def slip_acceleration(structure, row, a, cw, ddd):
    """``v'`` in the slip of ``row`` with mode acceleration ``ddd``."""
    s = row[M_SIGN]
    ck = structure[KINETIC_FRICTION]
    return -row[M_K] * ddd - s * ck * structure[GRAVITY] + s * ck * a * cw

