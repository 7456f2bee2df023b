"""The whole method in every result (issue 33, item 6): the solver, the coupling, the
friction law with its parameters and the lift-off law with its restitution, written by
one function (``study.studies.layout.method_attributes``) into the runner's files and
``study.compute_map``'s datasets, shown by ``study info`` and checked by validation."""

from __future__ import annotations

import shutil
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

import study
from study.cli import main
from study.engine.contact_attributes import method_summary
from study.engine.validation import ResultError, describe, read_attributes, validate_file
from study.model.contact import LAWS
from study.studies.checks import method_problems
from study.studies.layout import method_attributes, protocol_attributes
from study.studies.spec import parse_spec

STRUCTURE = """\
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = {M}
cs = 0.25
ck = {ck}
{extra}
"""

SPEC = """\
[study]
name = "{name}"
observables = ["velocity"]

{structure}
[sweep]
f = {{ values = [14.5] }}
a = {{ values = [{a}] }}

[solver]
{solver}
"""

STRIBECK_SPEED = 0.01


def spec_text(name: str = "stribeck", solver: str = "", *, M: float = 0.08, ck: float = 0.15,
              extra: str = "", a: str = "7.0", sweep: str = "") -> str:
    structure = STRUCTURE.format(M=M, ck=ck, extra=extra)
    text = SPEC.format(name=name, structure=structure, a=a, solver=solver)
    return text.replace("[solver]", f"{sweep}\n[solver]") if sweep else text


STRIBECK = spec_text(solver='method = "integrator"\n'
                     f'friction = {{ law = "stribeck", stribeck_speed = {STRIBECK_SPEED} }}')
FLIGHT = spec_text("flight", 'coupling = "two-way"\nflight = true', M=0.6, ck=0.25,
                   extra="restitution = 0.5", a="12.0")


@pytest.fixture(scope="module")
def stribeck_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("stribeck")
    spec = folder / "stribeck.toml"
    spec.write_text(STRIBECK)
    output = folder / "stribeck.nc"
    study.run(spec, output, workers=1, cache=folder / "cache", progress=False)
    return output


# ---------------------------------------------------------------------------
# What is written


def test_a_stribeck_file_records_the_law_and_its_parameters(stribeck_file: Path) -> None:
    attrs = read_attributes(stribeck_file)
    spec = parse_spec(STRIBECK, "stribeck.toml")
    assert attrs["study_solver_method"] == "integrator"
    assert attrs["study_coupling"] == "one-way"
    assert attrs["study_friction_law"] == spec.friction.law == "stribeck"
    # One float attribute per parameter the law declares, equal to the spec's value.
    with netCDF4.Dataset(stribeck_file) as nc:
        for parameter in LAWS["friction"]["stribeck"].parameters:
            value = nc.getncattr(f"study_friction_{parameter.name}")
            assert value.dtype == np.float64  # stored as a double
            assert value == spec.friction.values[parameter.name]
    assert attrs["study_friction_stribeck_speed"] == STRIBECK_SPEED
    # Always written now, also where the run stops at lift-off.
    assert attrs["study_lift_off"] == "stop"
    assert "study_lift_off_restitution" not in attrs
    assert "stribeck" in attrs["source"] and "stribeck_speed = 0.01 m s-1" in attrs["source"]
    assert "lift-off law 'stop'" in attrs["source"]
    # The summary says the whole method too.
    assert "friction law 'stribeck'" in attrs["summary"]
    validate_file(stribeck_file)


def test_study_info_shows_the_friction_law_with_its_parameters(stribeck_file: Path,
                                                               capsys) -> None:
    line = ("  method: integrator solver, one-way coupling, friction stribeck "
            "(stribeck_speed=0.01 m s-1), lift-off stop")
    assert line in describe(stribeck_file).splitlines()
    assert main(["info", str(stribeck_file)]) == 0
    assert line in capsys.readouterr().out.splitlines()


def test_compute_map_and_the_runner_write_the_same_method_attributes(tmp_path: Path) -> None:
    """With flight: the lift-off law and its restitution, in memory and on disk."""
    structure = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.6, cs=0.25,
                                restitution=0.5)
    in_memory = study.compute_map(structure, [14.5], [12.0], observables=("velocity",),
                                  coupling="two-way", flight=True, workers=1)
    spec_file = tmp_path / "map.toml"
    spec_file.write_text(in_memory.attrs["study_spec"])
    on_disk = study.run(spec_file, tmp_path / "map.nc", workers=1, cache=tmp_path / "cache",
                        progress=False)
    keys = method_attributes(parse_spec(in_memory.attrs["study_spec"], "map"))
    assert {"study_lift_off", "study_lift_off_restitution", "study_friction_law"} <= set(keys)
    assert {k: in_memory.attrs[k] for k in keys} == {k: on_disk.attrs[k] for k in keys}
    assert on_disk.attrs["study_lift_off"] == "flight"
    assert on_disk.attrs["study_lift_off_restitution"] == 0.5
    assert "restitution e = 0.5" in on_disk.attrs["source"]
    # No method attribute is written besides those (by either path).
    method_like = ("study_solver_method", "study_coupling", "study_friction", "study_lift_off")
    for dataset in (in_memory, on_disk):
        assert {k for k in dataset.attrs if k.startswith(method_like)} <= set(keys)
    assert ("  method: exact solver, two-way coupling, friction coulomb, lift-off flight, "
            "restitution e=0.5") in describe(on_disk).splitlines()
    np.testing.assert_array_equal(in_memory["velocity"].values, on_disk["velocity"].values)


def test_a_flight_spec_records_its_restitution_and_a_default_one_too() -> None:
    attrs = method_attributes(parse_spec(FLIGHT, "flight.toml"))
    assert attrs["study_lift_off"] == "flight"
    assert attrs["study_lift_off_restitution"] == 0.5
    plastic = method_attributes(parse_spec(FLIGHT.replace("restitution = 0.5", ""), "f.toml"))
    assert plastic["study_lift_off_restitution"] == 0.0
    assert "restitution e = 0.0" in plastic["source"]


def test_a_swept_restitution_is_left_to_its_coordinate() -> None:
    text = spec_text("swept", 'coupling = "two-way"\nflight = true', M=0.6, ck=0.25,
                     a="12.0", sweep="restitution = { values = [0.0, 0.5] }")
    attrs = method_attributes(parse_spec(text, "swept.toml"))
    assert attrs["study_lift_off"] == "flight"
    assert "study_lift_off_restitution" not in attrs
    assert "restitution e swept" in attrs["source"]
    assert method_summary(attrs, ("restitution", "f", "a")).endswith(
        "lift-off flight, restitution e swept")


def test_every_attribute_follows_the_spec_and_the_start_is_recorded() -> None:
    spec = parse_spec(spec_text("coulomb"), "coulomb.toml")
    attrs = method_attributes(spec)
    assert list(attrs) == ["source", "study_solver_method", "study_coupling",
                           "study_friction_law", "study_lift_off", "study_start",
                           "study_start_kind"]
    assert attrs["study_friction_law"] == "coulomb"
    assert attrs["study_lift_off"] == "stop"
    assert protocol_attributes(spec) == {"study_start": "release",
                                         "study_start_kind": "release"}
    assert method_problems(attrs, spec) == []


# ---------------------------------------------------------------------------
# Old files


def test_a_file_without_the_new_attributes_is_described_with_its_defaults() -> None:
    old = xr.Dataset(attrs={"study_solver_method": "exact", "study_coupling": "one-way"})
    line = next(x for x in describe(old, "old.nc").splitlines() if x.startswith("  method:"))
    assert line == ("  method: exact solver, one-way coupling, friction coulomb (not "
                    "recorded; the default), lift-off stop (not recorded; the default)")
    # An old flight file: the law, but not its restitution.
    assert method_summary({"study_solver_method": "exact", "study_coupling": "two-way",
                           "study_lift_off": "flight"}).endswith(
        "lift-off flight, restitution not recorded")
    assert method_summary({}) == ("solver not recorded, coupling not recorded, friction "
                                  "coulomb (not recorded; the default), lift-off stop (not "
                                  "recorded; the default)")


def test_odd_method_attributes_are_shown_as_they_are() -> None:
    line = method_summary({"study_solver_method": 3, "study_friction_law": "stribeck",
                           "study_lift_off": np.array([1, 2])})
    assert line.startswith("solver not recorded, coupling not recorded, friction stribeck "
                           "(stribeck_speed not recorded), lift-off array(")
    assert method_summary({"study_friction_law": "velvet", "study_friction_grip": 2.5}) \
        .split(", friction ")[1].startswith("velvet (grip=2.5)")


def test_missing_method_attributes_are_no_problem_but_lift_off_means_stop() -> None:
    spec = parse_spec(STRIBECK, "stribeck.toml")
    assert method_problems({}, spec) == []
    flying = parse_spec(FLIGHT, "flight.toml")
    # A file without study_lift_off has always stopped at lift-off.
    assert method_problems({}, flying) == [
        "study_lift_off differs from the embedded spec ('flight')"]


# ---------------------------------------------------------------------------
# Validation


@pytest.mark.parametrize(("name", "value", "expected"), [
    ("study_friction_law", "coulomb", "'stribeck'"),
    ("study_friction_stribeck_speed", 0.02, "0.01"),
    ("study_friction_stribeck_speed", "0.01", "0.01"),
    ("study_lift_off", "flight", "'stop'"),
    ("study_solver_method", "exact", "'integrator'"),
])
def test_an_edited_method_attribute_fails_validation_naming_it(
        stribeck_file: Path, tmp_path: Path, name: str, value: object, expected: str) -> None:
    """Global attributes are outside the content checksum: the method check catches
    the edit, and names the attribute and the embedded spec's value."""
    edited = Path(shutil.copyfile(stribeck_file, tmp_path / "edited.nc"))
    with netCDF4.Dataset(edited, "a") as nc:
        nc.setncattr(name, value)
    with pytest.raises(ResultError) as info:
        validate_file(edited)
    assert f"{name} differs from the embedded spec ({expected})" in str(info.value)
    assert "content differs" not in str(info.value)


def test_a_file_without_the_friction_attributes_is_described_not_refused_by_the_method_check(
        stribeck_file: Path, tmp_path: Path) -> None:
    """Files written before the method was recorded whole lack these attributes: the
    method check leaves them to the result schema, and info says what is missing."""
    edited = Path(shutil.copyfile(stribeck_file, tmp_path / "deleted.nc"))
    with netCDF4.Dataset(edited, "a") as nc:
        nc.delncattr("study_friction_law")
        nc.delncattr("study_friction_stribeck_speed")
    attrs = read_attributes(edited)
    assert method_problems(attrs, parse_spec(attrs["study_spec"], "embedded")) == []
    assert "friction coulomb (not recorded; the default)" in describe(edited)
