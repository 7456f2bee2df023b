"""Dormand-Prince 5(4) stepping shared by the time integrators (numba).

The tableau (Dormand & Prince 1980) with Shampine's (1986) 4th-order continuous
extension in Hairer's DOPRI5 form; one step of any model (:func:`step`, given the
model's right-hand side), its embedded error norm, the step-size controller and the
dense output. The drive is a schedule of segments with a continuous phase
(:func:`table_drive`); ``drive_args = (seg, seg_t0, seg_omega, seg_a, seg_phase0)``.

A model's right-hand side is a numba function ``rhs(model, mode, drive, y, out)``:
``model`` is whatever the model needs (an array or a tuple of arrays), ``mode`` its
contact mode, ``drive`` the table's acceleration [m s-2] at the stage's time.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# Dormand-Prince 5(4) tableau (Dormand & Prince 1980) with Shampine's (1986)
# continuous extension in Hairer's form.
C2, C3, C4, C5 = 0.2, 0.3, 0.8, 8.0 / 9.0
A21 = 0.2
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (
    9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0
)
B1, B3, B4, B5, B6 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
E1, E3, E4, E5, E6, E7 = (
    71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0, -1.0 / 40.0
)
D1 = -12715105075.0 / 11282082432.0
D3 = 87487479700.0 / 32700410799.0
D4 = -10690763975.0 / 1880347072.0
D5 = 701980252875.0 / 199316789632.0
D6 = -1453857185.0 / 822651844.0
D7 = 69997945.0 / 29380423.0

# The stages' coefficients as tables, for the stage loop.
STAGE_NODES = np.array([0.0, C2, C3, C4, C5, 1.0])
STAGE_WEIGHTS = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [A21, 0.0, 0.0, 0.0, 0.0],
    [A31, A32, 0.0, 0.0, 0.0],
    [A41, A42, A43, 0.0, 0.0],
    [A51, A52, A53, A54, 0.0],
    [A61, A62, A63, A64, A65],
])

# Step-size controller (standard for a 5th-order pair with local extrapolation).
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 5.0


@njit(cache=True, nogil=True, inline="always")
def table_drive(t, seg, seg_t0, seg_omega, seg_a, seg_phase0):
    """Table acceleration ``A = a cos(phi)`` [m s-2] and ``-dA/dt = a w sin(phi)``
    [m s^-3] at time ``t`` [s] in segment ``seg``."""
    phase = seg_phase0[seg] + seg_omega[seg] * (t - seg_t0[seg])
    return seg_a[seg] * math.cos(phase), seg_a[seg] * seg_omega[seg] * math.sin(phase)


@njit(cache=True, nogil=True)
def dense_output(theta, h, dense, out):
    """State at ``t0 + theta h`` from the step's continuous extension."""
    one_minus = 1.0 - theta
    for i in range(out.shape[0]):
        out[i] = dense[0, i] + theta * (
            dense[1, i]
            + one_minus * (dense[2, i] + theta * (dense[3, i] + one_minus * dense[4, i]))
        )


@njit(cache=True, nogil=True)
def stage_state(stage, y, h, k, out):
    """``out = y + h sum_l a_{stage, l} k[l]``: the state at which stage ``stage`` (1-5)
    of a Dormand-Prince step evaluates the right-hand side."""
    for i in range(y.shape[0]):
        total = STAGE_WEIGHTS[stage, 0] * k[0, i]
        for j in range(1, stage):
            total += STAGE_WEIGHTS[stage, j] * k[j, i]
        out[i] = y[i] + h * total


@njit(cache=True, nogil=True)
def solution_step(y, h, k, y_new):
    """The step's 5th-order solution from the stages ``k[0..5]``."""
    for i in range(y.shape[0]):
        y_new[i] = y[i] + h * (
            B1 * k[0, i] + B3 * k[2, i] + B4 * k[3, i] + B5 * k[4, i] + B6 * k[5, i]
        )


@njit(cache=True, nogil=True)
def error_and_dense(y, h, k, y_new, err, dense):
    """Embedded error estimate and Shampine's dense-output coefficients (needs the FSAL
    stage ``k[6] = f(t + h, y_new)``)."""
    for i in range(y.shape[0]):
        err[i] = h * (
            E1 * k[0, i] + E3 * k[2, i] + E4 * k[3, i] + E5 * k[4, i] + E6 * k[5, i]
            + E7 * k[6, i]
        )
        dense[0, i] = y[i]
        rise = y_new[i] - y[i]
        dense[1, i] = rise
        slope_gap = h * k[0, i] - rise
        dense[2, i] = slope_gap
        dense[3, i] = rise - h * k[6, i] - slope_gap
        dense[4, i] = h * (
            D1 * k[0, i] + D3 * k[2, i] + D4 * k[3, i] + D5 * k[4, i] + D6 * k[5, i]
            + D7 * k[6, i]
        )


@njit(cache=True, nogil=True, inline="always")
def step(rhs, model, mode, t, h, y, k, drive_args, y_new, err, dense, tmp):
    """One Dormand-Prince step of ``rhs`` from ``(t, y)`` with ``k[0] = f(t, y)`` (FSAL).

    Fills ``k[1..6]``, the 5th-order solution ``y_new``, the error estimate ``err``
    and the dense-output coefficients ``dense`` (5 rows); ``tmp`` is scratch of the
    state's length. ``t`` and ``h`` in s.
    """
    seg, seg_t0, seg_omega, seg_a, seg_phase0 = drive_args
    drive = 0.0
    for stage in range(1, 6):
        stage_state(stage, y, h, k, tmp)
        drive, _ = table_drive(t + STAGE_NODES[stage] * h, seg, seg_t0, seg_omega, seg_a,
                               seg_phase0)
        rhs(model, mode, drive, tmp, k[stage])
    solution_step(y, h, k, y_new)
    # The last stage is at t + h: its drive is the FSAL stage's.
    rhs(model, mode, drive, y_new, k[6])
    error_and_dense(y, h, k, y_new, err, dense)


@njit(cache=True, nogil=True)
def error_norm(err, y, y_new, scale, rtol, atol):
    """RMS of the error estimate relative to ``atol scale + rtol max(|y|, |y_new|)``:
    the step is accepted at ``<= 1``."""
    total = 0.0
    for i in range(err.shape[0]):
        size = atol * scale[i] + rtol * max(abs(y[i]), abs(y_new[i]))
        r = err[i] / size
        total += r * r
    return math.sqrt(total / err.shape[0])


@njit(cache=True, nogil=True)
def shrink_factor(norm):
    """Factor on the step size after a step rejected with error norm ``norm > 1``."""
    if not math.isfinite(norm):
        return MIN_FACTOR
    return max(MIN_FACTOR, SAFETY * norm ** -0.2)


@njit(cache=True, nogil=True)
def growth_factor(norm):
    """Factor on the next step size after a step accepted with error norm ``norm``."""
    if norm == 0.0:
        return MAX_FACTOR
    return min(MAX_FACTOR, SAFETY * norm ** -0.2)


@njit(cache=True, nogil=True)
def workspace(n):
    """Scratch of a step for a state of ``n`` components: ``(k, y_new, err, dense,
    tmp, ystate)``, the stages (7 rows), the new state, the error estimate, the
    dense-output coefficients (5 rows) and two state-sized temporaries."""
    return (np.empty((7, n)), np.empty(n), np.empty(n), np.empty((5, n)), np.empty(n),
            np.empty(n))
