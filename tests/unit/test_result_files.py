"""Result files on disk: schema, CF attributes, refusals and atomic writes (study.engine.store)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import jsonschema
import netCDF4
import numpy as np
import pytest
import xarray as xr

import study
import study.engine.store
from study.engine.runner import run_study
from study.engine.store import (
    RESULT_SCHEMA_PATH,
    ResultError,
    describe,
    header,
    open_result,
    write_atomic,
)

SPEC_TEXT = """\
[study]
name = "tiny-map"
title = "A tiny regime map for the result-file tests"
observables = ["thresholds", "lift_off", "velocity", "diagnostics"]

[structure]
f0 = 14.44   # Hz
Q = 17.5
alpha = 64.0 # degree
M = 0.08
cs = 0.25

[sweep]
f = { start = 10.0, stop = 20.0, num = 7 }  # Hz
a = { start = 0.0, stop = 12.0, num = 5 }   # m s-2
"""


@pytest.fixture(scope="module")
def result_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small, complete study result, written once for the module."""
    folder = tmp_path_factory.mktemp("result")
    spec_path = folder / "tiny-map.toml"
    spec_path.write_text(SPEC_TEXT)
    output = folder / "tiny-map.nc"
    report = run_study(spec_path, output, progress=False)
    assert not report.up_to_date
    assert report.output == output
    assert output.is_file()
    assert not list(folder.glob(".tiny-map.nc.*.tmp"))
    return output


@pytest.fixture(scope="module")
def result(result_file: Path) -> xr.Dataset:
    return open_result(result_file)


@pytest.fixture
def copy_of(result_file: Path, tmp_path: Path):
    """Copy the good result file into this test's folder (to damage the copy)."""

    def copy(name: str = "copy.nc") -> Path:
        target = tmp_path / name
        shutil.copyfile(result_file, target)
        return target

    return copy


# ---------------------------------------------------------------------------
# A good file


def test_open_result_accepts_a_fresh_result(result_file: Path, result: xr.Dataset) -> None:
    assert result.attrs["study_name"] == "tiny-map"
    assert result.attrs["study_result_schema"] == "study-result-v1"
    assert dict(result.sizes) == {"f": 7, "a": 5}
    np.testing.assert_allclose(result["f"].values, np.linspace(10.0, 20.0, 7))
    np.testing.assert_allclose(result["a"].values, np.linspace(0.0, 12.0, 5))
    for name in ("a_star_plus", "a_star_minus", "lift_off_acceleration", "velocity",
                 "status", "slips_per_period", "forward_slip_fraction",
                 "backward_slip_fraction", "orbit_period", "nonconvergence"):
        assert name in result.data_vars, name
    # The grid must contain static points for the tampering test below to mean anything.
    assert np.any(result["status"].values == study.Status.STATIC)


def test_header_validates_against_the_json_schema_file(result: xr.Dataset) -> None:
    schema = json.loads(RESULT_SCHEMA_PATH.read_text())
    assert RESULT_SCHEMA_PATH.name == "study-result-v1.schema.json"
    jsonschema.Draft202012Validator.check_schema(schema)
    document = header(result)
    # header() must be plain JSON data, as a schema validator sees it.
    assert json.loads(json.dumps(document)) == document
    jsonschema.validate(document, schema, cls=jsonschema.Draft202012Validator)


def test_every_variable_and_coordinate_has_units_and_long_name(result: xr.Dataset) -> None:
    names = list(result.variables)
    assert "f" in names and "a" in names and "f0" in names and "velocity" in names
    for name in names:
        attrs = result[name].attrs
        for key in ("units", "long_name"):
            assert isinstance(attrs.get(key), str), (name, key)
            assert attrs[key].strip(), (name, key)


@pytest.mark.parametrize(
    ("variable", "enum"), [("status", study.Status), ("nonconvergence", study.NonConvergence)]
)
def test_flag_variables_follow_cf(result_file: Path, result: xr.Dataset, variable, enum) -> None:
    attrs = result[variable].attrs
    flag_values = np.asarray(attrs["flag_values"])
    assert flag_values.dtype == np.int8
    assert flag_values.tolist() == [member.value for member in enum]
    assert attrs["flag_meanings"] == " ".join(member.name.lower() for member in enum)
    assert result[variable].dtype == np.int8
    # On disk too, flag_values has the type of the variable (CF).
    with netCDF4.Dataset(result_file) as nc:
        on_disk = nc[variable].getncattr("flag_values")
        assert np.asarray(on_disk).dtype == np.int8
        assert nc[variable].dtype == np.int8


def test_global_conventions(result: xr.Dataset) -> None:
    conventions = result.attrs["Conventions"]
    assert "CF-1.11" in conventions
    assert "ACDD-1.3" in conventions


def test_provenance_is_json(result: xr.Dataset) -> None:
    provenance = json.loads(result.attrs["provenance"])
    assert provenance["result_schema"] == "study-result-v1"
    assert provenance["study"]["name"] == "tiny-map"
    assert provenance["study"]["spec_sha256"] == result.attrs["study_spec_sha256"]
    assert provenance["run"]["chunks"] >= 1


def test_result_file_permissions_follow_the_umask(result: xr.Dataset, tmp_path: Path) -> None:
    # Any user the umask lets read a file may read a result; 0600 hides it from collaborators.
    target = tmp_path / "shared.nc"
    previous = os.umask(0o022)
    try:
        write_atomic(result, target)
    finally:
        os.umask(previous)
    mode = target.stat().st_mode & 0o777
    assert mode == 0o644, oct(mode)


# ---------------------------------------------------------------------------
# Refusals, each naming the file


def _refusal(path: Path) -> str:
    with pytest.raises(ResultError) as info:
        open_result(path)
    message = str(info.value)
    assert str(path) in message
    return message


def test_missing_file(tmp_path: Path) -> None:
    message = _refusal(tmp_path / "nowhere.nc")
    assert "no such file" in message


def test_truncated_file(result_file: Path, tmp_path: Path) -> None:
    truncated = tmp_path / "truncated.nc"
    truncated.write_bytes(result_file.read_bytes()[:3000])
    message = _refusal(truncated)
    assert "not a readable netCDF file" in message


def test_text_file(tmp_path: Path) -> None:
    text = tmp_path / "notes.nc"
    text.write_text("these are my notes, not a netCDF file\n" * 20)
    message = _refusal(text)
    assert "not a readable netCDF file" in message


def test_foreign_netcdf_file(tmp_path: Path) -> None:
    foreign = tmp_path / "foreign.nc"
    xr.Dataset({"temperature": ("x", np.arange(4.0))}).to_netcdf(foreign)
    message = _refusal(foreign)
    assert "not a study result" in message


def test_outdated_file(copy_of) -> None:
    outdated = copy_of("outdated.nc")
    with netCDF4.Dataset(outdated, "a") as nc:
        nc.setncattr("study_result_schema", "study-result-v0")
    message = _refusal(outdated)
    assert "study-result-v0" in message
    assert "study-result-v1" in message
    assert "rerun" in message.lower()


def test_tampered_velocity(copy_of, result: xr.Dataset) -> None:
    tampered = copy_of("tampered.nc")
    static = np.argwhere(result["status"].values == study.Status.STATIC)
    i, j = (int(k) for k in static[0])
    with netCDF4.Dataset(tampered, "a") as nc:
        assert nc["velocity"][i, j] == 0.0
        nc["velocity"][i, j] = 1.0
    message = _refusal(tampered)
    assert "velocity" in message
    assert "static" in message


def test_velocity_where_lift_off(copy_of, result: xr.Dataset) -> None:
    tampered = copy_of("lift-off.nc")
    lift_off = np.argwhere(result["status"].values == study.Status.LIFT_OFF)
    assert lift_off.size, "the grid should reach lift-off"
    i, j = (int(k) for k in lift_off[0])
    with netCDF4.Dataset(tampered, "a") as nc:
        nc["velocity"][i, j] = 0.5
    message = _refusal(tampered)
    assert "velocity" in message
    assert "NaN" in message


def test_changed_spec_hash(copy_of, result: xr.Dataset) -> None:
    changed = copy_of("sha.nc")
    original = result.attrs["study_spec_sha256"]
    forged = ("0" if original[0] != "0" else "1") + original[1:]
    with netCDF4.Dataset(changed, "a") as nc:
        nc.setncattr("study_spec_sha256", forged)
    message = _refusal(changed)
    assert "sha256" in message


def test_missing_units(copy_of) -> None:
    damaged = copy_of("no-units.nc")
    with netCDF4.Dataset(damaged, "a") as nc:
        nc["velocity"].delncattr("units")
    message = _refusal(damaged)
    assert "units" in message
    assert "velocity" in message


def test_each_problem_is_reported_once(copy_of) -> None:
    damaged = copy_of("no-units-once.nc")
    with netCDF4.Dataset(damaged, "a") as nc:
        nc["velocity"].delncattr("units")
    problems = _refusal(damaged).splitlines()[1:]
    assert problems
    assert len(problems) == len(set(problems)), problems


def test_the_good_file_still_opens_after_the_refusals(result_file: Path) -> None:
    # The damaging tests work on copies; the module's file is untouched.
    open_result(result_file)


# ---------------------------------------------------------------------------
# Atomic writes


def _temporaries(folder: Path) -> list[Path]:
    return sorted(folder.glob(".*.tmp"))


def test_write_atomic_keeps_the_old_file_when_validation_fails(
    copy_of, result: xr.Dataset, monkeypatch: pytest.MonkeyPatch
) -> None:
    existing = copy_of("existing.nc")
    before = existing.read_bytes()

    def refuse(path):
        raise ResultError(f"{path}: refused on purpose")

    monkeypatch.setattr(study.engine.store, "seal", refuse)
    with pytest.raises(ResultError, match="refused on purpose"):
        write_atomic(result, existing)
    assert existing.read_bytes() == before
    assert _temporaries(existing.parent) == []
    assert sorted(p.name for p in existing.parent.iterdir()) == ["existing.nc"]


def test_write_atomic_refuses_an_invalid_dataset(result: xr.Dataset, tmp_path: Path) -> None:
    invalid = result.copy()
    invalid.attrs = {k: v for k, v in result.attrs.items() if k != "provenance"}
    target = tmp_path / "invalid.nc"
    with pytest.raises(ResultError, match="provenance"):
        write_atomic(invalid, target)
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []


def test_write_atomic_round_trip(result: xr.Dataset, tmp_path: Path) -> None:
    target = tmp_path / "sub" / "again.nc"
    assert write_atomic(result, target) == target
    again = open_result(target)
    xr.testing.assert_identical(again, result)
    assert _temporaries(target.parent) == []


# ---------------------------------------------------------------------------
# For people


def test_describe(result_file: Path, result: xr.Dataset) -> None:
    text = describe(result, str(result_file))
    assert str(result_file) in text
    assert "tiny-map" in text
    lines = text.splitlines()
    axis_f = next(line for line in lines if "axis" in line and " f:" in line)
    assert "Hz" in axis_f and "7 values" in axis_f
    axis_a = next(line for line in lines if "axis" in line and " a:" in line)
    assert "m s-2" in axis_a and "5 values" in axis_a
    status_line = next(line for line in lines if line.strip().startswith("status:"))
    statuses = result["status"].values
    for member in study.Status:
        count = int(np.count_nonzero(statuses == member))
        if count:
            assert f"{member.name.lower()} {count / statuses.size:.1%}" in status_line
        else:
            assert member.name.lower() not in status_line
    assert "history:" in text
