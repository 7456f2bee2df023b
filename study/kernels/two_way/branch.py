"""A periodic orbit followed along its branch as the drive changes.

A periodic motion is a fixed point ``z*`` of the period map ``P^N`` (``N`` its period in
drive periods) on a Poincare section; as the drive changes, ``z*`` moves along a
branch, which can end: at a fold (a real Floquet multiplier through +1, where the
branch turns back), at a non-smooth end (an event appears or vanishes and the fixed
point of the new piece of the map lies on the other side: a border-collision fold), or
where the motion leaves the table without flight.

:func:`follow_orbit` follows a fixed point along a straight segment of the drive plane,
``t`` from 0 to 1, by pseudo-arclength continuation on the exact period map: the
tangent of the branch in the scaled space of ``(z, t)`` (the state in its natural
sizes at the start) from the exact Jacobian ``J`` and the parameter derivative of
``P`` (a forward difference), a step along it, and Newton's method on the fixed-point
equations bordered by the arclength condition. A step is accepted only where the
corrector contracts quickly from a first correction small beside the step, the tangent
turns by less than :data:`MOST_TURN` and the largest multiplier changes by less than
:data:`MOST_MULTIPLIER_CHANGE`: near a fold the multipliers change fast, so the steps
shrink there, and the corrector cannot land on a nearby orbit of another branch (on
the maps measured two coexisting hops can lie within 1e-3 of their natural sizes of
each other). A step refused with a converged corrector brackets a kink of the map (an
event that appears or vanishes, where the tangent and the multipliers jump): the steps
then halve towards it until one of at most :data:`KINK_STEP` crosses it. Where the
tangent's ``t`` turns negative the branch folded back before the end of the segment
(:data:`FOLDED`); where a multiplier reaches +1 it is at a fold or a branch point
(:data:`SINGULAR`); where the step falls below :data:`SMALLEST_STEP` it cannot be
followed on (:data:`ENDED`: a non-smooth end, lift-off without flight). Each accepted
step's multipliers are watched for a real one through -1 (a period doubling) and a
complex pair through the unit circle (a torus). :func:`follow_branch` goes on through
a period halving, where an orbit's branch meets the orbit of half its period.

The section lies in the middle of the orbit's longest stretch without events (moved
there again when an event comes near it): a section at an event puts a kink of the map
at its fixed point. With flight the runs record their event times; in contact the
orbit's mode is sampled (:data:`MODE_SAMPLES` a period).

The slow sweep (:mod:`~study.kernels.two_way.protocol`) calls it to tell whether the
motion it settled on is the continuation of the previous point's.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from study.kernels.eigenvalues import eigenvalues
from study.kernels.structure_vector import LIFT_OFF_LAW
from study.kernels.two_way.cycles import state_distance
from study.kernels.two_way.flight import (
    A_EVENT_COUNT,
    A_FIRST_EVENT,
    A_LAST_EVENT,
    A_QUIET_GAP,
    N_FLIGHT_ACC,
    N_ROWS,
    N_STATE,
    Z_GAP,
    Z_GAP_RATE,
    FlightRecord,
    flight_row,
    fly,
)
from study.kernels.two_way.flight_orbit import flight_scales, quiet_section, solve_linear
from study.kernels.two_way.modes import N_MODE, TWO_PI, DrivePoint, mode_constants, mode_drive
from study.kernels.two_way.orbit import (
    A_DISPLACEMENT,
    A_START_SLIVER,
    N_ACC,
    RUN_OK,
    PassRecord,
    run,
)

#: Outcomes of :func:`follow_orbit`: the orbit followed to the end of the segment; its
#: branch folded back on the segment; a multiplier reached +1 on it; it could not be
#: followed across a shortest step (a non-smooth end, lift-off without flight); the
#: step budget was spent.
FOLLOWED = 1
FOLDED = 2
SINGULAR = 3
ENDED = 0
LOST = -1
#: A multiplier within this of +1 at an accepted step: the branch is at a fold or a
#: branch point (where another branch crosses it, as the orbit of half its period does
#: an orbit's at that orbit's period doubling), which pseudo-arclength continuation
#: cannot pass: :data:`SINGULAR`.
SINGULAR_MARGIN = 1e-5

#: Newton's first correction from the branch's start, in the natural sizes of the state:
#: the start must be the fixed point to the solver's precision.
FIRST_CORRECTION = 1e-3
#: A step's first correction must be below this fraction of the step's length (in the
#: scaled space of state and parameter) ...
STEP_CORRECTION = 0.3
#: ... and every later correction below this factor times the one before (Newton's
#: method from the prediction converges quadratically within its basin).
CONTRACTION = 0.25
#: Newton's iteration ends when a correction is below this (scaled).
CORRECTION_TOLERANCE = 1e-10
#: Newton iterations of a step before it is refused.
MAX_CORRECTIONS = 8
#: The largest angle [rad] between the tangents at the ends of an accepted step.
MOST_TURN = 0.5
#: The largest change of the largest multiplier modulus over an accepted step.
MOST_MULTIPLIER_CHANGE = 0.15
#: Steps shorter than this (in the scaled space) are accepted on the corrector's
#: convergence alone: the map is only piecewise smooth, and across a kink (an event
#: that appears or vanishes) the tangent and the multipliers change at once.
KINK_STEP = 2.0 ** -14
#: The shortest step: a branch that cannot be followed across one ended there.
SMALLEST_STEP = 2.0 ** -22
#: Steps of one segment before it is given up.
MAX_STEPS = 200
#: The parameter's forward difference, in units of the segment.
DERIVATIVE_STEP = 1e-6
#: Two states at one drive point within this scaled distance are one orbit's.
SAME_STATE = 1e-6
#: A section is moved (to the middle of the orbit's longest stretch without events)
#: when an event of an accepted step comes within this fraction of that stretch of it.
SECTION_MARGIN = 0.25
#: Length of the extended vectors (the state and the segment's parameter ``t``).
N_EXTENDED = N_STATE + 1

#: A branch's scratch: the mode table of the drive point a pass is at (``N_ROWS`` x
#: ``N_MODE``); the state, a pass's end state, the residual and the correction (each
#: ``N_STATE``); the natural sizes at the drive point and at the segment's start; the
#: records of a pass in contact (3-state) and with flight (5-state); the multipliers'
#: real and imaginary parts; a pass's Jacobian; the extended point, its prediction,
#: the accepted point and its tangent, a new tangent (``N_EXTENDED``), the bordered
#: system and its right-hand side; the parameter derivative of the map; the flag of
#: the last pass (1).
BranchWork = namedtuple("BranchWork", (
    "table", "z", "work", "residual", "step", "scales", "reference", "contact", "flight",
    "real", "imag", "jac", "point", "predicted", "accepted", "tangent", "turned",
    "system", "rhs", "derivative", "flags"))


@njit(cache=True, nogil=True, error_model="numpy")
def new_branch_work(structure):
    """A fresh :data:`BranchWork` for ``structure`` (its mode table's rows hold their
    constants; each pass fills its drive's columns)."""
    table = np.zeros((N_ROWS, N_MODE))
    for row in range(3):
        mode_constants(structure, table, row)
    return BranchWork(
        table, np.zeros(N_STATE), np.zeros(N_STATE), np.zeros(N_STATE), np.zeros(N_STATE),
        np.ones(N_STATE), np.ones(N_STATE),
        PassRecord(np.zeros(N_ACC), np.eye(3), np.zeros((3, 3)), np.zeros(2)),
        FlightRecord(np.zeros(N_FLIGHT_ACC), np.eye(N_STATE), np.zeros((N_STATE, N_STATE)),
                     np.zeros((N_STATE, N_STATE)), np.zeros(2)),
        np.zeros(N_STATE), np.zeros(N_STATE), np.eye(N_STATE), np.zeros(N_EXTENDED),
        np.zeros(N_EXTENDED), np.zeros(N_EXTENDED), np.zeros(N_EXTENDED),
        np.zeros(N_EXTENDED), np.zeros((N_EXTENDED, N_EXTENDED)), np.zeros(N_EXTENDED),
        np.zeros(N_STATE), np.zeros(1))


#: A straight segment of the drive plane: ``t`` in [0, 1] goes from ``(omega0, a0)`` to
#: ``(omega1, a1)`` [rad s-1, m s-2].
Segment = namedtuple("Segment", ("omega0", "a0", "omega1", "a1"))


@njit(cache=True, nogil=True, error_model="numpy")
def drive_at(structure, work, segment, t, flying):
    """The drive point at ``t`` on ``segment``, with ``work.table`` and ``work.scales``
    filled for it."""
    omega = segment.omega0 + t * (segment.omega1 - segment.omega0)
    a = segment.a0 + t * (segment.a1 - segment.a0)
    table = work.table
    for row in range(3):
        mode_drive(structure, omega, a, table, row)
    point = DrivePoint(structure, table, omega, a)
    sizes = flight_scales(point)
    scales = work.scales
    for i in range(3):
        scales[i] = sizes[i]
    if flying:
        flight_row(structure, table)
        scales[Z_GAP] = sizes[Z_GAP]
        scales[Z_GAP_RATE] = sizes[Z_GAP_RATE]
    else:
        scales[Z_GAP] = 1.0
        scales[Z_GAP_RATE] = 1.0
    return point


@njit(cache=True, nogil=True, error_model="numpy")
def period_pass(point, z, section, periods, work, flying, want_jac, max_events):
    """One pass of ``P^periods`` from ``z`` at time ``section`` [s] into ``work.work``,
    its Jacobian (``N_STATE`` x ``N_STATE``; in contact the last two rows and columns
    are those of the identity) into ``work.jac`` when ``want_jac``. Returns the run's
    flag (``RUN_OK`` or why it stopped: lift-off in contact, the paradox, the budget),
    the displacement over the pass [m] and whether it began in a sliver of slip."""
    span = periods * TWO_PI / point.omega
    end = work.work
    jac = work.jac
    if flying:
        record = work.flight
        record.acc[:] = 0.0
        record.passes[0 if want_jac else 1] += 1.0
        for i in range(N_STATE):
            end[i] = z[i]
            for j in range(N_STATE):
                record.jac[i, j] = 1.0 if i == j else 0.0
        flag = fly(point, end, section, section + span, record, want_jac, False, max_events)
        work.flags[0] = flag
        if want_jac:
            for i in range(N_STATE):
                for j in range(N_STATE):
                    jac[i, j] = record.jac[i, j]
        return flag, record.acc[A_DISPLACEMENT], record.acc[A_START_SLIVER]
    record = work.contact
    record.acc[:] = 0.0
    for i in range(3):
        end[i] = z[i]
        for j in range(3):
            record.jac[i, j] = 1.0 if i == j else 0.0
    end[Z_GAP] = 0.0
    end[Z_GAP_RATE] = 0.0
    # Lift-off ends the pass: without flight the orbit does not exist past it.
    flag = run(point, end, section, section + span, record, want_jac, 0.0, max_events)
    work.flags[0] = flag
    if want_jac:
        for i in range(N_STATE):
            for j in range(N_STATE):
                jac[i, j] = (record.jac[i, j] if i < 3 and j < 3 else
                             (1.0 if i == j else 0.0))
    return flag, record.acc[A_DISPLACEMENT], record.acc[A_START_SLIVER]


@njit(cache=True, nogil=True, error_model="numpy")
def flow(point, z, t_begin, t_end, work, flying, max_events):
    """``z`` followed from ``t_begin`` to ``t_end`` [s] (in place, no Jacobian); the
    run's flag."""
    if t_end <= t_begin:
        return RUN_OK
    if flying:
        record = work.flight
        record.acc[:] = 0.0
        record.passes[1] += 1.0
        return fly(point, z, t_begin, t_end, record, False, False, max_events)
    record = work.contact
    record.acc[:] = 0.0
    return run(point, z, t_begin, t_end, record, False, 0.0, max_events)


@njit(cache=True, nogil=True, error_model="numpy")
def multiplier_signature(work, flying):
    """``(above, below, outside, radius)`` of ``work.jac``'s eigenvalues (the Floquet
    multipliers): the numbers of real multipliers above +1 (their parity is the sign of
    ``det(J - I)``, which changes at a fold) and below -1 (which changes at a period
    doubling), of complex pairs with modulus above 1 (at a torus), and the largest
    modulus. ``above`` is -1 where the eigenvalues could not be computed."""
    n = N_STATE if flying else 3
    real = work.real
    imag = work.imag
    if not eigenvalues(work.jac[:n, :n].copy(), real[:n], imag[:n]):
        return -1, 0, 0, np.inf
    above = 0
    below = 0
    outside = 0
    radius = 0.0
    for i in range(n):
        modulus = math.hypot(real[i], imag[i])
        radius = max(radius, modulus)
        if imag[i] == 0.0:
            if real[i] > 1.0:
                above += 1
            elif real[i] < -1.0:
                below += 1
        elif imag[i] > 0.0 and modulus > 1.0:
            outside += 1
    return above, below, outside, radius


#: Pieces of a period in which a contact orbit's mode is sampled to place its section.
MODE_SAMPLES = 32


@njit(cache=True, nogil=True, error_model="numpy")
def contact_section(point, z, section, periods, work, max_events):
    """For a contact orbit through ``z`` on the section at ``section`` [s]: the phase
    (fraction of ``periods`` periods from phase 0) of the middle of its longest stretch
    in one contact mode (stuck, slipping forward or backward), the mode sampled at
    :data:`MODE_SAMPLES` times a period, and whether ``section`` lies within
    :data:`SECTION_MARGIN` of that stretch of a change of mode. The contact run records
    no event times, so they are found to a sample. ``z`` is kept. Returns ``(phase,
    crowded)``; ``(section's phase, False)`` where a run stops."""
    span = periods * TWO_PI / point.omega
    samples = MODE_SAMPLES * periods
    piece = span / samples
    # The samples together make one pass over the orbit: counted as one.
    passes = work.contact.passes
    counted = passes[1] + 1.0
    state = work.residual
    for i in range(N_STATE):
        state[i] = z[i]
    first = 0.0 if state[2] == 0.0 else (1.0 if state[2] > 0.0 else -1.0)
    previous = first
    # The boundaries (in samples from the section) where the mode changed.
    first_change = -1
    last_change = -1
    longest = 0
    middle = 0.0
    for k in range(samples):
        if flow(point, state, section + k * piece, section + (k + 1) * piece, work, False,
                 max_events) != RUN_OK:
            return (section / span) % 1.0, False
        mode = 0.0 if state[2] == 0.0 else (1.0 if state[2] > 0.0 else -1.0)
        if mode != previous:
            if first_change < 0:
                first_change = k
            elif k - last_change > longest:
                longest = k - last_change
                middle = 0.5 * (k + last_change)
            last_change = k
        previous = mode
    passes[1] = counted
    if first_change < 0:
        return (section / span) % 1.0, False
    wrap = first_change + samples - last_change
    if wrap >= longest:
        longest = wrap
        middle = last_change + 0.5 * wrap
    # Changes are known to a sample: the section is crowded when one lies within the
    # margin, a sample included.
    nearest = min(first_change, samples - last_change)
    crowded = nearest < SECTION_MARGIN * longest + 1
    phase = ((section + (middle + 0.5) * piece) / span) % 1.0
    return phase, crowded


@njit(cache=True, nogil=True, error_model="numpy")
def near_one(work, flying):
    """A real multiplier of the last :func:`multiplier_signature` (its eigenvalues in
    ``work.real``, ``work.imag``) within :data:`SINGULAR_MARGIN` of +1."""
    n = N_STATE if flying else 3
    for i in range(n):
        if work.imag[i] == 0.0 and abs(work.real[i] - 1.0) < SINGULAR_MARGIN:
            return True
    return False


@njit(cache=True, nogil=True, error_model="numpy")
def crowded_section(work, section, span):
    """An event of the flight pass just made from ``section`` [s] lies within
    :data:`SECTION_MARGIN` of the longest stretch without events from it."""
    acc = work.flight.acc
    if acc[A_EVENT_COUNT] == 0.0:
        return False
    nearest = min(acc[A_FIRST_EVENT] - section, section + span - acc[A_LAST_EVENT])
    quiet = max(acc[A_QUIET_GAP], (acc[A_FIRST_EVENT] - section)
                + (section + span - acc[A_LAST_EVENT]))
    return nearest < SECTION_MARGIN * quiet


@njit(cache=True, nogil=True, error_model="numpy")
def fixed_point(point, z, section, periods, work, flying, max_events, first):
    """Newton's method on ``P^periods(z) - z`` at the drive ``point`` from ``z`` (in
    place) on the section at ``section`` [s], held to contract (each correction below
    :data:`CONTRACTION` times the one before) from a first correction below ``first``
    (scaled by ``work.scales``). Returns ``(converged, displacement, first_size)``:
    ``work.jac`` then holds the Jacobian of the last pass (within
    :data:`CORRECTION_TOLERANCE` of the fixed point), ``displacement`` [m] that pass's.
    """
    n = N_STATE if flying else 3
    scales = work.scales
    residual = work.residual
    step = work.step
    end = work.work
    jac = work.jac
    previous = np.inf
    first_size = np.nan
    for iteration in range(MAX_CORRECTIONS):
        flag, displacement, sliver = period_pass(point, z, section, periods, work, flying,
                                                 True, max_events)
        if flag != RUN_OK:
            return False, np.nan, first_size
        for i in range(n):
            residual[i] = z[i] - end[i]
            jac[i, i] -= 1.0
        solved = solve_linear(jac[:n, :n], residual[:n], step[:n])
        for i in range(n):
            jac[i, i] += 1.0
        if not solved:
            return False, np.nan, first_size
        size = 0.0
        for i in range(n):
            size = max(size, abs(step[i]) / scales[i])
        if iteration == 0:
            first_size = size
        if not math.isfinite(size) or (iteration == 0 and size > first):
            return False, np.nan, first_size
        if size > CONTRACTION * previous and size > CORRECTION_TOLERANCE:
            return False, np.nan, first_size
        for i in range(n):
            z[i] += step[i]
        if sliver != 0.0:
            # The orbit sticks across the section (see study.kernels.two_way.newton).
            z[2] = 0.0
        if flying and z[Z_GAP] < 0.0:
            return False, np.nan, first_size
        if size <= CORRECTION_TOLERANCE:
            return True, displacement, first_size
        previous = size
    return False, np.nan, first_size


@njit(cache=True, nogil=True, error_model="numpy")
def parameter_derivative(structure, work, segment, t, z, phase, periods, flying, max_events):
    """The derivative of ``P^periods`` in the segment's ``t`` at the fixed point ``z``
    (the map on the section at ``phase`` of the period) into ``work.derivative``, by a
    forward difference (``P(z) = z`` at ``t`` to the corrector's tolerance); the drive
    left at ``t``. False where the pass stopped."""
    step = DERIVATIVE_STEP if t + DERIVATIVE_STEP <= 1.0 else -DERIVATIVE_STEP
    point = drive_at(structure, work, segment, t + step, flying)
    span = periods * TWO_PI / point.omega
    flag, _, _ = period_pass(point, z, phase * span, periods, work, flying, False,
                             max_events)
    for i in range(N_STATE):
        work.derivative[i] = (work.work[i] - z[i]) / step
    drive_at(structure, work, segment, t, flying)
    return flag == RUN_OK


@njit(cache=True, nogil=True, error_model="numpy")
def branch_tangent(work, n, out):
    """The branch's unit tangent in the scaled space ``(z / reference, t)`` into ``out``
    (``N_EXTENDED``; the state's entries past ``n`` 0, the parameter's at
    ``N_STATE``), from ``work.jac`` and ``work.derivative``, oriented along
    ``work.tangent`` (the bordering row). False where the bordered system is
    singular."""
    m = n + 1
    system = work.system
    rhs = work.rhs
    reference = work.reference
    for i in range(n):
        for j in range(n):
            system[i, j] = ((work.jac[i, j] - (1.0 if i == j else 0.0)) * reference[j]
                            / reference[i])
        system[i, n] = work.derivative[i] / reference[i]
        rhs[i] = 0.0
    for j in range(n):
        system[n, j] = work.tangent[j]
    system[n, n] = work.tangent[N_STATE]
    rhs[n] = 1.0
    # solve_linear copies its right-hand side first: the solution may take its place.
    solution = rhs
    if not solve_linear(system[:m, :m], rhs[:m], solution[:m]):
        return False
    norm = 0.0
    for i in range(m):
        norm += solution[i] * solution[i]
    norm = math.sqrt(norm)
    if not (norm > 0.0 and math.isfinite(norm)):
        return False
    for i in range(N_EXTENDED):
        out[i] = 0.0
    for i in range(n):
        out[i] = solution[i] / norm
    out[N_STATE] = solution[n] / norm
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def moved_tangent(work, n, previous, out):
    """The branch's tangent into ``out`` after its section moved: the state's
    coordinates changed, so the tangent before (``previous``) can only orient it by its
    drive component, which is the same on every section; ``work.tangent`` is
    overwritten (``previous`` may be it)."""
    way = 1.0 if previous[N_STATE] >= 0.0 else -1.0
    for i in range(N_EXTENDED):
        work.tangent[i] = 0.0
    work.tangent[N_STATE] = way
    return branch_tangent(work, n, out)


@njit(cache=True, nogil=True, error_model="numpy")
def arclength_step(structure, work, segment, phase, periods, flying, max_events, h,
                   kink, fresh=False):
    """Newton's method on the fixed-point equations bordered by the arclength condition
    ``tangent . (y - predicted) = 0``, from ``work.predicted`` into ``work.point`` (the
    scaled ``(z / reference, t)``), the parameter derivative held at the accepted
    point's (``work.derivative``), or, with ``fresh``, taken anew at each iterate by a
    forward difference (a pass more an iteration: from a branch point, whose derivative
    lacks the very direction the new branch leaves in). Held as :func:`fixed_point`,
    the first correction below :data:`STEP_CORRECTION` ``h`` (unless ``kink``). Returns
    ``(converged, displacement)``; the drive is left at the point's ``t``."""
    n = N_STATE if flying else 3
    m = n + 1
    y = work.point
    reference = work.reference
    tangent = work.tangent
    predicted = work.predicted
    system = work.system
    rhs = work.rhs
    z = work.z
    for i in range(N_EXTENDED):
        y[i] = predicted[i]
    previous = np.inf
    derivative = work.step
    for i in range(N_STATE):
        derivative[i] = work.derivative[i]
    for iteration in range(MAX_CORRECTIONS):
        t = y[N_STATE]
        point = drive_at(structure, work, segment, t, flying)
        span = periods * TWO_PI / point.omega
        for i in range(n):
            z[i] = y[i] * reference[i]
        flag, displacement, sliver = period_pass(point, z, phase * span, periods, work,
                                                 flying, True, max_events)
        if flag != RUN_OK:
            return False, np.nan
        if fresh:
            mapped = work.residual
            for i in range(N_STATE):
                mapped[i] = work.work[i]
            step = DERIVATIVE_STEP if t + DERIVATIVE_STEP <= 1.0 else -DERIVATIVE_STEP
            shifted = drive_at(structure, work, segment, t + step, flying)
            flag, _, _ = period_pass(shifted, z, phase * periods * TWO_PI / shifted.omega,
                                     periods, work, flying, False, max_events)
            if flag != RUN_OK:
                return False, np.nan
            for i in range(N_STATE):
                derivative[i] = (work.work[i] - mapped[i]) / step
                work.work[i] = mapped[i]
            point = drive_at(structure, work, segment, t, flying)
        for i in range(n):
            for j in range(n):
                system[i, j] = ((work.jac[i, j] - (1.0 if i == j else 0.0)) * reference[j]
                                / reference[i])
            system[i, n] = derivative[i] / reference[i]
            rhs[i] = (z[i] - work.work[i]) / reference[i]
        along = 0.0
        for j in range(n):
            system[n, j] = tangent[j]
            along += tangent[j] * (y[j] - predicted[j])
        system[n, n] = tangent[N_STATE]
        along += tangent[N_STATE] * (t - predicted[N_STATE])
        rhs[n] = -along
        correction = work.turned
        if not solve_linear(system[:m, :m], rhs[:m], correction[:m]):
            return False, np.nan
        size = 0.0
        for i in range(m):
            size = max(size, abs(correction[i]))
        if not math.isfinite(size):
            return False, np.nan
        if iteration == 0 and not kink and size > STEP_CORRECTION * h:
            return False, np.nan
        if size > CONTRACTION * previous and size > CORRECTION_TOLERANCE:
            return False, np.nan
        for i in range(n):
            y[i] += correction[i]
        y[N_STATE] += correction[n]
        if sliver != 0.0:
            # The orbit sticks across the section (see study.kernels.two_way.newton).
            y[2] = 0.0
        if flying and y[Z_GAP] < 0.0:
            return False, np.nan
        if size <= CORRECTION_TOLERANCE:
            point = drive_at(structure, work, segment, y[N_STATE], flying)
            for i in range(n):
                z[i] = y[i] * reference[i]
            return True, displacement
        previous = size
    return False, np.nan


#: What :func:`follow_orbit` found: ``outcome`` (:data:`FOLLOWED`, :data:`FOLDED`,
#: :data:`ENDED` or :data:`LOST`), the segment's ``t`` reached, whether a real
#: multiplier crossed -1 (``flipped``) or a complex pair the unit circle (``torus``) on
#: the way, the largest multiplier modulus at the last accepted point, the mean
#: velocity [m s-1] of the orbit there, the section's phase (a fraction of the orbit's
#: period from phase 0) its state ``work.z`` is at, the steps accepted and the passes
#: taken with and without the Jacobian.
Followed = namedtuple("Followed", ("outcome", "reached", "flipped", "torus", "radius",
                                   "velocity", "section", "steps", "newton_passes",
                                   "map_passes"))


@njit(cache=True, nogil=True, error_model="numpy")
def follow_orbit(structure, segment, z0, periods, work, max_events,
                 first=FIRST_CORRECTION):
    """Follow the fixed point ``z0`` (``N_STATE``: ``(delta, delta', v, h, h')`` [m,
    m s-1, m s-1, m, m s-1] at phase 0, ``h = h' = 0`` on the table) of ``P^periods`` at
    the start of ``segment`` (a :data:`Segment`) along it to its end.

    Returns a :data:`Followed`; where the orbit was followed to the end, ``work.z``
    holds its state on the returned section there and ``work.jac`` the Jacobian of
    ``P^periods``; where it folded back, ``work.accepted`` holds the last point
    accepted, scaled (``(z / work.reference, t)``, its ``z`` on the returned section).
    ``z0`` must be the fixed point to within ``first`` of the natural sizes (the first
    step confirms it)."""
    flying = structure[LIFT_OFF_LAW] != 0.0
    n = N_STATE if flying else 3
    z = work.z
    y = work.point
    accepted = work.accepted
    tangent = work.tangent
    predicted = work.predicted
    turned = work.turned
    reference = work.reference
    for i in range(N_STATE):
        z[i] = z0[i] if i < n else 0.0
    passes = work.flight.passes if flying else work.contact.passes
    start_newton = passes[0]
    start_map = passes[1]
    phase = 0.0
    point = drive_at(structure, work, segment, 0.0, flying)
    span = periods * TWO_PI / point.omega
    for i in range(N_STATE):
        reference[i] = work.scales[i]
    # The section: the middle of the orbit's longest stretch without events.
    if flying:
        flag, _, _ = period_pass(point, z, 0.0, periods, work, flying, False, max_events)
        if flag == RUN_OK:
            phase = quiet_section(work.flight.acc, 0.0, span) / span
    else:
        phase, _ = contact_section(point, z, 0.0, periods, work, max_events)
    flow(point, z, 0.0, phase * span, work, flying, max_events)
    converged, displacement, _ = fixed_point(point, z, phase * span, periods, work, flying,
                                              max_events, first)
    steps = 0
    if not converged or not parameter_derivative(structure, work, segment, 0.0, z, phase, periods,
                                        flying, max_events):
        return Followed(LOST, 0.0, False, False, np.nan, np.nan, phase, steps,
                        passes[0] - start_newton, passes[1] - start_map)
    _, below, outside, radius = multiplier_signature(work, flying)
    # The first tangent oriented towards the segment's end.
    for i in range(N_EXTENDED):
        tangent[i] = 0.0
    tangent[N_STATE] = 1.0
    if not branch_tangent(work, n, turned):
        return Followed(LOST, 0.0, False, False, radius, np.nan, phase, steps,
                        passes[0] - start_newton, passes[1] - start_map)
    for i in range(N_EXTENDED):
        tangent[i] = turned[i]
        accepted[i] = 0.0
    for i in range(n):
        accepted[i] = z[i] / reference[i]
    if tangent[N_STATE] <= 0.0:
        return Followed(FOLDED, 0.0, False, False, radius, np.nan, phase, steps,
                        passes[0] - start_newton, passes[1] - start_map)
    flipped = False
    torus = False
    # The first step aims at the segment's end along the tangent.
    h = 1.0 / tangent[N_STATE]
    # Since a step was refused with a converged corrector (its multipliers or tangent
    # jumped: a kink of the map, or another branch): the next accepted steps halve the
    # distance to it, until a step across it is short enough to be a kink's.
    bracketed = False
    for _ in range(MAX_STEPS):
        t = accepted[N_STATE]
        to_end = (1.0 - t) / tangent[N_STATE] if tangent[N_STATE] > 0.0 else np.inf
        kink = h <= KINK_STEP
        if h >= to_end:
            # The end within reach: the fixed point at t = 1 from the tangent's
            # prediction there.
            length = to_end
            for i in range(n):
                z[i] = (accepted[i] + length * tangent[i]) * reference[i]
            point = drive_at(structure, work, segment, 1.0, flying)
            span = periods * TWO_PI / point.omega
            ok, displacement, _ = fixed_point(
                point, z, phase * span, periods, work, flying, max_events,
                np.inf if kink else STEP_CORRECTION * length)
            if ok:
                for i in range(n):
                    y[i] = z[i] / reference[i]
                y[N_STATE] = 1.0
        else:
            length = h
            for i in range(N_EXTENDED):
                predicted[i] = accepted[i] + h * tangent[i]
            ok, displacement = arclength_step(structure, work, segment, phase, periods,
                                               flying, max_events, h, kink)
            if ok:
                point = drive_at(structure, work, segment, y[N_STATE], flying)
                span = periods * TWO_PI / point.omega
        jumped = False
        if ok:
            next_above, next_below, next_outside, next_radius = multiplier_signature(
                work, flying)
            ok = next_above >= 0
            jumped = ok and not kink and (abs(next_radius - radius)
                                          > MOST_MULTIPLIER_CHANGE)
        if ok and not jumped:
            ok = parameter_derivative(structure, work, segment, y[N_STATE], z, phase, periods,
                             flying, max_events) and branch_tangent(work, n, turned)
            if ok:
                cosine = 0.0
                for i in range(N_EXTENDED):
                    cosine += turned[i] * tangent[i]
                jumped = not kink and cosine < math.cos(MOST_TURN)
        if not ok or jumped:
            h *= 0.5
            bracketed = bracketed or jumped
            if h < SMALLEST_STEP:
                return Followed(ENDED, t, flipped, torus, radius, np.nan, phase, steps,
                                passes[0] - start_newton, passes[1] - start_map)
            continue
        steps += 1
        if next_below != below:
            flipped = True
        if next_outside != outside:
            torus = True
        below, outside, radius = next_below, next_outside, next_radius
        for i in range(N_EXTENDED):
            accepted[i] = y[i]
            tangent[i] = turned[i]
        if tangent[N_STATE] <= 0.0:
            # The branch turned back before the segment's end: a fold.
            return Followed(FOLDED, accepted[N_STATE], flipped, torus, radius, np.nan,
                            phase, steps, passes[0] - start_newton,
                            passes[1] - start_map)
        if accepted[N_STATE] < 1.0 and near_one(work, flying):
            return Followed(SINGULAR, accepted[N_STATE], flipped, torus, radius, np.nan,
                            phase, steps, passes[0] - start_newton,
                            passes[1] - start_map)
        if accepted[N_STATE] >= 1.0:
            velocity = displacement / span
            return Followed(FOLLOWED, 1.0, flipped, torus, radius, velocity, phase, steps,
                            passes[0] - start_newton, passes[1] - start_map)
        if bracketed and not kink:
            h = max(0.5 * length, KINK_STEP)
        else:
            bracketed = False
            h = min(2.0 * length, 1.0)
        # With flight the parameter derivative's pass (from the section, at the accepted
        # point's drive but for its forward difference) holds the orbit's event times;
        # in contact the orbit's mode is sampled.
        moved = phase
        if flying:
            crowded = crowded_section(work, phase * span, span)
            if crowded:
                moved = quiet_section(work.flight.acc, phase * span,
                                      phase * span + span) / span
        else:
            moved, crowded = contact_section(point, z, phase * span, periods, work,
                                              max_events)
        if crowded:
            # An event came near the section: moved to the middle of the orbit's
            # longest stretch without events (the state followed there on the orbit),
            # and the branch's tangent found again there.
            if moved >= 1.0:
                moved -= 1.0
            start = phase * span
            if moved * span < start:
                flow(point, z, start, span, work, flying, max_events)
                start = 0.0
            flow(point, z, start, moved * span, work, flying, max_events)
            phase = moved
            ok, _, _ = fixed_point(point, z, phase * span, periods, work, flying,
                                    max_events, FIRST_CORRECTION)
            if not ok or not parameter_derivative(structure, work, segment, accepted[N_STATE], z,
                                         phase, periods, flying, max_events):
                return Followed(LOST, accepted[N_STATE], flipped, torus, radius, np.nan,
                                phase, steps, passes[0] - start_newton,
                                passes[1] - start_map)
            if not moved_tangent(work, n, tangent, turned):
                return Followed(LOST, accepted[N_STATE], flipped, torus, radius, np.nan,
                                phase, steps, passes[0] - start_newton,
                                passes[1] - start_map)
            for i in range(N_EXTENDED):
                tangent[i] = turned[i]
            for i in range(n):
                accepted[i] = z[i] / reference[i]
    return Followed(LOST, accepted[N_STATE], flipped, torus, radius, np.nan, phase, steps,
                    passes[0] - start_newton, passes[1] - start_map)


@njit(cache=True, nogil=True, error_model="numpy")
def on_orbit(point, z, phase, periods, state, work, flying, max_events):
    """Whether the state ``state`` (``N_STATE``) at phase 0 lies on the orbit of period
    ``periods`` whose state on the section ``phase`` (a fraction of its period from
    phase 0) is ``z`` (the fixed point of ``P^periods`` there, at the drive ``point``):
    ``state`` followed to the section lies within :data:`SAME_STATE` of one of the
    orbit's ``periods`` points there, in the natural sizes at ``point``
    (``work.scales``). ``z`` and ``state`` are kept."""
    n = N_STATE if flying else 3
    period = TWO_PI / point.omega
    section = phase * periods * period
    mapped = work.residual
    for i in range(N_STATE):
        mapped[i] = state[i]
    # The state's orbit followed to the section's drive phase.
    shift = section - period * math.floor(section / period)
    if flow(point, mapped, 0.0, shift, work, flying, max_events) != RUN_OK:
        return False
    current = work.step
    for i in range(N_STATE):
        current[i] = z[i]
    for k in range(periods):
        if state_distance(current[:n], mapped[:n], work.scales[:n]) <= SAME_STATE:
            return True
        if k + 1 == periods:
            break
        flag, _, _ = period_pass(point, current, section, 1, work, flying, False,
                                 max_events)
        if flag != RUN_OK:
            return False
        for i in range(N_STATE):
            current[i] = work.work[i]
    return False


#: Where the branch of an orbit of even period folds with the orbit's two halves (its
#: state on the section and that state half its period later) within this scaled
#: distance, the fold is the period doubling of the orbit of half its period, on which
#: the motion goes on.
HALVING_GAP = 0.05


@njit(cache=True, nogil=True, error_model="numpy")
def follow_branch(structure, segment, z0, periods, work, max_events):
    """:func:`follow_orbit` through a period halving: where the branch of an orbit of
    even period folds where its two halves merge (within :data:`HALVING_GAP`), it
    meets the orbit of half its period at that orbit's period doubling, and is followed
    on along that orbit from there (its period halved again where that happens).
    Returns ``(followed, periods)``, the :data:`Followed` of the last orbit followed
    (``reached`` on the whole segment; the passes of all) and its period."""
    flying = structure[LIFT_OFF_LAW] != 0.0
    n = N_STATE if flying else 3
    followed = follow_orbit(structure, segment, z0, periods, work, max_events)
    newton_passes = followed.newton_passes
    map_passes = followed.map_passes
    begin = 0.0
    while followed.outcome in (FOLDED, SINGULAR) and periods % 2 == 0:
        reached = begin + followed.reached * (1.0 - begin)
        point = drive_at(structure, work, segment, reached, flying)
        span = periods * TWO_PI / point.omega
        section = followed.section * span
        state = work.predicted
        for i in range(N_STATE):
            state[i] = work.accepted[i] * work.reference[i] if i < n else 0.0
        half = work.point
        for i in range(N_STATE):
            half[i] = state[i]
        if flow(point, half, section, section + 0.5 * span, work, flying,
                 max_events) != RUN_OK:
            break
        if state_distance(state[:n], half[:n], work.scales[:n]) > HALVING_GAP:
            break
        # The state at phase 0 (the end of the orbit's period from the section).
        if flow(point, state, section, span, work, flying, max_events) != RUN_OK:
            break
        omega = segment.omega0 + reached * (segment.omega1 - segment.omega0)
        a = segment.a0 + reached * (segment.a1 - segment.a0)
        rest = Segment(omega, a, segment.omega1, segment.a1)
        periods //= 2
        start = work.residual
        for i in range(N_STATE):
            start[i] = state[i]
        followed = follow_orbit(structure, rest, start, periods, work, max_events,
                                HALVING_GAP)
        newton_passes += followed.newton_passes
        map_passes += followed.map_passes
        begin = reached
    return Followed(followed.outcome, begin + followed.reached * (1.0 - begin),
                    followed.flipped, followed.torus, followed.radius, followed.velocity,
                    followed.section, followed.steps, newton_passes, map_passes), periods


@njit(cache=True, nogil=True, error_model="numpy")
def polish_orbit(structure, omega, a, z, periods, work, max_events):
    """Newton's method on ``P^periods(z) - z`` at the drive ``(omega, a)`` [rad s-1,
    m s-2] from ``z`` (``N_STATE`` at phase 0, in place), held to contract but not to a
    first correction: a state given near an orbit. True where it converged."""
    flying = structure[LIFT_OFF_LAW] != 0.0
    point = drive_at(structure, work, Segment(omega, a, omega, a), 0.0, flying)
    for _ in range(3):
        converged, _, _ = fixed_point(point, z, 0.0, periods, work, flying, max_events,
                                      np.inf)
        if converged:
            return True
    return False
