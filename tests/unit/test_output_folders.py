"""Every command creates the folders it writes to, says truthfully what a failed write
kept, and a figure drawn from another file never passes for one of ``make figures``."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

import study.engine.runner
from study.cli import default_figure_output, main
from study.engine.store import StoreError, open_result


def spec_text(name: str, Q: float = 17.5, observables: str = '"resonance", "thresholds"',
              extra: str = "") -> str:
    return f"""\
[study]
name = "{name}"
observables = [{observables}]

[structure]
f0 = 14.44
Q = {Q}
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = {{ start = 10.0, stop = 20.0, num = 9 }}
a = {{ start = 0.0, stop = 12.0, num = 4 }}
{extra}"""


def run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    capsys.readouterr()
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.fixture
def fresh(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A working folder with one spec and no results/ or figures/ folder, as on a fresh
    clone."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "own.toml").write_text(spec_text("own"))
    return tmp_path


def test_run_creates_the_default_results_folder(capsys, fresh: Path) -> None:
    assert not (fresh / "results").exists()
    status, out, err = run(capsys, "run", "own.toml")
    assert status == 0, err
    assert (fresh / "results" / "own.nc").is_file()
    assert "results/own.nc" in out


def test_run_creates_the_folders_of_an_explicit_output(capsys, fresh: Path) -> None:
    status, _, err = run(capsys, "run", "own.toml", "-o", "out/deeper/x.nc")
    assert status == 0, err
    assert open_result(fresh / "out" / "deeper" / "x.nc").attrs["study_name"] == "own"


def test_export_creates_the_folders_of_its_table(capsys, fresh: Path) -> None:
    assert run(capsys, "run", "own.toml", "-o", "own.nc")[0] == 0
    status, out, err = run(capsys, "export", "own.nc", "--csv", "newdir/sub/own.csv")
    assert status == 0, err
    table = fresh / "newdir" / "sub" / "own.csv"
    assert table.is_file()
    assert f"wrote {Path('newdir/sub/own.csv')}" in out
    assert table.read_text().splitlines()[0].startswith("f [Hz]")


def test_a_figure_without_output_is_named_after_its_file(capsys, fresh: Path) -> None:
    assert run(capsys, "run", "own.toml", "-o", "own.nc")[0] == 0
    status, _, err = run(capsys, "figure", "thresholds", "own.nc")
    assert status == 0, err
    assert default_figure_output("thresholds", Path("own.nc")) == Path(
        "figures/own-thresholds")
    assert (fresh / "figures" / "own-thresholds.png").is_file()
    assert (fresh / "figures" / "own-thresholds.pdf").is_file()
    # never the name make figures gives the workflow's figure
    assert not (fresh / "figures" / "thresholds.png").exists()


def test_figure_output_folders_are_created(capsys, fresh: Path) -> None:
    assert run(capsys, "run", "own.toml", "-o", "own.nc")[0] == 0
    status, _, err = run(capsys, "figure", "thresholds", "own.nc", "-o", "a/b/c/t")
    assert status == 0, err
    assert (fresh / "a" / "b" / "c" / "t.png").is_file()
    assert not list((fresh / "a" / "b" / "c").glob(".*"))  # no temporary left


def test_if_changed_redraws_a_figure_drawn_from_another_file(capsys, fresh: Path) -> None:
    (fresh / "other.toml").write_text(spec_text("other", Q=30.0))
    assert run(capsys, "run", "own.toml", "-o", "results/own.nc")[0] == 0
    assert run(capsys, "run", "other.toml", "-o", "results/other.nc")[0] == 0
    stem = fresh / "figures" / "thresholds"

    # make figures draws it, then finds it current
    status, out, _ = run(capsys, "figure", "thresholds", "results/own.nc", "-o", stem,
                         "--if-changed")
    assert status == 0 and "wrote" in out
    drawn = stem.with_suffix(".png").read_bytes()
    status, out, _ = run(capsys, "figure", "thresholds", "results/own.nc", "-o", stem,
                         "--if-changed")
    assert status == 0 and "up to date" in out and "wrote" not in out
    assert stem.with_suffix(".png").read_bytes() == drawn

    # a user draws another structure to the same name; its date is newer than the result
    assert run(capsys, "figure", "thresholds", "results/other.nc", "-o", stem)[0] == 0
    foreign = stem.with_suffix(".png").read_bytes()
    assert foreign != drawn
    os.utime(fresh / "results" / "own.nc", (1, 1))
    status, out, _ = run(capsys, "figure", "thresholds", "results/own.nc", "-o", stem,
                         "--if-changed")
    assert status == 0 and "wrote" in out, out
    assert stem.with_suffix(".png").read_bytes() != foreign

    # other options are another drawing too
    status, out, _ = run(capsys, "figure", "thresholds", "results/own.nc", "-o", stem,
                         "--if-changed", "--sel", "f=10:15")
    assert status == 0 and "wrote" in out

    # a missing PDF is redrawn
    assert run(capsys, "figure", "thresholds", "results/own.nc", "-o", stem)[0] == 0
    stem.with_suffix(".pdf").unlink()
    status, out, _ = run(capsys, "figure", "thresholds", "results/own.nc", "-o", stem,
                         "--if-changed")
    assert "wrote" in out and stem.with_suffix(".pdf").is_file()


def test_an_unwritable_output_claims_no_kept_values_when_none_were_computed(
        capsys, fresh: Path) -> None:
    (fresh / "plain-file").write_text("not a folder")
    status, _, err = run(capsys, "run", "own.toml", "-o", "plain-file/own.nc")
    assert status == 1
    assert "plain-file/own.nc" in err
    assert "kept" not in err
    assert len(err.strip().splitlines()) == 1


def test_a_failed_write_after_computing_says_where_the_values_are_kept(
        capsys, fresh: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (fresh / "moving.toml").write_text(spec_text("moving", observables='"velocity"'))

    def disk_full(temporary: Path, output: Path) -> Path:
        temporary.unlink(missing_ok=True)
        raise StoreError(f"{output}: cannot write the result (No space left on device); "
                         "any previous result is unchanged")

    with monkeypatch.context() as patched:
        patched.setattr(study.engine.runner, "commit", disk_full)
        status, _, err = run(capsys, "run", "moving.toml", "--cache", "kept")
    assert status == 1
    match = re.search(r"the (\d+) points computed are kept in (\S+) for the next run", err)
    assert match, err
    assert int(match[1]) == 9 * 4
    assert not (fresh / "results" / "moving.nc").exists()

    status, out, err = run(capsys, "run", "moving.toml", "--cache", "kept")
    assert status == 0, err
    assert "(0 computed, 36 reused)" in out
