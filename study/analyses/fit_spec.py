"""Fit specs: their schema, their parsing and their validation, before any model runs.

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

Reading one checks everything that can be checked without the model: the schema, the
bounds against each parameter's range, the start values against the bounds, a valid
:class:`~study.model.structure.Structure` at the start, ``ck <= cs`` reachable, and a
``sigma`` for every measurement row. The fit itself is :mod:`study.analyses.fit_search`.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from study.analyses.fit_model import measured_structure
from study.analyses.measurements import QUANTITIES, read_measurements
from study.engine.spec_files import (
    SpecError,
    canonical_sha256,
    check_schema,
    load_schema,
    parse_toml,
    read_spec_text,
)
from study.model.contact import DEFAULT_COUPLING
from study.model.parameters import PARAMETERS as PARAMETER_TABLE
from study.model.parameters import STRUCTURE, Parameter, schema_properties, units_list
from study.model.units import spoken

__all__ = [
    "FIT_SPEC_SCHEMA",
    "PARAMETERS",
    "FitSpec",
    "Parameter",
    "load_fit_spec",
    "parse_fit_spec",
]

FIT_SPEC_SCHEMA = "study-fit-spec-v1"


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
        measured_structure(start, 0.0)
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


def quantity_units() -> dict[str, str]:
    """Units of ``value`` by quantity (documentation helper)."""
    return {q.name: q.units for q in QUANTITIES.values()}
