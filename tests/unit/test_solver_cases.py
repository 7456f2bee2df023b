"""The exact solver on its difficult cases, against the 40-digit mpmath reference.

``tests/reference/one_way_exact.py`` re-derives the event-driven closed form in mpmath
(sharing no code with ``study``); it is exact to 40 digits, so every comparison
here is limited by float64 and the problem's own conditioning.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study import NonConvergence, SolverSettings, Status
from study.kernels import one_way as kernel
from study.model import codes, release_amplitudes, slip_amplitudes
from study.model.paper import PAPER_STRUCTURE as PAPER
from tests.reference.one_way_exact import exact_velocity

PARAMS = (PAPER["f0"], PAPER["Q"], PAPER["alpha"], PAPER["M"], PAPER["cs"])


def _exact(f, a, ck=None, params=PARAMS):
    value, status, _ = exact_velocity(*params, f, a, ck=ck)
    return float(value), status


@pytest.mark.parametrize(
    ("f", "a"),
    [(13.0, 8.5), (16.5, 8.5), (14.6, 7.0), (14.5, 6.0), (14.5, 9.0), (11.0, 9.0), (19.0, 9.5)],
)
def test_stick_slip_matches_40_digit_reference(paper_structure, f, a):
    v, status = study.steady_velocity(paper_structure, f, a)
    exact, exact_status = _exact(f, a)
    assert exact_status == "stick_slip" and status == Status.STICK_SLIP
    assert_allclose(v, exact, rtol=1e-13, atol=0)


@pytest.mark.parametrize("ck", [0.2, 0.1, 0.02])
@pytest.mark.parametrize(("f", "a"), [(13.0, 8.5), (14.6, 7.0), (16.5, 8.5)])
def test_kinetic_below_static_friction(paper_structure, ck, f, a):
    s = paper_structure.replace(ck=ck)
    v, status = study.steady_velocity(s, f, a)
    exact, exact_status = _exact(f, a, ck=ck)
    if exact_status == "continuous_sliding_unsupported":
        assert status == Status.CONTINUOUS_SLIDING
        return
    assert status == Status.STICK_SLIP
    assert_allclose(v, exact, rtol=1e-12, atol=0)


@pytest.mark.parametrize("sign", [+1, -1])
@pytest.mark.parametrize("f", [13.0, 14.3, 16.5])
def test_grazing_at_threshold(paper_structure, sign, f):
    """a = a*(1 -+ 1e-12): static exactly below; a vanishing, still exact, velocity above."""
    a_star = min(study.thresholds(paper_structure, f))
    below, above = a_star * (1 - 1e-12), a_star * (1 + 1e-12)
    v, status = study.steady_velocity(paper_structure, f, below)
    assert status == Status.STATIC and v == 0.0
    v, status = study.steady_velocity(paper_structure, f, above)
    assert status in (Status.STATIC, Status.STICK_SLIP)  # rounding decides at 1e-12
    assert abs(v) < 1e-12
    # Approaching the threshold the velocity vanishes continuously and stays exact
    # (relative condition number ~ 1/delta: allow 1e-15/delta).
    for delta in (1e-3, 1e-6, 1e-9):
        a = a_star * (1 + delta)
        v, status = study.steady_velocity(paper_structure, f, a)
        exact, _ = _exact(f, a)
        assert status == Status.STICK_SLIP
        assert_allclose(v, exact, rtol=max(1e-13, 1e-15 / delta), atol=0)


def _switching_acceleration(structure, f, sign):
    """Drive amplitude that puts phase 0 exactly on the switching surface s tau = cs n."""
    unit = release_amplitudes(structure, f, 1.0)[0 if sign > 0 else 1]
    return structure.cs * structure.g / unit.real


@pytest.mark.parametrize(("f", "sign"), [(13.0, +1), (14.2, +1), (15.3, -1), (16.5, -1)])
def test_start_exactly_on_switching_surface(paper_structure, f, sign):
    a = float(_switching_acceleration(paper_structure, f, sign))
    assert 0 < a < study.lift_off_acceleration(paper_structure, f)
    # The body starts at rest exactly where a slip criterion is zero.
    t0 = np.zeros(1)
    crit = sign * study.tangential_force(paper_structure, f, a, t0) - paper_structure.cs * (
        study.normal_force(paper_structure, f, a, t0)
    )
    assert abs(crit[0]) < 1e-14 * paper_structure.g
    v, status = study.steady_velocity(paper_structure, f, a)
    exact, exact_status = _exact(f, a)
    assert exact_status == "stick_slip" and status == Status.STICK_SLIP
    assert_allclose(v, exact, rtol=1e-12, atol=0)
    # And the orbit does not depend on which side of the surface rounding put phase 0.
    nudged, _ = study.steady_velocity(paper_structure, f, a * np.array([1 - 1e-15, 1 + 1e-15]))
    assert_allclose(nudged, v, rtol=1e-12)


def test_starting_phase_does_not_change_stick_slip_orbit(paper_structure):
    """After one stick the orbit forgets the start: solve from the two release phases."""
    f, a = 14.6, 7.0
    ap, am = release_amplitudes(paper_structure, f, a)
    bp, bm = slip_amplitudes(paper_structure, f, a)
    s = paper_structure
    k = kernel._constants(complex(ap), complex(am), complex(bp), complex(bm), s.cs * s.g,
                          s.ck * s.g)
    expected = study.steady_velocity(paper_structure, f, a)[0] * 2 * np.pi * f
    for start in np.linspace(0, 2 * np.pi, 13):
        wait, sign = kernel._next_release(start, 0, k)
        theta = start + wait
        # Run three releases-after-stick forward, measure the last period.
        marks = []
        distance = 0.0
        for _ in range(40):
            theta_next, sign_next, wait, _duration, moved, _ = kernel._advance(theta, sign, k)
            distance += sign * moved
            theta, sign = theta_next, sign_next
            if wait > 0:
                marks.append((theta, distance))
        (t1, d1), (t2, d2) = marks[-3], marks[-1]
        assert_allclose((d2 - d1) / (t2 - t1), expected, rtol=1e-12)


# Slowly attracting continuous sliding (map multiplier 0.9994 and similar): an
# earlier version closed these cycles first as 2 and 3 map iterations and reported
# those multiples as the orbit's period. Found by surveying random structures.
SLOW_CYCLE_A = (
    dict(f0=14.44, Q=747.9610884770862, alpha=24.4811237950245, M=0.8567953635433172,
         cs=0.24630808163619683, ck=0.025483767482620674),
    26.761095213194874, 3745.0964094888004,
)
SLOW_CYCLE_B = (
    dict(f0=1.0, Q=8.942021859330234, alpha=-28.6288029875571, M=0.8445792835541945,
         cs=1.5876920503220833, ck=0.02618166138461007),
    1.8165459949056075, 48.84867415419583,
)


def _long_run_velocity(s, f, a, transient=40_000, measured=40_000):
    """Second method: iterate the events (no cycle search, no Newton) and average."""
    ap, am = release_amplitudes(s, f, a)
    bp, bm = slip_amplitudes(s, f, a)
    k = kernel._constants(complex(ap), complex(am), complex(bp), complex(bm), s.cs * s.g,
                          s.ck * s.g)
    theta, sign = 0.0, kernel._next_release(0.0, 0, k)[1]
    for _ in range(transient):
        theta, sign = kernel._advance(theta, sign, k)[:2]
    while sign < 0:
        theta, sign = kernel._advance(theta, sign, k)[:2]
    start, distance = theta, 0.0
    for _ in range(measured):
        theta_next, sign_next, _, _, moved, _ = kernel._advance(theta, sign, k)
        distance += sign * moved
        theta, sign = theta_next, sign_next
    return distance / (theta - start) / (2 * np.pi * f)


@pytest.mark.parametrize(("params", "f", "a"), [SLOW_CYCLE_A, SLOW_CYCLE_B])
def test_slowly_attracting_sliding_cycles(params, f, a):
    """Cycles reported at their own period, velocity equal to a long plain iteration."""
    s = study.Structure(**params)
    result = study.steady_state(s, f, a)
    assert result.status == Status.CONTINUOUS_SLIDING
    assert result.orbit_period == 1
    assert result.slips_per_period == 2.0
    assert_allclose(result.velocity, _long_run_velocity(s, f, a), rtol=1e-6)


def test_budgets_flag_points_instead_of_guessing(paper_structure):
    params, f, a = SLOW_CYCLE_B
    s = study.Structure(**params)
    # A few map iterations cannot bring this slow transient near its cycle: the motion
    # is followed and averaged instead, a stable cycle longer than searched for
    # (quasi-periodic, its exponent clearly negative), its mean within its interval of
    # the cycle's velocity.
    cycle = study.steady_state(s, f, a)
    starved = study.steady_state(s, f, a, SolverSettings(max_map_iterations=3))
    assert starved.status == Status.QUASI_PERIODIC
    assert starved.lyapunov_exponent + 3.0 * starved.lyapunov_error < 0.0
    assert abs(starved.velocity - cycle.velocity) <= 4.0 * starved.velocity_error + 1e-3 * (
        a / (2.0 * np.pi * f))
    # With the averaging starved too (a tolerance it cannot reach in its least budget):
    # flagged, its partial mean kept, no velocity.
    starved = study.steady_state(s, f, a, SolverSettings(
        max_map_iterations=3, velocity_tolerance=1e-7, max_average_periods=256))
    assert starved.status == Status.NOT_CONVERGED
    assert starved.reason == NonConvergence.AVERAGE_BUDGET
    assert np.isnan(starved.velocity)
    assert np.isfinite(starved.averaged_velocity)
    starved = study.steady_state(paper_structure, 14.6, 7.0, SolverSettings(max_events=1))
    assert starved.status == Status.NOT_CONVERGED
    assert starved.reason == NonConvergence.EVENT_BUDGET
    assert np.isnan(starved.velocity)


@pytest.mark.parametrize("bad", [0, -5, 2.5, "10", True])
@pytest.mark.parametrize("name", ["max_events", "max_map_iterations"])
def test_bad_solver_settings_are_refused(name, bad):
    with pytest.raises(ValueError, match=f"'{name}' must be an integer >= 1"):
        SolverSettings(**{name: bad})


def test_status_codes_mirror_kernel_constants():
    # The exact kernel never returns FRICTION_PARADOX (a two-way coupling outcome).
    assert [s.value for s in Status][:5] == [
        kernel.STATIC, kernel.STICK_SLIP, kernel.CONTINUOUS_SLIDING, kernel.LIFT_OFF,
        kernel.NOT_CONVERGED,
    ]
    assert Status.FRICTION_PARADOX.value == 5
    assert [r.value for r in NonConvergence] == [
        kernel.REASON_NONE, kernel.REASON_NO_PERIODIC_ORBIT, kernel.REASON_EVENT_BUDGET,
        codes.REASON_AVERAGE_BUDGET,
    ]


def test_parallel_serial_and_threaded_calls_agree(paper_structure):
    """Parallel kernel, serial kernel and concurrent Python threads give identical bits."""
    f = np.linspace(10, 20, 97)[:, None]
    a = np.linspace(0, 12, 61)
    big = study.steady_state(paper_structure, f, a)  # 5917 points: parallel kernel
    assert big.velocity.size >= 2048
    pieces = [study.steady_state(paper_structure, f[i : i + 1], a) for i in range(f.shape[0])]
    np.testing.assert_array_equal(np.concatenate([p.velocity for p in pieces]), big.velocity)
    results = {}

    def work(key):
        results[key] = study.steady_velocity(paper_structure, f, a)[0]

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    np.testing.assert_array_equal(results[0], big.velocity)
    np.testing.assert_array_equal(results[1], big.velocity)


def test_broadcasting_shapes(paper_structure):
    v, status = study.steady_velocity(paper_structure, np.full((3, 1), 14.0), np.ones((1, 4)))
    assert v.shape == status.shape == (3, 4)
    v, status = study.steady_velocity(paper_structure, 14.0, 2.0)
    assert v.shape == status.shape == ()
