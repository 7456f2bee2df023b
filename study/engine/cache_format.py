"""The cache's on-disk layout: entry keys, the encodings of blocks and axis files, and
one file of the cache read back verified.

Values of the cached observables are kept in *entries*, one per (observable,
structure, solver settings, code fingerprint): the entry's key is the sha256 of
that content, so values are found again whatever grid they are part of. An entry
is a folder ``<root>/<key[:2]>/<key>/`` holding ``entry.json`` (the content the key
hashes), *axis files* and *blocks*.

A block is a rectangle of drive frequencies x accelerations: one zip file holding
``meta.json`` (the block's own copy of the key, its layout, the dtype and sha256 of
every array), ``f.bin`` and one ``<variable>.bin`` per variable. Arrays are stored
byte-shuffled (the k-th bytes of all values together) and deflated with run-length
matching: for solver output (exact zeros, NaN, repeated flags, smooth values) this
is smaller than plain deflate and about twice as fast, which matters because every
computed value is kept. The acceleration axis of a block, the same for every block
of a grid, is kept once per entry in ``axis-<sha256>.bin`` (named by the sha256 of
its values) instead of in each block: at 1e8 points it was a third of the cache.

A block is verified against its key, layout and the checksum of every array read
(and of its axis file) before its values are used; a file that fails is an
:class:`UnusableFile` (what is done with it is :mod:`study.engine.cache_health`'s).
Files are opened without following links and without blocking (``O_NOFOLLOW |
O_NONBLOCK``, then ``fstat``: a FIFO or ``/dev/zero`` in place of a block is refused
before a byte is read), and never read beyond :data:`MAX_BLOCK_BYTES`.

Blocks are encoded by :func:`encode_block`, a pure function that a worker can run
beside the solver.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import time
import zipfile
import zlib
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from numpy.typing import NDArray

from study.engine.files import NotRegularFile, SymbolicLink, TooLarge, open_regular

__all__ = [
    "CACHE_FORMAT",
    "ENTRY_FILE",
    "MAX_BLOCK_BYTES",
    "MAX_ENTRY_BYTES",
    "UnusableFile",
    "array_sha256",
    "block_points",
    "decode_array",
    "encode_array",
    "encode_block",
    "entry_folders",
    "entry_key",
    "read_axis",
    "read_block",
    "read_cache_file",
]

#: Version of the on-disk layout; part of every key.
CACHE_FORMAT = 2
#: An entry's record, in its folder: its key, layout version and the content the key
#: hashes.
ENTRY_FILE = "entry.json"
_META = "meta.json"
#: How arrays are stored in blocks and axis files (recorded in each block).
_ENCODING = "shuffle-deflate-rle"
#: Largest file read as a block or axis file [bytes]: a task holds at most
#: ``study.studies.size.MAX_CHUNK_BYTES`` (256 MiB) of values, deflate adds a few bytes per
#: 16 KiB and the zip its headers. A larger file is not a block (a sparse file...).
MAX_BLOCK_BYTES = 2**30
#: Largest ``entry.json`` read [bytes] (an entry's content is under 1 KiB).
MAX_ENTRY_BYTES = 2**20


class UnusableFile(Exception):
    """A file of the cache that cannot be used; the message says why."""


def _open_regular(path: Path, limit: int) -> BinaryIO:
    """``path`` opened for reading if it is a regular file of at most ``limit`` bytes
    (:func:`study.engine.files.open_regular`, links never followed): a link out of the cache, a
    FIFO or ``/dev/zero`` put in place of a block is refused before a byte is read.

    Raises
    ------
    UnusableFile
        If it is a link, not a regular file, larger than ``limit`` or unopenable.
    FileNotFoundError
        If it is gone (moved aside or pruned by another process).
    """
    try:
        return open_regular(path, limit)
    except FileNotFoundError:
        raise
    except SymbolicLink:
        raise UnusableFile("a symbolic link (never followed out of the cache)") from None
    except NotRegularFile as err:
        raise UnusableFile(f"{err.kind}, not a regular file") from None
    except TooLarge as err:
        raise UnusableFile(f"{err.size} bytes, more than any block holds ({limit})") from None
    except OSError as err:
        raise UnusableFile(f"cannot be opened ({err.strerror or err})") from None


def read_cache_file(path: Path, limit: int) -> bytes:
    """All bytes of a file of the cache, opened as a block is (links never followed,
    nothing but a regular file read).

    Parameters
    ----------
    path : pathlib.Path
        The file.
    limit : int
        Most bytes read [bytes] (:data:`MAX_BLOCK_BYTES`, :data:`MAX_ENTRY_BYTES`).

    Returns
    -------
    bytes

    Raises
    ------
    UnusableFile
        If it is a link, not a regular file, larger than ``limit`` (or grew beyond it
        while read) or unopenable.
    FileNotFoundError
        If it is gone.
    """
    with _open_regular(path, limit) as stream:
        data = stream.read(limit + 1)
    if len(data) > limit:
        raise UnusableFile(f"grew beyond {limit} bytes while read")
    return data


def entry_key(content: dict[str, Any]) -> str:
    """sha256 of an entry's content (canonical JSON) [64 hex]."""
    blob = json.dumps({"cache_format": CACHE_FORMAT, **content}, sort_keys=True,
                      separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()


def entry_folders(root: Path) -> list[Path]:
    """Every entry folder (``<key[:2]>/<key>``) under the cache folder ``root``, sorted;
    links and files among them left out.

    Parameters
    ----------
    root : pathlib.Path
        The cache folder (absent or unreadable: no entry).

    Returns
    -------
    list of pathlib.Path
    """
    found = []
    try:
        shards = sorted(os.scandir(root), key=lambda e: e.name)
    except OSError:
        return []
    for shard in shards:
        if len(shard.name) != 2 or not shard.is_dir(follow_symlinks=False):
            continue
        try:
            keys = sorted(os.scandir(shard.path), key=lambda e: e.name)
        except OSError:
            continue
        found += [Path(e.path) for e in keys if e.is_dir(follow_symlinks=False)]
    return found


def array_sha256(array: NDArray[Any]) -> str:
    """sha256 of an array's bytes (C order) [64 hex]: the checksum a block records for
    each of its arrays, and the name of an axis file.

    Parameters
    ----------
    array : numpy.ndarray

    Returns
    -------
    str
    """
    return hashlib.sha256(np.ascontiguousarray(array).data).hexdigest()


def encode_array(array: NDArray[Any]) -> bytes:
    """An array's bytes, byte-shuffled and deflated (raw deflate, run-length matching).

    Shape and dtype are not included: a block's ``meta.json`` records them.
    """
    array = np.ascontiguousarray(array)
    raw = array.view(np.uint8).reshape(-1, array.itemsize).T.tobytes() if array.size else b""
    compressor = zlib.compressobj(1, zlib.DEFLATED, -15, 8, zlib.Z_RLE)
    return compressor.compress(raw) + compressor.flush()


def decode_array(data: bytes, dtype: str | np.dtype, shape: tuple[int, ...]) -> NDArray[Any]:
    """The array :func:`encode_array` encoded, given its dtype and shape.

    Raises
    ------
    ValueError
        If ``data`` does not inflate to exactly that many values.
    """
    dtype = np.dtype(dtype)
    count = int(np.prod(shape, dtype=np.int64))
    raw = _inflate(data, count * dtype.itemsize)
    if len(raw) != count * dtype.itemsize:
        raise ValueError(f"{len(raw)} bytes, expected {count * dtype.itemsize}")
    return _unshuffle(raw, dtype, shape)


def _inflate(data: bytes, size: int) -> bytes:
    try:
        # At most one byte more than expected is inflated: enough to see a wrong size.
        inflater = zlib.decompressobj(-15)
        return inflater.decompress(data, size + 1)
    except zlib.error as err:
        raise ValueError(f"not a deflate stream ({err})") from None


def _unshuffle(raw: bytes, dtype: np.dtype, shape: tuple[int, ...]) -> NDArray[Any]:
    planes = np.frombuffer(raw, dtype=np.uint8).reshape(dtype.itemsize, -1)
    return planes.T.copy().view(dtype).reshape(shape)


def _decode_axis(data: bytes) -> NDArray[np.float64]:
    """An axis file's values (float64; their number follows from the inflated length)."""
    try:
        raw = zlib.decompress(data, -15)
    except zlib.error as err:
        raise ValueError(f"not a deflate stream ({err})") from None
    if len(raw) % 8:
        raise ValueError(f"{len(raw)} bytes is not a whole number of float64 values")
    return _unshuffle(raw, np.dtype("<f8"), (len(raw) // 8,))


def encode_block(key: str, f: NDArray[np.float64], a: NDArray[np.float64],
                 arrays: dict[str, NDArray[Any]]) -> bytes:
    """A block of computed values ``f x a`` as the bytes of its file.

    A pure function of its arguments (no file is touched), so that a worker can
    encode the values it computed; :meth:`study.engine.cache.ResultCache.store_encoded`
    writes them.

    Parameters
    ----------
    key : str
        Entry key (:func:`entry_key`).
    f, a : numpy.ndarray
        ``(n_f,)`` drive frequencies [Hz] and ``(n_a,)`` accelerations [m s-2].
    arrays : dict
        Variable name -> ``(n_f, n_a)`` array, or ``(n_f, n_a, ...)`` for a variable
        with a value of several numbers per point (a phase section's periods).
    """
    f = np.ascontiguousarray(f, dtype=np.float64)
    a = np.ascontiguousarray(a, dtype=np.float64)
    payload = {"f": f, **{name: np.ascontiguousarray(v) for name, v in arrays.items()}}
    meta = {
        "key": key,
        "encoding": _ENCODING,
        "variables": sorted(arrays),
        "shape": [int(f.size), int(a.size)],
        # Only where a point holds several numbers: blocks without it read as before.
        **({"trailing": {name: list(v.shape[2:]) for name, v in arrays.items()
                         if np.ndim(v) > 2}}
           if any(np.ndim(v) > 2 for v in arrays.values()) else {}),
        "a_sha256": array_sha256(a),
        "dtypes": {name: array.dtype.str for name, array in payload.items()},
        "sha256": {name: array_sha256(array) for name, array in payload.items()},
        "created": time.time(),
    }
    buffer = io.BytesIO()
    # Members are compressed by encode_array; the zip only adds names and CRC-32s.
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_STORED) as archive:
        archive.writestr(_META, json.dumps(meta, sort_keys=True))
        for name, array in payload.items():
            archive.writestr(f"{name}.bin", encode_array(array))
    return buffer.getvalue()


def read_block(path: Path, key: str, axes_only: bool = False
               ) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
    """A block's meta and arrays (only ``f`` if ``axes_only``) after verifying its
    key, layout and the checksum of every array read.

    Parameters
    ----------
    path : pathlib.Path
        The block's file.
    key : str
        The key of the entry it is in (:func:`entry_key`).
    axes_only : bool
        Read ``f`` only (the block's rows), not its variables.

    Returns
    -------
    meta : dict
        The block's ``meta.json``.
    arrays : dict
        Name -> array: ``f`` and, unless ``axes_only``, every variable.

    Raises
    ------
    UnusableFile
        Why the block cannot be used.
    FileNotFoundError
        If it is gone.
    """
    with _open_regular(path, MAX_BLOCK_BYTES) as stream:
        try:
            with zipfile.ZipFile(stream) as archive:
                meta = json.loads(archive.read(_META))
                if meta.get("key") != key:
                    raise UnusableFile("belongs to another entry")
                if meta.get("encoding") != _ENCODING:
                    raise UnusableFile(f"unknown encoding {meta.get('encoding')!r}")
                n_f, n_a = (int(n) for n in meta["shape"])
                names = ("f",) if axes_only else ("f", *meta["variables"])
                arrays = {}
                trailing = meta.get("trailing", {})
                for name in names:
                    shape = (n_f,) if name == "f" else (
                        n_f, n_a, *(int(n) for n in trailing.get(name, ())))
                    arrays[name] = decode_array(archive.read(f"{name}.bin"),
                                                meta["dtypes"][name], shape)
                problem = _check_block(meta, arrays)
                str(meta["a_sha256"])
        except UnusableFile:
            raise
        except Exception as err:  # any failure to parse means damage
            # zipfile alone raises BadZipFile, RuntimeError (a garbled "encrypted"
            # flag), NotImplementedError, ValueError, EOFError, struct.error...
            raise UnusableFile(f"unreadable ({type(err).__name__}: {err})") from None
    if problem:
        raise UnusableFile(problem)
    return meta, arrays


def read_axis(path: Path) -> NDArray[np.float64]:
    """An axis file's values, verified against the sha256 that names it.

    Parameters
    ----------
    path : pathlib.Path
        The axis file (``axis-<sha256>.bin``).

    Returns
    -------
    numpy.ndarray
        The accelerations [m s-2], float64.

    Raises
    ------
    UnusableFile
        Why the file cannot be used.
    FileNotFoundError
        If it is gone.
    """
    values = _decode_axis_checked(read_cache_file(path, MAX_BLOCK_BYTES))
    if array_sha256(values) != path.stem.removeprefix("axis-"):
        raise UnusableFile("does not match its checksum")
    return values


def block_points(path: Path) -> int:
    """Points of a block, from its layout only.

    Parameters
    ----------
    path : pathlib.Path
        The block's file.

    Returns
    -------
    int

    Raises
    ------
    Exception
        Any exception, on any damage.
    """
    with _open_regular(path, MAX_BLOCK_BYTES) as stream, zipfile.ZipFile(stream) as archive:
        shape = json.loads(archive.read(_META))["shape"]
    return int(shape[0]) * int(shape[1])


def _decode_axis_checked(data: bytes) -> NDArray[np.float64]:
    try:
        return _decode_axis(data)
    except ValueError as err:
        raise UnusableFile(f"unreadable ({err})") from None


def _check_block(meta: dict[str, Any], arrays: dict[str, NDArray[Any]]) -> str:
    """Why a block's arrays cannot be used, or '' if they can (shapes were decoded from
    the block's layout, so the checksums decide)."""
    for name, array in arrays.items():
        if meta["sha256"].get(name) != array_sha256(array):
            return f"{name} does not match its checksum"
    return ""
