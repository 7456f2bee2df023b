"""What a command may write over: never one of its inputs, never a folder or a device,
and an existing file only if it is an output of the same kind (or ``--overwrite``).

Every command that writes (``study run``, ``fit``, ``design``, ``export``, ``figure``)
asks :func:`check_output` before it computes anything, so that a typo in ``-o`` costs
one line and no data: ``study run spec.toml -o spec.toml`` is refused instead of
replacing the spec by a netCDF file.

The kinds of output, each recognised from the file itself:

* a result file (netCDF) of a given schema (``study_result_schema``: study, scene, fit
  or design);
* a CSV table written by ``study export`` (a header row of ``name`` or
  ``name [units]`` cells);
* a figure drawn by ``study figure`` (a PNG or PDF whose metadata names ``study``).
"""

from __future__ import annotations

import csv
import os
import stat
from collections.abc import Iterable
from pathlib import Path

__all__ = [
    "OutputError",
    "check_output",
    "describe_kind",
    "is_output_of_kind",
]

#: Bytes read from an existing file to recognise its kind (the header of a CSV table,
#: the metadata of a PNG figure); the whole file is never read.
_SNIFF_BYTES = 1 << 16


class OutputError(ValueError):
    """An output path that a command must not write to; the message is one line naming
    the path, why, and what to do."""


def _describe(path: Path) -> str:
    """A path as a person typed it, printable even if it is not valid UTF-8."""
    text = os.fsdecode(path)
    return text.encode("utf-8", "backslashreplace").decode("utf-8")


def describe_kind(kind: str) -> str:
    """Words for an output kind (``study-result-v1``, ``csv``, ``figure``...)."""
    if kind == "csv":
        return "a CSV table written by study export"
    if kind == "figure":
        return "a figure drawn by study figure"
    return f"a result file of schema {kind}"


def _same_file(path: Path, status: os.stat_result | None, other: Path) -> bool:
    try:
        if path.resolve() == other.resolve():
            return True
    except (OSError, RuntimeError):  # a symlink loop: compare by inode below
        pass
    if status is None:
        return False
    try:
        theirs = other.stat()
    except OSError:
        return False
    return (status.st_dev, status.st_ino) == (theirs.st_dev, theirs.st_ino)


def _netcdf_schema(path: Path) -> str | None:
    import netCDF4

    try:
        with netCDF4.Dataset(path, "r") as dataset:
            if "study_result_schema" in dataset.ncattrs():
                return str(dataset.getncattr("study_result_schema"))
    except Exception:  # netCDF4 raises OSError, RuntimeError... for a file it cannot read
        return None
    return None


def _head(path: Path) -> bytes:
    try:
        with open(path, "rb") as handle:
            return handle.read(_SNIFF_BYTES)
    except OSError:
        return b""


def _is_export_table(path: Path) -> bool:
    try:
        line = _head(path).decode("utf-8").splitlines()[0]
        header = next(csv.reader([line]))
    except (UnicodeDecodeError, IndexError, csv.Error, StopIteration):
        return False
    # ``study export`` writes ``name [units]`` or ``name`` cells, nothing else, and at
    # least the coordinates carry units (a measurement file's header carries none).
    return any(cell.endswith("]") for cell in header) and all(
        cell and " " not in cell.split(" [", 1)[0]
        and (cell.endswith("]") if " [" in cell else "[" not in cell)
        for cell in header)


def _is_study_figure(path: Path) -> bool:
    head = _head(path)
    if head.startswith(b"\x89PNG"):
        from PIL import Image, UnidentifiedImageError

        try:
            with Image.open(path) as image:
                return str(image.text.get("Software", "")).startswith("study")
        except (OSError, UnidentifiedImageError, AttributeError):
            return False
    if head.startswith(b"%PDF"):
        # matplotlib writes the document information dictionary at the end of the file.
        try:
            with open(path, "rb") as handle:
                handle.seek(max(0, path.stat().st_size - _SNIFF_BYTES))
                tail = handle.read()
        except OSError:
            return False
        return b"/Creator (study" in head + tail
    return False


def is_output_of_kind(path: str | Path, kind: str) -> bool:
    """Whether the existing regular file ``path`` is an output of ``kind``: a result
    schema name (``study-result-v1``...), ``"csv"`` or ``"figure"``."""
    path = Path(path)
    if kind == "csv":
        return _is_export_table(path)
    if kind == "figure":
        return _is_study_figure(path)
    return _netcdf_schema(path) == kind


def check_output(output: str | Path, kind: str, *, inputs: Iterable[str | Path] = (),
                 overwrite: bool = False, option: str = "-o") -> Path:
    """Refuse an output path that would lose something; return it as a Path.

    Parameters
    ----------
    output : path
        Where the command will write.
    kind : str
        What it writes: a result schema (``study-result-v1``, ``study-scene-v1``,
        ``study-fit-v1``, ``study-design-v1``), ``"csv"`` or ``"figure"``.
    inputs : iterable of path
        Every file the command reads (spec, result, measurement files). The output may
        never be one of them, by resolved path or by inode (a hard link); no flag
        allows it.
    overwrite : bool
        Allow replacing an existing regular file of another kind (``--overwrite``).
    option : str
        The option that named the output, for messages.

    Raises
    ------
    OutputError
        An empty name, a name that is not valid UTF-8, a folder, a device or other
        non-regular file, one of the inputs, or (without ``overwrite``) an existing
        file of another kind.
    """
    text = os.fsdecode(output) if not isinstance(output, Path) else str(output)
    if not text.strip():
        raise OutputError(f"{option} '': an empty output name; give a file name")
    path = Path(output)
    shown = _describe(path)
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        # netCDF-C takes UTF-8 names only, and a name that cannot be printed cannot be
        # reported: refused for every kind, before any work.
        raise OutputError(f"{option} {shown}: the name is not valid UTF-8; give a UTF-8 "
                          "file name") from None
    if text.endswith(os.sep) or path.name in ("", ".", ".."):
        raise OutputError(f"{option} {shown}: names a folder, not a file; give a file "
                          f"name inside it, e.g. {_describe(path / 'out')}")
    try:
        status: os.stat_result | None = path.stat()
    except FileNotFoundError:
        status = None
    except OSError as err:
        raise OutputError(f"{option} {shown}: cannot be checked ({err.strerror or err})"
                          ) from None
    for source in inputs:
        if _same_file(path, status, Path(source)):
            raise OutputError(f"{option} {shown}: is an input of this command "
                              f"({_describe(Path(source))}); writing it would destroy "
                              "it: give another output name")
    if status is None:
        return path
    if stat.S_ISDIR(status.st_mode):
        raise OutputError(f"{option} {shown}: is a folder; give a file name inside it, "
                          f"e.g. {_describe(path / 'out')}")
    if not stat.S_ISREG(status.st_mode):
        raise OutputError(f"{option} {shown}: is not a regular file (a device, pipe or "
                          "socket); give a file name")
    if not overwrite and not is_output_of_kind(path, kind):
        raise OutputError(f"{option} {shown}: exists and is not {describe_kind(kind)}; "
                          "give another name, or --overwrite to replace it")
    return path
