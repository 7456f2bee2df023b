"""Benchmark: reading a measurement file of a million rows (``study.analyses.measurements``).

Writes a file of ``--rows`` rows (half thresholds, half velocities, with a direction
and a short note: 49 bytes a row) into a temporary folder and times
:func:`study.analyses.measurements.read_measurements` on it ``--repeats`` times, each in this
process after a first read that imports what the reader needs. Reports the minimum
and the CPU time beside it (other work on the machine only ever adds time). Timed,
never asserted. Before the column-wise reader, a million rows took 106 s (row by row
through the JSON schema, with the cycle collector scanning every row's objects).

Usage: ``python benchmarks/bench_measurements.py [--rows 1000000] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from docs_tables import (
    load_average,
    machine,
    quick_option,
    use_quick,
    write_docs_table,
)

from study.analyses.measurements import read_measurements


def write_rows(path: Path, rows: int) -> None:
    """A measurement file of ``rows`` valid rows."""
    with path.open("w", encoding="utf-8") as out:
        out.write("quantity,f,a,value,sigma,direction,note\n")
        for i in range(rows):
            if i % 2:
                out.write(f"threshold,{10 + i * 1e-5:.6f},,{6 + i * 1e-6:.6f},0.05,forward,\n")
            else:
                out.write(f"velocity,{10 + i * 1e-5:.6f},8.5,{0.002 + i * 1e-9:.9f},0.0001,,"
                          f"run {i}\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=3)
    quick_option(parser)
    args = parser.parse_args()
    if use_quick(args.quick):  # 1e5 rows, one round
        args.rows, args.repeats = min(args.rows, 100_000), 1
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "measured.csv"
        write_rows(path, args.rows)
        read_measurements(path)  # imports (xarray's array modules) outside the timing
        walls, cpus = [], []
        for _ in range(args.repeats):
            wall, cpu = time.perf_counter(), time.process_time()
            data = read_measurements(path)
            walls.append(time.perf_counter() - wall)
            cpus.append(time.process_time() - cpu)
        assert data.sizes["measurement"] == args.rows
        size = path.stat().st_size / 2**20
        print(f"read_measurements: {args.rows} rows ({size:.1f} MiB) "
              f"in {min(walls):.2f} s (CPU {min(cpus):.2f} s; {args.repeats} repeats)")
    table = "\n".join([
        "| read_measurements | rows | file | time | CPU time | per row |",
        "|---|---|---|---|---|---|",
        f"| a CSV file of valid rows | {args.rows} | {size:.1f} MiB | {min(walls):.2f} s | "
        f"{min(cpus):.2f} s | {min(cpus) / args.rows * 1e6:.1f} us |"])
    write_docs_table("measurements", "bench_measurements.py",
                     f"{machine()}; load average {load_average()}; the minimum of "
                     f"{args.repeats} reads", table)


if __name__ == "__main__":
    main()
