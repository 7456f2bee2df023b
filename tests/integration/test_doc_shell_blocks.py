"""The shell blocks of the README and the documentation pages: every command they show
is one the project takes, and the README's own-structure example runs as printed.

* Every ``.venv/bin/study ...`` line (comments and placeholders aside) is parsed by the
  real argument parser (:func:`study.cli.build_parser`): a renamed option, a figure that
  no longer exists or a value of the wrong form fails here, naming page and line.
* Every ``make TARGET ...`` line names targets the Makefile has (``make -n``: nothing
  runs).
* The README's "Your own structure" example, its spec block saved where the README says
  (``own/own.toml``) and its three commands, runs in a temporary folder and writes what
  it says.

Lines with placeholders a reader fills in (``NAME``, ``FILE``, ``HOST``, ``[...]``) are
shown, not run; commands of other programs (``dask scheduler``) are the cluster page's.
"""

from __future__ import annotations

import re
import shlex
import subprocess
from pathlib import Path

import pytest

from study.cli import build_parser, main
from study.engine.store import open_result
from study.model.status import Status
from tests.integration.test_doc_blocks import PAGES, ROOT, blocks, name

STUDY = ".venv/bin/study"
#: Words a reader replaces: a command holding one is a template, not a command.
PLACEHOLDER = re.compile(r"\b(NAME|FILE|STEM|HOST|OUT|DIR|ADDR|CSV|SPEC)\b|\[|\.\.\.")


def shell_lines(language: str = "sh") -> list[tuple[str, int, str]]:
    """``(page, line, command)`` of every command line of every shell block."""
    found = []
    for page in PAGES:
        for start, code in blocks(page.read_text(encoding="utf-8"), language):
            for offset, line in enumerate(code.splitlines(), start=1):
                command = line.split(" #", 1)[0].strip()
                if command and not command.startswith("#"):
                    found.append((name(page), start + offset, command))
    return found


LINES = shell_lines()
STUDY_LINES = [item for item in LINES
               if item[2].startswith(STUDY + " ") and not PLACEHOLDER.search(item[2])]
MAKE_LINES = [item for item in LINES if item[2].startswith("make")]


def test_the_pages_show_commands() -> None:
    assert len(STUDY_LINES) >= 20
    assert len(MAKE_LINES) >= 4
    assert any(page == "README.md" and command == "make" for page, _, command in MAKE_LINES)


@pytest.mark.parametrize(("page", "line", "command"), STUDY_LINES,
                         ids=[f"{p}:{n}" for p, n, _ in STUDY_LINES])
def test_every_study_command_shown_is_one_the_parser_takes(page: str, line: int,
                                                          command: str) -> None:
    argv = shlex.split(command)[1:]
    try:
        build_parser().parse_args(argv)
    except SystemExit as stop:
        pytest.fail(f"{page} line {line}: `{command}` is refused by study's parser "
                    f"(exit {stop.code})")


def test_a_wrong_command_is_caught() -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args(shlex.split("figure regime-mapp own/own.nc"))
    with pytest.raises(SystemExit):
        build_parser().parse_args(shlex.split("run own.toml --outptu x.nc"))


@pytest.mark.parametrize(("page", "line", "command"), MAKE_LINES,
                         ids=[f"{p}:{n}" for p, n, _ in MAKE_LINES])
def test_every_make_target_shown_exists(page: str, line: int, command: str) -> None:
    targets = shlex.split(command)[1:]
    done = subprocess.run(["make", "-n", *targets], cwd=ROOT, capture_output=True,
                          text=True, timeout=120)
    assert "No rule to make target" not in done.stderr, f"{page} line {line}: {done.stderr}"
    assert done.returncode == 0, f"{page} line {line}: `{command}`: {done.stderr}"


def test_the_readme_own_structure_example_runs_as_printed(tmp_path: Path,
                                                           monkeypatch, capsys) -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Your own structure", 1)[1].split("\n## ", 1)[0]
    (_, spec), = blocks(section, "toml")
    (_, commands), = blocks(section, "sh")
    saved_as = re.search(r"Save this spec as `([^`]+)`", section)
    assert saved_as is not None, "README: the own-structure section names no spec file"
    assert saved_as[1].startswith("own/"), "README and own-structure.md keep specs in own/"
    monkeypatch.chdir(tmp_path)
    spec_path = tmp_path / saved_as[1]
    spec_path.parent.mkdir(parents=True, exist_ok=True)
    spec_path.write_text(spec, encoding="utf-8")
    for line in commands.splitlines():
        argv = shlex.split(line.split(" #", 1)[0])
        assert argv[0] == STUDY
        status = main(argv[1:])
        assert status == 0, f"README: `{line}`: {capsys.readouterr().err}"
    result = open_result(tmp_path / "own" / "own.nc")
    assert result.attrs["study_name"] == "own"
    assert {"velocity", "frontier_frequency", "lift_off_acceleration"} <= set(result)
    assert (tmp_path / "own" / "regime-map.png").is_file()
    assert (tmp_path / "own" / "own.csv").read_text().startswith("f [Hz]")
    # the example writes nothing where make writes
    assert not (tmp_path / "results").exists() and not (tmp_path / "figures").exists()


# Slow tier: the tutorial's flight map; README's own-structure example keeps the shell
# blocks' headline check in the default tier (issue 46).
@pytest.mark.slow
def test_the_flight_tutorial_runs_as_printed(tmp_path: Path, monkeypatch, capsys) -> None:
    """docs/getting-started/flight.md: its spec saved where the page says, every
    ``study`` command of its shell blocks run in order (run, validate, info, figures,
    export); the file holds every variable the page reads."""
    page = ROOT / "docs" / "getting-started" / "flight.md"
    text = page.read_text(encoding="utf-8")
    specs = [code for _, code in blocks(text, "toml") if code.startswith("[study]")]
    assert len(specs) == 1, "the flight tutorial shows one spec"
    saved_as = re.search(r"^`(own/[\w.-]+\.toml)`", text, re.MULTILINE)
    assert saved_as is not None, "flight.md names no spec file in own/"
    commands = [line.split(" #", 1)[0].strip() for _, code in blocks(text, "sh")
                for line in code.splitlines()]
    commands = [line for line in commands if line.startswith(STUDY + " ")]
    assert f"{STUDY} run {saved_as[1]} -o own/flight.nc" in commands
    assert sum(line.startswith(f"{STUDY} figure ") for line in commands) >= 3
    monkeypatch.chdir(tmp_path)
    spec_path = tmp_path / saved_as[1]
    spec_path.parent.mkdir(parents=True, exist_ok=True)
    spec_path.write_text(specs[0], encoding="utf-8")
    for line in commands:
        status = main(shlex.split(line)[1:])
        assert status == 0, f"flight.md: `{line}`: {capsys.readouterr().err}"
    result = open_result(tmp_path / "own" / "flight.nc")
    assert result.attrs["study_lift_off"] == "flight"
    read = {"status", "velocity", "largest_hop", "airborne_fraction", "impacts_per_period",
            "floquet_multiplier", "orbit_period", "nonconvergence",
            "velocity_without_flight", "status_without_flight"}
    assert read <= set(result), f"flight.md reads {sorted(read - set(result))}, not written"
    for variable in read:
        assert f"`{variable}`" in text, f"flight.md does not name `{variable}`"
    # with flight no point stops at lift-off: the page's reading of the statuses
    assert (result["status"] == Status.BOUNCING).any()
    assert not (result["status"] == Status.LIFT_OFF).any()
    assert (result["status_without_flight"] == Status.LIFT_OFF).any()
    for stem in ("regime-map-flight", "bouncing", "velocity-curves-flight"):
        assert (tmp_path / "own" / f"{stem}.png").is_file()
    assert (tmp_path / "own" / "flight.csv").is_file()
    assert not (tmp_path / "results").exists() and not (tmp_path / "figures").exists()
