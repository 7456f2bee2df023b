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
(and of its axis file) before its values are used. A file that fails (truncated,
garbled, a wrong checksum, not a regular file, a link, larger than any block) is
moved into ``<root>/quarantine/`` with one warning naming it, and its values are
recomputed: never reused, never fatal. Files are opened without following links and
without blocking (``O_NOFOLLOW | O_NONBLOCK``, then ``fstat``: a FIFO or
``/dev/zero`` in place of a block is refused before a byte is read), and never read
beyond :data:`MAX_BLOCK_BYTES`.

Blocks are encoded by :func:`encode_block`, a pure function that a worker can run
beside the solver, and written by :meth:`ResultCache.store_encoded` to a temporary
name and renamed, so a reader never sees half a block and several writers
(processes) can share a cache. Runs hold the cache's lock (``<root>/.lock``)
shared, for as long as they run (:meth:`ResultCache.session`); maintenance
(``study cache prune``, ``verify``) holds it exclusively
(:meth:`ResultCache.maintenance`), so it never removes a block a run reads or has
just written. Each process using the cache keeps a locked record in ``<root>/runs/``
naming it; a temporary carries its run's id and is removed only when it is old and
its run's record is no longer locked (the run is gone).
"""

from __future__ import annotations

import errno
import fcntl
import hashlib
import io
import json
import os
import re
import shutil
import socket
import stat
import time
import uuid
import zipfile
import zlib
from collections import OrderedDict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from numpy.typing import NDArray

from study.engine.files import NotRegularFile, SymbolicLink, TooLarge, file_kind, open_regular
from study.engine.store import StoreBusy

__all__ = [
    "CACHE_FORMAT",
    "MAX_BLOCK_BYTES",
    "QUARANTINE",
    "CacheBusy",
    "CacheEntry",
    "Quarantined",
    "ResultCache",
    "VerifyReport",
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
#: Largest file read as a block or axis file [bytes]: a task holds at most
#: ``study.engine.study_size.MAX_CHUNK_BYTES`` (256 MiB) of values, deflate adds a few bytes per
#: 16 KiB and the zip its headers. A larger file is not a block (a sparse file...).
MAX_BLOCK_BYTES = 2**30
#: Largest ``entry.json`` read [bytes] (an entry's content is under 1 KiB).
_MAX_ENTRY_BYTES = 2**20
#: Folder inside the cache where unreadable files are moved; never read again.
QUARANTINE = "quarantine"
#: Folder of run records: one file per process using the cache, locked while it does.
_RUNS = "runs"
#: The cache's lock file: runs hold it shared, maintenance (prune, verify) exclusively.
_LOCK = ".lock"
#: How long a run waits for cache maintenance to finish [s].
RUN_WAIT = 600.0
#: How often a waiting lock is tried again [s].
_POLL = 0.1
#: A cache temporary: ``.<name>.study-<run id>.tmp`` (see study.engine.store.temporary_path);
#: before run ids: ``.<name>.<pid>.<8 hex>.tmp``.
_CACHE_TEMPORARY = re.compile(
    r"^\.(?P<name>.+)\.(?:study-(?P<run>[0-9a-f]{32})|[0-9]+\.[0-9a-f]{8})\.tmp$")


class CacheBusy(StoreBusy):
    """Cache maintenance and a run cannot use the cache at the same time (one line)."""


class _Bad(Exception):
    """A file of the cache that cannot be used; the message says why."""


def _open_regular(path: Path, limit: int) -> BinaryIO:
    """``path`` opened for reading if it is a regular file of at most ``limit`` bytes
    (:func:`study.engine.files.open_regular`, links never followed): a link out of the cache, a
    FIFO or ``/dev/zero`` put in place of a block is refused before a byte is read.

    Raises
    ------
    _Bad
        If it is a link, not a regular file, larger than ``limit`` or unopenable.
    FileNotFoundError
        If it is gone (moved aside or pruned by another process).
    """
    try:
        return open_regular(path, limit)
    except FileNotFoundError:
        raise
    except SymbolicLink:
        raise _Bad("a symbolic link (never followed out of the cache)") from None
    except NotRegularFile as err:
        raise _Bad(f"{err.kind}, not a regular file") from None
    except TooLarge as err:
        raise _Bad(f"{err.size} bytes, more than any block holds ({limit})") from None
    except OSError as err:
        raise _Bad(f"cannot be opened ({err.strerror or err})") from None


def _read_regular(path: Path, limit: int) -> bytes:
    """All bytes of ``path`` (see :func:`_open_regular`), at most ``limit``."""
    with _open_regular(path, limit) as stream:
        data = stream.read(limit + 1)
    if len(data) > limit:
        raise _Bad(f"grew beyond {limit} bytes while read")
    return data


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
    unreadable : int
        Blocks whose layout cannot be read (``study cache verify`` moves them aside).
    """

    key: str
    path: Path
    content: dict[str, Any]
    blocks: int
    points: int
    size: int
    modified: float
    current_format: bool = True
    unreadable: int = 0


@dataclass(frozen=True)
class Quarantined:
    """A file of the cache found unusable and moved aside.

    Attributes
    ----------
    path : pathlib.Path
        Where it was.
    reason : str
        Why it cannot be used.
    moved_to : pathlib.Path or None
        Where it is now (in the quarantine folder); None if it could not be moved (a
        read-only cache): it is then skipped, not read.
    """

    path: Path
    reason: str
    moved_to: Path | None

    def message(self, consequence: str = "") -> str:
        """One line for the user."""
        where = (f"moved to {self.moved_to}" if self.moved_to is not None
                 else "could not be moved aside (read-only cache?): skipped")
        return f"{self.path}: {self.reason}; {where}{consequence}"


@dataclass
class VerifyReport:
    """What :meth:`ResultCache.verify` found.

    Attributes
    ----------
    entries, blocks, axes : int
        Entries, blocks and axis files checked.
    size : int
        Bytes checked.
    bad : list of Quarantined
        Files that failed, and where they went.
    other_layout : int
        Entries of another cache layout: never read, not checked (``prune --stale``).
    temporaries : int
        Temporaries of dead runs removed.
    """

    entries: int = 0
    blocks: int = 0
    axes: int = 0
    size: int = 0
    bad: list[Quarantined] = field(default_factory=list)
    other_layout: int = 0
    temporaries: int = 0


def _stderr_warning(message: str) -> None:
    import sys

    print(f"study: warning: {message}", file=sys.stderr, flush=True)


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
    warn : callable, optional
        Called with one line for each file moved aside (default: printed on stderr as
        ``study: warning: ...``).
    """

    def __init__(self, root: str | Path, warn: Callable[[str], None] | None = None) -> None:
        self.root = Path(root)
        self.warn = _stderr_warning if warn is None else warn
        #: Names this session's temporaries and its run record.
        self.run_id = uuid.uuid4().hex
        self._indexes: dict[str, _Index] = {}
        self._blocks: OrderedDict[Path, dict[str, NDArray[Any]] | None] = OrderedDict()
        #: Axis files known to exist (written or verified) in this session.
        self._axes_written: set[Path] = set()
        #: Files found unusable in this session (moved aside, or skipped if they could
        #: not be moved).
        self.quarantined: list[Quarantined] = []
        self._skipped: set[Path] = set()

    @property
    def discarded(self) -> list[str]:
        """One line per file found unusable in this session."""
        return [item.message() for item in self.quarantined]

    # -- layout ----------------------------------------------------------------

    def entry_path(self, key: str) -> Path:
        """Folder of the entry ``key``."""
        return self.root / key[:2] / key

    def _axis_path(self, key: str, a_sha256: str) -> Path:
        return self.entry_path(key) / f"axis-{a_sha256}.bin"

    def _entry_folder(self, key: str) -> Path | None:
        """The entry's folder if it is a real folder inside the cache (a link in its
        place is moved aside, never followed), else None."""
        folder = self.entry_path(key)
        for path in (folder.parent, folder):
            try:
                mode = os.lstat(path).st_mode
            except OSError:
                return None
            if stat.S_ISLNK(mode):
                self._quarantine(path, "a symbolic link (never followed out of the cache)")
                return None
            if not stat.S_ISDIR(mode):
                self._quarantine(path, f"{file_kind(mode)} in place of a folder")
                return None
        return folder

    def _block_paths(self, key: str) -> list[Path]:
        folder = self._entry_folder(key)
        if folder is None:
            return []
        return sorted(p for p in folder.glob("block-*.npz") if p not in self._skipped)

    # -- damaged files ------------------------------------------------------------

    def _quarantine(self, path: Path, why: str, consequence: str = "; its values are "
                    "recomputed") -> Quarantined | None:
        """Move ``path`` (itself, never a link's target) into the quarantine folder and
        warn once; None if it is gone already (another process moved it)."""
        self._skipped.add(path)
        self._blocks.pop(path, None)
        try:
            relative = path.relative_to(self.root)
        except ValueError:
            relative = Path(path.name)
        # Where it was, under the quarantine folder; a suffix if that name is taken.
        target = self.root / QUARANTINE / relative
        if os.path.lexists(target):
            target = target.with_name(f"{target.name}.{uuid.uuid4().hex[:8]}")
        moved_to: Path | None = target
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            os.rename(path, target)
        except FileNotFoundError:
            if not os.path.lexists(path):
                return None
            moved_to = None
        except OSError:
            moved_to = None
        item = Quarantined(path, why, moved_to)
        self.quarantined.append(item)
        self.warn(item.message(consequence))
        return item

    # -- reading ---------------------------------------------------------------

    def _read_block(self, path: Path, key: str, axes_only: bool = False
                    ) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
        """A block's meta and arrays (only ``f`` if ``axes_only``) after verifying its
        key, layout and the checksum of every array read.

        Raises
        ------
        _Bad
            Why the block cannot be used.
        FileNotFoundError
            If it is gone.
        """
        with _open_regular(path, MAX_BLOCK_BYTES) as stream:
            try:
                with zipfile.ZipFile(stream) as archive:
                    meta = json.loads(archive.read(_META))
                    if meta.get("key") != key:
                        raise _Bad("belongs to another entry")
                    if meta.get("encoding") != _ENCODING:
                        raise _Bad(f"unknown encoding {meta.get('encoding')!r}")
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
            except _Bad:
                raise
            except Exception as err:  # any failure to parse means damage
                # zipfile alone raises BadZipFile, RuntimeError (a garbled "encrypted"
                # flag), NotImplementedError, ValueError, EOFError, struct.error...
                raise _Bad(f"unreadable ({type(err).__name__}: {err})") from None
        if problem:
            raise _Bad(problem)
        return meta, arrays

    def _open_block(self, path: Path, key: str, axes_only: bool = False
                    ) -> tuple[dict[str, Any], dict[str, NDArray[Any]]] | None:
        """:meth:`_read_block`, or None after moving a bad block aside (or if gone)."""
        if path in self._skipped:
            return None
        try:
            return self._read_block(path, key, axes_only)
        except FileNotFoundError:
            return None
        except _Bad as err:
            self._quarantine(path, str(err))
            return None

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

    def _read_axis(self, path: Path) -> NDArray[np.float64]:
        """An axis file's values, verified against the sha256 that names it.

        Raises
        ------
        _Bad, FileNotFoundError
        """
        values = _decode_axis_checked(_read_regular(path, MAX_BLOCK_BYTES))
        if _array_sha256(values) != path.stem.removeprefix("axis-"):
            raise _Bad("does not match its checksum")
        return values

    def _axis(self, key: str, index: _Index, a_sha256: str
              ) -> tuple[NDArray[np.float64], NDArray[np.intp]] | None:
        """An acceleration axis of the entry and its sort order, read once per session
        and verified against the sha256 that names it; a bad axis file is moved aside."""
        if a_sha256 not in index.axes:
            path = self._axis_path(key, a_sha256)
            axis = None
            try:
                values = self._read_axis(path)
            except FileNotFoundError:
                pass
            except _Bad as err:
                self._quarantine(path, str(err), "; the values of its blocks are recomputed")
            else:
                axis = (values, np.argsort(values, kind="stable"))
                self._axes_written.add(path)
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
        trailing: dict[str, tuple[int, ...]] | None = None,
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
        trailing : dict, optional
            Variable name -> the shape of one point's value where it is not a number
            (a phase section's periods); a block whose values have another shape is
            not used.

        Returns
        -------
        values : dict
            Name -> ``(n_f, n_a)`` array; meaningful only where ``found``.
        found : numpy.ndarray of bool
            ``(n_f, n_a)``: which points were found.
        """
        trailing = trailing or {}
        values = {name: np.zeros((f.size, a.size, *trailing.get(name, ())), dtype=dtype)
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
                # Its values are recomputed; the axis file this run writes again makes
                # the block readable to the next run.
                continue
            block_a, sorter = axis
            pos = np.searchsorted(block_a, a, sorter=sorter)
            pos = np.minimum(pos, block_a.size - 1)
            columns = sorter[pos]
            match = block_a[columns] == a
            if not match.any():
                continue
            arrays = self._block(index.paths[b], key)
            if arrays is None or not all(
                    name in arrays and arrays[name].shape[2:] == values[name].shape[2:]
                    for name in variables):
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
        block's acceleration axis (written once per entry).

        Raises
        ------
        OSError
            If it cannot be written (disk full, read-only cache); no temporary is left.
        """
        folder = self._entry_folder(key)
        if folder is None:  # absent, or a link / file in its place (now moved aside)
            folder = self.entry_path(key)
            folder.mkdir(parents=True, exist_ok=True)
            if self._entry_folder(key) is None:
                raise OSError(errno.ENOTDIR, "the entry's folder cannot be made", str(folder))
        entry_file = folder / _ENTRY
        if not os.path.lexists(entry_file):
            self._write(entry_file, json.dumps(
                {"key": key, "cache_format": CACHE_FORMAT, "content": content},
                sort_keys=True, indent=1).encode())
        a = np.ascontiguousarray(a, dtype=np.float64)
        axis_file = self._axis_path(key, _array_sha256(a))
        if axis_file not in self._axes_written:
            if not os.path.lexists(axis_file) or axis_file in self._skipped:
                self._write(axis_file, encode_array(a))
                self._skipped.discard(axis_file)
            self._axes_written.add(axis_file)
        target = folder / f"block-{uuid.uuid4().hex}.npz"
        self._write(target, block)
        return target

    def temporary(self, target: Path) -> Path:
        """A new, empty temporary for ``target``, named with this session's run id."""
        path, handle = self._new_temporary(target)
        os.close(handle)
        return path

    def _new_temporary(self, target: Path) -> tuple[Path, int]:
        # One write at a time per session: the run id alone makes the name unique.
        path = target.with_name(f".{target.name}.study-{self.run_id}.tmp")
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
        return path, os.open(path, flags, 0o666 & ~_umask())

    def _write(self, target: Path, data: bytes) -> None:
        """Write ``target`` whole or not at all (temporary, then rename); on failure
        no temporary is left."""
        temporary, handle = self._new_temporary(target)
        try:
            with os.fdopen(handle, "wb") as stream:
                stream.write(data)
            os.replace(temporary, target)
        finally:
            temporary.unlink(missing_ok=True)

    # -- sharing the cache between runs and maintenance --------------------------

    def _record_text(self, what: str) -> str:
        return f"pid {os.getpid()} on {socket.gethostname()}: {what}"

    def live_runs(self) -> list[str]:
        """What each process using the cache now is doing (its run record)."""
        found = []
        for record in sorted((self.root / _RUNS).glob("*")):
            if record.name == self.run_id:
                continue
            text = _alive(record)
            if text is not None:
                found.append(text)
        return found

    @contextmanager
    def session(self, what: str, wait: float = RUN_WAIT,
                on_wait: Callable[[str], None] | None = None) -> Iterator[None]:
        """Use the cache for a run: shared with other runs, never with maintenance.

        Holds the cache's lock shared and a run record naming ``what`` (locked: its
        temporaries are known to be alive). A cache that cannot be written (read-only,
        or its folder cannot be made) is used without the lock.

        Raises
        ------
        CacheBusy
            If maintenance holds the cache for more than ``wait`` seconds.
        """
        with self._locked(fcntl.LOCK_SH, what, wait, on_wait,
                          "cache maintenance ({holders}) is using {root}; run again when "
                          "it has finished"):
            yield

    @contextmanager
    def maintenance(self, what: str, wait: float = 0.0,
                    on_wait: Callable[[str], None] | None = None) -> Iterator[None]:
        """Hold the cache alone (prune, verify): no run reads or writes it meanwhile.

        Raises
        ------
        CacheBusy
            If runs still use it after ``wait`` seconds; the message names them.
        """
        with self._locked(fcntl.LOCK_EX, what, wait, on_wait,
                          "in use by {holders}; try again when it has finished, or give "
                          "it time with --wait SECONDS"):
            yield

    @contextmanager
    def _locked(self, mode: int, what: str, wait: float,
                on_wait: Callable[[str], None] | None, busy: str) -> Iterator[None]:
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError:
            pass
        lock = _open_lock(self.root / _LOCK)
        if lock is None:  # a read-only cache: nobody can change it, nothing to lock
            yield
            return
        # The run record exists for as long as the lock is held or awaited, so a process
        # refused by the lock always finds it and names the holder.
        record = self._open_record(what)
        try:
            deadline = time.monotonic() + max(0.0, wait)
            told = False
            while True:
                try:
                    fcntl.flock(lock, mode | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    runs = self.live_runs()
                    if not runs:
                        # A holder removes its record only after letting go of the lock:
                        # no record left means it has just let go, so the lock is free
                        # now (unless a process without a record holds it).
                        try:
                            fcntl.flock(lock, mode | fcntl.LOCK_NB)
                            break
                        except BlockingIOError:
                            runs = self.live_runs()
                    holders = "; ".join(runs) or "another process"
                    if time.monotonic() >= deadline:
                        raise CacheBusy(f"{self.root}: "
                                        + busy.format(holders=holders, root=self.root)
                                        ) from None
                    if not told and on_wait is not None:
                        on_wait(f"{self.root}: waiting up to {wait:.0f} s for {holders}")
                        told = True
                    time.sleep(_POLL)
            yield
        finally:
            os.close(lock)
            if record is not None:
                (self.root / _RUNS / self.run_id).unlink(missing_ok=True)
                os.close(record)

    def _open_record(self, what: str) -> int | None:
        """This session's run record, locked for as long as it is open."""
        path = self.root / _RUNS / self.run_id
        try:
            path.parent.mkdir(exist_ok=True)
            record = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        except OSError:
            return None
        fcntl.flock(record, fcntl.LOCK_EX)
        os.write(record, self._record_text(what).encode())
        return record

    # -- housekeeping ----------------------------------------------------------

    def _entry_folders(self) -> list[Path]:
        """Every entry folder (``<key[:2]>/<key>``), links and files among them left out."""
        found = []
        try:
            shards = sorted(os.scandir(self.root), key=lambda e: e.name)
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

    def entries(self) -> Iterator[CacheEntry]:
        """Every entry under the root, with size and age (reads each block's layout
        only; never fails on a damaged file, never follows a link)."""
        for folder in self._entry_folders():
            try:
                entry = json.loads(_read_regular(folder / _ENTRY, _MAX_ENTRY_BYTES))
                content = entry["content"]
                if not isinstance(content, dict):
                    content = {}
            except Exception:  # absent or damaged: shown as unknown
                content = {}
            blocks, points, unreadable, size, modified = 0, 0, 0, 0, 0.0
            try:
                files = list(os.scandir(folder))
            except OSError:
                files = []
            for item in files:
                try:
                    info = item.stat(follow_symlinks=False)
                except OSError:
                    continue
                size += info.st_size if stat.S_ISREG(info.st_mode) else 0
                modified = max(modified, info.st_mtime)
                if not (item.name.startswith("block-") and item.name.endswith(".npz")):
                    continue
                blocks += 1
                try:
                    points += _block_points(Path(item.path))
                except Exception:  # any damage: counted, not fatal
                    unreadable += 1
            yield CacheEntry(
                key=folder.name, path=folder, content=content, blocks=blocks,
                points=points, size=size, modified=modified,
                current_format=bool(content) and _same_key(content, folder.name),
                unreadable=unreadable,
            )

    def quarantine_files(self) -> list[Path]:
        """Files moved aside (in the quarantine folder)."""
        folder = self.root / QUARANTINE
        if os.path.islink(folder) or not folder.is_dir():
            return []
        # Leaves: files, links, and folders found in place of a file (empty).
        return sorted(p for p in folder.rglob("*")
                      if p.is_symlink() or not p.is_dir() or not any(p.iterdir()))

    def remove_quarantine(self) -> int:
        """Delete the quarantine folder; the number of files it held."""
        files = len(self.quarantine_files())
        folder = self.root / QUARANTINE
        if os.path.islink(folder):
            folder.unlink()
        else:
            shutil.rmtree(folder, ignore_errors=True)
        return files

    def remove(self, key: str) -> None:
        """Delete one entry (a link in its place is removed, never followed)."""
        folder = self.entry_path(key)
        if os.path.islink(folder):
            folder.unlink(missing_ok=True)
        else:
            shutil.rmtree(folder, ignore_errors=True)
        self._indexes.pop(key, None)
        self._axes_written = {p for p in self._axes_written if p.parent.name != key}

    def clean_temporaries(self, older_than: float = 3600.0) -> int:
        """Remove temporaries of dead writers: older than ``older_than`` seconds AND
        their run's record no longer locked (its process is gone). This session's
        own temporaries and those of live runs are never touched."""
        now = time.time()
        removed = 0
        for folder in self._entry_folders():
            for path in folder.glob(".*.tmp"):
                found = _CACHE_TEMPORARY.match(path.name)
                if found is None or found["run"] == self.run_id:
                    continue
                try:
                    if now - os.lstat(path).st_mtime <= older_than:
                        continue
                    if found["run"] and _alive(self.root / _RUNS / found["run"]) is not None:
                        continue
                    path.unlink()
                    removed += 1
                except OSError:
                    continue
        for record in (self.root / _RUNS).glob("*"):  # records of killed runs
            if record.name != self.run_id and _alive(record) is None:
                record.unlink(missing_ok=True)
        return removed

    def verify(self) -> VerifyReport:
        """Read and check every block, axis file and entry record; move the bad ones
        into the quarantine folder (call under :meth:`maintenance`)."""
        report = VerifyReport()
        report.temporaries = self.clean_temporaries()
        before = len(self.quarantined)
        for folder in self._entry_folders():
            key = folder.name
            report.entries += 1
            entry = folder / _ENTRY
            if os.path.lexists(entry):
                try:
                    recorded = json.loads(_read_regular(entry, _MAX_ENTRY_BYTES))
                    if recorded.get("cache_format") != CACHE_FORMAT:
                        report.other_layout += 1
                        continue
                    if recorded.get("key") != key or not _same_key(recorded["content"], key):
                        raise _Bad("does not match its entry's key")
                except FileNotFoundError:
                    pass
                except _Bad as err:
                    self._quarantine(entry, str(err), "")
                except Exception as err:  # any damage
                    self._quarantine(entry, f"unreadable ({type(err).__name__}: {err})", "")
            axes_ok = set()
            for path in sorted(folder.glob("axis-*.bin")):
                report.axes += 1
                try:
                    report.size += os.lstat(path).st_size
                    self._read_axis(path)
                    axes_ok.add(path.stem.removeprefix("axis-"))
                except FileNotFoundError:
                    continue
                except (_Bad, OSError) as err:
                    self._quarantine(path, str(err), "")
            for path in sorted(folder.glob("block-*.npz")):
                report.blocks += 1
                try:
                    report.size += os.lstat(path).st_size
                    meta, _ = self._read_block(path, key)
                    if str(meta["a_sha256"]) not in axes_ok:
                        raise _Bad("its acceleration axis is missing or damaged")
                except FileNotFoundError:
                    continue
                except (_Bad, OSError) as err:
                    self._quarantine(path, str(err), "")
        report.bad = self.quarantined[before:]
        return report


def _same_key(content: Any, key: str) -> bool:
    try:
        return entry_key(content) == key
    except (TypeError, ValueError):
        return False


def _block_points(path: Path) -> int:
    """Points of a block, from its layout only (raises on any damage)."""
    with _open_regular(path, MAX_BLOCK_BYTES) as stream, zipfile.ZipFile(stream) as archive:
        shape = json.loads(archive.read(_META))["shape"]
    return int(shape[0]) * int(shape[1])


def _decode_axis_checked(data: bytes) -> NDArray[np.float64]:
    try:
        return _decode_axis(data)
    except ValueError as err:
        raise _Bad(f"unreadable ({err})") from None


def _open_lock(path: Path) -> int | None:
    """The cache's lock file, opened (read-only if the cache is), or None if it
    cannot be (a read-only cache without one)."""
    flags = os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
    try:
        return os.open(path, os.O_RDWR | os.O_CREAT | flags, 0o666 & ~_umask())
    except OSError:
        pass
    try:
        return os.open(path, os.O_RDONLY | flags)
    except OSError:
        return None


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def _alive(record: Path) -> str | None:
    """The text of a run record whose process still holds it, else None."""
    try:
        handle = os.open(record, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:
        return None
    try:
        if not stat.S_ISREG(os.fstat(handle).st_mode):
            return None
        try:
            fcntl.flock(handle, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return os.read(handle, 4096).decode(errors="replace").strip() or "a run"
        return None
    finally:
        os.close(handle)


def _check_block(meta: dict[str, Any], arrays: dict[str, NDArray[Any]]) -> str:
    """Why a block's arrays cannot be used, or '' if they can (shapes were decoded from
    the block's layout, so the checksums decide)."""
    for name, array in arrays.items():
        if meta["sha256"].get(name) != _array_sha256(array):
            return f"{name} does not match its checksum"
    return ""


