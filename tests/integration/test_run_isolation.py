"""Runs are kept apart: each removes only its own temporaries, and cache maintenance
waits for (or refuses) a live run instead of deleting what it reads or writes.

The concurrent cases run real processes (``study run`` and ``study cache prune``),
each under a timeout; they assert on outcomes (a valid result, bit-identical to a
clean run), never on timings.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from study.cli import main
from study.engine.runner import StudyInterrupted, run_study
from study.engine.store import exclusive, new_temporary, open_result
from tests.support.tiers import headline
from tests.unit.test_incremental import spec_text

TIMEOUT = 300


def test_a_run_keeps_the_temporary_of_another_output_in_its_folder(tmp_path):
    """A run writing D/test must not delete the temporary of a live run writing D/test.nc."""
    (tmp_path / "test.toml").write_text(spec_text(name="test"))
    other = tmp_path / "test.nc"
    with exclusive(other):  # a live run writing test.nc, mid-way
        theirs = new_temporary(other)
        theirs.write_bytes(b"half a result")
        run_study(tmp_path / "test.toml", tmp_path / "test", progress=False)
        assert theirs.read_bytes() == b"half a result"
        theirs.unlink()
    assert open_result(tmp_path / "test")["velocity"].size == 45


def test_a_run_removes_temporaries_of_a_killed_writer_of_its_own_output(tmp_path):
    (tmp_path / "inc.toml").write_text(spec_text())
    output = tmp_path / "inc.nc"
    with exclusive(output):
        dead = new_temporary(output)  # the writer is then killed: its lock goes
    dead.write_bytes(b"\0" * 1000)
    unrelated = [tmp_path / ".inc.nc.x.tmp", tmp_path / ".inc.nc.orig"]
    for path in unrelated:
        path.write_bytes(b"someone else's")
    run_study(tmp_path / "inc.toml", output, progress=False)
    assert not dead.exists()
    assert all(path.read_bytes() == b"someone else's" for path in unrelated)


def test_temporaries_of_two_outputs_are_never_the_same_name(tmp_path):
    names = {new_temporary(tmp_path / name).name for name in ("a", "a.nc", "a.nc.nc")}
    assert len(names) == 3
    assert len({new_temporary(tmp_path / "a").name for _ in range(20)}) == 20


# ---------------------------------------------------------------------------
# Cache maintenance against live runs (real processes)

#: Enough chunks (one f row each) that prunes land while the run computes.
LONG = spec_text(name="long", f="start = 12.0, stop = 16.0, num = 160",
                 a="start = 2.0, stop = 10.0, num = 41").replace("chunk_points = 10",
                                                                 "chunk_points = 20")


def study(*args: str, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "study.cli", *args], cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def finish(process: subprocess.Popen) -> tuple[int, str, str]:
    out, err = process.communicate(timeout=TIMEOUT)
    return process.returncode, out, err


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    folder = tmp_path_factory.mktemp("reference")
    (folder / "long.toml").write_text(LONG)
    run_study(folder / "long.toml", folder / "long.nc", progress=False, cache=folder / "c")
    result = open_result(folder / "long.nc")
    return {name: result[name].values.copy() for name in ("velocity", "status")}


def started(folder: Path, cache: Path) -> subprocess.Popen:
    """A run, once it has kept a block of its own (it is computing) or has ended."""
    before = set(cache.glob("??/*/block-*.npz"))
    run = study("run", "long.toml", "-o", "long.nc", "--cache", str(cache), "--no-progress",
                "--workers", "1", cwd=folder)
    for _ in range(TIMEOUT * 20):
        if set(cache.glob("??/*/block-*.npz")) - before or run.poll() is not None:
            break
        time.sleep(0.05)
    return run


def assert_reference(folder: Path, reference) -> None:
    result = open_result(folder / "long.nc")
    for name, values in reference.items():
        np.testing.assert_array_equal(result[name].values, values)


@pytest.mark.parametrize("trial", headline(range(3)))
def test_prunes_against_a_live_run_never_break_it(tmp_path, reference, trial, capsys):
    """``cache prune --all`` again and again while a run computes: each one refuses
    (one line naming the run) or finds the cache free; the run ends with the reference
    values and leaves a cache in which every block is readable."""
    (tmp_path / "long.toml").write_text(LONG)
    cache = tmp_path / "cache"
    if trial:  # start with kept values the prunes want to delete
        with pytest.raises(StudyInterrupted):
            run_study(tmp_path / "long.toml", tmp_path / "first.nc", progress=False,
                      cache=cache, stop_after=10 * trial, workers=1)
    run = started(tmp_path, cache)
    outcomes, refusals = [], []
    try:
        # Until one prune finds the cache free: the run has let go of it (it is ending).
        while run.poll() is None and 0 not in outcomes and len(outcomes) < 10_000:
            outcomes.append(main(["cache", "prune", "--all", "--cache", str(cache),
                                  "--wait", "0"]))
            _, err = capsys.readouterr()
            if outcomes[-1] == 1:
                refusals.append(err)
    finally:
        # Waited for even when a check fails: a run left behind would warn in later tests.
        run_status, _, run_err = finish(run)
    for err in refusals:
        assert err.count("\n") == 1 and "pid" in err and "--wait" in err, err
    assert run_status == 0 and "Traceback" not in run_err, run_err
    assert set(outcomes) <= {0, 1}
    assert_reference(tmp_path, reference)
    assert main(["cache", "verify", "--cache", str(cache), "--wait", "0"]) == 0
    assert "0 bad" in capsys.readouterr().out
    # The cache holds all the run kept, or nothing (a prune after the run): never part.
    report = run_study(tmp_path / "long.toml", tmp_path / "again.nc", progress=False,
                       cache=cache)
    assert report.points_computed in (0, report.points)


def test_prune_waits_for_a_live_run(tmp_path, reference):
    (tmp_path / "long.toml").write_text(LONG)
    cache = tmp_path / "cache"
    run = started(tmp_path, cache)
    prune = study("cache", "prune", "--all", "--cache", str(cache), "--wait", str(TIMEOUT),
                  cwd=tmp_path)
    status, out, err = finish(prune)
    run_status, _, run_err = finish(run)
    assert status == 0 and run_status == 0, err + run_err
    assert "Traceback" not in err + run_err
    assert_reference(tmp_path, reference)
    # The prune came after the run: it removed every block the run kept, whole.
    assert "removed 1 of 1 entries" in out
    assert not list(cache.glob("??/*/*"))


def test_a_run_waits_for_maintenance_then_proceeds(tmp_path, reference):
    from study.engine.cache import ResultCache

    (tmp_path / "long.toml").write_text(LONG)
    cache = ResultCache(tmp_path / "cache")
    with cache.maintenance("a test holding the cache"):
        run = study("run", "long.toml", "-o", "long.nc", "--cache", str(cache.root),
                    "--no-progress", cwd=tmp_path)
        # The run says it waits (its first line on stderr), then waits.
        line = run.stderr.readline()
        assert "waiting" in line and "a test holding the cache" in line, line
        assert run.poll() is None
    run_status, _, run_err = finish(run)
    assert run_status == 0, run_err
    assert_reference(tmp_path, reference)


def test_a_stale_cache_temporary_goes_only_when_its_owner_is_dead(tmp_path):
    from study.engine.cache import ResultCache

    cache = ResultCache(tmp_path / "cache")
    with cache.session("test"):
        cache.store("ab" * 32, {}, np.array([1.0]), np.array([2.0]),
                    {"velocity": np.zeros((1, 1))})
    folder = cache.entry_path("ab" * 32)
    live = ResultCache(cache.root)
    with live.session("a live run"):
        mine = live.temporary(folder / "block-x.npz")
        mine.write_bytes(b"being written")
        old = time.time() - 10 * 86400
        os.utime(mine, (old, old))
        other = ResultCache(cache.root)
        with other.session("another run"):
            other.clean_temporaries(older_than=0.0)
        assert mine.exists()  # old, but its owner is alive
    # Its owner is gone now (the session ended without removing it: a killed run).
    assert mine.exists()
    with other.session("a later run"):
        assert other.clean_temporaries(older_than=0.0) == 1
    assert not mine.exists()
