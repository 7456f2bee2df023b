"""Basins against a single-start map of the same grid (issue 37, item 3).

Times, on one numba thread (CPU time, the minimum of ``--repeats`` rounds, all in one
run), per point of a map: the two-way ``steady_state`` from the release (one start, the
unit) and ``basins`` with 24 starts, on the M = 0.99 flight map and on the paper's
two-way map without flight (f 5..30 Hz x a 0..12 m s-2); then each status's points (by
the single start's status) as one call of each, so that the ratio is seen where the
time goes; and ``basins`` with the seeded state of its slow sweep down along f
(``seeds="sweeps"``, the ``[basins]`` default of a study since issue 47 item 2), with the
points where it finds more attractors than the drawn starts. Writes
results/bench-basins.md and the documentation's table docs/speed/basins.md.

Goal of the issue: ``basins`` with 24 starts within 6x the single-start map per point.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from docs_tables import load_average, machine, write_docs_table

import study
from study.engine.provenance import git_state, utc_now
from study.solvers.basins import DEFAULT_STARTS, basins
from study.solvers.exact import steady_state

#: The issue's goal: basins with 24 starts at most this many single-start maps.
GOAL = 6.0
#: The maps: (structure, flight).
MAPS = {
    "M = 0.99 with flight": (study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99,
                                             cs=0.25), True),
    "paper, M = 0.08, two-way": (study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08,
                                                 cs=0.25), False),
}


def _best(call, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        start = time.process_time()
        call()
        best = min(best, time.process_time() - start)
    return best


def measure(structure: study.Structure, flight: bool, size: int,
            repeats: int) -> tuple[list[str], float]:
    """Table rows (one per status and the whole map) and the whole map's ratio."""
    f, a = (np.ascontiguousarray(x).ravel() for x in np.meshgrid(
        np.linspace(5.0, 30.0, size), np.linspace(0.0, 12.0, size), indexing="ij"))

    def single(mask):
        return lambda: steady_state(structure, f[mask], a[mask], coupling="two-way",
                                    flight=flight, parallel=False)

    def many(mask, seeds=None):
        return lambda: basins(structure, f[mask], a[mask], flight=flight, parallel=False,
                              seeds=seeds)

    everywhere = np.ones(f.size, dtype=bool)
    single(everywhere)()  # compile or load the numba cache
    many(everywhere)()
    many(np.arange(f.size) == 0, "sweeps")()  # the seeding kernels too
    status = np.asarray(steady_state(structure, f, a, coupling="two-way",
                                     flight=flight).status)
    found = basins(structure, f, a, flight=flight)
    seeded = basins(structure, f, a, flight=flight, seeds="sweeps")
    rows = []
    whole = np.nan
    groups = [(study.Status(code).name, status == code) for code in np.unique(status)]
    for name, mask in [*groups, ("whole map", everywhere)]:
        one = _best(single(mask), repeats) / mask.sum()
        all_starts = _best(many(mask), repeats) / mask.sum()
        with_seed = _best(many(mask, "sweeps"), repeats) / mask.sum()
        multistable = int(np.sum(found.count[mask] > 1))
        more = int(np.sum(seeded.count[mask] > found.count[mask]))
        rows.append(f"| {name} | {mask.sum()} | {multistable} | {one * 1e6:.1f} | "
                    f"{all_starts * 1e6:.1f} | {all_starts / one:.1f}x | "
                    f"{with_seed * 1e6:.1f} | {with_seed / all_starts:.2f}x | {more} |")
        whole = all_starts / one
    return rows, whole


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=41,
                        help="points per axis of each map (default 41)")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--output", type=Path, default=Path("results/bench-basins.md"))
    parser.add_argument("--docs", action=argparse.BooleanOptionalAction, default=True,
                        help="also write the documentation's table docs/speed/basins.md")
    args = parser.parse_args(argv)
    loads = [load_average()]
    table = []
    for name, (structure, flight) in MAPS.items():
        rows, whole = measure(structure, flight, args.size, args.repeats)
        table += [f"**{name}: {args.size} x {args.size} points, {DEFAULT_STARTS} starts**",
                  "", "| points (status of the release) | points | multistable | one "
                  "start [us] | basins [us] | ratio | with the seeded sweep [us] | its "
                  "ratio to basins | points with more attractors |",
                  "|---|---|---|---|---|---|---|---|---|", *rows,
                  "", f"Basins cost {whole:.1f}x the single-start map per point (goal <= "
                  f"{GOAL:g}x: {'met' if whole <= GOAL else 'not met'}).", ""]
        print("\n".join(table[-(len(rows) + 6):]), flush=True)
    loads.append(load_average())
    notes = ("Every start is followed to the attractor it reaches and verified, as a "
             "single start is; a start on the table that provably stays stuck and every "
             "start on a still table (a = 0) are decided static in closed form. The seeded "
             "sweep: 8 steps down along f from 1.5 f, each followed to its verified reach "
             "(study.solvers.basins.sweep_seeds). One numba "
             f"thread, CPU time, the minimum of {args.repeats} rounds in this one run; "
             f"load average {loads[0]} before, {loads[1]} after.")
    measured = f"{machine()}, commit {git_state().get('git_commit', '?')[:7]}"
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text("\n".join(["# Basins: cost per point", "",
                                      f"Machine: {measured}, {utc_now()}.", "", *table,
                                      notes]) + "\n")
    print(f"wrote {args.output}")
    if args.docs:
        write_docs_table("basins", "bench_basins.py", measured, "\n".join(table), notes)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
