"""Basins: every attractor at a drive point, with the share of starts that reach it.

Checked against something independent: the event-driven integrator followed from each
of the same starts (start by start, the attractor it settles on), the brute-force basin
fraction of 200 more starts by the integrator against the 24 starts' (slow tier), the
ordinary steady state for the solver's own start, and the Wilson interval's published
values.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import study
from study.model import mode_response
from study.solvers.basins import BasinStarts, basin_starts, basins, wilson_interval
from study.solvers.integrator import IntegratorSettings, Schedule, simulate
from study.solvers.settings import SolverSettings
from study.solvers.structure_constants import past_lift_off

#: The M -> 1 structure of the flight workflows: two hops coexist at 13 Hz, 12 m s-2
#: (+0.0800 m/s after the release, -0.1640 m/s after a switch-on).
M_TO_1 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
PAPER = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
F, A = 13.0, 12.0
#: Periods the integrator follows a start, and the last ones it averages over.
HELD = 300
AVERAGED = 50


def _integrated_velocity(structure, f, a, phase, factor, height, settings=None):
    """Mean velocity [m s-1] over the last :data:`AVERAGED` of :data:`HELD` periods of
    the integrator from the start (the base at rest ``height`` above the table at drive
    phase ``phase``, the mode at rest on ``factor`` times its steady stick response),
    with the integrator's ``settings`` (default: its defaults)."""
    omega = 2.0 * np.pi * f
    response = a * math.cos(structure.alpha_rad) * mode_response(structure, f)
    turn = np.exp(2j * np.pi * phase)
    state = [factor * (response * turn).real, factor * (1j * omega * response * turn).real,
             0.0, 0.0, height, 0.0]
    duration = HELD / f
    run = simulate(structure, Schedule.constant(f, a, duration, 360.0 * phase),
                   coupling="two-way", flight=True, initial_state=state,
                   output_times=[duration - AVERAGED / f, duration], max_events=0,
                   settings=settings)
    assert run.outcome == "completed"
    return (run.x[-1] - run.x[0]) * f / AVERAGED


def test_each_start_reaches_the_motion_the_integrator_reaches_from_it():
    """Start by start: the attractor basins reports for a start is the one the
    integrator, followed from the same state, settles on (to 1e-5 of a / (2 pi f))."""
    starts = basin_starts(36, seed=7, flight=True)
    found = basins(M_TO_1, F, A, starts=starts, flight=True)
    assert found.count == 2
    assert np.all(found.status[:2] == study.Status.BOUNCING)
    assert_allclose(np.sort(found.velocity[:2]), [-0.16405, 0.07997], rtol=0, atol=5e-5)
    reached = found.velocity[found.reached]
    assert set(found.reached.tolist()) == {0, 1}  # both basins are sampled
    integrated = np.array([
        _integrated_velocity(M_TO_1, F, A, starts.phase[k], starts.factor[k],
                             starts.height[k]) for k in range(len(starts))])
    scale = A / (2.0 * np.pi * F)
    assert_allclose(integrated / scale, reached / scale, rtol=0, atol=1e-5)
    assert found.starts_drawn == 36
    assert_allclose(found.fraction.sum(), 1.0, rtol=0, atol=1e-15)


#: Starts the integrator follows for the brute-force fractions, and the normal quantile
#: of the two-proportion check (two-sided 99.9 %: a seeded draw fails it by chance
#: once in a thousand).
BRUTE_STARTS = 200
BRUTE_Z = 3.29
#: The integrator's tolerance for those starts: its velocities are checked to 1e-5 of
#: a / (2 pi f); at 1e-8 they differ from the default 1e-10's by at most 9e-9 of it,
#: every one of the 200 starts on the same attractor (measured at both points), in 2.5
#: times fewer steps (86-103 s -> 38 s a point).
BRUTE_SETTINGS = IntegratorSettings(tolerance=1e-8)


@pytest.mark.slow
@pytest.mark.parametrize("f,a", [(13.0, 12.0), (14.5, 10.0)])
def test_basin_fractions_agree_with_brute_force_sampling(f, a):
    """The fraction of 24 starts against :data:`BRUTE_STARTS` more from the same
    distribution, each followed by the integrator: every start settles on one of the
    two attractors found, and the two estimates of each fraction agree within
    :data:`BRUTE_Z` standard errors of their difference."""
    found = basins(M_TO_1, f, a, flight=True)
    assert found.count == 2
    many = basin_starts(BRUTE_STARTS + 1, seed=2026, flight=True)
    velocities = np.array([
        _integrated_velocity(M_TO_1, f, a, many.phase[k], many.factor[k], many.height[k],
                             BRUTE_SETTINGS)
        for k in range(1, len(many))])
    nearest = np.argmin(np.abs(velocities[:, None] - found.velocity[None, :2]), axis=1)
    scale = a / (2.0 * np.pi * f)
    assert_allclose(velocities / scale, found.velocity[nearest] / scale, rtol=0, atol=1e-5)
    for attractor in range(2):
        brute = np.mean(nearest == attractor)
        sampled = found.fraction[attractor]
        pooled = (24 * sampled + BRUTE_STARTS * brute) / (24 + BRUTE_STARTS)
        spread = math.sqrt(pooled * (1.0 - pooled) * (1.0 / 24 + 1.0 / BRUTE_STARTS))
        assert abs(sampled - brute) <= BRUTE_Z * spread, (attractor, sampled, brute)
        assert 0.05 < brute < 0.95  # both basins are large: the check has power


@pytest.mark.parametrize("start", ["release", "switch-on"])
def test_the_solver_start_reaches_the_steady_state_it_reports(start):
    f = np.array([13.0, 14.5, 20.0, 9.0])
    a = np.array([12.0, 10.0, 3.0, 11.0])
    settings = SolverSettings(start=start)
    found = basins(M_TO_1, f, a, starts=6, flight=True, settings=settings)
    steady = study.steady_state(M_TO_1, f, a, coupling="two-way", flight=True,
                                settings=settings)
    chosen = found.default_attractor
    rows = np.arange(f.size)
    assert_array_equal(found.velocity[rows, chosen], steady.velocity)
    assert_array_equal(found.status[rows, chosen], steady.status)


def test_a_monostable_map_holds_one_attractor_with_fraction_one():
    """The paper's structure without flight, below lift-off: one motion at every point,
    whatever the start, its fraction 1 and its interval reaching 1."""
    f, a = np.meshgrid([10.0, 15.0, 20.0, 25.0], [2.0, 5.0, 8.0], indexing="ij")
    found = basins(PAPER, f, a, starts=12)
    assert found.status.shape == (4, 3, 1)
    assert_array_equal(found.count, 1)
    assert_array_equal(found.fraction[..., 0], 1.0)
    assert_array_equal(found.fraction_high[..., 0], 1.0)
    assert np.all(found.fraction_low[..., 0] > 0.7)
    steady = study.steady_state(PAPER, f, a, coupling="two-way")
    assert_array_equal(found.velocity[..., 0], steady.velocity)


def test_the_wilson_interval_has_its_published_values():
    """Wilson (1927) score interval at 95 %: 0 of 10 gives (0, 0.2775), 5 of 10
    (0.2366, 0.7634), 24 of 24 (0.8620, 1) (Newcombe 1998, Table I method 3)."""
    low, high = wilson_interval([0, 5, 24], [10, 10, 24])
    assert_allclose(low, [0.0, 0.2366, 0.8620], rtol=0, atol=1e-4)
    assert_allclose(high, [0.2775, 0.7634, 1.0], rtol=0, atol=1e-4)


def test_the_starts_are_seeded_and_drops_only_with_flight():
    one = basin_starts(30, seed=3, flight=True)
    assert_array_equal(one.phase, basin_starts(30, seed=3, flight=True).phase)
    assert not np.array_equal(one.phase, basin_starts(30, seed=4, flight=True).phase)
    assert (one.phase[0], one.factor[0], one.height[0]) == (0.0, 1.0, 0.0)
    assert np.sum(one.height > 0.0) == 9
    assert np.all(basin_starts(30, seed=3).height == 0.0)
    assert np.all((one.phase >= 0.0) & (one.phase < 1.0))


@pytest.mark.parametrize("kwargs,text", [
    ({"starts": 0}, "'starts' must be an integer >= 1"),
    ({"starts": 2.5}, "'starts' must be an integer >= 1"),
    ({"seed": -1}, "'seed' must be an integer >= 0"),
    ({"settings": SolverSettings(continuation=True)}, "'continuation' must be False"),
    ({"starts": BasinStarts(np.array([0.0]), np.array([1.0]), np.array([1e-3]))},
     "needs flight=True"),
    ({"starts": BasinStarts(np.array([1.0]), np.array([1.0]), np.array([0.0]))},
     "phase must be in [0, 1)"),
])
def test_bad_arguments_are_refused_naming_the_key(kwargs, text):
    with pytest.raises(ValueError, match=re.escape(text)):
        basins(PAPER, 15.0, 5.0, **kwargs)


@pytest.mark.slow  # about 35 s: the flight and no-flight maps past lift-off
def test_past_lift_off_without_flight_the_solver_start_is_still_followed():
    """Past the stick's lift-off threshold the release is no state the model can hold on
    the table, yet the solver follows it (lift-off, or an orbit that stays on the
    table); start 0 is followed the same way, so default_attractor names that answer
    at every point, while the other starts off the table are not drawn."""
    f, a = (x.ravel() for x in np.meshgrid(np.linspace(12.0, 18.0, 13), [9.5, 10.5, 11.5],
                                          indexing="ij"))
    lifted = past_lift_off(PAPER, f, a)
    assert lifted.sum() >= 20
    found = basins(PAPER, f, a, starts=8)
    steady = study.steady_state(PAPER, f, a, coupling="two-way")
    rows = np.arange(f.size)
    assert np.all(found.default_attractor == 0)
    assert_array_equal(found.velocity[rows, 0], steady.velocity)
    assert_array_equal(found.status[rows, 0], steady.status)
    assert np.any(steady.status[lifted] == study.Status.STICK_SLIP)
    assert np.any(found.starts_drawn[lifted] < 8)


def test_the_wilson_interval_always_holds_the_estimate():
    """At every count of up to 200 trials, low <= k / n <= high, at 0 and 1 too (a
    rounding had once put the upper end a few ulps below 1 at k = n)."""
    n = np.concatenate([np.full(k + 1, k) for k in range(1, 201)])
    k = np.concatenate([np.arange(m + 1) for m in range(1, 201)])
    low, high = wilson_interval(k, n)
    assert np.all(low <= k / n)
    assert np.all(k / n <= high)
    assert np.all((low >= 0.0) & (high <= 1.0))
