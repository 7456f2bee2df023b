"""Branches and their bifurcations: what a located fold and a fold curve cost (issue 45,
item 7).

On the M = 0.99 structure with flight (hysteresis-flight's), in one run, on one numba
thread (CPU time, the minimum of ``--repeats`` rounds):

- **a fold from a sweep's bracket**: the jump of a slow sweep up at 10 m s-2 between
  16.0 and 16.1 Hz located by the ``jumps`` observable's trace from the point before
  (period-map passes with and without the Jacobian, and CPU time) against the same
  sweep on a grid of 0.001 Hz through the bracket (its passes and time, for a place
  known only to 1e-3 Hz);
- **a fold curve against a line of basins**: ``bifurcation_curve`` of that fold over
  a = 10 to 12 m s-2 at 25, 50 and 100 values, against ``basins`` (24 starts) at 100
  points of the same line (f = 15 Hz, a = 10 to 12): a curve's cost grows with its
  length (the values asked for), a basins map's with its area.

Writes results/bench-branches.md and the documentation's table docs/speed/branches.md.
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
from study.model.bifurcations import kind_named
from study.solvers.basins import basins
from study.solvers.branch import trace
from study.solvers.protocol import slow_sweep

STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
#: The sweep's grid below the bracket, and the bracket the jump lies in.
SWEPT = np.round(np.arange(12.0, 16.01, 0.1), 6)
BRACKET = (16.0, 16.1)
A = 10.0


def _cpu(call):
    start = time.process_time()
    value = call()
    return time.process_time() - start, value


def _best(call, repeats: int):
    """The minimum CPU time of ``repeats`` calls and the last call's value."""
    best, value = np.inf, None
    for _ in range(repeats):
        seconds, value = _cpu(call)
        best = min(best, seconds)
    return best, value


def fold_from_bracket(repeats: int) -> tuple[list[str], dict[str, float]]:
    """Rows of the table and the numbers the notes quote."""
    swept = slow_sweep(STRUCTURE, np.append(SWEPT, BRACKET[1]), [A], along="f",
                       direction="up", flight=True)
    state = swept.state.phase_state[SWEPT.size - 1, 0]
    periods = int(swept.state.orbit_period[SWEPT.size - 1, 0])

    def locate():
        traced, _ = trace(STRUCTURE, BRACKET[0], A, along="f", to=BRACKET[1], start=state,
                          periods=periods, flight=True)
        return traced

    seconds, traced = _best(locate, repeats)
    fold = int(np.flatnonzero(traced.bifurcation_column("kind")
                              == kind_named("fold").code)[0])
    t = float(traced.bifurcation_column("t")[fold])
    where = BRACKET[0] + t * (BRACKET[1] - BRACKET[0])
    fine = np.round(np.concatenate([SWEPT, np.arange(BRACKET[0] + 0.001, BRACKET[1] + 1e-9,
                                                     0.001)]), 6)

    def sweep_fine():
        return slow_sweep(STRUCTURE, fine, [A], along="f", direction="up", flight=True,
                          parallel=False)

    def sweep_coarse():
        return slow_sweep(STRUCTURE, SWEPT, [A], along="f", direction="up", flight=True,
                          parallel=False)

    fine_seconds, _ = _best(sweep_fine, repeats)
    coarse_seconds, _ = _best(sweep_coarse, repeats)
    bracket_seconds = fine_seconds - coarse_seconds
    located = (float(traced.bifurcation_column("newton_passes")[fold]),
               float(traced.bifurcation_column("map_passes")[fold]))
    rows = ["| how | where the fold is [Hz] | passes (with Jacobian + without) | "
            "of which locating the fold | CPU [ms] |",
            "|---|---|---|---|---|",
            f"| the jump's trace from 16.0 Hz ({traced.steps.shape[0]} steps) | {where:.10f} | "
            f"{traced.newton_passes:.0f} + {traced.map_passes:.0f} | "
            f"{located[0]:.0f} + {located[1]:.0f} | {seconds * 1e3:.1f} |",
            f"| a sweep in 0.001 Hz steps through the bracket ({fine.size - SWEPT.size} "
            f"points) | to 1e-3 | | | {bracket_seconds * 1e3:.1f} |"]
    return rows, {"passes": traced.newton_passes + traced.map_passes, "where": where,
                  "trace": seconds, "fine": bracket_seconds, "located": sum(located)}


def curve_against_basins(repeats: int, counts: tuple[int, ...]) -> tuple[list[str], dict]:
    swept = slow_sweep(STRUCTURE, np.append(SWEPT, BRACKET[1]), [A], along="f",
                       direction="up", flight=True)
    k = int(np.flatnonzero(SWEPT == 15.9)[0])
    hop = study.branch(STRUCTURE, 15.9, A, along="f", to=16.2, flight=True,
                       start=swept.state.phase_state[k, 0],
                       periods=int(swept.state.orbit_period[k, 0]))
    fold = int(np.flatnonzero(hop.bifurcation_kind.values == kind_named("fold").code)[0])
    rows = ["| call | values | CPU [s] | per value [ms] |", "|---|---|---|---|"]
    times = {}
    for count in counts:
        seconds, curve = _best(lambda count=count: study.bifurcation_curve(
            STRUCTURE, hop, fold, to=12.0, num=count), repeats)
        times[count] = seconds
        rows.append(f"| `bifurcation_curve`, a = 10 to 12 m s-2 ({curve.sizes['point']} "
                    f"points located, end {curve.attrs['curve_end']}) | {count} | "
                    f"{seconds:.2f} | {seconds / count * 1e3:.1f} |")
    line = np.linspace(10.0, 12.0, counts[-1])
    seconds, _ = _best(lambda: basins(STRUCTURE, np.full(line.size, 15.0), line, flight=True,
                                      parallel=False), max(1, repeats - 1))
    times["basins"] = seconds
    rows.append(f"| `basins` (24 starts) at f = 15 Hz, a = 10 to 12 m s-2 | {line.size} | "
                f"{seconds:.2f} | {seconds / line.size * 1e3:.1f} |")
    # The same number of basins points on the curve itself, 0.1 % below each fold in f
    # (where the forward hop is about to end and its neighbours take longest to settle).
    on_curve = curve.f.values[:counts[-1]] * 0.999, curve.a.values[:counts[-1]]
    seconds, _ = _best(lambda: basins(STRUCTURE, *on_curve, flight=True, parallel=False),
                       max(1, repeats - 1))
    times["basins on the curve"] = seconds
    rows.append(f"| `basins` (24 starts) 0.1 % below each fold of the curve | "
                f"{on_curve[0].size} | {seconds:.2f} | {seconds / on_curve[0].size * 1e3:.1f} |")
    return rows, times


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--output", type=Path, default=Path("results/bench-branches.md"))
    parser.add_argument("--docs", action=argparse.BooleanOptionalAction, default=True,
                        help="also write the documentation's table docs/speed/branches.md")
    quick_option(parser)
    args = parser.parse_args(argv)
    counts = (25, 50, 100)
    if use_quick(args.quick):  # one round, the shortest curves
        args.repeats, counts = 1, (10, 20)
    args.output = output(args.output)
    loads = [load_average()]
    fold_rows, fold = fold_from_bracket(args.repeats)
    curve_rows, times = curve_against_basins(args.repeats, counts)
    loads.append(load_average())
    longest = counts[-1]
    table = ["**A fold from a slow sweep's bracket** (M = 0.99 with flight, a = 10 m s-2, "
             f"the jump between {BRACKET[0]:g} and {BRACKET[1]:g} Hz)", "", *fold_rows, "",
             f"The trace locates the fold to 1e-10 of the drive in {fold['passes']:.0f} passes "
             f"of the period map, {fold['fine'] / fold['trace']:.0f} times faster than a "
             "sweep that places it to 1e-3 Hz; the location itself (the regula falsi on the "
             f"tangent's drive component, from the step that crossed it) takes "
             f"{fold['located']:.0f} of them, beyond the branch's own steps.", "",
             "**A fold curve against a line of basins** (the fold above followed in a)", "",
             *curve_rows, "",
             f"A {longest}-value fold curve costs {times[longest]:.2f} s against "
             f"{times['basins']:.2f} s for {longest} points of basins on the same range of "
             f"a at one f ({times['basins'] / times[longest]:.2f}x) and "
             f"{times['basins on the curve']:.2f} s for as many next to the curve "
             f"({times['basins on the curve'] / times[longest]:.2f}x); a basins line "
             "places no fold (a map around the curve would, to its grid's step); "
             f"doubling the curve's values doubles its "
             f"cost ({times[counts[-1]] / times[counts[-2]]:.2f}x from {counts[-2]} to "
             f"{counts[-1]}), where a map's grows with its area.", ""]
    notes = [f"One numba thread, CPU time, the minimum of {args.repeats} rounds in this one "
             f"run (basins: {max(1, args.repeats - 1)}); load average {loads[0]} before, "
             f"{loads[1]} after."]
    print("\n".join(table), flush=True)
    measured = f"{machine()}, commit {git_state().get('git_commit', '?')[:7]}"
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text("\n".join(["# Branches: a located fold and a fold curve", "",
                                      f"Machine: {measured}, {utc_now()}.", "", *table,
                                      *notes]) + "\n")
    print(f"wrote {args.output}")
    if args.docs:
        write_docs_table("branches", "bench_branches.py", measured, "\n".join(table),
                         "\n".join(notes))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
