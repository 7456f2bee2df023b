"""Self-checks of ``tests/reference/two_way_exact.py``, the 40-digit two-way reference.

The reference is the yardstick of the fast two-way solver, so it is checked here
against things that do not share its code:

* its equations against the integrator kernel's ``_accelerations`` (two-way) and its
  closed forms against the ODE they solve (residuals at 40 digits, under-, critically
  and over-damped), its slip displacement against quadrature;
* with the coupling switched off, against the independent 40-digit one-way reference
  (``tests/reference/one_way_exact.py``) and the exact float solver ``study.steady_velocity``;
* with two-way coupling, against the time integrator ``study.solvers.integrator`` (converging to
  the reference as its tolerance is tightened), and 40 against 60 digits;
* its Floquet multipliers against the mode's free decay (one-way, where the slips do
  not act on the mode);
* the cached points (``tests/reference/data/two_way_reference.json``) against a regeneration.
"""

from __future__ import annotations

import json
import math

import mpmath
import numpy as np
import pytest
from mpmath import mp, mpf
from numpy.testing import assert_allclose

import study
from study.kernels.integrator import _accelerations
from study.model.paper import PAPER_STRUCTURE as PAPER
from study.model.status import Status
from study.model.structure import Structure
from study.solvers.integrator import IntegratorSettings, integrated_steady_state, model_parameters
from tests.reference.one_way_exact import exact_velocity
from tests.reference.two_way_exact import (
    CACHE_DPS,
    CACHE_PATH,
    CODE_VERSION,
    POINTS,
    STATUSES,
    TwoWayModel,
    generate_reference_points,
    period_map,
    reference_orbit,
    reference_points,
    segment_forms,
)

PAPER_ARGS = (PAPER["f0"], PAPER["Q"], PAPER["alpha"], PAPER["M"], PAPER["cs"])


# --- equations and closed forms -------------------------------------------------------


@pytest.mark.parametrize(
    "changes",
    [{}, {"M": 0.9, "alpha": 45.0}, {"M": 0.6, "ck": 0.15}, {"M": 0.985, "alpha": 80.0}],
)
def test_accelerations_match_the_integrator_kernel(paper_structure, changes):
    """``(delta'', x'')`` of every contact mode, against the kernel's two-way form."""
    s = paper_structure.replace(**changes)
    p = model_parameters(s, "two-way")
    rng = np.random.default_rng(7)
    f, a = 14.5, 7.0
    with mp.workdps(40):
        _check_accelerations(TwoWayModel(s, f, a), p, rng)


def _check_accelerations(model, p, rng):
    f, a = model.f_float, model.a_float
    for _ in range(20):
        t = rng.uniform(0, 1 / f)
        y = np.array([rng.normal(0, 1e-3), rng.normal(0, 0.1), 0.0, 0.0])
        drive = a * math.cos(2 * math.pi * f * t)
        for mode in (0, 1, -1):
            dd, xdd = model.accelerations(mode, mpf(t), mpf(y[0]), mpf(y[1]))
            k_dd, k_xdd = _accelerations(p, mode, drive, y)
            assert_allclose([float(dd), float(xdd)], [k_dd, k_xdd], rtol=1e-12, atol=1e-13)
            # The segment's closed forms start from the same accelerations.
            v0 = mpf(0) if mode == 0 else mpf(mode) * mpf("0.01")
            seg, forms = segment_forms(model, mode, mpf(t), (mpf(y[0]), mpf(y[1]), v0))
            assert abs(seg.value(forms["accel"], mpf(0)) - dd) <= 1e-25 * (1 + abs(dd))
            if mode != 0:
                assert abs(seg.value(seg.derive(forms["v"]), mpf(0)) - xdd) <= 1e-25
                assert abs(seg.value(forms["v"], mpf(0)) - v0) <= 1e-30


@pytest.mark.parametrize(
    ("q", "kinds"),
    [(17.5, {"under"}), (0.5, {"critical", "over"}), (0.3, {"over"})],
)
def test_closed_forms_solve_the_equations(paper_structure, q, kinds):
    """Mode ODE, ``v' = x''``, ``n`` and ``tau`` hold along each segment to 35 digits."""
    s = paper_structure.replace(Q=q, M=0.5)
    with mp.workdps(40):
        model = TwoWayModel(s, 12.0, 6.0)
        seen = set()
        state = (mpf("1e-4"), mpf("-0.02"), mpf("0.003"))
        t0 = mpf("0.011")
        for mode in (0, 1, -1):
            v0 = mpf(0) if mode == 0 else mode * state[2]
            seg, forms = segment_forms(model, mode, t0, (state[0], state[1], v0))
            seen.add(seg.kind)
            deff, fa, f0 = model.mode_params(mode)
            for tau in (mpf(0), mpf("0.003"), mpf("0.05"), mpf("0.2")):
                d, r, acc = (seg.value(forms[k], tau) for k in ("delta", "rate", "accel"))
                # delta' is the derivative of delta (numerically).
                delta = forms["delta"]
                assert abs(mpmath.diff(lambda x, g=delta, sg=seg: sg.value(g, x), tau) - r) < 1e-30
                t = t0 + tau
                ode = deff * acc + model.c * r + model.k * d - fa * mpmath.cos(model.w * t) - f0
                assert abs(ode) < mpf(10) ** -34 * (abs(fa) + model.k * abs(d))
                drive = model.a * mpmath.cos(model.w * t)
                n = model.g - drive + model.M * model.ca * acc
                assert abs(seg.value(forms["n"], tau) - n) < mpf(10) ** -35
                assert abs(seg.value(forms["tau"], tau) + model.M * model.sa * acc) < 1e-35
                if mode:
                    # Un-eliminated slip law: x'' = tau - s ck n, and delta'' = F - x'' sin.
                    xdd = seg.value(seg.derive(forms["v"]), tau)
                    assert abs(xdd - (-model.M * model.sa * acc - mode * model.ck * n)) < 1e-33
                    forcing = drive * model.ca - model.c * r - model.k * d
                    assert abs(acc - (forcing - xdd * model.sa)) < 1e-33
    assert seen == kinds


def test_slip_displacement_is_the_integral_of_v(paper_structure):
    with mp.workdps(40):
        model = TwoWayModel(paper_structure.replace(M=0.5), 14.0, 7.0)
        seg, forms = segment_forms(model, 1, mpf("0.02"), (mpf("1e-4"), mpf("0.01"), mpf("0.005")))
        tau = mpf("0.031")
        quad = mpmath.quad(lambda x: seg.value(forms["v"], x), [0, tau / 2, tau])
        assert abs(seg.integral(forms["v"], tau, forms["v_hom"]) - quad) < mpf(10) ** -36


# --- one-way limit: the coupling switched off -----------------------------------------

ONE_WAY_POINTS = [
    (13.0, 8.5, None, 1e-14),
    (16.5, 8.5, None, 1e-14),
    (14.6, 7.0, None, 1e-13),  # float solver's conditioning: observed 3e-14
    pytest.param(14.5, 6.0, None, 1e-13, marks=pytest.mark.slow),
    pytest.param(14.5, 9.0, None, 1e-13, marks=pytest.mark.slow),
    pytest.param(11.0, 9.0, None, 1e-14, marks=pytest.mark.slow),
    pytest.param(19.0, 9.5, None, 1e-14, marks=pytest.mark.slow),
    pytest.param(14.0, 7.0, 0.2, 1e-14, marks=pytest.mark.slow),
    pytest.param(14.6, 7.0, 0.1, 1e-14, marks=pytest.mark.slow),
]


@pytest.mark.parametrize(("f", "a", "ck", "rtol"), ONE_WAY_POINTS)
def test_one_way_matches_the_exact_solvers(paper_structure, f, a, ck, rtol):
    """Coupling off: the 40-digit one-way reference to 1e-30, the float solver to rtol."""
    s = paper_structure if ck is None else paper_structure.replace(ck=ck)
    r = reference_orbit(s, f, a, coupling="one-way")
    exact, status, _ = exact_velocity(*PAPER_ARGS, f, a, ck=ck)
    assert r.status == "STICK_SLIP" == status.upper()
    with mp.workdps(40):
        assert abs(r.velocity - exact) <= mpf(10) ** -30 * abs(exact)
    v, code = study.steady_velocity(s, f, a)
    assert code == Status.STICK_SLIP
    assert_allclose(v, float(r.velocity), rtol=rtol, atol=0)
    # The slips do not act on the mode: the multipliers are its free decay per period.
    with mp.workdps(40):
        decay = mpmath.exp(-mp.pi * mpf(PAPER["f0"]) / (mpf(PAPER["Q"]) * mpf(f)))
        assert abs(r.floquet - decay) < mpf(10) ** -20


def test_one_way_statuses(paper_structure):
    assert reference_orbit(paper_structure, 13.0, 5.0, coupling="one-way").status == "STATIC"
    assert study.steady_velocity(paper_structure, 13.0, 5.0)[1] == Status.STATIC
    # One-way lift-off at 14.5 Hz from a = 9.826; two-way already at 9.8 (test_outside_the_model).
    lifted = reference_orbit(paper_structure, 14.5, 9.85, coupling="one-way")
    assert lifted.status == "LIFT_OFF" and math.isnan(lifted.velocity)
    assert study.steady_velocity(paper_structure, 14.5, 9.85)[1] == Status.LIFT_OFF
    below = reference_orbit(paper_structure, 14.5, 9.8, coupling="one-way")
    assert below.status == "STICK_SLIP"
    assert study.steady_velocity(paper_structure, 14.5, 9.8)[1] == Status.STICK_SLIP


@pytest.mark.slow
@pytest.mark.parametrize("q", [0.5, 2.0])
def test_one_way_low_q(paper_structure, q):
    """Critically (Q = 0.5: stick mode) and over-damped slips, against both solvers."""
    s = paper_structure.replace(Q=q, M=0.3)
    f = 30.0
    a = 1.2 * min(study.thresholds(s, f))
    r = reference_orbit(s, f, a, coupling="one-way")
    exact, _, _ = exact_velocity(PAPER["f0"], q, PAPER["alpha"], 0.3, PAPER["cs"], f, a)
    with mp.workdps(40):
        assert abs(r.velocity - exact) <= mpf(10) ** -30 * abs(exact)
    assert_allclose(study.steady_velocity(s, f, a)[0], float(r.velocity), rtol=1e-14)


# --- two-way: against the time integrator ---------------------------------------------


@pytest.mark.parametrize(
    ("f", "a", "slips"), [(13.0, 8.5, 1), (14.5, 6.0, 2), (14.5, 9.0, 2), (16.5, 8.5, 1)]
)
def test_two_way_matches_the_integrator(paper_structure, f, a, slips):
    """Agreement within the integrator's accuracy (observed 1e-10 at tolerance 1e-12)."""
    r = reference_orbit(paper_structure, f, a)
    st = integrated_steady_state(
        paper_structure, f, a, coupling="two-way",
        settings=IntegratorSettings(tolerance=1e-12), parallel=False,
    )
    assert r.status == "STICK_SLIP" and st.status == Status.STICK_SLIP
    assert r.orbit_period == 1 and r.slips_per_period == slips == st.slips_per_period
    assert_allclose(float(st.velocity), float(r.velocity), rtol=2e-9, atol=0)
    assert_allclose(
        [float(r.forward_fraction), float(r.backward_fraction)],
        [float(st.forward_fraction), float(st.backward_fraction)], rtol=1e-7, atol=1e-12,
    )
    assert 0 < r.floquet < 0.9
    assert r.approach < 1e-2  # the canonical start is attracted to this orbit


def test_two_way_reverses_the_one_way_direction(paper_structure):
    """(14.5 Hz, 9 m s-2): one-way goes backward, two-way forward at +2.7455 mm s-1."""
    two = reference_orbit(paper_structure, 14.5, 9.0)
    one = reference_orbit(paper_structure, 14.5, 9.0, coupling="one-way")
    assert_allclose(float(two.velocity), 2.7455215736682266e-3, rtol=1e-15)
    assert_allclose(float(one.velocity), -7.5307752666179388e-3, rtol=1e-15)


@pytest.mark.slow
def test_integrator_converges_to_the_reference(paper_structure):
    """The integrator's error falls with its tolerance, towards the reference's value."""
    f, a = 14.5, 9.0
    ref = float(reference_orbit(paper_structure, f, a).velocity)
    errors = []
    for tol in (1e-10, 1e-11, 1e-12, 1e-13):
        st = integrated_steady_state(
            paper_structure, f, a, coupling="two-way",
            settings=IntegratorSettings(tolerance=tol), parallel=False,
        )
        errors.append(abs(float(st.velocity) / ref - 1))
    assert errors[-1] < 1e-9 and errors[-1] < errors[0] / 30, errors


def test_forty_against_sixty_digits(paper_structure):
    """The near-reversal point (small velocity, most cancellation) at two precisions."""
    r40 = reference_orbit(paper_structure, 14.6, 7.0, dps=40)
    r60 = reference_orbit(paper_structure, 14.6, 7.0, dps=60)
    with mp.workdps(60):
        assert abs(r40.velocity / r60.velocity - 1) < mpf(10) ** -32
        assert abs(r40.floquet - r60.floquet) < mpf(10) ** -12  # finite-difference Jacobian


def test_orbit_is_a_fixed_point_of_the_period_map(paper_structure):
    r = reference_orbit(paper_structure, 16.5, 8.5)
    with mp.workdps(r.dps):
        model = TwoWayModel(paper_structure, 16.5, 8.5)
        once = period_map(model, r.state)
        twice = period_map(model, r.state, 2)
        for z in (once.state, twice.state):
            for i in range(3):
                assert abs(z[i] - r.state[i]) <= mpf(10) ** -34 * model.scale[i]
        assert abs(twice.dx - 2 * once.dx) < mpf(10) ** -36
        assert abs(once.dx / model.T - r.velocity) < mpf(10) ** -36


def test_outside_the_model(paper_structure):
    paradox = reference_orbit(paper_structure.replace(alpha=80.0, M=1.0), 14.0, 2.0)
    assert paradox.status == "FRICTION_PARADOX" and math.isnan(paradox.velocity)
    lifted = reference_orbit(paper_structure, 14.5, 9.8)
    assert lifted.status == "LIFT_OFF" and math.isnan(lifted.velocity)
    for status in ("FRICTION_PARADOX", "LIFT_OFF", "STATIC", "STICK_SLIP"):
        assert status in STATUSES and Status[status].name == status
    with pytest.raises(ValueError, match="coupling"):
        TwoWayModel(paper_structure, 13.0, 8.5, coupling="three-way")


# --- cached points ----------------------------------------------------------------------


def test_cache_file_is_current():
    content = json.loads(CACHE_PATH.read_text())
    assert content["code_version"] == CODE_VERSION and content["dps"] == CACHE_DPS
    assert [e["name"] for e in content["points"]] == [p[0] for p in POINTS]
    points = reference_points()
    assert len(points) >= 10
    for p, (name, params, f, a, _) in zip(points, POINTS, strict=True):
        assert p["name"] == name and p["f"] == f and p["a"] == a
        assert p["structure"] == Structure(**params)
        assert p["status"] in STATUSES
        assert math.isnan(p["velocity"]) == (p["status"] in ("LIFT_OFF", "FRICTION_PARADOX"))
    statuses = {p["status"] for p in points}
    assert statuses >= {"STATIC", "STICK_SLIP", "CONTINUOUS_SLIDING", "LIFT_OFF",
                        "FRICTION_PARADOX"}


def _assert_entries_equal(fresh, cached):
    for key in ("name", "status", "orbit_period", "structure", "f", "a"):
        assert fresh[key] == cached[key], key
    for key in ("velocity", "floquet", "slips_per_period", "forward_fraction"):
        if cached[key] == "nan":
            assert fresh[key] == "nan"
            continue
        with mp.workdps(40):
            x, y = mpf(fresh[key]), mpf(cached[key])
            digits = 32 if key != "floquet" else 12  # floquet: finite-difference Jacobian
            assert abs(x - y) <= mpf(10) ** -digits * max(abs(y), mpf(10) ** -300), key


def test_cached_point_regenerates():
    cached = {e["name"]: e for e in json.loads(CACHE_PATH.read_text())["points"]}
    for fresh in generate_reference_points(["paper-13-8.5", "friction-paradox"]):
        _assert_entries_equal(fresh, cached[fresh["name"]])


@pytest.mark.slow
def test_all_cached_points_regenerate():
    cached = {e["name"]: e for e in json.loads(CACHE_PATH.read_text())["points"]}
    for fresh in generate_reference_points():
        _assert_entries_equal(fresh, cached[fresh["name"]])


@pytest.mark.slow
def test_cached_points_against_the_integrator():
    """Every cached point: same status, velocity within the integrator's accuracy."""
    for p in reference_points():
        st = integrated_steady_state(
            p["structure"], p["f"], p["a"], coupling="two-way",
            settings=IntegratorSettings(tolerance=1e-12), parallel=False,
        )
        assert Status(int(st.status)).name == p["status"], p["name"]
        if p["status"] in ("STICK_SLIP", "CONTINUOUS_SLIDING"):
            assert_allclose(float(st.velocity), p["velocity"], rtol=1e-7, atol=1e-12,
                            err_msg=p["name"])
            assert float(st.slips_per_period) == p["slips_per_period"], p["name"]
        elif p["status"] == "STATIC":
            assert float(st.velocity) == p["velocity"] == 0.0
