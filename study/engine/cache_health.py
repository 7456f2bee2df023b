"""A cache's health: what ``study cache list`` shows of it, damaged files moved aside
into its quarantine, and the checks of ``study cache verify``.

A file that fails its checks (truncated, garbled, a wrong checksum, not a regular file,
a link, larger than any block: :class:`study.engine.cache_format.UnusableFile`) is
moved into ``<root>/quarantine/`` (:func:`move_aside`) with one warning naming it, and
its values are recomputed: never reused, never fatal.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from study.engine.cache_format import (
    CACHE_FORMAT,
    ENTRY_FILE,
    MAX_ENTRY_BYTES,
    UnusableFile,
    block_points,
    entry_folders,
    entry_key,
    read_axis,
    read_block,
    read_cache_file,
)

__all__ = [
    "QUARANTINE",
    "CacheEntry",
    "Quarantined",
    "VerifyReport",
    "check_entries",
    "delete_quarantine",
    "files_in_quarantine",
    "list_entries",
    "move_aside",
]

#: Folder inside the cache where unreadable files are moved; never read again.
QUARANTINE = "quarantine"


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
        Written in this version's layout
        (:data:`study.engine.cache_format.CACHE_FORMAT`); entries of other layouts are
        never read and can be pruned.
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
    """What :meth:`study.engine.cache.ResultCache.verify` found.

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


def move_aside(root: Path, path: Path, why: str) -> Quarantined | None:
    """Move ``path`` (itself, never a link's target) into the quarantine folder of the
    cache ``root``.

    Parameters
    ----------
    root : pathlib.Path
        The cache folder.
    path : pathlib.Path
        The unusable file (or folder, or link).
    why : str
        Why it cannot be used.

    Returns
    -------
    Quarantined or None
        Where it went (``moved_to`` None if it could not be moved); None if it is
        gone already (another process moved it).
    """
    try:
        relative = path.relative_to(root)
    except ValueError:
        relative = Path(path.name)
    # Where it was, under the quarantine folder; a suffix if that name is taken.
    target = root / QUARANTINE / relative
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
    return Quarantined(path, why, moved_to)


def list_entries(root: Path) -> Iterator[CacheEntry]:
    """Every entry under the cache folder ``root``, with size and age (reads each
    block's layout only; never fails on a damaged file, never follows a link).

    Parameters
    ----------
    root : pathlib.Path

    Yields
    ------
    CacheEntry
    """
    for folder in entry_folders(root):
        try:
            entry = json.loads(read_cache_file(folder / ENTRY_FILE, MAX_ENTRY_BYTES))
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
                points += block_points(Path(item.path))
            except Exception:  # any damage: counted, not fatal
                unreadable += 1
        yield CacheEntry(
            key=folder.name, path=folder, content=content, blocks=blocks,
            points=points, size=size, modified=modified,
            current_format=bool(content) and _same_key(content, folder.name),
            unreadable=unreadable,
        )


def files_in_quarantine(root: Path) -> list[Path]:
    """Files moved aside (in the quarantine folder of the cache ``root``).

    Parameters
    ----------
    root : pathlib.Path

    Returns
    -------
    list of pathlib.Path
        Sorted.
    """
    folder = root / QUARANTINE
    if os.path.islink(folder) or not folder.is_dir():
        return []
    # Leaves: files, links, and folders found in place of a file (empty).
    return sorted(p for p in folder.rglob("*")
                  if p.is_symlink() or not p.is_dir() or not any(p.iterdir()))


def delete_quarantine(root: Path) -> int:
    """Delete the quarantine folder of the cache ``root`` (a link in its place is
    removed, never followed).

    Parameters
    ----------
    root : pathlib.Path

    Returns
    -------
    int
        The number of files it held.
    """
    files = len(files_in_quarantine(root))
    folder = root / QUARANTINE
    if os.path.islink(folder):
        folder.unlink()
    else:
        shutil.rmtree(folder, ignore_errors=True)
    return files


def check_entries(root: Path, report: VerifyReport,
                  quarantine: Callable[[Path, str, str], object]) -> None:
    """Read and check every block, axis file and entry record of the cache ``root``,
    counting them in ``report``.

    Parameters
    ----------
    root : pathlib.Path
        The cache folder.
    report : VerifyReport
        Its ``entries``, ``blocks``, ``axes``, ``size`` and ``other_layout`` are added to.
    quarantine : callable
        Called with (path, why, consequence) for each file that fails, to move it
        aside.
    """
    for folder in entry_folders(root):
        key = folder.name
        report.entries += 1
        entry = folder / ENTRY_FILE
        if os.path.lexists(entry):
            try:
                recorded = json.loads(read_cache_file(entry, MAX_ENTRY_BYTES))
                if recorded.get("cache_format") != CACHE_FORMAT:
                    report.other_layout += 1
                    continue
                if recorded.get("key") != key or not _same_key(recorded["content"], key):
                    raise UnusableFile("does not match its entry's key")
            except FileNotFoundError:
                pass
            except UnusableFile as err:
                quarantine(entry, str(err), "")
            except Exception as err:  # any damage
                quarantine(entry, f"unreadable ({type(err).__name__}: {err})", "")
        axes_ok = set()
        for path in sorted(folder.glob("axis-*.bin")):
            report.axes += 1
            try:
                report.size += os.lstat(path).st_size
                read_axis(path)
                axes_ok.add(path.stem.removeprefix("axis-"))
            except FileNotFoundError:
                continue
            except (UnusableFile, OSError) as err:
                quarantine(path, str(err), "")
        for path in sorted(folder.glob("block-*.npz")):
            report.blocks += 1
            try:
                report.size += os.lstat(path).st_size
                meta, _ = read_block(path, key)
                if str(meta["a_sha256"]) not in axes_ok:
                    raise UnusableFile("its acceleration axis is missing or damaged")
            except FileNotFoundError:
                continue
            except (UnusableFile, OSError) as err:
                quarantine(path, str(err), "")


def _same_key(content: Any, key: str) -> bool:
    try:
        return entry_key(content) == key
    except (TypeError, ValueError):
        return False
