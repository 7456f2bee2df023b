"""One drive point's steady orbit, its output row, and the drivers over many points.

:func:`solve_point` fills one row of :data:`OUTPUT_COLUMNS`; :func:`solve_points` (in
parallel) and :func:`solve_points_serial` fill a table of them for the validating
wrapper :func:`study.solvers.exact.steady_state`, each point of a line of the sweep
continued from the points before it (:mod:`~study.kernels.two_way.continuation`).

The drivers cut the points into runs (:func:`sweep_runs`): consecutive points that
share a frequency or an acceleration, at most :data:`RUN_LENGTH` of them. A run is
solved in order on one thread, so a point's result depends on the points before it in
its run only, whatever the threads: the parallel and the serial driver agree bit for
bit.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit, prange

from study.kernels.start import is_release
from study.kernels.structure_vector import (
    COS_ALPHA,
    DAMPING,
    GRAVITY,
    LIFT_OFF_LAW,
    MASS_RATIO,
    SIN_ALPHA,
    STATIC_FRICTION,
    STIFFNESS,
)
from study.kernels.time_average import (
    S_STATE,
)
from study.kernels.two_way.continuation import (
    CONTINUED_LIFT_OFF,
    CONTINUED_ORBIT,
    FAILED_UNSTABLE,
    continued_newton,
    forget,
    new_neighbours,
    predict,
    remember,
)
from study.kernels.two_way.cycles import MAX_PERIOD, STABILITY_MARGIN, find_orbit
from study.kernels.two_way.flight import (
    FLIGHT_ROW,
    N_ROWS,
    N_STATE,
    Z_GAP,
    Z_GAP_RATE,
    flight_row,
)
from study.kernels.two_way.flight_orbit import irregular_row, orbit_exponent, solve_flight
from study.kernels.two_way.modes import (
    EPS,
    M_OFFSET,
    M_PIM,
    M_PRE,
    N_MODE,
    TWO_PI,
    DrivePoint,
    mode_constants,
    mode_drive,
    mode_row,
    stick_response,
)
from study.kernels.two_way.newton import spectral_radius, stuck_radius
from study.kernels.two_way.orbit import (
    A_BACKWARD,
    A_DISPLACEMENT,
    A_EVENTS,
    A_FORWARD,
    A_SLIPS,
    A_STICK,
    N_ACC,
    PassRecord,
)
from study.kernels.two_way.propagation import particular, stick_propagator
from study.model.codes import (
    BOUNCING,
    CHAOTIC,
    CONTINUOUS_SLIDING,
    LIFT_OFF,
    NOT_CONVERGED,
    QUASI_PERIODIC,
    REASON_AVERAGE_BUDGET,
    REASON_NONE,
    STATIC,
    STICK_SLIP,
)

#: The columns of :func:`solve_point`'s output row, in order, with their units.
OUTPUT_COLUMNS = (
    ("status", "1", "study.model.status.Status code"),
    ("reason", "1", "study.model.status.NonConvergence code"),
    ("velocity", "m s-1", "mean velocity over the orbit"),
    ("slips", "1", "slip events per drive period"),
    ("forward", "1", "fraction of the drive period spent slipping forward"),
    ("backward", "1", "fraction of the drive period spent slipping backward"),
    ("period", "1", "the orbit's period in drive periods (0: no orbit)"),
    ("multiplier", "1", "largest modulus of the orbit's Floquet multipliers"),
    ("delta", "m", "the mode's displacement on the orbit at phase 0"),
    ("delta_rate", "m s-1", "the mode's velocity on the orbit at phase 0"),
    ("speed", "m s-1", "the sliding speed on the orbit at phase 0"),
    ("gap", "m", "the base's height above the table on the orbit at phase 0 (0 on it)"),
    ("gap_rate", "m s-1", "the rate of that height at phase 0 (0 on the table)"),
    ("airborne", "1", "fraction of the orbit's period the base spends off the table"),
    ("hop", "m", "largest gap between the base and the table over the orbit"),
    ("impacts", "1", "impacts of the base on the table per drive period"),
    ("averaged_velocity", "m s-1", "time-averaged velocity of a motion followed on the "
     "period map (irregular, or not converged after the most periods: its partial mean)"),
    ("velocity_error", "m s-1", "standard error of the mean velocity (0: an orbit's, exact)"),
    ("averaged_periods", "1", "drive periods an irregular motion was averaged over (0: an "
     "orbit)"),
    ("exponent", "1", "largest Lyapunov exponent per drive period (an orbit's: the log of "
     "its largest Floquet multiplier over its period)"),
    ("exponent_error", "1", "standard error of the exponent (0: an orbit's, exact)"),
    ("newton_passes", "1", "passes over the period map with its Jacobian the point took"),
    ("map_passes", "1", "passes over the period map without its Jacobian the point took"),
    ("continued", "1", "1: the contact orbit was continued from the sweep's last points; "
     "0: solved cold, nothing to continue from; < 0: solved cold, the continuation's "
     "FAILED_* code (study.kernels.two_way.continuation)"),
    ("from_start", "1", "1: the orbit reported is the fixed point Newton's method found from "
     "the point's start (its state after two periods with flight), verified reached; 0: "
     "the motion from the start reached another motion, or none"),
)
_NAMES = tuple(name for name, _, _ in OUTPUT_COLUMNS)

# Numba reads module-level integers as compile-time constants.
OUT_STATUS = _NAMES.index("status")
OUT_REASON = _NAMES.index("reason")
OUT_VELOCITY = _NAMES.index("velocity")
OUT_SLIPS = _NAMES.index("slips")
OUT_FORWARD = _NAMES.index("forward")
OUT_BACKWARD = _NAMES.index("backward")
OUT_PERIOD = _NAMES.index("period")
OUT_MULTIPLIER = _NAMES.index("multiplier")
OUT_DELTA = _NAMES.index("delta")
OUT_DELTA_RATE = _NAMES.index("delta_rate")
OUT_SPEED = _NAMES.index("speed")
OUT_GAP = _NAMES.index("gap")
OUT_GAP_RATE = _NAMES.index("gap_rate")
OUT_AIRBORNE = _NAMES.index("airborne")
OUT_HOP = _NAMES.index("hop")
OUT_IMPACTS = _NAMES.index("impacts")
OUT_AVERAGED_VELOCITY = _NAMES.index("averaged_velocity")
OUT_VELOCITY_ERROR = _NAMES.index("velocity_error")
OUT_AVERAGED_PERIODS = _NAMES.index("averaged_periods")
OUT_EXPONENT = _NAMES.index("exponent")
OUT_EXPONENT_ERROR = _NAMES.index("exponent_error")
OUT_NEWTON_PASSES = _NAMES.index("newton_passes")
OUT_MAP_PASSES = _NAMES.index("map_passes")
OUT_CONTINUED = _NAMES.index("continued")
OUT_FROM_START = _NAMES.index("from_start")
#: The columns that record the work a point took, not its orbit.
WORK_COLUMNS = (OUT_NEWTON_PASSES, OUT_MAP_PASSES, OUT_CONTINUED, OUT_FROM_START)
#: Length of an output row.
N_OUT = len(OUTPUT_COLUMNS)
# The columns :func:`~study.kernels.two_way.flight_orbit.solve_flight` writes, in its
# order.
FLIGHT_COLUMNS = (OUT_STATUS, OUT_REASON, OUT_VELOCITY, OUT_SLIPS, OUT_FORWARD,
                  OUT_BACKWARD, OUT_PERIOD, OUT_MULTIPLIER, OUT_DELTA, OUT_DELTA_RATE,
                  OUT_SPEED, OUT_AIRBORNE, OUT_HOP, OUT_IMPACTS, OUT_AVERAGED_VELOCITY,
                  OUT_VELOCITY_ERROR,
                  OUT_AVERAGED_PERIODS, OUT_EXPONENT, OUT_EXPONENT_ERROR, OUT_GAP,
                  OUT_GAP_RATE)


@njit(cache=True, nogil=True, error_model="numpy")
def _scales(point):
    """Natural sizes of ``(delta, delta', v)`` for residuals [m, m s-1, m s-1]."""
    table = point.table
    omega = point.omega
    a = point.a
    amp = math.hypot(table[0, M_PRE], table[0, M_PIM])
    k = point.structure[STIFFNESS]
    size = max(amp, a / (k + omega * omega), 1e-300)
    return size, size * max(omega, math.sqrt(k)), max(a / omega, 1e-300)


@njit(cache=True, nogil=True, error_model="numpy")
def start_state(table, omega, t, z, factor):
    """``z`` at rest at ``t`` [s] with the mode on ``factor`` times its steady stick
    response (``table`` the mode table, ``omega`` [rad s-1])."""
    cw = math.cos(omega * t)
    sw = math.sin(omega * t)
    dp, dpd, _, _ = particular(table[0], omega, cw, sw)
    z[0] = factor * dp
    z[1] = factor * dpd
    z[2] = 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def _is_static(structure, omega, a, pr, pi):
    """Neither release can happen with the mode on its steady response ``(pr, pi)`` [m]
    (:func:`~study.kernels.two_way.modes.stick_response`): the stuck structure's
    release amplitudes ``|s tau - cs n|`` against ``cs g``, the motion thresholds of
    :func:`study.model.forces.thresholds` (the two-way term vanishes in a stick)."""
    w2 = omega * omega
    m = structure[MASS_RATIO]
    ca = structure[COS_ALPHA]
    sa = structure[SIN_ALPHA]
    cs = structure[STATIC_FRICTION]
    level = cs * structure[GRAVITY] * (1.0 + 8.0 * EPS)
    for sign in (1.0, -1.0):
        kappa = -m * (sign * sa + cs * ca)
        if math.hypot(-kappa * w2 * pr + cs * a, -kappa * w2 * pi) > level:
            return False
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def stays_static(structure, omega, a, table, state, t):
    """The structure, stuck on the table at time ``t`` [s] in ``state`` (``(delta,
    delta', v, h, h')`` [m, m s-1, m s-1, m, m s-1]) under the drive ``omega``
    [rad s-1], ``a`` [m s-2] (``table`` the mode table of that drive), provably never
    slips: a sufficient test, in closed form, for the state a slow sweep carries or a
    start on the table.

    Stuck, the mode is its steady stick response plus a free decay ``delta_h`` from
    the state's difference to that response at ``t``. The decay adds
    ``kappa_s (-c delta_h' - k delta_h)`` to each release function of
    :func:`_is_static`; by Cauchy-Schwarz that is at most ``|kappa_s| sqrt((c^2 + k)
    E)`` with ``E = delta_h'^2 + k delta_h^2``, which the damping never lets grow
    (``E' = -2 c delta_h'^2``). So the structure stays stuck for ever when each release
    amplitude plus that bound stays below ``cs g``, at the precision of the static
    decision; then the motion it settles on is the static point's. False where the
    state is not stuck on the table, or the bound cannot decide (the motion must then
    be followed)."""
    if state[2] != 0.0 or state[Z_GAP] != 0.0 or state[Z_GAP_RATE] != 0.0:
        return False
    dp, dpd, _, _ = particular(table[0], omega, math.cos(omega * t), math.sin(omega * t))
    decay = state[0] - dp
    decay_rate = state[1] - dpd
    c = structure[DAMPING]
    k = structure[STIFFNESS]
    bound = math.sqrt((c * c + k) * (decay_rate * decay_rate + k * decay * decay))
    pr, pi = stick_response(structure, omega, a)
    w2 = omega * omega
    m = structure[MASS_RATIO]
    ca = structure[COS_ALPHA]
    sa = structure[SIN_ALPHA]
    cs = structure[STATIC_FRICTION]
    level = cs * structure[GRAVITY] * (1.0 + 8.0 * EPS)
    for sign in (1.0, -1.0):
        kappa = -m * (sign * sa + cs * ca)
        amplitude = math.hypot(-kappa * w2 * pr + cs * a, -kappa * w2 * pi)
        if not amplitude + abs(kappa) * bound <= level:
            return False
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _static_row(structure, omega, lifted, out, diagnostics):
    """``out`` (NaN, no reason, period 0) completed for a static point: ``LIFT_OFF``
    when ``lifted``, else at rest, its multiplier the stick's free decay over a period
    (as :func:`~study.kernels.two_way.newton.spectral_radius` gives it for that
    propagator)."""
    out[OUT_STATUS] = LIFT_OFF if lifted else STATIC
    if lifted:
        return
    out[OUT_VELOCITY] = 0.0
    out[OUT_SLIPS] = 0.0
    out[OUT_FORWARD] = 0.0
    out[OUT_BACKWARD] = 0.0
    out[OUT_AIRBORNE] = 0.0
    out[OUT_HOP] = 0.0
    out[OUT_IMPACTS] = 0.0
    out[OUT_VELOCITY_ERROR] = 0.0
    out[OUT_EXPONENT_ERROR] = 0.0
    if not diagnostics:
        return
    # The orbit is the mode's steady response: perturbations decay with it.
    e11, e12, e21, e22 = stick_propagator(structure, TWO_PI / omega)
    if (math.isfinite(e11) and math.isfinite(e12) and math.isfinite(e21)
            and math.isfinite(e22)):
        out[OUT_MULTIPLIER] = stuck_radius(e11, e12, e21, e22, 0.0)
    else:
        out[OUT_MULTIPLIER] = np.inf
    orbit_exponent(out, OUT_MULTIPLIER, OUT_PERIOD, OUT_VELOCITY_ERROR,
                   OUT_AVERAGED_PERIODS, OUT_EXPONENT, OUT_EXPONENT_ERROR)


#: Scratch arrays a run of points reuses (an allocation costs about as much as an
#: event of the orbit): the mode table (``N_ROWS`` x ``N_MODE``), the state's natural
#: scales, the state, a pass's end state, Newton's step and residual (2 x 3), the pass
#: record, the cycle search's history (``MAX_PERIOD`` x 3) and an output row kept
#: aside (``N_OUT``), and an irregular motion's averages (the ``S_*`` slots of
#: :mod:`study.kernels.time_average`, the state from ``S_STATE``).
Workspace = namedtuple("Workspace",
                       ("table", "scales", "z", "work", "newton", "record", "history",
                        "row", "stats"))


@njit(cache=True, nogil=True, error_model="numpy")
def new_workspace(structure):
    """A fresh :data:`Workspace` for ``structure``, its mode table's contact rows holding
    their :func:`~study.kernels.two_way.modes.mode_constants` (each point adds its
    drive's columns)."""
    table = np.zeros((N_ROWS, N_MODE))
    for row in range(3):
        mode_constants(structure, table, row)
    return Workspace(table, np.empty(3), np.empty(3), np.empty(3), np.empty((2, 3)),
                     PassRecord(np.zeros(N_ACC), np.empty((3, 3)), np.empty((3, 3)),
                                np.zeros(2)),
                     np.empty((MAX_PERIOD, 3)), np.empty(N_OUT), np.empty(S_STATE + 3))


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def start_row(out):
    """``out`` as a point starts it: NaN, no reason, period 0, no work."""
    out[:] = np.nan
    out[OUT_REASON] = REASON_NONE
    out[OUT_PERIOD] = 0.0
    out[OUT_AVERAGED_PERIODS] = 0.0
    out[OUT_NEWTON_PASSES] = 0.0
    out[OUT_MAP_PASSES] = 0.0
    out[OUT_CONTINUED] = 0.0
    out[OUT_FROM_START] = 0.0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def static_point(structure, omega, a, lifted, out, diagnostics):
    """Start ``out`` (NaN, no reason, period 0, no work) and decide whether the point is
    static, from the stick's response alone, in closed form (most points of a map
    never slip); a static point's row is then complete unless it is past lift-off with
    the lift-off law ``flight`` (it takes off). Inlined into the drivers: a static point
    costs the decision, not a call with the run's scratch arrays."""
    start_row(out)
    pr, pi = stick_response(structure, omega, a)
    static = _is_static(structure, omega, a, pr, pi)
    if static and not (lifted and structure[LIFT_OFF_LAW] != 0.0):
        _static_row(structure, omega, lifted, out, diagnostics)
    return static


@njit(cache=True, nogil=True, error_model="numpy")
def solve_point(structure, omega, a, lifted, budget, t_start, factor, out):
    """Steady orbit at one drive point: ``structure`` (the structure vector), ``omega``
    [rad s-1], ``a`` [m s-2], ``lifted`` (the point is past lift-off), within ``budget``
    (a :data:`~study.kernels.budget.Budget`); ``out`` receives one row of
    :data:`OUTPUT_COLUMNS`.

    ``t_start`` [s] and ``factor`` choose the starting state (rest, mode on ``factor``
    times its steady response).

    With the lift-off law ``flight`` (the structure vector's ``LIFT_OFF_LAW``):

    * a point past the stick's lift-off threshold (``lifted``) is solved first by the
      orbit with flight from the start
      (:func:`~study.kernels.two_way.flight_orbit.solve_flight`), and a ``BOUNCING``
      orbit found so is the answer;
    * every other point, and a lifted point whose orbit with flight does not bounce, is
      solved exactly as without flight, so it keeps every bit; where that ends
      ``LIFT_OFF``, the answer is the orbit with flight from the same start.

    This is the order "contact model first, flight where it ends ``LIFT_OFF``" except
    where the contact solver finds an orbit on the table and the motion from the start,
    followed with flight, settles on a bouncing one (two attractors): past the
    threshold the bouncing orbit is reported. No point of the workflows' grids is such
    a point; the order saves the contact search (about a stick-slip point's time) at
    the bouncing points past the threshold.
    """
    solve_point_along(structure, omega, a, lifted, budget, t_start, factor, out,
                      new_neighbours(), new_workspace(structure), True)


@njit(cache=True, nogil=True, error_model="numpy")
def solve_point_along(structure, omega, a, lifted, budget, t_start, factor, out,
                      neighbours, workspace, diagnostics):
    """:func:`solve_point` for a point of a sweep: the contact orbit is continued from
    ``neighbours`` (a :data:`~study.kernels.two_way.continuation.Neighbours` of the
    points before it on its line, for the same start) when they hold an orbit, and
    solved cold when they hold none or the continuation is not trusted; ``neighbours``
    then remembers this point. ``workspace`` (a :data:`Workspace` of ``structure``) is
    scratch space;
    without ``diagnostics`` only the status and velocity columns are sure to be right
    (a static point's multiplier is not computed)."""
    static = static_point(structure, omega, a, lifted, out, diagnostics)
    solve_decided(structure, omega, a, lifted, static, budget, t_start, factor, out,
                  neighbours, workspace, diagnostics)


@njit(cache=True, nogil=True, error_model="numpy")
def solve_decided(structure, omega, a, lifted, static, budget, t_start, factor, out,
                  neighbours, workspace, diagnostics):
    """:func:`solve_point_along` after :func:`static_point` started ``out`` and decided
    ``static``: the drivers decide it first (a static point then costs no call) and
    call this for the other points, so that it is not decided twice."""
    flying = structure[LIFT_OFF_LAW] != 0.0
    if static:
        forget(neighbours)
        if not (lifted and flying):
            return
    table = workspace.table
    # Only the columns the rows' event searches read (see mode_drive).
    mode_drive(structure, omega, a, table, 0, searched_only=True)
    mode_drive(structure, omega, a, table, 1, searched_only=True)
    mode_drive(structure, omega, a, table, 2, searched_only=True)
    initial = np.zeros(N_STATE)
    start_state(table, omega, t_start, initial, factor)
    solve_from(structure, omega, a, lifted, static, budget, t_start, initial, out,
               neighbours, workspace, diagnostics)


@njit(cache=True, nogil=True, error_model="numpy")
def solve_from(structure, omega, a, lifted, static, budget, t_start, initial, out,
               neighbours, workspace, diagnostics):
    """:func:`solve_decided` from the state ``initial`` at ``t_start`` [s] (in the first
    period): ``(delta, delta', v, h, h')`` [m, m s-1, m s-1, m, m s-1], on the table
    (``h = h' = 0``) unless the lift-off law is ``flight``; ``workspace.table`` holds
    the drive's columns (:func:`solve_decided` fills them). The contact search starts
    from its first three components, the search with flight from all five."""
    flying = structure[LIFT_OFF_LAW] != 0.0
    table = workspace.table
    point = DrivePoint(structure, table, omega, a)
    if flying and (initial[Z_GAP] != 0.0 or initial[Z_GAP_RATE] != 0.0):
        # Off the table (a carried state of a sweep, in flight at phase 0): only the
        # search with flight follows it; its answer stands, whatever it is.
        forget(neighbours)
        _fly_from(structure, table, omega, a, budget, t_start, initial, out)
        return
    flight_first = lifted and flying
    if flight_first:
        # Past the stick's lift-off threshold the motion from the start usually leaves
        # the table, and then the contact solver's search only ends in LIFT_OFF (about
        # a stick-slip point's time): the orbit with flight is sought first. Only
        # where it does not bounce is the contact solver's answer wanted (see
        # solve_point), so the row is kept aside for the case that it ends LIFT_OFF.
        _fly_from(structure, table, omega, a, budget, t_start, initial, out)
        if static or out[OUT_STATUS] == BOUNCING or (
                out[OUT_STATUS] in (CHAOTIC, QUASI_PERIODIC) and out[OUT_AIRBORNE] > 0.0):
            forget(neighbours)
            return
        workspace.row[:] = out
        start_row(out)
    scales = workspace.scales
    scales[0], scales[1], scales[2] = _scales(point)
    z = workspace.z
    record = workspace.record
    record.passes[:] = 0.0
    work = workspace.work
    status = NOT_CONVERGED
    reason = REASON_NONE
    periods = 0
    solved = False
    # The orbit's largest multiplier where the search computed it for its stability
    # check (record.jac is then that of the orbit's pass, which the row reports), so
    # that the row does not compute it again; NaN where it did not.
    radius = np.nan
    if predict(neighbours, omega, a, z):
        outcome, events, slips = continued_newton(point, z, scales, budget.max_events,
                                                  record, work, workspace.newton)
        if outcome == CONTINUED_LIFT_OFF:
            status = LIFT_OFF
            solved = True
        elif outcome == CONTINUED_ORBIT:
            radius = spectral_radius(record.jac)
            if radius < 1.0 + STABILITY_MARGIN:
                status = STICK_SLIP
                periods = 1
                solved = True
            else:
                outcome = FAILED_UNSTABLE
        if solved:
            out[OUT_CONTINUED] = 1.0
            remember(neighbours, omega, a, z, events, slips)
        else:
            out[OUT_CONTINUED] = outcome
    if not solved:
        z[0] = initial[0]
        z[1] = initial[1]
        z[2] = initial[2]
        status, reason, periods, newton_found, radius = find_orbit(
            point, z, t_start, scales, budget, record, work, workspace.history,
            workspace.stats)
        if newton_found and status == STICK_SLIP:
            remember(neighbours, omega, a, z, record.acc[A_EVENTS], record.acc[A_SLIPS])
        elif newton_found and status == LIFT_OFF:
            # The pass that left the table was cut short: its signature is unknown.
            remember(neighbours, omega, a, z, -1.0, -1.0)
        else:
            forget(neighbours)
    out[OUT_NEWTON_PASSES] = record.passes[0]
    out[OUT_MAP_PASSES] = record.passes[1]
    out[OUT_FROM_START] = 1.0 if newton_found and status == STICK_SLIP else 0.0
    if flying and status == LIFT_OFF:
        if flight_first:
            continued = out[OUT_CONTINUED]
            out[:] = workspace.row
            out[OUT_CONTINUED] = continued
        else:
            _fly_from(structure, table, omega, a, budget, t_start, initial, out)
        out[OUT_NEWTON_PASSES] += record.passes[0]
        out[OUT_MAP_PASSES] += record.passes[1]
        return
    if flight_first:
        out[OUT_NEWTON_PASSES] += workspace.row[OUT_NEWTON_PASSES]
        out[OUT_MAP_PASSES] += workspace.row[OUT_MAP_PASSES]
    out[OUT_STATUS] = status
    out[OUT_REASON] = reason
    if status in (CHAOTIC, QUASI_PERIODIC) or reason == REASON_AVERAGE_BUDGET:
        irregular_row(workspace.stats, omega, status, out, FLIGHT_COLUMNS)
        return
    if periods == 0:
        return
    acc = record.acc
    span = periods * TWO_PI / omega
    out[OUT_STATUS] = STICK_SLIP if acc[A_STICK] > 0.0 else CONTINUOUS_SLIDING
    out[OUT_VELOCITY] = acc[A_DISPLACEMENT] / span
    out[OUT_SLIPS] = acc[A_SLIPS] / periods
    out[OUT_FORWARD] = acc[A_FORWARD] / span
    out[OUT_BACKWARD] = acc[A_BACKWARD] / span
    out[OUT_PERIOD] = periods
    out[OUT_MULTIPLIER] = spectral_radius(record.jac) if math.isnan(radius) else radius
    out[OUT_DELTA] = z[0]
    out[OUT_DELTA_RATE] = z[1]
    out[OUT_SPEED] = z[2]
    out[OUT_GAP] = 0.0
    out[OUT_GAP_RATE] = 0.0
    out[OUT_AIRBORNE] = 0.0
    out[OUT_HOP] = 0.0
    out[OUT_IMPACTS] = 0.0
    orbit_exponent(out, OUT_MULTIPLIER, OUT_PERIOD, OUT_VELOCITY_ERROR,
                   OUT_AVERAGED_PERIODS, OUT_EXPONENT, OUT_EXPONENT_ERROR)


@njit(cache=True, nogil=True, error_model="numpy")
def _solve_flying(structure, table, omega, a, budget, t_start, factor, height, out):
    """The orbit with flight from rest ``height`` [m] above the table (0: on it) at
    ``t_start`` [s], the mode at rest on ``factor`` times its steady response;
    ``table`` has its contact rows filled. The flight search's passes are written to
    ``out`` (the caller adds its own)."""
    z = np.zeros(N_STATE)
    start_state(table, omega, t_start, z, factor)
    z[Z_GAP] = height
    _fly_from(structure, table, omega, a, budget, t_start, z, out)


@njit(cache=True, nogil=True, error_model="numpy")
def _fly_from(structure, table, omega, a, budget, t_start, initial, out):
    """The orbit with flight from the 5-state ``initial`` at ``t_start`` [s] (copied:
    ``initial`` is kept); ``table`` has its contact rows filled. The flight search's
    passes are written to ``out`` (the caller adds its own)."""
    flight_row(structure, table)
    z = initial.copy()
    with_jac, without, from_start = solve_flight(structure, table, omega, a, budget, z,
                                                 t_start, out, FLIGHT_COLUMNS)
    out[OUT_NEWTON_PASSES] = with_jac
    out[OUT_MAP_PASSES] = without
    out[OUT_FROM_START] = from_start


@njit(cache=True, nogil=True, error_model="numpy")
def solve_drop(structure, omega, a, budget, t_start, height, out):
    """The orbit with flight reached from a drop: the base released ``height`` [m] above
    the table at ``t_start`` [s], at rest relative to it, the mode at rest at its flight
    equilibrium ``g cos(alpha) / k`` (arguments as :func:`solve_point`)."""
    out[:] = np.nan
    out[OUT_REASON] = REASON_NONE
    out[OUT_PERIOD] = 0.0
    table = np.zeros((N_ROWS, N_MODE))
    mode_row(structure, omega, a, table, 0)
    mode_row(structure, omega, a, table, 1)
    mode_row(structure, omega, a, table, 2)
    flight_row(structure, table)
    z = np.zeros(N_STATE)
    z[0] = table[FLIGHT_ROW, M_OFFSET]
    z[Z_GAP] = height
    solve_flight(structure, table, omega, a, budget, z, t_start, out, FLIGHT_COLUMNS)


@njit(cache=True, nogil=True, error_model="numpy")
def solve_started(structure, omega, a, lifted, budget, start, out, neighbours, workspace,
                  diagnostics):
    """One point's motion from a named start other than the release: ``start`` a
    :data:`~study.kernels.start.Start` (the drive phase, the mode's factor, the base's
    height), the other arguments as :func:`solve_point_along`'s.

    The motion is followed from that state, never decided in closed form (a start off
    the steady stick response can slip or leave the table in its transient where the
    steady response would not) and never continued from ``neighbours`` (which are
    forgotten: the start is the protocol's, not a neighbour's orbit). On the table
    (height 0) the point is solved as :func:`solve_decided` solves a point that is not
    static, from that state; an orbit that never slips is reported ``STATIC``, as a
    static point's row, and a start that provably stays stuck
    (:func:`stays_static`) is decided so without following it. From above the table (a
    drop, only with the lift-off law ``flight``) the motion with flight is followed from
    the start. On a still table (``a = 0``) every start comes to rest: ``STATIC``.
    """
    start_row(out)
    forget(neighbours)
    if a == 0.0:
        # A still table: every motion dissipates to rest, from any start; the drive's
        # scales, by which the searches measure distances, vanish.
        _static_row(structure, omega, False, out, diagnostics)
        return
    t_start = start.phase * TWO_PI / omega
    if start.height == 0.0 and not lifted:
        # Stuck at the start and provably staying stuck: the static point's motion,
        # decided without following it (as a slow sweep decides a carried state).
        state = np.zeros(N_STATE)
        mode_drive(structure, omega, a, workspace.table, 0, searched_only=True)
        start_state(workspace.table, omega, t_start, state, start.factor)
        if stays_static(structure, omega, a, workspace.table, state, t_start):
            _static_row(structure, omega, False, out, diagnostics)
            return
    if start.height > 0.0:
        table = workspace.table
        mode_drive(structure, omega, a, table, 0, searched_only=True)
        mode_drive(structure, omega, a, table, 1, searched_only=True)
        mode_drive(structure, omega, a, table, 2, searched_only=True)
        _solve_flying(structure, table, omega, a, budget, t_start, start.factor,
                      start.height, out)
        return
    solve_decided(structure, omega, a, lifted, False, budget, t_start, start.factor, out,
                  neighbours, workspace, diagnostics)
    forget(neighbours)
    stuck_is_static(structure, omega, out, diagnostics)


@njit(cache=True, nogil=True, error_model="numpy")
def stuck_is_static(structure, omega, out, diagnostics):
    """A row whose orbit never slips (a motion followed from a state, not decided in
    closed form, that settled on the stick) made the static point's row: the steady
    stick response, its work kept."""
    if out[OUT_STATUS] == STICK_SLIP and out[OUT_SLIPS] == 0.0:
        newton_passes = out[OUT_NEWTON_PASSES]
        map_passes = out[OUT_MAP_PASSES]
        start_row(out)
        _static_row(structure, omega, False, out, diagnostics)
        out[OUT_NEWTON_PASSES] = newton_passes
        out[OUT_MAP_PASSES] = map_passes


#: Longest run of points continued one from the other (see :func:`sweep_runs`): a
#: sweep along one line longer than this is cut, so that its runs can be spread over
#: the threads.
RUN_LENGTH = 4096


@njit(cache=True, nogil=True, error_model="numpy")
def sweep_runs(omega, a):
    """Where the runs of points start: a point opens a run unless it shares its
    frequency ``omega`` [rad s-1] or its acceleration ``a`` [m s-2] with the point
    before it (the next point of a line of the sweep), or the run already holds
    :data:`RUN_LENGTH` points. Returns the starts and, last, the number of points."""
    n = omega.shape[0]
    starts = np.empty(n + 1, dtype=np.int64)
    count = 0
    length = 0
    for i in range(n):
        follows = i > 0 and (omega[i] == omega[i - 1] or a[i] == a[i - 1])
        if not follows or length >= RUN_LENGTH:
            starts[count] = i
            count += 1
            length = 0
        length += 1
    starts[count] = n
    return starts[:count + 1]


@njit(cache=True, nogil=True, error_model="numpy")
def _solve_run(structure, omega, a, lifted, budget, continued, start, begin, end, out):
    neighbours = new_neighbours()
    workspace = new_workspace(structure)
    flying = structure[LIFT_OFF_LAW] != 0.0
    released = is_release(start)
    for i in range(begin, end):
        if not released:
            solve_started(structure, omega[i], a[i], lifted[i], budget, start, out[i],
                          neighbours, workspace, True)
            continue
        if not continued:
            forget(neighbours)
        # The static decision here, and solve_decided for the others: a static point
        # then costs no call (measured 0.11 us a point of a static map, against 0.19 us
        # with solve_point_along deciding for the drivers), and no point is decided
        # twice.
        static = static_point(structure, omega[i], a[i], lifted[i], out[i], True)
        if static and not (lifted[i] and flying):
            forget(neighbours)
            continue
        solve_decided(structure, omega[i], a[i], lifted[i], static, budget, 0.0, 1.0,
                      out[i], neighbours, workspace, True)


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def solve_points(structure, omega, a, lifted, budget, continued, start, out):
    """Fill ``out`` (n x ``N_OUT``) at the points ``omega`` [rad s-1], ``a`` [m s-2]
    (``lifted``: past lift-off) in parallel: the runs of :func:`sweep_runs`, each in
    order on one thread, interleaved over the lanes. With ``continued`` each point of a
    run is continued from the points before it; else each is solved from ``start`` (a
    :data:`~study.kernels.start.Start`; the runs only share their scratch space: the
    results do not depend on them). A start other than the release is never continued
    (:func:`solve_started`)."""
    starts = sweep_runs(omega, a)
    runs = starts.shape[0] - 1
    lanes = min(runs, 256)
    for lane in prange(lanes):
        for r in range(lane, runs, lanes):
            _solve_run(structure, omega, a, lifted, budget, continued, start, starts[r],
                       starts[r + 1], out)


@njit(cache=True, nogil=True, error_model="numpy")
def solve_points_serial(structure, omega, a, lifted, budget, continued, start, out):
    """Same as :func:`solve_points` on one thread."""
    starts = sweep_runs(omega, a)
    for r in range(starts.shape[0] - 1):
        _solve_run(structure, omega, a, lifted, budget, continued, start, starts[r],
                   starts[r + 1], out)


@njit(cache=True, nogil=True, error_model="numpy")
def _velocity_run(structure, omega, a, lifted, budget, continued, start, begin, end,
                  velocity, status):
    neighbours = new_neighbours()
    workspace = new_workspace(structure)
    row = np.empty(N_OUT)
    flying = structure[LIFT_OFF_LAW] != 0.0
    released = is_release(start)
    for i in range(begin, end):
        if not continued:
            forget(neighbours)
        if not released:
            solve_started(structure, omega[i], a[i], lifted[i], budget, start, row,
                          neighbours, workspace, False)
            velocity[i] = row[OUT_VELOCITY]
            status[i] = np.int8(row[OUT_STATUS])
            continue
        static = static_point(structure, omega[i], a[i], lifted[i], row, False)
        if not static or (lifted[i] and flying):
            solve_decided(structure, omega[i], a[i], lifted[i], static, budget, 0.0, 1.0,
                          row, neighbours, workspace, False)
        else:
            forget(neighbours)
        velocity[i] = row[OUT_VELOCITY]
        status[i] = np.int8(row[OUT_STATUS])


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def velocity_points(structure, omega, a, lifted, budget, continued, start, velocity,
                    status):
    """The velocity [m s-1] and the status (int8) of :func:`solve_points`, bit for bit,
    into ``velocity`` and ``status``: no table of every column (136 bytes a point) and
    no multiplier of the static points."""
    starts = sweep_runs(omega, a)
    runs = starts.shape[0] - 1
    lanes = min(runs, 256)
    for lane in prange(lanes):
        for r in range(lane, runs, lanes):
            _velocity_run(structure, omega, a, lifted, budget, continued, start,
                          starts[r], starts[r + 1], velocity, status)


@njit(cache=True, nogil=True, error_model="numpy")
def velocity_points_serial(structure, omega, a, lifted, budget, continued, start,
                           velocity, status):
    """Same as :func:`velocity_points` on one thread."""
    starts = sweep_runs(omega, a)
    for r in range(starts.shape[0] - 1):
        _velocity_run(structure, omega, a, lifted, budget, continued, start, starts[r],
                      starts[r + 1], velocity, status)


@njit(cache=True, nogil=True, error_model="numpy")
def solve_points_cold(structure, omega, a, lifted, budget, out):
    """Every point solved by :func:`solve_point`, alone: the reference that the drivers
    without continuation reproduce bit for bit and the continued sweep is checked and
    timed against."""
    for i in range(omega.shape[0]):
        solve_point(structure, omega[i], a[i], lifted[i], budget, 0.0, 1.0, out[i])
