"""Run a study: the only module that crosses spec -> sweep -> store.

Chunks are fanned out over dask.distributed: by default an in-process local
cluster with one thread per core (the numba kernel releases the GIL), or any
cluster given by its scheduler address, unchanged. Each finished chunk is stored
as it arrives, so an interrupted run loses nothing and the next run resumes.
"""

from __future__ import annotations

import json
import os
import shlex
import sys
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from study.provenance import (
    code_sha256,
    environment,
    fingerprint,
    git_state,
    package_version,
    utc_now,
)
from study.spec import StudySpec, load_spec
from study.store import (
    RESULT_SCHEMA,
    ChunkStore,
    ResultError,
    assemble,
    build_dataset,
    open_result,
    write_atomic,
)
from study.sweep import compute_chunk, plan_chunks, solve

__all__ = ["RunReport", "StudyBusy", "StudyInterrupted", "is_up_to_date", "run_study"]


class StudyInterrupted(RuntimeError):
    """Raised when a run stops early on request (``stop_after``); chunks are kept."""


@dataclass(frozen=True)
class RunReport:
    """What a call to :func:`run_study` did."""

    output: Path
    up_to_date: bool
    chunks: int
    computed: int
    reused: int
    wall_seconds: float


def default_output(spec: StudySpec) -> Path:
    """``results/<spec file stem>.nc`` (what ``make`` and ``study list`` use), or
    ``results/<study name>.nc`` for a spec that did not come from a file."""
    source = Path(spec.path)
    stem = source.stem if source.suffix == ".toml" else spec.name
    return Path("results") / f"{stem}.nc"


def partial_folder(output: Path) -> Path:
    """Where the completed chunks of an unfinished run of ``output`` are kept."""
    return output.with_name(output.name + ".partial")


def is_up_to_date(spec: StudySpec, output: Path) -> bool:
    """Whether ``output`` is a valid result of this spec computed by this code."""
    try:
        dataset = open_result(output)
    except ResultError:
        return False
    return dataset.attrs.get("study_fingerprint") == fingerprint(spec.sha256)


@contextmanager
def _client(scheduler: str | None, workers: int | None):
    from distributed import Client, LocalCluster

    if scheduler is None:
        threads = workers or os.cpu_count() or 1
        # Threads, not processes: the kernel releases the GIL, and nothing is pickled.
        cluster = LocalCluster(n_workers=1, threads_per_worker=threads, processes=False,
                               dashboard_address=None)
        client = Client(cluster)
        try:
            yield client, "local", threads
        finally:
            client.close()
            cluster.close()
    else:
        client = Client(scheduler, timeout="30s")
        try:
            threads = sum(client.nthreads().values())
            yield client, scheduler, threads
        finally:
            client.close()


class _Progress:
    """A one-line text progress bar on stderr (only when it is a terminal or forced)."""

    def __init__(self, total: int, label: str, enabled: bool) -> None:
        self.total = max(total, 1)
        self.label = label
        self.enabled = enabled
        self.done = 0
        self.start = time.perf_counter()

    def advance(self) -> None:
        self.done += 1
        if not self.enabled:
            return
        fraction = self.done / self.total
        bar = "#" * int(30 * fraction)
        elapsed = time.perf_counter() - self.start
        sys.stderr.write(
            f"\r{self.label} [{bar:<30}] {self.done}/{self.total} chunks {elapsed:6.1f} s"
        )
        if self.done == self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def run_study(
    spec: StudySpec | str | Path,
    output: str | Path | None = None,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool | None = None,
    force: bool = False,
    stop_after: int | None = None,
    command: str | None = None,
    on_chunk: Callable[[int], None] | None = None,
) -> RunReport:
    """Run a study and write its result file.

    Parameters
    ----------
    spec : StudySpec or path
        The study (a spec file is read and validated first).
    output : path, optional
        Result file; default ``results/<spec file stem>.nc``.
    scheduler : str, optional
        Address of a dask.distributed scheduler; default: a local in-process cluster.
    workers : int, optional
        Threads of the local cluster (default: one per core).
    progress : bool, optional
        Show a progress bar (default: when stderr is a terminal).
    force : bool
        Recompute even if the result is up to date (stored chunks are still reused).
    stop_after : int, optional
        Stop with :class:`StudyInterrupted` after this many chunks were computed
        and stored in this run: the interrupted run a later run resumes.
    command : str, optional
        The command line recorded in the file's history.
    on_chunk : callable, optional
        Called with the chunk number each time a chunk is stored.

    Returns
    -------
    RunReport
    """
    started = time.perf_counter()
    started_utc = utc_now()
    if not isinstance(spec, StudySpec):
        spec = load_spec(spec)
    output = Path(output) if output is not None else default_output(spec)
    run_fingerprint = fingerprint(spec.sha256)
    chunks = plan_chunks(spec)
    if not force and is_up_to_date(spec, output):
        output.touch()  # tell make the target is current
        return RunReport(output, True, len(chunks), 0, len(chunks),
                         time.perf_counter() - started)

    output.parent.mkdir(parents=True, exist_ok=True)
    with exclusive(output):
        return _run_locked(spec, output, chunks, run_fingerprint, started, started_utc,
                           scheduler, workers, progress, stop_after, command, on_chunk)


def _frontier_arrays(spec: StudySpec, arrays: dict[str, Any]) -> dict[str, Any]:
    """Frontier f*(a) of every structure, refined on the solver, padded to one shape."""
    import numpy as np

    from study.analysis import frontier_from_grid

    f = spec.axis("f").values
    a = spec.axis("a").values
    found = {}
    for index, structure in spec.structures():
        found[index] = frontier_from_grid(
            structure, f, a, arrays["velocity"][index], arrays["status"][index],
            tolerance=spec.frontier_tolerance, settings=spec.solver,
            solve=lambda structure, f, a: solve(spec, structure, f, a),
        )
    branches = max(item.frequency.shape[1] for item in found.values())
    shape = (*(len(axis) for axis in spec.structure_axes), len(a), branches)
    out = {
        "frontier_frequency": np.full(shape, np.nan),
        "frontier_kind": np.zeros(shape, dtype=np.int8),
        "frontier_direction": np.zeros(shape, dtype=np.int8),
        "frontier_bracket": np.full(shape, np.nan),
    }
    for index, item in found.items():
        n = item.frequency.shape[1]
        out["frontier_frequency"][index][:, :n] = item.frequency
        out["frontier_kind"][index][:, :n] = item.kind
        out["frontier_direction"][index][:, :n] = item.direction
        out["frontier_bracket"][index][:, :n] = item.width
    return out


class StudyBusy(RuntimeError):
    """Another process is running the same study into the same file."""


@contextmanager
def exclusive(output: Path):
    """Hold an exclusive lock on ``output`` for the whole run (one writer per file)."""
    import fcntl

    lock_path = output.with_name(f".{output.name}.lock")
    with open(lock_path, "a+") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.seek(0)
            holder = lock.read().strip() or "another process"
            raise StudyBusy(
                f"{output}: another run is writing this result ({holder}); wait for it "
                "to finish, or stop it: its finished chunks will be reused"
            ) from None
        lock.seek(0)
        lock.truncate()
        lock.write(f"pid {os.getpid()}")
        lock.flush()
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _run_locked(spec, output, chunks, run_fingerprint, started, started_utc, scheduler,
                workers, progress, stop_after, command, on_chunk) -> RunReport:
    store = ChunkStore(partial_folder(output), run_fingerprint)
    command = command or "study.run_study(" + shlex.quote(spec.path) + ")"
    store.start_run(f"{started_utc}: {command} (study {package_version()})")
    done = store.completed()
    pending = [chunk for chunk in chunks if chunk.number not in done]
    reused = len(chunks) - len(pending)
    show = sys.stderr.isatty() if progress is None else progress
    bar = _Progress(len(pending), spec.name, show and bool(pending))
    computed = 0
    with _client(scheduler, workers) as (client, scheduler_name, threads):
        if pending:
            from distributed import as_completed

            futures = {
                client.submit(compute_chunk, spec, chunk, key=f"{spec.name}-chunk-"
                              f"{chunk.number}-{run_fingerprint[:12]}", pure=False): chunk
                for chunk in pending
            }
            try:
                for future in as_completed(futures):
                    chunk = futures[future]
                    store.save(chunk, future.result())
                    computed += 1
                    bar.advance()
                    if on_chunk is not None:
                        on_chunk(chunk.number)
                    if stop_after is not None and computed >= stop_after:
                        raise StudyInterrupted(
                            f"stopped after {computed} chunks on request; "
                            f"{len(pending) - computed} left, kept in {store.folder}"
                        )
            finally:
                client.cancel(list(futures))
        arrays = assemble(spec, chunks, store)
    if "frontier" in spec.observables:
        arrays.update(_frontier_arrays(spec, arrays))
    finished_utc = utc_now()
    wall = time.perf_counter() - started
    git = git_state()
    provenance: dict[str, Any] = {
        "result_schema": RESULT_SCHEMA,
        "study": {"name": spec.name, "spec_path": spec.path, "spec_sha256": spec.sha256,
                  "canonical_spec": spec.canonical},
        "code": {"code_sha256": code_sha256(), "fingerprint": run_fingerprint},
        "package": {"name": "study", "version": package_version(), **git},
        "environment": environment(),
        "run": {
            "started_utc": started_utc,
            "finished_utc": finished_utc,
            "wall_seconds": wall,
            "scheduler": scheduler_name,
            "workers": threads,
            "chunks": len(chunks),
            "chunks_computed": computed,
            "chunks_reused": reused,
            "solver_settings": {
                **spec.canonical["solver"],
                "chunk_points": spec.chunk_points,
            },
            "host": environment()["host"],
        },
    }
    attrs = {
        "history": "\n".join(store.history),
        "date_created": finished_utc,
        "date_modified": finished_utc,
        "product_version": package_version(),
        "study_version": package_version(),
        "study_code_sha256": code_sha256(),
        "study_fingerprint": run_fingerprint,
        "git_commit": str(git["git_commit"]),
        "git_dirty": str(git["git_dirty"]).lower(),
        "provenance": json.dumps(provenance, sort_keys=True),
    }
    dataset = build_dataset(spec, arrays, attrs)
    write_atomic(dataset, output)
    store.remove()
    return RunReport(output, False, len(chunks), computed, reused, wall)
