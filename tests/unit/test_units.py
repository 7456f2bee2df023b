"""Unit strings: one CF/UDUNITS spelling everywhere (study.model.units), so they cannot drift.

Three views, each able to fail on its own:

* every spelling of :data:`study.model.units.UNITS` is one the UDUNITS-2 library parses
  (through cf_units, which the compliance checker brings), and ``deg`` is not;
* the declarations that give every result kind its units (the study variables and
  axes, the fit and design parameters, the measurement columns, the scene's pose) use
  those spellings only;
* the package's source, read with :mod:`ast`: every ``units`` given to a dict entry,
  a keyword, a ``units`` parameter of a package function or class, or an
  ``attrs["units"]`` assignment is one of them, and no string of the package is a
  known wrong spelling (``deg``, ``m/s``, ``m s^-2``...);
* files written by ``study run`` (a closed-form study) and ``study fit`` carry only
  those spellings in their ``units`` attributes and ``parameter_units``.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import re
from pathlib import Path
from typing import Any

import cf_units
import numpy as np
import pytest
import xarray as xr

import study.model.units as units_module
from study.model.units import DIMENSIONLESS, UNITS, spoken

PACKAGE = Path(units_module.__file__).resolve().parents[1]  # study/, not study/model/

#: Whole strings that are units spelled otherwise than CF/UDUNITS (or than study does).
WRONG = re.compile(
    r"(deg|degs|degrees|rad/s|deg/s|degree/s|m/s|mm/s|m/s\^?2|m/s/s|m s\^-?[12]|"
    r"mm s\^-1|s\^-1|s\^-2|1/s|hz|HZ|sec|secs|meter|meters|metre|metres|kgs)"
)
#: Markers of the measurement columns that are not units: no units (text columns) and
#: "in the units of the row's quantity" (see study.analyses.measurements.Column).
NOT_UNITS = {"", "value"}


def test_every_spelling_is_one_udunits_parses():
    for spelling in UNITS:
        assert str(cf_units.Unit(spelling)) == spelling
    # The check can fail: the spelling study used to write for tilts is not UDUNITS.
    with pytest.raises(ValueError):
        cf_units.Unit("deg")


def test_dimensionless_is_spoken_as_nothing():
    assert spoken(DIMENSIONLESS) == ""
    assert spoken("Hz") == " Hz"
    assert f"Q = 17.5{spoken(DIMENSIONLESS)}" == "Q = 17.5"


def _declared() -> dict[str, str]:
    """Every unit a result kind's declarations give: where -> units."""
    from study.analyses import design_spec, fit_spec, measurements
    from study.solvers import planar
    from study.studies import spec, variables

    found: dict[str, str] = {}
    found.update({f"study variable {n}": v.units for n, v in variables.VARIABLES.items()})
    found.update({f"study axis {n}": u for n, (u, _) in spec.SWEEPABLE.items()})
    found.update({f"fit parameter {n}": p.units for n, p in fit_spec.PARAMETERS.items()})
    found.update({f"design plate parameter {n}": p.units
                  for n, p in design_spec.PLATE_PARAMETERS.items()})
    found.update({f"design parameter {n}": p.units
                  for n, p in design_spec.STRUCTURE_PARAMETERS.items()})
    found.update({f"measured {n}": q.units for n, q in measurements.QUANTITIES.items()})
    found.update({f"measurement column {c.name}": c.units
                  for c in measurements.COLUMNS.values() if c.units not in NOT_UNITS})
    found.update({f"scene pose {i}": u for i, u in enumerate(planar.POSE_UNITS)})
    return found


def test_the_declarations_of_every_result_kind_use_the_one_spelling():
    declared = _declared()
    assert len(declared) > 40, declared  # the tables were found
    wrong = {where: u for where, u in declared.items() if u not in UNITS}
    assert wrong == {}


def _value(node: ast.AST, namespace: dict[str, Any]) -> Any:
    """The value of a literal or of a module-level name; ``None`` when not known here."""
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.Name):
        return namespace.get(node.id)
    return None


def _units_parameter(call: ast.Call, namespace: dict[str, Any]) -> list[ast.AST]:
    """The argument a call gives to a ``units`` parameter of a package callable."""
    if not isinstance(call.func, ast.Name):
        return []
    target = namespace.get(call.func.id)
    if target is None or not getattr(target, "__module__", "").startswith("study"):
        return []
    try:
        signature = inspect.signature(target)
    except (TypeError, ValueError):
        return []
    if "units" not in signature.parameters:
        return []
    if any(isinstance(a, ast.Starred) for a in call.args) or any(
            k.arg is None for k in call.keywords):
        return []
    try:
        bound = signature.bind_partial(*range(len(call.args)),
                                       **{k.arg: k.arg for k in call.keywords})
    except TypeError:
        return []
    given = bound.arguments.get("units")
    if isinstance(given, int):
        return [call.args[given]]
    return [k.value for k in call.keywords if k.arg == given]


def unit_findings(source: str, namespace: dict[str, Any], where: str) -> list[str]:
    """Units in ``source`` (a module whose names are ``namespace``) not spelled once."""
    findings = []
    for node in ast.walk(ast.parse(source)):
        given: list[ast.AST] = []
        if isinstance(node, ast.Dict):
            given += [v for k, v in zip(node.keys, node.values, strict=True)
                      if isinstance(k, ast.Constant) and isinstance(k.value, str)
                      and (k.value == "units" or k.value.endswith("_units"))]
        elif isinstance(node, ast.Call):
            given += [k.value for k in node.keywords if k.arg == "units"]
            given += _units_parameter(node, namespace)
        elif isinstance(node, ast.Assign):
            given += [node.value for t in node.targets if isinstance(t, ast.Subscript)
                      and isinstance(t.slice, ast.Constant) and t.slice.value == "units"]
        elif (isinstance(node, ast.Constant) and isinstance(node.value, str)
              and WRONG.fullmatch(node.value)):
            findings.append(f"{where}:{node.lineno}: {node.value!r}")
        for value_node in {id(n): n for n in given}.values():  # a keyword may be both
            value = _value(value_node, namespace)
            if isinstance(value, str) and value not in UNITS | NOT_UNITS:
                findings.append(f"{where}:{value_node.lineno}: units {value!r}")
    return findings


def test_the_source_check_finds_a_wrong_spelling():
    """The scan below is not void: old spellings in each position it reads are found."""
    from study.analyses.fit_spec import Parameter

    source = '''
ALPHA = "deg"
Parameter("alpha", "deg", "tilt", -90.0, 90.0)
Parameter("alpha", units=ALPHA, long_name="tilt", lower=-90.0, upper=90.0)
x = {"units": "m/s", "parameter_units": "1/s"}
attrs["units"] = "m s^-2"
right = {"units": "m s-1"}
'''
    found = unit_findings(source, {"Parameter": Parameter, "ALPHA": "deg"}, "x.py")
    assert sorted(found) == sorted([
        "x.py:2: 'deg'", "x.py:3: 'deg'", "x.py:5: 'm/s'", "x.py:5: '1/s'",
        "x.py:6: 'm s^-2'", "x.py:3: units 'deg'", "x.py:4: units 'deg'",
        "x.py:5: units 'm/s'", "x.py:5: units '1/s'", "x.py:6: units 'm s^-2'"])


def _modules() -> list[tuple[str, Path]]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        found.append((name, path))
    return found


def test_the_package_source_spells_every_unit_once():
    findings = []
    for name, path in _modules():
        if name in ("study.__main__",):
            continue
        module = importlib.import_module(name)
        findings += unit_findings(path.read_text(encoding="utf-8"), vars(module),
                                  str(path.relative_to(PACKAGE.parent)))
    assert findings == []


def _units_in_file(path: Path) -> dict[str, Any]:
    with xr.open_dataset(path, decode_cf=False) as dataset:
        found = {name: var.attrs["units"] for name, var in dataset.variables.items()
                 if "units" in var.attrs}
        if "parameter_units" in dataset.variables:
            found.update({f"parameter_units[{i}]": str(u) for i, u in
                          enumerate(dataset["parameter_units"].values)})
    return found


CLOSED_FORM_SPEC = """\
[study]
name = "units-closed-form"
title = "Units of a closed-form study"
observables = ["resonance", "thresholds", "lift_off"]

[structure]
f0 = 14.44
M = 0.08
cs = 0.25

[sweep]
Q = { values = [10.0, 17.5] }
alpha = { values = [50.0, 64.0] }
f = { values = [12.0, 14.0, 16.0] }
"""


def test_a_study_file_holds_the_one_spelling(tmp_path: Path):
    from study.cli import main

    spec = tmp_path / "spec.toml"
    spec.write_text(CLOSED_FORM_SPEC)
    out = tmp_path / "out.nc"
    assert main(["run", str(spec), "-o", str(out)]) == 0
    found = _units_in_file(out)
    assert {"alpha", "Q", "f", "a_star_plus", "mode_phase"} <= set(found)
    assert found["alpha"] == "degree"
    assert {k: u for k, u in found.items() if u not in UNITS} == {}


def _fit_file(tmp_path: Path) -> Path:
    from study.analyses.fit import fit_dataset
    from study.analyses.fit_search import fit
    from study.analyses.fit_spec import parse_fit_spec
    from study.engine.store import write_atomic
    from study.model import thresholds
    from study.model.structure import Structure

    f = np.array([11.0, 12.0, 13.0, 13.8, 14.6, 15.2, 16.0])
    plus, minus = thresholds(Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25), f)
    rows = "".join(f"threshold,{float(fi)!r},,{float(v)!r},0.05\n"
                   for fi, v in zip(f, np.minimum(plus, minus), strict=True))
    (tmp_path / "m.csv").write_text("quantity,f,a,value,sigma\n" + rows)
    spec = parse_fit_spec(
        '[fit]\nname = "t"\nmeasurements = ["m.csv"]\nfree = { alpha = [40.0, 80.0] }\n'
        "[structure]\nf0 = 14.44\nQ = 17.5\nalpha = 60.0\nM = 0.08\ncs = 0.25\n",
        str(tmp_path / "fit.toml"), base=tmp_path)
    return write_atomic(fit_dataset(spec, fit(spec)), tmp_path / "fit.nc")


def test_a_fit_file_holds_the_one_spelling(tmp_path: Path):
    found = _units_in_file(_fit_file(tmp_path))
    assert found["parameter_units[0]"] == "degree"
    assert {k: u for k, u in found.items() if u not in UNITS | NOT_UNITS} == {}


def test_a_fit_file_written_before_the_one_spelling_is_refused_as_stale(tmp_path: Path):
    """Format 1 (no ``study_fit_format``) spelled alpha's units ``deg``: refused whole,
    naming the format, what it held and what to do, as stale scenes are."""
    from study.engine.validation import ResultError, validate_file

    with xr.open_dataset(_fit_file(tmp_path)) as dataset:
        old = dataset.load()
    del old.attrs["study_fit_format"]
    old["parameter_units"] = old["parameter_units"].copy(data=np.array(["deg"], dtype=object))
    old.to_netcdf(tmp_path / "old.nc")
    with pytest.raises(ResultError) as refused:
        validate_file(tmp_path / "old.nc")
    message = str(refused.value)
    assert "fit format 1 (units spelled deg, not degree) is stale" in message
    assert "this study reads format 2" in message and "rerun its spec with `study fit`" in message
    assert message.count("\n") == 1  # that one problem only, not a list of schema errors


def test_a_design_file_without_its_format_is_refused_as_stale(tmp_path: Path):
    from study.analyses.design import DESIGN_FORMAT, DESIGN_RESULT_SCHEMA
    from study.engine.validation import ResultError, validate_file

    xr.Dataset({"best": ("parameter", [56.2])}, attrs={
        "study_result_schema": DESIGN_RESULT_SCHEMA}).to_netcdf(tmp_path / "old.nc")
    with pytest.raises(ResultError, match=re.escape(
            "design format 1 (units spelled deg, not degree) is stale: this study reads "
            f"format {DESIGN_FORMAT} (every unit in CF/UDUNITS spelling, angles in degree); "
            "rerun its spec with `study design`")):
        validate_file(tmp_path / "old.nc")
