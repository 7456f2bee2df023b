"""The phase-0 Poincare section (issue 35, item 4): ``study.solvers.section.phase_section``
and the ``section`` observable.

Checked against something independent:

* an orbit of period ``p`` repeats every ``p`` entries and starts at the fixed point
  the solver reports (its own consistency: the fixed point of ``P^p``);
* the states after 1, 2 and 3 periods against the time integrator (adaptive steps,
  its own event location and impact law) from the same reported state, for a bouncing
  orbit and for a chaotic motion (whose trajectories part only after tens of periods);
* points without a motion (static, lift-off) hold NaN; a contact motion holds no gap;
* the observable through a study: dims ``(f, a, section_period)``, the values of the
  direct call, kept in the cache and read back whole by a second run.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.model.status import Status
from study.solvers.exact import steady_state
from study.solvers.integrator import Schedule, simulate
from study.solvers.section import SECTION_PERIODS, phase_section

BASE = dict(f0=14.44, Q=17.5, alpha=64.0, cs=0.25)
#: A period-1 bouncing orbit, a chaotic bouncing motion (M = 0.99, with flight) and a
#: two-way stick-slip orbit without flight (M = 0.3), as (M, f [Hz], a [m s-2]).
BOUNCING = (0.99, 7.0, 12.0)
CHAOTIC = (0.99, 5.625, 11.6)
CONTACT = (0.3, 15.0, 6.0)


def _structure(m: float) -> study.Structure:
    return study.Structure(M=m, **BASE)


def _section(m, f, a, flight=True, periods=SECTION_PERIODS):
    structure = _structure(m)
    solution = steady_state(structure, f, a, coupling="two-way", flight=flight)
    return solution, phase_section(structure, f, a, flight=flight, periods=periods,
                                   solution=solution)


def _stacked(section) -> np.ndarray:
    """``(..., periods, 4)``: delta, delta', v, h."""
    return np.stack([section.delta, section.delta_rate, section.speed, section.gap], -1)


@pytest.mark.parametrize("point", [BOUNCING, CONTACT], ids=["bouncing", "contact"])
def test_an_orbit_repeats_with_its_period_from_its_fixed_point(point):
    """The section starts at the reported fixed point and repeats every orbit period
    (to 1e-9 of the state's size: the orbit is a fixed point of P^p to Newton's
    tolerance, and each period's rounding is far below)."""
    flight = point is not CONTACT
    solution, section = _section(*point, flight=flight)
    assert Status(int(solution.status)) in (Status.BOUNCING, Status.STICK_SLIP)
    p = int(solution.orbit_period)
    values = _stacked(section)
    assert_allclose(values[0], solution.phase_state[:4], rtol=0, atol=0)
    size = np.max(np.abs(values), axis=0) + 1e-300
    assert_allclose(values[p:] / size, values[:-p] / size, rtol=0, atol=1e-9)
    if not flight:
        assert_allclose(section.gap, 0.0, rtol=0, atol=0)


def _integrated(structure, f, a, state, periods, flight):
    """The 5-states at phase 0 after 1..periods drive periods of the time integrator
    from ``state`` at phase 0."""
    period = 1.0 / f
    schedule = Schedule.constant(f, a, periods * period)
    y = np.array([state[0], state[1], 0.0, state[2], state[3], state[4]])
    run = simulate(structure, schedule, coupling="two-way", flight=flight, initial_state=y,
                   output_times=period * np.arange(periods + 1), max_events=0)
    assert run.outcome == "completed"
    return np.stack([run.delta, run.delta_rate, run.v, run.gap], -1)[1:]


@pytest.mark.parametrize("point", [BOUNCING, CHAOTIC], ids=["bouncing", "chaotic"])
def test_the_next_periods_against_the_integrator(point):
    """The section's states after 1, 2 and 3 periods against the time integrator's
    from the reported state (a different method of the same model): within 1e-6 of
    each component's natural size (the integrator's tolerance is 1e-10 per step; a
    chaotic motion amplifies the difference by exp(0.24) a period, far too little
    to matter in 3 periods)."""
    m, f, a = point
    solution, section = _section(m, f, a, periods=4)
    values = _stacked(section)
    reference = _integrated(_structure(m), f, a, solution.phase_state, 3, True)
    size = np.max(np.abs(values), axis=0) + 1e-12
    assert_allclose(values[1:] / size, reference / size, rtol=0, atol=1e-6)
    if point is CHAOTIC:
        assert Status(int(solution.status)) is Status.CHAOTIC
        # A chaotic motion's section does not repeat: no two of its states agree.
        assert np.min(np.abs(np.diff(values[:, 2]))) > 1e-6 * size[2]


def test_no_motion_no_section():
    """Static points and lift-off (two-way without flight) have no motion: NaN, and
    a phase_state of NaN."""
    structure = _structure(0.3)
    f = np.array([15.0, 15.0])
    a = np.array([0.5, 11.9])
    solution = steady_state(structure, f, a, coupling="two-way")
    assert [Status(int(s)) for s in solution.status] == [Status.STATIC, Status.LIFT_OFF]
    section = phase_section(structure, f, a, periods=3, solution=solution)
    assert np.isnan(_stacked(section)).all()
    assert np.isnan(solution.phase_state).all()


def test_phase_section_refuses_bad_arguments():
    structure = _structure(0.3)
    with pytest.raises(ValueError, match="periods must be a positive integer"):
        phase_section(structure, 15.0, 6.0, periods=0)
    one_way = steady_state(structure, 15.0, 6.0)
    with pytest.raises(ValueError, match="two-way steady_state"):
        phase_section(structure, 15.0, 6.0, solution=one_way)


def test_the_section_observable_through_a_study(tmp_path):
    """compute_map writes the direct call's values over (f, a, section_period); a study
    run keeps them in the cache and a second run reads them back whole and equal."""
    structure = _structure(0.99)
    f = np.array([5.625, 7.0])
    a = np.array([11.6, 12.0])
    ds = study.compute_map(structure, f, a, observables=["velocity", "section"],
                           coupling="two-way", flight=True)
    assert ds["section_speed"].dims == ("f", "a", "section_period")
    assert ds.sizes["section_period"] == SECTION_PERIODS
    assert ds["section_gap"].attrs["units"] == "m"
    direct = phase_section(structure, f[:, None], a[None, :], flight=True)
    assert_allclose(ds["section_speed"].values, direct.speed, rtol=0, atol=0)
    assert_allclose(ds["section_gap"].values, direct.gap, rtol=0, atol=0)

    spec = tmp_path / "section.toml"
    spec.write_text(ds.attrs["study_spec"])
    first = study.run(spec, output=tmp_path / "first.nc", cache=tmp_path / "cache")
    second = study.run(spec, output=tmp_path / "second.nc", cache=tmp_path / "cache")
    run = json.loads(second.attrs["provenance"])["run"]
    assert (run["points_computed"], run["points_reused"]) == (0, f.size * a.size)
    for name in ("section_delta", "section_delta_rate", "section_speed", "section_gap"):
        assert_allclose(second[name].values, first[name].values, rtol=0, atol=0)
        assert_allclose(first[name].values, ds[name].values, rtol=0, atol=0)
