"""The local executor (threads, no cluster): runs open no port, work not started is
cancelled, every item comes back once, and the reported time covers the write.
The dask executor is tests/integration/test_distributed.py."""

from __future__ import annotations

import json
import socket
import time
from pathlib import Path

from study.cli import main
from study.engine.executors import executor
from study.engine.provenance import code_sha256
from study.engine.runner import run_study
from study.engine.store import open_result

SPEC = """\
[study]
name = "{name}"
observables = [{observables}]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.25

[sweep]
f = {{ start = 12.0, stop = 17.0, num = {n_f} }}
a = {{ start = 0.5, stop = 10.0, num = {n_a} }}

[solver]
chunk_points = {chunk_points}
"""


def write_spec(folder: Path, name: str, n_f: int, n_a: int, chunk_points: int,
               observables: str = '"thresholds", "lift_off", "velocity", "diagnostics"'
               ) -> Path:
    path = folder / f"{name}.toml"
    path.write_text(SPEC.format(name=name, n_f=n_f, n_a=n_a, chunk_points=chunk_points,
                                observables=observables))
    return path


def test_local_runs_open_no_port_and_need_no_free_8787(tmp_path, capsys):
    """`make test` and `study run` while something else listens on 8787."""
    spec = write_spec(tmp_path, "busy", n_f=4, n_a=3, chunk_points=3)
    blocker = socket.socket()
    try:
        try:
            blocker.bind(("127.0.0.1", 8787))
            blocker.listen()
        except OSError:
            pass  # someone else holds it: just the situation to test
        # pytest turns warnings into errors too; this says so where it matters.
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("error")
            status = main(["run", str(spec), "-o", str(tmp_path / "busy.nc"),
                           "--no-progress"])
    finally:
        blocker.close()
    out, err = capsys.readouterr()
    assert status == 0, err
    assert err == "" and "4 chunks (4 computed, 0 reused)" in out


def test_the_local_executor_cancels_what_was_not_started():
    started = []

    def slow(item):
        started.append(item)
        time.sleep(0.05)
        return item

    with executor(None, 2, code_sha256()) as pool:
        assert (pool.name, pool.threads, pool.dashboard) == ("local", 2, None)
        results = pool.run_unordered(slow, list(range(100)), label="slow")
        first, value = next(results)
        assert first == value
        results.close()
    # At most two items per thread were ever handed to the pool.
    assert len(started) <= 4


def test_the_local_executor_yields_every_item_once():
    with executor(None, 3, code_sha256()) as pool:
        pairs = list(pool.run_unordered(lambda x: x * x, list(range(50)), label="squares"))
    assert sorted(pairs) == [(x, x * x) for x in range(50)]


def test_the_time_reported_includes_writing_the_file(tmp_path, monkeypatch):
    """The CLI prints ``RunReport.wall_seconds``: it must cover the write and its check."""
    import study.engine.runner

    write = study.engine.runner.commit

    def slow_write(*args, **kwargs):
        time.sleep(0.5)  # a slow disk
        return write(*args, **kwargs)

    monkeypatch.setattr(study.engine.runner, "commit", slow_write)
    spec = write_spec(tmp_path, "timed", n_f=4, n_a=3, chunk_points=3)
    report = run_study(spec, tmp_path / "timed.nc", workers=1, progress=False)
    assert report.wall_seconds >= 0.5
    provenance = json.loads(open_result(report.output).attrs["provenance"])
    assert provenance["run"]["wall_seconds"] < report.wall_seconds
