"""Compile the solver kernels most tests use into numba's on-disk cache, once, before
the test workers start.

The kernels are ``cache=True``. Without a warm-up every pytest-xdist worker of a fresh
clone compiles the same kernels at the same time (each of 2 workers spends minutes on
the two-way solver alone, during collection already: a test module draws its points
with it), and both write the same cache entries. Here the controller runs the jobs
below in as many processes as there are workers, each job its own family of kernels,
before the workers start: the workers then load the kernels from the cache (the
summary of :mod:`tests.support.numba_compiles` counts what each still compiled). A
finished warm-up leaves a stamp beside the cache (:func:`warm_stamp`): the next runs
skip it until a kernel source, this file, numba or Python changes.

A job calls the public functions on a few points, as the tests do (same argument
types, so the same compiled signatures); its results are not checked (the tests do).
``STUDY_WARM_KERNELS=0`` skips the warm-up; ``python -m tests.support.warm_kernels
[JOB ...]`` runs jobs by hand (all by default) and says what each compiled.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

F = np.array([13.0, 14.5])  # Hz
A = np.array([8.5, 9.0])    # m s-2
#: A grid big enough for the parallel velocity drivers (256 points; most below the
#: thresholds, so cheap): f [Hz], a [m s-2], flat.
GRID = tuple(np.array(np.meshgrid(np.linspace(12.0, 16.0, 16), np.linspace(1.0, 9.0, 16)))
             .reshape(2, -1))


def _paper():
    from study.model.paper import paper_structure

    return paper_structure()


def _heavy():
    import study

    return study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.9, cs=0.25)


def one_way() -> None:
    """The paper's one-way solver, its thresholds, frontier and labelled map."""
    import study

    s = _paper()
    for parallel in (False, True):
        study.steady_state(s, F, A, parallel=parallel)
    study.steady_velocity(s, 13.0, 8.5)
    study.steady_velocity(s, F, A)
    study.steady_velocity(s, *GRID)  # the parallel driver
    study.minimum_threshold(s)
    study.frontier(s, np.array([8.0, 9.0]), f_range=(13.5, 15.5))
    study.compute_map(s, F, A, observables=["resonance", "thresholds", "lift_off",
                                            "velocity", "diagnostics"])


def two_way() -> None:
    """The exact two-way solver (serial and parallel drivers): orbits, Floquet
    multipliers."""
    import study

    s = _paper()
    for parallel in (False, True):
        study.steady_state(s, F, A, coupling="two-way", parallel=parallel)
    study.steady_state(s, 14.5, 9.0, coupling="two-way", start="switch-on")


def two_way_more() -> None:
    """The drivers around the exact two-way solver: velocity only, attractors, sections,
    frontier, the labelled map's observables."""
    import study
    from study.solvers.attractors import attractors
    from study.solvers.section import phase_section

    s = _paper()
    study.steady_velocity(s, F, A, coupling="two-way")
    study.steady_velocity(s, *GRID, coupling="two-way")  # the parallel driver
    for parallel in (False, True):
        attractors(s, F, A, coupling="two-way", parallel=parallel)
    phase_section(s, 14.5, 9.0)
    study.frontier(s, np.array([8.0, 9.0]), f_range=(13.5, 15.5), coupling="two-way")
    study.compute_map(s, F, A, coupling="two-way",
                      observables=["velocity", "diagnostics", "floquet", "irregular",
                                   "section", "paper_model"])


def flight() -> None:
    """The two-way solver with flight: the base flies past lift-off and lands."""
    import study
    from study.solvers.attractors import attractors

    s = _heavy()
    f, a = np.array([12.0, 14.0]), np.array([9.5, 11.0])
    for parallel in (False, True):
        study.steady_state(s, f, a, coupling="two-way", flight=True, parallel=parallel)
    study.steady_state(s, 14.0, 11.0, coupling="two-way", flight=True,
                       start=study.Drop(0.002, phase=0.25))
    study.steady_velocity(s, f, a, coupling="two-way", flight=True)
    attractors(s, 14.0, 11.0, coupling="two-way", flight=True)
    study.compute_map(s, f, a, coupling="two-way", flight=True,
                      observables=["velocity", "diagnostics", "irregular", "section",
                                   "without_flight"])


def basins_and_sweeps() -> None:
    """Basins of many starts and slow sweeps (the protocol kernels), with and without
    flight."""
    from study.solvers.basins import basins
    from study.solvers.protocol import slow_sweep

    s, heavy = _paper(), _heavy()
    basins(s, F, A, starts=4)
    basins(heavy, np.array([12.0, 14.0]), np.array([9.5, 11.0]), starts=4, flight=True)
    for parallel in (False, True):
        slow_sweep(s, F, A, along="f", direction="up", parallel=parallel)
        slow_sweep(heavy, np.array([12.0, 14.0]), np.array([9.5, 11.0]), along="f",
                   direction="down", flight=True, parallel=parallel)


def integrator() -> None:
    """The time integrator (the event loop of the single plate), both couplings and
    flight, and its steady state."""
    from study.solvers.integrator import Schedule, integrated_steady_state, simulate

    s = _paper()
    drive = Schedule(frequency=[14.2, 15.2], acceleration=[8.0, 8.0], duration=[0.5, 0.5])
    simulate(s, drive)
    simulate(s, drive, coupling="two-way", initial_state=(0, 0, 0, 0))
    simulate(_heavy(), Schedule.constant(14.0, 11.0, 0.5), coupling="two-way",
             flight=True)
    integrated_steady_state(s, 13.0, 8.5)
    integrated_steady_state(s, 14.5, 9.0, coupling="two-way")


def continuation() -> None:
    """The two-way solver with each orbit continued along the sweep, and the kernels'
    single-point entries as tests call them."""
    import math

    import study
    from study.kernels.two_way import points as kernel
    from study.kernels.two_way.continuation import new_neighbours, remember
    from study.solvers.settings import DEFAULT_SETTINGS, kernel_budget
    from study.solvers.structure_constants import structure_vector

    s = _paper()
    study.steady_state(s, np.full(3, 14.5), np.array([8.0, 8.5, 9.0]), coupling="two-way",
                       settings=study.SolverSettings(continuation=True))
    vector = structure_vector(s, "two-way")
    budget = kernel_budget(DEFAULT_SETTINGS)
    omega = 2.0 * math.pi * 14.5
    cold = np.empty(kernel.N_OUT)
    kernel.solve_point(vector, omega, 6.0, False, budget, 0.0, 1.0, cold)
    neighbours = new_neighbours()
    remember(neighbours, omega, 5.9, cold[kernel.OUT_DELTA:kernel.OUT_SPEED + 1], 4.0, 2.0)
    out = np.empty(kernel.N_OUT)
    kernel.solve_point_along(vector, omega, 6.0, False, budget, 0.0, 1.0, out, neighbours,
                             kernel.new_workspace(vector), True)


def branches() -> None:
    """The branch tracer (study.branch) on the table and with flight."""
    import study

    study.branch(_paper(), 13.0, 2.0, along="a", to=8.0)
    ball = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=1e-12, cs=0.25,
                           restitution=0.5)
    study.branch(ball, 10.0, 12.0, along="a", to=11.0, flight=True)


#: The jobs, dearest first (each process takes the next job when it is free).
JOBS: dict[str, Callable[[], None]] = {
    "two_way": two_way,
    "integrator": integrator,
    "two_way_more": two_way_more,
    "one_way": one_way,
    "flight": flight,
    "basins_and_sweeps": basins_and_sweeps,
    "continuation": continuation,
    "branches": branches,
}

#: The jobs that start only once these have ended: they call the two-way solver's
#: kernels, which two processes would otherwise compile side by side (a kernel compiled
#: by a caller in another file is loaded from the cache once it is there).
AFTER = {"two_way": ("two_way_more", "flight", "basins_and_sweeps", "continuation",
                     "branches")}


def run_jobs(names: list[str]) -> None:
    """Run the named jobs in this process; say each one's time and compilations."""
    from numba.core import event

    from tests.support.numba_compiles import CompileCounter

    for name in names:
        counter = CompileCounter()
        event.register("numba:compile", counter)
        began = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                JOBS[name]()
        except Exception as error:  # the tests report what fails
            print(f"warm-up {name} failed: {type(error).__name__}: {error}", flush=True)
            continue
        finally:
            event.unregister("numba:compile", counter)
        c = counter.compiles
        print(f"warm-up {name}: {time.perf_counter() - began:.0f} s, "
              f"{c.count} compiled in {c.seconds:.0f} s", flush=True)


def warm(processes: int) -> tuple[float, list[str]]:
    """Run every job, spread over ``processes`` processes; the wall time [s] and what
    they said."""
    began = time.perf_counter()
    queue = list(JOBS)
    running: list[tuple[str, subprocess.Popen, object]] = []
    said: list[str] = []
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    after = {job: first for first, jobs in AFTER.items() for job in jobs}
    while queue or running:
        busy = {name for name, _, _ in running}
        ready = [job for job in queue
                 if job not in after or (after[job] not in queue and after[job] not in busy)]
        while ready and len(running) < max(1, processes):
            name = ready.pop(0)
            queue.remove(name)
            out = tempfile.TemporaryFile("w+")
            running.append((name, subprocess.Popen(
                [sys.executable, "-m", "tests.support.warm_kernels", name],
                cwd=ROOT, env=env, stdout=out, stderr=subprocess.STDOUT), out))
        done = [entry for entry in running if entry[1].poll() is not None]
        for entry in done:
            out = entry[2]
            out.seek(0)
            said += out.read().splitlines()[-20:]
            out.close()
            running.remove(entry)
        if not done:
            time.sleep(0.2)
    return time.perf_counter() - began, said


if __name__ == "__main__":
    run_jobs(sys.argv[1:] or list(JOBS))


def pytest_sessionstart(session) -> None:
    """In the controller of a pytest-xdist run, before the workers start: the warm-up,
    in one process per worker (none with ``-n 0`` or ``STUDY_WARM_KERNELS=0``)."""
    config = session.config
    if getattr(config, "workerinput", None) is not None:
        return
    workers = getattr(config.option, "numprocesses", None)
    if not isinstance(workers, int) or workers < 1 or config.getvalue("dist") == "no":
        return
    if os.environ.get("STUDY_WARM_KERNELS", "1") == "0" or config.option.collectonly:
        return
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    stamp = warm_stamp()
    if stamp.exists():
        if reporter is not None:
            reporter.write_line(f"numba warm-up: done before for these kernels ({stamp})")
        return
    seconds, said = warm(workers)
    finished = [line for line in said if " compiled in " in line]
    if len(finished) == len(JOBS):  # every job ran to its end
        try:
            stamp.parent.mkdir(parents=True, exist_ok=True)
            stamp.write_text("\n".join(said) + "\n")
        except OSError:
            pass
    if reporter is not None:
        reporter.write_line(
            f"numba warm-up: the kernels most tests use, compiled or loaded from the "
            f"on-disk cache in {seconds:.0f} s by {workers} processes "
            "(tests/support/warm_kernels.py; STUDY_WARM_KERNELS=0 skips it)")
        for line in said:
            reporter.write_line(f"  {line}")


def warm_stamp() -> Path:
    """The file a finished warm-up leaves beside numba's cache of the kernels: named by
    the kernel sources, these jobs and the numba and Python versions, so that any change
    of them (or a removed cache folder) warms up again."""
    import numba

    from study.kernels import KERNEL_SOURCES_SHA256, KERNELS_DIR

    digest = hashlib.sha256(Path(__file__).read_bytes())
    digest.update(f"{KERNEL_SOURCES_SHA256} {numba.__version__} {sys.version}".encode())
    folder = os.environ.get("NUMBA_CACHE_DIR") or KERNELS_DIR / "__pycache__"
    return Path(folder) / f"tests-warm-{digest.hexdigest()[:16]}"
