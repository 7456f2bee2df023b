"""Parameter fits with uncertainty: weighted least squares on the exact solvers.

A fit spec (TOML) names measurement files (:mod:`study.analyses.measurements`), the structure
with start values, the free parameters with their bounds and the coupling::

    [fit]
    name = "my-structure"
    measurements = ["measured.csv"]      # relative to the spec's folder
    free = { cs = [0.05, 1.0], M = [0.01, 0.5] }   # bounds; start values from [structure]
    [structure]
    f0 = 14.44
    Q = 17.5
    alpha = 64.0
    M = 0.1
    cs = 0.3

The model of each measurement row:

* ``threshold``: the lowest motion threshold at ``f``, ``min(a*_+, a*_-)``
  (:func:`study.model.thresholds`, closed form); ``direction = forward`` or
  ``backward`` compares with ``a*_+`` or ``a*_-`` alone;
* ``velocity``: :func:`study.solvers.exact.steady_velocity` at ``(f, a)`` with the spec's
  ``coupling`` (default :data:`study.solvers.exact.DEFAULT_COUPLING`, ``"one-way"``, the
  paper's model, as everywhere; ``"two-way"`` for the physical one);
* ``ringdown_f0``, ``ringdown_Q``: ``f0`` and ``Q`` themselves.

``chi^2 = sum ((model - value) / sigma)^2`` is minimised by
:func:`scipy.optimize.least_squares` (trust-region reflective, within the bounds).
Derivatives: analytic for thresholds and ring-downs (the closed form differentiated);
central finite differences for velocities (one-sided at a bound), where the solver has
no derivative with respect to the structure. Every trial point is a valid
:class:`~study.model.structure.Structure`: bounds are intersected with the parameters'
ranges, and when both ``cs`` and ``ck`` are free the search runs on ``cs`` and
``r = ck / cs`` in ``(0, 1]``. Standard errors come from the covariance
``(J^T W J)^-1`` at the optimum, taking the stated ``sigma`` as absolute.

A fit never stays silent about a doubtful answer. Velocities plainly in mm/s written
as m/s are refused before the search (:func:`study.analyses.measurements.check_velocity_units`,
the check of ``study figure --measurements``). After it, :attr:`FitResult.warnings`
(printed by ``study fit``, stored as ``study_warnings``) names what to check for an
estimate on a bound (within :data:`BOUND_MARGIN` of its width) or on ``ck <= cs``, a
parameter the data cannot fix, and a chi^2 whose p-value
(``scipy.stats.chi2.sf(chi2, dof)``, stored as ``chi2_p_value``) is below
:data:`CHI2_P_LIMIT`: the units of the measurements, sigma, the bounds, the fixed
parameters and the coupling.
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from study.analyses.measurements import QUANTITIES, check_velocity_units, read_measurements
from study.engine.kinds import ResultFormat, ResultKind, register
from study.engine.layout import contact_law_attributes
from study.engine.spec_files import (
    SpecError,
    canonical_sha256,
    check_schema,
    load_schema,
    parse_toml,
    read_spec_text,
)
from study.model import thresholds
from study.model.contact import DEFAULT_COUPLING
from study.model.inputs import bounded_integer, instance_of, real_number
from study.model.parameters import PARAMETERS as PARAMETER_TABLE
from study.model.parameters import STRUCTURE, Parameter, schema_properties, units_list
from study.model.structure import Structure, tilt_warnings
from study.model.units import DIMENSIONLESS, KILOGRAM, spoken
from study.solvers.exact import steady_velocity

__all__ = [
    "FIT_FORMAT",
    "FIT_KIND",
    "FIT_RESULT_SCHEMA",
    "FIT_SPEC_SCHEMA",
    "PARAMETERS",
    "FitResult",
    "FitSpec",
    "Parameter",
    "bound_side",
    "chi2_p_value",
    "fit",
    "fit_dataset",
    "fitted_structure",
    "load_fit_spec",
    "model_values",
    "parse_fit_spec",
    "structure_groups",
]

FIT_SPEC_SCHEMA = "study-fit-spec-v1"
FIT_RESULT_SCHEMA = "study-fit-v1"
#: Layout of a fit result (global attribute ``study_fit_format``): 2 spells every unit
#: in CF/UDUNITS (``parameter_units`` of alpha: ``degree``). Files without it are format
#: 1 (``deg``), refused as stale by validation.
FIT_FORMATS = (
    ResultFormat(1, "before 0.1.0", "units spelled deg", FIT_RESULT_SCHEMA),
    ResultFormat(2, "0.1.0", "every unit in CF/UDUNITS spelling (degree)", FIT_RESULT_SCHEMA),
)
#: The format this version writes.
FIT_FORMAT = FIT_FORMATS[-1].number

#: A standard error above this fraction of the bounds' width flags a parameter.
UNIDENTIFIABLE_FRACTION = 0.25
#: Directions of the scaled J^T J below this fraction of its largest eigenvalue are null.
SINGULAR_RCOND = 1e-12
#: Whitened residual of a row whose model has no value (lift-off, not converged).
NO_VALUE_RESIDUAL = 1e3
#: An estimate within this fraction of its bounds' width of a bound is on the bound.
BOUND_MARGIN = 1e-3
#: A chi^2 whose probability (chi^2 distribution, dof degrees of freedom) of being
#: exceeded is below this says the model does not describe the data.
CHI2_P_LIMIT = 1e-3


#: The parameters a fit can free, from the parameter table (:mod:`study.model.parameters`;
#: m0 and m1_fraction: [structure.mass]).
PARAMETERS: dict[str, Parameter] = {name: PARAMETER_TABLE[name] for name in (
    "f0", "Q", "alpha", "M", "cs", "ck", "m0", "m1_fraction")}


def fit_spec_schema() -> dict[str, Any]:
    """The JSON schema of fit specs (``study/schemas/study-fit-spec-v1.schema.json``): its
    parameters' ranges and the free ones from the parameter table (the file on disk is
    its export: ``make schemas``)."""
    schema = load_schema(FIT_SPEC_SCHEMA)
    properties = schema["properties"]["structure"]["properties"]
    mass = properties["mass"]
    mass["properties"] = schema_properties(("m0", "m1", "m1_fraction"))
    schema["properties"]["structure"]["properties"] = {**schema_properties(STRUCTURE),
                                                       "mass": mass}
    free = schema["properties"]["fit"]["properties"]["free"]
    free["properties"] = {name: {"$ref": "#/$defs/bounds"} for name in PARAMETERS}
    free["description"] = ("free parameters with their bounds: " + units_list(PARAMETERS)
                           + " (m0 and m1_fraction with [structure.mass])")
    return schema


def export_fit_spec_schema() -> str:
    """The fit spec schema as written to ``study/schemas`` (``make schemas``)."""
    return json.dumps(fit_spec_schema(), indent=2) + "\n"


@dataclass(frozen=True)
class FitSpec:
    """A validated fit spec.

    Attributes
    ----------
    name, title : str
    text : str
        The spec file's text.
    path : str
        Where it was read from.
    measurements : xarray.Dataset
        The measurement rows (:func:`study.analyses.measurements.read_measurements`), with
        ``sigma`` filled from ``[fit] sigma`` where the file left it blank.
    start : dict
        Every structure parameter's start value (``ck`` explicit, or None when tied to
        ``cs``); with ``[structure.mass]``: ``m0``, ``m1_fraction`` instead of ``M``.
    free : dict
        Free parameter -> (lower, upper) bounds as the spec gives them.
    coupling : {"one-way", "two-way"}
        Model of velocity rows (default :data:`study.solvers.exact.DEFAULT_COUPLING`).
    profile : str
        ``"unidentifiable"``, ``"all"`` or ``"none"``: which parameters get a chi^2 profile.
    profile_points : int
    max_evaluations : int
    """

    name: str
    title: str
    text: str
    path: str
    measurements: xr.Dataset = field(repr=False)
    start: dict[str, float | None]
    free: dict[str, tuple[float, float]]
    coupling: str = DEFAULT_COUPLING
    profile: str = "unidentifiable"
    profile_points: int = 21
    max_evaluations: int = 200

    @property
    def sha256(self) -> str:
        return canonical_sha256(parse_toml(self.text, self.path))

    @property
    def mass_model(self) -> bool:
        return "m0" in self.start


def load_fit_spec(path: str | Path) -> FitSpec:
    """Read and check a fit spec; measurement files are relative to its folder.

    Raises
    ------
    SpecError
        Naming the file, the key and what is allowed (a measurement file's problems
        name its file, line and column).
    """
    path = Path(path)
    return parse_fit_spec(read_spec_text(path, "fit spec"), str(path), base=path.parent)


def parse_fit_spec(text: str, path: str = "<string>", base: str | Path = ".") -> FitSpec:
    """A fit spec from its text (see :func:`load_fit_spec`)."""
    raw = parse_toml(text, path)
    check_schema(raw, fit_spec_schema(), path, "fit spec")
    table = raw["fit"]
    structure = dict(raw["structure"])
    mass = structure.pop("mass", None)
    start: dict[str, float | None] = {k: float(v) for k, v in structure.items()}
    start.setdefault("ck", None)
    start.setdefault("g", 9.8)
    if mass is not None:
        if "M" in start:
            raise SpecError(f"{path}: [structure.mass] gives M = m1/(m0 + m_add); "
                            "do not also give M")
        if ("m1" in mass) == ("m1_fraction" in mass):
            raise SpecError(f"{path}: [structure.mass] needs m0 and one of m1, m1_fraction")
        start["m0"] = float(mass["m0"])
        start["m1_fraction"] = (float(mass["m1_fraction"]) if "m1_fraction" in mass
                                else float(mass["m1"]) / float(mass["m0"]))
    required = ["f0", "Q", "alpha", "cs"] + ([] if mass is not None else ["M"])
    missing = [k for k in required if k not in start]
    if missing:
        raise SpecError(f"{path}: [structure] is missing {', '.join(missing)}; give every "
                        "structure parameter (the start value of a free one)")
    free = {k: (float(v[0]), float(v[1])) for k, v in table["free"].items()}
    if mass is not None and "M" in free:
        raise SpecError(f"{path}: [fit] free.M: with [structure.mass] the mass ratio follows "
                        "from m0 and m1_fraction; free those instead")
    if mass is None and ({"m0", "m1_fraction"} & set(free)):
        raise SpecError(f"{path}: [fit] free: m0 and m1_fraction need [structure.mass] "
                        "(m0 and one of m1, m1_fraction)")
    if "ck" in free and start["ck"] is None:
        start["ck"] = start["cs"]
    for name, (lower, upper) in free.items():
        parameter = PARAMETERS[name]
        where = f"{path}: [fit] free.{name} = [{lower:g}, {upper:g}]"
        if not lower < upper:
            raise SpecError(f"{where}: the lower bound must be below the upper one")
        for bound in (lower, upper):
            if not parameter.inside(bound):
                raise SpecError(f"{where}: bound {bound:g} is out of range; allowed: "
                                f"{parameter.allowed()}{spoken(parameter.units)}")
        value = start[name]
        if value is None or not lower <= value <= upper:
            raise SpecError(f"{where}: the start value {name} = {value!r} from [structure] is "
                            "outside the bounds")
    try:
        _structure(start, 0.0)
    except ValueError as err:
        raise SpecError(f"{path}: [structure]: {err}") from None
    if start["ck"] is not None and "cs" in free and "ck" not in free:
        lower, upper = free["cs"]
        if upper < start["ck"]:
            raise SpecError(f"{path}: [fit] free.cs = [{lower:g}, {upper:g}]: every cs is "
                            f"below the fixed ck = {start['ck']:g} (ck <= cs); lower ck in "
                            "[structure] or free it")
    if start["ck"] is not None and "ck" in free and "cs" not in free:
        lower, upper = free["ck"]
        if lower > start["cs"]:
            raise SpecError(f"{path}: [fit] free.ck = [{lower:g}, {upper:g}]: every ck is "
                            f"above the fixed cs = {start['cs']:g} (ck <= cs)")

    paths = [Path(base) / name for name in table["measurements"]]
    measurements = read_measurements(paths)
    measurements = _fill_sigma(measurements, table.get("sigma", {}), path)
    has_m_add = bool(np.isfinite(measurements["m_add"].values).any())
    if has_m_add and mass is None:
        line = int(measurements["line"].values[np.isfinite(measurements["m_add"].values)][0])
        source = str(measurements["source"].values[np.isfinite(
            measurements["m_add"].values)][0])
        raise SpecError(f"{source}, line {line}, column 'm_add': an added mass needs the "
                        f"structure's masses: give [structure.mass] m0 and m1_fraction in "
                        f"{path}")
    return FitSpec(
        name=table["name"], title=table.get("title", table["name"]), text=text, path=path,
        measurements=measurements, start=start, free=free,
        coupling=table.get("coupling", DEFAULT_COUPLING),
        profile=table.get("profile", "unidentifiable"),
        profile_points=int(table.get("profile_points", 21)),
        max_evaluations=int(table.get("max_evaluations", 200)),
    )


def _fill_sigma(data: xr.Dataset, defaults: dict[str, float], path: str) -> xr.Dataset:
    for quantity, value in defaults.items():
        if float(value) < sys.float_info.min:  # positive (the schema): subnormal
            raise SpecError(f"{path}: [fit] sigma.{quantity} = {value!r} is below the "
                            f"smallest normal float64 ({sys.float_info.min:.4g}); an "
                            "uncertainty is a positive normal number")
    sigma = data["sigma"].values.copy()
    quantity = data["quantity"].values
    for i in np.flatnonzero(~np.isfinite(sigma)):
        if quantity[i] in defaults:
            sigma[i] = float(defaults[quantity[i]])
        else:
            raise SpecError(
                f"{data['source'].values[i]}, line {int(data['line'].values[i])}, column "
                f"'sigma': blank, and {path} gives no [fit] sigma.{quantity[i]}; a fit "
                "weighs every row by its uncertainty")
    out = data.copy()
    out["sigma"] = data["sigma"].copy(data=sigma)
    return out


# ---------------------------------------------------------------------------
# The model of each row


def _structure(params: dict[str, float | None], m_add: float, M: float | None = None
               ) -> Structure:
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
        return _structure(params, 0.0, M)
    return _structure(params, 0.0 if m_add is None else m_add)


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


def _analytic_rows(params: dict[str, float | None], data: xr.Dataset, names: list[str]
                   ) -> NDArray[np.float64]:
    """d model / d parameter for threshold and ring-down rows (NaN for velocity rows)."""
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


# ---------------------------------------------------------------------------
# The search: a vector of internal coordinates, always a valid structure


@dataclass
class _Problem:
    spec_start: dict[str, float | None]
    free: dict[str, tuple[float, float]]
    data: xr.Dataset
    coupling: str
    names: list[str] = field(init=False)
    ratio: bool = field(init=False)  # ck searched as r = ck/cs
    tied: bool = field(init=False)   # ck follows cs (not given)
    lower: NDArray[np.float64] = field(init=False)
    upper: NDArray[np.float64] = field(init=False)
    evaluations: int = 0

    def __post_init__(self) -> None:
        self.names = list(self.free)
        self.ratio = "cs" in self.free and "ck" in self.free
        self.tied = self.spec_start.get("ck") is None
        lower = np.array([self.free[n][0] for n in self.names])
        upper = np.array([self.free[n][1] for n in self.names])
        ck = self.spec_start.get("ck")
        if "cs" in self.free and "ck" not in self.free and ck is not None:
            j = self.names.index("cs")
            lower[j] = max(lower[j], ck)
        if "ck" in self.free and "cs" not in self.free:
            j = self.names.index("ck")
            upper[j] = min(upper[j], self.spec_start["cs"])
        if self.ratio:
            j = self.names.index("ck")
            # ck = r cs >= its smallest allowed value for every cs within the bounds.
            lower[j] = max(self.free["ck"][0] / self.free["cs"][1],
                           PARAMETERS["ck"].lower / self.free["cs"][0])
            upper[j] = min(1.0, self.free["ck"][1] / self.free["cs"][0])
        self.lower, self.upper = lower, upper

    def start(self) -> NDArray[np.float64]:
        x = np.array([float(self.spec_start[n]) for n in self.names])
        if self.ratio:
            x[self.names.index("ck")] = self.spec_start["ck"] / self.spec_start["cs"]
        return np.clip(x, self.lower, self.upper)

    def params(self, x: NDArray[np.float64]) -> dict[str, float | None]:
        """Physical parameters of an internal vector (always a valid structure)."""
        p = dict(self.spec_start)
        for n, value in zip(self.names, x, strict=True):
            p[n] = float(value)
        if self.ratio:
            p["ck"] = p["ck"] * p["cs"]
        elif self.tied:
            p["ck"] = None
        return p

    def physical(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        p = self.params(x)
        return np.array([p[n] if p[n] is not None else p["cs"] for n in self.names])

    def transform(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """d physical / d internal."""
        T = np.eye(len(self.names))
        if self.ratio:
            j, k = self.names.index("ck"), self.names.index("cs")
            T[j, j] = x[k]
            T[j, k] = x[j]
        return T

    def residuals(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        self.evaluations += 1
        model, _ = model_values(self.params(x), self.data, self.coupling)
        r = (model - self.data["value"].values) / self.data["sigma"].values
        return np.where(np.isfinite(r), r, NO_VALUE_RESIDUAL)

    def _valid(self, x: NDArray[np.float64]) -> bool:
        return bool(np.all(x >= self.lower) and np.all(x <= self.upper))

    def physical_jacobian(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """d model / d physical parameter, whitened (rows / sigma)."""
        p = self.params(x)
        names = self.names
        jac = _analytic_rows(p, self.data, names)
        velocity = np.flatnonzero(self.data["quantity"].values == "velocity")
        if velocity.size:
            sub = self.data.isel(measurement=velocity)
            phys = self.physical(x)
            for j, name in enumerate(names):
                h = 1e-6 * max(abs(phys[j]), 1e-3)
                values = []
                for step in (+h, -h):
                    q = dict(p)
                    q[name] = phys[j] + step
                    values.append(q if self._physical_valid(q) else None)
                plus, minus = values
                if plus is not None and minus is not None:
                    d = (self._velocity(plus, sub) - self._velocity(minus, sub)) / (2 * h)
                elif plus is not None:
                    d = (self._velocity(plus, sub) - self._velocity(p, sub)) / h
                else:
                    d = (self._velocity(p, sub) - self._velocity(minus, sub)) / h
                jac[velocity, j] = np.where(np.isfinite(d), d, 0.0)
        return jac / self.data["sigma"].values[:, None]

    def _velocity(self, p: dict[str, float | None], sub: xr.Dataset) -> NDArray[np.float64]:
        self.evaluations += 1
        return model_values(p, sub, self.coupling)[0]

    def _physical_valid(self, q: dict[str, float | None]) -> bool:
        for n in self.names:
            lo, hi = self.free[n]
            if not lo <= q[n] <= hi:
                return False
        ck = q["ck"] if q["ck"] is not None else q["cs"]
        if self.tied and "cs" in self.names and "ck" not in self.names:
            ck = q["cs"]
        return ck <= q["cs"] and (q.get("M") is None or 0 < q["M"] <= 1)

    def jacobian(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.physical_jacobian(x) @ self.transform(x)


# ---------------------------------------------------------------------------
# Fitting and uncertainty


@dataclass(frozen=True)
class FitResult:
    """What :func:`fit` found (all arrays over the free parameters, in the spec's order).

    Attributes
    ----------
    names : list of str
    estimate, standard_error, lower, upper, start : numpy.ndarray
        Physical units (:data:`PARAMETERS`); ``standard_error`` is inf where the data
        cannot fix a parameter.
    covariance, correlation : numpy.ndarray
    identifiable : numpy.ndarray of bool
    model, status : numpy.ndarray
        Per measurement row, at the estimate.
    chi2 : float
    dof : int
    profile_values, profile_chi2 : numpy.ndarray
        (parameter, point): chi^2 minimised over the other free parameters with this
        one held at each value; NaN for parameters not profiled.
    success : bool
    message : str
    evaluations : int
    wall_seconds : float
    warnings : list of str
        What makes the estimate doubtful, each naming what to check (module doc).
    """

    names: list[str]
    estimate: NDArray[np.float64]
    standard_error: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    start: NDArray[np.float64]
    covariance: NDArray[np.float64]
    correlation: NDArray[np.float64]
    identifiable: NDArray[np.bool_]
    model: NDArray[np.float64]
    status: NDArray[np.int8]
    chi2: float
    dof: int
    profile_values: NDArray[np.float64]
    profile_chi2: NDArray[np.float64]
    success: bool
    message: str
    evaluations: int
    wall_seconds: float
    warnings: list[str]

    @property
    def chi2_per_dof(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else math.nan

    @property
    def on_bound(self) -> list[str]:
        """Per parameter: ``"lower"`` or ``"upper"`` when the estimate is on that bound
        (within :data:`BOUND_MARGIN` of the bounds' width), else ``""``."""
        return [bound_side(e, lo, hi) for e, lo, hi in
                zip(self.estimate, self.lower, self.upper, strict=True)]

    @property
    def p_value(self) -> float:
        """Probability of a chi^2 at least this large if the model held (NaN: no dof)."""
        return chi2_p_value(self.chi2, self.dof)


def bound_side(estimate: float, lower: float, upper: float) -> str:
    """``"lower"``/``"upper"`` when ``estimate`` is within :data:`BOUND_MARGIN` of the
    width ``upper - lower`` of that bound, else ``""`` (all in the parameter's units)."""
    estimate, lower, upper = (real_number(name, value) for name, value in
                              (("estimate", estimate), ("lower", lower), ("upper", upper)))
    margin = BOUND_MARGIN * (upper - lower)
    if abs(estimate - lower) <= margin:
        return "lower"
    if abs(estimate - upper) <= margin:
        return "upper"
    return ""


def chi2_p_value(chi2: float, dof: int) -> float:
    """``scipy.stats.chi2.sf(chi2, dof)``: how often a chi^2 this large arises by chance
    when the model holds and the sigma are right (NaN without a degree of freedom)."""
    chi2 = real_number("chi2", chi2)
    dof = bounded_integer("dof", dof, lower=-(2**63))
    if dof <= 0:
        return math.nan
    from scipy.stats import chi2 as distribution

    return float(distribution.sf(chi2, dof))


def _minimise(problem: _Problem, max_evaluations: int) -> Any:
    from scipy.optimize import least_squares

    return least_squares(problem.residuals, problem.start(), jac=problem.jacobian,
                         bounds=(problem.lower, problem.upper), method="trf",
                         x_scale="jac", max_nfev=max_evaluations, xtol=1e-10,
                         ftol=1e-10, gtol=1e-10)


def _covariance(jac: NDArray[np.float64], width: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """(J^T J)^-1 in physical units, inf along null directions, and which are null."""
    n = jac.shape[1]
    scaled = jac * width[None, :]
    _, s, vt = np.linalg.svd(scaled, full_matrices=False)
    s = np.concatenate([s, np.zeros(n - s.size)]) if s.size < n else s
    if vt.shape[0] < n:
        _, _, vt = np.linalg.svd(np.vstack([scaled, np.zeros((n - vt.shape[0], n))]))
    smax = s.max() if s.size and s.max() > 0 else 1.0
    null = s**2 <= SINGULAR_RCOND * smax**2
    inv = np.where(null, 0.0, 1.0 / np.where(null, 1.0, s) ** 2)
    cov = (vt.T * inv) @ vt
    cov = cov * np.outer(width, width)
    degenerate = np.zeros(n, dtype=bool)
    for k in np.flatnonzero(null):
        degenerate |= np.abs(vt[k]) > 0.1
    cov[degenerate, :] = np.inf
    cov[:, degenerate] = np.inf
    return cov, degenerate


def fit(spec: FitSpec, progress: Callable[[str], None] | None = None) -> FitResult:
    """Estimate the free parameters of ``spec`` (module doc); never raises on a poor fit.

    Raises
    ------
    SpecError
        If the model has no value at the start for some row (lift-off, not converged).
    """
    started = time.perf_counter()
    data = spec.measurements
    problem = _Problem(spec.start, spec.free, data, spec.coupling)
    _check_start(spec, problem)
    if progress is not None:
        progress(f"least squares: {len(problem.names)} parameters to "
                 f"{data.sizes['measurement']} measurements (at most "
                 f"{spec.max_evaluations} model evaluations)")
    solution = _minimise(problem, spec.max_evaluations)
    if progress is not None:
        progress(f"least squares done after {problem.evaluations} model evaluations; "
                 "uncertainties and chi^2 profiles next")
    x = solution.x
    names = problem.names
    p = problem.params(x)
    estimate = problem.physical(x)
    model, status = model_values(p, data, spec.coupling)
    resid = (model - data["value"].values) / data["sigma"].values
    chi2 = float(np.sum(np.where(np.isfinite(resid), resid, NO_VALUE_RESIDUAL) ** 2))
    dof = int(data.sizes["measurement"] - len(names))
    jac = problem.physical_jacobian(x)
    lower = np.array([spec.free[n][0] for n in names])
    upper = np.array([spec.free[n][1] for n in names])
    cov, degenerate, se, corr, identifiable = _uncertainty(jac, lower, upper)
    p_value = chi2_p_value(chi2, dof)
    warnings = [
        *_bound_warnings(spec, names, estimate, p, lower, upper),
        *_identifiability_warnings(names, identifiable, degenerate, se),
        *_quality_warnings(spec, chi2, dof, p_value, resid, model, solution),
    ]
    profile_values, profile_chi2 = _profiles(spec, problem, p, identifiable, lower, upper,
                                             progress)
    return FitResult(
        names=names, estimate=estimate, standard_error=se, lower=lower, upper=upper,
        start=np.array([float(spec.start[n]) for n in names]), covariance=cov,
        correlation=corr, identifiable=identifiable, model=model, status=status, chi2=chi2,
        dof=dof, profile_values=profile_values, profile_chi2=profile_chi2,
        success=bool(solution.success), message=str(solution.message),
        evaluations=problem.evaluations, wall_seconds=time.perf_counter() - started,
        warnings=warnings,
    )


def _check_start(spec: FitSpec, problem: _Problem) -> None:
    """Refuse start values at which some row has no model value, and velocities in the
    wrong units (:func:`study.analyses.measurements.check_velocity_units`)."""
    data = spec.measurements
    model0, _ = model_values(problem.params(problem.start()), data, spec.coupling)
    bad = np.flatnonzero(~np.isfinite(model0))
    if bad.size:
        rows = ", ".join(f"{data['source'].values[i]} line {int(data['line'].values[i])}"
                         for i in bad[:5])
        raise SpecError(f"{spec.path}: the model has no value at the start values for "
                        f"{rows} (lift-off or no steady orbit); change the start values")
    velocity = np.flatnonzero(data["quantity"].values == "velocity")
    check_velocity_units(data, velocity, float(np.max(np.abs(model0[velocity]), initial=0.0)))


def _uncertainty(jac: NDArray[np.float64], lower: NDArray[np.float64],
                 upper: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_],
                                                      NDArray[np.float64], NDArray[np.float64],
                                                      NDArray[np.bool_]]:
    """Covariance, null directions, standard errors, correlation and which parameters
    the data fix, from the Jacobian at the estimate and the bounds of the search."""
    cov, degenerate = _covariance(jac, upper - lower)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, np.inf))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    corr[~np.isfinite(corr)] = np.nan
    np.fill_diagonal(corr, np.where(np.isfinite(se) & (se > 0), 1.0, np.nan))
    identifiable = ~degenerate & np.isfinite(se) & (se <= UNIDENTIFIABLE_FRACTION
                                                      * (upper - lower))
    return cov, degenerate, se, corr, identifiable


def _identifiability_warnings(names: list[str], identifiable: NDArray[np.bool_],
                              degenerate: NDArray[np.bool_], se: NDArray[np.float64]
                              ) -> list[str]:
    """A warning for every parameter the data do not fix, saying why and what to do."""
    out = []
    for j in np.flatnonzero(~identifiable):
        why = ("the data do not depend on it (or only through a combination with other "
               "parameters)" if degenerate[j] else
               f"its standard error {se[j]:.3g}{spoken(PARAMETERS[names[j]].units)} is more than "
               f"{UNIDENTIFIABLE_FRACTION:g} of its bounds' width")
        out.append(f"parameter {names[j]} is not identifiable from these data: {why}; "
                   f"see its chi^2 profile (profile_chi2 in the file); fix {names[j]} "
                   "in [structure] (drop it from [fit] free) or add measurements that "
                   "depend on it")
    return out


def _quality_warnings(spec: FitSpec, chi2: float, dof: int, p_value: float,
                      resid: NDArray[np.float64], model: NDArray[np.float64],
                      solution: Any) -> list[str]:
    """Warnings on the fit as a whole: a misfit, no degree of freedom, rows without a
    model value at the estimate, an optimiser that stopped short."""
    data = spec.measurements
    out = []
    if p_value < CHI2_P_LIMIT:
        out.append(_misfit_warning(spec, chi2, dof, p_value, resid))
    if dof <= 0:
        out.append(f"{data.sizes['measurement']} measurements for {len(spec.free)} free "
                   "parameters: no degree of freedom left, chi^2 per dof undefined")
    if not np.all(np.isfinite(model)):
        out.append("the model has no value (lift-off or no orbit) at the estimate for "
                   f"{int(np.sum(~np.isfinite(model)))} rows")
    if not solution.success:
        out.append(f"the optimiser stopped: {solution.message}")
    return out


def _profiles(spec: FitSpec, problem: _Problem, best: dict[str, float | None],
              identifiable: NDArray[np.bool_], lower: NDArray[np.float64],
              upper: NDArray[np.float64], progress: Callable[[str], None] | None
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The chi^2 profiles ``spec.profile`` asks for (:func:`_profile`): the values each
    parameter is held at and the chi^2 there, NaN rows for those not profiled."""
    names = problem.names
    npoints = spec.profile_points
    profile_values = np.full((len(names), npoints), np.nan)
    profile_chi2 = np.full((len(names), npoints), np.nan)
    chosen = {"all": np.ones(len(names), bool), "none": np.zeros(len(names), bool),
              "unidentifiable": ~identifiable}[spec.profile]
    for j in np.flatnonzero(chosen):
        if progress is not None:
            progress(f"profiling {names[j]}")
        low, high = lower[j], upper[j]
        if not problem.ratio:  # the constraint ck <= cs is in the search's bounds
            low, high = problem.lower[j], problem.upper[j]
        values = np.linspace(low, high, npoints)
        profile_values[j] = values
        profile_chi2[j] = _profile(spec, best, names[j], values)
    return profile_values, profile_chi2


def _bound_warnings(spec: FitSpec, names: list[str], estimate: NDArray[np.float64],
                    params: dict[str, float | None], lower: NDArray[np.float64],
                    upper: NDArray[np.float64]) -> list[str]:
    """A warning for every estimate on (within :data:`BOUND_MARGIN` of) a bound of
    ``[fit] free`` or on the constraint ``ck <= cs``."""
    check = ("check the units of the measurements (SI: "
             + ", ".join(f"{q.name} in {q.units}" for q in QUANTITIES.values()
                         if q.name in set(spec.measurements["quantity"].values))
             + f"), the fixed parameters in [structure] and the model (coupling = "
             f"'{spec.coupling}')")
    out = []
    for j, name in enumerate(names):
        units = PARAMETERS[name].units
        units = "" if units == "1" else f" {units}"
        side = bound_side(estimate[j], lower[j], upper[j])
        if side:
            out.append(f"{name} = {estimate[j]:.6g}{units} is on its {side} bound "
                       f"(free.{name} = [{lower[j]:g}, {upper[j]:g}]): the best fit may "
                       f"lie beyond it and its standard error means little; widen the "
                       f"bound if {name} can be outside it, else {check}")
    ck, cs = params.get("ck"), params.get("cs")
    constrained = "ck" in names or ("cs" in names and spec.start.get("ck") is not None)
    if constrained and ck is not None and cs is not None and cs - ck <= BOUND_MARGIN * cs:
        out.append(f"ck = {ck:.6g} is on the constraint ck <= cs (cs = {cs:.6g}): the data "
                   f"pull the friction coefficients past it; {check}")
    return out


def _misfit_warning(spec: FitSpec, chi2: float, dof: int, p_value: float,
                    resid: NDArray[np.float64]) -> str:
    """chi^2 too large for the model to describe the data: where and what to check."""
    data = spec.measurements
    worst = int(np.nanargmax(np.abs(resid))) if np.isfinite(resid).any() else 0
    other = "one-way" if spec.coupling == "two-way" else "two-way"
    units = ", ".join(f"{q.name} in {q.units}" for q in QUANTITIES.values()
                      if q.name in set(data["quantity"].values))
    return (f"chi^2/dof = {chi2 / dof:.3g} on {dof} dof (p = {p_value:.2g} < "
            f"{CHI2_P_LIMIT:g}): the model does not describe these data within their sigma "
            f"(largest: {data['source'].values[worst]} line "
            f"{int(data['line'].values[worst])}, {resid[worst]:+.3g} sigma); check the "
            f"units of the measurements (SI: {units}), that sigma is one standard "
            f"deviation, the fixed parameters in [structure] and the model (coupling = "
            f"'{spec.coupling}'; the other is '{other}')")


def _profile(spec: FitSpec, best: dict[str, float | None], name: str,
             values: NDArray[np.float64]) -> NDArray[np.float64]:
    """chi^2 with ``name`` held at each value, the other free parameters re-fitted."""
    others = {n: b for n, b in spec.free.items() if n != name}
    out = np.full(values.size, np.nan)
    for i, value in enumerate(values):
        start = dict(spec.start)
        start.update({n: best[n] for n in spec.free})
        if best.get("ck") is not None:
            start["ck"] = best["ck"]
        start[name] = float(value)
        if name == "cs" and start.get("ck") is not None and start["ck"] > value:
            start["ck"] = float(value)
        if name == "ck" and start["ck"] > start["cs"]:
            if name in spec.free and "cs" in others:
                start["cs"] = float(value)  # the least cs that holds this ck
            else:
                continue  # not a valid structure
        for n, (lo, hi) in others.items():
            start[n] = float(np.clip(start[n], lo, hi))
        try:
            problem = _Problem(start, others, spec.measurements, spec.coupling)
            if others:
                x = _minimise(problem, max(20, spec.max_evaluations // 4)).x
            else:
                x = problem.start()
            r = problem.residuals(x)
        except ValueError:
            continue
        out[i] = float(np.sum(r**2))
    return out


# ---------------------------------------------------------------------------
# The result file


def fit_dataset(spec: FitSpec, result: FitResult, command: str = "") -> xr.Dataset:
    """The fit as a self-describing dataset (the layout of ``study-fit-v1``)."""
    from study.engine.fingerprint import code_fingerprint
    from study.engine.provenance import utc_now

    data = spec.measurements
    n_rows = data.sizes["measurement"]
    code = code_fingerprint(("study.analyses.fit",)).sha256
    now = utc_now()
    variables = {**_parameter_variables(result), **_measurement_variables(data, result)}
    attrs = {
        "Conventions": "CF-1.11",
        "title": spec.title,
        "study_result_schema": FIT_RESULT_SCHEMA,
        "study_fit_format": FIT_FORMAT,
        "study_fit_name": spec.name,
        "study_spec": spec.text,
        "study_spec_sha256": spec.sha256,
        "study_code_sha256": code,
        # The model's contact laws (issue 33): the spec's coupling, and the friction
        # and lift-off laws the model's solvers use unless told otherwise (Coulomb, stop
        # at lift-off), which a fit spec cannot change.
        **contact_law_attributes(spec.coupling),
        "study_measurement_files": json.dumps(sorted(set(map(str, data["source"].values)))),
        "study_fitted_structure": json.dumps(
            {k: v for k, v in _fitted(spec, result).items() if v is not None}),
        "study_success": int(result.success),
        "study_warnings": json.dumps(result.warnings),
        "date_created": now,
        "history": f"{now}: {command or 'study.analyses.fit'}",
        "provenance": json.dumps(_fit_provenance(spec, result, code, now, command),
                                 default=str),
    }
    ds = xr.Dataset({k: xr.Variable(*v) for k, v in variables.items()}, coords={
        k: xr.Variable(*v) for k, v in _parameter_coords(result.names).items()}, attrs=attrs)
    assert n_rows == ds.sizes["measurement"]
    return ds


def _fit_provenance(spec: FitSpec, result: FitResult, code: str, now: str, command: str
                    ) -> dict[str, Any]:
    """The run's provenance record: spec, code, environment and how the search went."""
    from study.engine.provenance import environment, git_state, package_version

    return {
        "spec": spec.text, "spec_sha256": spec.sha256, "code_sha256": code,
        "package_version": package_version(), **git_state(),
        "environment": environment(), "end_time": now, "command": command,
        "optimizer": "scipy.optimize.least_squares(method='trf', x_scale='jac')",
        "derivatives": "analytic (thresholds, ring-downs); central differences (velocities)",
        "evaluations": result.evaluations, "wall_seconds": result.wall_seconds,
        "message": result.message,
    }


def _parameter_coords(names: list[str]) -> dict[str, tuple[Any, ...]]:
    """The free parameters' axes (twice, for matrices), with their units and long names."""
    units = [PARAMETERS[n].units for n in names]
    long_names = [PARAMETERS[n].long_name for n in names]
    return {
        "parameter": ("parameter", np.array(names, dtype=object),
                      {"long_name": "free parameter"}),
        "parameter_2": ("parameter_2", np.array(names, dtype=object),
                        {"long_name": "free parameter (second index of matrices)"}),
        "parameter_units": ("parameter", np.array(units, dtype=object),
                            {"long_name": "units of the parameter's values"}),
        "parameter_long_name": ("parameter", np.array(long_names, dtype=object),
                                {"long_name": "what the parameter is"}),
    }


def _parameter_variables(result: FitResult) -> dict[str, tuple[Any, ...]]:
    """The variables over the free parameters (estimates, errors, profiles) and the
    fit's scalars (chi^2, degrees of freedom, p-value)."""
    pdim, qdim = ("parameter",), ("parameter_2",)
    per_unit = {"units_variable": "parameter_units",
                "comment": "in each parameter's own units (parameter_units)"}
    return {
        "estimate": (pdim, result.estimate, {"long_name": "best estimate", **per_unit}),
        "standard_error": (pdim, result.standard_error, {
            "long_name": "standard error (one standard deviation, sigma taken as absolute)",
            **per_unit}),
        "lower_bound": (pdim, result.lower, {"long_name": "lower bound of the search",
                                             **per_unit}),
        "upper_bound": (pdim, result.upper, {"long_name": "upper bound of the search",
                                             **per_unit}),
        "start": (pdim, result.start, {"long_name": "start value", **per_unit}),
        "identifiable": (pdim, result.identifiable.astype(np.int8), {
            "long_name": "whether the data fix the parameter",
            "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "not_identifiable identifiable",
            "comment": (f"not identifiable: standard error > {UNIDENTIFIABLE_FRACTION:g} x "
                        "bounds width, or along a null direction of J^T J")}),
        "correlation": (pdim + qdim, result.correlation, {
            "long_name": "correlation of the estimates", "units": DIMENSIONLESS}),
        "covariance": (pdim + qdim, result.covariance, {
            "long_name": "covariance of the estimates",
            "comment": "units: product of the two parameters' units"}),
        "profile_value": (("parameter", "profile_point"), result.profile_values, {
            "long_name": "value at which the parameter is held", **per_unit}),
        "profile_chi2": (("parameter", "profile_point"), result.profile_chi2, {
            "long_name": "chi^2 minimised over the other free parameters", "units": DIMENSIONLESS,
            "comment": "NaN: not profiled (only unidentifiable parameters by default)"}),
        "chi2": ((), result.chi2, {"long_name": "chi^2 at the estimate", "units": DIMENSIONLESS}),
        "degrees_of_freedom": ((), np.int32(result.dof), {
            "long_name": "measurements minus free parameters"}),
        "chi2_per_dof": ((), result.chi2_per_dof, {
            "long_name": "chi^2 per degree of freedom", "units": DIMENSIONLESS}),
        "chi2_p_value": ((), result.p_value, {
            "long_name": "probability of a chi^2 at least this large if the model holds",
            "units": DIMENSIONLESS,
            "comment": (f"scipy.stats.chi2.sf(chi2, degrees_of_freedom); below "
                        f"{CHI2_P_LIMIT:g} the fit warns (study_warnings); NaN: no degree "
                        "of freedom")}),
    }


def _measurement_variables(data: xr.Dataset, result: FitResult) -> dict[str, tuple[Any, ...]]:
    """The variables over the measurement rows: the rows as read, the model's value and
    the residuals at the estimate, and the solver's status of velocity rows."""
    from study.model.status import Status

    mdim = ("measurement",)
    residual = result.model - data["value"].values
    variables = {}
    for name in ("quantity", "f", "a", "value", "sigma", "value_units", "direction",
                 "m_add", "M", "source", "line"):
        variables[name] = (mdim, data[name].values, dict(data[name].attrs))
    variables["model"] = (mdim, result.model, {
        "long_name": "fitted model's value", "comment": "units by quantity, see value_units"})
    variables["residual"] = (mdim, residual, {
        "long_name": "model minus measured value",
        "comment": "units by quantity, see value_units"})
    variables["normalized_residual"] = (mdim, residual / data["sigma"].values, {
        "long_name": "residual over sigma", "units": DIMENSIONLESS})
    status_names = np.array(["" if s < 0 else Status(int(s)).name for s in result.status],
                            dtype=object)
    variables["solver_status"] = (mdim, status_names, {
        "long_name": "solver status of velocity rows at the estimate (empty: closed form)"})
    return variables


def _fitted(spec: FitSpec, result: FitResult) -> dict[str, float | None]:
    """Every structure parameter at the estimate."""
    params = dict(spec.start)
    params.update(zip(result.names, map(float, result.estimate), strict=True))
    return params


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
    return _structure(full, real_number("m_add", m_add, KILOGRAM), M)


def quantity_units() -> dict[str, str]:
    """Units of ``value`` by quantity (documentation helper)."""
    return {q.name: q.units for q in QUANTITIES.values()}


# ---------------------------------------------------------------------------
# The fit kind (study.engine.kinds): what the runner, validation and the CLI need


def _fit_for_runner(spec: FitSpec, progress: Any) -> FitResult:
    return fit(spec, progress=progress.say)


def _fit_inputs(spec: FitSpec) -> list[str]:
    """The spec and its measurement files: a fit never writes over what it reads."""
    return [spec.path, *sorted({str(p) for p in spec.measurements["source"].values})]


#: The fit kind: free structure parameters fitted to measurements.
FIT_KIND = register(ResultKind(
    name="fit", spec_table="fit", spec_schema=FIT_SPEC_SCHEMA, result_schema=FIT_RESULT_SCHEMA,
    entry_modules=("study.analyses.fit",),
    summary="fit: free structure parameters estimated from measurements",
    label="fit result", spec_type=FitSpec, load=load_fit_spec, parse=parse_fit_spec,
    validator="study.analyses.fit_checks:fit_problems", name_attribute="study_fit_name",
    compute=_fit_for_runner, build=fit_dataset, own_provenance=True, inputs=_fit_inputs,
    formats=FIT_FORMATS, format_attribute="study_fit_format",
))
