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
start again. A point jumped where the motion it settles on is not the continuation of
the motion before it (:func:`is_jump`: that motion's branch followed to the new drive).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from study.kernels.start import is_release
from study.kernels.structure_vector import LIFT_OFF_LAW
from study.kernels.two_way.branch import (
    FOLLOWED,
    LOST,
    Segment,
    follow_branch,
    new_branch_work,
    on_orbit,
)
from study.kernels.two_way.continuation import forget, new_neighbours
from study.kernels.two_way.flight import N_STATE, Z_GAP, Z_GAP_RATE
from study.kernels.two_way.modes import DrivePoint, mode_drive
from study.kernels.two_way.points import (
    OUT_DELTA,
    OUT_DELTA_RATE,
    OUT_GAP,
    OUT_GAP_RATE,
    OUT_MAP_PASSES,
    OUT_NEWTON_PASSES,
    OUT_PERIOD,
    OUT_SPEED,
    OUT_STATUS,
    OUT_VELOCITY,
    OUT_VELOCITY_ERROR,
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

#: Where the branch the sweep followed goes on to the next point but the motion there is
#: another one, it is still no jump when the followed orbit lost its stability on the
#: way (a period doubling, a torus) and the motion the sweep settles on (the doubled
#: orbit, the quasi-periodic motion around it) has its velocity to this fraction of
#: the velocity scale a / (2 pi f); an irregular motion followed to the next point
#: (which has no orbit to follow) jumped where the velocity changes by more than this
#: fraction plus IRREGULAR_SIGMAS combined standard errors.
JUMP_FRACTION = 0.05
#: Standard errors of two irregular motions' velocities within which they are one.
IRREGULAR_SIGMAS = 4.0


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
def _orbit(status):
    """A status with an orbit to follow: a periodic motion or the static point's."""
    return status in (STATIC, STICK_SLIP, CONTINUOUS_SLIDING, BOUNCING)


@njit(cache=True, nogil=True, error_model="numpy")
def _irregular(status):
    return status == CHAOTIC or status == QUASI_PERIODIC


@njit(cache=True, nogil=True, error_model="numpy")
def is_jump(structure, before, omega0, a0, z0, omega1, a1, row, z1, has_state, branch,
            max_events):
    """Whether the motion a sweep settled on at ``(omega1, a1)`` [rad s-1, m s-2] (its
    output row ``row``, its state at phase 0 ``z1`` where ``has_state``) is not the
    continuation of the motion it was carried from: the row ``before`` at ``(omega0,
    a0)``, whose state at phase 0 ``z0`` (``N_STATE``) was carried.

    - An orbit (or the static point) before is followed along its branch to the new
      drive by pseudo-arclength continuation on the exact period map
      (:func:`~study.kernels.two_way.branch.follow_branch`, through a period halving
      onto the orbit of half its period). Where the branch folds back or ends on the
      way (a fold, a non-smooth end, lift-off without flight) the motion jumped,
      whatever its velocity. Where it goes on, the motion continues it when it is that
      orbit (one of its points within ``SAME_STATE`` of the orbit followed); the
      doubled orbit of a period doubling on the way, or an irregular motion where the
      orbit followed lost its stability, continues it when its velocity is that of the
      orbit followed to :data:`JUMP_FRACTION` of ``a / omega`` (plus
      :data:`IRREGULAR_SIGMAS` standard errors); any other motion is a jump (the
      carried state left the branch's basin). Where the branch cannot be followed at
      all (a step budget spent), the velocity decides, to :data:`JUMP_FRACTION`.
    - An irregular motion before has no orbit to follow: the motion jumped where its
      velocity changes by more than :data:`JUMP_FRACTION` of ``a / omega`` plus
      :data:`IRREGULAR_SIGMAS` combined standard errors.
    - No motion now (lift-off without flight, the paradox, not converged) is no jump:
      its status says what happened, and the sweep starts again after it.

    Returns ``(jumped, newton_passes, map_passes)``, the passes the test took."""
    status0 = int(before[OUT_STATUS])
    status1 = int(row[OUT_STATUS])
    if not has_state or not (_orbit(status1) or _irregular(status1)):
        return False, 0.0, 0.0
    scale = JUMP_FRACTION * a1 / omega1
    if _irregular(status0):
        spread = IRREGULAR_SIGMAS * math.hypot(before[OUT_VELOCITY_ERROR],
                                               row[OUT_VELOCITY_ERROR])
        return abs(row[OUT_VELOCITY] - before[OUT_VELOCITY]) > scale + spread, 0.0, 0.0
    if not _orbit(status0):
        return False, 0.0, 0.0
    if status0 == STATIC and status1 == STATIC:
        return False, 0.0, 0.0
    periods0 = max(int(before[OUT_PERIOD]), 1)
    followed, periods0 = follow_branch(structure, Segment(omega0, a0, omega1, a1), z0,
                                       periods0, branch, max_events)
    if followed.outcome == LOST:
        # The branch could not be followed (a budget spent, a singular system): the
        # velocity alone decides.
        moved = abs(row[OUT_VELOCITY] - before[OUT_VELOCITY]) > scale
        return moved, followed.newton_passes, followed.map_passes
    if followed.outcome != FOLLOWED:
        # The branch folded back or ended before the new drive.
        return True, followed.newton_passes, followed.map_passes
    near = abs(row[OUT_VELOCITY] - followed.velocity) <= scale
    if _irregular(status1):
        spread = IRREGULAR_SIGMAS * row[OUT_VELOCITY_ERROR]
        lost = followed.radius > 1.0
        moved = not (lost and abs(row[OUT_VELOCITY] - followed.velocity) <= scale + spread)
        return moved, followed.newton_passes, followed.map_passes
    flying = structure[LIFT_OFF_LAW] != 0.0
    point = DrivePoint(structure, branch.table, omega1, a1)
    passes = branch.flight.passes if flying else branch.contact.passes
    before_map = passes[1]
    same = on_orbit(point, branch.z, followed.section, periods0, z1, branch, flying,
                    max_events)
    moved = not same
    if moved and followed.flipped and int(row[OUT_PERIOD]) == 2 * periods0 and near:
        # The doubled orbit of the period doubling the branch went through.
        moved = False
    return moved, followed.newton_passes, followed.map_passes + passes[1] - before_map


@njit(cache=True, nogil=True, error_model="numpy")
def sweep_run(structure, omega, a, lifted, budget, start, order, out, jumped):
    """Solve the points ``order`` (indices into ``omega`` [rad s-1], ``a`` [m s-2],
    ``lifted``, the rows of ``out`` and ``jumped``) as one slow sweep, in that order.

    ``jumped[i]`` is 1 where the motion the sweep settles on at point ``i``, started
    from the state carried from the point before, is not the continuation of the motion
    there, else 0 (:func:`is_jump`)."""
    workspace = new_workspace(structure)
    neighbours = new_neighbours()
    branch = new_branch_work(structure)
    state = np.zeros(N_STATE)
    carried_state = np.zeros(N_STATE)
    settled = np.zeros(N_STATE)
    carried = False
    previous = -1
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
        for m in range(N_STATE):
            carried_state[m] = state[m]
        has_state = settled_state(structure, omega[i], a[i], row, workspace.table, settled)
        jumped[i] = 0
        if carried:
            moved, newton_passes, map_passes = is_jump(
                structure, out[previous], omega[previous], a[previous], carried_state,
                omega[i], a[i], row, settled, has_state, branch, budget.max_events)
            jumped[i] = 1 if moved else 0
            row[OUT_NEWTON_PASSES] += newton_passes
            row[OUT_MAP_PASSES] += map_passes
        for m in range(N_STATE):
            state[m] = settled[m]
        carried = has_state
        previous = i


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
