"""Benchmark: the paper's (f, a) velocity map, one-way against two-way coupling, one thread.

The map of ``bench_velocity_map.py`` (paper structure f0 = 14.44 Hz, Q = 17.5,
alpha = 64 deg, M = 0.08, cs = 0.25; f 10..20 Hz, a 0..12 m s^-2, ``--size`` points
per axis, 1000 by default) is computed back to back, each call timed on one numba
thread (``NUMBA_NUM_THREADS=1``, set here unless given), after warm-up (compilation or
cache load), minimum of ``--repeats`` rounds, wall and process time:

* ``steady_velocity(..., coupling="one-way")``: the velocity-only one-way kernel;
* ``steady_state(..., coupling="one-way")``: the one-way solver with diagnostics;
* ``steady_velocity(..., coupling="two-way")``: the exact two-way orbit solver.

Reported: seconds, us per point, the ratio two-way / one-way per point for both
one-way calls, and the two-way time by two-way status (the points of each status
solved as one call, again against both one-way calls on the same points). Accuracy:
a random sample of moving points of the two-way map against the 40-digit mpmath orbit
(``tests/reference/two_way_exact.py``), with each point's relative condition number
``|d ln v/d ln f| + |d ln v/d ln a|``: float64 inputs alone allow a relative error
``eps cond``. The issue's goal: two-way within 10x the one-way exact time per point,
at <= 1e-12 relative error where the velocity is well conditioned (here: cond <= 1e3,
``eps cond <= 2.2e-13``). Timings are reported, never asserted.

Writes ``results/bench-two-way-map.md`` and the documentation's table,
``docs/speed/two-way-map.md`` (CPU time per point).

Usage: ``python benchmarks/bench_two_way_map.py [--size 1000] [--repeats 2] [--sample 30]``
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

from docs_tables import (  # noqa: E402
    exponent,
    load_average,
    machine,
    output,
    quick_option,
    use_quick,
    write_docs_table,
)

import study  # noqa: E402
from study.engine.provenance import git_state, utc_now  # noqa: E402
from study.solvers.exact import steady_state, steady_velocity  # noqa: E402

STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
#: Relative condition number up to which a velocity counts as well conditioned.
WELL_CONDITIONED = 1e3
#: The issue's goals.
GOAL_RATIO = 10.0
GOAL_ERROR = 1e-12


def _calls() -> dict[str, Callable]:
    return {
        "steady_velocity one-way": lambda f, a: steady_velocity(STRUCTURE, f, a,
                                                                coupling="one-way"),
        "steady_state one-way": lambda f, a: steady_state(STRUCTURE, f, a, coupling="one-way"),
        "steady_velocity two-way": lambda f, a: steady_velocity(STRUCTURE, f, a,
                                                                coupling="two-way"),
    }


def _timed(call: Callable[[], object]) -> tuple[float, float]:
    wall, cpu = time.perf_counter(), time.process_time()
    call()
    return time.perf_counter() - wall, time.process_time() - cpu


def _warm_up(calls: dict[str, Callable]) -> float:
    """Compile or load the cache of every kernel variant (serial and parallel)."""
    start = time.perf_counter()
    for call in calls.values():
        call(np.array([13.0, 16.5]), np.array([8.5, 8.5]))
        call(np.linspace(10.0, 20.0, 4096), np.linspace(0.0, 12.0, 4096))
    return time.perf_counter() - start


def _accuracy(f: np.ndarray, a: np.ndarray, velocity: np.ndarray, status: np.ndarray,
              sample: int, seed: int) -> list[dict]:
    """Random moving points of the two-way map against the 40-digit mpmath orbit."""
    from bench_work_precision import two_way_condition

    from tests.reference.two_way_exact import reference_orbit

    moving = np.flatnonzero((status == study.Status.STICK_SLIP)
                            | (status == study.Status.CONTINUOUS_SLIDING))
    rng = np.random.default_rng(seed)
    chosen = np.sort(rng.choice(moving, size=min(sample, moving.size), replace=False))
    rows = []
    for i in chosen:
        orbit = reference_orbit(STRUCTURE, float(f[i]), float(a[i]), coupling="two-way",
                                dps=40)
        reference = float(orbit.velocity)
        moving = orbit.status in ("STICK_SLIP", "CONTINUOUS_SLIDING")
        cond = (two_way_condition(STRUCTURE, float(f[i]), float(a[i]), orbit.velocity)
                if moving else math.nan)
        rows.append({
            "f": float(f[i]), "a": float(a[i]), "velocity": float(velocity[i]),
            "reference": reference, "status": study.Status(int(status[i])).name,
            "reference_status": orbit.status, "detail": orbit.detail,
            "relative": (abs(float(velocity[i]) - reference) / abs(reference) if moving
                         else math.nan),
            "cond": cond,
        })
    return rows


def _status_check(f: np.ndarray, a: np.ndarray, status: np.ndarray, stride: int,
                  tolerance: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Statuses of the exact solver against the integrator (integrated from the same
    canonical start until the orbit repeats) on every ``stride``-th point of each axis.

    Returns the confusion counts (rows exact, columns integrator, by status code), the
    subgrid's shape and the integrator's time."""
    from study.solvers.integrator import IntegratorSettings, integrated_steady_state

    f_sub, a_sub, s_sub = (x[::stride, ::stride] for x in (f, a, status))
    start = time.perf_counter()
    integrated = integrated_steady_state(
        STRUCTURE, f_sub, a_sub, coupling="two-way",
        settings=IntegratorSettings(tolerance=tolerance))
    elapsed = time.perf_counter() - start
    codes = len(study.Status)
    confusion = np.zeros((codes, codes), dtype=np.int64)
    np.add.at(confusion, (s_sub.ravel().astype(int), integrated.status.ravel().astype(int)), 1)
    return confusion, np.array(f_sub.shape), elapsed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1000, help="points per axis")
    parser.add_argument("--repeats", type=int, default=2, help="rounds of the three calls")
    parser.add_argument("--sample", type=int, default=30,
                        help="moving points checked against the mpmath orbit (0: none)")
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--check-stride", type=int, default=10,
                        help="statuses checked against the integrator on every N-th point "
                             "of each axis (0: no check)")
    parser.add_argument("--check-tolerance", type=float, default=1e-8,
                        help="the integrator's tolerance for that check")
    parser.add_argument("--output", type=Path,
                        default=ROOT / "results" / "bench-two-way-map.md")
    quick_option(parser)
    args = parser.parse_args(argv)
    if use_quick(args.quick):  # 200 x 200 points, one round, smaller checks
        args.size, args.repeats = min(args.size, 200), 1
        args.sample, args.check_stride = min(args.sample, 5), max(args.check_stride, 20)
    args.output = output(args.output)

    load_start = load_average()
    print(f"machine: {machine()}; load average {load_start}", flush=True)
    f = np.linspace(10.0, 20.0, args.size)[:, None]
    a = np.linspace(0.0, 12.0, args.size)[None, :]
    f_all, a_all = (np.ascontiguousarray(x).ravel() for x in np.broadcast_arrays(f, a))
    n = f_all.size
    calls = _calls()
    print(f"warm-up (compile or load the numba cache): {_warm_up(calls):.2f} s", flush=True)

    wall = {name: math.inf for name in calls}
    cpu = {name: math.inf for name in calls}
    results = {}
    for round_ in range(args.repeats):
        for name, call in calls.items():  # back to back, one round after the other
            w, c = _timed(lambda call=call, name=name: results.__setitem__(name, call(f, a)))
            wall[name], cpu[name] = min(wall[name], w), min(cpu[name], c)
            print(f"  round {round_ + 1}: {name:24s} {w:8.3f} s wall {c:8.3f} s CPU "
                  f"({w / n * 1e6:.3f} us per point)", flush=True)
    load_timed = load_average()

    velocity_2, status_2 = results["steady_velocity two-way"]
    velocity_2, status_2 = velocity_2.ravel(), status_2.ravel()
    status_1 = results["steady_velocity one-way"][1].ravel()

    # By two-way status: the points of each status as one call, each of the three calls.
    by_status = []
    for code in study.Status:
        index = np.flatnonzero(status_2 == code)
        if index.size == 0:
            continue
        f_s, a_s = f_all[index], a_all[index]
        times = {}
        for name, call in calls.items():
            best = math.inf
            for _ in range(max(1, args.repeats - 1)):
                best = min(best, _timed(lambda c=call, x=f_s, y=a_s: c(x, y))[0])
            times[name] = best / index.size
        by_status.append((code.name, index.size, times,
                          int(np.count_nonzero(status_1[index] == code))))
        print(f"  {code.name:19s} {index.size:8d} points: "
              + ", ".join(f"{k} {v * 1e6:.3f} us" for k, v in times.items()), flush=True)

    check = None
    if args.check_stride > 0:
        grid = (np.broadcast_to(f, (args.size, args.size)),
                np.broadcast_to(a, (args.size, args.size)),
                status_2.reshape(args.size, args.size))
        check = _status_check(*grid, args.check_stride, args.check_tolerance)
        print(f"status check against the integrator: {check[1][0]} x {check[1][1]} points "
              f"in {check[2]:.0f} s", flush=True)

    accuracy = []
    if args.sample > 0:
        start = time.perf_counter()
        accuracy = _accuracy(f_all, a_all, velocity_2, status_2, args.sample, args.seed)
        print(f"accuracy sample: {len(accuracy)} points in {time.perf_counter() - start:.0f} s",
              flush=True)
    load_end = load_average()

    text = report(args, n, wall, cpu, by_status, accuracy, check,
                  f"{load_start} (start), {load_timed} (after the timed rounds), "
                  f"{load_end} (end)")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(text)
    print(text)
    print(f"wrote {args.output}")
    write_docs_table(
        "two-way-map", "bench_two_way_map.py",
        f"{machine()}; load average {load_timed} (1, 5, 15 min) after the timed rounds; "
        f"CPU times, minimum of {args.repeats} rounds", docs_table(n, cpu))
    return 0


def docs_table(n: int, cpu: dict[str, float]) -> str:
    """The documentation's table: CPU time per point of each call, and the two-way
    call's time over it."""
    two = "steady_velocity two-way"
    lines = [f"| one thread, paper map, {exponent(n)} points | CPU per point | two-way / this |",
             "|---|---|---|"]
    for name in ("steady_velocity one-way", "steady_state one-way", two):
        function, coupling = name.split()
        ratio = "1" if name == two else f"{cpu[two] / cpu[name]:.1f}x"
        label = f'`{function}(..., coupling="{coupling}")`'
        if name == two:
            label += " (exact orbit)"
        lines.append(f"| {label} | {cpu[name] / n * 1e6:.2g} us | {ratio} |")
    return "\n".join(lines)


def _verdict(wall_ratio: float, cpu_ratio: float) -> str:
    if max(wall_ratio, cpu_ratio) <= GOAL_RATIO:
        return "met"
    if min(wall_ratio, cpu_ratio) <= GOAL_RATIO:
        return "met in one of wall and CPU time only"
    return "not met"


def report(args, n, wall, cpu, by_status, accuracy, check, loads) -> str:
    git = git_state()
    one_v, one_s, two = ("steady_velocity one-way", "steady_state one-way",
                         "steady_velocity two-way")
    lines = [
        "# Two-way coupling: the velocity map, one thread",
        "",
        f"Machine: {machine()}; shared, load average {loads} (1, 5, 15 min). "
        f"Commit {git['git_commit']}{' (dirty)' if git['git_dirty'] else ''}, {utc_now()}.",
        "",
        f"Map: paper structure (f0 = 14.44 Hz, Q = 17.5, alpha = 64 deg, M = 0.08, "
        f"cs = ck = 0.25), f = 10..20 Hz x a = 0..12 m/s^2, {args.size} x {args.size} = "
        f"{n} points (the grid of benchmarks/bench_velocity_map.py). Each call on one numba "
        f"thread, warm-up excluded, the three calls back to back, minimum over "
        f"{args.repeats} rounds.",
        "",
        "| call | wall [s] | CPU [s] | wall per point [us] | CPU per point [us] | "
        "two-way / this (wall) | two-way / this (CPU) |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in (one_v, one_s, two):
        ratio = wall[two] / wall[name]
        ratio_cpu = cpu[two] / cpu[name]
        lines.append(
            f"| `{name.split()[0]}(..., coupling=\"{name.split()[1]}\")` | {wall[name]:.3f} | "
            f"{cpu[name]:.3f} | {wall[name] / n * 1e6:.3f} | {cpu[name] / n * 1e6:.3f} | "
            f"{'-' if name == two else f'{ratio:.1f}'} | "
            f"{'-' if name == two else f'{ratio_cpu:.1f}'} |"
        )
    lines += [
        "",
        "By two-way status (the points of each status solved as one call; wall per point, "
        "minimum of repeats):",
        "",
        "| two-way status | points | same one-way status | two-way [us/pt] | "
        "one-way steady_velocity [us/pt] | one-way steady_state [us/pt] | "
        "two-way / one-way (velocity, state) |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, count, times, same in by_status:
        lines.append(
            f"| {name} | {count} | {same} | {times[two] * 1e6:.3f} | {times[one_v] * 1e6:.3f} "
            f"| {times[one_s] * 1e6:.3f} | {times[two] / times[one_v]:.1f}, "
            f"{times[two] / times[one_s]:.1f} |"
        )
    ratio_v, ratio_s = wall[two] / wall[one_v], wall[two] / wall[one_s]
    cpu_v, cpu_s = cpu[two] / cpu[one_v], cpu[two] / cpu[one_s]
    lines += ["", "## Accuracy", ""]
    goal_error = None
    if not accuracy and check is None:
        lines.append("Not checked in this run (`--sample 0 --check-stride 0`).")
    if accuracy:
        eps = np.finfo(float).eps
        moving = [r for r in accuracy if math.isfinite(r["relative"])]
        others = [r for r in accuracy if not math.isfinite(r["relative"])]
        rel = np.array([r["relative"] for r in moving])
        cond = np.array([r["cond"] for r in moving])
        scaled = rel / (eps * np.maximum(1.0, cond))
        well = cond <= WELL_CONDITIONED
        agree = sum(r["status"] == r["reference_status"] for r in accuracy)
        lines += [
            f"{len(accuracy)} random moving points of the two-way map (seed {args.seed}) "
            "against the 40-digit mpmath orbit from the same canonical start; statuses "
            f"agree at {agree} of {len(accuracy)}.",
            "",
        ]
        if moving:
            lines += [
                "| points (reference moving) | count | max relative error | median relative "
                "error | max error / (eps cond) |",
                "|---|---|---|---|---|",
                f"| all | {rel.size} | {rel.max():.1e} | {np.median(rel):.1e} | "
                f"{scaled.max():.2g} |",
            ]
            if np.any(well):
                goal_error = float(rel[well].max())
                lines.append(
                    f"| well conditioned (cond <= {WELL_CONDITIONED:g}) | {int(well.sum())} "
                    f"| {rel[well].max():.1e} | {np.median(rel[well]):.1e} | "
                    f"{scaled[well].max():.2g} |"
                )
            if np.any(~well):
                lines.append(
                    f"| cond > {WELL_CONDITIONED:g} | {int((~well).sum())} | "
                    f"{rel[~well].max():.1e} | {np.median(rel[~well]):.1e} | "
                    f"{scaled[~well].max():.2g} |"
                )
            worst = int(np.argmax(scaled))
            r = moving[worst]
            lines += [
                "",
                f"Worst in units of eps cond: f = {r['f']:.6g} Hz, a = {r['a']:.6g} m/s^2, "
                f"v = {r['reference']:.6e} m/s, cond {r['cond']:.2g}, relative error "
                f"{r['relative']:.1e}.",
            ]
        for r in others:
            lines += [
                "",
                f"Status differs at f = {r['f']!r} Hz, a = {r['a']!r} m/s^2: exact "
                f"{r['status']} (v = {r['velocity']:.6e} m/s), reference "
                f"{r['reference_status']} ({r['detail']}).",
            ]
    if check is not None:
        confusion, shape, elapsed = check
        names = [s.name for s in study.Status]
        used = [i for i in range(len(names))
                if confusion[i].sum() > 0 or confusion[:, i].sum() > 0]
        agree = int(np.trace(confusion))
        lines += [
            "",
            f"Statuses against the integrator (`integrated_steady_state(..., "
            f"coupling=\"two-way\")`, tolerance {args.check_tolerance:g}: integrates "
            f"from the same canonical start until the orbit repeats) on every "
            f"{args.check_stride}-th point of each axis, {shape[0]} x {shape[1]} = "
            f"{int(confusion.sum())} points ({elapsed:.0f} s): agree at {agree} "
            f"({agree / confusion.sum():.2%}). Rows: exact solver; columns: integrator.",
            "",
            "| exact \\ integrator | " + " | ".join(names[j] for j in used) + " |",
            "|---|" + "---|" * len(used),
        ]
        for i in used:
            lines.append(f"| {names[i]} | " + " | ".join(str(int(confusion[i, j]))
                                                     for j in used) + " |")
    lines += [
        "",
        "## Goal",
        "",
        f"Two-way exact within {GOAL_RATIO:g}x the one-way exact time per point: "
        f"two-way / one-way = {ratio_v:.1f}x wall ({cpu_v:.1f}x CPU) against "
        f"`steady_velocity` (velocity only): {_verdict(ratio_v, cpu_v)}; {ratio_s:.1f}x wall "
        f"({cpu_s:.1f}x CPU) against `steady_state` (with diagnostics): "
        f"{_verdict(ratio_s, cpu_s)}.",
    ]
    if goal_error is not None:
        lines.append(
            f"Relative error <= {GOAL_ERROR:g} where well conditioned: largest "
            f"{goal_error:.1e} over the sampled points with cond <= {WELL_CONDITIONED:g}: "
            f"{'met' if goal_error <= GOAL_ERROR else 'not met'}."
        )
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    raise SystemExit(main())
