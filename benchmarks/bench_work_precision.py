"""Work-precision benchmark: error against time per point for every way to get a velocity.

Methods, each at several settings, on a fixed set of drive points (the paper's
structure; P, N, three PN points including both signs at 14.5 Hz, and two points just
above a threshold, where slips are short and easy to miss):

* ``exact``: the closed-form event-driven steady-state solver (:mod:`study.solver`);
* ``integrator``: study's Dormand-Prince 5(4) integrator with events on the dense
  output, adaptive, at several tolerances (:mod:`study.transient`);
* ``integrator-fixed``: the same integrator with a fixed step (steps per period);
* ``naive``: fixed-step RK4 with contact switches by step-end sign tests only
  (``benchmarks/baselines.py``);
* ``solve_ivp``: scipy's RK45 with terminal events, restarted at each event, as a
  careful user would write it (``benchmarks/baselines.py``).

Error: largest ``|v - v_ref|`` over the points, against a 40-digit mpmath
implementation of the exact solution (``tests/exact_reference.py``, no code shared
with study). Time: seconds per point on one thread, warm-up (compilation) excluded,
minimum of repeats; cheap methods are timed on the point set tiled to a measurable
workload. Observed order: ``-slope`` of ``log(error)`` against ``log(work)``, with
work = steps per period for the fixed-step methods (their classical order) and
seconds per point for the adaptive ones (order per unit of work).

Writes ``results/bench.nc`` (dims ``method``, ``setting``, ``point``; variables
``error`` and ``seconds_per_point`` with units), ``results/bench.md`` (the README
table) and ``figures/work-precision.png`` (and ``.pdf``). Timings are reported, never
asserted.

Usage: ``python benchmarks/bench_work_precision.py [--quick]``
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
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from baselines import naive_velocity, solve_ivp_velocity  # noqa: E402
from exact_reference import exact_velocity  # noqa: E402

import study  # noqa: E402
from study.physics import thresholds  # noqa: E402
from study.provenance import code_sha256, git_state, utc_now  # noqa: E402
from study.solver import steady_state  # noqa: E402
from study.transient import IntegratorSettings, integrated_steady_state  # noqa: E402

STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)


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


#: method -> (setting name, units, values, one-thread solve, tiling for timing)
def _methods(quick: bool) -> dict[str, tuple[str, str, list[float], Callable, int]]:
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


def _timed(call: Callable[[], object], repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - start)
    return best


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


def run(quick: bool) -> xr.Dataset:
    points = benchmark_points()
    labels = [p[0] for p in points]
    f = np.array([p[1] for p in points])
    a = np.array([p[2] for p in points])
    print(f"machine: {_machine()}")
    print("reference: 40-digit mpmath exact solution ...", flush=True)
    reference = np.array([
        float(exact_velocity(STRUCTURE.f0, STRUCTURE.Q, STRUCTURE.alpha, STRUCTURE.M,
                             STRUCTURE.cs, fi, ai, ck=STRUCTURE.ck, g=STRUCTURE.g)[0])
        for fi, ai in zip(f, a, strict=True)
    ])
    methods = _methods(quick)
    width = max(len(spec[2]) for spec in methods.values())
    n_m, n_p = len(methods), len(points)
    error = np.full((n_m, width, n_p), np.nan)
    status_ok = np.zeros((n_m, width), dtype=np.int8)
    seconds = np.full((n_m, width), np.nan)
    setting_value = np.full((n_m, width), np.nan)
    setting_name = []
    exact_status = steady_state(STRUCTURE, f, a).status
    for i, (name, (setting, _, values, solve, tiles)) in enumerate(methods.items()):
        setting_name.append(setting)
        solve(f[:1], a[:1], values[0])  # warm-up: compilation or cache load
        for j, value in enumerate(values):
            velocity, status = solve(f, a, value)
            error[i, j] = np.where(np.isnan(velocity), np.inf, np.abs(velocity - reference))
            status_ok[i, j] = int(np.array_equal(np.asarray(status), exact_status))
            f_t, a_t = np.tile(f, tiles), np.tile(a, tiles)
            elapsed = _timed(lambda s=solve, x=f_t, y=a_t, v=value: s(x, y, v),
                             3 if tiles > 1 else 1)
            seconds[i, j] = elapsed / f_t.size
            setting_value[i, j] = value
            print(f"  {name:17s} {setting}={value:<8g} max error {np.max(error[i, j]):9.2e} "
                  f"m/s  {seconds[i, j]:9.2e} s/point  statuses "
                  f"{'agree' if status_ok[i, j] else 'DIFFER'}", flush=True)
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
    dataset = xr.Dataset(
        {
            "error": (("method", "setting"), worst, {
                "units": "m s-1",
                "long_name": "largest |v - v_ref| over the benchmark points (v_ref: 40-digit "
                             "mpmath exact solution); inf where a method gave no velocity",
            }),
            "point_error": (("method", "setting", "point"), error, {
                "units": "m s-1", "long_name": "|v - v_ref| at each benchmark point",
            }),
            "seconds_per_point": (("method", "setting"), seconds, {
                "units": "s",
                "long_name": "wall time per point on one thread, warm-up excluded, minimum "
                             "of repeats",
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
                "units": "m s-1", "long_name": "exact mean velocity (40-digit mpmath)",
            }),
            "f": (("point",), f, {"units": "Hz", "long_name": "drive frequency"}),
            "a": (("point",), a, {"units": "m s-2", "long_name": "drive acceleration amplitude"}),
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


def table(dataset: xr.Dataset) -> str:
    """The README's Markdown table."""
    lines = [
        "| method | setting | max error [m/s] | time per point [s] | statuses | observed order |",
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
            lines.append(
                f"| {method} | {setting} | {float(row['error'][j]):.1e} | "
                f"{float(row['seconds_per_point'][j]):.1e} | "
                f"{'agree' if int(row['statuses_agree'][j]) else 'differ'} | "
                f"{order_text if j == 0 else ''} |"
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
    parser.add_argument("--quick", action="store_true", help="fewer, cheaper settings")
    parser.add_argument("--output", type=Path, default=ROOT / "results" / "bench.nc")
    parser.add_argument("--figure", type=Path, default=ROOT / "figures" / "work-precision")
    args = parser.parse_args(argv)
    dataset = run(args.quick)
    write_atomic(dataset, args.output)
    markdown = table(dataset)
    args.output.with_suffix(".md").write_text(
        f"Machine: {dataset.attrs['machine']}\n\n{markdown}\n"
    )
    figure(dataset, args.figure)
    print(markdown)
    print(f"wrote {args.output}, {args.output.with_suffix('.md')}, "
          f"{args.figure.with_suffix('.png')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
