"""Continuous sliding of the one-way solver without a cycle within reach (issue 35, the
one-way part): the circle map of the reversal phases is followed and time-averaged
instead of being left ``NOT_CONVERGED`` (``NO_PERIODIC_ORBIT``).

Where the cycle search (``max_map_iterations`` iterations, cycles of up to
``MAX_MAP_PERIOD`` iterations) finds no cycle, the kernel
(:func:`study.kernels.one_way._average_sliding`) follows the map's iterates, discards
the transient, and reports ``QUASI_PERIODIC`` (or ``CHAOTIC``) with the time-averaged
velocity (total displacement over total time), its batch-means error and the mean of
``log|d theta_end / d theta_start|`` per drive period, or ``NOT_CONVERGED`` with
``AVERAGE_BUDGET`` past the averaging budget.

No point of the model reaches that path with the default budgets. A seeded search
(numpy default_rng 1, 2 and 4: ~28 million drive points of ~490 structures, Q 2-1000, alpha
0.5-89.5 degree, cs 0.003-1, ck/cs 0.01-1, M 0.001-0.98, f 1.4-144 Hz, a 0.1-1000 m s-2,
the paper's structure among them) found every continuous sliding a period-1 cycle, and
none NOT_CONVERGED. That is expected: a forward slip can only start where it accelerates
(``|psi0| < gamma <= pi / 2``), so the map's iterates stay on an arc of at most half
the circle, and its derivative (the product of two negative ratios of slopes) is
positive: an increasing map of an arc into itself has every orbit converging to a
fixed point. An invariant circle (quasi-periodic motion) or chaos cannot arise, and
the averaged exponent of a reachable motion is a fixed point's, negative.

The averaging is therefore exercised on real points by taking the cycle search's
budget away (``max_map_iterations=1``: the first iterate is not yet within the
search's detection gap of its fixed point, so no cycle is tried): the averages must
then reproduce the cycle the default solver finds, and the time integrator's long run
(an independent method). The motion reported is QUASI_PERIODIC by the two-way rule (an
exponent clearly below EXPONENT_ZERO: "a stable cycle longer than the cycles searched
for"). All runs are deterministic; no time is measured.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import study
from study.kernels import time_average
from study.model.codes import (
    CONTINUOUS_SLIDING,
    LIFT_OFF,
    NOT_CONVERGED,
    QUASI_PERIODIC,
    REASON_AVERAGE_BUDGET,
    REASON_NONE,
    STATIC,
    STICK_SLIP,
)
from study.solvers.exact import steady_state, steady_velocity
from study.solvers.integrator import Schedule, simulate, steady_mode_state
from study.solvers.settings import SolverSettings

#: A structure with continuous sliding at moderate drive (from the seeded search,
#: rounded): its cycles contract by exp(-0.1) a period, so the averaging's transient
#: of DISCARDED_PERIODS iterations has long decayed.
SLIDING = dict(f0=14.44, Q=45.5, alpha=28.7, cs=0.073, ck=0.0226, M=0.593)
#: A more weakly contracting one (exp(-0.057) a period), nearer the paper's (Q = 125,
#: alpha 39 degree, low friction).
WEAK = dict(f0=14.44, Q=125.4, alpha=39.1, cs=0.014, ck=0.0135, M=0.0574)
#: (structure, f [Hz], a [m s-2]) of the averaged points.
POINTS = {"sliding": (SLIDING, 22.94, 20.57), "weak": (WEAK, 14.706, 13.878)}
#: The cycle search without its budget: one iteration, no cycle tried.
NO_SEARCH = SolverSettings(max_map_iterations=1)
#: Drive periods of the integrator's runs (the first DISCARDED_PERIODS left out).
LONG_RUN = 2100


def _solve(key, settings=None):
    structure, f, a = POINTS[key]
    return steady_state(study.Structure(**structure), f, a, settings, coupling="one-way")


@pytest.fixture(scope="module")
def averaged():
    """Both points solved without the cycle search (averaged) and with it (the cycle)."""
    return {key: (_solve(key, NO_SEARCH), _solve(key)) for key in POINTS}


@pytest.mark.parametrize("key", sorted(POINTS))
def test_without_a_cycle_the_motion_is_averaged(averaged, key):
    """The point is QUASI_PERIODIC with the averaged velocity as its velocity, no orbit,
    a positive error whose 95 % half-width is within velocity_tolerance * a / (2 pi f),
    and at least MIN_AVERAGED periods; its exponent is clearly below EXPONENT_ZERO."""
    row, _ = averaged[key]
    _, f, a = POINTS[key]
    assert int(row.status) == QUASI_PERIODIC and int(row.reason) == REASON_NONE
    assert float(row.velocity) == float(row.averaged_velocity)
    assert int(row.orbit_period) == 0
    error = float(row.velocity_error)
    assert 0.0 < time_average.Z_95 * error <= NO_SEARCH.velocity_tolerance * a / (
        2.0 * math.pi * f)
    assert int(row.averaged_periods) >= time_average.MIN_AVERAGED
    exponent, exponent_error = float(row.lyapunov_exponent), float(row.lyapunov_error)
    assert exponent_error > 0.0
    assert exponent + time_average.EXPONENT_SIGMAS * exponent_error < time_average.EXPONENT_ZERO
    assert float(row.slips_per_period) > 0.0
    assert 0.0 < float(row.forward_fraction) < 1.0
    assert 0.0 < float(row.backward_fraction) < 1.0


@pytest.mark.parametrize("key", sorted(POINTS))
def test_averages_reproduce_the_cycle(averaged, key):
    """The averages of the iterates converging onto the cycle are the cycle's: velocity
    within 4 standard errors (the transient left after DISCARDED_PERIODS iterations
    biases it by about 2), the exponent (the mean log-derivative per drive period)
    within 4 errors of the cycle's log|multiplier| / period, the slip statistics to
    1e-3. Measured: sliding -4.56033 +- 0.0000039 mm s-1 against -4.56034, exponent
    -0.104846 against -0.104846; weak -32.9505 +- 0.0064 against -32.9649, -0.056494
    +- 0.0000028 against -0.056500."""
    row, cycle = averaged[key]
    assert int(cycle.status) == CONTINUOUS_SLIDING and int(cycle.orbit_period) == 1
    assert_allclose(float(row.velocity), float(cycle.velocity), rtol=0.0,
                    atol=4.0 * float(row.velocity_error))
    assert_allclose(float(row.lyapunov_exponent), float(cycle.lyapunov_exponent), rtol=0.0,
                    atol=4.0 * float(row.lyapunov_error))
    for name in ("slips_per_period", "forward_fraction", "backward_fraction"):
        assert_allclose(float(getattr(row, name)), float(getattr(cycle, name)), rtol=1e-3,
                        atol=0.0)


def _integrated_mean(structure, f, a):
    """Mean velocity [m s-1] and its batch-means standard error of the one-way
    integrator's run of LONG_RUN periods from the solver's start, the first
    DISCARDED_PERIODS left out."""
    period = 1.0 / f
    run = simulate(structure, Schedule.constant(f, a, LONG_RUN * period), coupling="one-way",
                   initial_state=steady_mode_state(structure, f, a),
                   output_times=np.arange(LONG_RUN + 1) * period, max_events=0)
    assert run.outcome == "completed"
    velocities = np.diff(run.x)[time_average.DISCARDED_PERIODS:] / period
    mean, error, _ = time_average.mean_and_error(velocities, velocities.size)
    return mean, error


@pytest.mark.parametrize("key", sorted(POINTS))
def test_mean_velocity_against_the_integrators_long_run(averaged, key):
    """The averaged velocity against the time integrator's 2000-period mean from the
    same start (a different numerical method): within 4 combined standard errors.
    Measured (mm s-1): sliding -4.5603343 +- 0.0000039 against -4.5603396 +- 0.0000010
    (1.3 errors); weak -32.9505 +- 0.0064 against -32.9628 +- 0.0018 (1.8 errors)."""
    row, _ = averaged[key]
    structure, f, a = POINTS[key]
    mean, error = _integrated_mean(study.Structure(**structure), f, a)
    solver, solver_error = float(row.velocity), float(row.velocity_error)
    assert solver_error > 0.0 and error > 0.0
    assert_allclose(solver, mean, rtol=0.0, atol=4.0 * math.hypot(error, solver_error))


def test_velocity_path_reports_the_same_motion(averaged):
    """``steady_velocity`` (the velocity-only kernel) averages the same iterates: the
    same velocity and status as ``steady_state``."""
    structure, f, a = POINTS["sliding"]
    velocity, status = steady_velocity(study.Structure(**structure), f, a, NO_SEARCH,
                                       coupling="one-way")
    row, _ = averaged["sliding"]
    assert int(status) == QUASI_PERIODIC
    assert float(velocity) == float(row.velocity)


def test_outside_the_tolerance_at_the_budget_is_not_converged():
    """A tolerance the budget cannot reach (1e-7 of a / (2 pi f) in 256 iterates):
    NOT_CONVERGED with AVERAGE_BUDGET, no velocity, the partial mean, its error and
    the periods averaged kept (the mean close to the cycle's)."""
    settings = SolverSettings(max_map_iterations=1, velocity_tolerance=1e-7,
                              max_average_periods=256)
    row = _solve("weak", settings)
    cycle = _solve("weak")
    assert int(row.status) == NOT_CONVERGED and int(row.reason) == REASON_AVERAGE_BUDGET
    assert np.isnan(float(row.velocity))
    assert float(row.velocity_error) > 0.0
    assert 250 <= int(row.averaged_periods) <= 262
    assert_allclose(float(row.averaged_velocity), float(cycle.velocity), rtol=0.0,
                    atol=4.0 * float(row.velocity_error))


#: Points of SLIDING solved before the averaging (release 0.3.0's one-way kernel):
#: static, stick-slip and four continuous slidings (period 1), with their values then,
#: bit for bit (float.hex).
BEFORE = {
    "f": [8.0, 24.0, 12.0, 18.0, 32.0, 22.94],
    "a": [2.0, 2.0, 2.0, 4.0, 4.0, 20.57],
    "status": [STATIC, STICK_SLIP] + [CONTINUOUS_SLIDING] * 4,
    "velocity": ["0x0.0p+0", "-0x1.f771a33860a44p-12", "0x1.37fe802582ef2p-9",
                 "0x1.57d29f37a7ca6p-20", "-0x1.c894fde902b92p-12", "-0x1.2addd1c7f44c8p-8"],
    "slips_per_period": ["0x0.0p+0"] + ["0x1.0000000000000p+1"] * 5,
    "forward_fraction": ["0x0.0p+0", "0x1.ccfa9ba4bf5dap-2", "0x1.1318cb03bbf68p-1",
                         "0x1.fe1a084a341a2p-2", "0x1.eea791c144e69p-2",
                         "0x1.e98b41fe4c111p-2"],
    "backward_fraction": ["0x0.0p+0", "0x1.08086258e9333p-1", "0x1.d9ce69f888132p-2",
                          "0x1.00f2fbdae5f2ep-1", "0x1.08ac371f5d8cbp-1",
                          "0x1.0b3a5f00d9f76p-1"],
}


@pytest.mark.parametrize("size", [6, 3000])
def test_periodic_points_are_unchanged(size):
    """Orbits are reported bit for bit as before the averaging, by the small-call
    kernel (6 points) and the array kernel (the same points repeated to 3000, past
    PARALLEL_THRESHOLD), and carry no averages: error 0, no periods averaged, no
    averaged velocity; a continuous sliding's exponent is log|multiplier| per period
    (negative: the cycle attracts), with error 0; static and stick-slip points have no
    exponent (a stick forgets the phase)."""
    repeat = size // 6
    f = np.tile(BEFORE["f"], repeat)
    a = np.tile(BEFORE["a"], repeat)
    rows = steady_state(study.Structure(**SLIDING), f, a, coupling="one-way")
    assert_array_equal(rows.status, np.tile(BEFORE["status"], repeat))
    assert_array_equal(rows.reason, REASON_NONE)
    assert_array_equal(rows.orbit_period, np.tile([0, 1, 1, 1, 1, 1], repeat))
    for name in ("velocity", "slips_per_period", "forward_fraction", "backward_fraction"):
        expected = np.tile([float.fromhex(x) for x in BEFORE[name]], repeat)
        assert_array_equal(getattr(rows, name), expected, err_msg=name)
    assert_array_equal(rows.velocity_error, 0.0)
    assert_array_equal(rows.averaged_periods, 0)
    assert np.all(np.isnan(rows.averaged_velocity))
    sliding = rows.status == CONTINUOUS_SLIDING
    assert np.all(rows.lyapunov_exponent[sliding] < 0.0)
    assert_array_equal(rows.lyapunov_error[sliding], 0.0)
    assert np.all(np.isnan(rows.lyapunov_exponent[~sliding]))
    assert np.all(np.isnan(rows.lyapunov_error[~sliding]))


def test_lift_off_rows_carry_no_averages():
    """Past lift-off: no averages (NaN), no periods averaged."""
    structure = study.Structure(**SLIDING)
    a = 2.0 * float(study.lift_off_acceleration(structure, 20.0))
    for f, accel in ((20.0, a), (np.array([20.0, 20.0]), np.array([a, a]))):
        rows = steady_state(structure, f, accel, coupling="one-way")
        assert np.all(np.asarray(rows.status) == LIFT_OFF)
        assert np.all(np.asarray(rows.averaged_periods) == 0)
        for name in ("averaged_velocity", "velocity_error", "lyapunov_exponent",
                     "lyapunov_error"):
            assert np.all(np.isnan(np.asarray(getattr(rows, name)))), name
