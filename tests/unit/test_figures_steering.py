"""Steering figures (trajectory, calibration, waypoint plan) drawn from synthetic scene
files with the layout the scene runner writes."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr
from matplotlib.colors import to_rgba
from PIL import Image

from study.figures import (
    FIGURES,
    FigureError,
    draw_figure,
    steering,
    steering_calibration,
    steering_plan,
)

ATTRS = {
    "study_name": "steering-synthetic",
    "study_spec_sha256": "0123456789abcdef" * 4,
    "study_fingerprint": "synthetic",
    "study_version": "test",
    "date_created": "2024-01-01T00:00:00Z",
}

DISK_RADIUS = 0.015  # m

#: label, frequency [Hz], duration [s]
SEGMENTS = (
    ("forward", 14.2, 2.0),
    ("left", 8.2, 1.0),
    ("forward", 14.2, 1.5),
    ("right", 7.2, 1.0),
    ("wiggle", 11.0, 0.5),
)
SPEED = {"forward": 5e-3, "backward": -4e-3, "left": 2e-3, "right": 2e-3}  # m s-1
TURN = {"left": 0.8, "right": -0.8}  # rad s-1
SEGMENT_STATUS = {"flag_values": np.array([0, 1, 2, 3], dtype=np.int8),
                  "flag_meanings": "completed lift_off not_reached step_budget"}
STATUS = {"flag_values": np.array([0, 1, 2, 3, 4], dtype=np.int8),
          "flag_meanings": "static stick_slip continuous_sliding lift_off not_converged"}


def _var(dims, values, units=None, long_name="", **attrs):
    if units is not None:
        attrs["units"] = units
    return xr.Variable(dims, np.asarray(values), {"long_name": long_name, **attrs})


def trajectory_dataset(lift_off_in: int | None = None, dt: float = 0.01) -> xr.Dataset:
    """A ``trajectory`` scene of :data:`SEGMENTS`; with ``lift_off_in``, the disk lifts
    off halfway through that segment and the later ones are not reached."""
    labels = [s[0] for s in SEGMENTS]
    frequency = np.array([s[1] for s in SEGMENTS])
    duration = np.array([s[2] for s in SEGMENTS])
    n = len(labels)
    start = np.concatenate([[0.0], np.cumsum(duration)[:-1]])
    end = start + duration
    status = np.zeros(n, dtype=np.int8)
    stop = end[-1]
    if lift_off_in is not None:
        stop = start[lift_off_in] + duration[lift_off_in] / 2
        status[lift_off_in] = 1
        status[lift_off_in + 1:] = 2
        end[lift_off_in] = stop
        start[lift_off_in + 1:] = np.nan
        end[lift_off_in + 1:] = np.nan
    time = np.arange(0.0, stop + dt / 2, dt)
    index = np.minimum(np.searchsorted(np.cumsum(duration), time, side="right"), n - 1)
    speed = np.array([SPEED.get(labels[k], 0.0) for k in index])
    turn = np.array([TURN.get(labels[k], 0.0) for k in index])
    heading = 0.3 + np.concatenate([[0.0], np.cumsum(turn[:-1] * dt)])
    x = np.concatenate([[0.0], np.cumsum((speed * np.cos(heading) * dt)[:-1])])
    y = np.concatenate([[0.0], np.cumsum((speed * np.sin(heading) * dt)[:-1])])
    path = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])

    def per_segment(values):
        out = np.full(n, np.nan)
        for k in range(n):
            picked = np.flatnonzero(index == k)
            if picked.size:
                out[k] = values[picked[-1]] - values[max(picked[0] - 1, 0)]
        return out

    dx, dy = per_segment(x), per_segment(y)
    return xr.Dataset(
        {
            "x": _var("t", x, "m", "x of the disk's centre"),
            "y": _var("t", y, "m", "y of the disk's centre"),
            "heading": _var("t", np.degrees(heading), "degree",
                            "heading, counterclockwise from +x"),
            "path_length": _var("t", path, "m", "path length"),
            "slipping": _var("t", (speed != 0).astype(np.int8), None, "slipping",
                             flag_values=np.array([0, 1], dtype=np.int8),
                             flag_meanings="stuck slipping"),
            "segment_index": _var("t", index.astype(np.int32), None, "segment"),
            "segment_label": _var("segment", np.array(labels), None, "command"),
            "frequency": _var("segment", frequency, "Hz", "drive frequency"),
            "acceleration": _var("segment", np.full(n, 8.0), "m s-2", "drive acceleration"),
            "duration": _var("segment", duration, "s", "duration"),
            "start_time": _var("segment", start, "s", "start"),
            "end_time": _var("segment", end, "s", "end"),
            "forward_displacement": _var("segment", dx, "m", "forward displacement"),
            "lateral_displacement": _var("segment", dy, "m", "lateral displacement"),
            "heading_change": _var("segment", np.degrees(per_segment(heading)), "degree",
                                   "heading change"),
            "segment_path_length": _var("segment", per_segment(path), "m", "path length"),
            "segment_status": _var("segment", status, None, "outcome", **SEGMENT_STATUS),
        },
        coords={"t": _var("t", time, "s", "t"),
                "segment": _var("segment", np.arange(n), None, "segment")},
        attrs={**ATTRS, "study_scene_kind": "trajectory", "disk_radius": DISK_RADIUS},
    )


def calibration_dataset(num_a: int = 3) -> xr.Dataset:
    """A ``calibration`` scene: forward motion around 14.4 Hz (reversing above it), turns
    around 8.5 Hz, lift-off near resonance at the largest acceleration and one point
    that did not converge."""
    f = np.linspace(5.0, 20.0, 31)
    a = np.linspace(6.0, 10.0, num_a)
    F, A = np.meshgrid(f, a, indexing="ij")
    forward = 5e-3 * (A / 10) * np.tanh(14.44 - F) * np.exp(-(((F - 14.44) / 1.5) ** 2))
    lateral = 1e-3 * (A / 10) * np.exp(-(((F - 8.5) / 1.0) ** 2))
    turn = 0.6 * (A / 10) * np.tanh(8.5 - F) * np.exp(-(((F - 8.5) / 1.0) ** 2))
    status = np.where(np.abs(forward) + np.abs(turn) > 1e-4, 1, 0).astype(np.int8)
    status[(np.abs(F - 14.44) < 0.8) & (A >= a.max())] = 3
    status[4, 0] = 4
    invalid = status >= 3
    for values in (forward, lateral, turn):
        values[invalid] = np.nan
    values = {"forward_speed": (forward, "m s-1"), "lateral_speed": (lateral, "m s-1"),
              "turn_rate": (np.degrees(turn), "degree s-1")}
    data = {name: _var(("f", "a"), v, u, name.replace("_", " "))
            for name, (v, u) in values.items()}
    data["status"] = _var(("f", "a"), status, None, "regime", **STATUS)
    data["slips_per_period"] = _var(("f", "a"), np.where(status == 1, 1.0, 0.0), "1", "slips")
    data["stuck_fraction"] = _var(("f", "a"), np.where(status == 1, 0.6, 1.0), "1", "stuck")
    return xr.Dataset(
        data,
        coords={"f": _var("f", f, "Hz", "drive frequency"),
                "a": _var("a", a, "m s-2", "drive acceleration")},
        attrs={**ATTRS, "study_scene_kind": "calibration"},
    )


WAYPOINTS = np.array([[0.03, 0.0], [0.03, 0.03], [0.0, 0.04]])  # m
STRATEGIES = ("open_loop", "closed_loop")


def plan_dataset(realisations: int = 5, samples: int = 300) -> xr.Dataset:
    """A ``plan`` scene: three waypoints, open-loop runs drifting by a heading error
    that closed-loop runs correct; each run stays at its last pose once done."""
    rng = np.random.default_rng(3)
    drift = np.concatenate([[0.0], rng.normal(0.0, 0.15, realisations - 1)])
    corners = np.vstack([[0.0, 0.0], WAYPOINTS])
    time = np.linspace(0.0, 12.0, samples)
    done = int(0.9 * samples)
    s = np.linspace(0.0, len(WAYPOINTS), done)
    leg = np.minimum(s.astype(int), len(WAYPOINTS) - 1)
    route = corners[leg] + (s - leg)[:, None] * (corners[leg + 1] - corners[leg])
    route = np.vstack([route, np.repeat(route[-1:], samples - done, axis=0)])
    x = np.empty((len(STRATEGIES), realisations, samples))
    y = np.empty_like(x)
    for r in range(realisations):
        for j, error in enumerate((drift[r], 0.1 * drift[r])):  # closed loop corrects
            c, s_ = np.cos(error), np.sin(error)
            x[j, r] = c * route[:, 0] - s_ * route[:, 1]
            y[j, r] = s_ * route[:, 0] + c * route[:, 1]
    heading = np.unwrap(np.arctan2(np.gradient(y, axis=-1), np.gradient(x, axis=-1)))
    miss = np.hypot(x[..., None] - WAYPOINTS[:, 0], y[..., None] - WAYPOINTS[:, 1]).min(axis=2)
    labels = ["forward", "left", "forward", "left", "forward"]
    frequency = [14.2, 8.2, 14.2, 8.2, 14.2]
    dims = ("strategy", "realisation", "t")
    return xr.Dataset(
        {
            "waypoint_x": _var("waypoint", WAYPOINTS[:, 0], "m", "waypoint x"),
            "waypoint_y": _var("waypoint", WAYPOINTS[:, 1], "m", "waypoint y"),
            "planned_x": _var("waypoint", WAYPOINTS[:, 0] + 0.001, "m", "planned end x"),
            "planned_y": _var("waypoint", WAYPOINTS[:, 1] - 0.001, "m", "planned end y"),
            "x": _var(dims, x, "m", "x"),
            "y": _var(dims, y, "m", "y"),
            "heading": _var(dims, np.degrees(heading), "degree", "heading"),
            "miss_distance": _var(("strategy", "realisation", "waypoint"), miss, "m", "miss"),
            "realisation_heading_drift": _var("realisation", np.degrees(drift), "degree",
                                               "heading drift"),
            "segment_label": _var("segment", np.array(labels), None, "command"),
            "frequency": _var("segment", frequency, "Hz", "drive frequency"),
            "acceleration": _var("segment", np.full(5, 8.0), "m s-2", "drive acceleration"),
            "duration": _var("segment", [3.0, 1.9, 3.0, 1.9, 3.0], "s", "duration"),
        },
        coords={"strategy": ("strategy", list(STRATEGIES)),
                "realisation": ("realisation", np.arange(realisations)),
                "t": _var("t", time, "s", "t")},
        attrs={**ATTRS, "study_scene_kind": "plan", "disk_radius": DISK_RADIUS,
               "start_x": 0.0, "start_y": 0.0, "start_heading": 0.0},
    )


MAKERS = {
    "steering": trajectory_dataset,
    "steering-calibration": calibration_dataset,
    "steering-plan": plan_dataset,
}


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _gids(fig, prefix: str) -> list:
    return [a for ax in fig.axes for a in ax.get_children()
            if (a.get_gid() or "").startswith(prefix)]


def _legend_texts(fig) -> list[str]:
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend()] + list(fig.legends)
    return [t.get_text() for legend in legends for t in legend.get_texts()]


def test_the_synthetic_scenes_hold_what_their_figures_require():
    for name, make in MAKERS.items():
        dataset = make()
        assert not [v for v in FIGURES[name].requires if v not in dataset.variables], name
        assert FIGURES[name].workflow == name


@pytest.mark.parametrize("figure", sorted(MAKERS))
def test_figure_writes_png_and_pdf_with_provenance(figure, tmp_path):
    dataset = MAKERS[figure]()
    written = draw_figure(figure, dataset, tmp_path / figure)
    assert written == [tmp_path / f"{figure}.png", tmp_path / f"{figure}.pdf"]
    png, pdf = written
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert pdf.read_bytes()[:4] == b"%PDF"
    assert all(p.stat().st_size > 1000 for p in written)
    with Image.open(png) as image:
        text = dict(image.text)
        width, height = image.size
    assert ATTRS["study_spec_sha256"] in text["Source"]
    assert text["Title"]
    assert width >= 900 and height >= 600


@pytest.mark.parametrize(
    ("figure", "missing"),
    [(name, variable) for name in sorted(MAKERS) for variable in FIGURES[name].requires],
)
def test_a_scene_without_a_required_variable_is_refused(figure, missing, tmp_path):
    dataset = MAKERS[figure]().drop_vars(missing)
    with pytest.raises(FigureError, match=missing) as caught:
        draw_figure(figure, dataset, tmp_path / figure)
    assert f"workflows/{figure}.toml" in str(caught.value)
    assert not (tmp_path / f"{figure}.png").exists()


@pytest.mark.parametrize(("figure", "other"), [("steering", "plan"),
                                               ("steering-calibration", "trajectory"),
                                               ("steering-plan", "calibration")])
def test_a_scene_of_another_kind_is_refused(figure, other, tmp_path):
    dataset = MAKERS[figure]()
    dataset.attrs["study_scene_kind"] = other
    with pytest.raises(FigureError, match=f"holds a '{other}' scene"):
        draw_figure(figure, dataset, tmp_path / figure)


def test_the_path_has_one_line_per_segment_coloured_by_label():
    dataset = trajectory_dataset()
    fig = steering._plot(dataset)
    lines = {line.get_gid(): line for line in _gids(fig, "segment-")}
    assert len(lines) == dataset.sizes["segment"]
    colors = steering.label_colors([s[0] for s in SEGMENTS])
    for k, (label, _, _) in enumerate(SEGMENTS):
        assert to_rgba(lines[f"segment-{k}"].get_color()) == to_rgba(colors[label])
    assert colors["forward"] == steering.LABEL_COLORS["forward"]
    assert colors["wiggle"] not in steering.LABEL_COLORS.values()
    # consecutive segments join: each line starts where the previous one ended
    for k in range(1, len(SEGMENTS)):
        previous = lines[f"segment-{k - 1}"].get_xydata()[-1]
        np.testing.assert_allclose(lines[f"segment-{k}"].get_xydata()[0], previous)
    texts = _legend_texts(fig)
    for entry in ("forward 14.2 Hz", "left 8.2 Hz", "right 7.2 Hz", "wiggle 11 Hz"):
        assert entry in texts
    assert not _gids(fig, "status-")


def test_segments_that_did_not_complete_are_marked(tmp_path):
    dataset = trajectory_dataset(lift_off_in=2)
    fig = steering._plot(dataset)
    assert sorted(line.get_gid() for line in _gids(fig, "segment-")) == [
        "segment-0", "segment-1", "segment-2"]  # 3 and 4 were never reached
    (lifted,) = _gids(fig, "status-lift_off")
    np.testing.assert_allclose(lifted.get_xydata()[0],
                               1e3 * np.array([dataset["x"][-1], dataset["y"][-1]]))
    (unreached,) = _gids(fig, "status-not_reached")
    assert len(unreached.get_xdata()) == 2
    texts = _legend_texts(fig)
    assert "lift_off: segment 2" in texts
    assert "not_reached: segments 3, 4" in texts
    written = draw_figure("steering", dataset, tmp_path / "lifted")
    assert all(p.stat().st_size > 1000 for p in written)


def test_calibration_has_one_line_per_acceleration_and_marks_points_without_speed():
    dataset = calibration_dataset()
    fig = steering_calibration._plot(dataset)
    a = dataset.sizes["a"]
    assert len(_gids(fig, "forward-")) == a
    assert len(_gids(fig, "turn-")) == a
    status = dataset["status"].values
    for kind in ("forward", "turn"):
        (lifted,) = _gids(fig, f"lift_off-{kind}")
        assert len(lifted.get_xdata()) == int(np.sum(status == 3))
        assert np.all(lifted.get_ydata() == 0)
        (stuck,) = _gids(fig, f"not_converged-{kind}")
        assert len(stuck.get_xdata()) == 1
    (top,) = _gids(fig, "forward-0")
    np.testing.assert_allclose(top.get_ydata(), 1e3 * dataset["forward_speed"].isel(a=0))
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    for name, frequency in steering_calibration.COMMANDS:
        assert f"{name} {frequency:g} Hz" in texts
    assert "a = 6 m s$^{-2}$" in _legend_texts(fig)


def test_calibration_of_many_accelerations_has_a_colour_bar_and_skips_far_commands():
    dataset = calibration_dataset(num_a=8).sel(f=slice(10.0, 20.0))
    fig = steering_calibration._plot(dataset)
    assert any("drive acceleration" in ax.get_ylabel() for ax in fig.axes)
    assert not any(t.startswith("a = ") for t in _legend_texts(fig))
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert "forward 14.2 Hz" in texts
    assert "turn 7.2 Hz" not in texts and "turn 8.2 Hz" not in texts


def test_the_plan_draws_every_run_and_every_miss_distance():
    dataset = plan_dataset(realisations=5)
    fig = steering_plan._plot(dataset)
    paths = {line.get_gid(): line for line in _gids(fig, "path-")}
    assert len(paths) == len(STRATEGIES) * 5
    for strategy, style in (("open_loop", "--"), ("closed_loop", "-")):
        assert paths[f"path-{strategy}-0"].get_linestyle() == style
        assert paths[f"path-{strategy}-0"].get_linewidth() > paths[f"path-{strategy}-1"]\
            .get_linewidth()
        (clean,) = _gids(fig, f"miss-{strategy}-noise-free")
        s = STRATEGIES.index(strategy)
        np.testing.assert_allclose(clean.get_ydata(),
                                   1e3 * dataset["miss_distance"].values[s, 0])
        noisy = [a for a in _gids(fig, f"miss-{strategy}") if a.get_gid() == f"miss-{strategy}"]
        assert len(noisy[0].get_xdata()) == 4 * len(WAYPOINTS)
    np.testing.assert_allclose(paths["path-closed_loop-3"].get_xdata(),
                               1e3 * dataset["x"].values[1, 3])
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert {"1", "2", "3"} <= set(texts)
    assert f"disk diameter {2e3 * DISK_RADIUS:g} mm" in texts
    assert "forward x3 at 14.2 Hz (9 s)" in fig.get_suptitle()
    drift = dataset["realisation_heading_drift"].values[1:]  # the noisy ones [degree]
    rms = float(np.sqrt(np.mean(drift**2)))
    assert f"(drift rms {rms:.3g} degree per diameter)" in fig.get_suptitle()
    # A file stating the drift in rad (before scene format 3) is refused, never misread.
    stale = dataset.copy()
    stale["realisation_heading_drift"].attrs["units"] = "rad"
    with pytest.raises(FigureError, match="'realisation_heading_drift' in 'degree'"):
        steering_plan._plot(stale)


@pytest.mark.parametrize("figure", sorted(MAKERS))
def test_figures_draw_from_a_netcdf_file(figure, tmp_path):
    """Strings, flag attributes and int8 flags as a netCDF reader returns them."""
    path = tmp_path / f"{figure}.nc"
    MAKERS[figure]().to_netcdf(path, engine="netcdf4")
    with xr.open_dataset(path, engine="netcdf4") as dataset:
        written = draw_figure(figure, dataset.load(), tmp_path / figure)
    assert all(p.stat().st_size > 1000 for p in written)
