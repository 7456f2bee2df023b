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

Usage: ``python benchmarks/bench_flight.py [--size 121] [--repeats 2] [--sample 8]``
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
from numba import njit

ROOT = Path(__file__).resolve().parent.parent
# The repo root, for tests.reference: the independent oracles are not installed.
sys.path.insert(0, str(ROOT))
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
from study.kernels.start import RELEASE  # noqa: E402
from study.kernels.two_way import flight, points  # noqa: E402
from study.kernels.two_way.modes import TWO_PI, DrivePoint, mode_row  # noqa: E402
from study.solvers.exact import steady_state, steady_velocity  # noqa: E402
from study.solvers.settings import DEFAULT_SETTINGS, kernel_budget  # noqa: E402
from study.solvers.structure_constants import structure_vector  # noqa: E402

#: The M -> 1 structure of the flight workflows (M = 1 is refused with flight).
STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
#: The issue's goal: a bouncing point costs at most this many stick-slip points.
GOAL_BOUNCING = 3.0
#: Issue 35's goals: the flight map at most this many times the one-way map per point,
#: and an irregular point (no periodic orbit) at most this share of its cost in release
#: 0.2.0, which exhausted the cycle search at each: PREVIOUS_IRREGULAR_US a point, this
#: benchmark's own figure on this machine (docs/speed/flight.md, 2026-11-27, 59 points).
GOAL_FLIGHT_OVER_ONE_WAY = 20.0
GOAL_IRREGULAR_SHARE = 0.2
PREVIOUS_IRREGULAR_US = 93169.91
#: The fewest Newton passes with the Jacobian that find an orbit and check it: from a
#: start ~1e-2 off (scaled), residuals 1e-4, 1e-8, 1e-16, and the pass that verifies.
FEWEST_NEWTON_PASSES = 4
#: Periods of a bouncing point's flight search besides its Newton passes: the two
#: followed from the start before Newton (the first hop from rest is not the orbit's),
#: the pass that places the section and the legs from phase 0 to the section and back.
PERIODS_BESIDE_NEWTON = 4
#: Passes of the flight pass's timing (the time of one: the difference of two counts
#: over their difference, after the first periods' transient).
PASS_COUNTS = (5, 15)
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


@njit(error_model="numpy")
def flight_passes(vector, omega, a, count, want_jac):
    """``count`` passes of the period map with flight from rest at each point (``fly``
    over a period, with or without the Jacobian), as the flight search runs them. Not
    cached: it must follow the kernel it calls.

    Parameters
    ----------
    vector : numpy.ndarray
        The structure vector (two-way, flight).
    omega, a : numpy.ndarray
        The points [rad s-1], [m s-2].
    count : int
        Passes at each point.
    want_jac : bool
        With the Jacobian (a Newton pass) or without (a map pass).

    Returns
    -------
    float
        The events of the points' passes, summed.
    """
    events = 0.0
    for i in range(omega.shape[0]):
        table = np.zeros((flight.N_ROWS, points.N_MODE))
        for row in range(3):
            mode_row(vector, omega[i], a[i], table, row)
        flight.flight_row(vector, table)
        point = DrivePoint(vector, table, omega[i], a[i])
        z = np.zeros(flight.N_STATE)
        points.start_state(table, omega[i], 0.0, z, 1.0)
        record = flight.FlightRecord(np.zeros(flight.N_FLIGHT_ACC),
                                     np.eye(flight.N_STATE),
                                     np.empty((flight.N_STATE, flight.N_STATE)),
                                     np.empty((flight.N_STATE, flight.N_STATE)),
                                     np.zeros(2))
        for _ in range(count):
            for j in range(flight.N_STATE):
                for m in range(flight.N_STATE):
                    record.jac[j, m] = 1.0 if j == m else 0.0
            flight.fly(point, z, 0.0, TWO_PI / omega[i], record, want_jac, False, 1_000_000)
        events += record.acc[flight.A_EVENT_COUNT]
    return events


def _work_table(f: np.ndarray, a: np.ndarray, with_flight: bool) -> np.ndarray:
    """The orbit kernel's output table (with its work columns) at ``f``, ``a``, every
    point from rest (no continuation), on one thread."""
    vector = structure_vector(STRUCTURE, "two-way", with_flight)
    out = np.empty((f.size, points.N_OUT))
    lifted = a > study.lift_off_acceleration(STRUCTURE, f)
    points.solve_points_serial(vector, 2.0 * np.pi * f, a, lifted,
                               kernel_budget(DEFAULT_SETTINGS), False, RELEASE, out)
    return out


def _bouncing_part(part: dict, args: argparse.Namespace) -> dict:
    """Where a bouncing point's time goes: the flight search's passes from the kernel's
    work columns, split by how its orbit was found, the contact search that the points
    below the stick's lift-off threshold take first (the same points without flight),
    and the time of a flight pass."""
    state = part["state"]
    index = np.flatnonzero(state.status == study.Status.BOUNCING)
    if index.size == 0:
        return {}
    f, a = part["f"][index], part["a"][index]
    # Past the stick's threshold the flight search comes first; below it only a contact
    # search that ends LIFT_OFF leads to it.
    lifted = a > study.lift_off_acceleration(STRUCTURE, f)
    with_flight = _work_table(f, a, True)
    contact = _work_table(f, a, False)
    contact_passes = (contact[:, points.OUT_NEWTON_PASSES]
                      + contact[:, points.OUT_MAP_PASSES])
    newton = with_flight[:, points.OUT_NEWTON_PASSES] - np.where(
        lifted, 0.0, contact[:, points.OUT_NEWTON_PASSES])
    maps = with_flight[:, points.OUT_MAP_PASSES] - np.where(
        lifted, 0.0, contact[:, points.OUT_MAP_PASSES])
    # Newton's method from the start takes one map pass to place its section and, when
    # its last pass was not foreseen, one for the largest gap; the cycle search takes
    # at least three (the first section, an iterate, its own section).
    direct = maps <= 2.0
    calls = _calls()
    kinds = {name: (f[chosen], a[chosen]) for name, chosen in (
        ("all", np.ones(index.size, bool)), ("direct", direct & lifted),
        ("cycle", ~direct), ("below", direct & ~lifted)) if chosen.any()}
    # The unit, the stick-slip points without flight, timed in the same rounds as the
    # kinds: on a shared machine a ratio is only as good as the two times are close.
    stick_slip = np.flatnonzero(state.status == study.Status.STICK_SLIP)
    kinds["stick-slip"] = (part["f"][stick_slip], part["a"][stick_slip])
    times = {name: {key: math.inf for key in ("two-way", "two-way, flight")}
             for name in kinds}
    for _ in range(args.repeats):
        for name, (x, y) in kinds.items():
            for key in times[name]:
                spent = _timed(lambda key=key, x=x, y=y: calls[key](x, y))[1]
                times[name][key] = min(times[name][key], spent / x.size)
    vector = structure_vector(STRUCTURE, "two-way", True)
    sample = index[:: max(1, index.size // 400)]
    omega_s, a_s = 2.0 * np.pi * part["f"][sample], part["a"][sample]
    flight_passes(vector, omega_s[:2], a_s[:2], 1, False)
    flight_passes(vector, omega_s[:2], a_s[:2], 1, True)
    pass_time = {}
    for want_jac in (False, True):
        spent = []
        for count in PASS_COUNTS:
            spent.append(min(_timed(lambda c=count, w=want_jac: flight_passes(
                vector, omega_s, a_s, c, w))[1] for _ in range(args.repeats)))
        pass_time[want_jac] = ((spent[1] - spent[0])
                               / ((PASS_COUNTS[1] - PASS_COUNTS[0]) * sample.size))

    def mean(values: np.ndarray, chosen: np.ndarray) -> float:
        return float(np.mean(values[chosen])) if chosen.any() else math.nan

    return {"n": index.size, "direct": int(np.count_nonzero(direct & lifted)),
            "cycle": int(np.count_nonzero(~direct)),
            "below": int(np.count_nonzero(direct & ~lifted)), "times": times,
            "newton": (mean(newton, direct & lifted), mean(newton, ~direct)),
            "maps": (mean(maps, direct & lifted), mean(maps, ~direct)),
            "contact_passes": mean(contact_passes, ~lifted),
            "skipped_passes": mean(contact_passes, lifted),
            "pass_time": pass_time}


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
        # The same points without flight: a stick-slip point's cost in the two-way
        # solver itself, the goal's unit (with flight, a stick-slip point past the
        # stick's lift-off threshold also takes the flight search first).
        without = math.inf
        for _ in range(args.repeats):
            without = min(without, _timed(lambda x=f_all[index], y=a_all[index]:
                                          calls["two-way"](x, y))[1])
        by_status.append((code.name, index.size, best / index.size,
                          float(np.mean(state.impacts_per_period[index]))
                          if code == study.Status.BOUNCING else math.nan,
                          without / index.size))
        print(f"  {code.name:19s} {index.size:7d} points: {best / index.size * 1e6:.2f} us "
              f"({without / index.size * 1e6:.2f} us without flight)", flush=True)
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
    # The integrator's kernels compile (or load their cache) on its first call: not
    # the first row's time.
    integrated_steady_state(STRUCTURE, float(map_part["f"][chosen[0]]),
                            float(map_part["a"][chosen[0]]), coupling="two-way",
                            flight=True, settings=IntegratorSettings(tolerance=TOLERANCES[0]))
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
              "", "| status with flight | points | CPU per point [us] | the same points "
              "without flight [us] | impacts per period |", "|---|---|---|---|---|"]
    per_point = {}
    stick_slip = math.nan
    for name, count, seconds, impacts, without in part["by_status"]:
        per_point[name] = seconds
        if name == "STICK_SLIP":
            stick_slip = without
        lines.append(f"| {name} | {count} | {seconds * 1e6:.2f} | {without * 1e6:.2f} | "
                     f"{'-' if math.isnan(impacts) else f'{impacts:.2f}'} |")
    if "BOUNCING" in per_point and "STICK_SLIP" in per_point:
        ratio = per_point["BOUNCING"] / stick_slip
        lines += ["", f"A bouncing point costs {ratio:.1f}x a stick-slip point of the two-way "
                  f"solver (goal <= {GOAL_BOUNCING:g}x: "
                  f"{'met' if ratio <= GOAL_BOUNCING else 'not met'}). The unit is the "
                  f"stick-slip points' time without flight, {stick_slip * 1e6:.1f} us; with "
                  f"flight they cost {per_point['STICK_SLIP'] * 1e6:.1f} us, those past the "
                  f"stick's lift-off threshold taking the flight search first."]
    if "STICK_SLIP" in per_point:
        lines += _bouncing_text(part.get("bouncing", {}))
    counts = {name: count for name, count, _, _, _ in part["by_status"]}
    irregular = [name for name in ("CHAOTIC", "QUASI_PERIODIC", "NOT_CONVERGED")
                 if name in per_point]
    if irregular:
        count = sum(counts[name] for name in irregular)
        spent = sum(per_point[name] * counts[name] for name in irregular)
        each = spent / count
        share = each * 1e6 / PREVIOUS_IRREGULAR_US
        met = "met" if share <= GOAL_IRREGULAR_SHARE else "not met"
        lines += ["", f"The {count} points without a periodic orbit within reach ("
                  + ", ".join(f"{counts[name]} `{name}`" for name in irregular)
                  + f") take {spent / cpu['two-way, flight']:.0%} of the flight map's time, "
                  f"{each * 1e3:.1f} ms a point: {share:.2f} of release 0.2.0's "
                  f"{PREVIOUS_IRREGULAR_US / 1e3:.1f} ms, which exhausted the cycle search at "
                  f"each (goal <= {GOAL_IRREGULAR_SHARE:g}: {met}). An irregular motion is "
                  "followed on the period map with its Jacobian (the tangent's exponent "
                  "stops the cycle search's Newton tries once clearly positive) and "
                  "averaged until its velocity's 95 % half-width is within "
                  "1e-3 a/(2 pi f)."]
    over = cpu["two-way, flight"] / cpu["one-way"]
    met = "met" if over <= GOAL_FLIGHT_OVER_ONE_WAY else "not met"
    line = (f"The flight map costs {over:.0f}x the one-way map per point (goal <= "
            f"{GOAL_FLIGHT_OVER_ONE_WAY:g}x: {met})")
    if "BOUNCING" in per_point:
        bouncing = per_point["BOUNCING"] * counts["BOUNCING"] / cpu["two-way, flight"]
        line += f"; its bouncing points take {bouncing:.0%} of its time."
    lines += ["", line + ("" if line.endswith(".") else ".")]
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


def _bouncing_text(bouncing: dict) -> list[str]:
    """The paragraph on where a bouncing point's time goes and the method's floor,
    against the time of a stick-slip point without flight timed in the same rounds."""
    if not bouncing:
        return []
    times = bouncing["times"]
    stick_slip = times["stick-slip"]["two-way"]
    n = bouncing["n"]
    direct, cycle, below = bouncing["direct"], bouncing["cycle"], bouncing["below"]
    pass_map, pass_jac = bouncing["pass_time"][False], bouncing["pass_time"][True]
    every = times["all"]
    text = (f"Where a bouncing point's time goes ({n} points as one call; each kind "
            f"below as one call, in the same rounds as the stick-slip points without "
            f"flight, {stick_slip * 1e6:.1f} us a point, the unit of the ratios here): "
            f"{every['two-way, flight'] * 1e6:.1f} us a point, "
            f"{every['two-way, flight'] / stick_slip:.1f}x. A "
            f"point past the stick's lift-off threshold is solved with flight first; "
            f"the contact search that it no longer takes (the same points without "
            f"flight, {bouncing['skipped_passes']:.2f} passes) would cost "
            f"{every['two-way'] * 1e6:.1f} us a point of them all. A pass of the period "
            f"map with flight takes {pass_map * 1e6:.2f} us ({pass_jac * 1e6:.2f} us "
            f"with its Jacobian).")
    if "direct" in times:
        found = times["direct"]
        text += (f" {direct} points ({direct / n:.0%}) are past the threshold and found "
                 f"by Newton's method from the start: "
                 f"{bouncing['newton'][0]:.2f} Newton passes, "
                 f"{bouncing['maps'][0]:.2f} map passes (the section's, and the "
                 f"largest gap's where the last Newton pass was not foreseen) and "
                 f"{PERIODS_BESIDE_NEWTON} periods beside them; such a point costs "
                 f"{found['two-way, flight'] * 1e6:.1f} us, "
                 f"{found['two-way, flight'] / stick_slip:.1f}x a stick-slip point.")
    if "below" in times:
        found = times["below"]
        text += (f" {below} ({below / n:.0%}) are below the threshold: the contact "
                 f"search ({bouncing['contact_passes']:.2f} passes, "
                 f"{found['two-way'] * 1e6:.1f} us) ends `LIFT_OFF` before the flight "
                 f"search, so that every point the contact solver keeps on the table "
                 f"keeps every bit of its result; such a point costs "
                 f"{found['two-way, flight'] * 1e6:.1f} us, "
                 f"{found['two-way, flight'] / stick_slip:.1f}x.")
    if "cycle" in times:
        found = times["cycle"]
        share = found["two-way, flight"] * cycle / (every["two-way, flight"] * n)
        text += (f" The other {cycle} ({cycle / n:.0%}) need the cycle search "
                 f"({bouncing['maps'][1]:.1f} map passes and {bouncing['newton'][1]:.1f} "
                 f"Newton passes of up to 16 periods each) and take {share:.0%} of the "
                 f"bouncing points' time.")
    floor = PERIODS_BESIDE_NEWTON * pass_map + FEWEST_NEWTON_PASSES * pass_jac
    text += (f" The floor of the method at a point past the threshold: "
             f"{PERIODS_BESIDE_NEWTON} periods beside Newton's method and its fewest "
             f"{FEWEST_NEWTON_PASSES} passes (a start ~1e-2 off, quadratic convergence to "
             f"the rounding and the pass that checks it) make {floor * 1e6:.1f} us, "
             f"{floor / stick_slip:.1f}x a stick-slip point ({stick_slip * 1e6:.1f} us).")
    return ["", text]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=SIZE, help="points per axis")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--sample", type=int, default=8,
                        help="bouncing points checked against the reference (0: none)")
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--output", type=Path, default=ROOT / "results" / "bench-flight.md")
    quick_option(parser)
    args = parser.parse_args(argv)
    if use_quick(args.quick):  # 41 x 41 points, one round, two reference points
        args.size, args.repeats, args.sample = min(args.size, 41), 1, min(args.sample, 2)
    args.output = output(args.output)
    load_start = load_average()
    print(f"machine: {machine()}; load average {load_start}", flush=True)
    part = _map_part(args)
    part["bouncing"] = _bouncing_part(part, args)
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
