"""Real distributed runs: a `dask scheduler` and `dask worker` processes on 127.0.0.1.

Every process listens on port 0 and is started in its own session, so that a kill
removes it for real (``--no-nanny``: no nanny restarts it) and the finalizers can
stop every process they started. Every remote run is bounded in time: a hang
fails the test instead of stopping the suite.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import study
from study.cli import main
from study.engine.executors import ClusterError, executor
from study.engine.provenance import code_sha256
from study.engine.runner import run_study
from study.engine.store import open_result
from tests.unit.test_local_executor import write_spec

DASK = Path(sys.executable).with_name("dask")
# The checkout these tests import study from: the workers import the same one.
PACKAGE_ROOT = Path(study.__file__).resolve().parents[1]
STARTUP = 90.0  # [s] at most, for a process to come up on a loaded machine
RUN = 120.0  # [s] at most, for any run: longer is a hang

# No package named study for the process that runs this sitecustomize.
REFUSE_STUDY = '''\
import sys


class RefuseStudy:
    """A meta-path finder in front of every other: there is no study here."""

    def find_spec(self, name, path=None, target=None):
        if name == "study" or name.startswith("study."):
            raise ModuleNotFoundError(f"No module named {name!r} (refused by the test)")
        return None


sys.meta_path.insert(0, RefuseStudy())
'''


def within(seconds: float, function, *args, **kwargs):
    """``function(*args, **kwargs)``, failing the test if it does not return in time."""
    outcome: dict = {}

    def target() -> None:
        try:
            outcome["value"] = function(*args, **kwargs)
        except BaseException as err:  # handed to the test's thread
            outcome["error"] = err

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(seconds)
    assert not thread.is_alive(), f"{function.__name__} still running after {seconds} s"
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


def assert_same_values(path: Path, reference: Path) -> None:
    remote, local = open_result(path), open_result(reference)
    assert sorted(remote.variables) == sorted(local.variables)
    for name in local.variables:
        np.testing.assert_array_equal(remote[name].values, local[name].values, err_msg=name)


class Cluster:
    """A scheduler process and its worker processes, all on 127.0.0.1, port 0."""

    def __init__(self, folder: Path, *, dashboard: bool) -> None:
        self.folder = folder
        self.processes: list[subprocess.Popen] = []
        self.workers: dict[str, subprocess.Popen] = {}
        scheduler_file = folder / "scheduler.json"
        # Even with --no-dashboard the scheduler serves /health on its HTTP port:
        # port 0 there too, never 8787.
        command = [str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0",
                   "--dashboard-address", "127.0.0.1:0", "--scheduler-file",
                   str(scheduler_file)]
        if not dashboard:
            command.append("--no-dashboard")
        self.scheduler = self._start(command, "scheduler", PACKAGE_ROOT)
        deadline = time.monotonic() + STARTUP
        while not scheduler_file.exists() or not scheduler_file.read_text().strip():
            assert self.scheduler.poll() is None, self.log("scheduler")
            assert time.monotonic() < deadline, "no scheduler: " + self.log("scheduler")
            time.sleep(0.05)
        self.address = json.loads(scheduler_file.read_text())["address"]
        self.scheduler_file = scheduler_file

    def log(self, name: str) -> str:
        return (self.folder / f"{name}.log").read_text(errors="replace")

    def _start(self, command: list[str], name: str, pythonpath: Path) -> subprocess.Popen:
        env = {**os.environ, "PYTHONPATH": str(pythonpath)}
        with open(self.folder / f"{name}.log", "wb") as log:
            process = subprocess.Popen(command, cwd=self.folder, env=env, stdout=log,
                                       stderr=subprocess.STDOUT, start_new_session=True)
        self.processes.append(process)
        return process

    def addresses(self) -> set[str]:
        from distributed import Client

        with Client(self.address, timeout=STARTUP, set_as_default=False) as client:
            return set(client.nthreads())

    def wait_for(self, addresses: set[str] | None = None, count: int | None = None,
                 started: list[subprocess.Popen] = ()) -> set[str]:
        """Wait until the scheduler has ``count`` workers (or these ``addresses``)."""
        from distributed import Client

        deadline = time.monotonic() + STARTUP
        with Client(self.address, timeout=STARTUP, set_as_default=False) as client:
            while True:
                found = set(client.nthreads())
                if (count is None or len(found) == count) and (
                        addresses is None or addresses <= found):
                    return found
                for process in started:
                    assert process.poll() is None, "a worker died while starting"
                assert time.monotonic() < deadline, f"workers: {found}"
                time.sleep(0.05)

    def add_workers(self, count: int = 1, pythonpath: Path = PACKAGE_ROOT) -> list[str]:
        """Start ``count`` single-thread workers; their addresses."""
        before = self.addresses()
        started = [
            self._start([str(DASK), "worker", "--scheduler-file", str(self.scheduler_file),
                         "--nthreads", "1", "--no-nanny", "--no-dashboard", "--host",
                         "127.0.0.1"], f"worker-{len(self.processes)}", pythonpath)
            for _ in range(count)
        ]
        after = self.wait_for(count=len(before) + count, started=started)
        # Which process is which worker: each log names its own address.
        new = sorted(after - before)
        for process in started:
            log = self.log(f"worker-{self.processes.index(process)}")
            (address,) = [a for a in new if a in log]
            self.workers[address] = process
        return [address for address in new]

    def kill(self, address: str) -> None:
        """SIGKILL the worker's whole process group: it is gone, not restarted."""
        process = self.workers.pop(address)
        os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=30)

    def stop(self) -> None:
        """Workers first (a worker outliving its scheduler lingers), then the scheduler."""
        for process in reversed(self.processes):
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGTERM)
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    os.killpg(process.pid, signal.SIGKILL)
                    process.wait(timeout=10)


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    """A scheduler (with a dashboard on port 0) and two good workers, for the module."""
    cluster = Cluster(tmp_path_factory.mktemp("shared"), dashboard=True)
    try:
        cluster.add_workers(2)
        yield cluster
    finally:
        cluster.stop()


@pytest.fixture
def healthy(shared):
    """The shared cluster with two live workers (a test may have killed one)."""
    live = shared.wait_for(started=[])
    missing = 2 - len(live)
    if missing > 0:
        shared.add_workers(missing)
    return shared


@pytest.fixture(scope="module")
def lonely(tmp_path_factory):
    """A scheduler without dashboard and (between tests) without workers."""
    cluster = Cluster(tmp_path_factory.mktemp("lonely"), dashboard=False)
    yield cluster
    cluster.stop()


@pytest.fixture
def empty(lonely):
    """The lonely scheduler; the workers a test adds are killed after it."""
    yield lonely
    for address in list(lonely.workers):
        lonely.kill(address)
    lonely.wait_for(count=0)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A small velocity study (6 chunks) and its local result."""
    folder = tmp_path_factory.mktemp("small")
    spec = write_spec(folder, "small", n_f=6, n_a=5, chunk_points=5)
    # Locally first: it also fills numba's cache the workers load their kernels from.
    report = run_study(spec, folder / "local.nc", workers=2, progress=False)
    assert report.chunks == 6
    return spec, report.output


@pytest.fixture
def other_code(tmp_path) -> Path:
    """A copy of the package whose solver differs by a comment: another code hash."""
    root = tmp_path / "other"
    shutil.copytree(PACKAGE_ROOT / "study", root / "study",
                    ignore=shutil.ignore_patterns("__pycache__"))
    with open(root / "study" / "solvers" / "exact.py", "a") as solver:
        solver.write("# a comment: other source, another code hash\n")
    return root


def test_a_scheduler_run_gives_the_local_values(small, healthy, tmp_path):
    spec, local = small
    report = within(RUN, run_study, spec, tmp_path / "remote.nc", scheduler=healthy.address,
                    progress=False)
    assert report.computed == report.chunks == 6
    assert_same_values(report.output, local)
    run = json.loads(open_result(report.output).attrs["provenance"])["run"]
    assert run["scheduler"] == healthy.address
    assert run["workers"] == 2


def test_the_cli_runs_on_a_scheduler_and_shows_its_dashboard(small, healthy, tmp_path,
                                                             capsys):
    spec, local = small
    output = tmp_path / "cli.nc"
    status = within(RUN, main, ["run", str(spec), "--scheduler", healthy.address,
                                "-o", str(output), "--no-progress"])
    out, err = capsys.readouterr()
    assert status == 0, err
    assert (f"{output}: 30 points (30 computed, 0 reused) in 6 chunks (6 computed, 0 "
            "reused) in ") in out
    assert f"2 threads on the workers of {healthy.address}" in err
    assert "dashboard: http://127.0.0.1:" in err
    assert_same_values(output, local)


def test_a_task_the_workers_cannot_load_ends_the_run(healthy, tmp_path, monkeypatch):
    """Its function lives in a module only this process can import."""
    (tmp_path / "only_here.py").write_text("def square(x):\n    return x * x\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    from only_here import square

    def run():
        with executor(healthy.address, None, code_sha256()) as pool:
            return list(pool.run_unordered(square, [1, 2, 3], label="unloadable"))

    with pytest.raises(ClusterError, match=r"cannot load the task.*only_here"):
        within(RUN, run)


def test_errors_of_the_task_itself_reach_the_caller(healthy):
    def fail(item):
        raise ValueError(f"bad item {item}")

    def run():
        with executor(healthy.address, None, code_sha256()) as pool:
            return list(pool.run_unordered(fail, [7], label="failing"))

    with pytest.raises(ValueError, match="bad item 7"):
        within(RUN, run)


def test_a_worker_killed_mid_run_loses_nothing(healthy, tmp_path):
    spec = write_spec(tmp_path, "slow", n_f=16, n_a=15000, chunk_points=30000,
                      observables='"velocity"')
    local = run_study(spec, tmp_path / "local.nc", workers=2, progress=False)
    assert local.chunks == 8
    (victim, survivor) = sorted(healthy.workers)
    seen = []

    def kill_after_the_first_chunk(number: int) -> None:
        seen.append(number)
        if len(seen) == 1:
            healthy.kill(victim)

    report = within(RUN, run_study, spec, tmp_path / "remote.nc", scheduler=healthy.address,
                    progress=False, on_chunk=kill_after_the_first_chunk,
                    cache=tmp_path / "remote-cache")  # not the local run's values
    # At the first chunk at most four of the eight were even submitted: the others
    # ran after the kill, on the survivor alone.
    assert report.computed == report.chunks == 8 and sorted(seen) == list(range(8))
    assert healthy.addresses() == {survivor}
    assert_same_values(report.output, local.output)


# Slow tier: test_a_worker_killed_mid_run_loses_nothing and the scheduler run keep the
# cluster's headline checks in the default tier (issue 46).
@pytest.mark.slow
def test_a_frozen_worker_ends_the_run_in_bounded_time_and_loses_nothing(healthy,
                                                                        tmp_path):
    """SIGSTOP on a worker mid-run: its task never finishes. The run ends after the task
    timeout with one message naming the worker; the chunks the other worker finished
    are kept, and the next run resumes to the local values."""
    spec = write_spec(tmp_path, "frozen", n_f=16, n_a=15000, chunk_points=30000,
                      observables='"velocity"')
    local = run_study(spec, tmp_path / "local.nc", workers=2, progress=False)
    (victim, _) = sorted(healthy.workers)
    process = healthy.workers[victim]
    seen = []

    def freeze_after_the_first_chunk(number: int) -> None:
        seen.append(number)
        if len(seen) == 1:
            os.killpg(process.pid, signal.SIGSTOP)

    output = tmp_path / "remote.nc"
    try:
        with pytest.raises(ClusterError, match="no task finished") as stopped:
            within(RUN, run_study, spec, output, scheduler=healthy.address,
                   progress=False, on_chunk=freeze_after_the_first_chunk,
                   cache=tmp_path / "remote-cache", task_timeout=3.0)
    finally:
        os.killpg(process.pid, signal.SIGCONT)
        healthy.kill(victim)
    message = str(stopped.value)
    assert victim in message and "finished work is kept" in message
    assert "--task-timeout" in message
    assert not output.exists() and not list(tmp_path.glob(".remote.nc.*.tmp"))
    kept = len(seen)
    assert 1 <= kept < 8
    resumed = within(RUN, run_study, spec, output, progress=False,
                     cache=tmp_path / "remote-cache")
    assert resumed.reused == kept and resumed.computed == 8 - kept
    assert_same_values(output, local.output)


def test_a_scheduler_nobody_listens_at_is_a_cluster_error():
    with socket.socket() as reserved:  # bound, never listening: connections are refused
        reserved.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{reserved.getsockname()[1]}"
        expected = re.escape(f"cannot reach the dask scheduler at {address}")
        with pytest.raises(ClusterError, match=expected):
            within(RUN, executor(address, None, code_sha256(), timeout=1.0).__enter__)


def test_a_scheduler_without_workers_is_a_cluster_error(empty):
    with pytest.raises(ClusterError, match="has no worker after 1 s"):
        within(RUN, executor(empty.address, None, code_sha256(), timeout=1.0).__enter__)


def test_workers_running_other_code_are_refused(small, empty, other_code, tmp_path,
                                                capsys):
    spec, _ = small
    (worker,) = empty.add_workers(1, pythonpath=other_code)
    output = tmp_path / "mixed.nc"
    status = within(RUN, main, ["run", str(spec), "--scheduler", empty.address,
                                "-o", str(output), "--no-progress"])
    out, err = capsys.readouterr()
    assert status == 1 and out == ""
    assert err.startswith("study: ") and len(err.strip().splitlines()) == 1
    assert f"{worker} has " in err and "run other study code" in err
    assert code_sha256()[:12] in err
    assert "install the same study" in err
    assert not output.exists() and not list(output.parent.glob(f".{output.name}.*.tmp"))


def test_workers_without_study_end_the_run_with_a_clear_error(small, empty, tmp_path):
    spec, _ = small
    (tmp_path / "sitecustomize.py").write_text(REFUSE_STUDY)
    (worker,) = empty.add_workers(1, pythonpath=tmp_path)
    output = tmp_path / "none.nc"
    with pytest.raises(ClusterError, match="cannot import study") as refused:
        within(RUN, run_study, spec, output, scheduler=empty.address, progress=False)
    assert worker in str(refused.value)
    assert "ModuleNotFoundError: No module named 'study'" in str(refused.value)
    assert not output.exists() and not list(output.parent.glob(f".{output.name}.*.tmp"))


# Slow tier: test_a_worker_killed_mid_run_loses_nothing and the scheduler run keep the
# cluster's headline checks in the default tier (issue 46).
@pytest.mark.slow
def test_workers_leaving_or_joining_mid_run_never_hang_or_mix(empty, other_code):
    """After the start: no worker left ends the run; a worker of other code is refused."""
    (good,) = empty.add_workers(1)
    with executor(empty.address, None, code_sha256(), timeout=2.0) as pool:
        assert pool.threads == 1
        assert pool.dashboard is None  # --no-dashboard: no page to show
        empty.kill(good)
        with pytest.raises(ClusterError, match="has had no worker for 2 s"):
            within(RUN, list, pool.run_unordered(abs, [-1, -2], label="alone"))
        (late,) = empty.add_workers(1, pythonpath=other_code)
        with pytest.raises(ClusterError, match="joined after the start") as refused:
            within(RUN, list, pool.run_unordered(abs, [-1, -2], label="late"))
    assert f"worker {late} " in str(refused.value)
    assert code_sha256()[:12] in str(refused.value)
