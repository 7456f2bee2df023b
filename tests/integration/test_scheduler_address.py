"""A scheduler address that is none, and an empty cache folder, are refused at once
with one line, before any connection or computation (study.engine.executors.check_address)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from study.engine.executors import ClusterError, check_address
from tests.support.tiers import headline

SPEC = """\
[study]
name = "addressed"
observables = ["velocity"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = { start = 10.0, stop = 20.0, num = 3 }
a = { start = 0.0, stop = 12.0, num = 3 }
"""


@pytest.mark.parametrize("address", ["garbage", "tcp://host", "tcp://:8786", "tcp://h:x",
                                     "", "8786"])
def test_what_is_no_address_is_refused(address: str) -> None:
    with pytest.raises(ClusterError, match="expected tcp://HOST:PORT"):
        check_address(address)


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:8786", "127.0.0.1:8786",
                                     "tls://scheduler.cluster:8786", "tcp://[::1]:8786",
                                     "inproc://10.0.0.1/1/1"])
def test_addresses_dask_takes_pass(address: str) -> None:
    assert check_address(address) == address


def test_the_command_refuses_garbage_in_one_line_at_once(tmp_path: Path) -> None:
    (tmp_path / "spec.toml").write_text(SPEC)
    done = subprocess.run(
        [sys.executable, "-m", "study.cli", "run", "spec.toml", "--scheduler", "garbage"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        "study: --scheduler 'garbage' is not a dask scheduler address (missing port "
        "number in address 'garbage'); expected tcp://HOST:PORT, e.g. "
        "tcp://127.0.0.1:8786"]
    assert not (tmp_path / "results" / "spec.nc").exists()


def test_an_empty_cache_folder_is_a_usage_error(tmp_path: Path) -> None:
    (tmp_path / "spec.toml").write_text(SPEC)
    done = subprocess.run(
        [sys.executable, "-m", "study.cli", "run", "spec.toml", "--cache", ""],
        cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert "an empty folder name" in done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.toml"]


@pytest.mark.parametrize("value", headline(["0", "-1", "nan", "inf", "soon"]))
def test_a_task_timeout_is_a_positive_number_of_seconds(tmp_path: Path, value: str) -> None:
    (tmp_path / "spec.toml").write_text(SPEC)
    done = subprocess.run(
        [sys.executable, "-m", "study.cli", "run", "spec.toml", "--task-timeout", value],
        cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert f"{value!r}: need a number of seconds > 0" in done.stderr
