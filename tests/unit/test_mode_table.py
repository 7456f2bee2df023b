"""The mode table's drive columns as the drivers fill them (``mode_drive`` with
``searched_only``): only the event sinusoids each row's own searches read are computed;
the others are NaN, and no pass over the period map, with or without flight, reads
them (its end state and statistics are those of the full table, bit for bit)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from study.kernels.budget import Budget
from study.kernels.two_way import flight, flight_orbit, modes, orbit, points
from study.model.codes import BOUNCING
from study.model.structure import Structure
from study.solvers.structure_constants import structure_vector

#: The release sinusoids' columns (forward, backward) and the slip speed's.
RELEASE = (modes.M_SIN_P, modes.M_AMP_P, modes.M_ARG_P,
           modes.M_SIN_M, modes.M_AMP_M, modes.M_ARG_M)
SLIP_SPEED = (modes.M_SIN_V,)

#: Structures across the model: the paper's, a heavy plate, a backward tilt, M = 1.
STRUCTURES = (
    Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25),
    Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.7, cs=0.25),
    Structure(f0=20.0, Q=5.0, alpha=-40.0, M=0.3, cs=0.4, ck=0.3),
    Structure(f0=14.44, Q=17.5, alpha=64.0, M=1.0, cs=0.25),
)


def _tables(vector: np.ndarray, omega: float, a: float, rows: int
            ) -> tuple[np.ndarray, np.ndarray]:
    """The full table (``mode_row``) and the drivers' (constants, then the searched
    columns), each ``rows`` x ``N_MODE``."""
    full = np.zeros((rows, modes.N_MODE))
    searched = np.zeros((rows, modes.N_MODE))
    for row in range(3):
        modes.mode_row(vector, omega, a, full, row)
        modes.mode_constants(vector, searched, row)
        modes.mode_drive(vector, omega, a, searched, row, searched_only=True)
    return full, searched


@pytest.mark.parametrize("structure", STRUCTURES, ids=lambda s: f"M{s.M}-alpha{s.alpha}")
def test_searched_columns_are_the_full_ones_and_the_others_nan(structure):
    vector = structure_vector(structure, "two-way")
    rng = np.random.default_rng(7)
    for _ in range(20):
        omega = 2.0 * math.pi * rng.uniform(2.0, 40.0)
        a = rng.uniform(0.0, 25.0)
        full, searched = _tables(vector, omega, a, 3)
        skipped = {0: SLIP_SPEED, 1: RELEASE, 2: RELEASE}
        for row in range(3):
            if full[row, modes.M_D] <= 0.0:
                # A slip with D <= 0 (the paradox): no drive columns at all.
                np.testing.assert_array_equal(searched[row], full[row])
                continue
            for col in range(modes.N_MODE):
                if col in skipped[row]:
                    assert math.isnan(searched[row, col]), (row, col)
                else:
                    assert searched[row, col] == full[row, col], (row, col)


def _pass(vector, table, omega, a, z, want_jac):
    """One period from ``z`` with the contact model, lift-off noted: end state, flag,
    statistics and Jacobian."""
    record = orbit.PassRecord(np.zeros(orbit.N_ACC), np.eye(3), np.zeros((3, 3)),
                              np.zeros(2))
    work = z.copy()
    flag = orbit.run(modes.DrivePoint(vector, table, omega, a), work, 0.0,
                     2.0 * math.pi / omega, record, want_jac, 0.0, 10_000, True)
    return work, flag, record.acc.copy(), record.jac.copy()


@pytest.mark.parametrize("structure", STRUCTURES, ids=lambda s: f"M{s.M}-alpha{s.alpha}")
def test_no_pass_reads_a_column_left_out(structure):
    """From stick and from forward and backward slips, at drives that stick, slip and
    lift off: the pass on the drivers' table is the full table's, bit for bit (a read
    of a NaN column would change it)."""
    vector = structure_vector(structure, "two-way")
    rng = np.random.default_rng(11)
    compared = 0
    for _ in range(40):
        omega = 2.0 * math.pi * rng.uniform(5.0, 30.0)
        a = rng.uniform(1.0, 15.0)
        full, searched = _tables(vector, omega, a, 3)
        scales = np.array([abs(complex(full[0, modes.M_PRE], full[0, modes.M_PIM])),
                           0.0, a / omega])
        scales[1] = scales[0] * omega
        for speed in (0.0, 1.0, -1.0):
            z = rng.normal(size=3) * scales
            z[2] = speed * scales[2] * rng.uniform(0.1, 2.0)
            for want_jac in (False, True):
                expected = _pass(vector, full, omega, a, z, want_jac)
                got = _pass(vector, searched, omega, a, z, want_jac)
                assert got[1] == expected[1]
                for g, e in zip(got, expected, strict=True):
                    np.testing.assert_array_equal(g, e)
                compared += 1
    assert compared == 40 * 3 * 2


def test_the_orbit_with_flight_does_not_read_a_column_left_out():
    """The flight search on the drivers' table (contact rows as the drivers fill them,
    then the flight row) gives the full table's row, bit for bit, at bouncing drives."""
    structure = Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.9, cs=0.25)
    vector = structure_vector(structure, "two-way", True)
    budget = Budget(10_000, 5_000, 1e-3, 20_000)
    statuses = set()
    for f, a in ((14.5, 11.0), (10.0, 12.0), (20.0, 14.0), (7.0, 10.5)):
        omega = 2.0 * math.pi * f
        rows = []
        for table in _tables(vector, omega, a, flight.N_ROWS):
            flight.flight_row(vector, table)
            z = np.zeros(flight.N_STATE)
            points.start_state(table, omega, 0.0, z, 1.0)
            out = np.full(points.N_OUT, np.nan)
            flight_orbit.solve_flight(vector, table, omega, a, budget, z, 0.0, out,
                                      points.FLIGHT_COLUMNS)
            rows.append(out)
        np.testing.assert_array_equal(rows[1], rows[0])
        statuses.add(int(rows[0][points.OUT_STATUS]))
    assert int(BOUNCING) in statuses
