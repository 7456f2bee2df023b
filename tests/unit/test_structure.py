"""Structure validation: every invalid parameter raises a clear ValueError."""

from __future__ import annotations

import math

import pytest

import study
from study.model.paper import PAPER_STRUCTURE

#: The paper's structure as a user writes it: without ck, which defaults to cs.
PAPER = {name: value for name, value in PAPER_STRUCTURE.items() if name != "ck"}


def test_paper_structure_builds_with_defaults():
    s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    assert s.ck == s.cs == 0.25
    assert s.g == 9.8
    assert s.omega0 == pytest.approx(2 * math.pi * 14.44, rel=1e-15)


@pytest.mark.parametrize(
    ("name", "value", "allowed"),
    [
        ("f0", 0.0, "0 < f0 <= 1e6 Hz"),
        ("f0", -3.0, "0 < f0 <= 1e6 Hz"),
        ("f0", 2e6, "0 < f0 <= 1e6 Hz"),
        ("Q", 0.0, "0.01 <= Q <= 1e6"),
        ("Q", -17.5, "0.01 <= Q <= 1e6"),
        ("Q", 0.001, "0.01 <= Q <= 1e6"),
        ("alpha", 90.0, "-90 < alpha < 90"),
        ("alpha", -90.0, "-90 < alpha < 90"),
        ("alpha", 120.0, "-90 < alpha < 90"),
        ("M", 0.0, "0 < M <= 1"),
        ("M", 1.0000001, "0 < M <= 1"),
        ("M", -0.1, "0 < M <= 1"),
        ("cs", 0.0, "1e-6 <= cs <= 100"),
        ("cs", -0.25, "1e-6 <= cs <= 100"),
        ("cs", 5e-324, "1e-6 <= cs <= 100"),
        ("ck", 0.3, "1e-6 <= ck <= cs (cs = 0.25)"),
        ("ck", 0.0, "1e-6 <= ck <= cs"),
        ("g", 0.0, "0 < g <= 1000 m s-2"),
        ("g", 1e300, "0 < g <= 1000 m s-2"),
    ],
)
def test_out_of_range_parameter_is_refused_with_name_value_and_range(name, value, allowed):
    params = dict(PAPER, **{name: value})
    with pytest.raises(ValueError, match="is out of range") as err:
        study.Structure(**params)
    message = str(err.value)
    assert repr(name) in message
    assert repr(float(value)) in message
    assert allowed in message


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, "abc", None, True, 1j])
@pytest.mark.parametrize("name", ["f0", "Q", "alpha", "M", "cs", "ck", "g"])
def test_non_finite_or_non_number_is_refused(name, bad):
    if name == "ck" and bad is None:
        pytest.skip("ck=None means ck defaults to cs")
    params = dict(PAPER, **{name: bad})
    with pytest.raises(ValueError, match=repr(name)):
        study.Structure(**params)


def test_boundary_values_are_accepted():
    study.Structure(**dict(PAPER, M=1.0))
    study.Structure(**dict(PAPER, ck=0.25))
    study.Structure(**dict(PAPER, alpha=-89.999))


def test_replace_validates_again():
    s = study.Structure(**PAPER)
    assert s.replace(M=0.5).M == 0.5
    with pytest.raises(ValueError, match="'Q'"):
        s.replace(Q=-1.0)


def test_structure_is_immutable():
    s = study.Structure(**PAPER)
    with pytest.raises(AttributeError):
        s.Q = 3.0  # type: ignore[misc]
