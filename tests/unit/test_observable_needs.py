"""What each observable needs of ``[solver]`` (method, coupling, flight), declared once
with it (:class:`study.studies.observables.Observable`) and enforced from there: by the
spec reader (every problem at once, one line each) and by the observable itself for a
direct caller. Spec parsing only: nothing is solved."""

from __future__ import annotations

import itertools
import json

import pytest

from study.model.contact import COUPLINGS
from study.model.contact import markdown_table as laws_table
from study.studies.observable_table import markdown_table as observables_table
from study.studies.observables import METHODS, OBSERVABLES, Method, Observable, unmet_needs
from study.studies.spec import SpecError, parse_spec

PATH = "specs/needs-under-test.toml"

SPEC = """\
[study]
name = "needs-under-test"
observables = {observables}

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = {{ start = 13.0, stop = 16.0, num = 3 }}
a = {{ start = 6.0, stop = 9.0, num = 2 }}

[solver]
method = "{method}"
coupling = "{coupling}"
flight = {flight}
"""


def spec_text(observables: list[str], method: str, coupling: str, flight: bool) -> str:
    return SPEC.format(observables=json.dumps(observables), method=method, coupling=coupling,
                       flight="true" if flight else "false")


def _settings_a_spec_takes() -> list[tuple[str, str, bool]]:
    """Every (method, coupling, flight) a spec of the velocity alone accepts (flight
    has needs of its own: two-way coupling)."""
    taken = []
    for method, coupling, flight in itertools.product(METHODS, COUPLINGS, (False, True)):
        try:
            parse_spec(spec_text(["velocity"], method, coupling, flight), PATH)
        except SpecError:
            continue
        taken.append((method, coupling, flight))
    return taken


SETTINGS = _settings_a_spec_takes()
NEEDY = [name for name, o in OBSERVABLES.items() if o.needs_anything]


def _applies(o: Observable, method: str, coupling: str, flight: bool) -> bool:
    """Whether ``o`` applies to a spec of these settings without a slow sweep (an
    unswept observable needs one, and so does one of the sweep's path)."""
    return (not o.unswept and not o.swept and (o.methods is None or method in o.methods)
            and (o.couplings is None or coupling in o.couplings)
            and (o.flight is None or o.flight == flight))


def _quoted(values: tuple[str, ...]) -> str:
    return " or ".join(f'"{v}"' for v in values)


def test_every_method_coupling_and_flight_a_spec_takes_is_tried():
    # The cases below cover both methods, both couplings, and flight on and off.
    assert {m for m, _, _ in SETTINGS} == set(METHODS)
    assert {c for _, c, _ in SETTINGS} == set(COUPLINGS)
    assert {f for _, _, f in SETTINGS} == {False, True}


def test_the_known_needs_are_declared():
    """The needs the solvers impose (issue 35): if one is dropped, this fails."""
    assert (OBSERVABLES["floquet"].methods, OBSERVABLES["floquet"].couplings) == (
        ("exact",), ("two-way",))
    assert OBSERVABLES["attractors"].methods == ("exact",)
    assert OBSERVABLES["attractors"].couplings is None
    assert OBSERVABLES["paper_model"].couplings == ("two-way",)
    assert OBSERVABLES["without_flight"].flight is True
    assert OBSERVABLES["unswept"].unswept and OBSERVABLES["unswept"].needs_anything
    assert OBSERVABLES["jumps"].swept and OBSERVABLES["jumps"].needs_anything
    for name in ("resonance", "thresholds", "lift_off", "velocity", "diagnostics",
                 "frontier"):
        assert not OBSERVABLES[name].needs_anything, name


@pytest.mark.parametrize(("method", "coupling", "flight"), SETTINGS,
                         ids=lambda v: {True: "flight", False: "no-flight"}.get(v, v))
@pytest.mark.parametrize("name", list(OBSERVABLES))
def test_each_declared_need_is_enforced_by_the_spec(name, method, coupling, flight):
    o = OBSERVABLES[name]
    text = spec_text(list(dict.fromkeys(["velocity", name])), method, coupling, flight)
    if _applies(o, method, coupling, flight):
        assert name in parse_spec(text, PATH).observables
        return
    with pytest.raises(SpecError) as refused:
        parse_spec(text, PATH)
    message = str(refused.value)
    # One problem: the observable's, alone on its line, naming the file and the key.
    assert "\n" not in message, message
    if o.unswept or o.swept:
        assert message.startswith(f'{PATH}: [study] observable "{name}" needs [sweep] '
                                  "protocol: "), message
        assert "got no protocol (allowed: with [sweep] protocol = " in message
        assert o.why in message
        return
    assert message.startswith(f'{PATH}: [study] observable "{name}" needs [solver] '), message
    allowed = message.split("(allowed: ", 1)[1]
    if o.methods is not None:
        assert f'method = "{method}"' in message
        assert f"method = {_quoted(o.methods)}" in allowed, message
    if o.couplings is not None:
        assert f'coupling = "{coupling}"' in message
        assert f"coupling = {_quoted(o.couplings)}" in allowed, message
    if o.flight is not None:
        assert f"flight = {'true' if o.flight else 'false'}" in allowed, message
    assert o.why in message


@pytest.mark.parametrize(
    ("name", "method", "coupling", "flight"),
    [(name, *settings) for name in NEEDY for settings in SETTINGS
     if not _applies(OBSERVABLES[name], *settings)],  # computing the others would solve
    ids=lambda v: {True: "flight", False: "no-flight"}.get(v, v))
def test_a_direct_caller_gets_the_same_refusal(name, method, coupling, flight):
    o = OBSERVABLES[name]
    # Refused before the work is touched: the work holds nothing but the method.
    work = type("Work", (), {"method": Method(method, coupling, flight=flight)})()
    with pytest.raises(ValueError) as refused:
        o.compute(work)
    assert str(refused.value) == unmet_needs((name,), method, coupling, flight)[0]
    assert f'observable "{name}"' in str(refused.value)


def test_every_unmet_need_is_reported_at_once_one_line_each():
    text = spec_text(list(OBSERVABLES), "integrator", "one-way", False)
    with pytest.raises(SpecError) as refused:
        parse_spec(text, PATH)
    lines = str(refused.value).splitlines()
    unmet = [n for n in NEEDY if not _applies(OBSERVABLES[n], "integrator", "one-way", False)]
    assert len(unmet) >= 4  # floquet, attractors, paper_model, without_flight
    assert lines[0] == f"{PATH}: {len(lines) - 1} problems, each to fix:"
    for name in unmet:
        assert sum(f'[study] observable "{name}" needs' in line for line in lines) == 1, name


def test_unmet_needs_follow_the_registry_order_and_ignore_what_applies():
    assert unmet_needs(list(OBSERVABLES), "exact", "two-way", True, protocol=True) == []
    assert [line.split('"')[1] for line in
            unmet_needs(list(OBSERVABLES), "exact", "two-way", True)] == ["unswept",
                                                                        "jumps",
                                                                        "branches"]
    names = [line.split('"')[1] for line in
             unmet_needs(list(reversed(OBSERVABLES)), "integrator", "one-way", False)]
    assert names == [n for n in OBSERVABLES if n in names]


@pytest.mark.parametrize(("changes", "fragment"), [
    ({"methods": ("exact", "rk4")}, "methods"),
    ({"couplings": ()}, "couplings"),
    ({"methods": ("exact",)}, "why"),
])
def test_a_declaration_of_unknown_needs_is_refused(changes, fragment):
    with pytest.raises(ValueError, match=fragment):
        Observable("new", "a new observable", "point", ("velocity",), lambda work: {},
                   **changes)


def test_the_docs_tables_come_from_the_declarations():
    table = observables_table()
    assert table.count("\n") == len(OBSERVABLES) + 2
    for name, o in OBSERVABLES.items():
        row = next(line for line in table.splitlines() if line.startswith(f"| `{name}` |"))
        assert all(f"`{v}`" in row for v in (*o.variables, *o.flight_variables))
        if o.needs_anything:
            assert o.needs() in row and o.why in row
    laws = laws_table()
    stribeck = next(line for line in laws.splitlines() if line.startswith("| `stribeck` |"))
    assert "| friction |" in stribeck and "`stribeck_speed` [m s-1]" in stribeck
    assert stribeck.endswith("| integrator |")
    flight = next(line for line in laws.splitlines() if line.startswith("| `flight` |"))
    assert "`restitution`" in flight and flight.endswith("| exact, integrator |")


@pytest.mark.parametrize("name", [n for n in NEEDY if OBSERVABLES[n].couplings is not None
                                  or OBSERVABLES[n].flight is not None])
def test_the_python_api_refuses_as_a_spec_does(name):
    """study.compute_map (always the exact solver) goes through the spec reader: the
    same refusal, before any solve, for a one-way study without flight, which each
    observable needing a coupling or flight does not apply to."""
    import study

    method, coupling, flight = "exact", "one-way", False
    assert not _applies(OBSERVABLES[name], method, coupling, flight), name
    structure = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    with pytest.raises(ValueError) as refused:
        study.compute_map(structure, [14.0], [6.0], observables=["velocity", name],
                          coupling=coupling, flight=flight)
    assert unmet_needs((name,), method, coupling, flight)[0] in str(refused.value)
