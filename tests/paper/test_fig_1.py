"""Paper Fig. 1: thresholds (1B) and the sign of the velocity against frequency (1C).

Statements checked (README, "How the solver works"): forward motion below the resonance
(10-14.5 Hz), backward above (15-20 Hz); the minimum threshold lies near the
resonance, a few m s-2, well below g.
"""

from __future__ import annotations

import numpy as np
import pytest

import study
from study import Status


def _valid_accelerations(structure, f, num=25):
    """Accelerations from just above the lower threshold to just below lift-off."""
    a_plus, a_minus = study.thresholds(structure, f)
    a_lift = study.lift_off_acceleration(structure, f)
    lower = min(a_plus, a_minus)
    assert lower < a_lift, "the paper's structure slips before it lifts off"
    return np.linspace(lower * (1 + 1e-6), a_lift * (1 - 1e-6), num)


@pytest.mark.parametrize("f", np.arange(10.0, 14.01, 0.5))
def test_forward_below_resonance(paper_structure, f):
    a = _valid_accelerations(paper_structure, f)
    v, status = study.steady_velocity(paper_structure, f, a)
    assert np.all(status == Status.STICK_SLIP)
    assert np.all(v > 0)


def test_forward_at_14_5_hz_just_above_threshold(paper_structure):
    a = _valid_accelerations(paper_structure, 14.5)[:3]
    v, _ = study.steady_velocity(paper_structure, 14.5, a)
    assert np.all(v > 0)


@pytest.mark.parametrize("f", np.arange(15.0, 20.01, 0.5))
def test_backward_above_resonance(paper_structure, f):
    a = _valid_accelerations(paper_structure, f)
    v, status = study.steady_velocity(paper_structure, f, a)
    assert np.all(status == Status.STICK_SLIP)
    assert np.all(v < 0)


def test_threshold_sign_matches_direction(paper_structure):
    """Fig. 1B: the lower threshold is a*_+ (blue, forward) below resonance, a*_- above."""
    below = np.linspace(10, 14.4, 45)
    above = np.linspace(14.8, 20, 53)
    a_plus, a_minus = study.thresholds(paper_structure, below)
    assert np.all(a_plus < a_minus)
    a_plus, a_minus = study.thresholds(paper_structure, above)
    assert np.all(a_minus < a_plus)


def test_minimum_threshold_near_resonance_and_well_below_g(paper_structure):
    f = np.linspace(10, 20, 100_001)
    a_star = np.minimum(*study.thresholds(paper_structure, f))
    i = np.argmin(a_star)
    assert abs(f[i] - paper_structure.f0) < 0.5
    assert 2.0 < a_star[i] < 6.0  # "a few m s-2"; Fig. 1C: lowest at about 4 near 14.5 Hz
    assert a_star[i] < 0.5 * paper_structure.g
