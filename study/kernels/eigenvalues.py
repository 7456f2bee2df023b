"""Eigenvalues of a small real matrix without LAPACK: the spectral radius of a period
map's Jacobian (the largest Floquet multiplier) inside the kernels.

A LAPACK eigenvalue call from numba (``np.linalg.eigvals`` of a complex 5x5) costs about
20 us, as much as two passes of a bouncing orbit, because of its workspace queries,
copies and the complex arithmetic. The orbit solvers need only the eigenvalues of a
5x5, for which the textbook algorithm is a few hundred floating-point operations:

1. balance the matrix by exact powers of 2 (Parlett and Reinsch), so that a Jacobian
   whose state components have different units loses no accuracy;
2. reduce it to upper Hessenberg form by stabilised elementary similarity transforms
   (Gaussian elimination with partial pivoting);
3. find the eigenvalues of the Hessenberg matrix by the Francis double-shift QR
   iteration, deflating one real or two (a real or a complex pair) eigenvalues at a
   time (Wilkinson and Reinsch's ``hqr``).

Every step is a similarity transform, so the eigenvalues are those of the matrix to
rounding: backward stable as LAPACK's ``dgeev``, which follows the same steps.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: QR iterations allowed per eigenvalue before :func:`hessenberg_eigenvalues` gives up
#: (the double-shift iteration converges in 2-4 in practice; exceptional shifts at 10
#: and 20 break the rare cycles).
MAX_QR_ITERATIONS = 30


@njit(cache=True, nogil=True, error_model="numpy")
def balance(a):
    """Balance the square ``a`` in place: scale row ``i`` by ``1/f`` and column ``i`` by
    ``f`` (``f`` a power of 2, so no rounding) until each row and column have comparable
    norms; the eigenvalues are unchanged."""
    n = a.shape[0]
    converged = False
    while not converged:
        converged = True
        for i in range(n):
            column = 0.0
            row = 0.0
            for j in range(n):
                if j != i:
                    column += abs(a[j, i])
                    row += abs(a[i, j])
            if column == 0.0 or row == 0.0:
                continue
            total = column + row
            factor = 1.0
            level = row / 2.0
            while column < level:
                factor *= 2.0
                column *= 4.0
            level = row * 2.0
            while column > level:
                factor /= 2.0
                column /= 4.0
            if (column + row) / factor < 0.95 * total:
                converged = False
                inverse = 1.0 / factor
                for j in range(n):
                    a[i, j] *= inverse
                for j in range(n):
                    a[j, i] *= factor


@njit(cache=True, nogil=True, error_model="numpy")
def hessenberg(a):
    """Reduce the square ``a`` in place to upper Hessenberg form by elementary
    similarity transforms with partial pivoting; the entries below the subdiagonal are
    set to 0."""
    n = a.shape[0]
    for m in range(1, n - 1):
        pivot = 0.0
        p = m
        for j in range(m, n):
            if abs(a[j, m - 1]) > abs(pivot):
                pivot = a[j, m - 1]
                p = j
        if p != m:
            # The permutation similarity: swap rows and columns p and m.
            for j in range(m - 1, n):
                a[p, j], a[m, j] = a[m, j], a[p, j]
            for j in range(n):
                a[j, p], a[j, m] = a[j, m], a[j, p]
        if pivot != 0.0:
            for i in range(m + 1, n):
                y = a[i, m - 1]
                if y != 0.0:
                    y /= pivot
                    a[i, m - 1] = 0.0
                    for j in range(m, n):
                        a[i, j] -= y * a[m, j]
                    for j in range(n):
                        a[j, m] += y * a[j, i]


@njit(cache=True, nogil=True, error_model="numpy")
def hessenberg_eigenvalues(a, real, imag, max_iterations):
    """Eigenvalues ``real + i imag`` of the upper Hessenberg ``a`` (destroyed) by the
    Francis double-shift QR iteration; False when an eigenvalue took more than
    ``max_iterations`` iterations (``real`` and ``imag`` then incomplete)."""
    n = a.shape[0]
    norm = 0.0
    for i in range(n):
        for j in range(max(i - 1, 0), n):
            norm += abs(a[i, j])
    last = n - 1
    shift = 0.0
    x = y = w = 0.0
    p = q = r = s = z = 0.0
    while last >= 0:
        iterations = 0
        while True:
            # The lowest negligible subdiagonal entry splits off a block [low, last].
            low = 0
            for l in range(last, 0, -1):
                s = abs(a[l - 1, l - 1]) + abs(a[l, l])
                if s == 0.0:
                    s = norm
                if abs(a[l, l - 1]) + s == s:
                    a[l, l - 1] = 0.0
                    low = l
                    break
            x = a[last, last]
            if low == last:
                # One real eigenvalue deflates.
                real[last] = x + shift
                imag[last] = 0.0
                last -= 1
                break
            y = a[last - 1, last - 1]
            w = a[last, last - 1] * a[last - 1, last]
            if low == last - 1:
                # A 2x2 block deflates: two real eigenvalues or a complex pair.
                p = 0.5 * (y - x)
                q = p * p + w
                z = math.sqrt(abs(q))
                x += shift
                if q >= 0.0:
                    z = p + math.copysign(z, p)
                    real[last - 1] = x + z
                    real[last] = x + z
                    if z != 0.0:
                        real[last] = x - w / z
                    imag[last - 1] = 0.0
                    imag[last] = 0.0
                else:
                    real[last - 1] = x + p
                    real[last] = x + p
                    imag[last - 1] = -z
                    imag[last] = z
                last -= 2
                break
            if iterations >= max_iterations:
                return False
            if iterations == 10 or iterations == 20:
                # An exceptional shift (breaks the rare cycles of the standard one).
                shift += x
                for i in range(last + 1):
                    a[i, i] -= x
                s = abs(a[last, last - 1]) + abs(a[last - 1, last - 2])
                x = 0.75 * s
                y = x
                w = -0.4375 * s * s
            iterations += 1
            # The double shift's first column, started where two consecutive
            # subdiagonal entries are small enough (saves the top of the sweep).
            m = last - 2
            while m >= low:
                z = a[m, m]
                r = x - z
                s = y - z
                p = (r * s - w) / a[m + 1, m] + a[m, m + 1]
                q = a[m + 1, m + 1] - z - r - s
                r = a[m + 2, m + 1]
                s = abs(p) + abs(q) + abs(r)
                p /= s
                q /= s
                r /= s
                if m == low:
                    break
                u = abs(a[m, m - 1]) * (abs(q) + abs(r))
                v = abs(p) * (abs(a[m - 1, m - 1]) + abs(z) + abs(a[m + 1, m + 1]))
                if u + v == v:
                    break
                m -= 1
            for i in range(m + 2, last + 1):
                a[i, i - 2] = 0.0
                if i != m + 2:
                    a[i, i - 3] = 0.0
            # The double QR step by Householder reflections chasing the bulge down.
            for k in range(m, last):
                if k != m:
                    p = a[k, k - 1]
                    q = a[k + 1, k - 1]
                    r = a[k + 2, k - 1] if k != last - 1 else 0.0
                    x = abs(p) + abs(q) + abs(r)
                    if x != 0.0:
                        p /= x
                        q /= x
                        r /= x
                s = math.copysign(math.sqrt(p * p + q * q + r * r), p)
                if s == 0.0:
                    continue
                if k == m:
                    if low != m:
                        a[k, k - 1] = -a[k, k - 1]
                else:
                    a[k, k - 1] = -s * x
                p += s
                x = p / s
                y = q / s
                z = r / s
                q /= p
                r /= p
                for j in range(k, last + 1):
                    p = a[k, j] + q * a[k + 1, j]
                    if k != last - 1:
                        p += r * a[k + 2, j]
                        a[k + 2, j] -= p * z
                    a[k + 1, j] -= p * y
                    a[k, j] -= p * x
                for i in range(low, min(last, k + 3) + 1):
                    p = x * a[i, k] + y * a[i, k + 1]
                    if k != last - 1:
                        p += z * a[i, k + 2]
                        a[i, k + 2] -= p * r
                    a[i, k + 1] -= p * q
                    a[i, k] -= p
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def eigenvalues(matrix, real, imag, max_iterations=MAX_QR_ITERATIONS):
    """Eigenvalues ``real + i imag`` of the real square ``matrix`` (left unchanged);
    False when the QR iteration did not converge within ``max_iterations`` iterations
    per eigenvalue."""
    a = matrix.copy()
    balance(a)
    hessenberg(a)
    return hessenberg_eigenvalues(a, real, imag, max_iterations)


@njit(cache=True, nogil=True, error_model="numpy")
def spectral_radius(matrix, max_iterations=MAX_QR_ITERATIONS):
    """Largest modulus of the eigenvalues of the real square ``matrix``: ``inf`` when it
    holds a non-finite entry (a run that did not end, say). The rare matrix on which the
    QR iteration does not converge within ``max_iterations`` iterations per eigenvalue
    goes to LAPACK."""
    n = matrix.shape[0]
    for i in range(n):
        for j in range(n):
            if not math.isfinite(matrix[i, j]):
                return np.inf
    real = np.empty(n)
    imag = np.empty(n)
    if not eigenvalues(matrix, real, imag, max_iterations):
        return np.max(np.abs(np.linalg.eigvals(matrix.astype(np.complex128))))
    radius = 0.0
    for i in range(n):
        radius = max(radius, math.hypot(real[i], imag[i]))
    return radius
