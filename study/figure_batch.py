"""Many ``study figure`` commands from one process: how ``make figures`` draws.

Every figure rule of the Makefile is one ``study figure NAME FILE -o OUT --if-changed``.
Run as processes of their own, each pays the start of Python and the imports of study
(numba, xarray, matplotlib) and the fingerprint of the figure code (the import graph
read with :mod:`ast`): about 2.5 s of the 3 s an up-to-date figure takes, and as much
again for each figure drawn. Here those are paid once, in this process; each command
then runs in a child forked from it (:func:`os.fork`), ``--jobs`` at a time. A child
is what a new ``study`` process would be after its imports, and it runs the same code
(:func:`study.cli.main`): the same ``--if-changed`` check, messages and exit status;
nothing one figure sets (matplotlib's state, a selection) is seen by another, since
each child starts from this process's state and ends with its figure.

``python -m study.figure_batch [--jobs N] FILE``: FILE (``-``: standard input) holds
one command per line, the arguments of ``study`` as a shell splits them (``figure
regime-map results/regime-map.nc -o figures/regime-map --if-changed``); blank lines
are skipped. Each command is printed as it starts. Exit status: 0 when every command
succeeded, else that of the first that failed; as make does, no command starts after a
failure and those running are waited for.
"""

from __future__ import annotations

import argparse
import importlib
import os
import shlex
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main", "read_commands", "run_commands"]


def read_commands(text: str) -> list[list[str]]:
    """The commands of ``text``: one ``study`` argument list per non-blank line."""
    return [shlex.split(line) for line in text.splitlines() if line.strip()]


def _prepare(commands: Sequence[Sequence[str]]) -> None:
    """Import, once and before any fork, what the figure commands use: the command line,
    the modules of the figures named and their code fingerprints (memoised per process,
    :func:`study.engine.fingerprint.code_fingerprint`, so every child inherits them),
    and what reading a result file imports on first use: dask (xarray asks whether the
    arrays are dask's, a fifth of a second), netCDF4, jsonschema (the header's check).
    """
    import dask  # noqa: F401
    import jsonschema  # noqa: F401
    import netCDF4  # noqa: F401

    import study.cli  # study, numba, xarray
    import study.engine.outputs
    import study.engine.validation  # noqa: F401
    from study.engine.fingerprint import code_fingerprint
    from study.figures import FIGURES

    for argv in commands:
        if len(argv) > 1 and argv[0] == "figure" and argv[1] in FIGURES:
            module = FIGURES[argv[1]].module
            importlib.import_module(module)
            code_fingerprint(("study.figures", module))  # as figure_request asks it


def _exit_code(code: object) -> int:
    """A process's exit status for ``sys.exit(code)``."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    print(code, file=sys.stderr)
    return 1


def _child(argv: Sequence[str]) -> None:
    """Run ``study ARGV`` in this forked child and end it with the command's status."""
    status = 1
    try:
        from study.cli import main

        status = _exit_code(main(list(argv)))
    except SystemExit as exit_:  # a usage error: argparse exits with 2
        status = _exit_code(exit_.code)
    except KeyboardInterrupt:
        status = 130
    except BaseException:  # what a `study` process would show: the traceback
        import traceback

        traceback.print_exc()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(status)


def _start(argv: Sequence[str]) -> int | subprocess.Popen:
    """Start ``study ARGV``: a forked child's id, or a process where there is no fork."""
    print("study " + shlex.join(argv), flush=True)
    sys.stderr.flush()
    if not hasattr(os, "fork"):
        return subprocess.Popen([sys.executable, "-m", "study.cli", *argv])
    pid = os.fork()
    if pid == 0:
        _child(argv)
    return pid


def run_commands(commands: Sequence[Sequence[str]], jobs: int = 1) -> int:
    """Run the ``study`` commands, ``jobs`` at a time; the exit status of
    :func:`main`."""
    _prepare(commands)
    pending = list(commands)
    running: dict[int, Sequence[str]] = {}
    processes: dict[int, subprocess.Popen] = {}
    failed = 0
    try:
        while pending or running:
            while pending and not failed and len(running) < max(1, jobs):
                started = _start(pending[0])
                if isinstance(started, subprocess.Popen):
                    processes[started.pid] = started
                    started = started.pid
                running[started] = pending.pop(0)
            if not running:
                break
            if processes:  # no fork: waited for in the order they started
                pid, process = next(iter(processes.items()))
                code = process.wait()
                del processes[pid]
            else:
                pid, wait_status = os.wait()
                code = os.waitstatus_to_exitcode(wait_status)
            argv = running.pop(pid)
            if code != 0 and not failed:
                failed = code if code > 0 else 1  # killed by a signal: 1
                print(f"study.figure_batch: 'study {shlex.join(argv)}' failed "
                      f"(status {code}); no other command is started", file=sys.stderr,
                      flush=True)
    except KeyboardInterrupt:  # the children had the same Ctrl-C
        for pid in running:
            try:
                os.waitpid(pid, 0)
            except ChildProcessError:
                pass
        return 130
    return failed


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m study.figure_batch [--jobs N] FILE``."""
    parser = argparse.ArgumentParser(
        prog="python -m study.figure_batch",
        description="run the study figure commands of FILE (one per line) in one "
                    "process, JOBS at a time")
    parser.add_argument("file", metavar="FILE",
                        help="the commands, one per line ('-': standard input)")
    parser.add_argument("-j", "--jobs", type=int, default=1, metavar="JOBS",
                        help="commands run at a time (default 1)")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error(f"--jobs must be >= 1, got {args.jobs}")
    try:
        text = sys.stdin.read() if args.file == "-" else Path(args.file).read_text(
            encoding="utf-8")
    except OSError as err:
        print(f"study.figure_batch: {args.file}: {err.strerror or err}", file=sys.stderr)
        return 1
    return run_commands(read_commands(text), jobs=args.jobs)


if __name__ == "__main__":
    sys.exit(main())
