"""Paper Fig. 2: the regime map S, P, N, PN and the non-vertical frontier f*(a)."""

from __future__ import annotations

import numpy as np
import pytest

import study
from study import Status


def _regime(structure, f, a):
    a_plus, a_minus = study.thresholds(structure, f)
    return {(False, False): "S", (True, False): "P", (False, True): "N", (True, True): "PN"}[
        (bool(a > a_plus), bool(a > a_minus))
    ]


@pytest.mark.parametrize(
    ("f", "a", "regime"),
    [(13.0, 5.0, "S"), (13.0, 8.5, "P"), (16.5, 8.5, "N"), (14.6, 7.0, "PN")],
)
def test_the_four_points_of_fig_2(paper_structure, f, a, regime):
    assert _regime(paper_structure, f, a) == regime
    result = study.steady_state(paper_structure, f, a)
    fwd, bwd = float(result.forward_fraction), float(result.backward_fraction)
    if regime == "S":
        assert result.status == Status.STATIC and result.velocity == 0.0
        return
    assert result.status == Status.STICK_SLIP
    # The solver's orbit slips in exactly the directions the thresholds allow.
    assert (fwd > 0) == (regime in ("P", "PN"))
    assert (bwd > 0) == (regime in ("N", "PN"))
    if regime == "P":
        assert result.velocity > 0
    if regime == "N":
        assert result.velocity < 0


def test_velocity_reverses_with_amplitude_at_14_5_hz(paper_structure):
    """'For f = 14.5 Hz the velocity is positive at a = 6 and negative at a = 9.'"""
    v, status = study.steady_velocity(paper_structure, 14.5, [6.0, 9.0])
    assert np.all(status == Status.STICK_SLIP)
    assert v[0] > 0 > v[1]


def test_frontier_is_not_vertical(paper_structure):
    """The zero-velocity frontier f*(a) moves with a inside PN."""
    f = np.linspace(14.3, 15.0, 1401)

    def frontier(a):
        v, _ = study.steady_velocity(paper_structure, f, a)
        crossing = np.nonzero(np.diff(np.sign(v)) < 0)[0]
        assert crossing.size >= 1
        return f[crossing[0]]

    assert abs(frontier(6.0) - frontier(9.0)) > 0.02


def test_alpha_mirror_reverses_motion(paper_structure):
    f = np.linspace(10, 20, 41)[:, None]
    a = np.linspace(0, 10, 21)
    v, status = study.steady_velocity(paper_structure, f, a)
    v_m, status_m = study.steady_velocity(paper_structure.replace(alpha=-64.0), f, a)
    np.testing.assert_array_equal(status, status_m)
    np.testing.assert_allclose(v_m, -v, rtol=1e-12, atol=1e-18)


def test_vanishing_mass_ratio_is_static(paper_structure):
    """M -> 0: the plate cannot drive the base, nothing slips below lift-off."""
    tiny = paper_structure.replace(M=1e-4)
    f = np.linspace(10, 20, 51)[:, None]
    a = np.linspace(0, 9.0, 19)
    v, status = study.steady_velocity(tiny, f, a)
    assert np.all(status == Status.STATIC)
    assert np.all(v == 0.0)
