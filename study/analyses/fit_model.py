"""The fit's model of each measurement row, and its analytic derivatives.

The model of each measurement row (:func:`model_values`):

* ``threshold``: the lowest motion threshold at ``f``, ``min(a*_+, a*_-)``
  (:func:`study.model.thresholds`, closed form); ``direction = forward`` or
  ``backward`` compares with ``a*_+`` or ``a*_-`` alone;
* ``velocity``: :func:`study.solvers.exact.steady_velocity` at ``(f, a)`` with the spec's
  ``coupling`` (default :data:`study.solvers.exact.DEFAULT_COUPLING`, ``"one-way"``, the
  paper's model, as everywhere; ``"two-way"`` for the physical one);
* ``ringdown_f0``, ``ringdown_Q``: ``f0`` and ``Q`` themselves.

Rows are grouped by the structure they measured (an added mass ``m_add`` with
``[structure.mass]``, or a given ``M``: :func:`structure_groups`). Derivatives with
respect to the structure parameters are analytic for thresholds and ring-downs (the
closed form differentiated, :func:`analytic_jacobian`); the solver has none for
velocities, whose derivatives the search takes by finite differences
(:mod:`study.analyses.fit_search`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from study.model import thresholds
from study.model.inputs import instance_of, real_number
from study.model.structure import Structure, tilt_warnings
from study.model.units import KILOGRAM
from study.solvers.exact import steady_velocity

__all__ = [
    "fitted_structure",
    "model_values",
    "structure_groups",
]


def measured_structure(params: dict[str, float | None], m_add: float, M: float | None = None
                       ) -> Structure:
    """The structure of a parameter set as measured with an added mass, unchecked.

    The search's and the spec parser's inner step (:func:`fitted_structure` is the
    checked one for callers): tilt warnings are off, since the search may go near 0.

    Parameters
    ----------
    params : dict
        Every structure parameter in the units of :mod:`study.model.parameters`:
        ``f0`` [Hz], ``Q`` [1], ``alpha`` [degree], ``cs`` and ``ck`` [1] (``ck`` None:
        tied to ``cs``), ``g`` [m s-2], and either ``M`` [1] or the mass model's ``m0``
        [kg] and ``m1_fraction`` [1].
    m_add : float
        Mass added to the structure [kg]: ``M = m1_fraction m0 / (m0 + m_add)`` with
        the mass model, ignored otherwise.
    M : float, optional
        The mass ratio [1], overriding both ``params["M"]`` and the mass model.

    Returns
    -------
    Structure

    Raises
    ------
    ValueError
        If the parameters are no valid structure.
    """
    if M is None:
        if "m0" in params:
            M = params["m1_fraction"] * params["m0"] / (params["m0"] + m_add)
        else:
            M = params["M"]
    with tilt_warnings(False):  # the spec's tilts are in degree; the search may go near 0
        return Structure(f0=params["f0"], Q=params["Q"], alpha=params["alpha"], M=M,
                         cs=params["cs"], ck=params["ck"], g=params["g"])


def structure_groups(data: xr.Dataset) -> dict[tuple[float | None, float | None],
                                                NDArray[np.intp]]:
    """Rows by structure measured: keys (m_add, M), None for a blank cell."""
    m_add = data["m_add"].values
    M = data["M"].values
    keys: dict[tuple[float | None, float | None], list[int]] = {}
    for i in range(m_add.size):
        key = (float(m_add[i]) if np.isfinite(m_add[i]) else None,
               float(M[i]) if np.isfinite(M[i]) else None)
        keys.setdefault(key, []).append(i)
    return {k: np.array(v, dtype=np.intp) for k, v in keys.items()}


def _key_structure(params: dict[str, float | None],
                   key: tuple[float | None, float | None]) -> Structure:
    m_add, M = key
    if M is not None:
        return measured_structure(params, 0.0, M)
    return measured_structure(params, 0.0 if m_add is None else m_add)


def model_values(params: dict[str, float | None], data: xr.Dataset, coupling: str
                 ) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """The model's value for every measurement row, and the solver status of velocities.

    Returns
    -------
    model : numpy.ndarray
        In each row's ``value_units``; NaN where the model has no value.
    status : numpy.ndarray of int8
        :class:`~study.model.status.Status` of velocity rows, -1 for other rows.
    """
    quantity = data["quantity"].values
    f = data["f"].values
    a = data["a"].values
    direction = data["direction"].values
    model = np.full(quantity.size, np.nan)
    status = np.full(quantity.size, -1, dtype=np.int8)
    for key, rows in structure_groups(data).items():
        s = _key_structure(params, key)
        for i in rows:
            if quantity[i] == "ringdown_f0":
                model[i] = s.f0
            elif quantity[i] == "ringdown_Q":
                model[i] = s.Q
        th = rows[quantity[rows] == "threshold"]
        if th.size:
            plus, minus = thresholds(s, f[th])
            model[th] = np.where(direction[th] == "forward", plus,
                                 np.where(direction[th] == "backward", minus,
                                          np.minimum(plus, minus)))
        vel = rows[quantity[rows] == "velocity"]
        if vel.size:
            v, st = steady_velocity(s, f[vel], a[vel], coupling=coupling)
            model[vel] = v
            status[vel] = st
    return model, status


def _threshold_gradient(s: Structure, f: NDArray[np.float64], sign: float
                        ) -> tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]:
    """a*_s and its derivatives with respect to f0, Q, alpha (degree), M, cs (paper eq. 5)."""
    w = 2.0 * np.pi * f
    w0 = s.omega0
    G = 1.0 / (w0 * w0 - w * w + 1j * w0 * w / s.Q)
    al = s.alpha_rad
    h = np.cos(al) * (np.cos(al) + sign * np.sin(al) / s.cs)
    K = w * w * s.M * G  # F = 1 + K h
    F = 1.0 + K * h
    mod = np.abs(F)
    value = s.g / mod
    dF = {
        "f0": K * h * (-G * (2.0 * w0 + 1j * w / s.Q)) * 2.0 * np.pi,
        "Q": K * h * G * 1j * w0 * w / s.Q**2,
        "alpha": K * (-np.sin(2 * al) + sign * np.cos(2 * al) / s.cs) * np.pi / 180.0,
        "M": K * h / s.M,
        "cs": K * np.cos(al) * (-sign * np.sin(al) / s.cs**2),
    }
    grad = {k: -s.g * (np.conj(F) * d).real / mod**3 for k, d in dF.items()}
    return value, grad


def analytic_jacobian(params: dict[str, float | None], data: xr.Dataset, names: list[str]
                      ) -> NDArray[np.float64]:
    """d model / d parameter for threshold and ring-down rows (NaN for velocity rows).

    Parameters
    ----------
    params : dict
        Every structure parameter, as :func:`measured_structure` takes them.
    data : xarray.Dataset
        The measurement rows (:func:`study.analyses.measurements.read_measurements`).
    names : list of str
        The parameters to differentiate by, in the order of the columns.

    Returns
    -------
    numpy.ndarray
        (row, parameter): the derivative of each row's model value (in its
        ``value_units``: m s-2 for thresholds, Hz and 1 for ring-downs) with respect to
        each parameter (in its own units, ``alpha`` per degree); NaN for velocity rows.
    """
    quantity = data["quantity"].values
    f = data["f"].values
    direction = data["direction"].values
    jac = np.full((quantity.size, len(names)), np.nan)
    col = {n: j for j, n in enumerate(names)}
    for key, rows in structure_groups(data).items():
        s = _key_structure(params, key)
        m_add, M_fixed = key
        dM: dict[str, float] = {}
        if M_fixed is None:
            if "m0" in params:
                ma = 0.0 if m_add is None else m_add
                m0, r = params["m0"], params["m1_fraction"]
                dM = {"m0": r * ma / (m0 + ma) ** 2, "m1_fraction": m0 / (m0 + ma)}
            else:
                dM = {"M": 1.0}
        for i in rows:
            if quantity[i] in ("ringdown_f0", "ringdown_Q"):
                jac[i] = 0.0
                own = "f0" if quantity[i] == "ringdown_f0" else "Q"
                if own in col:
                    jac[i, col[own]] = 1.0
        th = rows[quantity[rows] == "threshold"]
        if th.size:
            vp, gp = _threshold_gradient(s, f[th], +1.0)
            vm, gm = _threshold_gradient(s, f[th], -1.0)
            use_plus = np.where(direction[th] == "forward", True,
                                np.where(direction[th] == "backward", False, vp <= vm))
            for n, j in col.items():
                if n in gp:
                    d = np.where(use_plus, gp[n], gm[n])
                    jac[th, j] = 0.0 if n == "M" else d
                else:
                    jac[th, j] = 0.0
            for n, factor in dM.items():
                if n in col:
                    jac[th, col[n]] += factor * np.where(use_plus, gp["M"], gm["M"])
    return jac


def fitted_structure(params: dict[str, float | None], m_add: float = 0.0,
                     M: float | None = None) -> Structure:
    """The structure of a parameter set (``study_fitted_structure``) for one measured
    structure (``m_add`` with ``[structure.mass]``, or a given ``M``)."""
    params = instance_of("params", params, Mapping, "a dict of parameter values")
    needed = ("f0", "Q", "alpha", "cs", *(("m0", "m1_fraction") if "m0" in params else
                                         () if M is not None else ("M",)))
    missing = [name for name in needed if name not in params]
    if missing:
        raise ValueError(f"params must give {', '.join(needed)}; missing: {', '.join(missing)}")
    full = {"ck": None, "g": 9.8, **params}
    return measured_structure(full, real_number("m_add", m_add, KILOGRAM), M)

