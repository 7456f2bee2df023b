"""Computed values kept for reuse: resume, extend, refine and overlap without recomputing.

Values of the cached observables are kept in *entries*, one per (observable,
structure, solver settings, code fingerprint): the entry's key is the sha256 of
that content, so values are found again whatever grid they are part of. An entry
is a folder ``<root>/<key[:2]>/<key>/`` holding ``entry.json`` (the content the key
hashes) and *blocks*: rectangles of drive frequencies x accelerations, each one
zip file (the npz layout, deflate level 1) with the block's own copy of the key,
its layout and a sha256 of every array. A block is verified against all of that
before its values are used; one that fails is removed, never reused.

Blocks are written to a temporary name and renamed, so a reader never sees half
a block and several writers (processes) can share a cache.
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
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["CACHE_FORMAT", "CacheEntry", "ResultCache", "entry_key"]

#: Version of the on-disk layout; part of every key.
CACHE_FORMAT = 1
_ENTRY = "entry.json"
_META = "meta.json"
#: Decompressed blocks kept in memory while a chunk's values are gathered.
_BLOCKS_IN_MEMORY = 8


def entry_key(content: dict[str, Any]) -> str:
    """sha256 of an entry's content (canonical JSON) [64 hex]."""
    blob = json.dumps({"cache_format": CACHE_FORMAT, **content}, sort_keys=True,
                      separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()


def _array_sha256(array: NDArray[Any]) -> str:
    return hashlib.sha256(np.ascontiguousarray(array).tobytes()).hexdigest()


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
    """

    key: str
    path: Path
    content: dict[str, Any]
    blocks: int
    points: int
    size: int
    modified: float


class _Index:
    """Rows (f values) of every block of one entry, sorted for lookups."""

    def __init__(self, blocks: list[tuple[Path, NDArray[np.float64], NDArray[np.float64]]]):
        self.paths = [path for path, _, _ in blocks]
        self.a_values = [a for _, _, a in blocks]
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
        #: Blocks found corrupt or foreign and removed in this session.
        self.discarded: list[str] = []

    # -- layout ----------------------------------------------------------------

    def entry_path(self, key: str) -> Path:
        """Folder of the entry ``key``."""
        return self.root / key[:2] / key

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
                    ) -> dict[str, NDArray[Any]] | None:
        """A block's arrays (only ``f`` and ``a`` if ``axes_only``) after verifying its
        key, layout and the checksum of every array read; a bad block is removed."""
        try:
            with zipfile.ZipFile(path) as archive:
                meta = json.loads(archive.read(_META))
                names = ("f", "a") if axes_only else ("f", "a", *meta["variables"])
                arrays = {}
                for name in names:
                    with archive.open(f"{name}.npy") as stream:
                        arrays[name] = np.lib.format.read_array(
                            io.BytesIO(stream.read()), allow_pickle=False)
                problem = _check_block(meta, arrays, key)
        except (OSError, ValueError, KeyError, TypeError, IndexError, zipfile.BadZipFile,
                EOFError) as err:
            self._discard(path, f"unreadable ({type(err).__name__}: {err})")
            return None
        if problem:
            self._discard(path, problem)
            return None
        return arrays

    def _block(self, path: Path, key: str) -> dict[str, NDArray[Any]] | None:
        if path in self._blocks:
            self._blocks.move_to_end(path)
            return self._blocks[path]
        arrays = self._open_block(path, key)
        self._blocks[path] = arrays
        if len(self._blocks) > _BLOCKS_IN_MEMORY:
            self._blocks.popitem(last=False)
        return arrays

    def _index(self, key: str) -> _Index:
        """The entry's row index, read once per session (blocks written later by this
        session cover other points, so they are not needed for its own lookups)."""
        if key not in self._indexes:
            layouts = []
            for path in self._block_paths(key):
                arrays = self._open_block(path, key, axes_only=True)
                if arrays is not None:
                    layouts.append((path, arrays["f"], arrays["a"]))
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
            ``(n_f,)`` drive frequencies [Hz] and ``(n_a,)`` accelerations [m s^-2].
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
            block_a = index.a_values[b]
            sorter = np.argsort(block_a, kind="stable")
            pos = np.searchsorted(block_a, a, sorter=sorter)
            pos = np.minimum(pos, block_a.size - 1)
            columns = sorter[pos]
            match = block_a[columns] == a
            if not match.any():
                continue
            arrays = self._block(index.paths[b], key)
            if arrays is None or not all(name in arrays for name in variables):
                continue
            cols_query = np.flatnonzero(match)
            cols_block = columns[match]
            for name in variables:
                values[name][np.ix_(rows_here, cols_query)] = (
                    arrays[name][np.ix_(block_rows, cols_block)])
            found[np.ix_(rows_here, cols_query)] = True
        return values, found

    # -- writing ---------------------------------------------------------------

    def store(self, key: str, content: dict[str, Any], f: NDArray[np.float64],
              a: NDArray[np.float64], arrays: dict[str, NDArray[Any]]) -> Path:
        """Keep a computed block ``f x a`` (each array ``(n_f, n_a)``) under ``key``."""
        folder = self.entry_path(key)
        folder.mkdir(parents=True, exist_ok=True)
        entry_file = folder / _ENTRY
        if not entry_file.exists():
            _write_atomic_bytes(entry_file, json.dumps(
                {"key": key, "content": content}, sort_keys=True, indent=1).encode())
        payload = {"f": np.asarray(f, dtype=np.float64), "a": np.asarray(a, dtype=np.float64),
                   **arrays}
        meta = {
            "key": key,
            "variables": sorted(arrays),
            "shape": [int(np.size(f)), int(np.size(a))],
            "dtypes": {name: array.dtype.str for name, array in payload.items()},
            "sha256": {name: _array_sha256(array) for name, array in payload.items()},
            "created": time.time(),
        }
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED,
                             compresslevel=1) as archive:
            archive.writestr(_META, json.dumps(meta, sort_keys=True))
            for name, array in payload.items():
                stream = io.BytesIO()
                np.lib.format.write_array(stream, np.ascontiguousarray(array),
                                          allow_pickle=False)
                archive.writestr(f"{name}.npy", stream.getvalue())
        target = folder / f"block-{uuid.uuid4().hex}.npz"
        _write_atomic_bytes(target, buffer.getvalue())
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
            )

    def remove(self, key: str) -> None:
        """Delete one entry."""
        shutil.rmtree(self.entry_path(key), ignore_errors=True)
        self._indexes.pop(key, None)

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


def _check_block(meta: dict[str, Any], arrays: dict[str, NDArray[Any]], key: str) -> str:
    """Why a block cannot be used, or '' if it can."""
    if meta.get("key") != key:
        return "belongs to another entry"
    n_f, n_a = meta["shape"]
    if arrays["f"].shape != (n_f,) or arrays["a"].shape != (n_a,):
        return "layout does not match its axes"
    for name, array in arrays.items():
        if name not in ("f", "a") and array.shape != (n_f, n_a):
            return f"{name} has shape {array.shape}, expected {(n_f, n_a)}"
        if meta["dtypes"].get(name) != array.dtype.str:
            return f"{name} has dtype {array.dtype.str}"
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
