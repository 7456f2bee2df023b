"""Slow sweeps and verified starts against the one-way map (issue 36, item 4).

Times, on one numba thread (CPU time, the minimum of ``--repeats`` rounds, all in one
run), per point of a map: the one-way ``steady_velocity`` (the unit), the two-way
``steady_state`` from the release (verified reached) and continued from its neighbours
(unverified: the opt-in speed setting), and ``slow_sweep`` along ``a`` up,
and up plus down (a protocol swept ``"both"`` ways), on the paper's structure (M = 0.08)
and on M = 1. Writes results/bench-protocol.md and the documentation's table
docs/speed/protocol.md.

Goals of the issue: a swept map (one direction) within 5x the one-way map per point,
"both" about twice that.
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

from docs_tables import load_average, machine, output, quick_option, use_quick, write_docs_table

import study
from study.engine.provenance import git_state, utc_now
from study.solvers.exact import steady_state, steady_velocity
from study.solvers.protocol import slow_sweep
from study.solvers.settings import SolverSettings

#: The issue's goal: a swept map at most this many one-way maps per point.
GOAL_SWEPT = 5.0
#: The maps: the paper's structure and M = 1 (f 5..30 Hz x a 0..12 m s-2).
MAPS = {
    "paper, M = 0.08": study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25),
    "M = 1": study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=1.0, cs=0.25),
}


def _cpu(call) -> float:
    start = time.process_time()
    call()
    return time.process_time() - start


def measure(structure: study.Structure, size: int,
            repeats: int) -> tuple[dict[str, float], dict[str, int]]:
    """CPU seconds per point of each call on a ``size`` x ``size`` map, and how the
    sweep up reached its points (:func:`sweep_kinds`)."""
    f = np.linspace(5.0, 30.0, size)
    a = np.linspace(0.0, 12.0, size)
    flat_f, flat_a = (np.ascontiguousarray(x).ravel()
                      for x in np.meshgrid(f, a, indexing="ij"))
    calls = {
        "one-way steady_velocity": lambda: steady_velocity(structure, flat_f, flat_a,
                                                           coupling="one-way"),
        "two-way steady_state (release, verified)": lambda: steady_state(
            structure, flat_f, flat_a, coupling="two-way"),
        "two-way steady_state (continuation, unverified)": lambda: steady_state(
            structure, flat_f, flat_a, coupling="two-way",
            settings=SolverSettings(continuation=True)),
        "slow_sweep along a, up": lambda: slow_sweep(structure, f, a, along="a"),
        "slow_sweep along a, up and down": lambda: (
            slow_sweep(structure, f, a, along="a"),
            slow_sweep(structure, f, a, along="a", direction="down")),
    }
    for call in calls.values():  # compile or load the numba cache
        call()
    best = {name: np.inf for name in calls}
    for _ in range(repeats):
        for name, call in calls.items():
            best[name] = min(best[name], _cpu(call))
    kinds = sweep_kinds(slow_sweep(structure, f, a, along="a").state.status)
    return {name: seconds / flat_f.size for name, seconds in best.items()}, kinds


#: Statuses after which a sweep has a state to carry to the next point.
_CARRIES = (study.Status.STATIC, study.Status.STICK_SLIP, study.Status.CONTINUOUS_SLIDING,
            study.Status.BOUNCING, study.Status.CHAOTIC, study.Status.QUASI_PERIODIC)


def sweep_kinds(status: np.ndarray) -> dict[str, int]:
    """How a sweep along the second axis of ``status`` reached its points: a run's first
    point and every point after one with no state to carry start by the start (solved
    as the unswept map solves them), a point after a static one that is static itself
    (decided in closed form where it provably stays stuck), and the others followed from
    the carried state."""
    carried = np.isin(status[:, :-1], [int(c) for c in _CARRIES])
    static = status[:, 1:] == int(study.Status.STATIC)
    return {"started again (the first of a run, or after a point with no state)":
            int(status.shape[0] + np.sum(~carried)),
            "static, reached stuck": int(np.sum(carried & static)),
            "followed from the carried state": int(np.sum(carried & ~static))}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1001,
                        help="points per axis of the paper's map (default 1001: 1e6 points)")
    parser.add_argument("--size-m1", type=int, default=301,
                        help="points per axis of the M = 1 map (default 301)")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--output", type=Path, default=Path("results/bench-protocol.md"))
    parser.add_argument("--docs", action=argparse.BooleanOptionalAction, default=True,
                        help="also write the documentation's table docs/speed/protocol.md")
    quick_option(parser)
    args = parser.parse_args(argv)
    if use_quick(args.quick):  # 201 x 201 and 61 x 61 points, one round
        args.size, args.size_m1, args.repeats = min(args.size, 201), min(args.size_m1, 61), 1
    args.output = output(args.output)
    loads = [load_average()]
    table = []
    notes = []
    for name, structure in MAPS.items():
        size = args.size if name.startswith("paper") else args.size_m1
        times, kinds = measure(structure, size, args.repeats)
        unit = times["one-way steady_velocity"]
        table += [f"**{name}: {size} x {size} = {size * size} points**", "",
                  "| call | CPU per point [us] | over one-way |", "|---|---|---|"]
        for call, seconds in times.items():
            table.append(f"| {call} | {seconds * 1e6:.2f} | {seconds / unit:.1f}x |")
        swept = times["slow_sweep along a, up"] / unit
        both = times["slow_sweep along a, up and down"] / unit
        unswept = times["two-way steady_state (release, verified)"] / unit
        shares = ", ".join(f"{count / (size * size):.0%} {kind}"
                           for kind, count in kinds.items())
        table += ["", f"A swept map costs {swept:.1f}x the one-way map per point (goal <= "
                  f"{GOAL_SWEPT:g}x: {'met' if swept <= GOAL_SWEPT else 'not met'}); up "
                  f"and down {both:.1f}x; the unswept map from the release {unswept:.1f}x. "
                  f"The sweep up reached its points so: {shares}.", ""]
        print("\n".join(table[-(len(times) + 6):]), flush=True)
    loads.append(load_average())
    notes.append("One numba thread, CPU time, the minimum of "
                 f"{args.repeats} rounds in this one run; load average {loads[0]} before, "
                 f"{loads[1]} after.")
    measured = f"{machine()}, commit {git_state().get('git_commit', '?')[:7]}"
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text("\n".join(["# Slow sweeps and verified starts: cost per point",
                                      "", f"Machine: {measured}, {utc_now()}.", "",
                                      *table, *notes]) + "\n")
    print(f"wrote {args.output}")
    if args.docs:
        write_docs_table("protocol", "bench_protocol.py", measured, "\n".join(table),
                         "\n".join(notes))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
