"""``study export FILE --csv OUT``: tidy tables read back with the csv module alone,
compared value by value, unit by unit and status by status with the netCDF file."""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from study.analyses.export import ExportError, export_csv, tables
from study.cli import main
from study.engine.runner import run_scene, run_study
from study.engine.validation import open_result
from tests.support.sealed_results import scene_text

SPEC = """
[study]
name = "q-and-m"
title = "Thresholds, velocity and frontier for two Q and two M"
observables = ["thresholds", "velocity", "frontier"]

[structure]
f0 = 14.44
alpha = 64.0
cs = 0.25

[sweep]
Q = { values = [17.5, 30.0] }
M = { values = [0.08, 0.15] }
f = { start = 13.0, stop = 16.0, num = 7 }
a = { start = 0.0, stop = 12.0, num = 5 }
"""


@pytest.fixture(scope="module")
def swept(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("export")
    (folder / "q-and-m.toml").write_text(SPEC)
    return run_study(folder / "q-and-m.toml", folder / "q-and-m.nc", progress=False,
                     workers=1).output


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("scene")
    (folder / "steering.toml").write_text(scene_text())
    return run_scene(folder / "steering.toml", folder / "steering.nc").output


def read(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with open(path, newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    return rows[0], [dict(zip(rows[0], row, strict=True)) for row in rows[1:]]


def header_of(name: str, variable: xr.DataArray) -> str:
    units = variable.attrs.get("units")
    if "flag_meanings" in variable.attrs or not units or variable.dtype.kind in "OSU":
        return name
    return f"{name} [{units}]"


def number(cell: str) -> float:
    return math.nan if cell == "" else float(cell)


def check_table(dataset: xr.Dataset, path: Path, dims: tuple[str, ...],
                variables: list[str]) -> None:
    """Every cell of the CSV against the dataset: one row per point of ``dims``."""
    header, rows = read(path)
    assert len(rows) == int(np.prod([dataset.sizes[d] for d in dims]))
    expected = [header_of(d, dataset[d]) if d in dataset.coords else d for d in dims]
    expected += [header_of(str(n), c) for n, c in dataset.coords.items()
                 if n not in dims and set(c.dims) <= set(dims)]
    expected += [header_of(v, dataset[v]) for v in variables]
    assert header == expected
    names = dict(zip(header, [h.split(" [")[0] for h in header], strict=True))
    for row in rows:
        where = {d: (float(row[h]) if d in dataset.coords else int(row[h]))
                 for h, d in names.items() if d in dims}
        point = dataset.sel({d: v for d, v in where.items() if d in dataset.coords})
        point = point.isel({d: v for d, v in where.items() if d not in dataset.coords})
        for column, name in names.items():
            if name not in point.variables:
                continue  # a dimension without coordinate: its position, used above
            value = point[name]
            if "flag_meanings" in value.attrs:
                meanings = str(value.attrs["flag_meanings"]).split()
                codes = list(np.atleast_1d(value.attrs["flag_values"]))
                assert row[column] == meanings[codes.index(int(value))]
            elif value.dtype.kind == "f":
                got, want = number(row[column]), float(value)
                assert got == want or (math.isnan(got) and math.isnan(want)), (column, row)
            else:
                assert row[column] == str(value.values.item())


def test_a_swept_q_and_m_study_round_trips(swept: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "map.csv"
    assert main(["export", str(swept), "--csv", str(out)]) == 0
    dataset = open_result(swept)
    printed = capsys.readouterr().out
    assert f"wrote {out} (140 rows, " in printed
    frontier = tmp_path / "map.Q-M-a-branch.csv"
    assert f"wrote {frontier} " in printed
    point_vars = ["a_star_plus", "a_star_minus", "velocity", "status"]
    check_table(dataset, out, ("Q", "M", "f", "a"), point_vars)
    header, rows = read(out)
    assert header[:6] == ["Q [1]", "M [1]", "f [Hz]", "a [m s-2]", "alpha [degree]", "ck [1]"]
    assert "velocity [m s-1]" in header and "status" in header
    assert {r["status"] for r in rows} >= {"static", "stick_slip", "lift_off"}
    assert all(r["velocity [m s-1]"] == "" for r in rows if r["status"] == "lift_off")
    frontier_vars = [v for v in dataset.data_vars if dataset[v].dims[-1] == "branch"]
    check_table(dataset, frontier, ("Q", "M", "a", "branch"), frontier_vars)
    assert {r["frontier_kind"] for r in read(frontier)[1]} >= {"none"}
    # Nothing else written, no temporary left behind.
    assert sorted(p.name for p in tmp_path.iterdir()) == [frontier.name, out.name]


def test_selection_then_export(swept: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "slice.csv"
    assert main(["export", str(swept), "--csv", str(out), "--sel", "Q=29", "--sel", "M==0.15",
                 "--sel", "a=6", "--var", "velocity", "--var", "status"]) == 0
    assert "selected Q=30 (asked 29), M=0.15, a=6 m s-2" in capsys.readouterr().out
    header, rows = read(out)
    assert header[:2] == ["f [Hz]", "Q [1]"] and header[-2:] == ["velocity [m s-1]", "status"]
    assert [r["Q [1]"] for r in rows] == ["30.0"] * 7 and len(rows) == 7
    dataset = open_result(swept).sel(Q=30.0, M=0.15, a=6.0)
    check_table(dataset, out, ("f",), ["velocity", "status"])


def test_a_list_selection_exports_just_those_values(swept: Path, tmp_path: Path,
                                                    capsys) -> None:
    out = tmp_path / "list.csv"
    assert main(["export", str(swept), "--csv", str(out), "--sel", "Q=30", "--sel", "M=0.15",
                 "--sel", "f=13,14.6", "--sel", "a==0,12", "--var", "velocity"]) == 0
    assert "selected Q=30, M=0.15, f=13,14.5 Hz (asked 13,14.6), a=0,12 m s-2" in \
        capsys.readouterr().out
    _, rows = read(out)
    assert sorted({(r["f [Hz]"], r["a [m s-2]"]) for r in rows}) == [
        ("13.0", "0.0"), ("13.0", "12.0"), ("14.5", "0.0"), ("14.5", "12.0")]
    dataset = open_result(swept).sel(Q=30.0, M=0.15, f=[13.0, 14.5], a=[0.0, 12.0])
    check_table(dataset, out, ("f", "a"), ["velocity"])


def test_errors_are_one_line(swept: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "x.csv"
    assert main(["export", str(swept), "--csv", str(out), "--sel", "Q==20"]) == 1
    assert capsys.readouterr().err == (
        f"study: {swept}: --sel Q==20: Q has no value 20 exactly; available: 17.5, 30 "
        "(or Q=20 for the nearest)\n")
    assert main(["export", str(swept), "--csv", str(out), "--sel", "mu=0.3"]) == 1
    err = capsys.readouterr().err
    assert "--sel mu=0.3: no coordinate 'mu' in this file; available: Q [1]: 17.5, 30;" in err
    assert main(["export", str(swept), "--csv", str(out), "--var", "speed"]) == 1
    assert "--var speed: no such variable; available: a_star_plus, " in capsys.readouterr().err
    assert main(["export", str(tmp_path / "none.nc"), "--csv", str(out)]) == 1
    assert "none.nc" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere")
def test_an_unwritable_folder_is_one_line(swept: Path, tmp_path: Path, capsys) -> None:
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        assert main(["export", str(swept), "--csv", str(folder / "x.csv")]) == 1
    finally:
        folder.chmod(0o700)
    assert capsys.readouterr().err.startswith(f"study: {folder / 'x.csv'}: cannot write")


def test_a_scene_exports_its_tables(scene: Path, tmp_path: Path) -> None:
    dataset = open_result(scene)
    written = export_csv(dataset, tmp_path / "steering.csv", source=str(scene))
    assert [p.name for p, _, _ in written] == [
        "steering.csv", "steering.segment.csv", "steering.plate.csv"]
    for table, (path, _, _) in zip(tables(dataset), written, strict=True):
        check_table(dataset, path, table.dims, list(table.variables))
    header, rows = read(tmp_path / "steering.segment.csv")
    assert "heading_change [degree]" in header and "segment_status" in header
    assert [r["segment_label"] for r in rows] == [
        "forward", "right", "forward", "left", "forward", "backward"]
    assert "heading [degree]" in read(tmp_path / "steering.csv")[0]


def test_grouping_rule() -> None:
    dataset = xr.Dataset({"row": ("f", [1.0, 2.0]), "point": (("f", "a"), np.zeros((2, 3))),
                          "frontier": (("a", "branch"), np.zeros((3, 1))),
                          "note": ((), 1.0)})
    assert [(t.dims, t.variables) for t in tables(dataset)] == [
        (("f", "a"), ("row", "point", "note")), (("a", "branch"), ("frontier",))]
    with pytest.raises(ExportError, match="--var x: no such variable; available: row, "):
        tables(dataset, ["x"], source="d.nc")
