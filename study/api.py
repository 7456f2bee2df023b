"""Running studies from Python: a spec file in, a labelled :class:`xarray.Dataset` out.

:func:`run` is ``study run`` without the shell: the same runner, with its lock,
atomic write, provenance and kept values, returning the result file opened as a
dataset. :func:`study.open_result` (from :mod:`study.engine.validation`) opens a result file
written earlier.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import xarray as xr

__all__ = ["run"]


def run(
    spec: str | Path,
    output: str | Path | None = None,
    *,
    force: bool = False,
    cache: str | Path | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = False,
    overwrite: bool = False,
) -> xr.Dataset:
    """Run a study or scene spec file, as ``study run`` does, and open its result.

    The result file is written (or found up to date) exactly as by the command line:
    under a lock, through a temporary file validated before it replaces the result,
    with its provenance; computed values are kept in the cache for later runs, and a
    result whose spec and code are unchanged is not recomputed.

    Parameters
    ----------
    spec : str or pathlib.Path
        A study or scene spec file (TOML), e.g. ``"workflows/regime-map.toml"``.
    output : str or pathlib.Path, optional
        The result file (netCDF); missing folders are created. Default: beside the spec,
        ``<spec folder>/<spec file stem>.nc`` (``own/small.toml`` writes
        ``own/small.nc``), never ``results/``, the folder ``make`` owns (``study run``
        without ``-o`` writes ``results/<spec file stem>.nc``, as ``make`` does:
        :func:`study.engine.runner.default_output`).
    force : bool, default False
        Recompute and rewrite the result even if it is up to date (kept values are
        still reused).
    cache : str or pathlib.Path, optional
        Folder of kept values; default ``$STUDY_CACHE``, else ``.study-cache`` beside
        the result. Studies only (a scene keeps no values).
    scheduler : str, optional
        Address of a dask.distributed scheduler (``"tcp://host:8786"``); default: threads
        in this process. Studies only.
    workers : int, optional
        Threads of a local run [1]; default one per core. Studies only.
    progress : bool, default False
        Print progress lines (on stderr) while the study runs.
    overwrite : bool, default False
        Replace an existing file at ``output`` that is not a result of this kind, or the
        result of another study (another recorded ``[study] name``; as ``study run
        --overwrite``); the spec itself is never replaced.

    Returns
    -------
    xarray.Dataset
        The validated result, loaded into memory; the file is closed when this returns
        (nothing to close; for a result larger than memory open it yourself with
        ``xarray.open_dataset(path, chunks={})`` in a ``with`` block). Its ``encoding``
        ``"source"`` is the result file's path.

    Raises
    ------
    study.SpecError
        The spec file is missing, unreadable or invalid (the message names the file and
        the key); nothing is computed.
    study.ResultError
        The written file fails validation (names the file).
    study.engine.runner.StudyBusy
        Another process is writing the same result.
    study.engine.outputs.OutputError
        ``output`` is the spec, a folder, or (without ``overwrite``) a file of another
        kind or the result of another study; nothing is computed.
    study.engine.runner.RunInterrupted
        Ctrl-C (SIGINT, a notebook's interrupt): the work running was finished and every
        point computed is kept for the next call; the message says how many. A
        :class:`KeyboardInterrupt`.
    study.engine.executors.ClusterError
        ``scheduler`` cannot be reached or has no worker.

    See Also
    --------
    open_result : open a result file written earlier.
    compute_map : a labelled map over (f, a) in memory, without a spec file.

    Examples
    --------
    >>> import study
    >>> ds = study.run("own/regime-map.toml")                # doctest: +SKIP
    >>> ds["velocity"].sel(f=14.0, a=6.0, method="nearest")  # doctest: +SKIP
    """
    from study.engine.runner import default_output, load_any
    from study.engine.runner import run as run_any
    from study.engine.validation import open_result

    loaded = load_any(spec)
    report = run_any(
        loaded,
        default_output(loaded, beside_spec=True) if output is None else output,
        force=force,
        cache=cache,
        scheduler=scheduler,
        workers=workers,
        progress=progress,
        overwrite=overwrite,
        command=f"study.run({shlex.quote(str(spec))})",
    )
    dataset = open_result(report.output)
    dataset.encoding["source"] = str(report.output)
    return dataset
