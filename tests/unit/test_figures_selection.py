"""Every figure draws what a selection leaves (``study figure NAME FILE --sel KEY=VALUE``).

A selection that leaves one value of a dimension, dropped to a scalar coordinate
(``--sel a=7``) or kept with length 1 (``--sel a=7:7``), draws the reduced figure (one
curve instead of a family, one panel, one waypoint), with the selection in the title;
a selection a figure cannot draw (one value of the axis it draws along) is refused by
a FigureError naming the figure, the dimension and what it needs, never a traceback.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.figure import Figure
from PIL import Image

from study.analyses.selection import select
from study.cli import main
from study.engine.runner import run_study
from study.engine.store import open_result
from study.figures import FIGURES, FigureError, common, draw_figure
from tests.support.tiers import headline
from tests.unit.test_figures_steering import (
    calibration_dataset,
    plan_dataset,
    trajectory_dataset,
)

PAPER = """\
f0 = 14.44
Q = 17.5
alpha = 64.0
cs = 0.25
"""

SPECS = {
    # One structure of one's own, Q and M swept (a figure of one structure selects it).
    "own": """\
[study]
name = "own"
observables = ["resonance", "thresholds", "lift_off", "velocity", "frontier"]
[structure]
f0 = 22.0
alpha = 45.0
cs = 0.35
ck = 0.3
[sweep]
Q = { values = [15.0, 30.0] }
M = { values = [0.1, 0.15] }
f = { start = 15.0, stop = 30.0, num = 11 }
a = { start = 0.0, stop = 12.0, num = 9 }
""",
    "paper": f"""\
[study]
name = "paper-small"
observables = ["resonance", "thresholds", "lift_off", "velocity", "frontier"]
[structure]
{PAPER}M = 0.08
[sweep]
f = {{ start = 10.0, stop = 20.0, num = 21 }}
a = {{ start = 0.0, stop = 12.0, num = 13 }}
""",
    "loads": f"""\
[study]
name = "loads-small"
observables = ["thresholds", "lift_off", "velocity"]
[structure]
{PAPER}
[structure.mass]
m0 = 8.2e-3
m1_fraction = 0.08
[sweep]
m_add = {{ values = [0.0, 1.7e-3, 16.6e-3] }}
f = {{ start = 10.0, stop = 20.0, num = 41 }}
a = {{ start = 0.0, stop = 12.0, num = 7 }}
""",
    "collapse": """\
[study]
name = "collapse-small"
observables = ["thresholds", "lift_off"]
[structure]
f0 = 14.44
cs = 0.25
[sweep]
alpha = { values = [60.0, 64.0] }
Q = { values = [3.0, 17.5] }
M = { start = 0.01, stop = 1.0, num = 3, spacing = "log" }
f = { start = 7.0, stop = 29.0, num = 41 }
""",
    "limit": f"""\
[study]
name = "limit-small"
observables = ["thresholds", "lift_off", "velocity", "frontier"]
[structure]
{PAPER}
[sweep]
M = {{ values = [0.08, 1.0] }}
f = {{ start = 5.0, stop = 30.0, num = 21 }}
a = {{ start = 0.0, stop = 12.0, num = 9 }}
""",
    "coupling": f"""\
[study]
name = "coupling-small"
observables = ["lift_off", "velocity", "paper_model"]
[structure]
{PAPER}
[sweep]
M = {{ values = [0.08, 0.5] }}
f = {{ start = 10.0, stop = 20.0, num = 11 }}
a = {{ start = 0.0, stop = 12.0, num = 7 }}
[solver]
coupling = "two-way"
""",
    "flight": f"""\
[study]
name = "flight-small"
observables = ["lift_off", "velocity", "frontier"]
[structure]
{PAPER}
[sweep]
M = {{ values = [0.08, 0.99] }}
f = {{ start = 5.0, stop = 30.0, num = 11 }}
a = {{ start = 0.0, stop = 12.0, num = 7 }}
[solver]
coupling = "two-way"
flight = true
""",
    # Irregular bouncing at M = 0.99 (chaotic points among the orbits).
    "irregular": f"""\
[study]
name = "irregular-small"
observables = ["velocity", "irregular"]
[structure]
{PAPER}
[sweep]
M = {{ values = [0.99] }}
f = {{ start = 5.5, stop = 6.5, num = 3 }}
a = {{ start = 11.0, stop = 11.9, num = 3 }}
[solver]
coupling = "two-way"
flight = true
""",
    # Slow sweeps up and down at M = 0.99 with flight across the forward hop's fold.
    "hysteresis": f"""\
[study]
name = "hysteresis-small"
observables = ["velocity"]
[structure]
{PAPER}
M = 0.99
[sweep]
f = {{ values = [14.8, 15.6, 16.4] }}
a = {{ values = [9.0, 10.0] }}
protocol = {{ along = "f", direction = "both" }}
[solver]
coupling = "two-way"
flight = true
""",
    # The same sweeps with the branches they ride and their located jumps.
    "branches": f"""\
[study]
name = "branches-small"
observables = ["velocity", "jumps", "branches"]
[structure]
{PAPER}
M = 0.99
[sweep]
f = {{ values = [14.8, 15.6, 16.4] }}
a = {{ values = [9.0, 10.0] }}
protocol = {{ along = "f", direction = "both" }}
[solver]
coupling = "two-way"
flight = true
""",
    # The two hops' folds from sweeps both ways with the jumps observable, over M.
    "folds": f"""\
[study]
name = "folds-small"
observables = ["velocity", "jumps"]
[structure]
{PAPER}
[sweep]
M = {{ values = [0.95, 0.99] }}
f = {{ values = [14.8, 15.6, 16.4] }}
a = {{ values = [9.0, 10.0] }}
protocol = {{ along = "f", direction = "both" }}
[solver]
coupling = "two-way"
flight = true
""",
    # The phase-0 section of bouncing at M = 0.99 along f (a chaotic point among the
    # orbits).
    "section": f"""\
[study]
name = "section-small"
observables = ["velocity", "irregular", "section"]
[structure]
{PAPER}
M = 0.99
[sweep]
f = {{ values = [5.5, 5.625, 7.0] }}
a = {{ values = [11.6] }}
[solver]
coupling = "two-way"
flight = true
""",
}

LAB = """\
quantity,f,a,value,sigma
threshold,13.0,,6.25,0.05
threshold,16.5,,6.6,0.05
ringdown_Q,,,17.5,0.5
"""

#: A calibration scene of three frequencies at two accelerations (about a second).
CALIBRATION = """\
[scene]
name = "tiny-calibration"
kind = "calibration"
[disk]
radius = 0.02
cs = 0.25
[[plate]]
name = "head"
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
direction = 0.0
attachment = [0.02, 0.0]
[[plate]]
name = "tail"
f0 = 7.7
Q = 10.0
alpha = 64.0
M = 0.08
direction = -90.0
attachment = [-0.02, 0.0]
[calibration]
f = { values = [8.2, 14.2, 15.2] }
a = { values = [6.0, 7.0] }
"""

FIT = """\
[fit]
name = "sel"
measurements = ["lab.csv"]
free = { cs = [0.05, 1.0] }
coupling = "two-way"
[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.08
cs = 0.3
"""

def _plan() -> xr.Dataset:
    """The synthetic plan in the layout the runner writes: strategies named by an
    auxiliary coordinate (the dimension has none), waypoints numbered from 0."""
    dataset = plan_dataset()
    return dataset.assign_coords(
        strategy_name=("strategy", dataset["strategy"].values.astype(str)),
        waypoint=("waypoint", np.arange(dataset.sizes["waypoint"]))).drop_vars("strategy")


def _basins():
    """A small basins map at M = 0.99 with flight (tests/support/basins_dataset.py)."""
    import study
    from tests.support.basins_dataset import computed

    return computed(study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25),
                    [12.5, 13.0, 13.5], [10.0, 12.0], starts=6, flight=True)


SCENES = {
    "trajectory": trajectory_dataset,
    "calibration": calibration_dataset,
    "plan": _plan,
    "basins": _basins,
}


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("selection")
    out = {}
    for name, text in SPECS.items():
        (folder / f"{name}.toml").write_text(text)
        out[name] = folder / f"{name}.nc"
        run_study(folder / f"{name}.toml", out[name], progress=False, workers=1)
    (folder / "lab.csv").write_text(LAB)
    (folder / "fit.toml").write_text(FIT)
    out["fit"] = folder / "fit.nc"
    assert main(["fit", str(folder / "fit.toml"), "-o", str(out["fit"])]) == 0
    (folder / "scene.toml").write_text(CALIBRATION)
    out["scene"] = folder / "scene.nc"
    assert main(["run", str(folder / "scene.toml"), "-o", str(out["scene"]),
                 "--workers", "1"]) == 0
    for name, make in SCENES.items():
        out[name] = folder / f"{name}.nc"
        make().to_netcdf(out[name], engine="netcdf4")
    return out


def _open(path: Path) -> xr.Dataset:
    if path.stem in SCENES:
        with xr.open_dataset(path, engine="netcdf4") as dataset:
            return dataset.load()
    return open_result(path)


@pytest.fixture
def drawn(monkeypatch):
    """The matplotlib figures saved (``common.save`` closes each), kept for inspection."""
    figures: list[Figure] = []
    close = common.plt.close

    def keep(fig=None):
        if isinstance(fig, Figure):
            figures.append(fig)
        return close(fig)

    monkeypatch.setattr(common.plt, "close", keep)
    yield figures
    for fig in figures:
        close(fig)


def _title(png: Path) -> str:
    with Image.open(png) as image:
        return dict(image.text)["Title"]


def _gids(fig: Figure, prefix: str) -> list[str]:
    return sorted(a.get_gid() for ax in fig.axes for a in ax.get_children()
                  if (a.get_gid() or "").startswith(prefix))


def _draw(figure: str, files, source: str, sel: list[str], tmp_path, drawn) -> Figure:
    stem = tmp_path / figure
    png, pdf = draw_figure(figure, _open(files[source]), stem, sel=sel,
                           source=str(files[source]))
    assert png.stat().st_size > 1000 and pdf.stat().st_size > 1000
    (fig,) = drawn
    title = _title(png)
    for text in sel:
        assert text.split("=")[0] + "=" in title, title
    return fig


def _texts(fig: Figure) -> str:
    """The figure's title and its axes' titles, one string."""
    return "\n".join([fig.get_suptitle(), *(ax.get_title() for ax in fig.axes)])


# --- one value left: the reduced figure ------------------------------------------------


@pytest.mark.parametrize("figure", headline(["thresholds", "velocity-curves", "regime-map",
                                             "force-traces"]))
def test_a_structure_axis_kept_with_one_value_is_one_structure(figure, files, tmp_path,
                                                              drawn):
    fig = _draw(figure, files, "own", ["Q=30:30", "M=0.15:0.15"], tmp_path, drawn)
    assert "Q = 30, $\\alpha$ = 45°, M = 0.15" in _texts(fig)


def test_velocity_curves_of_one_frequency_draw_one_curve(files, tmp_path, drawn):
    fig = _draw("velocity-curves", files, "paper", ["f=14.5"], tmp_path, drawn)
    assert [line.get_label() for line in fig.axes[0].lines
            if line.get_label().endswith(" Hz")] == ["14.5 Hz"]


def test_velocity_curves_of_a_list_of_frequencies_draw_just_those(files, tmp_path, drawn):
    fig = _draw("velocity-curves", files, "paper", ["f=13,14.5,16"], tmp_path, drawn)
    labels = [line.get_label() for line in fig.axes[0].lines
              if line.get_label().endswith(" Hz")]
    assert labels == ["13 Hz", "14.5 Hz", "16 Hz"]
    assert "selected: f=13,14.5,16 Hz" in _texts(fig)


def test_regime_map_of_one_frontier_branch(files, tmp_path, drawn):
    fig = _draw("regime-map", files, "paper", ["branch=0"], tmp_path, drawn)
    frontier = [line for line in fig.axes[0].lines if line.get_marker() == "o"
                and len(line.get_xdata()) == _open(files["paper"]).sizes["a"]]
    assert len(frontier) == 1


def test_mass_ratio_at_one_acceleration_draws_it_and_keeps_the_thresholds(files, tmp_path,
                                                                       drawn):
    fig = _draw("mass-ratio", files, "loads", ["a=6"], tmp_path, drawn)
    left = fig.axes[0]
    assert any(line.get_label().startswith("selected a = 6") for line in left.lines)
    assert left.get_ylim()[1] >= 1.15 * 6.0  # not cut at the acceleration selected


def test_mass_ratio_of_one_load_draws_one_curve(files, tmp_path, drawn):
    fig = _draw("mass-ratio", files, "loads", ["m_add=1.7e-3"], tmp_path, drawn)
    labels = [line.get_label() for line in fig.axes[0].lines]
    assert [t for t in labels if t.startswith("m_add")] == ["m_add = 1.7 g, M = 6.6 %"]


def test_threshold_collapse_squeezes_a_structure_axis_of_one_value(files, tmp_path, drawn):
    fig = _draw("threshold-collapse", files, "collapse", ["alpha=64:64"], tmp_path, drawn)
    points = [line for line in fig.axes[0].lines if line.get_marker() == "o"
              and len(line.get_xdata())]
    assert sum(len(line.get_xdata()) for line in points) == 2 * 3  # Q x M structures


def test_mass_ratio_limit_of_one_frontier_branch(files, tmp_path, drawn):
    fig = _draw("mass-ratio-limit", files, "limit", ["M=1", "branch=0"], tmp_path, drawn)
    assert len([ax for ax in fig.axes if ax.get_visible() and ax.get_title()]) == 1


def test_coupling_at_one_mass_ratio(files, tmp_path, drawn):
    fig = _draw("coupling", files, "coupling", ["M=0.08"], tmp_path, drawn)
    left, right = fig.axes[:2]
    assert all(len(line.get_xdata()) <= 1 for line in left.lines)
    assert [line.get_label() for line in right.lines if line.get_label().startswith("M =")] \
        == ["M = 0.08"]
    assert "M = 0.08" in fig.get_suptitle()


def test_coupling_at_one_acceleration_and_at_one_frequency(files, tmp_path, drawn):
    fig = _draw("coupling", files, "coupling", ["a=8"], tmp_path, drawn)
    assert fig.axes[1].get_title().startswith("a = 8.00")
    assert fig.axes[1].get_xlabel().startswith("drive frequency")
    drawn.clear()
    fig = _draw("coupling", files, "coupling", ["f=14"], tmp_path, drawn)
    assert fig.axes[1].get_xlabel().startswith("drive acceleration")
    assert fig.axes[1].get_title().startswith("f = 14 Hz")


def test_steering_of_one_segment_draws_its_part_of_the_path(files, tmp_path, drawn):
    fig = _draw("steering", files, "trajectory", ["segment=2"], tmp_path, drawn)
    assert _gids(fig, "segment-") == ["segment-2"]
    dataset = trajectory_dataset()
    (line,) = [a for a in fig.axes[0].lines if a.get_gid() == "segment-2"]
    samples = int(np.count_nonzero(dataset["segment_index"].values == 2))
    assert len(line.get_xdata()) == samples
    assert "1 segment" in fig.get_suptitle()


def test_steering_at_one_time_draws_the_pose(files, tmp_path, drawn):
    fig = _draw("steering", files, "trajectory", ["t=2.5"], tmp_path, drawn)
    assert "the pose at t = 2.5 s, in segment 1 (left)" in fig.get_suptitle()


def test_steering_calibration_at_one_acceleration_draws_one_line(files, tmp_path, drawn):
    fig = _draw("steering-calibration", files, "calibration", ["a=8"], tmp_path, drawn)
    assert _gids(fig, "forward-") == ["forward-0"]
    assert _gids(fig, "turn-") == ["turn-0"]
    assert "at a = 8 m s" in fig.get_suptitle()


@pytest.mark.parametrize("sel", [["strategy_name=open_loop"], ["strategy=0"]])
def test_steering_plan_of_one_strategy(sel, files, tmp_path, drawn):
    fig = _draw("steering-plan", files, "plan", sel, tmp_path, drawn)
    assert _gids(fig, "path-") == [f"path-open_loop-{r}" for r in range(5)]


def test_steering_plan_without_the_noise_free_run_draws_none(files, tmp_path, drawn):
    fig = _draw("steering-plan", files, "plan", ["realisation=1:3"], tmp_path, drawn)
    assert len(_gids(fig, "path-")) == 2 * 3
    assert not _gids(fig, "miss-open_loop-noise-free")
    assert "noise-free" not in fig.get_suptitle()


def test_steering_plan_of_one_waypoint_keeps_its_number(files, tmp_path, drawn):
    fig = _draw("steering-plan", files, "plan", ["waypoint=1", "realisation=0"], tmp_path,
                drawn)
    left, right = fig.axes[:2]
    assert [t.get_text() for t in left.texts if t.get_text().isdigit()] == ["2"]
    assert [t.get_text() for t in right.get_xticklabels()] == ["2"]
    assert len(_gids(fig, "path-")) == 2


def test_steering_plan_at_one_time_draws_the_positions(files, tmp_path, drawn):
    fig = _draw("steering-plan", files, "plan", ["t=6"], tmp_path, drawn)
    t = float(_open(files["plan"])["t"].sel(t=6, method="nearest"))
    assert f"positions at t = {t:g} s" in fig.axes[0].get_title()
    assert all(line.get_marker() == "o" for line in fig.axes[0].lines
               if (line.get_gid() or "").startswith("path-"))
    assert "whole runs" in fig.axes[1].get_title()


def test_fit_of_one_measurement_and_one_parameter(files, tmp_path, drawn):
    fig = _draw("fit", files, "fit", ["measurement=0"], tmp_path, drawn)
    assert len(fig.axes) == 1
    drawn.clear()
    fig = _draw("fit", files, "fit", ["parameter=cs"], tmp_path, drawn)
    assert "cs = " in fig.get_suptitle()


def test_the_calibration_of_the_issue_draws_at_one_acceleration(files, tmp_path, capsys):
    """``study figure steering-calibration FILE --sel a=7``: one line; one frequency is
    refused, naming what the figure needs."""
    stem = tmp_path / "calibration"
    assert main(["figure", "steering-calibration", str(files["scene"]), "-o", str(stem),
                 "--sel", "a=7"]) == 0
    assert "selected: a=7 m s-2" in _title(stem.with_suffix(".png"))
    assert main(["figure", "steering-calibration", str(files["scene"]), "-o",
                 str(tmp_path / "f"), "--sel", "f=14.2"]) == 1
    message = capsys.readouterr().err
    assert "figure 'steering-calibration'" in message
    assert "several values of f" in message and "--sel f=START:STOP" in message
    assert not (tmp_path / "f.png").exists()


# --- what a figure cannot draw: a clear error -------------------------------------------


@pytest.mark.parametrize(("figure", "source", "sel", "words"), [
    ("thresholds", "paper", ["f=14.5"], ["f=14.5", "several values of f"]),
    ("thresholds", "paper", ["f=14.5:14.5"], ["several values of f"]),
    ("velocity-curves", "paper", ["a=6"], ["several values of a", "--sel a=START:STOP"]),
    ("regime-map", "paper", ["f=14.5"], ["several values of f", "'velocity-curves'"]),
    ("regime-map", "paper", ["a=6"], ["several values of a"]),
    ("force-traces", "own", ["Q=30", "M=0.15", "a=0"], ["no point with 0 < a",
                                                        "--point F,A"]),
    ("mass-ratio", "loads", ["f=14.5"], ["several values of f"]),
    ("threshold-collapse", "collapse", ["alpha=64", "f=14.5"], ["minimum of the thresholds",
                                                                "several values of f"]),
    ("mass-ratio-limit", "limit", ["a=6"], ["several values of a"]),
    ("coupling", "coupling", ["a=0"], ["no such point"]),
    ("steering-calibration", "calibration", ["f=14.5"], ["several values of f"]),
    ("steering", "trajectory", ["t=0:1", "segment=3"], ["no sample of segment 3"]),
    ("fit", "fit", ["measurement=2"], ["ringdown_Q", "no threshold or velocity row"]),
])
def test_a_selection_a_figure_cannot_draw_is_refused(figure, source, sel, words, files,
                                                     tmp_path):
    with pytest.raises(FigureError) as caught:
        draw_figure(figure, _open(files[source]), tmp_path / figure, sel=sel,
                    source=str(files[source]))
    message = str(caught.value)
    assert f"figure '{figure}'" in message, message
    for word in words:
        assert word in message, message
    assert not (tmp_path / f"{figure}.png").exists()


def test_the_command_line_says_it_in_one_line(files, tmp_path, capsys):
    assert main(["figure", "regime-map", str(files["paper"]), "-o", str(tmp_path / "x"),
                 "--sel", "a=6"]) == 1
    message = capsys.readouterr().err
    assert message.count("\n") == 1 and "Traceback" not in message
    assert message.startswith("study: figure 'regime-map' draws a map over (f, a), which "
                              "needs several values of a; the selection leaves only a=6")


def test_a_segment_never_reached_is_refused(tmp_path):
    dataset = select(trajectory_dataset(lift_off_in=2), ["segment=3"])
    with pytest.raises(FigureError, match="not_reached"):
        draw_figure("steering", dataset, tmp_path / "x")


def test_a_key_a_scene_does_not_hold_is_refused(files, tmp_path, capsys):
    assert main(["figure", "steering-calibration", str(files["scene"]), "-o",
                 str(tmp_path / "x"), "--sel", "t=1"]) == 1
    assert "no coordinate 't'" in capsys.readouterr().err


# --- every figure, every dimension, one value: a figure or a FigureError ----------------

SOURCES = {
    "thresholds": ("paper", ["Q=17.5"]),
    "velocity-curves": ("paper", []),
    "regime-map": ("paper", []),
    "force-traces": ("paper", []),
    "mass-ratio": ("loads", []),
    "threshold-collapse": ("collapse", ["alpha=64"]),
    "mass-ratio-limit": ("limit", []),
    "coupling": ("coupling", []),
    "bouncing": ("flight", []),
    "lyapunov": ("irregular", []),
    "bifurcation": ("section", []),
    "hysteresis": ("hysteresis", []),
    "basins": ("basins", []),
    "fold-curves": ("folds", []),
    "branch-diagram": ("branches", []),
    "steering": ("trajectory", []),
    "steering-calibration": ("calibration", []),
    "steering-plan": ("plan", []),
    "fit": ("fit", []),
}


def _cases():
    dims = {"paper": ("f", "a", "branch"), "loads": ("m_add", "f", "a"),
            "collapse": ("Q", "M", "f"), "limit": ("M", "f", "a", "branch"),
            "coupling": ("M", "f", "a"), "flight": ("M", "f", "a", "branch"),
            "irregular": ("M", "f", "a"), "section": ("f", "a", "section_period"),
            "hysteresis": ("direction", "f", "a"),
            "branches": ("direction", "f", "a", "branch"),
            "folds": ("direction", "M", "f", "a"),
            "basins": ("f", "a", "attractor"),
            "trajectory": ("t", "segment"),
            "calibration": ("f", "a"), "fit": ("measurement", "parameter", "profile_point"),
            "plan": ("strategy", "realisation", "t", "waypoint", "segment")}
    for figure, (source, base) in SOURCES.items():
        for dim in dims[source]:
            yield pytest.param(figure, source, base, dim, id=f"{figure}-{dim}")


def test_every_figure_is_registered_here():
    assert set(SOURCES) == set(FIGURES)


@pytest.mark.parametrize(("figure", "source", "base", "dim"),
                         headline(_cases(), per=lambda figure, *_: figure))
def test_one_value_of_any_dimension_draws_or_says_why_not(figure, source, base, dim, files,
                                                         tmp_path, monkeypatch):
    """Dropped to a scalar (``--sel KEY=VALUE``) and kept with length 1
    (``KEY=VALUE:VALUE``), the middle value of each dimension: a figure, rendered, or a
    FigureError naming the figure and the dimension."""
    def render(fig, path, **kwargs):  # draw everything, skip encoding the files
        fig.canvas.draw()
        Path(path).touch()

    monkeypatch.setattr(Figure, "savefig", render)
    dataset = _open(files[source])
    position = dataset.sizes[dim] // 2
    if dim not in dataset.coords:  # by position
        values = [str(position)]
    else:
        value = dataset[dim].values[position]
        values = ([f"{value:.12g}", f"{value:.12g}:{value:.12g}"]
                  if dataset[dim].dtype.kind in "iuf" else [str(value)])
    for value in values:
        try:
            written = draw_figure(figure, dataset, tmp_path / "out", sel=[*base, f"{dim}={value}"],
                                  source=source)
        except FigureError as err:
            assert f"figure '{figure}'" in str(err) and dim in str(err), str(err)
            assert "several values" in str(err), str(err)
        else:
            assert all(p.exists() for p in written)
        finally:
            common.plt.close("all")


def test_a_steering_title_names_the_disk_and_its_plates(files, tmp_path, drawn):
    """The calibration scene's disk (radius 20 mm, cs = ck = 0.25) and both plates with
    the values of CALIBRATION."""
    fig = _draw("steering-calibration", files, "scene", [], tmp_path, drawn)
    title = fig.get_suptitle()
    assert "disk: radius 20 mm" in title and "$c_s$ = 0.25, $c_k$ = 0.25" in title
    assert "head: $f_0$ = 14.44 Hz, Q = 17.5, $\\alpha$ = 64°, M = 0.08" in title
    assert "tail: $f_0$ = 7.7 Hz, Q = 10" in title and "towards -90° at (-20, 0) mm" in title


def test_the_fit_figure_names_the_fixed_parameters_and_p(files, tmp_path, drawn):
    """FIT frees cs (ck follows it); the rest of its [structure] is fixed."""
    fig = _draw("fit", files, "fit", [], tmp_path, drawn)
    title = fig.get_suptitle()
    assert ("fixed: $f_0$ = 14.44 Hz, Q = 17.5, $\\alpha$ = 64°, M = 0.08, "
            "g = 9.8 m s$^{-2}$") in title
    p = float(open_result(files["fit"])["chi2_p_value"])
    assert f"(p = {p:.2g})" in title
