"""Where a slow sweep jumps: the motion it settles on is not the continuation of the
motion at the point before, whatever its velocity does.

Each case is checked against something independent of the jump test: the
event-driven integrator run through the same protocol (a piecewise-constant drive, each
value held a whole number of its periods so that it switches at phase 0, the state
carried) settles on the motions the sweep reports, and the exact sweep on a grid 50
times finer (its velocities alone, not its flags) shows what happens between two
points: a discontinuity, two motions coexisting in the two directions, or a smooth
branch that the coarse sweep left. Each case fails on the rule of release 0.3 (a jump
where the motion did not settle on the fixed point Newton's method found from the
carried state and the velocity changed by more than 5 % of a / (2 pi f)).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.kernels.two_way import branch
from study.solvers.integrator import Schedule, simulate, steady_mode_state
from study.solvers.protocol import JUMP_FRACTION, slow_sweep
from study.solvers.structure_constants import structure_vector
from tests.support.integrated import integrated_from

#: A user's structure near M = 1 (the issue's): forward and backward hops coexist.
USER = study.Structure(f0=18.0, Q=25.0, alpha=55.0, M=0.9, cs=0.35)
#: A structure of M = 0.5 (the paper's plate, flight).
M05 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.5, cs=0.25)
#: Periods each drive value is held by the integrator, and the last periods averaged.
HELD = 240
AVERAGED = 120


def _integrated_sweep(structure: study.Structure, frequencies: np.ndarray,
                      acceleration: float) -> np.ndarray:
    """Mean velocities [m s-1] at the end of each held value of a sweep through
    ``frequencies`` [Hz] in that order at ``acceleration`` [m s-2], by the integrator
    with flight from the release at the first."""
    durations = HELD / frequencies
    schedule = Schedule(frequencies, np.full(frequencies.size, acceleration), durations)
    ends = np.cumsum(durations)
    times = np.sort(np.concatenate([ends - AVERAGED / frequencies, ends]))
    times[-1] = min(times[-1], ends[-1])
    trajectory = simulate(structure, schedule, coupling="two-way", flight=True,
                          initial_state=steady_mode_state(structure, frequencies[0],
                                                          acceleration),
                          output_times=times)
    assert trajectory.outcome == "completed"
    x = trajectory.x.reshape(-1, 2)
    return (x[:, 1] - x[:, 0]) * frequencies / AVERAGED


def _integrated_from(structure: study.Structure, f: float, a: float,
                     state: np.ndarray) -> float:
    """Mean velocity [m s-1] over the last AVERAGED of HELD periods (see
    :func:`tests.support.integrated.integrated_from`)."""
    return integrated_from(structure, f, a, state, held=HELD, averaged=AVERAGED)


def _swept(frequencies, acceleration, direction):
    """The sweep's velocities [m s-1] and flags in the order visited."""
    swept = slow_sweep(USER, frequencies, [acceleration], along="f", direction=direction,
                       flight=True)
    velocity = swept.state.velocity[:, 0]
    jumped = swept.jumped[:, 0]
    if direction == "down":
        return velocity[::-1], jumped[::-1], swept
    return velocity, jumped, swept


def test_a_reversal_of_direction_is_a_jump():
    # The case: swept up at 12 m s-2 the forward hop (+81.4 mm s-1) ends between
    # 11.5 and 11.6 Hz and the structure lands on the backward hop (-69.1 mm s-1).
    f = np.round(np.arange(11.3, 11.81, 0.1), 6)
    velocity, jumped, _ = _swept(f, 12.0, "up")
    scale = 12.0 / (2 * np.pi * f)
    assert_allclose(velocity / scale, _integrated_sweep(USER, f, 12.0) / scale,
                    rtol=0.0, atol=1e-6)
    assert velocity[2] > 0.08 and velocity[3] < -0.06
    np.testing.assert_array_equal(jumped, [False, False, False, True, False, False])


def test_a_fold_with_hardly_any_change_of_velocity_is_a_jump_both_ways():
    # At 10 m s-2 two forward hops 0.2 mm s-1 apart coexist over 9.4031-9.4040 Hz: swept
    # up the slower one folds at 9.4040 Hz (its multiplier 0.935 there), swept down the
    # faster one at 9.4031 Hz. Both sweeps jump, by 0.12 % of a / (2 pi f).
    up_f = np.array([9.4030, 9.4035, 9.4045])
    down_f = np.array([9.4045, 9.4035, 9.4025])
    v_up, j_up, _ = _swept(np.sort(up_f), 10.0, "up")
    v_down, j_down, _ = _swept(np.sort(down_f), 10.0, "down")
    scale = 10.0 / (2 * np.pi * 9.4035)
    assert_allclose(v_up / scale, _integrated_sweep(USER, up_f, 10.0) / scale, rtol=0.0,
                    atol=1e-6)
    assert_allclose(v_down / scale, _integrated_sweep(USER, down_f, 10.0) / scale,
                    rtol=0.0, atol=1e-6)
    # Two motions at 9.4035 Hz: the sweeps in the two directions end on different ones,
    # so each direction leaves one of them between its points.
    assert abs(v_up[1] - v_down[1]) > 1e-4
    np.testing.assert_array_equal(j_up, [False, False, True])
    np.testing.assert_array_equal(j_down, [False, False, True])
    # The velocity changes by far less than the rule of release 0.3 asked.
    assert abs(v_up[2] - v_up[1]) < 0.05 * JUMP_FRACTION * scale
    # The jump itself: on a sweep 0.0001 Hz finer the velocity steps between two points
    # by more than ten times its change between any others.
    fine = np.round(np.arange(9.4030, 9.40455, 0.0001), 6)
    v_fine, _, _ = _swept(fine, 10.0, "up")
    steps = np.abs(np.diff(v_fine))
    largest = int(np.argmax(steps))
    assert 9.4039 < fine[largest] < 9.4042
    assert steps[largest] > 10 * np.delete(steps, largest).max()


def test_leaving_a_branch_that_goes_on_is_a_jump():
    # M = 0.5 with flight at 17 Hz, swept down along a in steps of 0.2 m s-2: from the
    # hop at 7.6 m s-2 (-0.73 mm s-1) the branch goes on to 7.4 m s-2 (a sweep of
    # 0.004 m s-2 steps stays on it, at -1.31 mm s-1), but the state carried in one
    # step settles on another hop (-0.79 mm s-1): hardly any change of velocity.
    a = np.round(np.linspace(0.0, 12.0, 61), 6)
    swept = slow_sweep(M05, [17.0], a, along="a", direction="down", flight=True)
    i = int(np.flatnonzero(a == 7.4)[0])
    v = swept.state.velocity[0]
    assert swept.jumped[0, i]
    assert not swept.jumped[0, i + 1:].any()
    # The integrator from the state the sweep carried from 7.6 m s-2 settles on the
    # motion the sweep reports (and so do states 1e-5 off it: no basin boundary near).
    state = swept.state.phase_state[0, i + 1]
    rng = np.random.default_rng(1)
    scale = 7.4 / (2 * np.pi * 17.0)
    for factor in (0.0, 1e-5, -1e-5):
        start = np.array([state[0], state[1], 0.0, state[2], state[3], state[4]])
        start *= 1.0 + factor * rng.standard_normal(6)
        assert_allclose(_integrated_from(M05, 17.0, 7.4, start) / scale, v[i] / scale,
                        rtol=0.0, atol=1e-6)
    fine = np.round(np.concatenate([np.arange(7.4, 7.6001, 0.004), a[a > 7.6]]), 6)
    fine_swept = slow_sweep(M05, [17.0], fine, along="a", direction="down", flight=True)
    v_fine = fine_swept.state.velocity[0, fine <= 7.6]
    assert abs(v_fine[0] - v[i]) > 0.4e-3
    # The fine sweep follows one smooth branch: no step beyond twice its median.
    steps = np.abs(np.diff(v_fine))
    assert steps.max() < 2 * np.median(steps)
    assert not fine_swept.jumped[0, fine <= 7.6].any()
    # The rule of release 0.3 saw nothing: the velocity changed by 0.06 mm s-1.
    assert abs(v[i] - v[i + 1]) < JUMP_FRACTION * scale


@pytest.mark.parametrize("direction", ["up", "down"])
def test_a_period_doubling_is_no_jump(direction):
    # M = 0.5 with flight at 18.5 Hz: swept along a, the hop doubles its period between
    # 9.0 and 9.2 m s-2 on one smooth branch (-62.8 to -71.3 mm s-1, more than 5 % of
    # a / (2 pi f), which release 0.3 counted as a jump).
    a = np.round(np.linspace(0.0, 12.0, 61), 6)
    swept = slow_sweep(M05, [18.5], a, along="a", direction=direction, flight=True)
    i = int(np.flatnonzero(a == 9.2)[0])
    assert swept.state.orbit_period[0, i - 1] == 1
    assert swept.state.orbit_period[0, i] == 2
    assert not swept.jumped[0, i - 1:i + 1].any()
    assert abs(swept.state.velocity[0, i] - swept.state.velocity[0, i - 1]) > (
        JUMP_FRACTION * 9.2 / (2 * np.pi * 18.5))
    # The same on a grid 50 times finer: the velocity changes smoothly through the
    # doubling, no step beyond three times the median.
    fine = np.round(np.concatenate([a[a < 9.0], np.arange(9.0, 9.2001, 0.004)]), 6)
    fine_swept = slow_sweep(M05, [18.5], fine, along="a", direction="up", flight=True)
    v = fine_swept.state.velocity[0, fine >= 9.0]
    steps = np.abs(np.diff(v))
    assert steps.max() < 3 * np.median(steps)
    assert_allclose(v[[0, -1]], swept.state.velocity[0, [i - 1, i]], rtol=0.0, atol=1e-9)


def test_a_period_halving_is_no_jump():
    # The user's structure at 12 m s-2 swept up: the period-2 hop merges into the
    # period-1 hop near 15.37 Hz (a 0.002 Hz sweep shows it: -58.18 to -58.14 mm s-1);
    # the coarse step 15.3 -> 15.4 Hz follows the period-2 orbit onto the period-1 one.
    f = np.round(np.arange(15.1, 15.41, 0.1), 6)
    _, jumped, swept = _swept(f, 12.0, "up")
    np.testing.assert_array_equal(swept.state.orbit_period[:, 0], [2, 2, 2, 1])
    assert not jumped.any()


def test_the_branch_followed_folds_where_the_fine_sweep_jumps():
    # The orbit at 9.4030 Hz followed along its branch towards 9.4045 Hz turns back (or
    # reaches a multiplier of +1) between 9.4040 and 9.4041 Hz, where the sweep in
    # steps of 0.0001 Hz jumps (test above), its largest multiplier near 1 there.
    swept = slow_sweep(USER, [9.4030], [10.0], along="f", direction="up", flight=True)
    state = np.ascontiguousarray(swept.state.phase_state[0, 0])
    vector = structure_vector(USER, "two-way", True)
    work = branch.new_branch_work(vector)
    segment = branch.Segment(2 * np.pi * 9.4030, 10.0, 2 * np.pi * 9.4045, 10.0)
    followed = branch.follow_orbit(vector, segment, state, 1, work, 100_000)
    assert followed.outcome in (branch.FOLDED, branch.SINGULAR)
    f_end = 9.4030 + followed.reached * 0.0015
    assert 9.4040 <= f_end <= 9.4041
    assert_allclose(followed.radius, 1.0, rtol=0.0, atol=2e-2)
    # Followed to 9.4035 Hz instead, it goes on, onto the orbit the sweep reaches there.
    segment = branch.Segment(2 * np.pi * 9.4030, 10.0, 2 * np.pi * 9.4035, 10.0)
    followed = branch.follow_orbit(vector, segment, state, 1, work, 100_000)
    assert followed.outcome == branch.FOLLOWED
    reached = slow_sweep(USER, [9.4030, 9.4035], [10.0], along="f", direction="up",
                         flight=True).state.velocity[1, 0]
    assert_allclose(followed.velocity, reached, rtol=1e-8, atol=0.0)
