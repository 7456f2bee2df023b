"""Starts declared once (issue 44, item 1): everything a start needs outside its kernel
follows from its declaration in study/model/starts.py.

A start kind added to the declarations (here a hypothetical ramp, declared in the test
only) appears in the spec schema, the result schema, the docs' table, the allowed
values of every message, the labels, attributes and TOML of results and specs, and is
refused where the model cannot take it, in one wording for the API and for specs,
without another file changing.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import jsonschema
import pytest

import study
from study.engine.validation.header import RESULT_SCHEMA_PATH, export_result_schema
from study.model import starts
from study.model.starts import (
    START_KINDS,
    Drop,
    StartKind,
    StartParameter,
    as_start,
    canonical,
    kernel_fields,
    markdown_table,
    refusal,
    start_attributes,
    start_label,
    toml_value,
)
from study.solvers.exact import steady_state
from study.solvers.integrator import integrated_steady_state
from study.solvers.settings import SolverSettings, kernel_start
from study.studies.schema import spec_schema
from study.studies.spec import SpecError, parse_spec

REPO = Path(__file__).resolve().parents[2]
PAPER = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)


@dataclass(frozen=True)
class Ramp:
    """A start declared by the test alone: the drive ramped up over ``periods``."""

    periods: float

    def __post_init__(self) -> None:
        if not self.periods >= 1:
            raise ValueError("periods must be >= 1")


RAMP = StartKind(
    "ramp", "the drive's amplitude ramped up from 0 over a number of periods",
    lambda start: (0.25, 0.5, 0.0),
    parameters=(StartParameter("ramp", "periods", "periods", "periods of the ramp",
                               "periods", 1.0, 1000.0),),
    value_type=Ramp)


@pytest.fixture
def ramp(monkeypatch):
    monkeypatch.setitem(START_KINDS, "ramp", RAMP)
    return Ramp(4.0)


def test_a_new_start_appears_in_every_derived_piece(ramp):
    schema = starts.spec_schema()
    forms = schema["anyOf"]
    assert forms[0] == {"enum": ["release", "switch-on"]}
    ramp_form = next(form for form in forms if "ramp" in form.get("properties", {}))
    assert ramp_form["properties"]["ramp"]["minimum"] == 1
    assert ramp_form["properties"]["ramp"]["maximum"] == 1000
    assert ramp_form["required"] == ["ramp"]
    jsonschema.validate({"ramp": 4.0}, schema)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"ramp": 0.5}, schema)
    assert "{ ramp = periods }" in schema["description"]

    result = starts.result_schema()
    assert result["properties"]["study_start_kind"]["enum"] == [
        "release", "switch-on", "drop", "ramp"]
    assert result["properties"]["study_start_periods"]["maximum"] == 1000
    rule = next(r for r in result["allOf"]
                if r["if"]["properties"]["study_start_kind"]["const"] == "ramp")
    assert rule["then"] == {"required": ["study_start_periods"]}
    table = markdown_table()
    assert re.search(r"^\| `ramp` \| the drive's amplitude ramped up", table, re.M)

    assert start_label(ramp) == "ramp 4.0 periods"
    assert start_attributes(ramp) == {"start": "ramp 4.0 periods", "start_kind": "ramp",
                                      "start_periods": 4.0}
    assert canonical(ramp) == {"ramp": 4.0}
    assert toml_value(ramp) == "{ ramp = 4.0 }"
    assert as_start({"ramp": 4.0}) == ramp
    assert kernel_fields(ramp) == (0.25, 0.5, 0.0)
    assert tuple(kernel_start(ramp)) == (0.25, 0.5, 0.0)
    assert "needs coupling='two-way'" in refusal(ramp, coupling="one-way", flight=False)
    assert refusal(ramp, coupling="two-way", flight=False) is None


def test_the_integrator_refuses_a_start_it_cannot_set_up(ramp):
    """The ramp's state (the mode on half its steady response at a quarter period) is
    one the integrator does not build: refused by name, never run as another start."""
    with pytest.raises(ValueError, match=r"start 'ramp 4.0 periods': the integrator "):
        integrated_steady_state(PAPER, 14.0, 8.0, coupling="two-way", start=ramp)


def test_an_unknown_start_is_refused_everywhere_with_the_allowed_values():
    allowed = starts.START_ALLOWED
    for call in (lambda: SolverSettings(start="ramp"),
                 lambda: integrated_steady_state(PAPER, 14.0, 8.0, coupling="two-way",
                                                 start="ramp"),
                 lambda: steady_state(PAPER, 14.0, 8.0, coupling="two-way", start="ramp")):
        with pytest.raises(ValueError, match="start") as caught:
            call()
        assert allowed in str(caught.value)


def test_the_allowed_values_name_every_declared_start():
    for kind in START_KINDS.values():
        assert kind.name in starts.START_ALLOWED
        for parameter in kind.parameters:
            assert f"{parameter.key} = {parameter.placeholder}" in starts.START_ALLOWED
            assert parameter.range_text() in starts.START_ALLOWED


def test_the_schemas_on_disk_are_the_declarations():
    """`make schemas` writes both; the spec schema's [solver] start and the result
    schema's start attributes are the declared ones."""
    assert RESULT_SCHEMA_PATH.read_text(encoding="utf-8") == export_result_schema(), (
        "run `make schemas`")
    assert (REPO / "results_schema" / RESULT_SCHEMA_PATH.name).read_text(
        encoding="utf-8") == RESULT_SCHEMA_PATH.read_text(encoding="utf-8")
    solver = spec_schema()["properties"]["solver"]["properties"]
    assert solver["start"] == starts.spec_schema()
    attrs = json.loads(RESULT_SCHEMA_PATH.read_text())["properties"]["attrs"]
    for key, value in starts.result_schema()["properties"].items():
        assert attrs["properties"][key] == value


def test_the_result_schema_export_rebuilds_a_damaged_start_part():
    """The start attributes of the result schema are not hand-kept: an edited enum or a
    dropped parameter comes back from the declarations, the rest of the file stays."""
    text = RESULT_SCHEMA_PATH.read_text(encoding="utf-8")
    schema = json.loads(text)
    attrs = schema["properties"]["attrs"]
    attrs["properties"]["study_start_kind"]["enum"] = ["release"]
    del attrs["properties"]["study_start_phase"]
    attrs["allOf"] = []
    assert export_result_schema(json.dumps(schema, indent=2) + "\n") == text


@pytest.mark.parametrize(("start", "coupling", "flight", "observables"), [
    ("switch-on", "one-way", False, ()),
    (Drop(0.002, 0.25), "one-way", False, ()),
    (Drop(0.002, 0.25), "two-way", False, ()),
    (Drop(0.002), "two-way", True, ("velocity", "without_flight")),
])
def test_the_api_and_specs_refuse_a_start_in_one_wording(start, coupling, flight,
                                                         observables):
    """The same refusal, only the keys spelled as each writes them: the API's
    ``coupling='two-way'``, the spec's ``coupling = "two-way"``."""
    spec_words = refusal(start, coupling=coupling, flight=flight, observables=observables,
                         syntax="toml")
    api_words = refusal(start, coupling=coupling, flight=flight, observables=observables)
    assert spec_words is not None and api_words is not None
    reason = api_words.split(": ", 1)[1]
    respelled = (reason.replace("coupling='two-way'", 'coupling = "two-way"')
                 .replace(f"coupling={coupling!r}", f'coupling = "{coupling}"')
                 .replace("flight=True", "flight = true"))
    assert spec_words.split(": ", 1)[1] == respelled
    text = (
        '[study]\nname = "s"\nobservables = [' + ", ".join(f'"{o}"' for o in
                                                          observables or ("velocity",))
        + ']\n[structure]\nf0 = 14.44\nQ = 17.5\nalpha = 64.0\nM = 0.99\ncs = 0.25\n'
        '[sweep]\nf = { values = [13.0] }\na = { values = [12.0] }\n[solver]\n'
        f'coupling = "{coupling}"\nflight = {str(flight).lower()}\n'
        f"start = {toml_value(start)}\n")
    with pytest.raises(SpecError) as caught:
        parse_spec(text, "s.toml")
    assert spec_words in str(caught.value)
    if not observables:
        with pytest.raises(ValueError) as api:
            steady_state(PAPER, 13.0, 12.0, coupling=coupling, flight=flight, start=start)
        assert str(api.value) == api_words
