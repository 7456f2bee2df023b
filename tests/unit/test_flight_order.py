"""Which search a point takes first with flight (``study.kernels.two_way.points``).

Past the stick's lift-off threshold (``a > lift_off_acceleration(f)``) the orbit with
flight is sought first, and a bouncing orbit found so is the answer; every other point,
and a lifted point whose orbit with flight stays on the table, is solved as without
flight first, bit for bit. The order shows in the work columns: each check compares a
point's row against the two searches run on their own (the contact solver without
flight, :func:`~study.kernels.two_way.flight_orbit.solve_flight` from the same start),
so it fails when the contact search is run where it is not needed, or skipped where it
is.
"""

from __future__ import annotations

import numpy as np
import pytest

import study
from study.kernels.two_way import flight, flight_orbit, points
from study.model.status import Status
from study.solvers.settings import DEFAULT_SETTINGS, kernel_budget
from study.solvers.structure_constants import structure_vector
from tests.support.flight_points import flight_table

STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
BUDGET = kernel_budget(DEFAULT_SETTINGS)
WORK = list(points.WORK_COLUMNS)
ORBIT = [c for c in range(points.N_OUT) if c not in points.WORK_COLUMNS]


def _row(f: float, a: float, with_flight: bool) -> np.ndarray:
    out = np.empty(points.N_OUT)
    lifted = bool(a > study.lift_off_acceleration(STRUCTURE, f))
    points.solve_point(structure_vector(STRUCTURE, "two-way", with_flight),
                       2.0 * np.pi * f, a, lifted, BUDGET, 0.0, 1.0, out)
    return out


def _flight_alone(f: float, a: float) -> tuple[np.ndarray, float]:
    """The flight search from the solver's start, alone: its row and its passes."""
    vector = structure_vector(STRUCTURE, "two-way", True)
    omega = 2.0 * np.pi * f
    table = flight_table(vector, omega, a)
    z = np.zeros(flight.N_STATE)
    points.start_state(table, omega, 0.0, z, 1.0)
    out = np.full(points.N_OUT, np.nan)
    with_jac, without, _ = flight_orbit.solve_flight(vector, table, omega, a, BUDGET, z, 0.0,
                                                     out, points.FLIGHT_COLUMNS)
    return out, with_jac + without


def _passes(row: np.ndarray) -> float:
    return row[points.OUT_NEWTON_PASSES] + row[points.OUT_MAP_PASSES]


def _same(x: np.ndarray, y: np.ndarray) -> bool:
    return bool(np.all((x == y) | (np.isnan(x) & np.isnan(y))))


@pytest.fixture(scope="module")
def kinds() -> dict[str, tuple[float, float]]:
    """One point of each kind on a coarse M = 0.99 map."""
    f, a = np.meshgrid(np.linspace(5.0, 30.0, 26), np.linspace(0.5, 12.0, 24),
                       indexing="ij")
    f, a = f.ravel(), a.ravel()
    lifted = a > study.lift_off_acceleration(STRUCTURE, f)
    with_flight = study.steady_state(STRUCTURE, f, a, coupling="two-way", flight=True)
    without = study.steady_state(STRUCTURE, f, a, coupling="two-way")
    bouncing = np.asarray(with_flight.status == Status.BOUNCING)
    on_table = np.asarray(np.isin(without.status, [Status.STICK_SLIP,
                                                   Status.CONTINUOUS_SLIDING]))
    found = {}
    for name, chosen in (("lifted bouncing", bouncing & lifted),
                         ("bouncing below the threshold", bouncing & ~lifted),
                         ("lifted on the table", on_table & lifted)):
        index = np.flatnonzero(chosen)
        assert index.size, name
        found[name] = (float(f[index[0]]), float(a[index[0]]))
    return found


def test_lifted_bouncing_point_takes_the_flight_search_alone(kinds):
    f, a = kinds["lifted bouncing"]
    row = _row(f, a, True)
    alone, passes = _flight_alone(f, a)
    assert row[points.OUT_STATUS] == Status.BOUNCING
    columns = list(points.FLIGHT_COLUMNS)
    assert _same(row[columns], alone[columns])
    # No contact search before it: its passes are the flight search's.
    assert _passes(row) == passes
    assert _passes(_row(f, a, False)) > 0


def test_bouncing_point_below_the_threshold_takes_the_contact_search_first(kinds):
    f, a = kinds["bouncing below the threshold"]
    row = _row(f, a, True)
    contact = _row(f, a, False)
    alone, passes = _flight_alone(f, a)
    assert contact[points.OUT_STATUS] == Status.LIFT_OFF
    columns = list(points.FLIGHT_COLUMNS)
    assert _same(row[columns], alone[columns])
    assert _passes(row) == _passes(contact) + passes


def test_lifted_point_on_the_table_keeps_the_contact_solvers_bits(kinds):
    f, a = kinds["lifted on the table"]
    row = _row(f, a, True)
    contact = _row(f, a, False)
    alone, passes = _flight_alone(f, a)
    # The flight search found no bouncing orbit, so the contact solver's answer stands,
    # bit for bit, after both searches.
    assert alone[points.OUT_STATUS] != Status.BOUNCING
    assert row[ORBIT].tobytes() == contact[ORBIT].tobytes()
    assert _passes(row) == _passes(contact) + passes
