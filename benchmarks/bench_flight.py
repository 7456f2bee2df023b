"""Benchmark: flight and impacts, speed against error.

Two parts, measured in one run on one numba thread (``NUMBA_NUM_THREADS=1``, set here
unless given), after warm-up (compilation or cache load):

1. **The M -> 1 map with and without flight.** The grid of ``mass-ratio-limit-two-way``
   (f = 5..30 Hz x a = 0..12 m s^-2; ``--size`` points per axis) at ``M = 0.99`` (flight
   refuses ``M = 1``, a massless base), exact two-way solver, ``flight=False`` (the
   bouncing region is ``LIFT_OFF``) against ``flight=True``, and the one-way velocity map
   on the same grid; minimum of ``--repeats`` rounds, the calls back to back. Then the
   points of each flight status as one call: the issue's goal is a bouncing point at no
   more than 3x a stick-slip point of the two-way solver.
2. **Work against error at bouncing points.** A random sample of ``BOUNCING`` points
   against the independent event-driven reference (``tests/reference/flight.py``,
   ``scipy.integrate.solve_ivp`` at rtol 1e-12, its own impact law): the exact solver's
   error and time, and the time integrator's (``flight=True``) at several tolerances.

Writes ``results/bench-flight.md`` and the documentation's table ``docs/speed/flight.md``.
Timings are reported, never asserted.

Usage: ``python benchmarks/bench_flight.py [--size 121] [--repeats 3] [--sample 8]``
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
# The repo root, for tests.reference: the independent oracles are not installed.
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from docs_tables import load_average, machine, write_docs_table  # noqa: E402

import study  # noqa: E402
from study.engine.provenance import git_state, utc_now  # noqa: E402
from study.solvers.exact import steady_state, steady_velocity  # noqa: E402

#: The M -> 1 structure of the flight workflows (M = 1 is refused with flight).
STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
#: The issue's goal: a bouncing point costs at most this many stick-slip points.
GOAL_BOUNCING = 3.0
#: The time integrator's tolerances of the work-precision part.
TOLERANCES = (1e-6, 1e-8, 1e-10)
#: The map's frequencies [Hz] and accelerations [m s-2] (the grid of
#: mass-ratio-limit-two-way), and its default points per axis.
F_RANGE = (5.0, 30.0)
A_RANGE = (0.0, 12.0)
SIZE = 121


def grid(size: int) -> tuple[np.ndarray, np.ndarray]:
    """The map's points, flat, frequency outer and acceleration inner.

    Parameters
    ----------
    size : int
        Points per axis.

    Returns
    -------
    f, a : numpy.ndarray
        Frequencies [Hz] and accelerations [m s-2], ``size**2`` each.
    """
    f = np.linspace(*F_RANGE, size)[:, None]
    a = np.linspace(*A_RANGE, size)[None, :]
    return tuple(np.ascontiguousarray(x).ravel() for x in np.broadcast_arrays(f, a))


def _calls() -> dict[str, Callable]:
    return {
        "one-way": lambda f, a: steady_velocity(STRUCTURE, f, a, coupling="one-way"),
        "two-way": lambda f, a: steady_velocity(STRUCTURE, f, a, coupling="two-way"),
        "two-way, flight": lambda f, a: steady_velocity(STRUCTURE, f, a, coupling="two-way",
                                                        flight=True),
    }


def _timed(call: Callable[[], object]) -> tuple[float, float]:
    wall, cpu = time.perf_counter(), time.process_time()
    call()
    return time.perf_counter() - wall, time.process_time() - cpu


def _map_part(args: argparse.Namespace) -> dict:
    f_all, a_all = grid(args.size)
    calls = _calls()
    start = time.perf_counter()
    for call in calls.values():  # the serial and the parallel kernels
        call(np.array([13.0, 16.5]), np.array([8.5, 11.5]))
        call(np.linspace(10.0, 20.0, 4096), np.linspace(0.0, 12.0, 4096))
    warm = time.perf_counter() - start
    print(f"warm-up (compile or load the numba cache): {warm:.1f} s", flush=True)
    cpu = {name: math.inf for name in calls}
    results = {}
    for round_ in range(args.repeats):
        for name, call in calls.items():
            _, c = _timed(lambda call=call, name=name: results.__setitem__(name, call(f_all,
                                                                                     a_all)))
            cpu[name] = min(cpu[name], c)
            print(f"  round {round_ + 1}: {name:16s} {c:8.3f} s CPU "
                  f"({c / f_all.size * 1e6:.2f} us per point)", flush=True)
    state = steady_state(STRUCTURE, f_all, a_all, coupling="two-way", flight=True)
    by_status = []
    for code in study.Status:
        index = np.flatnonzero(state.status == code)
        if index.size == 0:
            continue
        best = math.inf
        for _ in range(args.repeats):
            best = min(best, _timed(lambda x=f_all[index], y=a_all[index]:
                                    calls["two-way, flight"](x, y))[1])
        by_status.append((code.name, index.size, best / index.size,
                          float(np.mean(state.impacts_per_period[index]))
                          if code == study.Status.BOUNCING else math.nan))
        print(f"  {code.name:19s} {index.size:7d} points: {best / index.size * 1e6:.2f} us",
              flush=True)
    lifted = int(np.count_nonzero(results["two-way"][1] == study.Status.LIFT_OFF))
    return {"n": f_all.size, "cpu": cpu, "by_status": by_status, "lifted": lifted,
            "f": f_all, "a": a_all, "state": state, "warm": warm}


def _precision_part(map_part: dict, args: argparse.Namespace) -> list[dict]:
    from study.solvers.integrator import IntegratorSettings, integrated_steady_state
    from tests.reference.flight import steady_motion

    state = map_part["state"]
    bouncing = np.flatnonzero(state.status == study.Status.BOUNCING)
    if bouncing.size == 0 or args.sample == 0:
        return []
    rng = np.random.default_rng(args.seed)
    chosen = np.sort(rng.choice(bouncing, size=min(args.sample, bouncing.size),
                                replace=False))
    rows = []
    for i in chosen:
        f, a = float(map_part["f"][i]), float(map_part["a"][i])
        start = time.perf_counter()
        reference = steady_motion(STRUCTURE, f, a)
        t_reference = time.perf_counter() - start
        exact_time = min(_timed(lambda f=f, a=a: steady_velocity(
            STRUCTURE, f, a, coupling="two-way", flight=True))[0] for _ in range(3))
        scale = max(abs(reference.velocity), 1e-12)
        row = {"f": f, "a": a, "reference": reference.velocity,
               "reference_time": t_reference,
               "exact": float(state.velocity[i]), "exact_time": exact_time,
               "exact_error": abs(float(state.velocity[i]) - reference.velocity) / scale,
               "integrator": []}
        for tolerance in TOLERANCES:
            start = time.perf_counter()
            integrated = integrated_steady_state(
                STRUCTURE, f, a, coupling="two-way", flight=True,
                settings=IntegratorSettings(tolerance=tolerance))
            elapsed = time.perf_counter() - start
            row["integrator"].append(
                (tolerance, elapsed,
                 abs(float(integrated.velocity) - reference.velocity) / scale))
        rows.append(row)
        print(f"  f = {f:.3f} Hz, a = {a:.3f}: reference {reference.velocity:+.6e} m/s; "
              f"exact error {row['exact_error']:.1e} in {exact_time * 1e6:.0f} us", flush=True)
    return rows


def report(args: argparse.Namespace, part: dict, rows: list[dict], loads: str) -> str:
    git = git_state()
    n, cpu = part["n"], part["cpu"]
    lines = [
        "# Flight and impacts: speed against error",
        "",
        f"Machine: {machine()}; shared, load average {loads} (1, 5, 15 min). "
        f"Commit {git['git_commit']}{' (dirty)' if git['git_dirty'] else ''}, {utc_now()}.",
        "",
        f"Map: M = {STRUCTURE.M} (f0 = 14.44 Hz, Q = 17.5, alpha = 64 deg, cs = ck = 0.25, "
        f"e = {STRUCTURE.restitution}), f = {F_RANGE[0]:g}..{F_RANGE[1]:g} Hz x "
        f"a = {A_RANGE[0]:g}..{A_RANGE[1]:g} m/s^2, {args.size} x "
        f"{args.size} = {n} points, one numba thread, CPU time, minimum of {args.repeats} "
        f"rounds back to back; warm-up {part['warm']:.1f} s excluded.",
        "",
        "| call | CPU [s] | CPU per point [us] | over one-way |",
        "|---|---|---|---|",
    ]
    for name, value in cpu.items():
        lines.append(f"| `steady_velocity`, {name} | {value:.3f} | {value / n * 1e6:.2f} | "
                     f"{value / cpu['one-way']:.1f}x |")
    lines += ["",
              f"Without flight {part['lifted']} points ({part['lifted'] / n:.0%}) are "
              f"`LIFT_OFF`; with flight, by status (the points of each status as one call):",
              "", "| status with flight | points | CPU per point [us] | impacts per period |",
              "|---|---|---|---|"]
    per_point = {}
    for name, count, seconds, impacts in part["by_status"]:
        per_point[name] = seconds
        lines.append(f"| {name} | {count} | {seconds * 1e6:.2f} | "
                     f"{'-' if math.isnan(impacts) else f'{impacts:.2f}'} |")
    if "BOUNCING" in per_point and "STICK_SLIP" in per_point:
        ratio = per_point["BOUNCING"] / per_point["STICK_SLIP"]
        lines += ["", f"A bouncing point costs {ratio:.1f}x a stick-slip point of the same "
                  f"call (goal <= {GOAL_BOUNCING:g}x: "
                  f"{'met' if ratio <= GOAL_BOUNCING else 'not met'})."]
    counts = {name: count for name, count, _, _ in part["by_status"]}
    if "NOT_CONVERGED" in per_point:
        share = per_point["NOT_CONVERGED"] * counts["NOT_CONVERGED"] / cpu["two-way, flight"]
        lines += ["", f"The {counts['NOT_CONVERGED']} `NOT_CONVERGED` points (no periodic "
                  f"orbit of up to 16 periods: chaotic bouncing, or a long cycle) take "
                  f"{share:.0%} of the flight map's time: each exhausts the cycle search."]
    if rows:
        lines += ["", "## Work against error at bouncing points", "",
                  "Relative velocity error against the event-driven reference "
                  "(`tests/reference/flight.py`, solve_ivp rtol 1e-12, its own impact law); "
                  "wall time per point.", "",
                  "| f [Hz] | a [m/s^2] | reference v [m/s] | exact: error, time | "
                  + " | ".join(f"integrator rtol {t:g}: error, time" for t in TOLERANCES)
                  + " |", "|---|---|---|---|" + "---|" * len(TOLERANCES)]
        for row in rows:
            cells = [f"{row['f']:.3f}", f"{row['a']:.3f}", f"{row['reference']:+.4e}",
                     f"{row['exact_error']:.1e}, {row['exact_time'] * 1e3:.2f} ms"]
            cells += [f"{error:.1e}, {seconds * 1e3:.1f} ms"
                      for _, seconds, error in row["integrator"]]
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=SIZE, help="points per axis")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sample", type=int, default=8,
                        help="bouncing points checked against the reference (0: none)")
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--output", type=Path, default=ROOT / "results" / "bench-flight.md")
    args = parser.parse_args(argv)
    load_start = load_average()
    print(f"machine: {machine()}; load average {load_start}", flush=True)
    part = _map_part(args)
    load_timed = load_average()
    rows = _precision_part(part, args)
    text = report(args, part, rows, f"{load_start} (start), {load_timed} (after the map)")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(text)
    print(text)
    # The report without its title and machine lines; a heading of its own would break
    # the page that includes the table.
    table = text.split("\n\n", 3)[3].replace("## Work against error at bouncing points",
                                              "**Work against error at bouncing points.**")
    write_docs_table("flight", "bench_flight.py",
                     f"{machine()}; load average {load_timed} after the map", table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
