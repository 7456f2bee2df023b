"""A log of run times: one line per ``study run --log-times FILE``, and the table of the
slowest.

``make`` passes ``--log-times results/run-times.jsonl`` to every ``study run`` and ends
with the table of the runs it started, slowest first (``python -m
study.engine.run_log results/run-times.jsonl --since T``): where a ``make`` spent its
time, with the points each run computed and reused beside it. Each run appends one JSON
line (well under the size the system writes in one piece, so runs side by side, ``make
-j``, never mix their lines); a line that cannot be read is skipped, never fatal: the
log is a report, not a result.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

__all__ = ["append_record", "main", "read_records", "record_of", "slowest_table"]

#: Rows of the table by default.
SHOWN = 10

#: The fields of a record, in the order of the table.
FIELDS = ("name", "kind", "wall_seconds", "points", "points_computed", "points_reused",
          "up_to_date", "started")


def record_of(report: Any, name: str, started: float) -> dict[str, Any]:
    """The log record of one run.

    Parameters
    ----------
    report : study.engine.runner.RunReport
        What the run did.
    name : str
        The spec's ``name``.
    started : float
        Unix time at the start of the run [s].

    Returns
    -------
    dict
        :data:`FIELDS` and the output's path.
    """
    return {
        "name": str(name),
        "kind": str(report.kind),
        "output": str(report.output),
        "wall_seconds": round(float(report.wall_seconds), 3),
        "points": int(report.points),
        "points_computed": int(report.points_computed),
        "points_reused": int(report.points_reused),
        "up_to_date": bool(report.up_to_date),
        "started": round(float(started), 3),
    }


def append_record(path: str | Path, record: dict[str, Any]) -> None:
    """Append ``record`` as one line to the log at ``path`` (its folder made if needed).

    The line is written by one ``write`` to a file opened for appending, so lines of
    runs side by side never interleave.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    line = (json.dumps(record, sort_keys=True) + "\n").encode("utf-8")
    descriptor = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(descriptor, line)
    finally:
        os.close(descriptor)


def _readable(record: Any) -> bool:
    if not isinstance(record, dict):
        return False
    try:
        return (isinstance(record["name"], str)
                and math.isfinite(float(record["wall_seconds"]))
                and math.isfinite(float(record["started"])))
    except (KeyError, TypeError, ValueError):
        return False


def read_records(path: str | Path, since: float | None = None) -> list[dict[str, Any]]:
    """The readable records of the log at ``path`` (none if it does not exist), those
    of runs started at or after ``since`` (Unix time [s]) if given; unreadable lines are
    skipped."""
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except FileNotFoundError:
        return []
    records = []
    for line in text.splitlines():
        try:
            record = json.loads(line)
        except ValueError:
            continue
        if not _readable(record):
            continue
        if since is not None and float(record["started"]) < since:
            continue
        records.append(record)
    return records


def _count(record: dict[str, Any], key: str) -> str:
    value = record.get(key)
    return str(value) if isinstance(value, int) and not isinstance(value, bool) else "?"


def slowest_table(records: Iterable[dict[str, Any]], shown: int = SHOWN) -> str:
    """A Markdown table of the ``shown`` slowest runs of ``records``, slowest first,
    and a line with the count and total wall time of them all.

    Parameters
    ----------
    records : iterable of dict
        Records as :func:`record_of` makes them.
    shown : int
        Rows at most.

    Returns
    -------
    str
        The table, or a line saying that nothing was run.
    """
    records = list(records)
    if not records:
        return "No study was run: every result is up to date.\n"
    ordered = sorted(records, key=lambda r: (-float(r["wall_seconds"]), r["name"]))
    lines = ["| study | kind | wall [s] | points | computed | reused |",
             "|---|---|---:|---:|---:|---:|"]
    for record in ordered[:shown]:
        kind = str(record.get("kind", "?"))
        if record.get("up_to_date"):
            kind += " (up to date)"
        lines.append(f"| {record['name']} | {kind} | {float(record['wall_seconds']):.1f} | "
                     f"{_count(record, 'points')} | {_count(record, 'points_computed')} | "
                     f"{_count(record, 'points_reused')} |")
    total = math.fsum(float(r["wall_seconds"]) for r in records)
    left = len(records) - min(shown, len(records))
    tail = f"; {left} more not shown" if left else ""
    lines.append("")
    lines.append(f"{len(records)} runs, {total:.1f} s of wall time summed over them "
                 f"(compiling the kernels included; runs side by side overlap){tail}.")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m study.engine.run_log LOG [--since T] [--shown N]``: print the table."""
    parser = argparse.ArgumentParser(
        prog="python -m study.engine.run_log",
        description="the slowest runs of a run-time log (study run --log-times)")
    parser.add_argument("log", type=Path, help="the log, e.g. results/run-times.jsonl")
    parser.add_argument("--since", type=float, default=None, metavar="T",
                        help="only runs started at or after Unix time T [s]")
    parser.add_argument("--shown", type=int, default=SHOWN, metavar="N",
                        help=f"rows at most (default {SHOWN})")
    args = parser.parse_args(argv)
    if args.shown < 1:
        parser.error(f"--shown {args.shown}: at least 1")
    records = read_records(args.log, args.since)
    if records:
        print(f"The slowest studies of this run ({args.log}):")
    sys.stdout.write(slowest_table(records, args.shown))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
