"""Seeded fuzz of the command line: random argv, run in this process by ``study.cli.main``.

The grammar is read from the CLI itself: every subcommand and its options, with their
metavars, from ``study --help`` and ``study SUBCOMMAND --help`` (so a new option is
fuzzed without editing this file). Each case (hypothesis, derandomized) picks a
subcommand, gives its positionals (sometimes leaving one out), zero to four options
and sometimes a stray token, in order or shuffled. Values come from pools by metavar:
the workspace's real inputs (a tiny spec, its result, a measurement file), a plain
text file, a folder, a FIFO, a link out of the folder, ``/dev/null`` and
``/dev/zero``, missing paths, an input named as the output, names that are not UTF-8,
empty strings, ``.``, ``/``, long and odd text, and numbers of every kind.

The workspace is a temporary folder that is the current directory while a case
runs. Not fuzzed: ``--scheduler`` and ``--workers`` (they start or wait for a dask
cluster; tests/integration/test_scheduler_address.py and test_distributed.py cover them).

Allowed outcomes: exit status 0, 1 or 2 (``SystemExit`` from argparse included);
with 1, one message on stderr, starting ``study: `` (an indented list of problems
may follow it; ``study validate`` gives one line for each file it was given);
never ``Traceback`` in the output, never an exception escaping ``main``, never a
hang (every case under a time limit); and every input file byte-identical
afterwards: a file the command read, and any file of the workspace the argv does
not name as its output.

``make fuzz`` runs it; a slice runs in ``make test`` (test_cli_fuzz_slice.py).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import re
import shutil
import warnings
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from study.cli import main
from study.engine.runner import run_study
from tests.fuzz.test_spec_runs import CaseTimeout, time_limit
from tests.support.reliability import record
from tests.unit.test_incremental import spec_text
from tests.unit.test_measurements import MINIMAL

#: Cases in ``make fuzz`` (``STUDY_FUZZ_CLI_CASES`` explores further).
CASES = int(os.environ.get("STUDY_FUZZ_CLI_CASES", "2000"))
#: Time limit of one case [s]: a tiny run or one figure takes about a second.
LIMIT = 20.0
#: Options not fuzzed (see module doc).
SKIPPED = ("--scheduler", "--workers", "-h", "--help")

OUTCOMES: Counter = Counter()
FAILURES: list[str] = []


# ---------------------------------------------------------------------------
# The grammar, from the CLI's help


@dataclass
class Option:
    flags: tuple[str, ...]
    metavar: str | None
    required: bool = False


@dataclass
class Command:
    words: tuple[str, ...]
    positionals: list[str] = field(default_factory=list)
    options: list[Option] = field(default_factory=list)


def help_text(words: tuple[str, ...]) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        main([*words, "--help"])
    return out.getvalue()


def parse_usage(words: tuple[str, ...]) -> Command:
    text = help_text(words)
    usage = " ".join(text.split("\n\n")[0].split())
    usage = usage.removeprefix("usage: study " + " ".join(words)).strip()
    command = Command(words)
    tokens = re.findall(r"\[[^\]]*\]|\{[^}]*\}|\S+", usage)
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if token.startswith("["):
            for alternative in token[1:-1].split(" | "):
                flag, _, metavar = alternative.strip().partition(" ")
                if not flag.startswith("-"):  # [FILE ...]: the positional repeated
                    command.positionals.append(flag)
                elif flag not in SKIPPED:
                    command.options.append(Option((flag,), metavar or None))
        elif token.startswith("-"):
            metavar = None
            if i + 1 < len(tokens) and re.fullmatch(r"[A-Z][A-Z_=,]*", tokens[i + 1]):
                metavar = tokens[i + 1]
                i += 1
            command.options.append(Option((token,), metavar, required=True))
        elif token != "...":
            command.positionals.append(token)
        i += 1
    return command


def grammar() -> dict[tuple[str, ...], Command]:
    top = help_text(())
    names = re.findall(r"^    ([a-z][\w-]*)\s", top, re.M)
    assert {"run", "cache", "validate", "figure", "export", "fit"} <= set(names), names
    return {(name,): parse_usage((name,)) for name in names}


# ---------------------------------------------------------------------------
# The workspace and the value pools

INPUTS = ("spec.toml", "result.nc", "measured.csv", "notes.txt")
PATHS = (*INPUTS, "sub", "fifo", "link-out.csv", "missing.nc", "out.nc", "out.csv", "out",
         "new/out.nc", "sub/out.nc", ".", "/", "", "/dev/null", "/dev/zero",
         "nc.\udcff.nc", "x" * 300 + ".nc", "-", "spec", "result")
NUMBERS = ("0", "1", "-1", "3", "0.5", "1e999", "nan", "inf", "-inf", "1e-320", "x", "",
           "9" * 30, "0x10", "6_25")
GARBAGE = ("", " ", "-", "--", "--nope", "x" * 300, "\udcff", "é", "..", "=", ",", ":",
           "1,2,3", "a=b=c")
POOLS: dict[str, tuple[str, ...]] = {
    "KEY=VALUE": ("f=13", "f==13", "a=2:6", "f=12,14", "f=", "=1", "x=1", "f=nan",
                  "f=1e999", "f=x", "status=0"),
    "F,A": ("13,5", "13", "x,y", "nan,nan", "1e999,1", "13,5,7", "-1,-1", "0,0"),
    "NAME": ("thresholds", "velocity-curves", "regime-map", "force-traces", "fit",
             "velocity", "status", "f", "nope", ""),
    "{list,prune,verify}": ("list", "prune", "verify", "nope"),
}


def pool(metavar: str) -> tuple[str, ...]:
    if metavar in POOLS:
        return POOLS[metavar]
    if metavar.startswith("{"):
        return (*metavar[1:-1].split(","), "nope")
    if metavar in ("N", "S", "SECONDS", "DAYS"):
        return NUMBERS
    return PATHS


@st.composite
def argvs(draw, commands: dict[tuple[str, ...], Command]) -> tuple[list[str], set[str],
                                                                   set[str]]:
    """An argv, the values it gives as inputs and those it gives as outputs."""
    command = commands[draw(st.sampled_from(sorted(commands)))]
    argv = list(command.words)
    inputs, outputs = set(), set()

    def value(metavar: str) -> str:
        if draw(st.integers(0, 5)) == 0:
            return draw(st.one_of(st.sampled_from(GARBAGE), st.text(max_size=6)))
        return draw(st.sampled_from(pool(metavar)))

    for positional in command.positionals:
        if draw(st.integers(0, 9)):
            argv.append(value(positional))
            inputs.add(argv[-1])
    chosen = [o for o in command.options if o.required and draw(st.integers(0, 9))]
    chosen += draw(st.lists(st.sampled_from(command.options), max_size=4)
                   if command.options else st.just([]))
    for option in chosen:
        argv.append(draw(st.sampled_from(option.flags)))
        if option.metavar:
            argv.append(value(option.metavar))
            (outputs if option.flags[0] in ("-o", "--csv") else inputs).add(argv[-1])
    if draw(st.integers(0, 9)) == 0:
        argv.insert(draw(st.integers(0, len(argv))), draw(st.sampled_from(GARBAGE)))
    if draw(st.integers(0, 4)) == 0:
        argv = list(draw(st.permutations(argv)))
    return argv, inputs, outputs


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Iterator[Path]:
    folder = tmp_path_factory.mktemp("cli")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("STUDY_CACHE", str(folder / ".study-cache"))  # not the user's
        yield make_workspace(folder, tmp_path_factory)


def make_workspace(folder: Path, tmp_path_factory) -> Path:
    (folder / "spec.toml").write_text(spec_text(
        name="spec", f="start = 12.0, stop = 16.0, num = 3", a="start = 2.0, stop = 10.0, num = 2"))
    with time_limit(600):  # compiles the kernels unless their cache is current
        run_study(folder / "spec.toml", folder / "result.nc", progress=False,
                  cache=folder / ".study-cache")
    (folder / "measured.csv").write_text(MINIMAL)
    (folder / "notes.txt").write_text("a file of another kind\n")
    (folder / "sub").mkdir()
    os.mkfifo(folder / "fifo")
    outside = tmp_path_factory.mktemp("outside") / "elsewhere.csv"
    outside.write_text(MINIMAL)
    (folder / "link-out.csv").symlink_to(outside)
    return folder


def fingerprints(folder: Path) -> dict[str, str]:
    return {name: hashlib.sha256((folder / name).read_bytes()).hexdigest()
            for name in INPUTS}


def run_argv(argv: list[str]) -> tuple[int | str, str, str]:
    """Exit status (or what escaped), stdout, stderr of ``study ARGV``."""
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
                warnings.catch_warnings(), time_limit(LIMIT):
            warnings.simplefilter("default")  # as a user's shell shows them
            status: int | str = main(argv)
    except SystemExit as exit_:
        status = exit_.code if isinstance(exit_.code, int) else 2
    except CaseTimeout:
        status = f"HANG (no end within {LIMIT:g} s)"
    except BaseException as error:  # any escape is what the fuzz finds
        status = f"TRACEBACK {type(error).__name__}: {error}"
    return status, out.getvalue(), err.getvalue()


def judge(workspace: Path, argv: list[str], inputs: set[str], outputs: set[str]) -> str:
    before = fingerprints(workspace)
    previous = Path.cwd()
    os.chdir(workspace)
    try:
        status, out, err = run_argv(argv)
    finally:
        os.chdir(previous)
    shown = f"study {' '.join(map(repr, argv))}"
    assert status in (0, 1, 2), f"{shown}: {status}\n{err[-1500:]}"
    assert "Traceback" not in out + err, f"{shown}:\n{err[-1500:]}"
    if status == 1:
        messages = [line for line in err.split("\n") if line and not line[0].isspace()]
        # validate reports on each file it is given, one line each
        most = max(1, len(argv) - 1) if argv[:1] == ["validate"] else 1
        assert 1 <= len(messages) <= most, f"{shown}:\n{err}"
        assert all(m.startswith("study: ") for m in messages), f"{shown}:\n{err}"
    after = fingerprints(workspace)
    for name in INPUTS:
        if after[name] != before[name]:
            named_output = any(Path(workspace, o).resolve() == (workspace / name).resolve()
                               for o in outputs if o)
            named_input = any(Path(workspace, i).resolve() == (workspace / name).resolve()
                              for i in inputs if i)
            assert named_output and not named_input and status == 0, \
                f"{shown} changed {name} (exit {status})"
    OUTCOMES[f"exit {status}"] += 1
    return f"exit {status}"


def restore(workspace: Path) -> None:
    """Outputs a case may leave that would change what later cases test."""
    for name in ("new", "results", "figures"):
        shutil.rmtree(workspace / name, ignore_errors=True)


COMMANDS = None


def commands() -> dict[tuple[str, ...], Command]:
    global COMMANDS
    if COMMANDS is None:
        COMMANDS = grammar()
    return COMMANDS


def fuzz_settings(cases: int) -> settings:
    """Derandomized, no example database, no deadline, and no shrinking: a failing case
    is reported as found (shrinking a hang would rerun it for minutes)."""
    return settings(max_examples=cases, derandomize=True, database=None, deadline=None,
                    suppress_health_check=list(HealthCheck),
                    phases=[Phase.explicit, Phase.generate])


@pytest.mark.fuzz
def test_the_grammar_is_read_from_the_cli() -> None:
    found = commands()
    assert found[("run",)].positionals == ["spec"]
    assert any(o.flags == ("--overwrite",) for o in found[("run",)].options)
    assert any(o.flags == ("--csv",) and o.required for o in found[("export",)].options)
    assert found[("cache",)].positionals == ["{list,prune,verify}"]


@pytest.mark.fuzz
@fuzz_settings(CASES)
@given(data=st.data())
def test_random_arguments_exit_0_1_or_2_in_one_message_and_change_no_input(
        data, workspace: Path) -> None:
    argv, inputs, outputs = data.draw(argvs(commands()))
    try:
        judge(workspace, argv, inputs, outputs)
    except AssertionError as failure:  # all failures are listed by the last test
        FAILURES.append(str(failure).split("\nassert ")[0][:800])
        OUTCOMES["failed"] += 1
    restore(workspace)


@pytest.mark.fuzz
def test_every_outcome_is_common_and_recorded(workspace: Path) -> None:
    tried = sum(OUTCOMES.values())
    print(f"\ncommand line: {tried} cases: {dict(OUTCOMES.most_common())}")
    if tried < CASES:
        pytest.skip("the generator did not run in this session")
    assert not FAILURES, f"{len(FAILURES)} failures of {tried}:\n" + "\n".join(FAILURES[:40])
    assert OUTCOMES["exit 0"] >= CASES // 20 and OUTCOMES["exit 1"] >= CASES // 5, OUTCOMES
    assert OUTCOMES["exit 2"] >= CASES // 20, OUTCOMES
    record("tests/fuzz/test_cli_arguments.py",
           "command line: random argv from the real subcommands and options with hostile "
           "values; exit 0/1/2, one message, inputs unchanged",
           cases=tried, faults=tried, results_checked=tried)
