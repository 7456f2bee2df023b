"""``[solver] flight`` in specs, maps and frontiers: the key, its refusals, what a
study with flight writes, and that studies without it keep every byte they had."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import study
from study.model.contact import LAWS
from study.model.status import Status
from study.solvers.settings import SolverSettings
from study.studies.layout import data_variables, method_of, observables_by_grid
from study.studies.maps import map_spec_text
from study.studies.observables import OBSERVABLES, Method, variables_of
from study.studies.spec import SPEC_SCHEMA_PATH, SpecError, load_spec, parse_spec
from study.studies.variables import VARIABLES

REPO = Path(__file__).resolve().parents[2]
FLIGHT_VARIABLES = ("airborne_fraction", "largest_hop", "impacts_per_period")

BASE = """\
[study]
name = "flight-under-test"
observables = {observables}

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
cs = 0.25
{structure}

[sweep]
{sweep}
f = {{ start = 13.0, stop = 16.0, num = 4 }}
a = {{ start = 6.0, stop = 9.0, num = 3 }}

[solver]
{solver}
"""
PATH = "workflows/flight-under-test.toml"


def parse(solver: str, *, structure: str = "M = 0.08", sweep: str = "",
          observables: str = '["velocity", "diagnostics"]'):
    return parse_spec(BASE.format(solver=solver, structure=structure, sweep=sweep,
                                  observables=observables), PATH)


def test_flight_is_off_by_default_and_left_out_of_the_fingerprint():
    spec = parse('coupling = "two-way"')
    assert spec.flight is False and spec.lift_off == "stop"
    assert "flight" not in spec.canonical["solver"]
    assert "flight" not in method_of(spec).canonical()
    # Spelled out at its default it is the same study.
    assert parse('coupling = "two-way"\nflight = false').sha256 == spec.sha256


def test_flight_changes_the_fingerprint_and_the_cache_keys():
    off = parse('coupling = "two-way"')
    on = parse('coupling = "two-way"\nflight = true')
    assert on.flight is True and on.lift_off == "flight"
    assert on.canonical["solver"]["flight"] is True
    assert on.sha256 != off.sha256
    assert method_of(on).canonical() == {**method_of(off).canonical(), "flight": True}


def test_the_schema_key_is_generated_from_the_lift_off_laws():
    schema = json.loads(SPEC_SCHEMA_PATH.read_text(encoding="utf-8"))
    key = schema["properties"]["solver"]["properties"]["flight"]
    assert key["type"] == "boolean" and key["default"] is False
    assert LAWS["lift_off"]["flight"].description in key["description"]
    assert LAWS["lift_off"]["stop"].description in key["description"]


def test_a_flight_that_is_not_a_boolean_is_refused_by_the_schema():
    with pytest.raises(SpecError,
                       match=r"(?s)flight-under-test\.toml.*\[solver\] flight.*boolean"):
        parse('coupling = "two-way"\nflight = "yes"')


def test_flight_with_one_way_coupling_is_refused_with_the_reason():
    with pytest.raises(SpecError) as err:
        parse("flight = true")
    message = str(err.value)
    for word in (PATH, "[solver] flight = true", 'coupling = "two-way"',
                 'coupling = "one-way"', "table alone", "flight = false"):
        assert word in message


def test_flight_with_a_swept_mass_ratio_of_one_is_refused_before_any_work():
    with pytest.raises(SpecError) as err:
        parse('coupling = "two-way"\nflight = true', structure="",
              sweep="M = { values = [0.5, 0.99, 1.0] }")
    message = str(err.value)
    for word in (PATH, "M = 1.0", "[sweep] point M = 1.0", "flight = true", "M < 1",
                 "massless base"):
        assert word in message
    # Up to 0.99 is accepted, and M = 1 without flight too.
    parse('coupling = "two-way"\nflight = true', structure="",
          sweep="M = { values = [0.5, 0.99] }")
    parse('coupling = "two-way"', structure="", sweep="M = { values = [0.5, 1.0] }")


def test_flight_with_a_fixed_mass_ratio_of_one_is_refused():
    with pytest.raises(SpecError, match=r"M = 1\.0 at \[structure\].*flight needs M < 1"):
        parse('coupling = "two-way"\nflight = true', structure="M = 1.0")


def test_flight_with_masses_giving_a_ratio_of_one_is_refused():
    with pytest.raises(SpecError, match=r"\[sweep\] point m_add = 0\.0.*flight needs M < 1"):
        parse('coupling = "two-way"\nflight = true',
              structure="[structure.mass]\nm0 = 0.01\nm1 = 0.01",
              sweep="m_add = { values = [0.0, 0.01] }")


def test_with_flight_the_velocity_observable_writes_three_more_variables():
    assert set(FLIGHT_VARIABLES) <= {v.name for v in variables_of(("velocity",), True)}
    assert not set(FLIGHT_VARIABLES) & {v.name for v in variables_of(("velocity",))}
    # Required by another observable, velocity brings them along.
    assert set(FLIGHT_VARIABLES) <= {v.name for v in variables_of(("floquet",), True)}
    assert OBSERVABLES["velocity"].flight_variables == FLIGHT_VARIABLES
    spec = parse('coupling = "two-way"\nflight = true')
    _, points, _ = observables_by_grid(spec)
    written = [v.name for v in data_variables(spec, points)]
    assert written[:5] == ["velocity", "status", *FLIGHT_VARIABLES]


@pytest.mark.parametrize("name", FLIGHT_VARIABLES)
def test_flight_variables_declare_units_and_are_nan_where_the_status_is_invalid(name):
    variable = VARIABLES[name]
    assert variable.units == ("m" if name == "largest_hop" else "1")
    assert variable.long_name and variable.dtype == "float64"
    assert variable.invalid_where == "status" and variable.zero_when_static


def test_a_study_without_flight_writes_no_flight_variable_and_says_it_stops():
    from study.studies.kind import _standard_attrs

    spec = parse('coupling = "two-way"')
    _, points, _ = observables_by_grid(spec)
    assert not set(FLIGHT_VARIABLES) & {v.name for v in data_variables(spec, points)}
    # The lift-off law is written whatever it is (issue 33: the whole method).
    assert _standard_attrs(spec)["study_lift_off"] == "stop"
    assert "study_lift_off_restitution" not in _standard_attrs(spec)
    flying = parse('coupling = "two-way"\nflight = true')
    assert _standard_attrs(flying)["study_lift_off"] == "flight"
    assert "flight" in _standard_attrs(flying)["source"]
    assert "flight" not in _standard_attrs(spec)["source"]


def test_status_flags_on_disk_come_from_the_status_enum():
    status = VARIABLES["status"]
    assert status.flags == tuple(s.name.lower() for s in Status)
    assert status.flag_values == tuple(int(s) for s in Status)
    assert dict(zip(status.flags, status.flag_values, strict=True))["bouncing"] == \
        int(Status.BOUNCING)
    assert "bouncing" in VARIABLES["status_one_way"].flags


def test_the_method_passes_flight_only_when_on():
    assert Method(coupling="two-way").flight_keyword == {}
    assert Method(coupling="two-way", flight=True).flight_keyword == {"flight": True}


def test_a_map_spec_says_flight_only_when_on():
    s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f, a = np.array([14.0]), np.array([6.0])
    args = (s, f, a, ("velocity",), "two-way", {}, SolverSettings())
    assert "flight" not in map_spec_text(*args)
    text = map_spec_text(*args, flight=True)
    assert "\nflight = true\n" in text
    assert parse_spec(text, "map").flight is True


@pytest.mark.parametrize("flight", ["yes", 1, None])
def test_compute_map_refuses_a_flight_that_is_not_a_bool(flight):
    s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    with pytest.raises(TypeError, match="flight must be True or False"):
        study.compute_map(s, [14.0], [6.0], coupling="two-way", flight=flight)


def test_compute_map_refuses_flight_with_one_way_coupling():
    s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    with pytest.raises(ValueError, match=r"flight.*needs coupling.*two-way.*table alone"):
        study.compute_map(s, [14.0], [6.0], flight=True)


def test_compute_map_refuses_flight_at_a_mass_ratio_of_one():
    s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.5, cs=0.25)
    with pytest.raises(ValueError, match=r"M = 1\.0.*flight needs M < 1"):
        study.compute_map(s, [14.0], [6.0], coupling="two-way", flight=True,
                          sweep={"M": [0.5, 1.0]})


def test_restitution_is_sweepable_and_in_the_fingerprint():
    spec = parse('coupling = "two-way"\nflight = true',
                 sweep="restitution = { values = [0.0, 0.25, 0.5, 0.75] }")
    assert spec.axes[0].name == "restitution" and spec.axes[0].units == "1"
    assert [s.restitution for _, s in spec.structures()] == [0.0, 0.25, 0.5, 0.75]
    with pytest.raises(SpecError, match=r"point restitution = 1\.5.*0 <= restitution <= 1"):
        parse('coupling = "two-way"\nflight = true',
              sweep="restitution = { values = [0.5, 1.5] }")
    plastic = parse('coupling = "two-way"\nflight = true')
    assert parse('coupling = "two-way"\nflight = true',
                 structure="M = 0.08\nrestitution = 0.5").sha256 != plastic.sha256


@pytest.mark.parametrize("path", sorted((REPO / "workflows").glob("*-flight.toml")),
                         ids=lambda p: p.stem)
def test_each_flight_workflow_is_its_two_way_workflow_with_flight(path):
    """The grid and structure of the workflow it is beside, flight on, M below 1."""
    spec = load_spec(path)
    assert spec.flight and spec.coupling == "two-way"
    stem = path.stem.removesuffix("-flight")
    sibling = REPO / "workflows" / f"{stem}-two-way.toml"
    if not sibling.exists():
        sibling = REPO / "workflows" / f"{stem}.toml"
    if not sibling.exists() and spec.protocol is not None:  # a slow sweep, of its own
        assert all(s.M < 1 for _, s in spec.structures())
        return
    if not sibling.exists() and "basins" in spec.observables:  # basins, of its own
        assert all(s.M < 1 for _, s in spec.structures())
        return
    if not sibling.exists():  # the sweep over the restitution, a study of its own
        assert [float(v) for v in spec.axis("restitution").values] == [0.0, 0.25, 0.5, 0.75]
        assert all(s.M < 1 for _, s in spec.structures())
        return
    other = load_spec(sibling)
    assert other.coupling == "two-way" and not other.flight
    assert {k: v for k, v in spec.fixed.items()} == other.fixed
    names = [axis.name for axis in spec.axes]
    assert names == [axis.name for axis in other.axes]


def test_every_flight_workflow_is_listed_in_the_makefile():
    makefile = (REPO / "Makefile").read_text(encoding="utf-8")
    for path in (REPO / "workflows").glob("*-flight.toml"):
        assert re.search(rf"results/{re.escape(path.stem)}\.nc", makefile) or \
            "$(wildcard workflows/*.toml)" in makefile


def test_without_flight_needs_flight():
    with pytest.raises(SpecError) as err:
        parse('coupling = "two-way"', observables='["velocity", "without_flight"]')
    for word in (PATH, '"without_flight"', "[solver] flight = true"):
        assert word in str(err.value)
    spec = parse('coupling = "two-way"\nflight = true',
                 observables='["velocity", "without_flight"]')
    names = {v.name for v in variables_of(spec.observables, spec.flight)}
    assert {"velocity_without_flight", "status_without_flight"} <= names
    assert VARIABLES["status_without_flight"].flags == VARIABLES["status"].flags


def test_the_without_flight_observable_refuses_a_study_that_does_not_fly():
    work = type("Work", (), {"method": Method(coupling="two-way")})()
    with pytest.raises(ValueError, match=r'observable "without_flight" needs \[solver\] '
                       r"flight = true .*got flight = false"):
        OBSERVABLES["without_flight"].compute(work)


def test_figures_draw_bouncing_velocities_and_lift_off_gaps():
    from study.figures.common import VALID

    assert Status.BOUNCING in VALID and Status.STICK_SLIP in VALID
    assert not {Status.LIFT_OFF, Status.NOT_CONVERGED, Status.FRICTION_PARADOX} & set(VALID)


def test_coupling_shares_count_bouncing_points_as_moving():
    """Four points where the one-way model moves: two-way moves by as much, reverses,
    bounces (counted as a change of more than 10 %) and lifts off."""
    import xarray as xr

    from study.analyses.coupling import coupling_effect

    dims = ("f", "a")
    v1 = np.array([[1e-3, 2e-3, 1e-3, 1e-3]])
    v2 = np.array([[1e-3, -2e-3, 5e-3, np.nan]])
    s1 = np.full((1, 4), int(Status.STICK_SLIP), dtype=np.int8)
    s2 = np.array([[Status.STICK_SLIP, Status.STICK_SLIP, Status.BOUNCING, Status.LIFT_OFF]],
                  dtype=np.int8)
    data = xr.Dataset({"velocity": (dims, v2), "status": (dims, s2),
                       "velocity_one_way": (dims, v1), "status_one_way": (dims, s1)})
    effect = coupling_effect(data)
    assert float(effect["bouncing"]) == 0.25
    assert float(effect["lifted"]) == 0.25
    assert float(effect["reversed"]) == 0.25
    assert float(effect["changed"]) == 0.5  # reversed (300 %) and bouncing (400 %)
    assert effect["bouncing"].attrs["units"] == "1"


SMALL_FLIGHT = """\
[study]
name = "small-flight"
observables = ["velocity", "floquet", "without_flight"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.6
cs = 0.25

[sweep]
f = { values = [12.0, 16.0] }
a = { values = [2.0, 9.0, 11.0] }

[solver]
coupling = "two-way"
flight = true
"""


@pytest.fixture(scope="module")
def small_flight_file(tmp_path_factory):
    from study.engine.runner import run_study

    folder = tmp_path_factory.mktemp("flight")
    (folder / "small-flight.toml").write_text(SMALL_FLIGHT)
    run_study(folder / "small-flight.toml", folder / "small-flight.nc", progress=False,
              workers=1)
    return folder / "small-flight.nc"


def test_a_study_with_flight_writes_and_validates_its_variables(small_flight_file):
    from study.engine.validation import open_result, validate_file

    assert validate_file(small_flight_file) == "study result"
    dataset = open_result(small_flight_file)
    assert dataset.attrs["study_lift_off"] == "flight"
    for name in FLIGHT_VARIABLES:
        assert dataset[name].dims == ("f", "a")
        assert dataset[name].attrs["units"] == VARIABLES[name].units
    assert dataset["floquet_multiplier"].attrs["long_name"] == \
        VARIABLES["floquet_multiplier"].flight_long_name
    # Below lift-off the two runs are the same computation: the same numbers.
    contact = dataset["status_without_flight"].isin(
        [int(Status.STATIC), int(Status.STICK_SLIP), int(Status.CONTINUOUS_SLIDING)])
    assert contact.any()
    assert np.array_equal(dataset["velocity"].where(contact).values,
                          dataset["velocity_without_flight"].where(contact).values,
                          equal_nan=True)


def test_a_flight_file_without_its_lift_off_attribute_is_refused(small_flight_file, tmp_path):
    import shutil

    import netCDF4

    from study.engine.validation import ResultError, validate_file

    copy = tmp_path / "tampered.nc"
    shutil.copy(small_flight_file, copy)
    with netCDF4.Dataset(copy, "a") as nc:
        nc.delncattr("study_lift_off")
    with pytest.raises(ResultError, match="study_lift_off differs from the embedded spec"):
        validate_file(copy)


def test_compute_map_with_flight_holds_the_files_values(small_flight_file):
    """The map in memory and the study file of the same spec: the same variables,
    attributes and values, bit for bit."""
    from study.engine.validation import open_result

    s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.6, cs=0.25)
    ours = study.compute_map(s, [12.0, 16.0], [2.0, 9.0, 11.0], coupling="two-way",
                             flight=True,
                             observables=["velocity", "floquet", "without_flight"])
    assert ours.attrs["study_lift_off"] == "flight"
    assert parse_spec(ours.attrs["study_spec"], "map").flight
    stored = open_result(small_flight_file)
    assert Status.BOUNCING in stored["status"].values  # the map reaches the bouncing region
    for name in ("velocity", "status", *FLIGHT_VARIABLES, "floquet_multiplier",
                 "velocity_without_flight", "status_without_flight"):
        for key in ("units", "long_name"):
            assert ours[name].attrs[key] == stored[name].attrs[key]
        np.testing.assert_array_equal(ours[name].values, stored[name].values)


def test_flight_with_the_time_integrator_is_accepted_as_the_contact_laws_declare():
    """The lift-off law 'flight' lists the integrator among its solvers: a spec may ask
    for it (the Method passes flight=True to integrated_steady_state)."""
    assert "integrator" in LAWS["lift_off"]["flight"].solvers
    spec = parse('method = "integrator"\ncoupling = "two-way"\nflight = true')
    assert spec.flight and method_of(spec).flight_keyword == {"flight": True}
    assert method_of(spec).canonical()["flight"] is True
