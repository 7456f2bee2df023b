"""Work-precision benchmark: error against time per point for every way to get a velocity.

Methods, each at several settings, on a fixed set of drive points (the paper's
structure; P, N, three PN points including both signs at 14.5 Hz, and two points just
above a threshold, where slips are short and easy to miss):

* ``exact``: the closed-form event-driven steady-state solver (:mod:`study.solvers.exact`);
* ``integrator``: study's Dormand-Prince 5(4) integrator with events on the dense
  output, adaptive, at several tolerances (:mod:`study.solvers.integrator`);
* ``integrator-fixed``: the same integrator with a fixed step (steps per period);
* ``naive``: fixed-step RK4 with contact switches by step-end sign tests only
  (``benchmarks/baselines.py``);
* ``solve_ivp``: scipy's RK45 with terminal events, restarted at each event, as a
  careful user would write it (``benchmarks/baselines.py``).

Error: largest ``|v - v_ref|`` over the points, against a 40-digit mpmath
implementation of the exact solution (``tests/reference/one_way_exact.py``, no code shared
with study). Time: seconds per point on one thread, warm-up (compilation) excluded,
minimum of repeats; cheap methods are timed on the point set tiled to a measurable
workload. Observed order: ``-slope`` of ``log(error)`` against ``log(work)``, with
work = steps per period for the fixed-step methods (their classical order) and
seconds per point for the adaptive ones (order per unit of work).

Writes ``results/bench.nc`` (dims ``method``, ``setting``, ``point``; variables
``error`` and ``seconds_per_point`` with units), ``results/bench.md``,
``figures/work-precision.png`` (and ``.pdf``) and the documentation's table,
``docs/speed/work-precision.md``. Timings are reported, never asserted.

``--coupling two-way``: the same report for the two-way coupled model, written to
``results/bench-two-way.nc``, ``.md``, ``figures/work-precision-two-way.png`` and
``docs/speed/work-precision-two-way.md``. Methods: ``exact`` (the exact orbit
solver, ``steady_state(..., coupling="two-way")``), ``integrator`` (adaptive, until
the orbit repeats) and ``solve_ivp`` (``baselines.solve_ivp_velocity(...,
coupling="two-way")``, whole periods until the orbit repeats). Points: the paper's
P, N, PN (both signs at 14.5 Hz), two points ``1e-3`` above a threshold and S, plus
one P point of the same structure at ``Q = 1000``. Reference: the 40-digit mpmath
orbit of ``tests/reference/two_way_exact.py`` (its cached points where they are the
same drive point, computed otherwise); the ``.md`` adds a per-point cross-check of the
exact solver and of the integrator at its tightest tolerance against it.

Usage: ``python benchmarks/bench_work_precision.py [--quick] [--coupling two-way]``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numba
import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parent.parent
# The repo root, for tests.reference: the independent oracles are not installed.
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from baselines import naive_velocity, solve_ivp_velocity  # noqa: E402
from docs_tables import output as quick_output  # noqa: E402
from docs_tables import use_quick, write_docs_table  # noqa: E402

import study  # noqa: E402
from study.engine.provenance import code_sha256, git_state, utc_now  # noqa: E402
from study.model import thresholds  # noqa: E402
from study.solvers.exact import steady_state  # noqa: E402
from study.solvers.integrator import IntegratorSettings, integrated_steady_state  # noqa: E402
from tests.reference.one_way_exact import exact_velocity  # noqa: E402

STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
HIGH_Q = STRUCTURE.replace(Q=1000.0)


def benchmark_points() -> list[tuple[str, float, float]]:
    """The fixed benchmark set: (label, f [Hz], a [m s^-2])."""
    a_plus_13, _ = thresholds(STRUCTURE, 13.0)
    _, a_minus_165 = thresholds(STRUCTURE, 16.5)
    return [
        ("P", 13.0, 8.5),
        ("N", 16.5, 8.5),
        ("PN", 14.6, 7.0),
        ("PN forward", 14.5, 6.0),
        ("PN backward", 14.5, 9.0),
        ("P near threshold", 13.0, float(a_plus_13) * (1 + 1e-3)),
        ("N near threshold", 16.5, float(a_minus_165) * (1 + 1e-3)),
        ("S", 13.0, 5.0),
    ]


def two_way_points() -> list[tuple[str, study.Structure, float, float]]:
    """The two-way set: (label, structure, f [Hz], a [m s^-2])."""
    a_plus_13, _ = thresholds(STRUCTURE, 13.0)
    _, a_minus_165 = thresholds(STRUCTURE, 16.5)
    return [
        ("P", STRUCTURE, 13.0, 8.5),
        ("N", STRUCTURE, 16.5, 8.5),
        ("PN", STRUCTURE, 14.6, 7.0),
        ("PN 14.5 Hz a=6", STRUCTURE, 14.5, 6.0),
        ("PN 14.5 Hz a=9", STRUCTURE, 14.5, 9.0),
        ("P near threshold", STRUCTURE, 13.0, float(a_plus_13) * (1 + 1e-3)),
        ("N near threshold", STRUCTURE, 16.5, float(a_minus_165) * (1 + 1e-3)),
        ("S", STRUCTURE, 13.0, 5.0),
        ("high-Q P (Q=1000)", HIGH_Q, 13.0, 8.0),
    ]


def two_way_condition(structure: study.Structure, f: float, a: float,
                      velocity: object | None = None, dps: int = 40) -> float:
    """Relative condition number ``|d ln v / d ln f| + |d ln v / d ln a|`` of the two-way
    velocity, by mpmath differences of the 40-digit orbit (NaN where ``v = 0``).

    float64 inputs are known only to ``eps``: ``eps * cond`` is the best relative error
    any float64 solver can promise at the point."""
    from mpmath import mp, mpf

    from tests.reference.two_way_exact import reference_orbit

    with mp.workdps(dps):
        v = (reference_orbit(structure, f, a, coupling="two-way", dps=dps).velocity
             if velocity is None else mpf(velocity))
        if not mp.isfinite(v) or v == 0:
            return math.nan
        h = mpf(10) ** -(dps * 3 // 8)
        v_f = reference_orbit(structure, mpf(f) * (1 + h), a, coupling="two-way",
                              dps=dps).velocity
        v_a = reference_orbit(structure, f, mpf(a) * (1 + h), coupling="two-way",
                              dps=dps).velocity
        return float((abs(v_f - v) + abs(v_a - v)) / (h * abs(v)))


def two_way_reference(points) -> tuple[np.ndarray, list[str], list[str], np.ndarray]:
    """40-digit two-way velocities, statuses, sources (cache or computed) and condition
    numbers (:func:`two_way_condition`)."""
    from tests.reference.two_way_exact import reference_orbit, reference_points

    cached = {(json.dumps(e["structure"].as_dict(), sort_keys=True), e["f"], e["a"]): e
              for e in reference_points()}
    velocity, status, source, condition = [], [], [], []
    for _, structure, f, a in points:
        key = (json.dumps(structure.as_dict(), sort_keys=True), f, a)
        if key in cached:
            text = cached[key]["velocity_text"]
            status.append(cached[key]["status"])
            source.append(f"cached ({cached[key]['name']})")
        else:
            orbit = reference_orbit(structure, f, a, coupling="two-way", dps=40)
            text = orbit.velocity
            status.append(orbit.status)
            source.append("computed, dps 40")
        velocity.append(float(text))
        condition.append(two_way_condition(structure, f, a, text))
    return np.array(velocity), status, source, np.array(condition)


def _groups(structures: list, tiles: int) -> list[tuple[study.Structure, np.ndarray | None]]:
    """``(structure, indices)`` of the points of each structure in the tiled set (indices
    None when one structure has them all)."""
    tiled = structures * tiles
    unique = list(dict.fromkeys(tiled))
    if len(unique) == 1:
        return [(unique[0], None)]
    return [(s, np.array([i for i, x in enumerate(tiled) if x == s])) for s in unique]


def _by_structure(solve: Callable) -> Callable:
    """``solve(structure, f, a, value)`` on every structure group of the points."""
    def grouped(groups, f, a, value):
        if len(groups) == 1 and groups[0][1] is None:
            return solve(groups[0][0], f, a, value)
        velocity = np.empty(f.size)
        status = np.empty(f.size, dtype=np.int8)
        for structure, index in groups:
            velocity[index], status[index] = solve(structure, f[index], a[index], value)
        return velocity, status
    return grouped


#: method -> (setting name, units, values, one-thread solve, tiling for timing)
def _methods(quick: bool, coupling: str = "one-way"
             ) -> dict[str, tuple[str, str, list[float], Callable, int]]:
    if coupling == "two-way":
        return _two_way_methods(quick)

    def exact(f, a, _):
        result = steady_state(STRUCTURE, f, a, parallel=False)
        return result.velocity, result.status

    def adaptive(f, a, tolerance):
        result = integrated_steady_state(STRUCTURE, f, a, parallel=False,
                                         settings=IntegratorSettings(tolerance=tolerance))
        return result.velocity, result.status

    def fixed(f, a, steps):
        result = integrated_steady_state(
            STRUCTURE, f, a, parallel=False,
            settings=IntegratorSettings(steps_per_period=int(steps), max_step=1.0),
        )
        return result.velocity, result.status

    def naive(f, a, steps):
        return naive_velocity(STRUCTURE, f, a, int(steps))

    def scipy_events(f, a, rtol):
        return solve_ivp_velocity(STRUCTURE, f, a, rtol)

    return {
        "exact": ("default", "1", [0.0], exact, 2000),
        "integrator": ("tolerance", "1", [1e-4, 1e-6, 1e-8, 1e-10, 1e-12], adaptive, 5),
        "integrator-fixed": ("steps_per_period", "1", [16, 32, 64, 128, 256], fixed, 5),
        "naive": ("steps_per_period", "1",
                  [64, 256, 1024, 4096] if quick else [64, 256, 1024, 4096, 16384], naive, 1),
        "solve_ivp": ("rtol", "1", [1e-4, 1e-6, 1e-8] if quick else [1e-4, 1e-6, 1e-8, 1e-10],
                      scipy_events, 1),
    }


def _two_way_methods(quick: bool) -> dict[str, tuple[str, str, list[float], Callable, int]]:
    def exact(structure, f, a, _):
        result = steady_state(structure, f, a, coupling="two-way", parallel=False)
        return result.velocity, result.status

    def adaptive(structure, f, a, tolerance):
        result = integrated_steady_state(structure, f, a, coupling="two-way", parallel=False,
                                         settings=IntegratorSettings(tolerance=tolerance))
        return result.velocity, result.status

    def scipy_events(structure, f, a, rtol):
        return solve_ivp_velocity(structure, f, a, rtol, coupling="two-way")

    return {
        "exact": ("default", "1", [0.0], _by_structure(exact), 2000),
        "integrator": ("tolerance", "1", [1e-6, 1e-8, 1e-10, 1e-12], _by_structure(adaptive),
                       1),
        "solve_ivp": ("rtol", "1", [1e-6, 1e-8] if quick else [1e-6, 1e-8, 1e-10],
                      _by_structure(scipy_events), 1),
    }


def _timed(call: Callable[[], object], repeats: int) -> tuple[float, float]:
    """Minimum over ``repeats`` of the wall and of the process (CPU) time [s]."""
    best, best_cpu = math.inf, math.inf
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        call()
        best = min(best, time.perf_counter() - start)
        best_cpu = min(best_cpu, time.process_time() - start_cpu)
    return best, best_cpu


def _load() -> str:
    try:
        one, five, fifteen = os.getloadavg()
    except OSError:
        return "unknown"
    return f"{one:.2f} {five:.2f} {fifteen:.2f}"


def _machine() -> str:
    cpu = platform.machine()
    try:
        with open("/proc/cpuinfo") as info:
            cpu = next(line.split(":", 1)[1].strip() for line in info
                       if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return (f"{cpu}, {os.cpu_count()} cores (timed on one thread), numba {numba.__version__}, "
            f"numpy {np.__version__}, Python {platform.python_version()}")


def _order(work: np.ndarray, error: np.ndarray) -> float:
    """``-slope`` of log(error) against log(work), over the settings with error above
    the rounding floor (1e-14 m/s here)."""
    keep = np.isfinite(error) & (error > 1e-14) & np.isfinite(work)
    if np.count_nonzero(keep) < 2:
        return math.nan
    slope = np.polyfit(np.log(work[keep]), np.log(error[keep]), 1)[0]
    return float(-slope)


def run(quick: bool, coupling: str = "one-way") -> xr.Dataset:
    load_before = _load()
    print(f"machine: {_machine()}; load average {load_before}")
    if coupling == "two-way":
        points = two_way_points()
        structures = [p[1] for p in points]
        labels = [p[0] for p in points]
        f = np.array([p[2] for p in points])
        a = np.array([p[3] for p in points])
        print("reference: 40-digit mpmath two-way orbit ...", flush=True)
        reference, reference_status, reference_source, condition = two_way_reference(points)
    else:
        points = benchmark_points()
        structures = [STRUCTURE] * len(points)
        labels = [p[0] for p in points]
        f = np.array([p[1] for p in points])
        a = np.array([p[2] for p in points])
        print("reference: 40-digit mpmath exact solution ...", flush=True)
        reference = np.array([
            float(exact_velocity(STRUCTURE.f0, STRUCTURE.Q, STRUCTURE.alpha, STRUCTURE.M,
                                 STRUCTURE.cs, fi, ai, ck=STRUCTURE.ck, g=STRUCTURE.g)[0])
            for fi, ai in zip(f, a, strict=True)
        ])
        reference_status = reference_source = condition = None
    methods = _methods(quick, coupling)
    width = max(len(spec[2]) for spec in methods.values())
    n_m, n_p = len(methods), len(points)
    error = np.full((n_m, width, n_p), np.nan)
    velocities = np.full((n_m, width, n_p), np.nan)
    statuses = np.full((n_m, width, n_p), -1, dtype=np.int8)
    status_ok = np.zeros((n_m, width), dtype=np.int8)
    seconds = np.full((n_m, width), np.nan)
    cpu_seconds = np.full((n_m, width), np.nan)
    setting_value = np.full((n_m, width), np.nan)
    setting_name = []
    if coupling == "two-way":
        exact_status = np.concatenate([
            steady_state(s, f[i:i + 1], a[i:i + 1], coupling="two-way").status
            for i, s in enumerate(structures)
        ])
    else:
        exact_status = steady_state(STRUCTURE, f, a).status
    for i, (name, (setting, _, values, solve, tiles)) in enumerate(methods.items()):
        setting_name.append(setting)
        if coupling == "two-way":
            groups = _groups(structures, 1)
            tiled_groups = _groups(structures, tiles)
            run_one = solve
            solve(_groups(structures[:1], 1), f[:1], a[:1], values[0])  # warm-up
        else:
            groups = tiled_groups = None

            def run_one(_, x, y, v, s=solve):
                return s(x, y, v)

            solve(f[:1], a[:1], values[0])  # warm-up: compilation or cache load
        for j, value in enumerate(values):
            velocity, status = run_one(groups, f, a, value)
            velocities[i, j] = velocity
            statuses[i, j] = status
            error[i, j] = np.where(np.isnan(velocity), np.inf, np.abs(velocity - reference))
            status_ok[i, j] = int(np.array_equal(np.asarray(status), exact_status))
            f_t, a_t = np.tile(f, tiles), np.tile(a, tiles)
            repeats = 3 if tiles > 1 else (2 if name == "integrator" else 1)
            elapsed, elapsed_cpu = _timed(
                lambda s=run_one, g=tiled_groups, x=f_t, y=a_t, v=value: s(g, x, y, v),
                repeats)
            seconds[i, j] = elapsed / f_t.size
            cpu_seconds[i, j] = elapsed_cpu / f_t.size
            setting_value[i, j] = value
            print(f"  {name:17s} {setting}={value:<8g} max error {np.max(error[i, j]):9.2e} "
                  f"m/s  {seconds[i, j]:9.2e} s/point ({cpu_seconds[i, j]:9.2e} CPU)  "
                  f"statuses {'agree' if status_ok[i, j] else 'DIFFER'}", flush=True)
    worst = np.max(error, axis=2)
    orders = []
    for i, name in enumerate(methods):
        if name in ("integrator-fixed", "naive"):
            orders.append(_order(setting_value[i], worst[i]))
        elif name == "exact":
            orders.append(math.nan)
        else:
            orders.append(_order(seconds[i], worst[i]))
    git = git_state()
    reference_name = ("40-digit mpmath two-way orbit" if coupling == "two-way"
                      else "40-digit mpmath exact solution")
    extra = {}
    if coupling == "two-way":
        extra = {
            "point_velocity": (("method", "setting", "point"), velocities, {
                "units": "m s-1", "long_name": "mean velocity each method gave",
            }),
            "point_status": (("method", "setting", "point"), statuses, {
                "units": "1", "long_name": "study.Status code each method gave",
            }),
            "exact_status": (("point",), np.asarray(exact_status, dtype=np.int8), {
                "units": "1", "long_name": "study.Status code of the exact solver",
            }),
            "reference_status": (("point",), np.array(reference_status), {
                "long_name": "status of the mpmath reference orbit",
            }),
            "reference_condition": (("point",), condition, {
                "units": "1",
                "long_name": "|d ln v/d ln f| + |d ln v/d ln a| of the reference velocity "
                             "(mpmath differences); NaN where v = 0",
            }),
            "reference_source": (("point",), np.array(reference_source), {
                "long_name": "cached in tests/reference/data/two_way_reference.json, or computed",
            }),
            "point_structure": (("point",), np.array(
                [json.dumps(s.as_dict()) for s in structures]), {
                "long_name": "structure parameters of each point (JSON)",
            }),
        }
    dataset = xr.Dataset(
        {
            "error": (("method", "setting"), worst, {
                "units": "m s-1",
                "long_name": f"largest |v - v_ref| over the benchmark points (v_ref: "
                             f"{reference_name}); inf where a method gave no velocity",
            }),
            "point_error": (("method", "setting", "point"), error, {
                "units": "m s-1", "long_name": "|v - v_ref| at each benchmark point",
            }),
            "seconds_per_point": (("method", "setting"), seconds, {
                "units": "s",
                "long_name": "wall time per point on one thread, warm-up excluded, minimum "
                             "of repeats",
            }),
            "cpu_seconds_per_point": (("method", "setting"), cpu_seconds, {
                "units": "s",
                "long_name": "process (CPU) time per point, warm-up excluded, minimum of "
                             "repeats",
            }),
            "setting_value": (("method", "setting"), setting_value, {
                "units": "1", "long_name": "value of the method's setting (see setting_name)",
            }),
            "statuses_agree": (("method", "setting"), status_ok, {
                "units": "1", "long_name": "1 where every point's status equals the exact "
                                           "solver's",
            }),
            "observed_order": (("method",), np.array(orders), {
                "units": "1",
                "long_name": "-slope of log(error) against log(steps per period) for "
                             "fixed-step methods, against log(seconds per point) for "
                             "adaptive ones",
            }),
            "reference_velocity": (("point",), reference, {
                "units": "m s-1", "long_name": f"exact mean velocity ({reference_name})",
            }),
            "f": (("point",), f, {"units": "Hz", "long_name": "drive frequency"}),
            "a": (("point",), a, {"units": "m s-2", "long_name": "drive acceleration amplitude"}),
            **extra,
        },
        coords={
            "method": list(methods),
            "setting": np.arange(width),
            "point": labels,
            "setting_name": (("method",), setting_name),
        },
        attrs={
            "title": "Work-precision benchmark of study's velocity solvers",
            "machine": _machine(),
            "structure": json.dumps(STRUCTURE.as_dict()),
            "date_created": utc_now(),
            "study_code_sha256": code_sha256(),
            "git_commit": str(git["git_commit"]),
            "git_dirty": str(git["git_dirty"]).lower(),
            "quick": int(quick),
            "coupling": coupling,
            "load_average": f"{load_before} (start), {_load()} (end); 1, 5, 15 min",
        },
    )
    return dataset


def write_atomic(dataset: xr.Dataset, path: Path) -> None:
    """Write, reopen and check, then rename: never a half-written benchmark file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(handle)
    try:
        dataset.to_netcdf(tmp)
        with xr.open_dataset(tmp) as check:
            for name in ("error", "seconds_per_point"):
                if check[name].dims[:2] != ("method", "setting") or not check[name].attrs.get(
                    "units"
                ):
                    raise RuntimeError(f"{tmp}: {name} lacks its dims or units")
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def table(dataset: xr.Dataset, compact: bool = False) -> str:
    """The Markdown table (two-way: with the CPU time as well; ``compact``: the
    documentation's, without the CPU time and, two-way, without the observed order)."""
    two_way = dataset.attrs.get("coupling") == "two-way"
    if two_way and compact:
        lines = [
            "| method | setting | max error [m/s] | time per point [s] | statuses |",
            "|---|---|---|---|---|",
        ]
    elif two_way:
        lines = [
            "| method | setting | max error [m/s] | time per point [s] | CPU per point [s] "
            "| statuses | observed order |",
            "|---|---|---|---|---|---|---|",
        ]
    else:
        lines = [
            "| method | setting | max error [m/s] | time per point [s] | statuses | "
            "observed order |",
            "|---|---|---|---|---|---|",
        ]
    for i, method in enumerate(dataset["method"].values.tolist()):
        row = dataset.isel(method=i)
        order = float(row["observed_order"])
        order_text = "-" if not math.isfinite(order) else f"{order:.1f}"
        for j in range(row.sizes["setting"]):
            value = float(row["setting_value"][j])
            if not math.isfinite(value):
                continue
            setting = "-" if method == "exact" else f"{row['setting_name'].item()} = {value:g}"
            cpu = (f"{float(row['cpu_seconds_per_point'][j]):.1e} | "
                   if two_way and not compact else "")
            order_cell = "" if two_way and compact else f" {order_text if j == 0 else ''} |"
            lines.append(
                f"| {method} | {setting} | {float(row['error'][j]):.1e} | "
                f"{float(row['seconds_per_point'][j]):.1e} | {cpu}"
                f"{'agree' if int(row['statuses_agree'][j]) else 'differ'} |{order_cell}"
            )
    return "\n".join(lines)


_STATUS_NAMES = {int(s): s.name for s in study.Status}


def cross_check(dataset: xr.Dataset) -> str:
    """Two-way: per point, the mpmath reference against the exact solver and against the
    integrator and solve_ivp at their tightest settings (two independent references)."""
    methods = dataset["method"].values.tolist()

    def tightest(method: str) -> tuple[int, int, float]:
        i = methods.index(method)
        values = dataset["setting_value"].values[i]
        j = int(np.nanargmin(values))
        return i, j, float(values[j])

    ie, je, _ = tightest("exact")
    ii, ji, tol = tightest("integrator")
    iv, jv, rtol = tightest("solve_ivp")
    velocity = dataset["point_velocity"].values
    status = dataset["point_status"].values
    lines = [
        f"| point | f [Hz] | a [m/s^2] | reference v [m/s] | reference status | "
        f"cond | exact: abs error | exact: rel error | rel error / (eps cond) | "
        f"integrator {tol:g}: abs error | "
        f"exact - integrator | solve_ivp {rtol:g}: abs error | statuses (exact, integrator, "
        f"solve_ivp) | reference from |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    eps = np.finfo(float).eps
    for k, label in enumerate(dataset["point"].values.tolist()):
        ref = float(dataset["reference_velocity"][k])
        v_e, v_i, v_v = velocity[ie, je, k], velocity[ii, ji, k], velocity[iv, jv, k]
        rel = abs(v_e - ref) / abs(ref) if ref != 0.0 else math.nan
        cond = float(dataset["reference_condition"][k])
        scaled = rel / (eps * max(1.0, cond))
        names = "/".join(_STATUS_NAMES.get(int(status[m, n, k]), "?").lower()
                         for m, n in ((ie, je), (ii, ji), (iv, jv)))
        lines.append(
            f"| {label} | {float(dataset['f'][k]):g} | {float(dataset['a'][k]):.6g} | "
            f"{ref:.10e} | {dataset['reference_status'].values[k]} | "
            f"{'-' if math.isnan(cond) else f'{cond:.2g}'} | "
            f"{abs(v_e - ref):.1e} | {'-' if math.isnan(rel) else f'{rel:.1e}'} | "
            f"{'-' if math.isnan(scaled) else f'{scaled:.2g}'} | "
            f"{abs(v_i - ref):.1e} | {abs(v_e - v_i):.1e} | {abs(v_v - ref):.1e} | {names} | "
            f"{dataset['reference_source'].values[k]} |"
        )
    worst_integrator = float(np.nanmax(np.abs(velocity[ii, ji] -
                                              dataset["reference_velocity"].values)))
    worst_exact = float(np.nanmax(np.abs(velocity[ie, je] -
                                         dataset["reference_velocity"].values)))
    lines.append("")
    lines.append(
        f"Largest |v - v_mpmath|: exact {worst_exact:.1e} m/s, integrator at tolerance "
        f"{tol:g} {worst_integrator:.1e} m/s (the integrator shares no orbit code with the "
        "exact solver, the mpmath reference none with either). cond: relative condition "
        "number |d ln v/d ln f| + |d ln v/d ln a| (mpmath differences); eps cond is the "
        "relative error float64 inputs alone allow."
    )
    return "\n".join(lines)


def figure(dataset: xr.Dataset, stem: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.2), constrained_layout=True)
    markers = {"exact": "*", "integrator": "o", "integrator-fixed": "s", "naive": "v",
               "solve_ivp": "^"}
    floor = 1e-17
    for i, method in enumerate(dataset["method"].values.tolist()):
        row = dataset.isel(method=i)
        keep = np.isfinite(row["setting_value"].values)
        err = np.maximum(row["error"].values[keep], floor)
        secs = row["seconds_per_point"].values[keep]
        order = float(row["observed_order"])
        if not math.isfinite(order):
            label = str(method)
        elif method in ("integrator-fixed", "naive"):
            label = f"{method} (order {order:.1f} in the step)"
        else:
            label = f"{method} (error ~ time^-{order:.1f})"
        ax.loglog(secs, err, marker=markers.get(str(method), "o"), ms=8 if method == "exact"
                  else 5, label=label)
    ax.set_xlabel("time per point, one thread [s]")
    ax.set_ylabel("largest velocity error over the benchmark points [m s$^{-1}$]")
    if dataset.attrs.get("coupling") == "two-way":
        ax.set_title("Work-precision, two-way coupling: velocity of the steady orbit\n"
                     f"{dataset.sizes['point']} points incl. PN, near-threshold and Q = 1000; "
                     "reference: 40-digit mpmath orbit", fontsize=9)
    else:
        ax.set_title("Work-precision: velocity of the steady stick-slip orbit\n"
                     f"{dataset.sizes['point']} points incl. PN and near-threshold; "
                     "reference: 40-digit exact solution", fontsize=9)
    ax.axhline(floor, color="0.7", lw=0.6)
    ax.grid(True, which="major", color="0.9")
    ax.legend(fontsize=8)
    ax.text(0.99, 0.99, dataset.attrs["machine"], transform=ax.transAxes, fontsize=6,
            color="0.4", ha="right", va="top")
    stem.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(stem.with_suffix(".png"), dpi=150)
    fig.savefig(stem.with_suffix(".pdf"))
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="fewer, cheaper settings; the table, report and figure go to "
                        "results/bench-quick/, never docs/speed/")
    parser.add_argument("--coupling", choices=("one-way", "two-way"), default="one-way")
    parser.add_argument("--output", type=Path, default=None,
                        help="default results/bench.nc (two-way: results/bench-two-way.nc)")
    parser.add_argument("--figure", type=Path, default=None,
                        help="default figures/work-precision (two-way: "
                             "figures/work-precision-two-way)")
    args = parser.parse_args(argv)
    suffix = "-two-way" if args.coupling == "two-way" else ""
    use_quick(args.quick)
    output = args.output or quick_output(ROOT / "results" / f"bench{suffix}.nc")
    stem = args.figure or quick_output(ROOT / "figures" / f"work-precision{suffix}")
    dataset = run(args.quick, args.coupling)
    write_atomic(dataset, output)
    markdown = table(dataset)
    if args.coupling == "two-way":
        text = (
            "# Work-precision, two-way coupling\n\n"
            f"Machine: {dataset.attrs['machine']}; load average {dataset.attrs['load_average']}"
            f" (shared machine). Commit {dataset.attrs['git_commit']}"
            f"{' (dirty)' if dataset.attrs['git_dirty'] == 'true' else ''}, "
            f"{dataset.attrs['date_created']}.\n\n"
            "Error: largest |v - v_ref| over the points, v_ref the 40-digit mpmath two-way "
            "orbit (tests/reference/two_way_exact.py). Time: one thread, warm-up excluded, "
            "minimum of repeats (exact: the point set tiled 2000 times); wall and process "
            "time.\n\n"
            f"{markdown}\n\n## Per point: the references against each other\n\n"
            f"{cross_check(dataset)}\n"
        )
    else:
        text = f"Machine: {dataset.attrs['machine']}\n\n{markdown}\n"
    output.with_suffix(".md").write_text(text)
    write_docs_table(f"work-precision{suffix}", "bench_work_precision.py",
                     f"{dataset.attrs['machine']}; load average "
                     f"{dataset.attrs['load_average']}", table(dataset, compact=True))
    figure(dataset, stem)
    print(text)
    print(f"wrote {output}, {output.with_suffix('.md')}, {stem.with_suffix('.png')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
