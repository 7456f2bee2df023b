"""The per-point table of the three contact modes (stick, forward and backward slip).

Each row holds one mode's coefficients, its particular response to the drive and the
bounds of its event functions: everything :mod:`~study.kernels.two_way.propagation` and
:mod:`~study.kernels.two_way.event_search` read at one drive point.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
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
    TWO_WAY,
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
def stick_response(structure, omega, a):
    """The stick's steady response ``(M_PRE, M_PIM)`` [m] at ``omega`` [rad s-1], ``a``
    [m s-2], operation for operation as :func:`mode_row` writes it in row 0 (``D = 1``),
    without the table."""
    d = 1.0
    c = structure[DAMPING]
    k = structure[STIFFNESS]
    force = a * structure[COS_ALPHA]
    re = k - d * omega * omega
    im = c * omega
    den = re * re + im * im
    return force * re / den, -force * im / den


@njit(cache=True, nogil=True, error_model="numpy")
def mode_row(structure, omega, a, table, row):
    """Fill one row of :func:`mode_table`: the stick (0), forward (1) or backward (2)
    (every column: a table is reused from point to point)."""
    mode_constants(structure, table, row)
    mode_drive(structure, omega, a, table, row)


@njit(cache=True, nogil=True, error_model="numpy")
def mode_constants(structure, table, row):
    """Fill the columns of one row of :func:`mode_table` that depend on the structure
    alone (the others 0): the mode's coefficients and the bounds of its homogeneous
    functionals, the most of a row's cost, which a run of points computes once."""
    table[row, :] = 0.0
    c = structure[DAMPING]
    k = structure[STIFFNESS]
    ca = structure[COS_ALPHA]
    sa = structure[SIN_ALPHA]
    m = structure[MASS_RATIO]
    ck = structure[KINETIC_FRICTION]
    cs = structure[STATIC_FRICTION]
    g = structure[GRAVITY]
    coupled = structure[TWO_WAY] != 0.0
    s = 0.0 if row == 0 else (1.0 if row == 1 else -1.0)
    if row == 0 or not coupled:
        d = 1.0
        gconst = 0.0
    else:
        d = 1.0 - m * sa * (sa + s * ck * ca)
        gconst = s * ck * g * sa
    table[row, M_SIGN] = s
    kk = 0.0 if row == 0 else m * (sa + s * ck * ca)
    table[row, M_K] = kk
    table[row, M_D] = d
    table[row, M_GCONST] = gconst
    if d <= 0.0:
        table[row, M_D] = 0.0
        return
    sigma = 0.5 * c / d
    table[row, M_SIGMA] = sigma
    kd = k / d
    cd = c / d
    table[row, M_KD] = kd
    table[row, M_CD] = cd
    table[row, M_NU2] = k / d - sigma * sigma
    table[row, M_OFFSET] = gconst / k
    values = table[row]
    for sign, col in ((1.0, M_SIN_P), (-1.0, M_SIN_M)):
        kappa = -m * (sign * sa + cs * ca)
        values[col + 1] = abs(kappa) * functional_bound(values, -kd, -cd, k, 0)
        values[col + 2] = abs(kappa) * functional_bound(values, -kd, -cd, k, 2)
        values[col + 3] = abs(kappa) * functional_bound(values, -kd, -cd, k, 3)
    values[M_HOM2_V] = functional_bound(values, 0.0, kk, k, 2)
    values[M_HOM3_V] = functional_bound(values, 0.0, kk, k, 3)
    values[M_HOM0_N] = m * ca * functional_bound(values, kd, cd, k, 0)
    values[M_HOM2_N] = m * ca * functional_bound(values, kd, cd, k, 2)
    values[M_HOM3_N] = m * ca * functional_bound(values, kd, cd, k, 3)


@njit(cache=True, nogil=True, error_model="numpy")
def mode_drive(structure, omega, a, table, row, searched_only=False):
    """Fill the columns of one row of :func:`mode_table` that depend on the drive
    ``omega`` [rad s-1], ``a`` [m s-2] (the row's :func:`mode_constants` already in
    place): the forcing, the particular response and the sinusoids of the event
    functions.

    With ``searched_only``, only the sinusoids that the row's own event searches read
    (:func:`~study.kernels.two_way.event_search.search`: the releases in a stick, the
    slip's end in a slip, lift-off in any mode) are computed: the releases' on the
    stick's row, the slip speed's on the slip rows, lift-off's on every row; the others
    are set to NaN, so that a reader of one would not go unnoticed. Each column computed
    is computed as without it, operation for operation (the three full rows cost a
    point of a continued sweep about 0.28 us, a quarter of its time outside the passes,
    most of it in the hypot and atan2 of columns its passes never read)."""
    k = structure[STIFFNESS]
    c = structure[DAMPING]
    ca = structure[COS_ALPHA]
    sa = structure[SIN_ALPHA]
    m = structure[MASS_RATIO]
    cs = structure[STATIC_FRICTION]
    ck = structure[KINETIC_FRICTION]
    values = table[row]
    s = values[M_SIGN]
    if row == 0 or structure[TWO_WAY] == 0.0:
        force = a * ca
    else:
        force = a * (ca - s * ck * sa)
    values[M_FORCE] = force
    d = values[M_D]
    if d <= 0.0:
        return
    re = k - d * omega * omega
    im = c * omega
    den = re * re + im * im
    pr = force * re / den
    pi = -force * im / den
    values[M_PRE] = pr
    values[M_PIM] = pi
    kk = values[M_K]
    w2 = omega * omega
    for sign, col in ((1.0, M_SIN_P), (-1.0, M_SIN_M)):
        if searched_only and row != 0:
            values[col] = np.nan
            values[col + 4] = np.nan
            values[col + 5] = np.nan
            continue
        # Release s tau - cs n = kappa delta'' - cs g + cs A (a stick's delta'').
        kappa = -m * (sign * sa + cs * ca)
        cr = -kappa * w2 * pr + cs * a
        ci = -kappa * w2 * pi
        amplitude = math.hypot(cr, ci)
        values[col] = w2 * amplitude
        values[col + 4] = amplitude
        values[col + 5] = math.atan2(ci, cr)
    if searched_only and row == 0:
        values[M_SIN_V] = np.nan
    else:
        # s v: sinusoid -s K delta_p' + ck a sin(wt) / w; homogeneous -s K h'.
        values[M_SIN_V] = w2 * math.hypot(kk * omega * pi, kk * omega * pr + s * ck * a / omega)
    # -n = A - g - M cos(alpha) delta''.
    cr = a + m * ca * w2 * pr
    ci = m * ca * w2 * pi
    amplitude = math.hypot(cr, ci)
    values[M_SIN_N] = w2 * amplitude
    values[M_AMP_N] = amplitude
    values[M_ARG_N] = math.atan2(ci, cr)


@njit(cache=True, nogil=True, error_model="numpy")
def functional_bound(row, l1, l2, k, power):
    """``||l A^power||`` in the dual of the energy norm ``sqrt(k h^2 + D h'^2)``:
    bounds the ``power``-th derivative of ``l . (h, h')`` per unit energy norm."""
    kd = row[M_KD]
    cd = row[M_CD]
    for _ in range(power):
        # (l1, l2) A with A = [[0, 1], [-kd, -cd]]
        l1, l2 = -kd * l2, l1 - cd * l2
    return math.sqrt(l1 * l1 / k + l2 * l2 / row[M_D])




#: One drive point as the orbit kernels read it: the structure vector
#: (:mod:`study.kernels.structure_vector`), the table of :func:`mode_table`
#: (3 x ``N_MODE``), the drive's angular frequency [rad s-1] and amplitude [m s-2].
DrivePoint = namedtuple("DrivePoint", ("structure", "table", "omega", "a"))
