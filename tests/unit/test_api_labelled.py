"""Labelled results for both couplings (``frontier``, ``minimum_threshold``), the array
functions' shapes and dtypes, and the one coupling default across the API."""

from __future__ import annotations

import inspect

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose, assert_array_equal

import study
from study.analyses.thresholds import lowest_threshold
from study.model.contact import DEFAULT_COUPLING

PAPER = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)


# -- minimum_threshold ------------------------------------------------------------------


def test_minimum_threshold_is_labelled_and_names_its_coupling() -> None:
    found = study.minimum_threshold(PAPER)
    assert found["a_min"].attrs["units"] == "m s-2"
    assert found["f_min"].attrs["units"] == "Hz"
    assert found.attrs["study_coupling"] == "one-way"
    # The closed form at f_min (an independent evaluation of paper eq. 5).
    plus, minus = study.thresholds(PAPER, float(found["f_min"]))
    assert float(found["a_min"]) == min(plus, minus)
    assert float(found["a_star_plus"]) == plus and float(found["a_star_minus"]) == minus
    assert (float(found["a_min"]), float(found["f_min"])) == lowest_threshold(PAPER)


def test_both_couplings_give_the_same_minimum_threshold() -> None:
    one = study.minimum_threshold(PAPER, coupling="one-way")
    two = study.minimum_threshold(PAPER, coupling="two-way")
    for name in one.data_vars:
        assert float(one[name]) == float(two[name]), name
    assert two.attrs["study_coupling"] == "two-way"


@pytest.mark.parametrize("coupling", ["one-way", "two-way"])
def test_the_threshold_is_where_each_solver_starts_to_move(coupling: str) -> None:
    """Stuck below the threshold, the sliding base forces nothing: the two-way solver
    (an independent computation, the period map) is static just below the closed-form
    minimum and moves just above it, as the one-way solver does."""
    found = study.minimum_threshold(PAPER, coupling=coupling)
    f_min, a_min = float(found["f_min"]), float(found["a_min"])
    below = study.steady_state(PAPER, f_min, a_min * (1 - 1e-6), coupling=coupling)
    above = study.steady_state(PAPER, f_min, a_min * (1 + 1e-3), coupling=coupling)
    assert below.status == study.Status.STATIC and below.velocity == 0.0
    assert above.status in (study.Status.STICK_SLIP, study.Status.CONTINUOUS_SLIDING)
    assert above.velocity != 0.0


# -- frontier -----------------------------------------------------------------------------


def test_the_one_way_frontier_is_unchanged_and_labelled() -> None:
    ds = study.frontier(PAPER, [6.0, 8.0], (13.5, 16.0), num=101)
    assert ds.attrs["study_coupling"] == "one-way"
    assert ds["frontier_frequency"].dims == ("a", "branch")
    assert ds["frontier_frequency"].attrs["units"] == "Hz"
    # Every frontier point is a root of the one-way velocity: opposite signs 1e-6 Hz
    # on either side (the bracket is 1e-9 Hz).
    for a, row in zip(ds["a"].values, ds["frontier_frequency"].values, strict=True):
        for f_star in row[np.isfinite(row)]:
            v, _ = study.steady_velocity(PAPER, [f_star - 1e-6, f_star + 1e-6], a)
            assert np.sign(v[0]) * np.sign(v[1]) < 0


def test_the_two_way_frontier_is_the_workflows() -> None:
    """The two-way frontier of study.frontier is that of the frontier-two-way
    workflow's machinery (the frontier observable of a two-way study) on the same scan
    grid: the same frequencies, bit for bit."""
    a = [5.0, 7.0, 9.0]
    num = 51
    ours = study.frontier(PAPER, a, (13.5, 16.0), num=num, coupling="two-way")
    workflow = study.compute_map(PAPER, np.linspace(13.5, 16.0, num), a,
                                 observables=["frontier"], coupling="two-way")
    assert ours.attrs["study_coupling"] == workflow.attrs["study_coupling"] == "two-way"
    for name in ("frontier_frequency", "frontier_kind", "frontier_direction",
                 "frontier_bracket"):
        xr.testing.assert_identical(ours[name].reset_coords(drop=True).drop_vars("a"),
                                    workflow[name].reset_coords(drop=True).drop_vars("a"))
    assert_array_equal(ours["a"].values, workflow["a"].values)
    assert np.isfinite(ours["frontier_frequency"].values).any()


def test_the_two_way_frontier_roots_are_two_way_roots() -> None:
    ds = study.frontier(PAPER, [7.0], (13.5, 16.0), num=51, coupling="two-way")
    one_way = study.frontier(PAPER, [7.0], (13.5, 16.0), num=51)
    row = ds["frontier_frequency"].values[0]
    for f_star in row[np.isfinite(row)]:
        v, _ = study.steady_velocity(PAPER, [f_star - 1e-6, f_star + 1e-6], 7.0,
                                     coupling="two-way")
        assert np.sign(v[0]) * np.sign(v[1]) < 0
    # The sliding base moves the frontier (README, "Two-way coupling").
    assert not np.array_equal(row, one_way["frontier_frequency"].values[0])


def test_frontier_refuses_an_unknown_coupling() -> None:
    with pytest.raises(ValueError, match="coupling must be one of"):
        study.frontier(PAPER, [7.0], (13.5, 16.0), coupling="both")


# -- the array functions: numpy in, numpy out ------------------------------------------


def test_scalars_in_give_numpy_scalars_out() -> None:
    v, status = study.steady_velocity(PAPER, 14.0, 8.0)
    assert isinstance(v, np.float64) and isinstance(status, np.int8)
    assert study.Status(int(status)) is study.Status.STICK_SLIP
    result = study.steady_state(PAPER, 14.0, 8.0)
    assert isinstance(result.velocity, np.float64) and isinstance(result.status, np.int8)
    assert result.velocity == v  # the same orbit
    two, _ = study.steady_velocity(PAPER, 14.0, 8.0, coupling="two-way")
    assert isinstance(two, np.float64)
    plus, minus = study.thresholds(PAPER, 14.0)
    assert isinstance(plus, np.float64) and isinstance(minus, np.float64)
    assert isinstance(study.lift_off_acceleration(PAPER, 14.0), np.float64)


@pytest.mark.parametrize("coupling", ["one-way", "two-way"])
def test_arrays_in_give_arrays_of_the_broadcast_shape(coupling: str) -> None:
    f = np.linspace(13.0, 16.0, 4)[:, None]
    a = np.array([0.0, 6.0, 8.0])
    v, status = study.steady_velocity(PAPER, f, a, coupling=coupling)
    assert v.shape == status.shape == (4, 3)
    assert v.dtype == np.float64 and status.dtype == np.int8
    assert set(np.unique(status).tolist()) <= {int(s) for s in study.Status}
    result = study.steady_state(PAPER, f, a, coupling=coupling)
    assert_array_equal(result.velocity, v)
    for name in ("status", "reason", "slips_per_period", "orbit_period"):
        assert getattr(result, name).shape == (4, 3), name
    # One-element inputs stay arrays of one element.
    v1, s1 = study.steady_velocity(PAPER, [14.0], 8.0, coupling=coupling)
    assert v1.shape == s1.shape == (1,)
    plus, _ = study.thresholds(PAPER, f)
    assert plus.shape == (4, 1)


def test_scalar_results_are_the_array_results() -> None:
    f, a = np.array([13.0, 14.0, 15.5]), np.array([6.0, 8.0, 9.0])
    v, status = study.steady_velocity(PAPER, f, a)
    for i in range(f.size):
        vi, si = study.steady_velocity(PAPER, f[i], a[i])
        assert_allclose(vi, v[i], rtol=0, atol=0)
        assert si == status[i]


# -- one coupling default --------------------------------------------------------------------


def test_one_coupling_default_everywhere() -> None:
    from study.analyses.design_spec import DesignSpec
    from study.analyses.fit_spec import FitSpec
    from study.model.disk import Disk
    from study.solvers.attractors import attractors
    from study.solvers.integrator import integrated_steady_state, simulate
    from study.studies.observables import Method
    from study.studies.spec import StudySpec

    assert DEFAULT_COUPLING == "one-way"
    functions = (study.steady_state, study.steady_velocity, attractors, study.frontier,
                 study.minimum_threshold, study.compute_map, integrated_steady_state,
                 simulate)
    for function in functions:
        default = inspect.signature(function).parameters["coupling"].default
        assert default == DEFAULT_COUPLING, function.__name__
    for cls in (Method, StudySpec, FitSpec, Disk):
        assert cls.__dataclass_fields__["coupling"].default == DEFAULT_COUPLING, cls
    assert "coupling" in DesignSpec.__dataclass_fields__


def test_the_spec_schemas_declare_the_default() -> None:
    import json
    from pathlib import Path

    folder = Path(study.__file__).parent / "schemas"
    paths = {
        "study-spec-v1": ("properties", "solver", "properties", "coupling"),
        "study-fit-spec-v1": ("properties", "fit", "properties", "coupling"),
        "study-design-spec-v1": ("properties", "design", "properties", "coupling"),
    }
    for name, keys in paths.items():
        node = json.loads((folder / f"{name}.schema.json").read_text(encoding="utf-8"))
        for key in keys:
            node = node[key]
        assert node["default"] == DEFAULT_COUPLING, name
        assert f"{DEFAULT_COUPLING} (default)" in node["description"], name
