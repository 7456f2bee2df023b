"""``study.compute_map``: the dataset of a study file, computed in memory.

Each map is compared with the file ``study run`` writes for the equivalent spec file
(every data variable and coordinate, values and attributes), and its values with
direct calls of the array functions.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import study
from study.cli import main

STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
F = np.linspace(12.0, 17.0, 11)
A = np.linspace(0.0, 10.0, 6)

SPEC = """\
[study]
name = "equivalent"
observables = [{observables}]

[structure]
f0 = 14.44
alpha = 64.0
M = 0.08
cs = 0.25
{fixed}

[sweep]
{sweeps}
f = {{ start = 12.0, stop = 17.0, num = 11 }}
a = {{ start = 0.0, stop = 10.0, num = 6 }}

[solver]
coupling = "{coupling}"
"""


def _file_of(tmp_path: Path, observables: list[str], coupling: str = "one-way",
             fixed: str = "Q = 17.5", sweeps: str = "") -> xr.Dataset:
    spec = tmp_path / "equivalent.toml"
    spec.write_text(SPEC.format(observables=", ".join(f'"{o}"' for o in observables),
                                coupling=coupling, fixed=fixed, sweeps=sweeps))
    output = tmp_path / "equivalent.nc"
    assert main(["run", str(spec), "-o", str(output), "--workers", "1"]) == 0
    return study.open_result(output)


def _without_global_attrs(dataset: xr.Dataset) -> xr.Dataset:
    return dataset.drop_attrs(deep=False)


def test_the_map_is_the_file_of_the_same_spec(tmp_path: Path) -> None:
    observables = ["resonance", "thresholds", "lift_off", "velocity", "diagnostics",
                   "frontier"]
    ours = study.compute_map(STRUCTURE, F, A, observables=observables,
                             sweep={"Q": [10.0, 17.5, 30.0]})
    theirs = _file_of(tmp_path, observables, fixed="", sweeps="Q = { values = [10.0, "
                      "17.5, 30.0] }")
    xr.testing.assert_identical(_without_global_attrs(ours), _without_global_attrs(theirs))
    assert ours["velocity"].dims == ("Q", "f", "a")
    assert ours.attrs["study_coupling"] == theirs.attrs["study_coupling"] == "one-way"


def test_a_two_way_map_is_the_two_way_file(tmp_path: Path) -> None:
    observables = ["thresholds", "velocity", "floquet", "paper_model"]
    ours = study.compute_map(STRUCTURE, F, A, observables=observables, coupling="two-way")
    theirs = _file_of(tmp_path, observables, coupling="two-way")
    xr.testing.assert_identical(_without_global_attrs(ours), _without_global_attrs(theirs))
    assert ours.attrs["study_coupling"] == "two-way"


def test_its_spec_text_runs_to_the_same_file(tmp_path: Path) -> None:
    """The equivalent spec kept in the dataset is a spec file `study run` accepts."""
    ours = study.compute_map(STRUCTURE, F, A, sweep={"alpha": [30.0, 64.0]})
    spec = tmp_path / "kept.toml"
    spec.write_text(ours.attrs["study_spec"])
    theirs = study.run(spec, tmp_path / "kept.nc", workers=1)
    xr.testing.assert_identical(_without_global_attrs(ours), _without_global_attrs(theirs))


def test_values_are_the_array_functions(tmp_path: Path) -> None:
    ds = study.compute_map(STRUCTURE, F, A, sweep={"M": [0.05, 0.08]})
    for m in (0.05, 0.08):
        s = STRUCTURE.replace(M=m)
        v, status = study.steady_velocity(s, F[:, None], A[None, :])
        np.testing.assert_array_equal(ds["velocity"].sel(M=m).values, v)
        np.testing.assert_array_equal(ds["status"].sel(M=m).values, status)
        plus, minus = study.thresholds(s, F)
        np.testing.assert_array_equal(ds["a_star_plus"].sel(M=m).values, plus)
        np.testing.assert_array_equal(ds["a_star_minus"].sel(M=m).values, minus)


def test_status_names_and_units_are_the_files() -> None:
    ds = study.compute_map(STRUCTURE, F, A)
    status = ds["status"]
    names = dict(zip(status.attrs["flag_values"].tolist(),
                     status.attrs["flag_meanings"].split(), strict=True))
    assert names == {int(s): s.name.lower() for s in study.Status}
    assert set(np.unique(status.values).tolist()) <= set(names)
    assert ds["velocity"].attrs["units"] == "m s-1"
    assert ds["a"].attrs["units"] == "m s-2"
    assert ds["f"].attrs["units"] == "Hz"
    # Static points: below both closed-form thresholds, exactly 0.
    below = ds["a"] < np.minimum(ds["a_star_plus"], ds["a_star_minus"])
    assert (ds["status"].where(below) == study.Status.STATIC).sum() == below.sum()
    assert float(abs(ds["velocity"].where(below)).max()) == 0.0


def test_a_swept_cs_carries_a_default_ck_along() -> None:
    ds = study.compute_map(STRUCTURE, F, A, observables=["thresholds"],
                           sweep={"cs": [0.2, 0.3]})
    assert "ck" not in ds.coords  # follows cs, as in a spec without ck
    np.testing.assert_array_equal(ds["a_star_plus"].sel(cs=0.3).values,
                                  study.thresholds(STRUCTURE.replace(cs=0.3, ck=0.3), F)[0])


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"sweep": {"f": [1.0]}}, ValueError, "'f' is not a structure parameter"),
    ({"sweep": {"Q": [-1.0]}}, ValueError, "'Q' = -1.0 is out of range"),
    ({"sweep": {"Q": ["10"]}}, TypeError, r"sweep\['Q'\]"),
    ({"coupling": "both"}, ValueError, "coupling must be one of"),
    ({"observables": "velocity"}, TypeError, "observables must be a list"),
    ({"observables": ["speed"]}, ValueError, "speed"),
])
def test_bad_arguments_are_refused_by_name(kwargs, error, match) -> None:
    with pytest.raises(error, match=match):
        study.compute_map(STRUCTURE, F, A, **kwargs)


@pytest.mark.parametrize(("f", "a", "name"), [
    (["12", "13"], A, "f"),
    (F, np.array(["2020-01-01"], dtype="datetime64[D]"), "a"),
    (F, A + 0j, "a"),
    ([True, False], A, "f"),
])
def test_drive_arrays_of_other_types_are_refused(f, a, name) -> None:
    with pytest.raises(TypeError, match=f"^{name} must be real numbers"):
        study.compute_map(STRUCTURE, f, a)


def test_a_swept_tilt_in_radians_warns() -> None:
    with pytest.warns(study.SuspectInputWarning, match=r"sweep\['alpha'\] holds 2 tilts"):
        ds = study.compute_map(STRUCTURE, F, A, observables=["thresholds"],
                               sweep={"alpha": [0.5, 1.1, 64.0]})
    assert ds["alpha"].values.tolist() == [0.5, 1.1, 64.0]  # computed as given, in degree
