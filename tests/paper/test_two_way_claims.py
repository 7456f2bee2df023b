"""Which of the paper's claims survive two-way coupling (README, "The paper's claims with
two-way coupling"): each survive/fail statement of that table, computed with the exact
two-way solver (``coupling="two-way"``) beside the paper's one-way model, so the README
cannot drift from the numbers.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import study
from study import Status

MOVING = (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING)


def velocity(structure, f, a, coupling):
    v, status = study.steady_velocity(structure, f, a, coupling=coupling)
    return v, status


def sign_changes(v, status):
    """Indices i where the velocity changes sign between moving points i and i + 1."""
    moving = np.isin(status, MOVING) & (v != 0)
    sign = np.sign(v)
    return np.flatnonzero(moving[:-1] & moving[1:] & (sign[:-1] * sign[1:] < 0))


# -- survives: the regions S, P, N, PN and the direction in P and N ---------------------

@pytest.mark.parametrize(
    ("f", "a", "regime", "one_way_mm_s", "two_way_mm_s"),
    [(13.0, 5.0, "S", 0.0, 0.0), (13.0, 8.5, "P", 2.195, 2.036),
     (16.5, 8.5, "N", -0.965, -1.060), (14.6, 7.0, "PN", -3.380, 0.118)],
)
def test_the_four_points(paper_structure, f, a, regime, one_way_mm_s, two_way_mm_s):
    one = study.steady_state(paper_structure, f, a)
    two = study.steady_state(paper_structure, f, a, coupling="two-way")
    assert float(one.velocity) * 1e3 == pytest.approx(one_way_mm_s, abs=1e-3)
    assert float(two.velocity) * 1e3 == pytest.approx(two_way_mm_s, abs=1e-3)
    if regime == "S":
        assert one.status == two.status == Status.STATIC
        assert one.velocity == two.velocity == 0.0
        return
    assert one.status == two.status == Status.STICK_SLIP
    # The orbit slips in the directions of the paper's region, in both couplings.
    for result in (one, two):
        assert (float(result.forward_fraction) > 0) == (regime in ("P", "PN"))
        assert (float(result.backward_fraction) > 0) == (regime in ("N", "PN"))
    if regime in ("P", "N"):
        # Same direction, within 10 %.
        assert np.sign(two.velocity) == np.sign(one.velocity)
        assert abs(two.velocity / one.velocity - 1) < 0.1


def test_at_the_pn_point_the_direction_reverses(paper_structure):
    """Fails: the paper's PN point (14.6 Hz, 7 m s-2) goes backward at -3.38 mm s-1 in the
    one-way model, barely forward (+0.12 mm s-1) with two-way coupling, where the
    frontier lies at 14.605 Hz."""
    v1, _ = velocity(paper_structure, 14.6, 7.0, "one-way")
    v2, _ = velocity(paper_structure, 14.6, 7.0, "two-way")
    assert v1 < 0 < v2
    f = np.linspace(14.55, 14.65, 201)
    v, status = velocity(paper_structure, f, 7.0, "two-way")
    (i,) = sign_changes(v, status)
    assert 14.60 < f[i] < 14.61


# -- 14.5 Hz: positive at a = 6 survives, negative at a = 9 does not -------------------

def test_at_14_5_hz_the_velocity_no_longer_reverses(paper_structure):
    v1, s1 = velocity(paper_structure, 14.5, [6.0, 9.0], "one-way")
    v2, s2 = velocity(paper_structure, 14.5, [6.0, 9.0], "two-way")
    assert np.all(s1 == Status.STICK_SLIP) and np.all(s2 == Status.STICK_SLIP)
    assert v1[0] > 0 > v1[1]  # the paper: positive at 6, negative at 9
    assert v2[0] > 0 and v2[1] > 0  # two-way: still forward at 9 (+2.75 mm s-1)
    assert v2[1] * 1e3 == pytest.approx(2.746, abs=1e-3)
    # Forward from the threshold to lift-off, which comes earlier (9.30 against 9.83).
    a = np.linspace(3.8, 9.8, 601)
    v, status = velocity(paper_structure, 14.5, a, "two-way")
    moving = np.isin(status, MOVING)
    assert np.all(v[moving] > 0)
    assert 9.29 < a[status == Status.LIFT_OFF].min() <= 9.31
    assert float(study.lift_off_acceleration(paper_structure, 14.5)) > 9.8


# -- forward below the resonance, backward above: survives -----------------------------

def _valid_accelerations(structure, f, num=25):
    a_plus, a_minus = study.thresholds(structure, f)
    a_lift = study.lift_off_acceleration(structure, f)
    return np.linspace(min(a_plus, a_minus) * (1 + 1e-6), a_lift * (1 - 1e-6), num)


@pytest.mark.parametrize("f", [10.0, 11.0, 12.0, 13.0, 14.0, 14.5, 15.0, 16.0, 18.0, 20.0])
def test_forward_below_backward_above_the_resonance(paper_structure, f):
    a = _valid_accelerations(paper_structure, f)
    v, status = velocity(paper_structure, f, a, "two-way")
    moving = np.isin(status, MOVING)
    # Where it does not move it has lifted off (two-way: at most the last few points).
    assert np.all(moving | (status == Status.LIFT_OFF))
    assert np.count_nonzero(moving) >= a.size - 3
    assert np.all(v[moving] > 0) if f <= 14.5 else np.all(v[moving] < 0)


# -- thresholds: unchanged, computed with the base at rest -----------------------------

@pytest.mark.parametrize("M", [0.08, 0.066, 0.3, 1.0])
def test_the_thresholds_are_those_of_the_one_way_model(paper_structure, M):
    """Slips start where the stuck structure's forces first allow one: while stuck the
    base does not accelerate, so two-way coupling has no term to add."""
    structure = replace(paper_structure, M=M)
    f = np.linspace(10.0, 20.0, 41)
    lower = np.minimum(*study.thresholds(structure, f))
    lift = study.lift_off_acceleration(structure, f)
    below = lower < lift
    f, lower = f[below], lower[below]
    v, status = velocity(structure, f, lower * (1 - 1e-6), "two-way")
    assert np.all(status == Status.STATIC) and np.all(v == 0.0)
    _, status = velocity(structure, f, lower * (1 + 1e-6), "two-way")
    assert np.all(np.isin(status, MOVING))


def test_the_static_region_of_the_map_is_the_same(paper_structure):
    f = np.linspace(10.0, 20.0, 101)[:, None]
    a = np.linspace(0.0, 12.0, 61)[None, :]
    _, s1 = velocity(paper_structure, f, a, "one-way")
    _, s2 = velocity(paper_structure, f, a, "two-way")
    np.testing.assert_array_equal(s1 == Status.STATIC, s2 == Status.STATIC)


# -- the frontier f*(a) ----------------------------------------------------------------

#: Frequencies scanned for the frontier at M = 0.08 [Hz].
SCAN = np.linspace(14.3, 14.8, 1001)


def _frontier(structure, a, coupling, f=SCAN):
    v, status = velocity(structure, f, a, coupling)
    changes = sign_changes(v, status)
    assert changes.size == 1
    return f[changes[0]]


def test_at_m_0_08_the_frontier_bends_the_other_way(paper_structure):
    """One-way: f* falls from 14.55 Hz (a = 5) to 14.38 Hz (a = 9); two-way it rises to
    14.60 Hz at a = 7 and stays within 14.55-14.61 Hz."""
    one = [_frontier(paper_structure, a, "one-way") for a in (5.0, 7.0, 9.0)]
    two = [_frontier(paper_structure, a, "two-way") for a in (5.0, 7.0, 9.0)]
    assert one[0] > one[1] > one[2] and one[0] - one[2] > 0.15
    assert two[1] > two[0] and two[1] > two[2]
    assert max(two) - min(two) < 0.06
    assert min(two) > 14.5  # hence 14.5 Hz never reverses


@pytest.mark.parametrize("M", [0.8, 1.0])
def test_as_m_grows_the_frontier_keeps_one_branch(paper_structure, M):
    """One-way: three sign changes at a = 2.7 m s-2 (M = 0.8 and 1), none from a = 4;
    two-way: a single branch at every a, moving up in frequency with a."""
    structure = replace(paper_structure, M=M)
    f = np.linspace(5.0, 30.0, 5001)
    counts = {}
    where = []
    for a in (2.7, 4.0, 5.0):
        counts[a] = [sign_changes(*velocity(structure, f, a, c)).size
                     for c in ("one-way", "two-way")]
        (i,) = sign_changes(*velocity(structure, f, a, "two-way"))
        where.append(f[i])
    assert counts[2.7] == [3, 1]
    assert counts[4.0] == counts[5.0] == [0, 1]
    assert where[0] < where[1] < where[2]
    assert where[0] > 16.5


# -- the limit M -> 1 ------------------------------------------------------------------

def test_continuous_sliding_is_rare_with_two_way_coupling(paper_structure):
    """One-way: continuous sliding covers a fifth of the M = 1 map; two-way: none."""
    structure = replace(paper_structure, M=1.0)
    f = np.linspace(5.0, 30.0, 126)[:, None]
    a = np.linspace(0.0, 12.0, 61)[None, :]
    _, s1 = velocity(structure, f, a, "one-way")
    _, s2 = velocity(structure, f, a, "two-way")
    assert np.mean(s1 == Status.CONTINUOUS_SLIDING) > 0.15
    assert np.mean(s2 == Status.CONTINUOUS_SLIDING) < 0.01
    # ... and it lifts off over half the map (15 % one-way).
    assert np.mean(s1 == Status.LIFT_OFF) < 0.2 < 0.45 < np.mean(s2 == Status.LIFT_OFF)
