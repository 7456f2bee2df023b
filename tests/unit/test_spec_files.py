"""The shared spec layer (``study.engine.spec_files``): reading files on disk (encodings,
size, what is not a regular file), parsing, schema messages, the axis grammar, the
canonical hash and the kind of a spec, for studies and scenes alike.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from study.cli import main
from study.engine.spec_files import (
    MAX_NESTING,
    MAX_SPEC_BYTES,
    SpecError,
    axis_values,
    canonical_json,
    canonical_sha256,
    detect_kind,
    jsonable,
    load_schema,
    parse_toml,
    read_spec_text,
    where,
)
from study.scenes.scene_spec import load_scene, parse_scene
from study.studies.spec import load_spec, parse_spec
from tests.unit.test_cache_health import deadline

REPO = Path(__file__).resolve().parents[2]
WORKFLOWS = sorted((REPO / "workflows").glob("*.toml"))
STUDY = (REPO / "workflows" / "regime-map.toml").read_text(encoding="utf-8")
SCENE = (REPO / "workflows" / "steering.toml").read_text(encoding="utf-8")


# --------------------------------------------------------------------------- reading


@pytest.mark.parametrize(
    ("encoding", "fragment"),
    [("utf-16", "this file is UTF-16"), ("utf-32", "this file is UTF-32"),
     ("utf-16-be", "byte 0 is a NUL"), ("utf-16-le", "byte 1 is a NUL")],
)
def test_a_utf16_or_utf32_file_is_refused_naming_the_encoding(tmp_path, encoding, fragment):
    path = tmp_path / "spec.toml"
    path.write_bytes(STUDY.encode(encoding))  # with a byte-order mark, or without
    with pytest.raises(SpecError) as excinfo:
        read_spec_text(path)
    message = str(excinfo.value)
    assert message.startswith(f"{path}: a spec must be UTF-8 text (TOML); ")
    assert fragment in message


def test_a_non_utf8_byte_is_refused_with_its_offset(tmp_path):
    path = tmp_path / "latin.toml"
    path.write_bytes('[study]\nname = "café"\n'.encode("latin-1"))
    with pytest.raises(SpecError, match=r"latin\.toml: a study spec must be UTF-8 text \(TOML\); "
                                        r"byte 19 is not"):
        load_spec(path)


def test_a_utf8_byte_order_mark_is_read_and_kept_in_the_text(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + STUDY.encode())
    spec = load_spec(path)
    assert spec.text == "\ufeff" + STUDY  # the stored text is the file's text
    assert spec.sha256 == parse_spec(STUDY).sha256


def test_a_file_larger_than_the_cap_is_refused_with_its_size(tmp_path):
    path = tmp_path / "big.toml"
    size = MAX_SPEC_BYTES + 10
    path.write_bytes(b"#" * size)
    with pytest.raises(SpecError, match=rf"big\.toml: spec is {size} bytes; allowed at most "
                                        rf"{MAX_SPEC_BYTES}"):
        read_spec_text(path)


@pytest.mark.parametrize("make", [lambda p: p, lambda p: p.mkdir() or p], ids=["missing", "folder"])
def test_an_unreadable_file_is_one_line(tmp_path, make):
    path = make(tmp_path / "spec.toml")
    with pytest.raises(SpecError) as excinfo:
        read_spec_text(path, "scene spec")
    message = str(excinfo.value)
    assert message.startswith(f"{path}: cannot read the scene spec (")
    assert "\n" not in message


def test_the_cli_refuses_a_utf16_spec_without_a_traceback(tmp_path, capsys):
    path = tmp_path / "spec.toml"
    path.write_bytes(SCENE.encode("utf-16"))
    assert main(["run", str(path), "-o", str(tmp_path / "out.nc")]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"study: {path}: a spec must be UTF-8")
    assert "Traceback" not in err
    assert not (tmp_path / "out.nc").exists()


@pytest.mark.parametrize("command", ["run", "design", "fit"])
def test_a_fifo_device_or_folder_as_the_spec_is_refused(command: str, tmp_path: Path,
                                                        capsys) -> None:
    """Refused in one line, never waited on (found by the command-line fuzz tier:
    `study design FIFO` hung)."""
    fifo = tmp_path / "spec.toml"
    os.mkfifo(fifo)
    for path, kind in ((fifo, "a FIFO"), (Path("/dev/zero"), "a device"),
                       (Path("/dev/null"), "a device")):
        with deadline(20):
            status = main([command, str(path), "-o", str(tmp_path / "out.nc")])
        err = capsys.readouterr().err
        assert status == 1 and err.startswith(f"study: {path}: {kind}, not a regular file"), err
    with deadline(20):
        assert main([command, str(tmp_path), "-o", str(tmp_path / "out.nc")]) == 1
    assert capsys.readouterr().err.count("\n") == 1


# --------------------------------------------------------------------------- parsing


@pytest.mark.parametrize(
    "text",
    [
        "x = " + "[" * 5000 + "]" * 5000,  # deep enough to exhaust the parser's recursion
        "x = " + "{ y = " * 3000 + "1" + " }" * 3000,
        "x = " + "[" * (MAX_NESTING + 1) + "]" * (MAX_NESTING + 1),
        "[study]\n" + "a." * (MAX_NESTING + 1) + "b = 1",
    ],
    ids=["arrays-5000", "inline-tables-3000", "arrays-just-too-deep", "dotted-keys"],
)
def test_deep_nesting_is_refused_before_any_schema_work(text):
    with pytest.raises(SpecError, match=rf"deep\.toml: tables or arrays nested .*allowed at most "
                                        rf"{MAX_NESTING} levels"):
        parse_toml(text, "deep.toml")


def test_the_nesting_the_specs_need_is_accepted():
    raw = parse_toml("[plan]\nwaypoints = [[0.0, 0.08], [0.06, 0.12]]\n", "plan.toml")
    assert raw["plan"]["waypoints"][1] == [0.06, 0.12]


@pytest.mark.parametrize(
    ("line", "shown"),
    [("Q = nan", "[structure] Q = nan"), ("Q = -inf", "[structure] Q = -inf"),
     ("f = { values = [1.0, inf] }", "[structure] f.values[1] = inf")],
)
def test_inf_and_nan_are_refused_naming_the_key(line, shown):
    with pytest.raises(SpecError) as excinfo:
        parse_toml(f"[structure]\n{line}\n", "s.toml")
    assert str(excinfo.value).startswith(f"s.toml: {shown} is not a finite number; allowed:")


def test_toml_syntax_errors_name_the_file_and_line():
    with pytest.raises(SpecError, match=r"s\.toml: not valid TOML: .*line 2"):
        parse_toml("[study]\nname = \n", "s.toml")


# --------------------------------------------------------------------------- kinds


@pytest.mark.parametrize("path", WORKFLOWS, ids=lambda p: p.stem)
def test_every_workflow_has_a_kind_and_loads_as_it(path):
    kind = detect_kind(path)
    spec = load_spec(path) if kind == "study" else load_scene(path)
    assert detect_kind(path.read_text(encoding="utf-8")) == kind
    assert (kind == "scene") == hasattr(spec, "disk")


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("[structure]\nQ = 1\n", "needs a [study] or [scene] or [fit] or [design] table "
                                 "(top-level tables found: 'structure')"),
        ("", "top-level tables found: none"),
        ("[study]\nname = 'x'\n[scene]\nname = 'y'\n", "both [study] and [scene]"),
        ("study = 3\n", "[study] must be a table"),
    ],
)
def test_a_spec_without_exactly_one_kind_table_is_refused(tmp_path, text, fragment):
    path = tmp_path / "odd.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(SpecError) as excinfo:
        detect_kind(path)
    assert str(excinfo.value).startswith(f"{path}: ")
    assert fragment in str(excinfo.value)


# --------------------------------------------------------------------------- messages


def test_where_writes_locations_as_the_user_wrote_them():
    assert where([]) == "top level"
    assert where(["sweep", "f", "num"]) == "[sweep] f.num"
    assert where(["sweep", "a", "values", 3]) == "[sweep] a.values[3]"
    assert where(["plate", 1, "Q"]) == "[plate #2] Q"
    assert where(["plan", "waypoints", 0, 1]) == "[plan] waypoints[0][1]"


def test_a_wrong_type_names_key_type_and_what_the_key_is():
    with pytest.raises(SpecError) as excinfo:
        parse_scene(SCENE.replace("sample_interval = 0.05", "sample_interval = '0.05'"), "s.toml")
    message = str(excinfo.value)
    assert "[trajectory] sample_interval: '0.05' has the wrong type; expected number" in message
    assert "spacing of the stored samples [s]" in message


# --------------------------------------------------------------------------- axes


def test_studies_and_scenes_share_one_axis_grammar():
    assert load_schema("study-scene-spec-v1")["$defs"]["axis"] == (
        load_schema("study-spec-v1")["$defs"]["axis"])


def test_a_scene_calibration_takes_the_whole_grammar_log_spacing_included():
    text = (REPO / "workflows" / "steering-calibration.toml").read_text(encoding="utf-8")
    text = text.replace("f = { start = 6.0, stop = 16.0, num = 81 }",
                        'f = { start = 6.0, stop = 16.0, num = 5, spacing = "log" }')
    spec = parse_scene(text, "cal.toml")
    assert_allclose(spec.options["f"], np.geomspace(6.0, 16.0, 5), rtol=1e-15, atol=0)


@pytest.mark.parametrize(
    ("table", "fragment"),
    [({"start": 1.0, "stop": 1.0 + 1e-15, "num": 100}, "values must be distinct"),
     ({"start": 0.0, "stop": 1.0, "num": 3, "spacing": "log"}, "log spacing needs start > 0"),
     ({"start": 1.0, "stop": 2.0, "num": 3.0}, "num = 3.0 must be an integer"),
     ({"start": -1.7e308, "stop": 1.7e308, "num": 3}, "values must be finite")],
)
def test_axis_values_refuse_what_cannot_be_an_axis(table, fragment):
    with pytest.raises(SpecError, match=r"^s\.toml: \[sweep\] f: ") as excinfo:
        axis_values(table, "s.toml: [sweep] f")
    assert fragment in str(excinfo.value)


# --------------------------------------------------------------------------- hash


def test_the_canonical_hash_ignores_key_order_and_numpy_types():
    a = {"b": [1.0, 2.0], "a": {"y": 1, "x": (2.5, 3)}}
    b = {"a": {"x": [np.float64(2.5), np.int64(3)], "y": 1}, "b": np.array([1.0, 2.0])}
    assert canonical_json(a) == '{"a":{"x":[2.5,3],"y":1},"b":[1.0,2.0]}'
    assert canonical_sha256(a) == canonical_sha256(b)
    assert canonical_sha256(a) == hashlib.sha256(canonical_json(a).encode()).hexdigest()
    assert canonical_sha256(a) != canonical_sha256({**a, "b": [1.0, 2.0000000000000004]})
    assert jsonable(b) == json.loads(canonical_json(a))


def test_the_canonical_hash_refuses_nan():
    with pytest.raises(ValueError, match="JSON"):
        canonical_sha256({"x": math.nan})


def test_study_and_scene_hashes_are_the_canonical_hash():
    study = parse_spec(STUDY)
    scene = parse_scene(SCENE)
    assert study.sha256 == canonical_sha256(study.canonical)
    assert scene.sha256 == canonical_sha256(scene.canonical)


def test_study_list_marks_an_unreadable_spec_invalid(tmp_path, capsys):
    (tmp_path / "a.toml").write_bytes(STUDY.encode("utf-16"))
    (tmp_path / "b.toml").write_text("x = " + "[" * 5000 + "]" * 5000, encoding="utf-8")
    assert main(["list", "--workflows", str(tmp_path), "--results", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"{tmp_path / 'a.toml'}: INVALID SPEC: ")
    assert "UTF-16" in lines[0]
    assert lines[1].startswith(f"{tmp_path / 'b.toml'}: INVALID SPEC: ")
    assert "nested too deeply" in lines[1]


def test_log_spacing_up_to_the_largest_double_raises_no_warning():
    values = axis_values({"start": 1e-3, "stop": 1.7976931348623157e308, "num": 5,
                          "spacing": "log"}, "s.toml: [sweep] f")
    assert values[-1] == 1.7976931348623157e308
