"""Basins: every motion a drive point holds, with the starts that reach each.

At each drive point the motion from each of a list of starts (each a
:data:`~study.kernels.start.Start`) is followed to the attractor it reaches, verified
as every start is (:func:`~study.kernels.two_way.points.solve_started`; the release as
the point drivers solve it, so that its answer is the ordinary one bit for bit), and the
outcomes are grouped into attractors (:func:`match_attractor`). :func:`basins_point`
fills one point's table of :data:`BASIN_COLUMNS` rows, one per attractor;
:func:`basins_points` (in parallel) and :func:`basins_points_serial` fill many, for the
validating wrapper :func:`study.solvers.basins.basins`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from study.kernels.start import Start, is_release
from study.kernels.structure_vector import COS_ALPHA, GRAVITY, LIFT_OFF_LAW, MASS_RATIO
from study.kernels.two_way.continuation import forget, new_neighbours
from study.kernels.two_way.flight import N_STATE, Z_GAP, Z_GAP_RATE
from study.kernels.two_way.modes import N_MODE, TWO_PI, mode_drive, mode_table
from study.kernels.two_way.points import (
    N_OUT,
    OUT_DELTA,
    OUT_DELTA_RATE,
    OUT_EXPONENT,
    OUT_GAP,
    OUT_GAP_RATE,
    OUT_HOP,
    OUT_MULTIPLIER,
    OUT_PERIOD,
    OUT_SPEED,
    OUT_STATUS,
    OUT_VELOCITY,
    OUT_VELOCITY_ERROR,
    new_workspace,
    solve_from,
    solve_point,
    solve_started,
    start_row,
    start_state,
    static_point,
    stays_static,
    stuck_is_static,
)
from study.kernels.two_way.propagation import stick_releases
from study.model.codes import (
    BOUNCING,
    CHAOTIC,
    CONTINUOUS_SLIDING,
    QUASI_PERIODIC,
    STATIC,
    STICK_SLIP,
)

#: Two periodic orbits are one attractor when their statuses and periods agree and
#: their mean velocities agree to this fraction of the velocity scale a / w (as the
#: multistability count's).
SAME_ORBIT = 1e-9
#: Two irregular motions (chaotic or quasi-periodic) are one attractor when their mean
#: velocities agree within this many of their combined standard errors.
IRREGULAR_SIGMAS = 4.0

#: The columns of an attractor's row, in order, with their units.
BASIN_COLUMNS = (
    ("status", "1", "study.model.status.Status code of the attractor (an outcome "
     "outside the model, LIFT_OFF, FRICTION_PARADOX or NOT_CONVERGED, is one entry)"),
    ("velocity", "m s-1", "mean velocity of the motion on the attractor"),
    ("velocity_error", "m s-1", "its standard error (0: an orbit's, exact)"),
    ("largest_hop", "m", "largest gap between the base and the table over the motion"),
    ("period", "1", "an orbit's period in drive periods (0: static or irregular)"),
    ("multiplier", "1", "an orbit's largest Floquet multiplier modulus"),
    ("exponent", "1", "largest Lyapunov exponent per drive period"),
    ("starts", "1", "starts that reached the attractor"),
    ("first_start", "1", "index of the first start that reached it (the drawn starts "
     "first, then the seeded states: a seeded state's index is the number of drawn "
     "starts plus its own)"),
    ("seeded", "1", "seeded states (a slow sweep's states, not drawn) that reached it"),
)
_NAMES = tuple(name for name, _, _ in BASIN_COLUMNS)

# Numba reads module-level integers as compile-time constants.
B_STATUS = _NAMES.index("status")
B_VELOCITY = _NAMES.index("velocity")
B_VELOCITY_ERROR = _NAMES.index("velocity_error")
B_HOP = _NAMES.index("largest_hop")
B_PERIOD = _NAMES.index("period")
B_MULTIPLIER = _NAMES.index("multiplier")
B_EXPONENT = _NAMES.index("exponent")
B_STARTS = _NAMES.index("starts")
B_FIRST_START = _NAMES.index("first_start")
B_SEEDED = _NAMES.index("seeded")
#: Length of an attractor's row.
N_BASIN = len(BASIN_COLUMNS)


@njit(cache=True, nogil=True, error_model="numpy")
def _periodic(status):
    return status == STICK_SLIP or status == CONTINUOUS_SLIDING or status == BOUNCING


@njit(cache=True, nogil=True, error_model="numpy")
def _irregular(status):
    return status == CHAOTIC or status == QUASI_PERIODIC


@njit(cache=True, nogil=True, error_model="numpy")
def match_attractor(row, table, count, scale):
    """The index in ``table[:count]`` (rows of :data:`BASIN_COLUMNS`) of the attractor
    the outcome ``row`` (a row of the point drivers' output) reached, or -1 for a new
    one. ``scale`` [m s-1] is the velocity scale ``a / w``.

    Periodic orbits (stick-slip, continuous sliding, bouncing) match when the status
    and the period agree and the mean velocities agree to :data:`SAME_ORBIT` ``scale``;
    irregular motions (chaotic or quasi-periodic: either, the distinction being a
    measured one) when their velocities agree within :data:`IRREGULAR_SIGMAS` combined
    standard errors; every other outcome (static, lift-off, the paradox, not
    converged) by its status alone."""
    status = row[OUT_STATUS]
    velocity = row[OUT_VELOCITY]
    for i in range(count):
        other = table[i, B_STATUS]
        if _periodic(int(status)):
            if (other == status and table[i, B_PERIOD] == row[OUT_PERIOD]
                    and abs(table[i, B_VELOCITY] - velocity) <= SAME_ORBIT * scale):
                return i
        elif _irregular(int(status)):
            if _irregular(int(other)):
                reach = IRREGULAR_SIGMAS * math.hypot(table[i, B_VELOCITY_ERROR],
                                                      row[OUT_VELOCITY_ERROR])
                if abs(table[i, B_VELOCITY] - velocity) <= reach:
                    return i
        elif other == status:
            return i
    return -1


@njit(cache=True, nogil=True, error_model="numpy")
def on_the_table(structure, omega, a, table, start):
    """Whether ``start`` (on the table: height 0) is a state the model can hold there:
    the normal force at the start, with the mode on its start, is not negative."""
    state = np.empty(3)
    t_start = start.phase * TWO_PI / omega
    start_state(table, omega, t_start, state, start.factor)
    _, _, acc0 = stick_releases(structure, a, math.cos(omega * t_start), state[0],
                                state[1])
    return (structure[GRAVITY] - a * math.cos(omega * t_start)
            + structure[MASS_RATIO] * structure[COS_ALPHA] * acc0) >= 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def basins_point(structure, omega, a, lifted, budget, phases, factors, heights, seeds,
                 out, reached):
    """The attractors the starts ``(phases[s], factors[s], heights[s])`` reach at one
    drive point (arguments as :func:`~study.kernels.two_way.points.solve_point`).

    ``out`` (starts x :data:`N_BASIN`) receives one row per attractor, in the order
    they were first reached, the rest NaN; ``reached[s]`` the index of the attractor
    start ``s`` reached, or -1 where the start was not drawn: a start on the table that
    the model cannot hold there (a negative normal force) without the lift-off law
    ``flight``. Start 0, the solver's own, is always followed, as the point drivers
    follow it (past the stick's lift-off threshold too), so that the attractor it
    reaches is the one they report. Then each seeded state ``seeds[s]`` (a 5-state at
    phase 0, :func:`solve_seeded`; a row with a NaN is none, ``reached`` -1) is
    followed, its attractor counted in the column ``seeded``, not ``starts``, and
    ``reached[len(phases) + s]`` its index. Returns the number of attractors."""
    flying = structure[LIFT_OFF_LAW] != 0.0
    out[:, :] = np.nan
    row = np.empty(N_OUT)
    table = np.zeros((3, N_MODE))
    mode_table(structure, omega, a, table)
    workspace = new_workspace(structure)
    neighbours = new_neighbours()
    scale = a / omega
    count = 0
    for s in range(phases.shape[0]):
        start = Start(phases[s], factors[s], heights[s])
        if s > 0 and start.height == 0.0 and not flying and not on_the_table(
                structure, omega, a, table, start):
            reached[s] = -1
            continue
        if is_release(start):
            solve_point(structure, omega, a, lifted, budget, 0.0, 1.0, row)
        else:
            solve_started(structure, omega, a, lifted, budget, start, row, neighbours,
                          workspace, True)
        i = _attractor_of(row, out, count, scale, s)
        if i == count:
            count += 1
        out[i, B_STARTS] += 1.0
        reached[s] = i
    drawn = phases.shape[0]
    for s in range(seeds.shape[0]):
        state = seeds[s]
        if not np.all(np.isfinite(state)) or (not flying and (
                state[Z_GAP] != 0.0 or state[Z_GAP_RATE] != 0.0)):
            reached[drawn + s] = -1
            continue
        solve_seeded(structure, omega, a, lifted, budget, state, row, neighbours,
                     workspace)
        i = _attractor_of(row, out, count, scale, drawn + s)
        if i == count:
            count += 1
        out[i, B_SEEDED] += 1.0
        reached[drawn + s] = i
    return count


@njit(cache=True, nogil=True, error_model="numpy")
def _attractor_of(row, out, count, scale, s):
    """The index of the attractor ``row`` reached among ``out[:count]``, or ``count``
    with that new attractor's row filled from ``row`` (first reached by start ``s``)."""
    i = match_attractor(row, out, count, scale)
    if i >= 0:
        return i
    attractor = out[count]
    attractor[B_STATUS] = row[OUT_STATUS]
    attractor[B_VELOCITY] = row[OUT_VELOCITY]
    attractor[B_VELOCITY_ERROR] = row[OUT_VELOCITY_ERROR]
    attractor[B_HOP] = row[OUT_HOP]
    attractor[B_PERIOD] = (row[OUT_PERIOD] if _periodic(int(row[OUT_STATUS]))
                           else 0.0)
    attractor[B_MULTIPLIER] = row[OUT_MULTIPLIER]
    attractor[B_EXPONENT] = row[OUT_EXPONENT]
    attractor[B_STARTS] = 0.0
    attractor[B_FIRST_START] = s
    attractor[B_SEEDED] = 0.0
    return count


@njit(cache=True, nogil=True, error_model="numpy")
def solve_seeded(structure, omega, a, lifted, budget, state, row, neighbours, workspace):
    """The motion from the 5-state ``state`` (``(delta, delta', v, h, h')`` [m, m s-1,
    m s-1, m, m s-1]) at phase 0 into ``row``, followed as a slow sweep follows the
    state it carries to a point (:func:`study.kernels.two_way.protocol.sweep_run`): a
    state stuck on the table that provably stays stuck is the static point's motion,
    every other is followed to its verified reach."""
    start_row(row)
    table = workspace.table
    mode_drive(structure, omega, a, table, 0, searched_only=True)
    mode_drive(structure, omega, a, table, 1, searched_only=True)
    mode_drive(structure, omega, a, table, 2, searched_only=True)
    if not lifted and (a == 0.0 or stays_static(structure, omega, a, table, state, 0.0)):
        static_point(structure, omega, a, False, row, True)
        return
    initial = np.empty(N_STATE)
    initial[:] = state
    solve_from(structure, omega, a, lifted, False, budget, 0.0, initial, row, neighbours,
               workspace, True)
    forget(neighbours)
    stuck_is_static(structure, omega, row, True)


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def basins_points(structure, omega, a, lifted, budget, phases, factors, heights, seeds,
                  out, reached, counts):
    """Fill ``out`` (points x starts x :data:`N_BASIN`, starts the drawn and the seeded),
    ``reached`` (points x starts) and ``counts`` (points) in parallel over points;
    ``seeds`` (points x seeded states x 5) the seeded states of each point."""
    n = omega.shape[0]
    lanes = min(n, 256)
    for lane in prange(lanes):
        for i in range(lane, n, lanes):
            counts[i] = basins_point(structure, omega[i], a[i], lifted[i], budget, phases,
                                     factors, heights, seeds[i], out[i], reached[i])


@njit(cache=True, nogil=True, error_model="numpy")
def basins_points_serial(structure, omega, a, lifted, budget, phases, factors, heights,
                         seeds, out, reached, counts):
    """Same as :func:`basins_points` on one thread."""
    for i in range(omega.shape[0]):
        counts[i] = basins_point(structure, omega[i], a[i], lifted[i], budget, phases,
                                 factors, heights, seeds[i], out[i], reached[i])


@njit(cache=True, nogil=True, error_model="numpy")
def _settled(structure, omega, a, row, table, state):
    """The state at phase 0 of the motion ``row`` reports into ``state`` (an orbit's or
    an irregular motion's phase-0 state, a static point's steady stick response; as a
    slow sweep carries it); False where the motion has none (outside the model, not
    converged)."""
    status = int(row[OUT_STATUS])
    if status == STATIC:
        mode_drive(structure, omega, a, table, 0, searched_only=True)
        start_state(table, omega, 0.0, state, 1.0)
        state[Z_GAP] = 0.0
        state[Z_GAP_RATE] = 0.0
        return True
    if not (_periodic(status) or _irregular(status)):
        return False
    if math.isnan(row[OUT_DELTA]) or math.isnan(row[OUT_SPEED]):
        return False
    state[0] = row[OUT_DELTA]
    state[1] = row[OUT_DELTA_RATE]
    state[2] = row[OUT_SPEED]
    state[Z_GAP] = 0.0 if math.isnan(row[OUT_GAP]) else row[OUT_GAP]
    state[Z_GAP_RATE] = 0.0 if math.isnan(row[OUT_GAP_RATE]) else row[OUT_GAP_RATE]
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def seed_path(structure, omega, a, lifted, budget, begin, end, state):
    """A coarse slow sweep over the drive points ``begin..end-1`` of ``omega``
    [rad s-1], ``a`` [m s-2], ``lifted``: the first from the release, each next one from
    the state carried from the one before (the drive switched at phase 0, the motion
    followed to its verified reach, :func:`solve_seeded`), a point without a state to
    carry making the next start from the release again. ``state`` receives the state at
    phase 0 of the motion at the last point (NaN where it has none)."""
    row = np.empty(N_OUT)
    workspace = new_workspace(structure)
    neighbours = new_neighbours()
    carried = False
    state[:] = np.nan
    for i in range(begin, end):
        if carried:
            solve_seeded(structure, omega[i], a[i], lifted[i], budget, state, row,
                         neighbours, workspace)
        else:
            solve_point(structure, omega[i], a[i], lifted[i], budget, 0.0, 1.0, row)
        carried = _settled(structure, omega[i], a[i], row, workspace.table, state)
    if not carried:
        state[:] = np.nan


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def seed_paths(structure, omega, a, lifted, budget, bounds, states):
    """:func:`seed_path` over each run ``bounds[r]..bounds[r+1]-1``, its end state into
    ``states[r]``, in parallel over runs."""
    for r in prange(bounds.shape[0] - 1):
        seed_path(structure, omega, a, lifted, budget, bounds[r], bounds[r + 1], states[r])


@njit(cache=True, nogil=True, error_model="numpy")
def seed_paths_serial(structure, omega, a, lifted, budget, bounds, states):
    """Same as :func:`seed_paths` on one thread."""
    for r in range(bounds.shape[0] - 1):
        seed_path(structure, omega, a, lifted, budget, bounds[r], bounds[r + 1], states[r])
