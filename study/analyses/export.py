"""Result files as tidy CSV tables a spreadsheet reads without the package.

One row per point, one column per coordinate then per variable, one header line:
``name [units]`` (``f [Hz]``, ``velocity [m s-1]``; no brackets for text, flags and
unitless indices), no index column, no comment lines. Flag variables (``status``,
``frontier_kind``, a scene's ``slipping`` ...) are written as their names
(``stick_slip``) from the file's CF ``flag_values``/``flag_meanings``, never as codes.
Numbers are written to the last bit (Python's shortest round-trip form); NaN (no value:
lift-off, not converged, a missing frontier branch) is an empty cell. Scalar
coordinates (the structure parameters a spec fixes, or a value chosen with ``--sel``)
are constant columns, so tables from several files can be stacked.

**Tables.** Variables are grouped by their dimensions: a variable whose dimensions are
all among another's joins that table (repeated along the dimensions it lacks: the
thresholds ``a_star_plus(f)`` beside ``velocity(f, a)``), otherwise it starts a table of
its own. A study result has one table over its structure axes, ``f`` and ``a`` (``f``
only without a solver), and the frontier's table over its structure axes, ``a`` and
``branch``; a scene has one per time series, segment list, plate list... The first
table (the one of the file's first variable) is written to ``OUT``; any other to
``OUT``'s stem followed by ``.`` and its dimensions joined by ``-``
(``map.csv``, ``map.a-branch.csv``). ``variables`` (``--var``) restricts what is written.
Every file is written to a temporary file in the destination folder, then renamed.
"""

from __future__ import annotations

import csv
import math
import os
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from study.engine.outputs import check_output
from study.model.inputs import instance_of

__all__ = ["ExportError", "Table", "export_csv", "tables"]

#: Units that mean "a count or an index" on a flag or integer variable: no brackets.
_NO_UNITS = (None, "")


class ExportError(ValueError):
    """An export that cannot be done; names the file and what is available."""


@dataclass(frozen=True)
class Table:
    """One CSV table: its dimensions and its data variables, in file order."""

    dims: tuple[str, ...]
    variables: tuple[str, ...]

    @property
    def suffix(self) -> str:
        """File name part of a secondary table (``a-branch``)."""
        return "-".join(self.dims) if self.dims else "scalar"


def tables(dataset: xr.Dataset, variables: list[str] | None = None,
           source: str = "") -> list[Table]:
    """The tables ``dataset`` exports to, the first one being the main table.

    Raises
    ------
    ExportError
        For a variable that is not in the file (naming those that are).
    TypeError
        For a ``dataset`` that is not an :class:`xarray.Dataset`.
    """
    instance_of("dataset", dataset, xr.Dataset, "an xarray.Dataset")
    names = list(dataset.data_vars)
    if variables is not None and (isinstance(variables, str) or not isinstance(
            variables, list | tuple) or not all(isinstance(v, str) for v in variables)):
        raise ExportError(f"variables must be a list of variable names, got {variables!r}")
    if variables:
        unknown = [v for v in variables if v not in dataset.data_vars]
        if unknown:
            raise ExportError(f"{source or 'dataset'}: --var {', '.join(unknown)}: no such "
                              f"variable; available: {', '.join(names)}")
        names = [n for n in names if n in variables]
    if not names:
        raise ExportError(f"{source or 'dataset'}: no data variable to export")
    # Largest dimension sets first; each variable joins the first set containing its own.
    sets: list[tuple[str, ...]] = []
    for name in sorted(names, key=lambda n: -dataset[n].ndim):
        dims = tuple(dataset[name].dims)
        if not any(set(dims) <= set(s) for s in sets):
            sets.append(dims)
    groups: dict[tuple[str, ...], list[str]] = {s: [] for s in sets}
    for name in names:
        dims = set(dataset[name].dims)
        home = next(s for s in sets if dims <= set(s))
        groups[home].append(name)
    # The main table is the one of the first variable in file order.
    order = sorted(groups, key=lambda s: names.index(groups[s][0]))
    return [Table(s, tuple(groups[s])) for s in order]


def _header(name: str, variable: xr.DataArray) -> str:
    units = variable.attrs.get("units")
    if "flag_meanings" in variable.attrs or variable.dtype.kind in "OSU" or units in _NO_UNITS:
        return name
    return f"{name} [{units}]"


def _cells(variable: xr.DataArray, values: np.ndarray) -> list[str]:
    """Text cells of ``values`` (flattened): flag names, shortest round-trip numbers,
    empty for NaN."""
    flat = np.asarray(values).ravel()
    if "flag_meanings" in variable.attrs:
        codes = np.atleast_1d(np.asarray(variable.attrs.get("flag_values"))).tolist()
        meanings = str(variable.attrs["flag_meanings"]).split()
        names = dict(zip(codes, meanings, strict=False))
        out = []
        for value in flat.tolist():
            if isinstance(value, float) and math.isnan(value):
                out.append("")
            else:
                key = int(value) if isinstance(value, float) else value
                out.append(names.get(key, str(value)))
        return out
    kind = flat.dtype.kind
    if kind == "f":
        return ["" if math.isnan(v) else repr(v) for v in flat.astype(float).tolist()]
    if kind in "iu":
        return [str(int(v)) for v in flat.tolist()]
    if kind == "b":
        return ["true" if v else "false" for v in flat.tolist()]
    if kind == "M":
        return [np.datetime_as_string(v, unit="auto") for v in flat]
    return [str(v) for v in flat.tolist()]


def _columns(dataset: xr.Dataset, table: Table) -> list[tuple[str, xr.DataArray, np.ndarray]]:
    """Header, source and flattened values (row-major over the table's dimensions) of
    every column of one table: the dimensions' coordinates (or positions), auxiliary
    coordinates along them, scalar coordinates, then the variables."""
    dims = table.dims
    shape = tuple(dataset.sizes[d] for d in dims)

    def flat(array: xr.DataArray) -> np.ndarray:
        values = array.transpose(*[d for d in dims if d in array.dims]).values
        values = values.reshape([shape[k] if d in array.dims else 1
                                 for k, d in enumerate(dims)])
        return np.broadcast_to(values, shape).reshape(-1)

    columns = []
    for axis, dim in enumerate(dims):
        coord = dataset[dim] if dim in dataset.coords else \
            xr.DataArray(np.arange(shape[axis]), dims=(dim,))
        columns.append((_header(dim, coord), coord, flat(coord)))
    for name, coord in dataset.coords.items():
        if name not in dims and set(coord.dims) <= set(dims):
            columns.append((_header(str(name), coord), coord, flat(coord)))
    for name in table.variables:
        columns.append((_header(name, dataset[name]), dataset[name], flat(dataset[name])))
    return columns


def _write_table_atomic(path: Path, columns: list[tuple[str, xr.DataArray, np.ndarray]],
                        block: int = 65536) -> int:
    """Write one table (streamed in blocks of rows) to a temporary file, then rename it;
    returns the number of rows."""
    folder = path.parent if str(path.parent) else Path(".")
    count = columns[0][2].size if columns else 0
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as err:
        raise ExportError(f"{path}: cannot write ({err.strerror or err})") from None
    temporary = Path(name)
    try:
        with os.fdopen(fd, "w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle, lineterminator="\n")
            writer.writerow([c[0] for c in columns])
            for start in range(0, count, block):
                cells = [_cells(source, values[start:start + block])
                         for _, source, values in columns]
                writer.writerows(zip(*cells, strict=True))
        os.chmod(temporary, 0o644)
        os.replace(temporary, path)
    except OSError as err:
        temporary.unlink(missing_ok=True)
        raise ExportError(f"{path}: cannot write ({err.strerror or err})") from None
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return count


def export_csv(dataset: xr.Dataset, output: str | Path, variables: list[str] | None = None,
               source: str = "", *, inputs: Iterable[str | Path] = (),
               overwrite: bool = False) -> list[tuple[Path, int, int]]:
    """Write ``dataset`` as tidy CSV tables (see the module's description).

    Parameters
    ----------
    dataset : xarray.Dataset
        A result (already selected, e.g. by :func:`study.analyses.selection.select`).
    output : path
        The main table's file; other tables go beside it (``STEM.DIMS.csv``).
    variables : list of str, optional
        Export only these data variables (``--var``).
    source : str
        The result file's name, for messages.
    inputs : iterable of path
        Files this export reads (the result file): no table may be written over one.
    overwrite : bool
        Replace existing files that are not tables of ``study export``.

    Returns
    -------
    list of (path, rows, columns)
        Every file written, the main table first.

    Raises
    ------
    ExportError
        For an unknown variable or a file that cannot be written.
    study.engine.outputs.OutputError
        For a table's path that is an input, a folder, a device or (without
        ``overwrite``) another kind of file; checked for every table before any is
        written.
    """
    instance_of("dataset", dataset, xr.Dataset, "an xarray.Dataset")
    output = check_output(output, "csv", inputs=inputs, overwrite=overwrite,
                          option="--csv")
    found = tables(dataset, variables, source)
    paths = [output if i == 0 else output.with_name(
        f"{output.stem}.{table.suffix}{output.suffix or '.csv'}")
        for i, table in enumerate(found)]
    for path in paths[1:]:
        check_output(path, "csv", inputs=inputs, overwrite=overwrite, option="--csv")
    written = []
    for path, table in zip(paths, found, strict=True):
        columns = _columns(dataset, table)
        written.append((path, _write_table_atomic(path, columns), len(columns)))
    return written
