"""The event-driven time integrator (study.solvers.integrator) against closed forms and the
exact solver."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from study import Structure
from study.kernels import integrator as kernel
from study.model import codes, lift_off_acceleration, mode_response, release_amplitudes, thresholds
from study.model.status import NonConvergence, Status
from study.solvers.exact import steady_state
from study.solvers.integrator import (
    IntegratorSettings,
    Schedule,
    integrated_steady_state,
    simulate,
    steady_mode_state,
)

PAPER = Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)


def _free_mode(structure, state0, f, a, t):
    """Closed-form deflection of the driven damped mode from ``state0`` (no slip needed)."""
    w = 2 * math.pi * f
    w0 = structure.omega0
    zeta = 1 / (2 * structure.Q)
    amp = a * math.cos(structure.alpha_rad) * complex(mode_response(structure, f))
    particular = lambda tt: (amp * np.exp(1j * w * tt)).real  # noqa: E731
    particular_rate = (1j * w * amp).real
    d0 = state0[0] - amp.real
    v0 = state0[1] - particular_rate
    wd = w0 * math.sqrt(1 - zeta**2)
    homogeneous = np.exp(-zeta * w0 * t) * (
        d0 * np.cos(wd * t) + (v0 + zeta * w0 * d0) / wd * np.sin(wd * t)
    )
    return particular(t) + homogeneous


def test_mode_transient_from_rest_matches_closed_form_on_dense_output():
    # Below both thresholds for the whole transient: the base never moves, and the
    # samples (taken between steps, on the dense output) follow the closed form.
    f, a = 12.0, 1.0
    schedule = Schedule.constant(f, a, 20 / f)
    times = np.linspace(0, 20 / f, 997)
    run = simulate(PAPER, schedule, output_times=times,
                   settings=IntegratorSettings(tolerance=1e-12))
    assert run.outcome == "completed"
    assert run.event_time.size == 0
    assert np.all(run.x == 0.0) and np.all(run.v == 0.0) and np.all(run.mode == 0)
    exact = _free_mode(PAPER, (0.0, 0.0), f, a, times)
    scale = np.max(np.abs(exact))
    assert_allclose(run.delta, exact, rtol=0, atol=1e-9 * scale)


def test_dense_output_is_fourth_order_between_steps():
    # Fixed steps: halving the step divides the dense-output error by ~2^5 (local order 5).
    f, a = 12.0, 1.0
    times = np.linspace(0, 3 / f, 301)
    exact = _free_mode(PAPER, (0.0, 0.0), f, a, times)
    errors = []
    for steps in (16, 32, 64):
        run = simulate(PAPER, Schedule.constant(f, a, 3 / f), output_times=times,
                       settings=IntegratorSettings(steps_per_period=steps, max_step=1.0))
        errors.append(np.max(np.abs(run.delta - exact)))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 3.7), (errors, orders)


def test_sliding_to_rest_without_drive_matches_closed_form():
    # No drive, mode at rest, a push v0: Coulomb deceleration ck g, stop at v0/(ck g).
    structure = PAPER.replace(ck=0.2)
    v0 = 0.05
    stop = v0 / (structure.ck * structure.g)
    run = simulate(structure, Schedule.constant(10.0, 0.0, 2 * stop),
                   initial_state=(0.0, 0.0, 0.0, v0), output_times=[0.5 * stop, 2 * stop])
    ends = run.event_time[run.event_kind == kernel.EVENT_SLIP_END]
    assert ends.size == 1
    assert_allclose(ends[0], stop, rtol=1e-11)
    assert_allclose(run.x[-1], v0**2 / (2 * structure.ck * structure.g), rtol=1e-10)
    assert_allclose(run.v[0], v0 / 2, rtol=1e-10)
    assert run.mode[-1] == 0 and run.v[-1] == 0.0


def test_two_way_slide_conserves_momentum_up_to_friction_impulse():
    # Two-way: while sliding, d/dt (v + M sin(alpha) delta') = -s ck n exactly (the
    # plate's horizontal momentum is internal). n is integrated from the samples.
    structure = PAPER.replace(M=0.5, ck=0.2)
    v0 = 0.05
    times = np.linspace(0, 0.6 * v0 / (structure.ck * structure.g), 4001)
    run = simulate(structure, Schedule.constant(10.0, 0.0, times[-1]), coupling="two-way",
                   initial_state=(0.0, 0.0, 0.0, v0), output_times=times,
                   settings=IntegratorSettings(tolerance=1e-13))
    assert np.all(run.mode == 1)
    sa, ca = math.sin(structure.alpha_rad), math.cos(structure.alpha_rad)
    momentum = run.v + structure.M * sa * run.delta_rate
    w0 = structure.omega0
    forcing = -(w0 / structure.Q) * run.delta_rate - w0**2 * run.delta
    denominator = 1 - structure.M * sa * (sa + structure.ck * ca)
    ddd = (forcing + structure.ck * sa * structure.g) / denominator
    n = structure.g + structure.M * ca * ddd
    impulse = np.concatenate(([0.0], np.cumsum(0.5 * (n[1:] + n[:-1]) * np.diff(times))))
    assert_allclose(momentum - momentum[0], -structure.ck * impulse, rtol=0, atol=1e-8 * v0)
    # ... and the slide is not the one-way one: the mode was set ringing.
    assert np.max(np.abs(run.delta)) > 1e-6


PAPER_POINTS = [(13.0, 5.0), (13.0, 8.5), (16.5, 8.5), (14.6, 7.0), (14.5, 6.0), (14.5, 9.0)]


@pytest.mark.parametrize(("f", "a"), PAPER_POINTS)
def test_one_way_mean_velocity_matches_exact_solver(f, a):
    exact = steady_state(PAPER, f, a)
    run = integrated_steady_state(PAPER, f, a, settings=IntegratorSettings(tolerance=1e-11))
    assert run.status == exact.status
    assert_allclose(run.velocity, exact.velocity, rtol=1e-8, atol=1e-13)
    assert_allclose(run.slips_per_period, exact.slips_per_period, rtol=0, atol=1e-12)
    assert_allclose(run.forward_fraction, exact.forward_fraction, rtol=0, atol=1e-8)
    assert_allclose(run.backward_fraction, exact.backward_fraction, rtol=0, atol=1e-8)


def test_random_points_agree_with_exact_solver_across_regimes():
    rng = np.random.default_rng(5)
    structures = [PAPER, PAPER.replace(ck=0.15), PAPER.replace(M=0.9), PAPER.replace(Q=4.0)]
    for structure in structures:
        f = rng.uniform(11.0, 18.0, 12)
        a = rng.uniform(3.0, 11.0, 12)
        exact = steady_state(structure, f, a)
        run = integrated_steady_state(structure, f, a,
                                      settings=IntegratorSettings(tolerance=1e-11))
        assert np.array_equal(run.status, exact.status), (structure, f, a)
        moving = np.isfinite(exact.velocity)
        assert_allclose(run.velocity[moving], exact.velocity[moving], rtol=1e-7, atol=1e-12)


def test_continuous_sliding_is_classified_and_matches():
    structure = PAPER.replace(M=1.0)
    f, a = np.array([15.0, 15.5, 16.0, 17.0]), np.array([6.0, 6.0, 6.5, 7.0])
    exact = steady_state(structure, f, a)
    assert np.all(exact.status == Status.CONTINUOUS_SLIDING)
    run = integrated_steady_state(structure, f, a, settings=IntegratorSettings(tolerance=1e-11))
    assert np.all(run.status == Status.CONTINUOUS_SLIDING)
    assert_allclose(run.velocity, exact.velocity, rtol=1e-7, atol=1e-12)


def test_fixed_step_converges_at_fifth_order():
    f, a = 14.6, 7.0  # PN: forward and backward slips cancel in part
    exact = float(steady_state(PAPER, f, a).velocity)
    errors = []
    for steps in (16, 32, 64):
        run = integrated_steady_state(PAPER, f, a,
                                      settings=IntegratorSettings(steps_per_period=steps))
        errors.append(abs(float(run.velocity) - exact))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 4.0) & (orders < 6.5)), (errors, orders)


def test_tolerance_controls_the_error():
    f, a = 14.6, 7.0
    exact = float(steady_state(PAPER, f, a).velocity)
    for tolerance in (1e-6, 1e-8, 1e-10):
        run = integrated_steady_state(PAPER, f, a,
                                      settings=IntegratorSettings(tolerance=tolerance))
        # Error per unit of the drive's velocity scale g/w stays within ~10x tolerance.
        scale = PAPER.g / (2 * math.pi * f)
        assert abs(float(run.velocity) - exact) < 10 * tolerance * scale


def test_short_slip_between_samples_is_not_missed():
    # Just above a*_+: the release window is ~1e-3 of a period, far inside one sample
    # interval (1/32 period). The release function is watched at its minimum.
    f = 13.0
    a_plus, _ = thresholds(PAPER, f)
    a = float(a_plus) * (1 + 1e-6)
    settings = IntegratorSettings(tolerance=1e-10, samples_per_step=2)
    run = integrated_steady_state(PAPER, f, a, settings=settings)
    exact = steady_state(PAPER, f, a)
    assert exact.status == Status.STICK_SLIP
    assert run.status == Status.STICK_SLIP
    assert run.slips_per_period == 1.0
    # v ~ 2e-14 m s-1 here: the error is judged against the drive's velocity scale g/w.
    assert run.velocity > 0
    assert_allclose(run.velocity, exact.velocity, rtol=0, atol=1e-13 * PAPER.g / (2 * np.pi * f))


def test_lift_off_is_flagged_not_computed():
    f = 14.44
    a_lift = float(lift_off_acceleration(PAPER, f))
    run = integrated_steady_state(PAPER, f, [a_lift * (1 - 1e-6), a_lift * (1 + 1e-6)])
    assert run.status[1] == Status.LIFT_OFF and np.isnan(run.velocity[1])
    assert run.status[0] != Status.LIFT_OFF and np.isfinite(run.velocity[0])
    trajectory = simulate(PAPER, Schedule.constant(f, 1.2 * a_lift, 2 / f))
    assert trajectory.outcome == "lift_off"
    assert trajectory.event_kind[-1] == codes.EVENT_LIFT_OFF
    assert trajectory.end_time < 2 / f


def test_friction_paradox_is_a_status_for_two_way_only():
    # M = 1 at steep tilt: D_+ = 1 - M sin(a)(sin(a) + ck cos(a)) < 0 for forward slips.
    structure = Structure(f0=14.44, Q=17.5, alpha=83.0, M=1.0, cs=0.25)
    sa, ca = math.sin(structure.alpha_rad), math.cos(structure.alpha_rad)
    assert 1 - sa * (sa + 0.25 * ca) < 0
    f = np.array([11.0, 12.0, 13.0])
    a = np.full(3, 7.0)
    plus, minus = release_amplitudes(structure, f, a)
    # Only forward slips are possible at these points (and no lift-off from the drive).
    assert np.all(np.abs(plus) > structure.cs * structure.g)
    assert np.all(np.abs(minus) < structure.cs * structure.g)
    assert np.all(a < lift_off_acceleration(structure, f))
    two_way = integrated_steady_state(structure, f, a, coupling="two-way")
    assert np.all(two_way.status == Status.FRICTION_PARADOX)
    assert np.all(np.isnan(two_way.velocity))
    one_way = integrated_steady_state(structure, f, a)
    assert not np.any(one_way.status == Status.FRICTION_PARADOX)


def test_schedule_phase_is_continuous_and_restart_agrees():
    # Two segments of the same drive are the same run as one long segment.
    f, a = 14.0, 8.0
    times = np.linspace(0, 6 / f, 200)
    one = simulate(PAPER, Schedule.constant(f, a, 6 / f), output_times=times,
                   settings=IntegratorSettings(tolerance=1e-12))
    two = simulate(PAPER, Schedule([f, f], [a, a], [2.3 / f, 3.7 / f]), output_times=times,
                   settings=IntegratorSettings(tolerance=1e-12))
    assert_allclose(two.x, one.x, rtol=0, atol=1e-11)
    assert_allclose(two.v, one.v, rtol=0, atol=1e-10)
    # A frequency switch: running the second segment from the first one's end state
    # with the continued phase gives the same trajectory.
    schedule = Schedule([14.0, 15.2], [8.0, 8.0], [0.3, 0.3])
    whole = simulate(PAPER, schedule, output_times=[0.3, 0.6],
                     settings=IntegratorSettings(tolerance=1e-12))
    first = simulate(PAPER, Schedule([14.0], [8.0], [0.3]), output_times=[0.3],
                     settings=IntegratorSettings(tolerance=1e-12))
    state = (first.delta[0], first.delta_rate[0], first.x[0], first.v[0])
    second = simulate(PAPER, Schedule([15.2], [8.0], [0.3], phase=schedule.start_phases[1]),
                      initial_state=state, output_times=[0.3],
                      settings=IntegratorSettings(tolerance=1e-12))
    assert_allclose(second.x[0], whole.x[1], rtol=1e-9, atol=1e-12)
    assert_allclose(schedule.start_phases[1], 360.0 * 14.0 * 0.3, rtol=1e-15)
    assert_allclose(schedule.start_phases_rad[1], 2 * math.pi * 14.0 * 0.3, rtol=1e-15)


def test_canonical_start_is_the_steady_mode_response():
    state = steady_mode_state(PAPER, 14.0, 8.0)
    times = np.linspace(0, 1 / 14.0, 50)
    run = simulate(PAPER, Schedule.constant(14.0, 2.0, 1 / 14.0),
                   initial_state=steady_mode_state(PAPER, 14.0, 2.0), output_times=times)
    amp = 2.0 * math.cos(PAPER.alpha_rad) * complex(mode_response(PAPER, 14.0))
    assert_allclose(run.delta, (amp * np.exp(2j * math.pi * 14.0 * times)).real,
                    rtol=0, atol=1e-9 * abs(amp))
    assert state.shape == (4,) and state[2] == state[3] == 0.0


def test_budget_exhaustion_is_not_converged():
    run = integrated_steady_state(PAPER, 14.6, 7.0,
                                  settings=IntegratorSettings(max_periods=1))
    assert run.status == Status.NOT_CONVERGED
    assert run.reason == NonConvergence.NO_PERIODIC_ORBIT
    assert np.isnan(run.velocity)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"tolerance": -1e-9}, "'tolerance'"),
        ({"tolerance": 2.0}, "'tolerance'"),
        ({"steps_per_period": 0}, "'steps_per_period'"),
        ({"samples_per_step": 1.5}, "'samples_per_step'"),
        ({"max_periods": True}, "'max_periods'"),
        ({"period_tolerance": 0.0}, "'period_tolerance'"),
    ],
)
def test_settings_refuse_bad_values(kwargs, message):
    with pytest.raises(ValueError, match=message):
        IntegratorSettings(**kwargs)


def test_schedule_and_simulate_refuse_bad_input():
    with pytest.raises(ValueError, match="duration"):
        Schedule([14.0], [8.0], [-1.0])
    with pytest.raises(ValueError, match="one length"):
        Schedule([14.0, 15.0], [8.0], [1.0, 1.0])
    with pytest.raises(ValueError, match="coupling"):
        simulate(PAPER, Schedule.constant(14, 8, 0.1), coupling="both")
    with pytest.raises(ValueError, match="initial_state"):
        simulate(PAPER, Schedule.constant(14, 8, 0.1), initial_state=(0, 0, 0))
    with pytest.raises(ValueError, match="output_times"):
        simulate(PAPER, Schedule.constant(14, 8, 0.1), output_times=[0.2])
    with pytest.raises(TypeError, match="Schedule"):
        simulate(PAPER, (14, 8, 0.1))


def test_kernel_status_codes_mirror_the_enum():
    assert kernel.STATIC == Status.STATIC
    assert kernel.STICK_SLIP == Status.STICK_SLIP
    assert kernel.CONTINUOUS_SLIDING == Status.CONTINUOUS_SLIDING
    assert kernel.LIFT_OFF == Status.LIFT_OFF
    assert kernel.FRICTION_PARADOX == Status.FRICTION_PARADOX
    assert kernel.REASON_NO_PERIODIC_ORBIT == NonConvergence.NO_PERIODIC_ORBIT
