"""The exact flight solver's periodic orbits, checked by the independent reference
without any transient: the reference (``tests/reference/flight.py``, ``solve_ivp`` at
rtol 1e-12 with its own impact law) starts ON the exact solver's orbit state at phase 0
and follows it for a few orbit periods. A periodic orbit must come back to its start
(to the reference's tolerance, in its natural units ``g / W^2`` and ``g / W``) with the
exact solver's mean velocity, airborne fraction and impacts. This needs no transient, so
it holds for Q = 1e4 (whose transients last thousands of periods) as cheaply as for
Q = 17.5, and it checks the whole state of the orbit, not only its statistics.

The orbit's state at phase 0 is the 5-state ``z`` that
:func:`study.kernels.two_way.flight_orbit.solve_flight` updates in place (the output
row keeps only ``delta``, ``delta'``, ``v``; the gap and its rate are not written there);
the call is the one ``solve_point`` makes for a point past lift-off, and its velocity is
checked to equal ``steady_state``'s bit for bit.

Covered: Q 0.5-1e4 at four drives; two seeded samples (plastic and e = 0.5; chattering,
e 0.2-0.85); grazing take-off (n' -> 0, with the reference at rtol 3e-14); M = 0.999,
0.9999; always-airborne orbits against their closed form; and (slow) the points without
a periodic orbit, where the reference finds none either.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.kernels.two_way.flight import CHATTER
from study.kernels.two_way.flight_orbit import solve_flight
from study.kernels.two_way.points import FLIGHT_COLUMNS, OUTPUT_COLUMNS, start_state
from study.model.status import NonConvergence, Status
from study.solvers.exact import steady_state
from study.solvers.settings import DEFAULT_SETTINGS, kernel_budget
from tests.hard_cases.test_flight_hard_cases import _threshold
from tests.reference.flight import FlightModel, simulate, steady_motion
from tests.unit.test_flight_exact import drive_point

PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25}
NAMES = tuple(name for name, _, _ in OUTPUT_COLUMNS)
#: The orbit's phase-0 state after the reference's periods, in natural units.
STATE_TOLERANCE = 1e-8
#: Mean velocity over those periods, in units of the table's speed a / w.
VELOCITY_TOLERANCE = 1e-10


def exact_orbit(structure, f, a):
    """The exact solver's orbit from rest: its state at phase 0 ``(delta [m], delta'
    [m s-1], v [m s-1], h [m], h' [m s-1])`` and its output row (by column name)."""
    point = drive_point(structure, f, a)
    z = np.zeros(5)
    start_state(point.table, point.omega, 0.0, z, 1.0)
    out = np.full(len(NAMES), np.nan)
    solve_flight(point.structure, point.table, point.omega, a,
                 kernel_budget(DEFAULT_SETTINGS), z, 0.0, out, FLIGHT_COLUMNS)
    return z, dict(zip(NAMES, out, strict=True))


def check_closure(structure, f, a, repeats=2, airborne_tolerance=1e-9,
                  state_tolerance=STATE_TOLERANCE, **options):
    """The reference from the exact orbit's phase-0 state over ``repeats`` orbit periods:
    back at the start, with the exact velocity, airborne fraction and (plastic) impacts
    (``options``: the reference's ``rtol``, ``steps_per_period``). Returns the exact row
    and the measured differences."""
    z, row = exact_orbit(structure, f, a)
    public = steady_state(structure, f, a, coupling="two-way", flight=True, parallel=False)
    assert Status(int(row["status"])) == Status(int(public.status)) == Status.BOUNCING
    assert row["velocity"] == float(public.velocity)
    periods = int(row["period"])
    assert periods >= 1
    span = repeats * periods / f
    sim = simulate(structure, f, a, span, z, **options)
    assert sim.status == "ok"
    scale = FlightModel(structure, f, a).scale[[0, 1, 3, 4, 5]]
    state_error = float(np.max(np.abs(np.asarray(sim.final) - z) / scale))
    speed = a / (2.0 * math.pi * f)
    velocity_error = abs(sim.displacement / span - row["velocity"]) / speed
    airborne_error = abs(sim.airborne_time / span - row["airborne"])
    assert state_error < state_tolerance, (state_error, z, sim.final)
    assert velocity_error < VELOCITY_TOLERANCE, (sim.displacement / span, row["velocity"])
    if structure.restitution == 0.0:
        assert airborne_error < airborne_tolerance, (sim.airborne_time / span, row["airborne"])
        assert sim.impacts == round(row["impacts"] * repeats * periods)
    else:
        # The chatter cut-offs differ: the exact solver lands plastically below CHATTER
        # (1e-7) of the natural speed, the reference below 1e-9 of a / w, so the exact
        # orbit counts fewer of the tiny last rebounds (24 against 31, say) and its
        # airborne fraction is shorter by their duration, ~CHATTER of a period when the
        # gap's effective gravity is ~g (more where it is small: see the Q test).
        assert airborne_error < max(3.0 * CHATTER, airborne_tolerance)
        assert row["impacts"] <= sim.impacts / (repeats * periods)
    return row, state_error, velocity_error


Q_POINTS = {
    "M0.3": ({"M": 0.3}, 14.5, 12.0),
    "M0.99": ({"M": 0.99}, 14.5, 10.0),
    "M0.08": ({"M": 0.08}, 14.5, 12.0),
    "M0.6-e0.5": ({"M": 0.6, "restitution": 0.5}, 15.0, 9.0),
}


@pytest.mark.parametrize("q", [0.5, 2.0, 17.5, 100.0, 1e3, 1e4])
@pytest.mark.parametrize("name", sorted(Q_POINTS))
def test_q_half_to_ten_thousand_orbit_closes_in_reference(name, q):
    """Q from 0.5 to 1e4 at four bouncing drives (M = 0.99, Q = 1e4: a period-4 orbit):
    the exact orbit is an orbit of the reference, with the same velocity. Where the
    exact solver does not bounce (M = 0.6, e = 0.5, Q = 0.5: stick-slip) the reference
    from rest agrees on the status and the velocity.

    The chatter at M = 0.6, e = 0.5, Q = 2 happens where the gap's effective gravity is
    small (0.36 m s-2, from the reference's successive rebounds): the exact solver's
    cut-off then shortens the airborne fraction by 6e-7 (of 0.059), more than the
    ~CHATTER (1e-7) its comment states for g_eff ~ g (the skipped rebounds last
    2 u / (g_eff (1 - e))); the velocity still agrees to 1e-13 a / w."""
    changes, f, a = Q_POINTS[name]
    s = study.Structure(**{**PAPER, **changes, "Q": q})
    _, row = exact_orbit(s, f, a)
    if Status(int(row["status"])) != Status.BOUNCING:
        motion = steady_motion(s, f, a)
        assert (Status(int(row["status"])), motion.status) == (Status.STICK_SLIP, "stick-slip")
        assert abs(motion.velocity - row["velocity"]) < VELOCITY_TOLERANCE * a / (
            2.0 * math.pi * f)
        return
    airborne = 1e-6 if s.restitution > 0.0 else 1e-9
    check_closure(s, f, a, repeats=3, airborne_tolerance=airborne)


def _random_points(count, seed):
    rng = np.random.default_rng(seed)
    points = []
    for _ in range(count):
        s = study.Structure(**{**PAPER, "M": float(rng.uniform(0.05, 0.99)),
                               "restitution": float(rng.choice([0.0, 0.5]))})
        points.append((s, float(rng.uniform(8.0, 25.0)), float(rng.uniform(8.0, 20.0))))
    return points


def test_random_bouncing_orbits_close_in_reference():
    """A seeded sample (M 0.05-0.99, e in {0, 0.5}, f 8-25 Hz, a 8-20 m s-2): at every
    bouncing point the exact orbit closes in the reference with the exact velocity; no
    point is LIFT_OFF or without a status."""
    bouncing = 0
    for s, f, a in _random_points(40, 2111):
        r = steady_state(s, f, a, coupling="two-way", flight=True, parallel=False)
        st = Status(int(r.status))
        assert st != Status.LIFT_OFF
        if st != Status.BOUNCING:
            continue
        check_closure(s, f, a)
        bouncing += 1
    assert bouncing >= 20


@pytest.mark.parametrize(("M", "f", "lo", "hi"),
                         [(0.08, 14.5, 9.0, 12.0), (0.6, 12.0, 6.0, 8.0), (0.99, 14.5, 3.0, 6.0)])
def test_grazing_take_off_against_reference(M, f, lo, hi):
    """Take-off with n' -> 0: 1e-6 and 1e-4 (relative) above the bouncing threshold the
    exact orbit (flights of 1e-3 and 1e-2 of a period, hops of 1e-14 and 1e-10 m) closes
    in the reference with the exact velocity and airborne fraction, and the reference
    from rest reaches the same orbit and hop.

    The airborne fraction is ill-conditioned there: a take-off is located where
    ``n = 0`` with ``n'`` small, so the reference's time error is its residual over
    ``n'``. At its default rtol 1e-12 it is off by 1.2e-7 (1e-6 above, M = 0.08); at
    3e-14 by 5e-11, converging to the exact solver's value, so the check uses 3e-14."""
    s = study.Structure(**{**PAPER, "M": M})
    _, above = _threshold(s, f, lo, hi)
    for excess in (1e-6, 1e-4):
        a = above * (1.0 + excess)
        row, _, _ = check_closure(s, f, a, repeats=1, airborne_tolerance=2e-10,
                                  rtol=3e-14, steps_per_period=128)
        assert 0.0 < row["airborne"] < 0.02 and 0.0 < row["hop"] < 1e-9
    # From rest (the transient too), at the default rtol: the same orbit and hop.
    motion = steady_motion(s, f, a)
    assert motion.status == "bouncing" and motion.period == int(row["period"])
    assert abs(motion.velocity - row["velocity"]) < VELOCITY_TOLERANCE * a / (2 * math.pi * f)
    assert_allclose(motion.largest_hop, row["hop"], rtol=1e-3)



# Slow tier: the random bouncing orbits keep closure's headline in the default tier
# (issue 46).
@pytest.mark.slow
def test_random_chattering_orbits_close_in_reference():
    """A second seeded sample with restitution (M 0.02-0.98, Q 0.7-300, e in {0.2, 0.5,
    0.7, 0.85}, f 6-25 Hz, a 6-22 m s-2): every bouncing orbit (79 of 150) closes in the
    reference with the exact velocity (found: to 7e-13 a / w, state to 5e-11); the chatter
    cut-offs move the airborne fraction by up to 1.9e-7 (tolerance 1e-6: see the Q test
    for where the gap's effective gravity is small)."""
    rng = np.random.default_rng(5)
    bouncing = 0
    for _ in range(150):
        s = study.Structure(**{
            **PAPER, "M": float(rng.uniform(0.02, 0.98)),
            "Q": float(np.exp(rng.uniform(np.log(0.7), np.log(300.0)))),
            "restitution": float(rng.choice([0.2, 0.5, 0.7, 0.85]))})
        f, a = float(rng.uniform(6.0, 25.0)), float(rng.uniform(6.0, 22.0))
        _, row = exact_orbit(s, f, a)
        st = Status(int(row["status"]))
        assert st != Status.LIFT_OFF
        if st != Status.BOUNCING:
            continue
        check_closure(s, f, a, repeats=1, airborne_tolerance=1e-6)
        bouncing += 1
    assert bouncing >= 60



@pytest.mark.parametrize("M", [0.999, pytest.param(0.9999, marks=pytest.mark.slow)])
def test_mass_ratio_towards_one_orbits_close_in_reference(M):
    """M -> 1 across the small map of the hard cases (f 11-18 Hz, a 4-12 m s-2): every
    bouncing orbit (32 of 40, periods 1 and 2) closes in the reference with the exact
    velocity.

    The state tolerance is 1e-8 of the reference's natural scales ``g / W^2`` and
    ``g / W`` with ``W = w0 / sqrt(1 - M)``: at M = 0.9999 the length scale is 1e-4 of
    M = 0.99's, and at its default rtol the reference misses it by up to 5e-8 (its gap
    to ~1e-15 m), so it runs at rtol 1e-13 with 64 steps a period, over one orbit
    period, to 1e-7 (found: up to 1.1e-8 at M = 0.9999; velocity to 1e-10 a / w)."""
    s = study.Structure(**{**PAPER, "M": M})
    bouncing = 0
    for f in np.linspace(11.0, 18.0, 8):
        for a in np.linspace(4.0, 12.0, 5):
            _, row = exact_orbit(s, f, a)
            if Status(int(row["status"])) != Status.BOUNCING:
                continue
            check_closure(s, f, a, repeats=1, state_tolerance=1e-7, rtol=1e-13,
                          steps_per_period=64)
            bouncing += 1
    assert bouncing >= 30


#: Points where the exact solver finds no periodic orbit: four of the seeded sample above
#: (e = 0.5) and e = 0.9 at M = 0.6, 15 Hz, 9 m s-2. Since the solver follows irregular
#: motions (issue 35) two of them are CHAOTIC or QUASI_PERIODIC with a time-averaged
#: velocity and three end NOT_CONVERGED (AVERAGE_BUDGET: the mean's standard error stayed
#: above the velocity tolerance over the averaged periods).
IRREGULAR = [
    ({"M": 0.4791, "restitution": 0.5}, 14.621, 17.737),
    ({"M": 0.7509, "restitution": 0.5}, 23.214, 16.400),
    ({"M": 0.7938, "restitution": 0.5}, 16.899, 19.066),
    ({"M": 0.2533, "restitution": 0.5}, 24.451, 17.986),
    ({"M": 0.6, "restitution": 0.9}, 15.0, 9.0),
]


@pytest.mark.slow
@pytest.mark.parametrize(("changes", "f", "a"), IRREGULAR)
def test_no_periodic_orbit_is_irregular_in_reference(changes, f, a):
    """Where the exact solver finds no periodic orbit, the reference followed from rest
    finds no orbit of up to 8 periods in 400 periods either (5-16 s each), and the
    solver says so: an irregular motion (CHAOTIC or QUASI_PERIODIC, no multiplier) whose
    averaged velocity the reference's own 64-period mean confirms, or NOT_CONVERGED with
    AVERAGE_BUDGET and no velocity.

    The two means are of different trajectories over different spans, so they agree to
    their statistical error: within 5 standard errors of the reference's shorter mean,
    the solver's error scaled by sqrt(averaged periods / 64) (measured: 5.9e-5 m s-1 at
    the chaotic point, 0.5 of that bound; 1.1e-5 at the quasi-periodic one). A
    wrong time average (a term or a sign) is off by a fraction of the velocity."""
    s = study.Structure(**{**PAPER, **changes})
    r = steady_state(s, f, a, coupling="two-way", flight=True, parallel=False)
    motion = steady_motion(s, f, a, max_periods=400)
    assert motion.status == "not-periodic" and motion.period == 0
    status = Status(int(r.status))
    assert math.isnan(float(r.floquet_multiplier))
    if status == Status.NOT_CONVERGED:
        assert NonConvergence(int(r.reason)) == NonConvergence.AVERAGE_BUDGET
        assert math.isnan(float(r.velocity))
        return
    assert status in (Status.CHAOTIC, Status.QUASI_PERIODIC)
    error = float(r.velocity_error) * math.sqrt(1.0 + int(r.averaged_periods) / 64)
    assert_allclose(motion.velocity, float(r.velocity), rtol=0.0, atol=5.0 * error)


def always_airborne_velocity(structure, f):
    """Mean velocity [m s-1] of a period-1 orbit that never rests on the table and lands
    once a period with the base stuck (``v+ = 0``), in closed form.

    Over a period the normal impulse balances gravity, ``Pz = g T``; the horizontal
    momentum ``v + M sa delta'`` is constant in flight and, the orbit being periodic, the
    impact's tangential impulse is 0, so the mean velocity is that momentum, ``M sa
    delta'+`` (the mean of ``delta'`` vanishes). In flight the mode is the free oscillator
    ``(1 - M) delta'' + c delta' + k delta = g ca``, kicked at each impact by
    ``d(delta') = -e.dV = -ca g T / (1 - M)`` (``dV = W (0, Pz)``): its periodic response
    to that comb, just after a kick, is ``J Re[(1 + i b / W_d) / (1 - exp((-b + i W_d) T))]``
    (``b = c / (2 (1 - M))``, ``W_d^2 = k / (1 - M) - b^2``). Independent of ``e`` and of
    the drive amplitude."""
    alpha = math.radians(structure.alpha)
    sa, ca = math.sin(alpha), math.cos(alpha)
    w0 = 2.0 * math.pi * structure.f0
    m = structure.M
    period = 1.0 / f
    b = w0 / structure.Q / (2.0 * (1.0 - m))
    wd = math.sqrt(w0 * w0 / (1.0 - m) - b * b)
    kick = -ca * structure.g * period / (1.0 - m)
    response = (1.0 + 1j * b / wd) / (1.0 - cmath.exp(complex(-b, wd) * period))
    return m * sa * kick * response.real


@pytest.mark.parametrize(("M", "e", "f", "a"),
                         [(0.08, 0.6, 14.5, 16.0), (0.08, 0.8, 14.5, 12.0),
                          (0.08, 0.9, 14.5, 12.0), (0.08, 0.95, 14.5, 10.0),
                          (0.08, 0.95, 14.5, 12.0), (0.3, 0.6, 14.5, 16.0),
                          (0.3, 0.8, 14.5, 16.0)])
def test_always_airborne_orbit_closed_form(M, e, f, a):
    """e -> 1: orbits always in the air with one stuck landing a period (found on a grid
    of M, e, f, a) have the closed-form velocity to 1e-12 relative; the reference sees
    one impact a period, ending stuck, with normal impulse g T."""
    s = study.Structure(**{**PAPER, "M": M, "restitution": e})
    row, _, _ = check_closure(s, f, a)
    assert row["airborne"] == 1.0 and row["impacts"] == 1.0 and row["period"] == 1.0
    assert_allclose(row["velocity"], always_airborne_velocity(s, f), rtol=1e-12)
    z, _ = exact_orbit(s, f, a)
    landings = simulate(s, f, a, 1.0 / f, z).events
    assert [ev["kind"] for ev in landings] == ["impact"]
    assert landings[0]["ended"] == "stick"
    assert_allclose(landings[0]["normal_impulse"], s.g / f, rtol=1e-10)
