"""Study specs (``study.studies.spec``): parsing, axes, structures, the hash, refusals.

Specs are built from Python tables rendered to TOML by :func:`render`; :func:`spec_text`
applies a few changes to the paper's minimal spec (:data:`MINIMAL`), so each test
states only what differs. Tests whose subject is the TOML text itself (comments,
key order, the ``[structure.mass]`` header) use literal text.
"""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study.model
import study.model.forces
import study.solvers.exact
import study.studies.observables
import study.studies.spec
import study.studies.sweep
from study.model.structure import Structure
from study.solvers.settings import SolverSettings
from study.studies.spec import (
    OBSERVABLES,
    MassModel,
    SpecError,
    StudySpec,
    load_spec,
    parse_spec,
)

REPO = Path(__file__).resolve().parents[2]

#: The path handed to ``parse_spec``; every refusal must name it.
SPEC_PATH = "workflows/under-test.toml"

MINIMAL_TEXT = """\
[study]
name = "regime-map"
observables = ["thresholds", "velocity"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = { start = 10.0, stop = 20.0, num = 401 }
a = { start = 0.0, stop = 12.0, num = 241 }
"""

#: The same spec as tables: the base that :func:`spec_text` edits.
MINIMAL: dict[str, dict[str, Any]] = {
    "study": {"name": "regime-map", "observables": ["thresholds", "velocity"]},
    "structure": {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25},
    "sweep": {
        "f": {"start": 10.0, "stop": 20.0, "num": 401},
        "a": {"start": 0.0, "stop": 12.0, "num": 241},
    },
}

#: The paper's masses (kg): structure mass and resonant fraction.
M0 = 8.2e-3
M1_FRACTION = 0.08
M_ADD = [0.0, 1.7e-3, 3.8e-3, 7.7e-3, 16.6e-3]

MASS_STUDY_TEXT = """\
[study]
name = "mass-ratio"
observables = ["thresholds", "velocity"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
cs = 0.25

[structure.mass]
m0 = 8.2e-3
{m1_line}

[sweep]
m_add = {{ values = [0.0, 1.7e-3, 3.8e-3, 7.7e-3, 16.6e-3] }}
f = {{ start = 10.0, stop = 20.0, num = 401 }}
a = {{ start = 0.0, stop = 12.0, num = 241 }}
"""


# --------------------------------------------------------------------------- helpers


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)  # repr of a float (incl. inf, nan, 1e-05) is valid TOML
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(map(_toml_value, value)) + "]"
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"cannot render {value!r} as TOML")


def render(tables: Mapping[str, Mapping[str, Any]]) -> str:
    """TOML text of ``{table: {key: value}}``; nested tables become inline tables."""
    blocks = []
    for table, keys in tables.items():
        lines = [f"[{table}]"] + [f"{k} = {_toml_value(v)}" for k, v in keys.items()]
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + "\n"


def spec_text(changes: Mapping[str, Mapping[str, Any] | None] | None = None) -> str:
    """The minimal spec with ``changes``: ``{table: {key: value}}`` sets keys (new keys
    go last), a value of None removes a key, a table of None removes the table."""
    tables = copy.deepcopy(MINIMAL)
    for table, keys in (changes or {}).items():
        if keys is None:
            del tables[table]
            continue
        target = tables.setdefault(table, {})
        for key, value in keys.items():
            if value is None:
                del target[key]
            else:
                target[key] = value
    return render(tables)


def parse(changes: Mapping[str, Mapping[str, Any] | None] | None = None) -> StudySpec:
    return parse_spec(spec_text(changes), SPEC_PATH)


def axis_names(spec: StudySpec) -> list[str]:
    return [axis.name for axis in spec.axes]


def test_helpers_render_the_minimal_spec():
    assert parse_spec(spec_text()).canonical == parse_spec(MINIMAL_TEXT).canonical


# --------------------------------------------------------------------------- the minimal spec


def test_minimal_spec_parses_as_written():
    spec = parse_spec(MINIMAL_TEXT, SPEC_PATH)

    assert spec.name == "regime-map"
    assert spec.title == "regime-map"
    assert spec.description == ""
    assert spec.observables == ("thresholds", "velocity")
    assert spec.fixed == {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25}
    assert spec.mass is None
    assert spec.text == MINIMAL_TEXT
    assert spec.path == SPEC_PATH

    assert axis_names(spec) == ["f", "a"]
    f, a = spec.axes
    assert (len(f), len(a)) == (401, 241)
    assert f.values.dtype == a.values.dtype == np.float64
    assert_allclose(f.values, np.linspace(10.0, 20.0, 401), rtol=1e-15, atol=0)
    assert_allclose(a.values, np.linspace(0.0, 12.0, 241), rtol=1e-15, atol=1e-15)
    assert (f.values[0], f.values[-1], a.values[0], a.values[-1]) == (10.0, 20.0, 0.0, 12.0)
    assert (f.units, a.units) == ("Hz", "m s-2")
    assert spec.axis("f") is f
    assert spec.axis("a") is a
    assert spec.axis("Q") is None
    assert spec.structure_axes == ()

    assert spec.solver == SolverSettings()
    assert (spec.solver.max_events, spec.solver.max_map_iterations) == (10_000, 5_000)
    assert spec.chunk_points == 20_000
    assert spec.needs_solver


def test_minimal_spec_has_one_structure_the_papers():
    spec = parse_spec(MINIMAL_TEXT, SPEC_PATH)
    assert list(spec.structures()) == [
        ((), Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25))
    ]


def test_observables_are_kept_in_canonical_order():
    """Asked in any order, the observables are kept in their declared order (that of
    the registry, whose declarations the spec's list follows)."""
    declared = tuple(study.studies.observables.OBSERVABLES)
    # Every one but unswept, jumps and branches (which need a slow sweep, where the
    # frontier is refused) and basins (refused beside attractors, whose attractor_count
    # it writes too, and with a slow sweep).
    plain = tuple(o for o in declared if o not in ("unswept", "jumps", "branches",
                                                   "basins"))
    spec = parse({"study": {"observables": list(reversed(plain))},
                  "solver": {"coupling": "two-way", "flight": True}})
    assert spec.observables == plain and OBSERVABLES == declared
    assert declared.index("velocity") < declared.index("frontier")
    with_basins = (*(o for o in plain if o != "attractors"), "basins")
    spec = parse({"study": {"observables": list(reversed(with_basins))},
                  "solver": {"coupling": "two-way", "flight": True}})
    assert spec.observables == tuple(o for o in declared if o in with_basins)
    swept = tuple(o for o in declared if o not in ("frontier", "basins"))
    spec = parse({"study": {"observables": list(reversed(swept))},
                  "sweep": {"protocol": {"along": "f", "direction": "both"}},
                  "solver": {"coupling": "two-way", "flight": True}})
    assert spec.observables == swept


def test_solver_settings_and_chunk_points_are_read():
    spec = parse({"solver": {"max_events": 7, "max_map_iterations": 11, "chunk_points": 1024}})
    assert spec.solver == SolverSettings(max_events=7, max_map_iterations=11)
    assert spec.chunk_points == 1024


def test_example_workflow_is_valid():
    path = REPO / "workflows" / "regime-map.toml"
    spec = load_spec(path)
    # The paper's map (Fig. 2): every observable it names applies to a one-way study
    # without flight, as each declares what it needs; an observable added to the
    # registry does not change this workflow.
    assert (spec.method, spec.coupling, spec.flight) == ("exact", "one-way", False)
    assert study.studies.observables.unmet_needs(
        spec.observables, spec.method, spec.coupling, spec.flight) == []
    assert spec.observables == ("resonance", "thresholds", "lift_off", "velocity",
                                "diagnostics", "frontier")
    assert spec.title == "Regime map of the paper's structure (Fig. 2)"
    assert axis_names(spec) == ["f", "a"]
    assert [len(axis) for axis in spec.axes] == [401, 241]


# --------------------------------------------------------------------------- axis forms


@pytest.mark.parametrize(
    ("form", "expected"),
    [
        pytest.param({"start": 10.0, "stop": 20.0, "num": 401}, np.linspace(10, 20, 401), id="lin"),
        pytest.param(
            {"start": 10.0, "stop": 20.0, "num": 6, "spacing": "linear"},
            np.linspace(10, 20, 6),
            id="lin-explicit",
        ),
        pytest.param(
            {"start": 20.0, "stop": 10.0, "num": 3}, np.array([20.0, 15.0, 10.0]), id="descending"
        ),
        pytest.param({"start": 12.5, "stop": 20.0, "num": 1}, np.array([12.5]), id="num-1"),
        pytest.param(
            {"start": 1.0, "stop": 1000.0, "num": 4, "spacing": "log"},
            np.geomspace(1.0, 1000.0, 4),
            id="log",
        ),
        pytest.param(
            {"start": 5.0, "stop": 50.0, "num": 17, "spacing": "log"},
            np.geomspace(5.0, 50.0, 17),
            id="log-17",
        ),
        pytest.param({"values": [14.0, 10.5, 19.25]}, np.array([14.0, 10.5, 19.25]), id="values"),
        pytest.param({"values": [10, 12]}, np.array([10.0, 12.0]), id="integer-values"),
    ],
)
def test_axis_forms(form, expected):
    (f,) = parse({"sweep": {"f": form, "a": None}, "study": {"observables": ["thresholds"]}}).axes
    assert f.name == "f"
    assert f.values.dtype == np.float64
    assert f.values.shape == expected.shape
    assert_allclose(f.values, expected, rtol=1e-15, atol=0)


def test_log_axis_is_geometric():
    (f,) = parse(
        {
            "sweep": {"f": {"start": 2.0, "stop": 32.0, "num": 5, "spacing": "log"}, "a": None},
            "study": {"observables": ["thresholds"]},
        }
    ).axes
    assert_allclose(f.values, [2.0, 4.0, 8.0, 16.0, 32.0], rtol=1e-14, atol=0)


# --------------------------------------------------------------------------- swept structure


Q_VALUES = [5.0, 17.5, 40.0]


@pytest.mark.parametrize("first", [True, False], ids=["declared-first", "declared-last"])
def test_swept_q_is_an_axis_before_f_and_a(first):
    tables = copy.deepcopy(MINIMAL)
    del tables["structure"]["Q"]
    q = {"values": Q_VALUES}
    tables["sweep"] = {"Q": q, **tables["sweep"]} if first else {**tables["sweep"], "Q": q}
    text = render(tables)
    assert (text.index("Q =") < text.index("f =")) is first
    spec = parse_spec(text, SPEC_PATH)
    assert axis_names(spec) == ["Q", "f", "a"]
    assert [axis.name for axis in spec.structure_axes] == ["Q"]
    assert "Q" not in spec.fixed
    q = spec.axis("Q")
    assert (q.units, q.long_name) == ("1", "quality factor of the plate's first mode")
    assert_allclose(q.values, Q_VALUES, rtol=0, atol=0)

    structures = list(spec.structures())
    assert [index for index, _ in structures] == [(0,), (1,), (2,)]
    for (_, structure), value in zip(structures, Q_VALUES, strict=True):
        assert structure == Structure(f0=14.44, Q=value, alpha=64.0, M=0.08, cs=0.25)


def test_swept_m_linspace_gives_one_structure_per_value():
    spec = parse({"structure": {"M": None}, "sweep": {"M": {"start": 0.02, "stop": 0.2, "num": 4}}})
    assert axis_names(spec) == ["M", "f", "a"]
    expected = np.linspace(0.02, 0.2, 4)
    assert_allclose(spec.axis("M").values, expected, rtol=1e-15, atol=0)
    ms = [s.M for _, s in spec.structures()]
    assert_allclose(ms, expected, rtol=1e-15, atol=0)
    assert all(s.Q == 17.5 and s.cs == 0.25 for _, s in spec.structures())


def test_two_swept_structure_parameters_give_their_product_in_declared_order():
    spec = parse(
        {
            "structure": {"Q": None, "alpha": None},
            "sweep": {"alpha": {"values": [30.0, 64.0]}, "Q": {"values": Q_VALUES}},
        }
    )
    assert axis_names(spec) == ["alpha", "Q", "f", "a"]
    got = [(index, s.alpha, s.Q) for index, s in spec.structures()]
    assert got == [
        ((i, j), alpha, q) for i, alpha in enumerate([30.0, 64.0]) for j, q in enumerate(Q_VALUES)
    ]
    assert spec.structure_at((1, 2)) == Structure(f0=14.44, Q=40.0, alpha=64.0, M=0.08, cs=0.25)


# --------------------------------------------------------------------------- masses


@pytest.mark.parametrize(
    ("m1_line", "m1"),
    [("m1_fraction = 0.08", M1_FRACTION * M0), ("m1 = 6.56e-4", 6.56e-4)],
    ids=["m1_fraction", "m1"],
)
def test_mass_ratio_study_in_the_papers_terms(m1_line, m1):
    spec = parse_spec(MASS_STUDY_TEXT.format(m1_line=m1_line), SPEC_PATH)

    assert spec.mass == MassModel(m0=M0, m1=m1)
    assert "M" not in spec.fixed
    assert axis_names(spec) == ["m_add", "f", "a"]
    m_add = spec.axis("m_add")
    assert m_add.units == "kg"
    assert_allclose(m_add.values, M_ADD, rtol=0, atol=0)

    structures = list(spec.structures())
    assert [index for index, _ in structures] == [(i,) for i in range(len(M_ADD))]
    expected = [M1_FRACTION * M0 / (M0 + added) for added in M_ADD]
    assert_allclose([s.M for _, s in structures], expected, rtol=1e-15, atol=0)
    assert structures[0][1].M == pytest.approx(0.08, rel=1e-15)


def test_fixed_added_mass_sets_the_mass_ratio():
    spec = parse(_mass(m0=M0, m1_fraction=M1_FRACTION, m_add=3.8e-3))
    assert spec.fixed["m_add"] == 3.8e-3
    ((index, structure),) = spec.structures()
    assert index == ()
    assert structure.M == pytest.approx(M1_FRACTION * M0 / (M0 + 3.8e-3), rel=1e-15)


def test_mass_without_added_mass_gives_m1_over_m0():
    spec = parse({"structure": {"M": None, "mass": {"m0": 2.0, "m1": 0.5}}})
    ((_, structure),) = spec.structures()
    assert structure.M == 0.25


# --------------------------------------------------------------------------- canonical hash


REFORMATTED_TEXT = """\
# The same study as MINIMAL_TEXT, written differently.
[sweep]
f = {num = 401, stop = 20.0, start = 10.0}   # Hz
a = {   stop = 12,   start = 0,  num = 241   }

[structure]
cs    = 0.25
M     = 8e-2
alpha = 64
Q     = 1.75e1   # quality factor
f0    = 14.44

[study]
observables = [ "velocity",
                "thresholds" ]   # order does not matter
name = 'regime-map'
title = "A title is not part of the study"
description = "nor is the description"

[solver]
max_events = 10_000          # the defaults, written out
max_map_iterations = 5000
chunk_points = 4096          # how the work is cut, not what is computed
"""


def test_sha256_is_a_hex_digest_of_the_canonical_form():
    spec = parse_spec(MINIMAL_TEXT)
    assert len(spec.sha256) == 64
    int(spec.sha256, 16)
    json.dumps(spec.canonical)  # plain JSON data


def test_sha256_ignores_comments_whitespace_key_order_and_number_spelling():
    assert parse_spec(REFORMATTED_TEXT).sha256 == parse_spec(MINIMAL_TEXT).sha256


def test_sha256_ignores_the_path_and_the_verbatim_text():
    assert parse_spec(MINIMAL_TEXT, "a.toml").sha256 == parse_spec(
        "# comment\n" + MINIMAL_TEXT, "b/c.toml"
    ).sha256


@pytest.mark.parametrize(
    ("linspace", "values"),
    [
        ({"start": 0, "stop": 1, "num": 3}, [0.0, 0.5, 1.0]),
        ({"start": 0.0, "stop": 12.0, "num": 241}, np.linspace(0.0, 12.0, 241).tolist()),
        ({"start": 1.0, "stop": 100.0, "num": 3, "spacing": "log"}, [1.0, 10.0, 100.0]),
    ],
    ids=["0-1-3", "minimal-a", "log"],
)
def test_sha256_is_the_same_for_a_range_and_its_explicit_values(linspace, values):
    by_range = parse({"sweep": {"a": linspace}})
    by_values = parse({"sweep": {"a": {"values": values}}})
    assert_allclose(by_range.axis("a").values, values, rtol=1e-15, atol=0)
    assert by_range.sha256 == by_values.sha256


@pytest.mark.parametrize(
    "changes",
    [
        pytest.param({"structure": {"Q": 17.6}}, id="Q"),
        pytest.param({"structure": {"f0": 14.440000000000001}}, id="f0-one-ulp"),
        pytest.param({"structure": {"ck": 0.2}}, id="ck-added"),
        pytest.param({"sweep": {"f": {"start": 10.0, "stop": 20.0, "num": 402}}}, id="f-num"),
        pytest.param({"sweep": {"a": {"start": 0.0, "stop": 12.5, "num": 241}}}, id="a-stop"),
        pytest.param(
            {"sweep": {"a": {"start": 0.05, "stop": 12.0, "num": 241, "spacing": "log"}}},
            id="a-spacing",
        ),
        pytest.param({"study": {"observables": ["thresholds"]}}, id="fewer-observables"),
        pytest.param(
            {"study": {"observables": ["thresholds", "lift_off", "velocity"]}},
            id="more-observables",
        ),
        pytest.param({"study": {"name": "regime-map-2"}}, id="name"),
        pytest.param({"solver": {"max_events": 10_001}}, id="max_events"),
        pytest.param({"solver": {"max_map_iterations": 4_999}}, id="max_map_iterations"),
        pytest.param(
            {"structure": {"M": None, "mass": {"m0": 1.0, "m1": 0.08}}}, id="mass-instead-of-M"
        ),
    ],
)
def test_sha256_changes_with_what_is_computed(changes):
    assert parse(changes).sha256 != parse_spec(MINIMAL_TEXT).sha256


def test_sha256_distinguishes_the_order_of_structure_axes():
    q_then_m = parse(
        {"structure": {"Q": None, "M": None},
         "sweep": {"Q": {"values": [10.0, 20.0]}, "M": {"values": [0.05, 0.1]}}}
    )
    m_then_q = parse(
        {"structure": {"Q": None, "M": None},
         "sweep": {"M": {"values": [0.05, 0.1]}, "Q": {"values": [10.0, 20.0]}}}
    )
    assert axis_names(q_then_m) != axis_names(m_then_q)
    assert q_then_m.sha256 != m_then_q.sha256


# --------------------------------------------------------------------------- refusals


@pytest.fixture
def no_computation(monkeypatch):
    """Any call into the physics or the solver while a spec is checked fails the test."""

    def forbidden(*args, **kwargs):
        raise AssertionError("computation started while checking a study spec")

    for module, names in [
        (study.solvers.exact, ["steady_state", "steady_velocity"]),
        (study.model, ["thresholds", "lift_off_acceleration"]),
        (study.model.forces, ["thresholds", "lift_off_acceleration", "force_amplitudes"]),
        (study.studies.observables, ["steady_state", "thresholds", "lift_off_acceleration",
                             "integrated_steady_state"]),
        (study.studies.sweep, ["compute_task"]),
    ]:
        for name in names:
            monkeypatch.setattr(module, name, forbidden)


def test_spec_error_is_a_value_error():
    assert issubclass(SpecError, ValueError)


def _mass(**keys: Any) -> dict[str, Any]:
    """Changes replacing M with a ``mass`` table."""
    return {"structure": {"M": None, "mass": keys}}


# The observables in their declared order (study.studies.observables' registry).
_OBS_ALLOWED = ", ".join(repr(name) for name in study.studies.observables.OBSERVABLES)
# The [solver] keys, from the spec schema the package exports.
_SOLVER_KEYS = ", ".join(sorted(
    study.studies.schema.spec_schema()["properties"]["solver"]["properties"]))
_FORMS = "allowed forms: { start = x, stop = y, num = n }"

REFUSALS = [
    # unknown tables and keys: the message lists what is allowed
    pytest.param(
        {"output": {"file": "x.nc"}},
        ["top level", "'output'", "allowed keys: basins, solver, structure, study, sweep"],
        id="unknown-table",
    ),
    pytest.param(
        {"study": {"nme": "x"}},
        ["[study]", "unknown key 'nme'", "allowed keys: description, name, observables, title"],
        id="unknown-key-study",
    ),
    pytest.param(
        {"structure": {"colour": 1.0}},
        ["[structure]", "unknown key 'colour'", "allowed keys: M, Q, alpha, ck, cs, f0, g, mass"],
        id="unknown-key-structure",
    ),
    pytest.param(
        {"structure": {"f0": None, "fo": 14.44}},
        ["[structure]", "unknown key 'fo'", "allowed keys:", "f0"],
        id="typo-fo",
    ),
    pytest.param(
        {"sweep": {"b": {"values": [1.0]}}},
        ["[sweep]", "unknown key 'b'", "allowed keys: M, Q, a, alpha, ck, cs, f, f0, g, m_add"],
        id="unknown-key-sweep",
    ),
    pytest.param(
        {"solver": {"max_event": 10}},
        ["[solver]", "unknown key 'max_event'", f"allowed keys: {_SOLVER_KEYS}",
         "max_events"],
        id="unknown-key-solver",
    ),
    pytest.param(
        _mass(m0=M0, m1=6.56e-4, madd=1e-3),
        ["[structure] mass", "unknown key 'madd'", "allowed keys: m0, m1, m1_fraction, m_add"],
        id="unknown-key-mass",
    ),
    pytest.param(
        {"study": None}, ["top level", "'study' is a required property"], id="no-study-table"
    ),
    pytest.param(
        {"sweep": None}, ["top level", "'sweep' is a required property"], id="no-sweep-table"
    ),
    # wrong types
    pytest.param(
        {"structure": {"Q": "17.5"}},
        ["[structure] Q", "'17.5'", "wrong type", "expected number"],
        id="string-for-number",
    ),
    pytest.param(
        {"structure": {"cs": True}},
        ["[structure] cs", "wrong type", "expected number"],
        id="bool-for-number",
    ),
    pytest.param(
        {"sweep": {"a": {"start": 0.0, "stop": 12.0, "num": 240.5}}},
        ["[sweep] a", "240.5", _FORMS],
        id="fractional-num",
    ),
    pytest.param(
        {"sweep": {"a": 3.0}}, ["[sweep] a", "3.0", _FORMS], id="axis-not-a-table"
    ),
    pytest.param(
        {"sweep": {"a": {"values": ["1.0"]}}}, ["[sweep] a", _FORMS], id="string-in-values"
    ),
    pytest.param(
        {"solver": {"max_events": 10.0}},
        ["[solver] max_events: 10.0 has the wrong type; expected integer"],
        id="float-max_events",
    ),
    pytest.param(
        {"study": {"name": 7}}, ["[study] name", "wrong type", "string"], id="name-not-string"
    ),
    # out of range
    pytest.param({"structure": {"Q": -1}}, ["[structure] Q = -1", "allowed: >= 0.01"], id="Q-neg"),
    pytest.param({"structure": {"Q": 0}}, ["[structure] Q = 0", "allowed: >= 0.01"], id="Q-zero"),
    pytest.param(
        {"structure": {"f0": 0.0}}, ["[structure] f0 = 0.0", "allowed: > 0"], id="f0-zero"
    ),
    pytest.param(
        {"structure": {"alpha": 90}},
        ["[structure] alpha = 90", "allowed: > -90 and < 90"],
        id="alpha-90",
    ),
    pytest.param(
        {"structure": {"alpha": -90.0}},
        ["[structure] alpha = -90.0", "allowed: > -90 and < 90"],
        id="alpha-minus-90",
    ),
    pytest.param(
        {"structure": {"M": 1.5}}, ["[structure] M = 1.5", "allowed: > 0 and <= 1"], id="M-1.5"
    ),
    pytest.param(
        {"structure": {"M": 0}}, ["[structure] M = 0", "allowed: > 0 and <= 1"], id="M-zero"
    ),
    pytest.param({"structure": {"cs": 0}}, ["[structure] cs = 0", "allowed: >= 1e-06"],
                 id="cs-zero"),
    pytest.param({"structure": {"g": -9.8}}, ["[structure] g = -9.8", "> 0"], id="g-neg"),
    pytest.param(
        {"structure": {"ck": 0.3}},
        ["[structure]", "'ck' = 0.3", "1e-6 <= ck <= cs (cs = 0.25)"],
        id="ck-above-cs",
    ),
    pytest.param(
        {"structure": {"Q": math.nan}}, ["[structure] Q = nan", "finite"], id="Q-nan"
    ),
    pytest.param(
        {"sweep": {"a": {"start": 0.0, "stop": 12.0, "num": -1}}},
        ["[sweep] a", _FORMS],
        id="num-neg",
    ),
    pytest.param(
        {"sweep": {"a": {"start": 0.0, "stop": 12.0, "num": 0}}},
        ["[sweep] a", _FORMS],
        id="num-zero",
    ),
    pytest.param(
        {"solver": {"max_events": 0}}, ["[solver] max_events = 0", "allowed: >= 1"],
        id="max_events-zero",
    ),
    pytest.param(
        {"solver": {"max_map_iterations": -5}},
        ["[solver] max_map_iterations = -5", "allowed: >= 1"],
        id="max_map_iterations-neg",
    ),
    pytest.param(
        {"solver": {"chunk_points": 0}}, ["[solver] chunk_points = 0", "allowed: >= 1"],
        id="chunk_points-zero",
    ),
    pytest.param(
        {"sweep": {"f": {"values": [0.0, 10.0]}}}, ["[sweep] f", "> 0 Hz"], id="f-zero"
    ),
    pytest.param(
        {"sweep": {"a": {"values": [-1.0, 1.0]}}}, ["[sweep] a", ">= 0 m s-2"], id="a-neg"
    ),
    # axis forms
    pytest.param(
        {"sweep": {"a": {"values": []}}}, ["[sweep] a", "{'values': []}", _FORMS], id="empty-axis"
    ),
    pytest.param(
        {"sweep": {"a": {"start": 0.0, "stop": 12.0}}}, ["[sweep] a", _FORMS], id="missing-num"
    ),
    pytest.param(
        {"sweep": {"a": {"start": 0.0, "stop": 12.0, "num": 5, "spacing": "geom"}}},
        ["[sweep] a", "'geom'", 'spacing = "linear" | "log"'],
        id="unknown-spacing",
    ),
    pytest.param(
        {"sweep": {"a": {"values": [1.0, 2.0], "num": 2}}},
        ["[sweep] a", _FORMS],
        id="values-and-num",
    ),
    pytest.param(
        {"sweep": {"a": {"start": 0.0, "stop": 12.0, "num": 5, "spacing": "log"}}},
        ["[sweep] a", "log spacing needs start > 0 and stop > 0"],
        id="log-start-zero",
    ),
    pytest.param(
        {"sweep": {"f": {"start": 10.0, "stop": -20.0, "num": 5, "spacing": "log"}}},
        ["[sweep] f", "log spacing needs start > 0 and stop > 0"],
        id="log-stop-neg",
    ),
    pytest.param(
        {"sweep": {"a": {"values": [1.0, 2.0, 1.0]}}},
        ["[sweep] a", "values must be distinct"],
        id="duplicate-values",
    ),
    pytest.param(
        {"sweep": {"a": {"start": 3.0, "stop": 3.0, "num": 4}}},
        ["[sweep] a", "values must be distinct"],
        id="duplicate-range",
    ),
    pytest.param(
        {"sweep": {"a": {"values": [0.0, math.nan]}}},
        ["[sweep] a.values[1] = nan", "finite"],
        id="nan-value",
    ),
    # structure parameters: where they are given
    pytest.param(
        {"sweep": {"Q": {"values": [10.0, 20.0]}}},
        ["Q both fixed in [structure] and swept in [sweep]", "one place"],
        id="fixed-and-swept",
    ),
    pytest.param(
        {"structure": {"mass": {"m0": M0, "m1": 6.56e-4}}},
        ["[structure.mass]", "do not also give M"],
        id="M-and-mass",
    ),
    pytest.param(
        {"structure": {"M": None, "mass": {"m0": M0, "m1": 6.56e-4}},
         "sweep": {"M": {"values": [0.05, 0.1]}}},
        ["[structure.mass]", "do not also give M"],
        id="M-swept-and-mass",
    ),
    pytest.param(
        {"sweep": {"m_add": {"values": [0.0, 1e-3]}}},
        ["[sweep] m_add", "needs [structure.mass]"],
        id="m_add-without-mass",
    ),
    pytest.param(
        {**_mass(m0=M0, m1=6.56e-4), "sweep": {"m_add": {"values": [-1e-3, 1e-3]}}},
        ["[sweep] m_add", ">= 0 kg"],
        id="m_add-neg",
    ),
    pytest.param(
        _mass(m0=M0, m1=6.56e-4, m_add=-1e-3),
        ["[structure] mass.m_add = -0.001", "allowed: >= 0"],
        id="fixed-m_add-neg",
    ),
    pytest.param(
        _mass(m0=M0, m1=6.56e-4, m1_fraction=M1_FRACTION),
        ["[structure] mass", "does not match any allowed form"],
        id="m1-and-m1_fraction",
    ),
    pytest.param(
        _mass(m0=M0), ["[structure] mass", "does not match any allowed form"], id="no-m1"
    ),
    pytest.param(
        _mass(m0=0.0, m1=6.56e-4), ["[structure] mass.m0 = 0.0", "allowed: > 0"], id="m0-zero"
    ),
    pytest.param(
        _mass(m0=1.0, m1=2.0),
        ["invalid structure at [structure]", "'M' = 2.0", "0 < M <= 1"],
        id="m1-above-m0",
    ),
    pytest.param(
        {"structure": {"Q": None}},
        ["[structure] is missing Q", "give each structure parameter"],
        id="missing-Q",
    ),
    pytest.param(
        {"structure": {"Q": None, "cs": None}}, ["[structure] is missing Q, cs"], id="missing-Q-cs"
    ),
    pytest.param(
        {"structure": {"M": None}}, ["[structure] is missing M"], id="missing-M"
    ),
    pytest.param(
        {"sweep": {"f": None}}, ["[sweep] needs the drive frequency f"], id="missing-f"
    ),
    pytest.param(
        {"sweep": {"f": None, "a": None}}, ["[sweep]", "non-empty"], id="empty-sweep"
    ),
    pytest.param(
        {"sweep": {"a": None}},
        ["[sweep] needs the drive acceleration a", "velocity"],
        id="velocity-without-a",
    ),
    pytest.param(
        {"sweep": {"a": None}, "study": {"observables": ["thresholds", "diagnostics"]}},
        ["[sweep] needs the drive acceleration a", "diagnostics"],
        id="diagnostics-without-a",
    ),
    # invalid swept structures: the message names the parameter and the value
    pytest.param(
        {"sweep": {"ck": {"values": [0.1, 0.3]}}},
        ["invalid structure at [sweep] point ck = 0.3", "'ck' = 0.3", "1e-6 <= ck <= cs"],
        id="ck-swept-above-cs",
    ),
    pytest.param(
        {"structure": {"Q": None}, "sweep": {"Q": {"values": [10.0, -1.0]}}},
        ["invalid structure at [sweep] point Q = -1.0", "'Q' = -1.0", "0.01 <= Q <= 1e6"],
        id="Q-swept-negative",
    ),
    pytest.param(
        {"structure": {"alpha": None}, "sweep": {"alpha": {"start": 0.0, "stop": 90.0, "num": 4}}},
        ["invalid structure at [sweep] point alpha = 90.0", "-90 < alpha < 90"],
        id="alpha-swept-to-90",
    ),
    pytest.param(
        {"structure": {"Q": None, "M": None},
         "sweep": {"Q": {"values": [10.0]}, "M": {"values": [0.5, 1.5]}}},
        ["[sweep] point Q = 10.0, M = 1.5", "'M' = 1.5"],
        id="two-axes-names-both",
    ),
    # observables and name
    pytest.param(
        {"study": {"observables": ["thresholds", "speed"]}},
        ["[study] observables[1]", "'speed'", f"allowed: {_OBS_ALLOWED}"],
        id="unknown-observable",
    ),
    pytest.param(
        {"study": {"observables": []}}, ["[study] observables", "non-empty"], id="no-observables"
    ),
    pytest.param(
        {"study": {"observables": ["velocity", "velocity"]}},
        ["[study] observables", "non-unique"],
        id="repeated-observable",
    ),
    pytest.param(
        {"study": {"name": "regime map"}},
        ["[study] name", "'regime map'", "^[A-Za-z0-9][A-Za-z0-9_.-]*$"],
        id="name-with-space",
    ),
    pytest.param(
        {"study": {"name": "maps/regime"}},
        ["[study] name", "'maps/regime'", "^[A-Za-z0-9][A-Za-z0-9_.-]*$"],
        id="name-with-slash",
    ),
    pytest.param({"study": {"name": ""}}, ["[study] name", "''"], id="empty-name"),
    # not TOML at all
    pytest.param("[study\nname = 'x'\n", ["not valid TOML", "line 1"], id="not-toml"),
    pytest.param(
        MINIMAL_TEXT.replace("Q = 17.5\n", "Q = 17.5\nQ = 18.0\n"),
        ["not valid TOML", "line 8"],
        id="toml-duplicate-key",
    ),
]


@pytest.mark.usefixtures("no_computation")
@pytest.mark.parametrize(("changes", "fragments"), REFUSALS)
def test_refusal_names_file_key_and_what_is_allowed(changes, fragments):
    text = changes if isinstance(changes, str) else spec_text(changes)
    with pytest.raises(SpecError) as excinfo:
        parse_spec(text, SPEC_PATH)
    message = str(excinfo.value)
    assert message.startswith(f"{SPEC_PATH}: ")
    for fragment in fragments:
        assert fragment in message


def test_several_schema_violations_are_reported_together():
    with pytest.raises(SpecError) as excinfo:
        parse({"structure": {"Q": -1, "cs": "x"}, "solver": {"max_events": 0}})
    message = str(excinfo.value)
    assert "[structure] Q = -1" in message
    assert "[structure] cs: 'x' has the wrong type" in message
    assert "[solver] max_events = 0" in message


@pytest.mark.usefixtures("no_computation")
def test_float_num_is_refused():
    with pytest.raises(SpecError, match=r"\[sweep\] a"):
        parse({"sweep": {"a": {"start": 0.0, "stop": 12.0, "num": 241.0}}})


@pytest.mark.usefixtures("no_computation")
def test_m_add_both_fixed_and_swept_is_refused():
    with pytest.raises(SpecError, match="m_add"):
        parse(
            {
                **_mass(m0=M0, m1_fraction=M1_FRACTION, m_add=1e-3),
                "sweep": {"m_add": {"values": [0.0, 2e-3]}},
            }
        )


@pytest.mark.usefixtures("no_computation")
def test_mass_table_without_m1_says_m1_or_m1_fraction():
    with pytest.raises(SpecError) as excinfo:
        parse(_mass(m0=M0))
    message = str(excinfo.value)
    assert "[structure] mass" in message
    assert "m1_fraction" in message


@pytest.mark.parametrize("spacing", ["linear", "log"])
def test_infinite_range_is_refused_without_numpy_warnings(spacing):
    with pytest.raises(SpecError, match="finite"):
        parse({"sweep": {"f": {"start": 10.0, "stop": math.inf, "num": 3, "spacing": spacing}}})


# --------------------------------------------------------------------------- load_spec


def test_load_spec_matches_parse_spec_and_keeps_text_and_path(tmp_path):
    path = tmp_path / "regime-map.toml"
    text = "# leading comment\n" + MINIMAL_TEXT
    path.write_text(text)

    loaded = load_spec(path)
    parsed = parse_spec(text, str(path))
    assert loaded.text == text
    assert loaded.path == str(path)
    assert loaded.canonical == parsed.canonical
    assert loaded.sha256 == parsed.sha256
    for name in ("name", "title", "observables", "fixed", "mass", "solver", "chunk_points"):
        assert getattr(loaded, name) == getattr(parsed, name)
    assert axis_names(loaded) == axis_names(parsed)
    for mine, theirs in zip(loaded.axes, parsed.axes, strict=True):
        np.testing.assert_array_equal(mine.values, theirs.values)
    assert load_spec(str(path)).sha256 == loaded.sha256


@pytest.mark.usefixtures("no_computation")
def test_load_spec_of_a_missing_file_names_the_path(tmp_path):
    path = tmp_path / "nowhere" / "missing.toml"
    with pytest.raises(SpecError) as excinfo:
        load_spec(path)
    message = str(excinfo.value)
    assert message.startswith(f"{path}: ")
    assert "cannot read the study spec" in message


def test_load_spec_of_a_directory_is_refused(tmp_path):
    with pytest.raises(SpecError, match="cannot read the study spec"):
        load_spec(tmp_path)


def test_load_spec_refusal_names_the_file(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(MINIMAL_TEXT.replace("Q = 17.5", "Q = -1"))
    with pytest.raises(SpecError) as excinfo:
        load_spec(path)
    assert str(excinfo.value).startswith(f"{path}: ")
    assert "[structure] Q = -1" in str(excinfo.value)


def test_load_spec_of_a_non_utf8_file_is_a_spec_error(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(MINIMAL_TEXT.replace("regime-map", "r\xe9gime").encode("latin-1"))
    with pytest.raises(SpecError) as excinfo:
        load_spec(path)
    assert str(excinfo.value).startswith(f"{path}: ")


def test_load_spec_keeps_crlf_text_verbatim(tmp_path):
    path = tmp_path / "crlf.toml"
    text = MINIMAL_TEXT.replace("\n", "\r\n")
    path.write_bytes(text.encode())
    assert load_spec(path).text == text


# --------------------------------------------------------------------------- needs_solver


@pytest.mark.parametrize(
    ("observables", "needs_solver"),
    [
        (["thresholds"], False),
        (["lift_off"], False),
        (["thresholds", "lift_off"], False),
        (["velocity"], True),
        (["thresholds", "velocity"], True),
        (["diagnostics"], True),
    ],
)
def test_needs_solver_follows_the_observables(observables, needs_solver):
    assert parse({"study": {"observables": observables}}).needs_solver is needs_solver


def test_thresholds_only_spec_without_a_is_accepted():
    spec = parse({"study": {"observables": ["thresholds"]}, "sweep": {"a": None}})
    assert axis_names(spec) == ["f"]
    assert spec.axis("a") is None
    assert spec.needs_solver is False
    assert spec.observables == ("thresholds",)


def test_sha256_counts_defaults_written_out_as_the_same_study():
    explicit = MINIMAL_TEXT.replace("cs = 0.25", "cs = 0.25\nck = 0.25\ng = 9.8")
    assert explicit != MINIMAL_TEXT
    assert parse_spec(explicit).sha256 == parse_spec(MINIMAL_TEXT).sha256
    other = MINIMAL_TEXT.replace("cs = 0.25", "cs = 0.25\nck = 0.2")
    assert parse_spec(other).sha256 != parse_spec(MINIMAL_TEXT).sha256
