"""Self-checks of the flight references ``tests/reference/flight.py`` and ``rigid_block.py``.

The flight reference is the yardstick of the exact flight solver and of the flight
integrator, so it is checked against things that share none of its code:

* below lift-off, against the exact two-way solver ``study.steady_velocity``;
* at ``M -> 0``, against the rigid block's closed form (``rigid_block.py``), whose own
  numbers are checked against its closed-form threshold ``a = g sqrt(1 + pi^2)``;
* a flight after a take-off, against the closed-form flight of the issue (ballistic
  base, free damped mode), including the first impact past the triple zero;
* ``alpha -> -alpha`` mirrors the motion;
* its numerical Darboux-Keller impact law against momentum balance, the continuity of
  the plate's velocity along the mode, energy (no plastic impact gains any; a
  frictionless elastic one keeps it) and the piecewise-linear closed form;
* the chattering cut-off and the time step do not move the results;
* the cached points (``tests/reference/data/flight_points.json``) against a regeneration.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from tests.reference import flight
from tests.reference.flight import FlightModel, impact, simulate, steady_motion
from tests.reference.rigid_block import one_period_amplitude, rigid_block

# --- below lift-off: the exact two-way solver ---------------------------------------------


@pytest.mark.parametrize(
    ("changes", "f", "a", "status"),
    [
        ({}, 13.0, 8.5, "stick-slip"),
        ({}, 16.5, 8.5, "stick-slip"),
        ({}, 13.0, 5.0, "static"),
        ({"M": 0.6}, 20.0, 8.0, "continuous"),
    ],
)
def test_below_lift_off_equals_the_exact_two_way_solver(paper_structure, changes, f, a, status):
    s = paper_structure.replace(**changes)
    exact, _ = study.steady_velocity(s, f, a, coupling="two-way")
    got = steady_motion(s, f, a)
    assert got.status == status
    assert got.airborne_fraction == 0.0 and got.impacts_per_period == 0.0
    assert_allclose(got.velocity, float(exact), rtol=1e-8, atol=1e-14)


@pytest.mark.parametrize(("M", "f", "a"), [(0.08, 13.0, 8.5), (0.99, 16.0, 3.0)])
def test_drop_lands_on_the_exact_two_way_motion(paper_structure, M, f, a):
    """A 3 mm drop below lift-off: impact, then the contact rules reach the contact orbit."""
    s = paper_structure.replace(M=M)
    exact, _ = study.steady_velocity(s, f, a, coupling="two-way")
    got = steady_motion(s, f, a, start=("drop", 3e-3))
    assert got.status == "stick-slip" and got.airborne_fraction == 0.0
    assert_allclose(got.velocity, float(exact), rtol=1e-8)


def test_grazing_take_off_just_above_the_lift_off_threshold(paper_structure):
    """1e-7 m s-2 above the exact solver's lift-off threshold the normal force dips below 0
    for about 3e-6 s, inside one step: the reference must still take off (a hop of
    about 1e-18 m), and the velocity must join the contact velocity continuously."""
    from study.model.status import Status

    f = 14.5
    lo, hi = 9.0, 9.8
    for _ in range(48):
        mid = 0.5 * (lo + hi)
        _, status = study.steady_velocity(paper_structure, f, mid, coupling="two-way")
        lo, hi = (lo, mid) if Status(int(status)) == Status.LIFT_OFF else (mid, hi)
    below, _ = study.steady_velocity(paper_structure, f, lo, coupling="two-way")
    got = steady_motion(paper_structure, f, hi + 1e-7)
    assert got.status == "bouncing" and got.take_offs_per_period == 1.0
    assert 0 < got.largest_hop < 1e-15 and 0 < got.airborne_fraction < 1e-3
    assert_allclose(got.velocity, float(below), rtol=1e-7)


# --- M -> 0: the rigid block ----------------------------------------------------------------


def test_rigid_block_flight_lasts_one_period_at_its_threshold():
    """``rigid_block`` landing phase against the closed-form threshold ``g sqrt(1 + pi^2)``."""
    f = 14.5
    a_star = one_period_amplitude(9.8)
    below, above = rigid_block(f, a_star * (1 - 1e-9)), rigid_block(f, a_star * (1 + 1e-9))
    assert below.status == "bouncing" and below.period == 1
    assert above.status == "beyond"
    assert_allclose(below.airborne_fraction, 1.0, atol=1e-7)
    assert rigid_block(f, 9.7).status == "static"


@pytest.mark.parametrize(("f", "a"), [(14.5, 12.0), (14.5, 20.0), (5.0, 11.0)])
def test_tiny_mass_ratio_is_the_rigid_block(paper_structure, f, a):
    """``M = 1e-10``: the plate's effect is O(M), the reference's error about 1e-11."""
    block = rigid_block(f, a)
    got = steady_motion(paper_structure.replace(M=1e-10), f, a)
    assert got.status == "bouncing" and got.period == block.period == 1
    assert_allclose(got.airborne_fraction, block.airborne_fraction, rtol=0, atol=1e-8)
    assert_allclose(got.largest_hop, block.largest_hop, rtol=1e-8)
    assert got.impacts_per_period == block.impacts_per_period
    assert abs(got.velocity) < 1e-9


# --- a flight against its closed form -----------------------------------------------------


def _closed_form_flight(model, t0, delta0, rate0):
    """``h(t)`` and ``delta(t)`` of a flight from ``h = h' = 0`` at ``t0`` (issue's formulas)."""
    m, c, k, g, a, w = 1 - model.M, model.c, model.k, model.g, model.a, model.w
    rest = g * model.ca / k
    sigma = c / (2 * m)
    wd = math.sqrt(k / m - sigma**2)
    p, q = delta0 - rest, (rate0 + sigma * (delta0 - rest)) / wd

    def delta(t):
        tau = t - t0
        return rest + math.exp(-sigma * tau) * (p * math.cos(wd * tau) + q * math.sin(wd * tau))

    def gap(t):
        tau = t - t0
        return (-g * tau**2 / 2 + a / w**2 * (math.cos(w * t0) - math.cos(w * t))
                - a / w * math.sin(w * t0) * tau
                - model.M * model.ca * (delta(t) - delta0 - rate0 * tau))
    return gap, delta


@pytest.mark.parametrize(("M", "f", "a"), [(0.08, 14.5, 12.0), (0.9, 14.0, 10.0)])
def test_first_flight_and_impact_match_the_closed_form(paper_structure, M, f, a):
    from scipy.optimize import brentq

    s = paper_structure.replace(M=M)
    model = FlightModel(s, f, a)
    run = simulate(s, f, a, 3.0 / f, model.stick_start()[[0, 1, 3, 4, 5]])
    kinds = [ev["kind"] for ev in run.events]
    i = kinds.index("take-off")
    take_off, hit = run.events[i], run.events[i + 1]
    assert hit["kind"] == "impact"
    t0, y0 = take_off["t"], take_off["state"]
    gap, _ = _closed_form_flight(model, t0, y0[0], y0[1])
    # the closed form is positive through the flight and lands at the reference's impact
    ts = np.linspace(t0, hit["t"], 2001)[1:-1]
    assert min(gap(t) for t in ts) > 0
    landing = brentq(gap, 0.5 * (t0 + hit["t"]), hit["t"] + 0.1 * (hit["t"] - t0), xtol=1e-15)
    assert_allclose(hit["t"], landing, rtol=0, atol=1e-11)
    # flight samples of the reference against the closed form
    inside = (run.t > t0) & (run.t < hit["t"]) & (run.modes == flight.FLIGHT)
    hop = max(gap(t) for t in ts)
    assert_allclose([gap(t) for t in run.t[inside]], run.states[inside, 4], rtol=0,
                    atol=1e-9 * hop)


# --- symmetry -------------------------------------------------------------------------------


def test_mirrored_tilt_mirrors_a_bouncing_motion(paper_structure):
    s = paper_structure.replace(M=0.5)
    right = steady_motion(s, 14.0, 11.0)
    left = steady_motion(s.replace(alpha=-s.alpha), 14.0, 11.0)
    assert right.status == left.status == "bouncing"
    assert abs(right.velocity) > 1e-3
    assert_allclose(left.velocity, -right.velocity, rtol=1e-9)
    assert_allclose(left.airborne_fraction, right.airborne_fraction, rtol=1e-9)
    assert_allclose(left.largest_hop, right.largest_hop, rtol=1e-9)


# --- the impact law -------------------------------------------------------------------------


def _random_impacts(n, seed):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        params = {
            "f0": 14.44, "Q": 17.5, "alpha": rng.uniform(-89, 89), "M": rng.uniform(0.01, 0.99),
            "cs": rng.uniform(0.05, 1.5), "restitution": rng.choice([0.0, rng.uniform(0, 1)]),
        }
        params["ck"] = params["cs"] * rng.uniform(0.3, 1.0)
        model = FlightModel(params, 14.5, 10.0)
        pre = (rng.normal(0, 0.5), rng.choice([0.0, rng.normal(0, 0.3)]), -abs(rng.normal(0, 0.3)))
        yield model, pre


def _energy(model, rate, v, gap_rate):
    """Kinetic energy per unit total mass in the table's frame (inertial over an impact)."""
    base = np.array([v, gap_rate])
    plate = base + rate * np.array([model.sa, model.ca])
    return 0.5 * (1 - model.M) * base @ base + 0.5 * model.M * plate @ plate


def test_numeric_impacts_keep_momentum_and_lose_energy():
    checked = paradoxes = 0
    for model, (rate, v, gap_rate) in _random_impacts(400, 21):
        hit = impact(model, rate, v, gap_rate)
        if hit.paradox:
            paradoxes += 1
            continue
        checked += 1
        M, sa, ca = model.M, model.sa, model.ca
        # total momentum (base + plate) changes by the impulse
        assert_allclose(hit.velocity + M * sa * hit.delta_rate - (v + M * sa * rate),
                        hit.tangential_impulse, atol=1e-13)
        assert_allclose(hit.gap_rate + M * ca * hit.delta_rate - (gap_rate + M * ca * rate),
                        hit.normal_impulse, atol=1e-13)
        # the plate's velocity along the mode is continuous
        assert_allclose(sa * hit.velocity + ca * hit.gap_rate + hit.delta_rate,
                        sa * v + ca * gap_rate + rate, atol=1e-13)
        # Newton's law, Coulomb's cone
        assert_allclose(hit.gap_rate, -model.e * gap_rate, atol=1e-14)
        assert abs(hit.tangential_impulse) <= model.cs * hit.normal_impulse * (1 + 1e-12)
        if model.e == 0.0:
            before = _energy(model, rate, v, gap_rate)
            assert _energy(model, hit.delta_rate, hit.velocity, hit.gap_rate) <= before * (
                1 + 1e-12)
    assert checked > 300 and paradoxes < 100


def test_frictionless_elastic_impact_keeps_energy():
    model = FlightModel({"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.9, "cs": 0.0,
                         "ck": 0.0, "restitution": 1.0}, 14.5, 10.0)
    hit = impact(model, 0.3, -0.2, -0.4)
    assert_allclose(_energy(model, hit.delta_rate, hit.velocity, hit.gap_rate),
                    _energy(model, 0.3, -0.2, -0.4), rtol=1e-13)


def test_numeric_impact_against_the_piecewise_linear_closed_form():
    """One sliding phase, then a stick: the impulses from the slopes of ``W``."""
    model = FlightModel({"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.5, "cs": 0.6,
                         "ck": 0.6}, 14.5, 10.0)
    mu = model.M / (1 - model.M)
    wxx, wxz, wzz = 1 + mu * model.sa**2, mu * model.sa * model.ca, 1 + mu * model.ca**2
    assert abs(wxz / wxx) <= model.cs  # sticks once v reaches 0
    v, gap_rate = 0.05, -0.5
    p1 = v / (model.ck * wxx - wxz)  # v = 0 here (sliding forward)
    h1 = gap_rate + p1 * (wzz - model.ck * wxz)
    p2 = -h1 / (wzz - wxz**2 / wxx)
    hit = impact(model, 0.0, v, gap_rate)
    assert hit.ended == "stick" and hit.velocity == 0.0
    assert_allclose(hit.normal_impulse, p1 + p2, rtol=1e-13)
    assert_allclose(hit.tangential_impulse, -model.ck * p1 - wxz / wxx * p2, rtol=1e-13)


def test_impact_paradox_is_flagged():
    """``dh'/dp = D_s / (1 - M) <= 0``: steep tilt, heavy plate, sliding forward."""
    model = FlightModel({"f0": 14.44, "Q": 17.5, "alpha": 80.0, "M": 0.99, "cs": 1.0},
                        14.5, 10.0)
    assert impact(model, 0.0, 0.1, -0.3).paradox


# --- numerical settings ---------------------------------------------------------------------


def test_chattering_cut_off_error_scales_with_the_cut_off(paper_structure):
    """The airborne time lost by landing a rebound ``u`` plastically is about
    ``2 u / (g_eff (1 - e))`` per landing: proportional to the cut-off, so ten times
    smaller per decade, and the displacement does not see it."""
    s = paper_structure.replace(restitution=0.5)
    f, a = 14.5, 12.0
    start = FlightModel(s, f, a).stick_start()[[0, 1, 3, 4, 5]]
    runs = {u: simulate(s, f, a, 3 / f, start, chatter_speed=u) for u in (1e-5, 1e-6, 1e-9)}
    assert runs[1e-9].impacts > runs[1e-6].impacts > runs[1e-5].impacts > 3
    finest = runs[1e-9]
    lost = {u: finest.airborne_time - runs[u].airborne_time for u in (1e-5, 1e-6)}
    assert 0 < lost[1e-6] < lost[1e-5] and 5 < lost[1e-5] / lost[1e-6] < 20
    assert lost[1e-6] * f < 1e-5  # so below 1e-8 of the time at the default 1e-9
    assert_allclose(runs[1e-6].displacement, finest.displacement, rtol=1e-9)


def test_time_step_and_tolerance_do_not_move_the_result(paper_structure):
    s = paper_structure.replace(M=0.5)
    base = steady_motion(s, 14.0, 11.0)
    coarse = steady_motion(s, 14.0, 11.0, steps_per_period=12, rtol=1e-10)
    assert base.status == coarse.status == "bouncing"
    assert_allclose(coarse.velocity, base.velocity, rtol=1e-8)
    assert_allclose(coarse.airborne_fraction, base.airborne_fraction, atol=1e-9)
    assert_allclose(coarse.largest_hop, base.largest_hop, rtol=1e-9)


@pytest.mark.slow
def test_two_starts_near_m_one(paper_structure):
    """M = 0.99, 14.5 Hz, 10 m s-2: the drive switched on from stillness and a 3 mm drop
    reach different motions; the exact solver's start reaches the drop's."""
    s = paper_structure.replace(M=0.99)
    still = steady_motion(s, 14.5, 10.0, start="still")
    drop = steady_motion(s, 14.5, 10.0, start=("drop", 3e-3))
    rest = steady_motion(s, 14.5, 10.0, start="rest")
    assert still.status == drop.status == rest.status == "bouncing"
    assert 0.03 < still.velocity < 0.06 and still.largest_hop < 1e-3
    assert -0.14 < drop.velocity < -0.10 and drop.largest_hop > 3e-3
    assert_allclose(rest.velocity, drop.velocity, rtol=1e-8)


# --- cached points --------------------------------------------------------------------------


def test_cached_points_regenerate(tmp_path):
    from tests.reference import make_flight_points as maker

    content = json.loads(maker.DATA_PATH.read_text())
    assert content["code_version"] == flight.CODE_VERSION
    kinds = {p["kind"] for p in content["points"]}
    assert len(content["points"]) >= 60 and len(kinds) >= 3
    # regenerate the cheapest few and compare within the stated tolerances
    cheap = sorted(content["points"], key=lambda p: p["seconds"])[:3]
    for point in cheap:
        again = maker.compute(point, refine=False)
        for name in ("velocity", "airborne_fraction", "largest_hop"):
            assert_allclose(again[name], point[name], rtol=0, atol=point["tolerance"][name])
        assert again["status"] == point["status"]
