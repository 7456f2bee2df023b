"""Benchmark: ``steady_velocity`` against a single-purpose floor on the paper's map.

The floor is the straightforward numba program a careful user would write for this
one map and nothing else: per point the force amplitudes (paper eqs. 2-3), lift-off,
the two release arcs (an arccos each), then the stick-slip orbit from rest at phase
0, each slip end found by Newton iteration bracketed on the decreasing stretch of
the slip speed (stopped once the speed is below the rounding error of its own
evaluation), until a release after a stick recurs; the mean velocity over that
orbit. It computes nothing else: no diagnostics, no validation, no continuous
sliding (a point that has not closed an orbit after ``MAX_EVENTS`` slips is reported
as not converged; there is none on the paper's map), one thread.

``steady_velocity`` (the package's public call, validation and all), the floor and
``steady_state`` (the same orbit with its diagnostics) are timed back to back on one
numba thread over the paper's 1000 x 1000 (f, a) map (f 10-20 Hz, a 0-12 m s^-2,
f0 14.44 Hz, Q 17.5, alpha 64 deg, M 0.08, cs = ck = 0.25), after compilation,
minimum of repeats, the three alternating. The floor must give the same statuses and
velocities within ``AGREEMENT`` m/s (asserted); the package's velocity must be
bit-identical to ``steady_state``'s (asserted). Timings are reported, never asserted.
The table goes to ``results/bench-floor.md`` and, in CPU time, to the documentation's
``docs/speed/floor.md``.

Usage: ``python benchmarks/floor_one_way.py [--size 1000] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time
from pathlib import Path

import numba
import numpy as np
from docs_tables import output, per_point, quick_option, use_quick, write_docs_table
from numba import njit

import study

ROOT = Path(__file__).resolve().parent.parent
PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25}
F_RANGE = (10.0, 20.0)  # Hz
A_RANGE = (0.0, 12.0)  # m s-2
#: Largest |v_floor - v_package| allowed where both give a velocity [m s^-1].
AGREEMENT = 2e-15
MAX_EVENTS = 10_000
TWO_PI = 2.0 * math.pi
EPS = float(np.finfo(np.float64).eps)

STATIC = int(study.Status.STATIC)
STICK_SLIP = int(study.Status.STICK_SLIP)
LIFT_OFF = int(study.Status.LIFT_OFF)
NOT_CONVERGED = int(study.Status.NOT_CONVERGED)


@njit(cache=True)
def _wrap(x):
    return x - TWO_PI * math.floor(x / TWO_PI)


@njit(cache=True)
def _slip(psi0, h, c, gamma):
    """Slip from rest at phase ``psi0`` (relative to the phase of ``B_s``): the scaled
    speed ``U(D) = -c D + h (sin(psi0 + D) - sin(psi0))`` until it is 0 again.
    ``U`` is largest where ``psi0 + D = gamma`` and smallest at ``2 pi - gamma``
    (mod 2 pi): the end is on that decreasing stretch. Returns its phase length and
    ``integral of U dD``."""
    if gamma <= 0.0:
        return 0.0, 0.0
    lo = _wrap(gamma - psi0)
    hi = lo + TWO_PI - 2.0 * gamma
    sin0 = math.sin(psi0)
    cos0 = math.cos(psi0)
    speed_lo = -c * lo + h * (math.sin(psi0 + lo) - sin0)
    if speed_lo <= 0.0:
        return 0.0, 0.0
    speed_hi = -c * hi + h * (math.sin(psi0 + hi) - sin0)
    d = lo + (hi - lo) * speed_lo / (speed_lo - speed_hi)  # regula falsi, then Newton
    for _ in range(100):
        sin_d = math.sin(psi0 + d)
        speed = -c * d + h * (sin_d - sin0)
        # Done once the speed is below the rounding error of its own evaluation.
        if abs(speed) <= 4.0 * EPS * (c * d + h * (abs(sin_d) + abs(sin0))):
            break
        if speed > 0.0:
            lo = d
        else:
            hi = d
        d_new = d - speed / (h * math.cos(psi0 + d) - c)
        d = d_new if lo < d_new < hi else 0.5 * (lo + hi)
    distance = -0.5 * c * d * d + h * (cos0 - math.cos(psi0 + d) - d * sin0)
    return d, distance


@njit(cache=True)
def _release(theta, entry_p, width_p, entry_m, width_m):
    """Wait from rest at ``theta`` until a release arc is entered, and its sign."""
    wait = np.inf
    sign = 0
    if width_p > 0.0:
        d = _wrap(theta - entry_p)
        wait = 0.0 if d < width_p else TWO_PI - d
        sign = 1
    if width_m > 0.0:
        d = _wrap(theta - entry_m)
        w = 0.0 if d < width_m else TWO_PI - d
        if w < wait:
            wait = w
            sign = -1
    return wait, sign


@njit(cache=True)
def floor_point(f, a, w0, q, m, cos_a, sin_a, cs, ck, g):
    """Mean steady velocity [m s^-1] and status at one drive point."""
    w = TWO_PI * f
    k = w * w * m * cos_a / complex(w0 * w0 - w * w, w0 * w / q)
    one = 1.0 + k * cos_a
    if a > g / abs(one):
        return np.nan, LIFT_OFF
    normal = -a * one
    tangential = a * k * sin_a
    a_p = tangential - cs * normal
    a_m = -tangential - cs * normal
    b_p = tangential - ck * normal
    b_m = -tangential - ck * normal
    level = cs * g
    width_p = 2.0 * math.acos(level / abs(a_p)) if abs(a_p) > level else 0.0
    width_m = 2.0 * math.acos(level / abs(a_m)) if abs(a_m) > level else 0.0
    if width_p == 0.0 and width_m == 0.0:
        return 0.0, STATIC
    entry_p = _wrap(-0.5 * width_p - math.atan2(a_p.imag, a_p.real))
    entry_m = _wrap(-0.5 * width_m - math.atan2(a_m.imag, a_m.real))
    h_p, phi_p = abs(b_p), math.atan2(b_p.imag, b_p.real)
    h_m, phi_m = abs(b_m), math.atan2(b_m.imag, b_m.real)
    c = ck * g
    gamma_p = math.acos(c / h_p) if h_p > c else 0.0
    gamma_m = math.acos(c / h_m) if h_m > c else 0.0
    # Stick-slip: after a stick the orbit restarts at an arc's entry, so it is
    # periodic as soon as a release after a stick of the same sign recurs.
    wait, sign = _release(0.0, entry_p, width_p, entry_m, width_m)
    theta = wait
    distance = 0.0
    seen_p = seen_m = False  # a release after a stick: its phase and the distance then
    last_p = last_m = dist_p = dist_m = 0.0
    for _ in range(MAX_EVENTS):
        if wait > 0.0:
            seen = seen_p if sign > 0 else seen_m
            turns = round((theta - (last_p if sign > 0 else last_m)) / TWO_PI)
            if seen and turns >= 1:
                previous = dist_p if sign > 0 else dist_m
                return (distance - previous) / (TWO_PI * turns) / w, STICK_SLIP
            if sign > 0:
                seen_p, last_p, dist_p = True, theta, distance
            else:
                seen_m, last_m, dist_m = True, theta, distance
        if sign > 0:
            duration, moved = _slip(_wrap(theta + phi_p), h_p, c, gamma_p)
        else:
            duration, moved = _slip(_wrap(theta + phi_m), h_m, c, gamma_m)
        distance += sign * moved
        theta += duration
        wait, sign = _release(theta, entry_p, width_p, entry_m, width_m)
        theta += wait
    return np.nan, NOT_CONVERGED


@njit(cache=True)
def floor_map(f, a, w0, q, m, cos_a, sin_a, cs, ck, g, velocity, status):
    """:func:`floor_point` over flat arrays ``f``, ``a``, into ``velocity``, ``status``."""
    for i in range(f.shape[0]):
        velocity[i], status[i] = floor_point(f[i], a[i], w0, q, m, cos_a, sin_a, cs, ck, g)


def floor_velocity(structure, f, a):
    """The floor on flat ``f``, ``a``: (velocity, status)."""
    alpha = math.radians(structure.alpha)
    velocity = np.empty(f.size)
    status = np.empty(f.size, np.int8)
    floor_map(f, a, TWO_PI * structure.f0, structure.Q, structure.M, math.cos(alpha),
              math.sin(alpha), structure.cs, structure.ck, structure.g, velocity, status)
    return velocity, status


def _machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as info:
            for line in info:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} cores, numba {numba.__version__}, numpy "
            f"{np.__version__}, Python {platform.python_version()}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1000, help="points per axis")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--output", type=Path, default=ROOT / "results" / "bench-floor.md")
    quick_option(parser)
    args = parser.parse_args()
    if use_quick(args.quick):  # 300 x 300 points, two rounds
        args.size, args.repeats = min(args.size, 300), 2
    args.output = output(args.output)
    numba.set_num_threads(1)

    structure = study.Structure(**PAPER)
    f = np.linspace(*F_RANGE, args.size)[:, None]
    a = np.linspace(*A_RANGE, args.size)[None, :]
    f_flat = np.ascontiguousarray(np.broadcast_to(f, (args.size, args.size))).ravel()
    a_flat = np.ascontiguousarray(np.broadcast_to(a, (args.size, args.size))).ravel()

    start = time.perf_counter()
    velocity, status = study.steady_velocity(structure, f, a)
    state = study.steady_state(structure, f, a)
    v_floor, s_floor = floor_velocity(structure, f_flat, a_flat)
    print(f"first calls (compile or load the numba caches): {time.perf_counter() - start:.1f} s")

    # Same answers: the package's velocity path bit for bit, the floor to AGREEMENT.
    assert np.array_equal(status, state.status)
    assert np.array_equal(velocity, state.velocity, equal_nan=True)
    assert np.array_equal(s_floor, status.ravel()), "floor and package statuses differ"
    both = np.isfinite(v_floor)
    assert np.array_equal(both, np.isfinite(velocity.ravel()))
    difference = float(np.max(np.abs(v_floor[both] - velocity.ravel()[both])))
    assert difference <= AGREEMENT, difference

    calls = {
        "steady_velocity": lambda: study.steady_velocity(structure, f, a),
        "floor": lambda: floor_velocity(structure, f_flat, a_flat),
        "steady_state": lambda: study.steady_state(structure, f, a),
    }
    best = dict.fromkeys(calls, np.inf)
    cpu = dict.fromkeys(calls, np.inf)
    load = os.getloadavg()[0]
    for _ in range(args.repeats):
        for name, call in calls.items():
            begin, begin_cpu = time.perf_counter(), time.process_time()
            call()
            best[name] = min(best[name], time.perf_counter() - begin)
            cpu[name] = min(cpu[name], time.process_time() - begin_cpu)

    n = velocity.size
    counts = {s.name.lower(): int(np.sum(status == s)) / n for s in study.Status}
    regimes = ", ".join(f"{100 * v:.0f} % {k.replace('_', '-')}" for k, v in counts.items() if v)
    lines = [
        "# The one-way velocity map against a single-purpose floor",
        "",
        f"Machine: {_machine()}; one numba thread. Paper's map, {args.size} x {args.size} "
        f"points (f {F_RANGE[0]:g}-{F_RANGE[1]:g} Hz, a {A_RANGE[0]:g}-{A_RANGE[1]:g} "
        f"m s^-2; {regimes}); after compilation, minimum of {args.repeats} alternating "
        "repeats. Floor (`benchmarks/floor_one_way.py`) and package agree on every status "
        f"and to {difference:.1e} m/s on every velocity (asserted <= {AGREEMENT:g}); "
        "`steady_velocity` and `steady_state` give bit-identical velocities (asserted). "
        f"Load average {load:.1f} before, {os.getloadavg()[0]:.1f} after (CPU time is the "
        "steadier figure on a shared machine).",
        "",
        "| call | time [s] | CPU time [s] | per point [ns] | ratio to the floor (time / CPU) |",
        "|---|---|---|---|---|",
    ]
    for name, seconds in best.items():
        lines.append(f"| `{name}` | {seconds:.3f} | {cpu[name]:.3f} | {seconds / n * 1e9:.0f} "
                     f"| {seconds / best['floor']:.2f}x / {cpu[name] / cpu['floor']:.2f}x |")
    text = "\n".join(lines) + "\n"
    args.output.parent.mkdir(exist_ok=True)
    args.output.write_text(text)
    print(text)

    # The documentation's table: CPU time, the steadier figure on a shared machine.
    rows = ["| one thread, paper map | time | per point | ratio to the floor |",
            "|---|---|---|---|"]
    for name, seconds in cpu.items():
        shown = f"**{seconds:.2f} s**" if name == "steady_velocity" else f"{seconds:.2f} s"
        label = "single-purpose floor" if name == "floor" else f"`{name}`"
        ratio = "1" if name == "floor" else f"{seconds / cpu['floor']:.3g}x"
        rows.append(f"| {label} | {shown} | {per_point(seconds, n)} | {ratio} |")
    wall_gap = max(abs(best[k] / cpu[k] - 1) for k in cpu)
    write_docs_table(
        "floor", "floor_one_way.py",
        f"{_machine()}, one numba thread, load average {load:.1f}; CPU times (wall times "
        f"within {100 * wall_gap:.0f} %)", "\n".join(rows),
        f"Floor and package agree on every status and to {difference:.1e} m/s on every "
        "velocity.")


if __name__ == "__main__":
    main()
