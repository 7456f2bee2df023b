"""Running studies: values, provenance, resume, reruns, dask clusters, CF compliance."""

from __future__ import annotations

import json
import platform
import socket
import subprocess
import sys
from datetime import datetime
from pathlib import Path

import netCDF4
import numpy as np
import pytest

import study
from study.engine.cache import ResultCache
from study.engine.provenance import code_sha256, fingerprint
from study.engine.runner import StudyInterrupted, run_study
from study.engine.store import open_result
from study.studies.spec import load_spec

SPEC = """\
# a small regime map
[study]
name = "{name}"
observables = [{observables}]

[structure]
f0 = 14.44
Q = {Q}
alpha = 64.0
cs = 0.25
{extra}

[sweep]
{sweeps}
f = {{ start = 12.0, stop = 17.0, num = 23 }}
a = {{ start = 0.0, stop = 10.0, num = 17 }}

[solver]
chunk_points = 51
"""


def kept_blocks(folder: Path) -> list[Path]:
    """Blocks of kept values in the default cache of results written to ``folder``."""
    return sorted((folder / ".study-cache").glob("??/*/block-*.npz"))


def write_spec(folder: Path, name="small", Q=17.5, extra="M = 0.08", sweeps="",
               observables='"thresholds", "lift_off", "velocity", "diagnostics"') -> Path:
    path = folder / f"{name}.toml"
    path.write_text(SPEC.format(name=name, Q=Q, extra=extra, sweeps=sweeps,
                                observables=observables))
    return path


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A small study run to completion once, uninterrupted."""
    folder = tmp_path_factory.mktemp("finished")
    spec_path = write_spec(folder)
    report = run_study(spec_path, folder / "small.nc", progress=False, workers=2)
    return spec_path, report, open_result(folder / "small.nc")


def test_values_equal_direct_solver_calls(finished):
    _, report, ds = finished
    assert report.chunks == report.computed > 1
    s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f, a = ds["f"].values, ds["a"].values
    v, status = study.steady_velocity(s, f[:, None], a[None, :])
    np.testing.assert_array_equal(ds["velocity"].values, v)
    np.testing.assert_array_equal(ds["status"].values, status)
    a_plus, a_minus = study.thresholds(s, f)
    np.testing.assert_array_equal(ds["a_star_plus"].values, a_plus)
    np.testing.assert_array_equal(ds["a_star_minus"].values, a_minus)
    np.testing.assert_array_equal(ds["lift_off_acceleration"].values,
                                  study.lift_off_acceleration(s, f))
    assert ds["velocity"].dims == ("f", "a") and ds["a_star_plus"].dims == ("f",)


def test_provenance_fields_present_and_true(finished):
    spec_path, report, ds = finished
    attrs = ds.attrs
    spec = load_spec(spec_path)
    assert attrs["study_spec"] == spec_path.read_text()
    assert attrs["study_spec_sha256"] == spec.sha256
    assert attrs["study_code_sha256"] == code_sha256()
    assert attrs["study_fingerprint"] == fingerprint(spec.sha256)
    assert attrs["study_version"] == study.__version__
    provenance = json.loads(attrs["provenance"])
    env = provenance["environment"]
    assert env["python"] == platform.python_version()
    assert env["numpy"] == np.__version__
    assert env["netCDF4"] == netCDF4.__version__
    assert env["netcdf_c"] == netCDF4.__netcdf4libversion__
    assert env["hdf5"] == netCDF4.__hdf5libversion__
    for library in ("numba", "xarray", "dask", "distributed"):
        assert env[library] == __import__(library).__version__
    assert env["host"] == socket.gethostname()
    run = provenance["run"]
    started = datetime.fromisoformat(run["started_utc"])
    finished_at = datetime.fromisoformat(run["finished_utc"])
    assert started <= finished_at
    assert 0 < run["wall_seconds"] < 600
    assert run["scheduler"] == "local" and run["workers"] == 2
    assert run["solver_settings"]["max_events"] == spec.solver.max_events
    assert run["chunks"] == report.chunks
    package_dir = Path(study.__file__).parent
    git = subprocess.run(["git", "-C", str(package_dir), "rev-parse", "HEAD"],
                         capture_output=True, text=True)
    if git.returncode == 0:
        assert attrs["git_commit"] == git.stdout.strip()
        assert attrs["git_dirty"] in ("true", "false")
    assert len(attrs["history"].splitlines()) == 1
    assert str(spec_path) in attrs["history"]


def test_thresholds_only_study_runs_no_solver(tmp_path, monkeypatch):
    def no_solver(*args, **kwargs):
        raise AssertionError("the solver ran for a thresholds-only study")

    monkeypatch.setattr("study.studies.observables.steady_state", no_solver)
    monkeypatch.setattr("study.studies.observables.integrated_steady_state", no_solver)
    spec_path = write_spec(tmp_path, observables='"thresholds"')
    run_study(spec_path, tmp_path / "t.nc", progress=False)
    ds = open_result(tmp_path / "t.nc")
    assert set(ds.data_vars) == {"a_star_plus", "a_star_minus"}


def test_interrupted_run_resumes_to_the_same_result(tmp_path, finished):
    _, full_report, full = finished
    spec_path = write_spec(tmp_path)
    output = tmp_path / "small.nc"
    first = []
    with pytest.raises(StudyInterrupted):
        run_study(spec_path, output, progress=False, stop_after=3, on_chunk=first.append)
    assert not output.exists() and not list(tmp_path.glob(".small.nc.*.tmp"))
    assert len(first) == 3
    # velocity and diagnostics: at least the three chunks (units of chunks still running
    # when it stopped are kept too)
    kept = {entry.content["observable"]: entry.points
            for entry in ResultCache(tmp_path / ".study-cache").entries()}
    assert set(kept) == {"velocity", "diagnostics"}
    assert kept["velocity"] == kept["diagnostics"] >= 3 * 51
    seen = []
    report = run_study(spec_path, output, progress=False, on_chunk=seen.append)
    assert report.reused == 3 and report.computed == full_report.chunks - 3
    assert len(seen) == report.computed and not set(seen) & set(first)
    assert report.points_computed + report.points_reused == report.points == 23 * 17
    resumed = open_result(output)
    for name in full.data_vars:
        np.testing.assert_array_equal(resumed[name].values, full[name].values)
    run = json.loads(resumed.attrs["provenance"])["run"]
    assert (run["points_computed"], run["points_reused"]) == (
        report.points_computed, report.points_reused)


def test_chunks_of_another_spec_are_never_reused(tmp_path):
    output = tmp_path / "small.nc"
    with pytest.raises(StudyInterrupted):
        run_study(write_spec(tmp_path, Q=17.5), output, progress=False, stop_after=2)
    report = run_study(write_spec(tmp_path, Q=18.0), output, progress=False)
    assert report.reused == 0 and report.computed == report.chunks
    assert float(open_result(output)["Q"]) == 18.0


def test_unchanged_study_is_not_recomputed_changed_one_is(tmp_path):
    spec_path = write_spec(tmp_path)
    output = tmp_path / "small.nc"
    run_study(spec_path, output, progress=False)
    before = output.read_bytes()
    seen = []
    report = run_study(spec_path, output, progress=False, on_chunk=seen.append)
    assert report.up_to_date and not seen and output.read_bytes() == before
    # Comments and formatting change no number: the stored spec follows the file,
    # nothing is recomputed.
    spec_path.write_text("# reformatted\n" + spec_path.read_text().replace(" = ", "="))
    report = run_study(spec_path, output, progress=False, on_chunk=seen.append)
    assert report.up_to_date and report.metadata_updated and not seen
    assert open_result(output).attrs["study_spec"] == spec_path.read_text()
    # A number is.
    spec_path.write_text(spec_path.read_text().replace("Q=17.5", "Q=17.25"))
    report = run_study(spec_path, output, progress=False)
    assert not report.up_to_date and report.computed == report.chunks


def test_mass_ratio_study_in_the_papers_terms(tmp_path):
    spec_path = write_spec(
        tmp_path, name="masses",
        extra="[structure.mass]\nm0 = 8.2e-3\nm1_fraction = 0.08",
        sweeps="m_add = { values = [0.0, 1.7e-3, 3.8e-3, 7.7e-3, 16.6e-3] }",
        observables='"thresholds"',
    )
    run_study(spec_path, tmp_path / "m.nc", progress=False)
    ds = open_result(tmp_path / "m.nc")
    m_add = np.array([0.0, 1.7e-3, 3.8e-3, 7.7e-3, 16.6e-3])
    np.testing.assert_allclose(ds["m_add"].values, m_add, rtol=0)
    np.testing.assert_allclose(ds["M"].values, 0.08 * 8.2e-3 / (8.2e-3 + m_add), rtol=1e-15)
    assert ds["M"].dims == ("m_add",) and ds["a_star_plus"].dims == ("m_add", "f")
    for i, M in enumerate(ds["M"].values):
        s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=M, cs=0.25)
        np.testing.assert_allclose(ds["a_star_plus"].values[i],
                                   study.thresholds(s, ds["f"].values)[0], rtol=1e-15)


def test_distributed_cluster_gives_the_local_result(tmp_path, finished):
    """A real dask.distributed cluster on loopback: a scheduler and two worker processes."""
    from distributed import LocalCluster

    _, _, local = finished
    spec_path = write_spec(tmp_path)
    # dashboard_address=None still opens the scheduler's HTTP server on 8787: port 0.
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0") as cluster:
        report = run_study(spec_path, tmp_path / "d.nc", scheduler=cluster.scheduler_address,
                           progress=False)
    remote = open_result(tmp_path / "d.nc")
    assert report.computed == report.chunks
    provenance = json.loads(remote.attrs["provenance"])
    assert provenance["run"]["scheduler"].startswith("tcp://127.0.0.1:")
    assert provenance["run"]["workers"] == 2
    for name in local.data_vars:
        np.testing.assert_array_equal(remote[name].values, local[name].values)


def test_written_file_passes_the_cf_compliance_checker(finished, tmp_path):
    """IOOS compliance-checker, CF-1.11, offline (it falls back to its packaged tables)."""
    _, report, _ = finished
    checker = Path(sys.executable).with_name("compliance-checker")
    out = tmp_path / "cf.json"
    subprocess.run(
        [str(checker), "--test", "cf:1.11", "--criteria", "strict", "--format", "json",
         "--output", str(out), str(report.output)],
        capture_output=True, text=True, timeout=300,
    )
    result = json.loads(out.read_text())["cf:1.11"]
    failures = [p for p in result["all_priorities"] if p["value"][0] < p["value"][1]]
    assert result["scored_points"] == result["possible_points"], failures


def test_a_second_writer_of_the_same_result_is_refused(tmp_path):
    import fcntl

    from study.engine.runner import StudyBusy

    spec_path = write_spec(tmp_path)
    output = tmp_path / "small.nc"
    with open(tmp_path / ".small.nc.lock", "a+") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(StudyBusy, match="another run is writing"):
            run_study(spec_path, output, progress=False)
    assert not output.exists() and not kept_blocks(tmp_path)
    run_study(spec_path, output, progress=False)  # free again
    assert output.exists()


# Slow tier: the resume computes the other 20000 points' attractors (78 s in CI); the
# default tier keeps the in-process interrupt and resume (test_interrupted_run_resumes_...).
@pytest.mark.slow
def test_ctrl_c_keeps_every_computed_point_of_a_one_chunk_study(tmp_path):
    """A real SIGINT to `study run` of a study in one chunk, then a second `study run`.

    The values of a chunk used to be kept only once the whole chunk was computed: a
    one-chunk study interrupted kept nothing, though it said "computed values are kept".
    Now each work unit (about a second of solving) is kept as it comes back, the units
    running when the signal comes are finished and kept, and the message counts them.
    The work (the multistability check: twelve two-way orbit solves per point, about 6 s
    on one thread) outlasts the interrupt by far: the signal is sent once the first units
    are kept, seconds before the end even on a busy machine.
    """
    import re
    import signal
    import time

    spec_path = tmp_path / "slow.toml"
    spec_path.write_text(
        SPEC.format(name="slow", Q=17.5, extra="M = 0.3", sweeps="",
                    observables='"velocity", "attractors"')
        .replace("num = 23", "num = 100").replace("num = 17", "num = 200")
        .replace("chunk_points = 51", 'chunk_points = 20000\ncoupling = "two-way"')
    )
    output = tmp_path / "slow.nc"
    cache = ResultCache(tmp_path / ".study-cache")

    def kept_points() -> dict[str, int]:
        """Points kept for each observable."""
        return {entry.content.get("observable", "?"): entry.points
                for entry in cache.entries()}

    command = [str(Path(sys.executable).with_name("study")), "run", str(spec_path),
               "-o", str(output), "--no-progress", "--workers", "1"]
    # A shell starts background jobs with SIGINT ignored, and an ignored signal stays
    # ignored across exec (Python then installs no KeyboardInterrupt handler): the child
    # gets the default disposition, as a command typed at a terminal has.
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 300
    seen = 0
    while time.monotonic() < deadline and process.poll() is None:
        counts = kept_points()
        seen = min(counts.values()) if len(counts) == 2 else 0
        if seen >= 3:  # a few units of both observables
            break
        time.sleep(0.02)
    assert process.poll() is None, "the run ended before it could be interrupted"
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=300)
    assert process.returncode == 130, stderr
    said = re.search(r"kept (\d+) of (\d+) points \((\d+) computed in this run\)", stderr)
    assert said, stderr
    kept, total, computed = map(int, said.groups())
    assert total == 100 * 200 and kept == computed and seen <= kept < total
    assert kept_points() == {"velocity": kept, "attractors": kept}
    assert not output.exists()
    report = run_study(spec_path, output, progress=False)
    assert report.chunks == 1
    assert (report.points_reused, report.points_computed) == (kept, total - kept)
    s = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.3, cs=0.25)
    ds = open_result(output)
    f, a = ds["f"].values, ds["a"].values
    v, status = study.steady_velocity(s, f[:, None], a[None, :], coupling="two-way")
    np.testing.assert_array_equal(ds["velocity"].values, v)
    np.testing.assert_array_equal(ds["status"].values, status)
    # the attractor counts of a row kept before the interrupt and one computed on resume
    for row in (0, f.size - 1):
        found = study.solvers.attractors.attractors(s, f[row], a, coupling="two-way")
        np.testing.assert_array_equal(ds["attractor_count"].values[row], found.count)
