"""The parameter-study kind: a spec's sweep computed chunk by chunk into its file.

Registers the ``study`` kind (:mod:`study.engine.kinds`): its spec parser
(:mod:`study.studies.spec`), its computation, which streams (the grid is planned
in chunks, looked up in the cache of kept values, the missing points cut into work
units of about a second (:func:`study.studies.sweep.cut_unit`) and sent to the
executor; each unit's values go into the cache as it arrives, and each chunk into the
result file once its units are all back; memory holds a bounded number of chunks,
never the study), its validator (:mod:`study.studies.checks`) and its description. The
runner (:mod:`study.engine.runner`) decides whether to run at all, holds the lock and
commits the file; this module is what a run of a study does once it runs.
"""

from __future__ import annotations

import hashlib
import json
import os
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from study.engine.cache import ResultCache
from study.engine.cache_format import encode_block, entry_key
from study.engine.compiling import compile_notices
from study.engine.executors import TASK_TIMEOUT, Executor, executor
from study.engine.interrupts import RunInterrupted, stop_requests
from study.engine.kinds import ResultKind, register
from study.engine.progress import Progress
from study.engine.provenance import (
    code_sha256,
    environment,
    fingerprint,
    git_state,
    package_version,
    utc_now,
)
from study.engine.runner import RunJob, RunReport, StudyInterrupted
from study.engine.store import (
    PAPER_REFERENCE,
    RESULT_SCHEMA,
    GridWriter,
    StoreError,
    advice,
    new_temporary,
)
from study.model.structure import Structure
from study.solvers.fold_curves import HOPS, SIDES, fold_curve_work
from study.solvers.frontier import frontier_branches, frontier_work
from study.studies.layout import (
    coordinates,
    curve_observable,
    data_variables,
    direction_methods,
    method_attributes,
    method_of,
    observables_by_grid,
    pad_branches,
    plan_study,
    study_summary,
)
from study.studies.observables import CurveWork, Observable
from study.studies.spec import StudySpec, load_spec, parse_spec
from study.studies.spec_types import SPEC_SCHEMA
from study.studies.sweep import (
    Chunk,
    Task,
    UnitSizer,
    compute_task,
    cut_unit,
    missing_rectangles,
    unit_grain,
)
from study.studies.variables import GRIDS, RESULT_FORMAT, STUDY_FORMATS, VARIABLES

__all__ = ["STUDY_KIND", "default_cache", "stream_study"]


def _metadata_attrs(spec: StudySpec) -> dict[str, Any]:
    """Attributes that follow the spec's text but not its numbers."""
    return {
        "title": spec.title,
        "summary": study_summary(spec),
        "id": f"{spec.name}-{spec.sha256[:16]}",
        "study_name": spec.name,
        "study_spec": spec.text,
        "study_spec_path": spec.path,
    }


def default_cache(output: Path) -> Path:
    """Where kept values live: ``$STUDY_CACHE``, else ``.study-cache`` beside the result
    (so every study writing into one folder shares them)."""
    return Path(os.environ.get("STUDY_CACHE") or output.parent / ".study-cache")


def stream_study(spec: StudySpec, job: RunJob) -> RunReport:
    """Compute a study into a temporary file and commit it (the runner holds the lock).

    ``job.options`` are :func:`study.engine.runner.run_study`'s: ``scheduler``,
    ``workers``, ``progress``, ``stop_after``, ``on_chunk``, ``cache``, ``on_start``,
    ``task_timeout``.
    """
    options = job.options
    cache = options.get("cache")
    kept = ResultCache(Path(cache) if cache is not None else default_cache(job.output))
    computing = _Run(spec, job, kept)
    try:
        # Shared with other runs; cache maintenance (prune, verify) waits for it.
        with kept.session(f"study run -> {job.output}", on_wait=kept.warn):
            return computing.execute(
                options.get("scheduler"), options.get("workers"), options.get("progress"),
                options.get("stop_after"), options.get("on_start"),
                options.get("task_timeout", TASK_TIMEOUT))
    except StoreError as err:
        if not computing.points_kept:
            raise
        raise StoreError(f"{err}; the {computing.points_kept} points computed are "
                         f"kept in {computing.cache.root} for the next run") from None


def whole_runs(missing: np.ndarray, along: str) -> np.ndarray:
    """A slow sweep's missing points widened to their whole runs: a point's value
    depends on the points before it on its run, so a run is computed whole or not at
    all (along a: every a of a row of f; along f: every f of a column of a)."""
    if along == "a":
        return np.broadcast_to(missing.any(axis=1, keepdims=True), missing.shape).copy()
    return np.broadcast_to(missing.any(axis=0, keepdims=True), missing.shape).copy()


def _structure_content(structure: Structure) -> dict[str, float]:
    return {name: float(getattr(structure, name)) for name in Structure.__dataclass_fields__}


def _creator() -> str:
    """Who ran the study: $STUDY_CREATOR, else the login name."""
    import getpass

    try:
        return os.environ.get("STUDY_CREATOR") or getpass.getuser()
    except (KeyError, OSError):
        return "unknown"


def _standard_attrs(spec: StudySpec) -> dict[str, Any]:
    return {
        "Conventions": "CF-1.11, ACDD-1.3",
        **_metadata_attrs(spec),
        "keywords": "stick-slip, friction, locomotion, resonance, vibration, parameter study",
        "naming_authority": "study",
        **method_attributes(spec),
        "processing_level": "model output",
        "references": PAPER_REFERENCE,
        "standard_name_vocabulary": "CF Standard Name Table v85",
        "comment": "Forces per unit total mass in the table frame; SI units. No CF standard "
        "names exist for these model quantities, so variables carry long_name only.",
        "acknowledgement": "Model of " + PAPER_REFERENCE,
        "creator_name": _creator(),
        "study_result_schema": RESULT_SCHEMA,
        "study_result_format": RESULT_FORMAT,
        "study_spec_sha256": spec.sha256,
    }


@dataclass(frozen=True)
class _Job:
    """A work unit and the cache entries its computed values go to: what a worker gets.

    The unit is a :class:`~study.studies.sweep.Task` of one chunk holding one piece of
    its missing points (or none: a chunk's closed-form rows alone); the chunk's first
    unit carries its rows."""

    task: Task
    #: (entry key, variable names) of each solver observable the task computes.
    entries: tuple[tuple[str, tuple[str, ...]], ...]


def _compute_and_encode(job: _Job) -> tuple[dict[str, np.ndarray], list[dict[str, Any]],
                                            list[list[bytes]], float]:
    """Compute a work unit and encode its values as cache blocks, on the worker:
    compression and checksums run beside the solver, in parallel, not on the one thread
    that writes the file (and a remote worker sends compressed blocks).

    Returns
    -------
    rows, rectangles
        As :func:`study.studies.sweep.compute_task`.
    blocks : list of list of bytes
        For each rectangle, one encoded block per entry of ``job.entries``.
    seconds : float
        Computing time of the unit [s] (what the next units are sized by).
    """
    began = time.perf_counter()
    rows, rectangles = compute_task(job.task)
    seconds = time.perf_counter() - began
    task = job.task
    blocks = [
        [encode_block(key, task.f[rectangle.rows], task.a[rectangle.columns],
                      {v: computed[v] for v in variables})
         for key, variables in job.entries]
        for rectangle, computed in zip(task.rectangles, rectangles, strict=True)
    ]
    return rows, rectangles, blocks, seconds


@dataclass
class _OpenChunk:
    """A chunk whose work units are out: the values found kept, filled in by its units
    as they come back, and written into the file once the last is back."""

    #: The chunk's whole task (every missing rectangle).
    task: Task
    found: dict[str, tuple[dict[str, np.ndarray], np.ndarray]]
    rows: dict[str, np.ndarray] = field(default_factory=dict)
    #: Units handed out and not back yet.
    out: int = 0
    #: Every unit of the chunk is handed out.
    cut: bool = False


def _gather_provenance(found: dict[str, Any]) -> None:
    """Fill the caches of :func:`git_state` and :func:`environment`; the package
    version (read from its metadata) goes into ``found``."""
    git_state()
    environment()
    found["version"] = package_version()


class _Run:
    """One computing run of a study into a temporary file, committed at the end."""

    def __init__(self, spec: StudySpec, job: RunJob, cache: ResultCache):
        self.spec = spec
        self.job = job
        self.output = job.output
        self.started = job.started
        self.started_utc = job.started_utc
        self.command = job.command
        self.cache = cache
        self.on_chunk: Callable[[int], None] | None = job.options.get("on_chunk")
        self.method = method_of(spec)
        #: The method of each direction of a slow sweep both ways (a chunk's
        #: ``direction`` indexes it); else the study's method alone.
        self.methods = direction_methods(spec)
        self.rows, self.points, self.frontier = observables_by_grid(spec)
        #: The fold curves, continued after the map (and the frontier), if asked for.
        self.curves = curve_observable(spec)
        self.f = spec.axis("f").values
        a_axis = spec.axis("a")
        self.a = a_axis.values if (a_axis is not None and spec.needs_solver) else np.empty(0)
        self.chunks = plan_study(spec)
        #: Every structure of the study by its index: the spec is read once, here.
        self.structures = dict(spec.structures())
        self.code = code_sha256()
        self.points_computed = 0
        self.points_reused = 0
        #: Computed points kept in the cache (all of them unless it cannot be written).
        self.points_kept = 0
        self.keeping = True
        self.chunks_computed = 0
        self.chunks_reused = 0
        self._keys: dict[tuple[tuple[int, ...], str], tuple[str, dict[str, Any]]] = {}

    # -- cache keys --------------------------------------------------------------

    def key(self, structure_index: tuple[int, ...], observable: Observable,
            direction: int = 0) -> tuple[str, dict[str, Any]]:
        """Cache key and content of an observable's values for one structure (in one
        direction of a slow sweep both ways: each direction's values are those of a
        sweep that way alone, and shared with it)."""
        if observable.unswept:
            # Each point from its start alone: the same both ways, kept under the key
            # of the study's method without its protocol (and no swept values).
            direction = -1
        item = (structure_index, observable.name, direction)
        if item not in self._keys:
            method = (replace(self.method, protocol=None) if observable.unswept
                      else self.methods[direction])
            content = {
                "observable": observable.name,
                "variables": {v: VARIABLES[v].dtype for v in observable.variables},
                "structure": _structure_content(self.structures[structure_index]),
                "method": method.canonical(),
                "code_sha256": self.code,
            }
            if observable.settings is not None:
                # What its values depend on beyond the method (the basins' [basins]):
                # only in its own key, so that every other key stays as it was.
                content.update(observable.settings(method))
            if method.protocol is not None:
                # A point of a slow sweep depends on every value its run visits before
                # it: a changed swept axis changes every run, and no value is lent to
                # another run (only when a protocol is given: other keys are kept).
                along = method.protocol[0]
                content["swept"] = {along: (self.f if along == "f" else self.a).tolist()}
            self._keys[item] = (entry_key(content), content)
        return self._keys[item]

    # -- the file ------------------------------------------------------------------

    def _open(self, path: Path) -> GridWriter:
        spec = self.spec
        writer = GridWriter(path, _standard_attrs(spec), self.output)
        scalars = []
        for coordinate in coordinates(spec):
            writer.coordinate(coordinate.name, coordinate.dims, coordinate.values,
                              coordinate.attrs)
            if coordinate.auxiliary:
                scalars.append(coordinate.name)
        self.auxiliary = " ".join(scalars)
        block = max(chunk.size for chunk in self.chunks)
        ones = (1,) * len(spec.structure_axes)
        sizes = spec.dimension_sizes
        for variable in data_variables(spec, (*self.rows, *self.points)):
            trailing = VARIABLES[variable.name].trailing(sizes)
            chunks = (*ones, block) if variable.grid == "row" else (
                *(1,) * (len(variable.dims) - len(ones) - 2 - len(trailing)),
                *ones, block, max(self.a.size, 1), *trailing)
            writer.variable(variable.name, variable.dims, variable.dtype,
                            {**variable.attrs, "coordinates": self.auxiliary}, chunks)
        return writer

    # -- the work --------------------------------------------------------------------

    def _jobs(self, pending: dict[int, _OpenChunk]) -> Iterator[_Job]:
        """Look each chunk up in the cache; yield the work units of what needs
        computing, each sized when it is drawn (:class:`study.studies.sweep.UnitSizer`).
        Chunks found whole are written at once (``pending`` keeps a chunk's values until
        its last unit is back)."""
        for chunk in self.chunks:
            structure = self.structures[chunk.structure_index]
            f = self.f[chunk.f_start:chunk.f_stop]
            found: dict[str, tuple[dict[str, np.ndarray], np.ndarray]] = {}
            missing = np.zeros((f.size, self.a.size), dtype=bool)
            for observable in self._points(chunk):
                key, _ = self.key(chunk.structure_index, observable, chunk.direction)
                dtypes = {v: np.dtype(VARIABLES[v].dtype) for v in observable.variables}
                trailing = {v: VARIABLES[v].trailing(self.spec.dimension_sizes)
                            for v in observable.variables}
                values, present = self.cache.lookup(key, f, self.a, dtypes, trailing)
                found[observable.name] = (values, present)
                missing |= ~present
            if self.method.protocol is not None:
                missing = whole_runs(missing, self.method.protocol[0])
            rectangles = missing_rectangles(missing) if self.points else ()
            needed = tuple(o.name for o in self._points(chunk)
                           if not found[o.name][1].all())
            # Rows are the same both ways: written by the first direction's chunk.
            rows = tuple(o.name for o in self.rows) if chunk.direction == 0 else ()
            task = Task(chunk, structure, f, self.a, rows, needed, rectangles,
                        self.methods[chunk.direction])
            if self.points:
                reused = chunk.size * self.a.size - task.point_count
                self.points_reused += reused
                if reused:
                    self.progress.update(reused, 0)
            opened = _OpenChunk(task, found)
            if not rectangles and not rows:
                self._write_chunk(opened)
                continue
            pending[chunk.number] = opened
            entries = tuple((self.key(chunk.structure_index, observable, chunk.direction)[0],
                             observable.variables)
                            for observable in self._points(chunk)
                            if observable.name in needed)
            if not rectangles:  # the closed-form rows alone
                opened.out, opened.cut = 1, True
                yield _Job(task, entries)
                continue
            left = list(rectangles)
            first = True
            while left:
                rectangle = left.pop(0)
                piece, rest = cut_unit(rectangle, unit_grain(task.method, rectangle),
                                       self.sizer.points())
                left[:0] = rest
                opened.out += 1
                opened.cut = not left
                yield _Job(replace(task, rows=rows if first else (), rectangles=(piece,)),
                           entries)
                first = False

    def _points(self, chunk: Chunk) -> tuple[Observable, ...]:
        """The solver observables a chunk computes and writes: with a slow sweep both
        ways, those of each point from its start alone (:attr:`Observable.unswept`) with
        the first direction only, as the rows."""
        if chunk.direction == 0:
            return self.points
        return tuple(o for o in self.points if not o.unswept)

    def _unit_done(self, job: _Job, result: tuple[dict[str, np.ndarray],
                                                  list[dict[str, Any]], list[list[bytes]],
                                                  float],
                   pending: dict[int, _OpenChunk]) -> _OpenChunk | None:
        """Keep a work unit's values (encoded by the worker) in the cache at once and
        put them into its chunk; the chunk, if this was its last unit (it is then
        written into the file), else None."""
        task = job.task
        chunk = task.chunk
        opened = pending[chunk.number]
        rows, blocks, encoded, seconds = result
        opened.rows.update(rows)
        stored = [o for o in self._points(chunk) if o.name in task.points]
        for rectangle, datas in zip(task.rectangles, encoded, strict=True):
            for observable, data in zip(stored, datas, strict=True):
                key, content = self.key(chunk.structure_index, observable, chunk.direction)
                self._keep(key, content, task.a[rectangle.columns], data)
        for observable in self._points(chunk):
            values, _ = opened.found[observable.name]
            for rectangle, computed in zip(task.rectangles, blocks, strict=True):
                for name in observable.variables:
                    if name in computed:
                        values[name][np.ix_(rectangle.rows, rectangle.columns)] = computed[name]
        computed_points = task.point_count if self.points else chunk.size * max(
            self.a.size, 1)
        self.points_computed += computed_points
        if self.points:
            if self.keeping:
                self.points_kept += computed_points
            self.sizer.measured(computed_points, seconds)
        if computed_points:
            self.progress.update(computed_points, computed_points)
        opened.out -= 1
        if not (opened.cut and opened.out == 0):
            return None
        del pending[chunk.number]
        self._write_chunk(opened)
        return opened

    def _write_chunk(self, opened: _OpenChunk) -> None:
        """Write one chunk, its values all found or computed, into the file."""
        task = opened.task
        chunk = task.chunk
        where_rows = (*chunk.structure_index, slice(chunk.f_start, chunk.f_stop))
        for name, values in opened.rows.items():
            self.writer.write(name, where_rows, values)
        swept_where = ((chunk.direction,) if self.spec.both_directions else ()) + (
            *where_rows, slice(None))
        for observable in self._points(chunk):
            where_points = (*where_rows, slice(None)) if observable.unswept else swept_where
            values, _ = opened.found[observable.name]
            for name in observable.variables:
                self.writer.write(name, where_points, values[name])
        if task.point_count if self.points else chunk.size:
            self.chunks_computed += 1
        else:
            self.chunks_reused += 1

    def _keep(self, key: str, content: dict[str, Any], a: np.ndarray, block: bytes) -> None:
        """Keep a computed block; a cache that cannot be written (disk full, read-only)
        is said once and the run goes on without keeping values: the result matters
        more than its reuse."""
        if not self.keeping:
            return
        try:
            self.cache.store_encoded(key, content, a, block)
        except OSError as err:
            self.keeping = False
            what_to_do = advice(err).replace("(-o)", "(--cache)")
            self.cache.warn(
                f"{self.cache.root}: cannot keep computed values ({err.strerror or err}); "
                "the run goes on without keeping them" + (f": {what_to_do}" if what_to_do
                                                          else ""))

    def _say_stopping(self) -> None:
        """Ctrl-C came: the run finishes the units running, to keep them."""
        self.progress.say("stopping: finishing the work running to keep it (about a "
                          "second; longer while the solver kernels compile); Ctrl-C again "
                          "to stop at once")

    def interrupted(self) -> RunInterrupted:
        """The error that ends an interrupted run: what it kept, in one line for people
        (every point computed was kept as its unit came back, unless the cache could not
        be written)."""
        total = self._total()
        kept = self.points_kept + self.points_reused
        where = f" in {self.cache.root}" if kept else ""
        lost = ("" if self.keeping or not self.points_computed else
                f"; the cache could not keep the {self.points_computed - self.points_kept} "
                "others computed")
        return RunInterrupted(
            f"interrupted; kept {kept} of {total} points ({self.points_kept} computed in "
            f"this run){where}{lost}; run again to resume", kept, total, self.points_kept)

    def execute(self, scheduler: str | None, workers: int | None, progress: bool | None,
                stop_after: int | None, on_start: Callable[[Executor], None] | None,
                task_timeout: float = TASK_TIMEOUT) -> RunReport:
        try:
            return self._execute(scheduler, workers, progress, stop_after, on_start,
                                 task_timeout)
        except (RunInterrupted, StudyInterrupted):
            raise
        except KeyboardInterrupt:
            # A second Ctrl-C, or one outside the computing phases (the values computed
            # are kept all the same: each was kept as its unit came back).
            raise self.interrupted() from None

    def _total(self) -> int:
        """Drive points of the study, in each direction of a slow sweep both ways."""
        return len(self.f) * max(self.a.size, 1) * int(np.prod(
            [len(axis) for axis in self.spec.structure_axes], dtype=np.int64)) * len(
            self.methods)

    def _execute(self, scheduler: str | None, workers: int | None, progress: bool | None,
                 stop_after: int | None, on_start: Callable[[Executor], None] | None,
                 task_timeout: float) -> RunReport:
        self.cache.clean_temporaries()
        # What the provenance records of the checkout and the machine (a git
        # subprocess, package metadata) does not depend on the run: gathered while the
        # workers compute, not after the last chunk, when nothing overlaps it.
        self.gathered: dict[str, Any] = {}
        gathering = threading.Thread(target=_gather_provenance, args=(self.gathered,),
                                     daemon=True)
        gathering.start()
        temporary = new_temporary(self.output)
        self.sizer = UnitSizer()
        try:
            self.writer = self._open(temporary)
            # "done" is said only of the whole run: the map is one phase of it.
            then = ("frontier next" if self.frontier is not None else
                    "fold curves next" if self.curves is not None else "sealing the file")
            self.progress = Progress(self._total(), self.spec.name, progress,
                                     finished=f"map done; {then}")
            pending: dict[int, _OpenChunk] = {}
            computed_chunks = 0
            with stop_requests(on_request=self._say_stopping) as stop:
                try:
                    with ExitStack() as running:
                        pool = running.enter_context(executor(
                            scheduler, workers, self.code, task_timeout=task_timeout))
                        running.enter_context(self.progress.running())
                        running.enter_context(compile_notices(self.progress))
                        self.scheduler_name, self.threads = pool.name, pool.threads
                        if on_start is not None:
                            on_start(pool)
                        for job, result in pool.run_unordered(
                                _compute_and_encode, self._jobs(pending),
                                label=self.spec.name, stop=stop):
                            opened = self._unit_done(job, result, pending)
                            if opened is None or not opened.task.rectangles:
                                continue
                            computed_chunks += 1
                            if self.on_chunk is not None:
                                self.on_chunk(opened.task.chunk.number)
                            if stop_after is not None and computed_chunks >= stop_after:
                                kept = (f"their values are kept in {self.cache.root}"
                                        if self.keeping else "the cache could not keep them")
                                raise StudyInterrupted(
                                    f"stopped after {computed_chunks} computed chunks on "
                                    f"request; {kept}")
                finally:
                    self.progress.close()
                if stop.is_set():
                    raise self.interrupted()
                if self.frontier is not None:
                    self._write_frontier(progress, stop)
                if self.curves is not None:
                    self._write_curves(progress, stop)
            gathering.join()
            self.writer.set_attributes(self._provenance_attrs())
            self.writer.close()
        except BaseException:
            if hasattr(self, "writer"):
                self.writer.discard()  # never raises: the first failure is reported
            temporary.unlink(missing_ok=True)
            raise
        self.job.commit(temporary)
        return RunReport(
            self.output, False, len(self.chunks), self.chunks_computed, self.chunks_reused,
            time.perf_counter() - self.started, self.points_computed + self.points_reused,
            self.points_computed, self.points_reused,
        )

    def _write_frontier(self, progress: bool | None, stop: threading.Event) -> None:
        """Frontier f*(a) of every structure from its whole velocity rows, with its own
        progress (the points its bisections solve, counted beforehand). A structure's
        frontier is kept once it is found; a stop request (Ctrl-C) ends the phase
        after the bisection step running."""
        spec = self.spec
        rows = {}
        for index in self.structures:
            where = (*index, slice(None), slice(None))
            rows[index] = (self.writer.read("velocity", where),
                           self.writer.read("status", where))
        work = {index: frontier_work(self.f, velocity, status, spec.frontier_tolerance)
                for index, (velocity, status) in rows.items()}
        shown = Progress(sum(work.values()), f"{spec.name} frontier", progress, unit="solve",
                         finished="frontier done; sealing the file")

        def advance(solves: int) -> None:
            shown.update(solves)
            if stop.is_set():
                raise KeyboardInterrupt  # what the frontier found so far is kept

        found = {}
        reused = 0
        try:
            with shown.running(), compile_notices(shown):
                for index, structure in self.structures.items():
                    if stop.is_set():
                        raise KeyboardInterrupt
                    velocity, status = rows[index]
                    key, content = self._frontier_key(index, velocity, status)
                    slots = np.arange(frontier_branches(velocity, status), dtype=np.float64)
                    kept = self._kept_frontier(key, slots)
                    if kept is not None:
                        found[index] = kept
                        reused += 1
                        shown.update(work[index], 0)
                        continue
                    found[index] = self.frontier.compute(
                        structure, self.f, self.a, velocity, status, self.method,
                        spec.frontier_tolerance, progress=advance)
                    self._keep_frontier(key, content, slots, found[index])
            if reused:
                shown.say(f"frontier of {reused} of {len(self.structures)} structures "
                          "reused from the cache (same map, solver and tolerance)")
        finally:
            shown.close()
        branches = max(1, *(item["frontier_frequency"].shape[1] for item in found.values()))
        self.writer.dimension("branch", branches)
        ones = (1,) * len(spec.structure_axes)
        variables = data_variables(spec, (self.frontier,))
        for variable in variables:
            self.writer.variable(variable.name, variable.dims, variable.dtype,
                                 {**variable.attrs, "coordinates": self.auxiliary},
                                 (*ones, self.a.size, branches))
        for index, item in found.items():
            for variable in variables:
                self.writer.write(variable.name, (*index, slice(None), slice(None)),
                                  pad_branches(item[variable.name], branches, variable.dtype))

    def _frontier_key(self, index: tuple[int, ...], velocity: np.ndarray,
                      status: np.ndarray) -> tuple[str, dict[str, Any]]:
        """Cache key of a structure's frontier: it follows from its velocity map (the
        brackets), the solver that refines them and the tolerance, so a frontier is
        kept like points and found again by a rerun onto any output or with force."""
        velocity = np.ascontiguousarray(velocity, dtype=np.float64)
        status = np.ascontiguousarray(status)
        content = {
            "observable": self.frontier.name,
            "variables": {v: VARIABLES[v].dtype for v in self.frontier.variables},
            "structure": _structure_content(self.structures[index]),
            "method": self.method.canonical(),
            "code_sha256": self.code,
            "tolerance": float(self.spec.frontier_tolerance),
            "f_sha256": hashlib.sha256(np.ascontiguousarray(self.f).tobytes()).hexdigest(),
            "map_sha256": hashlib.sha256(velocity.tobytes() + status.tobytes()
                                         + str(status.dtype).encode()).hexdigest(),
        }
        return entry_key(content), content

    def _kept_frontier(self, key: str, slots: np.ndarray) -> dict[str, np.ndarray] | None:
        """A structure's frontier kept by an earlier run (its branches stored as the
        rows of a block over the accelerations), or None."""
        if self.a.size == 0:
            return None
        dtypes = {v: np.dtype(VARIABLES[v].dtype) for v in self.frontier.variables}
        values, present = self.cache.lookup(key, slots, self.a, dtypes)
        if not present.all():
            return None
        return {name: np.ascontiguousarray(array.T) for name, array in values.items()}

    def _keep_frontier(self, key: str, content: dict[str, Any], slots: np.ndarray,
                       found: dict[str, np.ndarray]) -> None:
        if self.a.size == 0 or not self.keeping:
            return
        arrays = {name: np.ascontiguousarray(found[name].T) for name in self.frontier.variables}
        self._keep(key, content, self.a, encode_block(key, slots, self.a, arrays))

    def _write_curves(self, progress: bool | None, stop: threading.Event) -> None:
        """The fold curves of every structure (:mod:`study.solvers.fold_curves`: slow
        sweeps along the study's f, each hop's fold continued over its a, and the
        forward hop's period doubling), each variable over its declared grid, with their
        own progress. A structure's curves are kept once found, under a key of what
        they follow from (the structure, the solver, the f and a axes, not the map); a
        stop request (Ctrl-C) ends the phase after the step running."""
        spec = self.spec
        work = fold_curve_work(self.a)
        shown = Progress(work * len(self.structures), f"{spec.name} fold curves", progress,
                         unit="step", finished="fold curves done; sealing the file")

        def advance(steps: int) -> None:
            shown.update(steps)
            if stop.is_set():
                raise KeyboardInterrupt  # the curves of the structures done are kept

        found = {}
        reused = 0
        try:
            with shown.running(), compile_notices(shown):
                for index, structure in self.structures.items():
                    if stop.is_set():
                        raise KeyboardInterrupt
                    keys = self._curve_keys(index)
                    kept = self._kept_curves(keys)
                    if kept is not None:
                        found[index] = kept
                        reused += 1
                        shown.update(work, 0)
                        continue
                    found[index] = self.curves.compute(
                        CurveWork(structure, self.f, self.a, self.method), progress=advance)
                    self._keep_curves(keys, found[index])
            if reused:
                shown.say(f"fold curves of {reused} of {len(self.structures)} structures "
                          "reused from the cache (same structure, solver and axes)")
        finally:
            shown.close()
        ones = (1,) * len(spec.structure_axes)
        sizes = {"hop": len(HOPS), "a": self.a.size, "curve_end": len(SIDES)}
        for variable in data_variables(spec, (self.curves,)):
            grid = GRIDS[VARIABLES[variable.name].grid]
            self.writer.variable(variable.name, variable.dims, variable.dtype,
                                 {**variable.attrs, "coordinates": self.auxiliary},
                                 (*ones, *(sizes[d] for d in grid)))
        for index, item in found.items():
            for variable in data_variables(spec, (self.curves,)):
                value = item[variable.name]
                self.writer.write(variable.name, (*index, *(slice(None),) * value.ndim),
                                  value)

    def _curve_keys(self, index: tuple[int, ...]
                    ) -> dict[str, tuple[str, dict[str, Any], np.ndarray]]:
        """For each part of a structure's fold curves (over ``(hop, a)``, over
        ``(hop, curve_end)`` and over ``a``): its cache key, content and the block's
        columns. The
        curves follow from the structure, the solver (not the protocol: they sweep on
        their own) and the f and a axes, not from the map."""
        method = replace(self.method, protocol=None).canonical()
        keys = {}
        for part, (_, columns) in self._curve_parts().items():
            names = [v for v in self.curves.variables if VARIABLES[v].grid == part]
            content = {
                "observable": self.curves.name,
                "part": part,
                "variables": {v: VARIABLES[v].dtype for v in names},
                "structure": _structure_content(self.structures[index]),
                "method": method,
                "code_sha256": self.code,
                "f_sha256": hashlib.sha256(np.ascontiguousarray(self.f).tobytes()).hexdigest(),
                "a_sha256": hashlib.sha256(np.ascontiguousarray(self.a).tobytes()).hexdigest(),
            }
            keys[part] = (entry_key(content), content, columns)
        return keys

    def _kept_curves(self, keys: dict[str, tuple[str, dict[str, Any], np.ndarray]]
                     ) -> dict[str, np.ndarray] | None:
        """A structure's fold curves kept by an earlier run (the hops the rows of each
        block), or None."""
        parts = self._curve_parts()
        found: dict[str, np.ndarray] = {}
        for part, (key, _, columns) in keys.items():
            slots = parts[part][0]
            dtypes = {v: np.dtype(VARIABLES[v].dtype) for v in self.curves.variables
                      if VARIABLES[v].grid == part}
            values, present = self.cache.lookup(key, slots, columns, dtypes)
            if not present.all():
                return None
            # A block's rows are its slots: one row for a grid without hops.
            found.update({v: value if part != "doubling" else value[0]
                          for v, value in values.items()})
        return found

    def _keep_curves(self, keys: dict[str, tuple[str, dict[str, Any], np.ndarray]],
                     found: dict[str, np.ndarray]) -> None:
        if not self.keeping:
            return
        parts = self._curve_parts()
        for part, (key, content, columns) in keys.items():
            slots = parts[part][0]
            arrays = {v: np.ascontiguousarray(found[v]).reshape(slots.size, columns.size)
                      for v in self.curves.variables if VARIABLES[v].grid == part}
            self._keep(key, content, columns, encode_block(key, slots, columns, arrays))

    def _curve_parts(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Each grid the curves observable writes (:data:`~study.studies.variables.
        GRIDS`): the rows (slots) and columns of its kept block, the hops by the
        accelerations (``curve``) or by the curve's ends (``curve_end``), or one row
        by the accelerations (``doubling``)."""
        hops = np.arange(len(HOPS), dtype=np.float64)
        parts = {"curve": (hops, self.a),
                 "curve_end": (hops, np.arange(len(SIDES), dtype=np.float64)),
                 "doubling": (np.zeros(1), self.a)}
        grids = {VARIABLES[v].grid for v in self.curves.variables}
        return {part: value for part, value in parts.items() if part in grids}

    def _provenance_attrs(self) -> dict[str, Any]:
        spec = self.spec
        finished_utc = utc_now()
        git = git_state()
        run_fingerprint = fingerprint(spec.sha256, self.code)
        version = self.gathered.get("version") or package_version()
        provenance: dict[str, Any] = {
            "result_schema": RESULT_SCHEMA,
            "study": {"name": spec.name, "spec_path": spec.path, "spec_sha256": spec.sha256,
                      "canonical_spec": spec.canonical},
            "code": {"code_sha256": self.code, "fingerprint": run_fingerprint},
            "package": {"name": "study", "version": version, **git},
            "environment": environment(),
            "run": {
                "started_utc": self.started_utc,
                "finished_utc": finished_utc,
                "wall_seconds": time.perf_counter() - self.started,
                "scheduler": self.scheduler_name,
                "workers": self.threads,
                "chunks": len(self.chunks),
                "chunks_computed": self.chunks_computed,
                "chunks_reused": self.chunks_reused,
                "points": self.points_computed + self.points_reused,
                "points_computed": self.points_computed,
                "points_reused": self.points_reused,
                "cache": str(self.cache.root),
                "solver_settings": {**spec.canonical["solver"],
                                    "chunk_points": spec.chunk_points},
                "host": environment()["host"],
            },
        }
        return {
            "history": f"{self.started_utc}: {self.command} (study {version})",
            "date_created": finished_utc,
            "date_modified": finished_utc,
            "product_version": version,
            "study_version": version,
            "study_code_sha256": self.code,
            "study_fingerprint": run_fingerprint,
            "git_commit": str(git["git_commit"]),
            "git_dirty": str(git["git_dirty"]).lower(),
            "provenance": json.dumps(provenance, sort_keys=True),
        }


def _study_chunks(spec: StudySpec) -> int:
    return len(plan_study(spec))


#: The parameter-study kind.
STUDY_KIND = register(ResultKind(
    name="study", spec_table="study", spec_schema=SPEC_SCHEMA, result_schema=RESULT_SCHEMA,
    entry_modules=("study.studies.sweep", "study.solvers.frontier", "study.studies.spec"),
    summary="parameter study: observables over swept structure and drive parameters",
    label="study result", spec_type=StudySpec, load=load_spec, parse=parse_spec,
    validator="study.studies.checks:study_problems",
    stream=stream_study, metadata=_metadata_attrs, size=_study_chunks, formats=STUDY_FORMATS,
))
