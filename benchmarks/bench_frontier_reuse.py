"""Benchmark: a flight map with its frontier, run once, then again onto another output
and forced: the second and third runs reuse the kept points and the kept frontier.

The study of issue 34: M = 0.95, restitution 0.5, two-way coupling with flight, f 10-20
Hz (101 values) x a 2-12 m s-2 (61 values), observables velocity and frontier. Each run
is a whole ``study run`` command in its own process (compile time, kept-value reads,
writing and sealing included), timed by the wall clock; the cache starts empty for the
first. Timings are reported, never asserted: ``results/bench-frontier-reuse.md``.

Usage: ``python benchmarks/bench_frontier_reuse.py [--quick]`` (``--quick``: a 41 x 25
map; the table goes to ``results/bench-quick/``). The table also goes to
``docs/speed/frontier-reuse.md``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_study_overhead import machine
from docs_tables import output, quick_option, use_quick, write_docs_table

SPEC = """
[study]
name = "frontier-reuse"
observables = ["velocity", "frontier"]
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.95
cs = 0.25
restitution = 0.5
[sweep]
f = { start = 10.0, stop = 20.0, num = 101 }
a = { start = 2.0, stop = 12.0, num = 61 }
[solver]
coupling = "two-way"
flight = true
"""


def _run(study: Path, folder: Path, output: str, *extra: str) -> tuple[float, str]:
    started = time.perf_counter()
    done = subprocess.run([str(study), "run", "spec.toml", "-o", output, "--cache", "cache",
                           "--no-progress", *extra], cwd=folder, capture_output=True,
                          text=True, check=True)
    return time.perf_counter() - started, done.stdout.strip().splitlines()[-1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    quick_option(parser)
    args = parser.parse_args()
    spec, grid = SPEC, "101 x 61"
    if use_quick(args.quick):
        spec = spec.replace("num = 101", "num = 41").replace("num = 61", "num = 25")
        grid = "41 x 25"
    study = Path(sys.executable).with_name("study")
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        (folder / "spec.toml").write_text(spec)
        rows = [("first run (empty cache)", *_run(study, folder, "first.nc")),
                ("onto another output", *_run(study, folder, "second.nc")),
                ("forced (--force)", *_run(study, folder, "second.nc", "--force"))]
    first = rows[0][1]
    table = [f"A {grid} flight map with its frontier (M = 0.95, e = 0.5), each run a whole "
             "`study run` process:", "",
             "| run | wall time [s] | against the first |", "|---|---|---|"]
    table += [f"| {what} | {seconds:.2f} | {seconds / first:.3f} |"
              for what, seconds, _ in rows]
    last = "Last lines: " + "; ".join(f"{what}: `{line}`" for what, _, line in rows)
    lines = [f"*Written by `make bench` on {time.strftime('%Y-%m-%d')}: {machine()}.*", "",
             *table, "", last]
    text = "\n".join(lines) + "\n"
    print(text)
    report = output(Path("results/bench-frontier-reuse.md"))
    report.parent.mkdir(exist_ok=True)
    report.write_text(text)
    write_docs_table("frontier-reuse", "bench_frontier_reuse.py", machine(), "\n".join(table),
                     last)


if __name__ == "__main__":
    main()
