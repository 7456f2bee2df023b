"""Benchmark: the paper's 1000 x 1000 (f, a) velocity map with the exact solver.

Reports kernel time (parallel and one-thread, after compilation, minimum of
repeats), the whole ``steady_state`` call, the first calls of a fresh process with a
cold numba cache and with the cache loaded, and the accuracy of a random sample of
points against a 40-digit mpmath implementation of the same event-driven closed
form (``tests/reference/one_way_exact.py``, which shares no code with ``study``).
Timings are reported, never asserted.

Writes the documentation's table, ``docs/speed/velocity-map.md``.

Usage: ``python benchmarks/bench_velocity_map.py [--size 1000] [--sample 60]``
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from docs_tables import per_point, quick_option, use_quick, write_docs_table

import study
from study.kernels import one_way as kernel
from study.kernels.budget import Budget
from study.model import lift_off_acceleration, release_amplitudes, slip_amplitudes

# The repo root, for tests.reference: the independent oracles are not installed.
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

# The first calls of a fresh process (imports excluded): the numba kernels are compiled
# on first use, or loaded from numba's cache when they were compiled before.
_FIRST_CALLS = """
import time
import numpy as np
import study
s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
start = time.perf_counter()
study.steady_state(s, np.linspace(10.0, 20.0, 2)[:, None], np.linspace(0.0, 12.0, 2))
study.steady_state(s, np.full(4096, 13.0), 8.5)
print(time.perf_counter() - start)
"""


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
    return (
        f"{cpu}, {os.cpu_count()} cores, numba {numba.__version__} "
        f"({numba.config.NUMBA_NUM_THREADS} threads), numpy {np.__version__}, "
        f"Python {platform.python_version()}"
    )


def _kernel_inputs(structure, f, a):
    f_flat = np.ascontiguousarray(np.broadcast_to(f, np.broadcast_shapes(f.shape, a.shape))).ravel()
    a_flat = np.ascontiguousarray(np.broadcast_to(a, np.broadcast_shapes(f.shape, a.shape))).ravel()
    a_plus, a_minus = release_amplitudes(structure, f_flat, a_flat)
    b_plus, b_minus = slip_amplitudes(structure, f_flat, a_flat)
    lifted = a_flat > lift_off_acceleration(structure, f_flat)
    n = f_flat.size
    outputs = (np.empty((n, kernel.N_OUTPUTS)),)
    inputs = (
        kernel.Amplitudes(a_plus, a_minus, b_plus, b_minus), a_flat, lifted,
        2 * np.pi * f_flat,
        kernel.FrictionLevels(structure.cs * structure.g, structure.ck * structure.g),
        Budget(10_000, 5_000, 1e-3, 20_000),
    )
    return inputs, outputs


def _first_calls(cold: bool) -> float:
    """Seconds of the first calls in a fresh process: with an empty numba cache
    (``cold``: every kernel compiled) or with the cache this process filled."""
    environment = dict(os.environ)
    with tempfile.TemporaryDirectory() as empty:
        if cold:
            environment["NUMBA_CACHE_DIR"] = empty
        child = subprocess.run([sys.executable, "-c", _FIRST_CALLS], env=environment,
                               capture_output=True, text=True, check=True)
    return float(child.stdout.split()[-1])


def _shares(status: np.ndarray) -> str:
    """``56 % static, 27 % stick-slip, 17 % lift-off``: the statuses of a map."""
    counts = [(s.name.lower().replace("_", "-"), np.mean(status == s)) for s in study.Status]
    return ", ".join(f"{100 * share:.0f} % {name}" for name, share in counts if share > 0)


def _best_of(repeats, func):
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1000, help="points per axis")
    parser.add_argument("--sample", type=int, default=60, help="points checked with mpmath")
    parser.add_argument("--repeats", type=int, default=2)
    quick_option(parser)
    args = parser.parse_args()
    if use_quick(args.quick):  # 300 x 300 points, one round, no cold compile
        args.size, args.sample, args.repeats = min(args.size, 300), min(args.sample, 5), 1

    structure = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f = np.linspace(10.0, 20.0, args.size)[:, None]
    a = np.linspace(0.0, 12.0, args.size)[None, :]
    print(f"machine: {_machine()}")

    start = time.perf_counter()
    study.steady_state(structure, f[:2], a[:, :2])
    study.steady_state(structure, np.full(4096, 13.0), 8.5)
    print(f"first calls (compile or load the numba cache): {time.perf_counter() - start:.2f} s")

    inputs, outputs = _kernel_inputs(structure, f, a)
    parallel = _best_of(args.repeats, lambda: kernel.solve_points_averaged(*inputs, *outputs))
    serial = _best_of(1, lambda: kernel.solve_points_averaged_serial(*inputs, *outputs))
    whole = _best_of(args.repeats, lambda: study.steady_state(structure, f, a))
    result = study.steady_state(structure, f, a)
    n = result.velocity.size
    counts = {s.name: int(np.sum(result.status == s)) for s in study.Status}
    print(f"map {args.size} x {args.size} = {n} points; statuses {counts}")
    print(f"kernel, parallel:   {parallel:.3f} s  ({parallel / n * 1e9:.0f} ns per point)")
    print(f"kernel, one thread: {serial:.3f} s  (parallel speed-up {serial / parallel:.2f}x)")
    print(f"steady_state call:  {whole:.3f} s  (kernel share {parallel / whole:.0%})")

    # The same map for a fully resonant structure (M = 1): continuous sliding dominates.
    sliding = structure.replace(M=1.0)
    inputs_1, outputs_1 = _kernel_inputs(sliding, f, a)
    kernel.solve_points_averaged(*inputs_1, *outputs_1)
    parallel_1 = _best_of(args.repeats, lambda: kernel.solve_points_averaged(*inputs_1, *outputs_1))
    counts_1 = {s.name: int(np.sum(outputs_1[0][:, kernel.OUT_STATUS] == s))
                for s in study.Status}
    print(f"same map at M = 1: statuses {counts_1}")
    print(f"kernel, parallel:   {parallel_1:.3f} s  ({parallel_1 / n * 1e9:.0f} ns per point)")

    # A cold compile takes minutes on a busy machine: not in quick mode (NaN).
    cold = math.nan if args.quick else _first_calls(cold=True)
    cached = _first_calls(cold=False)
    print(f"first calls of a fresh process: {cold:.1f} s cold, {cached:.1f} s from the cache")
    threads = numba.config.NUMBA_NUM_THREADS
    sliding_share = np.mean(outputs_1[0].status == study.Status.CONTINUOUS_SLIDING)
    rows = [
        (f"kernel, {threads} threads, paper map (M = 0.08: {_shares(result.status)})",
         f"**{parallel:.2f} s**", per_point(parallel, n)),
        ("kernel, 1 thread, same map",
         f"{serial:.2f} s ({threads} threads are {serial / parallel:.2f}x faster)",
         per_point(serial, n)),
        (f"whole `steady_state` call, {threads} threads (validation, force amplitudes, "
         "kernel, diagnostics)", f"{whole:.2f} s", per_point(whole, n)),
        (f"kernel, {threads} threads, same grid at M = 1 ({100 * sliding_share:.0f} % "
         "continuous sliding)", f"{parallel_1:.2f} s", per_point(parallel_1, n)),
        ("numba compilation on first use (cold cache) / loading the cache",
         f"{cold:.1f} s / {cached:.1f} s", ""),
    ]
    table = "\n".join(["| what | time | per point |", "|---|---|---|"]
                      + [f"| {what} | {time_} | {point} |" for what, time_, point in rows])
    measured = f"{_machine()}, load average {os.getloadavg()[0]:.1f}"

    try:
        from tests.reference.one_way_exact import exact_velocity
    except ImportError as err:  # mpmath is in the test extra
        print(f"accuracy check skipped: {err}")
        write_docs_table("velocity-map", "bench_velocity_map.py", measured, table)
        return
    if args.sample < 1:
        write_docs_table("velocity-map", "bench_velocity_map.py", measured, table)
        return
    rng = np.random.default_rng(2026)
    moving = np.flatnonzero(result.status.ravel() == study.Status.STICK_SLIP)
    chosen = rng.choice(moving, size=min(args.sample, moving.size), replace=False)
    f_all = np.broadcast_to(f, result.velocity.shape).ravel()
    a_all = np.broadcast_to(a, result.velocity.shape).ravel()
    eps = np.finfo(float).eps
    errors = []
    conditioned = []
    start = time.perf_counter()
    for i in chosen:
        params = (14.44, 17.5, 64.0, 0.08, 0.25)
        exact, status, _ = exact_velocity(*params, f_all[i], a_all[i])
        assert status == "stick_slip", (f_all[i], a_all[i], status)
        relative = abs(float((result.velocity.ravel()[i] - exact) / exact))
        errors.append(relative)
        # Float64 inputs are known only to eps: the best any float64 solver can do is
        # eps times the relative condition number of v with respect to f and a.
        cond = _condition(exact_velocity, params, f_all[i], a_all[i], exact)
        conditioned.append(relative / (eps * max(1.0, cond)))
    errors = np.array(errors)
    conditioned = np.array(conditioned)
    print(
        f"accuracy vs 40-digit reference on {errors.size} random moving points "
        f"({time.perf_counter() - start:.1f} s): relative error max {errors.max():.2e} "
        f"({errors.max() / eps:.0f} eps), median {np.median(errors):.2e} "
        f"({np.median(errors) / eps:.1f} eps)"
    )
    print(
        "error in units of eps x condition number (1 = as good as float64 inputs allow): "
        f"max {conditioned.max():.2f}, median {np.median(conditioned):.2f}"
    )
    accuracy = (
        f"Accuracy on {errors.size} random moving points of the map, against the 40-digit "
        f"reference: relative error {np.median(errors):.1e} median "
        f"({np.median(errors) / eps:.0f} eps), {errors.max():.1e} at worst; in units of "
        "eps x the point's condition number (1: as accurate as float64 inputs allow), "
        f"{conditioned.max():.1f} at worst, {np.median(conditioned):.1f} median.")
    write_docs_table("velocity-map", "bench_velocity_map.py", measured, table, accuracy)


def _condition(exact_velocity, params, f, a, exact) -> float:
    """Relative condition number ``|d ln v/d ln f| + |d ln v/d ln a|``, in mpmath."""
    from mpmath import mp, mpf

    with mp.workdps(40):
        h = mpf("1e-20")
        v_f, _, _ = exact_velocity(*params, mpf(f) * (1 + h), a)
        v_a, _, _ = exact_velocity(*params, f, mpf(a) * (1 + h))
        return float((abs(v_f - exact) + abs(v_a - exact)) / (h * abs(exact)))


if __name__ == "__main__":
    main()
