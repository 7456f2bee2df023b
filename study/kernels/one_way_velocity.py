"""The one-way kernel's velocity path (``study.solvers.exact.steady_velocity``) and its
small calls: the lift-off test and the force amplitudes evaluated point by point,
bit-identical to ``study.model``'s arrays without their temporaries, then the orbit of
:func:`study.kernels.one_way.solve_point`, keeping the velocity and status only, dealt to
threads in blocks as :func:`study.kernels.one_way.solve_points_averaged` deals them.

A small call (:func:`velocity_points_small`, :func:`steady_points_small`,
:func:`lift_off_small`) takes the named tuples' fields as plain tuples: numba's dispatch
types those in C, named tuples in Python.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit, prange

from study.kernels.budget import Budget
from study.kernels.one_way import (
    N_OUTPUTS,
    OUT_STATUS,
    OUT_VELOCITY,
    POINT_BLOCK,
    TWO_PI,
    FrictionLevels,
    solve_point,
    write_lifted,
)
from study.model.codes import LIFT_OFF, NOT_CONVERGED, STATIC

#: The structure as the velocity path reads it, operation for operation as numpy
#: evaluates ``study.model`` (see :func:`_lift_off`): ``Structure.omega0`` [rad s-1],
#: ``1 / Q``, ``M``, numpy's cos and sin of the tilt, ``cs``, ``ck``, ``g`` [m s-2].
ForceConstants = namedtuple(
    "ForceConstants",
    ("w0", "inv_q", "mass_ratio", "cos_alpha", "sin_alpha", "static_friction",
     "kinetic_friction", "gravity"))
#: The output arrays of :func:`velocity_points`: velocity [m s-1] and status (int8).
VelocityOutputs = namedtuple("VelocityOutputs", ("velocity", "status"))

# Squares of the normal doubles in (1e-140, 1e140): products of three of them are
# still normal, so their rounding error is a few ulps.
SQUARES_LOW = 1e-280
SQUARES_HIGH = 1e280
# Status of a point the velocity path leaves to numpy's lift-off test.
LIFT_UNDECIDED = -1
# Comparisons of squares decided with this relative margin (rounding is < 1e-15).
SURE_ABOVE = 1.0 + 1e-13
SURE_BELOW = 1.0 - 1e-13


@njit(cache=True, nogil=True)
def _lift_off(f, a, constants):
    """The mode coupling ``k = w^2 M cos(alpha) G`` at one point and the lift-off
    test ``a > lift_off_acceleration`` (1, 0 or LIFT_UNDECIDED), operation for operation
    as numpy evaluates ``study.model`` there (see :func:`_forces`).

    numpy multiplies a real by a complex as ``(x + 0j) * z`` and divides by a real
    ``q`` as ``z * (1 / q)`` (Smith's algorithm); the zero products are kept so that
    signed zeros come out as numpy's. ``constants`` are :data:`ForceConstants`.
    """
    w0 = constants.w0
    inv_q = constants.inv_q
    m = constants.mass_ratio
    cos_a = constants.cos_alpha
    g = constants.gravity
    w = TWO_PI * f
    # G = 1 / (w0^2 - w^2 + 1j * w0 * w / Q)
    d_re = w0 * w0 - w * w + 0.0
    d_im = 0.0 + (0.0 * 0.0 + w0 * w) * inv_q
    if abs(d_re) >= abs(d_im):
        rat = d_im / d_re
        scl = 1.0 / (d_re + d_im * rat)
        g_re = (1.0 + 0.0 * rat) * scl
        g_im = (0.0 - 1.0 * rat) * scl
    else:
        rat = d_re / d_im
        scl = 1.0 / (d_im + d_re * rat)
        g_re = (1.0 * rat + 0.0) * scl
        g_im = (0.0 * rat - 1.0) * scl
    # k = w^2 M cos(alpha) G
    x = w * w * m * cos_a
    k_re = x * g_re - 0.0 * g_im
    k_im = x * g_im + 0.0 * g_re
    # 1 + k cos(alpha)
    one_re = 1.0 + (k_re * cos_a - k_im * 0.0)
    one_im = 0.0 + (k_re * 0.0 + k_im * cos_a)
    # Lifted if a > g / |1 + k cos(alpha)|, decided on squares (no square root) where
    # that is sure: farther than 1e-13 from the threshold, all squares normal. Nearer,
    # the answer depends on how numpy rounds |z| (its SIMD loops do not call hypot):
    # LIFT_UNDECIDED, for the caller to decide with numpy.
    a2 = a * a
    q2 = one_re * one_re + one_im * one_im
    g2 = g * g
    lhs = a2 * q2
    lift = LIFT_UNDECIDED
    if (SQUARES_LOW < a2 < SQUARES_HIGH and SQUARES_LOW < q2 < SQUARES_HIGH
            and SQUARES_LOW < g2 < SQUARES_HIGH):
        if lhs > g2 * SURE_ABOVE:
            lift = 1
        elif lhs < g2 * SURE_BELOW:
            lift = 0
    return lift, w, k_re, k_im, one_re, one_im


@njit(cache=True, nogil=True)
def lift_off_decisions(f, a, constants, out):
    """``out[i]`` (int8): 1 where ``a[i]`` [m s-2] is past lift-off at ``f[i]`` [Hz], 0
    where it is not, ``LIFT_UNDECIDED`` within 1e-13 of the threshold, as numpy decides
    ``a > study.model.lift_off_acceleration`` (see :func:`_lift_off`; ``constants`` the
    :data:`ForceConstants`)."""
    for i in range(f.shape[0]):
        out[i] = _lift_off(f[i], a[i], constants)[0]


@njit(cache=True, nogil=True)
def _forces(a, k_re, k_im, one_re, one_im, sin_a, cs, ck):
    """Release and slip amplitudes ``A_s``, ``B_s`` at one point, bit-identical to
    ``study.model``' ``release_amplitudes`` and ``slip_amplitudes`` there."""
    # N = -a (1 + k cos(alpha)), T = a k sin(alpha)
    na = -a
    n_re = na * one_re - 0.0 * one_im
    n_im = na * one_im + 0.0 * one_re
    ak_re = a * k_re - 0.0 * k_im
    ak_im = a * k_im + 0.0 * k_re
    t_re = ak_re * sin_a - ak_im * 0.0
    t_im = ak_re * 0.0 + ak_im * sin_a
    # s T - c N for c = cs (release) and ck (slip)
    csn_re = cs * n_re - 0.0 * n_im
    csn_im = cs * n_im + 0.0 * n_re
    ckn_re = ck * n_re - 0.0 * n_im
    ckn_im = ck * n_im + 0.0 * n_re
    a_plus = complex(t_re - csn_re, t_im - csn_im)
    a_minus = complex(-t_re - csn_re, -t_im - csn_im)
    b_plus = complex(t_re - ckn_re, t_im - ckn_im)
    b_minus = complex(-t_re - ckn_re, -t_im - ckn_im)
    return a_plus, a_minus, b_plus, b_minus


@njit(cache=True, nogil=True)
def _velocity_into(i, f, a, constants, levels, budget, out, given, row):
    """Solve point ``i`` for its velocity and status only, into the
    :data:`VelocityOutputs` ``out``.

    ``given`` is the lift-off decision if known (0 or 1), else LIFT_UNDECIDED: then a
    point too near the lift-off threshold to decide here gets that status (velocity
    NaN), to be solved again with the decision numpy makes.
    """
    lift, w, k_re, k_im, one_re, one_im = _lift_off(f[i], a[i], constants)
    if given != LIFT_UNDECIDED:
        lift = given
    if lift != 0:
        out.velocity[i] = np.nan
        out.status[i] = LIFT_OFF if lift == 1 else LIFT_UNDECIDED
        return
    a_plus, a_minus, b_plus, b_minus = _forces(
        a[i], k_re, k_im, one_re, one_im, constants.sin_alpha, constants.static_friction,
        constants.kinetic_friction)
    # Most points of a map never slip: decided before the slip constants are computed,
    # on squares where that is sure (else solve_point decides, as steady_state does).
    cs_g = levels.static
    level2 = cs_g * cs_g * SURE_BELOW
    p2 = a_plus.real * a_plus.real + a_plus.imag * a_plus.imag
    m2 = a_minus.real * a_minus.real + a_minus.imag * a_minus.imag
    if p2 < level2 and m2 < level2 and SQUARES_LOW < level2 < SQUARES_HIGH:
        out.velocity[i] = 0.0
        out.status[i] = STATIC
        return
    # ``row`` is a scratch row of OUTPUT_COLUMNS, one a thread: nothing is allocated
    # per point.
    solve_point(a_plus, a_minus, b_plus, b_minus, levels, budget, a[i], w, row)
    st = row[OUT_STATUS]
    out.status[i] = st
    out.velocity[i] = np.nan if st == NOT_CONVERGED else row[OUT_VELOCITY]


@njit(cache=True, nogil=True, parallel=True)
def velocity_points(f, a, constants, levels, budget, out):
    """Velocity and status of every point of the flat ``f`` [Hz], ``a`` [m s-2] into the
    :data:`VelocityOutputs` ``out``, in parallel; ``constants`` the
    :data:`ForceConstants`, ``levels`` the :data:`FrictionLevels`, ``budget`` a
    :data:`~study.kernels.budget.Budget`. Points too near lift-off to decide here get
    the status ``LIFT_UNDECIDED`` (see :func:`velocity_points_given`)."""
    n = f.shape[0]
    blocks = (n + POINT_BLOCK - 1) // POINT_BLOCK
    lanes = min(blocks, 256)
    for lane in prange(lanes):
        row = np.empty(N_OUTPUTS)
        for block in range(lane, blocks, lanes):
            for i in range(block * POINT_BLOCK, min(n, (block + 1) * POINT_BLOCK)):
                _velocity_into(i, f, a, constants, levels, budget, out, LIFT_UNDECIDED,
                               row)


@njit(cache=True, nogil=True)
def velocity_points_serial(f, a, constants, levels, budget, out):
    """Same as :func:`velocity_points` on one thread."""
    row = np.empty(N_OUTPUTS)
    for i in range(f.shape[0]):
        _velocity_into(i, f, a, constants, levels, budget, out, LIFT_UNDECIDED, row)


@njit(cache=True, nogil=True)
def velocity_points_given(f, a, lifted, constants, levels, budget, out):
    """Same as :func:`velocity_points_serial` with the lift-off decisions ``lifted``
    given."""
    row = np.empty(N_OUTPUTS)
    for i in range(f.shape[0]):
        _velocity_into(i, f, a, constants, levels, budget, out, 1 if lifted[i] else 0, row)


# Small calls (a fit's few velocity rows, thousands of times): numba types a plain tuple
# of numbers in C but a named tuple in Python, about 2 us each, more than the solve of a
# point. These drivers take the named tuples' fields as plain tuples (in their fields'
# order) and the output arrays one by one, build the named tuples here and run the same
# per-point code, and return how many points they left LIFT_UNDECIDED (no scan of the
# status for the caller).


@njit(cache=True, nogil=True)
def velocity_points_small(f, a, constants, levels, budget, velocity, status):
    """:func:`velocity_points_serial` with plain-tuple arguments: ``constants``, ``levels``
    and ``budget`` the fields of :data:`ForceConstants`, :data:`FrictionLevels` and
    :data:`~study.kernels.budget.Budget`, the outputs ``velocity`` and ``status`` of
    :data:`VelocityOutputs`. Returns the number of points left ``LIFT_UNDECIDED``."""
    out = VelocityOutputs(velocity, status)
    force = ForceConstants(*constants)
    friction = FrictionLevels(*levels)
    limits = Budget(*budget)
    undecided = 0
    row = np.empty(N_OUTPUTS)
    for i in range(f.shape[0]):
        _velocity_into(i, f, a, force, friction, limits, out, LIFT_UNDECIDED, row)
        if status[i] == LIFT_UNDECIDED:
            undecided += 1
    return undecided


@njit(cache=True, nogil=True)
def steady_points_small(f, a, constants, levels, budget, out):
    """:func:`study.kernels.one_way.solve_points_averaged_serial` at ``f`` [Hz], ``a``
    [m s-2], the force amplitudes and the lift-off decision evaluated point by point as
    :func:`velocity_points` does (bit-identical to ``study.model``'s arrays, without
    their temporaries), with plain-tuple arguments as :func:`velocity_points_small`, into
    ``out`` (one row of :data:`study.kernels.one_way.OUTPUT_COLUMNS` a point).

    A point within 1e-13 of the lift-off threshold gets the status ``LIFT_UNDECIDED``
    (its other outputs unset), for the caller to solve with numpy's decision. Returns
    the number of such points.
    """
    force = ForceConstants(*constants)
    friction = FrictionLevels(*levels)
    limits = Budget(*budget)
    undecided = 0
    for i in range(f.shape[0]):
        lift, w, k_re, k_im, one_re, one_im = _lift_off(f[i], a[i], force)
        if lift == LIFT_UNDECIDED:
            out[i, OUT_STATUS] = LIFT_UNDECIDED
            undecided += 1
        elif lift == 1:
            write_lifted(out[i])
        else:
            a_plus, a_minus, b_plus, b_minus = _forces(
                a[i], k_re, k_im, one_re, one_im, force.sin_alpha, force.static_friction,
                force.kinetic_friction)
            solve_point(a_plus, a_minus, b_plus, b_minus, friction, limits, a[i], w,
                         out[i])
    return undecided


@njit(cache=True, nogil=True)
def lift_off_small(f, a, constants, lifted):
    """``lifted[i]`` (bool): whether ``a[i]`` is past lift-off at ``f[i]`` where
    :func:`lift_off_decisions` decides it (``constants`` the fields of
    :data:`ForceConstants` as a plain tuple); returns the number of points it leaves
    undecided (``lifted`` False there), for the caller to decide with numpy."""
    force = ForceConstants(*constants)
    undecided = 0
    for i in range(f.shape[0]):
        decision = _lift_off(f[i], a[i], force)[0]
        lifted[i] = decision == 1
        if decision == LIFT_UNDECIDED:
            undecided += 1
    return undecided
