"""The ``study`` command: run, validate, describe and list studies.

Exit status: 0 on success, 1 when a file or spec is invalid or a run fails,
2 for a command-line usage error.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import time
from pathlib import Path
from typing import Any

from study.model.units import spoken
from study.version import DISTRIBUTION, VERSION

__all__ = ["build_parser", "default_figure_output", "main"]


def _show_cluster(pool) -> None:
    """Where a run on a dask scheduler goes, and its dashboard if it has one."""
    line = f"study: {pool.threads} threads on the workers of {pool.name}"
    if pool.dashboard:
        line += f"; dashboard: {pool.dashboard}"
    print(line, file=sys.stderr, flush=True)


def _load_telling_warnings(path: Path) -> Any:
    """Read a spec of any kind; what it allows but looks like a mistake (a tilt that
    looks like radians: :class:`study.SuspectInputWarning`) is said on stderr, one
    ``study: warning:`` line each, before any work."""
    import warnings

    from study.engine.runner import load_any
    from study.model.inputs import StudyWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", StudyWarning)
        spec = load_any(path)
    for warning in caught:
        if issubclass(warning.category, StudyWarning):
            print(f"study: warning: {warning.message}", file=sys.stderr, flush=True)
        else:  # not ours: as it would have been
            warnings.warn_explicit(warning.message, warning.category, warning.filename,
                                   warning.lineno)
    return spec


def _run(args: argparse.Namespace) -> int:
    from study.engine.runner import RunInterrupted, StudyInterrupted, run

    spec = _load_telling_warnings(args.spec)
    command = "study " + " ".join(shlex.quote(a) for a in args.argv)
    started = time.time()
    try:
        report = run(
            spec,
            args.output,
            scheduler=args.scheduler,
            workers=args.workers,
            progress=args.progress,
            force=args.force,
            command=command,
            cache=args.cache,
            on_start=_show_cluster if args.scheduler else None,
            overwrite=args.overwrite,
            task_timeout=args.task_timeout,
        )
    except StudyInterrupted as err:
        print(f"study: {err}", file=sys.stderr)
        return 1
    except RunInterrupted as err:  # Ctrl-C: it says what was kept
        print(f"\nstudy: {err}", file=sys.stderr)
        _exit_now_if_computing()
        return 130
    except KeyboardInterrupt:  # before a study computed anything, or a scene, fit, design
        print("\nstudy: interrupted before the result was written; nothing of this run "
              "was kept", file=sys.stderr)
        _exit_now_if_computing()
        return 130
    if report.metadata_updated:
        print(f"{report.output}: metadata updated (numbers unchanged, nothing recomputed)")
    elif report.up_to_date:
        print(f"{report.output}: up to date (spec and code unchanged)")
    elif report.in_one_piece:
        what = " ".join(reversed(report.kind.split(":")))  # "trajectory scene", "fit"
        print(f"{report.output}: {what} computed in {report.wall_seconds:.2f} s")
    else:
        print(
            f"{report.output}: {report.points} points ({report.points_computed} computed, "
            f"{report.points_reused} reused) in {report.chunks} chunks "
            f"({report.computed} computed, {report.reused} reused) in "
            f"{report.wall_seconds:.2f} s"
        )
    if report.reason:
        print(f"{report.output}: rewritten because {report.reason} (values the cache kept "
              "were reused); the file it replaces was kept until the new one was sealed")
    if args.log_times is not None:
        from study.engine.run_log import append_record, record_of

        try:
            append_record(args.log_times,
                          record_of(report, getattr(spec, "name", args.spec.stem), started))
        except OSError as err:  # the log is a report: the result is written all the same
            print(f"study: warning: --log-times {args.log_times}: cannot append "
                  f"({err.strerror or err})", file=sys.stderr)
    return 0


def _exit_now_if_computing() -> None:
    """After a second Ctrl-C, threads may still be computing units whose values nobody
    will keep (numba kernels cannot be stopped): the interpreter would wait for them
    before it exits, up to minutes while a kernel compiles. Everything kept is on disk
    (written whole or not at all) and the result's temporary is gone: exit at once."""
    from study.engine.interrupts import computing_threads

    if computing_threads():
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)


def _cache(args: argparse.Namespace) -> int:
    import time

    from study.engine.cache import ResultCache
    from study.engine.provenance import code_sha256

    cache = ResultCache(args.cache)
    if args.action == "list":
        # Read-only: no lock, no file moved; damaged blocks are counted, not fatal.
        entries = list(cache.entries())
        current = code_sha256()
        now = time.time()
        quarantined = len(cache.quarantine_files())
        if not entries:
            print(f"{cache.root}: no kept values"
                  + (f"; {quarantined} files in quarantine" if quarantined else ""))
            return 0
        total, unreadable = 0, 0
        for entry in entries:
            content = entry.content
            code = str(content.get("code_sha256", "?"))
            structure = ", ".join(f"{k}={v:.6g}" for k, v in
                                  sorted(content.get("structure", {}).items())
                                  if isinstance(v, int | float))
            method = content.get("method", {})
            method = method if isinstance(method, dict) else {}
            print(
                f"{entry.key[:12]}  {content.get('observable', '?'):<12} "
                f"{method.get('method', '?')}/{method.get('coupling', '?')}"
                f"{'/flight' if method.get('flight') else ''}  "
                f"{entry.points:>10d} pts {entry.blocks:>5d} blocks {entry.size / 1e6:9.2f} MB "
                f"{(now - entry.modified) / 86400:7.1f} d  code {code[:12]}"
                f"{'' if code == current else ' (stale code)'}  {structure}"
                + (f"  ({entry.unreadable} unreadable)" if entry.unreadable else "")
            )
            total += entry.size
            unreadable += entry.unreadable
        print(f"{len(entries)} entries, {total / 1e6:.2f} MB in {cache.root}"
              + (f"; {unreadable} unreadable blocks (study cache verify moves them aside)"
                 if unreadable else "")
              + (f"; {quarantined} files in quarantine" if quarantined else ""))
        return 0
    if args.action == "prune" and not (args.all or args.stale or args.older_than is not None):
        print("study: cache prune needs --stale, --older-than DAYS or --all", file=sys.stderr)
        return 2
    if args.wait < 0 or args.wait != args.wait:
        print(f"study: --wait must be a number of seconds >= 0, got {args.wait}",
              file=sys.stderr)
        return 2
    if not cache.root.is_dir():
        print(f"{cache.root}: no kept values")
        return 0

    def waiting(message: str) -> None:
        print(f"study: {message}", file=sys.stderr, flush=True)

    # Maintenance holds the cache alone: no run reads a block it removes.
    with cache.maintenance(f"study cache {args.action}", wait=args.wait, on_wait=waiting):
        if args.action == "verify":
            return _cache_verify(cache)
        return _cache_prune(cache, args, code_sha256(), time.time())


def _cache_verify(cache) -> int:
    report = cache.verify()
    for item in report.bad:
        print(item.message())
    other = (f"; {report.other_layout} entries of an older layout not checked "
             "(study cache prune --stale removes them)" if report.other_layout else "")
    print(f"checked {report.blocks} blocks and {report.axes} axis files in {report.entries} "
          f"entries ({report.size / 1e6:.2f} MB) in {cache.root}: {len(report.bad)} bad"
          + (f", moved to {cache.root / 'quarantine'}" if report.bad else "") + other)
    return 1 if report.bad else 0


def _cache_prune(cache, args: argparse.Namespace, current: str, now: float) -> int:
    cache.clean_temporaries()
    entries = list(cache.entries())
    doomed = [
        e for e in entries
        if args.all
        or (args.stale and (e.content.get("code_sha256") != current or not e.current_format))
        or (args.older_than is not None and now - e.modified > args.older_than * 86400)
    ]
    freed = sum(e.size for e in doomed)
    # Files moved aside are never read again: --all and --stale remove them too.
    quarantined = len(cache.quarantine_files()) if (args.all or args.stale) else 0
    if not args.dry_run:
        for entry in doomed:
            cache.remove(entry.key)
        if args.all or args.stale:
            cache.remove_quarantine()
    verb = "would remove" if args.dry_run else "removed"
    print(f"{verb} {len(doomed)} of {len(entries)} entries ({freed / 1e6:.2f} MB) "
          + (f"and {quarantined} quarantined files " if quarantined else "")
          + f"from {cache.root}")
    return 0


def _validate(args: argparse.Namespace) -> int:
    from study.engine.validation import ResultError, validate_file

    status = 0
    for path in args.files:
        try:
            what = validate_file(path)
        except ResultError as err:
            print(f"study: {err}", file=sys.stderr)
            status = 1
        else:
            print(f"{path}: valid {what}")
            _note_format(path)
    return status


def _note_format(path: Path) -> None:
    """One line on stderr where a file is of an older format than this version writes."""
    from study.engine.validation import file_format_note

    note = file_format_note(path)
    if note:
        print(note, file=sys.stderr)


def _upgrade(args: argparse.Namespace) -> int:
    from study.engine.upgrade import upgrade_result

    report = upgrade_result(args.file, args.output, command=_command(args),
                            overwrite=args.overwrite)
    print(report.summary)
    return 0


def _info(args: argparse.Namespace) -> int:
    from study.engine.validation import describe, validate_file

    # Both read the file in slabs: info works on results larger than memory.
    validate_file(args.file)
    print(describe(args.file, str(args.file)))
    return 0


def _figure(args: argparse.Namespace) -> int:
    from study.engine.outputs import check_output
    from study.engine.validation import open_result
    from study.figures import draw_figure, figure_request, is_current

    dataset = open_result(args.file)
    _note_format(args.file)
    output = args.output or default_figure_output(args.name, args.file)
    stem = Path(output)
    if stem.suffix in (".png", ".pdf"):
        stem = stem.with_suffix("")
    for suffix in (".png", ".pdf"):
        check_output(stem.with_suffix(suffix), "figure", overwrite=args.overwrite,
                     inputs=[args.file, *(args.measurements or ())])
    if args.if_changed:
        request = figure_request(args.name, dataset, sel=args.sel, points=args.point,
                                 measurements=args.measurements)
        if is_current(output, request):
            print(f"{Path(output).with_suffix('.png')}: up to date (drawn from this file "
                  "with these options by this code)")
            return 0
    written = draw_figure(args.name, dataset, output, sel=args.sel, source=str(args.file),
                          points=args.point, measurements=args.measurements)
    for path in written:
        print(f"wrote {path}")
    return 0


def default_figure_output(name: str, result: Path) -> Path:
    """Where ``study figure NAME FILE`` writes without ``-o``: ``figures/STEM-NAME``.

    Named after the result file as well as the figure, so that a figure of one's own
    file never takes the name of a figure ``make figures`` draws from the workflows
    (``figures/NAME.png``).
    """
    return Path("figures") / f"{Path(result).stem}-{name}"


def _output_path(text: str) -> Path:
    """An output name as typed (``Path('')`` would silently mean the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty output name; give a file name")
    return Path(text)


def _folder_path(text: str) -> Path:
    """A folder name as typed (``Path('')`` would silently mean the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty folder name; give a folder")
    return Path(text)


def _seconds(text: str) -> float:
    """A positive, finite number of seconds."""
    import math

    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r}: need a number of seconds > 0")
    return value


def _point(text: str) -> tuple[float, float]:
    """``F,A`` of ``--point``: a drive frequency [Hz] and acceleration [m s-2]."""
    import math

    parts = text.split(",")
    try:
        f, a = (float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected F,A (drive frequency in Hz, acceleration in m s-2), "
            "e.g. 14.6,7.0") from None
    if not (math.isfinite(f) and math.isfinite(a)) or f <= 0 or a < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: need f > 0 Hz and a >= 0 m s-2")
    return f, a


def _export(args: argparse.Namespace) -> int:
    from study.analyses.export import export_csv
    from study.analyses.selection import select
    from study.engine.validation import open_result

    dataset = open_result(args.file)
    _note_format(args.file)
    if args.sel:
        dataset = select(dataset, args.sel, source=str(args.file))
        print(f"selected {dataset.attrs['study_selection']}")
    for path, rows, columns in export_csv(dataset, args.csv, args.var, source=str(args.file),
                                          inputs=[args.file], overwrite=args.overwrite):
        print(f"wrote {path} ({rows} rows, {columns} columns)")
    return 0


def _command(args: argparse.Namespace) -> str:
    """The command line, as recorded in a result's history."""
    return "study " + " ".join(shlex.quote(a) for a in args.argv)


def _fit(args: argparse.Namespace) -> int:
    from study.analyses.fit import FIT_KIND
    from study.analyses.fit_spec import PARAMETERS
    from study.engine.outputs import check_output
    from study.engine.runner import run_kind

    spec = FIT_KIND.load(args.spec)
    if args.figure is not None:
        for suffix in (".png", ".pdf"):
            check_output(Path(args.figure).with_suffix(suffix), "figure",
                         inputs=FIT_KIND.inputs(spec),
                         overwrite=args.overwrite, option="--figure")
    report = run_kind(FIT_KIND, spec, args.output, overwrite=args.overwrite,
                      command=_command(args))
    output, result = report.output, report.outcome
    rows = spec.measurements.sizes["measurement"]
    print(f"{output}: fit '{spec.name}' of {len(result.names)} parameters to {rows} "
          f"measurements ({spec.coupling} coupling), chi^2/dof = {result.chi2_per_dof:.4g} "
          f"(chi^2 = {result.chi2:.4g}, {result.dof} dof, p = {result.p_value:.3g}), "
          f"{result.evaluations} model "
          f"evaluations in {result.wall_seconds:.1f} s")
    for name, value, error, ok, side in zip(result.names, result.estimate,
                                            result.standard_error, result.identifiable,
                                            result.on_bound, strict=True):
        flag = "" if ok else "   NOT IDENTIFIABLE"
        flag += f"   ON ITS {side.upper()} BOUND" if side else ""
        print(f"  {name:<12} = {value:.6g} +- {error:.3g}{spoken(PARAMETERS[name].units)}{flag}")
    for warning in result.warnings:
        print(f"study: warning: {warning}", file=sys.stderr)
    if args.figure is not None:
        from study.engine.validation import open_result
        from study.figures.fit_result import draw

        for path in draw(open_result(output), args.figure):
            print(f"wrote {path}")
    return 0


def _design(args: argparse.Namespace) -> int:
    from study.analyses.design import DESIGN_KIND
    from study.engine.runner import run_kind

    spec = DESIGN_KIND.load(args.spec)
    report = run_kind(DESIGN_KIND, spec, args.output, overwrite=args.overwrite,
                      command=_command(args))
    output, result = report.output, report.outcome
    print(f"{output}: design '{spec.name}' of {len(result.names)} parameters for "
          f"{len(spec.targets)} targets ({spec.coupling} coupling), {result.evaluations} "
          f"model evaluations in {result.wall_seconds:.1f} s")
    for name, value, low, high in zip(result.names, result.best, result.lower, result.upper,
                                      strict=True):
        units = spoken(spec.parameter(name).units)
        print(f"  {name:<12} = {value:.6g}{units}   (bounds {low:g} to {high:g})")
    ev = result.evaluation
    for i, target in enumerate(spec.targets):
        speed = ev.speed_margin[i]
        print(f"  {'met    ' if ev.met[i] else 'NOT MET'} {target.label}: margin "
              f"{ev.margin[i]:.4g} ({ev.limiting[i]}); speed {speed:.4g}, threshold "
              f"{ev.threshold_margin[i]:.4g}, lift-off {ev.lift_margin[i]:.4g}")
    print(result.message)
    return 0


def _list(args: argparse.Namespace) -> int:
    from study.engine.runner import is_up_to_date, load_any
    from study.studies.spec import SpecError

    specs = sorted(Path(args.workflows).glob("*.toml"))
    if not specs:
        print(f"no workflows in {args.workflows}/")
        return 0
    for path in specs:
        output = Path(args.results) / f"{path.stem}.nc"
        try:
            spec = load_any(path)
        except SpecError as err:
            print(f"{path}: INVALID SPEC: {str(err).splitlines()[0]}")
            continue
        if is_up_to_date(spec, output):
            state = "up to date"
        elif output.exists():
            state = "out of date"
        else:
            state = "not run"
        print(f"{path}  ->  {output}: {state}")
    return 0


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="study",
        description="Parameter studies of vibration-driven stick-slip locomotion.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {VERSION}",
                        help=f"print the version of {DISTRIBUTION} and exit")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_run_command(commands)
    _add_cache_command(commands)

    validate = commands.add_parser("validate", help="check result files against the schema")
    validate.add_argument("files", type=Path, nargs="+", metavar="FILE")
    validate.set_defaults(handler=_validate)

    info = commands.add_parser("info", help="summary of a result file with its provenance")
    info.add_argument("file", type=Path, metavar="FILE")
    info.set_defaults(handler=_info)

    upgrade = commands.add_parser(
        "upgrade", help="rewrite a result file of an older format in today's format",
        description="Rewrite a result file (study, scene, fit or design) written by an "
        "earlier version of study in the format this version writes, without recomputing "
        "it: its values, provenance and fingerprint are kept, its history says so, and its "
        "content checksum is recomputed. FILE is checked by the rules of its own format "
        "first and is never modified (docs/user-guide/result-files.md).")
    upgrade.add_argument("file", type=Path, metavar="FILE", help="result file (netCDF)")
    upgrade.add_argument("-o", "--output", type=_output_path, required=True, metavar="NEW",
                         help="the upgraded file (never FILE itself)")
    _overwrite_option(upgrade, "result")
    upgrade.set_defaults(handler=_upgrade)

    _add_figure_command(commands)
    _add_export_command(commands)
    _add_fit_command(commands)
    _add_design_command(commands)

    listing = commands.add_parser("list", help="the workflows and whether results are current")
    listing.add_argument("--workflows", default="workflows", help="spec folder")
    listing.add_argument("--results", default="results", help="result folder")
    listing.set_defaults(handler=_list)
    return parser


def _add_run_command(commands: Any) -> None:
    """``study run``: a study spec to a netCDF result."""
    from study.engine.executors import TASK_TIMEOUT

    run = commands.add_parser("run", help="run a study spec and write its netCDF result")
    run.add_argument("spec", type=Path, help="study spec (TOML), e.g. workflows/regime-map.toml")
    run.add_argument("-o", "--output", type=_output_path,
                     help="result file (default: results/<spec file stem>.nc)")
    run.add_argument("--scheduler", metavar="ADDR",
                     help="dask.distributed scheduler address, e.g. tcp://host:8786 "
                          "(default: threads in this process)")
    run.add_argument("--task-timeout", type=_seconds, default=TASK_TIMEOUT, metavar="S",
                     help="with --scheduler: end the run when no task has finished for S "
                     f"seconds (a frozen worker; default {TASK_TIMEOUT:g}); finished work "
                     "is kept")
    run.add_argument("--workers", type=int, metavar="N",
                     help="threads of a local run (default: one per core)")
    run.add_argument("--force", action="store_true",
                     help="recompute even when the result is up to date")
    run.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                     help="progress with rate and time left (default: a bar on a terminal, "
                     "a line every 10%% or 30 s otherwise)")
    run.add_argument("--cache", type=_folder_path, metavar="DIR",
                     help="kept values to reuse and extend (default: $STUDY_CACHE, else "
                     "RESULT_FOLDER/.study-cache)")
    run.add_argument("--log-times", type=Path, metavar="FILE",
                     help="append a line of this run's wall time and point counts to FILE "
                     "(make: results/run-times.jsonl; python -m study.engine.run_log FILE "
                     "prints the slowest)")
    _overwrite_option(run, "result", ", or the result of another study (another "
                      "recorded name)")
    run.set_defaults(handler=_run)


def _add_cache_command(commands: Any) -> None:
    """``study cache``: list, prune or verify the kept values."""
    cache = commands.add_parser(
        "cache", help="show, prune or verify the kept computed values",
        description="list: what is kept (read-only). prune: remove entries (--stale, "
        "--older-than DAYS or --all). verify: read and check every block; bad ones are "
        "moved to DIR/quarantine (exit status 1 if any). prune and verify wait for runs "
        "using the cache (--wait), and runs wait for them.")
    cache.add_argument("action", choices=("list", "prune", "verify"))
    cache.add_argument("--cache", type=_folder_path, metavar="DIR",
                       default=Path(os.environ.get("STUDY_CACHE") or "results/.study-cache"),
                       help="cache folder (default: $STUDY_CACHE, else results/.study-cache)")
    cache.add_argument("--stale", action="store_true",
                       help="prune: entries computed by other code than this, or kept in an "
                       "older cache layout")
    cache.add_argument("--older-than", type=float, metavar="DAYS",
                       help="prune: entries not written for DAYS days")
    cache.add_argument("--all", action="store_true", help="prune: everything")
    cache.add_argument("--dry-run", action="store_true", help="prune: only say what would go")
    cache.add_argument("--wait", type=float, metavar="SECONDS", default=60.0,
                       help="prune, verify: wait this long for runs using the cache to "
                       "finish, then give up (default: 60)")
    cache.set_defaults(handler=_cache)


def _add_figure_command(commands: Any) -> None:
    """``study figure``: a figure from a result file."""
    from study.figures import FIGURES

    figure = commands.add_parser(
        "figure", help="draw a figure from a result file (PNG and PDF)",
        description="Figures: " + "; ".join(f"{k}: {v.shows}" for k, v in FIGURES.items()),
    )
    figure.add_argument("name", choices=sorted(FIGURES), metavar="NAME",
                        help="one of: " + ", ".join(FIGURES))
    figure.add_argument("file", type=Path, metavar="FILE", help="result file (netCDF)")
    figure.add_argument("-o", "--output", type=_output_path,
                        help="output stem, its folders created (default: "
                        "figures/STEM-NAME -> .png and .pdf, STEM the result file's)")
    figure.add_argument("--if-changed", action="store_true",
                        help="draw only if the output is missing or was drawn from other "
                        "data, options or figure code (as make figures does)")
    figure.add_argument("--sel", action="append", default=[], metavar="KEY=VALUE",
                        help="draw part of the file: KEY=VALUE nearest, KEY==VALUE exact, "
                        "KEY=V1,V2,... a list (each nearest; == exact), KEY=START:STOP a "
                        "range (repeatable); a figure of fewer axes than the file says "
                        "which keys to select")
    figure.add_argument("--point", action="append", type=_point, default=None,
                        metavar="F,A",
                        help="force-traces: a drive point, frequency [Hz] and acceleration "
                        "[m s-2] (repeatable; default: the paper's S, P, N, PN for its "
                        "structure, else one point per region the file holds)")
    figure.add_argument("--measurements", action="append", type=Path, default=None,
                        metavar="CSV",
                        help="thresholds, velocity-curves, mass-ratio: measurement file "
                        "drawn with error bars over the model (repeatable; format: "
                        "docs/user-guide/measurements-and-fits.md)")
    _overwrite_option(figure, "figure")
    figure.set_defaults(handler=_figure)


def _add_export_command(commands: Any) -> None:
    """``study export``: a result file as CSV tables."""
    export = commands.add_parser(
        "export", help="write a result file as tidy CSV tables (units in the header)",
        description="One row per point, one column per coordinate and variable, "
        "'name [units]' headers, status names instead of codes, NaN as an empty cell. "
        "Variables over other dimensions than the main table's (the frontier, a scene's "
        "segments or plates) go to OUT_STEM.DIMS.csv beside OUT.")
    export.add_argument("file", type=Path, metavar="FILE", help="result file (netCDF)")
    export.add_argument("--csv", type=_output_path, required=True, metavar="OUT",
                        help="CSV file of the main table")
    export.add_argument("--sel", action="append", default=[], metavar="KEY=VALUE",
                        help="select by coordinate: KEY=VALUE nearest, KEY==VALUE exact, "
                        "KEY=V1,V2,... a list (each nearest; == exact), KEY=START:STOP a "
                        "range (repeatable)")
    export.add_argument("--var", action="append", default=None, metavar="NAME",
                        help="export only this variable (repeatable; default: all)")
    _overwrite_option(export, "table")
    export.set_defaults(handler=_export)


def _add_fit_command(commands: Any) -> None:
    """``study fit``: structure parameters fitted to measurements."""
    fitting = commands.add_parser(
        "fit", help="fit free structure parameters to measurements (weighted least squares)",
        description="Estimate the free parameters of a fit spec (TOML: [fit] measurements, "
        "free = { NAME = [lower, upper] }, coupling; [structure] start values) from "
        "measurement CSV files; writes estimates, standard errors, correlations, residuals, "
        "chi^2 and its p-value to a netCDF file (docs/user-guide/measurements-and-fits.md). "
        "Warns, and stores the warnings in the file, when an estimate is on a bound, a "
        "parameter is not identifiable or chi^2 is improbable (p < 0.001); refuses "
        "velocities plainly in mm s-1.")
    fitting.add_argument("spec", type=Path, help="fit spec (TOML)")
    fitting.add_argument("-o", "--output", type=_output_path,
                         help="result file (default: results/<spec file stem>.nc)")
    fitting.add_argument("--figure", type=_output_path, metavar="STEM",
                         help="also draw measurements over the fitted model (STEM.png, .pdf)")
    _overwrite_option(fitting, "result", ", or the result of another fit")
    fitting.set_defaults(handler=_fit)


def _add_design_command(commands: Any) -> None:
    """``study design``: structure parameters for target behaviours."""
    designing = commands.add_parser(
        "design", help="search structure parameters that achieve target behaviours",
        description="Search the free parameters of a design spec (TOML: [design], "
        "[structure] or [disk] with [[plate]], [free] bounds, [[target]] f, a, behaviour) "
        "for the largest smallest margin over the targets; writes the design, every "
        "target's velocities and margins, and whether all are met (docs/user-guide/design.md). An "
        "infeasible design is reported (exit status 0) naming the target that fails.")
    designing.add_argument("spec", type=Path, help="design spec (TOML)")
    designing.add_argument("-o", "--output", type=_output_path,
                           help="result file (default: results/<spec file stem>.nc)")
    _overwrite_option(designing, "result", ", or the result of another design")
    designing.set_defaults(handler=_design)


def build_parser() -> argparse.ArgumentParser:
    """The ``study`` command's argument parser (the CLI reference page is generated from it)."""
    return _parser()


def _overwrite_option(command: argparse.ArgumentParser, what: str,
                      another: str = "") -> None:
    command.add_argument(
        "--overwrite", action="store_true",
        help=f"replace an existing file that is not a {what} written by study{another} (a "
        "file the command reads is never replaced)")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``study`` console script."""
    from study.analyses.export import ExportError
    from study.analyses.selection import SelectionError
    from study.engine.executors import ClusterError
    from study.engine.outputs import OutputError
    from study.engine.store import StoreBusy, StoreError
    from study.engine.validation import ResultError
    from study.figures import FigureError
    from study.studies.spec import SpecError

    parser = _parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    # Recorded in the result's history: a name that is not UTF-8 (kept by Python as
    # lone surrogates) is written escaped, not refused by the netCDF attribute.
    args.argv = [a.encode("utf-8", "backslashreplace").decode("utf-8") for a in argv]
    if getattr(args, "workers", None) is not None and args.workers < 1:
        parser.error(f"--workers must be >= 1, got {args.workers}")
    try:
        return args.handler(args)
    except (SpecError, ResultError, FigureError, StoreError, StoreBusy, ClusterError,
            SelectionError, ExportError, OutputError) as err:
        print(f"study: {err}", file=sys.stderr)
        return 1
    except BrokenPipeError:
        # The reader went away (`study info FILE | head`): not an error of ours, and
        # Python must not complain again when it flushes stdout at exit.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except OSError as err:
        # What the commands do not name themselves (a name too long, a path through a
        # file, ...): one line naming the path, not a traceback.
        where = f"{err.filename}: " if err.filename is not None else ""
        print(f"study: {where}{err.strerror or err}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
