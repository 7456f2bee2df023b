"""The ``study`` command line: run, validate, info, list and its refusals (study.cli)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from study.cli import main
from study.engine.provenance import package_version
from study.engine.runner import StudyInterrupted, run_study
from study.engine.store import open_result

# 7 x 5 points, 2 frequencies (10 points) per chunk: 4 chunks.
CHUNKS = 4


def spec_text(name: str = "tiny", f_num: int = 7, extra: str = "") -> str:
    return f"""\
[study]
name = "{name}"
title = "A tiny regime map for the command-line tests"
observables = ["thresholds", "lift_off", "velocity", "diagnostics"]
{extra}
[structure]
f0 = 14.44   # Hz
Q = 17.5
alpha = 64.0 # degree
M = 0.08
cs = 0.25

[sweep]
f = {{ start = 10.0, stop = 20.0, num = {f_num} }}  # Hz
a = {{ start = 0.0, stop = 12.0, num = 5 }}   # m s-2

[solver]
chunk_points = 10
"""


@pytest.fixture
def workspace(tmp_path: Path) -> tuple[Path, Path]:
    """``workflows/`` holding ``tiny.toml``, and an empty ``results/``."""
    workflows = tmp_path / "workflows"
    results = tmp_path / "results"
    workflows.mkdir()
    results.mkdir()
    (workflows / "tiny.toml").write_text(spec_text())
    return workflows, results


@pytest.fixture
def spec(workspace: tuple[Path, Path]) -> Path:
    return workspace[0] / "tiny.toml"


@pytest.fixture
def output(workspace: tuple[Path, Path]) -> Path:
    return workspace[1] / "tiny.nc"


def run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    """``study ARGV...`` in-process: exit status, stdout, stderr."""
    capsys.readouterr()
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def counts(line: str) -> tuple[int, int, int]:
    match = re.search(r"(\d+) chunks \((\d+) computed, (\d+) reused\)", line)
    assert match, line
    return int(match[1]), int(match[2]), int(match[3])


@pytest.fixture
def good_file(spec: Path, output: Path) -> Path:
    run_study(spec, output, progress=False)
    return output


# ---------------------------------------------------------------------------
# run


def test_run_then_up_to_date_then_force(capsys, spec: Path, output: Path) -> None:
    status, out, err = run(capsys, "run", spec, "-o", output, "--no-progress")
    assert status == 0, err
    assert str(output) in out
    assert counts(out) == (CHUNKS, CHUNKS, 0)
    assert err == ""  # --no-progress: no bar
    open_result(output)
    assert not list(output.parent.glob(".tiny.nc.*.tmp"))
    first = output.read_bytes()

    status, out, err = run(capsys, "run", spec, "-o", output, "--no-progress")
    assert status == 0, err
    assert str(output) in out
    assert "up to date" in out
    assert output.read_bytes() == first

    # --force rewrites the file; the values are kept, so nothing is recomputed.
    status, out, err = run(capsys, "run", spec, "-o", output, "--no-progress", "--force")
    assert status == 0, err
    assert "up to date" not in out
    assert counts(out) == (CHUNKS, 0, CHUNKS)
    run_info = json.loads(open_result(output).attrs["provenance"])["run"]
    assert run_info["chunks_computed"] == 0
    assert run_info["chunks_reused"] == CHUNKS
    assert run_info["points_reused"] == run_info["points"] == 35


def test_run_with_workers(capsys, spec: Path, output: Path) -> None:
    status, _, err = run(capsys, "run", spec, "-o", output, "--no-progress", "--workers", 1)
    assert status == 0, err
    run_info = json.loads(open_result(output).attrs["provenance"])["run"]
    assert run_info["workers"] == 1
    assert run_info["scheduler"] == "local"


def test_run_resumes_an_interrupted_study(capsys, spec: Path, output: Path) -> None:
    with pytest.raises(StudyInterrupted):
        run_study(spec, output, progress=False, stop_after=1)
    assert list((output.parent / ".study-cache").glob("??/*/block-*.npz"))
    status, out, err = run(capsys, "run", spec, "-o", output, "--no-progress")
    assert status == 0, err
    assert counts(out) == (CHUNKS, CHUNKS - 1, 1)


def test_another_study_s_result_is_refused_naming_both(capsys, workspace, spec: Path,
                                                      output: Path) -> None:
    """`study run hyst.toml -o map-copy.nc` replaced the map of study `nc-map` without a
    word but "rewritten because its spec changed", its values kept only in another
    folder's cache."""
    status, _, err = run(capsys, "run", spec, "-o", output, "--no-progress")
    assert status == 0, err
    before = output.read_bytes()
    other = workspace[0] / "other.toml"
    other.write_text(spec_text(name="other", f_num=9))
    status, out, err = run(capsys, "run", other, "-o", output, "--no-progress")
    assert status == 1 and out == ""
    assert err == (f"study: -o {output}: holds the result of study 'tiny', not of the study "
                   f"'other' of {other}; its values may exist nowhere else: give another "
                   "output name, or --overwrite to replace it\n")
    assert output.read_bytes() == before
    # Asked to: replaced, and the file is the other study's.
    status, out, err = run(capsys, "run", other, "-o", output, "--no-progress", "--overwrite")
    assert status == 0, err
    assert open_result(output).attrs["study_name"] == "other"


def test_the_same_study_rewrites_its_own_result(capsys, spec: Path, output: Path) -> None:
    """"Same study" is the recorded [study] name: a spec whose numbers changed (or that
    moved to another file) still rewrites the file it wrote."""
    status, _, err = run(capsys, "run", spec, "-o", output, "--no-progress")
    assert status == 0, err
    moved = spec.with_name("tiny-moved.toml")
    moved.write_text(spec_text(f_num=9))
    status, out, err = run(capsys, "run", moved, "-o", output, "--no-progress")
    assert status == 0, err
    assert "rewritten because its spec changed" in out
    assert open_result(output).sizes["f"] == 9


def test_history_records_the_command_given_to_main(capsys, spec: Path, output: Path) -> None:
    status, _, err = run(capsys, "run", spec, "-o", output, "--no-progress")
    assert status == 0, err
    history = open_result(output).attrs["history"]
    assert f"study run {spec} -o {output} --no-progress" in history


# ---------------------------------------------------------------------------
# validate


def test_validate_good(capsys, good_file: Path) -> None:
    status, out, err = run(capsys, "validate", good_file)
    assert status == 0, err
    assert f"{good_file}: valid study result" in out
    assert err == ""


def test_validate_bad(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "bad.nc"
    bad.write_text("not a netCDF file\n")
    status, out, err = run(capsys, "validate", bad)
    assert status == 1
    assert out == ""
    assert str(bad) in err
    assert "not a readable netCDF file" in err


def test_validate_several(capsys, good_file: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.nc"
    bad.write_text("not a netCDF file\n")
    missing = tmp_path / "missing.nc"
    status, out, err = run(capsys, "validate", good_file, bad, missing, good_file)
    assert status == 1
    assert out.count(f"{good_file}: valid study result") == 2
    assert f"{bad}: not a readable netCDF file" in err
    assert f"{missing}: no such file" in err

    status, out, err = run(capsys, "validate", good_file, good_file)
    assert status == 0, err
    assert out.count("valid study result") == 2


# ---------------------------------------------------------------------------
# info


def test_info_prints_provenance(capsys, good_file: Path) -> None:
    status, out, err = run(capsys, "info", good_file)
    assert status == 0, err
    assert str(good_file) in out
    assert "'tiny'" in out
    assert f"made by study {package_version()}" in out
    assert "scheduler local" in out
    history = [line for line in out.splitlines() if line.strip().startswith("history:")]
    assert len(history) == 1
    assert f"(study {package_version()})" in history[0]
    assert "status:" in out


def test_info_of_a_bad_file(capsys, tmp_path: Path) -> None:
    missing = tmp_path / "missing.nc"
    status, out, err = run(capsys, "info", missing)
    assert status == 1
    assert out == ""
    assert f"{missing}: no such file" in err


# ---------------------------------------------------------------------------
# list


def listing(capsys, workflows: Path, results: Path) -> dict[str, str]:
    status, out, err = run(capsys, "list", "--workflows", workflows, "--results", results)
    assert status == 0, err
    lines = {}
    for line in out.splitlines():
        name = next(p.name for p in workflows.glob("*.toml") if line.startswith(f"{p}"))
        lines[name] = line
    return lines


def test_list_follows_the_life_of_a_study(capsys, workspace, spec: Path, output: Path) -> None:
    workflows, results = workspace
    line = listing(capsys, workflows, results)["tiny.toml"]
    assert line.startswith(str(spec))
    assert str(output) in line
    assert line.endswith("not run")

    assert run(capsys, "run", spec, "-o", output, "--no-progress")[0] == 0
    assert listing(capsys, workflows, results)["tiny.toml"].endswith(": up to date")

    # Formatting and comments do not count, numbers do.
    spec.write_text("# reformatted\n" + spec_text())
    assert listing(capsys, workflows, results)["tiny.toml"].endswith(": up to date")
    spec.write_text(spec_text(f_num=6))
    assert listing(capsys, workflows, results)["tiny.toml"].endswith(": out of date")

    broken = workflows / "broken.toml"
    broken.write_text(spec_text(name="broken", extra='colour = "red"'))
    lines = listing(capsys, workflows, results)
    assert set(lines) == {"broken.toml", "tiny.toml"}
    assert lines["broken.toml"].startswith(f"{broken}: INVALID SPEC")
    assert lines["tiny.toml"].endswith(": out of date")


def test_list_interrupted(capsys, workspace, spec: Path, output: Path) -> None:
    with pytest.raises(StudyInterrupted):
        run_study(spec, output, progress=False, stop_after=1)
    line = listing(capsys, *workspace)["tiny.toml"]
    assert line.endswith(": not run")


def test_list_without_workflows(capsys, tmp_path: Path) -> None:
    status, out, _ = run(capsys, "list", "--workflows", tmp_path, "--results", tmp_path)
    assert status == 0
    assert "no workflows" in out


# ---------------------------------------------------------------------------
# Bad input


def test_unknown_key_in_the_spec(capsys, workspace, output: Path) -> None:
    workflows, _ = workspace
    bad = workflows / "tiny.toml"
    bad.write_text(spec_text(extra='colour = "red"'))
    status, out, err = run(capsys, "run", bad, "-o", output, "--no-progress")
    assert status == 1
    assert out == ""
    assert str(bad) in err
    assert "'colour'" in err
    assert "allowed keys" in err
    for key in ("name", "observables", "title", "description"):
        assert key in err.split("allowed keys", 1)[1]
    assert not output.exists()
    assert list(output.parent.iterdir()) == []


def test_missing_spec_file(capsys, tmp_path: Path) -> None:
    missing = tmp_path / "nowhere.toml"
    output = tmp_path / "nowhere.nc"
    status, out, err = run(capsys, "run", missing, "-o", output, "--no-progress")
    assert status == 1
    assert out == ""
    assert str(missing) in err
    assert not output.exists()


def test_workers_must_be_positive(capsys, spec: Path, output: Path) -> None:
    with pytest.raises(SystemExit) as info:
        main(["run", str(spec), "-o", str(output), "--workers", "0"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "usage:" in err
    assert "--workers" in err
    assert not output.exists()


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["frobnicate"],
        ["run"],
        ["run", "spec.toml", "--colour", "red"],
        ["validate"],
        ["list", "--all"],
        ["run", "spec.toml", "--workers", "many"],
    ],
    ids=["nothing", "unknown-command", "run-no-spec", "unknown-option", "validate-no-file",
         "list-unknown-option", "workers-not-int"],
)
def test_usage_errors(capsys, argv: list[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    assert "usage:" in capsys.readouterr().err

