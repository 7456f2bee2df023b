"""No command overwrites something it did not write (study.engine.outputs): an input of the
command (by path, symlink or hard link), a folder, a device or a file of another kind
is refused with one line and left byte for byte as it was; ``--overwrite`` gets past the
kind check only."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from study.cli import main
from study.engine.outputs import OutputError, check_output, is_output_of_kind
from study.engine.store import open_result

SPEC = """\
[study]
name = "guarded"
observables = ["resonance", "thresholds"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = { start = 10.0, stop = 20.0, num = 5 }
"""

SCENE = """\
[scene]
name = "guarded-scene"
kind = "steering"
"""

MEASUREMENTS = "quantity,f,a,value,sigma,direction\nthreshold,14.0,,4.1,0.2,forward\n"


def run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    capsys.readouterr()
    status = main([os.fsdecode(a) if isinstance(a, bytes) else str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(SPEC)
    (tmp_path / "lab.csv").write_text(MEASUREMENTS)
    return tmp_path


@pytest.fixture
def result(capsys, folder: Path) -> Path:
    assert run(capsys, "run", "spec.toml", "-o", "guarded.nc")[0] == 0
    return folder / "guarded.nc"


def refused(capsys, *argv: object, says: str) -> str:
    status, _, err = run(capsys, *argv)
    assert status == 1, err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    assert says in err, err
    return err


def test_a_spec_is_never_its_own_output(capsys, folder: Path) -> None:
    before = (folder / "spec.toml").read_bytes()
    refused(capsys, "run", "spec.toml", "-o", "spec.toml", says="is an input")
    refused(capsys, "run", "spec.toml", "-o", "./sub/../spec.toml", "--overwrite",
            says="is an input")
    os.link(folder / "spec.toml", folder / "hard.nc")
    refused(capsys, "run", "spec.toml", "-o", "hard.nc", "--overwrite", says="is an input")
    (folder / "soft.nc").symlink_to(folder / "spec.toml")
    refused(capsys, "run", "spec.toml", "-o", "soft.nc", "--overwrite", says="is an input")
    assert (folder / "spec.toml").read_bytes() == before


def test_export_never_writes_over_its_result(capsys, result: Path) -> None:
    before = result.read_bytes()
    refused(capsys, "export", result, "--csv", result, "--overwrite", says="is an input")
    assert result.read_bytes() == before
    assert open_result(result).attrs["study_name"] == "guarded"


def test_a_file_of_another_kind_needs_overwrite(capsys, folder: Path, result: Path) -> None:
    notes = folder / "notes.txt"
    notes.write_text("my notes\n")
    err = refused(capsys, "run", "spec.toml", "-o", notes, says="--overwrite")
    assert "exists and is not a result file of schema study-result-v1" in err
    refused(capsys, "export", result, "--csv", "lab.csv", says="is not a CSV table")
    (folder / "notes.png").write_bytes(b"\x89PNG\r\n\x1a\n not drawn by study")
    refused(capsys, "figure", "thresholds", result, "-o", "notes", says="--overwrite")
    assert notes.read_text() == "my notes\n"
    assert (folder / "lab.csv").read_text() == MEASUREMENTS

    status, _, err = run(capsys, "run", "spec.toml", "-o", notes, "--overwrite")
    assert status == 0, err
    assert open_result(notes).attrs["study_name"] == "guarded"
    status, _, err = run(capsys, "export", result, "--csv", "lab.csv", "--overwrite")
    assert status == 0, err
    assert (folder / "lab.csv").read_text().startswith("f [Hz]")


def test_outputs_of_the_same_kind_are_replaced_without_a_flag(capsys, folder: Path,
                                                            result: Path) -> None:
    # rerunning, re-exporting and redrawing is the everyday case
    assert run(capsys, "run", "spec.toml", "-o", result, "--force")[0] == 0
    assert run(capsys, "export", result, "--csv", "t.csv")[0] == 0
    assert run(capsys, "export", result, "--csv", "t.csv")[0] == 0
    assert run(capsys, "figure", "thresholds", result, "-o", "fig")[0] == 0
    assert run(capsys, "figure", "thresholds", result, "-o", "fig")[0] == 0
    assert is_output_of_kind(folder / "t.csv", "csv")
    assert is_output_of_kind(folder / "fig.png", "figure")
    assert is_output_of_kind(folder / "fig.pdf", "figure")
    assert is_output_of_kind(result, "study-result-v1")
    assert not is_output_of_kind(result, "study-scene-v1")


def test_a_study_result_does_not_replace_a_scene_result(capsys, folder: Path) -> None:
    (folder / "scene.toml").write_text(SPEC.replace('name = "guarded"', 'name = "other"'))
    assert run(capsys, "run", "spec.toml", "-o", "x.nc")[0] == 0
    # the same file, asked to hold a scene, is of another kind
    with pytest.raises(OutputError, match="is not a result file of schema study-scene-v1"):
        check_output(folder / "x.nc", "study-scene-v1")


def test_an_empty_output_name_is_a_usage_error(capsys, folder: Path) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["run", "spec.toml", "-o", ""])
    assert stop.value.code == 2
    assert "an empty output name" in capsys.readouterr().err
    assert not (folder / "results").exists()


@pytest.mark.parametrize("name, says", [
    (".", "names a folder"),
    ("/", "names a folder"),
    ("sub/", "is a folder"),
    ("/dev/null", "not a regular file"),
])
def test_names_that_are_no_file(capsys, folder: Path, name: str, says: str) -> None:
    (folder / "sub").mkdir()
    refused(capsys, "run", "spec.toml", "-o", name, says=says)
    assert not (folder / "results").exists()


def test_an_existing_folder_is_refused(capsys, folder: Path) -> None:
    (folder / "there.nc").mkdir()
    refused(capsys, "run", "spec.toml", "-o", "there.nc", "--overwrite", says="is a folder")


def test_a_name_that_is_not_utf8_is_refused_in_one_printable_line(capsys,
                                                                    folder: Path) -> None:
    name = os.fsdecode(b"r\xe9sultat.nc")
    err = refused(capsys, "run", "spec.toml", "-o", name, says="not valid UTF-8")
    assert "r\\udce9sultat.nc" in err
    assert sorted(os.listdir(folder)) == ["lab.csv", "spec.toml"]


FIT = """\
[fit]
name = "guarded-fit"
measurements = ["lab.csv"]
free = { cs = [0.05, 1.0] }

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25
"""


def test_a_fit_never_writes_over_its_spec_or_measurements(capsys, folder: Path) -> None:
    (folder / "fit.toml").write_text(FIT)
    refused(capsys, "fit", "fit.toml", "-o", "lab.csv", "--overwrite", says="is an input")
    refused(capsys, "fit", "fit.toml", "-o", "fit.toml", "--overwrite", says="is an input")
    (folder / "lab.png").write_bytes(b"\x89PNG\r\n\x1a\n a photograph of the rig")
    refused(capsys, "fit", "fit.toml", "--figure", "lab.png", "-o", "out.nc",
            says="is not a figure drawn by study")
    assert (folder / "lab.csv").read_text() == MEASUREMENTS
    assert (folder / "fit.toml").read_text() == FIT
    assert not (folder / "out.nc").exists()


def test_a_design_never_writes_over_its_spec(capsys, folder: Path) -> None:
    spec = Path(__file__).resolve().parents[2] / "designs" / "forward-backward.toml"
    (folder / "design.toml").write_text(spec.read_text())
    refused(capsys, "design", "design.toml", "-o", "design.toml", "--overwrite",
            says="is an input")
    (folder / "notes.txt").write_text("x")
    refused(capsys, "design", "design.toml", "-o", "notes.txt", says="--overwrite")
    assert (folder / "design.toml").read_text() == spec.read_text()
