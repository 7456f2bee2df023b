"""The entry points of validation: check a result file of any kind, seal a fresh one,
open a valid one."""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from study.engine.kinds import RESULT_KINDS, kind_of_schema
from study.engine.validation.checksums import CONTENT_ATTRIBUTE, content_sha256
from study.engine.validation.formats import newer_release_advice, written_format
from study.engine.validation.header import short
from study.engine.validation.reading import (
    LIBRARY_ERRORS,
    ResultError,
    file_metadata,
    jsonable,
    open_netcdf,
    unreadable,
)
from study.version import VERSION

__all__ = ["open_result", "seal", "validate_file"]


def validate_file(path: str | Path) -> str:
    """Check a result file of any kind, reading its data in bounded slabs.

    Studies (``study-result-v1``): the header against
    ``results_schema/study-result-v1.schema.json``; the embedded spec parses and
    its hash, name and title are the file's; ``study_fingerprint`` follows from
    the file's spec and code hashes; every variable the spec's observables
    declare (:mod:`study.studies.variables`) is present with the declared dimensions,
    dtype, units, long_name and flags, every flag value is declared, and
    ``velocity``-like variables are NaN exactly where their status is invalid
    and 0 where static; coordinates and fixed parameters equal the spec's; the
    ``provenance`` attribute has the structure of
    ``study-provenance-v1.schema.json``; the content checksum matches.

    Scenes (``study-scene-v1``): the header against the scene schema; the
    embedded spec parses and its hash, name, title, kind and the attributes
    repeated from it are the file's; the fingerprint, the provenance's
    structure, units on every float variable, flag values within their
    ``flag_values``; the content checksum matches.

    Fits and designs: the header against their schemas, the checksum. Each kind's own
    checks are its registered validator (:mod:`study.engine.kinds`).

    Returns
    -------
    str
        What the file is: the kind's label ("study result", "steering scene result",
        "fit result", "design result").

    Raises
    ------
    ResultError
        Naming the file and listing every problem found.
    """
    path = Path(path)
    nc = open_netcdf(path)
    try:
        meta = file_metadata(nc, path)
        attrs = meta.attrs
        kind = attrs.get("study_result_schema")
        if kind is None:
            raise ResultError(
                f"{path}: not a study result file (no 'study_result_schema' attribute; "
                f"global attributes: {short(', '.join(sorted(attrs)) or 'none')})")
        result_kind = kind_of_schema(kind) if isinstance(kind, str) else None
        if result_kind is None:
            schemas = [repr(k.result_schema) for k in RESULT_KINDS.values()]
            known = f"{', '.join(schemas[:-1])} and {schemas[-1]}"
            if _newer_release(attrs):
                raise ResultError(f"{path}: result schema {short(repr(jsonable(kind)), 80)}, "
                                  f"{newer_release_advice(attrs)} (this version reads "
                                  f"{known})")
            raise ResultError(
                f"{path}: written with result schema {short(repr(jsonable(kind)), 80)}; "
                f"this version of study reads {known}. Rerun its study to rewrite it.")
        written = written_format(result_kind, attrs, path)
        if meta.groups:
            problems = [f"groups {', '.join(meta.groups)}: study writes no groups"]
        else:
            problems = result_kind.problems(nc, meta, str(path), written)
    finally:
        nc.close()
    what = result_kind.label
    if problems:
        problems = list(dict.fromkeys(problems))  # two schema branches may see one fault
        raise ResultError(f"{path}: invalid {what}:\n  " + "\n  ".join(problems))
    return what


def _newer_release(attrs: dict) -> bool:
    """Whether a file names a version of study later than this one."""
    from packaging.version import InvalidVersion, Version

    written = attrs.get("study_version")
    try:
        return isinstance(written, str) and Version(written) > Version(VERSION)
    except InvalidVersion:
        return False


def open_result(path: str | Path) -> xr.Dataset:
    """Validate a result file, then return it loaded into memory (the file is closed).

    Every kind of result opens here: a study, a scene, a fit or a design file.
    Validation checks the file against its schema, its checksum and its spec before a
    value is read, as ``study validate`` does.

    Parameters
    ----------
    path : str or pathlib.Path
        A result file (netCDF) written by ``study run``, ``study fit``, ``study design``
        or :func:`study.run`.

    Returns
    -------
    xarray.Dataset
        The file's variables with their ``units``, ``long_name`` and CF flag attributes
        (``status`` holds :class:`study.Status` codes, named by ``flag_meanings``), its
        coordinates and global attributes (``study_coupling`` names the coupling),
        loaded into memory: no file handle stays open, nothing needs closing. For a
        file larger than memory use ``xarray.open_dataset(path, chunks={})`` in a
        ``with`` block instead.

    Raises
    ------
    ResultError
        For a missing, truncated, foreign, outdated or inconsistent file; the message
        starts with the file's path.
    """
    path = Path(path)
    validate_file(path)
    try:
        with xr.open_dataset(path, engine="netcdf4", mask_and_scale=True) as dataset:
            return dataset.load()
    except Exception as err:  # netCDF4 raises OSError, RuntimeError, ValueError...
        raise unreadable(path, err) from None


def seal(path: str | Path) -> str:
    """Record the content checksum in a freshly written result file, then validate it.

    Writes :func:`content_sha256` as the global attribute ``study_content_sha256``
    (appending to the file in place), then runs :func:`validate_file`.

    Returns
    -------
    str
        The checksum.

    Raises
    ------
    ResultError
        If the file cannot be read or does not validate.
    """
    path = Path(path)
    checksum = content_sha256(path)
    nc = open_netcdf(path, "a")
    try:
        nc.setncattr(CONTENT_ATTRIBUTE, checksum)
    except LIBRARY_ERRORS as err:
        raise unreadable(path, err) from None
    finally:
        nc.close()
    validate_file(path)
    return checksum
