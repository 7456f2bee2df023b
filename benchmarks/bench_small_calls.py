"""Benchmark: the cost of one small call of ``steady_velocity`` and ``steady_state``.

Fits and designs evaluate a handful of velocity rows thousands of times, so the cost
of a call on a few points is mostly what the wrapper does around the kernel:
argument checks, array conversions, allocations, the kernel's constants and numba's
dispatch. This benchmark times one call of each function, both couplings, on the
paper's structure (f0 = 14.44 Hz, Q = 17.5, alpha = 64 deg, M = 0.08, cs = 0.25) at

* one static point (f = 10 Hz, a = 1 m s^-2, scalars),
* one moving point (f = 14.5 Hz, a = 8 m s^-2, scalars; stick-slip in both couplings),
* 5 moving points (f = 14.5 Hz, a = 7..9 m s^-2, arrays),
* 50 moving points (f = 13.5..15.5 Hz, a = 8 m s^-2, arrays),

on one numba thread (``NUMBA_NUM_THREADS=1``, set here unless given), after warm-up
(compilation or cache load). Each case is a batch of calls sized to take about
``--batch`` seconds; the cases take turns for ``--repeats`` rounds (so that each round
sees the machine in one state) and each keeps its fastest batch (other work on the
machine only ever adds time), in CPU time (the steadier figure on a shared machine:
it leaves out the time other processes had the core) and in wall time. Reported per
call in us, with the ratio two-way / one-way of each function at one point, all
measured in this one run; beside them the numba kernels alone on the static and the
moving point (their arguments prepared beforehand), so that the rest of a call is the
wrapper's, and on no point (numba's dispatch alone). Timings are reported, never
asserted.

Writes ``results/bench-small-calls.md`` and the documentation's table,
``docs/speed/small-calls.md``.

Usage: ``python benchmarks/bench_small_calls.py [--repeats 40] [--batch 0.01]``
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

from docs_tables import (  # noqa: E402
    load_average,
    machine,
    output,
    quick_option,
    use_quick,
    write_docs_table,
)

import study  # noqa: E402
from study.engine.provenance import git_state, utc_now  # noqa: E402
from study.kernels import one_way_velocity  # noqa: E402
from study.kernels.budget import Budget  # noqa: E402
from study.kernels.start import RELEASE  # noqa: E402
from study.kernels.two_way import points as orbit_kernel  # noqa: E402
from study.solvers.exact import steady_state, steady_velocity  # noqa: E402
from study.solvers.structure_constants import structure_vector  # noqa: E402

STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
#: The point sets: (label, points, f, a).
CASES = (
    ("1 static", 1, 10.0, 1.0),
    ("1 moving", 1, 14.5, 8.0),
    ("5 moving", 5, np.full(5, 14.5), np.linspace(7.0, 9.0, 5)),
    ("50 moving", 50, np.linspace(13.5, 15.5, 50), np.full(50, 8.0)),
)
FUNCTIONS = {"steady_velocity": steady_velocity, "steady_state": steady_state}
COUPLINGS = ("one-way", "two-way")
#: The issue's goal: one two-way point within this factor of one one-way point.
GOAL_RATIO = 2.0


def _kernels(f: float, a: float, points: int) -> dict[str, Callable[[], object]]:
    """The numba kernels alone on ``points`` copies of the point ``f``, ``a`` (0: numba's
    dispatch and the driver's call alone), their arguments built beforehand: the
    one-way velocity kernel and the two-way orbit kernel as a small call runs them."""
    s = STRUCTURE
    f_flat, a_flat = np.full(points, f), np.full(points, a)
    constants = (float(s.omega0), 1.0 / s.Q, float(s.M), float(np.cos(s.alpha_rad)),
                 float(np.sin(s.alpha_rad)), float(s.cs), float(s.ck), float(s.g))
    levels = (s.cs * s.g, s.ck * s.g)
    velocity, status = np.empty(points), np.empty(points, dtype=np.int8)
    vector = structure_vector(s, "two-way")
    omega = 2.0 * np.pi * f_flat
    lifted = np.zeros(points, dtype=bool)
    table = np.empty((points, orbit_kernel.N_OUT))
    budget = Budget(10_000, 5_000, 1e-3, 20_000)
    return {
        "one-way": lambda: one_way_velocity.velocity_points_small(
            f_flat, a_flat, constants, levels, tuple(budget), velocity, status),
        "two-way": lambda: orbit_kernel.solve_points_serial(vector, omega, a_flat, lifted,
                                                            budget, False, RELEASE,
                                                            table),
    }


def _calls() -> dict[tuple[str, str, str], Callable[[], object]]:
    calls = {}
    for label, _, f, a in CASES:
        for name, function in FUNCTIONS.items():
            for coupling in COUPLINGS:
                calls[(name, coupling, label)] = (
                    lambda fn=function, f=f, a=a, c=coupling: fn(STRUCTURE, f, a, coupling=c))
    for label, points, f, a in (("0 points", 0, 14.5, 8.0), *CASES[:2]):
        for coupling, kernel in _kernels(f, a, points).items():
            calls[("kernel", coupling, label)] = kernel
    return calls


def _batch_size(call: Callable[[], object], seconds: float) -> int:
    """Calls in a batch of about ``seconds``."""
    start = time.perf_counter()
    count = 0
    while time.perf_counter() - start < seconds / 5 or count < 3:
        call()
        count += 1
    per_call = (time.perf_counter() - start) / count
    return max(3, int(seconds / per_call))


def _fastest(calls: dict, repeats: int, seconds: float) -> tuple[dict, dict]:
    """Fastest wall and CPU time per call of each call, batches taking turns over
    ``repeats`` rounds (CPU time leaves out the time other processes had the core)."""
    sizes = {key: _batch_size(call, seconds) for key, call in calls.items()}
    wall = dict.fromkeys(calls, math.inf)
    cpu = dict.fromkeys(calls, math.inf)
    for round_ in range(repeats):
        for key, call in calls.items():
            n = sizes[key]
            start, start_cpu = time.perf_counter(), time.process_time()
            for _ in range(n):
                call()
            wall[key] = min(wall[key], (time.perf_counter() - start) / n)
            cpu[key] = min(cpu[key], (time.process_time() - start_cpu) / n)
        if (round_ + 1) % 10 == 0 or round_ + 1 == repeats:
            print(f"  round {round_ + 1} of {repeats} done", flush=True)
    return wall, cpu


def _us(seconds: float) -> str:
    us = seconds * 1e6
    return f"{us:.3g}" if us < 100 else f"{us:.0f}"


def tables(best: dict, what: str) -> tuple[str, str]:
    """The per-call table of ``best`` times (``what`` they are: us per call, and per
    point for several points) and the ratio line."""
    lines = [f"| {what} per call [us], one thread | "
             + " | ".join(label for label, *_ in CASES) + " |",
             "|---|" + "---|" * len(CASES)]
    for name in FUNCTIONS:
        for coupling in COUPLINGS:
            cells = []
            for label, points, *_ in CASES:
                t = best[(name, coupling, label)]
                cells.append(_us(t) + (f" ({_us(t / points)} per point)" if points > 1
                                        else ""))
            lines.append(f'| `{name}(..., coupling="{coupling}")` | ' + " | ".join(cells)
                         + " |")
    for coupling in COUPLINGS:
        cells = [_us(best[("kernel", coupling, label)]) if ("kernel", coupling, label) in best
                 else "" for label, *_ in CASES]
        lines.append(f"| {coupling} kernel alone | " + " | ".join(cells) + " |")
    ratios = []
    for name in FUNCTIONS:
        for label in ("1 static", "1 moving"):
            ratio = best[(name, "two-way", label)] / best[(name, "one-way", label)]
            ratios.append(f"`{name}` {label} point {ratio:.1f}x")
    return "\n".join(lines), "Two-way / one-way, one point: " + "; ".join(ratios) + "."


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=40, help="rounds of all the calls")
    parser.add_argument("--batch", type=float, default=0.01,
                        help="seconds of calls in one batch")
    parser.add_argument("--output", type=Path,
                        default=ROOT / "results" / "bench-small-calls.md")
    quick_option(parser)
    args = parser.parse_args(argv)
    if use_quick(args.quick):  # 5 rounds
        args.repeats = min(args.repeats, 5)
    args.output = output(args.output)

    load_start = load_average()
    print(f"machine: {machine()}; load average {load_start}", flush=True)
    calls = _calls()
    start = time.perf_counter()
    for call in calls.values():
        call()
    print(f"warm-up (compile or load the numba cache): {time.perf_counter() - start:.1f} s",
          flush=True)
    wall, cpu = _fastest(calls, args.repeats, args.batch)
    load_end = load_average()
    table, ratios = tables(cpu, "CPU time")
    wall_table, wall_ratios = tables(wall, "wall time")
    one = cpu[("steady_velocity", "one-way", "1 moving")]
    two = cpu[("steady_velocity", "two-way", "1 moving")]
    dispatch = {c: cpu[("kernel", c, "0 points")] for c in COUPLINGS}
    notes = (
        f"{ratios} The goal, one two-way point within {GOAL_RATIO:g}x one one-way point "
        f"(`steady_velocity`, moving point): {two / one:.1f}x, "
        f"{'met' if two / one <= GOAL_RATIO else 'not met'}. A kernel called on no point "
        f"(numba's dispatch and the driver's call) takes {_us(dispatch['one-way'])} us "
        f"(one-way) and {_us(dispatch['two-way'])} us (two-way).")
    git = git_state()
    text = "\n".join([
        "# Small calls: the cost of one call on a few points",
        "",
        f"Machine: {machine()}; shared, load average {load_start} (start), {load_end} "
        f"(end). Commit {git['git_commit']}{' (dirty)' if git['git_dirty'] else ''}, "
        f"{utc_now()}.",
        "",
        f"Paper structure; fastest batch of calls over {args.repeats} rounds, the cases "
        "taking turns; per call (per point in brackets). CPU time leaves out the time "
        "other processes had the core; wall time below.",
        "",
        table,
        "",
        notes,
        "",
        wall_table,
        "",
        wall_ratios,
        "",
    ])
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(text)
    print(text)
    print(f"wrote {args.output}")
    write_docs_table(
        "small-calls", "bench_small_calls.py",
        f"{machine()}; load average {load_end} (1, 5, 15 min) after the timed rounds; "
        f"CPU time per call, fastest of {args.repeats} rounds", table, notes)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
