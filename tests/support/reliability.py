"""Counts of what the reliability suite tries, for its documentation page.

Each tier of the suite (``make fuzz``) calls :func:`record` once it has passed, with
what it tried: cases run, faults injected (damaged files, mutations, corrupted cells,
hostile arguments) and finished results compared afterwards, of which none may be
lost (a tier that loses one fails before it records). When the environment names a
file in :data:`ENV` (``make fuzz`` does), the counts are merged into it as JSON;
``python -m tests.support.reliability COUNTS.json`` prints the page's table. Without the
variable, :func:`record` does nothing: a plain ``pytest`` run writes no file. ``make
fuzz`` runs the tiers in pytest-xdist workers (one module per worker at a time): each
merge holds a lock beside the file, so that two workers recording at once keep both.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

try:
    import fcntl
except ImportError:  # Windows: no fcntl; make fuzz runs on POSIX
    fcntl = None  # type: ignore[assignment]

#: Environment variable naming the JSON file the counts are merged into.
ENV = "STUDY_RELIABILITY_COUNTS"


def record(tier: str, what: str, *, cases: int, faults: int, results_checked: int = 0,
           results_lost: int = 0) -> None:
    """Merge one passed tier's counts into the file named by :data:`ENV`, if any.

    Parameters
    ----------
    tier : str
        The tier's test module, e.g. ``tests/fuzz/test_measurement_files.py``.
    what : str
        What it does, in a few words.
    cases : int
        Cases run [1].
    faults : int
        Faults injected or hostile inputs given [1].
    results_checked : int
        Results or input files checked afterwards [1]: bit-identical to a clean
        reference (damaged cache), sealed and valid (spec runs, accepted result files),
        or byte-identical to before (the command line's input files).
    results_lost : int
        Of those, lost or changed [1] (0 for a passed tier: it fails first).
    """
    name = os.environ.get(ENV)
    if not name:
        return
    path = Path(name)
    path.parent.mkdir(parents=True, exist_ok=True)
    # Read, merge and replace under an exclusive lock: test workers record concurrently.
    with open(path.with_name(f".{path.name}.lock"), "a", encoding="utf-8") as lock:
        if fcntl is not None:
            fcntl.flock(lock, fcntl.LOCK_EX)
        counts = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}
        counts[tier] = {"what": what, "cases": cases, "faults": faults,
                        "results_checked": results_checked, "results_lost": results_lost}
        temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        temporary.write_text(json.dumps(counts, indent=2, sort_keys=True) + "\n",
                             encoding="utf-8")
        temporary.replace(path)


def table(counts: dict[str, dict]) -> str:
    """The counts as a Markdown table with a total row."""
    lines = ["| tier | what it tries | cases | faults injected | results checked | "
             "results lost |", "|---|---|---:|---:|---:|---:|"]
    total = dict.fromkeys(("cases", "faults", "results_checked", "results_lost"), 0)
    for tier, row in sorted(counts.items()):
        lines.append(f"| `{tier}` | {row['what']} | {row['cases']} | {row['faults']} | "
                     f"{row['results_checked']} | {row['results_lost']} |")
        for key in total:
            total[key] += row[key]
    lines.append(f"| **all** | | **{total['cases']}** | **{total['faults']}** | "
                 f"**{total['results_checked']}** | **{total['results_lost']}** |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(table(json.loads(Path(sys.argv[1]).read_text(encoding="utf-8"))), end="")
