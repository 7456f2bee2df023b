"""The ``study`` command: run, validate, describe and list studies.

Exit status: 0 on success, 1 when a file or spec is invalid or a run fails,
2 for a command-line usage error.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

__all__ = ["main"]


def _run_scene(args: argparse.Namespace) -> int:
    from study.runner import StudyBusy
    from study.scene import load_scene
    from study.scene_run import run_scene

    spec = load_scene(args.spec)
    output = args.output or Path("results") / f"{Path(args.spec).stem}.nc"
    try:
        path, up_to_date, wall = run_scene(spec, output, force=args.force)
    except StudyBusy as err:
        print(f"study: {err}", file=sys.stderr)
        return 1
    if up_to_date:
        print(f"{path}: up to date (scene and code unchanged)")
    else:
        print(f"{path}: {spec.kind} scene computed in {wall:.2f} s")
    return 0


def _run(args: argparse.Namespace) -> int:
    from study.runner import StudyBusy, StudyInterrupted, run_study
    from study.spec import load_spec
    from study.specfile import detect_kind

    if detect_kind(args.spec) == "scene":
        return _run_scene(args)
    spec = load_spec(args.spec)
    command = "study " + " ".join(shlex.quote(a) for a in args.argv)
    try:
        report = run_study(
            spec,
            args.output,
            scheduler=args.scheduler,
            workers=args.workers,
            progress=False if args.no_progress else None,
            force=args.force,
            command=command,
        )
    except (StudyInterrupted, StudyBusy) as err:
        print(f"study: {err}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("\nstudy: interrupted; completed chunks are kept, run again to resume",
              file=sys.stderr)
        return 130
    if report.up_to_date:
        print(f"{report.output}: up to date (spec and code unchanged)")
    else:
        print(
            f"{report.output}: {report.chunks} chunks ({report.computed} computed, "
            f"{report.reused} reused) in {report.wall_seconds:.2f} s"
        )
    return 0


def _validate(args: argparse.Namespace) -> int:
    from study.store import ResultError, open_result

    status = 0
    for path in args.files:
        try:
            open_result(path)
        except ResultError as err:
            print(f"study: {err}", file=sys.stderr)
            status = 1
        else:
            print(f"{path}: valid study result")
    return status


def _info(args: argparse.Namespace) -> int:
    from study.store import describe, open_result

    dataset = open_result(args.file)
    print(describe(dataset, str(args.file)))
    return 0


def _figure(args: argparse.Namespace) -> int:
    from study.figures import draw_figure
    from study.store import open_result

    dataset = open_result(args.file)
    output = args.output or Path("figures") / args.name
    for path in draw_figure(args.name, dataset, output):
        print(f"wrote {path}")
    return 0


def _list(args: argparse.Namespace) -> int:
    from study.runner import is_up_to_date, partial_folder
    from study.scene import load_scene
    from study.scene_run import scene_up_to_date
    from study.spec import SpecError, load_spec
    from study.specfile import detect_kind

    specs = sorted(Path(args.workflows).glob("*.toml"))
    if not specs:
        print(f"no workflows in {args.workflows}/")
        return 0
    for path in specs:
        output = Path(args.results) / f"{path.stem}.nc"
        try:
            kind = detect_kind(path)
        except SpecError as err:
            print(f"{path}: INVALID SPEC: {str(err).splitlines()[0]}")
            continue
        if kind == "scene":
            try:
                scene = load_scene(path)
            except SpecError as err:
                print(f"{path}: INVALID SPEC: {str(err).splitlines()[0]}")
                continue
            state = ("up to date" if scene_up_to_date(scene, output)
                     else "out of date" if output.exists() else "not run")
            print(f"{path}  ->  {output}: {state}")
            continue
        try:
            spec = load_spec(path)
        except SpecError as err:
            print(f"{path}: INVALID SPEC: {str(err).splitlines()[0]}")
            continue
        if is_up_to_date(spec, output):
            state = "up to date"
        elif partial_folder(output).exists():
            state = "interrupted (resumable)"
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
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = commands.add_parser("run", help="run a study spec and write its netCDF result")
    run.add_argument("spec", type=Path, help="study spec (TOML), e.g. workflows/regime-map.toml")
    run.add_argument("-o", "--output", type=Path,
                     help="result file (default: results/<spec file stem>.nc)")
    run.add_argument("--scheduler", metavar="ADDR",
                     help="dask.distributed scheduler address (default: local cluster)")
    run.add_argument("--workers", type=int, metavar="N",
                     help="threads of the local cluster (default: one per core)")
    run.add_argument("--force", action="store_true",
                     help="recompute even when the result is up to date")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.set_defaults(handler=_run)

    validate = commands.add_parser("validate", help="check result files against the schema")
    validate.add_argument("files", type=Path, nargs="+", metavar="FILE")
    validate.set_defaults(handler=_validate)

    info = commands.add_parser("info", help="summary of a result file with its provenance")
    info.add_argument("file", type=Path, metavar="FILE")
    info.set_defaults(handler=_info)

    from study.figures import FIGURES

    figure = commands.add_parser(
        "figure", help="draw a figure from a result file (PNG and PDF)",
        description="Figures: " + "; ".join(f"{k}: {v.shows}" for k, v in FIGURES.items()),
    )
    figure.add_argument("name", choices=sorted(FIGURES), metavar="NAME",
                        help="one of: " + ", ".join(FIGURES))
    figure.add_argument("file", type=Path, metavar="FILE", help="result file (netCDF)")
    figure.add_argument("-o", "--output", type=Path,
                        help="output stem (default: figures/NAME -> .png and .pdf)")
    figure.set_defaults(handler=_figure)

    listing = commands.add_parser("list", help="the workflows and whether results are current")
    listing.add_argument("--workflows", default="workflows", help="spec folder")
    listing.add_argument("--results", default="results", help="result folder")
    listing.set_defaults(handler=_list)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``study`` console script."""
    from study.figures import FigureError
    from study.spec import SpecError
    from study.store import ResultError

    parser = _parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    args.argv = argv  # recorded in the result's history
    if getattr(args, "workers", None) is not None and args.workers < 1:
        parser.error(f"--workers must be >= 1, got {args.workers}")
    try:
        return args.handler(args)
    except (SpecError, ResultError, FigureError) as err:
        print(f"study: {err}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
