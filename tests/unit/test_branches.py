"""Branches of periodic orbits and their bifurcations (study.branch), checked against
closed forms and second methods.

- The bouncing block: a structure of negligible mass ratio whose base, of restitution
  e, hops on the shaken table as a ball does. Its period-1 orbit with one impact a
  period is born in a fold at Gamma = a / g = pi (1 - e) / (1 + e) and period-doubles
  at Gamma^2 = (pi (1 - e) / (1 + e))^2 + (2 (1 + e^2) / (1 + e)^2)^2 (Holmes 1982;
  the trace of the impact map's Jacobian 1 + e^2 + (1 + e)^2 s'' / g, its
  determinant e^2). The located fold and period doubling must agree to 1e-9.
- The static motion ends where the paper's eq. 5 says (a slip onset at a*+-), or
  without flight at the lift-off acceleration of the base at rest.
- A fold of a hop near M = 1 against the slow sweep on a fine grid, and the unstable
  orbit past it against the integrator's period map.
- Curves over the drive plane (study.bifurcation_curve): the bouncing block's fold and
  period doubling at constant Gamma whatever f, the slip onset on a*(f) of eq. 5, and
  the fold curve of the hop at M = 0.99 against slow sweeps on both sides of its end.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.model.bifurcations import kind_named
from study.solvers.integrator import Schedule, simulate
from study.solvers.protocol import slow_sweep
from tests.support.bouncing_ball import G, ball, ball_doubling, ball_fold, ball_orbit

FOLD = kind_named("fold").code
DOUBLING = kind_named("period_doubling").code
SLIP_ONSET = kind_named("slip_onset").code
LIFT_OFF = kind_named("lift_off").code


@pytest.mark.parametrize("e", [0.3, 0.5, 0.7])
def test_the_bouncing_block_folds_and_doubles_where_the_closed_forms_say(e):
    f = 10.0
    a = 0.5 * (ball_fold(e) + ball_doubling(e)) * G
    state = ball_orbit(e, f, a)
    down = study.branch(ball(e), f, a, along="a", to=0.8 * ball_fold(e) * G,
                        start=state, flight=True)
    up = study.branch(ball(e), f, a, along="a", to=1.1 * ball_doubling(e) * G,
                      start=state, flight=True)
    assert set(down.event_signature.values[:3]) == {"flight + 1 impact"}
    folds = down.bifurcation_kind.values == FOLD
    assert np.count_nonzero(folds) == 1
    assert_allclose(down.bifurcation_a.values[folds] / G, ball_fold(e), rtol=1e-9, atol=0)
    # The multiplier that crosses is +1 there to 1e-8; past the fold the branch runs
    # back, unstable.
    assert_allclose(down.bifurcation_multiplier_modulus.values[folds], 1.0, rtol=0,
                    atol=1e-8)
    assert_allclose(np.cos(down.bifurcation_multiplier_angle.values[folds]), 1.0, rtol=0,
                    atol=1e-12)
    past = int(down.bifurcation_step.values[folds][0]) + 2
    assert np.all(down.branch_direction.values[past:] == -1)
    assert np.all(down.stable.values[past:] == 0)
    doublings = up.bifurcation_kind.values == DOUBLING
    assert np.count_nonzero(doublings) == 1
    assert_allclose(up.bifurcation_a.values[doublings] / G, ball_doubling(e), rtol=1e-9,
                    atol=0)
    assert_allclose(up.bifurcation_multiplier_modulus.values[doublings], 1.0, rtol=0,
                    atol=1e-8)
    assert_allclose(np.cos(up.bifurcation_multiplier_angle.values[doublings]), -1.0,
                    rtol=0, atol=1e-12)
    assert up.attrs["branch_end"] == "reached"
    assert_allclose(up.a.values[-1], 1.1 * ball_doubling(e) * G, rtol=1e-12, atol=0)
    # Between the two, the orbit is the closed form's: its impact map's multipliers have
    # the modulus e (determinant e^2).
    moduli = np.abs(up.multiplier_modulus.values[0])
    assert np.any(np.isclose(moduli, e, rtol=1e-9, atol=0))


def test_the_doubled_orbit_is_born_at_the_period_doubling():
    e = 0.5
    f = 10.0
    a = 0.5 * (ball_fold(e) + ball_doubling(e)) * G
    up = study.branch(ball(e), f, a, along="a", to=1.05 * ball_doubling(e) * G,
                      start=ball_orbit(e, f, a), flight=True)
    index = int(np.flatnonzero(up.bifurcation_kind.values == DOUBLING)[0])
    doubled = study.doubled_branch(ball(e), up, index)
    assert doubled.attrs["orbit_period"] == 2
    # Supercritical: the doubled orbit exists past the doubling, stable, its two impacts
    # drifting apart (two heights), and it starts on the period-1 orbit.
    assert np.all(doubled.a.values[1:] > up.bifurcation_a.values[index])
    assert np.all(doubled.stable.values[1:] == 1)
    assert set(doubled.event_signature.values[1:]) == {"flight + 1 impact"}
    assert_allclose(doubled.a.values[0], up.bifurcation_a.values[index], rtol=1e-12, atol=0)
    with pytest.raises(ValueError, match="not a period doubling"):
        study.doubled_branch(ball(e), up, index + 1)


def test_the_static_motion_slips_at_the_threshold_of_eq_5():
    paper = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f = 13.0
    a_plus, a_minus = study.thresholds(paper, f)
    onset = float(min(a_plus, a_minus))
    static = study.branch(paper, f, 0.5 * onset, along="a", to=1.2 * onset)
    assert static.event_signature.values[0] == "stick"
    onsets = static.bifurcation_kind.values == SLIP_ONSET
    assert np.count_nonzero(onsets) >= 1
    assert_allclose(static.bifurcation_a.values[onsets][0], onset, rtol=1e-9, atol=0)
    # Along f at a fixed drive, where a*(f) crosses it (bisection on the closed form).
    a = 6.0
    from scipy.optimize import brentq
    along_f = study.branch(paper, 12.0, a, along="f", to=14.0)
    crossing = brentq(lambda x: float(min(study.thresholds(paper, x))) - a, 12.0, 14.0,
                      xtol=1e-14)
    onsets = along_f.bifurcation_kind.values == SLIP_ONSET
    assert_allclose(along_f.bifurcation_f.values[onsets][0], crossing, rtol=1e-9, atol=0)


def test_without_flight_the_static_motion_ends_at_lift_off():
    # A horizontal plate (alpha = 0) pushes the base only normally: it never slips, and
    # the base at rest lifts off where the closed form says. (With a tilt, the stick
    # always slips first: the tangential force meets cs n before n meets 0.)
    sticky = study.Structure(f0=14.44, Q=17.5, alpha=0.0, M=0.08, cs=0.25)
    f = 14.0
    lift = float(study.lift_off_acceleration(sticky, f))
    static = study.branch(sticky, f, 0.5 * lift, along="a", to=1.5 * lift)
    assert static.attrs["branch_end"] == "ended"
    ends = static.bifurcation_kind.values == LIFT_OFF
    assert np.count_nonzero(ends) == 1
    assert_allclose(static.bifurcation_a.values[ends], lift, rtol=1e-9, atol=0)


#: The issue's M -> 1 structure, whose forward hop folds near 16.05 Hz at 10 m s-2.
M099 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)


def test_a_fold_of_a_hop_brackets_the_slow_sweeps_jump_and_its_unstable_orbit_is_real():
    # The forward hop as a slow sweep up brings the structure to 15.9 Hz (the release
    # there reaches the backward hop).
    lead = slow_sweep(M099, [14.8, 15.4, 15.9], [10.0], along="f", direction="up",
                      flight=True)
    assert lead.state.velocity[-1, 0] > 0.0
    hop = study.branch(M099, 15.9, 10.0, along="f", to=16.2, flight=True,
                       start=lead.state.phase_state[-1, 0],
                       periods=int(lead.state.orbit_period[-1, 0]))
    folds = np.flatnonzero(hop.bifurcation_kind.values == FOLD)
    assert folds.size >= 1
    fold = float(hop.bifurcation_f.values[folds[0]])
    assert_allclose(hop.bifurcation_multiplier_modulus.values[folds[0]], 1.0, rtol=0,
                    atol=1e-8)
    # The slow sweep on a 0.002 Hz grid rides the forward hop up to the fold and jumps
    # at the first point past it.
    f = np.round(np.concatenate([[14.8, 15.4], np.arange(15.9, 16.1, 0.002)]), 6)
    swept = slow_sweep(M099, f, [10.0], along="f", direction="up", flight=True)
    jumps = np.flatnonzero(swept.jumped[:, 0])
    assert jumps.size >= 1
    assert f[jumps[0] - 1] < fold < f[jumps[0]]
    assert np.all(swept.state.velocity[:jumps[0], 0] > 0.0)
    assert swept.state.velocity[jumps[0], 0] < 0.0
    # Past the fold, on the way back: an unstable orbit with exactly one multiplier
    # outside the unit circle, a fixed point of the integrator's period map too.
    back = np.flatnonzero((hop.branch_direction.values == -1) & (hop.stable.values == 0))
    assert back.size >= 1
    k = int(back[min(3, back.size - 1)])
    assert np.count_nonzero(hop.multiplier_modulus.values[k] > 1.0) == 1
    f_k = float(hop.f.values[k])
    state = _phase_zero_state(hop, k)
    period = 1.0 / f_k
    run = simulate(M099, Schedule(np.array([f_k]), np.array([10.0]), np.array([period])),
                   coupling="two-way", flight=True,
                   initial_state=[state[0], state[1], 0.0, state[2], state[3], state[4]],
                   output_times=[period])
    assert run.outcome == "completed"
    end = np.array([run.delta[-1], run.delta_rate[-1], run.v[-1], run.gap[-1],
                    run.gap_rate[-1]])
    scale = hop["state_scale"].values
    assert_allclose(end / scale, state / scale, rtol=0, atol=1e-6)


def _phase_zero_state(dataset, k):
    """The state at phase 0 of step ``k``'s orbit: its state on the section followed
    by the exact solver's own map to the end of the period."""
    from study.kernels.two_way import branch as kernel
    from study.solvers.structure_constants import structure_vector

    vector = structure_vector(M099, "two-way", True)
    work = kernel.new_branch_work(vector)
    f_k = float(dataset.f.values[k])
    segment = kernel.Segment(2 * np.pi * f_k, 10.0, 2 * np.pi * f_k, 10.0)
    point = kernel.drive_at(vector, work, segment, 0.0, True)
    z = np.ascontiguousarray(dataset.section_state.values[k], dtype=float)
    span = 2 * np.pi / point.omega
    kernel.flow(point, z, float(dataset.section_phase.values[k]) * span, span, work, True,
                100_000)
    return z


def test_bad_branch_requests_are_refused_naming_the_key():
    paper = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    with pytest.raises(ValueError, match="'along' must be one of"):
        study.branch(paper, 13.0, 5.0, along="q", to=6.0)
    with pytest.raises(ValueError, match="coupling must be 'two-way'"):
        study.branch(paper, 13.0, 5.0, along="a", to=6.0, coupling="one-way")
    with pytest.raises(ValueError, match="'to' must differ"):
        study.branch(paper, 13.0, 5.0, along="a", to=5.0)
    with pytest.raises(ValueError, match="lift_off, not a periodic orbit"):
        study.branch(paper, 14.3, 12.0, along="a", to=11.0)


@pytest.mark.parametrize("e", [0.5])
def test_the_bouncing_blocks_fold_and_doubling_curves_keep_gamma_whatever_f(e):
    f = 10.0
    a = 0.5 * (ball_fold(e) + ball_doubling(e)) * G
    state = ball_orbit(e, f, a)
    down = study.branch(ball(e), f, a, along="a", to=0.8 * ball_fold(e) * G,
                        start=state, flight=True)
    fold = int(np.flatnonzero(down.bifurcation_kind.values == FOLD)[0])
    curve = study.bifurcation_curve(ball(e), down, fold, to=13.0, num=7)
    assert curve.attrs["curve_end"] == "reached" and curve.attrs["curve_kind"] == "fold"
    assert_allclose(curve.f.values[[0, -1]], [f, 13.0], rtol=1e-12, atol=0)
    assert curve.sizes["point"] >= 7
    assert_allclose(curve.a.values / G, ball_fold(e), rtol=1e-9, atol=0)
    assert_allclose(curve.multiplier_modulus.values, 1.0, rtol=0, atol=1e-8)
    up = study.branch(ball(e), f, a, along="a", to=1.1 * ball_doubling(e) * G,
                      start=state, flight=True)
    doubling = int(np.flatnonzero(up.bifurcation_kind.values == DOUBLING)[0])
    curve = study.bifurcation_curve(ball(e), up, doubling, to=8.0, num=5)
    assert curve.attrs["curve_end"] == "reached"
    assert_allclose(curve.a.values / G, ball_doubling(e), rtol=1e-9, atol=0)
    assert_allclose(np.cos(curve.multiplier_angle.values), -1.0, rtol=0, atol=1e-10)


def test_the_slip_onset_curve_is_eq_5s_threshold_over_f():
    paper = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    static = study.branch(paper, 13.0, 2.0, along="a", to=8.0)
    onset = int(np.flatnonzero(static.bifurcation_kind.values == SLIP_ONSET)[0])
    curve = study.bifurcation_curve(paper, static, onset, to=15.0, num=5)
    assert curve.attrs["curve_end"] == "reached"
    closed = np.array([min(study.thresholds(paper, x)) for x in curve.f.values])
    assert_allclose(curve.a.values, closed, rtol=1e-9, atol=0)
    # Bad requests name the argument.
    with pytest.raises(ValueError, match="'bifurcation' must be an index"):
        study.bifurcation_curve(paper, static, 7, to=15.0)
    with pytest.raises(ValueError, match="'to' must differ"):
        study.bifurcation_curve(paper, static, onset, to=13.0)
    with pytest.raises(ValueError, match="'num' must be"):
        study.bifurcation_curve(paper, static, onset, to=15.0, num=1)
    with pytest.raises(ValueError, match="structure's M"):
        study.bifurcation_curve(study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.5,
                                                cs=0.25), static, onset, to=15.0)


def test_the_fold_curve_of_the_hop_ends_where_slow_sweeps_stop_jumping():
    lead = slow_sweep(M099, [14.8, 15.4, 15.9], [10.0], along="f", direction="up",
                      flight=True)
    hop = study.branch(M099, 15.9, 10.0, along="f", to=16.2, flight=True,
                       start=lead.state.phase_state[-1, 0],
                       periods=int(lead.state.orbit_period[-1, 0]))
    fold = int(np.flatnonzero(hop.bifurcation_kind.values == FOLD)[0])
    curve = study.bifurcation_curve(M099, hop, fold, to=7.0, num=13)
    # Towards small a the fold moves up in f until it vanishes: a cusp, bracketed.
    assert curve.attrs["curve_end"] == "vanished"
    low, high = curve.attrs["curve_end_low"], curve.attrs["curve_end_high"]
    assert 7.85 < high < low < 8.0 and low - high <= 1e-6 * low
    # Where the two folds meet, a long step could pass both: the end is bracketed with
    # the branch's own steps, so the short-stepped curve ends in the same place.
    short = study.bifurcation_curve(M099, hop, fold, to=7.0, num=13, max_step=0.02)
    assert short.attrs["curve_end"] == "vanished"
    assert_allclose([short.attrs["curve_end_low"], short.attrs["curve_end_high"]],
                    [low, high], rtol=3e-6, atol=0)
    assert_allclose(curve.multiplier_modulus.values, 1.0, rtol=0, atol=1e-7)
    at_8 = float(curve.f.values[np.flatnonzero(curve.a.values == 8.0)[0]])
    # Slow sweeps up on a 0.01 Hz grid: at 8 m s-2 the forward hop jumps at the first
    # point past the fold; below the cusp (7.85) it never jumps.
    f = np.round(np.concatenate([np.arange(14.8, 20.6, 0.4),
                                 np.arange(20.6, 21.6, 0.01)]), 6)
    swept = slow_sweep(M099, f, [7.85, 8.0], along="f", direction="up", flight=True)
    jumps = np.flatnonzero(swept.jumped[:, 1])
    assert jumps.size == 1 and f[jumps[0] - 1] < at_8 < f[jumps[0]]
    assert swept.state.velocity[jumps[0] - 1, 1] > 0.0 > swept.state.velocity[jumps[0], 1]
    assert not swept.jumped[:, 0].any()
    assert np.all(swept.state.velocity[:, 0] > 0.0)
