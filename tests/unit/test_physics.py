"""Closed-form physics: thresholds against the paper's eq. 5 verbatim, forces, lift-off."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.model import release_amplitudes, slip_amplitudes


def paper_eq5(f, f0, Q, alpha_deg, M, cs, g, sign):
    """The paper's eq. 5 written out verbatim (with A, B and Omega_pm as defined there)."""
    w = 2 * np.pi * np.asarray(f, dtype=float)
    w0 = 2 * np.pi * f0
    alpha = np.radians(alpha_deg)
    inv_omega_sq = (
        w**2 * M * np.cos(alpha) * (np.cos(alpha) + sign * np.sin(alpha) / cs)
        / ((w0**2 - w**2) ** 2 + (w0 * w / Q) ** 2)
    )
    A = 1 + (w0**2 - w**2) * inv_omega_sq
    B = w0 * w / Q * inv_omega_sq
    return g * np.sqrt(A**2 + B**2) / (A + inv_omega_sq * ((w0**2 - w**2) * A + (w0 * w / Q) * B))


GRID = list(
    itertools.product(
        [2.0, 14.44, 80.0],  # f0
        [0.7, 17.5, 300.0],  # Q
        [-70.0, 10.0, 64.0],  # alpha
        [0.01, 0.08, 1.0],  # M
        [0.1, 0.25, 0.9],  # cs
    )
)


@pytest.mark.parametrize(("f0", "Q", "alpha", "M", "cs"), GRID)
def test_thresholds_equal_paper_eq5_verbatim(f0, Q, alpha, M, cs):
    s = study.Structure(f0=f0, Q=Q, alpha=alpha, M=M, cs=cs)
    f = np.linspace(0.05, 3.0, 301) * f0
    a_plus, a_minus = study.thresholds(s, f)
    ref_plus = paper_eq5(f, f0, Q, alpha, M, cs, s.g, +1)
    ref_minus = paper_eq5(f, f0, Q, alpha, M, cs, s.g, -1)
    for ours, ref in ((a_plus, ref_plus), (a_minus, ref_minus)):
        assert_allclose(ours, ref, rtol=1e-12, atol=0)


def test_thresholds_broadcast_and_units(paper_structure):
    f = np.linspace(10, 20, 7)[:, None]
    a_plus, a_minus = study.thresholds(paper_structure, f)
    assert a_plus.shape == a_minus.shape == (7, 1)
    # As f -> 0 the plate follows the table rigidly (tau -> 0): slipping then needs
    # n -> 0, so both thresholds tend to g.
    low_plus, low_minus = study.thresholds(paper_structure, 1e-6)
    assert_allclose([low_plus, low_minus], [paper_structure.g] * 2, rtol=1e-9)


def test_force_amplitudes_match_time_series(paper_structure):
    s = paper_structure
    f, a = 13.7, 6.3
    t = np.linspace(0, 2 / f, 401)
    w, w0 = 2 * np.pi * f, s.omega0
    alpha = math.radians(s.alpha)
    # Mode acceleration of the steady response, from the real ODE solution written
    # with amplitude and phase (independent of the complex-notation code).
    amp = a * math.cos(alpha) / math.hypot(w0**2 - w**2, w0 * w / s.Q)
    lag = math.atan2(w0 * w / s.Q, w0**2 - w**2)
    ddelta = -(w**2) * amp * np.cos(w * t - lag)
    n_ref = s.g - a * np.cos(w * t) + s.M * ddelta * math.cos(alpha)
    tau_ref = -s.M * ddelta * math.sin(alpha)
    assert_allclose(study.normal_force(s, f, a, t), n_ref, rtol=0, atol=1e-13)
    assert_allclose(study.tangential_force(s, f, a, t), tau_ref, rtol=0, atol=1e-13)


def test_mode_response_solves_mode_equation(paper_structure):
    s = paper_structure
    f = np.array([1.0, 14.44, 30.0])
    w = 2 * np.pi * f
    G = study.mode_response(s, f)
    # delta = G e^{iwt} must satisfy delta'' + (w0/Q) delta' + w0^2 delta = e^{iwt}
    residual = (-(w**2) + 1j * w * s.omega0 / s.Q + s.omega0**2) * G
    assert_allclose(residual, 1.0, rtol=1e-14)


def test_thresholds_are_where_the_slip_criterion_first_touches_zero(paper_structure):
    s = paper_structure
    f = 15.1
    a_plus, a_minus = study.thresholds(s, f)
    t = np.linspace(0, 1 / f, 200_001)
    for a_star, sign in ((a_plus, 1), (a_minus, -1)):
        crit = sign * study.tangential_force(s, f, a_star, t) - s.cs * study.normal_force(
            s, f, a_star, t
        )
        assert abs(crit.max()) < 1e-8 * s.g


def test_lift_off_is_where_normal_force_first_touches_zero(paper_structure):
    s = paper_structure
    f = np.array([10.0, 14.44, 19.0])
    a_lift = study.lift_off_acceleration(s, f)
    t = np.linspace(0, 1, 400_001)[:, None] / f
    n = study.normal_force(s, f, a_lift, t)
    assert_allclose(n.min(axis=0), 0.0, atol=1e-8)


def test_release_and_slip_amplitudes_reproduce_criteria(paper_structure):
    s = paper_structure.replace(ck=0.2)
    f, a = 14.0, 7.0
    t = np.linspace(0, 1 / f, 97)
    phase = np.exp(2j * np.pi * f * t)
    n = study.normal_force(s, f, a, t)
    tau = study.tangential_force(s, f, a, t)
    A_p, A_m = release_amplitudes(s, f, a)
    B_p, B_m = slip_amplitudes(s, f, a)
    assert_allclose((A_p * phase).real - s.cs * s.g, tau - s.cs * n, atol=1e-13)
    assert_allclose((A_m * phase).real - s.cs * s.g, -tau - s.cs * n, atol=1e-13)
    assert_allclose((B_p * phase).real - s.ck * s.g, tau - s.ck * n, atol=1e-13)
    assert_allclose((B_m * phase).real - s.ck * s.g, -tau - s.ck * n, atol=1e-13)


@pytest.mark.parametrize("bad_f", [0.0, -1.0, np.nan, np.inf, [10.0, -2.0]])
def test_bad_frequency_is_refused(paper_structure, bad_f):
    with pytest.raises(ValueError, match="drive frequency f"):
        study.thresholds(paper_structure, bad_f)
    with pytest.raises(ValueError, match="drive frequency f"):
        study.steady_velocity(paper_structure, bad_f, 5.0)


@pytest.mark.parametrize("bad_a", [-0.1, np.nan, np.inf, [1.0, -2.0]])
def test_bad_acceleration_is_refused(paper_structure, bad_a):
    with pytest.raises(ValueError, match="drive acceleration a"):
        study.steady_velocity(paper_structure, 14.0, bad_a)


def test_structure_type_is_checked():
    with pytest.raises(TypeError, match=r"study\.Structure"):
        study.steady_velocity({"f0": 14.44}, 14.0, 5.0)
