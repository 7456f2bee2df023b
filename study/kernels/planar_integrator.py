"""Event-driven Dormand-Prince 5(4) integrator of the planar disk with resonant plates.

State ``y = (x, y, theta, vx, vy, spin, path, delta_1, delta_1', ..., delta_P,
delta_P')`` (world frame; ``path`` is the distance slid) and a contact mode, ``STICK``
or ``SLIP``. Per unit total mass, table frame, drive ``A(t) = a cos(phi(t))``::

    F_i  = A cos(alpha_i) - (w_i/Q_i) delta_i' - w_i^2 delta_i      (delta_i'' = F_i)
    n    = g - A + sum_i M_i cos(alpha_i) F_i
    f_b  = sum_i -M_i sin(alpha_i) F_i e_i,   T = sum_i -M_i sin(alpha_i) F_i l_i
    W    = (R(theta) f_b, T / c),              u = (vx, vy, c spin)
    stick: u = 0 while |W| <= cs n
    slip:  (vx, vy)' = R(theta) f_b - ck n uhat_xy,  spin' = (T - ck n c uhat_3) / rho^2

``e_i`` is plate i's direction and ``l_i`` its lever (``r_i x e_i``) in the body frame,
``c`` the length of the ellipsoidal limit surface (maximum friction torque ``mu n c``)
and ``rho`` the gyration radius. In the scaled twist ``u`` the limit surface is a
sphere and the sliding law reads ``u' = K (W - ck n uhat)`` with ``K = diag(1, 1,
c^2/rho^2)``.

Two-way coupling (``disk[DK_TWO_WAY] = 1``): while sliding, plate i's base (its
attachment point ``r_i``) accelerates along ``e_i`` at ``b_i = e_i . a + (r_i x e_i)
spin' - spin^2 (r_i . e_i)`` (body frame), and ``delta_i'' = F_i - sin(alpha_i) b_i``
replaces ``F_i`` in the mode, the plate forces and ``n``: a 3x3 linear system for
``(a, spin')`` per slip direction (:func:`_two_way`), the single-plate two-way model
along each plate. Its determinant ``<= 0`` is Painleve's paradox: the run stops
(``RUN_PARADOX``). While stuck both couplings are the same.

A slip starts from rest along the direction ``uhat`` whose acceleration is parallel to
itself, ``K (W - ck n uhat) = lambda uhat`` with ``lambda >= 0``, i.e. ``uhat_j =
W_j / (lambda / K_j + ck n)`` with ``|uhat| = 1`` (a monotone scalar equation in
``lambda``). A slip ends where the twist vanishes; on the dense output this is the
zero of ``u . d`` with ``d`` the twist direction at the start of the step (near its
end a slip's twist shrinks to zero along a converging direction, so the projection
changes sign there).

The loop is :func:`study.kernels.event_loop.make_loop` (shared with the single plate):
steps are :mod:`study.kernels.dopri`'s; events are located by
:mod:`study.kernels.events`: sampled on the dense output, watched at their minima,
refined by the Illinois method. This module gives the loop the disk as hooks;
:mod:`study.solvers.planar` packs the disk (:data:`PLATE_ENTRIES`, :data:`DISK_ENTRIES`),
validates, allocates and calls :func:`integrate`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from study.kernels import structure_vector as sv
from study.kernels.dopri import dense_output, step, table_drive
from study.kernels.event_loop import Hooks, make_loop
from study.kernels.events import record
from study.model.codes import (
    EVENT_PARADOX,
    EVENT_RELEASE,
    EVENT_SLIP_END,
    RUN_DONE,
    RUN_PARADOX,
    STICK,
)

# Contact modes besides STICK. A slip that starts from rest is in its ONSET phase until
# its twist exceeds the slaving threshold: there its direction is the slaved one, which
# removes the stiffness (relaxation rate ck n / |u|) of the direction near u = 0.
SLIP = 1
ONSET = 2

# State layout.
X = 0
Y = 1
HEADING = 2
VX = 3
VY = 4
SPIN = 5
PATH = 6
MODES = 7


def _shared(*names):
    """The single plate's structure-vector entries ``names`` (name, units, meaning)."""
    return tuple(sv.ENTRIES[sv.index(name)] for name in names)


#: The columns of the plate parameter table, in order, with their units: a plate's mode
#: is the single plate's (the structure vector's entries of the same names), then where
#: and along what the plate acts on the disk. The solvers pack them by these names
#: (:func:`study.solvers.planar.disk_parameters`).
PLATE_ENTRIES = (
    *_shared("damping", "stiffness", "cos_alpha", "sin_alpha", "mass_ratio"),
    ("direction_forward", "1", "body-frame direction e of the plate's mode, forward component"),
    ("direction_left", "1", "body-frame direction e of the plate's mode, left component"),
    ("lever", "m", "r x e, the moment arm of the plate's horizontal force about the centre"),
    ("reach", "m", "r . e, the attachment point r along the plate's direction e"),
)

#: The entries of the disk parameter vector, in order, with their units: the friction
#: coefficients, gravity and the coupling are the single plate's (the structure vector's
#: entries of the same names), the limit surface, the inertia and the slaving threshold
#: the disk's own.
DISK_ENTRIES = (
    *_shared("static_friction", "kinetic_friction", "gravity"),
    ("friction_length", "m", "length c of the ellipsoidal limit surface"),
    ("gyration_radius_squared", "m2", "rho^2, the disk's radius of gyration squared"),
    ("slaved_twist", "m s-1", "twist below which a slip's direction is the slaved one"),
    *_shared("two_way"),
)
_PLATE_NAMES = tuple(name for name, _, _ in PLATE_ENTRIES)
_DISK_NAMES = tuple(name for name, _, _ in DISK_ENTRIES)

# Columns of the plate parameter table (numba reads module-level integers as
# compile-time constants).
PL_DAMPING = _PLATE_NAMES.index("damping")  # w0/Q [s-1]
PL_STIFFNESS = _PLATE_NAMES.index("stiffness")  # w0^2 [s-2]
PL_COS = _PLATE_NAMES.index("cos_alpha")  # cos(alpha)
PL_SIN = _PLATE_NAMES.index("sin_alpha")  # sin(alpha)
PL_MASS = _PLATE_NAMES.index("mass_ratio")  # M
PL_EX = _PLATE_NAMES.index("direction_forward")  # body-frame direction, forward component
PL_EY = _PLATE_NAMES.index("direction_left")  # body-frame direction, left component
PL_LEVER = _PLATE_NAMES.index("lever")  # r x e [m]
PL_REACH = _PLATE_NAMES.index("reach")  # r . e [m]
N_PLATE_PARAMETERS = len(PLATE_ENTRIES)

# Entries of the disk parameter vector.
DK_CS = _DISK_NAMES.index("static_friction")
DK_CK = _DISK_NAMES.index("kinetic_friction")
DK_G = _DISK_NAMES.index("gravity")
DK_LENGTH = _DISK_NAMES.index("friction_length")  # limit-surface length c [m]
DK_GYRATION2 = _DISK_NAMES.index("gyration_radius_squared")  # rho^2 [m^2]
DK_SLAVED = _DISK_NAMES.index("slaved_twist")  # twist below which its direction is slaved [m s-1]
DK_TWO_WAY = _DISK_NAMES.index("two_way")  # 1.0 for two-way coupling of the plates
N_DISK_PARAMETERS = len(DISK_ENTRIES)

# Event functions: release (stick) or slip end (slip), lift-off (always).
EVENTS = 2
LIFT = 1

# Entries of the run statistics.
STEPS = 0
REJECTED = 1
SLIPS = 2
STUCK_TIME = 3
SLIPPING_TIME = 4
STATS_SIZE = 5

# Length of the scratch array of the model's functions.
WORK_SIZE = 23

# Safeguarded Newton iterations of the slaved-direction equation (converges in a few).
SLAVED_ITERATIONS = 100


@njit(cache=True, nogil=True)
def _loads(plates, disk, drive, drive_rate_neg, y, out):
    """Normal force, body-frame plate force and torque per unit mass, and their rates.

    ``out = (n, fx, fy, T, n', fx', fy', T')``; ``drive_rate_neg = -dA/dt``.
    """
    n = disk[DK_G] - drive
    n_rate = drive_rate_neg
    fx = 0.0
    fy = 0.0
    torque = 0.0
    fx_rate = 0.0
    fy_rate = 0.0
    torque_rate = 0.0
    for i in range(plates.shape[0]):
        d = y[MODES + 2 * i]
        d_rate = y[MODES + 2 * i + 1]
        forcing = drive * plates[i, PL_COS] - plates[i, PL_DAMPING] * d_rate \
            - plates[i, PL_STIFFNESS] * d
        forcing_rate = -drive_rate_neg * plates[i, PL_COS] - plates[i, PL_DAMPING] * forcing \
            - plates[i, PL_STIFFNESS] * d_rate
        n += plates[i, PL_MASS] * plates[i, PL_COS] * forcing
        n_rate += plates[i, PL_MASS] * plates[i, PL_COS] * forcing_rate
        push = -plates[i, PL_MASS] * plates[i, PL_SIN]
        fx += push * forcing * plates[i, PL_EX]
        fy += push * forcing * plates[i, PL_EY]
        torque += push * forcing * plates[i, PL_LEVER]
        fx_rate += push * forcing_rate * plates[i, PL_EX]
        fy_rate += push * forcing_rate * plates[i, PL_EY]
        torque_rate += push * forcing_rate * plates[i, PL_LEVER]
    out[0] = n
    out[1] = fx
    out[2] = fy
    out[3] = torque
    out[4] = n_rate
    out[5] = fx_rate
    out[6] = fy_rate
    out[7] = torque_rate


@njit(cache=True, nogil=True)
def _world_wrench(disk, heading, loads, wrench):
    """Scaled wrench ``W = (R(theta) f_b, T/c)`` and its rate (the heading is frozen
    while stuck, and its rate's contribution is not needed elsewhere)."""
    c = math.cos(heading)
    s = math.sin(heading)
    length = disk[DK_LENGTH]
    wrench[0] = c * loads[1] - s * loads[2]
    wrench[1] = s * loads[1] + c * loads[2]
    wrench[2] = loads[3] / length
    wrench[3] = c * loads[5] - s * loads[6]
    wrench[4] = s * loads[5] + c * loads[6]
    wrench[5] = loads[7] / length


@njit(cache=True, nogil=True)
def _slaved_direction(disk, n, wrench, out):
    """Unit twist direction ``uhat`` whose acceleration is parallel to itself.

    Solves ``K (W - ck n uhat) = lambda uhat``, i.e. ``uhat_j = W_j / (lambda / K_j +
    ck n)`` with ``sum_j uhat_j^2 = 1``; the sum falls monotonically in ``lambda`` on
    ``(-ck n min K, inf)``, so the root is unique: ``lambda >= 0`` for a slip that
    starts (``|W| >= ck n``), ``lambda < 0`` for one that comes to rest. A slip's
    twist relaxes to this direction at the rate ``ck n / |u|``: it is the direction
    of a slip starting from rest and the one a vanishing twist follows.
    Returns ``lambda``.
    """
    kappa = disk[DK_LENGTH] ** 2 / disk[DK_GYRATION2]
    friction = disk[DK_CK] * max(n, 0.0)
    w0 = wrench[0]
    w1 = wrench[1]
    w2 = wrench[2]
    size = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if size == 0.0:
        out[0] = 1.0
        out[1] = 0.0
        out[2] = 0.0
        return -friction
    # Components below rounding relative to |W| count as zero: near the poles they would
    # only add rounding noise (and overflow).
    if abs(w0) < 1e-14 * size:
        w0 = 0.0
    if abs(w1) < 1e-14 * size:
        w1 = 0.0
    if abs(w2) < 1e-14 * size:
        w2 = 0.0
    # In lambda the poles are -ck n (x, y) and -ck n kappa (spin); a zero component of
    # W has none. The root lies right of the rightmost pole, often very close to it:
    # solve for the distance ``gap`` from that pole, so the denominator that vanishes
    # there keeps its full relative precision (no cancellation in lambda + ck n).
    xy2 = w0 * w0 + w1 * w1
    z2 = w2 * w2
    if xy2 == 0.0:
        pole = -friction * kappa
    elif z2 == 0.0:
        pole = -friction
    else:
        pole = max(-friction, -friction * kappa)
    offset_xy = pole + friction  # m_xy = gap + offset_xy, both >= 0
    offset_z = pole + friction * kappa  # kappa m_z = gap + offset_z
    lo = 0.0
    hi = size * max(1.0, kappa)
    gap = min(max(size - friction - pole, 1e-3 * hi), hi)
    for _ in range(SLAVED_ITERATIONS):
        m_xy = gap + offset_xy
        m_z = (gap + offset_z) / kappa
        phi = -1.0
        slope = 0.0
        if xy2 > 0.0:
            phi += xy2 / (m_xy * m_xy)
            slope -= 2.0 * xy2 / m_xy**3
        if z2 > 0.0:
            phi += z2 / (m_z * m_z)
            slope -= 2.0 * z2 / (kappa * m_z**3)
        if phi > 0.0:
            lo = gap
        else:
            hi = gap
        candidate = gap - phi / slope
        if not (lo < candidate < hi):
            candidate = 0.5 * (lo + hi)
        if abs(candidate - gap) <= 1e-15 * gap or hi - lo <= 1e-16 * hi:
            gap = candidate
            break
        gap = candidate
    m_xy = gap + offset_xy
    m_z = (gap + offset_z) / kappa
    out[0] = w0 / m_xy if w0 != 0.0 else 0.0
    out[1] = w1 / m_xy if w1 != 0.0 else 0.0
    out[2] = w2 / m_z if w2 != 0.0 else 0.0
    norm = math.sqrt(out[0] ** 2 + out[1] ** 2 + out[2] ** 2)
    for j in range(3):
        out[j] /= norm
    return gap + pole


@njit(cache=True, nogil=True)
def _friction_direction(disk, mode, reference, y, n, wrench, out):
    """Unit twist direction that the friction wrench opposes.

    ``u / |u|`` while the twist exceeds the slaving threshold ``disk[DK_SLAVED]``.
    Below it, at a slip's onset, the slaved direction; at a slip's end, the direction
    ``reference`` at the step's start, frozen for the step. Both keep the right-hand
    side smooth where ``u / |u|`` would turn at the rate ``ck n / |u|`` (stiff) or flip
    (at ``u = 0``), so the twist crosses zero inside a step, where the slip-end event
    finds it.
    """
    u0 = y[VX]
    u1 = y[VY]
    u2 = disk[DK_LENGTH] * y[SPIN]
    size = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    if size > disk[DK_SLAVED] or (size > 0.0 and disk[DK_SLAVED] == 0.0):
        out[0] = u0 / size
        out[1] = u1 / size
        out[2] = u2 / size
    elif mode == ONSET or (size == 0.0 and mode != SLIP):
        _slaved_direction(disk, n, wrench, out)
    else:
        out[0] = reference[0]
        out[1] = reference[1]
        out[2] = reference[2]


@njit(cache=True, nogil=True)
def _two_way(plates, disk, y, loads, direction, accel):
    """Accelerations of a two-way coupled slip against the friction direction
    ``direction`` (unit, scaled twist, world frame).

    Plate i's base accelerates along its direction ``e_i`` at ``b_i = g_i . q -
    spin^2 (r_i . e_i)`` (the attachment point's rigid-body acceleration, ``g_i =
    (e_i, r_i x e_i)`` and ``q = (a_x, a_y, spin')`` in the body frame), which
    forces its mode: ``delta_i'' = F_i - sin(alpha_i) b_i``. The plates' forces and
    the normal force then use ``delta_i''``; with the sliding law this is the linear
    system ``A q = w`` with ``A = diag(1, 1, rho^2) - sum_i M_i sin(alpha_i) (sin(alpha_i)
    g_i + ck cos(alpha_i) d) g_i^T`` (``d`` the friction direction, unscaled: ``(d_x,
    d_y, c d_3)``). ``loads`` are the one-way loads (:func:`_loads`).

    Fills ``accel = (a_x, a_y, spin')`` in the world frame [m s-2, rad s-2] and
    ``q`` in ``accel[3:6]``; returns ``(n, det A)`` with ``n`` the coupled normal force
    per unit mass [m s-2]. ``det A <= 0`` is Painleve's paradox (then ``accel`` is
    not filled).
    """
    heading = y[HEADING]
    c = math.cos(heading)
    s = math.sin(heading)
    length = disk[DK_LENGTH]
    ck = disk[DK_CK]
    n0 = loads[0]
    dx = c * direction[0] + s * direction[1]
    dy = -s * direction[0] + c * direction[1]
    dz = length * direction[2]
    spin2 = y[SPIN] * y[SPIN]
    a00, a01, a02 = 1.0, 0.0, 0.0
    a10, a11, a12 = 0.0, 1.0, 0.0
    a20, a21, a22 = 0.0, 0.0, disk[DK_GYRATION2]
    r0 = loads[1] - ck * n0 * dx
    r1 = loads[2] - ck * n0 * dy
    r2 = loads[3] - ck * n0 * dz
    for i in range(plates.shape[0]):
        sa = plates[i, PL_SIN]
        ca = plates[i, PL_COS]
        coef = plates[i, PL_MASS] * sa
        g0 = plates[i, PL_EX]
        g1 = plates[i, PL_EY]
        g2 = plates[i, PL_LEVER]
        v0 = sa * g0 + ck * ca * dx
        v1 = sa * g1 + ck * ca * dy
        v2 = sa * g2 + ck * ca * dz
        a00 -= coef * v0 * g0
        a01 -= coef * v0 * g1
        a02 -= coef * v0 * g2
        a10 -= coef * v1 * g0
        a11 -= coef * v1 * g1
        a12 -= coef * v1 * g2
        a20 -= coef * v2 * g0
        a21 -= coef * v2 * g1
        a22 -= coef * v2 * g2
        kappa = -spin2 * plates[i, PL_REACH]
        r0 += coef * kappa * v0
        r1 += coef * kappa * v1
        r2 += coef * kappa * v2
    m00 = a11 * a22 - a12 * a21
    m01 = a10 * a22 - a12 * a20
    m02 = a10 * a21 - a11 * a20
    det = a00 * m00 - a01 * m01 + a02 * m02
    if not det > 0.0:
        return n0, det
    q0 = (r0 * m00 - a01 * (r1 * a22 - a12 * r2) + a02 * (r1 * a21 - a11 * r2)) / det
    q1 = (a00 * (r1 * a22 - a12 * r2) - r0 * m01 + a02 * (a10 * r2 - r1 * a20)) / det
    q2 = (a00 * (a11 * r2 - r1 * a21) - a01 * (a10 * r2 - r1 * a20) + r0 * m02) / det
    n = n0
    for i in range(plates.shape[0]):
        base = plates[i, PL_EX] * q0 + plates[i, PL_EY] * q1 + plates[i, PL_LEVER] * q2 \
            - spin2 * plates[i, PL_REACH]
        n -= plates[i, PL_MASS] * plates[i, PL_COS] * plates[i, PL_SIN] * base
    accel[0] = c * q0 - s * q1
    accel[1] = s * q0 + c * q1
    accel[2] = q2
    accel[3] = q0
    accel[4] = q1
    accel[5] = q2
    return n, det


@njit(cache=True, nogil=True)
def _rhs(plates, disk, mode, reference, drive, y, out, work):
    """Time derivative of the state; ``work`` is scratch of length >= 23."""
    loads = work[0:8]
    wrench = work[8:14]
    direction = work[14:17]
    _loads(plates, disk, drive, 0.0, y, loads)
    for i in range(plates.shape[0]):
        j = MODES + 2 * i
        out[j] = y[j + 1]
        out[j + 1] = drive * plates[i, PL_COS] - plates[i, PL_DAMPING] * y[j + 1] \
            - plates[i, PL_STIFFNESS] * y[j]
    out[X] = y[VX]
    out[Y] = y[VY]
    out[HEADING] = y[SPIN]
    if mode == STICK:
        out[VX] = 0.0
        out[VY] = 0.0
        out[SPIN] = 0.0
        out[PATH] = 0.0
        return
    _world_wrench(disk, y[HEADING], loads, wrench)
    _friction_direction(disk, mode, reference, y, loads[0], wrench, direction)
    out[PATH] = math.sqrt(y[VX] * y[VX] + y[VY] * y[VY])
    if disk[DK_TWO_WAY] != 0.0:
        accel = work[17:23]
        _two_way(plates, disk, y, loads, direction, accel)
        out[VX] = accel[0]
        out[VY] = accel[1]
        out[SPIN] = accel[2]
        spin2 = y[SPIN] * y[SPIN]
        for i in range(plates.shape[0]):
            base = plates[i, PL_EX] * accel[3] + plates[i, PL_EY] * accel[4] \
                + plates[i, PL_LEVER] * accel[5] - spin2 * plates[i, PL_REACH]
            out[MODES + 2 * i + 1] -= plates[i, PL_SIN] * base
        return
    friction = disk[DK_CK] * loads[0]
    out[VX] = wrench[0] - friction * direction[0]
    out[VY] = wrench[1] - friction * direction[1]
    out[SPIN] = (loads[3] - friction * disk[DK_LENGTH] * direction[2]) / disk[DK_GYRATION2]


@njit(cache=True, nogil=True)
def _event_values(plates, disk, mode, reference, drive, drive_rate_neg, y, values,
                  rates, work):
    """Event functions of the current mode, positive while nothing happens.

    stick: ``cs n - |W|`` (release); slip: ``u . d`` (slip end, ``d`` the reference
    direction); always: ``n`` (lift-off). In a two-way coupled slip the rate of ``n``
    leaves out the plates' coupling (it only serves to watch for a dip of ``n``
    between samples; ``n`` itself is the coupled one).
    """
    loads = work[0:8]
    wrench = work[8:14]
    direction = work[14:17]
    _loads(plates, disk, drive, drive_rate_neg, y, loads)
    _world_wrench(disk, y[HEADING], loads, wrench)
    if mode == STICK:
        size = math.sqrt(wrench[0] ** 2 + wrench[1] ** 2 + wrench[2] ** 2)
        size_rate = 0.0
        if size > 0.0:
            size_rate = (wrench[0] * wrench[3] + wrench[1] * wrench[4]
                         + wrench[2] * wrench[5]) / size
        values[0] = disk[DK_CS] * loads[0] - size
        rates[0] = disk[DK_CS] * loads[4] - size_rate
    else:
        _friction_direction(disk, mode, reference, y, loads[0], wrench, direction)
        length = disk[DK_LENGTH]
        if disk[DK_TWO_WAY] != 0.0:
            accel = work[17:23]
            n, _ = _two_way(plates, disk, y, loads, direction, accel)
            loads[0] = n
            ax = accel[0]
            ay = accel[1]
            aspin = accel[2]
        else:
            friction = disk[DK_CK] * loads[0]
            ax = wrench[0] - friction * direction[0]
            ay = wrench[1] - friction * direction[1]
            aspin = (loads[3] - friction * length * direction[2]) / disk[DK_GYRATION2]
        values[0] = y[VX] * reference[0] + y[VY] * reference[1] \
            + length * y[SPIN] * reference[2]
        rates[0] = ax * reference[0] + ay * reference[1] + length * aspin * reference[2]
    values[1] = loads[0]
    rates[1] = loads[4]


@njit(cache=True, nogil=True, inline="always")
def _model_rhs(model, mode, drive, y, out):
    """:func:`_rhs` in the form the shared stepper calls, ``model = (plates, disk,
    reference, work)``."""
    plates, disk, reference, work = model
    _rhs(plates, disk, mode, reference, drive, y, out, work)


@njit(cache=True, nogil=True)
def _step(model, mode, t, h, y, k, drive_args, y_new, err, dense, tmp):
    """One Dormand-Prince step from ``(t, y)`` with ``k[0] = f(t, y)`` (FSAL),
    ``model = (plates, disk, reference, work)``."""
    step(_model_rhs, model, mode, t, h, y, k, drive_args, y_new, err, dense, tmp)
    if mode == STICK:
        # The pose is exactly frozen while stuck.
        for i in range(MODES):
            y_new[i] = y[i]
            err[i] = 0.0
            for row in range(1, 5):
                dense[row, i] = 0.0
        y_new[VX] = 0.0
        y_new[VY] = 0.0
        y_new[SPIN] = 0.0


@njit(cache=True, nogil=True, inline="always")
def _values_at(theta, model, mode, t, h, dense, drive_args, ystate, values, rates):
    """Event functions at ``t + theta h`` on the dense output (the form
    :func:`study.kernels.events.first_event` calls), ``model = (plates, disk,
    reference, work)``."""
    plates, disk, reference, work = model
    seg, seg_t0, seg_omega, seg_a, seg_phase0 = drive_args
    dense_output(theta, h, dense, ystate)
    drive, rate = table_drive(t + theta * h, seg, seg_t0, seg_omega, seg_a, seg_phase0)
    _event_values(plates, disk, mode, reference, drive, rate, ystate, values, rates,
                  work)


@njit(cache=True, nogil=True)
def _mode_after_rest(plates, disk, drive, y, work):
    """``SLIP`` if the wrench at rest exceeds the static limit surface, else ``STICK``."""
    loads = work[0:8]
    wrench = work[8:14]
    _loads(plates, disk, drive, 0.0, y, loads)
    _world_wrench(disk, y[HEADING], loads, wrench)
    size = math.sqrt(wrench[0] ** 2 + wrench[1] ** 2 + wrench[2] ** 2)
    if size > disk[DK_CS] * loads[0]:
        return ONSET
    return STICK


@njit(cache=True, nogil=True)
def _restart(model, mode, fresh, t, drive, rate, y, k0, values, rates, events, stats):
    """The event loop's ``restart`` hook (:data:`study.kernels.event_loop.Hooks`)."""
    plates, disk, reference, work = model
    if mode == STICK:
        y[VX] = 0.0
        y[VY] = 0.0
        y[SPIN] = 0.0
        if _mode_after_rest(plates, disk, drive, y, work) == ONSET:
            mode = ONSET
            fresh = True
            stats[SLIPS] += 1.0
            record(events, t, EVENT_RELEASE, y)
    _event_values(plates, disk, mode, reference, drive, rate, y, values, rates, work)
    _rhs(plates, disk, mode, reference, drive, y, k0, work)
    return mode, fresh, RUN_DONE


@njit(cache=True, nogil=True)
def _prepare(model, mode, t, drive_args, y, k0, events):
    """The ``prepare`` hook: in a slip, the direction along which this step watches the
    slip end, and Painleve's paradox of a two-way slip."""
    if mode == STICK:
        return RUN_DONE
    plates, disk, reference, work = model
    length = disk[DK_LENGTH]
    # The slip end is watched along the friction direction at the step start.
    seg, seg_t0, seg_omega, seg_a, seg_phase0 = drive_args
    drive, _ = table_drive(t, seg, seg_t0, seg_omega, seg_a, seg_phase0)
    loads = work[0:8]
    wrench = work[8:14]
    _loads(plates, disk, drive, 0.0, y, loads)
    _world_wrench(disk, y[HEADING], loads, wrench)
    size = math.sqrt(y[VX] ** 2 + y[VY] ** 2 + (length * y[SPIN]) ** 2)
    if size > 0.0 and (mode == SLIP or size > disk[DK_SLAVED]):
        reference[0] = y[VX] / size
        reference[1] = y[VY] / size
        reference[2] = length * y[SPIN] / size
    else:
        _slaved_direction(disk, loads[0], wrench, reference)
    if disk[DK_TWO_WAY] != 0.0:
        _, det = _two_way(plates, disk, y, loads, reference, work[17:23])
        if not det > 0.0:
            record(events, t, EVENT_PARADOX, y)
            return RUN_PARADOX
    if mode == SLIP and size <= disk[DK_SLAVED]:
        # The frozen direction of this step differs from the last step's.
        _rhs(plates, disk, mode, reference, drive, y, k0, work)
    return RUN_DONE


@njit(cache=True, nogil=True)
def _hold(model, mode, before, state):
    """The ``hold`` hook: nothing to restore (a stuck step's dense output is frozen)."""


@njit(cache=True, nogil=True)
def _account(mode, duration, stats):
    if mode == STICK:
        stats[STUCK_TIME] += duration
    else:
        stats[SLIPPING_TIME] += duration


@njit(cache=True, nogil=True)
def _accepted(model, mode, y):
    """The ``accepted`` hook: a slip's onset ends once its twist exceeds the slaving
    threshold."""
    if mode == ONSET:
        disk = model[1]
        length = disk[DK_LENGTH]
        twist = math.sqrt(y[VX] ** 2 + y[VY] ** 2 + (length * y[SPIN]) ** 2)
        if twist > disk[DK_SLAVED]:
            return SLIP
    return mode


@njit(cache=True, nogil=True)
def _transition(model, mode, which, t, drive, y, events, stats):
    """The ``transition`` hook: a release starts a slip's onset; a slip end sticks, or
    starts a new slip when the wrench at rest exceeds the static limit surface."""
    if mode == STICK:
        stats[SLIPS] += 1.0
        record(events, t, EVENT_RELEASE, y)
        return ONSET, True
    plates, disk, _, work = model
    y[VX] = 0.0
    y[VY] = 0.0
    y[SPIN] = 0.0
    record(events, t, EVENT_SLIP_END, y)
    mode = _mode_after_rest(plates, disk, drive, y, work)
    fresh = mode == ONSET
    if fresh:
        stats[SLIPS] += 1.0
        record(events, t, EVENT_RELEASE, y)
    return mode, fresh


@njit(cache=True, nogil=True)
def _at_rest(y):
    return y[VX] == 0.0 and y[VY] == 0.0 and y[SPIN] == 0.0


_loop = make_loop(Hooks(_restart, _prepare, _step, _values_at, _hold, _account, _accepted,
                        _transition, _at_rest, EVENTS, LIFT))


@njit(cache=True, nogil=True)
def integrate(plates, disk, segments, state, t_stop, control, samples, events, stats):
    """Integrate the disk from ``state.clock[0]`` to ``t_stop`` in place
    (:func:`study.kernels.event_loop.make_loop`; ``control.fixed_step`` must be 0).

    ``state`` carries the state in and out, so a run can be continued by another call.
    ``stats`` (:data:`STATS_SIZE` entries) accumulates steps, rejected steps, slips and
    the time stuck and slipping [s]. Returns a ``RUN_*`` code.
    """
    model = (plates, disk, np.zeros(3), np.empty(WORK_SIZE))
    return _loop(model, segments, state, t_stop, control, samples, events, stats)
