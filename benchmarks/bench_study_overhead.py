"""Benchmark: cost of `study run` beyond the kernel, on a 1000 x 1000 velocity study.

Runs the paper's map as a study (dask fan-out, chunk store, netCDF write with
validation) and compares its wall time with the bare kernel on the same grid,
both after compilation, in one process. Timings are reported, never asserted.

Usage: ``python benchmarks/bench_study_overhead.py [--size 1000]``
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

import study
from study.runner import run_study

SPEC = """\
[study]
name = "bench-map"
observables = ["velocity"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = {{ start = 10.0, stop = 20.0, num = {n} }}
a = {{ start = 0.0, stop = 12.0, num = {n} }}
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    n = args.size
    structure = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f = np.linspace(10.0, 20.0, n)[:, None]
    a = np.linspace(0.0, 12.0, n)[None, :]
    study.steady_velocity(structure, f[:4], a)  # compile / load the cache

    kernel = np.inf
    for _ in range(args.repeats):
        start = time.perf_counter()
        study.steady_velocity(structure, f, a)
        kernel = min(kernel, time.perf_counter() - start)

    with tempfile.TemporaryDirectory() as folder:
        spec_path = Path(folder) / "bench-map.toml"
        spec_path.write_text(SPEC.format(n=n))
        output = Path(folder) / "bench-map.nc"
        run_study(spec_path, output, progress=False)  # warm the dask and netCDF imports
        whole = np.inf
        for _ in range(args.repeats):
            start = time.perf_counter()
            report = run_study(spec_path, output, progress=False, force=True)
            whole = min(whole, time.perf_counter() - start)
        size_mb = output.stat().st_size / 1e6
        start = time.perf_counter()
        up_to_date = run_study(spec_path, output, progress=False)
        check = time.perf_counter() - start
    print(f"machine: {os.cpu_count()} cores; {n} x {n} = {n * n} points, "
          f"{report.chunks} chunks")
    print(f"steady_velocity on the grid (2 numba threads): {kernel:.3f} s")
    print(f"study run, netCDF write and validation included: {whole:.3f} s "
          f"(overhead {whole - kernel:.3f} s = {whole / kernel:.2f}x the solver call), "
          f"file {size_mb:.1f} MB")
    print(f"rerun of the unchanged study (fingerprint check only): {check:.3f} s, "
          f"up to date: {up_to_date.up_to_date}")


if __name__ == "__main__":
    main()
