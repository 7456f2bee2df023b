"""Newton's method on the period map, with the exact Jacobian of a run.

The period map's Jacobian is the product of the flow's matrix exponentials between
events and the saltation matrices at events (:func:`~study.kernels.two_way.orbit.run`);
the Floquet multipliers are its eigenvalues at the fixed point.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from study.kernels.two_way.modes import TWO_PI
from study.kernels.two_way.orbit import (
    A_BACKWARD,
    A_DISPLACEMENT,
    A_EVENTS,
    A_FORWARD,
    A_SHORTEST,
    A_SLIPS,
    A_START_SLIVER,
    RUN_LIFT_OFF,
    RUN_OK,
    SLIVER,
    run,
)

# Newton iterations on the period map before falling back to the map's iteration.
MAX_NEWTON = 24
# A Newton iterate is a fixed point when the scaled residual is below this, or below
# LOOSE_TOLERANCE and no longer decreasing (the rounding floor of the map).
NEWTON_TOLERANCE = 1e-13
LOOSE_TOLERANCE = 1e-11
# A Newton step this small (scaled) ends the iteration: its own error is ~ its square.
NEWTON_STEP = 1e-7
# Newton iterates after a step and residual below this (scaled), with the events of the
# pass unchanged, are watched for lift-off.
LIFT_WATCH = 1e-3


@njit(cache=True, nogil=True, error_model="numpy")
def solve3(m, r, out):
    """Solve ``m x = r`` (3x3, partial pivoting) into ``out``; False when singular.

    The rows ``(m[i], r[i])`` are held as tuples, not copied into arrays: a Newton pass
    of a continued sweep costs about 2.5 us, and two small arrays a pass cost a few
    percent of it. The operations and their order are those of textbook Gaussian
    elimination with partial pivoting (the first of equal pivots kept)."""
    row0 = (m[0, 0], m[0, 1], m[0, 2], r[0])
    row1 = (m[1, 0], m[1, 1], m[1, 2], r[1])
    row2 = (m[2, 0], m[2, 1], m[2, 2], r[2])
    pivot = row0[0]
    if abs(row1[0]) > abs(pivot):
        pivot = row1[0]
        if abs(row2[0]) > abs(pivot):
            pivot = row2[0]
            row0, row2 = row2, row0
        else:
            row0, row1 = row1, row0
    elif abs(row2[0]) > abs(pivot):
        pivot = row2[0]
        row0, row2 = row2, row0
    if pivot == 0.0 or not math.isfinite(pivot):
        return False
    f = row1[0] / row0[0]
    row1 = (row1[0] - f * row0[0], row1[1] - f * row0[1], row1[2] - f * row0[2],
            row1[3] - f * row0[3])
    f = row2[0] / row0[0]
    row2 = (row2[0] - f * row0[0], row2[1] - f * row0[1], row2[2] - f * row0[2],
            row2[3] - f * row0[3])
    if abs(row2[1]) > abs(row1[1]):
        row1, row2 = row2, row1
    if row1[1] == 0.0 or not math.isfinite(row1[1]):
        return False
    f = row2[1] / row1[1]
    row2 = (row2[0], row2[1] - f * row1[1], row2[2] - f * row1[2], row2[3] - f * row1[3])
    if row2[2] == 0.0 or not math.isfinite(row2[2]):
        return False
    x2 = row2[3] / row2[2]
    x1 = (row1[3] - row1[2] * x2) / row1[1]
    x0 = (row0[3] - row0[1] * x1 - row0[2] * x2) / row0[0]
    out[0] = x0
    out[1] = x1
    out[2] = x2
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def stuck_radius(j00, j01, j10, j11, j22):
    """Largest modulus of the eigenvalues of the finite 3x3 Jacobian ``[[j00, j01, *],
    [j10, j11, *], [0, 0, j22]]`` of an orbit with a stick (``v`` reset)."""
    half = 0.5 * (j00 + j11)
    det = j00 * j11 - j01 * j10
    disc = half * half - det
    if disc < 0.0:
        rho = math.sqrt(max(det, 0.0))
    else:
        root = math.sqrt(disc)
        rho = max(abs(half + root), abs(half - root))
    return max(rho, abs(j22))


@njit(cache=True, nogil=True, error_model="numpy")
def _polished(x, c2, c1, c0):
    """A root ``x`` of ``x^3 - c2 x^2 + c1 x - c0`` after up to two Newton steps that
    lower the residual (the closed form's shift by ``c2 / 3`` costs digits when the roots
    are small beside ``c2``)."""
    value = ((x - c2) * x + c1) * x - c0
    for _ in range(2):
        slope = (3.0 * x - 2.0 * c2) * x + c1
        if slope == 0.0:
            break
        trial = x - value / slope
        trial_value = ((trial - c2) * trial + c1) * trial - c0
        # Only a step that lowers the residual: near a cluster of roots Newton's step
        # from the closed form's rounding can leave it.
        if not abs(trial_value) < abs(value):
            break
        x = trial
        value = trial_value
    return x


@njit(cache=True, nogil=True, error_model="numpy")
def _pair_radius(b, c):
    """Largest modulus of the roots of ``x^2 + b x + c``."""
    half = 0.5 * b
    disc = half * half - c
    if disc < 0.0:
        return math.sqrt(c)
    return abs(half) + math.sqrt(disc)


@njit(cache=True, nogil=True, error_model="numpy")
def cubic_radius(c2, c1, c0):
    """Largest modulus of the roots of ``x^3 - c2 x^2 + c1 x - c0`` (real coefficients).

    Cardano's closed form on the cubic shifted by ``c2 / 3``: with one real root ``r``,
    the complex pair from the quadratic left by dividing out ``x - r``; with three real
    roots, the trigonometric form. Each real root is polished by Newton's method on the
    unshifted cubic. The largest modulus is good to a few ulps of the largest root unless
    two roots nearly coincide (then to about the square root of the rounding, as for any
    eigenvalue method on a nearly defective matrix).
    """
    shift = c2 / 3.0
    p = c1 - c2 * shift
    q = (c1 * shift - c0) - 2.0 * shift * shift * shift
    half = 0.5 * q
    third = p / 3.0
    disc = half * half + third * third * third
    if disc > 0.0:
        # One real root (u - third / u, u chosen away from cancellation), a complex pair.
        u = -(half + math.copysign(math.sqrt(disc), half))
        u = math.copysign(abs(u) ** (1.0 / 3.0), u)
        t = u - third / u if u != 0.0 else 0.0
        r = _polished(t + shift, c2, c1, c0)
        b = r - c2
        return max(abs(r), _pair_radius(b, c1 + r * b))
    if third == 0.0:
        return abs(_polished(shift, c2, c1, c0))
    m = 2.0 * math.sqrt(-third)
    cos3 = min(1.0, max(-1.0, -half / ((-third) * math.sqrt(-third))))
    theta = math.acos(cos3) / 3.0
    radius = 0.0
    for k in range(3):
        r = _polished(m * math.cos(theta - k * (2.0 * math.pi / 3.0)) + shift, c2, c1, c0)
        radius = max(radius, abs(r))
    return radius


@njit(cache=True, nogil=True, error_model="numpy")
def spectral_radius(jac):
    """Largest modulus of the eigenvalues of the 3x3 ``jac`` (the Floquet multipliers),
    from its characteristic polynomial (:func:`cubic_radius`): a LAPACK eigenvalue call
    costs more than a pass of the orbit."""
    # Element by element: np.isfinite(jac) would allocate a 3x3 array at every call.
    for i in range(3):
        for j in range(3):
            if not math.isfinite(jac[i, j]):
                return np.inf
    if jac[2, 0] == 0.0 and jac[2, 1] == 0.0:
        # A stick on the orbit: v is reset, one multiplier is jac[2, 2] (0).
        return stuck_radius(jac[0, 0], jac[0, 1], jac[1, 0], jac[1, 1], jac[2, 2])
    j00, j01, j02 = jac[0, 0], jac[0, 1], jac[0, 2]
    j10, j11, j12 = jac[1, 0], jac[1, 1], jac[1, 2]
    j20, j21, j22 = jac[2, 0], jac[2, 1], jac[2, 2]
    trace = j00 + j11 + j22
    minors = (j00 * j11 - j01 * j10) + (j00 * j22 - j02 * j20) + (j11 * j22 - j12 * j21)
    det = (j00 * (j11 * j22 - j12 * j21) - j01 * (j10 * j22 - j12 * j20)
           + j02 * (j10 * j21 - j11 * j20))
    return cubic_radius(trace, minors, det)


@njit(cache=True, nogil=True, error_model="numpy")
def newton(point, z, periods, section, scales, max_events, record, work):
    """Newton's method on ``P^periods(z) - z`` from ``z`` (updated in place), ``P`` the
    period map of the Poincare section at time ``section`` [s] (``z`` is the state there)
    at the drive point ``point``; residuals and steps are measured in ``scales`` (the
    natural sizes of the state), each pass follows at most ``max_events`` events, and
    ``work`` (3) holds the pass's end state.

    Iterates within ~1e-6 of the orbit (their previous Newton step and residual were
    below ``LIFT_WATCH`` with an unchanged sequence of events; Newton converges
    quadratically) are watched for lift-off.

    Returns
    -------
    flag, converged
        ``RUN_LIFT_OFF`` when a watched iterate leaves the table; else the last
        stretch's flag and whether ``z`` is the fixed point. ``record.jac`` then holds
        the Jacobian of ``P^periods`` at the last iterate and ``record.acc`` the orbit's
        statistics, moved to the fixed point along their gradients (``record.grad``) by
        the last Newton step: what is left is of the order of the step's square.
    """
    acc = record.acc
    jac = record.jac
    grad = record.grad
    span = periods * TWO_PI / point.omega
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
        flag = run(point, work, section, section + span, record, True, margin, max_events)
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
        solved = solve3(jac, residual, step)
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

