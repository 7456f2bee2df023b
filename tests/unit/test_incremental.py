"""Kept values: a study computes only what no earlier run computed with the same code.

Every reuse is checked twice: the counts (points computed and reused, exact) and the
values (bit-identical to the solver called directly on the new grid).
"""

from __future__ import annotations

import errno
import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

import study
from study.cli import main
from study.engine.cache_format import decode_array, encode_array
from study.engine.progress import Progress
from study.engine.runner import run_study
from study.engine.store import open_result

BASE = dict(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)


def spec_text(name="inc", observables='"velocity"', f="start = 12.0, stop = 16.0, num = 9",
              a="start = 2.0, stop = 10.0, num = 5", structure=None, sweeps="", title=None):
    structure = dict(BASE) if structure is None else structure
    lines = ["[study]", f'name = "{name}"', f"observables = [{observables}]"]
    if title:
        lines.append(f'title = "{title}"')
    lines.append("[structure]")
    lines += [f"{k} = {v!r}" for k, v in structure.items()]
    lines += ["[sweep]", sweeps, f"f = {{ {f} }}", f"a = {{ {a} }}",
              "[solver]", "chunk_points = 10"]
    return "\n".join(lines) + "\n"


def run(folder: Path, text: str, name: str = "inc", **kwargs):
    path = folder / f"{name}.toml"
    path.write_text(text)
    report = run_study(path, folder / f"{name}.nc", progress=False, **kwargs)
    return report, open_result(folder / f"{name}.nc")


def direct(ds, **structure):
    """velocity and status by the solver on the file's own grid."""
    s = study.Structure(**{**BASE, **structure})
    return study.steady_velocity(s, ds["f"].values[:, None], ds["a"].values[None, :])


def assert_same_as_solver(ds, **structure):
    v, status = direct(ds, **structure)
    np.testing.assert_array_equal(ds["velocity"].values, v)
    np.testing.assert_array_equal(ds["status"].values, status)


def test_refining_and_extending_axes_computes_only_new_points(tmp_path):
    first, _ = run(tmp_path, spec_text())
    assert (first.points, first.points_computed, first.points_reused) == (45, 45, 0)
    # f refined by two on the same range (every other value bitwise equal) and a extended
    # with the same step: 9 x 5 old points are among 17 x 7.
    report, ds = run(tmp_path, spec_text(f="start = 12.0, stop = 16.0, num = 17",
                                         a="start = 2.0, stop = 14.0, num = 7"))
    assert (report.points, report.points_reused) == (17 * 7, 45)
    assert report.points_computed == 17 * 7 - 45
    assert_same_as_solver(ds)


def test_an_explicit_list_reuses_matching_values(tmp_path):
    run(tmp_path, spec_text())
    report, ds = run(tmp_path, spec_text(f="values = [12.5, 13.0, 13.25, 20.0]"))
    # 12.5 and 13.0 are on the first grid (12 + k 0.5), 13.25 and 20.0 are not.
    assert report.points_reused == 2 * 5 and report.points_computed == 2 * 5
    assert_same_as_solver(ds)


def test_adding_a_swept_value_computes_only_that_structure(tmp_path):
    structure = {k: v for k, v in BASE.items() if k != "Q"}
    run(tmp_path, spec_text(structure=structure, sweeps="Q = { values = [15.0, 30.0] }"))
    report, ds = run(tmp_path, spec_text(structure=structure,
                                         sweeps="Q = { values = [15.0, 30.0, 60.0] }"))
    assert report.points_reused == 2 * 45 and report.points_computed == 45
    for i, Q in enumerate(ds["Q"].values):
        v, _ = direct(ds, Q=float(Q))
        np.testing.assert_array_equal(ds["velocity"].values[i], v)


def test_adding_an_observable_computes_only_that_observable(tmp_path, monkeypatch):
    run(tmp_path, spec_text())
    report, ds = run(tmp_path, spec_text(observables='"velocity", "diagnostics"'))
    # diagnostics were never computed: every point is solved again, velocity included.
    assert report.points_computed == 45
    report, ds = run(tmp_path, spec_text(observables='"velocity", "diagnostics"'),
                     force=True)
    assert report.points_computed == 0 and report.points_reused == 45
    s = study.Structure(**BASE)
    full = study.steady_state(s, ds["f"].values[:, None], ds["a"].values[None, :])
    np.testing.assert_array_equal(ds["slips_per_period"].values, full.slips_per_period)
    np.testing.assert_array_equal(ds["orbit_period"].values, full.orbit_period)


def test_a_second_spec_overlapping_the_first_shares_its_values(tmp_path):
    run(tmp_path, spec_text(), name="one")
    report, ds = run(tmp_path, spec_text(name="two", f="start = 14.0, stop = 18.0, num = 9"),
                     name="two")
    # f = 14.0 .. 16.0 (5 values) were computed by "one".
    assert report.points_reused == 5 * 5 and report.points_computed == 4 * 5
    assert_same_as_solver(ds)


def test_other_structure_solver_or_code_never_reuses(tmp_path, monkeypatch):
    run(tmp_path, spec_text())
    report, _ = run(tmp_path, spec_text(structure={**BASE, "cs": 0.3}))
    assert report.points_reused == 0
    text = spec_text() + "max_events = 5000\n"
    report, _ = run(tmp_path, text)
    assert report.points_reused == 0
    monkeypatch.setattr("study.studies.kind.code_sha256", lambda: "0" * 64)
    report, _ = run(tmp_path, spec_text(), force=True)
    assert report.points_reused == 0


def test_the_two_couplings_never_share_kept_values(tmp_path):
    """Same structure, grid and exact solver: only the coupling differs."""
    run(tmp_path, spec_text())
    two_way = spec_text(observables='"velocity", "floquet"') + 'coupling = "two-way"\n'
    report, ds = run(tmp_path, two_way)
    assert report.points_reused == 0 and report.points_computed == 45
    assert ds.attrs["study_coupling"] == "two-way"
    assert ds.attrs["study_solver_method"] == "exact"
    s = study.Structure(**BASE)
    expected = study.steady_state(s, ds["f"].values[:, None], ds["a"].values[None, :],
                                  coupling="two-way")
    np.testing.assert_array_equal(ds["velocity"].values, expected.velocity)
    np.testing.assert_array_equal(ds["status"].values, expected.status)
    np.testing.assert_array_equal(ds["floquet_multiplier"].values,
                                  expected.floquet_multiplier)
    # Rerun from the cache alone: the two-way values come back, the one-way ones stay.
    (tmp_path / "inc.nc").unlink()
    report, again = run(tmp_path, two_way)
    assert report.points_reused == 45 and report.points_computed == 0
    np.testing.assert_array_equal(again["velocity"].values, expected.velocity)
    report, one_way = run(tmp_path, spec_text(), force=True)
    assert report.points_reused == 45 and report.points_computed == 0
    assert_same_as_solver(one_way)


def blocks(folder: Path) -> list[Path]:
    return sorted((folder / ".study-cache").glob("??/*/block-*.npz"))


@pytest.mark.parametrize("damage", ["truncate", "values", "foreign", "axis"])
def test_a_damaged_kept_block_is_removed_and_recomputed(tmp_path, damage):
    _, reference = run(tmp_path, spec_text())
    reference = reference["velocity"].values.copy()
    target = blocks(tmp_path)[0]
    if damage == "truncate":
        target.write_bytes(target.read_bytes()[:200])
    elif damage == "values":
        # Rewrite a block with velocities x 1.01 but the recorded checksums unchanged (a
        # block of a work unit may hold static points alone, whose 0 stays 0, or a flagged
        # point alone, whose NaN stays NaN: one that moves).
        for target in blocks(tmp_path):
            with zipfile.ZipFile(target) as archive:
                members = {name: archive.read(name) for name in archive.namelist()}
            meta = json.loads(members["meta.json"])
            velocity = decode_array(members["velocity.bin"], meta["dtypes"]["velocity"],
                                    tuple(meta["shape"]))
            if np.any(np.isfinite(velocity) & (velocity != 0)):
                break
        members["velocity.bin"] = encode_array(velocity * 1.01)
        with zipfile.ZipFile(target, "w") as archive:
            for name, data in members.items():
                archive.writestr(name, data)
    elif damage == "axis":
        # The acceleration axis the blocks share, changed in place.
        axis = next(target.parent.glob("axis-*.bin"))
        axis.write_bytes(encode_array(np.linspace(2.0, 10.0, 5) * 1.01))
    else:
        # A block of another entry (other cs) moved into this entry's folder.
        run(tmp_path, spec_text(structure={**BASE, "cs": 0.3}), name="other")
        foreign = next(b for b in blocks(tmp_path) if b.parent != target.parent)
        foreign.replace(target)
    report, ds = run(tmp_path, spec_text(), force=True)
    assert report.points_computed >= 1
    np.testing.assert_array_equal(ds["velocity"].values, reference)


def test_stale_temporaries_of_a_killed_run_are_removed(tmp_path):
    dead = tmp_path / ".inc.nc.abcd1234.tmp"
    dead.write_bytes(b"\0" * 1000)
    run(tmp_path, spec_text())
    assert not dead.exists()


def test_a_full_disk_is_one_line_and_keeps_the_old_result(tmp_path, monkeypatch, capsys):
    path = tmp_path / "inc.toml"
    path.write_text(spec_text())
    output = tmp_path / "inc.nc"
    run_study(path, output, progress=False)
    before = output.read_bytes()

    def full(self, name, index, values):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("study.engine.store.GridWriter._put", full)
    status = main(["run", str(path), "-o", str(output), "--force", "--no-progress"])
    err = capsys.readouterr().err
    assert status == 1
    assert err.count("\n") == 1 and "No space left on device" in err and str(output) in err
    assert output.read_bytes() == before
    assert not list(tmp_path.glob(".inc.nc.*.tmp"))


def test_an_unwritable_folder_is_one_line(tmp_path, capsys):
    path = tmp_path / "inc.toml"
    path.write_text(spec_text())
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    status = main(["run", str(path), "-o", str(blocker / "inc.nc"), "--no-progress"])
    err = capsys.readouterr().err
    assert status == 1
    assert err.count("\n") == 1 and str(blocker) in err


def test_cache_list_and_prune(tmp_path, capsys, monkeypatch):
    run(tmp_path, spec_text())
    cache = tmp_path / ".study-cache"
    assert main(["cache", "list", "--cache", str(cache)]) == 0
    out = capsys.readouterr().out
    assert "velocity" in out and "45 pts" in out and "1 entries" in out
    assert main(["cache", "prune", "--stale", "--cache", str(cache)]) == 0
    assert "removed 0 of 1" in capsys.readouterr().out
    monkeypatch.setattr("study.engine.provenance.code_sha256", lambda: "f" * 64)
    assert main(["cache", "prune", "--stale", "--dry-run", "--cache", str(cache)]) == 0
    assert "would remove 1 of 1" in capsys.readouterr().out and blocks(tmp_path)
    assert main(["cache", "prune", "--all", "--cache", str(cache)]) == 0
    assert not blocks(tmp_path)
    assert main(["cache", "prune", "--cache", str(cache)]) == 2


def test_progress_lines_off_a_terminal_every_tenth():
    stream = io.StringIO()
    progress = Progress(1000, "study-x", None, stream=stream)
    for _ in range(100):
        progress.update(10)
    progress.close()
    lines = stream.getvalue().splitlines()
    assert 10 <= len(lines) <= 11
    assert all(line.startswith("study-x") for line in lines)
    assert "100%" in lines[-1] and "1.00k/1.00k" in lines[-1] and "pt/s" in lines[-1]
    quiet = io.StringIO()
    Progress(1000, "x", False, stream=quiet).update(1000)
    assert quiet.getvalue() == ""


def test_provenance_records_the_reuse(tmp_path):
    run(tmp_path, spec_text())
    _, ds = run(tmp_path, spec_text(f="start = 12.0, stop = 16.0, num = 17"))
    run_info = json.loads(ds.attrs["provenance"])["run"]
    assert run_info["points"] == 17 * 5
    assert (run_info["points_computed"], run_info["points_reused"]) == (8 * 5, 9 * 5)
