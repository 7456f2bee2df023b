"""A run's lock (``.<name>.lock`` beside the result) lasts as long as the run: it is gone
when the run ends, successfully or not; one left by a killed run is cleared with a note;
two holders at once are still refused, also when a holder removes the file while
another opens it (in-process; the killed process is tests/integration/test_lock_cleanup.py).
"""

from __future__ import annotations

import fcntl
from contextlib import ExitStack
from pathlib import Path

import pytest

import study
from study.engine.runner import StudyInterrupted, run_study
from study.engine.store import StoreBusy, exclusive
from tests.unit.test_incremental import spec_text

#: Above the largest pid Linux hands out (2**22): a process that is surely not running.
DEAD_PID = 2**22 + 1


def locks(folder: Path) -> list[Path]:
    return sorted(folder.rglob(".*.lock"))


def test_no_lock_stays_after_a_successful_run(tmp_path: Path) -> None:
    spec = tmp_path / "inc.toml"
    spec.write_text(spec_text())
    ds = study.run(spec, tmp_path / "own" / "inc.nc", cache=tmp_path / "cache", workers=1)
    assert ds["velocity"].size == 45
    assert locks(tmp_path / "own") == []
    # A rerun that finds the file current, and one that recomputes it, leave none either.
    study.run(spec, tmp_path / "own" / "inc.nc", cache=tmp_path / "cache", workers=1)
    study.run(spec, tmp_path / "own" / "inc.nc", cache=tmp_path / "cache", workers=1,
              force=True)
    assert locks(tmp_path) == []


def test_no_lock_stays_after_a_run_that_raises(tmp_path: Path) -> None:
    spec = tmp_path / "inc.toml"
    spec.write_text(spec_text())
    with pytest.raises(StudyInterrupted):
        run_study(spec, tmp_path / "inc.nc", cache=tmp_path / "cache", stop_after=0,
                  progress=False)
    assert locks(tmp_path) == []
    with pytest.raises(RuntimeError, match="inside"), exclusive(tmp_path / "x.nc"):
        raise RuntimeError("inside the run")
    assert locks(tmp_path) == []


def test_a_stale_lock_of_a_dead_pid_is_cleared_with_a_note(tmp_path: Path, capsys) -> None:
    spec = tmp_path / "inc.toml"
    spec.write_text(spec_text())
    stale = tmp_path / ".inc.nc.lock"
    stale.write_text(f"pid {DEAD_PID}")  # a run killed mid-way: file kept, flock gone
    run_study(spec, tmp_path / "inc.nc", cache=tmp_path / "cache", progress=False)
    err = capsys.readouterr().err
    assert f"cleared a lock left by pid {DEAD_PID}, which is no longer running" in err
    assert str(stale) in err
    assert locks(tmp_path) == []


def test_a_lock_of_a_live_process_or_of_no_pid_is_taken_without_a_note(tmp_path: Path,
                                                                       capsys) -> None:
    for text in ("pid 1", "", "written by some other tool"):  # pid 1 always runs
        (tmp_path / ".x.nc.lock").write_text(text)
        with exclusive(tmp_path / "x.nc"):
            assert (tmp_path / ".x.nc.lock").read_text().startswith("pid ")
        assert locks(tmp_path) == []
    assert "cleared" not in capsys.readouterr().err


def test_two_holders_at_once_are_refused_and_the_refused_one_removes_nothing(
        tmp_path: Path) -> None:
    output = tmp_path / "x.nc"
    lock = tmp_path / ".x.nc.lock"
    with exclusive(output):
        held = lock.stat().st_ino
        for _ in range(2):
            with pytest.raises(StoreBusy, match=r"another run is writing this result \(pid "):
                with exclusive(output):
                    pytest.fail("a second holder")
            assert lock.stat().st_ino == held  # still there, still the holder's
    assert locks(tmp_path) == []
    with exclusive(output):  # free again
        pass


def test_a_lock_held_by_another_open_file_is_refused(tmp_path: Path) -> None:
    """A holder that is not :func:`exclusive` (an older release, another tool)."""
    output = tmp_path / "x.nc"
    with open(tmp_path / ".x.nc.lock", "a+") as other:
        fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(StoreBusy):
            with exclusive(output):
                pass
        assert (tmp_path / ".x.nc.lock").exists()  # not ours to remove


def test_a_lock_removed_by_its_holder_while_another_opens_it_is_taken_anew(
        tmp_path: Path, monkeypatch) -> None:
    """The race: B opens the file, A ends (removes it, then releases it), B locks the
    file A removed. B must see that the path no longer names it and lock the path's
    current file, else a third run C would create and lock a new file while B runs."""
    output = tmp_path / "x.nc"
    lock = tmp_path / ".x.nc.lock"
    a = ExitStack()
    a.enter_context(exclusive(output))
    real_flock = fcntl.flock
    calls = []

    def flock_after_a_ends(fd, operation):  # B's flock, just after A has ended
        calls.append(fd)
        if len(calls) == 1:
            a.close()
        return real_flock(fd, operation)

    with monkeypatch.context() as patched:
        patched.setattr(fcntl, "flock", flock_after_a_ends)
        b = ExitStack()
        b.enter_context(exclusive(output))
    assert len(calls) == 2  # the removed file, then the path's new one
    assert lock.exists() and lock.read_text().startswith("pid ")
    with pytest.raises(StoreBusy):  # C is refused while B runs
        with exclusive(output):
            pass
    b.close()
    assert locks(tmp_path) == []
