"""A run killed while it holds a result's lock (SIGKILL: no cleanup runs) leaves its
lock file; the kernel drops its flock, so the next run takes the lock, removes the file
when it ends and says on stderr whose lock it cleared (a real process, killed)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

from study.engine.store import exclusive

TIMEOUT = 120

HOLDER = """
import sys, time
from pathlib import Path
from study.engine.store import exclusive
with exclusive(Path(sys.argv[1])):
    print("held", flush=True)
    time.sleep(600)
"""


def test_the_lock_of_a_killed_run_is_cleared_with_a_note(tmp_path: Path, capsys) -> None:
    output = tmp_path / "own.nc"
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(output)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None
        assert holder.stdout.readline().strip() == "held"
        lock = tmp_path / ".own.nc.lock"
        assert lock.read_text() == f"pid {holder.pid}"
    finally:
        os.kill(holder.pid, signal.SIGKILL)
        holder.communicate(timeout=TIMEOUT)
    assert lock.exists()  # killed: nothing removed it
    with exclusive(output):
        assert lock.read_text() == f"pid {os.getpid()}"
    assert not lock.exists()
    err = capsys.readouterr().err
    assert (f"cleared a lock left by pid {holder.pid}, which is no longer running"
            in err)
