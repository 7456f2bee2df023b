"""The basins figure: each motion followed over the drive, drawn from a map the engine
computes (compute_map with the basins observable; M = 0.99 with flight, where the
forward and backward hops coexist)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from matplotlib.collections import QuadMesh
from matplotlib.colors import to_rgb
from numpy.testing import assert_allclose, assert_array_equal

import study
from study.analyses.basins import follow_attractors, fraction_by_label
from study.figures import FigureError, draw_figure
from study.figures.basins import MAX_PANELS, compose, draw, label_colour
from tests.support.basins_dataset import computed

M_TO_1 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)


@pytest.fixture(scope="module")
def basins_map():
    # At least MIN_CELLS values of each axis: a map of cells (fewer: lines per value).
    return computed(M_TO_1, np.arange(12.5, 15.01, 0.5), [10.0, 10.5, 11.0, 11.5, 12.0],
                    starts=8, flight=True, name="basins-figure-test")


def test_the_map_has_one_panel_per_label_coloured_by_its_fraction(basins_map, tmp_path):
    labelled, summary = follow_attractors(basins_map)
    shares = fraction_by_label(labelled).transpose("label", "f", "a")
    fig, title = compose(basins_map)
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_title().startswith("label")]
    assert len(panels) == min(summary.sizes["label"], MAX_PANELS) >= 2
    for ax in panels:
        label = int(ax.get_title().split(":")[0].split()[1])
        assert to_rgb(ax.title.get_color()) == label_colour(label)
        points = int(summary["points"].sel(label=label))
        assert f"{points} points" in ax.get_title()
        mesh = ax.collections[0]
        drawn = np.ma.filled(mesh.get_array().astype(float), np.nan).ravel()
        assert_array_equal(drawn, shares.sel(label=label).values.T.ravel())
        assert mesh.get_clim() == (0.0, 1.0)
    # Both hops are drawn: one label moves forward, one backward.
    texts = " ".join(ax.get_title() for ax in panels)
    assert "v +" in texts and "v -" in texts
    assert "Basins over (f, a)" in title
    paths = draw(basins_map, tmp_path / "basins")
    assert all(p.exists() and p.stat().st_size > 0 for p in paths)


def test_a_line_stacks_the_fractions_in_the_maps_colours(basins_map):
    labelled, _ = follow_attractors(basins_map)
    line = labelled.sel(a=10.0)  # the map's labels kept (attractor_label in the dataset)
    fig, title = compose(line)
    top, bottom = fig.axes
    stacks = {c.get_label(): c for c in bottom.containers}  # a bar per grid point
    shares = fraction_by_label(line)
    present = [int(k) for k in shares["label"].values
               if bool(shares.sel(label=k).notnull().any())]
    assert sorted(stacks) == sorted(f"label {k}" for k in present)
    assert len(present) >= 2  # the fold: two motions along f at 10 m s-2
    for k in present:
        bars = stacks[f"label {k}"].patches
        assert_allclose(bars[0].get_facecolor()[:3], label_colour(k))
        assert_allclose([b.get_height() for b in bars],
                        shares.sel(label=k).fillna(0.0).values, rtol=0, atol=0)
        assert_allclose([b.get_x() + 0.5 * b.get_width() for b in bars],
                        line["f"].values, rtol=1e-12)
        assert all(b.get_width() <= 0.5 for b in bars)  # within the grid's step
    # The stacked fractions add up to 1 at every frequency: the top of the stack.
    total = shares.fillna(0.0).sum("label").values
    assert_allclose(total, 1.0, rtol=0, atol=1e-12)
    tops = sum(np.array([b.get_height() for b in c.patches]) for c in stacks.values())
    assert_allclose(tops, 1.0, rtol=0, atol=1e-12)
    # The velocity of each label, in mm s-1, where it exists.
    curves = {c.get_label().split(":")[0]: c for c in top.get_lines() if
              c.get_label().startswith("label")}
    for k in present:
        where = line["attractor_label"] == k
        expected = 1e3 * line["basin_velocity"].where(where).max("attractor").values
        assert_allclose(curves[f"label {k}"].get_ydata(), expected, rtol=1e-12)
    assert "Basins along f at a = 10" in title


def test_a_coarse_axis_is_drawn_as_lines_per_value(basins_map):
    """Three values of a (fewer than MIN_CELLS): a column of lines and bars per value,
    no map cells spanning the values between."""
    coarse = basins_map.isel(a=[0, 2, 4])  # 3 values, fewer than MIN_CELLS = 5
    fig, title = compose(coarse)
    assert not [c for ax in fig.axes for c in ax.collections if isinstance(c, QuadMesh)]
    tops = [ax for ax in fig.axes if ax.get_title()]
    assert [ax.get_title().split(":")[0] for ax in tops] == [
        "a = 10 m s$^{-2}$", "a = 11 m s$^{-2}$", "a = 12 m s$^{-2}$"]
    assert "Basins along f at a = 10, 11, 12 m s^-2" in title


def test_a_line_selected_from_the_file_draws(basins_map, tmp_path):
    paths = draw_figure("basins", basins_map, tmp_path / "line", sel=["f=13.5"])
    assert all(p.exists() for p in paths)


def test_one_drive_point_is_refused(basins_map):
    with pytest.raises(FigureError, match="several values of f or a"):
        compose(basins_map.isel(f=0, a=0))
    with pytest.raises(FigureError, match="several values of attractor"):
        compose(basins_map.isel(attractor=0))
    assert int(basins_map["attractor_count"].max()) == 2
    with pytest.raises(FigureError, match=r"several values of attractor \(all its slots"):
        compose(basins_map.isel(attractor=[0]))


def _with_folds(dataset):
    """The map with fold curves as the fold_curves observable writes them: the forward
    hop's fold at every a but the last, no backward fold found."""
    a = dataset["a"].values
    forward = 16.0 - 1.2 * (a - 10.0)
    forward[-1] = np.nan
    return dataset.assign_coords(hop=["forward", "backward"]).assign(
        fold_f=(("hop", "a"), np.stack([forward, np.full(a.size, np.nan)])))


def test_the_fold_curves_are_drawn_over_every_panel(basins_map):
    folded = _with_folds(basins_map)
    fig, _ = compose(folded)
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_title().startswith("label")]
    limits = compose(basins_map)[0].axes[0].get_xlim()
    for ax in panels:
        lines = [line for line in ax.get_lines() if "fold" in line.get_label()]
        assert [line.get_label() for line in lines] == [
            "forward hop's fold (a sweep up jumps there)"]
        assert lines[0].get_linestyle() == "-" and to_rgb(lines[0].get_color()) == (0, 0, 0)
        assert_allclose(lines[0].get_xdata(), folded.fold_f.values[0], rtol=0, atol=0)
        assert_allclose(lines[0].get_ydata(), folded.a.values, rtol=0, atol=0)
        assert ax.get_xlim() == limits  # the map's extent kept
    assert [t.get_text() for t in fig.legends[0].get_texts()] == [
        "forward hop's fold (a sweep up jumps there)"]
    # Without the fold curves nothing of them is drawn.
    bare, _ = compose(basins_map)
    assert not [line for ax in bare.axes for line in ax.get_lines()
                if "fold" in line.get_label()]


DOUBLING_LABEL = "forward hop's period doubling (period 2 below it in f)"


def test_the_period_doubling_is_drawn_beside_the_folds(basins_map):
    a = basins_map["a"].values
    doubling = 12.03 - 0.6 * (a - 10.0)
    doubling[0] = np.nan  # not found there
    folded = _with_folds(basins_map).assign(doubling_f=(("a",), doubling))
    fig, _ = compose(folded)
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_title().startswith("label")]
    limits = compose(basins_map)[0].axes[0].get_xlim()
    for ax in panels:
        lines = {line.get_label(): line for line in ax.get_lines()}
        drawn = lines[DOUBLING_LABEL]
        assert drawn.get_linestyle() == ":" and to_rgb(drawn.get_color()) == (0, 0, 0)
        assert_allclose(drawn.get_xdata(), doubling, rtol=0, atol=0)
        assert_allclose(drawn.get_ydata(), a, rtol=0, atol=0)
        assert "forward hop's fold (a sweep up jumps there)" in lines
        assert ax.get_xlim() == limits
    assert [t.get_text() for t in fig.legends[0].get_texts()] == [
        "forward hop's fold (a sweep up jumps there)", DOUBLING_LABEL]
    # Along f, at one acceleration: a vertical line at its frequency.
    labelled, _ = follow_attractors(folded)
    fig, _ = compose(labelled.sel(a=a[1]))
    for ax in fig.axes:
        lines = {line.get_label(): line for line in ax.get_lines()}
        assert_allclose(lines[DOUBLING_LABEL].get_xdata(), [doubling[1]] * 2, rtol=0, atol=0)
    # A file without it (written before the curve) draws the folds alone.
    fig, _ = compose(_with_folds(basins_map))
    assert not [line for ax in fig.axes for line in ax.get_lines()
                if line.get_label() == DOUBLING_LABEL]


def test_along_f_each_fold_is_a_vertical_line_at_its_frequency(basins_map):
    folded = _with_folds(basins_map)
    folded["fold_f"].values[1] = 13.3  # a backward fold too, at every a
    labelled, _ = follow_attractors(folded)
    fig, _ = compose(labelled.sel(a=10.5))
    top, bottom = fig.axes
    for ax in (top, bottom):
        lines = {line.get_label(): line for line in ax.get_lines()
                 if "fold" in line.get_label()}
        forward = lines["forward hop's fold (a sweep up jumps there)"]
        backward = lines["backward hop's fold (a sweep down jumps there)"]
        assert_allclose(forward.get_xdata(), [16.0 - 1.2 * 0.5] * 2, rtol=0, atol=1e-12)
        assert_allclose(backward.get_xdata(), [13.3, 13.3], rtol=0, atol=0)
        assert backward.get_linestyle() == "--"
