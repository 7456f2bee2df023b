"""The fit kind: its registration (:mod:`study.engine.kinds`) and the layout of its result file.

A fit estimates free structure parameters, with uncertainty, from measured thresholds,
velocities and ring-downs (``study fit``). Its pieces, one job each:

* :mod:`study.analyses.fit_spec`: the spec (TOML), read and checked;
* :mod:`study.analyses.fit_model`: the model of each measurement row and its derivatives;
* :mod:`study.analyses.fit_search`: the least squares, the uncertainty and the warnings;
* this module: the result file (``study-fit-v1``, :func:`fit_dataset`) and the kind that
  ties them for the runner, validation and the CLI.

:func:`fit` and :func:`load_fit_spec` are importable from here too, the way the user
guide calls them. The code fingerprint of a fit (``study_code_sha256``) is the import
closure of this module, so it covers every piece.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import xarray as xr

from study.analyses.fit_search import CHI2_P_LIMIT, UNIDENTIFIABLE_FRACTION, FitResult, fit
from study.analyses.fit_spec import (
    FIT_SPEC_SCHEMA,
    PARAMETERS,
    FitSpec,
    load_fit_spec,
    parse_fit_spec,
)
from study.engine.contact_attributes import contact_law_attributes
from study.engine.kinds import ResultFormat, ResultKind, register
from study.model.units import DIMENSIONLESS

__all__ = [
    "FIT_FORMAT",
    "FIT_KIND",
    "FIT_RESULT_SCHEMA",
    "fit",
    "fit_dataset",
    "load_fit_spec",
]

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
