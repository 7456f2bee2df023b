"""Validation, content checksum and description of result files of every kind
(study.engine.validation)."""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Callable
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

import study.engine.validation.reading
from study.cli import main
from study.engine.validation import (
    CONTENT_ATTRIBUTE,
    ResultError,
    content_sha256,
    describe,
    open_result,
    read_attributes,
    seal,
    validate_file,
)
from study.model.status import Status
from tests.support.sealed_results import make_sealed_results, rewrite


@pytest.fixture(scope="module")
def sealed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The sealed files: studies "velocity", "thresholds", "swept-q"; scene "steering"."""
    return make_sealed_results(tmp_path_factory.mktemp("sealed"))


@pytest.fixture
def copy(sealed: dict[str, Path], tmp_path: Path) -> Callable[[str], Path]:
    def make(name: str) -> Path:
        return Path(shutil.copyfile(sealed[name], tmp_path / f"{name}.nc"))

    return make


def _refusal(path: Path) -> str:
    with pytest.raises(ResultError) as info:
        validate_file(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    return message


# ---------------------------------------------------------------------------
# Good files


@pytest.mark.parametrize("name", ["velocity", "thresholds", "swept-q", "steering"])
def test_a_sealed_file_validates_and_its_seal_is_its_checksum(sealed, copy, name: str) -> None:
    path = copy(name)
    validate_file(path)
    recorded = read_attributes(path)[CONTENT_ATTRIBUTE]
    assert recorded == content_sha256(path)
    assert seal(path) == recorded  # sealing again changes nothing
    text = describe(path)
    assert str(path) in text and read_attributes(path)["study_name"] in text


def test_the_checksum_follows_its_documented_definition(tmp_path: Path) -> None:
    path = tmp_path / "small.nc"
    with netCDF4.Dataset(path, "w") as nc:
        nc.createDimension("x", 3)
        nc.setncattr("title", "global attributes are not covered")
        speed = nc.createVariable("speed", "f8", ("x",), fill_value=np.nan)
        speed.units = "m s-1"
        speed[:] = [1.5, np.nan, -2.0]
        code = nc.createVariable("code", "i1", ())
        code.flag_values = np.array([0, 1], dtype=np.int8)
        code[...] = 1
        label = nc.createVariable("label", str, ("x",))
        label[:] = np.array(["a", "bé", ""], dtype=object)
    stream = hashlib.sha256()
    # Sorted names: code, label, speed. Header, attributes (sorted), values.
    stream.update(b"code\0|i1\0\0\0" + b"1\0")
    stream.update(b"flag_values\0|i1\0" + b"2\0" + b"\x00\x01")
    stream.update(b"\x01")
    stream.update(b"label\0str\0x\0" + b"3\0" + b"0\0")
    stream.update("a\0bé\0\0".encode())
    stream.update(b"speed\0<f8\0x\0" + b"3\0" + b"2\0")
    stream.update(b"_FillValue\0<f8\0\0" + np.array(np.nan).astype("<f8").tobytes())
    stream.update(b"units\0str\0\0" + b"m s-1\0")
    stream.update(np.array([1.5, np.nan, -2.0], dtype="<f8").tobytes())
    assert content_sha256(path) == stream.hexdigest()


def test_storage_layout_is_not_content(sealed, tmp_path: Path) -> None:
    # Deflated, rechunked copies hold the same content: same checksum, still valid.
    for name in ("velocity", "steering"):
        again = rewrite(sealed[name], tmp_path / f"{name}.nc", compress=True)
        assert content_sha256(again) == content_sha256(sealed[name])
        validate_file(again)


def test_values_are_read_in_bounded_slabs(copy, monkeypatch: pytest.MonkeyPatch) -> None:
    path = copy("swept-q")
    whole = content_sha256(path)
    # 24 bytes a read: three float64 values, several reads per row.
    monkeypatch.setattr(study.engine.validation.reading, "SLAB_BYTES", 24)
    assert content_sha256(path) == whole
    validate_file(path)
    with netCDF4.Dataset(path, "a") as nc:
        nc["status"][-1, -1, -1] = 99  # in the last slab
    message = _refusal(path)
    assert "99 (1 points)" in message


# ---------------------------------------------------------------------------
# Studies: each check refuses its corruption


def _set(name: str, value) -> Callable[[Path], None]:
    def edit(path: Path) -> None:
        with netCDF4.Dataset(path, "a") as nc:
            nc.setncattr(name, value)
    return edit


def _delete(name: str) -> Callable[[Path], None]:
    def edit(path: Path) -> None:
        with netCDF4.Dataset(path, "a") as nc:
            nc.delncattr(name)
    return edit


def _variable(name: str, change: Callable) -> Callable[[Path], None]:
    def edit(path: Path) -> None:
        with netCDF4.Dataset(path, "a") as nc:
            nc.set_auto_maskandscale(False)
            change(nc[name])
    return edit


def _rewritten(**changes) -> Callable[[Path], None]:
    def edit(path: Path) -> None:
        moved = path.with_suffix(".orig")
        path.rename(moved)
        rewrite(moved, path, **changes)
    return edit


def _provenance(change: Callable[[dict], None]) -> Callable[[Path], None]:
    def edit(path: Path) -> None:
        with netCDF4.Dataset(path, "a") as nc:
            document = json.loads(nc.getncattr("provenance"))
            change(document)
            nc.setncattr("provenance", json.dumps(document))
    return edit


def _status_99(var) -> None:
    var[0, 0] = 99


def _times_1000(var) -> None:
    var[...] = var[...] * 1000.0


def _first_f(var) -> None:
    var[0] = 9.0


def _other_spec(document: dict) -> None:
    document["study"]["spec_sha256"] = "0" * 64


def _inconsistent_points(document: dict) -> None:
    document["run"].update(points=12, points_computed=5, points_reused=5)


STUDY_CORRUPTIONS = {
    "status 99": (_variable("status", _status_99), ["status", "outside its flag_values", "99"]),
    "transposed velocity": (_rewritten(transpose={"velocity": (1, 0)}),
                            ["velocity has dimensions (a, f); declared (f, a)"]),
    "velocity float32": (_rewritten(dtypes={"velocity": "float32"}),
                         ["velocity is float32; declared float64"]),
    "units furlong": (_variable("velocity", lambda v: v.setncattr("units", "furlong")),
                      ["velocity: units 'furlong'; declared 'm s-1'"]),
    "provenance []": (_set("provenance", "[]"), ["provenance", "not of type 'object'"]),
    "provenance {}": (_set("provenance", "{}"), ["provenance", "'code' is a required"]),
    "provenance not json": (_set("provenance", "not json"), ["'provenance' is not a JSON"]),
    "provenance points": (_provenance(_inconsistent_points), ["points_computed"]),
    "provenance spec": (_provenance(_other_spec), ["provenance: study.spec_sha256 differs"]),
    "fingerprint removed": (_delete("study_fingerprint"), ["'study_fingerprint' is a required"]),
    "fingerprint changed": (_set("study_fingerprint", "ab" * 32),
                            ["study_fingerprint does not match"]),
    "velocity x1000": (_variable("velocity", _times_1000), ["content differs from the checksum"]),
    "flag_meanings changed": (
        _variable("status", lambda v: v.setncattr("flag_meanings", "a b c d e f")),
        ["status: flag_meanings differ"]),
    "missing variable": (_rewritten(drop=("slips_per_period",)),
                         ["'slips_per_period' asked for by the spec is missing"]),
    "coordinate changed": (_variable("f", _first_f),
                           ["coordinate 'f' differs from the embedded spec"]),
    "checksum removed": (_delete(CONTENT_ATTRIBUTE), ["no content checksum", "rerun"]),
    "title changed": (_set("title", "Another title"), ["title differs"]),
}


@pytest.mark.parametrize("corruption", list(STUDY_CORRUPTIONS))
def test_a_corrupted_study_is_refused(copy, corruption: str) -> None:
    edit, words = STUDY_CORRUPTIONS[corruption]
    path = copy("velocity")
    edit(path)
    message = _refusal(path)
    assert message.startswith(f"{path}: invalid study result:\n  ")
    for word in words:
        assert word in message, message


@pytest.mark.parametrize(
    ("name", "edit", "words"),
    [
        ("swept-q", _rewritten(transpose={"status": (1, 0, 2)}),
         ["status has dimensions (f, Q, a); declared (Q, f, a)"]),
        ("swept-q", _variable("Q", lambda v: v.__setitem__(1, 31.0)), ["coordinate 'Q'"]),
        ("thresholds", _variable("a_star_plus", lambda v: v.setncattr("units", "furlong")),
         ["a_star_plus: units 'furlong'"]),
        ("thresholds", _variable("f0", lambda v: v.assignValue(15.0)),
         ["f0 differs from the embedded spec"]),
        ("thresholds", _rewritten(drop=("cs",)), ["fixed parameter 'cs' must be"]),
    ],
    ids=["transposed-status", "changed-Q", "units-furlong", "changed-f0", "dropped-cs"],
)
def test_other_studies_are_checked_against_their_spec(copy, name, edit, words) -> None:
    path = copy(name)
    edit(path)
    message = _refusal(path)
    for word in words:
        assert word in message, message


def test_velocity_must_be_nan_exactly_where_the_status_is_invalid(copy) -> None:
    path = copy("velocity")
    with netCDF4.Dataset(path, "a") as nc:
        status = nc["status"][...]
        lift_off = tuple(np.argwhere(status == Status.LIFT_OFF)[0])
        static = tuple(np.argwhere(status == Status.STATIC)[0])
        nc["velocity"][lift_off] = 0.5
        nc["velocity"][static] = 1e-3
    message = _refusal(path)
    assert ("velocity must be NaN exactly where status is one of lift_off, not_converged, "
            "friction_paradox; 1 points disagree") in message
    assert "velocity is not 0 where status is static (1 points)" in message


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (None, ["no such file"]),
        (b"", ["not a readable netCDF file"]),
        (b"these are my notes, not a netCDF file\n" * 20, ["not a readable netCDF file"]),
        ("truncated", ["not a readable netCDF file"]),
    ],
    ids=["missing", "empty", "text", "truncated"],
)
def test_unreadable_files_are_one_line(sealed, tmp_path: Path, content, words) -> None:
    path = tmp_path / "bad.nc"
    if content == "truncated":
        content = sealed["velocity"].read_bytes()[:3000]
    if content is not None:
        path.write_bytes(content)
    for function in (validate_file, read_attributes, content_sha256, open_result):
        with pytest.raises(ResultError) as info:
            function(path)
        message = str(info.value)
        assert message.startswith(f"{path}: ") and "\n" not in message
        for word in words:
            assert word in message


def test_a_foreign_or_outdated_file_says_what_it_is(copy, tmp_path: Path) -> None:
    foreign = tmp_path / "foreign.nc"
    xr.Dataset({"temperature": ("x", np.arange(4.0))}).to_netcdf(foreign)
    assert "not a study result file" in _refusal(foreign)
    outdated = copy("velocity")
    _set("study_result_schema", "study-result-v0")(outdated)
    message = _refusal(outdated)
    assert "study-result-v0" in message and "Rerun" in message


# ---------------------------------------------------------------------------
# Scenes


def _segment_status_9(var) -> None:
    var[0] = 9


def _shift_x(var) -> None:
    var[3] = var[3] + 1e-3


SCENE_CORRUPTIONS = {
    "flag out of range": (_variable("segment_status", _segment_status_9),
                          ["segment_status holds values outside its flag_values"]),
    "no units": (_variable("x", lambda v: v.delncattr("units")), ["x has no units"]),
    "units furlong": (_variable("x", lambda v: v.setncattr("units", "furlong")),
                      ["content differs"]),
    "disk radius": (_set("disk_radius", 0.03), ["disk_radius differs from the embedded spec"]),
    "fingerprint": (_set("study_fingerprint", "0" * 64), ["study_fingerprint does not match"]),
    "provenance []": (_set("provenance", "[]"), ["provenance"]),
    "value": (_variable("x", _shift_x), ["content differs"]),
    "scene kind": (_set("study_scene_kind", "plan"), ["study_scene_kind"]),
}


@pytest.mark.parametrize("corruption", list(SCENE_CORRUPTIONS))
def test_a_corrupted_scene_is_refused(copy, corruption: str) -> None:
    edit, words = SCENE_CORRUPTIONS[corruption]
    path = copy("steering")
    edit(path)
    message = _refusal(path)
    assert message.startswith(f"{path}: invalid steering scene result:\n  ")
    for word in words:
        assert word in message, message


# ---------------------------------------------------------------------------
# For people


def test_describe_names_the_flag_counts(sealed) -> None:
    text = describe(sealed["velocity"])
    with netCDF4.Dataset(sealed["velocity"]) as nc:
        status = nc["status"][...]
    line = next(x for x in text.splitlines() if x.strip().startswith("status:"))
    for member in Status:
        count = int(np.count_nonzero(status == member))
        if count:
            assert f"{member.name.lower()} {count / status.size:.1%} ({count})" in line
        else:
            assert member.name.lower() not in line
    scene = describe(sealed["steering"])
    assert "segment_status: completed 100.0% (6)" in scene


def test_describe_takes_strings_and_odd_provenance() -> None:
    # A plan scene's string coordinate crashed `study info` ("Unknown format code 'g'").
    dataset = xr.Dataset(
        {"run_status": (("strategy",), np.array([0, 1, 7], dtype=np.int8),
                        {"flag_values": np.array([0, 1], dtype=np.int8),
                         "flag_meanings": "completed lift_off"})},
        coords={"strategy_name": ("strategy", np.array(["calibration", "open", "closed"])),
                "label": ((), "head"), "t": ("t", np.array([0.0, 0.5]))},
        attrs={"study_name": "plan", "provenance": "[]", "history": 3},
    )
    text = describe(dataset, "plan.nc")
    assert "strategy_name along strategy: calibration, open, closed" in text
    assert "label=head" in text
    assert "run_status: completed 33.3% (1), lift_off 33.3% (1), value 7 33.3% (1)" in text


def test_info_and_validate_commands_read_every_kind(sealed, capsys) -> None:
    for path in sealed.values():
        assert main(["validate", str(path)]) == 0
        assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    valid = out.count(": valid study result") + out.count(": valid steering scene result")
    assert valid == len(sealed)
    assert "segment_status: completed" in out and "status: static" in out


def test_open_result_loads_a_validated_file(sealed) -> None:
    dataset = open_result(sealed["swept-q"])
    assert dataset["velocity"].dims == ("Q", "f", "a")
    assert dataset.attrs[CONTENT_ATTRIBUTE] == content_sha256(sealed["swept-q"])


# ---------------------------------------------------------------------------
# Result formats: a file whose units changed since is stale, never misread


def test_mode_phase_is_in_degree_and_a_file_with_it_in_rad_is_stale(sealed, tmp_path) -> None:
    """Format 2 on stores the mode's phase lag in degree (90 at resonance); a file without
    ``study_result_format`` (format 1: mode_phase in rad) is refused as stale, while
    one that holds no changed variable stays valid."""
    from study.engine.runner import run_study
    from study.studies.variables import RESULT_FORMAT

    spec = tmp_path / "resonance.toml"
    spec.write_text("""
[study]
name = "resonance"
observables = ["resonance"]
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25
[sweep]
f = { values = [1.0, 14.44, 1000.0] }
""")
    output = run_study(spec, tmp_path / "resonance.nc", progress=False, workers=1).output
    validate_file(output)
    with xr.open_dataset(output) as data:
        assert data.attrs["study_result_format"] == RESULT_FORMAT == 5
        assert data.mode_phase.attrs["units"] == "degree"
        phase = data.mode_phase.values
    # Below, at and far above resonance: ~0, 90 and ~180 degree (not 0, pi/2, pi).
    assert 0.0 < phase[0] < 1.0 and 179.0 < phase[2] < 180.0
    np.testing.assert_allclose(phase[1], 90.0, rtol=1e-12)
    with netCDF4.Dataset(output, "a") as nc:
        nc.delncattr("study_result_format")
        nc["mode_phase"].setncattr("units", "rad")
    message = _refusal(output)
    assert ("study result format 1 (mode_phase in rad) is stale: this study reads format "
            f"{RESULT_FORMAT} (mode_phase in degree); rerun its spec") in message, message
    # No mode_phase in it: nothing changed units, the file is still valid.
    other = Path(shutil.copyfile(sealed["thresholds"], tmp_path / "thresholds.nc"))
    with netCDF4.Dataset(other, "a") as nc:
        nc.delncattr("study_result_format")
    validate_file(other)
