"""Hard cases of the exact two-way solver, each accurate against a reference or flagged.

References: the 30-digit mpmath orbit (``tests/reference/two_way_exact.py``, run live on
a few points) and the time integrator ``study.solvers.integrator.integrated_steady_state`` at
tolerance 1e-11, which agrees with the cached 40-digit points to <= 8e-10 a / w (its
error is trusted to ``INTEGRATOR_TOLERANCE`` = 1e-8 a / w). The integrator flags
``LIFT_OFF`` met anywhere from its start, the exact solver only on the orbit (or on the
iterated attractor): where the integrator lifts off, only the invariant is asserted.

Invariant, over every point of this module: a converged status (``STATIC``,
``STICK_SLIP``, ``CONTINUOUS_SLIDING``) has a finite velocity (0 when static), an invalid
one (``LIFT_OFF``, ``NOT_CONVERGED``, ``FRICTION_PARADOX``) a NaN velocity.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from study.model import lift_off_acceleration, thresholds
from study.model.status import INVALID_STATUSES, Status
from study.model.structure import Structure, tilt_warnings
from study.solvers.exact import steady_state
from study.solvers.integrator import IntegratorSettings, integrated_steady_state
from tests.reference.two_way_exact import reference_orbit

PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25}
INTEGRATOR_TOLERANCE = 1e-8  # of a / w
CONVERGED = (Status.STATIC, Status.STICK_SLIP, Status.CONTINUOUS_SLIDING)


def _scale(f: float, a: float) -> float:
    return a / (2.0 * math.pi * f)


def _solve(s: Structure, f, a):
    """The exact two-way solve, with the status/velocity invariant checked."""
    r = steady_state(s, f, a, coupling="two-way", parallel=False)
    for st, v, fl in zip(np.ravel(r.status), np.ravel(r.velocity),
                         np.ravel(r.floquet_multiplier), strict=True):
        st = Status(int(st))
        if st in INVALID_STATUSES:
            assert math.isnan(v), (s, f, a, st, v)
        elif st in (Status.CHAOTIC, Status.QUASI_PERIODIC):
            # An irregular motion: its time-averaged velocity, no orbit (no multiplier).
            assert math.isfinite(v), (s, f, a, st, v)
            assert math.isnan(fl), (s, f, a, st, fl)
        else:
            assert math.isfinite(v), (s, f, a, st, v)
            assert math.isfinite(fl) and fl < 1.0 + 1e-6, (s, f, a, st, fl)
            if st == Status.STATIC:
                assert v == 0.0
    return r


def _integrated(s: Structure, f: float, a: float, max_periods: int = 4000):
    return integrated_steady_state(
        s, f, a, coupling="two-way",
        settings=IntegratorSettings(tolerance=1e-11, max_periods=max_periods))


def _agrees_with_integrator(s: Structure, f: float, a: float, max_periods: int = 4000,
                            moving_status: bool = True):
    """Exact and integrated orbits agree (status and velocity), unless the integrator
    met lift-off on its way. Returns the exact result. ``moving_status=False``: STICK_SLIP
    and CONTINUOUS_SLIDING are not told apart (a stick shorter than the integrator's
    event resolution)."""
    r = _solve(s, f, a)
    ig = _integrated(s, f, a, max_periods)
    st, st_ig = Status(int(r.status)), Status(int(ig.status))
    if st_ig == Status.LIFT_OFF and st != Status.LIFT_OFF:
        pytest.fail(f"integrator lifted off on its way: no reference for {s, f, a}")
    moving = (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING)
    if moving_status or st not in moving or st_ig not in moving:
        assert st == st_ig, (s, f, a, st, st_ig)
    if st in CONVERGED:
        err = abs(float(r.velocity) - float(ig.velocity))
        assert err <= INTEGRATOR_TOLERANCE * _scale(f, a), (
            s, f, a, float(r.velocity), float(ig.velocity), err / _scale(f, a))
    return r


def _window(s: Structure, f: float, position: float) -> float:
    """``a`` at ``position`` (0..1) between the lowest threshold and lift-off."""
    low = float(min(thresholds(s, f)))
    lift = float(lift_off_acceleration(s, f))
    assert low < lift, (s, f, low, lift)
    return low + position * (lift - low)


# --- grazing releases ------------------------------------------------------------------


@pytest.mark.parametrize("excess", [1e-9, 1e-7, 1e-5, 1e-3])
@pytest.mark.parametrize(("f", "direction"), [(13.0, 1.0), (16.5, -1.0)])
def test_grazing_release(f, direction, excess):
    """``a = a* (1 + excess)``: one short slip per period in the threshold's direction;
    ``v ~ excess^2`` and, where it is above rounding, the integrator's value."""
    s = Structure(**PAPER)
    a = float(min(thresholds(s, f))) * (1.0 + excess)
    r = _agrees_with_integrator(s, f, a)
    assert Status(int(r.status)) == Status.STICK_SLIP
    v = float(r.velocity)
    scale = _scale(f, a)
    if excess >= 1e-7:
        assert v * direction > 0.0, v
    # v / (a/w) ~ C excess^2 with C = O(1..100)
    assert abs(v) <= 100.0 * excess**2 * scale + 1e-15 * scale, v


def test_grazing_release_against_the_mpmath_orbit():
    s = Structure(**PAPER)
    f = 16.5
    a = float(min(thresholds(s, f))) * (1.0 + 1e-3)
    ref = reference_orbit(s, f, a, dps=30)
    r = _solve(s, f, a)
    assert ref.status == "STICK_SLIP" == Status(int(r.status)).name
    assert abs(float(r.velocity) - float(ref.velocity)) <= 1e-13 * _scale(f, a)
    assert abs(float(r.velocity) / float(ref.velocity) - 1.0) <= 1e-6  # v ~ 1e-6 a/w


# --- slip ending on the stick boundary: STICK_SLIP <-> CONTINUOUS_SLIDING ---------------


def test_slip_ending_on_the_stick_boundary():
    """Along ``a`` the last stick of the orbit shrinks to nothing (the slip ends exactly
    where the reversal becomes possible). Bisected to 1e-12 relative: both sides solved,
    the velocity continuous across the boundary, the stick fraction -> 0."""
    s = Structure(**{**PAPER, "alpha": 45.0, "M": 0.9})
    f = 21.0
    lo, hi = 4.45, 4.6
    assert Status(int(_solve(s, f, lo).status)) == Status.STICK_SLIP
    assert Status(int(_solve(s, f, hi).status)) == Status.CONTINUOUS_SLIDING
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if Status(int(_solve(s, f, mid).status)) == Status.STICK_SLIP:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12 * hi:
            break
    left, right = _solve(s, f, lo), _solve(s, f, hi)
    stick_left = 1.0 - float(left.forward_fraction) - float(left.backward_fraction)
    assert 0.0 <= stick_left < 1e-4, stick_left
    scale = _scale(f, hi)
    assert abs(float(left.velocity) - float(right.velocity)) <= 1e-8 * scale
    # Both sides are accurate, not merely continuous; a stick of ~1e-12 periods is below
    # the integrator's event resolution, so its status may be either there.
    _agrees_with_integrator(s, f, lo, moving_status=False)
    _agrees_with_integrator(s, f, hi, moving_status=False)
    _agrees_with_integrator(s, f, lo * (1 - 1e-3))
    _agrees_with_integrator(s, f, hi * (1 + 1e-3))


# --- D_s -> 0+ and D_s <= 0 ------------------------------------------------------------


def _near_paradox(distance: float) -> Structure:
    """``D_+ = distance``: ``M sin(alpha) (sin(alpha) + ck cos(alpha)) = 1 - distance``."""
    alpha = 80.0
    sa, ca = math.sin(math.radians(alpha)), math.cos(math.radians(alpha))
    return Structure(**{**PAPER, "alpha": alpha, "M": (1.0 - distance) / (sa * (sa + 0.25 * ca))})


def test_stiff_slip_d_plus_1e_2_against_the_integrator():
    _agrees_with_integrator(_near_paradox(1e-2), 12.0, 4.0)


@pytest.mark.parametrize("distance", [1e-3, 1e-4, 1e-6, 1e-9])
def test_stiff_slip_d_plus_to_zero_is_flagged_or_converged(distance):
    """The 30-digit reference leaves the model from the canonical start (``n = 0`` at
    ``t = 0`` in a forward slip) and the integrator lifts off: no reference orbit. The
    exact solver must not return NaN with a converged status (nor the reverse), and
    a converged orbit must stay on the table over a full pass (checked by the solver's
    final pass)."""
    r = _solve(_near_paradox(distance), 12.0, 4.0)
    assert Status(int(r.status)) in (Status.STICK_SLIP, Status.LIFT_OFF, Status.NOT_CONVERGED)


@pytest.mark.parametrize("distance", [0.0, -1e-12, -1e-6, -1e-3])
def test_friction_paradox(distance):
    s = _near_paradox(distance)
    r = _solve(s, 12.0, 4.0)
    assert Status(int(r.status)) == Status.FRICTION_PARADOX
    ig = _integrated(s, 12.0, 4.0)
    assert Status(int(ig.status)) == Status.FRICTION_PARADOX


# --- ck << cs, continuous sliding at M -> 1 --------------------------------------------


@pytest.mark.parametrize(("f", "a"), [(13.0, 8.5), (14.6, 7.0)])
def test_kinetic_friction_1e_3_of_static(f, a):
    """``ck = 1e-3 cs``: long, almost frictionless slips."""
    _agrees_with_integrator(Structure(**{**PAPER, "ck": 0.25e-3}), f, a)


@pytest.mark.parametrize(
    ("params", "f", "a", "status"),
    [
        (dict(Q=62.228798048531836, alpha=56.633345451129, M=1.0 - 1e-6,
              cs=0.06911648701693282), 41.56468001951312, 8.372100689608722,
         Status.CONTINUOUS_SLIDING),
        (dict(Q=6.648159003105809, alpha=-56.85205936908241, M=1.0,
              cs=0.07232280061136713), 47.91543270411562, 4.485319915933137,
         Status.CONTINUOUS_SLIDING),
        (dict(Q=26.796894979000264, alpha=47.204457369947306, M=1.0, cs=0.5187119709466558,
              ck=0.08160985683507785), 56.275018182688555, 18.24459343748892,
         Status.CONTINUOUS_SLIDING),
        (dict(Q=5.252982874101628, alpha=76.67390680328589, M=1.0 - 1e-6,
              cs=0.4294539984998661), 43.8945431498037, 9.04983187444019, Status.STICK_SLIP),
    ],
    ids=["M-1e-6-sliding", "M-1-sliding", "M-1-ck-sliding", "M-1e-6-steep-stick-slip"],
)
def test_mass_ratio_to_one(params, f, a, status):
    r = _agrees_with_integrator(Structure(f0=14.44, **params), f, a)
    assert Status(int(r.status)) == status


def test_continuous_sliding_m_to_one_against_the_mpmath_orbit():
    s = Structure(f0=14.44, Q=6.648159003105809, alpha=-56.85205936908241, M=1.0,
                  cs=0.07232280061136713)
    f, a = 47.91543270411562, 4.485319915933137
    ref = reference_orbit(s, f, a, dps=30)
    r = _solve(s, f, a)
    assert ref.status == "CONTINUOUS_SLIDING" == Status(int(r.status)).name
    v = float(ref.velocity)
    assert abs(float(r.velocity) - v) <= 1e-13 * _scale(f, a) + 1e-12 * abs(v)


# --- Q from 0.5 (critical damping in the stick) to 1e4 --------------------------------

CRITICAL = dict(alpha=-77.30321703658433, M=0.27278469158633273, cs=0.09631982519080966)


@pytest.mark.parametrize("q", [0.5, 0.5 * (1 - 1e-9), 0.5 * (1 + 1e-9), 0.5 * (1 + 1e-6), 0.7])
def test_critical_damping_in_the_stick(q):
    """``Q = 1/2``: the stick's homogeneous solution is ``(p + q t) e^{-w0 t}`` (the
    kernel's special branch); ``Q`` a hair either side must give the same orbit."""
    s = Structure(f0=14.44, Q=q, **CRITICAL)
    f, a = 10.7019347239627, 9.731598624638377
    r = _agrees_with_integrator(s, f, a)
    assert Status(int(r.status)) == Status.STICK_SLIP
    if q != 0.7:
        at_half = _solve(Structure(f0=14.44, Q=0.5, **CRITICAL), f, a)
        assert abs(float(r.velocity) - float(at_half.velocity)) <= 1e-7 * _scale(f, a)


def test_critical_damping_against_the_mpmath_orbit():
    s = Structure(f0=14.44, Q=0.5, **CRITICAL)
    f, a = 10.7019347239627, 9.731598624638377
    ref = reference_orbit(s, f, a, dps=30)
    r = _solve(s, f, a)
    assert ref.status == "STICK_SLIP" == Status(int(r.status)).name
    assert abs(float(r.velocity) - float(ref.velocity)) <= 1e-13 * _scale(f, a)


@pytest.mark.parametrize("q", [1e2, 1e3, 1e4])
def test_high_quality_factor(q):
    """Slow free decay (``exp(-pi f0 / (Q f))`` per period): the slips' damping still
    makes the orbit attract (the integrator reaches it within 4000 periods)."""
    s = Structure(**{**PAPER, "Q": q})
    f = 13.0
    r = _agrees_with_integrator(s, f, float(min(thresholds(s, f))) * 1.3)
    assert Status(int(r.status)) == Status.STICK_SLIP


# --- f from 0.01 to 100 f0 ------------------------------------------------------------


@pytest.mark.parametrize(
    ("params", "ratio", "position"),
    [
        (dict(Q=18.046189321429537, alpha=67.6051933784533, M=0.5183718677951554,
              cs=0.8520194857283039, ck=0.3395132509581494), 0.01, 0.5),
        (dict(Q=17.5, alpha=64.0, M=0.5, cs=0.25), 0.1, 0.5),
        (dict(Q=17.5, alpha=30.0, M=0.6, cs=0.3), 10.0, 0.5),
        # (Q = 50 at 100 f0 decays by e in 1600 periods: beyond the integrator's budget)
        (dict(Q=2.875164931123514, alpha=20.720210775385084, M=0.4005434675433014,
              cs=0.5358205207130995), 100.0, 0.5),
    ],
    ids=["0.01f0", "0.1f0", "10f0", "100f0"],
)
def test_frequency_range(params, ratio, position):
    s = Structure(f0=14.44, **params)
    f = s.f0 * ratio
    a = _window(s, f, position)
    r = _agrees_with_integrator(s, f, a, max_periods=4000)
    assert Status(int(r.status)) in CONVERGED


# --- zeros of the frontier -------------------------------------------------------------


@pytest.mark.parametrize(
    ("params", "a", "f_range"),
    [
        (PAPER, 7.0, (14.0, 15.5)),
        ({**PAPER, "alpha": 45.0, "M": 0.9}, 3.625, None),
    ],
    ids=["paper-a7-along-f", "sliding-structure-along-a"],
)
def test_frontier_zero(params, a, f_range):
    """Where ``v`` changes sign along ``f`` at fixed ``a`` (or along ``a`` at fixed
    ``f``): both sides solved with consistent signs, and the bisected zero has a tiny
    ``|v|`` (bounded by the slope times the bracket) and no NaN."""
    s = Structure(**params)
    if f_range is not None:
        grid = np.linspace(*f_range, 61)
        velocity = _solve(s, grid, a).velocity

        def v_at(x):
            return float(_solve(s, x, a).velocity)
    else:
        f = 21.0
        grid = np.linspace(3.4, 3.8, 41)
        velocity = _solve(s, f, grid).velocity

        def v_at(x):
            return float(_solve(s, f, x).velocity)
    assert np.all(np.isfinite(velocity))
    changes = np.nonzero(np.sign(velocity[:-1]) * np.sign(velocity[1:]) < 0)[0]
    assert changes.size >= 1
    for i in changes:
        lo, hi = grid[i], grid[i + 1]
        v_lo, v_hi = v_at(lo), v_at(hi)
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            v_mid = v_at(mid)
            assert math.isfinite(v_mid), mid
            if v_mid == 0.0 or hi - lo <= 4e-16 * hi:
                break
            if np.sign(v_mid) == np.sign(v_lo):
                lo, v_lo = mid, v_mid
            else:
                hi, v_hi = mid, v_mid
        assert np.sign(v_lo) * np.sign(v_hi) <= 0
        slope = abs(velocity[i + 1] - velocity[i]) / (grid[i + 1] - grid[i])
        scale = _scale(f_range[0] if f_range else 21.0, a if f_range else mid)
        assert abs(v_mid) <= 2.0 * slope * (hi - lo) + 1e-13 * scale, (mid, v_mid)
        assert abs(v_mid) <= 1e-12 * scale


# --- the invariant over a random sample of everything ----------------------------------


def test_status_velocity_invariant_over_random_points():
    """2000 random points over the whole parameter space (Q to 1e4, M to 1, f over
    0.01..100 f0, a from 0.5 to 3 times the lowest threshold): the invariant holds."""
    rng = np.random.default_rng(99)
    seen = set()
    for _ in range(2000):
        q = 10.0 ** rng.uniform(math.log10(0.5), 4.0)
        m = rng.uniform(0.01, 1.0) if rng.uniform() < 0.7 else 1.0 - 10.0 ** rng.uniform(-9, -1)
        cs = rng.uniform(0.05, 1.0)
        with tilt_warnings(False):  # small tilts are part of the space, in degree
            s = Structure(f0=14.44, Q=q, alpha=rng.uniform(-85.0, 85.0), M=m, cs=cs,
                          ck=cs * rng.uniform(0.01, 1.0))
        f = s.f0 * 10.0 ** rng.uniform(-2.0, 2.0)
        a = float(min(thresholds(s, f))) * rng.uniform(0.5, 3.0)
        seen.add(Status(int(_solve(s, f, a).status)))
    assert {Status.STATIC, Status.STICK_SLIP, Status.CONTINUOUS_SLIDING, Status.LIFT_OFF} <= seen


# A scan of 24 maps (Q 5-1000, M 0.08-1, two tilts) for points whose velocity stands
# out of both neighbours along a (a V shape) found 139; these three, at regime edges
# where a slip appears or changes, stand for them. Each point and its neighbours:
# the solver's orbit state is a fixed point of the 30-digit reference's period map
# (independent code) with its velocity, and the slip structure changes across the kink.
REGIME_EDGES = [
    # (structure, f [Hz], a of the V's tip [m s^-2], step in a, what changes)
    ({"f0": 14.44, "Q": 5.0, "alpha": 30.0, "M": 0.5, "cs": 0.5, "ck": 0.3}, 16.6, 8.6, 0.1,
     "backward"),
    ({**PAPER, "M": 0.5}, 15.9, 2.7, 0.1, "forward"),
    ({"f0": 14.44, "Q": 5.0, "alpha": 30.0, "M": 1.0, "cs": 0.5, "ck": 0.3}, 36.0, 12.0, 0.1,
     "forward"),
]


@pytest.mark.parametrize("params,f,a,step,changes", REGIME_EDGES)
def test_velocity_kinks_at_regime_edges_are_orbits_of_the_reference(params, f, a, step,
                                                                    changes):
    from mpmath import mp, mpf

    from study.kernels.budget import Budget
    from study.kernels.two_way import points
    from study.kernels.two_way.points import (
        OUT_DELTA,
        OUT_PERIOD,
        OUT_SPEED,
        OUT_STATUS,
        OUT_VELOCITY,
    )
    from study.solvers.structure_constants import structure_vector
    from tests.reference.two_way_exact import TwoWayModel, period_map

    s = Structure(**params)
    rows = []
    for ai in (a - step, a, a + step):
        out = np.empty(points.N_OUT)
        points.solve_point(structure_vector(s, "two-way"), 2.0 * math.pi * f, ai,
                           bool(ai > lift_off_acceleration(s, f)),
                           Budget(10_000, 5_000, 1e-3, 20_000), 0.0, 1.0,
                           out)
        assert Status(int(out[OUT_STATUS])) == Status.STICK_SLIP and out[OUT_PERIOD] == 1
        with mp.workdps(30):
            model = TwoWayModel(s, f, ai)
            z = tuple(mpf(float(x)) for x in out[OUT_DELTA:OUT_SPEED + 1])
            image = period_map(model, z)
            residual = [float((image.state[i] - z[i]) / model.scale[i]) for i in range(3)]
            velocity = float(image.dx * f)
        np.testing.assert_allclose(residual, 0.0, atol=1e-13)
        np.testing.assert_allclose(out[OUT_VELOCITY], velocity, rtol=0.0,
                                   atol=1e-13 * _scale(f, ai))
        assert float(_solve(s, f, ai).velocity) == out[OUT_VELOCITY]
        rows.append(out)
    below, tip, above = rows
    # a V: the tip stands out of both neighbours, on the same side
    assert (tip[2] - below[2]) * (tip[2] - above[2]) > 0.0
    column = 4 if changes == "forward" else 5
    fractions = [below[column], tip[column], above[column]]
    # the slip fraction that changes is not linear across the kink (a regime edge)
    assert abs(fractions[2] - 2.0 * fractions[1] + fractions[0]) > 1e-3, fractions
