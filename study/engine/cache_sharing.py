"""One cache shared by several processes: the cache's lock, the records naming the runs
that use it, and writes that a reader never sees half done.

A file is written to a temporary name and renamed (:func:`write_whole`), so a reader
never sees half a block and several writers (processes) can share a cache. Runs hold
the cache's lock (``<root>/.lock``) shared, for as long as they run
(:meth:`study.engine.cache.ResultCache.session`); maintenance (``study cache prune``,
``verify``) holds it exclusively (:meth:`study.engine.cache.ResultCache.maintenance`),
so it never removes a block a run reads or has just written. Each process using the cache
keeps a locked record in ``<root>/runs/`` naming it; a temporary carries its run's id
and is removed only when it is old and its run's record is no longer locked (the run is
gone: :func:`remove_dead_temporaries`).
"""

from __future__ import annotations

import fcntl
import os
import re
import socket
import stat
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from study.engine.cache_format import entry_folders
from study.engine.store import StoreBusy

__all__ = [
    "RUN_WAIT",
    "CacheBusy",
    "hold_lock",
    "live_records",
    "new_temporary",
    "remove_dead_temporaries",
    "write_whole",
]

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


def new_temporary(target: Path, run_id: str) -> tuple[Path, int]:
    """A new temporary for ``target``, created empty and open for writing.

    Parameters
    ----------
    target : pathlib.Path
        The file it is to become.
    run_id : str
        The run's id (32 hex), which names it.

    Returns
    -------
    path : pathlib.Path
        ``.<name>.study-<run id>.tmp`` beside ``target``.
    handle : int
        Its file descriptor (the caller closes it).

    Raises
    ------
    OSError
        If it cannot be made (it exists, a read-only cache...).
    """
    # One write at a time per session: the run id alone makes the name unique.
    path = target.with_name(f".{target.name}.study-{run_id}.tmp")
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
    return path, os.open(path, flags, 0o666 & ~_umask())


def write_whole(target: Path, data: bytes, run_id: str) -> None:
    """Write ``target`` whole or not at all (temporary, then rename); on failure
    no temporary is left.

    Parameters
    ----------
    target : pathlib.Path
    data : bytes
    run_id : str
        The run's id, which names the temporary (:func:`new_temporary`).

    Raises
    ------
    OSError
        If it cannot be written (disk full, read-only cache).
    """
    temporary, handle = new_temporary(target, run_id)
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
        os.replace(temporary, target)
    finally:
        temporary.unlink(missing_ok=True)


def _record_text(what: str) -> str:
    return f"pid {os.getpid()} on {socket.gethostname()}: {what}"


def live_records(root: Path, run_id: str) -> list[str]:
    """What each process using the cache ``root`` now is doing (its run record), but
    the run ``run_id``.

    Parameters
    ----------
    root : pathlib.Path
        The cache folder.
    run_id : str
        The asking run's id: its own record is left out.

    Returns
    -------
    list of str
        One line per live run.
    """
    found = []
    for record in sorted((root / _RUNS).glob("*")):
        if record.name == run_id:
            continue
        text = _alive(record)
        if text is not None:
            found.append(text)
    return found


@contextmanager
def hold_lock(root: Path, run_id: str, mode: int, what: str, wait: float,
              on_wait: Callable[[str], None] | None, busy: str,
              live_runs: Callable[[], list[str]]) -> Iterator[None]:
    """Hold the cache's lock (and a run record naming ``what``) for the ``with`` block.

    A cache that cannot be written (read-only, or its folder cannot be made) is used
    without the lock.

    Parameters
    ----------
    root : pathlib.Path
        The cache folder.
    run_id : str
        The run's id, which names its record.
    mode : int
        ``fcntl.LOCK_SH`` (a run) or ``fcntl.LOCK_EX`` (maintenance).
    what : str
        What the run does (its record's text).
    wait : float
        How long to wait for the lock [s].
    on_wait : callable or None
        Told once, with one line, when the lock is awaited.
    busy : str
        The refusal's text, with ``{holders}`` and ``{root}`` to fill in.
    live_runs : callable
        The other runs using the cache now (:func:`live_records`): named in the
        refusal, and none left means the holder has just let go.

    Raises
    ------
    CacheBusy
        If the lock is not had within ``wait`` seconds.
    """
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError:
        pass
    lock = _open_lock(root / _LOCK)
    if lock is None:  # a read-only cache: nobody can change it, nothing to lock
        yield
        return
    # The run record exists for as long as the lock is held or awaited, so a process
    # refused by the lock always finds it and names the holder.
    record = _open_record(root, run_id, what)
    try:
        deadline = time.monotonic() + max(0.0, wait)
        told = False
        while True:
            try:
                fcntl.flock(lock, mode | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                runs = live_runs()
                if not runs:
                    # A holder removes its record only after letting go of the lock:
                    # no record left means it has just let go, so the lock is free
                    # now (unless a process without a record holds it).
                    try:
                        fcntl.flock(lock, mode | fcntl.LOCK_NB)
                        break
                    except BlockingIOError:
                        runs = live_runs()
                holders = "; ".join(runs) or "another process"
                if time.monotonic() >= deadline:
                    raise CacheBusy(f"{root}: "
                                    + busy.format(holders=holders, root=root)
                                    ) from None
                if not told and on_wait is not None:
                    on_wait(f"{root}: waiting up to {wait:.0f} s for {holders}")
                    told = True
                time.sleep(_POLL)
        yield
    finally:
        os.close(lock)
        if record is not None:
            (root / _RUNS / run_id).unlink(missing_ok=True)
            os.close(record)


def _open_record(root: Path, run_id: str, what: str) -> int | None:
    """This session's run record, locked for as long as it is open."""
    path = root / _RUNS / run_id
    try:
        path.parent.mkdir(exist_ok=True)
        record = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
    except OSError:
        return None
    fcntl.flock(record, fcntl.LOCK_EX)
    os.write(record, _record_text(what).encode())
    return record


def remove_dead_temporaries(root: Path, run_id: str, older_than: float = 3600.0) -> int:
    """Remove temporaries of dead writers: older than ``older_than`` seconds AND
    their run's record no longer locked (its process is gone). The run ``run_id``'s
    own temporaries and those of live runs are never touched; the records of killed
    runs are removed too.

    Parameters
    ----------
    root : pathlib.Path
        The cache folder.
    run_id : str
        The asking run's id.
    older_than : float
        Age a temporary must have [s].

    Returns
    -------
    int
        Temporaries removed.
    """
    now = time.time()
    removed = 0
    for folder in entry_folders(root):
        for path in folder.glob(".*.tmp"):
            found = _CACHE_TEMPORARY.match(path.name)
            if found is None or found["run"] == run_id:
                continue
            try:
                if now - os.lstat(path).st_mtime <= older_than:
                    continue
                if found["run"] and _alive(root / _RUNS / found["run"]) is not None:
                    continue
                path.unlink()
                removed += 1
            except OSError:
                continue
    for record in (root / _RUNS).glob("*"):  # records of killed runs
        if record.name != run_id and _alive(record) is None:
            record.unlink(missing_ok=True)
    return removed


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
