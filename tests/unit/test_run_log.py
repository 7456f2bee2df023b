"""The log of run times and its table of the slowest runs (study.engine.run_log,
``study run --log-times``): what ``make`` prints at its end."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from study.cli import main
from study.engine.run_log import append_record, read_records, slowest_table
from study.engine.run_log import main as table_main

from .test_cli import spec_text


def record(name: str, wall: float, computed: int = 0, reused: int = 0, *,
           kind: str = "study", up_to_date: bool = False, started: float = 100.0) -> dict:
    return {"name": name, "kind": kind, "output": f"results/{name}.nc",
            "wall_seconds": wall, "points": computed + reused,
            "points_computed": computed, "points_reused": reused,
            "up_to_date": up_to_date, "started": started}


def test_table_of_hand_built_records_slowest_first() -> None:
    records = [
        record("quick", 1.25, 10, 0),
        record("slow", 104.0, 96641, 0),
        record("scene", 39.04, 1, 0, kind="scene:calibration"),
        record("kept", 0.5, 0, 35, up_to_date=True),
    ]
    assert slowest_table(records, shown=3) == (
        "| study | kind | wall [s] | points | computed | reused |\n"
        "|---|---|---:|---:|---:|---:|\n"
        "| slow | study | 104.0 | 96641 | 96641 | 0 |\n"
        "| scene | scene:calibration | 39.0 | 1 | 1 | 0 |\n"
        "| quick | study | 1.2 | 10 | 10 | 0 |\n"
        "\n"
        "4 runs, 144.8 s of wall time summed over them (compiling the kernels included; "
        "runs side by side overlap); 1 more not shown.\n"
    )
    shown = slowest_table(records)
    assert "| kept | study (up to date) | 0.5 | 35 | 0 | 35 |" in shown
    assert "more not shown" not in shown


def test_ties_by_name_and_nothing_run() -> None:
    table = slowest_table([record("b", 2.0), record("a", 2.0)])
    assert table.index("| a |") < table.index("| b |")
    assert slowest_table([]) == "No study was run: every result is up to date.\n"


def test_log_appends_skips_bad_lines_and_filters_by_start(tmp_path: Path) -> None:
    log = tmp_path / "results" / "run-times.jsonl"  # folder made on the first line
    append_record(log, record("old", 5.0, started=10.0))
    append_record(log, record("new", 3.0, started=20.0))
    with log.open("a") as text:
        text.write('{"name": "torn", "wall_s\n')      # a torn line
        text.write("[1, 2]\n")                        # not a record
        text.write(json.dumps({"name": "x", "wall_seconds": "NaN", "started": 30}) + "\n")
    assert [r["name"] for r in read_records(log)] == ["old", "new"]
    assert [r["name"] for r in read_records(log, since=20.0)] == ["new"]
    assert read_records(tmp_path / "none.jsonl") == []


def test_table_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "run-times.jsonl"
    append_record(log, record("first", 7.0, 3, 4, started=50.0))
    assert table_main([str(log), "--since", "40"]) == 0
    out = capsys.readouterr().out
    assert "| first | study | 7.0 | 7 | 3 | 4 |" in out
    assert table_main([str(log), "--since", "60"]) == 0
    assert "every result is up to date" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        table_main([str(log), "--shown", "0"])


def test_study_run_appends_its_counts(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                      ) -> None:
    spec = tmp_path / "tiny.toml"
    spec.write_text(spec_text())
    output = tmp_path / "tiny.nc"
    log = tmp_path / "times.jsonl"
    for _ in range(2):  # computed, then up to date
        assert main(["run", str(spec), "-o", str(output), "--no-progress",
                     "--log-times", str(log)]) == 0
    first, second = read_records(log)
    assert (first["name"], first["kind"], first["up_to_date"]) == ("tiny", "study", False)
    assert (first["points"], first["points_computed"], first["points_reused"]) == (35, 35, 0)
    assert (second["up_to_date"], second["points_computed"]) == (True, 0)
    assert first["started"] <= second["started"]
    assert first["wall_seconds"] > 0.0
