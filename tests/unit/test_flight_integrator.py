"""Flight and impacts in the time integrator (``flight=True``, :mod:`study.solvers.integrator`).

Each test compares against something the integrator does not share code with:

* refusals: ``flight`` must be a bool, needs two-way coupling and ``M < 1``;
* below lift-off ``flight=True`` is the contact orbit of ``flight=False`` (a second run
  with another state size and step sequence);
* M -> 0: the rigid block on a shaken table (``tests/reference/rigid_block.py``, closed
  form: take-off where ``a cos(w t) = g``, parabolic flight, plastic landing), errors
  of order M;
* a drop on a still table: the bouncing ball's closed form (impact times, rebound speeds
  ``e^k u1``, the accumulation of chattering and its cut-off);
* the independent ``solve_ivp`` reference (``tests/reference/flight.py``, rtol 1e-12,
  its own impact law and cut-off) on velocity, airborne fraction, largest hop and
  impacts at M in {0.08, 0.5, 0.9} and e in {0, 0.5, 0.9}, also for a transient after
  a frequency switch that passes through flight;
* the reference's 78 cached steady motions from rest (``tests/reference/data/
  flight_points.json``: stick-slip then bouncing, static then bouncing, M up to 0.99,
  large drives with subharmonic and chaotic bouncing, a long chattering sequence at
  e = 0.9), and its 24 from a drop or from stillness (two stable motions near M = 1,
  drops onto contact), by transients;
* the mirror ``alpha -> -alpha`` (velocity reversed, the rest unchanged);
* one event sample per step (impacts then found only by the watch of the gap's minima)
  against four;
* a grazing take-off just above the lift-off threshold: a hop of the size the dip of
  the normal force allows, and the contact velocity.
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from study import Structure
from study.kernels import integrator as kernel
from study.model.disk import Disk, Plate
from study.model.status import Status
from study.solvers.exact import steady_state
from study.solvers.integrator import (
    EVENT_KINDS,
    IntegratorSettings,
    Schedule,
    integrated_steady_state,
    simulate,
    steady_mode_state,
)
from tests.reference import flight as reference
from tests.reference.rigid_block import one_period_amplitude, rigid_block
from tests.support.tiers import headline

PAPER = dict(f0=14.44, Q=17.5, alpha=64.0, cs=0.25)
TOLERANCE = 1e-10
SETTINGS = IntegratorSettings(tolerance=TOLERANCE)
# The integrator's global error against the reference: its local tolerance times a
# factor for the accumulation over the transient and the orbit, in natural units.
GLOBAL = 1e3 * TOLERANCE


def _structure(M, e=0.0, **changes):
    return Structure(**{**PAPER, "M": M, "restitution": e, **changes})


def _kinds(run):
    return [EVENT_KINDS[int(k)] for k in run.event_kind]


# ---------------------------------------------------------------- refusals


@pytest.mark.parametrize("value", [1, 0, "yes", None])
def test_flight_must_be_a_bool(value):
    with pytest.raises(TypeError, match="flight must be True or False"):
        simulate(_structure(0.5), Schedule.constant(14.0, 5.0, 0.1), coupling="two-way",
                 flight=value)
    with pytest.raises(TypeError, match="flight must be True or False"):
        integrated_steady_state(_structure(0.5), 14.0, 5.0, coupling="two-way", flight=value)


def test_flight_refused_with_one_way_coupling_and_at_unit_mass_ratio():
    schedule = Schedule.constant(14.0, 5.0, 0.1)
    with pytest.raises(ValueError, match=r"flight=True needs coupling='two-way'.*"
                                         r"driven by the table alone"):
        simulate(_structure(0.5), schedule, flight=True)
    with pytest.raises(ValueError, match=r"flight=True needs coupling='two-way'"):
        integrated_steady_state(_structure(0.5), 14.0, 5.0, coupling="one-way", flight=True)
    with pytest.raises(ValueError, match=r"M < 1, got M=1.0.*massless.*unbounded"):
        simulate(_structure(1.0), schedule, coupling="two-way", flight=True)
    with pytest.raises(ValueError, match=r"M < 1, got M=1.0"):
        integrated_steady_state(_structure(1.0), 14.0, 5.0, coupling="two-way", flight=True)


def test_flight_start_state_is_checked():
    schedule = Schedule.constant(14.0, 5.0, 0.1)
    with pytest.raises(ValueError, match=r"the gap h = -0.001 m must be >= 0"):
        simulate(_structure(0.5), schedule, coupling="two-way", flight=True,
                 initial_state=(0, 0, 0, 0, -1e-3, 0))
    with pytest.raises(ValueError, match=r"initial_state must be 4 finite numbers"):
        simulate(_structure(0.5), schedule, coupling="two-way",
                 initial_state=(0, 0, 0, 0, 1e-3, 0))


def test_the_planar_model_refuses_flight_naming_law_solver_and_allowed_values():
    plate = Plate(f0=14.44, Q=17.5, alpha=64.0, M=0.08)
    with pytest.raises(ValueError, match=r"Disk: flight = True: lift_off law 'flight' is not "
                                         r"implemented by the planar integrator \('planar'\); "
                                         r"allowed: 'stop'"):
        Disk(radius=0.02, plates=(plate,), cs=0.25, flight=True)
    assert not Disk(radius=0.02, plates=(plate,), cs=0.25).flight


# ---------------------------------------------------------------- without flight


def test_without_flight_the_run_stops_at_lift_off_and_reports_no_flight():
    run = simulate(_structure(0.5), Schedule.constant(14.44, 14.0, 1.0), coupling="two-way")
    assert run.outcome == "lift_off"
    assert run.gap is None and run.gap_rate is None
    assert (run.airborne_time, run.largest_hop, run.impacts) == (0.0, 0.0, 0)
    assert run.event_state.shape[1] == kernel.STATE_SIZE
    state = integrated_steady_state(_structure(0.5), 14.44, 14.0, coupling="two-way")
    assert state.status == Status.LIFT_OFF
    assert state.airborne_fraction is None and state.impacts_per_period is None


def test_below_lift_off_flight_is_the_contact_orbit():
    # Never leaves the table: same orbit as without flight (another state size and so
    # another step sequence: equal to the tolerance, not bit for bit).
    f = np.array([12.0, 14.44, 16.0])
    for M in (0.08, 0.5):
        without = integrated_steady_state(_structure(M), f, 4.0, coupling="two-way",
                                          settings=SETTINGS)
        with_flight = integrated_steady_state(_structure(M), f, 4.0, coupling="two-way",
                                              settings=SETTINGS, flight=True)
        # (At 14.44 Hz the two-way transient from the canonical start lifts off at
        # M = 0.08: LIFT_OFF without flight; with flight it lands and settles.)
        stays = without.status != Status.LIFT_OFF
        assert stays.sum() >= 2
        assert np.all(without.status[stays] == with_flight.status[stays])
        assert np.all(np.isin(with_flight.status, (Status.STICK_SLIP, Status.STATIC)))
        assert_allclose(with_flight.velocity[stays], without.velocity[stays], rtol=0,
                        atol=GLOBAL * 9.8 / (2 * np.pi * f).max())
        assert np.all(with_flight.airborne_fraction == 0.0)
        assert np.all(with_flight.largest_hop == 0.0)
        assert np.all(with_flight.impacts_per_period == 0.0)


# ---------------------------------------------------------------- the bouncing ball


@pytest.mark.parametrize("e", [0.0, 0.5, 0.9])
def test_a_drop_on_a_still_table_is_the_bouncing_ball(e):
    # The mode starts at its flight equilibrium g cos(alpha) / k, so the first fall is a
    # parabola; with M = 1e-9 the mode's kicks at the impacts move the gap by ~1e-9.
    s = _structure(1e-9, e)
    g = s.g
    h0 = 1e-3
    rest = g * math.cos(s.alpha_rad) / s.omega0**2
    t1 = math.sqrt(2 * h0 / g)
    u1 = g * t1  # the first impact speed
    cut = kernel.CHATTER_SPEED * g / s.omega0
    rebounds = 0 if e == 0 else math.floor(math.log(cut / (e * u1)) / math.log(e)) + 1
    t_end = t1 + (2 * e * u1 / (g * (1 - e)) if e else 0.0) + 0.02
    run = simulate(s, Schedule.constant(10.0, 0.0, t_end), coupling="two-way", flight=True,
                   initial_state=(rest, 0, 0, 0, h0, 0), max_events=10_000,
                   settings=IntegratorSettings(tolerance=1e-12))
    assert run.outcome == "completed"
    impacts = run.event_kind == 6
    assert _kinds(run)[: impacts.sum()] == ["impact"] * int(impacts.sum())
    # Every rebound above the cut-off flies, the next lands plastically.
    assert run.impacts == impacts.sum() == rebounds + 1
    times = run.event_time[impacts]
    speeds = run.event_state[impacts, kernel.GAP_RATE]
    k = np.arange(rebounds + 1)
    expected_speeds = np.where(k < rebounds, u1 * e ** (k + 1), 0.0)
    # Each impact is located to the event tolerance, 1e-12 drive periods (0.1 s): its
    # speed to about g 1e-13 s.
    assert_allclose(speeds, expected_speeds, rtol=1e-9, atol=10 * g * 1e-13)
    # t_k = t1 + sum_{j<k} 2 e^(j+1) u1 / g: the flight times shrink by e.
    expected_times = t1 + np.concatenate(([0.0], np.cumsum(2 * u1 * e ** (k[:-1] + 1) / g)))
    # (each impact time to the event tolerance, and the errors add up over 200 impacts)
    assert_allclose(times, expected_times, rtol=0, atol=1e-10)
    # Chattering ends before its accumulation point, on the table at rest.
    if e:
        assert times[-1] < t1 + 2 * e * u1 / (g * (1 - e))
    assert run.gap[-1] == 0.0 and run.mode[-1] == 0
    assert run.v[-1] == 0.0
    assert_allclose(run.largest_hop, h0, rtol=0, atol=1e-12)
    assert_allclose(run.airborne_time, times[-1], rtol=1e-9)


# ---------------------------------------------------------------- grazing take-off


def test_a_grazing_take_off_hops_and_joins_the_contact_velocity():
    # Just above the two-way lift-off threshold (found by bisection on the exact solver)
    # the normal force dips below 0 for microseconds: a hop of order da^2 (the dip's
    # depth times its duration squared), 6e-19 m at 1e-7 m s-2 above, 8e-15 m at 1e-5
    # (the reference's grazing test: a hop of about 1e-18 m). The take-off, the landing
    # and no Zeno loop between them; the velocity joins the contact velocity.
    s = _structure(0.08)
    f = 14.5
    lo, hi = 9.0, 9.8
    for _ in range(48):
        mid = 0.5 * (lo + hi)
        status = steady_state(s, f, mid, coupling="two-way").status
        lo, hi = (lo, mid) if status == Status.LIFT_OFF else (mid, hi)
    below = steady_state(s, f, lo, coupling="two-way").velocity
    hops = []
    for above in (1e-7, 1e-5):
        ours = integrated_steady_state(s, f, hi + above, coupling="two-way", flight=True,
                                       settings=SETTINGS)
        assert ours.status == Status.BOUNCING and ours.impacts_per_period == 1.0
        assert 0.0 < ours.airborne_fraction < 1e-2
        assert_allclose(ours.velocity, below, rtol=1e-5)
        hops.append(ours.largest_hop)
    assert 1e-19 < hops[0] < 1e-17
    assert_allclose(hops[1] / hops[0], 1e4, rtol=0.5)


# ---------------------------------------------------------------- the rigid block


@pytest.mark.parametrize("M", [1e-6, 1e-9])
@pytest.mark.parametrize(("f", "a"), [(14.44, 11.0), (14.44, 14.0), (14.44, 25.0),
                                      (14.44, 35.0), (8.0, 20.0), (30.0, 12.0)])
def test_a_light_plate_is_the_rigid_block(M, f, a):
    # The plate's mass moves the block's flight by O(M): the errors scale with M.
    s = _structure(M)
    block = rigid_block(f, a, s.g)
    expected = "one-period-flight" if a > one_period_amplitude(s.g) else "bouncing"
    assert block.status == expected
    ours = integrated_steady_state(s, f, a, coupling="two-way", flight=True, settings=SETTINGS)
    assert ours.status == Status.BOUNCING
    assert ours.impacts_per_period == block.impacts_per_period == 1.0
    w = 2 * math.pi * f
    assert_allclose(ours.airborne_fraction, block.airborne_fraction, rtol=0,
                    atol=10 * M + GLOBAL)
    assert_allclose(ours.largest_hop, block.largest_hop, rtol=10 * M + 1e-8)
    # No horizontal force on the block: the velocity is of order M.
    assert abs(ours.velocity) < 100 * M * s.g / w + GLOBAL * s.g / w


# ---------------------------------------------------------------- the reference

# (M, e, f [Hz], a [m s-2]): bouncing orbits of one or two periods, one impact a
# period or a chattering sequence of about 30.
# The reference takes 5-15 s at a chattering point: two of them are in the slow tier.
REFERENCE_POINTS = [
    (0.08, 0.0, 14.44, 14.0),
    (0.08, 0.0, 12.0, 10.0),
    pytest.param(0.08, 0.5, 14.44, 14.0, marks=pytest.mark.slow),
    (0.5, 0.0, 12.0, 10.0),
    (0.5, 0.5, 14.44, 14.0),
    (0.9, 0.0, 14.44, 14.0),
    pytest.param(0.9, 0.5, 12.0, 10.0, marks=pytest.mark.slow),
    (0.99, 0.0, 14.5, 10.0),  # the M -> 1 example: a big hop, backwards
]


@pytest.mark.parametrize(("M", "e", "f", "a"), headline(REFERENCE_POINTS))
def test_bouncing_orbits_match_the_reference(M, e, f, a):
    s = _structure(M, e)
    ours = integrated_steady_state(s, f, a, coupling="two-way", flight=True, settings=SETTINGS)
    theirs = reference.steady_motion(s, f, a)
    assert theirs.status == "bouncing"
    assert ours.status == Status.BOUNCING
    w = 2 * math.pi * f
    assert_allclose(ours.velocity, theirs.velocity, rtol=0, atol=GLOBAL * s.g / w)
    assert_allclose(ours.airborne_fraction, theirs.airborne_fraction, rtol=0, atol=GLOBAL)
    assert_allclose(ours.largest_hop, theirs.largest_hop, rtol=0, atol=GLOBAL * s.g / w**2)
    if e == 0.0:
        assert ours.impacts_per_period == theirs.impacts_per_period == 1.0
    else:
        # The two cut-offs differ (g/w0 and a/w units): one rebound more or less.
        assert abs(ours.impacts_per_period - theirs.impacts_per_period) <= 1.0
        assert ours.impacts_per_period > 20


POINTS = Path(reference.__file__).parent / "data" / "flight_points.json"


# Slow tier (35 s in CI): the default tier keeps the cached motions from a drop or from
# stillness (test_cached_reference_motions_from_a_drop_or_from_stillness).
@pytest.mark.slow
def test_every_cached_reference_motion_from_rest():
    # The reference's file: every steady motion from rest (the integrator's start), by
    # structure (one call each, the points in parallel). A point the reference did not
    # settle (its refined rerun disagreed: today the two chaotic ones at 36 m s-2, near
    # M = 1) has nothing to compare with and is not integrated: the integrator spent
    # 20000 periods on each before NOT_CONVERGED, two thirds of this test's time.
    rest = [point for point in json.loads(POINTS.read_text(encoding="utf-8"))["points"]
            if point["start"] == "rest"]
    assert len(rest) >= 70
    groups = defaultdict(list)
    for point in rest:
        if point["settled"]:
            groups[tuple(sorted(point["structure"].items()))].append(point)
    compared = 0
    for key, points in groups.items():
        s = Structure(**dict(key))
        f = np.array([p["f"] for p in points])
        a = np.array([p["a"] for p in points])
        ours = integrated_steady_state(s, f, a, coupling="two-way", flight=True,
                                       settings=SETTINGS)
        w = 2 * np.pi * f
        for i, point in enumerate(points):
            if point["status"] == "not-periodic":
                # A settled irregular motion: no orbit either way.
                assert ours.status[i] == Status.NOT_CONVERGED, point["name"]
                continue
            assert point["status"] == "bouncing" and ours.status[i] == Status.BOUNCING
            tolerance = point["tolerance"]
            assert abs(ours.velocity[i] - point["velocity"]) <= (
                GLOBAL * s.g / w[i] + tolerance["velocity"]), point["name"]
            assert abs(ours.airborne_fraction[i] - point["airborne_fraction"]) <= (
                GLOBAL + tolerance["airborne_fraction"]), point["name"]
            # With e > 0 the two chatter cut-offs (1e-9 g/w0 here, 1e-9 a/w there) end
            # the rebounds differently, which moves the next apex: measured up to
            # 1.5e-7 g/w^2 at M = 0.99, 13 Hz, 7 m s-2, e = 0.5 (a near-flip point).
            hop_factor = 1.0 if s.restitution == 0.0 else 3.0
            assert abs(ours.largest_hop[i] - point["largest_hop"]) <= (
                hop_factor * GLOBAL * s.g / w[i] ** 2 + tolerance["largest_hop"]), point["name"]
            if s.restitution == 0.0:
                assert ours.impacts_per_period[i] == point["impacts_per_period"]
            compared += 1
    assert compared >= 70


# Slow tier: test_bouncing_orbits_match_the_reference keeps the flight integrator's
# headline check against the reference in the default tier (issue 46).
@pytest.mark.slow
def test_cached_reference_motions_from_a_drop_or_from_stillness():
    # Transients from the other starts of the reference's file: a 3 mm drop (the mode
    # at its flight equilibrium) and everything still; 600 periods, then the mean
    # velocity over 40. Near M = 1 they reach different motions (at M = 0.99, 14.5 Hz,
    # 10 m s-2: +0.043 m/s from stillness, -0.116 m/s from the drop), and a drop below
    # lift-off lands in the contact motion.
    points = [p for p in json.loads(POINTS.read_text(encoding="utf-8"))["points"]
              if p["start"] != "rest" and p["settled"]]
    assert len(points) >= 20
    velocities = {}
    for point in points:
        s = Structure(**point["structure"])
        f, a = point["f"], point["a"]
        if point["start"] == "still":
            start = np.zeros(kernel.FLIGHT_STATE_SIZE)
        else:
            kind, height = point["start"]
            assert kind == "drop"
            rest = s.g * math.cos(s.alpha_rad) / s.omega0**2
            start = np.array([rest, 0.0, 0.0, 0.0, height, 0.0])
        run = simulate(s, Schedule.constant(f, a, 600 / f), coupling="two-way", flight=True,
                       initial_state=start, output_times=np.array([560 / f, 600 / f]),
                       max_events=0, settings=SETTINGS)
        assert run.outcome == "completed"
        velocity = (run.x[1] - run.x[0]) * f / 40
        assert abs(velocity - point["velocity"]) <= GLOBAL * s.g / (2 * math.pi * f), (
            point["name"])
        velocities[point["name"]] = velocity
    assert velocities["two-starts/M0.99/f14.5/a10/e0/still"] > 0.04
    assert velocities["two-starts/M0.99/f14.5/a10/e0/drop3mm"] < -0.11


def test_mirrored_tilt_reverses_the_velocity_only():
    f = np.array([12.0, 14.44])
    a = np.array([10.0, 14.0])
    for M, e in ((0.5, 0.0), (0.9, 0.5)):
        plus = integrated_steady_state(_structure(M, e), f, a, coupling="two-way",
                                       flight=True, settings=SETTINGS)
        minus = integrated_steady_state(_structure(M, e, alpha=-PAPER["alpha"]), f, a,
                                        coupling="two-way", flight=True, settings=SETTINGS)
        assert np.all(plus.status == Status.BOUNCING) and np.all(minus.status == plus.status)
        assert_allclose(minus.velocity, -plus.velocity, rtol=1e-9, atol=1e-15)
        for name in ("airborne_fraction", "largest_hop", "impacts_per_period"):
            assert_allclose(getattr(minus, name), getattr(plus, name), rtol=1e-9)


def test_one_event_sample_per_step_finds_the_same_impacts():
    # With one sample a step, a flight shorter than a step between two samples is found
    # only by the watch of the gap's minimum.
    s = _structure(0.5, 0.5)
    sparse = IntegratorSettings(tolerance=TOLERANCE, samples_per_step=1)
    for f, a in ((12.0, 10.0), (14.44, 14.0)):
        four = integrated_steady_state(s, f, a, coupling="two-way", flight=True,
                                       settings=SETTINGS)
        one = integrated_steady_state(s, f, a, coupling="two-way", flight=True,
                                      settings=sparse)
        assert one.status == four.status == Status.BOUNCING
        assert_allclose(one.velocity, four.velocity, rtol=0,
                        atol=GLOBAL * s.g / (2 * math.pi * f))
        assert abs(one.impacts_per_period - four.impacts_per_period) <= 1.0


@pytest.mark.parametrize(("e", "a"), [(0.5, 10.0), (0.9, 9.0)])
def test_chattering_terminates_and_is_counted(e, a):
    # (At e = 0.9 and 10 m s-2 the table keeps the base bouncing: no orbit.)
    s = _structure(0.5, e)
    f = 12.0
    run = simulate(s, Schedule.constant(f, a, 10 / f), coupling="two-way", flight=True,
                   initial_state=steady_mode_state(s, f, a), max_events=100_000)
    assert run.outcome == "completed"
    kinds = _kinds(run)
    take_offs = kinds.count("lift_off")
    assert take_offs >= 9
    # Each flight ends in a sequence of rebounds, shrinking by about e, the last one
    # landing plastically (h' = 0 after it).
    impacts = run.event_kind == 6
    assert run.impacts == impacts.sum()
    after = run.event_state[impacts, kernel.GAP_RATE]
    landings = np.flatnonzero(after == 0.0)
    assert landings.size == take_offs - (run.mode[-1] == kernel.FLIGHT)
    expected = math.log(kernel.CHATTER_SPEED * s.g / s.omega0 / 0.1) / math.log(e)
    assert run.impacts / take_offs > 0.5 * expected
    # The first sequence's last rebounds (the table barely moves during them) shrink
    # by e; the last one is above the cut-off.
    tail = after[: landings[0]][-20:]
    assert tail.size == 20
    assert_allclose(tail[1:] / tail[:-1], e, rtol=0.02)
    assert tail[-1] > kernel.CHATTER_SPEED * s.g / s.omega0 > e * tail[-1]
    steady = integrated_steady_state(s, f, a, coupling="two-way", flight=True,
                                     settings=SETTINGS)
    assert steady.status == Status.BOUNCING
    assert steady.impacts_per_period > 0.5 * expected


def _cached_motion(name, structure, f, a):
    """The reference's cached steady motion ``name`` (``POINTS``), checked to be of this
    structure and drive."""
    point = next(p for p in json.loads(POINTS.read_text(encoding="utf-8"))["points"]
                 if p["name"] == name)
    assert point["settled"] and point["start"] == "rest"
    assert (point["f"], point["a"]) == (f, a)
    for key, value in point["structure"].items():
        assert getattr(structure, key) == value, (name, key)
    return point


@pytest.mark.parametrize(("e", "a"), [(0.5, 10.0),
                                      pytest.param(0.9, 9.0, marks=pytest.mark.slow)])
def test_the_chattering_cut_off_does_not_move_the_velocity(e, a):
    # The reference cuts chattering off elsewhere (1e-9 a/w, and redoes the last impact
    # plastically): the velocities agree to the integrator's error. At e = 0.9 (slow
    # tier) the reference takes 2 to 5 minutes (496 periods of 185 rebounds): its motion
    # is the cached point chattering/M0.5/f12/a9/e0.9/rest of the reference's file
    # (tests/reference/make_flight_points.py; --only NAME computes it again).
    s = _structure(0.5, e)
    f = 12.0
    ours = integrated_steady_state(s, f, a, coupling="two-way", flight=True, settings=SETTINGS)
    if e == 0.9:
        cached = _cached_motion("chattering/M0.5/f12/a9/e0.9/rest", s, f, a)
        status, velocity, impacts = (cached["status"], cached["velocity"],
                                     cached["impacts_per_period"])
    else:
        theirs = reference.steady_motion(s, f, a)
        status, velocity, impacts = theirs.status, theirs.velocity, theirs.impacts_per_period
    assert ours.status == Status.BOUNCING and status == "bouncing"
    assert_allclose(ours.velocity, velocity, rtol=0, atol=GLOBAL * s.g / (2 * math.pi * f))
    assert abs(ours.impacts_per_period - impacts) <= 2.0


# ---------------------------------------------------------------- a frequency switch


def test_a_switch_into_bouncing_follows_the_reference_through_flight():
    # 12 Hz below lift-off for whole periods (so the second segment starts at phase 0),
    # then 14.44 Hz at 14 m s-2: the transient takes off, lands and settles to bouncing.
    s = _structure(0.5)
    f1, f2, a = 12.0, 14.44, 14.0
    d1 = 24 / f1
    d2 = 6 / f2
    run = simulate(s, Schedule(np.array([f1, f2]), np.array([4.0, a]), np.array([d1, d2])),
                   coupling="two-way", flight=True, initial_state=steady_mode_state(s, f1, 4.0),
                   output_times=np.array([d1, d1 + d2]),
                   settings=IntegratorSettings(tolerance=1e-12))
    assert run.outcome == "completed"
    kinds = _kinds(run)
    assert "lift_off" in kinds and "impact" in kinds
    # The first take-off is at the switch itself (n = g - 14 m s-2 < 0 at phase 0: the
    # restart takes off at once), the later ones from the landings.
    take_offs = run.event_time[np.array(kinds) == "lift_off"]
    assert take_offs[0] == d1 and np.all(take_offs[1:] > d1)
    assert run.mode[0] in (-1, 0, 1) and run.gap[0] == 0.0  # on the table at the switch
    switch = (run.delta[0], run.delta_rate[0], run.v[0], 0.0, 0.0)
    theirs = reference.simulate(s, f2, a, d2, switch)
    assert theirs.status == "ok" and theirs.impacts > 0
    ours = (run.delta[1], run.delta_rate[1], run.v[1], run.gap[1], run.gap_rate[1],
            run.x[1] - run.x[0])
    w = 2 * math.pi * f2
    scale = np.array([s.g / w**2, s.g / w, s.g / w, s.g / w**2, s.g / w, s.g / w**2])
    assert_allclose(np.array(ours) / scale,
                    np.array([*theirs.final, theirs.displacement]) / scale, rtol=0, atol=1e-6)
    assert run.impacts == theirs.impacts
