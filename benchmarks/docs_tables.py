"""The benchmark tables of the documentation: ``docs/speed/NAME.md``.

``docs/speed-and-accuracy.md`` includes these files; they are never typed by hand. Each
benchmark that ``make bench`` runs writes its table here (beside its own report in
``results/``), headed by one line that says which script wrote it, when, and on what
machine, so the page always shows the numbers of the last ``make bench`` with their
date. The files are committed: the documentation builds without running benchmarks.
"""

from __future__ import annotations

import os
import platform
import time
from pathlib import Path

import numba
import numpy as np

#: Where the documentation's benchmark tables live.
DOCS_SPEED = Path(__file__).resolve().parent.parent / "docs" / "speed"

#: Where a quick run (``--quick``, ``make bench-quick``) writes its tables and reports:
#: never ``docs/speed/`` nor the full run's reports, whose numbers stay those of a full
#: ``make bench``.
QUICK_OUTPUT = Path(__file__).resolve().parent.parent / "results" / "bench-quick"

_QUICK = {"on": False}


def quick_option(parser) -> None:
    """Add ``--quick`` to a benchmark's ``argparse`` parser (asv's quick mode: fewer
    rounds, smaller sizes, for a change's before and after; the tables go to
    :data:`QUICK_OUTPUT`)."""
    parser.add_argument("--quick", action="store_true",
                        help="fewer rounds and smaller sizes (a minute or so); tables "
                        "and reports go to results/bench-quick/, never docs/speed/")


def use_quick(on: bool) -> bool:
    """Switch this process to quick mode (``--quick``); returns ``on``."""
    _QUICK["on"] = bool(on)
    if on:
        QUICK_OUTPUT.mkdir(parents=True, exist_ok=True)
    return bool(on)


def is_quick() -> bool:
    """Whether this process runs in quick mode."""
    return _QUICK["on"]


def output(path: str | Path) -> Path:
    """Where a report goes: ``path``, or in quick mode the same name in
    :data:`QUICK_OUTPUT`."""
    path = Path(path)
    return QUICK_OUTPUT / path.name if _QUICK["on"] else path


def written_by(script: str, measured: str, date: str | None = None) -> str:
    """The first line of a table file: who wrote it, when and where it was measured.

    Parameters
    ----------
    script : str
        The benchmark's file name in ``benchmarks/``.
    measured : str
        The machine and conditions (CPU, cores, threads, versions, load).
    date : str, optional
        ``YYYY-MM-DD`` (UTC); default today.
    """
    date = date or time.strftime("%Y-%m-%d", time.gmtime())
    return (f"*Written by `make bench` (`benchmarks/{script}`); the next run overwrites "
            f"this file. Measured {date}, {measured}.*")


def write_docs_table(name: str, script: str, measured: str, table: str,
                     notes: str = "") -> Path:
    """Write ``docs/speed/NAME.md``: the :func:`written_by` line, the table, notes.

    Parameters
    ----------
    name : str
        File stem, e.g. ``"velocity-map"``.
    script : str
        The benchmark's file name in ``benchmarks/``.
    measured : str
        The machine and conditions, for :func:`written_by`.
    table : str
        The Markdown table.
    notes : str, optional
        Markdown after the table (accuracy, what a column means).

    Returns
    -------
    pathlib.Path
        The file written (via a temporary file beside it, then renamed).
    """
    text = f"{written_by(script, measured)}\n\n{table.rstrip()}\n"
    if notes:
        text += f"\n{notes.rstrip()}\n"
    path = (QUICK_OUTPUT / f"docs-{name}.md") if _QUICK["on"] else DOCS_SPEED / f"{name}.md"
    if _QUICK["on"]:
        text = text.replace("*Written by `make bench`", "*Written by `make bench-quick` "
                            "(fewer rounds, smaller sizes: not the documentation's numbers)",
                            1)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_text(text, encoding="utf-8")
    temporary.replace(path)
    print(f"wrote {path}")
    return path


def per_point(seconds: float, points: int) -> str:
    """Time per point in ns below 1 us, else in us (``216 ns``, ``1.4 us``)."""
    nanoseconds = seconds / points * 1e9
    return f"{nanoseconds:.0f} ns" if nanoseconds < 999.5 else f"{nanoseconds / 1e3:.2g} us"


def exponent(value: float) -> str:
    """A power of ten as people write it: ``1e-8``, not ``1e-08``."""
    mantissa, power = f"{value:.0e}".split("e")
    return f"{mantissa}e{int(power)}"


def machine() -> str:
    """The CPU, cores, numba threads and versions a benchmark ran on."""
    cpu = platform.machine()
    try:
        with open("/proc/cpuinfo") as info:
            cpu = next(line.split(":", 1)[1].strip() for line in info
                       if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return (f"{cpu}, {os.cpu_count()} cores, numba {numba.__version__} "
            f"({numba.config.NUMBA_NUM_THREADS} thread(s)), numpy {np.__version__}, "
            f"Python {platform.python_version()}")


def load_average() -> str:
    """The 1, 5 and 15 min load averages, or "unknown"."""
    try:
        return "{:.2f} {:.2f} {:.2f}".format(*os.getloadavg())
    except OSError:
        return "unknown"
