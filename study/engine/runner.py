"""The one runner: every kind of result is run, locked, written and recorded here.

A run of any kind (:mod:`study.engine.kinds`) goes down one path: read the spec
(the kind's parser), decide from the file's attributes alone whether it is current
(same spec numbers and code: nothing is computed; only the spec's text changed: the
metadata is rewritten), take the output's lock, compute (the kind's computation and
dataset builder, or its own streaming writer: a study writes chunk by chunk, see
:mod:`study.studies.kind`), add the provenance and write the file atomically
through :mod:`study.engine.store` (sealed with its content checksum and validated
before it replaces the output). The runner never branches on a kind: it calls the
kind's hooks.
"""

from __future__ import annotations

import json
import os
import shlex
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from study.engine.compiling import compile_notices
from study.engine.executors import TASK_TIMEOUT, Executor
from study.engine.interrupts import RunInterrupted
from study.engine.kinds import ResultKind, kind_named, kind_of_spec
from study.engine.outputs import OutputError, check_output
from study.engine.progress import Progress
from study.engine.provenance import (
    environment,
    fingerprint,
    git_state,
    kind_code_sha256,
    package_version,
    utc_now,
)
from study.engine.spec_files import detect_kind
from study.engine.store import (
    PAPER_REFERENCE,
    StoreBusy,
    clean_temporaries,
    commit,
    exclusive,
    file_attributes,
    rewrite_attributes,
    write_atomic,
)
from study.engine.validation.formats import newer_release_advice
from study.engine.validation.reading import ResultError

__all__ = [
    "PAPER_REFERENCE",
    "RunInterrupted",
    "RunJob",
    "RunReport",
    "StudyBusy",
    "StudyInterrupted",
    "default_output",
    "is_up_to_date",
    "load_any",
    "run",
    "run_scene",
    "run_study",
]

StudyBusy = StoreBusy


class StudyInterrupted(RuntimeError):
    """Raised when a run stops early on request (``stop_after``); values are kept."""


@dataclass(frozen=True)
class RunReport:
    """What a call to :func:`run_study` did.

    Attributes
    ----------
    output : pathlib.Path
    up_to_date : bool
        Nothing was computed: the file was current (or only its metadata changed).
    chunks, computed, reused : int
        Chunks of the study, chunks that needed the solver, chunks found whole in the
        cache.
    wall_seconds : float
        Wall time of the call, writing and validating included [s].
    points, points_computed, points_reused : int
        Grid points of the study, computed in this run, and taken from the cache.
    metadata_updated : bool
        Only the file's metadata was rewritten (title, description, spec text).
    kind : str
        Result kind (:mod:`study.engine.kinds`); for a scene, its scene kind follows:
        ``"scene:trajectory"``.
    reason : str
        Why an existing output was recomputed (its spec or code changed, it was
        written by an older version in an older format, ``force``); empty where there
        was none or nothing was recomputed.
    """

    output: Path
    up_to_date: bool
    chunks: int
    computed: int
    reused: int
    wall_seconds: float
    points: int = 0
    points_computed: int = 0
    points_reused: int = 0
    metadata_updated: bool = False
    kind: str = "study"

    #: Computed in one piece (a scene, a fit, a design), not chunk by chunk.
    in_one_piece: bool = False
    reason: str = ""

    #: What the kind computed (a fit's or a design's result object), for the CLI's
    #: summary; None for studies and scenes, and when nothing was computed.
    outcome: Any = field(default=None, compare=False)


@dataclass
class RunJob:
    """One run as a kind's hooks see it: where it goes, when it started, its options.

    Attributes
    ----------
    kind : ResultKind
    output : pathlib.Path
    started : float
        :func:`time.perf_counter` at the start [s].
    started_utc : str
    command : str
        The command line recorded in the file's history.
    options : dict
        The kind's own run options (a study's scheduler, workers, cache, ...).
    """

    kind: ResultKind
    output: Path
    started: float
    started_utc: str
    command: str
    options: dict[str, Any]

    def seconds(self) -> float:
        """Wall time since the start [s]."""
        return time.perf_counter() - self.started

    def commit(self, temporary: Path) -> Path:
        """Seal, validate and rename a finished temporary file over the output."""
        return commit(temporary, self.output)

    def report(self, up_to_date: bool, chunks: int, computed: int, reused: int,
               **counts: Any) -> RunReport:
        return RunReport(self.output, up_to_date, chunks, computed, reused, self.seconds(),
                         **counts)


def load_any(path: str | Path) -> Any:
    """Read and validate a spec of any result kind (:mod:`study.engine.kinds`): the kind
    whose top table the file has reads it."""
    return kind_named(detect_kind(Path(path))).load(path)


def default_output(spec: Any, *, beside_spec: bool = False) -> Path:
    """Where a run without an output writes.

    ``study run`` (the default): ``results/<spec file stem>.nc``, what ``make`` and
    ``study list`` use for a workflow, or ``results/<study name>.nc`` for a spec that did
    not come from a file. ``beside_spec=True`` (what :func:`study.run` uses): the spec's
    own folder, ``<spec folder>/<spec file stem>.nc``, or ``<study name>.nc`` in the
    current folder for a spec that did not come from a file; never ``results/``, the
    folder ``make`` owns.
    """
    source = Path(spec.path)
    from_file = source.suffix == ".toml"
    stem = source.stem if from_file else spec.name
    if beside_spec:
        return source.with_name(f"{stem}.nc") if from_file else Path(f"{stem}.nc")
    return Path("results") / f"{stem}.nc"


def _identity(kind: ResultKind, spec: Any) -> tuple[str, dict[str, Any]]:
    """Fingerprint and metadata attributes a current file of ``spec`` must carry."""
    code = kind_code_sha256(kind.name)
    return fingerprint(spec.sha256, code), kind.metadata(spec) if kind.metadata else {}


def _state(kind: ResultKind, spec: Any, output: Path) -> str:
    """"current", "metadata" (same numbers, other spec text) or "stale"; reads only the
    file's attributes. A kind without metadata rules (a fit, a design) is always
    "stale": it is recomputed at every run."""
    if kind.metadata is None:
        return "stale"
    wanted_fingerprint, wanted = _identity(kind, spec)
    attrs = file_attributes(output)
    if attrs is None or attrs.get("study_result_schema") != kind.result_schema:
        return "stale"
    if "study_content_sha256" not in attrs:  # never sealed: not a finished result
        return "stale"
    if attrs.get("study_fingerprint") != wanted_fingerprint:
        return "stale"
    return "current" if all(attrs.get(k) == v for k, v in wanted.items()) else "metadata"


def _refuse_newer(kind: ResultKind, output: Path) -> None:
    """A result that a later version wrote in a newer format is not replaced by this
    older one's (``force`` replaces it)."""
    attrs = file_attributes(output)
    if attrs is None or attrs.get("study_result_schema") != kind.result_schema:
        return
    number = attrs.get(kind.format_attribute, kind.formats[0].number)
    if isinstance(number, int | np.integer) and number > kind.current_format.number:
        raise ResultError(
            f"{output}: {kind.label} format {number}, {newer_release_advice(attrs)}, or "
            "write to another output; this older study replaces it only when forced "
            "(--force)")


def _refuse_another(kind: ResultKind, spec: Any, output: Path, overwrite: bool) -> None:
    """A result of this kind written by another study (spec, fit, design: its recorded
    name, :attr:`ResultKind.name_attribute`, is not this spec's ``name``) is not
    replaced without ``overwrite``: its values may exist nowhere else. A rerun of the
    same study (same name, whatever changed in its spec) rewrites its own file."""
    if overwrite:
        return
    attrs = file_attributes(output)
    if attrs is None or attrs.get("study_result_schema") != kind.result_schema:
        return
    theirs = attrs.get(kind.name_attribute)
    if theirs is None or str(theirs) == spec.name:
        return
    raise OutputError(
        f"-o {output}: holds the result of {kind.name} {str(theirs)!r}, not of the "
        f"{kind.name} {spec.name!r} of {spec.path}; its values may exist nowhere else: "
        "give another output name, or --overwrite to replace it")


def _why_recomputed(kind: ResultKind, spec: Any, output: Path, force: bool) -> str:
    """Why an existing ``output`` is computed again (``""`` if there is none)."""
    attrs = file_attributes(output)
    if attrs is None or attrs.get("study_result_schema") != kind.result_schema:
        return ""
    if force:
        return "asked to (force)"
    written_by = f"study {attrs.get('study_version', '?')}"
    number = attrs.get(kind.format_attribute, kind.formats[0].number)
    if number != kind.current_format.number:
        return (f"it was written by {written_by} in {kind.label} format {number}; this "
                f"study {package_version()} writes format {kind.current_format.number}")
    if "study_content_sha256" not in attrs:
        return "it was never finished (no content checksum)"
    if kind.metadata is None:
        return f"a {kind.name} is computed at every run"
    if attrs.get("study_spec_sha256") != spec.sha256:
        return "its spec changed"
    return f"the code that computes it changed (it was written by {written_by})"


def is_up_to_date(spec: Any, output: Path) -> bool:
    """Whether ``output`` holds this spec's numbers computed by this code (reads only
    the file's attributes; ``study validate`` checks the data)."""
    return _state(kind_of_spec(spec), spec, Path(output)) != "stale"


def _update_metadata(job: RunJob, spec: Any) -> None:
    """Rewrite the metadata of a current file whose spec text changed (data untouched)."""
    _, wanted = _identity(job.kind, spec)
    attrs = file_attributes(job.output) or {}
    history = f"{attrs.get('history', '')}\n{job.started_utc}: {job.command} (metadata only)"
    rewrite_attributes(job.output, {**wanted, "history": history.strip(),
                                    "date_modified": job.started_utc})


def _spec_of(kind: ResultKind, spec: Any) -> Any:
    """``spec`` itself if it is one of ``kind``'s, else read from the file it names."""
    return spec if type(spec) is kind.spec_type else kind.load(spec)


def run(spec: Any, output: str | Path | None = None, *, force: bool = False,
        command: str | None = None, overwrite: bool = False, **options: Any) -> RunReport:
    """Run a spec (or a spec file) of any kind and write its result.

    Parameters
    ----------
    spec : spec of a registered kind, or path of a spec file
    output : path, optional
        Result file; default ``results/<spec file stem>.nc``.
    force : bool
        Recompute even if the result is up to date.
    command : str, optional
        The command line recorded in the file's history.
    overwrite : bool
        Replace an existing file at ``output`` that is not a result of this kind
        (:func:`study.engine.outputs.check_output`; the spec itself is never replaced), or
        a result of this kind written by another study (another recorded name).
    **options
        The kind's own options (:func:`run_study`'s for a study; ``progress`` for all).
    """
    if isinstance(spec, str | os.PathLike):
        spec = load_any(spec)
    return run_kind(kind_of_spec(spec), spec, output, force=force, command=command,
                    overwrite=overwrite, **options)


def run_kind(kind: ResultKind, spec: Any, output: str | Path | None = None, *,
             force: bool = False, command: str | None = None, overwrite: bool = False,
             **options: Any) -> RunReport:
    """Run ``spec`` of ``kind`` (a spec or a spec file): :func:`run` once the kind is known."""
    started, started_utc = time.perf_counter(), utc_now()
    spec = _spec_of(kind, spec)
    output = Path(output) if output is not None else default_output(spec)
    check_output(output, kind.result_schema, inputs=kind.inputs(spec), overwrite=overwrite)
    _refuse_another(kind, spec, output, overwrite)
    if not force:
        _refuse_newer(kind, output)
    command = command or f"study.run({shlex.quote(spec.path)})"
    job = RunJob(kind, output, started, started_utc, command, options)
    size = kind.size(spec)
    if not force and _state(kind, spec, output) == "current":
        output.touch()  # tell make the target is current
        return job.report(True, size, 0, size, kind=_tag(kind, spec))
    with exclusive(output):
        clean_temporaries(output)
        if not force and _state(kind, spec, output) == "metadata":
            _update_metadata(job, spec)
            return job.report(True, size, 0, size, metadata_updated=True, kind=_tag(kind, spec))
        reason = _why_recomputed(kind, spec, output, force)
        report = (kind.stream(spec, job) if kind.stream is not None
                  else _compute_and_write(job, spec))
        return replace(report, reason=reason)


def _tag(kind: ResultKind, spec: Any) -> str:
    """``RunReport.kind``: the kind's name, and its variant (``"scene:trajectory"``)."""
    return f"{kind.name}:{kind.variant(spec)}" if kind.variant else kind.name


def _compute_and_write(job: RunJob, spec: Any) -> RunReport:
    """A kind computed in one piece: compute, build the dataset, add the provenance,
    write it atomically."""
    kind = job.kind
    total, unit = kind.work(spec) if kind.work else (0, "pt")
    shown = Progress(total, spec.name, job.options.get("progress"), unit=unit)
    try:
        with shown.running(), compile_notices(shown):
            outcome = kind.compute(spec, shown)
    finally:
        shown.close()
    dataset = kind.build(spec, outcome, job.command)
    if not kind.own_provenance:
        provenance = _provenance(job, spec, utc_now())
        # Provenance first, then what the result says of itself (the order ncdump shows).
        dataset.attrs = {"Conventions": provenance.pop("Conventions"), **dataset.attrs,
                         **provenance}
    write_atomic(dataset, job.output)
    # The outcome goes back only where it is a small summary object (a fit's, a
    # design's result, printed by the CLI); a scene's arrays are left to the file.
    return job.report(False, 1, 1, 0, points=1, points_computed=1, kind=_tag(kind, spec),
                      in_one_piece=True, outcome=outcome if kind.own_provenance else None)


def _provenance(job: RunJob, spec: Any, finished_utc: str) -> dict[str, Any]:
    """The ACDD and provenance attributes of a result computed in one piece by this code."""
    kind = job.kind
    git = git_state()
    code = kind_code_sha256(kind.name)
    run_fingerprint = fingerprint(spec.sha256, code)
    section = {"name": spec.name, "spec_path": spec.path, "spec_sha256": spec.sha256,
               "canonical_spec": spec.canonical}
    if kind.variant:
        section["kind"] = kind.variant(spec)
    provenance = {
        "result_schema": kind.result_schema,
        kind.name: section,
        "code": {"code_sha256": code, "fingerprint": run_fingerprint},
        "package": {"name": "study", "version": package_version(), **git},
        "environment": environment(),
        "run": {"started_utc": job.started_utc, "finished_utc": finished_utc,
                "wall_seconds": job.seconds()},
    }
    return {
        "Conventions": "CF-1.11, ACDD-1.3",
        **(kind.metadata(spec) if kind.metadata else {}),
        "naming_authority": "study",
        "processing_level": "model output",
        "references": PAPER_REFERENCE,
        "history": f"{job.started_utc}: {job.command} (study {package_version()})",
        "date_created": finished_utc,
        "study_result_schema": kind.result_schema,
        "study_spec_sha256": spec.sha256,
        "study_code_sha256": code,
        "study_fingerprint": run_fingerprint,
        "study_version": package_version(),
        "git_commit": str(git["git_commit"]),
        "git_dirty": str(git["git_dirty"]).lower(),
        "provenance": json.dumps(provenance, sort_keys=True),
    }


def run_scene(spec: Any, output: str | Path | None = None, *, force: bool = False,
              command: str | None = None, overwrite: bool = False,
              progress: bool | None = None) -> RunReport:
    """Compute a steering scene and write its result (one task; same lock, atomic
    write, seal, up-to-date and metadata rules as a study).

    Parameters
    ----------
    spec : study.scenes.scene_spec.SceneSpec or path
    output : path, optional
        Result file; default ``results/<spec file stem>.nc``.
    force : bool
        Recompute even if the result is up to date.
    command : str, optional
        The command line recorded in the file's history.
    overwrite : bool
        Replace an existing file at ``output`` that is not a scene result, or the result
        of another scene (:func:`study.engine.outputs.check_output`; the spec itself is
        never replaced).
    progress : bool, optional
        Force progress output on or off; default: a bar on a terminal, log lines
        otherwise (work in the units of :func:`study.scenes.scene_run.scene_work`).
    """
    kind = kind_named("scene")
    spec = _spec_of(kind, spec)
    return run_kind(kind, spec, output, force=force, overwrite=overwrite, progress=progress,
                    command=command or "study.run_scene(" + shlex.quote(spec.path) + ")")


def run_study(
    spec: Any,
    output: str | Path | None = None,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool | None = None,
    force: bool = False,
    stop_after: int | None = None,
    command: str | None = None,
    on_chunk: Callable[[int], None] | None = None,
    cache: str | Path | None = None,
    on_start: Callable[[Executor], None] | None = None,
    overwrite: bool = False,
    task_timeout: float = TASK_TIMEOUT,
) -> RunReport:
    """Run a study and write its result file.

    The public entry of a study run (thirteen documented keywords, the options of
    ``study run``): it reads the spec and hands it down to :func:`run_kind`, the
    options travelling on as the job's (:func:`study.studies.kind.stream_study`).

    Parameters
    ----------
    spec : study.studies.spec_types.StudySpec or path
        The study (a spec file is read and validated first).
    output : path, optional
        Result file; default ``results/<spec file stem>.nc``.
    scheduler : str, optional
        Address of a dask.distributed scheduler; default: threads in this process.
    workers : int, optional
        Threads of the local run (default: one per core).
    progress : bool, optional
        Force progress output on or off; default: a bar on a terminal, log lines
        otherwise.
    force : bool
        Rewrite the result even if it is up to date (kept values are still reused).
    stop_after : int, optional
        Stop with :class:`StudyInterrupted` after this many chunks were computed in
        this run (an interrupted run, for tests); their values are kept.
    command : str, optional
        The command line recorded in the file's history.
    on_chunk : callable, optional
        Called with the chunk number each time a computed chunk is written.
    cache : path, optional
        Folder of kept values (default
        :func:`study.studies.kind.default_cache`).
    on_start : callable, optional
        Called with the :class:`study.engine.executors.Executor` once it is ready, before any
        chunk is computed (to show where the run goes, e.g. the dashboard).
    overwrite : bool
        Replace an existing file at ``output`` that is not a study result, or the result
        of another study (its recorded ``[study] name`` is not this spec's;
        :func:`study.engine.outputs.check_output`; the spec itself is never replaced).
    task_timeout : float
        With ``scheduler``: seconds the workers may go without finishing a task
        before the run ends, naming the workers that hold the tasks (a frozen
        worker); finished work is kept.

    Returns
    -------
    RunReport

    Raises
    ------
    study.engine.executors.ClusterError
        The scheduler cannot be reached, has no worker, or a worker does not run this
        code; nothing is written then.
    study.engine.store.StoreError, study.engine.store.StoreBusy
        The result cannot be written, or another process is writing it.
    """
    kind = kind_named("study")
    spec = _spec_of(kind, spec)
    return run_kind(kind, spec, output, force=force, overwrite=overwrite,
                    command=command or "study.run_study(" + shlex.quote(spec.path) + ")",
                    scheduler=scheduler, workers=workers, progress=progress,
                    stop_after=stop_after, on_chunk=on_chunk, cache=cache, on_start=on_start,
                    task_timeout=task_timeout)
