"""The multistability check: the distinct stable orbits reached from several starts.

:func:`attractors_point` fills one row of :data:`ATTRACTOR_COLUMNS`;
:func:`attractors_points` (in parallel) and :func:`attractors_points_serial` fill a
table of them for the validating wrapper :func:`study.solvers.attractors.attractors`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from study.kernels.structure_vector import COS_ALPHA, GRAVITY, LIFT_OFF_LAW, MASS_RATIO
from study.kernels.two_way.modes import N_MODE, TWO_PI, mode_table
from study.kernels.two_way.points import (
    N_OUT,
    OUT_PERIOD,
    OUT_STATUS,
    OUT_VELOCITY,
    OUT_VELOCITY_ERROR,
    solve_drop,
    solve_point,
    start_state,
)
from study.kernels.two_way.propagation import stick_releases
from study.model.codes import (
    CHAOTIC,
    FRICTION_PARADOX,
    LIFT_OFF,
    NOT_CONVERGED,
    QUASI_PERIODIC,
    STATIC,
)

# Starting states of the multistability check: rest at these drive phases [periods]
# with the mode on these multiples of its steady response.
START_PHASES = (0.0, 0.25, 0.5, 0.75)
START_FACTORS = (1.0, 0.0, 2.0)
# With flight, also drops: the base released at rest relative to the table from these
# heights [m] at these drive phases [periods], the mode on its steady stick response.
DROP_HEIGHTS = (0.5e-3, 1e-3, 3e-3)
DROP_PHASES = (0.0, 0.25, 0.5, 0.75)
# Two orbits are the same attractor when their periods agree and their mean velocities
# agree to this fraction of the velocity scale a / w.
SAME_ORBIT = 1e-9
# Two irregular motions are the same attractor when their time-averaged velocities
# agree within this many of their standard errors.
IRREGULAR_SIGMAS = 4.0

#: The columns of :func:`attractors_point`'s output row, in order, with their units.
ATTRACTOR_COLUMNS = (
    ("count", "1", "distinct outcomes: stable orbits, lift-off, friction paradox"),
    ("spread", "m s-1", "largest minus smallest mean velocity of the orbits found"),
    ("starts_converged", "1", "starting states that reached an outcome"),
)
_NAMES = tuple(name for name, _, _ in ATTRACTOR_COLUMNS)

# Numba reads module-level integers as compile-time constants.
OUT_COUNT = _NAMES.index("count")
OUT_SPREAD = _NAMES.index("spread")
OUT_STARTS_CONVERGED = _NAMES.index("starts_converged")
#: Length of an output row.
N_ATTRACTOR_OUT = len(ATTRACTOR_COLUMNS)


@njit(cache=True, nogil=True, error_model="numpy")
def _tally(row, velocities, periods, count, converged, others, scale):
    """Add the outcome ``row`` (of :func:`solve_point`) to the distinct orbits found so
    far: ``(count, converged, others)`` updated."""
    status = int(row[OUT_STATUS])
    if status == NOT_CONVERGED:
        return count, converged, others
    converged += 1
    if status == LIFT_OFF:
        return count, converged, others | 1
    if status == FRICTION_PARADOX:
        return count, converged, others | 2
    period = 0.0 if status == STATIC else row[OUT_PERIOD]
    reach = SAME_ORBIT * scale
    if status == CHAOTIC or status == QUASI_PERIODIC:
        # An irregular motion: one attractor whatever the start, its time averages
        # alike within their errors (period -1 marks it).
        period = -1.0
        reach = max(reach, IRREGULAR_SIGMAS * row[OUT_VELOCITY_ERROR])
    for i in range(count):
        if periods[i] == period and abs(velocities[i] - row[OUT_VELOCITY]) <= reach:
            return count, converged, others
    velocities[count] = row[OUT_VELOCITY]
    periods[count] = period
    return count + 1, converged, others


@njit(cache=True, nogil=True, error_model="numpy")
def attractors_point(structure, omega, a, lifted, budget, out):
    """Distinct stable orbits reached from the starting states above (arguments as
    :func:`~study.kernels.two_way.points.solve_point`).

    ``out`` receives one row of :data:`ATTRACTOR_COLUMNS`: the number of distinct
    orbits (LIFT_OFF or FRICTION_PARADOX outcomes count as one outcome each), the
    spread of their mean velocities [m s-1], and how many starts reached an outcome.
    Starts off the table (``n < 0``) are skipped. With the lift-off law ``flight``
    the drops of :data:`DROP_HEIGHTS` at :data:`DROP_PHASES` are further starts, a
    bouncing orbit is an orbit, and a static outcome is one orbit among the others
    (velocity 0, period 0) rather than the answer for every start.
    """
    row = np.empty(N_OUT)
    flying = structure[LIFT_OFF_LAW] != 0.0
    n_starts = len(START_PHASES) * len(START_FACTORS)
    n_drops = len(DROP_HEIGHTS) * len(DROP_PHASES) if flying else 0
    velocities = np.empty(n_starts + n_drops)
    periods = np.empty(n_starts + n_drops)
    count = 0
    converged = 0
    others = 0  # bit 1: lift-off seen, bit 2: paradox seen
    scale = a / omega
    table = np.zeros((3, N_MODE))
    mode_table(structure, omega, a, table)
    start = np.empty(3)
    for phase in START_PHASES:
        for factor in START_FACTORS:
            t_start = phase * TWO_PI / omega
            start_state(table, omega, t_start, start, factor)
            _, _, acc0 = stick_releases(structure, a, math.cos(omega * t_start), start[0],
                                        start[1])
            if (structure[GRAVITY] - a * math.cos(omega * t_start)
                    + structure[MASS_RATIO] * structure[COS_ALPHA] * acc0) < 0.0:
                # A start off the table is no state of the model.
                continue
            solve_point(structure, omega, a, lifted, budget, t_start, factor, row)
            status = int(row[OUT_STATUS])
            if status == STATIC and not flying:
                out[OUT_COUNT] = 1.0
                out[OUT_SPREAD] = 0.0
                out[OUT_STARTS_CONVERGED] = n_starts
                return
            count, converged, others = _tally(row, velocities, periods, count, converged,
                                              others, scale)
    if flying:
        for height in DROP_HEIGHTS:
            for phase in DROP_PHASES:
                solve_drop(structure, omega, a, budget, phase * TWO_PI / omega, height, row)
                count, converged, others = _tally(row, velocities, periods, count,
                                                  converged, others, scale)
    spread = 0.0
    if count > 0:
        spread = np.max(velocities[:count]) - np.min(velocities[:count])
    out[OUT_COUNT] = count + (others & 1) + ((others >> 1) & 1)
    out[OUT_SPREAD] = spread
    out[OUT_STARTS_CONVERGED] = converged


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def attractors_points(structure, omega, a, lifted, budget, out):
    """Fill ``out`` (n x ``N_ATTRACTOR_OUT``) in parallel over points."""
    n = omega.shape[0]
    lanes = min(n, 256)
    for lane in prange(lanes):
        for i in range(lane, n, lanes):
            attractors_point(structure, omega[i], a[i], lifted[i], budget, out[i])


@njit(cache=True, nogil=True, error_model="numpy")
def attractors_points_serial(structure, omega, a, lifted, budget, out):
    """Same as :func:`attractors_points` on one thread."""
    for i in range(omega.shape[0]):
        attractors_point(structure, omega[i], a[i], lifted[i], budget, out[i])
