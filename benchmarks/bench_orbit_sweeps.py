"""Benchmark: orbit sweeps, the two-way solver continued along a sweep against one-way.

The goals of issue 22 ("Orbit sweeps at the one-way cost"), measured in one run on one
numba thread (``NUMBA_NUM_THREADS=1``, set here unless given), after warm-up
(compilation or cache load), CPU time (``time.process_time``), minimum of ``--repeats``
rounds, the calls of a round back to back:

1. **Maps** (``--maps``): the paper's map (``bench_two_way_map.py``'s structure, M = 0.08,
   ``floor_one_way.py``'s f and a ranges, ``--size`` points per axis) and the M = 1 map
   (the M = 1 slice of ``workflows/mass-ratio-limit-two-way.toml``, read with the
   package's spec parser; ``--m1-stride`` keeps every k-th f and a). Each: the one-way
   velocity map (``steady_velocity(..., coupling="one-way")``), the two-way map by the
   public call (``steady_velocity(..., coupling="two-way")``) and by the kernel's
   continued driver (``points.solve_points_serial``: the work columns), and the cold
   reference (``points.solve_points_cold``).
2. **The flight map** (``flight`` in ``--maps``): ``bench_flight.py``'s M = 0.99 map
   (``--flight-size`` points per axis): one-way, two-way without flight and with flight,
   each two-way variant continued and cold.
3. **One point** (``--point-calls`` calls a round; 0 skips): ``steady_velocity`` one-way
   against two-way at a moving, a static and a lift-off point of the paper's structure,
   and the two-way kernel alone on that point.

For each two-way variant, by status: points, Newton and map passes per point
(continued and cold; the flight search's included), the share continued, the cold
fallbacks by ``FAILED_*`` reason (the names read from
``study.kernels.two_way.continuation``), and the time.

**How time is attributed.** A row of a map (one frequency, every acceleration) is one
run of the sweep (``points.sweep_runs``): a point depends on the points before it in its
row only, so a row's first k points solved alone are solved exactly as in the map
(checked bit for bit). Each row is cut where the status changes and its prefixes up to
each cut are timed: a stretch of one status costs the difference of two prefixes, with
its neighbours before it. Cold points depend on nothing: each status's points of the
cold map are timed as one call. **The time of a pass** is measured at a sample of
each status's points (``--pass-sample``): the kernel's ``orbit.run`` over one period,
with its Jacobian (a Newton pass) and without (a map pass), three passes against one,
from the state the continued map's first pass at that point starts from (the
prediction from the points before it, or the cold start where there is none), the
contact model followed through the period noting lift-off (as a continued pass runs).
What a status costs beyond its passes times that time is its overhead outside passes.
The rows timed alone are not scaled to the map timed whole: what the two differ by
(the load of a shared machine between calls, either sign) is reported as such.
The flight search's passes are not timed alone: the flight searches cost the flight
map's rows less the same map's without flight (both timed alone), net of the contact
searches that they
spare at bouncing points past the stick's lift-off threshold (solved with flight first).

Then the goals, each with its measured ratio and whether it is met; for a goal not met,
where its time goes (wrapper, static points, passes, overhead outside them, cold
fallbacks, line starts, ``NOT_CONVERGED`` points, the flight search), derived from the
measurements. Accuracy beside speed: the continued map against the cold map (``|dv|`` in
ulps of ``a / omega``, status mismatches), the public call against the kernel (bit for
bit).

Writes ``results/bench-orbit-sweeps.md`` (the full report) and the documentation's
tables, ``docs/speed/orbit-sweeps.md``. Timings are reported, never asserted.

Usage: ``python benchmarks/bench_orbit_sweeps.py [--maps paper m1 flight] [--size 1000]
[--m1-stride 1] [--flight-size 121] [--repeats 2] [--point-calls 2000]
[--pass-sample 20000]``
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numba import njit

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_flight import SIZE as FLIGHT_SIZE  # noqa: E402
from bench_flight import STRUCTURE as FLIGHT_STRUCTURE  # noqa: E402
from bench_flight import grid as flight_grid  # noqa: E402
from bench_two_way_map import STRUCTURE as PAPER_STRUCTURE  # noqa: E402
from docs_tables import (  # noqa: E402
    exponent,
    load_average,
    machine,
    output,
    quick_option,
    use_quick,
    write_docs_table,
)
from floor_one_way import A_RANGE as PAPER_A  # noqa: E402
from floor_one_way import F_RANGE as PAPER_F  # noqa: E402

import study  # noqa: E402
from study.engine.provenance import git_state, utc_now  # noqa: E402
from study.kernels.start import RELEASE  # noqa: E402
from study.kernels.structure_vector import LIFT_OFF_LAW  # noqa: E402
from study.kernels.two_way import continuation  # noqa: E402
from study.kernels.two_way import points as orbit  # noqa: E402
from study.kernels.two_way.modes import N_MODE, TWO_PI, DrivePoint, mode_row  # noqa: E402
from study.kernels.two_way.orbit import A_EVENTS, N_ACC, PassRecord, run  # noqa: E402
from study.kernels.two_way.points import start_state  # noqa: E402
from study.solvers.exact import steady_velocity  # noqa: E402
from study.solvers.settings import DEFAULT_SETTINGS, SolverSettings, kernel_budget  # noqa: E402
from study.solvers.structure_constants import structure_vector  # noqa: E402
from study.studies.spec import load_spec  # noqa: E402

#: The two-way solver's settings with each orbit continued along the sweep.
CONTINUED = SolverSettings(continuation=True)

#: The workflow whose M = 1 slice is the M = 1 map.
M1_WORKFLOW = ROOT / "workflows" / "mass-ratio-limit-two-way.toml"
#: The issue's goals: two-way over one-way CPU time per point.
GOAL_MAP = 5.0
GOAL_FLIGHT = 10.0
GOAL_POINT = 2.0
#: The one-point part's drive points (f [Hz], a [m s-2]) of the paper's structure.
POINTS = {"moving": (14.5, 8.0), "static": (14.5, 1.0), "lift-off": (14.5, 11.5)}
#: The continuation's fallback codes, by name (read from the module, never retyped).
FAILED = {int(getattr(continuation, name)): name for name in dir(continuation)
          if name.startswith("FAILED_")}
MOVING = (int(study.Status.STICK_SLIP), int(study.Status.CONTINUOUS_SLIDING))
STATIC = int(study.Status.STATIC)
NOT_CONVERGED = int(study.Status.NOT_CONVERGED)
#: Passes timed per point against one, for the time of a pass.
PASS_COUNT = 3


@dataclass(frozen=True)
class SweepMap:
    """A map of the benchmark: a structure on an (f, a) grid, frequency outer.

    Attributes
    ----------
    key : str
        The name ``--maps`` knows it by.
    title : str
        How the report names it.
    structure : study.Structure
        The structure.
    f, a : numpy.ndarray
        The axes [Hz], [m s-2]; a row of the map is one f with every a.
    flights : tuple of bool
        The two-way variants measured: without flight, and with it.
    goal : float
        The issue's bound on two-way (the last variant) over one-way per point.
    """

    key: str
    title: str
    structure: study.Structure
    f: np.ndarray
    a: np.ndarray
    flights: tuple[bool, ...] = (False,)
    goal: float = GOAL_MAP

    @property
    def flat(self) -> tuple[np.ndarray, np.ndarray]:
        """The points, flat (``f.size * a.size`` each, acceleration fastest)."""
        f, a = np.broadcast_arrays(self.f[:, None], self.a[None, :])
        return np.ascontiguousarray(f).ravel(), np.ascontiguousarray(a).ravel()

    @property
    def n(self) -> int:
        """Number of points."""
        return self.f.size * self.a.size

    @property
    def grid_text(self) -> str:
        """The grid in words."""
        return (f"f = {self.f[0]:g}..{self.f[-1]:g} Hz ({self.f.size}) x a = "
                f"{self.a[0]:g}..{self.a[-1]:g} m/s^2 ({self.a.size}) = {self.n} points")


def paper_map(size: int) -> SweepMap:
    """The paper's map, ``size`` points per axis."""
    return SweepMap("paper", "paper map (M = 0.08)", PAPER_STRUCTURE,
                    np.linspace(*PAPER_F, size), np.linspace(*PAPER_A, size))


def m1_map(stride: int) -> SweepMap:
    """The M = 1 slice of :data:`M1_WORKFLOW`, every ``stride``-th f and a."""
    spec = load_spec(M1_WORKFLOW)
    structure = next(s for _, s in spec.structures() if s.M == 1.0)
    return SweepMap("m1", "M = 1 map (mass-ratio-limit-two-way)", structure,
                    spec.axis("f").values[::stride], spec.axis("a").values[::stride])


def flight_map(size: int) -> SweepMap:
    """``bench_flight.py``'s M = 0.99 map, ``size`` points per axis."""
    f, a = flight_grid(size)
    return SweepMap("flight", f"flight map (M = {FLIGHT_STRUCTURE.M})", FLIGHT_STRUCTURE,
                    np.unique(f), np.unique(a), (False, True), GOAL_FLIGHT)


def cpu(call: Callable[[], object]) -> tuple[float, object]:
    """The CPU time [s] of ``call()`` and its result."""
    start = time.process_time()
    result = call()
    return time.process_time() - start, result


class Kernel:
    """The two-way kernels' arguments for one structure and lift-off law.

    The lifted flags are ``a > lift_off_acceleration(f)``, the public test
    (:func:`study.lift_off_acceleration`), which the solver's own decision equals.

    Parameters
    ----------
    structure : study.Structure
        The structure.
    flight : bool
        The lift-off law: follow the base off the table.
    """

    def __init__(self, structure: study.Structure, flight: bool) -> None:
        self.vector = structure_vector(structure, "two-way", flight)
        self.budget = kernel_budget(DEFAULT_SETTINGS)
        self.structure = structure

    def arguments(self, f: np.ndarray, a: np.ndarray) -> tuple:
        """``(omega, a, lifted, out)`` for the flat points ``f`` [Hz], ``a`` [m s-2]."""
        f = np.ascontiguousarray(f, dtype=float)
        a = np.ascontiguousarray(a, dtype=float)
        lifted = a > study.lift_off_acceleration(self.structure, f)
        return 2.0 * np.pi * f, a, lifted, np.empty((f.size, orbit.N_OUT))

    def run(self, driver: Callable, arguments: tuple) -> np.ndarray:
        """``driver`` (a ``points.solve_points*``) on ``arguments``; its output table.
        ``points.solve_points_serial`` runs with continuation."""
        omega, a, lifted, out = arguments
        if driver is orbit.solve_points_serial:
            driver(self.vector, omega, a, lifted, self.budget, True, RELEASE, out)
        else:
            driver(self.vector, omega, a, lifted, self.budget, out)
        return out


@njit(error_model="numpy")
def pass_work(vector, omega, a, z, count, want_jac, max_events):
    """Passes over the period map, as a continued Newton pass runs them: the contact
    model followed through the period, lift-off noted (``orbit.run`` with
    ``note_lift_off``). Not cached: it must follow the kernel it calls.

    Parameters
    ----------
    vector : numpy.ndarray
        The structure vector.
    omega, a : numpy.ndarray
        The points [rad s-1], [m s-2].
    z : numpy.ndarray
        Each point's state ``(delta, delta', v)`` at phase 0 (n x 3); a row whose first
        value is NaN starts from the cold start (rest, the mode on its stick response).
    count : int
        Passes at each point, each from ``z``.
    want_jac : bool
        With the Jacobian (a Newton pass) or without (a map pass).
    max_events : int
        The event budget of a pass.

    Returns
    -------
    float
        The events of each point's last pass, summed.
    """
    events = 0.0
    for i in range(omega.shape[0]):
        table = np.zeros((3, N_MODE))
        for row in range(3):
            mode_row(vector, omega[i], a[i], table, row)
        point = DrivePoint(vector, table, omega[i], a[i])
        record = PassRecord(np.zeros(N_ACC), np.empty((3, 3)), np.empty((3, 3)), np.zeros(2))
        start = np.empty(3)
        if np.isnan(z[i, 0]):
            start_state(table, omega[i], 0.0, start, 1.0)
        else:
            start[:] = z[i]
        work = np.empty(3)
        span = TWO_PI / omega[i]
        for _ in range(count):
            for j in range(3):
                work[j] = start[j]
                for m in range(3):
                    record.jac[j, m] = 1.0 if j == m else 0.0
                    record.grad[j, m] = 0.0
            record.acc[:] = 0.0
            run(point, work, 0.0, span, record, want_jac, 0.0, max_events, True)
        events += record.acc[A_EVENTS]
    return events


@njit(error_model="numpy")
def first_states(vector, omega, a, lifted, budget, out, z):
    """The continued map (the kernel's ``_solve_run``, every run in order) into ``out``,
    and each point's prediction from the points before it into ``z`` (n x 3): the state
    its first Newton pass starts from, NaN where the continuation has nothing to start
    from (a static point, a line's start: the cold start). Not cached: it must follow
    the kernel it calls, and ``out`` must be the map's bit for bit."""
    starts = orbit.sweep_runs(omega, a)
    flying = vector[LIFT_OFF_LAW] != 0.0
    guess = np.empty(3)
    for r in range(starts.shape[0] - 1):
        neighbours = continuation.new_neighbours()
        workspace = orbit.new_workspace(vector)
        for i in range(starts[r], starts[r + 1]):
            z[i, :] = np.nan
            static = orbit.static_point(vector, omega[i], a[i], lifted[i], out[i], True)
            if static and not (lifted[i] and flying):
                continuation.forget(neighbours)
                continue
            if continuation.predict(neighbours, omega[i], a[i], guess):
                z[i, :] = guess
            orbit.solve_decided(vector, omega[i], a[i], lifted[i], static, budget, 0.0,
                                1.0, out[i], neighbours, workspace, True)


@dataclass
class Variant:
    """The measurements of one two-way variant (flight or not) of a map: CPU seconds
    (minimum over rounds) and the output tables.

    ``cuts`` holds, per row, where the status changes and the row's end, ``prefixes``
    the minimum time of the row's prefix up to each; ``call`` the time of a call of the
    driver on no point (which every prefix's time includes); ``cold_status`` the cold
    time of each status's points as one call; ``pass_time`` per status code the time of
    a Newton pass and of a map pass and the events of a pass (without flight only).
    """

    flight: bool
    public: float = math.inf
    public_default: float = math.inf
    kernel: float = math.inf
    cold: float = math.inf
    static_one_way: float = math.inf
    static_two_way: float = math.inf
    out: np.ndarray | None = None
    cold_out: np.ndarray | None = None
    public_out: tuple | None = None
    cuts: list[np.ndarray] = field(default_factory=list)
    prefixes: list[np.ndarray] = field(default_factory=list)
    prefixes_identical: bool = True
    call: float = math.inf
    cold_status: dict = field(default_factory=dict)
    pass_time: dict = field(default_factory=dict)
    first: np.ndarray | None = None
    first_identical: bool = True

    @property
    def name(self) -> str:
        """``two-way`` or ``two-way, flight``."""
        return "two-way, flight" if self.flight else "two-way"

    def status_time(self, width: int) -> dict[int, float]:
        """The continued map's time by status [s]: the stretches of each status, each
        the difference of the two prefixes that end it and the one before."""
        times: dict[int, float] = {}
        status = self.out[:, orbit.OUT_STATUS]
        for r, (cuts, prefix) in enumerate(zip(self.cuts, self.prefixes, strict=True)):
            begin, before = 0, self.call
            for cut, seconds in zip(cuts, prefix, strict=True):
                code = int(status[r * width + begin])
                times[code] = times.get(code, 0.0) + seconds - before
                begin, before = cut, seconds
        return times



@dataclass
class MapResult:
    """A map's measurements: the one-way call and the two-way variants."""

    sweep: SweepMap
    one_way: float = math.inf
    one_way_out: tuple | None = None
    variants: list[Variant] = field(default_factory=list)
    warm: float = 0.0

    @property
    def base(self) -> Variant:
        """The variant without flight."""
        return self.variants[0]


def passes(out: np.ndarray) -> np.ndarray:
    """Newton plus map passes of each row of an output table."""
    return out[:, orbit.OUT_NEWTON_PASSES] + out[:, orbit.OUT_MAP_PASSES]


def _warm_up(sweep: SweepMap) -> float:
    """Compile or load every kernel variant the map's calls use; seconds taken."""
    start = time.perf_counter()
    f, a = np.array([13.0, 16.5]), np.array([8.5, 11.5])
    big_f, big_a = np.linspace(10.0, 20.0, 4096), np.linspace(0.0, 12.0, 4096)
    for x, y in ((f, a), (big_f, big_a)):  # the serial and the parallel drivers
        steady_velocity(sweep.structure, x, y, coupling="one-way")
        for flight in sweep.flights:
            steady_velocity(sweep.structure, x, y, coupling="two-way", flight=flight)
            steady_velocity(sweep.structure, x, y, CONTINUED, coupling="two-way",
                            flight=flight)
    for flight in sweep.flights:
        kernel = Kernel(sweep.structure, flight)
        for driver in (orbit.solve_points_serial, orbit.solve_points_cold):
            kernel.run(driver, kernel.arguments(f, a))
    kernel = Kernel(sweep.structure, False)
    for want_jac in (True, False):
        pass_work(kernel.vector, 2.0 * np.pi * f, a, np.full((2, 3), np.nan), 1, want_jac,
                  kernel.budget.max_events)
    return time.perf_counter() - start


def measure_map(sweep: SweepMap, repeats: int, pass_sample: int, seed: int) -> MapResult:
    """Time the map's calls, ``repeats`` rounds back to back (see the module's text).

    Parameters
    ----------
    sweep : SweepMap
        The map.
    repeats : int
        Rounds; each time is the minimum over them.
    pass_sample : int
        Points of each status at which the time of a pass is measured.
    seed : int
        Seed of that sample.

    Returns
    -------
    MapResult
        The minimum CPU times and the outputs.
    """
    result = MapResult(sweep, warm=_warm_up(sweep))
    print(f"{sweep.title}: {sweep.grid_text}; warm-up {result.warm:.1f} s", flush=True)
    f, a = sweep.flat
    n, width = sweep.n, sweep.a.size
    result.variants = [Variant(flight) for flight in sweep.flights]
    kernels = [Kernel(sweep.structure, flight) for flight in sweep.flights]
    for round_ in range(repeats):
        seconds, result.one_way_out = cpu(
            lambda: steady_velocity(sweep.structure, f, a, coupling="one-way"))
        result.one_way = min(result.one_way, seconds)
        line = [f"one-way {seconds / n * 1e6:.3f}"]
        for variant, kernel in zip(result.variants, kernels, strict=True):
            seconds, variant.public_out = cpu(lambda v=variant: steady_velocity(
                sweep.structure, f, a, CONTINUED, coupling="two-way", flight=v.flight))
            variant.public = min(variant.public, seconds)
            line.append(f"{variant.name} {seconds / n * 1e6:.3f}")
            seconds, _ = cpu(lambda v=variant: steady_velocity(
                sweep.structure, f, a, coupling="two-way", flight=v.flight))
            variant.public_default = min(variant.public_default, seconds)
            line.append(f"from rest {seconds / n * 1e6:.3f}")
            arguments = kernel.arguments(f, a)
            seconds, variant.out = cpu(lambda k=kernel, x=arguments:
                                       k.run(orbit.solve_points_serial, x))
            variant.kernel = min(variant.kernel, seconds)
            line.append(f"kernel {seconds / n * 1e6:.3f}")
            arguments = kernel.arguments(f, a)
            seconds, variant.cold_out = cpu(lambda k=kernel, x=arguments:
                                            k.run(orbit.solve_points_cold, x))
            variant.cold = min(variant.cold, seconds)
            line.append(f"cold {seconds / n * 1e6:.3f}")
            _time_prefixes(kernel, f, a, width, variant)
            _time_cold_status(kernel, f, a, variant)
            _time_static(sweep, f, a, variant)
            if not variant.flight:
                _time_passes(kernel, f, a, variant, pass_sample, seed)
        print(f"  round {round_ + 1}, CPU us per point: " + ", ".join(line), flush=True)
    return result


def _time_prefixes(kernel: Kernel, f: np.ndarray, a: np.ndarray, width: int,
                   variant: Variant) -> None:
    """Each row's prefixes up to each status change and to its end, solved alone by the
    continued driver: their minimum times. Each prefix's output must be the map's bit
    for bit (else ``prefixes_identical`` is cleared)."""
    status = variant.out[:, orbit.OUT_STATUS].reshape(-1, width)
    first = not variant.cuts
    empty = kernel.arguments(f[:0], a[:0])
    for _ in range(100):
        seconds, _ = cpu(lambda: kernel.run(orbit.solve_points_serial, empty))
        variant.call = min(variant.call, seconds)
    for r in range(status.shape[0]):
        if first:
            cuts = np.append(np.flatnonzero(np.diff(status[r]) != 0) + 1, width)
            variant.cuts.append(cuts)
            variant.prefixes.append(np.full(cuts.size, math.inf))
        cuts, best = variant.cuts[r], variant.prefixes[r]
        for j, cut in enumerate(cuts):
            part = slice(r * width, r * width + cut)
            arguments = kernel.arguments(f[part], a[part])
            seconds, out = cpu(lambda x=arguments: kernel.run(orbit.solve_points_serial, x))
            best[j] = min(best[j], seconds)
            if not np.array_equal(out, variant.out[part], equal_nan=True):
                variant.prefixes_identical = False


def _time_cold_status(kernel: Kernel, f: np.ndarray, a: np.ndarray,
                      variant: Variant) -> None:
    """Each status's points of the cold map as one call (cold points are independent)."""
    status = variant.cold_out[:, orbit.OUT_STATUS]
    for code in np.unique(status).astype(int):
        index = np.flatnonzero(status == code)
        arguments = kernel.arguments(f[index], a[index])
        seconds, _ = cpu(lambda x=arguments: kernel.run(orbit.solve_points_cold, x))
        variant.cold_status[code] = min(variant.cold_status.get(code, math.inf), seconds)


def _time_static(sweep: SweepMap, f: np.ndarray, a: np.ndarray, variant: Variant) -> None:
    """The two-way STATIC points by both public calls alone, one call each."""
    static = np.flatnonzero(variant.out[:, orbit.OUT_STATUS] == STATIC)
    if static.size:
        x, y = f[static], a[static]
        seconds, _ = cpu(lambda: steady_velocity(sweep.structure, x, y, coupling="one-way"))
        variant.static_one_way = min(variant.static_one_way, seconds)
        seconds, _ = cpu(lambda: steady_velocity(sweep.structure, x, y, coupling="two-way",
                                                 flight=variant.flight))
        variant.static_two_way = min(variant.static_two_way, seconds)


def _time_passes(kernel: Kernel, f: np.ndarray, a: np.ndarray, variant: Variant,
                 sample: int, seed: int) -> None:
    """The time of a Newton pass and of a map pass at a sample of each status's solved
    points (:func:`pass_work`, :data:`PASS_COUNT` passes against one), minimum over
    rounds; and the events of a pass."""
    out = variant.out
    status = out[:, orbit.OUT_STATUS]
    if variant.first is None:
        omega, a_, lifted, table = kernel.arguments(f, a)
        variant.first = np.empty((f.size, 3))
        first_states(kernel.vector, omega, a_, lifted, kernel.budget, table, variant.first)
        variant.first_identical = bool(np.array_equal(table, out, equal_nan=True))
    rng = np.random.default_rng(seed)
    for code in np.unique(status[passes(out) > 0]).astype(int):
        index = np.flatnonzero((status == code) & (passes(out) > 0))
        index = np.sort(rng.choice(index, size=min(sample, index.size), replace=False))
        omega = 2.0 * np.pi * f[index]
        z = np.ascontiguousarray(variant.first[index])
        points = (kernel.vector, omega, a[index], z)
        best = variant.pass_time.get(code, {"newton": math.inf, "map": math.inf})
        for name, want_jac in (("newton", True), ("map", False)):
            times = []
            for count in (1, PASS_COUNT):
                seconds, events = cpu(lambda x=points, c=count, w=want_jac: pass_work(
                    *x, c, w, kernel.budget.max_events))
                times.append(seconds)
            per_pass = (times[1] - times[0]) / ((PASS_COUNT - 1) * index.size)
            best[name] = min(best[name], per_pass)
            best["events"] = events / index.size
        best["sample"] = index.size
        variant.pass_time[code] = best


def pass_seconds(result: MapResult, variant: Variant) -> np.ndarray:
    """The time of each point's contact passes [s]: its Newton and map passes (for the
    flight variant those of the same map without flight, which it repeats bit for bit)
    at the measured time of a pass of its status without flight."""
    base = result.base
    status = base.out[:, orbit.OUT_STATUS]
    newton = np.zeros(status.size)
    maps = np.zeros(status.size)
    for code, timing in base.pass_time.items():
        newton[status == code] = timing["newton"]
        maps[status == code] = timing["map"]
    return (base.out[:, orbit.OUT_NEWTON_PASSES] * newton
            + base.out[:, orbit.OUT_MAP_PASSES] * maps)


def ulp_errors(variant: Variant, a: np.ndarray, f: np.ndarray) -> dict:
    """The continued map against the cold map: ``|dv|`` in ulps of ``a / omega`` where
    both have a velocity, status mismatches, and the public call against the kernel."""
    out, cold = variant.out, variant.cold_out
    both = np.isfinite(out[:, orbit.OUT_VELOCITY]) & np.isfinite(cold[:, orbit.OUT_VELOCITY])
    scale = np.spacing(np.maximum(a / (2.0 * np.pi * f), np.finfo(float).tiny))
    ulps = (np.abs(out[:, orbit.OUT_VELOCITY] - cold[:, orbit.OUT_VELOCITY])[both]
            / scale[both])
    velocity, status = variant.public_out
    public_same = (np.array_equal(velocity.ravel(), out[:, orbit.OUT_VELOCITY],
                                  equal_nan=True)
                   and np.array_equal(status.ravel(), out[:, orbit.OUT_STATUS]))
    return {"compared": int(both.sum()),
            "max": float(ulps.max()) if ulps.size else math.nan,
            "p999": float(np.quantile(ulps, 0.999)) if ulps.size else math.nan,
            "status_mismatch": int(np.count_nonzero(out[:, orbit.OUT_STATUS]
                                                    != cold[:, orbit.OUT_STATUS])),
            "public_same": public_same}


def fallbacks(codes: np.ndarray) -> str:
    """Counts of the continuation's fallback reasons among ``codes`` (OUT_CONTINUED)."""
    values, counts = np.unique(codes[codes < 0].astype(int), return_counts=True)
    return ", ".join(f"{FAILED.get(v, v)} {c}" for v, c in zip(values, counts, strict=True)
                     ) or "-"


def status_rows(result: MapResult, variant: Variant) -> list[dict]:
    """Per two-way status of the continued map: counts, passes, continuation, time."""
    out, cold = variant.out, variant.cold_out
    n = result.sweep.n
    status = out[:, orbit.OUT_STATUS]
    cold_status = cold[:, orbit.OUT_STATUS]
    times = variant.status_time(result.sweep.a.size)
    total = sum(times.values())
    contact = pass_seconds(result, variant)
    rows = []
    for code in study.Status:
        index = status == code
        count = int(index.sum())
        if count == 0:
            continue
        continued = out[index, orbit.OUT_CONTINUED]
        seconds = times.get(int(code), 0.0)
        cold_count = int(np.count_nonzero(cold_status == code))
        cold_seconds = variant.cold_status.get(int(code), math.nan)
        timing = result.base.pass_time.get(int(code)) if not variant.flight else None
        rows.append({
            "name": code.name, "count": count, "share": count / n,
            "newton": out[index, orbit.OUT_NEWTON_PASSES].mean(),
            "newton_cold": cold[index, orbit.OUT_NEWTON_PASSES].mean(),
            "map": out[index, orbit.OUT_MAP_PASSES].mean(),
            "map_cold": cold[index, orbit.OUT_MAP_PASSES].mean(),
            "continued": (float(np.mean(continued == 1)) if passes(out[index]).any()
                          else math.nan),
            "first": int(np.count_nonzero((continued == 0) & (passes(out[index]) > 0))),
            "fallbacks": fallbacks(continued),
            "time_share": seconds / total if total > 0 else math.nan,
            "per_point": seconds / count,
            "cold_per_point": cold_seconds / cold_count if cold_count else math.nan,
            "timing": timing,
            "outside": (seconds - contact[index].sum()) / count,
        })
    return rows


@dataclass
class PointResult:
    """The one-point part: per-call CPU seconds (minimum over rounds) by point."""

    calls: int
    one_way: dict = field(default_factory=dict)
    two_way: dict = field(default_factory=dict)
    kernel: dict = field(default_factory=dict)
    work: dict = field(default_factory=dict)
    status: dict = field(default_factory=dict)


def measure_points(calls: int, repeats: int) -> PointResult:
    """``steady_velocity`` one-way and two-way, and the two-way kernel, on each of
    :data:`POINTS`: ``calls`` calls a round, ``repeats`` rounds, CPU seconds per call.

    Parameters
    ----------
    calls : int
        Calls per round.
    repeats : int
        Rounds.

    Returns
    -------
    PointResult
        Per point: the per-call times, the point's passes and both statuses.
    """
    result = PointResult(calls)
    structure = PAPER_STRUCTURE
    kernel = Kernel(structure, False)
    for label, (f, a) in POINTS.items():
        arguments = kernel.arguments(np.array([f]), np.array([a]))
        out = kernel.run(orbit.solve_points_serial, arguments)
        result.work[label] = (out[0, orbit.OUT_NEWTON_PASSES], out[0, orbit.OUT_MAP_PASSES])
        result.status[label] = tuple(
            study.Status(int(steady_velocity(structure, f, a, coupling=c)[1])).name
            for c in ("one-way", "two-way"))
        timed = {
            "one_way": lambda f=f, a=a: steady_velocity(structure, f, a, coupling="one-way"),
            "two_way": lambda f=f, a=a: steady_velocity(structure, f, a, coupling="two-way"),
            "kernel": lambda x=arguments: kernel.run(orbit.solve_points_serial, x),
        }
        for call in timed.values():
            call()
        best = dict.fromkeys(timed, math.inf)
        for _ in range(repeats):
            for name, call in timed.items():
                start = time.process_time()
                for _ in range(calls):
                    call()
                best[name] = min(best[name], (time.process_time() - start) / calls)
        result.one_way[label] = best["one_way"]
        result.two_way[label] = best["two_way"]
        result.kernel[label] = best["kernel"]
        print(f"  {label} point f = {f:g} Hz, a = {a:g} m/s^2: one-way "
              f"{best['one_way'] * 1e6:.2f} us, two-way {best['two_way'] * 1e6:.2f} us "
              f"(kernel {best['kernel'] * 1e6:.2f} us), {calls} calls a round", flush=True)
    return result


def us(seconds: float) -> str:
    """Microseconds, three significant digits."""
    return f"{seconds * 1e6:.3g}"


def solved_passes(out: np.ndarray) -> float:
    """Newton passes per point that took a pass."""
    solved = passes(out) > 0
    return float(out[solved, orbit.OUT_NEWTON_PASSES].mean()) if solved.any() else 0.0


def map_table(results: list[MapResult]) -> str:
    """The maps' summary: CPU per point of each call and the ratios to one-way."""
    lines = ["| map | points | one-way [us/pt] | two-way call | two-way, continuation "
             "[us/pt] | / one-way | two-way, from rest (default) [us/pt] | / one-way | "
             "kernel, continued [us/pt] | kernel, cold [us/pt] | "
             "Newton passes per solved point, continued / cold |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for result in results:
        n = result.sweep.n
        for variant in result.variants:
            lines.append(
                f"| {result.sweep.title} | {exponent(n) if n >= 1e5 else n} | "
                f"{us(result.one_way / n)} | `{variant.name}` | {us(variant.public / n)} | "
                f"{variant.public / result.one_way:.1f}x | {us(variant.public_default / n)} | "
                f"{variant.public_default / result.one_way:.1f}x | {us(variant.kernel / n)} | "
                f"{us(variant.cold / n)} | "
                f"{solved_passes(variant.out):.2f} / {solved_passes(variant.cold_out):.2f} |")
    return "\n".join(lines)


def status_table(result: MapResult, variant: Variant) -> str:
    """The variant's statuses: passes, continuation, fallbacks and time."""
    outside = ("outside passes" if not variant.flight
               else "outside contact passes (flight search included)")
    lines = [f"| {variant.name} status | points | share | Newton passes/pt, continued / "
             "cold | map passes/pt, continued / cold | continued | line starts | "
             "cold fallbacks | share of time | us/pt, continued / cold | us a pass, "
             f"Newton / map (events a pass) | {outside} [us/pt] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in status_rows(result, variant):
        timing = row["timing"]
        pass_text = (f"{us(timing['newton'])} / {us(timing['map'])} ({timing['events']:.1f})"
                     if timing else "-")
        continued = "-" if math.isnan(row["continued"]) else f"{row['continued']:.1%}"
        lines.append(
            f"| {row['name']} | {row['count']} | {row['share']:.1%} | {row['newton']:.2f} / "
            f"{row['newton_cold']:.2f} | {row['map']:.2f} / {row['map_cold']:.2f} | "
            f"{continued} | {row['first']} | {row['fallbacks']} | "
            f"{row['time_share']:.1%} | {us(row['per_point'])} / {us(row['cold_per_point'])} "
            f"| {pass_text} | {us(row['outside'])} |")
    return "\n".join(lines)


def timing_text(result: MapResult, variant: Variant) -> str:
    """How the variant's times by status were measured, with their totals."""
    prefixes = sum(p[-1] - variant.call for p in variant.prefixes)
    cold = sum(variant.cold_status.values())
    samples = ", ".join(f"{study.Status(code).name} {t['sample']}"
                        for code, t in result.base.pass_time.items())
    return (f"Times by status: continued, {len(variant.prefixes)} rows cut at their "
            f"{sum(c.size - 1 for c in variant.cuts)} status changes, the prefixes timed "
            f"alone (bit-identical to the map: "
            f"{'yes' if variant.prefixes_identical else 'NO'}; a call on no point "
            f"{us(variant.call)} us, taken off each row; whole rows {prefixes:.3f} s "
            f"against the map's {variant.kernel:.3f} s); cold, each status as one call "
            f"({cold:.3f} s against {variant.cold:.3f} s). The times by status are the rows' "
            f"as timed alone, not scaled to the map timed whole. Time of a pass at {samples} "
            "points, from the state the continued map's first pass there starts from (the "
            "continued map run so, bit-identical to the map: "
            f"{'yes' if variant.first_identical else 'NO'}; see the method).")


def static_text(variant: Variant) -> str:
    """The static points' cost against one-way's on the same points."""
    count = int(np.count_nonzero(variant.out[:, orbit.OUT_STATUS] == STATIC))
    if count == 0:
        return "No static points."
    return (f"Static points ({count}, each public call on them alone): two-way "
            f"{us(variant.static_two_way / count)} us a point against one-way "
            f"{us(variant.static_one_way / count)} us "
            f"({variant.static_two_way / variant.static_one_way:.1f}x).")


def accuracy_text(result: MapResult, variant: Variant) -> str:
    """The accuracy line of a variant."""
    f, a = result.sweep.flat
    e = ulp_errors(variant, a, f)
    return (f"Accuracy ({variant.name}): continued against cold, {e['compared']} points "
            f"with a velocity in both: |dv| max {e['max']:.3g} ulps of a/omega, 99.9th "
            f"percentile {e['p999']:.3g}; status mismatches {e['status_mismatch']}; "
            f"public call and kernel bit-identical: {'yes' if e['public_same'] else 'NO'}.")


def map_goal(result: MapResult) -> dict:
    """The map's goal: its last variant's public call over one-way, and, when not met,
    where the time goes."""
    sweep, variant = result.sweep, result.variants[-1]
    n, goal = sweep.n, sweep.goal
    ratio = variant.public / result.one_way
    entry = {"goal": f"{sweep.title}: `{variant.name}` with continuation within {goal:g}x "
                     "one-way per point",
             "ratio": ratio, "limit": goal, "met": ratio <= goal, "why": ""}
    if entry["met"]:
        return entry
    out = variant.out
    status = out[:, orbit.OUT_STATUS]
    times = variant.status_time(sweep.a.size)
    rows_alone = sum(times.values())
    solved = passes(out) > 0
    n_solved = max(int(solved.sum()), 1)
    contact = pass_seconds(result, variant)  # measured directly: not scaled
    # Both maps' rows timed alone, so that the load between calls stays out of it.
    flight_search = (rows_alone - sum(result.base.status_time(sweep.a.size).values())
                     if variant.flight else 0.0)
    static = times.get(STATIC, 0.0)
    pass_time = float(contact.sum())
    contact_passes = float(passes(result.base.out).sum())
    # The rows timed alone, less static points, passes and flight searches; what the map
    # timed whole differs from its rows timed alone is the load between calls.
    outside = rows_alone - static - pass_time - flight_search
    load = variant.kernel - rows_alone
    limit = goal * result.one_way / n
    spent = variant.public / n
    kind = "contact passes" if variant.flight else "passes"
    parts = [f"the Python wrapper (public call less kernel) {us(spent - variant.kernel / n)}",
             f"static points {us(static / n)}",
             f"{contact_passes / n_solved:.2f} {kind} per solved point "
             f"at {us(pass_time / max(contact_passes, 1))} us {us(pass_time / n)}"]
    if variant.flight:
        # Past the stick's lift-off threshold the flight search comes first and spares
        # the contact search of a bouncing point: the difference is net of it.
        flight_passes = passes(out).sum() - contact_passes
        flying = int(np.count_nonzero(passes(out) != passes(result.base.out)))
        parts.append(f"the flight searches, net of the contact searches they spare past "
                     f"the lift-off threshold (the map's rows less the map's without "
                     f"flight, timed alone; {flying} points, {flight_passes / max(flying, 1):.1f} "
                     f"passes more each) {us(flight_search / n)}")
    overhead = (f"the solved points' overhead outside passes ({us(outside / n_solved)} us "
                f"a solved point) {us(outside / n)}")
    if outside < 0.0:
        # Passes at the measured time overstate the passes of a lift-off point: its last
        # pass ends at the lift-off, and a cold start's passes before it do not watch for
        # one (no lift-off event to seek), while the time of a pass is measured on whole
        # passes that watch, as a continued pass does.
        overhead += (" (negative: the passes of LIFT_OFF points cost less than the time "
                     "of a pass measured, their last pass ending at the lift-off and a "
                     "cold start's passes not watching for it)")
    parts.append(overhead)
    parts.append(f"the map timed whole less its rows timed alone (the load between calls, "
                 f"either sign) {us(load / n)}")
    lines = [f"{us(spent)} us a point against a budget of {us(limit)} us ({goal:g}x one-way "
             f"{us(result.one_way / n)} us): {us(spent - limit)} us a point to go. Where "
             "the time goes, us per point of the map: " + "; ".join(parts) + "."]
    # Shares of the rows' time: exact for a status, estimated for scattered points.
    per_status_outside = {code: (times.get(code, 0.0) - contact[status == code].sum())
                          / max(np.sum(status == code), 1)
                          for code in np.unique(status).astype(int)}
    overhead = np.array([per_status_outside[int(code)] for code in status])
    continued = out[:, orbit.OUT_CONTINUED]
    shares = []
    for name, mask in (("cold fallbacks", continued < 0),
                       ("line starts (nothing to continue from)", (continued == 0) & solved)):
        if mask.any():
            seconds = contact[mask].sum() + overhead[mask].sum()
            shares.append(f"{name}, {int(mask.sum())} points: {seconds / rows_alone:.0%}")
    if shares:
        shares[-1] += " (estimated from their passes and their status's overhead a point)"
    for code in np.unique(status).astype(int):
        if code not in (STATIC, *MOVING):
            shares.append(f"{study.Status(code).name}, {int(np.sum(status == code))} points: "
                          f"{times.get(code, 0.0) / rows_alone:.0%}")
    lines.append("Shares of the rows' time (timed alone): " + "; ".join(shares) + ".")
    rest = spent - pass_time / n
    if rest >= limit:
        lines.append(f"Without any of its {kind} the rest ({us(rest)} us a point) is "
                     "already over the budget.")
    elif pass_time:
        allowed = (limit - rest) * n / (pass_time / contact_passes) / n_solved
        lines.append(f"At the measured time of a pass the goal allows {allowed:.2f} passes "
                     f"per solved point (now {contact_passes / n_solved:.2f}).")
    entry["why"] = " ".join(lines)
    return entry


def point_goals(points: PointResult) -> list[dict]:
    """One point's goals: two-way over one-way per call at each of :data:`POINTS`."""
    entries = []
    for label, (f, a) in POINTS.items():
        one, two, kernel = (points.one_way[label], points.two_way[label],
                            points.kernel[label])
        ratio = two / one
        newton, maps = points.work[label]
        entry = {"goal": f"one {label} point (f = {f:g} Hz, a = {a:g} m/s^2): "
                         f"within {GOAL_POINT:g}x one one-way point",
                 "ratio": ratio, "limit": GOAL_POINT, "met": ratio <= GOAL_POINT, "why": ""}
        if not entry["met"]:
            entry["why"] = (
                f"{us(two)} us a call against a budget of {us(GOAL_POINT * one)} us: the "
                f"kernel {us(kernel)} us ({newton:.0f} Newton and {maps:.0f} map passes, "
                f"cold: a lone point has nothing to continue from), the Python wrapper "
                f"(validation, lift-off flags, allocation) {us(two - kernel)} us; one-way "
                f"{us(one)} us a call.")
        entries.append(entry)
    return entries


def passes_goal(results: list[MapResult]) -> dict:
    """The goal "Newton passes per point reported": the values, per map."""
    parts = []
    for result in results:
        for variant in result.variants:
            moving = np.isin(variant.out[:, orbit.OUT_STATUS], MOVING)
            if moving.any():
                parts.append(
                    f"{result.sweep.title}, {variant.name}: "
                    f"{variant.out[moving, orbit.OUT_NEWTON_PASSES].mean():.2f} per moving "
                    f"point (cold {variant.cold_out[moving, orbit.OUT_NEWTON_PASSES].mean():.2f})")
    return {"goal": "Newton passes per point reported by the benchmark",
            "ratio": math.nan, "limit": math.nan, "met": True,
            "why": "Newton passes: " + "; ".join(parts) + "." if parts else ""}


def goals_table(entries: list[dict]) -> str:
    """The goals: measured ratio, limit, met or not; then the lines for those not met."""
    lines = ["| goal | measured | met |", "|---|---|---|"]
    for entry in entries:
        measured = ("reported" if math.isnan(entry["ratio"])
                    else f"{entry['ratio']:.2f}x (<= {entry['limit']:g}x)")
        lines.append(f"| {entry['goal']} | {measured} | {'yes' if entry['met'] else 'no'} |")
    missed = [entry for entry in entries if not entry["met"] and entry["why"]]
    if missed:
        lines += ["", "Where the time is left, for each goal not met:", ""]
        lines += [f"* {entry['goal']}: {entry['why']}" for entry in missed]
    reported = [entry["why"] for entry in entries if entry["met"] and entry["why"]]
    if reported:
        lines += ["", *reported]
    return "\n".join(lines)


def points_table(points: PointResult) -> str:
    """The one-point part's table."""
    lines = ["| point | status one-way / two-way | one-way [us/call] | two-way [us/call] | "
             "/ one-way | two-way kernel [us/call] | Newton + map passes |",
             "|---|---|---|---|---|---|---|"]
    for label, (f, a) in POINTS.items():
        newton, maps = points.work[label]
        lines.append(
            f"| {label}, f = {f:g} Hz, a = {a:g} m/s^2 | {' / '.join(points.status[label])} "
            f"| {us(points.one_way[label])} | {us(points.two_way[label])} | "
            f"{points.two_way[label] / points.one_way[label]:.1f}x | "
            f"{us(points.kernel[label])} | {newton:.0f} + {maps:.0f} |")
    return "\n".join(lines)


#: How the report's times are measured, in its words.
METHOD = (
    "A row of a map (one f, every a) is one run of the sweep: a point depends on the "
    "points before it in its row only. The continued map's time by status: each row cut "
    "where the status changes, its prefixes up to each cut solved alone (bit-identical to "
    "the map), a stretch's time the difference of two prefixes (the first stretch less "
    "the time of a call on no point), not scaled to the map timed whole (what the two "
    "differ by, the load between calls, is reported). The cold map's: each "
    "status's points as one call (cold points are independent). The time of a pass: the "
    f"kernel's `orbit.run` over one period, {PASS_COUNT} passes against one at a sample "
    "of each status's points, from the state the continued map's first pass there starts "
    "from (the prediction from the points before it, else the cold start), following the "
    "contact model through the period as a continued pass "
    "does; what a status costs beyond its passes at that time is its overhead outside "
    "passes. The flight searches: the flight map's rows timed alone less the same map's "
    "without flight, net of the contact searches they spare (past the stick's lift-off threshold "
    "a point is solved with flight first). Shares of scattered points "
    "(cold fallbacks, line starts) are estimated from their passes and their status's "
    "overhead a point.")


def report(args: argparse.Namespace, results: list[MapResult], points: PointResult | None,
           goals: list[dict], loads: str) -> tuple[str, str]:
    """The full report and the documentation's tables (Markdown)."""
    git = git_state()
    head = [
        "# Orbit sweeps: the two-way solver continued, against one-way",
        "",
        f"Machine: {machine()}; shared, load average {loads} (1, 5, 15 min). "
        f"Commit {git['git_commit']}{' (dirty)' if git['git_dirty'] else ''}, {utc_now()}.",
        "",
        f"One numba thread, CPU time (`time.process_time`), warm-up excluded, minimum of "
        f"{args.repeats} rounds, the calls of a round back to back. Two-way call: the public "
        "`steady_velocity(..., coupling=\"two-way\")` with "
        "`SolverSettings(continuation=True)` and without (the default: every point from "
        "rest); kernel: `points.solve_points_serial` "
        "(continued along each row of the map) and `points.solve_points_cold` (every point "
        "cold), with the lifted flags of `study.lift_off_acceleration`.",
        "",
        "## Maps",
        "",
        map_table(results),
        "",
    ]
    docs = ["**Maps** (CPU per point; Newton passes per point that took a pass):", "",
            map_table(results), ""]
    body = []
    for result in results:
        body += [f"### {result.sweep.title}", "",
                 f"{result.sweep.grid_text}; structure {result.sweep.structure}; warm-up "
                 f"{result.warm:.1f} s.", ""]
        for variant in result.variants:
            body += [status_table(result, variant), "", timing_text(result, variant), "",
                     static_text(variant), "", accuracy_text(result, variant), ""]
            docs += [f"{result.sweep.title}, {variant.name}: "
                     + accuracy_text(result, variant).split(": ", 1)[1], ""]
    if points is not None:
        body += ["## One point", "",
                 f"Per call, {points.calls} calls a round, paper structure; the kernel is "
                 "`points.solve_points_serial` on the one point (arrays made beforehand).",
                 "", points_table(points), ""]
        docs += [f"**One point** (per call, {points.calls} calls a round):", "",
                 points_table(points), ""]
    goals_text = goals_table(goals)
    body += ["## Goals (issue 22)", "", goals_text, "", "## Method", "", METHOD, ""]
    docs += ["**Goals** (issue 22):", "", goals_text, "", f"*Method.* {METHOD}"]
    return "\n".join(head + body), "\n".join(docs) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark (see the module's text); returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", nargs="*", default=["paper", "m1", "flight"],
                        choices=["paper", "m1", "flight"], help="the maps measured")
    parser.add_argument("--size", type=int, default=1000,
                        help="points per axis of the paper map")
    parser.add_argument("--m1-stride", type=int, default=1,
                        help="every k-th f and a of the M = 1 workflow's grid")
    parser.add_argument("--flight-size", type=int, default=FLIGHT_SIZE,
                        help="points per axis of the flight map")
    parser.add_argument("--repeats", type=int, default=2, help="rounds; minimum taken")
    parser.add_argument("--point-calls", type=int, default=2000,
                        help="calls a round of the one-point part (0: skip it)")
    parser.add_argument("--pass-sample", type=int, default=20000,
                        help="points of each status at which a pass is timed")
    parser.add_argument("--seed", type=int, default=2026, help="seed of that sample")
    parser.add_argument("--output", type=Path,
                        default=ROOT / "results" / "bench-orbit-sweeps.md")
    parser.add_argument("--no-docs-table", action="store_true",
                        help="do not write docs/speed/orbit-sweeps.md (smoke tests)")
    quick_option(parser)
    args = parser.parse_args(argv)
    if use_quick(args.quick):  # smaller maps, one round, fewer calls and passes
        args.size, args.m1_stride = min(args.size, 200), max(args.m1_stride, 4)
        args.flight_size, args.repeats = min(args.flight_size, 41), 1
        args.point_calls, args.pass_sample = min(args.point_calls, 200), min(
            args.pass_sample, 2000)
    args.output = output(args.output)

    load_start = load_average()
    print(f"machine: {machine()}; load average {load_start}", flush=True)
    builders = {"paper": lambda: paper_map(args.size), "m1": lambda: m1_map(args.m1_stride),
                "flight": lambda: flight_map(args.flight_size)}
    results = [measure_map(builders[key](), args.repeats, args.pass_sample, args.seed)
               for key in builders if key in args.maps]
    points = None
    if args.point_calls > 0:
        print("one point:", flush=True)
        points = measure_points(args.point_calls, args.repeats)
    load_timed = load_average()
    goals = [map_goal(result) for result in results]
    if points is not None:
        goals += point_goals(points)
    goals.append(passes_goal(results))
    text, docs = report(args, results, points, goals,
                        f"{load_start} (start), {load_timed} (end)")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(text + "\n")
    print(text)
    print(f"wrote {args.output}")
    if not args.no_docs_table:
        write_docs_table("orbit-sweeps", "bench_orbit_sweeps.py",
                         f"{machine()}; load average {load_timed} at the end; CPU times, "
                         f"minimum of {args.repeats} rounds", docs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
