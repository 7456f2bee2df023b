"""Benchmark: `study run` against the bare solver call, from 1e6 to 1e8 points.

Velocity studies of the paper's structure (f0 14.44 Hz, Q 17.5, alpha 64 deg,
M 0.08, cs 0.25) on square (f, a) grids, f 10-20 Hz and a 0-12 m s^-2. For each
size, every measurement runs in a fresh Python process (so its peak RSS is its
own) that first imports what it needs and loads the compiled kernels, then times:

a. ``bare``: ``study.steady_velocity(structure, f[:, None], a[None, :])`` on the same
   points in one call (up to 3e7 points: its temporaries take about 150 bytes per
   point), and ``blocks``: the same in blocks of whole f rows of about
   ``--block-points`` points (default 1e6), each block's values copied into one
   velocity/status pair of the whole grid. A whole-grid call streams its
   temporaries through memory and is slower than blocks from 1e7 points on; the
   blocked call is the stronger reference;
b. ``run``: ``run_study(..., force=True)`` with an empty cache folder: everything is
   computed, written into the netCDF file and kept in the cache, and the file is
   sealed (validated) before the atomic rename;
c. ``rerun``: the unchanged study again (reads the file's metadata only);
d. ``reuse``: the study again after deleting the result but keeping the cache
   (every value is read back from the cache, nothing is computed).

The measurements alternate ``--repeats`` times, so that each repeat sees the
machine in one state; each timing is the minimum (other work on the machine only ever
adds time), with the CPU time of the same process beside it, and the peak RSS is the
largest seen (``ru_maxrss`` of the child). Timings are reported, never asserted. The
table goes to ``results/bench-study.md`` and to the documentation's
``docs/speed/study-overhead.md``.

Usage: ``python benchmarks/bench_study_overhead.py [--sizes 1e6 1e7 1e8] [--repeats 2]
[--repeats-large 1]``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from docs_tables import output, quick_option, use_quick, write_docs_table

F_RANGE = (10.0, 20.0)  # Hz
A_RANGE = (0.0, 12.0)  # m s-2
STRUCTURE = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "M": 0.08, "cs": 0.25}

SPEC = """\
[study]
name = "bench-map"
observables = ["velocity"]

[structure]
f0 = {f0}
Q = {Q}
alpha = {alpha}
M = {M}
cs = {cs}

[sweep]
f = {{ start = {f_lo}, stop = {f_hi}, num = {n} }}
a = {{ start = {a_lo}, stop = {a_hi}, num = {n} }}
"""

KINDS = ("bare", "blocks", "run", "rerun", "reuse")
#: The whole-grid call is measured up to this many points (its temporaries take about
#: 150 bytes per point: 15 GB at 1e8).
WHOLE_MAX = 3e7


# ---------------------------------------------------------------------------
# Child process: one measurement


def _warm() -> None:
    """Import what a run uses (also the libraries it imports on first use: jsonschema
    for the spec, dask through xarray when the file is validated) and load both
    compiled kernels (serial and parallel), so that timings measure the work, not
    imports or the first use of numba."""
    import dask  # noqa: F401
    import jsonschema  # noqa: F401
    import netCDF4  # noqa: F401
    import xarray  # noqa: F401

    import study
    import study.engine.runner
    from study.solvers.exact import PARALLEL_THRESHOLD, steady_state

    structure = study.Structure(**STRUCTURE)
    f = np.linspace(*F_RANGE, 64)[:, None]
    a = np.linspace(*A_RANGE, 64)[None, :]
    assert f.size * a.size >= PARALLEL_THRESHOLD
    steady_state(structure, f, a, parallel=True)
    steady_state(structure, f[:4], a, parallel=False)


def _bare(n: int, block_points: int | None) -> dict[str, float]:
    """One ``steady_velocity`` call on the whole grid (``block_points`` None), or one
    per block of whole f rows of about ``block_points`` points, each block's values
    copied into one velocity and status array of the whole grid."""
    import study

    structure = study.Structure(**STRUCTURE)
    f = np.linspace(*F_RANGE, n)
    a = np.linspace(*A_RANGE, n)
    cpu = time.process_time()
    start = time.perf_counter()
    if block_points is None:
        velocity, status = study.steady_velocity(structure, f[:, None], a[None, :])
    else:
        velocity = np.empty((n, n))
        status = np.empty((n, n), dtype=np.int8)
        rows = max(1, block_points // n)
        for lo in range(0, n, rows):
            hi = min(n, lo + rows)
            velocity[lo:hi], status[lo:hi] = study.steady_velocity(
                structure, f[lo:hi, None], a[None, :])
    seconds = time.perf_counter() - start
    return {"seconds": seconds, "cpu": time.process_time() - cpu}


def _run(spec: Path, output: Path, cache: Path, force: bool) -> dict[str, float]:
    from study.engine.runner import run_study

    # Peak RSS when the last computed chunk is written: before the file is sealed.
    computing = {"max_rss": 0}

    def written(_: int) -> None:
        computing["max_rss"] = _max_rss()

    cpu = time.process_time()
    start = time.perf_counter()
    report = run_study(spec, output, progress=False, force=force, cache=cache,
                       on_chunk=written)
    seconds = time.perf_counter() - start
    return {"seconds": seconds, "cpu": time.process_time() - cpu,
            "max_rss_computing": computing["max_rss"],
            "up_to_date": report.up_to_date, "chunks": report.chunks,
            "points_computed": report.points_computed, "points_reused": report.points_reused}


def _max_rss() -> int:
    """Peak resident memory of this process so far [bytes] (Linux: ru_maxrss in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def child(kind: str, n: int, folder: Path, block_points: int) -> None:
    """Run one measurement and print it as one JSON line."""
    _warm()
    spec, output, cache = folder / "bench-map.toml", folder / "bench-map.nc", folder / "cache"
    if kind in ("bare", "blocks"):
        result = _bare(n, block_points if kind == "blocks" else None)
    else:
        result = _run(spec, output, cache, force=kind == "run")
    result["max_rss"] = _max_rss()
    print("RESULT " + json.dumps(result))


# ---------------------------------------------------------------------------
# Parent process: the table


def _measure(kind: str, n: int, folder: Path, block_points: int) -> dict[str, float]:
    command = [sys.executable, __file__, "--child", kind, "--side", str(n),
               "--folder", str(folder), "--block-points", str(block_points)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{kind} at {n} x {n} failed:\n{done.stdout}\n{done.stderr}")
    line = next(x for x in done.stdout.splitlines() if x.startswith("RESULT "))
    return json.loads(line.removeprefix("RESULT "))


def _folder_size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def _keep_best(best: dict[str, dict], kind: str, result: dict[str, float], n: int) -> None:
    """Minimum time (and CPU time) and largest peak RSS seen for ``kind``."""
    print(f"  {kind:>5} {n} x {n}: {result['seconds']:.3f} s, {result['cpu']:.3f} s CPU, "
          f"peak RSS {result['max_rss'] / 2**20:.0f} MiB", flush=True)
    if kind not in best:
        best[kind] = dict(result)
        return
    for key, pick in (("seconds", min), ("cpu", min), ("max_rss", max),
                      ("max_rss_computing", max)):
        if key in result:
            best[kind][key] = pick(best[kind][key], result[key])


def machine() -> str:
    """Cores, CPU model and the versions that set the speed."""
    import netCDF4
    import numba

    model = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return (f"{os.cpu_count()} cores, {model}, {memory:.0f} GiB; Python "
            f"{platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}, "
            f"netCDF4 {netCDF4.__version__} (HDF5 {netCDF4.__hdf5libversion__})")


def measure_size(points: float, repeats: int, block_points: int, root: Path) -> dict:
    n = round(math.sqrt(points))
    folder = Path(tempfile.mkdtemp(prefix=f"bench-{n}-", dir=root))
    try:
        spec, output, cache = (folder / "bench-map.toml", folder / "bench-map.nc",
                               folder / "cache")
        spec.write_text(SPEC.format(n=n, f_lo=F_RANGE[0], f_hi=F_RANGE[1], a_lo=A_RANGE[0],
                                    a_hi=A_RANGE[1], **STRUCTURE))

        row: dict = {"side": n, "points": n * n}
        best: dict[str, dict] = {}
        # The four measurements alternate, so that each repeat sees the machine in the
        # same state for all of them (other work on the machine only ever adds time).
        for _ in range(repeats):
            # Up to one block, the blocked call is the whole-grid call: measured once.
            if block_points < n * n <= WHOLE_MAX:
                _keep_best(best, "bare", _measure("bare", n, folder, block_points), n)
            _keep_best(best, "blocks", _measure("blocks", n, folder, block_points), n)
            output.unlink(missing_ok=True)
            shutil.rmtree(cache, ignore_errors=True)
            _keep_best(best, "run", _measure("run", n, folder, block_points), n)
            row["file_size"] = output.stat().st_size
            row["cache_size"] = _folder_size(cache)
            _keep_best(best, "rerun", _measure("rerun", n, folder, block_points), n)
            output.unlink()
            _keep_best(best, "reuse", _measure("reuse", n, folder, block_points), n)
        row.update(best)
        if n * n <= block_points:
            row["bare"] = row["blocks"]
        assert row["rerun"]["up_to_date"] and not row["reuse"]["points_computed"]
        return row
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def table(rows: list[dict], about: str) -> str:
    """The markdown table of the measured sizes."""
    mib = 2**20
    lines = [
        about, "",
        "| points | bare call, whole grid / in row blocks | `study run` | ratio to whole "
        "/ blocks | CPU whole / blocks / run | rerun, unchanged | rerun, cache only "
        "| peak RSS whole / blocks / run (before sealing) / rerun / cache only "
        "| file | cache |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        bare, blocks, run, rerun, reuse = (row.get(k) for k in KINDS)

        def whole(key: str, form: str, scale: float = 1.0, bare: dict | None = bare) -> str:
            return "-" if bare is None else format(bare[key] / scale, form)

        lines.append(
            f"| {row['side']} x {row['side']} = {row['points']:.3g} "
            f"| {whole('seconds', '.2f')} / {blocks['seconds']:.2f} s "
            f"| {run['seconds']:.2f} s "
            f"| {'-' if bare is None else format(run['seconds'] / bare['seconds'], '.2f')} / "
            f"**{run['seconds'] / blocks['seconds']:.2f}x** "
            f"| {whole('cpu', '.2f')} / {blocks['cpu']:.2f} / {run['cpu']:.2f} s "
            f"| {rerun['seconds']:.3f} s | {reuse['seconds']:.2f} s "
            f"| {whole('max_rss', '.0f', mib)} / {blocks['max_rss'] / mib:.0f} / "
            f"{run['max_rss'] / mib:.0f} ({run['max_rss_computing'] / mib:.0f}) / "
            f"{rerun['max_rss'] / mib:.0f} / {reuse['max_rss'] / mib:.0f} MiB "
            f"| {row['file_size'] / 1e6:.1f} MB | {row['cache_size'] / 1e6:.1f} MB |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", type=float, default=[1e6, 1e7, 1e8],
                        help="grid points per study (square grids)")
    parser.add_argument("--repeats", type=int, default=2,
                        help="processes per measurement up to 3e7 points")
    parser.add_argument("--repeats-large", type=int, default=1,
                        help="processes per measurement above 3e7 points")
    parser.add_argument("--block-points", type=int, default=1_000_000,
                        help="points per block of the blocked bare call")
    parser.add_argument("--output", type=Path, default=Path("results/bench-study.md"))
    parser.add_argument("--scratch", type=Path, default=None,
                        help="folder for the temporary studies (default: system temp)")
    quick_option(parser)
    parser.add_argument("--child", choices=KINDS, help=argparse.SUPPRESS)
    parser.add_argument("--side", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--folder", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.side, args.folder, args.block_points)
        return
    if use_quick(args.quick):  # one study of 1e6 points, one process per measurement
        args.sizes, args.repeats, args.repeats_large = [1e6], 1, 1
    args.output = output(args.output)
    rows = []
    load = os.getloadavg()[0]
    for points in args.sizes:
        repeats = args.repeats if points <= 3e7 else args.repeats_large
        print(f"{points:.3g} points, {repeats} process(es) per measurement", flush=True)
        rows.append(measure_size(points, repeats, args.block_points,
                                 args.scratch or Path(tempfile.gettempdir())))
    stamp = time.strftime("%Y-%m-%d")
    repeats = f"{args.repeats} ({args.repeats_large} above 3e7 points)"
    about = (
        f"Measured {stamp}, one run of `benchmarks/bench_study_overhead.py`; {machine()}; "
        f"load average {load:.1f} before and {os.getloadavg()[0]:.1f} after. Velocity "
        "studies of the paper's structure; every measurement a fresh process (after imports "
        f"and loading the compiled kernels), alternated, {repeats} times; time = minimum, "
        "peak RSS = largest `ru_maxrss` (before sealing: when the last chunk was written, "
        "before `commit` validates the file). `study run` = `run_study(force=True)` with an "
        "empty cache (2 worker threads; writing, sealing and validating the file included); "
        f"the bare call uses numba's 2 threads, on the whole grid (up to {WHOLE_MAX:.3g} "
        f"points) and in blocks of whole f rows of about {args.block_points:.3g} points, "
        "each block's values copied into one velocity and status array of the grid; the "
        "ratio in bold is to the faster, blocked call.")
    text = table(rows, about)
    print()
    print(text)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(text + "\n")
    write_docs_table(
        "study-overhead", "bench_study_overhead.py",
        f"{machine()}; load average {load:.1f} before and {os.getloadavg()[0]:.1f} after; "
        f"time = minimum over {repeats} processes per measurement", table(rows, "").strip())


if __name__ == "__main__":
    main()
