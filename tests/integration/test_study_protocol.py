"""Slow sweeps in studies ([sweep] protocol): the file holds slow_sweep's values bit for
bit, resume and extend recompute whole runs only, and every refusal names its key."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from study.engine.runner import StudyInterrupted, run_study
from study.engine.spec_files import SpecError
from study.engine.store import open_result
from study.model.structure import Structure
from study.solvers.protocol import slow_sweep
from study.solvers.settings import SolverSettings
from study.studies.spec import load_spec

SPEC = """\
[study]
name = "hysteresis-small"
observables = ["velocity"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.99
cs = 0.25

[sweep]
f = {{ values = {f} }}
a = {{ values = {a} }}
protocol = {protocol}

[solver]
coupling = "two-way"
flight = true
chunk_points = {chunk_points}
"""

STRUCTURE = Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
F = [14.8, 15.2, 15.6, 16.0, 16.4]


def write(folder: Path, protocol: str, f=F, a=(10.0,), chunk_points=5, name="h") -> Path:
    path = folder / f"{name}.toml"
    path.write_text(SPEC.format(f=list(f), a=list(a), protocol=protocol,
                                chunk_points=chunk_points))
    return path


def expected(f, a, along, direction):
    return slow_sweep(STRUCTURE, np.asarray(f), np.asarray(a), along=along,
                      direction=direction, flight=True, settings=SolverSettings())


@pytest.mark.parametrize("direction", ["up", "down"])
def test_a_sweep_along_f_is_slow_sweeps_bit_for_bit(tmp_path, direction):
    spec = write(tmp_path, f'{{ along = "f", direction = "{direction}" }}')
    report = run_study(spec, tmp_path / "h.nc", progress=False)
    ds = open_result(tmp_path / "h.nc")
    swept = expected(F, [10.0], "f", direction)
    np.testing.assert_array_equal(ds["velocity"].values, swept.state.velocity)
    np.testing.assert_array_equal(ds["status"].values, swept.state.status)
    np.testing.assert_array_equal(ds["jumped"].values, swept.jumped.astype(np.int8))
    assert ds["jumped"].dtype == np.int8 and list(ds["jumped"].attrs["flag_values"]) == [0, 1]
    assert ds.attrs["study_protocol_along"] == "f"
    assert ds.attrs["study_protocol_direction"] == direction
    # One chunk holds every f (whole runs), whatever chunk_points says.
    assert report.chunks == 1


def test_both_ways_is_up_and_down_under_a_direction_dimension(tmp_path):
    spec = write(tmp_path, '{ along = "f", direction = "both" }')
    report = run_study(spec, tmp_path / "h.nc", progress=False)
    ds = open_result(tmp_path / "h.nc")
    assert list(ds["direction"].values) == ["up", "down"]
    assert ds["velocity"].dims == ("direction", "f", "a")
    assert ds["jumped"].dims == ("direction", "f", "a")
    assert ds.attrs["study_protocol_direction"] == "both"
    for direction in ("up", "down"):
        swept = expected(F, [10.0], "f", direction)
        np.testing.assert_array_equal(ds["velocity"].sel(direction=direction).values,
                                      swept.state.velocity)
        np.testing.assert_array_equal(ds["jumped"].sel(direction=direction).values,
                                      swept.jumped.astype(np.int8))
    assert report.chunks == 2 and report.points == 2 * len(F)
    # Each direction's values are those of a sweep that way alone: shared with it.
    report = run_study(write(tmp_path, '{ along = "f", direction = "down" }', name="d"),
                       tmp_path / "d.nc", progress=False)
    assert (report.points_computed, report.points_reused) == (0, len(F))


def test_both_ways_with_thresholds_keeps_rows_without_direction(tmp_path):
    path = write(tmp_path, '{ along = "a", direction = "both" }', f=[15.2, 16.0],
                 a=[9.0, 10.0])
    path.write_text(path.read_text().replace('observables = ["velocity"]',
                                             'observables = ["thresholds", "diagnostics"]'))
    run_study(path, tmp_path / "h.nc", progress=False)
    ds = open_result(tmp_path / "h.nc")
    assert ds["a_star_plus"].dims == ("f",)
    assert ds["slips_per_period"].dims == ("direction", "f", "a")
    np.testing.assert_array_equal(ds["velocity"].sel(direction="down").values,
                                  expected([15.2, 16.0], [9.0, 10.0], "a", "down")
                                  .state.velocity)


def test_up_and_down_differ_at_m_099(tmp_path):
    up = expected(F, [10.0], "f", "up").state.velocity
    down = expected(F, [10.0], "f", "down").state.velocity
    assert np.sum(up != down) >= 1  # hysteresis: the fixture is worth its name


def test_along_a_resume_recomputes_whole_runs_and_extend_adds_runs(tmp_path):
    f, a = [15.2, 15.6, 16.0, 16.4], [9.0, 10.0]
    spec = write(tmp_path, '{ along = "a", direction = "up" }', f=f, a=a, chunk_points=2)
    output = tmp_path / "h.nc"
    with pytest.raises(StudyInterrupted):
        run_study(spec, output, progress=False, stop_after=2)
    report = run_study(spec, output, progress=False)
    assert report.chunks == 4 and report.reused == 2 and report.computed == 2
    assert (report.points_computed, report.points_reused) == (4, 4)
    swept = expected(f, a, "a", "up")
    np.testing.assert_array_equal(open_result(output)["velocity"].values,
                                  swept.state.velocity)
    # A new f adds a run (a row along a); the other runs are reused.
    f_more = [*f, 16.8]
    spec = write(tmp_path, '{ along = "a", direction = "up" }', f=f_more, a=a,
                 chunk_points=2)
    report = run_study(spec, output, progress=False)
    assert (report.points_computed, report.points_reused) == (2, 8)
    np.testing.assert_array_equal(open_result(output)["velocity"].values,
                                  expected(f_more, a, "a", "up").state.velocity)
    # A new a changes every run: nothing is reused.
    spec = write(tmp_path, '{ along = "a", direction = "up" }', f=f_more, a=[*a, 11.0],
                 chunk_points=2)
    report = run_study(spec, output, progress=False)
    assert (report.points_computed, report.points_reused) == (15, 0)


def test_along_f_a_new_a_adds_runs_and_a_new_f_changes_every_run(tmp_path):
    output = tmp_path / "h.nc"
    f = F[:3]
    run_study(write(tmp_path, '{ along = "f" }', f=f, a=[10.0]), output, progress=False)
    report = run_study(write(tmp_path, '{ along = "f" }', f=f, a=[9.0, 10.0]), output,
                       progress=False)
    assert (report.points_computed, report.points_reused) == (3, 3)
    np.testing.assert_array_equal(open_result(output)["velocity"].values,
                                  expected(f, [9.0, 10.0], "f", "up").state.velocity)
    report = run_study(write(tmp_path, '{ along = "f" }', f=F[:4], a=[9.0, 10.0]), output,
                       progress=False)
    assert (report.points_computed, report.points_reused) == (8, 0)


def test_a_protocol_changes_the_fingerprint_and_only_then(tmp_path):
    up = load_spec(write(tmp_path, '{ along = "f", direction = "up" }', name="u"))
    down = load_spec(write(tmp_path, '{ along = "f", direction = "down" }', name="d"))
    path = write(tmp_path, '{ along = "f" }', name="n")
    path.write_text(path.read_text().replace('protocol = { along = "f" }\n', ""))
    plain = load_spec(path)
    assert plain.protocol is None and "protocol" not in plain.canonical
    assert up.protocol == ("f", "up") and up.sha256 != down.sha256 != plain.sha256


REFUSALS = [
    ('{ along = "f", speed = 1 }', {}, "unknown key 'speed'; allowed keys: along, direction"),
    ('{ along = "M" }', {}, "protocol.along: 'M' is not allowed; allowed: 'f', 'a'"),
    ('{ along = "a" }', {}, 'along = "a": [sweep] a has 1 value'),
    ('{ along = "f", direction = "sideways" }', {},
     "protocol.direction: 'sideways' is not allowed; allowed: 'up', 'down', 'both'"),
    ('{ along = "f" }', {"coupling": '"one-way"'}, 'got coupling = "one-way"'),
    ('{ along = "f" }', {"continuation": "true"}, "continuation = true"),
]


@pytest.mark.parametrize(("protocol", "solver", "words"), REFUSALS)
def test_refusals_name_the_key_and_the_allowed_values(tmp_path, protocol, solver, words):
    path = write(tmp_path, protocol)
    text = path.read_text()
    for key, value in solver.items():
        text = text.replace('coupling = "two-way"\n', "") if key == "coupling" else text
        text += f"{key} = {value}\n"
    if "one-way" in str(solver.values()):
        text = text.replace("flight = true\n", "")
    path.write_text(text)
    with pytest.raises(SpecError) as err:
        load_spec(path)
    assert str(path) in str(err.value) and "[sweep] protocol" in str(err.value)
    assert words in str(err.value)


def test_the_integrator_is_refused(tmp_path):
    path = write(tmp_path, '{ along = "f" }')
    path.write_text(path.read_text().replace("flight = true\n", 'flight = true\nmethod = '
                                             '"integrator"\n'))
    with pytest.raises(SpecError, match=r'\[sweep\] protocol needs method = "exact"'):
        load_spec(path)


# ----------------------------------------------------------- unswept: each point alone


def with_unswept(path: Path) -> Path:
    path.write_text(path.read_text().replace('observables = ["velocity"]',
                                             'observables = ["velocity", "unswept"]'))
    return path


def without_protocol(path: Path) -> Path:
    text = path.read_text()
    path.write_text(text[:text.index("protocol = ")] + text[text.index("\n[solver]"):])
    return path


def test_unswept_is_the_same_study_without_its_protocol_bit_for_bit(tmp_path):
    from study.studies.variables import VARIABLES

    a = (9.0, 10.0)
    spec = with_unswept(write(tmp_path, '{ along = "f", direction = "both" }', a=a))
    run_study(spec, tmp_path / "h.nc", progress=False, cache=tmp_path / "kept")
    plain = without_protocol(write(tmp_path, '{ along = "f" }', a=a, name="plain"))
    run_study(plain, tmp_path / "p.nc", progress=False, cache=tmp_path / "other")
    ds, alone = open_result(tmp_path / "h.nc"), open_result(tmp_path / "p.nc")
    # No direction: the answer from the start alone does not depend on the sweep.
    assert ds["velocity_unswept"].dims == ds["status_unswept"].dims == ("f", "a")
    np.testing.assert_array_equal(ds["velocity_unswept"].values, alone["velocity"].values)
    np.testing.assert_array_equal(ds["status_unswept"].values, alone["status"].values)
    for name in ("velocity_unswept", "status_unswept"):
        assert ds[name].attrs["long_name"] == VARIABLES[name].long_name
        assert ds[name].attrs["units"] == VARIABLES[name].units
    assert ds["velocity_unswept"].attrs["units"] == "m s-1"
    assert list(ds["status_unswept"].attrs["flag_meanings"].split()) == \
        ds["status"].attrs["flag_meanings"].split()
    # The fixture shows what the figure puts beside the sweeps: the sweep up keeps the
    # forward hop where the start alone settles on the backward one.
    up = ds["velocity"].sel(direction="up").values
    assert np.any(up != ds["velocity_unswept"].values)
    # Kept once for both directions: a study swept one way reuses them all.
    down = with_unswept(write(tmp_path, '{ along = "f", direction = "down" }', a=a,
                              name="d"))
    report = run_study(down, tmp_path / "d.nc", progress=False, cache=tmp_path / "kept")
    assert (report.points_computed, report.points_reused) == (0, 2 * len(F))
    np.testing.assert_array_equal(open_result(tmp_path / "d.nc")["velocity_unswept"].values,
                                  alone["velocity"].values)


def test_unswept_added_to_a_sweep_computes_it_alone_and_keeps_the_other_keys(tmp_path):
    spec = write(tmp_path, '{ along = "f", direction = "up" }')
    before = load_spec(spec)
    run_study(spec, tmp_path / "h.nc", progress=False, cache=tmp_path / "kept")
    with_unswept(spec)
    after = load_spec(spec)
    assert after.sha256 != before.sha256
    report = run_study(spec, tmp_path / "h.nc", progress=False, cache=tmp_path / "kept")
    # The sweep's values are reused; the unswept map is the one computed.
    assert report.points_computed == len(F) and report.chunks == 1
    ds = open_result(tmp_path / "h.nc")
    np.testing.assert_array_equal(ds["velocity"].values,
                                  expected(F, [10.0], "f", "up").state.velocity)
    again = run_study(spec, tmp_path / "h.nc", progress=False, cache=tmp_path / "kept",
                      force=True)
    assert (again.points_computed, again.points_reused) == (0, len(F))


def test_unswept_without_a_protocol_is_refused_naming_the_key_and_the_file(tmp_path):
    path = without_protocol(with_unswept(write(tmp_path, '{ along = "f" }')))
    with pytest.raises(SpecError) as err:
        load_spec(path)
    message = str(err.value)
    assert message.startswith(f'{path}: [study] observable "unswept" needs [sweep] '
                              "protocol")
    assert 'allowed: with [sweep] protocol = { along = "f" or "a"' in message
    assert "observables without a protocol: resonance, thresholds" in message


# ------------------------------------------- compute_map(protocol=...): the file in memory


def _data(dataset):
    """Variables and coordinates with their attributes, without the global attributes
    (provenance, the spec's text and path differ)."""
    return dataset.drop_attrs(deep=False)


@pytest.mark.parametrize(("along", "direction", "a"), [("f", "both", (9.0, 10.0)),
                                                       ("a", "down", (9.0, 10.0, 11.0))])
def test_compute_map_with_a_protocol_is_the_study_file_bit_for_bit(tmp_path, along,
                                                                   direction, a):
    import xarray as xr

    from study import compute_map

    observables = ["velocity", "diagnostics", "unswept"]
    ours = compute_map(STRUCTURE, F, a, observables=observables, coupling="two-way",
                       flight=True, protocol={"along": along, "direction": direction},
                       workers=2)
    spec = with_unswept(write(tmp_path, f'{{ along = "{along}", direction = '
                                        f'"{direction}" }}', a=a))
    spec.write_text(spec.read_text().replace('"unswept"]', '"diagnostics", "unswept"]'))
    run_study(spec, tmp_path / "h.nc", progress=False, cache=tmp_path / "kept")
    theirs = open_result(tmp_path / "h.nc")
    xr.testing.assert_identical(_data(ours), _data(theirs))
    for key in ("study_protocol", "study_protocol_along", "study_protocol_direction",
                "study_start"):
        assert ours.attrs[key] == theirs.attrs[key]
    assert ("direction" in ours.dims) == (direction == "both")
    # The equivalent spec it records runs to the same dataset.
    kept = tmp_path / "kept.toml"
    kept.write_text(ours.attrs["study_spec"])
    assert load_spec(kept).protocol == (along, direction)
    run_study(kept, tmp_path / "kept.nc", progress=False, cache=tmp_path / "kept")
    xr.testing.assert_identical(_data(ours), _data(open_result(tmp_path / "kept.nc")))


@pytest.mark.parametrize(("protocol", "solver", "words"), REFUSALS)
def test_compute_map_refuses_a_protocol_as_a_spec_does(tmp_path, protocol, solver, words):
    import tomllib

    from study import compute_map
    from study.studies.maps import MAP_SPEC_SOURCE

    table = tomllib.loads(f"p = {protocol}")["p"]
    one_way = solver.get("coupling") == '"one-way"'
    settings = SolverSettings(continuation=solver.get("continuation") == "true")
    a = (10.0,) if 'along = "a"' in protocol else (9.0, 10.0)
    with pytest.raises(ValueError) as refused:
        compute_map(STRUCTURE, F, a, observables=["velocity"],
                    coupling="one-way" if one_way else "two-way", flight=not one_way,
                    settings=settings, protocol=table)
    assert str(refused.value).startswith(f"{MAP_SPEC_SOURCE}: ")
    assert "[sweep] protocol" in str(refused.value) and words in str(refused.value)
    # The same words as the spec file's, but for where.
    path = write(tmp_path, protocol, a=a)
    text = path.read_text()
    for key, value in solver.items():
        text = text.replace('coupling = "two-way"\n', "") if key == "coupling" else text
        text += f"{key} = {value}\n"
    if one_way:
        text = text.replace("flight = true\n", "")
    path.write_text(text)
    with pytest.raises(SpecError) as spec_refused:
        load_spec(path)
    assert str(refused.value).replace(MAP_SPEC_SOURCE, "") == \
        str(spec_refused.value).replace(str(path), "")


def test_compute_map_refuses_unswept_without_a_protocol_and_a_protocol_not_a_table():
    from study import compute_map

    with pytest.raises(ValueError, match=r'observable "unswept" needs \[sweep\] protocol'):
        compute_map(STRUCTURE, F, [10.0], observables=["velocity", "unswept"],
                    coupling="two-way", flight=True)
    with pytest.raises(TypeError, match="protocol must be a dict"):
        compute_map(STRUCTURE, F, [10.0], coupling="two-way", flight=True, protocol="f")


def test_the_equivalent_spec_keeps_the_averaging_settings(tmp_path):
    """compute_map's spec text dropped velocity_tolerance and max_average_periods: run
    as a study it averaged irregular motions with the defaults."""
    import xarray as xr

    from study import compute_map
    from study.studies.spec import parse_spec

    settings = SolverSettings(velocity_tolerance=2e-2, max_average_periods=300)
    f, a = np.array([5.5, 7.0, 8.5]), np.array([12.0])  # chaos of bifurcation-along-f
    observables = ["velocity", "irregular"]
    ours = compute_map(STRUCTURE, f, a, observables=observables, coupling="two-way",
                       flight=True, settings=settings, workers=1)
    text = ours.attrs["study_spec"]
    assert "velocity_tolerance = 0.02" in text and "max_average_periods = 300" in text
    assert parse_spec(text, "map.toml").solver == settings
    spec = tmp_path / "map.toml"
    spec.write_text(text)
    run_study(spec, tmp_path / "map.nc", progress=False, cache=tmp_path / "kept")
    theirs = open_result(tmp_path / "map.nc")
    xr.testing.assert_identical(_data(ours), _data(theirs))
    # The settings decide the numbers here: the defaults average longer.
    plain = compute_map(STRUCTURE, f, a, observables=observables, coupling="two-way",
                        flight=True, workers=1)
    assert "velocity_tolerance" not in plain.attrs["study_spec"]
    assert not np.array_equal(plain["averaged_periods"].values,
                              ours["averaged_periods"].values)
