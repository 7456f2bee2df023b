"""Reading result files with netCDF4: their metadata (no data) and their values in slabs.

Nothing here knows a kind of result: :func:`file_metadata` lists dimensions, variables
and attributes as stored, :func:`slabs` cuts a variable into reads of at most
:data:`SLAB_BYTES`, and every failure of the netCDF/HDF5 libraries becomes a
:class:`ResultError` naming the file.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["LIBRARY_ERRORS", "MAX_EXPANSION", "MIN_DATA_BYTES", "SLAB_BYTES", "ResultError",
           "StoredFile", "StoredVariable", "file_metadata", "jsonable", "open_netcdf",
           "read_attributes", "read_slab", "slabs", "unreadable"]

#: Most bytes one read of a variable asks for (validation, checksum, describe).
SLAB_BYTES = 32 * 2**20

#: A file may hold at most this many bytes of data per byte on disk (and at least
#: :data:`MIN_DATA_BYTES`): deflate compresses at most ~1000:1, so more means a
#: corrupt header (a damaged dimension size), which would otherwise make
#: validation read terabytes of fill values.
MAX_EXPANSION = 4096
MIN_DATA_BYTES = 64 * 2**20

#: What the netCDF/HDF5 libraries raise on a damaged file (through netCDF4-python).
LIBRARY_ERRORS = (OSError, RuntimeError, ValueError, IndexError, KeyError, TypeError,
                   AttributeError, UnicodeError, MemoryError, OverflowError)


class ResultError(ValueError):
    """A result file that is unreadable, foreign, outdated or inconsistent."""


@dataclass(frozen=True)
class StoredVariable:
    """One variable's metadata as stored (no values)."""

    name: str
    dims: tuple[str, ...]
    shape: tuple[int, ...]
    #: numpy dtype of the values, None for variable-length strings.
    dtype: np.dtype | None
    #: "float64", "int8", ... or "str"; "unsupported ..." for types study never writes.
    type_name: str
    attrs: dict[str, Any]

    @property
    def nbytes(self) -> int:
        itemsize = 64 if self.dtype is None else self.dtype.itemsize
        return itemsize * math.prod(self.shape)


@dataclass(frozen=True)
class StoredFile:
    """A result file's metadata: global attributes, dimensions and variables."""

    path: Path
    attrs: dict[str, Any]
    dims: dict[str, int]
    variables: dict[str, StoredVariable]
    groups: tuple[str, ...]


def unreadable(path: Path, err: BaseException) -> ResultError:
    detail = " ".join(str(err).split()) or type(err).__name__
    return ResultError(f"{path}: not a readable netCDF file (truncated or corrupt?): {detail}")


def open_netcdf(path: Path, mode: str = "r"):
    """A netCDF4 dataset on ``path`` giving the stored values unchanged."""
    import netCDF4

    path = Path(path)
    try:
        regular = path.is_file()
    except OSError as err:  # a name too long, a permission denied on the way...
        raise ResultError(f"{path}: cannot read the result file ({err.strerror or err})"
                          ) from None
    if not regular:
        raise ResultError(f"{path}: no such file")
    try:
        nc = netCDF4.Dataset(path, mode)
    except Exception as err:  # the C library reports damage as OSError, RuntimeError...
        raise unreadable(path, err) from None
    try:
        # Raw values: no masking, no scaling, char arrays stay char arrays.
        nc.set_auto_maskandscale(False)
        nc.set_always_mask(False)
        nc.set_auto_chartostring(False)
    except LIBRARY_ERRORS as err:
        nc.close()
        raise unreadable(path, err) from None
    return nc


def _variable_type(var: Any) -> tuple[np.dtype | None, str]:
    import netCDF4

    if var.dtype is str:
        return None, "str"
    datatype = var.datatype
    if isinstance(datatype, netCDF4.CompoundType | netCDF4.VLType | netCDF4.EnumType):
        return None, f"unsupported {type(datatype).__name__}"
    dtype = np.dtype(var.dtype)
    if dtype.kind not in "biufS":
        return None, f"unsupported {dtype}"
    return dtype, dtype.name


def file_metadata(nc: Any, path: Path) -> StoredFile:
    """Everything but the values, read once."""
    try:
        attrs = {str(k): nc.getncattr(k) for k in nc.ncattrs()}
        dims = {str(k): len(v) for k, v in nc.dimensions.items()}
        variables = {}
        for name, var in nc.variables.items():
            dtype, type_name = _variable_type(var)
            variables[str(name)] = StoredVariable(
                str(name), tuple(str(d) for d in var.dimensions),
                tuple(int(n) for n in var.shape), dtype, type_name,
                {str(k): var.getncattr(k) for k in var.ncattrs()})
        groups = tuple(str(g) for g in nc.groups)
    except LIBRARY_ERRORS as err:
        raise unreadable(path, err) from None
    return StoredFile(Path(path), attrs, dims, variables, groups)


def jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    return value


def read_attributes(path: str | Path) -> dict[str, Any]:
    """The global attributes of a result file, as plain Python values; no data is read.

    Raises
    ------
    ResultError
        For a missing, unreadable, truncated or non-netCDF file (one line naming it).
    """
    path = Path(path)
    nc = open_netcdf(path)
    try:
        return {k: jsonable(v) for k, v in file_metadata(nc, path).attrs.items()}
    finally:
        nc.close()


def slabs(shape: tuple[int, ...], itemsize: int) -> Iterator[tuple[Any, ...]]:
    """Indices of consecutive slabs of at most :data:`SLAB_BYTES`, in C order.

    The slabs split the leading dimensions: one index of every dimension before
    the first whose trailing block fits the budget, then as many of its indices
    as fit. Concatenated, the slabs are the array in C order.
    """
    if not shape:
        yield (Ellipsis,)
        return
    if 0 in shape:
        return
    axis = next(k for k in range(len(shape))
                if math.prod(shape[k + 1:]) * itemsize <= SLAB_BYTES or k == len(shape) - 1)
    step = max(1, SLAB_BYTES // (math.prod(shape[axis + 1:]) * itemsize))
    for outer in np.ndindex(*shape[:axis]):
        for start in range(0, shape[axis], step):
            yield (*outer, slice(start, min(start + step, shape[axis])))


def read_slab(var: Any, index: tuple[Any, ...], path: Path) -> np.ndarray:
    try:
        values = var[index[0] if index == (Ellipsis,) else index]
    except LIBRARY_ERRORS as err:
        raise unreadable(path, err) from None
    return np.asarray(values)
