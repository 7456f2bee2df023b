"""Results on disk: one writer per file, written as values arrive, never half-written.

A result file is written to a temporary file in the destination folder, block by
block as values arrive (chunked, compressed netCDF-4 variables: memory never holds
the whole result), then closed, sealed (a content checksum, then streaming
validation) and only then renamed over the final name: a reader never sees a
half-written file, and a failed write leaves the previous result intact. One
process at a time writes a given result (:func:`exclusive`); temporaries left by
a killed writer are removed by the next writer of the same file.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

# Validation and reading live in study.engine.validation; re-exported for callers of the store.
from study.engine.validation import (  # noqa: F401
    RESULT_SCHEMA,
    RESULT_SCHEMA_PATH,
    SCENE_SCHEMA,
    SCENE_SCHEMA_PATH,
    ResultError,
    describe,
    header,
    open_result,
    seal,
)

__all__ = [
    "PAPER_REFERENCE",
    "RESULT_SCHEMA",
    "GridWriter",
    "ResultError",
    "StoreBusy",
    "StoreError",
    "advice",
    "clean_temporaries",
    "commit",
    "describe",
    "exclusive",
    "file_attributes",
    "new_temporary",
    "open_result",
    "rewrite_attributes",
    "temporary_path",
    "temporary_target",
    "write_atomic",
]

PAPER_REFERENCE = (
    "T. Barois, A. Boucherie, L. Tadrist and H. Kellay, Controlled locomotion of a "
    "minimal soft structure by stick-slip nonlinearity"
)


# ---------------------------------------------------------------------------
# Writing a dataset held in memory (small results: scenes)


def _encoding(dataset: xr.Dataset) -> dict[str, dict[str, Any]]:
    encoding = {}
    for name, var in dataset.variables.items():
        enc: dict[str, Any] = {}
        # CF: coordinates have no fill value; NaN marks the points without a velocity.
        if var.dtype.kind == "f" and name not in dataset.coords:
            enc["_FillValue"] = np.nan
        else:
            enc["_FillValue"] = None
        if var.ndim >= 2:
            enc.update(zlib=True, complevel=1, shuffle=True)
        encoding[name] = enc
    return encoding


def write_atomic(dataset: xr.Dataset, path: str | Path) -> Path:
    """Write a result file so that ``path`` is never half-written.

    Writes ``dataset`` to a temporary file in the same folder, closes it, seals it
    (content checksum, then validation: :func:`study.engine.validation.seal`), then renames
    it over ``path`` (atomic on POSIX).

    Raises
    ------
    ResultError
        If the written file does not validate; ``path`` is then left untouched.
    """
    path = Path(path)
    temporary = new_temporary(path)
    try:
        dataset.to_netcdf(temporary, engine="netcdf4", format="NETCDF4",
                          encoding=_encoding(dataset))
    except (OSError, RuntimeError) as err:
        temporary.unlink(missing_ok=True)
        raise _store_error(path, err) from None
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return commit(temporary, path)



# ---------------------------------------------------------------------------
# Writing as values arrive


class StoreError(RuntimeError):
    """A result cannot be written (disk full, no permission...); one line, file named."""


#: What a user can do about an OSError, by errno.
_ADVICE = {
    errno.ENOSPC: "free space on that disk or write elsewhere (-o)",
    errno.EDQUOT: "free space within your quota or write elsewhere (-o)",
    errno.EROFS: "the file system is read-only: write elsewhere (-o)",
    errno.EACCES: "make the folder writable for you or write elsewhere (-o)",
    errno.EPERM: "make the folder writable for you or write elsewhere (-o)",
    errno.ENOTDIR: "a file stands where a folder is needed: write elsewhere (-o)",
    errno.EISDIR: "a folder stands where the result goes: write elsewhere (-o)",
}


def advice(err: OSError) -> str:
    """What to do about ``err``, for a one-line message ('' if nothing specific)."""
    return _ADVICE.get(err.errno or 0, "")


def _diagnose(folder: Path) -> OSError | None:
    """The likely cause of a write that failed without one (the netCDF library says
    only "HDF error"): a full disk or a folder not writable, or None."""
    try:
        space = os.statvfs(folder)
        if space.f_bavail * space.f_frsize < 2**20:
            return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        if space.f_flag & os.ST_RDONLY:
            return OSError(errno.EROFS, os.strerror(errno.EROFS))
    except OSError:
        return None
    if not os.access(folder, os.W_OK):
        return OSError(errno.EACCES, os.strerror(errno.EACCES))
    return None


def _store_error(target: Path, err: OSError | RuntimeError) -> StoreError:
    if not isinstance(err, OSError):  # netCDF4: RuntimeError("NetCDF: HDF error")
        err = _diagnose(target.parent) or OSError(0, str(err))
    reason = err.strerror or str(err)
    what_to_do = advice(err)
    # Whether computed values survive is the runner's to say: it knows whether any were.
    return StoreError(f"{target}: cannot write the result ({reason}); any previous result "
                      "is unchanged" + (f"; {what_to_do}" if what_to_do else ""))


@contextmanager
def exclusive(output: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``output`` for the whole run (one writer per file).

    The lock is the file ``.<name>.lock`` beside ``output``, flocked and holding the
    holder's pid. It lasts only as long as the run: the holder removes it when the run
    ends, successfully or not, while still holding the flock, so no lock file stays
    behind. A second process may have opened the file just before it went; it then
    locks a file no longer at that path, sees so (the path names another inode, or
    none) and starts again on the path's current file: at any time at most one process
    holds the lock on the file the path names. A run that was killed leaves its file,
    but the kernel releases its flock: the next run takes it, and says on stderr that
    it cleared the lock of a process no longer running.

    Raises
    ------
    StoreBusy
        If another process holds it; its message names the holder.
    """
    import fcntl

    lock_path = output.with_name(f".{output.name}.lock")
    try:
        # The lock lives beside the result, so the result's folder must exist first.
        output.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise _store_error(output, err) from None
    while True:
        try:
            lock = os.open(lock_path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
        except OSError as err:
            raise _store_error(output, err) from None
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _read_lock(lock) or "another process"
            os.close(lock)
            raise StoreBusy(
                f"{output}: another run is writing this result ({holder}); wait for it "
                "to finish, or stop it: its computed values are kept and reused"
            ) from None
        except BaseException:
            os.close(lock)
            raise
        if _same_file(lock, lock_path):
            break
        # The holder removed this file as we opened it: take the one now at the path.
        os.close(lock)
    try:
        _note_stale(lock_path, _read_lock(lock))
        os.ftruncate(lock, 0)
        os.pwrite(lock, f"pid {os.getpid()}".encode(), 0)
        yield
    finally:
        # Removed while still held: whoever opened it meanwhile finds it gone (above).
        try:
            lock_path.unlink(missing_ok=True)
        finally:
            os.close(lock)  # releases the flock


def _read_lock(lock: int) -> str:
    """What a lock file says of its holder (``"pid 1234"``), '' if nothing readable."""
    try:
        return os.pread(lock, 256, 0).decode("utf-8", "replace").strip()
    except OSError:
        return ""


def _same_file(lock: int, path: Path) -> bool:
    """Whether ``path`` still names the file open as ``lock``."""
    try:
        named = os.stat(path, follow_symlinks=False)
    except FileNotFoundError:
        return False
    held = os.fstat(lock)
    return (named.st_dev, named.st_ino) == (held.st_dev, held.st_ino)


def _note_stale(lock_path: Path, holder: str) -> None:
    """Say on stderr that ``lock_path`` was left by a run that is no longer running
    (killed: its flock went with it, its file stayed)."""
    import sys

    found = re.fullmatch(r"pid (\d+)", holder)
    if found is None:
        return
    pid = int(found[1])
    if pid == os.getpid() or _running(pid):
        return
    print(f"study: note: {lock_path}: cleared a lock left by pid {pid}, which is no "
          "longer running", file=sys.stderr, flush=True)


def _running(pid: int) -> bool:
    """Whether process ``pid`` exists (on this machine)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # another user's process, or not a pid at all: say nothing
    return True


class StoreBusy(RuntimeError):
    """Another process is writing the same result file."""


#: A temporary's name: ``.<output name>.study-<run id>.tmp``; the run id (32 hex
#: digits, unique per temporary) makes the name of one output's temporary never match
#: another output's, whatever the names (``test`` and ``test.nc`` in one folder).
_TEMPORARY = re.compile(r"^\.(?P<name>.+)\.study-(?P<run>[0-9a-f]{32})\.tmp$")
#: Temporaries of releases before the run id (``tempfile.mkstemp``: 8 characters).
_OLD_TEMPORARY = re.compile(r"^\.(?P<name>.+)\.(?P<run>[a-z0-9_]{8})\.tmp$")


def temporary_path(target: Path) -> Path:
    """A new, unique temporary name beside ``target`` (see :data:`_TEMPORARY`)."""
    return target.with_name(f".{target.name}.study-{uuid.uuid4().hex}.tmp")


def temporary_target(path: Path) -> str | None:
    """The name of the file the temporary ``path`` was to become, or None if ``path``
    is not a temporary of this package."""
    found = _TEMPORARY.match(path.name) or _OLD_TEMPORARY.match(path.name)
    return found["name"] if found else None


def new_temporary(output: Path) -> Path:
    """A fresh temporary file next to ``output`` (same file system: rename is atomic),
    readable as the umask allows (a result is for sharing)."""
    umask = os.umask(0)
    os.umask(umask)
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
        path = temporary_path(output)
        handle = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW,
                         0o666 & ~umask)
    except OSError as err:
        raise _store_error(output, err) from None
    os.close(handle)
    return path


def clean_temporaries(output: Path) -> int:
    """Remove temporaries of ``output`` left by killed runs (call under :func:`exclusive`).

    Only temporaries of exactly ``output`` go: every writer of ``output`` holds its
    lock, and the caller holds it now, so their writers are gone. Temporaries of
    other outputs in the folder (``test`` and ``test.nc``) are never touched.
    """
    removed = 0
    try:
        candidates = list(output.parent.iterdir())
    except OSError:
        return 0
    for path in candidates:
        if temporary_target(path) != output.name:
            continue
        try:
            path.unlink()
            removed += 1
        except OSError:
            continue
    return removed


def commit(temporary: Path, output: Path) -> Path:
    """Seal and validate ``temporary``, then rename it over ``output`` (atomic).

    On any failure ``temporary`` is removed and ``output`` is left as it was.
    """
    try:
        seal(temporary)  # the content checksum, then streaming validation
        os.replace(temporary, output)
    except (OSError, RuntimeError) as err:
        raise _store_error(output, err) from None
    finally:
        temporary.unlink(missing_ok=True)
    return output


def file_attributes(path: Path) -> dict[str, Any] | None:
    """Global attributes of a netCDF file (metadata only), or None if unreadable."""
    import netCDF4

    if not path.is_file():
        return None
    try:
        with netCDF4.Dataset(path, "r") as dataset:
            return {name: dataset.getncattr(name) for name in dataset.ncattrs()}
    except Exception:  # netCDF4 raises OSError, RuntimeError, ... for a bad file
        return None


def rewrite_attributes(output: Path, attrs: dict[str, Any]) -> Path:
    """Replace global attributes of ``output`` without touching its data (atomic)."""
    import netCDF4

    temporary = new_temporary(output)
    try:
        shutil.copyfile(output, temporary)
        with netCDF4.Dataset(temporary, "a") as dataset:
            for name, value in attrs.items():
                dataset.setncattr(name, value)
    except (OSError, RuntimeError) as err:
        temporary.unlink(missing_ok=True)
        raise _store_error(output, err) from None
    return commit(temporary, output)


class GridWriter:
    """A result file being written block by block (netCDF-4, HDF5 chunks = blocks).

    Parameters
    ----------
    path : pathlib.Path
        The temporary file (see :func:`new_temporary`).
    attrs : dict
        Global attributes.
    target : pathlib.Path, optional
        The result file the temporary becomes (named in error messages).
    """

    def __init__(self, path: Path, attrs: dict[str, Any], target: Path | None = None) -> None:
        import netCDF4

        self.path = path
        self.target = path if target is None else target
        with self._writing():
            self.dataset = netCDF4.Dataset(path, "w", format="NETCDF4")
            self.dataset.set_auto_mask(False)
            self.dataset.setncatts(attrs)

    @contextmanager
    def _writing(self) -> Iterator[None]:
        """Turn a failed write (OSError, or netCDF's RuntimeError "HDF error": a full
        disk) into one :class:`StoreError` naming the result file."""
        try:
            yield
        except (OSError, RuntimeError) as err:
            raise _store_error(self.target, err) from None

    def coordinate(self, name: str, dims: tuple[str, ...], values: Any,
                   attrs: dict[str, Any]) -> None:
        """A coordinate variable (a dimension of its own if ``dims == (name,)``)."""
        values = np.asarray(values)
        with self._writing():
            if dims == (name,):
                self.dataset.createDimension(name, values.size)
            if values.dtype.kind == "U":  # labels: netCDF strings
                var = self.dataset.createVariable(name, str, dims)
                var.setncatts(attrs)
                var[:] = values.astype(object)
                return
            var = self.dataset.createVariable(name, values.dtype, dims)
            var.setncatts(attrs)
            var[...] = values

    def dimension(self, name: str, size: int) -> None:
        """A dimension without a coordinate variable."""
        with self._writing():
            self.dataset.createDimension(name, size)

    def variable(self, name: str, dims: tuple[str, ...], dtype: str, attrs: dict[str, Any],
                 chunks: tuple[int, ...]) -> None:
        """A data variable, compressed, in HDF5 chunks of ``chunks``."""
        dtype_ = np.dtype(dtype)
        # CF: NaN marks the points without a value; integer flags have no fill value.
        fill = np.nan if dtype_.kind == "f" else False
        with self._writing():
            var = self.dataset.createVariable(name, dtype_, dims, zlib=True, complevel=1,
                                              shuffle=True, chunksizes=chunks,
                                              fill_value=fill)
        # Every write covers whole chunks, written once: with a cache too small for any
        # chunk, HDF5 compresses and writes each chunk during ``write`` (while the
        # workers compute the next ones) instead of holding up to the default 64 MiB
        # per variable and compressing it all in ``close``, after the last chunk, when
        # nothing overlaps. (A size of 0 would mean "keep the default" to netCDF.)
        var.set_var_chunk_cache(size=1, nelems=1, preemption=1.0)
        var.setncatts(attrs)

    def write(self, name: str, index: tuple[Any, ...], values: np.ndarray) -> None:
        """Write ``values`` at ``index`` of variable ``name`` (whole chunks of a data
        variable, each once: partial chunks are read, changed and compressed again)."""
        with self._writing():
            self._put(name, index, values)

    def _put(self, name: str, index: tuple[Any, ...], values: np.ndarray) -> None:
        self.dataset.variables[name][index] = values

    def read(self, name: str, index: tuple[Any, ...]) -> np.ndarray:
        """Read back part of a variable."""
        return np.asarray(self.dataset.variables[name][index])

    def set_attributes(self, attrs: dict[str, Any]) -> None:
        """Add or replace global attributes."""
        with self._writing():
            self.dataset.setncatts(attrs)

    def close(self) -> None:
        """Close the file (idempotent)."""
        if hasattr(self, "dataset") and self.dataset.isopen():
            with self._writing():
                self.dataset.close()

    def discard(self) -> None:
        """Close and delete the temporary after a failure (never raises)."""
        try:
            self.close()
        except Exception:  # the first failure is the one reported
            pass
        finally:
            self.path.unlink(missing_ok=True)
