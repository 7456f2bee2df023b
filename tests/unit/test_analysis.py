"""Analyses: the zero-velocity frontier f*(a) and the threshold minima."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import brentq

import study
from study.analyses.frontier import frontier
from study.analyses.thresholds import minimum_threshold, resonance_threshold
from study.engine.runner import run_study
from study.engine.store import open_result
from study.solvers.frontier import FRONTIER_CROSSING, frontier_from_grid


def _assert_sign_changes_across(structure, a, points, delta=1e-8):
    for a_value, row in zip(a, points, strict=True):
        for f_star in row[np.isfinite(row)]:
            v, status = study.steady_velocity(structure, [f_star - delta, f_star + delta],
                                              a_value)
            assert np.all(np.isin(status, [1, 2]))
            assert v[0] * v[1] < 0, (a_value, f_star, v)


def test_every_frontier_root_has_the_velocity_changing_sign_across_it(paper_structure):
    a = np.linspace(4.5, 9.0, 10)  # PN up to lift-off near 9.4 m s-2
    ds = frontier(paper_structure, a, (13.0, 17.0), num=401)
    points = ds["frontier_frequency"].values
    assert np.all(np.isfinite(points[:, 0]))  # one branch at every a in PN for M = 0.08
    assert np.nanmax(ds["frontier_bracket"].values) <= 1e-9
    _assert_sign_changes_across(paper_structure, a, points)
    # The paper: at 14.5 Hz, v > 0 at a = 6 and v < 0 at a = 9, so f*(a) passes 14.5 Hz
    # between them and the frontier is not vertical.
    f6 = points[np.argmin(abs(a - 6.0)), 0]
    f9 = points[np.argmin(abs(a - 9.0)), 0]
    assert f9 < 14.5 < f6


def test_several_branches_near_m_equal_one_each_a_root(paper_structure):
    s = paper_structure.replace(M=1.0)
    a = np.array([1.0, 1.5, 2.0, 3.0])
    ds = frontier(s, a, (5.0, 30.0), num=1001)
    points = ds["frontier_frequency"].values
    assert ds.sizes["branch"] >= 2
    _assert_sign_changes_across(s, a, points)
    # Every branch: as many roots as sign changes of a much finer scan.
    fine = np.linspace(5.0, 30.0, 20001)
    v, status = study.steady_velocity(s, fine[:, None], a[None, :])
    moving = np.isin(status, [1, 2]) & (v != 0)
    changes = (moving[:-1] & moving[1:] & (np.sign(v[:-1]) != np.sign(v[1:]))).sum(axis=0)
    np.testing.assert_array_equal(np.isfinite(points).sum(axis=1), changes)


def test_frontier_just_above_threshold_is_where_both_thresholds_meet(paper_structure):
    """Closed form: where a*_+ = a*_- the forward and backward slips are mirror images
    (|A_+| = |A_-| and |B_+| = |B_-|), so while they do not interact v = 0 exactly."""
    s = paper_structure

    def gap(f):
        a_plus, a_minus = study.thresholds(s, f)
        return float(a_plus - a_minus)

    f_equal = brentq(gap, 14.4, 14.7, xtol=1e-14, rtol=1e-15)
    a_equal = min(study.thresholds(s, f_equal))
    a = np.array([1.02, 1.1]) * a_equal
    ds = frontier(s, a, (14.0, 15.0), num=201)
    assert_allclose(ds["frontier_frequency"].values[:, 0], f_equal, rtol=0, atol=2e-9)
    assert np.all(ds["frontier_kind"].values[:, 0] == FRONTIER_CROSSING)


def test_mirror_structure_has_the_same_frontier_with_opposite_direction(paper_structure):
    a = np.array([6.0, 8.0])
    ds = frontier(paper_structure, a, (13.5, 15.5), num=201)
    mirrored = frontier(paper_structure.replace(alpha=-64.0), a, (13.5, 15.5), num=201)
    assert_allclose(mirrored["frontier_frequency"], ds["frontier_frequency"], rtol=0, atol=2e-9)
    np.testing.assert_array_equal(mirrored["frontier_direction"], -ds["frontier_direction"])


def test_frontier_from_synthetic_grid_ignores_static_gaps_and_flags(paper_structure):
    """Sign changes across a static or lift-off gap are not frontier points."""
    f = np.array([13.0, 13.5, 14.0, 14.5, 15.0])
    a = np.array([5.0])
    velocity = np.array([[1e-3], [0.0], [-1e-3], [np.nan], [1e-3]])
    status = np.array([[1], [0], [1], [3], [1]], dtype=np.int8)
    found = frontier_from_grid(paper_structure, f, a, velocity, status)
    assert np.all(np.isnan(found.frequency)) and np.all(found.kind == 0)


def test_frontier_input_errors(paper_structure):
    with pytest.raises(ValueError, match="shape"):
        frontier_from_grid(paper_structure, [13.0, 14.0], [5.0], np.zeros((3, 1)),
                           np.zeros((3, 1)))
    with pytest.raises(ValueError, match="f_min < f_max"):
        frontier(paper_structure, [5.0], (15.0, 14.0))
    with pytest.raises(ValueError, match="tolerance"):
        frontier_from_grid(paper_structure, [13.0, 14.0], [5.0], np.zeros((2, 1)),
                           np.zeros((2, 1)), tolerance=0.0)


def test_study_frontier_equals_the_analysis_function(tmp_path, paper_structure):
    spec = tmp_path / "front.toml"
    spec.write_text(
        '[study]\nname = "front"\nobservables = ["frontier"]\n'
        "[structure]\nf0 = 14.44\nQ = 17.5\nalpha = 64.0\nM = 0.08\ncs = 0.25\n"
        "[sweep]\nf = { start = 13.5, stop = 15.5, num = 81 }\n"
        "a = { start = 5.0, stop = 9.0, num = 5 }\n"
    )
    run_study(spec, tmp_path / "front.nc", progress=False)
    ds = open_result(tmp_path / "front.nc")
    direct = frontier(paper_structure, ds["a"].values, (13.5, 15.5), num=81)
    np.testing.assert_array_equal(ds["frontier_frequency"].values,
                                  direct["frontier_frequency"].values)
    assert "velocity" in ds  # the frontier is found on a solved grid, kept in the file


@pytest.mark.parametrize("M", [0.01, 0.066, 0.3, 1.0])
@pytest.mark.parametrize("Q", [2.0, 17.5, 300.0])
def test_resonance_threshold_is_eq5_at_f0(paper_structure, M, Q):
    s = paper_structure.replace(M=M, Q=Q)
    assert_allclose(resonance_threshold(s), study.thresholds(s, s.f0), rtol=1e-13)


def test_minimum_threshold_is_the_grid_minimum(paper_structure):
    found = minimum_threshold(paper_structure)
    a_min, f_min = float(found["a_min"]), float(found["f_min"])
    f = np.linspace(13.5, 15.5, 200_001)
    grid = np.minimum(*study.thresholds(paper_structure, f))
    assert_allclose(a_min, grid.min(), rtol=1e-9)
    assert_allclose(f_min, f[np.argmin(grid)], atol=2e-5)
    assert a_min <= grid.min()
