"""Hard cases for the time integrator: each asserts accuracy or the right status, never a
hang or a silent wrong number. The exact solver (itself checked against 40-digit and
independent references in test_exact_solver_hard_cases.py) is the reference here."""

from __future__ import annotations

import contextlib
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from study import Structure
from study.analyses.frontier import frontier
from study.model import lift_off_acceleration, release_amplitudes, thresholds
from study.model.inputs import SuspectInputWarning, tilt_looks_like_radians
from study.model.status import Status
from study.solvers.exact import steady_state
from study.solvers.integrator import (
    IntegratorSettings,
    Schedule,
    integrated_steady_state,
    simulate,
    steady_mode_state,
)
from tests.support.tiers import headline

PAPER = Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
SETTINGS = IntegratorSettings(tolerance=1e-11)


def _compare(structure, f, a, *, rtol=1e-7, scale_atol=1e-10, statuses=None):
    """Integrator against the exact solver at one point; returns both results."""
    exact = steady_state(structure, f, a)
    run = integrated_steady_state(structure, f, a, settings=SETTINGS)
    allowed = {int(exact.status)} if statuses is None else set(statuses)
    assert int(run.status) in allowed, (structure, f, a, int(run.status), int(exact.status))
    if np.isfinite(exact.velocity) and np.isfinite(run.velocity):
        # Absolute part in units of the drive's velocity scale g / w.
        atol = scale_atol * structure.g / (2 * math.pi * f)
        assert_allclose(run.velocity, exact.velocity, rtol=rtol, atol=atol)
    else:
        assert np.isnan(run.velocity) == np.isnan(exact.velocity)
    return exact, run


def _inside_window(structure, f, share=0.5):
    """An acceleration between the lower threshold and lift-off (or None)."""
    a_plus, a_minus = thresholds(structure, f)
    low = float(min(a_plus, a_minus))
    high = float(lift_off_acceleration(structure, f))
    return low + share * (high - low) if high > low else None


@pytest.mark.parametrize("side", [-1, 1])
@pytest.mark.parametrize(("f", "which"), [(13.0, 0), (16.5, 1)])
def test_grazing_the_threshold(f, which, side):
    a_star = float(thresholds(PAPER, f)[which]) * (1 + side * 1e-12)
    _, run = _compare(PAPER, f, a_star, scale_atol=1e-12,
                          statuses={Status.STATIC, Status.STICK_SLIP})
    if side < 0:
        assert run.status == Status.STATIC and run.velocity == 0.0


def test_starting_exactly_on_the_switching_surface_with_ck_below_cs():
    # Start at the phase where s tau - cs n reaches zero on the steady response: the run
    # must slip from there, as a run started a little earlier (stuck until that phase).
    structure = PAPER.replace(ck=0.1)
    f, a = 13.0, 8.5
    w = 2 * math.pi * f
    amplitude = release_amplitudes(structure, f, a)[0]
    level = structure.cs * structure.g
    entry = -math.acos(level / abs(amplitude)) - math.atan2(amplitude.imag, amplitude.real)
    late, early = entry, entry - 1e-3
    runs = []
    for phase in (late, early):
        start = steady_mode_state(structure, f, a)
        # The steady response at phase `phase` instead of 0.
        amp = complex(start[0], -start[1] / w)  # delta = Re[amp e^{i w t}]
        shifted = amp * np.exp(1j * phase)
        state = (shifted.real, (1j * w * shifted).real, 0.0, 0.0)
        duration = 3 / f
        times = np.array([duration - (phase - late) / w]) if phase != late else np.array(
            [duration])
        runs.append(simulate(structure, Schedule.constant(f, a, duration + 1e-3 / w,
                                                          math.degrees(phase)),
                             initial_state=state, output_times=times,
                             settings=IntegratorSettings(tolerance=1e-12)))
    late_run, early_run = runs
    assert late_run.event_kind[0] == 1 and late_run.event_time[0] < 1e-9 / f
    assert_allclose(early_run.event_time[0], 1e-3 / w, rtol=1e-6)
    # Same physical motion, shifted in time by the 1e-3 rad of stick.
    assert_allclose(late_run.x[0], early_run.x[0], rtol=1e-8)


@pytest.mark.parametrize("f", [10.0, 14.44, 20.0])
def test_near_lift_off(f):
    a_lift = float(lift_off_acceleration(PAPER, f))
    below = integrated_steady_state(PAPER, f, a_lift * (1 - 1e-6), settings=SETTINGS)
    above = integrated_steady_state(PAPER, f, a_lift * (1 + 1e-6), settings=SETTINGS)
    assert below.status != Status.LIFT_OFF
    assert above.status == Status.LIFT_OFF and np.isnan(above.velocity)
    _compare(PAPER, f, a_lift * (1 - 1e-6))


@pytest.mark.parametrize("Q", [0.5, 3.0, 100.0, 1e4])
def test_quality_factor_range(Q):
    structure = PAPER.replace(Q=Q)
    tried = 0
    for f in (12.0, 14.0, 14.44, 16.0):
        a = _inside_window(structure, f)
        if a is None:
            continue
        tried += 1
        _compare(structure, f, a)
    assert tried >= 1


@pytest.mark.parametrize("ratio", [0.01, 0.1, 10.0, 100.0])
def test_drive_frequency_range(ratio):
    f = ratio * PAPER.f0
    a = _inside_window(PAPER, f)
    if a is None:  # no motion window: only static below and lift-off above
        a_lift = float(lift_off_acceleration(PAPER, f))
        _compare(PAPER, f, 0.99 * a_lift)
        _compare(PAPER, f, 1.01 * a_lift)
    else:
        _compare(PAPER, f, a)


@pytest.mark.parametrize("ck_over_cs", [1e-2, 1e-3])
def test_kinetic_friction_far_below_static(ck_over_cs):
    structure = PAPER.replace(ck=PAPER.cs * ck_over_cs)
    for f, a in ((13.0, 8.5), (16.5, 8.5), (14.6, 7.0)):
        _compare(structure, f, a)


@pytest.mark.parametrize("M", [0.9, 0.97, 1.0])
def test_continuous_sliding_near_full_resonant_mass(M):
    structure = PAPER.replace(M=M)
    f = np.linspace(14.8, 18.0, 9)
    a = np.full(f.shape, 6.0)
    exact = steady_state(structure, f, a)
    assert np.any(exact.status == Status.CONTINUOUS_SLIDING)
    for fi, ai in zip(f, a, strict=True):
        _compare(structure, fi, ai)


def test_slowly_attracting_sliding_cycle():
    # A sliding cycle with a circle-map multiplier close to 1 (found by the exact suite):
    # the integrator must reach it within its period budget or say NOT_CONVERGED.
    structure = PAPER.replace(M=1.0, ck=0.2)
    f, a = 15.0, 4.0
    exact = steady_state(structure, f, a)
    run = integrated_steady_state(structure, f, a, settings=SETTINGS)
    if run.status == Status.NOT_CONVERGED:
        assert np.isnan(run.velocity)
    else:
        assert run.status == exact.status
        assert_allclose(run.velocity, exact.velocity, rtol=1e-7,
                        atol=1e-10 * structure.g / (2 * math.pi * f))


def test_near_zero_velocity_on_the_frontier():
    found = frontier(PAPER, [6.5, 8.0], (14.0, 15.5), num=31, tolerance=1e-12)
    frequency = found["frontier_frequency"].values
    assert np.isfinite(frequency).sum() >= 1
    for a, f_star in zip([6.5, 8.0], frequency[:, 0], strict=True):
        if not np.isfinite(f_star):
            continue
        exact = steady_state(PAPER, f_star, a)
        run = integrated_steady_state(PAPER, f_star, a, settings=SETTINGS)
        # The velocity is ~0 there: the error is absolute.
        assert abs(float(run.velocity) - float(exact.velocity)) < 1e-12
        assert abs(float(run.velocity)) < 1e-10


def _warns_of_radians(alpha: float):
    if tilt_looks_like_radians(alpha):
        return pytest.warns(SuspectInputWarning, match="looks like an angle in radians")
    return contextlib.nullcontext()


@pytest.mark.parametrize("alpha", [1e-3, 1.0, 89.0, 89.99])
def test_tilt_near_flat_and_near_vertical(alpha):
    # 1 degree looks like radians: the structure warns (and is built in degree).
    with _warns_of_radians(alpha):
        structure = PAPER.replace(alpha=alpha)
    for f in (12.0, 14.44, 16.0):
        a = _inside_window(structure, f)
        if a is not None:
            _compare(structure, f, a)
    with _warns_of_radians(alpha):
        mirrored = PAPER.replace(alpha=-alpha)
    a = _inside_window(structure, 14.44)
    if a is not None:
        plus = integrated_steady_state(structure, 14.44, a, settings=SETTINGS)
        minus = integrated_steady_state(mirrored, 14.44, a, settings=SETTINGS)
        assert_allclose(minus.velocity, -plus.velocity, rtol=1e-8, atol=1e-16)


@pytest.mark.parametrize("M", [1e-4, 1e-2, 1.0])
def test_mass_ratio_near_zero_and_one(M):
    structure = PAPER.replace(M=M)
    for f in (13.0, 14.44, 16.0):
        for share in (0.3, 0.9):
            a = _inside_window(structure, f, share)
            if a is not None:
                _compare(structure, f, a)


@pytest.mark.parametrize("M", headline([0.08, 0.5, 1.0]))
def test_two_way_runs_end_with_a_status_not_a_hang(M):
    # Two-way over a coarse map: every point ends with a status; velocities only where valid.
    structure = PAPER.replace(M=M)
    f = np.linspace(10, 20, 11)[:, None]
    a = np.linspace(1, 12, 7)[None, :]
    run = integrated_steady_state(structure, f, a, coupling="two-way",
                                  settings=IntegratorSettings(tolerance=1e-9))
    valid = np.isin(run.status, [Status.STATIC, Status.STICK_SLIP, Status.CONTINUOUS_SLIDING])
    assert np.all(np.isfinite(run.velocity[valid]))
    assert np.all(np.isnan(run.velocity[~valid]))
    assert np.all(run.status[~valid] != Status.NOT_CONVERGED) or M == 1.0
