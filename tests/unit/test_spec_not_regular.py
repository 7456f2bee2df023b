"""A spec named by a FIFO, a device or a folder is refused in one line, never waited on
(found by the command-line fuzz tier: `study design FIFO` hung)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from study.cli import main
from tests.unit.test_cache_health import deadline


@pytest.mark.parametrize("command", ["run", "design", "fit"])
def test_a_fifo_device_or_folder_as_the_spec_is_refused(command: str, tmp_path: Path,
                                                        capsys) -> None:
    fifo = tmp_path / "spec.toml"
    os.mkfifo(fifo)
    for path, kind in ((fifo, "a FIFO"), (Path("/dev/zero"), "a device"),
                       (Path("/dev/null"), "a device")):
        with deadline(20):
            status = main([command, str(path), "-o", str(tmp_path / "out.nc")])
        err = capsys.readouterr().err
        assert status == 1 and err.startswith(f"study: {path}: {kind}, not a regular file"), err
    with deadline(20):
        assert main([command, str(tmp_path), "-o", str(tmp_path / "out.nc")]) == 1
    assert capsys.readouterr().err.count("\n") == 1
