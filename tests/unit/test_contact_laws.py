"""Contact laws chosen by name (study.model.contact): declarations, refusals, and the
Stribeck friction law of the integrator against closed forms and the exact solver."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad

from study.kernels import structure_vector as sv
from study.model import codes
from study.model.contact import LAWS, SOLVERS, Friction, check_friction, check_law
from study.model.paper import paper_structure
from study.model.status import Status
from study.solvers.exact import steady_state
from study.solvers.integrator import (
    IntegratorSettings,
    Schedule,
    integrated_steady_state,
    model_parameters,
    simulate,
)
from study.studies.observables import Method
from study.studies.spec import SpecError, parse_spec

PAPER = paper_structure()
TIGHT = IntegratorSettings(tolerance=1e-11)
POINTS = (np.array([14.6, 14.5, 14.5, 16.5]), np.array([7.0, 6.0, 9.0, 8.5]))


def stribeck(speed: float) -> Friction:
    return Friction("stribeck", stribeck_speed=speed)


def test_every_law_is_declared_with_known_solvers_and_distinct_codes():
    for kind, laws in LAWS.items():
        assert len({law.code for law in laws.values()}) == len(laws), kind
        for name, law in laws.items():
            assert (law.kind, law.name) == (kind, name)
            assert set(law.solvers) <= set(SOLVERS), name
    # Every friction law's parameter has its entry in the kernels' structure vector.
    for law in LAWS["friction"].values():
        for parameter in law.parameters:
            assert sv.ENTRIES[sv.index(parameter.name)][1] == parameter.units


def test_a_solver_refuses_a_law_it_does_not_implement_naming_law_solver_and_allowed():
    with pytest.raises(ValueError, match=r"friction law 'stribeck' is not implemented by the "
                       r"exact steady-state solver \('exact'\); allowed: 'coulomb'"):
        steady_state(PAPER, 14.0, 7.0, friction=stribeck(1e-3))
    with pytest.raises(ValueError, match=r"'exact'.*allowed: 'coulomb'"):
        Method("exact", friction=stribeck(1e-3))
    with pytest.raises(ValueError, match=r"friction law 'viscous' is unknown; friction laws "
                       r"are 'coulomb', 'stribeck'"):
        simulate(PAPER, Schedule.constant(14.0, 7.0, 0.1), friction="viscous")
    with pytest.raises(ValueError, match=r"needs the parameters.*stribeck_speed"):
        integrated_steady_state(PAPER, 14.0, 7.0, friction="stribeck")
    with pytest.raises(ValueError, match=r"stribeck_speed = -1.0 is out of range; allowed: "
                       r"0.0 < stribeck_speed"):
        stribeck(-1.0)
    with pytest.raises(ValueError, match="coupling law 'three-way' is unknown"):
        check_law("coupling", "three-way", "integrator")
    assert check_friction({"law": "stribeck", "stribeck_speed": 0.01}, "integrator") \
        == stribeck(0.01)
    assert check_law("lift_off", "stop", "planar").name == "stop"


def test_the_law_and_its_parameter_reach_the_structure_vector():
    coulomb = model_parameters(PAPER)
    chosen = model_parameters(PAPER, friction=stribeck(0.02))
    assert coulomb[sv.FRICTION_LAW] == LAWS["friction"]["coulomb"].code
    assert chosen[sv.FRICTION_LAW] == LAWS["friction"]["stribeck"].code
    assert chosen[sv.index("stribeck_speed")] == 0.02
    assert np.array_equal(coulomb[:sv.FRICTION_LAW], chosen[:sv.FRICTION_LAW])


@pytest.mark.parametrize("coupling", ["one-way", "two-way"])
def test_stribeck_with_ck_equal_cs_is_coulomb_exactly(coupling):
    """``ck = cs``: mu(v) = ck + 0 exp(...) = ck, the same numbers bit for bit; and those
    are the exact solver's within the integrator's accuracy."""
    structure = PAPER.replace(ck=PAPER.cs)
    f, a = POINTS
    run = integrated_steady_state(structure, f, a, coupling=coupling, settings=TIGHT,
                                  friction=stribeck(0.01))
    coulomb = integrated_steady_state(structure, f, a, coupling=coupling, settings=TIGHT)
    assert np.array_equal(run.velocity, coulomb.velocity, equal_nan=True)
    assert np.array_equal(run.status, coulomb.status)
    if coupling == "one-way":
        exact = steady_state(structure, f, a)
        assert np.array_equal(run.status, exact.status)
        assert_allclose(run.velocity, exact.velocity, rtol=1e-8, atol=1e-13)


def test_stribeck_tends_to_coulomb_as_its_speed_vanishes():
    """v_s -> 0: mu = ck for every slip speed but a vanishing band at rest; the steady
    velocity tends to the exact solver's Coulomb one (cs, ck), the gap of the order of
    v_s itself (measured: 2-8 v_s from 1e-4 down to 1e-8 m s-1; below that the
    integrator's resolution of the band, about 1e-7 m s-1 at tolerance 1e-11, stops it)."""
    structure = PAPER.replace(ck=0.18)
    f, a = POINTS
    exact = steady_state(structure, f, a)
    assert np.all(exact.status == Status.STICK_SLIP)
    gaps = []
    for speed in (1e-5, 1e-6, 1e-7):
        run = integrated_steady_state(structure, f, a, settings=TIGHT, friction=stribeck(speed))
        assert np.array_equal(run.status, exact.status)
        assert np.array_equal(run.slips_per_period, exact.slips_per_period)
        assert_allclose(run.velocity, exact.velocity, rtol=0, atol=20 * speed)
        gaps.append(np.max(np.abs(run.velocity - exact.velocity)))
    assert gaps[0] > 5 * gaps[1] > 25 * gaps[2], gaps


def test_stribeck_differs_from_coulomb_in_slips_only():
    """With v_s of the order of the slip speeds the steady velocity lies clearly apart
    from Coulomb's (either coefficient); the first release from rest is Coulomb's to the
    bit (a stick never reads the kinetic coefficient), the first slip's end is not."""
    structure = PAPER.replace(ck=0.15)
    f, a = POINTS
    run = integrated_steady_state(structure, f, a, settings=TIGHT, friction=stribeck(0.01))
    for ck in (0.15, 0.25):
        coulomb = steady_state(structure.replace(ck=ck), f, a)
        assert np.all(np.abs(run.velocity - coulomb.velocity) > 1e-3 * np.abs(coulomb.velocity))
    schedule = Schedule.constant(14.5, 7.0, 0.5)
    weak = simulate(structure, schedule, friction=stribeck(0.01), settings=TIGHT)
    plain = simulate(structure, schedule, settings=TIGHT)
    assert weak.event_kind[0] == plain.event_kind[0]
    assert plain.event_kind[0] in (codes.EVENT_RELEASE_FORWARD, codes.EVENT_RELEASE_BACKWARD)
    assert weak.event_time[0] == plain.event_time[0]
    assert weak.event_kind[1] == plain.event_kind[1] == codes.EVENT_SLIP_END
    assert abs(weak.event_time[1] - plain.event_time[1]) > 1e-4 / 14.5


def test_slide_to_rest_matches_the_stribeck_closed_form():
    """No drive, a push v0: v' = -g mu(v). Stop time in closed form,
    T = v_s / (g ck) ln((ck e^(v0/v_s) + cs - ck) / cs); stop distance by quadrature of
    v / (g mu(v)) (an independent method)."""
    structure = PAPER.replace(ck=0.15)
    cs, ck, g = structure.cs, structure.ck, structure.g
    v0, speed = 0.05, 0.01
    stop = speed / (g * ck) * math.log((ck * math.exp(v0 / speed) + cs - ck) / cs)
    distance, _ = quad(lambda v: v / (g * (ck + (cs - ck) * math.exp(-v / speed))), 0.0, v0,
                       epsabs=0.0, epsrel=1e-13)
    run = simulate(structure, Schedule.constant(10.0, 0.0, 2 * stop), friction=stribeck(speed),
                   initial_state=(0.0, 0.0, 0.0, v0), output_times=[2 * stop],
                   settings=IntegratorSettings(tolerance=1e-12))
    ends = run.event_time[run.event_kind == codes.EVENT_SLIP_END]
    assert ends.size == 1
    assert_allclose(ends[0], stop, rtol=1e-9)
    assert_allclose(run.x[-1], distance, rtol=1e-9)


SPEC = """\
[study]
name = "friction-under-test"
observables = ["velocity"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25
ck = 0.15

[sweep]
f = {{ values = [14.5] }}
a = {{ values = [7.0] }}

[solver]
{solver}
"""


def test_a_spec_chooses_the_friction_law_by_name_with_its_parameter():
    text = SPEC.format(solver='method = "integrator"\n'
                       'friction = { law = "stribeck", stribeck_speed = 0.01 }')
    spec = parse_spec(text, "workflows/friction.toml")
    assert spec.friction == stribeck(0.01)
    assert spec.canonical["solver"]["friction"] == {"law": "stribeck", "stribeck_speed": 0.01}
    plain = parse_spec(SPEC.format(solver='method = "integrator"'), "workflows/friction.toml")
    assert plain.friction == Friction() and "friction" not in plain.canonical["solver"]
    spelled = parse_spec(SPEC.format(solver='method = "integrator"\nfriction = "coulomb"'),
                         "workflows/friction.toml")
    assert spelled.canonical == plain.canonical


def test_a_spec_asking_the_exact_solver_for_stribeck_friction_is_refused():
    text = SPEC.format(solver='friction = { law = "stribeck", stribeck_speed = 0.01 }')
    with pytest.raises(SpecError, match=r"workflows/friction.toml: \[solver\] friction: "
                       r"friction law 'stribeck' is not implemented by the exact steady-state "
                       r"solver \('exact'\); allowed: 'coulomb'"):
        parse_spec(text, "workflows/friction.toml")
    with pytest.raises(SpecError, match="friction"):
        parse_spec(SPEC.format(solver='method = "integrator"\nfriction = "stribeck"'),
                   "workflows/friction.toml")
