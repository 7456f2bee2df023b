"""Computed values kept for reuse: resume, extend, refine and overlap without recomputing.

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
(and of its axis file) before its values are used; one that fails is removed,
never reused.

Blocks are encoded by :func:`encode_block`, a pure function that a worker can run
beside the solver, and written by :meth:`ResultCache.store_encoded` to a temporary
name and renamed, so a reader never sees half a block and several writers
(processes) can share a cache.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import shutil
import time
import uuid
import zipfile
import zlib
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "CACHE_FORMAT",
    "CacheEntry",
    "ResultCache",
    "decode_array",
    "encode_array",
    "encode_block",
    "entry_key",
]

#: Version of the on-disk layout; part of every key.
CACHE_FORMAT = 2
_ENTRY = "entry.json"
_META = "meta.json"
#: How arrays are stored in blocks and axis files (recorded in each block).
_ENCODING = "shuffle-deflate-rle"
#: Decompressed blocks kept in memory while a chunk's values are gathered.
_BLOCKS_IN_MEMORY = 8


def entry_key(content: dict[str, Any]) -> str:
    """sha256 of an entry's content (canonical JSON) [64 hex]."""
    blob = json.dumps({"cache_format": CACHE_FORMAT, **content}, sort_keys=True,
                      separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()


def _array_sha256(array: NDArray[Any]) -> str:
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
    encode the values it computed; :meth:`ResultCache.store_encoded` writes them.

    Parameters
    ----------
    key : str
        Entry key (:func:`entry_key`).
    f, a : numpy.ndarray
        ``(n_f,)`` drive frequencies [Hz] and ``(n_a,)`` accelerations [m s-2].
    arrays : dict
        Variable name -> ``(n_f, n_a)`` array.
    """
    f = np.ascontiguousarray(f, dtype=np.float64)
    a = np.ascontiguousarray(a, dtype=np.float64)
    payload = {"f": f, **{name: np.ascontiguousarray(v) for name, v in arrays.items()}}
    meta = {
        "key": key,
        "encoding": _ENCODING,
        "variables": sorted(arrays),
        "shape": [int(f.size), int(a.size)],
        "a_sha256": _array_sha256(a),
        "dtypes": {name: array.dtype.str for name, array in payload.items()},
        "sha256": {name: _array_sha256(array) for name, array in payload.items()},
        "created": time.time(),
    }
    buffer = io.BytesIO()
    # Members are compressed by encode_array; the zip only adds names and CRC-32s.
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_STORED) as archive:
        archive.writestr(_META, json.dumps(meta, sort_keys=True))
        for name, array in payload.items():
            archive.writestr(f"{name}.bin", encode_array(array))
    return buffer.getvalue()


@dataclass(frozen=True)
class CacheEntry:
    """What ``study cache list`` shows of one entry.

    Attributes
    ----------
    key : str
    path : pathlib.Path
    content : dict
        What the key hashes (observable, structure, method, code); empty if unreadable.
    blocks : int
    points : int
        Drive points held (with repeats if blocks overlap).
    size : int
        Bytes on disk.
    modified : float
        Newest block's modification time (POSIX seconds).
    current_format : bool
        Written in this version's layout (:data:`CACHE_FORMAT`); entries of other
        layouts are never read and can be pruned.
    """

    key: str
    path: Path
    content: dict[str, Any]
    blocks: int
    points: int
    size: int
    modified: float
    current_format: bool = True


class _Index:
    """Rows (f values) of every block of one entry, sorted for lookups; each distinct
    acceleration axis once."""

    def __init__(self, blocks: list[tuple[Path, NDArray[np.float64], str]]):
        self.paths = [path for path, _, _ in blocks]
        self.a_keys = [a_sha for _, _, a_sha in blocks]
        #: a-axis sha256 -> (values, argsort of the values), filled as axes are read.
        self.axes: dict[str, tuple[NDArray[np.float64], NDArray[np.intp]] | None] = {}
        if blocks:
            f_all = np.concatenate([f for _, f, _ in blocks])
            block = np.concatenate([np.full(f.size, i) for i, (_, f, _) in enumerate(blocks)])
            row = np.concatenate([np.arange(f.size) for _, f, _ in blocks])
        else:
            f_all, block, row = np.empty(0), np.empty(0, int), np.empty(0, int)
        order = np.argsort(f_all, kind="stable")
        self.f = f_all[order]
        self.block = block[order]
        self.row = row[order]


class ResultCache:
    """The kept values under one folder (default ``<results>/.study-cache``).

    Parameters
    ----------
    root : path
        Cache folder; created on first write.
    """

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self._indexes: dict[str, _Index] = {}
        self._blocks: OrderedDict[Path, dict[str, NDArray[Any]] | None] = OrderedDict()
        #: Axis files known to exist (written or verified) in this session.
        self._axes_written: set[Path] = set()
        #: Blocks found corrupt or foreign and removed in this session.
        self.discarded: list[str] = []

    # -- layout ----------------------------------------------------------------

    def entry_path(self, key: str) -> Path:
        """Folder of the entry ``key``."""
        return self.root / key[:2] / key

    def _axis_path(self, key: str, a_sha256: str) -> Path:
        return self.entry_path(key) / f"axis-{a_sha256}.bin"

    def _block_paths(self, key: str) -> list[Path]:
        folder = self.entry_path(key)
        if not folder.is_dir():
            return []
        return sorted(folder.glob("block-*.npz"))

    # -- reading ---------------------------------------------------------------

    def _discard(self, path: Path, why: str) -> None:
        self.discarded.append(f"{path}: {why}")
        path.unlink(missing_ok=True)

    def _open_block(self, path: Path, key: str, axes_only: bool = False
                    ) -> tuple[dict[str, Any], dict[str, NDArray[Any]]] | None:
        """A block's meta and arrays (only ``f`` if ``axes_only``) after verifying its
        key, layout and the checksum of every array read; a bad block is removed."""
        try:
            with zipfile.ZipFile(path) as archive:
                meta = json.loads(archive.read(_META))
                if meta.get("key") != key:
                    self._discard(path, "belongs to another entry")
                    return None
                if meta.get("encoding") != _ENCODING:
                    self._discard(path, f"unknown encoding {meta.get('encoding')!r}")
                    return None
                n_f, n_a = (int(n) for n in meta["shape"])
                names = ("f",) if axes_only else ("f", *meta["variables"])
                arrays = {}
                for name in names:
                    shape = (n_f,) if name == "f" else (n_f, n_a)
                    arrays[name] = decode_array(archive.read(f"{name}.bin"),
                                                meta["dtypes"][name], shape)
                problem = _check_block(meta, arrays)
        except (OSError, ValueError, KeyError, TypeError, IndexError, zipfile.BadZipFile,
                EOFError, zlib.error) as err:
            self._discard(path, f"unreadable ({type(err).__name__}: {err})")
            return None
        if problem:
            self._discard(path, problem)
            return None
        return meta, arrays

    def _block(self, path: Path, key: str) -> dict[str, NDArray[Any]] | None:
        if path in self._blocks:
            self._blocks.move_to_end(path)
            return self._blocks[path]
        opened = self._open_block(path, key)
        arrays = None if opened is None else opened[1]
        self._blocks[path] = arrays
        if len(self._blocks) > _BLOCKS_IN_MEMORY:
            self._blocks.popitem(last=False)
        return arrays

    def _axis(self, key: str, index: _Index, a_sha256: str
              ) -> tuple[NDArray[np.float64], NDArray[np.intp]] | None:
        """An acceleration axis of the entry and its sort order, read once per session
        and verified against the sha256 that names it; a bad axis file is removed."""
        if a_sha256 not in index.axes:
            path = self._axis_path(key, a_sha256)
            axis = None
            try:
                values = _decode_axis(path.read_bytes())
            except (OSError, ValueError) as err:
                values = None
                if path.exists():
                    self._discard(path, f"unreadable ({type(err).__name__}: {err})")
            if values is not None:
                if _array_sha256(values) == a_sha256:
                    axis = (values, np.argsort(values, kind="stable"))
                    self._axes_written.add(path)
                else:
                    self._discard(path, "does not match its checksum")
            index.axes[a_sha256] = axis
        return index.axes[a_sha256]

    def _index(self, key: str) -> _Index:
        """The entry's row index, read once per session (blocks written later by this
        session cover other points, so they are not needed for its own lookups)."""
        if key not in self._indexes:
            layouts = []
            for path in self._block_paths(key):
                opened = self._open_block(path, key, axes_only=True)
                if opened is not None:
                    meta, arrays = opened
                    layouts.append((path, arrays["f"], str(meta["a_sha256"])))
            self._indexes[key] = _Index(layouts)
        return self._indexes[key]

    def lookup(
        self, key: str, f: NDArray[np.float64], a: NDArray[np.float64],
        variables: dict[str, np.dtype],
    ) -> tuple[dict[str, NDArray[Any]], NDArray[np.bool_]]:
        """Kept values at the grid ``f x a``.

        Parameters
        ----------
        key : str
            Entry key (:func:`entry_key`).
        f, a : numpy.ndarray
            ``(n_f,)`` drive frequencies [Hz] and ``(n_a,)`` accelerations [m s-2].
            Values match only if bitwise equal.
        variables : dict
            Variable name -> dtype of the arrays returned.

        Returns
        -------
        values : dict
            Name -> ``(n_f, n_a)`` array; meaningful only where ``found``.
        found : numpy.ndarray of bool
            ``(n_f, n_a)``: which points were found.
        """
        values = {name: np.zeros((f.size, a.size), dtype=dtype)
                  for name, dtype in variables.items()}
        found = np.zeros((f.size, a.size), dtype=bool)
        index = self._index(key)
        if index.f.size == 0:
            return values, found
        lo = np.searchsorted(index.f, f, side="left")
        hi = np.searchsorted(index.f, f, side="right")
        query_rows, hits = [], []
        for i in np.flatnonzero(hi > lo):
            for j in range(lo[i], hi[i]):
                query_rows.append(i)
                hits.append(j)
        if not hits:
            return values, found
        query_rows_arr = np.asarray(query_rows)
        hits_arr = np.asarray(hits)
        for b in np.unique(index.block[hits_arr]):
            mine = index.block[hits_arr] == b
            rows_here = query_rows_arr[mine]
            block_rows = index.row[hits_arr[mine]]
            axis = self._axis(key, index, index.a_keys[b])
            if axis is None:
                self._discard(index.paths[b], "its acceleration axis is missing or damaged")
                continue
            block_a, sorter = axis
            pos = np.searchsorted(block_a, a, sorter=sorter)
            pos = np.minimum(pos, block_a.size - 1)
            columns = sorter[pos]
            match = block_a[columns] == a
            if not match.any():
                continue
            arrays = self._block(index.paths[b], key)
            if arrays is None or not all(name in arrays for name in variables):
                continue
            rows_query = rows_here
            cols_query = np.flatnonzero(match)
            cols_block = columns[match]
            whole = (cols_query.size == a.size and cols_block.size == block_a.size
                     and np.array_equal(cols_block, np.arange(block_a.size)))
            for name in variables:
                if whole:
                    # The usual case (a whole chunk kept as one block): rows only.
                    values[name][rows_query] = arrays[name][block_rows]
                else:
                    values[name][np.ix_(rows_query, cols_query)] = (
                        arrays[name][np.ix_(block_rows, cols_block)])
            found[np.ix_(rows_query, cols_query)] = True
        return values, found

    # -- writing ---------------------------------------------------------------

    def store(self, key: str, content: dict[str, Any], f: NDArray[np.float64],
              a: NDArray[np.float64], arrays: dict[str, NDArray[Any]]) -> Path:
        """Keep a computed block ``f x a`` (each array ``(n_f, n_a)``) under ``key``."""
        return self.store_encoded(key, content, a, encode_block(key, f, a, arrays))

    def store_encoded(self, key: str, content: dict[str, Any], a: NDArray[np.float64],
                      block: bytes) -> Path:
        """Keep a block encoded by :func:`encode_block` under ``key``; ``a`` is the
        block's acceleration axis (written once per entry)."""
        folder = self.entry_path(key)
        folder.mkdir(parents=True, exist_ok=True)
        entry_file = folder / _ENTRY
        if not entry_file.exists():
            _write_atomic_bytes(entry_file, json.dumps(
                {"key": key, "cache_format": CACHE_FORMAT, "content": content},
                sort_keys=True, indent=1).encode())
        a = np.ascontiguousarray(a, dtype=np.float64)
        axis_file = self._axis_path(key, _array_sha256(a))
        if axis_file not in self._axes_written:
            if not axis_file.exists():
                _write_atomic_bytes(axis_file, encode_array(a))
            self._axes_written.add(axis_file)
        target = folder / f"block-{uuid.uuid4().hex}.npz"
        _write_atomic_bytes(target, block)
        return target

    # -- housekeeping ----------------------------------------------------------

    def entries(self) -> Iterator[CacheEntry]:
        """Every entry under the root, with size and age."""
        if not self.root.is_dir():
            return
        for folder in sorted(self.root.glob("??/*")):
            if not folder.is_dir():
                continue
            try:
                content = json.loads((folder / _ENTRY).read_text())["content"]
            except (OSError, ValueError, KeyError, TypeError):
                content = {}
            blocks = sorted(folder.glob("block-*.npz"))
            points = 0
            for path in blocks:
                try:
                    with zipfile.ZipFile(path) as archive:
                        shape = json.loads(archive.read(_META))["shape"]
                    points += int(shape[0]) * int(shape[1])
                except (OSError, ValueError, KeyError, TypeError, IndexError,
                        zipfile.BadZipFile):
                    continue
            files = [p for p in folder.iterdir() if p.is_file()]
            yield CacheEntry(
                key=folder.name, path=folder, content=content, blocks=len(blocks),
                points=points, size=sum(p.stat().st_size for p in files),
                modified=max((p.stat().st_mtime for p in files), default=0.0),
                current_format=bool(content) and entry_key(content) == folder.name,
            )

    def remove(self, key: str) -> None:
        """Delete one entry."""
        shutil.rmtree(self.entry_path(key), ignore_errors=True)
        self._indexes.pop(key, None)
        self._axes_written = {p for p in self._axes_written if p.parent.name != key}

    def clean_temporaries(self, older_than: float = 3600.0) -> int:
        """Remove block temporaries left by killed writers (older than ``older_than`` s)."""
        if not self.root.is_dir():
            return 0
        now = time.time()
        removed = 0
        for path in self.root.glob("??/*/.*.tmp"):
            try:
                if now - path.stat().st_mtime > older_than:
                    path.unlink()
                    removed += 1
            except OSError:
                continue
        return removed


def _check_block(meta: dict[str, Any], arrays: dict[str, NDArray[Any]]) -> str:
    """Why a block's arrays cannot be used, or '' if they can (shapes were decoded from
    the block's layout, so the checksums decide)."""
    for name, array in arrays.items():
        if meta["sha256"].get(name) != _array_sha256(array):
            return f"{name} does not match its checksum"
    return ""


def _write_atomic_bytes(target: Path, data: bytes) -> None:
    temporary = target.with_name(f".{target.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        with open(temporary, "wb") as stream:
            stream.write(data)
        os.replace(temporary, target)
    finally:
        temporary.unlink(missing_ok=True)
