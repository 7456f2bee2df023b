"""Property tests of the steady-state solver over the whole valid parameter space."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import study
from study import NonConvergence, Status
from study.model.structure import tilt_warnings

finite = {"allow_nan": False, "allow_infinity": False}


@st.composite
def structures(draw):
    cs = draw(st.floats(0.02, 2.0, **finite))
    params = dict(
        f0=draw(st.floats(0.5, 200.0, **finite)),
        Q=draw(st.floats(0.5, 1e4, **finite)),
        alpha=draw(st.floats(-89.9, 89.9, **finite)),
        M=draw(st.floats(1e-4, 1.0, **finite)),
        cs=cs,
        ck=cs * draw(st.floats(0.05, 1.0, **finite)),
        g=draw(st.sampled_from([9.8, 9.81, 1.62])),
    )
    with tilt_warnings(False):  # small tilts are part of the space, in degree
        return study.Structure(**params)


@st.composite
def drives(draw, structure):
    f = structure.f0 * draw(st.floats(0.01, 100.0, **finite))
    a = structure.g * draw(st.floats(0.0, 3.0, **finite))
    return f, a


@st.composite
def cases(draw):
    s = draw(structures())
    f, a = draw(drives(s))
    return s, f, a


PROPERTY_SETTINGS = settings(max_examples=300, deadline=None, derandomize=True)


@PROPERTY_SETTINGS
@given(cases())
def test_returns_a_valid_status_and_nan_only_when_flagged(case):
    s, f, a = case
    result = study.steady_state(s, f, a)
    status = Status(int(result.status))
    reason = NonConvergence(int(result.reason))
    flagged = status in (Status.LIFT_OFF, Status.NOT_CONVERGED)
    assert math.isnan(result.velocity) == flagged
    assert (reason != NonConvergence.NONE) == (status == Status.NOT_CONVERGED)
    if not flagged:
        assert 0.0 <= result.forward_fraction <= 1.0
        assert 0.0 <= result.backward_fraction <= 1.0
        assert result.forward_fraction + result.backward_fraction <= 1.0 + 1e-12
        if status == Status.CONTINUOUS_SLIDING:
            assert math.isclose(
                result.forward_fraction + result.backward_fraction, 1.0, rel_tol=1e-9
            )


@PROPERTY_SETTINGS
@given(structures(), st.floats(0.01, 100.0, **finite), st.floats(0.0, 1.0, **finite))
def test_exactly_static_below_both_thresholds(s, f_ratio, fraction):
    f = s.f0 * f_ratio
    a_plus, a_minus = study.thresholds(s, f)
    a = fraction * min(a_plus, a_minus) * (1 - 1e-9)
    v, status = study.steady_velocity(s, f, a)
    if a > study.lift_off_acceleration(s, f):
        assert status == Status.LIFT_OFF
    else:
        assert status == Status.STATIC
        assert v == 0.0


@PROPERTY_SETTINGS
@given(cases())
def test_mirror_alpha_mirrors_velocity(case):
    s, f, a = case
    v, status = study.steady_velocity(s, f, a)
    with tilt_warnings(False):  # the mirror of a small tilt, in degree
        mirrored = s.replace(alpha=-s.alpha)
    v_m, status_m = study.steady_velocity(mirrored, f, a)
    assert status == status_m
    if status in (Status.STATIC, Status.STICK_SLIP, Status.CONTINUOUS_SLIDING):
        np.testing.assert_allclose(v_m, -v, rtol=1e-9, atol=1e-15 * s.g / (2 * np.pi * f))


@PROPERTY_SETTINGS
@given(cases())
def test_lift_off_flagged_exactly_above_lift_off_acceleration(case):
    s, f, a = case
    _, status = study.steady_velocity(s, f, a)
    assert (status == Status.LIFT_OFF) == (a > study.lift_off_acceleration(s, f))
