"""Computed values kept for reuse: resume, extend, refine and overlap without recomputing.

:class:`ResultCache` is the cache of one folder as a run and ``study cache`` use it:
kept values looked up at a grid (read back through an index of each entry's blocks,
bad files moved aside and their values recomputed) and new blocks kept. What it
stands on is in modules of their own: the on-disk layout, the keys and the encodings
(:mod:`study.engine.cache_format`), sharing the cache between processes, its lock and
its whole-or-nothing writes (:mod:`study.engine.cache_sharing`), and its health:
listing, quarantine and ``verify`` (:mod:`study.engine.cache_health`).
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import shutil
import stat
import uuid
from collections import OrderedDict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.engine.cache_format import (
    CACHE_FORMAT,
    ENTRY_FILE,
    UnusableFile,
    array_sha256,
    encode_array,
    encode_block,
    read_axis,
    read_block,
)
from study.engine.cache_health import (
    CacheEntry,
    Quarantined,
    VerifyReport,
    check_entries,
    delete_quarantine,
    files_in_quarantine,
    list_entries,
    move_aside,
)
from study.engine.cache_sharing import (
    RUN_WAIT,
    hold_lock,
    live_records,
    new_temporary,
    remove_dead_temporaries,
    write_whole,
)
from study.engine.files import file_kind

__all__ = ["ResultCache"]

#: Decompressed blocks kept in memory while a chunk's values are gathered.
_BLOCKS_IN_MEMORY = 8


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
        item = move_aside(self.root, path, why)
        if item is None:
            return None
        self.quarantined.append(item)
        self.warn(item.message(consequence))
        return item

    # -- reading ---------------------------------------------------------------

    def _open_block(self, path: Path, key: str, axes_only: bool = False
                    ) -> tuple[dict[str, Any], dict[str, NDArray[Any]]] | None:
        """:func:`study.engine.cache_format.read_block`, or None after moving a bad
        block aside (or if gone)."""
        if path in self._skipped:
            return None
        try:
            return read_block(path, key, axes_only)
        except FileNotFoundError:
            return None
        except UnusableFile as err:
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

    def _axis(self, key: str, index: _Index, a_sha256: str
              ) -> tuple[NDArray[np.float64], NDArray[np.intp]] | None:
        """An acceleration axis of the entry and its sort order, read once per session
        and verified against the sha256 that names it; a bad axis file is moved aside."""
        if a_sha256 not in index.axes:
            path = self._axis_path(key, a_sha256)
            axis = None
            try:
                values = read_axis(path)
            except FileNotFoundError:
                pass
            except UnusableFile as err:
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
            Entry key (:func:`study.engine.cache_format.entry_key`).
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
        """Keep a block encoded by :func:`study.engine.cache_format.encode_block` under
        ``key``; ``a`` is the block's acceleration axis (written once per entry).

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
        entry_file = folder / ENTRY_FILE
        if not os.path.lexists(entry_file):
            self._write(entry_file, json.dumps(
                {"key": key, "cache_format": CACHE_FORMAT, "content": content},
                sort_keys=True, indent=1).encode())
        a = np.ascontiguousarray(a, dtype=np.float64)
        axis_file = self._axis_path(key, array_sha256(a))
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
        path, handle = new_temporary(target, self.run_id)
        os.close(handle)
        return path

    def _write(self, target: Path, data: bytes) -> None:
        """Write ``target`` whole or not at all (temporary, then rename); on failure
        no temporary is left."""
        write_whole(target, data, self.run_id)

    # -- sharing the cache between runs and maintenance --------------------------

    def live_runs(self) -> list[str]:
        """What each process using the cache now is doing (its run record)."""
        return live_records(self.root, self.run_id)

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
        with hold_lock(self.root, self.run_id, fcntl.LOCK_SH, what, wait, on_wait,
                       "cache maintenance ({holders}) is using {root}; run again when "
                       "it has finished", self.live_runs):
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
        with hold_lock(self.root, self.run_id, fcntl.LOCK_EX, what, wait, on_wait,
                       "in use by {holders}; try again when it has finished, or give "
                       "it time with --wait SECONDS", self.live_runs):
            yield

    # -- housekeeping ----------------------------------------------------------

    def entries(self) -> Iterator[CacheEntry]:
        """Every entry under the root, with size and age (reads each block's layout
        only; never fails on a damaged file, never follows a link)."""
        return list_entries(self.root)

    def quarantine_files(self) -> list[Path]:
        """Files moved aside (in the quarantine folder)."""
        return files_in_quarantine(self.root)

    def remove_quarantine(self) -> int:
        """Delete the quarantine folder; the number of files it held."""
        return delete_quarantine(self.root)

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
        return remove_dead_temporaries(self.root, self.run_id, older_than)

    def verify(self) -> VerifyReport:
        """Read and check every block, axis file and entry record; move the bad ones
        into the quarantine folder (call under :meth:`maintenance`)."""
        report = VerifyReport()
        report.temporaries = self.clean_temporaries()
        before = len(self.quarantined)
        check_entries(self.root, report, self._quarantine)
        report.bad = self.quarantined[before:]
        return report
