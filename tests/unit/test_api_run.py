"""``study.run`` and ``study.open_result``: a spec run from Python is the run of
``study run`` (same file, same values), returned as an in-memory dataset."""

from __future__ import annotations

import gc
import os
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import study
from study.cli import main

SPEC = """\
[study]
name = "api-small"
observables = ["thresholds", "velocity"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = { start = 12.0, stop = 17.0, num = 9 }
a = { start = 0.0, stop = 10.0, num = 7 }
"""


@pytest.fixture()
def spec_file(tmp_path: Path) -> Path:
    path = tmp_path / "api-small.toml"
    path.write_text(SPEC)
    return path


def test_run_returns_the_file_it_wrote(spec_file: Path, tmp_path: Path) -> None:
    output = tmp_path / "out.nc"
    ds = study.run(spec_file, output, workers=1)
    assert output.exists()
    on_disk = study.open_result(output)
    xr.testing.assert_identical(ds, on_disk)
    # The values are the solver's at the same points (an independent call).
    s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    v, status = study.steady_velocity(s, ds["f"].values[:, None], ds["a"].values[None, :])
    np.testing.assert_array_equal(ds["velocity"].values, v)
    np.testing.assert_array_equal(ds["status"].values, status)
    assert ds.attrs["study_coupling"] == "one-way"
    assert ds.encoding["source"] == str(output)


def test_run_is_the_command_line_run(spec_file: Path, tmp_path: Path) -> None:
    """`study run` writes the same numbers and the same variables (attributes too)."""
    ours = study.run(spec_file, tmp_path / "python.nc", workers=1)
    assert main(["run", str(spec_file), "-o", str(tmp_path / "cli.nc"), "--workers",
                 "1"]) == 0
    theirs = study.open_result(tmp_path / "cli.nc")
    xr.testing.assert_identical(ours.drop_attrs(deep=False), theirs.drop_attrs(deep=False))
    assert "study.run(" in ours.attrs["history"]


def test_default_output_is_beside_the_spec(spec_file: Path, tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """Not results/, the folder make owns (issue 34): <spec folder>/<stem>.nc."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    ds = study.run(spec_file, workers=1)
    assert Path(ds.encoding["source"]) == tmp_path / "api-small.nc"
    assert (tmp_path / "api-small.nc").exists()
    assert not (elsewhere / "results").exists() and not (tmp_path / "results").exists()


def test_a_second_run_is_up_to_date_and_force_recomputes(spec_file: Path,
                                                          tmp_path: Path) -> None:
    output = tmp_path / "out.nc"
    first = study.run(spec_file, output, workers=1)
    written = output.stat().st_ino
    study.run(spec_file, output, workers=1)
    assert output.stat().st_ino == written  # up to date: not rewritten
    forced = study.run(spec_file, output, workers=1, force=True)
    assert output.stat().st_ino != written  # a new file replaced it
    xr.testing.assert_identical(forced.drop_attrs(deep=False), first.drop_attrs(deep=False))


def test_no_file_handle_stays_open(spec_file: Path, tmp_path: Path) -> None:
    """filterwarnings=error makes a ResourceWarning of a leaked handle fail here; the
    file can also be removed and replaced while the dataset lives."""
    output = tmp_path / "out.nc"
    ds = study.run(spec_file, output, workers=1)
    os.replace(output, tmp_path / "moved.nc")
    gc.collect()
    assert float(ds["velocity"].isnull().sum()) >= 0  # values are in memory
    reopened = study.open_result(tmp_path / "moved.nc")
    del reopened
    gc.collect()


def test_open_result_names_the_file(tmp_path: Path) -> None:
    missing = tmp_path / "none.nc"
    with pytest.raises(study.ResultError, match=re.escape(str(missing))):
        study.open_result(missing)
    junk = tmp_path / "junk.nc"
    junk.write_text("not a netCDF file")
    with pytest.raises(study.ResultError, match=re.escape(str(junk))):
        study.open_result(junk)


def test_a_bad_spec_is_refused_naming_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(SPEC.replace("Q = 17.5", "Q = -1.0"))
    with pytest.raises(study.SpecError, match=r"bad\.toml"):
        study.run(bad, tmp_path / "out.nc")
    assert not (tmp_path / "out.nc").exists()


def test_study_info_names_the_coupling(spec_file: Path, tmp_path: Path, capsys) -> None:
    output = tmp_path / "out.nc"
    study.run(spec_file, output, workers=1)
    assert main(["info", str(output)]) == 0
    assert "  study 'api-small', one-way coupling, spec sha256" in capsys.readouterr().out


def test_another_kind_of_file_is_not_overwritten_unless_asked(spec_file: Path,
                                                              tmp_path: Path) -> None:
    from study.engine.outputs import OutputError

    notes = tmp_path / "notes.nc"
    notes.write_text("my notes")
    with pytest.raises(OutputError, match=r"notes\.nc"):
        study.run(spec_file, notes, workers=1)
    assert notes.read_text() == "my notes"
    ds = study.run(spec_file, notes, workers=1, overwrite=True)
    assert ds.attrs["study_name"] == "api-small"
