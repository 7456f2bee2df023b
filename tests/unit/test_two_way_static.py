"""Static points of the exact two-way solver, decided and written before any orbit.

A stuck structure does not force the mode through the base, so the two-way motion
thresholds are the one-way ones (:func:`study.thresholds`) and the static region is the
same point for point. The orbit kernel decides a static point from the stick's response
alone (:func:`study.kernels.two_way.modes.stick_response`) and writes its row without the
mode table. Compared against:

* the closed-form thresholds, at ``a = a*_pm (1 +- 1e-9)`` on random structures and
  frequencies, and the one-way solver's statuses there;
* the row the full construction gives (the stick's row of the mode table, its propagator
  by :func:`~study.kernels.two_way.propagation.homogeneous`, the 3x3 spectral radius),
  bit for bit;
* the free decay ``exp(-c T / 2)`` of the underdamped stick, in closed form.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import study
from study.kernels.budget import Budget
from study.kernels.two_way import modes, newton, points, propagation
from study.model import lift_off_acceleration, thresholds
from study.model.codes import LIFT_OFF, REASON_NONE, STATIC
from study.model.inputs import SuspectInputWarning
from study.solvers.exact import steady_state
from study.solvers.structure_constants import structure_vector

BUDGET = Budget(10_000, 5_000, 1e-3, 20_000)
# Columns of a static row that are not computed: no orbit, no state at phase 0.
NAN_COLUMNS = (points.OUT_DELTA, points.OUT_DELTA_RATE, points.OUT_SPEED)


def _random_structures(count, seed):
    rng = np.random.default_rng(seed)
    structures = []
    with warnings.catch_warnings():
        # Random tilts in the radian-like band are meant (degrees).
        warnings.simplefilter("ignore", SuspectInputWarning)
        for _ in range(count):
            cs = rng.uniform(0.05, 1.0)
            structures.append(study.Structure(
                f0=rng.uniform(5.0, 30.0), Q=rng.uniform(1.0, 60.0),
                alpha=rng.uniform(-89.0, 89.0), M=rng.uniform(0.0, 0.6), cs=cs,
                ck=cs * rng.uniform(0.3, 1.0)))
    return structures, rng


def _threshold_points(structure, rng, n_f=12):
    """Each frequency at ``a*_+`` and ``a*_-`` times ``1 - 1e-9`` and ``1 + 1e-9``."""
    f = rng.uniform(0.2, 3.0, n_f) * structure.f0
    a_plus, a_minus = thresholds(structure, f)
    a = np.concatenate([a_plus * (1 - 1e-9), a_plus * (1 + 1e-9),
                        a_minus * (1 - 1e-9), a_minus * (1 + 1e-9)])
    return np.tile(f, 4), a


def test_static_exactly_below_the_closed_form_thresholds():
    structures, rng = _random_structures(60, 2211)
    for structure in structures:
        f, a = _threshold_points(structure, rng)
        a_plus, a_minus = thresholds(structure, f)
        below = a < np.minimum(a_plus, a_minus)
        lifted = a > lift_off_acceleration(structure, f)
        two_way = steady_state(structure, f, a, coupling="two-way").status
        expected = np.where(lifted, LIFT_OFF, STATIC)
        assert_array_equal(two_way[below], expected[below], err_msg=str(structure))
        assert not np.any(two_way[~below] == STATIC), str(structure)
        # The static region is the one-way one, point for point.
        one_way = steady_state(structure, f, a, coupling="one-way").status
        assert_array_equal(two_way == STATIC, one_way == STATIC, err_msg=str(structure))


def _full_static_row(structure, omega, a):
    """A static point's row from the mode table and the 3x3 Jacobian."""
    vector = structure_vector(structure, "two-way")
    table = np.zeros((3, modes.N_MODE))
    modes.mode_row(vector, omega, a, table, 0)
    _, _, e11, e12, e21, e22 = propagation.homogeneous(table[0], 2.0 * math.pi / omega,
                                                       0.0, 0.0)
    free = np.zeros((3, 3))
    free[0, 0], free[0, 1], free[1, 0], free[1, 1] = e11, e12, e21, e22
    return table[0], newton.spectral_radius(free)


def test_static_row_is_the_full_construction_bit_for_bit():
    structures, rng = _random_structures(30, 2212)
    checked = 0
    for structure in structures:
        vector = structure_vector(structure, "two-way")
        f = rng.uniform(0.2, 3.0, 10) * structure.f0
        a_plus, a_minus = thresholds(structure, f)
        a = np.minimum(a_plus, a_minus) * rng.uniform(0.0, 1.0 - 1e-9, f.size)
        for fi, ai in zip(f, a, strict=True):
            omega = 2.0 * math.pi * fi
            row, multiplier = _full_static_row(structure, omega, ai)
            pr, pi = modes.stick_response(vector, omega, ai)
            assert (pr, pi) == (row[modes.M_PRE], row[modes.M_PIM])
            out = np.empty(points.N_OUT)
            points.solve_point(vector, omega, ai, False, BUDGET, 0.0, 1.0, out)
            assert out[points.OUT_STATUS] == STATIC
            assert out[points.OUT_REASON] == REASON_NONE
            assert out[points.OUT_PERIOD] == 0.0
            for column in (points.OUT_VELOCITY, points.OUT_SLIPS, points.OUT_FORWARD,
                           points.OUT_BACKWARD):
                assert out[column] == 0.0
            assert out[points.OUT_MULTIPLIER] == multiplier
            assert np.all(np.isnan(out[list(NAN_COLUMNS)]))
            checked += 1
    assert checked == 300


def test_lifted_static_row():
    """A static point past lift-off: LIFT_OFF, everything but the reason, period, periods
    averaged and the work columns (no pass: 0) NaN."""
    structure = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    vector = structure_vector(structure, "two-way")
    out = np.empty(points.N_OUT)
    points.solve_point(vector, 2.0 * math.pi * 12.0, 0.5, True, BUDGET, 0.0, 1.0, out)
    assert out[points.OUT_STATUS] == LIFT_OFF
    assert out[points.OUT_REASON] == REASON_NONE
    assert out[points.OUT_PERIOD] == 0.0
    assert out[points.OUT_AVERAGED_PERIODS] == 0.0
    rest = [i for i in range(points.N_OUT)
            if i not in (points.OUT_STATUS, points.OUT_REASON, points.OUT_PERIOD,
                         points.OUT_AVERAGED_PERIODS, *points.WORK_COLUMNS)]
    assert np.all(np.isnan(out[rest]))
    assert np.all(out[list(points.WORK_COLUMNS)] == 0.0)


@pytest.mark.parametrize("f", [5.0, 14.0, 40.0])
def test_static_multiplier_is_the_free_decay(f):
    """Underdamped stick: both free multipliers have modulus ``exp(-c T / 2)``."""
    structure = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    result = steady_state(structure, f, 0.1, coupling="two-way")
    assert result.status == STATIC
    damping = structure.omega0 / structure.Q
    assert_allclose(result.floquet_multiplier, math.exp(-0.5 * damping / f),
                    rtol=1e-12, atol=0.0)
