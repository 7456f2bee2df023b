"""The exact flight solver (``steady_state(..., coupling="two-way", flight=True)``).

* the ``flight`` keyword: refused values (not a bool, one-way coupling, M = 1), each
  message naming ``flight``, the value and why;
* below lift-off, ``flight=True`` gives every field of ``flight=False`` bit for bit, on
  a map;
* the new fields are ``None`` unless ``flight=True``.
"""

from __future__ import annotations

import numpy as np
import pytest

import study
from study.kernels import structure_vector as sv
from study.solvers.exact import attractors, steady_state, steady_velocity, structure_vector

PAPER = dict(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
FIELDS = ("velocity", "status", "reason", "slips_per_period", "forward_fraction",
          "backward_fraction", "orbit_period", "floquet_multiplier")


@pytest.mark.parametrize("call", [steady_state, steady_velocity, attractors])
@pytest.mark.parametrize("value", [1, 0, "yes", None, 1.0])
def test_flight_must_be_a_bool(call, value):
    s = study.Structure(**PAPER)
    with pytest.raises(TypeError, match=r"flight must be True or False.*" + repr(value)[:3]):
        call(s, 14.5, 9.0, coupling="two-way", flight=value)


@pytest.mark.parametrize("call", [steady_state, steady_velocity, attractors])
def test_flight_refused_with_one_way(call):
    s = study.Structure(**PAPER)
    with pytest.raises(ValueError, match=r"flight=True needs coupling='two-way'.*one-way.*"
                                         r"driven by the table alone"):
        call(s, 14.5, 9.0, coupling="one-way", flight=True)


@pytest.mark.parametrize("call", [steady_state, steady_velocity, attractors])
def test_flight_refused_at_unit_mass_ratio(call):
    s = study.Structure(**{**PAPER, "M": 1.0})
    with pytest.raises(ValueError, match=r"flight=True needs a mass ratio M < 1, got M=1.0.*"
                                         r"massless.*unbounded"):
        call(s, 14.5, 9.0, coupling="two-way", flight=True)
    # Just below is accepted.
    call(study.Structure(**{**PAPER, "M": 0.999}), 14.5, 1.0, coupling="two-way", flight=True)


def test_structure_vector_lift_off_law():
    s = study.Structure(**PAPER)
    assert structure_vector(s, "two-way")[sv.LIFT_OFF_LAW] == 0.0
    assert structure_vector(s, "two-way", True)[sv.LIFT_OFF_LAW] == 1.0
    assert structure_vector(s, "two-way", False).tobytes() == structure_vector(
        s, "two-way").tobytes()


def test_flight_fields_only_with_flight():
    s = study.Structure(**PAPER)
    without = steady_state(s, 14.5, 9.0, coupling="two-way")
    assert without.airborne_fraction is None
    assert without.largest_hop is None
    assert without.impacts_per_period is None
    with_flight = steady_state(s, 14.5, 9.0, coupling="two-way", flight=True)
    assert with_flight.airborne_fraction == 0.0
    assert with_flight.largest_hop == 0.0
    assert with_flight.impacts_per_period == 0.0


@pytest.mark.parametrize("M", [0.08, 0.6, 0.99])
def test_below_lift_off_bit_identical(M):
    """Every point of a map that stays on the table: flight changes no bit of any field."""
    s = study.Structure(**{**PAPER, "M": M})
    f = np.linspace(10.0, 20.0, 21)[:, None]
    a = np.linspace(0.0, 12.0, 25)[None, :]
    without = steady_state(s, f, a, coupling="two-way")
    with_flight = steady_state(s, f, a, coupling="two-way", flight=True)
    on_table = without.status != study.Status.LIFT_OFF
    assert on_table.sum() >= 100
    for name in FIELDS:
        x = np.asarray(getattr(without, name))[on_table]
        y = np.asarray(getattr(with_flight, name))[on_table]
        assert x.tobytes() == y.tobytes(), name
    v0, st0 = steady_velocity(s, f, a, coupling="two-way")
    v1, st1 = steady_velocity(s, f, a, coupling="two-way", flight=True)
    assert v0[on_table].tobytes() == v1[on_table].tobytes()
    assert st0[on_table].tobytes() == st1[on_table].tobytes()
    assert np.all(np.asarray(with_flight.airborne_fraction)[on_table
                  & np.isfinite(without.velocity)] == 0.0)
