"""The parameter table (study.model.parameters) and everything derived from it agree."""

from __future__ import annotations

import math
from decimal import Decimal
from pathlib import Path

import jsonschema
import numpy as np
import pytest

import study
from study.analyses import design_spec, fit_spec
from study.model import paper
from study.model.drive import as_acceleration, as_frequency
from study.model.parameters import (
    DRIVE,
    MASS,
    PARAMETERS,
    STRUCTURE,
    markdown_table,
    schema_definition,
)
from study.model.structure import Structure, tilt_warnings
from study.model.units import UNITS
from study.studies import schema as study_schema
from study.studies import spec_types as study_types

SCHEMAS = Path(study.__file__).resolve().parent / "schemas"
PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25, "ck": 0.25, "g": 9.8}


def _probes(lower: float, upper: float) -> list[float]:
    """Values at, just inside and just outside both bounds."""
    values = []
    for bound in (lower, upper):
        values += [bound, np.nextafter(bound, -math.inf), np.nextafter(bound, math.inf)]
    return [float(v) for v in values]


def test_the_groups_partition_the_table() -> None:
    assert {**STRUCTURE, **MASS, **DRIVE} == PARAMETERS
    assert len(STRUCTURE) + len(MASS) + len(DRIVE) == len(PARAMETERS)
    assert list(STRUCTURE) == list(Structure.__dataclass_fields__)


@pytest.mark.parametrize("name", sorted(PARAMETERS))
def test_every_parameter_declares_units_symbol_range_and_reason(name: str) -> None:
    p = PARAMETERS[name]
    assert p.units in UNITS
    assert p.symbol and p.long_name and p.reason
    assert p.lower < p.upper


@pytest.mark.parametrize("name", sorted(STRUCTURE))
def test_structure_accepts_exactly_what_the_spec_schema_accepts(name: str) -> None:
    """Structure (the table's inside()) against jsonschema's reading of the generated
    spec schema, at and on both sides of every bound."""
    definition = study_schema.spec_schema()["$defs"]["parameter"][name]
    p = STRUCTURE[name]
    for value in _probes(p.lower, p.upper):
        params = dict(PAPER, **{name: value})
        if name == "cs":  # ck <= cs holds where cs is allowed
            params["ck"] = min(value, PAPER["ck"]) if value > 0 else value
        if name == "ck":  # ck is held to the largest cs
            params["cs"] = STRUCTURE["cs"].upper
        by_schema = jsonschema.Draft202012Validator(definition).is_valid(value)
        with tilt_warnings(False):
            try:
                Structure(**params)
                by_structure = True
            except ValueError as err:
                by_structure = False
                assert repr(name) in str(err) and p.range_text() in str(err)
        assert by_structure == by_schema, (name, value)


@pytest.mark.parametrize("name", sorted(fit_spec.PARAMETERS))
def test_fit_and_design_bounds_are_the_table_ranges(name: str) -> None:
    p = PARAMETERS[name]
    for value in _probes(p.lower, p.upper):
        assert fit_spec.PARAMETERS[name].inside(value) == jsonschema.Draft202012Validator(
            schema_definition(name)).is_valid(value)
    if name in design_spec.STRUCTURE_PARAMETERS:
        assert design_spec.STRUCTURE_PARAMETERS[name] is p


def test_ck_may_not_exceed_cs() -> None:
    with pytest.raises(ValueError, match=r"1e-6 <= ck <= cs \(cs = 0.25\)"):
        Structure(**dict(PAPER, ck=np.nextafter(0.25, 1.0)))
    assert Structure(**dict(PAPER, ck=None)).ck == 0.25


def test_defaults_come_from_the_table() -> None:
    s = Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.3)
    assert s.g == STRUCTURE["g"].default == 9.8
    assert s.ck == s.cs
    assert study_types.Structure.__dataclass_fields__["g"].default == 9.8


@pytest.mark.parametrize(("name", "group"), [
    *((n, study_types.STRUCTURE_PARAMETERS) for n in STRUCTURE),
    *((n, study_types.DRIVE_PARAMETERS) for n in DRIVE),
    ("m_add", study_types.MASS_PARAMETERS),
])
def test_the_spec_layer_reads_units_and_long_names_from_the_table(name, group) -> None:
    assert group[name] == (PARAMETERS[name].units, PARAMETERS[name].long_name)


@pytest.mark.parametrize(("schema", "export"), [
    ("study-spec-v1", study_schema.export_spec_schema),
    ("study-fit-spec-v1", fit_spec.export_fit_spec_schema),
    ("study-design-spec-v1", design_spec.export_design_spec_schema),
])
def test_the_committed_schema_is_the_generated_one(schema, export) -> None:
    on_disk = (SCHEMAS / f"{schema}.schema.json").read_text(encoding="utf-8")
    assert on_disk == export(), "run `make schemas`"


def test_the_fit_and_design_schemas_hold_structures_to_the_table() -> None:
    schemas = [fit_spec.fit_spec_schema()["properties"]["structure"]["properties"],
               design_spec.design_spec_schema()["properties"]["structure"]["properties"]]
    for properties in schemas:
        for name in STRUCTURE:
            assert properties[name] == schema_definition(name)
    mass = fit_spec.fit_spec_schema()["properties"]["structure"]["properties"]["mass"]["properties"]
    for name in ("m0", "m1", "m1_fraction"):
        assert mass[name] == schema_definition(name)


@pytest.mark.parametrize("name", sorted(paper.PAPER_STRUCTURE))
def test_paper_tolerance_is_half_a_unit_of_the_last_stated_digit(name: str) -> None:
    stated = Decimal(STRUCTURE[name].paper)
    half_unit = float(Decimal(5).scaleb(stated.as_tuple().exponent - 1))
    assert paper.PAPER_STRUCTURE[name] == PAPER[name]
    assert paper.PAPER_TOLERANCE[name] == half_unit
    if name == "ck":  # compared with cs, not with the paper's value
        return
    for factor, expected in ((0.9, True), (1.1, False)):
        for sign in (1, -1):
            changed = dict(PAPER, **{name: PAPER[name] + sign * factor * half_unit})
            if name == "cs":
                changed["ck"] = changed["cs"]
            assert paper.is_paper_structure(changed) is expected, (name, factor, sign)


def test_the_drive_limits_are_the_tables() -> None:
    spec = study_schema.spec_schema()["$defs"]["parameter"]
    for name, check in (("f", as_frequency), ("a", as_acceleration)):
        upper = DRIVE[name].upper
        assert spec[name]["maximum"] == upper == 1e6
        assert check([upper])[0] == upper
        with pytest.raises(ValueError, match=f"{name} must be"):
            check([np.nextafter(upper, math.inf)])
    with pytest.raises(ValueError, match="> 0 Hz"):
        as_frequency([0.0])
    assert as_acceleration([0.0])[0] == 0.0


def test_structure_docstring_states_the_table() -> None:
    """Structure's documented units and ranges are the table's."""
    doc = " ".join(Structure.__doc__.split())
    for name, p in STRUCTURE.items():
        assert f"[{p.units}], ``{p.range_text()}" in doc, name


def test_markdown_table_is_a_table_with_a_row_per_parameter() -> None:
    markdown_it = pytest.importorskip("markdown_it")
    text = markdown_table()
    tokens = markdown_it.MarkdownIt("commonmark").enable("table").parse(text)
    kinds = [t.type for t in tokens]
    assert kinds.count("table_open") == 1
    assert kinds.count("tr_open") == len(PARAMETERS) + 1
    assert kinds.count("td_open") == 6 * len(PARAMETERS)
    cells = [t.content for t in tokens if t.type == "inline"]
    header, rows = cells[:6], [cells[6 * (i + 1):6 * (i + 2)] for i in range(len(PARAMETERS))]
    assert header == ["name", "symbol", "units", "allowed range (why)", "default", "paper"]
    for row, (name, p) in zip(rows, PARAMETERS.items(), strict=True):
        assert row[0] == f"`{name}`"
        assert row[2] == f"`{p.units}`"
        assert row[3].startswith(f"`{p.range_text()}` (")
        assert row[5] == (p.paper or "-")
    assert markdown_table(["Q"]).count("\n") == 3
