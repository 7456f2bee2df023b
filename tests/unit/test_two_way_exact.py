"""The exact two-way solver (``steady_state(..., coupling="two-way")``) against references.

* every cached 40-digit point of ``tests/reference/two_way_exact.py``: status, mean
  velocity, Floquet multiplier, slip statistics;
* the orbit kernel run with ``coupling="one-way"`` (the paper's model with the mode as a
  state) against the exact one-way solver, on a random sample of structures;
* the mirror symmetry ``alpha -> -alpha``: ``v -> -v``, same status;
* the limit ``M -> 0`` (two-way -> one-way, with a relative difference ~ M);
* refused arguments.

Velocity conditioning
---------------------
The natural velocity scale of a point is ``a / w`` (the table's velocity amplitude): the
slips' speeds are of that order, and the mean velocity is the small difference of their
displacements. Rounding therefore leaves an absolute error of a few ``eps a / w``
whatever ``v``; a relative accuracy only means something where ``|v|`` is not itself a
rounding-sized remainder. The cached points are asked for ``|dv| <= 1e-13 a / w``
always, and ``|dv| <= 1e-12 |v|`` where ``|v| >= 1e-6 a / w``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.kernels.budget import Budget
from study.kernels.two_way import attractors as attractor_kernel
from study.kernels.two_way import modes, newton, orbit, points
from study.kernels.two_way.points import (
    OUT_BACKWARD,
    OUT_DELTA,
    OUT_FORWARD,
    OUT_MULTIPLIER,
    OUT_PERIOD,
    OUT_SPEED,
    OUT_STATUS,
    OUT_VELOCITY,
)
from study.model import lift_off_acceleration, thresholds
from study.model.status import INVALID_STATUSES, Status
from study.model.structure import Structure, tilt_warnings
from study.solvers.attractors import attractors
from study.solvers.exact import steady_state, steady_velocity
from study.solvers.structure_constants import structure_vector
from tests.reference.two_way_exact import reference_points

POINTS = reference_points()
NAMES = [p["name"] for p in POINTS]
BY_NAME = {p["name"]: p for p in POINTS}

# Velocity accuracy on the cached points (see the module docstring).
ABS_TOLERANCE = 1e-13  # of a / w
REL_TOLERANCE = 1e-12
REL_FLOOR = 1e-6  # of a / w: below it only the absolute bound applies
# The multiplier is the spectral radius of the Jacobian at the last Newton iterate, which
# lies within the last Newton step (<= NEWTON_STEP = 1e-7, scaled) of the fixed point:
# the multiplier is good to about that, relative (README, "Two-way coupling, exact").
FLOQUET_TOLERANCE = 1e-6
# At the fixed point itself the Jacobian's multiplier is the reference's to rounding.
FLOQUET_AT_FIXED_POINT = ("paper-14.5-6", "near-paradox")


def _scale(f: float, a: float) -> float:
    return a / (2.0 * math.pi * f)


def _two_way(point: dict):
    return steady_state(point["structure"], point["f"], point["a"], coupling="two-way",
                        parallel=False)


# --- the cached 40-digit reference points ---------------------------------------------


@pytest.mark.parametrize("name", NAMES)
def test_cached_point_status_and_velocity(name):
    p = BY_NAME[name]
    r = _two_way(p)
    status = Status(int(r.status))
    assert status.name == p["status"], (status.name, p["status"])
    v = float(r.velocity)
    if status in INVALID_STATUSES:
        assert math.isnan(v)
        assert math.isnan(float(r.floquet_multiplier))
        assert int(r.orbit_period) == 0
        return
    # The exact decimal string, not its float rounding, is the yardstick.
    exact = float(p["velocity_text"])
    scale = _scale(p["f"], p["a"])
    err = abs(v - exact)
    assert err <= ABS_TOLERANCE * scale, (v, p["velocity_text"], err / scale)
    if abs(exact) >= REL_FLOOR * scale:
        assert err <= REL_TOLERANCE * abs(exact), (v, p["velocity_text"], err / abs(exact))
    if status == Status.STATIC:
        assert v == 0.0
        assert float(r.slips_per_period) == 0.0
    else:
        assert int(r.orbit_period) == p["orbit_period"]
        assert float(r.slips_per_period) == p["slips_per_period"]
        assert_allclose(float(r.forward_fraction), p["forward_fraction"], rtol=0, atol=1e-10)
        assert_allclose(float(r.backward_fraction), p["backward_fraction"], rtol=0, atol=1e-10)


@pytest.mark.parametrize(
    "name",
    [
        n
        for n in NAMES
        if BY_NAME[n]["status"] not in ("LIFT_OFF", "FRICTION_PARADOX", "NOT_CONVERGED")
    ],
)
def test_cached_point_floquet_multiplier(name):
    p = BY_NAME[name]
    r = _two_way(p)
    assert abs(float(r.floquet_multiplier) - p["floquet"]) <= FLOQUET_TOLERANCE, (
        float(r.floquet_multiplier), p["floquet"])


def test_floquet_multiplier_at_the_fixed_point_is_the_reference_one():
    """The Jacobian of the period map re-taken AT the returned fixed point does give the
    reference's multiplier to rounding: the saltation matrices are right."""
    for name in FLOQUET_AT_FIXED_POINT:
        p = BY_NAME[name]
        s, f, a = p["structure"], p["f"], p["a"]
        vector = structure_vector(s, "two-way")
        omega = 2.0 * math.pi * f
        out = np.empty(points.N_OUT)
        points.solve_point(vector, omega, a, False, Budget(10_000, 5_000, 1e-3, 20_000), 0.0,
                           1.0, out)
        table = np.zeros((3, modes.N_MODE))
        modes.mode_table(vector, omega, a, table)
        z = out[OUT_DELTA:OUT_SPEED + 1].copy()
        jac = np.eye(3)
        acc = np.zeros(orbit.N_ACC)
        grad = np.zeros((3, 3))
        flag = orbit.run(modes.DrivePoint(vector, table, omega, a), z, 0.0,
                         int(out[OUT_PERIOD]) * 2 * math.pi / omega,
                         orbit.PassRecord(acc, jac, grad, np.zeros(2)), True, -1.0, 10_000)
        assert flag == orbit.RUN_OK
        assert abs(newton.spectral_radius(jac) - p["floquet"]) <= 1e-13


# --- the kernel's one-way mode against the exact one-way solver ----------------------


def _kernel_point(structure: Structure, f: float, a: float, coupling: str) -> np.ndarray:
    """The orbit kernel's output row at one point (see ``orbit.solve_point``)."""
    out = np.empty(points.N_OUT)
    lifted = bool(a > lift_off_acceleration(structure, f))
    points.solve_point(structure_vector(structure, coupling), 2.0 * math.pi * f, a, lifted,
                       Budget(10_000, 5_000, 1e-3, 20_000), 0.0, 1.0, out)
    return out


def _random_structure(rng: np.random.Generator, q_max: float = 1e3) -> Structure:
    """Q log-uniform 0.5..q_max; half the masses within 1e-6..1e-1 of 1 (continuous
    sliding); half the ck below cs (down to cs / 100)."""
    q = 10.0 ** rng.uniform(math.log10(0.5), math.log10(q_max))
    if rng.uniform() < 0.5:
        m = rng.uniform(0.01, 1.0)
    else:
        m = 1.0 - 10.0 ** rng.uniform(-6.0, -1.0)
    cs = rng.uniform(0.05, 1.0)
    ck = cs if rng.uniform() < 0.5 else cs * rng.uniform(0.01, 1.0)
    with tilt_warnings(False):  # small tilts are part of the space, in degree
        return Structure(f0=14.44, Q=q, alpha=rng.uniform(-85.0, 85.0), M=m, cs=cs, ck=ck)


def _random_point(rng: np.random.Generator, q_max: float = 1e3):
    """A structure, f log-uniform over 0.1..10 f0 and a over 0.8..3 times the lowest
    release threshold."""
    s = _random_structure(rng, q_max)
    f = s.f0 * 10.0 ** rng.uniform(-1.0, 1.0)
    a = float(min(thresholds(s, f))) * rng.uniform(0.8, 3.0)
    return s, f, a


# Kernel's acceptance of a fixed point: the last pass must close to FINAL_TOLERANCE
# (scaled), which leaves the state up to FINAL_TOLERANCE / (1 - rho) off and the
# velocity about as far off in units of a / w. Observed ratio error / allowance <= 1.
def _kernel_allowance(rho: float) -> float:
    return newton.NEWTON_TOLERANCE / max(1.0 - rho, 1e-6)


def test_one_way_mode_of_the_kernel_is_the_exact_one_way_solver():
    """400 random points: same status; ``|dv| <= 1e-12 |v| + 1e-13 a / w`` plus the kernel's
    documented acceptance ``NEWTON_TOLERANCE / (1 - rho) a / w`` (only continuous-sliding
    points have needed it; the sliding test below checks them against the reference)."""
    rng = np.random.default_rng(20240611)
    seen = set()
    needed_allowance = 0
    for _ in range(400):
        s, f, a = _random_point(rng)
        exact = steady_state(s, f, a, coupling="one-way", parallel=False)
        out = _kernel_point(s, f, a, "one-way")
        st_exact, st_kernel = Status(int(exact.status)), Status(int(out[OUT_STATUS]))
        where = (s, f, a)
        assert st_kernel == st_exact, (where, st_exact, st_kernel)
        seen.add(st_exact)
        v_exact, v_kernel = float(exact.velocity), out[OUT_VELOCITY]
        if st_exact in INVALID_STATUSES:
            assert math.isnan(v_exact) and math.isnan(v_kernel), where
            continue
        scale = _scale(f, a)
        err = abs(v_kernel - v_exact)
        tight = 1e-12 * abs(v_exact) + 1e-13 * scale
        if err > tight:
            needed_allowance += 1
            assert st_exact == Status.CONTINUOUS_SLIDING, (where, err / scale)
            rho = out[OUT_MULTIPLIER]
            assert err <= tight + _kernel_allowance(rho) * scale, (where, err / scale, rho)
    assert {Status.STATIC, Status.STICK_SLIP, Status.CONTINUOUS_SLIDING} <= seen
    assert needed_allowance <= 8  # observed: 12 of 10 000 points on other seeds


@pytest.mark.parametrize(
    ("params", "f", "a", "v_reference"),
    [
        (dict(Q=3.5269141174095204, alpha=25.679289662093325, M=0.999921823216287,
              cs=0.4997066183933994, ck=0.06509092039674007),
         55.4325842848501, 18.15666205782768, -0.0039956412637890786),
        (dict(Q=213.3247836879195, alpha=26.222053649649354, M=0.7674353179212096,
              cs=0.22776918358249776, ck=0.010401725959116434),
         22.13777079677899, 7.105704881541038, -1.62447361979521e-05),
    ],
    ids=["sliding-rho-0.79", "sliding-rho-0.99"],
)
def test_one_way_kernel_sliding_to_float_accuracy(params, f, a, v_reference):
    """``v_reference``: ``reference_orbit(..., coupling="one-way", dps=30)``. Newton moves
    the statistics to the fixed point by its last step, so slowly attracting sliding
    orbits (multiplier 0.99) are as accurate as the others."""
    s = Structure(f0=14.44, **params)
    out = _kernel_point(s, f, a, "one-way")
    assert Status(int(out[OUT_STATUS])) == Status.CONTINUOUS_SLIDING
    assert abs(out[OUT_VELOCITY] - v_reference) <= 1e-13 * abs(v_reference) + 1e-14 * _scale(f, a)


# --- mirror symmetry -----------------------------------------------------------------


def _start_contact_force(s: Structure, f: float, a: float) -> float:
    """``n`` at the canonical start (phase 0, mode on its steady stick response)."""
    w = 2.0 * math.pi * f
    k = (2.0 * math.pi * s.f0) ** 2
    response = a * math.cos(s.alpha_rad) / complex(k - w * w, w * math.sqrt(k) / s.Q)
    return s.g - a + s.M * math.cos(s.alpha_rad) * (-w * w * response).real


def test_mirror_symmetry_alpha_to_minus_alpha():
    """``alpha -> -alpha`` maps ``(delta, v, s)`` to ``(delta, -v, -s)`` exactly (the
    structure vector's sines change sign, nothing else): same status, ``v -> -v`` to a
    few ulps of ``a / w`` (observed 1.2e-15). Points whose canonical start is already
    off the table (``n(0) < 0``) are left to the test below."""
    rng = np.random.default_rng(7)
    moving = 0
    for _ in range(400):
        s, f, a = _random_point(rng)
        if _start_contact_force(s, f, a) < 0.0:
            continue
        with tilt_warnings(False):  # the mirror of a small tilt, in degree
            mirror = s.replace(alpha=-s.alpha)
        r1 = steady_state(s, f, a, coupling="two-way", parallel=False)
        r2 = steady_state(mirror, f, a, coupling="two-way", parallel=False)
        assert int(r1.status) == int(r2.status), (s, f, a, int(r1.status), int(r2.status))
        v1, v2 = float(r1.velocity), float(r2.velocity)
        if math.isnan(v1):
            assert math.isnan(v2)
            continue
        assert abs(v1 + v2) <= 1e-13 * _scale(f, a), (s, f, a, v1, v2)
        assert float(r1.forward_fraction) == pytest.approx(float(r2.backward_fraction),
                                                           abs=1e-12)
        moving += v1 != 0.0
    assert moving > 50


def test_mirror_symmetry_when_the_start_is_off_the_table():
    """Off the table at the start both release functions are positive: the larger one
    decides the contact, so the mirror image makes the mirror choice."""
    s = Structure(f0=14.44, Q=24.317570731315648, alpha=72.55239398331275,
                  M=0.9313633292979101, cs=0.8434510285408526)
    f, a = 134.55352196834204, 19.444033886088665
    assert _start_contact_force(s, f, a) < 0.0
    r1 = steady_state(s, f, a, coupling="two-way")
    r2 = steady_state(s.replace(alpha=-s.alpha), f, a, coupling="two-way")
    assert int(r1.status) == int(r2.status)


# --- M -> 0: two-way tends to one-way ----------------------------------------------


@pytest.mark.parametrize(
    ("f", "position", "alpha", "ck"),
    [(13.0, 0.5, 64.0, 0.25), (16.0, 0.7, 64.0, 0.25), (14.0, 0.5, -30.0, 0.1)],
)
def test_small_mass_limit_difference_scales_like_M(f, position, alpha, ck):
    """At a fixed relative position in the motion window ``a*(M) < a < a_lift(M)``
    (which closes onto ``g`` as ``M -> 0``), ``(v2 - v1) / (M v1)`` tends to a finite,
    nonzero constant: the two-way correction is first order in ``M``."""
    ratios = []
    for m in (1e-4, 1e-5, 1e-6):
        s = Structure(f0=14.44, Q=17.5, alpha=alpha, M=m, cs=0.25, ck=ck)
        low = float(min(thresholds(s, f)))
        lift = float(lift_off_acceleration(s, f))
        a = low + position * (lift - low)
        one = steady_state(s, f, a, coupling="one-way")
        two = steady_state(s, f, a, coupling="two-way")
        assert int(one.status) == int(two.status) == Status.STICK_SLIP
        v1, v2 = float(one.velocity), float(two.velocity)
        assert v1 != 0.0
        ratios.append((v2 - v1) / (m * v1))
    assert all(0.05 < abs(r) < 10.0 for r in ratios), ratios
    assert abs(ratios[1] / ratios[0] - 1.0) < 0.1, ratios
    assert abs(ratios[2] / ratios[1] - 1.0) < 0.01, ratios


# --- refused arguments -------------------------------------------------------------


@pytest.mark.parametrize(
    "call",
    [
        lambda s: steady_state(s, 13.0, 8.5, coupling="two_way"),
        lambda s: steady_velocity(s, 13.0, 8.5, coupling="two_way"),
        lambda s: attractors(s, 13.0, 8.5, coupling="two_way"),
        lambda s: structure_vector(s, "two_way"),
    ],
    ids=["steady_state", "steady_velocity", "attractors", "structure_vector"],
)
def test_coupling_typo_names_the_allowed_values(paper_structure, call):
    with pytest.raises(ValueError, match="two_way") as info:
        call(paper_structure)
    assert "'one-way'" in str(info.value) and "'two-way'" in str(info.value)


def test_two_way_refuses_bad_points(paper_structure):
    with pytest.raises(ValueError):
        steady_state(paper_structure, -13.0, 8.5, coupling="two-way")
    with pytest.raises(ValueError):
        steady_state(paper_structure, 13.0, -1.0, coupling="two-way")
    with pytest.raises(TypeError):
        steady_state({"f0": 14.44}, 13.0, 8.5, coupling="two-way")
    assert study.Structure is Structure


def test_every_start_reaches_the_same_orbit_near_a_kink_of_the_period_map():
    """(12.85 Hz, 6.5 m s^-2), just above the threshold: the orbit sticks across phase
    0, and from rest at phase 3/4 with the mode at twice its steady response Newton
    approaches it through states with a sliver of slip at phase 0. It once stopped there
    9e-4 off in velocity, and the multistability check counted two orbits."""
    s = Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f, a = 12.85, 6.5
    vector = structure_vector(s, "two-way")
    omega = 2.0 * math.pi * f
    canonical = _kernel_point(s, f, a, "two-way")
    out = np.empty(points.N_OUT)
    for phase in attractor_kernel.START_PHASES:
        for factor in attractor_kernel.START_FACTORS:
            points.solve_point(vector, omega, a, False, Budget(10_000, 5_000, 1e-3, 20_000),
                               phase / f, factor, out)
            assert Status(int(out[OUT_STATUS])) == Status.STICK_SLIP
            # v is 3.7e-6 a/w here: ill-conditioned, so compare in units of a/w (the
            # bad start was 3.3e-9 a/w off).
            gap = abs(out[OUT_VELOCITY] - canonical[OUT_VELOCITY])
            assert gap <= 1e-13 * _scale(f, a), (phase, factor)
    assert int(attractors(s, f, a, coupling="two-way").count) == 1


def test_an_orbit_crossing_phase_zero_in_a_sliver_of_slip_is_found():
    """(13.9 Hz, 4.4 m s^-2) at M = 1: the orbit is still sliding backward at phase 0 and
    stops 2.6e-7 periods later. Newton on the phase-0 map took that sliver for an
    approach to a stick, and the iterated map, which converges there, never had a
    Newton step accepted: NOT_CONVERGED (no periodic orbit) between neighbours that all
    have a stable orbit (multiplier 0.37). The cycle is now also sought on a section
    elsewhere in the period. The 30-digit reference's period map (independent code)
    confirms the fixed point and the velocity."""
    from mpmath import mp, mpf

    from tests.reference.two_way_exact import TwoWayModel, period_map

    s = Structure(f0=14.44, Q=17.5, alpha=64.0, M=1.0, cs=0.25)
    f, a = 13.9, 4.4
    out = _kernel_point(s, f, a, "two-way")
    assert Status(int(out[OUT_STATUS])) == Status.STICK_SLIP and out[OUT_PERIOD] == 1
    assert out[10] < 0.0  # the state reported at phase 0 is in a backward slip
    assert out[OUT_MULTIPLIER] < 0.5  # strongly attracting, as its neighbours
    with mp.workdps(30):
        model = TwoWayModel(s, f, a)
        z = tuple(mpf(float(x)) for x in out[OUT_DELTA:OUT_SPEED + 1])
        image = period_map(model, z)
        residual = [float((image.state[i] - z[i]) / model.scale[i]) for i in range(3)]
        velocity = float(image.dx * f)
        forward = float(image.forward_time * f)
        backward = float(image.backward_time * f)
    assert_allclose(residual, 0.0, atol=1e-12)
    assert_allclose(out[OUT_VELOCITY], velocity, rtol=1e-12, atol=0.0)
    assert_allclose(out[OUT_FORWARD:OUT_BACKWARD + 1], [forward, backward], rtol=1e-10, atol=0.0)
    found = attractors(s, f, a, coupling="two-way")
    assert int(found.count) == 1
    state = steady_state(s, f, a, coupling="two-way")
    assert Status(int(state.status)) == Status.STICK_SLIP
    assert float(state.velocity) == out[OUT_VELOCITY]
