"""Slow sweeps of the drive: each point the motion the sweep brings it to.

Checked against something independent: the event-driven integrator run through the same
protocol (a piecewise-constant drive, each value held a whole number of its periods so
that it switches at phase 0, the state carried), whose mean velocity over whole periods
at the end of each value is the settled motion's; and the hysteresis that an
independent simulation of the M = 0.99 structure shows (forward hop swept up, backward
hop swept down over the same drives).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.solvers.integrator import Schedule, simulate, steady_mode_state
from study.solvers.protocol import JUMP_FRACTION, reversal_jumps, slow_sweep, sweep_order

#: The M -> 1 structure of the flight workflows.
STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
#: Frequencies [Hz] across the up sweep's jump (between 16.0 and 16.1 Hz at 10 m s-2),
#: from one where the release reaches the forward hop.
FREQUENCIES = np.array([14.8, 15.4, 16.0, 16.1, 16.4])
ACCELERATION = 10.0
#: Periods each drive value is held by the integrator, and the last periods averaged.
HELD = 240
AVERAGED = 120


def _integrated_sweep(frequencies: np.ndarray) -> np.ndarray:
    """Mean velocities [m s-1] at the end of each held value of a sweep through
    ``frequencies`` in that order, by the integrator from the release start."""
    durations = HELD / frequencies
    schedule = Schedule(frequencies, np.full(frequencies.size, ACCELERATION), durations)
    ends = np.cumsum(durations)
    times = np.sort(np.concatenate([ends - AVERAGED / frequencies, ends]))
    times[-1] = min(times[-1], ends[-1])
    trajectory = simulate(STRUCTURE, schedule, coupling="two-way", flight=True,
                          initial_state=steady_mode_state(STRUCTURE, frequencies[0],
                                                          ACCELERATION),
                          output_times=times)
    assert trajectory.outcome == "completed"
    x = trajectory.x.reshape(-1, 2)
    return (x[:, 1] - x[:, 0]) * frequencies / AVERAGED


@pytest.mark.parametrize("direction", ["up", "down"])
def test_a_sweep_agrees_with_the_integrator_through_the_same_protocol(direction):
    swept = slow_sweep(STRUCTURE, FREQUENCIES, [ACCELERATION], along="f",
                       direction=direction, flight=True)
    order = FREQUENCIES if direction == "up" else FREQUENCIES[::-1]
    integrated = _integrated_sweep(order)
    velocity = swept.state.velocity[:, 0]
    if direction == "down":
        velocity = velocity[::-1]
    assert np.all(swept.state.status == study.Status.BOUNCING)
    scale = ACCELERATION / (2.0 * np.pi * order)
    assert_allclose(velocity / scale, integrated / scale, rtol=0.0, atol=1e-6)


def test_the_m_to_1_structure_shows_hysteresis():
    up = slow_sweep(STRUCTURE, FREQUENCIES, [ACCELERATION], along="f", direction="up",
                    flight=True)
    down = slow_sweep(STRUCTURE, FREQUENCIES, [ACCELERATION], along="f",
                      direction="down", flight=True)
    v_up, v_down = up.state.velocity[:, 0], down.state.velocity[:, 0]
    # Swept up the structure hops forward until it jumps onto the big backward hop;
    # swept down it stays on the backward hop throughout.
    jump = int(np.flatnonzero(up.jumped[:, 0])[0])
    # The forward hop's branch ends between 16.0 and 16.1 Hz (a sweep in steps of
    # 0.1 Hz jumps at 16.1 Hz); the step of 0.6 Hz to 16.0 Hz may already leave it.
    assert FREQUENCIES[jump] in (16.0, 16.1)
    assert np.count_nonzero(up.jumped) == 1
    assert np.all(v_up[:jump] > 0.0)
    assert np.all(v_up[jump:] < 0.0)
    assert np.all(v_down < 0.0)
    assert not down.jumped.any()
    # Past the jump both sweeps are on the same orbit.
    assert_allclose(v_up[jump:], v_down[jump:], rtol=0.0, atol=1e-12)
    # The jump is far more than the jump threshold.
    assert abs(v_up[jump] - v_up[jump - 1]) > 10 * JUMP_FRACTION * ACCELERATION / (
        2 * np.pi * 16.1)


# Slow tier (54 s in CI): the default tier keeps the sweep against the integrator and the
# hysteresis at M -> 1.
@pytest.mark.slow
def test_a_monostable_structure_sweeps_alike_both_ways():
    paper = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f = np.linspace(12.0, 16.0, 9)
    a = np.array([6.0, 8.0])
    up = slow_sweep(paper, f, a, along="a", direction="up")
    down = slow_sweep(paper, f, a, along="a", direction="down")
    assert_allclose(up.state.velocity, down.state.velocity, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(up.state.status, down.state.status)


def test_the_order_visits_each_line_in_the_direction():
    f = np.array([10.0, 12.0, 11.0])
    a = np.array([1.0, 2.0])
    order, bounds = sweep_order(f, a, "f", "up")
    np.testing.assert_array_equal(bounds, [0, 3, 6])
    np.testing.assert_array_equal(f[order[:3] // a.size], [10.0, 11.0, 12.0])
    np.testing.assert_array_equal(order[3:] % a.size, [1, 1, 1])
    order, _ = sweep_order(f, a, "a", "down")
    np.testing.assert_array_equal(a[order[:2] % a.size], [2.0, 1.0])


def test_the_reversals_are_the_jumps_from_forward_to_backward_up_and_back_down():
    # An axis given high to low: the sweep's order, not the index, says what is before.
    f = np.array([15.0, 14.0, 13.0, 12.0, 11.0, 10.0])
    velocity = np.array([-1.0, 2.0, -3.0, np.nan, 4.0, 5.0])
    jumped = np.array([True, True, True, False, True, False])
    # Up (10 -> 15 Hz): 14 -> 15 reverses; 13 Hz follows a NaN and 12 Hz did not jump.
    np.testing.assert_array_equal(reversal_jumps(f, velocity, jumped, "up"), [0])
    # Down (15 -> 10 Hz): 15 -> 14 reverses; 14 -> 13 goes forward to backward.
    np.testing.assert_array_equal(reversal_jumps(f, velocity, jumped, "down"), [1])
    jumped[1] = False
    assert reversal_jumps(f, velocity, jumped, "down").size == 0
    # Several, in the order the sweep meets them.
    f = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    velocity = np.array([1.0, -1.0, 1.0, -1.0, -1.0])
    np.testing.assert_array_equal(reversal_jumps(f, velocity, np.ones(5, bool), "up"), [1, 3])
    np.testing.assert_array_equal(reversal_jumps(f, velocity, np.ones(5, bool), "down"), [2, 0])


@pytest.mark.parametrize(("key", "kwargs", "text"), [
    ("along", {"along": "frequency"}, "'along' must be one of ['f', 'a']"),
    ("direction", {"along": "f", "direction": "sideways"},
     "'direction' must be one of ['up', 'down']"),
])
def test_bad_protocols_are_refused_naming_the_key(key, kwargs, text):
    with pytest.raises(ValueError, match=key) as error:
        slow_sweep(STRUCTURE, [15.0], [10.0], flight=True, **kwargs)
    assert text in str(error.value)


def test_a_sweep_with_continuation_is_refused():
    with pytest.raises(ValueError, match="continuation"):
        slow_sweep(STRUCTURE, [15.0], [10.0], along="f", flight=True,
                   settings=study.SolverSettings(continuation=True))
