"""Benchmark: speed against error of the planar steering model.

For the steering disk of ``workflows/steering.toml`` at the four paper commands
(7.2, 8.2, 14.2, 15.2 Hz at a = 7 m s^-2), integrates three drive periods from the
plates' steady response with ``study.solvers.planar.simulate_planar`` over a grid of
tolerances and slaving thresholds, and with the independent reference of the tests
(``tests/reference/planar.py``: scipy Radau/DOP853). The error is the largest
distance of the final position from the tightest package run (tolerance 1e-13,
slaving 1e-7), relative to the distance slid; time is per drive period, one thread,
warm, minimum of three repeats. Timings are reported, never asserted.

Writes ``results/bench-planar.md`` and the documentation's table,
``docs/speed/planar.md``. Usage: ``python benchmarks/bench_planar.py``
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
from docs_tables import exponent, output, quick_option, use_quick, write_docs_table

from study.scenes.planar_model import rest_state
from study.scenes.scene_spec import load_scene
from study.solvers.integrator import IntegratorSettings, Schedule
from study.solvers.planar import simulate_planar

ROOT = Path(__file__).resolve().parent.parent
# The repo root, for tests.reference: the independent oracles are not installed.
sys.path.insert(0, str(ROOT))

from tests.reference.planar import RefPlate, reference_planar  # noqa: E402

COMMANDS = {"left": 7.2, "right": 8.2, "forward": 14.2, "backward": 15.2}
ACCELERATION = 7.0
PERIODS = 3


def _start(disk, f):
    return rest_state(disk, drive=(f, ACCELERATION))


def _package(disk, f, tolerance, slaving):
    schedule = Schedule.constant(f, ACCELERATION, PERIODS / f)
    run = simulate_planar(disk, schedule, initial_state=_start(disk, f),
                          output_times=[PERIODS / f],
                          settings=IntegratorSettings(tolerance=tolerance), slaving=slaving)
    return run.final_state, run.steps


def _reference(disk, f, rtol):
    plates = [RefPlate(p.f0, p.Q, p.alpha, p.M, p.direction, p.attachment)
              for p in disk.plates]
    run = reference_planar(plates, [f], [ACCELERATION], [PERIODS / f], cs=disk.cs,
                           radius=disk.radius, initial_state=_start(disk, f),
                           output_times=[PERIODS / f], rtol=rtol)
    return np.array([run.x[-1], run.y[-1], run.heading[-1]])


def _milliseconds(seconds: float) -> str:
    """Two significant digits, no exponent: ``0.56 ms``, ``72 ms``, ``120 ms``."""
    ms = seconds * 1e3
    return f"{ms:.2g} ms" if ms < 100 else f"{ms:.0f} ms"


#: Repeats of each timed call (1 with --quick).
REPEATS = {"count": 3}


def _timed(function, *args):
    best = np.inf
    result = None
    for _ in range(REPEATS["count"]):
        started = time.perf_counter()
        result = function(*args)
        best = min(best, time.perf_counter() - started)
    return result, best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    quick_option(parser)
    args = parser.parse_args()
    tolerances, slavings, rtols = (1e-6, 1e-8, 1e-10, 1e-12), (1e-3, 1e-4, 1e-5), (1e-8, 1e-10)
    if use_quick(args.quick):  # two tolerances, one slaving, the looser reference, once
        tolerances, slavings, rtols = (1e-6, 1e-10), (1e-4,), (1e-8,)
        REPEATS["count"] = 1
    disk = load_scene(ROOT / "workflows" / "steering.toml").disk
    truth = {}
    for name, f in COMMANDS.items():
        state, _ = _package(disk, f, 1e-13, 1e-7)
        truth[name] = state
    rows = []
    for tolerance in tolerances:
        for slaving in slavings:
            errors, seconds, steps = [], [], []
            for name, f in COMMANDS.items():
                (state, count), spent = _timed(_package, disk, f, tolerance, slaving)
                slid = truth[name][6]
                errors.append(np.hypot(*(state[:2] - truth[name][:2])) / slid)
                seconds.append(spent / PERIODS)
                steps.append(count / PERIODS)
            rows.append(("package", f"tolerance {exponent(tolerance)}, slaving "
                         f"{exponent(slaving)}", max(errors), float(np.mean(seconds)),
                         float(np.mean(steps))))
    for rtol in rtols:
        errors, seconds = [], []
        for name, f in COMMANDS.items():
            pose, spent = _timed(_reference, disk, f, rtol)
            errors.append(np.hypot(*(pose[:2] - truth[name][:2])) / truth[name][6])
            seconds.append(spent / PERIODS)
        rows.append(("reference (scipy Radau + DOP853)", f"rtol {exponent(rtol)}", max(errors),
                     float(np.mean(seconds)), float("nan")))
    machine = f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, " \
        f"Python {platform.python_version()}"
    lines = [
        "# Planar steering model: speed against error",
        "",
        f"Machine: {machine}. Three drive periods at each of 7.2, 8.2, 14.2, 15.2 Hz, "
        "a = 7 m s^-2; error = largest final-position difference from the package at "
        "tolerance 1e-13, slaving 1e-7, relative to the distance slid.",
        "",
        "| method | setting | error (relative) | seconds per period | steps per period |",
        "|---|---|---|---|---|",
    ]
    for method, setting, error, seconds, steps in rows:
        lines.append(f"| {method} | {setting} | {error:.1e} | {seconds:.2e} | "
                     + ("" if np.isnan(steps) else f"{steps:.0f}") + " |")
    text = "\n".join(lines) + "\n"
    report = output(ROOT / "results" / "bench-planar.md")
    report.parent.mkdir(exist_ok=True)
    report.write_text(text)
    print(text)
    docs = ["| method | setting | error | time per drive period |", "|---|---|---|---|"]
    docs += [f"| {method} | {setting} | {error:.1e} | {_milliseconds(seconds)} |"
             for method, setting, error, seconds, _ in rows]
    write_docs_table("planar", "bench_planar.py", f"{machine}, one thread", "\n".join(docs),
                     "Three drive periods at each of the four commands (7.2, 8.2, 14.2, 15.2 Hz "
                     "at 7 m s^-2); error of the final position relative to the distance slid, "
                     "against the package at tolerance 1e-13 and slaving 1e-7.")


if __name__ == "__main__":
    main()
