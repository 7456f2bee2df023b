"""Figures of studies with flight: the bouncing region, and the velocity figures drawn
from a flight file (bouncing points drawn as velocities, the region's edge, the curves
without flight beside them), each saying in its title that the base flies."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from study.cli import main
from study.engine.runner import run_study
from study.engine.store import open_result
from study.figures import FIGURES, FigureError, draw_figure
from study.figures.bouncing import bouncing_share, row_indices
from study.figures.common import VALID, coupling_label
from study.model.status import Status
from tests.support.tiers import headline

SPEC = """\
[study]
name = "small-flight-maps"
observables = ["thresholds", "lift_off", "velocity", "diagnostics", "paper_model",
               "without_flight", "frontier"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
cs = 0.25

[sweep]
M = { values = [0.08, 0.6, 0.99] }
f = { start = 10.0, stop = 20.0, num = 21 }
a = { start = 0.0, stop = 12.0, num = 13 }

[solver]
coupling = "two-way"
flight = true
"""

#: figure -> the --sel it needs on the small file.
DRAWN = {
    "bouncing": [],
    "mass-ratio-limit": [],
    "coupling": [],
    "regime-map": ["M=0.99"],
    "velocity-curves": ["M=0.99", "f=12,14,16"],
}


@pytest.fixture(scope="module")
def flight_file(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("flight-figures")
    (folder / "maps.toml").write_text(SPEC)
    run_study(folder / "maps.toml", folder / "maps.nc", progress=False, workers=1)
    return folder / "maps.nc"


@pytest.fixture(scope="module")
def bouncing_dataset(flight_file):
    """The small file with every lift-off point of the run without flight made a
    bouncing point with made-up values, so that the drawing of a bouncing region is
    tested whatever the solver gives there."""
    dataset = open_result(flight_file)
    lifted = dataset["status_without_flight"] == int(Status.LIFT_OFF)
    assert lifted.any()
    hop = 1e-3 * (dataset["a"] / 12.0) * lifted
    dataset["status"] = dataset["status"].where(~lifted, int(Status.BOUNCING)).astype("int8")
    dataset["velocity"] = dataset["velocity"].where(~lifted, 1e-2 * (dataset["f"] - 15.0))
    dataset["largest_hop"] = dataset["largest_hop"].where(~lifted, hop)
    dataset["airborne_fraction"] = dataset["airborne_fraction"].where(~lifted, 0.4 * lifted)
    return dataset


def _drawn(figure, dataset, tmp_path, monkeypatch):
    """Draw ``figure`` and return its title and legend labels."""
    from study.figures import common

    kept = []
    close = common.plt.close
    monkeypatch.setattr(common.plt, "close", lambda fig=None: kept.append(fig))
    png, _ = draw_figure(figure, dataset, tmp_path / figure, sel=DRAWN[figure])
    (fig,) = kept
    labels = [t.get_text() for legend in fig.legends + [ax.get_legend() for ax in fig.axes]
              if legend is not None for t in legend.get_texts()]
    close(fig)
    with Image.open(png) as image:
        title = dict(image.text)["Title"]
    return title, labels


def test_the_bouncing_figure_is_registered_with_the_flight_workflow():
    figure = FIGURES["bouncing"]
    assert figure.workflow == "mass-ratio-limit-flight"
    assert (Path(__file__).resolve().parents[2] / "workflows" /
            f"{figure.workflow}.toml").exists()
    assert {"largest_hop", "airborne_fraction"} <= set(figure.requires)


@pytest.mark.parametrize("figure", headline(sorted(DRAWN)))
def test_each_figure_of_a_flight_file_says_it_flies(figure, flight_file, tmp_path):
    stem = tmp_path / figure
    arguments = ["figure", figure, str(flight_file), "-o", str(stem)]
    for selection in DRAWN[figure]:
        arguments += ["--sel", selection]
    assert main(arguments) == 0
    png = stem.with_suffix(".png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert stem.with_suffix(".pdf").read_bytes()[:4] == b"%PDF"
    with Image.open(png) as image:
        title = dict(image.text)["Title"]
    assert "flight past lift-off" in title, title
    assert coupling_label(open_result(flight_file)) in title


@pytest.mark.parametrize("figure", headline(["bouncing", "mass-ratio-limit", "regime-map"]))
def test_a_bouncing_region_gets_its_edge_in_the_legend(figure, bouncing_dataset, tmp_path,
                                                       monkeypatch):
    _, labels = _drawn(figure, bouncing_dataset, tmp_path, monkeypatch)
    assert any(label.startswith("edge of the bouncing region") for label in labels), labels
    # With flight no point lifts off: no lift-off patch in the legend.
    assert not any(label.startswith("lift-off:") for label in labels), labels


def test_velocity_curves_of_a_flight_file_show_bouncing_and_the_curves_without(
        bouncing_dataset, tmp_path, monkeypatch):
    _, labels = _drawn("velocity-curves", bouncing_dataset, tmp_path, monkeypatch)
    assert any(label.startswith("bouncing: flights and") for label in labels), labels
    assert any("without flight (same\ncoupling): ends at lift-off" == label
               for label in labels), labels


def test_the_bouncing_figure_refuses_a_file_that_does_not_fly(flight_file, tmp_path):
    dataset = open_result(flight_file)
    del dataset.attrs["study_lift_off"]
    with pytest.raises(FigureError, match=r"stops at lift-off.*flight = true"):
        draw_figure("bouncing", dataset, tmp_path / "bouncing")


def test_a_missing_flight_variable_names_the_flight_key(flight_file, tmp_path):
    dataset = open_result(flight_file).drop_vars("largest_hop")
    with pytest.raises(FigureError, match=r"largest_hop.*with flight.*\[solver\] flight = "
                       r"true"):
        draw_figure("bouncing", dataset, tmp_path / "bouncing")


def test_bouncing_share_counts_of_the_map_and_of_the_moving_points():
    status = np.array([Status.STATIC, Status.STICK_SLIP, Status.BOUNCING, Status.BOUNCING,
                       Status.NOT_CONVERGED, Status.CONTINUOUS_SLIDING], dtype=np.int8)
    share, of_moving = bouncing_share(status)
    assert share == pytest.approx(2 / 6) and of_moving == pytest.approx(2 / 4)
    assert Status.BOUNCING in VALID


def test_rows_spread_over_the_mass_ratios_ends_included():
    assert row_indices(2) == [0, 1]
    assert row_indices(6) == [0, 2, 5] or row_indices(6) == [0, 3, 5]
    assert row_indices(10)[0] == 0 and row_indices(10)[-1] == 9 and len(row_indices(10)) == 3


def _pixels(artist, renderer):
    return artist.get_window_extent(renderer)


def test_each_colour_bar_label_reads_as_its_own_maps(bouncing_dataset):
    """Each map's colour-bar label lies under its own map, inside the map's width, and
    touches no other map: beside a map of a row sharing its y axis, a label would read
    as the next map's y label (issue 34)."""
    import matplotlib.pyplot as plt

    from study.figures.bouncing import compose

    fig, _ = compose(bouncing_dataset)
    try:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        maps = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
        bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
        assert len(maps) == len(bars) == 3 * len(bouncing_dataset["M"])
        for bar in bars:
            label = bar.xaxis.label if bar.xaxis.label.get_text() else bar.yaxis.label
            assert label.get_text()
            box = _pixels(label, renderer)
            centre = 0.5 * (box.x0 + box.x1)
            # Its map: the one straight above the bar.
            bar_box = bar.get_window_extent(renderer)
            above = [ax for ax in maps if ax.get_window_extent(renderer).y0 >= bar_box.y1
                     and ax.get_window_extent(renderer).x0 <= centre
                     <= ax.get_window_extent(renderer).x1]
            assert above, f"colour bar {label.get_text()!r} has no map above it"
            own = min(above, key=lambda ax: ax.get_window_extent(renderer).y0 - bar_box.y1)
            own_box = own.get_window_extent(renderer)
            assert own_box.x0 <= box.x0 and box.x1 <= own_box.x1, label.get_text()
            for other in maps:
                tight = other.get_tightbbox(renderer)
                if other is not own:
                    assert not box.overlaps(tight), (label.get_text(), other.get_title())
    finally:
        plt.close(fig)


@pytest.mark.parametrize("figure", headline(["bouncing", "mass-ratio-limit", "regime-map"]))
def test_irregular_points_are_their_own_class_with_their_velocity(
        figure, bouncing_dataset, tmp_path, monkeypatch):
    """Chaotic and quasi-periodic points keep their velocity on the maps and are named in
    the legend by their declared text (issue 35), not drawn as holes."""
    dataset = bouncing_dataset.copy()
    bouncing = (dataset["status"] == int(Status.BOUNCING)).values
    chosen = np.flatnonzero(bouncing.ravel())
    assert chosen.size >= 4
    status = dataset["status"].values.copy().ravel()
    status[chosen[::2]] = int(Status.CHAOTIC)
    status[chosen[1::4]] = int(Status.QUASI_PERIODIC)
    dataset["status"] = dataset["status"].copy(data=status.reshape(bouncing.shape))
    _, labels = _drawn(figure, dataset, tmp_path, monkeypatch)
    for irregular in (Status.CHAOTIC, Status.QUASI_PERIODIC):
        assert irregular.legend in labels, labels
    assert not any(label.startswith("not converged") for label in labels), labels
    assert Status.CHAOTIC in VALID and Status.QUASI_PERIODIC in VALID


@pytest.mark.parametrize("figure", headline(["bouncing", "mass-ratio-limit"]))
def test_no_two_panel_titles_overlap(figure, bouncing_dataset, tmp_path, monkeypatch):
    """Each panel's title stays over its own panel, even with every count a title can
    carry (chaotic, quasi-periodic, not converged): titles of neighbouring panels must
    not run into each other."""
    from study.figures import common

    dataset = bouncing_dataset.copy()
    status = dataset["status"].values.copy().ravel()
    bouncing = np.flatnonzero(status == int(Status.BOUNCING))
    for k, flag in enumerate((Status.CHAOTIC, Status.QUASI_PERIODIC, Status.NOT_CONVERGED)):
        status[bouncing[k::3][:40]] = int(flag)
    dataset["status"] = dataset["status"].copy(data=status.reshape(dataset["status"].shape))
    dataset["velocity"] = dataset["velocity"].where(
        dataset["status"] != int(Status.NOT_CONVERGED))
    kept = []
    close = common.plt.close
    monkeypatch.setattr(common.plt, "close", lambda fig=None: kept.append(fig))
    draw_figure(figure, dataset, tmp_path / figure, sel=DRAWN[figure])
    (fig,) = kept
    try:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        titles = [ax.title for ax in fig.axes if ax.get_title()]
        assert len(titles) >= 3
        boxes = [title.get_window_extent(renderer) for title in titles]
        for i, first in enumerate(boxes):
            for j in range(i + 1, len(boxes)):
                assert not first.overlaps(boxes[j]), (titles[i].get_text(),
                                                     titles[j].get_text())
    finally:
        close(fig)


IRREGULAR_SPEC = """\
[study]
name = "irregular-small"
observables = ["velocity", "diagnostics", "irregular"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
cs = 0.25
M = 0.99

[sweep]
f = { start = 5.5, stop = 6.5, num = 5 }
a = { start = 11.0, stop = 11.9, num = 4 }

[solver]
coupling = "two-way"
flight = true
"""


def test_the_lyapunov_figure_draws_velocity_and_exponent(tmp_path):
    """The lyapunov figure of a small irregular study: both maps, each colour bar under
    its own map, the chaotic points named in the legend, the exponent's scale spanning
    both signs (stable orbits below 0, chaotic motions above)."""
    import matplotlib.pyplot as plt

    from study.figures.lyapunov import compose

    (tmp_path / "irregular.toml").write_text(IRREGULAR_SPEC)
    run_study(tmp_path / "irregular.toml", tmp_path / "irregular.nc", progress=False,
              workers=1)
    dataset = open_result(tmp_path / "irregular.nc")
    status = dataset["status"].values
    assert np.any(status == Status.CHAOTIC), np.unique(status)
    exponent = dataset["lyapunov_exponent"].values
    assert np.nanmax(exponent) > 0.0 > np.nanmin(exponent)
    fig, title = compose(dataset)
    try:
        assert "Lyapunov" in title
        labels = [t.get_text() for legend in fig.legends for t in legend.get_texts()]
        assert Status.CHAOTIC.legend in labels
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        maps = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
        bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
        assert len(maps) == len(bars) == 2
        for own, bar in zip(maps, bars, strict=True):
            box = bar.xaxis.label.get_window_extent(renderer)
            own_box = own.get_window_extent(renderer)
            assert own_box.x0 <= box.x0 and box.x1 <= own_box.x1
            assert box.y1 < own_box.y0
    finally:
        plt.close(fig)
    assert main(["figure", "lyapunov", str(tmp_path / "irregular.nc"), "-o",
                 str(tmp_path / "lyapunov")]) == 0


BIFURCATION_SPEC = """\
[study]
name = "bifurcation-small"
observables = ["velocity", "irregular", "section"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
cs = 0.25
M = 0.99

[sweep]
f = { values = [5.3, 5.5, 5.625, 7.0] }
a = { values = [11.6, 12.0] }

[solver]
coupling = "two-way"
flight = true
"""


def test_the_bifurcation_figure_draws_the_section_along_one_axis(tmp_path):
    """The bifurcation figure of a small section study: refused while both f and a are
    swept (naming the --sel to give); along f (a selected) one dot per point and
    section period in each section panel, as many as the file's finite section values,
    coloured by the point's exponent; the chaotic points named in the legend."""
    import matplotlib.pyplot as plt

    from study.analyses.selection import select
    from study.figures.bifurcation import compose

    (tmp_path / "section.toml").write_text(BIFURCATION_SPEC)
    run_study(tmp_path / "section.toml", tmp_path / "section.nc", progress=False, workers=1)
    dataset = open_result(tmp_path / "section.nc")
    with pytest.raises(FigureError, match="--sel a="):
        compose(dataset)
    along_f = select(dataset, ["a=11.6"])
    status = along_f["status"].values
    assert np.any(status == Status.CHAOTIC), np.unique(status)
    fig, title = compose(along_f)
    try:
        assert "along f" in title
        top, middle, bottom = (ax for ax in fig.axes if ax.get_label() != "<colorbar>")
        finite = int(np.isfinite(along_f["section_speed"].values).sum())
        assert finite > 0
        for ax, name in ((top, "section_speed"), (middle, "section_gap")):
            (dots,) = ax.collections
            assert len(dots.get_offsets()) == int(np.isfinite(along_f[name].values).sum())
            assert np.ma.count(dots.get_array()) == len(dots.get_offsets())
        labels = [t.get_text() for t in bottom.get_legend().get_texts()]
        assert Status.CHAOTIC.legend in labels
    finally:
        plt.close(fig)
    assert main(["figure", "bifurcation", str(tmp_path / "section.nc"), "--sel", "a=11.6",
                 "-o", str(tmp_path / "bifurcation")]) == 0


# Slow tier: test_a_bouncing_region_gets_its_edge_in_the_legend keeps the legend's
# headline check in the default tier (issue 46).
@pytest.mark.slow
def test_the_bouncing_legend_names_only_what_is_drawn(bouncing_dataset, tmp_path,
                                                      monkeypatch):
    """Drawn before a frontier is computed (no frontier observable), the legend has no
    frontier; with one it has."""
    _, labels = _drawn("bouncing", bouncing_dataset, tmp_path, monkeypatch)
    assert any(label.startswith("frontier") for label in labels), labels
    frontier = [name for name in bouncing_dataset.data_vars if name.startswith("frontier_")]
    before = bouncing_dataset.drop_vars(frontier)
    _, labels = _drawn("bouncing", before, tmp_path, monkeypatch)
    assert not any("frontier" in label for label in labels), labels
    assert any(label.startswith("edge of the bouncing region") for label in labels), labels


def test_the_bouncing_maps_draw_the_studys_lift_off_not_the_one_way_estimate(
        bouncing_dataset, tmp_path, monkeypatch):
    """The closed-form lift-off is the one-way model's for a base at rest; the two-way
    base that slides leaves the table elsewhere (the edge drawn from the file's own
    statuses), so the estimate is neither drawn nor in the legend."""
    from study.figures import common

    kept = []
    close = common.plt.close
    monkeypatch.setattr(common.plt, "close", lambda fig=None: kept.append(fig))
    draw_figure("bouncing", bouncing_dataset, tmp_path / "bouncing")
    (fig,) = kept
    estimates = [bouncing_dataset["lift_off_acceleration"].isel(M=i).values
                 for i in range(bouncing_dataset.sizes["M"])]
    lines = [np.asarray(line.get_ydata(), dtype=float) for ax in fig.axes
             for line in ax.get_lines()]
    labels = [t.get_text() for legend in fig.legends for t in legend.get_texts()]
    close(fig)
    assert not [line for line in lines for e in estimates
                if line.shape == e.shape and np.allclose(line, e, equal_nan=True)]
    assert not any(label.startswith("lift-off of the base at rest") for label in labels)
