"""The kernels' small linear solves (Newton's step on the 3-state and the 5-state):
against LAPACK on random systems, their partial pivoting, and their refusals."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from study.kernels.two_way.flight_orbit import solve_linear
from study.kernels.two_way.newton import solve3


def _solve(matrix: np.ndarray, rhs: np.ndarray) -> tuple[bool, np.ndarray]:
    out = np.full(rhs.size, 7.0)
    solver = solve3 if rhs.size == 3 else solve_linear
    return solver(matrix, rhs, out), out


@pytest.mark.parametrize("size", [3, 5])
def test_random_systems_against_lapack(size):
    """2000 random systems with entries over six decades: the solution to 1e-10
    relative to its norm times the condition number's share (LAPACK's own error)."""
    rng = np.random.default_rng(size)
    for _ in range(2000):
        matrix = rng.normal(size=(size, size)) * 10.0 ** rng.uniform(-3.0, 3.0,
                                                                     size=(size, size))
        rhs = rng.normal(size=size)
        solved, out = _solve(matrix, rhs)
        assert solved
        expected = np.linalg.solve(matrix, rhs)
        bound = 1e-13 * np.linalg.cond(matrix) * np.linalg.norm(expected)
        assert_allclose(out, expected, rtol=0.0, atol=max(bound, 1e-300))


@pytest.mark.parametrize("size", [3, 5])
def test_pivoting_handles_a_zero_leading_entry(size):
    """A permutation-like system whose leading entries are 0: only pivoting solves it;
    the answer is exact."""
    matrix = np.roll(np.diag(np.arange(1.0, size + 1.0)), 1, axis=0)
    rhs = np.arange(2.0, 2.0 * size + 1.0, 2.0)
    solved, out = _solve(matrix, rhs)
    assert solved
    assert_allclose(matrix @ out, rhs, rtol=0.0, atol=0.0)


@pytest.mark.parametrize("size", [3, 5])
@pytest.mark.parametrize("defect", ["zero column", "equal rows", "nan", "inf"])
def test_singular_or_not_finite_is_refused_and_out_untouched(size, defect):
    rng = np.random.default_rng(11)
    matrix = rng.normal(size=(size, size))
    if defect == "zero column":
        matrix[:, 1] = 0.0
    elif defect == "equal rows":
        # Exactly dependent: the last pivot is exactly 0 after elimination.
        matrix = np.ones((size, size))
    elif defect == "nan":
        matrix[0, 0] = np.nan
    else:
        matrix[:, 0] = np.inf
    solved, out = _solve(matrix, rng.normal(size=size))
    assert not solved
    assert np.all(out == 7.0)


def test_the_inputs_are_not_changed():
    rng = np.random.default_rng(3)
    matrix = rng.normal(size=(3, 3))
    rhs = rng.normal(size=3)
    kept = matrix.copy(), rhs.copy()
    _solve(matrix, rhs)
    assert np.array_equal(matrix, kept[0]) and np.array_equal(rhs, kept[1])
