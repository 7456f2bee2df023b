"""The zero-velocity frontier f*(a) runs on through the bouncing region: bouncing points
have a velocity, so a sign change between two of them is a frontier point."""

from __future__ import annotations

import numpy as np

import study
from study.model.status import Status
from study.solvers.exact import steady_velocity
from study.solvers.frontier import frontier_from_grid
from study.solvers.steady import SteadyState

NEAR_ONE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)


def _bouncing(root: float):
    """A made-up solver: every point bounces, with velocity ``f - root`` [m s-1]."""

    def solve(structure, f, a):
        f, a = np.broadcast_arrays(np.asarray(f, float), np.asarray(a, float))
        nan = np.full(f.shape, np.nan)
        return SteadyState(velocity=f - root, status=np.full(f.shape, int(Status.BOUNCING),
                                                             dtype=np.int8),
                           slips_per_period=nan, forward_fraction=nan,
                           backward_fraction=nan, orbit_period=np.ones(f.shape, np.int32),
                           reason=np.zeros(f.shape, np.int8))

    return solve


def test_a_sign_change_between_bouncing_points_is_refined_to_its_root():
    f = np.linspace(14.0, 16.0, 5)
    a = np.array([9.0, 11.0])
    solve = _bouncing(15.123456)
    grid = solve(NEAR_ONE, f[:, None], a[None, :])
    found = frontier_from_grid(NEAR_ONE, f, a, grid.velocity, grid.status, tolerance=1e-9,
                               solve=solve)
    np.testing.assert_allclose(found.frequency[:, 0], 15.123456, rtol=0, atol=1e-9)
    assert np.all(found.direction[:, 0] == 1)


PAPER = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)


def test_the_paper_frontier_runs_on_through_the_bouncing_region_as_a_crossing():
    """Above lift-off (a = 10-12 m s-2 near 14.5 Hz) the paper's structure bounces; the
    velocity still passes continuously through zero there: the frontier is found as a
    crossing, with bouncing points of opposite sign and small speed on either side
    (checked by the solver at the two sides), where without flight there is none."""
    a = np.array([10.0, 11.0, 12.0])
    found = study.frontier(PAPER, a, (13.5, 16.0), num=26, tolerance=1e-9,
                           coupling="two-way", flight=True)
    assert found.attrs["study_lift_off"] == "flight"
    f_star = found["frontier_frequency"].values[:, 0]
    assert np.all(np.isfinite(f_star)) and np.all(found["frontier_kind"].values[:, 0] == 1)
    np.testing.assert_allclose(f_star, 14.54, atol=0.02)
    _, status = steady_velocity(PAPER, f_star, a, coupling="two-way")
    assert np.all(status == Status.LIFT_OFF)
    without = study.frontier(PAPER, a, (13.5, 16.0), num=26, coupling="two-way")
    assert not np.isfinite(without["frontier_frequency"].values).any()
    below, s_below = steady_velocity(PAPER, f_star - 1e-3, a, coupling="two-way",
                                     flight=True)
    above, s_above = steady_velocity(PAPER, f_star + 1e-3, a, coupling="two-way",
                                     flight=True)
    assert np.all(s_below == Status.BOUNCING) and np.all(s_above == Status.BOUNCING)
    assert np.all(np.sign(below) * np.sign(above) < 0)
    assert np.all(np.abs(below) < 1e-3) and np.all(np.abs(above) < 1e-3)
    assert np.all(np.sign(above) == found["frontier_direction"].values[:, 0])


def test_near_one_the_frontier_marks_jumps_between_bouncing_motions():
    """At M = 0.99, a = 10 m s-2 the motion reached from rest switches between a small
    forward hop and a big backward one as f changes: frontier points of kind jump,
    each bracket's ends bouncing with opposite velocities (solved again at the ends)."""
    a = np.array([10.0])
    found = study.frontier(NEAR_ONE, a, (13.0, 16.0), num=16, tolerance=1e-6,
                           coupling="two-way", flight=True)
    frequency = found["frontier_frequency"].values[0]
    kept = np.isfinite(frequency)
    assert kept.any()
    assert np.all(found["frontier_kind"].values[0][kept] == 2)
    f_star, width = frequency[kept], found["frontier_bracket"].values[0][kept]
    lo, s_lo = steady_velocity(NEAR_ONE, f_star - width / 2, 10.0, coupling="two-way",
                               flight=True)
    hi, s_hi = steady_velocity(NEAR_ONE, f_star + width / 2, 10.0, coupling="two-way",
                               flight=True)
    assert np.all(s_lo == Status.BOUNCING) and np.all(s_hi == Status.BOUNCING)
    assert np.all(np.sign(lo) * np.sign(hi) < 0)
    assert np.all(np.abs(hi - lo) > 0.05)  # a jump of tens of mm/s, not a crossing
