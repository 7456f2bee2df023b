"""Paper Fig. 4: the two-plate disk steered by a sequence of drive frequencies.

The disk is the one of ``workflows/steering.toml``: the paper's plate at the head
along the axis, a tail plate across it (parameters chosen, see README "Steering").
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from study.model.status import Status
from study.scenes.planar_model import periodic_motion, rest_state
from study.scenes.scene_spec import load_scene
from study.solvers.integrator import IntegratorSettings, Schedule
from study.solvers.planar import simulate_planar

WORKFLOW = "workflows/steering.toml"
A_OPERATING = 7.0  # m s-2
FORWARD, BACKWARD, LEFT, RIGHT = 14.2, 15.2, 7.2, 8.2  # Hz, paper Fig. 4A caption


@pytest.fixture(scope="module")
def disk():
    return load_scene(WORKFLOW).disk


@pytest.fixture(scope="module")
def motions(disk):
    return {f: periodic_motion(disk, f, A_OPERATING) for f in (FORWARD, BACKWARD, LEFT, RIGHT)}


def _run(disk, f, a, periods, heading=0.0):
    state = rest_state(disk, (0.0, 0.0, heading), drive=(f, a))
    schedule = Schedule.constant(f, a, periods / f)
    return simulate_planar(disk, schedule, initial_state=state, output_times=[0.0, periods / f],
                           settings=IntegratorSettings(tolerance=1e-9))


def test_forward_and_backward_move_along_the_heading_with_opposite_signs(disk, motions):
    forward, backward = motions[FORWARD], motions[BACKWARD]
    assert forward.status == Status.STICK_SLIP and backward.status == Status.STICK_SLIP
    assert forward.forward_speed > 0.0 > backward.forward_speed
    # Mostly along the heading: the lateral drift is a small fraction of the speed.
    assert abs(forward.lateral_speed) < 0.1 * forward.forward_speed
    assert abs(backward.lateral_speed) < 0.3 * abs(backward.forward_speed)
    # The same in a simulated run started facing 40 degrees: the displacement's
    # component along that heading has the command's sign.
    heading = math.radians(40.0)
    for f, sign in ((FORWARD, 1.0), (BACKWARD, -1.0)):
        run = _run(disk, f, A_OPERATING, 30, 40.0)  # the API's heading is in degree
        dx, dy = run.x[-1] - run.x[0], run.y[-1] - run.y[0]
        along = math.cos(heading) * dx + math.sin(heading) * dy
        assert sign * along > 0.0
        assert abs(-math.sin(heading) * dx + math.cos(heading) * dy) < 0.3 * abs(along)


def test_the_two_turn_frequencies_turn_opposite_ways(disk, motions):
    left, right = motions[LEFT], motions[RIGHT]
    assert left.turn_rate > 0.0 > right.turn_rate  # counterclockwise, clockwise
    # Turning, not sliding: over one radian of turn the centre moves less than a radius
    # (turn rates in degree s-1).
    for motion in (left, right):
        assert math.hypot(motion.forward_speed, motion.lateral_speed) / abs(
            math.radians(motion.turn_rate)) < disk.radius
    run_left = _run(disk, LEFT, A_OPERATING, 20)
    run_right = _run(disk, RIGHT, A_OPERATING, 20)
    # More than 0.05 rad each way, in degree.
    assert run_left.heading[-1] > math.degrees(0.05) and run_right.heading[-1] < -math.degrees(
        0.05)


def test_the_straight_commands_turn_much_slower_than_the_turn_commands(motions):
    slowest_turn = min(abs(motions[LEFT].turn_rate), abs(motions[RIGHT].turn_rate))
    for f in (FORWARD, BACKWARD):
        assert abs(motions[f].turn_rate) < 0.15 * slowest_turn


@pytest.mark.parametrize("f", [FORWARD, BACKWARD, LEFT, RIGHT])
def test_below_threshold_nothing_moves(disk, f):
    run = _run(disk, f, 2.0, 20, heading=17.0)  # degree (it converts to rad and back exactly)
    assert run.slips == 0
    assert_allclose([run.x[-1], run.y[-1], run.heading[-1]], [0.0, 0.0, 17.0], rtol=0, atol=0)
    assert periodic_motion(disk, f, 2.0).status == Status.STATIC


def test_with_the_papers_tail_resonance_the_turns_go_the_same_way(disk):
    """README claim: at f0 = 8.5 Hz, 7.2 and 8.2 Hz do not turn opposite ways."""
    head, tail = disk.plates
    paper_tail = replace(disk, plates=(head, replace(tail, f0=8.5)))
    for a in (6.0, 7.0, 8.0):
        rates = [periodic_motion(paper_tail, f, a).turn_rate for f in (LEFT, RIGHT)]
        assert rates[0] * rates[1] >= 0.0


def test_heading_noise_reproduces_the_measured_drift(disk):
    """0.1 rad (5.73 degree) of heading spread per diameter slid (paper, Fig. 4 text);
    the API's drift, noise and kicks are in degree."""
    drift = math.degrees(0.1)
    noise = drift / math.sqrt(disk.diameter)  # degree m^-1/2
    state = rest_state(disk, drive=(FORWARD, A_OPERATING))
    periods = 600
    run = simulate_planar(disk, Schedule.constant(FORWARD, A_OPERATING, periods / FORWARD),
                          initial_state=state, heading_noise=noise, rng=11,
                          output_times=[periods / FORWARD])
    kicks = run.heading_kicks
    assert kicks.size >= periods
    # Per period the kick variance is noise^2 times the distance slid: the summed
    # variance per diameter is drift^2 (chi-square with ~600 dof: 6 % spread).
    per_diameter = np.sum(kicks**2) / (run.path[-1] / disk.diameter)
    assert_allclose(per_diameter, drift**2, rtol=0.25)


def test_the_commands_keep_the_disk_in_full_contact(disk):
    """The model assumes full contact; at the operating point it holds, rim included."""
    from study.scenes.planar_model import contact_margins

    for f in (FORWARD, BACKWARD, LEFT, RIGHT):
        rim, normal = contact_margins(disk, f, A_OPERATING)
        assert rim > 0.0 and normal > 0.0
