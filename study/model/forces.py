"""Mode response, contact forces, motion thresholds and lift-off (paper eqs. 2-5).

Every function is plain numpy and broadcasts over the drive frequency ``f`` and
acceleration amplitude ``a`` (and time ``t`` where it appears): it returns numpy arrays
of the broadcast shape of its inputs, or numpy scalars (``numpy.float64``,
``numpy.complex128``) when they are all scalars, as numpy's ufuncs and scipy's
functions do. Forces are per unit total mass [m s-2], in the table frame, with the
mode on its steady harmonic response::

    n(t)   = g + Re[N e^{i w t}]      N = -a (1 + w^2 M cos^2(alpha) G)
    tau(t) =     Re[T e^{i w t}]      T =  a w^2 M sin(alpha) cos(alpha) G

with ``G = 1 / (w0^2 - w^2 + i w0 w / Q)`` (docs/theory/model.md).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.model.drive import as_acceleration, as_frequency, as_time
from study.model.structure import Structure, check_structure

__all__ = [
    "force_amplitudes",
    "lift_off_acceleration",
    "mode_response",
    "normal_force",
    "release_amplitudes",
    "slip_amplitudes",
    "tangential_force",
    "thresholds",
]


def _omega(f: ArrayLike) -> NDArray[np.float64]:
    return 2.0 * np.pi * as_frequency(f)


def mode_response(structure: Structure, f: ArrayLike) -> NDArray[np.complex128]:
    """Complex response ``G`` of the plate's first mode.

    ``delta(t) = Re[a cos(alpha) G e^{i w t}]`` is the steady response to the
    forcing ``a cos(w t) cos(alpha)``.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0.

    Returns
    -------
    numpy.ndarray of complex128
        ``G = 1 / (w0^2 - w^2 + i w0 w / Q)`` [s2], the shape of ``f`` (a
        ``numpy.complex128`` for a scalar ``f``).
    """
    if not all(hasattr(structure, name) for name in ("omega0", "Q")):
        check_structure(structure)  # study.model.disk's plates have a mode too: duck-typed
    w = _omega(f)
    w0 = structure.omega0
    return 1.0 / (w0 * w0 - w * w + 1j * w0 * w / structure.Q)


def _coupling(structure: Structure, f: ArrayLike) -> NDArray[np.complex128]:
    """``w^2 M cos(alpha) G`` [1], the plate's share of the forces per unit drive."""
    w = _omega(f)
    return w * w * structure.M * np.cos(structure.alpha_rad) * mode_response(structure, f)


def force_amplitudes(
    structure: Structure, f: ArrayLike, a: ArrayLike
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Complex amplitudes of the normal and tangential forces per unit mass.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0.
    a : array_like
        Drive acceleration amplitude [m s-2], >= 0.

    Returns
    -------
    N, T : numpy.ndarray of complex128
        ``n(t) = g + Re[N e^{i w t}]`` and ``tau(t) = Re[T e^{i w t}]`` [m s-2], the
        broadcast shape of ``f`` and ``a`` (numpy scalars for scalars).
    """
    check_structure(structure)
    a = as_acceleration(a)
    k = _coupling(structure, f)
    alpha = structure.alpha_rad
    normal = -a * (1.0 + k * np.cos(alpha))
    tangential = a * k * np.sin(alpha)
    return normal, tangential


def normal_force(
    structure: Structure, f: ArrayLike, a: ArrayLike, t: ArrayLike
) -> NDArray[np.float64]:
    """Normal contact force per unit mass ``n(t)`` [m s-2] (paper eq. 2).

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz].
    a : array_like
        Drive acceleration amplitude [m s-2].
    t : array_like
        Time [s], finite, phase origin at a maximum of the table's upward acceleration.

    Returns
    -------
    numpy.ndarray of float64
        ``n(t)`` [m s-2], the broadcast shape of ``f``, ``a`` and ``t`` (a
        ``numpy.float64`` for scalars); the model holds only where it is positive.
    """
    normal, _ = force_amplitudes(structure, f, a)
    phase = np.exp(1j * _omega(f) * as_time(t))
    return structure.g + (normal * phase).real


def tangential_force(
    structure: Structure, f: ArrayLike, a: ArrayLike, t: ArrayLike
) -> NDArray[np.float64]:
    """Tangential contact force per unit mass ``tau(t)`` [m s-2] (paper eq. 3).

    Parameters are those of :func:`normal_force`.

    Returns
    -------
    numpy.ndarray of float64
        ``tau(t)`` [m s-2], positive forward, the broadcast shape of ``f``, ``a`` and
        ``t`` (a ``numpy.float64`` for scalars).
    """
    _, tangential = force_amplitudes(structure, f, a)
    phase = np.exp(1j * _omega(f) * as_time(t))
    return (tangential * phase).real


def _threshold_factor(structure: Structure, f: ArrayLike, sign: float) -> NDArray[np.float64]:
    alpha = structure.alpha_rad
    k = _coupling(structure, f)
    return np.abs(1.0 + k * (np.cos(alpha) + sign * np.sin(alpha) / structure.cs))


def thresholds(
    structure: Structure, f: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Drive accelerations at which forward and backward slips start (paper eq. 5).

    ``a*_pm = g / |1 + w^2 M cos(alpha) (cos(alpha) +- sin(alpha)/cs) G|``, the
    compact form of the paper's eq. 5. Below ``min(a*_+, a*_-)`` the structure
    never slips.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0.

    Returns
    -------
    a_plus, a_minus : numpy.ndarray of float64
        Thresholds [m s-2] for ``tau = +cs n`` (forward) and ``tau = -cs n``
        (backward) slips, the shape of ``f`` (``numpy.float64`` for a scalar ``f``).
        The same with either coupling: below them the structure sticks and the
        sliding base forces nothing.
    """
    g = check_structure(structure).g
    return g / _threshold_factor(structure, f, +1.0), g / _threshold_factor(structure, f, -1.0)


def lift_off_acceleration(structure: Structure, f: ArrayLike) -> NDArray[np.float64]:
    """Drive acceleration above which ``n(t)`` becomes negative somewhere in a cycle.

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequency [Hz], > 0.

    Returns
    -------
    numpy.ndarray of float64
        ``a_lift = g / |1 + w^2 M cos^2(alpha) G|`` [m s-2], the shape of ``f``
        (``numpy.float64`` for a scalar ``f``). Above it the structure leaves the
        table and the model does not apply.
    """
    k = _coupling(check_structure(structure), f)
    return structure.g / np.abs(1.0 + k * np.cos(structure.alpha_rad))


def release_amplitudes(
    structure: Structure, f: ArrayLike, a: ArrayLike
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Amplitudes of the slip criteria ``s tau - cs n`` for ``s = +1, -1``.

    ``s tau(t) - cs n(t) = Re[A_s e^{i w t}] - cs g``: a slip of sign ``s`` starts
    where this crosses zero upwards, which happens only if ``|A_s| > cs g``.

    Returns
    -------
    A_plus, A_minus : numpy.ndarray of complex
        [m s-2].
    """
    normal, tangential = force_amplitudes(structure, f, a)
    return tangential - structure.cs * normal, -tangential - structure.cs * normal


def slip_amplitudes(
    structure: Structure, f: ArrayLike, a: ArrayLike
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Amplitudes of the sliding acceleration in a slip of sign ``s = +1, -1``.

    During a slip of sign ``s``, ``s dv/dt = s tau - ck n = Re[B_s e^{i w t}] - ck g``.

    Returns
    -------
    B_plus, B_minus : numpy.ndarray of complex
        [m s-2].
    """
    normal, tangential = force_amplitudes(structure, f, a)
    return tangential - structure.ck * normal, -tangential - structure.ck * normal
