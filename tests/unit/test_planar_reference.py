"""The planar reference integrator, and the package's planar solver against it.

Part 1 checks ``tests/reference/planar.py`` (independent of ``study``) against things
that share nothing with its formulation:

* the onset direction of a slip, by its defining property;
* free slides without drive: the closed form for ``kappa = 1`` (the twist decays
  along a straight line at the rate ``ck g``) and for pure translation, and for
  ``kappa != 1`` the power-law solution ``b = b0 (a / a0)^kappa`` (``a`` the speed, ``b``
  the scaled spin), whose stop time, distance and rotation are 1-D quadratures:
  the twist direction turns all the way into the stop, the hard case of the stop
  detection;
* convergence studies in the stop threshold ``stop_tol`` (the accuracy parameter of
  the stop detection) and in ``rtol``;
* the exact reduction to the 1-D model (one plate along the heading, lever 0),
  compared with ``tests/reference/integrator.py``;
* brute-force integrations of the plain Cartesian slip equation (scipy's DOP853 and
  Radau) through a linear and a quadratic slip onset;
* mirror symmetry and rotation invariance.

Part 2 compares ``study.solvers.planar.simulate_planar`` with the reference: the 1-D
reduction, the paper's two-plate steering disk (forward, backward, turning, and a
frequency switch mid-run), symmetries, and the free-slide closed forms.

The steering disk (README, "Steering"): radius R = 0.02 m, cs = ck = 0.25; head plate
f0 = 14.44 Hz, Q = 17.5, alpha = 64 degree, M = 0.08, along the heading at (R, 0); tail
plate f0 = 8.5 Hz, Q = 10, alpha = 64 degree, M = 0.05, across the heading at (-R, 0).
"""

from __future__ import annotations

import itertools
import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.integrate import quad, solve_ivp

from tests.reference.integrator import Integrator, System
from tests.reference.planar import RefPlate, onset_direction, reference_planar

R, CS, G = 0.02, 0.25, 9.8
C = 2.0 * R / 3.0  # default friction length
RHO = R / math.sqrt(2.0)  # default gyration radius
HEAD = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "direction": 0.0, "attachment": (R, 0.0)}
TAIL = {"f0": 8.5, "Q": 10.0, "alpha": 64.0, "M": 0.05, "direction": 90.0, "attachment": (-R, 0.0)}
STEER = (HEAD, TAIL)
PKG_TOL = 1e-10  # tolerance of the package runs compared here
DONE = ("done", "completed")  # the package names a full run "completed", not "done"


# --- helpers -------------------------------------------------------------------------


def steady_modes(plates, f, a, phase=0.0):
    """Plate states ``(delta_1, delta_1', ...)`` on the steady response at ``t = 0``."""
    out = []
    for p in plates:
        w, w0 = 2.0 * math.pi * f, 2.0 * math.pi * p["f0"]
        amp = a * math.cos(math.radians(p["alpha"])) * complex(math.cos(phase), math.sin(phase))
        amp /= complex(w0 * w0 - w * w, w0 * w / p["Q"])
        out += [amp.real, (1j * w * amp).real]
    return np.array(out)


def initial_state(plates, f, a, pose=(0.0,) * 7):
    return np.concatenate((np.asarray(pose, float), steady_modes(plates, f, a)))


def mirrored(plates):
    """Plates reflected in the heading axis: beta -> -beta, r_left -> -r_left."""
    return tuple(
        dict(p, direction=-p["direction"], attachment=(p["attachment"][0], -p["attachment"][1]))
        for p in plates
    )


def deg(value):
    """An angle (or angular rate, or its tolerance) of the reference [rad] in the
    package's unit [degree]."""
    return np.degrees(value)


def ref(plates, freq, acc, dur, **kw):
    kw.setdefault("cs", CS)
    return reference_planar([RefPlate(**p) for p in plates], freq, acc, dur, g=G, radius=R, **kw)


# Drive scenarios of the steering disk: (frequencies, accelerations, durations, f of the
# steady initial modes). Output times: six, equally spaced up to the end.
SCENARIOS = {
    "forward": ([14.2], [7.0], [3 / 14.2], 14.2),
    "backward": ([15.2], [7.0], [3 / 15.2], 15.2),
    "turn": ([8.2], [7.0], [2 / 8.2], 8.2),
    "switch": ([14.2, 8.2], [7.0, 7.0], [2 / 14.2, 1.5 / 8.2], 14.2),
}
_REF_CACHE: dict = {}


def scenario(name):
    freq, acc, dur, f_init = SCENARIOS[name]
    times = np.linspace(0.0, sum(dur), 7)[1:]
    return freq, acc, dur, initial_state(STEER, f_init, acc[0]), times


def ref_scenario(name, rtol=1e-12):
    key = (name, rtol)
    if key not in _REF_CACHE:
        freq, acc, dur, init, times = scenario(name)
        _REF_CACHE[key] = ref(STEER, freq, acc, dur, initial_state=init, output_times=times,
                              rtol=rtol)
    return _REF_CACHE[key]


def ref_1d_period_ends(f, a, n_periods, mode0):
    """``x`` at the ends of the first drive periods from ``tests/reference/integrator.py``."""
    T = 1.0 / f
    sys_ = System(HEAD["f0"], HEAD["Q"], HEAD["alpha"], HEAD["M"], CS, CS, G, f, a)
    integ = Integrator(sys_, T, 1e-13, 1e-15, T / 64)
    y = [mode0[0], mode0[1], 0.0, 0.0]
    mode = integ.release_direction(0.0, y)
    fresh = mode != 0
    xs, x = [], 0.0
    for _ in range(n_periods):
        y, mode, fresh, _ = integ.period(y, mode, fresh)
        x += y[2]
        y[2] = 0.0
        xs.append(x)
    return np.array(xs)


def free_slide(speed, spin, kappa, c=C, ck=CS, g=G):
    """Free slide (no drive, ``n = g``) from speed ``a0`` and spin: stop time, distance
    along the initial velocity, rotation.

    With ``K = diag(1, 1, kappa)`` the speed ``a`` and the scaled spin ``b = c spin`` obey
    ``a' = -ck g a / r``, ``b' = -ck g kappa b / r``, ``r = |(a, b)|``: the velocity keeps
    its direction and ``b = b0 q^kappa``, ``q = a / a0``. Then ``dt = -(r / q) dq / (ck g)``:
    ``t_s = int_0^1 |(a0, b0 q^(kappa-1))| dq / (ck g)``,
    ``d = a0 int_0^1 r dq / (ck g)``, ``theta = b0 int_0^1 q^(kappa-1) r dq / (c ck g)``.
    """
    a0, b0 = speed, c * spin
    opts = {"epsabs": 0.0, "epsrel": 1e-13, "limit": 500}

    def r(q):
        return math.hypot(a0 * q, b0 * q**kappa)

    t_s = quad(lambda q: math.hypot(a0, b0 * q ** (kappa - 1.0)) if q > 0 else 0.0, 0.0, 1.0,
               **opts)[0] / (ck * g)
    d = a0 * quad(r, 0.0, 1.0, **opts)[0] / (ck * g)
    th = b0 * quad(lambda q: q ** (kappa - 1.0) * r(q) if q > 0 else 0.0, 0.0, 1.0,
                   **opts)[0] / (c * ck * g)
    return t_s, d, th


def stop_time(traj):
    return next(t for t, kind in traj.events if kind.startswith("stop"))


def free_state(v, spin, heading=0.0, n_plates=1):
    s = np.zeros(7 + 2 * n_plates)
    s[2], s[3], s[4], s[5] = heading, v[0], v[1], spin
    return s


# --- part 1: the reference ----------------------------------------------------------


finite = {"allow_nan": False, "allow_infinity": False}


@settings(max_examples=200, deadline=None, derandomize=True)
@given(
    w=st.tuples(*(st.floats(-1.0, 1.0, **finite),) * 3).filter(lambda v: np.linalg.norm(v) > 1e-3),
    excess=st.floats(0.0, 5.0, **finite),
    n=st.floats(0.1, 30.0, **finite),
    ck=st.floats(0.01, 2.0, **finite),
    kappa=st.floats(0.05, 20.0, **finite),
)
def test_onset_direction_definition(w, excess, n, ck, kappa):
    """|e| = 1, lambda >= 0 and K (W - ck n e) = lambda e for |W| >= ck n."""
    W = np.asarray(w) / np.linalg.norm(w) * ck * n * (1.0 + excess)
    e, lam = onset_direction(W, n, ck, kappa)
    K = np.array([1.0, 1.0, kappa])
    assert lam >= 0.0
    assert_allclose(np.linalg.norm(e), 1.0, rtol=0, atol=1e-14)
    scale = max(1.0, kappa) * np.linalg.norm(W)
    assert_allclose(K * (W - ck * n * e), lam * e, rtol=0, atol=1e-12 * scale)
    assert float(e @ W) > 0.0


def test_onset_direction_special_cases():
    W, n, ck = np.array([0.3, -0.4, 1.2]), 2.0, 0.25
    e, lam = onset_direction(W, n, ck, 1.0)  # kappa = 1: along W, rate |W| - ck n
    assert_allclose(e, W / np.linalg.norm(W), rtol=0, atol=1e-15)
    assert_allclose(lam, np.linalg.norm(W) - ck * n, rtol=1e-14)
    e, _ = onset_direction([0.3, -0.4, 0.0], n, ck, 0.3)  # no torque: pure translation
    assert e[2] == 0.0
    e, lam = onset_direction(W, n, ck=np.linalg.norm(W) / n, kappa=3.0)  # at ck n = |W|
    assert lam == 0.0
    assert_allclose(e, W / np.linalg.norm(W), rtol=0, atol=1e-15)


def test_reference_free_slide_kappa_one_closed_form():
    """kappa = 1: u(t) = u0 (1 - ck g t / |u0|) until |u0| / (ck g), then rest."""
    v, spin = (0.03, -0.02), 4.0
    u0 = np.array([v[0], v[1], C * spin])
    r0 = np.linalg.norm(u0)
    t_s = r0 / (CS * G)
    times = np.linspace(0.0, 1.5 * t_s, 13)
    tr = ref([HEAD], [14.0], [0.0], [times[-1]], initial_state=free_state(v, spin),
             output_times=times, gyration_radius=C)
    assert tr.outcome == "done"
    assert_allclose(stop_time(tr), t_s, rtol=1e-12)
    tt = np.minimum(times, t_s)
    decay = 1.0 - tt / t_s
    moved = tt - 0.5 * tt * tt / t_s  # int_0^t (1 - s / t_s) ds
    scale = r0 * t_s
    tol = 1e-12  # relative to the scales of the slide
    assert_allclose(tr.vx, np.where(times < t_s, u0[0] * decay, 0.0), rtol=0, atol=tol * r0)
    assert_allclose(tr.vy, np.where(times < t_s, u0[1] * decay, 0.0), rtol=0, atol=tol * r0)
    assert_allclose(tr.spin, np.where(times < t_s, spin * decay, 0.0), rtol=0,
                    atol=tol * r0 / C)
    assert_allclose(tr.x, u0[0] * moved, rtol=0, atol=tol * scale)
    assert_allclose(tr.y, u0[1] * moved, rtol=0, atol=tol * scale)
    assert_allclose(tr.heading, spin * moved, rtol=0, atol=tol * scale / C)
    assert_allclose(tr.path, math.hypot(*v) * moved, rtol=0, atol=tol * scale)


@pytest.mark.parametrize("gyration", [RHO, C / math.sqrt(2.0), C / math.sqrt(0.3)])
def test_reference_free_slide_pure_translation(gyration):
    """No spin: any kappa, stop at v0 / (ck g) after v0^2 / (2 ck g), no rotation."""
    v = (-0.012, 0.025)
    v0 = math.hypot(*v)
    tr = ref([HEAD], [14.0], [0.0], [0.05], initial_state=free_state(v, 0.0),
             output_times=[0.05], gyration_radius=gyration)
    assert_allclose(stop_time(tr), v0 / (CS * G), rtol=1e-12)
    d = v0 * v0 / (2.0 * CS * G)
    assert_allclose([tr.x[0], tr.y[0], tr.path[0]], [d * v[0] / v0, d * v[1] / v0, d],
                    rtol=1e-11)
    assert tr.heading[0] == 0.0


FREE_CASES = [
    (0.03, 5.0, 8.0 / 9.0),  # the default disk: kappa = (2R/3)^2 / (R^2/2)
    (0.001, 8.0, 8.0 / 9.0),  # mostly spin
    (0.02, -3.0, 0.5),  # kappa < 1: ends in pure spin
    (0.03, 5.0, 2.0),  # kappa > 1: ends in pure translation
    (0.001, 8.0, 2.0),
]


@pytest.mark.parametrize(("speed", "spin", "kappa"), FREE_CASES)
def test_reference_free_slide_power_law(speed, spin, kappa):
    """kappa != 1: the direction of the twist turns into the stop (power law)."""
    heading0, angle = 0.4, -2.1
    v = (speed * math.cos(angle), speed * math.sin(angle))
    t_s, d, th = free_slide(speed, spin, kappa)
    tr = ref([HEAD], [14.0], [0.0], [1.2 * t_s], output_times=[1.2 * t_s],
             initial_state=free_state(v, spin, heading0), gyration_radius=C / math.sqrt(kappa))
    assert_allclose(stop_time(tr), t_s, rtol=1e-12)
    assert_allclose([tr.x[0], tr.y[0], tr.path[0]],
                    [d * math.cos(angle), d * math.sin(angle), d], rtol=1e-11, atol=1e-16)
    assert_allclose(tr.heading[0] - heading0, th, rtol=1e-11)


def test_reference_stop_detection_converges_in_stop_tol():
    """Convergence study of the stop threshold on a slide whose twist turns into the
    stop: kappa = 8/9 ends in pure spin with e - e_stop ~ r^p, p = 1/kappa - 1 = 1/8,
    so the first-order completion from r_end leaves an error ~ r_end^(1+p).

    Measured (stop-time error vs quadrature): 1.3e-11 s at 1e-6, 7.3e-13 at 1e-7,
    4.5e-14 at 1e-8, then the noise floor ~4e-15 s from 1e-9 on (default 1e-14)."""
    speed, spin, kappa = 0.02, 3.0, 8.0 / 9.0
    t_s, d, th = free_slide(speed, spin, kappa)
    errors = []
    for stop_tol in (1e-6, 1e-7, 1e-8, 1e-14):
        tr = ref([HEAD], [14.0], [0.0], [0.1], output_times=[0.1], stop_tol=stop_tol,
                 initial_state=free_state((speed, 0.0), spin))
        errors.append(abs(stop_time(tr) - t_s))
        assert_allclose([tr.x[0], tr.heading[0]], [d, th], rtol=1e-11)
    e6, e7, e8, e14 = errors
    assert 5e-13 < e6 < 1e-10  # pre-asymptotic: the stop tolerance dominates
    assert e7 < e6 / 10.0 and e8 < e7 / 10.0  # order 1 + p = 1.125
    assert e14 < 2e-14  # default: at the integration noise, 2e-15 relative


def test_reference_stop_detection_converges_driven():
    """Same study on the driven steering disk (one drive period, two slips, the
    second one small and ending slowly): event times and poses against
    stop_tol = 1e-16.

    Measured, event times: 2.2e-10 s (stop_tol 1e-6), 3.6e-12 (1e-7), 3.1e-13 (1e-8),
    1.3e-15 (1e-10), 3e-16 (1e-14, the default); poses within 6e-17 m and 4e-15 rad
    throughout (a slip end barely moves the disk; its time matters for what follows)."""
    freq, acc, _, init, _ = scenario("forward")
    T = 1.0 / freq[0]
    runs = {}
    for stop_tol in (1e-6, 1e-8, 1e-14, 1e-16):
        tr = ref(STEER, freq, acc, [T], initial_state=init, output_times=[0.5 * T, T],
                 stop_tol=stop_tol)
        runs[stop_tol] = (np.array([t for t, _ in tr.events]), tr)
    best_t, best = runs[1e-16]
    err = {}
    for stop_tol, (times, tr) in runs.items():
        assert times.shape == best_t.shape
        err[stop_tol] = float(np.abs(times - best_t).max())
        assert_allclose(np.r_[tr.x, tr.y], np.r_[best.x, best.y], rtol=0, atol=1e-15)
        assert_allclose(tr.heading, best.heading, rtol=0, atol=1e-13)
    assert [kind for _, kind in best.events].count("stop_stick") == 2
    assert err[1e-6] > 1e-11  # the threshold is visible ...
    assert err[1e-8] < err[1e-6] / 100.0  # ... and converges at least quadratically
    assert err[1e-14] < 1e-14


def test_reference_converges_in_rtol():
    """Steering disk, three drive periods (six slips): rtol 1e-12 (the default, used
    everywhere here) against 1e-13. Measured: 7.4e-15 m in x, 6e-17 m in y,
    8.3e-15 rad in heading, 3e-14 rad s-1 in spin: 4e-12 of the motion."""
    a, b = ref_scenario("forward", 1e-12), ref_scenario("forward", 1e-13)
    assert_allclose(a.x, b.x, rtol=0, atol=5e-14)
    assert_allclose(a.y, b.y, rtol=0, atol=5e-14)
    assert_allclose(a.path, b.path, rtol=0, atol=5e-14)
    assert_allclose(a.heading, b.heading, rtol=0, atol=5e-14)
    assert_allclose(np.r_[a.vx, a.vy], np.r_[b.vx, b.vy], rtol=0, atol=5e-14)
    assert_allclose(a.spin, b.spin, rtol=0, atol=3e-13)


@pytest.mark.slow
def test_reference_convergence_table_in_rtol():
    """rtol 1e-9 .. 1e-12 against 1e-13 on the forward drive: about a decade per
    decade of rtol. Measured (max over x [m], y [m], heading [rad]): 5.9e-12, 6.5e-13,
    6.2e-14, 8.3e-15."""
    best = ref_scenario("forward", 1e-13)
    diffs = []
    for rtol in (1e-9, 1e-10, 1e-11, 1e-12):
        tr = ref_scenario("forward", rtol)
        diffs.append(max(np.abs(tr.x - best.x).max(), np.abs(tr.y - best.y).max(),
                         np.abs(tr.heading - best.heading).max()))
    assert diffs[0] < 5e-11
    assert diffs[-1] < 5e-14
    assert all(later < earlier / 3.0 for earlier, later in itertools.pairwise(diffs))


@pytest.mark.parametrize(("f", "a"), [(14.2, 7.0), (14.6, 7.0), (16.5, 8.5)])
def test_reference_reduces_to_1d_model(f, a):
    """One plate along the heading with lever 0 is the 1-D model along the heading:
    x at the period ends against tests/reference/integrator.py (forward, with
    reversals, backward). Measured: 6e-15, 3e-15, 1e-16 m (rtol 1e-12)."""
    n = 3
    T = 1.0 / f
    mode0 = steady_modes([HEAD], f, a)
    tr = ref([HEAD], [f], [a], [n * T], output_times=np.arange(1, n + 1) * T,
             initial_state=np.r_[np.zeros(7), mode0])
    x1 = ref_1d_period_ends(f, a, n, mode0)
    assert np.abs(x1).max() > 1e-5  # it moves
    assert_allclose(tr.x, x1, rtol=0, atol=1e-14)
    assert np.all(tr.y == 0.0) and np.all(tr.heading == 0.0) and np.all(tr.vy == 0.0)


def _cartesian(plates, f, a, c, kappa, ck):
    """The planar model written out independently, with the slip equation in plain
    Cartesian form ``u' = K (W - ck n u / |u|)``; state ``(x, y, theta, u, modes)``.

    Returns ``rhs(t, s)`` and ``wrench(t, s) -> (W, n)``."""
    w = 2.0 * math.pi * f
    P = [(2 * math.pi * p["f0"], p["Q"], math.radians(p["alpha"]), p["M"],
          math.radians(p["direction"]), p["attachment"]) for p in plates]
    K = np.array([1.0, 1.0, kappa])

    def forces(t, s):
        A = a * math.cos(w * t)
        fb, torque, n, rates = np.zeros(2), 0.0, G - A, []
        for i, (w0, Q, al, M, be, (rf, rl)) in enumerate(P):
            d, dd = s[6 + 2 * i], s[7 + 2 * i]
            F = A * math.cos(al) - w0 / Q * dd - w0 * w0 * d
            rates += [dd, F]
            tang = -M * math.sin(al) * F
            fb += tang * np.array([math.cos(be), math.sin(be)])
            torque += tang * (rf * math.sin(be) - rl * math.cos(be))
            n += M * math.cos(al) * F
        th = s[2]
        W = np.array([math.cos(th) * fb[0] - math.sin(th) * fb[1],
                      math.sin(th) * fb[0] + math.cos(th) * fb[1], torque / c])
        return W, n, rates

    def rhs(t, s):
        W, n, rates = forces(t, s)
        u = s[3:6]
        return np.r_[u[0], u[1], u[2] / c, K * (W - ck * n * u / np.linalg.norm(u)), rates]

    def wrench(t, s):
        return forces(t, s)[:2]

    return rhs, wrench


def test_reference_onsets_against_brute_force():
    """The first tenth of a period of two slips from rest, where the onset is stiff,
    against scipy's integrators on the plain Cartesian equation from a tiny seed (a
    seed of size s changes the result by up to ~s t):

    * at t = 0 (|W| > cs n, the twist grows linearly): DOP853, rtol 1e-13, seed
      1e-16 m s-1. Measured: 6e-17 m, 1.5e-16 rad (4e-18 m, 3e-18 rad against
      rtol = 1e-13).
    * at a release from stick with ck = cs (|W| = ck n: the twist grows like
      (t - t0)^2, too stiff for an explicit method): Radau with atol 1e-22 (a tiny
      absolute tolerance is needed: with atol ~ |u| the direction of a small twist is
      left free and Radau drifts), seed 1e-14 m s-1 along W. Measured: 2e-17 m,
      3e-16 rad, 1.3e-14 m s-1 (2e-12 relative).
    """
    f, a = 14.2, 7.0
    T = 1.0 / f
    kappa = (C / RHO) ** 2
    rhs, wrench = _cartesian(STEER, f, a, C, kappa, CS)
    modes = steady_modes(STEER, f, a)
    init = np.r_[np.zeros(7), modes]
    # 1. linear onset at t = 0
    t1 = 0.1 * T
    tr = ref(STEER, [f], [a], [t1], output_times=[t1], initial_state=init)
    assert tr.events[0] == (0.0, "release")
    s0 = np.r_[np.zeros(3), [1.0, 0.0, 0.0], modes]
    W, n = wrench(0.0, s0)
    assert np.linalg.norm(W) > CS * n
    s0[3:6] = 1e-16 * W / np.linalg.norm(W)
    sol = solve_ivp(rhs, (0.0, t1), s0, method="DOP853", rtol=1e-13, atol=1e-18)
    assert sol.status == 0
    assert abs(sol.y[2, -1]) > 1e-4  # it turns
    assert_allclose([tr.x[0], tr.y[0]], sol.y[0:2, -1], rtol=0, atol=1e-15)
    assert_allclose(tr.heading[0], sol.y[2, -1], rtol=0, atol=2e-15)
    assert_allclose([tr.vx[0], tr.vy[0], C * tr.spin[0]], sol.y[3:6, -1], rtol=0, atol=1e-14)
    # 2. quadratic onset at the release that starts the second big slip
    first = ref_scenario("forward")  # the same drive and start
    t_r = [t for t, kind in first.events if kind == "release"][2]
    t2 = t_r + 0.1 * T
    tr = ref(STEER, [f], [a], [t2], output_times=[t_r, t2], initial_state=init)
    assert abs(tr.vx[0]) < 1e-14  # released at t_r to round-off
    m_r = solve_ivp(lambda t, m: rhs(t, np.r_[np.zeros(3), 1.0, 0.0, 0.0, m])[6:], (0.0, t_r),
                    modes, method="DOP853", rtol=1e-13, atol=1e-20).y[:, -1]
    s0 = np.r_[tr.x[0], tr.y[0], tr.heading[0], 0.0, 0.0, 0.0, m_r]
    W, n = wrench(t_r, s0)
    assert_allclose(np.linalg.norm(W), CS * n, rtol=1e-10)  # a release: lambda = 0
    s0[3:6] = 1e-14 * W / np.linalg.norm(W)
    sol = solve_ivp(rhs, (t_r, t2), s0, method="Radau", rtol=1e-12, atol=1e-22)
    assert sol.status == 0
    assert abs(sol.y[2, -1] - tr.heading[0]) > 1e-4
    assert_allclose([tr.x[1], tr.y[1]], sol.y[0:2, -1], rtol=0, atol=1e-15)
    assert_allclose(tr.heading[1], sol.y[2, -1], rtol=0, atol=5e-15)
    assert_allclose([tr.vx[1], tr.vy[1], C * tr.spin[1]], sol.y[3:6, -1], rtol=0, atol=3e-14)


def test_reference_mirror_symmetry_and_rotation_invariance():
    f, a = 14.2, 7.0
    T = 1.0 / f
    times = np.array([0.25, 0.5, 1.0]) * T
    init = initial_state(STEER, f, a)
    base = ref(STEER, [f], [a], [T], initial_state=init, output_times=times)
    mirror = ref(mirrored(STEER), [f], [a], [T], initial_state=init, output_times=times)
    assert np.abs(base.y).max() > 1e-6 and np.abs(base.heading).max() > 1e-3
    assert_allclose(mirror.x, base.x, rtol=0, atol=1e-15)
    assert_allclose(mirror.y, -base.y, rtol=0, atol=1e-15)
    assert_allclose(mirror.heading, -base.heading, rtol=0, atol=1e-13)
    theta0 = 2.0
    rot = ref(STEER, [f], [a], [T], output_times=times,
              initial_state=initial_state(STEER, f, a, pose=(0, 0, theta0, 0, 0, 0, 0)))
    c, s = math.cos(theta0), math.sin(theta0)
    assert_allclose(rot.x, c * base.x - s * base.y, rtol=0, atol=1e-14)
    assert_allclose(rot.y, s * base.x + c * base.y, rtol=0, atol=1e-14)
    assert_allclose(rot.heading, base.heading + theta0, rtol=0, atol=1e-13)
    assert_allclose(rot.path, base.path, rtol=0, atol=1e-14)


# --- part 2: the package against the reference ------------------------------------------


@pytest.fixture(scope="module")
def planar():
    from study.model.disk import Disk, Plate
    from study.solvers.planar import simulate_planar

    return SimpleNamespace(Disk=Disk, Plate=Plate, simulate_planar=simulate_planar)


def pkg_disk(planar, plates, **kw):
    made = tuple(planar.Plate(**p, name=f"plate{i}") for i, p in enumerate(plates))
    return planar.Disk(radius=R, plates=made, cs=CS, g=G, **kw)


def pkg_run(planar, disk, freq, acc, dur, init, times, tol=PKG_TOL):
    """The package's run from the reference's state ``init`` (heading [rad], spin
    [rad s-1]), given to the package in its units (degree, degree s-1); the
    trajectory's heading and spin come back in degree (compare with ``deg``)."""
    from study.solvers.integrator import IntegratorSettings, Schedule

    init = np.array(init, dtype=float)
    init[[2, 5]] = np.degrees(init[[2, 5]])
    schedule = Schedule(np.asarray(freq, float), np.asarray(acc, float), np.asarray(dur, float))
    return planar.simulate_planar(disk, schedule, initial_state=init, output_times=times,
                                  settings=IntegratorSettings(tolerance=tol))


@pytest.mark.parametrize(("f", "a"), [(14.2, 7.0), (14.6, 7.0), (16.5, 8.5)])
def test_package_1d_reduction(planar, f, a):
    """One plate along the heading, lever 0: x against the planar reference and the
    1-D reference; y and heading exactly zero. Measured (package tolerance 1e-10):
    1.1e-12, 5e-13, 9e-14 m, 5e-10 of the displacement (4.7e-15 m at 1e-12)."""
    n = 3
    T = 1.0 / f
    times = np.arange(1, n + 1) * T
    init = initial_state([HEAD], f, a)
    traj = pkg_run(planar, pkg_disk(planar, [HEAD]), [f], [a], [n * T], init, times)
    assert traj.outcome in DONE
    tr = ref([HEAD], [f], [a], [n * T], output_times=times, initial_state=init)
    x1 = ref_1d_period_ends(f, a, n, init[7:])
    scale = np.abs(x1).max()
    assert_allclose(traj.x, tr.x, rtol=1e-6, atol=1e-6 * scale)
    assert_allclose(traj.x, x1, rtol=1e-6, atol=1e-6 * scale)
    assert np.all(traj.y == 0.0) and np.all(traj.heading == 0.0)
    assert np.all(traj.vy == 0.0) and np.all(traj.spin == 0.0)


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_package_steering_disk(planar, name):
    """The two-plate disk: pose, twist and path at six times against the reference
    (rtol 1e-12, itself good to ~4e-12 of the motion); asserted to 1e-6 of each
    quantity's scale over the run.

    Measured (package tolerance 1e-10, relative to those scales): positions and path
    up to 5.6e-9, heading up to 1.1e-8, velocities up to 5.9e-8, spin up to 7.1e-8
    (forward). This is a floor: about the same at tolerance 1e-12; it comes from the
    package's slaved onset (``slaving = 1e-4``) and falls like ``slaving^2``."""
    freq, acc, dur, init, times = scenario(name)
    traj = pkg_run(planar, pkg_disk(planar, STEER), freq, acc, dur, init, times)
    tr = ref_scenario(name)
    assert traj.outcome in DONE and tr.outcome == "done"
    assert_allclose(traj.time, tr.time, rtol=0, atol=0)
    length = max(np.abs(tr.x).max(), np.abs(tr.y).max())
    speed = max(np.abs(tr.vx).max(), np.abs(tr.vy).max(), 1e-3)
    angle = deg(max(np.abs(tr.heading).max(), 1e-3))
    rate = deg(max(np.abs(tr.spin).max(), 1e-2))
    assert length > 1e-5
    assert_allclose(traj.x, tr.x, rtol=1e-6, atol=1e-6 * length)
    assert_allclose(traj.y, tr.y, rtol=1e-6, atol=1e-6 * length)
    assert_allclose(traj.heading, deg(tr.heading), rtol=1e-6, atol=1e-6 * angle)
    assert_allclose(traj.path, tr.path, rtol=1e-6, atol=1e-6 * length)
    assert_allclose(traj.vx, tr.vx, rtol=1e-6, atol=1e-6 * speed)
    assert_allclose(traj.vy, tr.vy, rtol=1e-6, atol=1e-6 * speed)
    assert_allclose(traj.spin, deg(tr.spin), rtol=1e-6, atol=1e-6 * rate)


def test_package_mirror_symmetry(planar):
    """beta -> -beta, r_left -> -r_left gives (x, -y, -heading). Measured: exact."""
    freq, acc, dur, init, times = scenario("switch")
    base = pkg_run(planar, pkg_disk(planar, STEER), freq, acc, dur, init, times)
    mirror = pkg_run(planar, pkg_disk(planar, mirrored(STEER)), freq, acc, dur, init, times)
    length = np.abs(base.x).max()
    assert np.abs(base.y).max() > 1e-6 and np.abs(base.heading).max() > deg(1e-3)
    assert_allclose(mirror.x, base.x, rtol=1e-9, atol=1e-9 * length)
    assert_allclose(mirror.y, -base.y, rtol=1e-9, atol=1e-9 * length)
    assert_allclose(mirror.heading, -base.heading, rtol=1e-9, atol=deg(1e-12))
    assert_allclose(mirror.path, base.path, rtol=1e-9, atol=1e-9 * length)


@pytest.mark.parametrize("theta0", [1.0, -2.5])
def test_package_rotation_invariance(planar, theta0):
    """An initial heading theta0 rotates the whole path about the start. Measured:
    8e-11 of the displacement, 1.3e-12 rad."""
    freq, acc, dur, init, times = scenario("switch")
    disk = pkg_disk(planar, STEER)
    base = pkg_run(planar, disk, freq, acc, dur, init, times)
    start = init.copy()
    start[2] = theta0
    rot = pkg_run(planar, disk, freq, acc, dur, start, times)
    c, s = math.cos(theta0), math.sin(theta0)
    length = np.abs(base.x).max()
    assert_allclose(rot.x, c * base.x - s * base.y, rtol=1e-9, atol=1e-9 * length)
    assert_allclose(rot.y, s * base.x + c * base.y, rtol=1e-9, atol=1e-9 * length)
    assert_allclose(rot.heading, base.heading + deg(theta0), rtol=0, atol=deg(1e-11))
    assert_allclose(rot.vx, c * base.vx - s * base.vy, rtol=1e-9, atol=1e-12)
    assert_allclose(rot.path, base.path, rtol=1e-9, atol=1e-9 * length)


def test_package_free_slide_kappa_one(planar):
    """kappa = 1 (gyration radius = friction length): u(t) = u0 (1 - ck g t / |u0|).
    Measured: 4e-10 of the distance (the path after the stop), else round-off."""
    v, spin = (0.03, -0.02), 4.0
    u0 = np.array([v[0], v[1], C * spin])
    r0 = np.linalg.norm(u0)
    t_s = r0 / (CS * G)
    times = np.linspace(0.0, 1.5 * t_s, 13)
    disk = pkg_disk(planar, [HEAD], gyration_radius=C, friction_length=C)
    traj = pkg_run(planar, disk, [14.0], [0.0], [times[-1]], free_state(v, spin), times)
    assert traj.outcome in DONE
    tt = np.minimum(times, t_s)
    decay = np.where(times < t_s, 1.0 - tt / t_s, 0.0)
    moved = tt - 0.5 * tt * tt / t_s
    scale = r0 * t_s
    tol = 1e-8
    assert_allclose(traj.vx, u0[0] * decay, rtol=0, atol=tol * r0)
    assert_allclose(traj.vy, u0[1] * decay, rtol=0, atol=tol * r0)
    assert_allclose(traj.spin, deg(spin * decay), rtol=0, atol=deg(tol * r0 / C))
    assert_allclose(traj.x, u0[0] * moved, rtol=0, atol=tol * scale)
    assert_allclose(traj.y, u0[1] * moved, rtol=0, atol=tol * scale)
    assert_allclose(traj.heading, deg(spin * moved), rtol=0, atol=deg(tol * scale / C))
    assert_allclose(traj.path, math.hypot(*v) * moved, rtol=0, atol=tol * scale)


def test_package_free_slide_pure_translation(planar):
    """No spin, default disk (kappa = 8/9): stop at v0 / (ck g) after v0^2 / (2 ck g).
    Measured: speed to round-off, path 2.6e-11 relative."""
    v = (-0.012, 0.025)
    v0 = math.hypot(*v)
    t_s = v0 / (CS * G)
    times = np.array([0.5 * t_s, 0.999 * t_s, 1.001 * t_s, 2.0 * t_s])
    traj = pkg_run(planar, pkg_disk(planar, [HEAD]), [14.0], [0.0], [times[-1]],
                   free_state(v, 0.0), times)
    speed = v0 * np.maximum(1.0 - times / t_s, 0.0)
    assert_allclose(np.hypot(traj.vx, traj.vy), speed, rtol=0, atol=1e-8 * v0)
    tt = np.minimum(times, t_s)
    d = v0 * (tt - 0.5 * tt * tt / t_s)
    assert_allclose(traj.path, d, rtol=0, atol=1e-8 * v0 * t_s)
    assert_allclose(np.hypot(traj.x, traj.y), d, rtol=0, atol=1e-8 * v0 * t_s)
    assert np.all(traj.heading == 0.0) and np.all(traj.spin == 0.0)


@pytest.mark.parametrize(("speed", "spin", "kappa"), FREE_CASES)
def test_package_free_slide_power_law(planar, speed, spin, kappa):
    """kappa != 1, twist turning into the stop: final pose against the quadratures,
    and at rest just after the stop, still moving just before. Measured: distance
    within 4.6e-9 relative (kappa = 2, mostly spin), 4e-11 otherwise; rotation within
    1e-10."""
    angle = 0.8
    v = (speed * math.cos(angle), speed * math.sin(angle))
    t_s, d, th = free_slide(speed, spin, kappa)
    times = np.array([(1.0 - 1e-6) * t_s, (1.0 + 1e-6) * t_s, 1.2 * t_s])
    disk = pkg_disk(planar, [HEAD], gyration_radius=C / math.sqrt(kappa))
    traj = pkg_run(planar, disk, [14.0], [0.0], [times[-1]], free_state(v, spin), times)
    assert traj.outcome in DONE
    assert np.hypot(traj.vx[0], C * np.radians(traj.spin[0])) > 0.0
    assert traj.vx[1] == traj.vy[1] == traj.spin[1] == 0.0
    assert_allclose([traj.x[-1], traj.y[-1], traj.path[-1]],
                    [d * math.cos(angle), d * math.sin(angle), d], rtol=1e-8)
    assert_allclose(traj.heading[-1], deg(th), rtol=1e-8)


def test_package_lift_off(planar):
    """Resonant drive from rest (plates at rest, a = 10 m s-2 at 14.44 Hz): the
    growing head mode makes n reach 0 in the third period. Both stop there, with the
    same time and the same samples before it. Measured: 1.5e-12 s, 6e-13 m."""
    f, a = 14.44, 10.0
    dur = [6.0 / f]
    times = np.linspace(0.0, dur[0], 13)[1:]
    init = np.zeros(7 + 2 * len(STEER))
    tr = ref(STEER, [f], [a], dur, initial_state=init, output_times=times)
    traj = pkg_run(planar, pkg_disk(planar, STEER), [f], [a], dur, init, times)
    assert tr.outcome == traj.outcome == "lift_off"
    assert 2.0 / f < tr.end_time < 4.0 / f
    assert_allclose(traj.end_time, tr.end_time, rtol=0, atol=1e-9 / f)
    assert traj.time.size == tr.time.size > 0
    length = np.abs(tr.x).max()
    assert_allclose(traj.x, tr.x, rtol=1e-6, atol=1e-6 * length)
    assert_allclose(traj.y, tr.y, rtol=1e-6, atol=1e-6 * length)
    assert_allclose(traj.heading, deg(tr.heading), rtol=1e-6,
                    atol=1e-6 * deg(np.abs(tr.heading).max()))
