"""Figures that read as they should (issue 47, item 5): listed or coarse axes drawn as
their values, never as cells spanning values that were not computed; basin fractions a
bar per grid point; the thresholds' axis kept to the study's range with the curves that
leave it marked, and no "model invalid" over a study with flight; slow sweeps that
resumed from the declared start marked; many velocity curves cut to a readable subset;
a file without a slow sweep told to add one.

Most datasets here are built by hand (their values chosen, so that what the figure
must show is known exactly) or in closed form; the solver runs only where its answer
is what is checked.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
import xarray as xr
from matplotlib.collections import PolyCollection, QuadMesh
from numpy.testing import assert_allclose, assert_array_equal

import study
from study.figures import draw_figure
from study.model.status import Status
from study.studies.maps import compute_map

#: The issue's structure (f0 = 18 Hz, Q = 25, alpha = 55 degree, M = 0.9, cs = 0.35).
USER = study.Structure(f0=18.0, Q=25.0, alpha=55.0, M=0.9, cs=0.35)
PARAMETERS = {k: getattr(USER, k) for k in ("f0", "Q", "alpha", "M", "cs", "ck", "g")}


def _meshes(fig) -> list[QuadMesh]:
    """The cells drawn on the figure's plots over f (not the colour bars' own)."""
    return [c for ax in fig.axes if ax.get_xlabel().startswith("drive frequency")
            for c in ax.collections if isinstance(c, QuadMesh)]


def _legend_texts(fig) -> list[str]:
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes]
    return [t.get_text() for legend in legends if legend is not None
            for t in legend.get_texts()]


@pytest.fixture
def kept(monkeypatch):
    from matplotlib.figure import Figure

    from study.figures import common

    figures = []
    close = common.plt.close

    def keep(fig=None):
        if isinstance(fig, Figure):
            figures.append(fig)
        return close(fig)

    monkeypatch.setattr(common.plt, "close", keep)
    return figures


# --- slow sweeps: listed values as panels, cells no wider than computed, restarts ---

def _sweeps(f, a, along="f") -> xr.Dataset:
    """Sweeps up and down by hand: up +20 mm s-1, down -20 mm s-1 everywhere (every
    point differs), stick-slip, no jump."""
    f, a = np.asarray(f, dtype=float), np.asarray(a, dtype=float)
    shape = (2, f.size, a.size)
    velocity = np.empty(shape)
    velocity[0], velocity[1] = 0.02, -0.02
    dims = ("direction", "f", "a")
    return xr.Dataset(
        {"velocity": (dims, velocity),
         "status": (dims, np.full(shape, int(Status.STICK_SLIP), dtype=np.int8)),
         "jumped": (dims, np.zeros(shape, dtype=np.int8))},
        coords={"direction": ["up", "down"], "f": f, "a": a, **PARAMETERS},
        attrs={"study_name": "sweeps-by-hand", "study_protocol_along": along,
               "study_coupling": "two-way", "study_lift_off": "flight",
               "study_start": "release"})


def test_listed_values_of_the_other_axis_are_panels_not_bands():
    """a = [10, 12] (the issue's sweep): one panel of lines per value, no map whose
    cells would span 9-11 and 11-13."""
    from study.figures.hysteresis import compose

    dataset = _sweeps(np.round(np.arange(8.0, 20.01, 0.1), 6), [10.0, 12.0])
    fig, title = compose(dataset)
    assert not _meshes(fig)
    panels = [ax for ax in fig.axes if ax.get_lines()]
    assert [ax.get_title().split(":")[0] for ax in panels] == [
        "a = 10 m s$^{-2}$", "a = 12 m s$^{-2}$"]
    for ax, a in zip(panels, (10.0, 12.0), strict=True):
        lines = {line.get_label(): line for line in ax.get_lines()}
        assert_allclose(lines["swept up"].get_ydata(),
                        1e3 * dataset["velocity"].sel(direction="up", a=a).values, rtol=0)
        assert ax.get_title().endswith("121 of 121 drive values end on different motions "
                                       "up and down; 0 jumps")
    assert "Hysteresis along f at a = 10, 12 m s^-2" in title


def test_a_listed_axis_on_a_map_has_cells_only_as_wide_as_its_step():
    """a = [1, 2, 3, 4, 8] (enough values for a map, not evenly spaced): each value's
    cell is 1 m s-2 high (the smallest step), centred on it; nothing is drawn over
    4.5-7.5, where nothing was computed (a nearest-cell map would stretch the cells of
    4 and 8 to meet at 6)."""
    from study.figures.hysteresis import compose

    a = np.array([1.0, 2.0, 3.0, 4.0, 8.0])
    dataset = _sweeps(np.arange(10.0, 12.01, 0.5), a)
    fig, _ = compose(dataset)
    (mesh,) = _meshes(fig)
    corners = mesh.get_coordinates()  # (rows + 1, columns + 1, 2)
    shown = ~np.ma.getmaskarray(mesh.get_array()).reshape(corners.shape[0] - 1,
                                                          corners.shape[1] - 1)
    low, high = corners[:-1, 0, 1], corners[1:, 0, 1]
    drawn_rows = shown.any(axis=1)
    assert_allclose(high[drawn_rows] - low[drawn_rows], 1.0, rtol=1e-12)
    assert_allclose(0.5 * (low + high)[drawn_rows], a, rtol=1e-12)
    # Between 4.5 and 7.5 only a blank cell.
    assert not drawn_rows[(low >= 4.5 - 1e-9) & (high <= 7.5 + 1e-9)].any()
    assert_allclose([low[0], high[-1]], [0.5, 8.5], rtol=1e-12)


def test_a_regular_grid_keeps_its_cells_from_midpoint_to_midpoint():
    """On a regular grid the cells are those of shading='nearest': edges at the
    midpoints, half a step beyond each end (the maps of the workflows stay the same)."""
    from study.figures.common import cell_edges

    a = np.linspace(0.0, 12.0, 49)
    edges, index = cell_edges(a)
    assert_allclose(edges, np.linspace(-0.125, 12.125, 50), rtol=0, atol=1e-12)
    assert_array_equal(index, np.arange(49))
    edges, index = cell_edges(np.array([1.0, 2.0, 4.0]))
    assert_allclose(edges, [0.5, 1.5, 2.5, 3.5, 4.5], rtol=0, atol=1e-12)
    assert_array_equal(index, [0, 1, -1, 2])


def _with_lost_points(dataset: xr.Dataset) -> xr.Dataset:
    """Down: not converged at 9.6 Hz; up: lift-off at 10.0 and 10.1 Hz (no state)."""
    dataset = dataset.copy(deep=True)
    down = {"direction": 1, "f": int(np.argmin(np.abs(dataset["f"].values - 9.6)))}
    dataset["status"][down] = int(Status.NOT_CONVERGED)
    dataset["velocity"][down] = np.nan
    for f in (10.0, 10.1):
        up = {"direction": 0, "f": int(np.argmin(np.abs(dataset["f"].values - f)))}
        dataset["status"][up] = int(Status.LIFT_OFF)
        dataset["velocity"][up] = np.nan
    return dataset


def test_restarts_are_the_points_after_a_point_without_a_state():
    """A sweep visits f in order, up or down; after a point without a state to carry
    it starts by the declared start (docs/theory/starts.md): down, 9.5 Hz after 9.6 Hz;
    up, 10.2 Hz after the lift-off at 10.0 and 10.1 Hz (10.1 Hz has no velocity
    either: nothing resumed there)."""
    from study.figures.hysteresis import restarted

    f = np.round(np.arange(9.0, 11.01, 0.1), 6)
    dataset = _with_lost_points(_sweeps(f, [10.0]))
    again = restarted(dataset).squeeze("a")
    assert again.dims == ("direction", "f")
    assert_allclose(f[again.sel(direction="down").values], [9.5])
    assert_allclose(f[again.sel(direction="up").values], [10.2])


def test_the_hysteresis_figure_marks_where_a_sweep_resumed_from_its_start():
    from study.figures.hysteresis import compose

    f = np.round(np.arange(9.0, 11.01, 0.1), 6)
    dataset = _with_lost_points(_sweeps(f, [10.0]))
    fig, _ = compose(dataset)
    (ax,) = fig.axes
    marks = {line.get_label(): line for line in ax.get_lines() if line.get_marker() == "s"}
    down = marks["resumed from the release (swept down): the point before left no state "
                 "to carry"]
    assert_allclose(down.get_xdata(), [9.5])
    assert_allclose(down.get_ydata(), [-20.0])
    up = marks["resumed from the release (swept up): the point before left no state to "
               "carry"]
    assert_allclose(up.get_xdata(), [10.2])
    assert ax.get_title().endswith("; 0 jumps; 2 resumed from the release")
    lost = [line for line in ax.get_lines() if line.get_label().startswith("no velocity")]
    assert sorted(line.get_label() for line in lost) == [
        "no velocity (swept down: not converged)", "no velocity (swept up: lift off)"]


def test_on_a_map_the_restarts_are_marked_and_counted():
    from study.figures.hysteresis import compose

    f = np.round(np.arange(9.0, 11.01, 0.1), 6)
    a = np.linspace(9.0, 11.0, 5)
    dataset = _sweeps(f, a)
    lost = {"direction": 1, "f": int(np.argmin(np.abs(f - 9.6))), "a": 2}
    dataset["status"][lost] = int(Status.NOT_CONVERGED)
    dataset["velocity"][lost] = np.nan
    fig, _ = compose(dataset)
    ax = fig.axes[0]
    (mark,) = [line for line in ax.get_lines() if line.get_marker() == "v"]
    assert_allclose(mark.get_xdata(), [9.5])
    assert_allclose(mark.get_ydata(), [a[2]])
    assert "1 points where a sweep resumed from the release" in ax.get_title()


def test_a_sweep_resumes_on_the_release_after_lift_off():
    """On the solver's own sweep (the paper's structure, two-way, a swept down at
    14 Hz through lift-off): the point marked as resumed is the first below lift-off,
    and its velocity is the release's from rest at that point, bit for bit (the
    protocol started it by the declared start, not by a carried state)."""
    from study.figures.hysteresis import restarted
    from study.solvers.exact import steady_velocity
    from study.solvers.protocol import slow_sweep

    paper = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f, a = np.array([14.0]), np.array([8.0, 8.4, 8.8, 9.2, 9.6])
    sweeps = [slow_sweep(paper, f, a, along="a", direction=d) for d in ("up", "down")]
    dims = ("direction", "f", "a")
    dataset = xr.Dataset(
        {"velocity": (dims, np.stack([s.state.velocity for s in sweeps])),
         "status": (dims, np.stack([s.state.status for s in sweeps]))},
        coords={"direction": ["up", "down"], "f": f, "a": a},
        attrs={"study_protocol_along": "a"})
    status = dataset["status"].sel(direction="down").values.ravel()
    assert list(status[3:]) == [Status.LIFT_OFF] * 2 and np.all(np.isin(status[:3], (
        Status.STATIC, Status.STICK_SLIP)))
    again = restarted(dataset)
    assert_array_equal(again.sel(direction="down").values.ravel(),
                       [False, False, True, False, False])
    assert not again.sel(direction="up").any()
    alone, status = steady_velocity(paper, 14.0, 8.8, coupling="two-way")
    assert status == Status.STICK_SLIP
    assert float(dataset["velocity"].sel(direction="down", a=8.8).item()) == float(alone)


def test_a_file_without_a_sweep_is_told_to_add_the_protocol(tmp_path, capsys):
    """The issue: 'needs jumped' said nothing of [sweep] protocol. The message names it,
    and a spec with the protocol writes what the figure needs."""
    from study.cli import main
    from study.engine.runner import run_study
    from study.figures import FIGURES
    from study.studies.observables import variables_of

    spec = tmp_path / "map.toml"
    spec.write_text('[study]\nname = "no-sweep"\nobservables = ["velocity"]\n'
                    "[structure]\nf0 = 14.44\nQ = 17.5\nalpha = 64.0\nM = 0.08\ncs = 0.25\n"
                    "[sweep]\nf = { values = [13.0, 14.0] }\na = { values = [6.0] }\n")
    run_study(spec, tmp_path / "map.nc", progress=False, workers=1)
    assert main(["figure", "hysteresis", str(tmp_path / "map.nc"), "-o",
                 str(tmp_path / "h")]) == 1
    message = capsys.readouterr().err
    assert "needs jumped" in message
    assert ('add [sweep] protocol = { along = "f", direction = "both" }' in message), message
    assert "run it again" in message
    written = {v.name for v in variables_of(["velocity"], protocol=True)}
    assert set(FIGURES["hysteresis"].requires) <= written


# --- basins: a bar per grid point, coarse axes as lines ---

def _basins_by_hand(f, a) -> xr.Dataset:
    """Label 0 (+20 mm s-1) every start at every point but one, f = 9.5 Hz at the
    first a, where label 1 (+40 mm s-1) takes every start: a motion seen at one point."""
    f, a = np.asarray(f, dtype=float), np.asarray(a, dtype=float)
    shape = (f.size, a.size, 2)
    label = np.full(shape, -1, dtype=np.int64)
    label[..., 0] = 0
    alone = (int(np.argmin(np.abs(f - 9.5))), 0, 0)
    label[alone] = 1
    fraction = np.where(label >= 0, 1.0, np.nan)
    velocity = np.where(label == 0, 0.02, np.where(label == 1, 0.04, np.nan))
    dims = ("f", "a", "attractor")
    return xr.Dataset(
        {"attractor_label": (dims, label),
         "basin_status": (dims, np.where(label >= 0, int(Status.STICK_SLIP), -1)),
         "basin_velocity": (dims, velocity),
         "basin_largest_hop": (dims, np.full(shape, np.nan)),
         "basin_period": (dims, np.where(label >= 0, 1, 0)),
         "basin_fraction": (dims, fraction),
         "attractor_count": (("f", "a"), (label >= 0).sum(axis=-1))},
        coords={"f": f, "a": a, "attractor": [0, 1], **PARAMETERS},
        attrs={"study_name": "basins-by-hand", "study_coupling": "two-way",
               "study_lift_off": "flight"})


def test_basin_fractions_are_a_bar_per_grid_point_not_a_wedge():
    """The motion seen at 9.5 Hz alone is one bar there, no wider than the grid's step
    (stacked areas would draw it as a wedge from 9.25 to 9.75 Hz)."""
    from study.figures.basins import compose

    f = np.array([9.0, 9.25, 9.5, 9.75, 10.0])
    fig, _ = compose(_basins_by_hand(f, [10.0]))
    _, bottom = fig.axes
    assert not [c for c in bottom.collections if isinstance(c, PolyCollection)]
    bars = {c.get_label(): c for c in bottom.containers}
    assert sorted(bars) == ["label 0", "label 1"]
    heights = np.array([p.get_height() for p in bars["label 1"].patches])
    assert_allclose(heights, [0, 0, 1, 0, 0], rtol=0)
    (one,) = [p for p in bars["label 1"].patches if p.get_height() > 0]
    assert one.get_x() >= 9.5 - 0.125 and one.get_x() + one.get_width() <= 9.5 + 0.125
    assert_allclose(one.get_x() + 0.5 * one.get_width(), 9.5, rtol=1e-12)
    # Every point's bars stack to 1.
    total = sum(np.array([p.get_height() for p in c.patches]) for c in bars.values())
    assert_allclose(total, 1.0, rtol=0)


def test_a_few_point_basins_map_is_drawn_as_lines_per_listed_value():
    """f = 5 values by a = [10, 12]: a column of lines and bars per a, no cells
    spanning 9-13 m s-2."""
    from study.figures.basins import compose

    f = np.array([9.0, 9.25, 9.5, 9.75, 10.0])
    fig, title = compose(_basins_by_hand(f, [10.0, 12.0]))
    assert not _meshes(fig)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert [t.split(":")[0] for t in titles] == ["a = 10 m s$^{-2}$", "a = 12 m s$^{-2}$"]
    assert titles[0].endswith("2 motions along f, at most 1 at one drive")
    assert titles[1].endswith("1 motions along f, at most 1 at one drive")
    assert "Basins along f at a = 10, 12 m s^-2" in title


# --- thresholds: the study's range, curves that leave it, no hatch with flight ---

@pytest.fixture(scope="module")
def thresholds_map():
    """The issue's structure with flight over the issue's range, in closed form."""
    return compute_map(USER, np.round(np.linspace(8.0, 22.0, 141), 6),
                       np.linspace(0.0, 14.0, 15),
                       observables=["resonance", "thresholds", "lift_off"],
                       coupling="two-way", flight=True)


def _thresholds_axis(fig):
    return next(ax for ax in fig.axes if ax.get_ylabel().startswith("drive acceleration"))


def test_the_thresholds_axis_is_the_studys_range_of_a(thresholds_map, kept, tmp_path):
    """a*_- diverges near 12.9 Hz (162 m s-2 at 13 Hz) and the lift-off reaches 87:
    the axis stays the study's 0-14 m s-2 instead of 110."""
    draw_figure("thresholds", thresholds_map, tmp_path / "t")
    (fig,) = kept
    assert _thresholds_axis(fig).get_ylim() == (0.0, 14.0)
    assert float(thresholds_map["a_star_minus"].max()) > 150.0
    assert float(thresholds_map["lift_off_acceleration"].max()) > 80.0


def test_curves_that_leave_the_axis_are_marked_where_they_cross_it(thresholds_map, kept,
                                                                  tmp_path):
    """An arrowhead on the top edge where each curve crosses 14 m s-2, at the crossing
    of the closed form (found independently on a 100 times finer grid)."""
    from study.model.forces import lift_off_acceleration, thresholds

    draw_figure("thresholds", thresholds_map, tmp_path / "t")
    (fig,) = kept
    ax = _thresholds_axis(fig)
    arrows = [line for line in ax.get_lines() if line.get_marker() == "^"]
    fine = np.linspace(8.0, 22.0, 14001)
    _, minus = thresholds(USER, fine)
    lift = lift_off_acceleration(USER, fine)
    for curve, colour in ((minus, "tab:red"), (lift, "black")):
        above = curve > 14.0
        crossings = fine[np.flatnonzero(above[1:] != above[:-1])]
        assert crossings.size >= 1
        drawn = sorted(float(line.get_xdata()[0]) for line in arrows
                       if matplotlib.colors.same_color(line.get_color(), colour))
        assert_allclose(drawn, crossings, rtol=0, atol=0.1)  # the file's step
    assert "a curve leaves the axis" in _legend_texts(fig)


def test_a_study_with_flight_is_not_hatched_invalid_above_lift_off(thresholds_map, kept,
                                                                  tmp_path):
    """With flight the model follows the base past lift-off: no 'model invalid'."""
    draw_figure("thresholds", thresholds_map, tmp_path / "flight")
    fig = kept[-1]
    hatched = [c for ax in fig.axes for c in ax.collections if c.get_hatch()]
    texts = _legend_texts(fig)
    assert not hatched
    assert not any("invalid" in t or "outside the model" in t for t in texts), texts
    assert "lift-off of a base at rest (one-way estimate)" in texts
    # Without flight the hatch stays: above it the model does not apply.
    stopped = thresholds_map.copy()
    stopped.attrs["study_lift_off"] = "stop"
    draw_figure("thresholds", stopped, tmp_path / "stopped")
    fig = kept[-1]
    assert [c for ax in fig.axes for c in ax.collections if c.get_hatch() == "///"]
    assert "above: outside the model (no flight)" in _legend_texts(fig)


def test_a_file_without_a_range_of_a_gets_a_sensible_one(thresholds_map, kept, tmp_path):
    """Without an a axis (a thresholds study): room above the thresholds, but not past
    2 g here (the old top was 1.25 times the lift-off's 87 m s-2); the paper's file
    keeps its axis (1.25 times its highest lift-off, 14.07 m s-2)."""
    from study.model.forces import lift_off_acceleration, thresholds

    only_f = thresholds_map.drop_dims("a")
    draw_figure("thresholds", only_f, tmp_path / "only-f")
    assert_allclose(_thresholds_axis(kept[-1]).get_ylim(), (0.0, 2.0 * USER.g), rtol=1e-12)
    paper = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f = np.linspace(10.0, 20.0, 2001)
    dataset = compute_map(paper, f, [0.0], observables=["resonance", "thresholds",
                                                        "lift_off"]).drop_dims("a")
    draw_figure("thresholds", dataset, tmp_path / "paper")
    ax = _thresholds_axis(kept[-1])
    plus, minus = thresholds(paper, f)
    room = max(1.25 * lift_off_acceleration(paper, f).max(),
               1.15 * np.fmin(plus, minus).max(), 1.1 * paper.g)
    assert_allclose(ax.get_ylim(), (0.0, room), rtol=1e-12)
    assert_allclose(room, 14.07, atol=0.01)


# --- velocity curves: a readable subset of many ---

@pytest.fixture(scope="module")
def many_curves():
    """81 frequencies of the one-way model (the paper's), 10-26 Hz."""
    one_way = study.Structure(f0=18.0, Q=25.0, alpha=55.0, M=0.09, cs=0.35)
    dataset = compute_map(one_way, np.round(np.linspace(10.0, 26.0, 81), 6),
                          np.linspace(0.0, 12.0, 7),
                          observables=["thresholds", "lift_off", "velocity"])
    dataset.attrs["study_name"] = "many-curves"
    return dataset


def _curve_frequencies(fig) -> list[float]:
    ax = fig.axes[0]
    return [float(line.get_label().removesuffix(" Hz")) for line in ax.get_lines()
            if line.get_label().endswith(" Hz")]


def test_eighty_one_curves_are_cut_to_twelve_said_in_the_title(many_curves, kept,
                                                               tmp_path):
    draw_figure("velocity-curves", many_curves, tmp_path / "many")
    (fig,) = kept
    drawn = _curve_frequencies(fig)
    f = many_curves["f"].values
    assert len(drawn) == 12
    # Both ends and the frequency nearest the resonance (18 Hz) among them.
    assert {10.0, 26.0, 18.0} <= set(drawn)
    assert set(drawn) <= set(f.tolist())
    assert "12 of the file's 81 frequencies" in fig.axes[0].get_title()
    assert "--sel f=" in fig.axes[0].get_title()


def test_frequencies_chosen_with_sel_are_all_drawn(many_curves, kept, tmp_path):
    draw_figure("velocity-curves", many_curves, tmp_path / "chosen", sel=["f=14:18"])
    (fig,) = kept
    assert len(_curve_frequencies(fig)) == 21  # 14, 14.2, ..., 18
    assert "of the file's" not in fig.axes[0].get_title()


def test_twelve_curves_are_all_drawn(many_curves, kept, tmp_path):
    """The paper's file holds 12 frequencies: its figure draws every one."""
    twelve = many_curves.isel(f=np.arange(0, 81, 7)[:12])
    draw_figure("velocity-curves", twelve, tmp_path / "twelve")
    (fig,) = kept
    assert_allclose(_curve_frequencies(fig), twelve["f"].values, rtol=0)
    assert "of the file's" not in fig.axes[0].get_title()
