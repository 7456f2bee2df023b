"""Property tests of the impact law over the whole valid space of structures and
pre-impact velocities: what must hold for every impact, from the Lagrangian of base and
plate (momentum balance, the plate's velocity along e, no energy gain when plastic),
Coulomb's cone and Newton's law, the mirror alpha -> -alpha."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import study
from study.model.codes import IMPACT_PARADOX, IMPACT_STICK
from study.model.structure import tilt_warnings
from study.solvers.impact import impact

finite = {"allow_nan": False, "allow_infinity": False}


@st.composite
def structures(draw):
    cs = draw(st.floats(1e-6, 2.0, **finite))
    with tilt_warnings(False):  # small tilts are part of the space, in degree
        return study.Structure(
            f0=20.0, Q=10.0,
            alpha=draw(st.floats(-89.9, 89.9, **finite)),
            M=draw(st.floats(1e-6, 0.9999, **finite)),
            cs=cs, ck=max(1e-6, cs * draw(st.floats(0.0, 1.0, **finite))),
            restitution=draw(st.sampled_from([0.0, 1.0]) | st.floats(0.0, 1.0, **finite)))


velocities = st.floats(-10.0, 10.0, **finite) | st.just(0.0)
approaches = st.floats(1e-6, 10.0, **finite).map(lambda speed: -speed)

PROPERTY_SETTINGS = settings(max_examples=400, deadline=None, derandomize=True)


@PROPERTY_SETTINGS
@given(structures(), velocities, velocities, approaches)
def test_every_impact_balances_momentum_and_never_gains_energy_when_plastic(
        s, delta_rate, velocity, gap_rate):
    after = impact(s, delta_rate, velocity, gap_rate)
    sa, ca = math.sin(math.radians(s.alpha)), math.cos(math.radians(s.alpha))
    # Only the first slide can meet Painleve's paradox (a slide from rest never does).
    paradox = velocity != 0.0 and 1.0 - s.M * sa * (sa + math.copysign(s.ck, velocity) * ca) <= 0
    assert (after.outcome == IMPACT_PARADOX) == paradox
    if paradox:
        assert math.isnan(after.velocity)
        return
    d, v, h = float(after.delta_rate), float(after.velocity), float(after.gap_rate)
    px, pz = float(after.tangential_impulse), float(after.normal_impulse)
    scale = abs(delta_rate) + abs(velocity) + abs(gap_rate)
    tolerance = 1e-13 * scale
    assert abs((v + s.M * sa * d) - (velocity + s.M * sa * delta_rate) - px) <= tolerance
    assert abs((h + s.M * ca * d) - (gap_rate + s.M * ca * delta_rate) - pz) <= tolerance
    assert abs((sa * v + ca * h + d) - (sa * velocity + ca * gap_rate + delta_rate)) <= (
        tolerance)
    assert h == -s.restitution * gap_rate
    assert pz > 0.0 and abs(px) <= s.cs * pz * (1 + 1e-12)
    assert (after.outcome == IMPACT_STICK) == (v == 0.0)
    if s.restitution == 0.0:
        def energy(d, v, h):
            return ((1 - s.M) * (v * v + h * h)
                    + s.M * ((v + d * sa) ** 2 + (h + d * ca) ** 2)) / 2
        assert energy(d, v, h) <= energy(delta_rate, velocity, gap_rate) * (1 + 1e-13)


@PROPERTY_SETTINGS
@given(structures(), velocities, velocities, approaches)
def test_mirror(s, delta_rate, velocity, gap_rate):
    with tilt_warnings(False):
        mirrored = study.Structure(f0=s.f0, Q=s.Q, alpha=-s.alpha, M=s.M, cs=s.cs, ck=s.ck,
                                   restitution=s.restitution)
    one = impact(s, delta_rate, velocity, gap_rate)
    other = impact(mirrored, delta_rate, -velocity, gap_rate)
    assert one.outcome == other.outcome
    got = np.array([other.delta_rate, other.velocity, other.gap_rate, other.normal_impulse,
                    other.tangential_impulse])
    want = np.array([one.delta_rate, -one.velocity, one.gap_rate, one.normal_impulse,
                     -one.tangential_impulse])
    np.testing.assert_allclose(got, want, rtol=1e-14, atol=0)
