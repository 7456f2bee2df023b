"""``make figures`` draws from one process (``python -m study.figure_batch``, which
forks a child per figure): each command does what its own ``study figure`` process does
(same pictures, same ``--if-changed`` check, same exit status), a failure stops the batch
as it stops make, and every figure rule of the Makefile goes through it."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from study.cli import main
from study.figure_batch import read_commands, run_commands

ROOT = Path(__file__).resolve().parents[2]

SPEC = """\
[study]
name = "own"
observables = ["resonance", "thresholds"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = { start = 10.0, stop = 20.0, num = 9 }
a = { start = 0.0, stop = 12.0, num = 4 }
"""


@pytest.fixture
def result(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "own.toml").write_text(SPEC)
    assert main(["run", "own.toml", "-o", "results/own.nc"]) == 0
    return tmp_path / "results" / "own.nc"


def test_read_commands_splits_lines_as_a_shell_and_skips_blank_ones() -> None:
    text = "figure thresholds 'a b.nc' -o figures/t --if-changed\n\n  \nfigure x y\n"
    assert read_commands(text) == [["figure", "thresholds", "a b.nc", "-o", "figures/t",
                                    "--if-changed"], ["figure", "x", "y"]]


def test_the_batch_draws_what_study_figure_draws_and_then_finds_it_current(
        result: Path, capfd: pytest.CaptureFixture[str]) -> None:
    assert main(["figure", "thresholds", str(result), "-o", "alone"]) == 0
    commands = [["figure", "thresholds", str(result), "-o", f"figures/{name}", "--if-changed"]
                for name in ("one", "two")]
    capfd.readouterr()
    assert run_commands(commands, jobs=2) == 0
    out = capfd.readouterr().out
    for name in ("one", "two"):
        assert f"study figure thresholds {result} -o figures/{name} --if-changed" in out
        assert f"wrote figures/{name}.png" in out and f"wrote figures/{name}.pdf" in out
        assert Path(f"figures/{name}.png").read_bytes() == Path("alone.png").read_bytes()

    assert run_commands(commands, jobs=2) == 0
    out = capfd.readouterr().out
    assert out.count("up to date") == 2 and "wrote" not in out


def test_a_failed_command_stops_the_batch_with_its_status(
        result: Path, capfd: pytest.CaptureFixture[str]) -> None:
    commands = [["figure", "thresholds", "results/none.nc", "-o", "figures/a"],
                ["figure", "thresholds", str(result), "-o", "figures/b"]]
    capfd.readouterr()
    assert run_commands(commands, jobs=1) == 1
    out, err = capfd.readouterr()
    assert "results/none.nc" in err
    assert "'study figure thresholds results/none.nc -o figures/a' failed (status 1)" in err
    assert "figures/b" not in out and not Path("figures/b.png").exists()

    assert run_commands([["figure", "no-such-figure", str(result)]]) == 2  # argparse's
    assert "invalid choice" in capfd.readouterr().err


def test_the_module_reads_its_commands_from_a_file_or_standard_input(result: Path) -> None:
    line = f"figure thresholds {result} -o figures/t --if-changed\n"
    Path("commands").write_text(line)
    done = subprocess.run([sys.executable, "-m", "study.figure_batch", "--jobs", "2",
                           "commands"], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert "wrote figures/t.png" in done.stdout
    done = subprocess.run([sys.executable, "-m", "study.figure_batch", "-"], input=line,
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0 and "figures/t.png: up to date" in done.stdout, done.stderr
    done = subprocess.run([sys.executable, "-m", "study.figure_batch", "none"],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 1 and "none" in done.stderr


def test_make_figures_runs_every_figure_rule_through_the_batch() -> None:
    makefile = (ROOT / "Makefile").read_text()
    target = re.search(r"^figures:.*\n((?:\t.*\n)+)", makefile, re.MULTILINE)
    assert target is not None
    assert "-m study.figure_batch --jobs $(FIGURE_JOBS)" in target[1]
    assert re.search(r"^FIGURE_JOBS \?= 2$", makefile, re.MULTILINE)
    recipes = re.findall(r"^\t(.*) figure .*--if-changed$", makefile, re.MULTILINE)
    assert len(recipes) >= 6 and set(recipes) == {"$(STUDY_FIGURE)"}
