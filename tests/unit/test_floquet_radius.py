"""The Floquet multiplier's closed form: the largest modulus of a 3x3 Jacobian's
eigenvalues from its characteristic cubic (``newton.spectral_radius``), against LAPACK
and against matrices whose eigenvalues are known."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.kernels.budget import Budget
from study.kernels.two_way import modes, newton, orbit, points
from study.solvers.structure_constants import structure_vector


def _lapack_radius(matrix: np.ndarray) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(matrix))))


def test_random_matrices_against_lapack():
    """20 000 random matrices with entries over nine decades (a third with a nearly
    zero last row, as an orbit that almost sticks has): within 1e-12 relative of
    LAPACK (which is itself good to ~1e-13 there; the closed form's worst, checked once
    against 50-digit eigenvalues, was 3e-13)."""
    rng = np.random.default_rng(20261126)
    worst = 0.0
    for k in range(20_000):
        matrix = rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-6.0, 3.0, size=(3, 3))
        if k % 3 == 0:
            matrix[2] *= 1e-8
        expected = _lapack_radius(matrix)
        got = newton.spectral_radius(matrix)
        worst = max(worst, abs(got - expected) / expected)
    assert worst <= 1e-12, worst


@pytest.mark.parametrize("values", [(0.9, 0.5, -0.2), (-0.99, 1e-3, 1e-9), (2.0, 2.0, 0.1),
                                    (0.0, 0.0, 0.3), (-1.0, -1.0, -1.0 + 1e-3)])
def test_real_eigenvalues_of_a_similar_matrix(values):
    """``S diag(values) S^-1``: the largest |value| (a double root to ~sqrt(eps))."""
    rng = np.random.default_rng(7)
    basis = rng.normal(size=(3, 3))
    matrix = basis @ np.diag(values) @ np.linalg.inv(basis)
    tolerance = 1e-7 if len(set(values)) < 3 else 1e-12
    assert_allclose(newton.spectral_radius(matrix), max(abs(v) for v in values),
                    rtol=tolerance, atol=0.0)


@pytest.mark.parametrize("modulus, angle, real", [(0.8, 1.0, 0.3), (0.5, 3.0, -0.95),
                                                   (1e-3, 0.1, 1e-6), (1.2, 2.0, 1.1)])
def test_a_complex_pair(modulus, angle, real):
    """A rotation-scaling block beside a real eigenvalue, in a random basis."""
    block = modulus * np.array([[math.cos(angle), -math.sin(angle), 0.0],
                                [math.sin(angle), math.cos(angle), 0.0],
                                [0.0, 0.0, real / modulus]])
    basis = np.random.default_rng(3).normal(size=(3, 3))
    matrix = basis @ block @ np.linalg.inv(basis)
    assert_allclose(newton.spectral_radius(matrix), max(modulus, abs(real)), rtol=1e-12,
                    atol=0.0)


def test_a_stick_row_uses_the_two_by_two_block():
    """A zero last row but its diagonal: the multipliers of the (delta, delta') block and
    jac[2, 2] (the stick's reset), as LAPACK finds them."""
    matrix = np.array([[0.3, -0.7, 2.0], [0.4, 0.1, -1.0], [0.0, 0.0, 0.0]])
    assert_allclose(newton.spectral_radius(matrix), _lapack_radius(matrix), rtol=1e-14,
                    atol=0.0)


def test_not_finite_is_infinite():
    matrix = np.eye(3)
    matrix[0, 1] = np.nan
    assert newton.spectral_radius(matrix) == np.inf


def test_orbit_jacobians_against_lapack():
    """The Jacobians of the period map at moving points of the paper's structure and
    at M = 1 (continuous sliding): the closed form within 1e-13 of LAPACK."""
    budget = Budget(10_000, 5_000, 1e-3, 20_000)
    checked = 0
    for mass, f_values in ((0.08, (12.0, 14.5, 16.5, 19.0)), (1.0, (8.0, 14.0, 25.0))):
        structure = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=mass, cs=0.25)
        vector = structure_vector(structure, "two-way")
        for f in f_values:
            for a in (4.0, 5.5, 7.0, 8.0, 9.0, 10.0, 11.0):
                omega = 2.0 * math.pi * f
                out = np.empty(points.N_OUT)
                points.solve_point(vector, omega, a, False, budget, 0.0, 1.0, out)
                if out[points.OUT_PERIOD] != 1.0:
                    continue
                table = np.zeros((3, modes.N_MODE))
                modes.mode_table(vector, omega, a, table)
                z = out[[points.OUT_DELTA, points.OUT_DELTA_RATE, points.OUT_SPEED]].copy()
                record = orbit.PassRecord(np.zeros(orbit.N_ACC), np.eye(3), np.zeros((3, 3)),
                                          np.zeros(2))
                orbit.run(modes.DrivePoint(vector, table, omega, a), z, 0.0,
                          2.0 * math.pi / omega, record, True, -1.0, 10_000)
                assert_allclose(newton.spectral_radius(record.jac),
                                _lapack_radius(record.jac), rtol=1e-13, atol=0.0)
                checked += 1
    assert checked >= 15, checked
