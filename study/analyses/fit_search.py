"""The fit itself: weighted least squares on the exact solvers, with uncertainty and warnings.

``chi^2 = sum ((model - value) / sigma)^2`` (the model of each row:
:mod:`study.analyses.fit_model`) is minimised by :func:`scipy.optimize.least_squares`
(trust-region reflective, within the bounds). Derivatives: analytic for thresholds and
ring-downs (the closed form differentiated); central finite differences for velocities
(one-sided at a bound), where the solver has no derivative with respect to the
structure. Every trial point is a valid :class:`~study.model.structure.Structure`:
bounds are intersected with the parameters' ranges, and when both ``cs`` and ``ck`` are
free the search runs on ``cs`` and ``r = ck / cs`` in ``(0, 1]``. Standard errors come
from the covariance ``(J^T W J)^-1`` at the optimum, taking the stated ``sigma`` as
absolute.

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

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from study.analyses.fit_model import analytic_jacobian, model_values
from study.analyses.fit_spec import PARAMETERS, FitSpec
from study.analyses.measurements import QUANTITIES, check_velocity_units
from study.engine.spec_files import SpecError
from study.model.inputs import bounded_integer, real_number
from study.model.units import spoken

__all__ = [
    "FitResult",
    "bound_side",
    "chi2_p_value",
    "fit",
]

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
        jac = analytic_jacobian(p, self.data, names)
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
        Physical units (:data:`~study.analyses.fit_spec.PARAMETERS`); ``standard_error``
        is inf where the data cannot fix a parameter.
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

