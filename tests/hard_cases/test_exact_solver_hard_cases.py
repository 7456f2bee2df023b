"""Hard cases of the exact steady-state solver, each against an independent reference.

Every case asserts either the correct status or an accuracy against a reference that
is far more accurate than the assertion -- never just "it returned something".

References (none shares code with ``study``)
--------------------------------------------
* ``tests.reference.one_way_exact.exact_velocity``: the event-driven closed form in 40-digit mpmath
  (stick-slip only).
* :func:`_sliding_cycle` (below): continuous sliding in 30-digit mpmath. A period-1
  orbit without stick is a forward slip from rest at phase ``p``, a reversal, a
  backward slip and a reversal at ``p + 2 pi``; its phase is the root of
  ``gap(p) = R(p) - p - 2 pi`` (``R``: reversal map built from the slip primitives of
  ``one_way_exact``) reached by following the motion from rest, refined by secant.
  Its multiplier ``R'(p)`` tells how slowly the cycle attracts.
* ``tests.reference.integrator.reference_velocity``: ``solve_ivp`` (DOP853, rtol 1e-12) of the
  full ODE with event location; slow, so used on a few points (more in ``slow`` tests).

Tolerances (the error model, used by :attr:`Reference.bound`)
-------------------------------------------------------------
float64 rounds every force amplitude, ``omega``, ``G`` and ``cs g`` by a few ulps. A
relative perturbation of the amplitudes acts like one of the drive amplitude ``a``; one
of the phases and of the resonance denominator ``w0^2 - w^2`` like one of ``f``. The
velocity error is therefore bounded by ``64 eps (|v| + |a dv/da| + |f dv/df|)``, with the
derivatives measured on the 40-digit reference by forward differences of relative step
1e-15 (truncation ~1e-15 relative, rounding ~1e-25 at 40 digits). ``64`` covers the few
dozen roundings along an orbit. Near a threshold at relative distance ``delta``,
``v ~ delta^2`` gives ``a dv/da = 2 v / delta``: the bound grows as ``1/delta`` by itself;
near resonance ``|f dv/df| ~ Q |v|`` does the same for the ``w0^2 - w^2`` cancellation.
On every point here the observed error stays below 3 % of this bound.

A continuous-sliding cycle is the fixed point of the reversal map. The solver accepts
it once the map closes it to ``CYCLE_TOLERANCE`` = 1e-12 rad (its documented backward
error), which leaves the phase up to ``1e-12 / (1 - multiplier)`` off; the bound adds
``2 CYCLE_TOLERANCE |dv/dp| / (1 - |multiplier|)`` (``dv/dp`` from the reference).
float64 itself would allow ~100 times less (the solver's own map closes the exact cycle
to ~1e-15 rad, a few ``eps 2 pi``): :func:`test_sliding_cycles_to_float64_accuracy`
asks for ``16 eps 2 pi`` and is an expected failure (reported).

The integrator is trusted to 1e-8 relative (or 1e-8 of the slip speed scale when the
net velocity is a small difference of large slips): its step error control is 1e-12
and it agrees with the 40-digit references to 1e-10 or better on every point here.
"""

from __future__ import annotations

import contextlib
import functools
import math
from dataclasses import dataclass

import mpmath
import numpy as np
import pytest
from mpmath import mp, mpf

import study
from study import NonConvergence, Status
from study.kernels.one_way import CYCLE_TOLERANCE
from study.model import release_amplitudes, slip_amplitudes
from study.model.paper import PAPER_STRUCTURE as PAPER
from study.model.structure import tilt_warnings
from study.solvers.frontier import FRONTIER_CROSSING
from tests.reference import one_way_exact
from tests.reference.integrator import reference_velocity
from tests.reference.one_way_exact import end_of_slip, exact_velocity, slip_displacement

EPS = float(np.finfo(float).eps)
TWO_PI = 2.0 * math.pi
#: Relative step of the finite differences taken on the mpmath references.
STEP = "1e-15"
#: Working precision of the continuous-sliding cycle reference [digits].
CYCLE_DPS = 30
#: Trust in the solve_ivp reference (see the module docstring).
INTEGRATOR_RTOL = 1e-8

PAPER_STRUCTURE = study.Structure(**PAPER)
STATUS_NAMES = {
    "static": Status.STATIC,
    "stick_slip": Status.STICK_SLIP,
    "continuous_sliding": Status.CONTINUOUS_SLIDING,
    "lift_off": Status.LIFT_OFF,
}


def _paper(**changes: float) -> study.Structure:
    return PAPER_STRUCTURE.replace(**changes)


def _args(s: study.Structure) -> tuple[float, float, float, float, float]:
    return (s.f0, s.Q, s.alpha, s.M, s.cs)


# ----------------------------------------------------------------------------------
# References
# ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Reference:
    """Reference outcome of one drive point and the error the solver may make on it."""

    status: Status
    velocity: float
    a_dv_da: float = 0.0
    f_dv_df: float = 0.0
    slips: int = 0  # slips per orbit (stick-slip, from the 40-digit reference)
    multiplier: float = 0.0  # continuous sliding: R'(p) of the cycle
    dv_dphase: float = 0.0  # continuous sliding: d(mean velocity)/d(cycle phase)

    @property
    def bound(self) -> float:
        """Largest admissible |v_solver - v_reference| (module docstring)."""
        return self.conditioning_bound + self.cycle_bound(2 * CYCLE_TOLERANCE)

    @property
    def conditioning_bound(self) -> float:
        return 64 * EPS * (abs(self.velocity) + abs(self.a_dv_da) + abs(self.f_dv_df))

    def cycle_bound(self, phase_error: float) -> float:
        """Velocity error of a sliding cycle whose map closes to ``phase_error``."""
        if self.status != Status.CONTINUOUS_SLIDING:
            return 0.0
        return phase_error * abs(self.dv_dphase) / (1.0 - abs(self.multiplier))


def _exact(s: study.Structure, f, a) -> tuple[mpf, str, int]:
    return exact_velocity(*_args(s), f, a, ck=s.ck, g=s.g)


def _exact_sensitivities(s: study.Structure, f: float, a: float, here: mpf
                         ) -> tuple[float, float]:
    """``a dv/da`` and ``f dv/df`` of a stick-slip point of 40-digit velocity ``here``."""
    with mp.workdps(50):
        h, fm, am = mpf(STEP), mpf(f), mpf(a)

        def v(ff: mpf, aa: mpf) -> mpf:
            value, status, _ = _exact(s, ff, aa)
            assert status == "stick_slip", status
            return value

        a_dv = (v(fm, am * (1 + h)) - here) / h
        f_dv = (v(fm * (1 + h), am) - here) / h
    return float(a_dv), float(f_dv)


@dataclass(frozen=True)
class SlidingCycle:
    velocity: float
    multiplier: float
    phase: float
    dv_dphase: float


class _SlidingModel:
    """Reversal map of continuous sliding, in ``CYCLE_DPS``-digit mpmath.

    Built on the slip primitives of ``one_way_exact`` (closed-form slip end and
    displacement); the amplitudes are re-derived here from the model (see the README).
    """

    def __init__(self, s: study.Structure, f, a):
        f0, q, m, cs, ck, g = (mpf(x) for x in (s.f0, s.Q, s.M, s.cs, s.ck, s.g))
        fm, am = mpf(f), mpf(a)
        self.w = w = 2 * mp.pi * fm
        w0 = 2 * mp.pi * f0
        alpha = mpmath.radians(mpf(s.alpha))
        ca, sa = mpmath.cos(alpha), mpmath.sin(alpha)
        gain = 1 / mpmath.mpc(w0 * w0 - w * w, w0 * w / q)
        normal = -am * (1 + w * w * m * ca * ca * gain)
        tangential = am * w * w * m * sa * ca * gain
        self.level, self.kg = cs * g, ck * g
        self.release = {sign: sign * tangential - cs * normal for sign in (1, -1)}
        self.slip = {sign: sign * tangential - ck * normal for sign in (1, -1)}
        self.tol = mpf(10) ** (8 - CYCLE_DPS)
        self.two_pi = 2 * mp.pi

    def released(self, sign: int, theta: mpf) -> bool:
        return mpmath.re(self.release[sign] * mpmath.expjpi(theta / mp.pi)) > self.level

    def slip_end(self, sign: int, theta: mpf) -> mpf:
        return end_of_slip(self.slip[sign], self.kg, theta, self.tol)

    def round_trip(self, p: mpf):
        """Forward slip from rest at ``p``, reversal, backward slip, reversal: the gap
        ``R(p) - p - 2 pi`` and the mean velocity ``w D / 2 pi`` of the round trip
        (None where the map is undefined: a slip that does not move or a stick)."""
        t1 = self.slip_end(1, p)
        if t1 == p or not self.released(-1, t1):
            return None
        t2 = self.slip_end(-1, t1)
        if t2 == t1 or not self.released(1, t2):
            return None
        moved = slip_displacement(self.slip[1], self.kg, p, t1, self.w) - slip_displacement(
            self.slip[-1], self.kg, t1, t2, self.w
        )
        return t2 - p - self.two_pi, moved * self.w / self.two_pi

    def gap(self, p: mpf) -> mpf:
        trip = self.round_trip(p)
        if trip is None:
            raise ValueError("the reversal map is not defined here")
        return trip[0]

    def sliding_phase(self, reversals: int = 60, max_events: int = 4000) -> mpf:
        """Follow the motion from rest at phase 0 (stick rule applied at 0) until
        ``reversals`` slips in a row end in a reversal; return the phase of the next
        forward start (AssertionError if that never happens within ``max_events``)."""
        theta = mpf(0)
        sign = next((s for s in (1, -1) if self.released(s, theta)), 0)
        in_a_row = 0
        for _ in range(max_events):
            if sign == 0:  # stick: wait for the first release of either sign
                starts = []
                for s in (1, -1):
                    t = one_way_exact.next_release(self.release[s], self.level, theta,
                                                      self.tol)
                    if t is not None:
                        starts.append((max(t, theta), s))
                theta, sign = min(starts)
                in_a_row = 0
            if in_a_row >= reversals and sign > 0:
                return theta
            end = self.slip_end(sign, theta)
            if self.released(-sign, end):
                theta, sign, in_a_row = end, -sign, in_a_row + 1
            else:
                theta, sign = end, 0
        raise AssertionError("no sustained sliding from rest")


def _sliding_cycle(s: study.Structure, f, a, guess=None) -> SlidingCycle:
    """The period-1 sliding cycle reached from rest (seeded by the motion itself, or
    by ``guess``): root of ``gap``, with its multiplier ``R'`` and ``dv/dp``."""
    with mp.workdps(CYCLE_DPS):
        model = _SlidingModel(s, f, a)
        start = model.sliding_phase() if guess is None else mpf(guess)
        # Secant from two close phases: a default second point 1/4 rad away may fall
        # where the map is undefined.
        p = mpmath.findroot(model.gap, (start, start + mpf("1e-9")))
        h = mpf(10) ** (3 - CYCLE_DPS // 2)
        lam = 1 + (model.gap(p + h) - model.gap(p - h)) / (2 * h)
        dv = (model.round_trip(p + h)[1] - model.round_trip(p - h)[1]) / (2 * h)
        return SlidingCycle(float(model.round_trip(p)[1]), float(lam), float(p), float(dv))


def _sliding_reference(s: study.Structure, f: float, a: float) -> Reference:
    c = _sliding_cycle(s, f, a)
    assert abs(c.multiplier) < 1, f"the cycle found is not attracting: {c}"
    with mp.workdps(50):
        h, fm, am = mpf(STEP), mpf(f), mpf(a)

        def v(ff: mpf, aa: mpf) -> float:
            return _sliding_cycle(s, ff, aa, guess=c.phase).velocity

        # Differences of CYCLE_DPS-digit values: exact to ~15 digits, ample for a bound.
        a_dv = (v(fm, am * (1 + h)) - c.velocity) / float(h)
        f_dv = (v(fm * (1 + h), am) - c.velocity) / float(h)
    return Reference(
        Status.CONTINUOUS_SLIDING, c.velocity, a_dv, f_dv,
        multiplier=c.multiplier, dv_dphase=c.dv_dphase,
    )


#: Slips in a row without a stick after which the 40-digit reference hands over to the
#: sliding cycle (its own default, 200, costs 0.4 s a point). A sliding transient that
#: sticks later cannot pass silently: the cycle is seeded only after 60 reversals in a
#: row, a transient without a cycle is followed to its stick by the 40-digit reference
#: with its budgets lifted, and the solver's status is always compared.
SLIDING_AFTER = 40


@contextlib.contextmanager
def _exact_budgets(slips_without_stick: int, events: int):
    """Temporarily set the budgets of the 40-digit reference (module constants)."""
    saved = one_way_exact.MAX_SLIPS_WITHOUT_STICK, one_way_exact.MAX_EVENTS
    one_way_exact.MAX_SLIPS_WITHOUT_STICK, one_way_exact.MAX_EVENTS = (
        slips_without_stick, events)
    try:
        yield
    finally:
        one_way_exact.MAX_SLIPS_WITHOUT_STICK, one_way_exact.MAX_EVENTS = saved


@functools.cache
def _reference(s: study.Structure, f: float, a: float) -> Reference:
    """40-digit reference; the mpmath sliding cycle once the motion slides."""
    with _exact_budgets(SLIDING_AFTER, one_way_exact.MAX_EVENTS):
        value, status, slips = _exact(s, f, a)
    budgets = (one_way_exact.MAX_SLIPS_WITHOUT_STICK, one_way_exact.MAX_EVENTS)
    if status == "continuous_sliding_unsupported":
        try:
            return _sliding_reference(s, f, a)
        except (AssertionError, ValueError, ZeroDivisionError):
            pass  # no sliding cycle: a long sliding transient; follow it to its stick
        budgets = (100_000, 100_000)
        with _exact_budgets(*budgets):
            value, status, slips = _exact(s, f, a)
    if status == "stick_slip":
        with _exact_budgets(*budgets):
            sensitivities = _exact_sensitivities(s, f, a, value)
        return Reference(Status.STICK_SLIP, float(value), *sensitivities, slips=slips)
    assert status in ("static", "lift_off"), status
    return Reference(STATUS_NAMES[status], float(value))


@functools.cache
def _integrated(s: study.Structure, f: float, a: float, max_periods: int = 2000):
    return reference_velocity(*_args(s), f, a, ck=s.ck, g=s.g, rtol=1e-12, atol=1e-14,
                              max_periods=max_periods)


def _slip_speed_scale(s: study.Structure, f: float, a: float) -> float:
    """Scale of the slip speeds [m/s]: ``(max |B_s| + ck g) / w`` bounds ``|dv/dt| / w``."""
    b_plus, b_minus = slip_amplitudes(s, f, a)
    return float(max(abs(b_plus), abs(b_minus)) + s.ck * s.g) / (TWO_PI * f)


def _assert_matches(s: study.Structure, f: float, a: float):
    """Solve one point and check status and velocity against :func:`_reference`."""
    result = study.steady_state(s, f, a)
    ref = _reference(s, f, a)
    v = float(result.velocity)
    status = Status(int(result.status))
    assert status == ref.status, (s, f, a, status, ref)
    assert NonConvergence(int(result.reason)) == NonConvergence.NONE
    if status == Status.LIFT_OFF:
        assert math.isnan(v)
    elif status == Status.STATIC:
        assert v == 0.0
    else:
        error = abs(v - ref.velocity)
        assert error <= ref.bound, (
            f"{s} f={f!r} a={a!r}: v={v!r} reference={ref.velocity!r} "
            f"error={error:.3e} > bound={ref.bound:.3e}"
        )
    return result, ref


def _assert_matches_integrator(s: study.Structure, f: float, a: float, max_periods: int):
    v, status = study.steady_velocity(s, f, a)
    ref, ref_status, periods = _integrated(s, f, a, max_periods)
    assert ref_status in STATUS_NAMES, f"integrator: {ref_status} after {periods} periods"
    assert status == STATUS_NAMES[ref_status]
    atol = INTEGRATOR_RTOL * _slip_speed_scale(s, f, a)
    assert abs(float(v) - ref) <= INTEGRATOR_RTOL * abs(ref) + atol
    return periods


def _window(s: study.Structure, f: float, xi: float) -> float:
    """Drive amplitude at the fraction ``xi`` of the way from the lower threshold to
    lift-off (requires a non-empty window)."""
    a_min = float(min(study.thresholds(s, f)))
    a_lift = float(study.lift_off_acceleration(s, f))
    assert a_min < a_lift
    return a_min + xi * (a_lift - a_min)


def _mp_thresholds(s: study.Structure, f: float) -> tuple[mpf, mpf, mpf]:
    """``a*_+, a*_-, a_lift`` from the closed forms, at 40 digits."""
    with mp.workdps(40):
        w, w0 = 2 * mp.pi * mpf(f), 2 * mp.pi * mpf(s.f0)
        alpha = mpmath.radians(mpf(s.alpha))
        ca, sa = mpmath.cos(alpha), mpmath.sin(alpha)
        k = w * w * mpf(s.M) * ca / mpmath.mpc(w0 * w0 - w * w, w0 * w / mpf(s.Q))
        g = mpf(s.g)
        return (g / abs(1 + k * (ca + sa / mpf(s.cs))), g / abs(1 + k * (ca - sa / mpf(s.cs))),
                g / abs(1 + k * ca))


# ----------------------------------------------------------------------------------
# 1. Grazing at the motion thresholds
# ----------------------------------------------------------------------------------

# (f, sign of the threshold): the lower threshold, where motion starts from rest, on
# both sides of the resonance (forward below, backward above) ...
LOWER_THRESHOLDS = [(10.0, +1), (13.5, +1), (14.44, +1), (14.6, -1), (15.5, -1), (20.0, -1)]
# ... and the higher one inside PN, where the second slip direction appears.
UPPER_THRESHOLDS = [(14.2, -1), (14.44, -1), (14.6, +1), (14.8, +1), (15.0, +1)]


def _threshold(s, f, sign):
    a_plus, a_minus = study.thresholds(s, f)
    return float(a_plus if sign > 0 else a_minus)


@pytest.mark.parametrize(("f", "sign"), LOWER_THRESHOLDS)
def test_grazing_the_lower_threshold(f, sign):
    """At ``a*(1 - 1e-12)`` static; at ``a*(1 + 1e-12)`` a velocity ``~ delta^2`` that is
    still exact to its conditioning (``a dv/da = 2 v / delta``: 64 eps / delta relative)
    and continuous with ``a*(1 + 1e-6)``."""
    s = PAPER_STRUCTURE
    a_star = _threshold(s, f, sign)
    assert a_star == float(min(study.thresholds(s, f))) < study.lift_off_acceleration(s, f)
    result, _ = _assert_matches(s, f, a_star * (1 - 1e-12))
    assert result.status == Status.STATIC
    scaled = {}
    for delta in (1e-12, 1e-6):
        result, ref = _assert_matches(s, f, a_star * (1 + delta))
        assert result.status == Status.STICK_SLIP
        assert np.sign(result.velocity) == sign
        # Only the threshold's own direction slips.
        own, other = ((result.forward_fraction, result.backward_fraction) if sign > 0
                      else (result.backward_fraction, result.forward_fraction))
        assert own > 0 and other == 0
        scaled[delta] = (float(result.velocity) / delta**2, ref.velocity / delta**2,
                         ref.bound / delta**2)
    # Continuity: v / delta^2 tends to a constant (next order ~ sqrt(delta) = 1e-3).
    (v12, r12, b12), (v6, r6, _) = scaled[1e-12], scaled[1e-6]
    assert r12 == pytest.approx(r6, rel=1e-2)
    assert abs(v12 - v6) <= 1e-2 * abs(r6) + b12


@pytest.mark.parametrize(("f", "sign"), UPPER_THRESHOLDS)
def test_grazing_the_upper_threshold(f, sign):
    """Across the higher threshold the other direction appears with vanishing slips
    (their phase fraction ~ sqrt(delta)); the velocity is continuous, with the slope
    ``dv/da`` of the reference, and exact on both sides."""
    s = PAPER_STRUCTURE
    a_star = _threshold(s, f, sign)
    assert a_star == float(max(study.thresholds(s, f))) < study.lift_off_acceleration(s, f)
    points = {}
    for delta in (-1e-12, 1e-12, 1e-6, 2e-6):
        result, ref = _assert_matches(s, f, a_star * (1 + delta))
        assert result.status == Status.STICK_SLIP
        assert result.slips_per_period * result.orbit_period == ref.slips
        new = result.forward_fraction if sign > 0 else result.backward_fraction
        points[delta] = (float(result.velocity), ref, float(new))
    below, above, far = points[-1e-12], points[1e-12], points[1e-6]
    assert below[2] == 0.0 and below[1].slips == 1
    if above[1].slips > below[1].slips:
        # The new direction slips, for a phase fraction growing like sqrt(delta).
        assert above[2] > 0
        assert far[2] / above[2] == pytest.approx(1e3, rel=1e-2)
    else:
        # Its release arc lies inside a slip of the other direction: nothing appears.
        assert above[2] == far[2] == 0.0
    # No jump: from either side of a*, v(a*(1 + 1e-6)) is reached with the slope
    # a dv/da of the reference (a second-order term ~ 1e-6 of it at most).
    slope = (points[2e-6][1].velocity - far[1].velocity) / 1e-6
    for delta in (-1e-12, 1e-12):
        v = points[delta][0]
        predicted = far[0] - slope * (1e-6 - delta)
        assert abs(v - predicted) <= 1e-2 * abs(slope) * 1e-6 + points[delta][1].bound + (
            far[1].bound
        )


# ----------------------------------------------------------------------------------
# 2. Starting exactly on the switching surface, with ck < cs
# ----------------------------------------------------------------------------------


def _switching_acceleration(s: study.Structure, f: float, sign: int) -> float:
    """Drive amplitude that puts drive phase 0 exactly on ``sign tau = cs n``."""
    unit = release_amplitudes(s, f, 1.0)[0 if sign > 0 else 1]
    return float(s.cs * s.g / unit.real)


SWITCHING = [
    # (f, sign, alpha, crossing): at an 'entry' phase 0 is where the criterion rises
    # through zero (a release), at an 'exit' where it falls; for ck < cs a slip started
    # there by rounding is macroscopic (s tau - ck n = (cs - ck) n > 0 at its start).
    (13.0, +1, 64.0, "entry"),
    (14.6, -1, 64.0, "exit"),
    (16.5, -1, 64.0, "exit"),
    (13.0, -1, -64.0, "entry"),
    (16.5, +1, -64.0, "exit"),
]


@pytest.mark.parametrize("ck", [0.2, 0.025, 0.0025])
@pytest.mark.parametrize(("f", "sign", "alpha", "crossing"), SWITCHING)
def test_start_on_the_switching_surface_with_kinetic_below_static(f, sign, alpha, crossing,
                                                                  ck):
    """Rest at phase 0 exactly on ``sign tau = cs n``, for ck = 0.8, 0.1, 0.01 cs (the
    paper's ck = cs is covered in tests/unit): the orbit after the first stick does not
    depend on the start, so the result is exact and the same on either side."""
    s = _paper(alpha=alpha, ck=ck)
    a = _switching_acceleration(s, f, sign)
    assert 0 < a < study.lift_off_acceleration(s, f)
    t0 = np.zeros(1)
    criterion = sign * study.tangential_force(s, f, a, t0) - s.cs * study.normal_force(
        s, f, a, t0
    )
    assert abs(criterion[0]) < 1e-14 * s.g
    unit = release_amplitudes(s, f, 1.0)[0 if sign > 0 else 1]
    assert (-unit.imag > 0) == (crossing == "entry")  # d/dtheta Re[A e^{i theta}] at 0
    result, ref = _assert_matches(s, f, a)
    assert result.status == Status.STICK_SLIP
    # Either side of the surface (rounding decides which at phase 0): the same orbit,
    # whose velocity moves by |a dv/da| 1e-15 only.
    for nudge in (1 - 1e-15, 1 + 1e-15):
        nudged = study.steady_state(s, f, a * nudge)
        assert nudged.status == Status.STICK_SLIP
        assert abs(float(nudged.velocity) - ref.velocity) <= ref.bound + 2e-15 * abs(
            ref.a_dv_da
        )


# ----------------------------------------------------------------------------------
# 3. Lift-off
# ----------------------------------------------------------------------------------

LIFT_OFF = [
    # (M, f): stick-slip for M = 0.08, continuous sliding at large M near resonance.
    (0.08, 5.0), (0.08, 14.44), (0.08, 16.5), (0.08, 40.0),
    (0.5, 11.0), (0.5, 16.5), (1.0, 5.0), (1.0, 14.44), (1.0, 19.0),
]


@pytest.mark.parametrize(("M", "f"), LIFT_OFF)
def test_just_below_and_just_above_lift_off(M, f):
    s = _paper(M=M)
    a_lift = float(study.lift_off_acceleration(s, f))
    # Well-conditioned in a (|a dv/da| ~ |v|): n(t) touching 0 changes nothing abruptly.
    result, ref = _assert_matches(s, f, a_lift * (1 - 1e-9))
    assert result.status in (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING)
    result, ref = _assert_matches(s, f, a_lift * (1 + 1e-9))
    assert result.status == Status.LIFT_OFF and ref.status == Status.LIFT_OFF
    assert math.isnan(result.velocity) and math.isnan(result.slips_per_period)
    assert result.reason == NonConvergence.NONE and result.orbit_period == 0


@pytest.mark.parametrize(("M", "f"), [(0.08, 14.44), (1.0, 14.44)])
def test_just_below_lift_off_against_the_integrator(M, f):
    """Also against solve_ivp (which samples n(t) itself, and sees n_min ~ 1e-9 g > 0)."""
    s = _paper(M=M)
    a = float(study.lift_off_acceleration(s, f)) * (1 - 1e-9)
    _assert_matches_integrator(s, f, a, max_periods=400)


@pytest.mark.parametrize("f", [5.9375, 6.3125])
@pytest.mark.parametrize("ck", [0.25, 0.1])
def test_untilted_plate_at_the_lift_off_amplitude(ck, f):
    """alpha = 0: tau = 0 exactly, so the only outcomes are STATIC (n >= 0, v = 0) or
    LIFT_OFF. At a = lift_off_acceleration(f) itself (accepted as valid by the solver),
    the 40-digit reference says static at f = 6.3125 and lift-off at f = 5.9375."""
    s = _paper(alpha=0.0, ck=ck)
    a = float(study.lift_off_acceleration(s, f))
    result = study.steady_state(s, f, a)
    assert result.status in (Status.STATIC, Status.LIFT_OFF)
    if result.status == Status.STATIC:
        assert result.velocity == 0.0


# ----------------------------------------------------------------------------------
# 4. Quality factor from 0.5 to 1e4
# ----------------------------------------------------------------------------------


def _quality_cases():
    cases = []
    for Q in (0.5, 2.0, 50.0, 1e3, 1e4):
        # Below resonance, at it, and at the upper half-power point (G most sensitive to f).
        for ratio in (0.9, 1.0, 1.0 + 1.0 / (2.0 * Q)):
            for xi in (0.1, 0.7):
                cases.append(pytest.param(Q, 14.44 * ratio, xi,
                                          id=f"Q{Q:g}-f{ratio:.5g}f0-xi{xi}"))
    return cases


@pytest.mark.parametrize(("Q", "f", "xi"), _quality_cases())
def test_quality_factor_range(Q, f, xi):
    """Bound includes |f dv/df| ~ Q |v| near resonance (w0^2 - w^2 cancels)."""
    s = _paper(Q=Q)
    a = _window(s, f, xi)
    result, _ = _assert_matches(s, f, a)
    assert result.status in (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING)


@pytest.mark.parametrize(("Q", "f", "xi"), [
    (50.0, 14.44, 0.7),
    pytest.param(1e4, 14.44 * 1.01, 0.7, marks=pytest.mark.slow),
])
def test_quality_factor_continuous_sliding_against_the_integrator(Q, f, xi):
    s = _paper(Q=Q)
    a = _window(s, f, xi)
    assert study.steady_velocity(s, f, a)[1] == Status.CONTINUOUS_SLIDING
    _assert_matches_integrator(s, f, a, max_periods=1000)


# ----------------------------------------------------------------------------------
# 5. Drive frequency from 0.01 f0 to 100 f0
# ----------------------------------------------------------------------------------

FAR_RATIOS = [0.01, 0.03, 0.1, 0.3, 3.0, 10.0, 30.0, 100.0]


@pytest.mark.parametrize("ratio", FAR_RATIOS)
def test_far_from_resonance(ratio):
    s = PAPER_STRUCTURE
    f = s.f0 * ratio
    a_plus, a_minus = (float(x) for x in study.thresholds(s, f))
    a_lift = float(study.lift_off_acceleration(s, f))
    ref_plus, ref_minus, ref_lift = _mp_thresholds(s, f)
    for mine, exact in ((a_plus, ref_plus), (a_minus, ref_minus), (a_lift, ref_lift)):
        assert mine == pytest.approx(float(exact), rel=1e-14)
    ca, sa = math.cos(s.alpha_rad), math.sin(s.alpha_rad)
    x_plus = s.M * ca * (ca + sa / s.cs)
    x_minus = s.M * ca * (ca - sa / s.cs)
    if ratio < 1:
        # w^2 G = r^2 (1 + r^2 - i r/Q + ...), r = f/f0: the thresholds approach g, from
        # below (+) and above (-), by r^2 x_pm, x_pm = M c (c +- s/cs), to a relative
        # O(r^2 (1 + |x|)).
        assert 1 - a_plus / s.g == pytest.approx(ratio**2 * x_plus, rel=2 * ratio**2)
        assert 1 - a_minus / s.g == pytest.approx(ratio**2 * x_minus, rel=2 * ratio**2)
    else:
        # w^2 G = -(1 + r^-2 + i / (r Q) + ...): the plate no longer loads the table,
        # a*_pm -> g / |1 - x_pm| (not g), to a relative O(r^-2 + 1/(r Q)) (|x_pm| < 1).
        rel = ratio**-2 + 1 / (ratio * s.Q)
        assert a_plus == pytest.approx(s.g / abs(1 - x_plus), rel=rel)
        assert a_minus == pytest.approx(s.g / abs(1 - x_minus), rel=rel)
    a_min = min(a_plus, a_minus)
    assert a_min < a_lift
    # Static below the threshold, exactly.
    for a in (0.5 * a_min, a_min * (1 - 1e-9)):
        result, _ = _assert_matches(s, f, a)
        assert result.status == Status.STATIC and result.velocity == 0.0
    # Moving points: the window shrinks to ~(f/f0)^2 at low f (a dv/da ~ v / window).
    for xi in (0.5, 0.999):
        result, _ = _assert_matches(s, f, _window(s, f, xi))
        assert result.status == Status.STICK_SLIP
        assert np.sign(result.velocity) == (1 if ratio < 1 else -1)
    result, _ = _assert_matches(s, f, a_lift * (1 + 1e-9))
    assert result.status == Status.LIFT_OFF


# ----------------------------------------------------------------------------------
# 6. Kinetic friction far below static friction
# ----------------------------------------------------------------------------------

SMALL_CK = [
    # (M, ck / cs, f, a): stick-slip at M = 0.08, continuous sliding at M = 0.3.
    (0.08, 1e-3, 14.44, 6.0),
    (0.08, 1e-3, 16.5, 8.5), (0.08, 1e-3, 11.0, 9.0),
    (0.3, 1e-2, 13.5, 7.0), (0.3, 1e-2, 16.0, 8.0), (0.3, 1e-3, 13.5, 7.0),
    (0.3, 1e-3, 16.0, 8.0), (0.3, 1e-3, 14.44, 6.0),
]


@pytest.mark.parametrize(("M", "ratio", "f", "a"), SMALL_CK)
def test_kinetic_friction_much_smaller_than_static(M, ratio, f, a):
    s = _paper(M=M, ck=PAPER["cs"] * ratio)
    result, ref = _assert_matches(s, f, a)
    if result.status == Status.CONTINUOUS_SLIDING:
        # Weak friction attracts the sliding cycle weakly: multiplier -> 1 as ck -> 0.
        assert 0.95 < ref.multiplier < 1.0
        assert result.orbit_period == 1 and result.slips_per_period == 2


def test_long_sliding_transient_before_the_stick_slip_orbit(monkeypatch):
    """ck = cs/1000 at (14.6 Hz, 7): ~1500 slips without any stick before the orbit
    sticks; the solver's circle map must hand back to stick-slip, not report sliding.
    (The 40-digit reference gives up after 200 slips by default: lift its budgets.)"""
    s = _paper(ck=PAPER["cs"] / 1000)
    f, a = 14.6, 7.0
    assert _exact(s, f, a)[1] == "continuous_sliding_unsupported"
    monkeypatch.setattr(one_way_exact, "MAX_SLIPS_WITHOUT_STICK", 100_000)
    monkeypatch.setattr(one_way_exact, "MAX_EVENTS", 100_000)
    value, status, _ = _exact(s, f, a)
    assert status == "stick_slip"
    v, solver_status = study.steady_velocity(s, f, a)
    assert solver_status == Status.STICK_SLIP
    # Same orbit as any stick-slip point: well conditioned (the sliding transient only
    # decides which orbit, and there is only one).
    assert float(v) == pytest.approx(float(value), rel=1e-12)


@pytest.mark.slow
def test_long_sliding_transient_against_the_integrator():
    s = _paper(ck=PAPER["cs"] / 1000)
    periods = _assert_matches_integrator(s, 14.6, 7.0, max_periods=3000)
    assert periods > 500


@pytest.mark.slow
@pytest.mark.parametrize(("f", "a"), [(13.5, 7.0), (16.0, 8.0)])
def test_small_kinetic_friction_sliding_against_the_integrator(f, a):
    s = _paper(M=0.3, ck=PAPER["cs"] / 100)
    periods = _assert_matches_integrator(s, f, a, max_periods=4000)
    assert periods > 500


# ----------------------------------------------------------------------------------
# 7. Continuous sliding with reversals as M -> 1
# ----------------------------------------------------------------------------------

NEAR_ONE = [0.9, 0.99, 1.0]
# (f, xi, ck / cs): strongly attracting sliding with ck = cs (multiplier 0.36..0.7,
# ~90 integrator periods) and slowly attracting with ck = cs/10 (multiplier ~0.96,
# ~700 integrator periods).
SLIDING_POINTS = [(15.25, 0.5, 1.0), (16.5, 0.5, 1.0), (15.25, 0.9, 0.1)]


@pytest.mark.parametrize(("f", "xi", "ratio"), SLIDING_POINTS)
@pytest.mark.parametrize("M", NEAR_ONE)
def test_sliding_near_unit_mass_ratio(M, f, xi, ratio):
    s = _paper(M=M, ck=PAPER["cs"] * ratio)
    result, ref = _assert_matches(s, f, _window(s, f, xi))
    assert result.status == Status.CONTINUOUS_SLIDING
    assert result.orbit_period == 1 and result.slips_per_period == 2
    assert result.forward_fraction + result.backward_fraction == pytest.approx(1.0, abs=1e-12)
    assert (ref.multiplier > 0.95) == (ratio < 1)  # slowly attracting iff ck << cs


@pytest.mark.parametrize("M", [0.99, 1.0])
def test_sliding_on_a_narrow_domain(M):
    """13 Hz, M -> 1: the reversal map is defined only on a sliver of phases (most
    starts stick) and its cycle is superattracting (multiplier ~ 2e-3)."""
    s = _paper(M=M)
    result, ref = _assert_matches(s, 13.0, _window(s, 13.0, 0.5))
    assert result.status == Status.CONTINUOUS_SLIDING
    assert 0 < ref.multiplier < 0.01


@pytest.mark.parametrize("M", [pytest.param(0.9, marks=pytest.mark.slow),
                               pytest.param(0.99, marks=pytest.mark.slow), 1.0])
def test_sliding_near_unit_mass_ratio_against_the_integrator(M):
    s = _paper(M=M)
    periods = _assert_matches_integrator(s, 15.25, _window(s, 15.25, 0.9), max_periods=1000)
    assert periods > 50


@pytest.mark.slow
@pytest.mark.parametrize("M", NEAR_ONE)
def test_slowly_attracting_sliding_against_the_integrator(M):
    """Multiplier ~0.96: the integrator needs ~700 periods to settle to 1e-13."""
    s = _paper(M=M, ck=PAPER["cs"] / 10)
    periods = _assert_matches_integrator(s, 15.25, _window(s, 15.25, 0.9), max_periods=4000)
    assert periods > 500


# Found by random surveys (M 0.3..1, ck/cs 1e-3..1): an ordinary cycle and two very
# slowly attracting ones (multiplier 1 - 6e-5 and 1 - 1.3e-3). The solver's reversal map
# is exact to ~1e-15 rad at the true fixed point (checked on its kernel), but the cycle
# search stops once the map closes to CYCLE_TOLERANCE = 1e-12 rad.
SLIDING_CYCLES_TO_FLOAT64 = [
    pytest.param(
        dict(f0=14.44, Q=2705.373946267338, alpha=33.04344874445755, M=0.41723024934854475,
             cs=0.3678934228765267, ck=0.023400695301706298),
        15.139777550949388, 3.342748873748451, id="multiplier-0.88",
    ),
    pytest.param(
        dict(f0=14.44, Q=425.00697871268807, alpha=5.920545367667373,
             M=0.7105577241060421, cs=0.06598130635895484, ck=6.89575544136938e-05),
        26.024192975792186, 438.8557141109368, id="multiplier-0.99994",
    ),
    pytest.param(
        dict(f0=14.44, Q=8836.296394310972, alpha=11.344306645548698,
             M=0.9185333525511279, cs=0.10362183700407808, ck=0.0003267999378233256),
        33.51999801215585, 46.65564993855342, id="multiplier-0.9987",
    ),
]


@pytest.mark.parametrize(("params", "f", "a"), SLIDING_CYCLES_TO_FLOAT64)
def test_slowly_attracting_cycles_within_the_documented_backward_error(params, f, a):
    s = study.Structure(**params)
    result, _ = _assert_matches(s, f, a)
    assert result.status == Status.CONTINUOUS_SLIDING
    assert result.orbit_period == 1 and result.slips_per_period == 2


@pytest.mark.parametrize(("params", "f", "a"), SLIDING_CYCLES_TO_FLOAT64)
def test_sliding_cycles_to_float64_accuracy(params, f, a):
    s = study.Structure(**params)
    ref = _reference(s, f, a)
    v = float(study.steady_velocity(s, f, a)[0])
    assert abs(v - ref.velocity) <= ref.conditioning_bound + ref.cycle_bound(16 * EPS * TWO_PI)


# ----------------------------------------------------------------------------------
# 8. The zero-velocity frontier
# ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def paper_frontier():
    return study.frontier(PAPER_STRUCTURE, [6.0, 8.0], (13.5, 16.0), num=401)


@pytest.mark.parametrize("index", [0, 1], ids=["a=6", "a=8"])
def test_velocity_vanishes_on_the_frontier(paper_frontier, index):
    """At f* the velocity is tiny in absolute terms: f* is within half the 1e-9 Hz
    bracket of the root, so |v(f*)| <= |dv/df| 1e-9 Hz + rounding of the slips."""
    s = PAPER_STRUCTURE
    a = float(paper_frontier.a[index])
    kinds = paper_frontier.frontier_kind.values[index]
    freqs = paper_frontier.frontier_frequency.values[index]
    brackets = paper_frontier.frontier_bracket.values[index]
    crossings = [(float(f), float(w)) for f, k, w in zip(freqs, kinds, brackets, strict=True)
                 if k == FRONTIER_CROSSING]
    assert crossings
    for f_star, width in crossings:
        assert 0 < width <= 1e-9
        result, ref = _assert_matches(s, f_star, a)  # absolute error <= ref.bound
        assert result.status == Status.STICK_SLIP
        dv_df = ref.f_dv_df / f_star
        v = float(result.velocity)
        assert abs(v) <= abs(dv_df) * 1e-9 + 4 * EPS * _slip_speed_scale(s, f_star, a)
        # _assert_matches compared with the reference in absolute terms: near v = 0 its
        # bound is set by 64 eps |f dv/df| (rounding of f and of the phases), not by |v|.


# ----------------------------------------------------------------------------------
# 9. Plate tilt near 0 and near 90 degrees
# ----------------------------------------------------------------------------------

TILTS = [1e-6, 0.01, 89.99, 89.9999]
TILT_FREQUENCIES = [13.0, 14.44, 16.0]


@pytest.mark.parametrize("f", TILT_FREQUENCIES)
@pytest.mark.parametrize("alpha", TILTS)
def test_extreme_tilts(alpha, f):
    """Motion lives in a thin window between min(a*) and a_lift (width ~ alpha near 0,
    ~ cos(alpha) off resonance and ~ cos^2(alpha) at it near 90 deg): thresholds match
    the 40-digit closed forms, and velocities the reference, with a dv/da ~ v / width."""
    s = _paper(alpha=alpha)
    mine = (*study.thresholds(s, f), study.lift_off_acceleration(s, f))
    for value, exact in zip(mine, _mp_thresholds(s, f), strict=True):
        assert float(value) == pytest.approx(float(exact), rel=1e-14)
    a_min = float(min(mine[:2]))
    result, _ = _assert_matches(s, f, a_min * (1 - 1e-9))
    assert result.status == Status.STATIC
    for xi in (0.5, 0.9):
        a = _window(s, f, xi)
        result, _ = _assert_matches(s, f, a)
        assert result.status == Status.STICK_SLIP
        # Mirror symmetry alpha -> -alpha, bit for bit up to rounding.
        mirrored, _ = study.steady_velocity(_paper(alpha=-alpha), f, a)
        assert abs(float(mirrored) + float(result.velocity)) <= 4 * EPS * abs(result.velocity)


@pytest.mark.parametrize("f", TILT_FREQUENCIES)
@pytest.mark.parametrize("alpha", [1e-6, 0.01])
def test_velocity_scales_as_tilt_squared(alpha, f):
    """Not linear: at a fixed relative position xi in the window (whose width ~ alpha),
    n_min and |tau| are ~ alpha, the release arcs ~ sqrt(alpha), slip speeds
    ~ alpha^(3/2) and displacements ~ alpha^2. So v(2 alpha) = 4 v(alpha) (1 + O(alpha)).
    At a fixed a instead the point is simply static once alpha is small enough."""
    for xi in (0.5, 0.9):
        solver, reference, relative_bound = [], [], 0.0
        for tilt in (alpha, 2 * alpha):
            s = _paper(alpha=tilt)
            result, ref = _assert_matches(s, f, _window(s, f, xi))
            solver.append(float(result.velocity))
            reference.append(ref.velocity)
            relative_bound += ref.bound / abs(ref.velocity)
        # Reference: 4 to O(alpha) (alpha <= 2e-4 rad); the solver's ratio within the sum
        # of its two relative bounds (~ 64 eps / window width: up to ~1e-5 at 1e-6 deg).
        assert reference[1] / reference[0] == pytest.approx(4.0, rel=1e-3)
        assert solver[1] / solver[0] == pytest.approx(reference[1] / reference[0],
                                                      rel=relative_bound)
    # And the motion is tiny: v(0.01 deg) ~ 1e-9..1e-8 m/s times (1e-4)^2.
    if alpha == 1e-6:
        s = _paper(alpha=alpha)
        assert abs(study.steady_velocity(s, f, _window(s, f, 0.999))[0]) < 1e-16


@pytest.mark.parametrize("f", [13.0, 16.0])
def test_near_vertical_plate_velocity_vanishes_with_cos_alpha(f):
    """Off resonance the window width is ~ cos(alpha): the same argument gives
    v ~ cos(alpha)^2 at a fixed xi; compare 89.99 with 89.9999 (cos ratio 100)."""
    v = []
    for tilt in (89.99, 89.9999):
        s = _paper(alpha=tilt)
        v.append(_assert_matches(s, f, _window(s, f, 0.5))[1].velocity)
    c = math.cos(math.radians(89.99)) / math.cos(math.radians(89.9999))
    assert v[0] / v[1] == pytest.approx(c**2, rel=1e-2)


# ----------------------------------------------------------------------------------
# 10. Mass ratio near 0 and exactly 1
# ----------------------------------------------------------------------------------


@pytest.mark.parametrize("f", [13.0, 14.44, 16.0])
@pytest.mark.parametrize("M", [1e-6, 1e-4])
def test_tiny_mass_ratio(M, f):
    """M -> 0: thresholds and lift-off all tend to g; static below, and the motion in
    the window (width ~ M) is tiny, ~ M^2 (same argument as for the tilt)."""
    s = _paper(M=M)
    a_min = float(min(study.thresholds(s, f)))
    a_lift = float(study.lift_off_acceleration(s, f))
    assert abs(a_lift / s.g - 1) < 10 * M and abs(a_min / s.g - 1) < 10 * M
    for a in (0.5 * s.g, a_min * (1 - 1e-9)):
        result, _ = _assert_matches(s, f, a)
        assert result.status == Status.STATIC and result.velocity == 0.0
    for xi in (0.5, 0.9, 0.999):
        a = _window(s, f, xi)
        result, _ = _assert_matches(s, f, a)
        assert result.status == Status.STICK_SLIP
        # Table velocity amplitude a / w times M^2, with a margin of 100 over the
        # observed prefactor (11 at most, at xi = 0.999).
        assert abs(result.velocity) < 100 * M**2 * a / (TWO_PI * f)


@pytest.mark.parametrize("f", [13.0, 16.0])
def test_velocity_scales_as_mass_ratio_squared(f):
    v = [_reference(_paper(M=M), f, _window(_paper(M=M), f, 0.5)).velocity
         for M in (1e-6, 1e-4)]
    assert v[1] / v[0] == pytest.approx(1e4, rel=1e-2)  # next order ~ Q M cos^2 = 3e-4


UNIT_MASS_FREQUENCIES = [5.0, 11.0, 16.0, 40.0]


@pytest.mark.parametrize("f", UNIT_MASS_FREQUENCIES)
def test_unit_mass_ratio(f):
    """M = 1 exactly (the whole mass resonates): stick-slip off resonance, sliding near."""
    s = _paper(M=1.0)
    result, _ = _assert_matches(s, f, _window(s, f, 0.5))
    assert result.status == (Status.CONTINUOUS_SLIDING if f == 16.0 else Status.STICK_SLIP)


# ----------------------------------------------------------------------------------
# 11. Every case returns; a random sample of the whole parameter space
# ----------------------------------------------------------------------------------


def _all_cases():
    """(structure, f, a) of every point solved above."""
    s = PAPER_STRUCTURE
    cases = []
    for f, sign in LOWER_THRESHOLDS + UPPER_THRESHOLDS:
        a_star = _threshold(s, f, sign)
        cases += [(s, f, a_star * (1 + d)) for d in (-1e-12, 1e-12, 1e-6, 2e-6)]
    for ck in (0.2, 0.025, 0.0025):
        for f, sign, alpha, _ in SWITCHING:
            t = _paper(alpha=alpha, ck=ck)
            cases.append((t, f, _switching_acceleration(t, f, sign)))
    for M, f in LIFT_OFF:
        t = _paper(M=M)
        a_lift = float(study.lift_off_acceleration(t, f))
        cases += [(t, f, a_lift * (1 - 1e-9)), (t, f, a_lift * (1 + 1e-9))]
    for param in _quality_cases():
        Q, f, xi = param.values
        cases.append((_paper(Q=Q), f, _window(_paper(Q=Q), f, xi)))
    for ratio in FAR_RATIOS:
        cases += [(s, s.f0 * ratio, _window(s, s.f0 * ratio, xi)) for xi in (0.5, 0.999)]
    for M, ratio, f, a in SMALL_CK:
        cases.append((_paper(M=M, ck=PAPER["cs"] * ratio), f, a))
    for M in NEAR_ONE:
        for f, xi, ratio in SLIDING_POINTS:
            t = _paper(M=M, ck=PAPER["cs"] * ratio)
            cases.append((t, f, _window(t, f, xi)))
        cases.append((_paper(M=M), 13.0, _window(_paper(M=M), 13.0, 0.5)))
    for param in SLIDING_CYCLES_TO_FLOAT64:
        params, f, a = param.values
        cases.append((study.Structure(**params), f, a))
    for alpha in TILTS:
        for f in TILT_FREQUENCIES:
            t = _paper(alpha=alpha)
            cases += [(t, f, _window(t, f, xi)) for xi in (0.5, 0.9)]
    for M in (1e-6, 1e-4):
        for f in (13.0, 14.44, 16.0):
            t = _paper(M=M)
            cases += [(t, f, _window(t, f, xi)) for xi in (0.5, 0.9, 0.999)]
    cases += [(_paper(M=1.0), f, _window(_paper(M=1.0), f, 0.5)) for f in UNIT_MASS_FREQUENCIES]
    cases += [(_paper(alpha=0.0, ck=ck), f, float(study.lift_off_acceleration(
        _paper(alpha=0.0), f))) for ck in (0.25, 0.1) for f in (5.9375, 6.3125)]
    return cases


def _assert_well_formed(result) -> None:
    status = np.asarray(result.status)
    assert np.isin(status, [s.value for s in Status]).all()
    flagged = np.isin(status, [Status.LIFT_OFF, Status.NOT_CONVERGED])
    assert (np.isnan(result.velocity) == flagged).all()
    not_converged = status == Status.NOT_CONVERGED
    assert ((np.asarray(result.reason) != NonConvergence.NONE) == not_converged).all()
    assert (result.velocity[status == Status.STATIC] == 0).all()
    moving = np.isin(status, [Status.STICK_SLIP, Status.CONTINUOUS_SLIDING])
    assert (result.orbit_period[moving] >= 1).all()
    for fraction in (result.forward_fraction, result.backward_fraction):
        assert ((fraction[moving] >= 0) & (fraction[moving] <= 1)).all()


def test_every_hard_case_returns_a_well_formed_result():
    """A timing guard without timing: every case above returns, each with a valid status
    and NaN exactly where flagged (the alpha = 0 lift-off points included: flagged
    NOT_CONVERGED there is wrong, but it is not silent)."""
    cases = _all_cases()
    assert len(cases) > 150
    for s, f, a in cases:
        result = study.steady_state(s, np.array([f]), np.array([a]))
        _assert_well_formed(result)


RANDOM_POINTS = 2000


def _random_points(seed: int):
    """Points over the whole valid space: Q 0.5..1e4, f 0.01..100 f0, alpha
    -89.99..89.99, M 1e-6..1, ck/cs 1e-3..1 (log-uniform where the range spans
    decades), cs 0.1..1; a uniform on [0, a_lift) for half of them and on
    [min a*, a_lift) for the other half, so that many points move."""
    rng = np.random.default_rng(seed)
    points = []
    for i in range(RANDOM_POINTS):
        cs = float(np.exp(rng.uniform(np.log(0.1), 0.0)))
        with tilt_warnings(False):  # small tilts are part of the space, in degree
            s = study.Structure(
                f0=14.44,
                Q=float(np.exp(rng.uniform(np.log(0.5), np.log(1e4)))),
                alpha=float(rng.uniform(-89.99, 89.99)),
                M=float(np.exp(rng.uniform(np.log(1e-6), 0.0))),
                cs=cs,
                ck=cs * float(np.exp(rng.uniform(np.log(1e-3), 0.0))),
            )
        f = s.f0 * float(np.exp(rng.uniform(np.log(0.01), np.log(100.0))))
        a_lift = float(study.lift_off_acceleration(s, f))
        a_min = float(min(study.thresholds(s, f)))
        u = float(rng.uniform())
        a = a_min + u * (a_lift - a_min) if i % 2 and a_min < a_lift else u * a_lift
        points.append((s, f, a))
    return points


@pytest.fixture(scope="module")
def random_sample():
    points = _random_points(20261121)
    results = [study.steady_state(s, f, a) for s, f, a in points]
    return points, results


def test_random_sample_of_the_whole_parameter_space(random_sample):
    points, results = random_sample
    statuses = np.array([int(r.status) for r in results])
    for result in results:
        _assert_well_formed(result)
    not_converged = [(p, int(r.reason)) for p, r in zip(points, results, strict=True)
                     if r.status == Status.NOT_CONVERGED]
    assert len(not_converged) < 1e-3 * RANDOM_POINTS, not_converged
    for _, reason in not_converged:
        assert reason in (NonConvergence.NO_PERIODIC_ORBIT, NonConvergence.EVENT_BUDGET)
    # The sample is not trivial: it moves both ways and slides.
    assert (statuses == Status.STICK_SLIP).sum() > 500
    assert (statuses == Status.CONTINUOUS_SLIDING).sum() >= 5
    assert (statuses == Status.STATIC).sum() > 500


def test_random_sample_spot_checks(random_sample):
    """Every 25th stick-slip point and every 4th sliding one against the references."""
    points, results = random_sample
    statuses = [Status(int(r.status)) for r in results]
    chosen = ([i for i, st in enumerate(statuses) if st == Status.STICK_SLIP][::25]
              + [i for i, st in enumerate(statuses) if st == Status.CONTINUOUS_SLIDING][::4])
    assert len(chosen) >= 30
    for i in chosen:
        _assert_matches(*points[i])
