"""The content checksum of a result file: its data, dimensions and variable attributes.

:func:`content_sha256` hashes what a file holds in a form that does not depend on
chunking or compression, reading in slabs; the writer records it in the global
attribute :data:`CONTENT_ATTRIBUTE` (:func:`study.engine.validation.seal`).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from study.engine.validation.reading import (
    ResultError,
    StoredFile,
    file_metadata,
    open_netcdf,
    read_slab,
    slabs,
)

__all__ = ["CONTENT_ATTRIBUTE", "content_digest", "content_sha256"]

#: Global attribute holding :func:`content_sha256` of the file.
CONTENT_ATTRIBUTE = "study_content_sha256"


def _text_bytes(values: np.ndarray) -> bytes:
    out = bytearray()
    for item in values.ravel(order="C"):
        text = item.decode("utf-8", "surrogateescape") if isinstance(item, bytes) else str(item)
        out += text.encode("utf-8", "surrogateescape") + b"\0"
    return bytes(out)


def _numeric_bytes(values: np.ndarray) -> bytes:
    little = values.dtype.newbyteorder("<")
    return np.ascontiguousarray(values, dtype=little).tobytes(order="C")


def _type_token(dtype: np.dtype | None) -> str:
    return "str" if dtype is None else dtype.newbyteorder("<").str


def _attribute_bytes(value: Any) -> bytes:
    array = np.asarray(value)
    if isinstance(value, str) or array.dtype.kind in "OU":
        head = f"str\0{','.join(map(str, array.shape))}\0"
        return head.encode() + _text_bytes(array.astype(object))
    head = f"{_type_token(array.dtype)}\0{','.join(map(str, array.shape))}\0"
    return head.encode() + _numeric_bytes(array)


def content_digest(nc: Any, meta: StoredFile) -> str:
    digest = hashlib.sha256()
    for name in sorted(meta.variables):
        var = meta.variables[name]
        if var.type_name.startswith("unsupported"):
            raise ResultError(f"{meta.path}: variable {name!r} has a type study never writes "
                              f"({var.type_name.removeprefix('unsupported ')})")
        digest.update(
            f"{name}\0{_type_token(var.dtype)}\0{','.join(var.dims)}\0"
            f"{','.join(map(str, var.shape))}\0{len(var.attrs)}\0".encode("utf-8",
                                                                            "surrogateescape"))
        for key in sorted(var.attrs):
            digest.update(key.encode("utf-8", "surrogateescape") + b"\0")
            digest.update(_attribute_bytes(var.attrs[key]))
        handle = nc.variables[name]
        for index in slabs(var.shape, 64 if var.dtype is None else var.dtype.itemsize):
            values = read_slab(handle, index, meta.path)
            digest.update(_text_bytes(values) if var.dtype is None else _numeric_bytes(values))
    return digest.hexdigest()


def content_sha256(path: str | Path) -> str:
    """SHA-256 of everything a result file holds in its variables.

    This definition is part of the file format: the global attribute
    ``study_content_sha256`` holds it, and :func:`validate_file` recomputes it.
    It is the SHA-256 of the following byte stream, built from every variable of
    the file's root group (data and coordinate variables alike), taken in sorted
    name order (Python ``str`` order):

    1. the variable's header, ``NAME 0 TYPE 0 DIMS 0 SHAPE 0 NATTRS 0`` (``0``
       is one NUL byte): ``NAME`` in UTF-8; ``TYPE`` the numpy dtype string of the
       little-endian type (``<f8``, ``|i1``, ``<i4``, ``|S1``...), or ``str``
       for variable-length strings; ``DIMS`` the dimension names joined by
       ``,``; ``SHAPE`` the sizes in decimal joined by ``,`` (both empty for a
       scalar); ``NATTRS`` the number of its attributes in decimal;
    2. each of its attributes in sorted name order: ``ANAME 0 TYPE 0 SHAPE 0``
       then the attribute's values (a text attribute has ``TYPE`` ``str`` and
       shape empty);
    3. its values as stored (no masking or scaling), in C order.

    Values are encoded as little-endian bytes for numbers, and as UTF-8 followed
    by one NUL byte per element for strings.

    Global attributes are not covered: validation checks them against the
    schema, the embedded spec and each other, and rewriting metadata (title,
    history) must not require reading the data again.

    Raises
    ------
    ResultError
        For a missing, unreadable or truncated file.
    """
    path = Path(path)
    nc = open_netcdf(path)
    try:
        return content_digest(nc, file_metadata(nc, path))
    finally:
        nc.close()
