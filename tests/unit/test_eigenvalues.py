"""The kernels' eigenvalues of small real matrices (``study.kernels.eigenvalues``, the
flight orbit's Floquet multiplier): against 40-digit eigenvalues (mpmath), against
matrices whose eigenvalues are known by construction, and against LAPACK on the
Jacobians of real bouncing orbits."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
import scipy.linalg
from numpy.testing import assert_allclose

import study
from study.kernels import eigenvalues
from study.kernels.budget import Budget
from study.kernels.two_way import flight, flight_orbit, modes
from study.kernels.two_way.cycles import MAX_PERIOD
from study.kernels.two_way.points import start_state
from study.solvers.structure_constants import structure_vector


def _exact_radius(matrix: np.ndarray) -> float:
    """The spectral radius from mpmath's eigenvalues at 40 digits (no shared code)."""
    with mpmath.workdps(40):
        values = mpmath.eig(mpmath.matrix(matrix.tolist()), left=False, right=False)
        return float(max(abs(v) for v in values))


def _similar(values: np.ndarray, seed: int) -> np.ndarray:
    """``S B S^-1`` for the block-diagonal ``B`` of ``values`` (complex ones as 2x2
    rotation-scaling blocks with their conjugate)."""
    blocks = []
    for value in values:
        if value.imag == 0.0:
            blocks.append(np.array([[value.real]]))
        elif value.imag > 0.0:
            blocks.append(np.array([[value.real, -value.imag], [value.imag, value.real]]))
    n = sum(b.shape[0] for b in blocks)
    matrix = np.zeros((n, n))
    at = 0
    for block in blocks:
        size = block.shape[0]
        matrix[at:at + size, at:at + size] = block
        at += size
    basis = np.random.default_rng(seed).normal(size=(n, n))
    return basis @ matrix @ np.linalg.inv(basis)


def _condition(matrix: np.ndarray) -> float:
    """The condition number ``|y| |x| / |y^H x|`` of the eigenvalue of largest modulus
    (``x``, ``y`` its right and left eigenvectors; scipy's LAPACK, as the scale of the
    error any backward-stable method makes)."""
    values, left, right = scipy.linalg.eig(matrix, left=True, right=True)
    i = int(np.argmax(np.abs(values)))
    x, y = right[:, i], left[:, i]
    return float(np.linalg.norm(x) * np.linalg.norm(y) / abs(np.vdot(y, x)))


#: The random matrices' kinds, each with its own fixed seed.
KINDS = {"normal": 11, "badly scaled": 12, "nearly rank one": 13, "two zero rows": 14}


def _random_matrix(kind: str, rng: np.random.Generator) -> np.ndarray:
    matrix = rng.normal(size=(5, 5))
    if kind == "badly scaled":
        matrix *= 10.0 ** rng.uniform(-6.0, 6.0, size=(5, 1))
        matrix *= 10.0 ** rng.uniform(-6.0, 6.0, size=(1, 5))
    elif kind == "nearly rank one":
        matrix = (rng.normal(size=(5, 1)) @ rng.normal(size=(1, 5))
                  + 1e-9 * rng.normal(size=(5, 5)))
    elif kind == "two zero rows":
        # A pass that ends in contact: the gap rows of its Jacobian vanish.
        matrix[3:] = 0.0
    return matrix


@pytest.mark.parametrize("kind", list(KINDS))
def test_random_matrices_against_40_digits(kind):
    """60 random 5x5 of each kind: the radius within 50 eps ||A|| cond(lambda) of the
    40-digit one, the error bound of a backward-stable method (ours and LAPACK's worst,
    over 1440 such matrices: 6.3 and 6.1 of it)."""
    rng = np.random.default_rng(KINDS[kind])
    eps = np.finfo(float).eps
    for _ in range(60):
        matrix = _random_matrix(kind, rng)
        error = abs(eigenvalues.spectral_radius(matrix) - _exact_radius(matrix))
        assert error <= 50.0 * eps * np.linalg.norm(matrix) * _condition(matrix)


def test_badly_scaled_matrices_are_balanced():
    """Entries over twelve decades: balancing keeps the radius within 1e-13 relative of
    the 40-digit one (1.3e-15 at worst on these matrices; without balancing, the rows
    of small entries lose digits to the large ones: 1.5e-10)."""
    rng = np.random.default_rng(KINDS["badly scaled"])
    for _ in range(60):
        matrix = _random_matrix("badly scaled", rng)
        exact = _exact_radius(matrix)
        assert_allclose(eigenvalues.spectral_radius(matrix), exact, rtol=1e-13, atol=0.0)


@pytest.mark.parametrize("values", [
    (0.9, 0.5, -0.2, 1e-3, 0.0),
    (0.3 + 0.9j, 0.3 - 0.9j, -0.5, 0.1, 0.05),
    (1.0000001, 0.999, 0.5 + 0.5j, 0.5 - 0.5j, -0.2),
    (-0.99, 0.2 + 0.98j, 0.2 - 0.98j, 1e-8, -1e-8),
    (1e-6, 2e-7, -3e-7, 1e-9, 0.0),
    (0.4 + 0.1j, 0.4 - 0.1j, 0.4 + 0.3j, 0.4 - 0.3j, 0.41),
])
def test_known_eigenvalues_in_a_random_basis(values):
    """A similarity of a block-diagonal matrix of real values and complex pairs: the
    largest modulus to 1e-12 (the basis's condition number costs a few digits)."""
    values = np.array(values, dtype=complex)
    for seed in range(5):
        matrix = _similar(values, seed)
        assert_allclose(eigenvalues.spectral_radius(matrix), np.max(np.abs(values)),
                        rtol=1e-12, atol=0.0)


def test_every_eigenvalue_of_a_companion_matrix():
    """The companion matrix of ``(x - 0.5)(x + 0.25)(x - 2)(x^2 + 1)``: all five
    eigenvalues (0.5, -0.25, 2 and +-i), not only the largest."""
    roots = np.array([0.5, -0.25, 2.0, 1j, -1j])
    coefficients = np.real(np.poly(roots))
    companion = np.zeros((5, 5))
    companion[0] = -coefficients[1:]
    companion[1:, :-1] = np.eye(4)
    real = np.empty(5)
    imag = np.empty(5)
    assert eigenvalues.eigenvalues(companion, real, imag)
    got = np.sort_complex(real + 1j * imag)
    assert_allclose(got, np.sort_complex(roots), rtol=0.0, atol=1e-13)


@pytest.mark.parametrize("matrix", [
    np.zeros((5, 5)),
    np.eye(5),
    np.eye(5)[[1, 2, 3, 4, 0]],  # a cyclic permutation: the fifth roots of unity
    np.triu(np.arange(1.0, 26.0).reshape(5, 5)),
    np.diag([1e-300, 1e300, 1.0, -2.0, 0.5]),
])
def test_structured_matrices(matrix):
    """Zero, identity, a permutation (all five eigenvalues on the unit circle), a
    triangular matrix and a diagonal over 600 decades."""
    expected = float(np.max(np.abs(np.diag(matrix)))) if np.allclose(
        matrix, np.triu(matrix)) else 1.0
    assert_allclose(eigenvalues.spectral_radius(matrix), expected, rtol=1e-14, atol=0.0)


def test_a_jordan_block_is_found_to_its_conditioning():
    """A defective double eigenvalue 0.7 (a Jordan block): its computed value moves by
    ~sqrt(eps), as for any backward-stable method."""
    block = np.diag([0.7, 0.7, 0.1, -0.3, 0.2])
    block[0, 1] = 1.0
    basis = np.random.default_rng(5).normal(size=(5, 5))
    matrix = basis @ block @ np.linalg.inv(basis)
    assert_allclose(eigenvalues.spectral_radius(matrix), 0.7, rtol=1e-6, atol=0.0)


def test_a_qr_iteration_that_does_not_converge_goes_to_lapack():
    """With no QR iteration allowed, a matrix that needs one is refused by
    ``eigenvalues`` and its radius comes from LAPACK; a triangular one needs none."""
    matrix = np.random.default_rng(9).normal(size=(5, 5))
    real = np.empty(5)
    imag = np.empty(5)
    assert not eigenvalues.eigenvalues(matrix, real, imag, 0)
    assert_allclose(eigenvalues.spectral_radius(matrix, 0),
                    np.max(np.abs(np.linalg.eigvals(matrix))), rtol=1e-14, atol=0.0)
    triangular = np.triu(matrix)
    assert eigenvalues.eigenvalues(triangular, real, imag, 0)
    assert_allclose(np.sort(real), np.sort(np.diag(triangular)), rtol=0.0, atol=0.0)


def test_not_finite_is_infinite_and_the_matrix_is_kept():
    matrix = np.eye(5)
    matrix[2, 3] = np.inf
    assert eigenvalues.spectral_radius(matrix) == np.inf
    finite = np.random.default_rng(2).normal(size=(5, 5))
    kept = finite.copy()
    eigenvalues.spectral_radius(finite)
    assert np.array_equal(finite, kept)


def test_bouncing_orbit_multipliers_against_lapack():
    """The Floquet multiplier of bouncing orbits at M = 0.99 (the Jacobian with flight
    flows and impact saltations), recomputed by LAPACK from the orbit's own Jacobian:
    the same to 1e-12."""
    structure = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
    vector = structure_vector(structure, "two-way", True)
    checked = 0
    for f, a in [(10.0, 9.0), (12.5, 10.0), (14.5, 10.0), (17.0, 11.0), (20.0, 11.5)]:
        omega = 2.0 * math.pi * f
        table = np.zeros((flight.N_ROWS, modes.N_MODE))
        for row in range(3):
            modes.mode_row(vector, omega, a, table, row)
        jacobian = _orbit_jacobian(vector, table, omega, a)
        if jacobian is None:
            continue
        expected = float(np.max(np.abs(np.linalg.eigvals(jacobian))))
        assert_allclose(eigenvalues.spectral_radius(jacobian), expected, rtol=1e-12,
                        atol=1e-15)
        checked += 1
    assert checked >= 3


def _orbit_jacobian(vector, table, omega, a):
    """The 5x5 Jacobian of one pass around the orbit with flight reached from rest, or
    None when no bouncing orbit was found."""
    flight.flight_row(vector, table)
    point = modes.DrivePoint(vector, table, omega, a)
    z = np.zeros(flight.N_STATE)
    start_state(table, omega, 0.0, z, 1.0)
    record = flight.FlightRecord(np.zeros(flight.N_FLIGHT_ACC), np.eye(5),
                                 np.empty((5, 5)), np.empty((5, 5)), np.zeros(2))
    _, _, periods, _ = flight_orbit.find_flight_orbit(
        point, z, 0.0, flight_orbit.flight_scales(point), Budget(100_000, 5_000, 1e-3, 20_000),
        record, np.empty(5), np.empty((MAX_PERIOD, 5)), np.empty(flight_orbit.N_STATS))
    if periods == 0 or record.acc[flight.A_AIRBORNE] == 0.0:
        return None
    return record.jac.copy()
