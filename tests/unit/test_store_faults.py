"""Full and read-only disks: one line naming the path and what to do, no traceback,
no temporary left behind, the previous result untouched.

Faults are injected by patching the writers (the tests run as root, for whom
``chmod`` does not make a folder read-only): ``ENOSPC`` from the result writer, the
netCDF library's bare "HDF error" on a full disk, the final rename, and ``EROFS`` from
every write into a folder or the cache.
"""

from __future__ import annotations

import builtins
import errno
import io
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from study.cli import main
from study.engine.runner import run_study
from study.engine.store import open_result
from tests.unit.test_incremental import spec_text


@pytest.fixture
def previous(tmp_path):
    """A finished result and its bytes (a fault must leave them as they are)."""
    (tmp_path / "inc.toml").write_text(spec_text())
    run_study(tmp_path / "inc.toml", tmp_path / "inc.nc", progress=False)
    return tmp_path, (tmp_path / "inc.nc").read_bytes()


def rerun(folder: Path, capsys) -> tuple[int, str]:
    capsys.readouterr()
    status = main(["run", str(folder / "inc.toml"), "-o", str(folder / "inc.nc"), "--force",
                   "--no-progress"])
    return status, capsys.readouterr().err


def temporaries(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.name.endswith(".tmp")]


def assert_one_line_and_untouched(folder: Path, before: bytes, err: str, *words: str) -> None:
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert str(folder / "inc.nc") in err
    for word in words:
        assert word in err, err
    assert (folder / "inc.nc").read_bytes() == before
    assert not temporaries(folder)


def full_disk(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_a_full_disk_while_writing(previous, capsys, monkeypatch):
    folder, before = previous
    monkeypatch.setattr("study.engine.store.GridWriter._put", full_disk)
    status, err = rerun(folder, capsys)
    assert status == 1
    assert_one_line_and_untouched(folder, before, err, "No space left on device",
                                  "free space")


def test_the_netcdf_library_s_bare_hdf_error_on_a_full_disk(previous, capsys, monkeypatch):
    """netCDF4 says only "NetCDF: HDF error"; the message says why (the disk is full)."""
    folder, before = previous

    def hdf_error(*args, **kwargs):
        raise RuntimeError("NetCDF: HDF error")

    monkeypatch.setattr("study.engine.store.GridWriter._put", hdf_error)
    monkeypatch.setattr(os, "statvfs", lambda path: SimpleNamespace(
        f_bavail=0, f_frsize=4096, f_flag=0))
    status, err = rerun(folder, capsys)
    assert status == 1
    assert_one_line_and_untouched(folder, before, err, "No space left on device",
                                  "free space")


def test_a_full_disk_at_the_final_rename(previous, capsys, monkeypatch):
    folder, before = previous
    replace = os.replace

    def failing(source, target, *args, **kwargs):
        if Path(target) == folder / "inc.nc":
            full_disk()
        return replace(source, target, *args, **kwargs)

    monkeypatch.setattr(os, "replace", failing)
    status, err = rerun(folder, capsys)
    assert status == 1
    assert_one_line_and_untouched(folder, before, err, "No space left on device")


def read_only(monkeypatch, folder: Path) -> None:
    """Every write into ``folder`` fails with EROFS (creating, renaming, removing)."""
    folder = folder.resolve()

    def inside(path) -> bool:
        try:
            return Path(os.fspath(path)).resolve().is_relative_to(folder)
        except (TypeError, ValueError):
            return False

    def refuse(path):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(path))

    real_open, real_io_open = os.open, io.open
    writing = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_APPEND

    def os_open(path, flags, *args, **kwargs):
        if flags & writing and inside(path):
            refuse(path)
        return real_open(path, flags, *args, **kwargs)

    def io_open(file, mode="r", *args, **kwargs):
        if isinstance(file, str | bytes | os.PathLike) and set(mode) & set("wax+") \
                and inside(file):
            refuse(file)
        return real_io_open(file, mode, *args, **kwargs)

    def guard(function):
        def guarded(*args, **kwargs):
            if any(inside(a) for a in args[:2]):
                refuse(args[0])
            return function(*args, **kwargs)
        return guarded

    monkeypatch.setattr(os, "open", os_open)
    monkeypatch.setattr(builtins, "open", io_open)
    monkeypatch.setattr(io, "open", io_open)
    for name in ("mkdir", "rename", "replace", "unlink", "rmdir", "utime"):
        monkeypatch.setattr(os, name, guard(getattr(os, name)))


def test_a_read_only_result_folder(previous, capsys, monkeypatch):
    folder, before = previous
    read_only(monkeypatch, folder)
    status, err = rerun(folder, capsys)
    monkeypatch.undo()
    assert status == 1
    assert_one_line_and_untouched(folder, before, err, "Read-only file system",
                                  "write elsewhere (-o)")


def test_a_read_only_cache_is_one_warning_and_the_result_is_written(tmp_path, capsys,
                                                                    monkeypatch):
    (tmp_path / "inc.toml").write_text(spec_text())
    cache = tmp_path / "cache"
    run_study(tmp_path / "inc.toml", tmp_path / "first.nc", progress=False, cache=cache,
              workers=1)
    reference = open_result(tmp_path / "first.nc")["velocity"].values
    # A wider grid: part of it is kept (read), the rest computed (and not kept).
    (tmp_path / "inc.toml").write_text(spec_text(f="start = 12.0, stop = 16.0, num = 17"))
    read_only(monkeypatch, cache)
    capsys.readouterr()
    status = main(["run", str(tmp_path / "inc.toml"), "-o", str(tmp_path / "inc.nc"),
                   "--cache", str(cache), "--no-progress"])
    err = capsys.readouterr().err
    monkeypatch.undo()
    assert status == 0, err
    assert err.count("\n") == 1 and str(cache) in err and "Read-only file system" in err
    result = open_result(tmp_path / "inc.nc")["velocity"].values
    np.testing.assert_array_equal(result[::2], reference)  # the kept values, read back
    assert not temporaries(tmp_path)


def test_a_full_cache_disk_is_one_warning_and_the_result_is_written(previous, capsys,
                                                                    monkeypatch):
    folder, _ = previous
    reference = open_result(folder / "inc.nc")["velocity"].values
    for block in (folder / ".study-cache").glob("??/*/block-*.npz"):
        block.unlink()  # everything must be computed again, and kept
    monkeypatch.setattr("study.engine.cache.ResultCache._write", full_disk)
    status, err = rerun(folder, capsys)
    assert status == 0, err
    assert err.count("\n") == 1 and "No space left on device" in err
    np.testing.assert_array_equal(open_result(folder / "inc.nc")["velocity"].values,
                                  reference)
    assert not temporaries(folder)
