"""The basins observable in studies: the file holds study.solvers.basins.basins' values in
its attractor slots, resumes and extends like any observable (only the new points
computed, the same values), keeps its settings in its own cache key, and compute_map
gives the file's dataset."""

from __future__ import annotations

from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

import study
from study.engine.runner import StudyInterrupted, run_study
from study.engine.store import open_result
from study.engine.validation.files import seal, validate_file
from study.engine.validation.reading import ResultError
from study.solvers.basins import basins, sampling_reach, sweep_seeds

SPEC = """\
[study]
name = "basins-small"
observables = {observables}

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.99
cs = 0.25

[sweep]
f = {{ values = {f} }}
a = {{ values = {a} }}

[solver]
coupling = "two-way"
flight = true
chunk_points = 2

[basins]
starts = {starts}
seed = {seed}
max_attractors = {slots}
sweep_steps = {steps}
"""

STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
#: Where the small forward hop and the big backward hop coexist (M = 0.99, flight).
F = [13.0, 14.0, 15.0]
A = [10.0, 12.0]
STARTS = 8


def write(folder: Path, f=F, a=A, starts=STARTS, seed=0, slots=3, name="b",
          observables='["velocity", "basins"]', steps=8) -> Path:
    path = folder / f"{name}.toml"
    path.write_text(SPEC.format(f=list(f), a=list(a), starts=starts, seed=seed, slots=slots,
                                observables=observables, steps=steps))
    return path


PER_ATTRACTOR = {"basin_status": "status", "basin_velocity": "velocity",
                 "basin_velocity_error": "velocity_error",
                 "basin_largest_hop": "largest_hop", "basin_period": "orbit_period",
                 "basin_multiplier": "floquet_multiplier",
                 "basin_exponent": "lyapunov_exponent", "basin_fraction": "fraction",
                 "basin_fraction_low": "fraction_low", "basin_fraction_high": "fraction_high"}


def expected(f, a, starts=STARTS, seed=0, steps=8):
    grid_f, grid_a = np.meshgrid(f, a, indexing="ij")
    seeds = sweep_seeds(STRUCTURE, grid_f, grid_a, flight=True, steps=steps) if steps else None
    return basins(STRUCTURE, grid_f, grid_a, starts=starts, seed=seed, flight=True,
                  parallel=False, seeds=seeds)


def assert_holds(ds: xr.Dataset, found, slots: int) -> None:
    """The file's slots are the API's first ``slots`` attractors (empty ones: status
    -1, NaN values, period 0), its per-point values the API's."""
    width = found.status.shape[-1]
    present = np.arange(slots) < np.minimum(found.count, slots)[..., None]
    for name, field in PER_ATTRACTOR.items():
        held = ds[name].values
        api = getattr(found, field)
        kept = min(width, slots)
        mask = present[..., :kept]
        np.testing.assert_array_equal(held[..., :kept][mask], api[..., :kept][mask], name)
        empty = held[~present]
        if name == "basin_status":
            assert np.all(empty == -1)
        elif name == "basin_period":
            assert np.all(empty == 0)
        else:
            assert np.all(np.isnan(empty)), name
    np.testing.assert_array_equal(ds["attractor_count"].values, found.count)
    np.testing.assert_array_equal(ds["default_attractor"].values, found.default_attractor)
    np.testing.assert_array_equal(ds["starts_drawn"].values, found.starts_drawn)


def test_the_file_holds_the_attractors_of_basins(tmp_path):
    output = tmp_path / "b.nc"
    run_study(write(tmp_path), output, progress=False)
    validate_file(output)  # raises on any problem
    ds = open_result(output)
    found = expected(F, A)
    assert found.count.max() == 2  # the point of the fixture: bistable points
    assert ds["basin_velocity"].dims == ("f", "a", "attractor")
    assert ds["attractor_count"].dims == ("f", "a")
    assert list(ds["attractor"].values) == [0, 1, 2]
    assert ds["attractor"].dtype == np.int32
    assert_holds(ds, found, 3)
    for name in (*PER_ATTRACTOR, "attractor_count", "default_attractor", "starts_drawn"):
        assert ds[name].attrs["units"] and ds[name].attrs["long_name"], name
    assert ds["basin_velocity"].attrs["units"] == "m s-1"
    assert ds["basin_largest_hop"].attrs["units"] == "m"
    assert list(ds["basin_status"].attrs["flag_values"])[:2] == [-1, 0]
    assert ds["basin_status"].attrs["flag_meanings"].startswith("no_attractor static ")
    assert (ds.attrs["study_basins_starts"], ds.attrs["study_basins_seed"],
            ds.attrs["study_basins_max_attractors"]) == (STARTS, 0, 3)
    # The solver's start reaches the attractor the velocity reports, bit for bit.
    rows = np.indices(found.count.shape)
    chosen = ds["basin_velocity"].values[(*rows, ds["default_attractor"].values)]
    np.testing.assert_array_equal(chosen, ds["velocity"].values)


def test_a_point_with_more_attractors_than_slots_keeps_the_first_and_its_count(tmp_path):
    output = tmp_path / "one.nc"
    run_study(write(tmp_path, slots=1, name="one"), output, progress=False)
    validate_file(output)  # raises on any problem
    ds = open_result(output)
    found = expected(F, A)
    assert_holds(ds, found, 1)
    over = found.count > 1
    assert over.any()
    # Nothing is lost silently: the count is exact and the slot's fraction under 1.
    assert np.all(ds["attractor_count"].values[over] == found.count[over])
    assert np.all(ds["basin_fraction"].values[over, 0] < 1.0)


def test_resume_and_extend_compute_only_new_points_with_the_same_values(tmp_path):
    output = tmp_path / "b.nc"
    spec = write(tmp_path)
    with pytest.raises(StudyInterrupted):
        run_study(spec, output, progress=False, stop_after=1)
    report = run_study(spec, output, progress=False)
    # chunk_points = 2 with 2 accelerations: one frequency a chunk. The stop comes
    # after the first whole chunk; work units of the others finished by then are
    # kept too (how many depends on the workers' timing), never computed twice.
    assert (report.chunks, report.reused + report.computed) == (3, 3)
    assert report.reused >= 1
    assert report.points_computed + report.points_reused == 6
    assert report.points_reused >= 2
    whole = open_result(output)
    assert_holds(whole, expected(F, A), 3)
    # Along f: only the new frequency is computed, the others are the same bit for bit.
    f_more = [*F, 16.0]
    report = run_study(write(tmp_path, f=f_more), output, progress=False)
    assert (report.points_computed, report.points_reused) == (2, 6)
    extended = open_result(output)
    assert_holds(extended, expected(f_more, A), 3)
    for name in (*PER_ATTRACTOR, "attractor_count", "velocity"):
        np.testing.assert_array_equal(extended[name].values[:3], whole[name].values, name)


def test_the_basins_settings_key_only_the_basins_values(tmp_path):
    run_study(write(tmp_path), tmp_path / "b.nc", progress=False)
    # Another seed: the velocity is reused, basins recomputed.
    report = run_study(write(tmp_path, seed=5, name="s"), tmp_path / "s.nc", progress=False)
    assert report.points_computed == len(F) * len(A)
    assert_holds(open_result(tmp_path / "s.nc"), expected(F, A, seed=5), 3)
    # No seeding sweep: the drawn starts alone, as before study 0.5.
    report = run_study(write(tmp_path, steps=0, name="n"), tmp_path / "n.nc", progress=False)
    assert report.points_computed == len(F) * len(A)
    unseeded = open_result(tmp_path / "n.nc")
    assert_holds(unseeded, expected(F, A, steps=0), 3)
    assert unseeded.attrs["study_basins_sweep_steps"] == 0
    assert unseeded.attrs["study_basins_reach"] == sampling_reach(True, 0)
    # A study without basins reuses the velocity kept beside them.
    plain = tmp_path / "v.toml"
    plain.write_text(write(tmp_path, name="v", observables='["velocity"]').read_text()
                     .split("[basins]")[0])
    report = run_study(plain, tmp_path / "v.nc", progress=False)
    assert (report.points_computed, report.points_reused) == (0, len(F) * len(A))


def test_compute_map_gives_the_dataset_of_the_study_file(tmp_path):
    output = tmp_path / "b.nc"
    run_study(write(tmp_path), output, progress=False)
    from_file = open_result(output)
    in_memory = study.compute_map(STRUCTURE, F, A, observables=["velocity", "basins"],
                                  coupling="two-way", flight=True,
                                  basins={"starts": STARTS, "max_attractors": 3})
    assert set(in_memory.data_vars) == set(from_file.data_vars)
    for name in in_memory.data_vars:
        assert in_memory[name].dims == from_file[name].dims, name
        assert in_memory[name].dtype == from_file[name].dtype, name
        np.testing.assert_array_equal(in_memory[name].values, from_file[name].values, name)
        for key in ("units", "long_name"):
            assert in_memory[name].attrs[key] == from_file[name].attrs[key], (name, key)
    np.testing.assert_array_equal(in_memory["attractor"].values, from_file["attractor"].values)
    for key in ("study_basins_starts", "study_basins_seed", "study_basins_max_attractors",
                "study_basins_sweep_steps", "study_basins_reach"):
        assert in_memory.attrs[key] == from_file.attrs[key]
    assert from_file.attrs["study_basins_reach"] == sampling_reach(True, 8)
    # Its equivalent spec, run as a study, writes the same values.
    spec = tmp_path / "map.toml"
    spec.write_text(in_memory.attrs["study_spec"])
    run_study(spec, tmp_path / "map.nc", progress=False)
    again = open_result(tmp_path / "map.nc")
    for name in in_memory.data_vars:
        np.testing.assert_array_equal(again[name].values, in_memory[name].values, name)


@pytest.mark.parametrize(("name", "change", "words"), [
    ("basin_fraction", lambda v: v.__setitem__((0, 0, 0), 0.2),
     "basin_fraction adds up to 1"),
    ("basin_velocity", lambda v: v.__setitem__((0, 0, 2), 0.01),
     "basin_velocity is NaN exactly where basin_status is no_attractor"),
    ("basin_status", lambda v: v.__setitem__((0, 0, 2), 1),
     "basin_status is no_attractor exactly in the slots after"),
    ("default_attractor", lambda v: v.__setitem__((0, 0), 5),
     "default_attractor is -1 or an attractor found"),
])
def test_validation_refuses_inconsistent_basins(tmp_path, name, change, words):
    output = tmp_path / "b.nc"
    run_study(write(tmp_path), output, progress=False)
    with netCDF4.Dataset(output, "a") as nc:
        variable = nc.variables[name]
        variable.set_auto_maskandscale(False)
        values = variable[:]
        change(values)
        variable[:] = values
    with pytest.raises(ResultError, match=words):
        seal(output)  # the checksum of the changed values, then validation


def test_the_header_schema_needs_the_basins_settings_beside_the_basins(tmp_path):
    """A file with the basins' variables but without the study_basins_* attributes that
    say how its starts were drawn is refused by the format's header schema."""
    output = tmp_path / "b.nc"
    run_study(write(tmp_path), output, progress=False)
    with netCDF4.Dataset(output, "a") as nc:
        nc.delncattr("study_basins_starts")
        nc.delncattr("study_basins_seed")
        nc.delncattr("study_basins_max_attractors")
    with pytest.raises(ResultError, match="study_basins_starts"):
        seal(output)
