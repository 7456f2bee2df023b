"""Self-checks of the two-way coupled path of ``tests/reference/integrator.py``.

The reference integrator is itself the independent check of the package's solvers,
so its two-way path (sliding base acceleration ``x''`` forcing the plate mode) is
checked here against things that do not share its formulation:

* the limit ``M -> 0``, where two-way and one-way coupling must agree;
* a free slide without drive: the one-way closed form ``t = v0 / (ck g)``,
  ``d = v0^2 / (2 ck g)``, and for two-way coupling the horizontal momentum balance
  ``d/dt (v + M sin(alpha) delta') = -s ck n``, with ``n`` rebuilt here from the
  *eliminated* form of the slip equations (the module solves the 2x2 system
  numerically) and integrated by Gauss-Legendre quadrature of the dense output;
* Painleve's paradox: the boundary ``1 - M sin(alpha) (sin(alpha) + s ck cos(alpha)) = 0``
  and the ``"friction_paradox"`` status only when the bad direction is entered.

Paper structure (README, "Steering"): f0 = 14.44 Hz, Q = 17.5, alpha = 64 degree,
cs = ck = 0.25, g = 9.8 m s-2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from tests.reference.integrator import (
    STATUSES,
    ReferenceModelInvalid,
    reference_slide_to_rest,
    reference_velocity,
)

F0, Q, ALPHA, CS, G = 14.44, 17.5, 64.0, 0.25, 9.8
PAPER = {"f0": F0, "Q": Q, "alpha_deg": ALPHA, "cs": CS, "g": G}


def _velocity(M, f, a, coupling, **kw):
    return reference_velocity(F0, Q, ALPHA, M, CS, f, a, ck=CS, g=G, coupling=coupling, **kw)


# --- API ---------------------------------------------------------------------------


def test_statuses_and_coupling_argument():
    assert "friction_paradox" in STATUSES
    with pytest.raises(ValueError, match="coupling"):
        _velocity(0.08, 13.0, 8.5, "three-way")
    with pytest.raises(ValueError, match="coupling"):
        reference_slide_to_rest(M=0.08, v0=0.1, coupling="both", **PAPER)


def test_one_way_default_unchanged():
    """The default is one-way and reproduces the values from before two-way existed."""
    for f, a, v_before in ((13.0, 8.5, 0.0021952402056934386), (14.6, 7.0, -0.0033797661980393694)):
        default = reference_velocity(F0, Q, ALPHA, 0.08, CS, f, a)
        explicit = _velocity(0.08, f, a, "one-way")
        assert default == explicit
        assert default[1] == "stick_slip"
        assert_allclose(default[0], v_before, rtol=1e-12, atol=0.0)


# --- 1. small mass: two-way -> one-way ----------------------------------------------


def test_two_way_tends_to_one_way_for_small_mass():
    """M = 1e-4: mean velocities agree to 1e-3 (observed 9e-5, i.e. about M).

    As M -> 0 the motion thresholds tend to g (README, "Steering"), so at M = 1e-4
    stick-slip exists only in the narrow window a*_+ = 9.785 < a < a_lift = 9.798
    (f = 14 Hz); (13 Hz, 8.5) is static there.
    """
    M, f, a = 1e-4, 14.0, 9.795
    v1, s1, _ = _velocity(M, f, a, "one-way")
    v2, s2, n2 = _velocity(M, f, a, "two-way")
    assert s1 == s2 == "stick_slip", (s1, s2, n2)
    assert v1 > 0.0
    assert_allclose(v2, v1, rtol=1e-3, atol=0.0)
    # The coupling is really on: the difference is O(M), not round-off.
    assert abs(v2 / v1 - 1.0) > 1e-6


def test_two_way_orbit_is_periodic_in_full_state():
    """The two-way orbit is detected on (delta, delta', v, mode), not on v alone.

    One-way, the orbit repeats after 3 periods; two-way the mode transient must
    decay first (factor e per Q/pi = 5.6 periods). Tightening the periodicity
    tolerance from 1e-9 to 1e-11 moves the velocity by < 1e-7 (observed 1e-9).
    """
    v_a, s_a, n_a = _velocity(0.08, 13.0, 8.5, "two-way")
    v_b, s_b, n_b = _velocity(0.08, 13.0, 8.5, "two-way", period_tol=1e-11)
    assert s_a == s_b == "stick_slip"
    assert n_a >= 20
    assert n_b > n_a
    assert_allclose(v_a, v_b, rtol=1e-7, atol=0.0)


# --- 2. free slide without drive ----------------------------------------------------


@pytest.mark.parametrize("ck", [0.25, 0.1])
@pytest.mark.parametrize("M", [0.08, 0.9])
@pytest.mark.parametrize("v0", [0.3, -0.3, 0.02])
def test_one_way_slide_closed_form(v0, M, ck):
    t_stop, distance = reference_slide_to_rest(M=M, v0=v0, ck=ck, coupling="one-way", **PAPER)
    assert_allclose(t_stop, abs(v0) / (ck * G), rtol=1e-11, atol=0.0)
    assert_allclose(distance, math.copysign(v0 * v0 / (2.0 * ck * G), v0), rtol=1e-11, atol=0.0)


def _gauss_cumulative(traj, fun, order=8):
    """Integrals of ``fun(t, state)`` from 0 to every breakpoint of ``traj``.

    The dense output is a degree-7 polynomial between breakpoints and ``fun`` is
    affine in the state, so an 8-point Gauss-Legendre rule is exact there.
    """
    x, wts = np.polynomial.legendre.leggauss(order)
    bp = traj.breakpoints
    mid, half = 0.5 * (bp[1:] + bp[:-1]), 0.5 * (bp[1:] - bp[:-1])
    t = (mid[:, None] + half[:, None] * x[None, :]).ravel()
    vals = fun(t, traj(t)).reshape(mid.size, order)
    return np.concatenate([[0.0], np.cumsum(half * (vals @ wts))])


@pytest.mark.parametrize("mode0", [(0.0, 0.0), (3e-4, -0.1)], ids=["mode-at-rest", "mode-moving"])
@pytest.mark.parametrize("M", [0.08, 0.3, 0.9])
@pytest.mark.parametrize("v0", [0.3, -0.3])
def test_two_way_slide_momentum_balance(v0, M, mode0):
    """v + M sin(alpha) delta' changes only by the friction impulse -s ck int n dt."""
    ck = CS
    s = 1.0 if v0 > 0 else -1.0
    t_stop, distance, traj = reference_slide_to_rest(
        M=M, v0=v0, coupling="two-way", mode0=mode0, return_trajectory=True, **PAPER
    )
    ca, sa = math.cos(math.radians(ALPHA)), math.sin(math.radians(ALPHA))
    w0 = 2.0 * math.pi * F0

    def normal_force(t, y):
        # Eliminated slip equations (a = 0), derived independently of the module:
        # delta'' (1 - M sa (sa + s ck ca)) = -(w0/Q) delta' - w0^2 delta + s ck sa g.
        F = -(w0 / Q) * y[1] - w0 * w0 * y[0]
        acc = (F + s * ck * sa * G) / (1.0 - M * sa * (sa + s * ck * ca))
        return G + M * ca * acc

    bp = traj.breakpoints
    assert bp[0] == 0.0 and bp[-1] == t_stop and bp.size > 5
    y = traj(bp)
    assert_allclose(y[:, 0], [mode0[0], mode0[1], 0.0, v0], rtol=0.0, atol=1e-15)
    assert_allclose(y[3, -1], 0.0, rtol=0.0, atol=1e-12 * abs(v0))
    assert_allclose(y[2, -1], distance, rtol=1e-13, atol=0.0)
    assert np.all(s * y[3, :-1] > 0.0)  # first return of v to 0

    momentum = y[3] + M * sa * y[1]
    impulse = -s * ck * _gauss_cumulative(traj, normal_force)
    assert_allclose(momentum - momentum[0], impulse, rtol=1e-9, atol=1e-9 * abs(v0))
    # and x is the integral of v
    assert_allclose(y[2], _gauss_cumulative(traj, lambda t, z: z[3]), rtol=1e-9, atol=1e-12)


# --- 3. Painleve's paradox ------------------------------------------------------------


def test_paradox_boundary_in_free_slide():
    """Slip +1 has a non-positive determinant exactly for M >= 1 / (sa (sa + ck ca))."""
    alpha = 85.0
    ca, sa = math.cos(math.radians(alpha)), math.sin(math.radians(alpha))
    m_crit = 1.0 / (sa * (sa + CS * ca))  # 0.986
    par = dict(PAPER, alpha_deg=alpha)
    with pytest.raises(ReferenceModelInvalid) as info:
        reference_slide_to_rest(M=m_crit * (1 + 1e-9), v0=0.3, coupling="two-way", **par)
    assert info.value.status == "friction_paradox"
    # Just below the boundary, and in the other direction, the slide is computed.
    t_stop, _ = reference_slide_to_rest(M=m_crit * (1 - 1e-2), v0=0.3, coupling="two-way", **par)
    assert t_stop > 0.0
    t_stop, d = reference_slide_to_rest(M=m_crit * (1 + 1e-9), v0=-0.3, coupling="two-way", **par)
    assert t_stop > 0.0 and d < 0.0
    # One-way has no paradox.
    t_stop, _ = reference_slide_to_rest(M=m_crit * (1 + 1e-9), v0=0.3, **par)
    assert_allclose(t_stop, 0.3 / (CS * G), rtol=1e-11, atol=0.0)


def test_paradox_status_only_when_bad_direction_is_entered():
    """alpha = 85 degree, M = 1: det(+1) < 0 < det(-1).

    At 14.44 Hz the structure slips forward: friction_paradox. At 16 Hz it slips only
    backward (one-way velocity < 0, no forward slip): a normal two-way orbit.
    """
    par = (F0, Q, 85.0, 1.0, CS)
    v, status, n = reference_velocity(*par, 14.44, 2.0, coupling="two-way")
    assert status == "friction_paradox" and math.isnan(v) and n >= 1
    v1, s1, _ = reference_velocity(*par, 14.44, 2.0, coupling="one-way")
    assert s1 == "stick_slip" and v1 > 0.0
    v2, s2, _ = reference_velocity(*par, 16.0, 5.0, coupling="two-way")
    assert s2 == "stick_slip" and v2 < 0.0
