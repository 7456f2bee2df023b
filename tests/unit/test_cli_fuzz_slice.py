"""A seeded slice of the command-line fuzz tier (tests/fuzz/test_cli_arguments.py) in
the unit tier, and the failures that tier found, each as a plain test."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from study.cli import main
from tests.fuzz.test_cli_arguments import (
    argvs,
    commands,
    fuzz_settings,
    judge,
    restore,
    workspace,  # noqa: F401 (the fixture)
)
from tests.unit.test_cache_health import deadline

SLICE = 150


@fuzz_settings(SLICE)
@given(data=st.data())
def test_random_arguments_slice(data, workspace: Path) -> None:  # noqa: F811
    argv, inputs, outputs = data.draw(argvs(commands()))
    judge(workspace, argv, inputs, outputs)
    restore(workspace)


LONG = "x" * 300


@pytest.mark.parametrize("argv", [
    ["validate", LONG + ".nc"],
    ["info", LONG + ".nc"],
    ["export", LONG + ".nc", "--csv", "out.csv"],
    ["list", "--workflows", LONG],
    ["cache", "list", "--cache", LONG],
])
def test_a_name_too_long_is_one_line_naming_it(argv: list[str], tmp_path: Path, monkeypatch,
                                                capsys) -> None:
    monkeypatch.chdir(tmp_path)
    with deadline(60):
        status = main(argv)
    err = capsys.readouterr().err
    assert status == 1 and err.count("\n") == 1 and err.startswith("study: "), err
    assert LONG in err and "Traceback" not in err


def test_a_cache_name_that_is_not_utf8_runs_and_is_recorded_escaped(workspace: Path,  # noqa: F811
                                                                    monkeypatch, capsys
                                                                    ) -> None:
    monkeypatch.chdir(workspace)
    with deadline(120):
        status = main(["run", "spec.toml", "-o", "new/escaped.nc", "--cache", "\udcff",
                       "--no-progress"])
    err = capsys.readouterr().err
    assert status == 0, err
    from study.engine.store import open_result

    assert "--cache '\\udcff'" in open_result(workspace / "new/escaped.nc").attrs["history"]
    restore(workspace)
