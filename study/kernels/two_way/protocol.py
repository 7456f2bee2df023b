"""Slow sweeps: the drive stepped from point to point of a run at phase 0, the state
carried, the motion followed until it settles again.

A run is a list of drive points in the order the experiment visits them (a line of the
map along the swept axis, up or down). Its first point starts by the declared start (a
:data:`~study.kernels.start.Start`); each later point starts from the state the motion
before it settled on, at phase 0 (the table's velocity ``-(a/w) sin(wt)`` is 0 there
for every drive, so the switch keeps the state relative to the table continuous), and
is solved as any point from a state (:func:`~study.kernels.two_way.points.solve_from`:
Newton's method from the carried state, verified reached, else the iterates followed).
Where a point's motion has no state to carry (outside the model: lift-off without
flight, the friction paradox, a budget spent) the next point starts by the declared
start again.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from study.kernels.start import is_release
from study.kernels.structure_vector import LIFT_OFF_LAW
from study.kernels.two_way.continuation import forget, new_neighbours
from study.kernels.two_way.flight import N_STATE, Z_GAP, Z_GAP_RATE
from study.kernels.two_way.modes import mode_drive
from study.kernels.two_way.points import (
    OUT_DELTA,
    OUT_DELTA_RATE,
    OUT_FROM_START,
    OUT_GAP,
    OUT_GAP_RATE,
    OUT_SPEED,
    OUT_STATUS,
    OUT_VELOCITY,
    new_workspace,
    solve_decided,
    solve_from,
    solve_started,
    start_row,
    start_state,
    static_point,
    stays_static,
    stuck_is_static,
)
from study.model.codes import (
    BOUNCING,
    CHAOTIC,
    CONTINUOUS_SLIDING,
    QUASI_PERIODIC,
    STATIC,
    STICK_SLIP,
)

#: A point of a sweep jumped when the motion from the carried state did not settle on
#: the fixed point Newton's method continues from it (the branch followed ended: a
#: fold, a loss of stability, lift-off) and its mean velocity differs from the point's
#: before it by more than this fraction of the velocity scale a / (2 pi f): a loss of
#: stability onto a nearby motion (a period doubling) is no jump.
JUMP_FRACTION = 0.05


@njit(cache=True, nogil=True, error_model="numpy")
def settled_state(structure, omega, a, out, table, state):
    """The state at phase 0 of the motion the row ``out`` reports, into ``state``
    (``(delta, delta', v, h, h')``): an orbit's state at phase 0 (of a cycle, the one
    it was found at), an irregular motion's last iterate, a static point's steady stick
    response (``table`` is filled for the drive here). Returns False where the motion
    has none (outside the model, not converged)."""
    status = int(out[OUT_STATUS])
    if status == STATIC:
        mode_drive(structure, omega, a, table, 0, searched_only=True)
        start_state(table, omega, 0.0, state, 1.0)
        state[Z_GAP] = 0.0
        state[Z_GAP_RATE] = 0.0
        return True
    if status not in (STICK_SLIP, CONTINUOUS_SLIDING, BOUNCING, CHAOTIC, QUASI_PERIODIC):
        return False
    if math.isnan(out[OUT_DELTA]) or math.isnan(out[OUT_SPEED]):
        return False
    state[0] = out[OUT_DELTA]
    state[1] = out[OUT_DELTA_RATE]
    state[2] = out[OUT_SPEED]
    gap = out[OUT_GAP]
    rate = out[OUT_GAP_RATE]
    state[Z_GAP] = 0.0 if math.isnan(gap) else gap
    state[Z_GAP_RATE] = 0.0 if math.isnan(rate) else rate
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _first_point(structure, omega, a, lifted, budget, start, out, neighbours, workspace):
    """A run's first point (or the point after one without a state), by ``start``, as
    the point drivers solve any point from it (not continued)."""
    forget(neighbours)
    if not is_release(start):
        solve_started(structure, omega, a, lifted, budget, start, out, neighbours,
                      workspace, True)
        return
    static = static_point(structure, omega, a, lifted, out, True)
    if static and not (lifted and structure[LIFT_OFF_LAW] != 0.0):
        return
    solve_decided(structure, omega, a, lifted, static, budget, 0.0, 1.0, out, neighbours,
                  workspace, True)
    forget(neighbours)


@njit(cache=True, nogil=True, error_model="numpy")
def sweep_run(structure, omega, a, lifted, budget, start, order, out, jumped):
    """Solve the points ``order`` (indices into ``omega`` [rad s-1], ``a`` [m s-2],
    ``lifted``, the rows of ``out`` and ``jumped``) as one slow sweep, in that order.

    ``jumped[i]`` is 1 where point ``i``, started from the carried state, did not
    settle on the fixed point Newton's method found from it and its mean velocity
    differs from the previous point's by more than :data:`JUMP_FRACTION` of
    ``a / omega`` (both with a velocity), else 0."""
    workspace = new_workspace(structure)
    neighbours = new_neighbours()
    state = np.zeros(N_STATE)
    carried = False
    previous = np.nan
    for k in range(order.shape[0]):
        i = order[k]
        row = out[i]
        if carried:
            start_row(row)
            table = workspace.table
            mode_drive(structure, omega[i], a[i], table, 0, searched_only=True)
            mode_drive(structure, omega[i], a[i], table, 1, searched_only=True)
            mode_drive(structure, omega[i], a[i], table, 2, searched_only=True)
            if not lifted[i] and (a[i] == 0.0 or stays_static(structure, omega[i], a[i],
                                                              table, state, 0.0)):
                # Most of a map's points: stuck and provably staying stuck, the
                # motion is the static point's, decided without following it. On a
                # still table (a = 0) every motion dissipates to that rest, and the
                # drive's scales, which the search measures distances by, vanish.
                static_point(structure, omega[i], a[i], False, row, True)
            else:
                solve_from(structure, omega[i], a[i], lifted[i], False, budget, 0.0,
                           state, row, neighbours, workspace, True)
                forget(neighbours)
                stuck_is_static(structure, omega[i], row, True)
        else:
            _first_point(structure, omega[i], a[i], lifted[i], budget, start, row,
                         neighbours, workspace)
        velocity = row[OUT_VELOCITY]
        jumped[i] = 1 if carried and row[OUT_FROM_START] != 1.0 and abs(
            velocity - previous) > JUMP_FRACTION * a[i] / omega[i] else 0
        previous = velocity
        carried = settled_state(structure, omega[i], a[i], row, workspace.table, state)


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def sweep_points(structure, omega, a, lifted, budget, start, order, bounds, out, jumped):
    """The runs ``order[bounds[r]:bounds[r + 1]]`` of slow sweeps (:func:`sweep_run`),
    each in order on one thread, in parallel over runs."""
    for r in prange(bounds.shape[0] - 1):
        sweep_run(structure, omega, a, lifted, budget, start, order[bounds[r]:bounds[r + 1]],
                  out, jumped)


@njit(cache=True, nogil=True, error_model="numpy")
def sweep_points_serial(structure, omega, a, lifted, budget, start, order, bounds, out,
                        jumped):
    """Same as :func:`sweep_points` on one thread."""
    for r in range(bounds.shape[0] - 1):
        sweep_run(structure, omega, a, lifted, budget, start, order[bounds[r]:bounds[r + 1]],
                  out, jumped)
