"""The hysteresis figure: slow sweeps up and down, from the solver's own sweeps."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
import xarray as xr

import study
from study.figures import FigureError
from study.figures.hysteresis import DIFFERENT, compose, differing, draw
from study.solvers.protocol import slow_sweep

STRUCTURE = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)


def _dataset(f, a, along="f"):
    """A result-like dataset of sweeps up and down (``direction``, ``f``, ``a``)."""
    sweeps = [slow_sweep(STRUCTURE, f, a, along=along, direction=d, flight=True)
              for d in ("up", "down")]
    dims = ("direction", "f", "a")
    return xr.Dataset(
        {"velocity": (dims, np.stack([s.state.velocity for s in sweeps])),
         "status": (dims, np.stack([s.state.status for s in sweeps])),
         "jumped": (dims, np.stack([s.jumped for s in sweeps]).astype(np.int8))},
        coords={"direction": ["up", "down"], "f": f, "a": a,
                **{k: getattr(STRUCTURE, k) for k in ("f0", "Q", "alpha", "M", "cs")}},
        attrs={"study_name": "hysteresis-test", "study_protocol_along": along,
               "study_coupling": "two-way", "study_flight": 1})


@pytest.fixture(scope="module")
def line():
    return _dataset(np.array([14.8, 15.2, 15.6, 16.0, 16.4]), np.array([10.0]))


def test_the_sweeps_differ_where_the_forward_hop_persists(line):
    apart = differing(line.squeeze("a")).values
    # Swept up the forward hop persists to 16.0 Hz; swept down the backward hop; both
    # on the backward hop at 16.4 Hz after the up sweep's jump.
    np.testing.assert_array_equal(apart, [True, True, True, True, False])
    up = line["velocity"].sel(direction="up").values.ravel()
    down = line["velocity"].sel(direction="down").values.ravel()
    assert np.all(up[:4] > 0.0) and np.all(down < 0.0)


def test_the_line_figure_counts_what_it_shows(line, tmp_path):
    fig, title = compose(line)
    text = fig.axes[0].get_title()
    assert text.startswith("4 of 5 drive values end on different motions")
    assert "1 jumps" in text
    assert "Hysteresis along f" in title
    paths = draw(line, tmp_path / "hysteresis")
    assert all(p.exists() and p.stat().st_size > 0 for p in paths)


def test_two_accelerations_are_a_panel_each_counting_where_the_sweeps_differ(tmp_path):
    """Two values of a (a listed axis) are two panels of lines, not a map whose cells
    would span 8.5-10.5: each counts its own drive values that differ."""
    dataset = _dataset(np.array([14.8, 16.0, 16.4]), np.array([9.0, 10.0]))
    fig, _ = compose(dataset)
    panels = [ax for ax in fig.axes if ax.get_lines()]
    assert len(panels) == 2
    counts = [int(differing(dataset.sel(a=a)).sum()) for a in (9.0, 10.0)]
    for ax, a, count in zip(panels, ("9", "10"), counts, strict=True):
        assert ax.get_title().startswith(f"a = {a} m s$^{{-2}}$: {count} of 3 drive values")
    assert 0 < sum(counts) < 6


def test_a_file_without_both_directions_is_refused(line):
    with pytest.raises(FigureError, match="several values of direction"):
        compose(line.sel(direction=["up"]))


SPEC = """\
[study]
name = "hysteresis-unswept"
observables = ["velocity", "unswept"]

[structure]
f0 = 14.44
Q = 17.5
alpha = 64.0
M = 0.99
cs = 0.25

[sweep]
f = { values = [14.8, 15.2, 15.6, 16.0, 16.4] }
a = { values = [10.0] }
protocol = { along = "f", direction = "both" }

[solver]
coupling = "two-way"
flight = true
"""


def test_a_computed_file_shows_each_points_answer_from_its_start_beside_the_sweeps(
        tmp_path):
    from study.engine.runner import run_study
    from study.engine.store import open_result
    from study.figures import draw_figure

    (tmp_path / "h.toml").write_text(SPEC)
    run_study(tmp_path / "h.toml", tmp_path / "h.nc", progress=False,
              cache=tmp_path / "kept")
    dataset = open_result(tmp_path / "h.nc")
    assert dataset["velocity_unswept"].dims == ("f", "a")
    fig, _ = compose(dataset)
    drawn = {line.get_label(): line for line in fig.axes[0].get_lines()}
    unswept = drawn["each point from its start alone (release)"]
    np.testing.assert_array_equal(unswept.get_ydata(),
                                  1e3 * dataset["velocity_unswept"].values.ravel())
    # The release lands on the up sweep's forward hop or the down sweep's backward hop,
    # point by point: each value is one of the two sweeps' (the same orbit, to the
    # figure's tolerance).
    up, down = (dataset["velocity"].sel(direction=d).values.ravel() for d in ("up", "down"))
    alone = dataset["velocity_unswept"].values.ravel()
    scale = DIFFERENT * 10.0 / (2.0 * np.pi * dataset["f"].values)
    assert np.all((np.abs(alone - up) <= scale) | (np.abs(alone - down) <= scale))
    paths = draw_figure("hysteresis", dataset, tmp_path / "figure")
    assert all(p.exists() and p.stat().st_size > 0 for p in paths)


def test_each_located_jump_is_drawn_at_its_bifurcation(line):
    # The jumps observable's values beside the sweeps: the fold the up sweep left the
    # forward hop at, marked where it was located (not at a grid point) by the fold's
    # declared marker, its drive written beside it.
    from study.model.bifurcations import kind_named
    from study.solvers.jumps import sweep_jumps

    f, a = line["f"].values, line["a"].values
    located = {d: sweep_jumps(STRUCTURE, f, a, slow_sweep(STRUCTURE, f, a, along="f",
                                                          direction=d, flight=True),
                              flight=True) for d in ("up", "down")}
    dims = ("direction", "f", "a")
    with_jumps = line.assign(
        jump_bifurcation=(dims, np.stack([located[d].kind for d in ("up", "down")])),
        jump_f=(dims, np.stack([located[d].f for d in ("up", "down")])),
        jump_a=(dims, np.stack([located[d].a for d in ("up", "down")])),
        jump_velocity=(dims, np.stack([located[d].velocity for d in ("up", "down")])))
    fold = kind_named("fold")
    where = float(np.nanmax(located["up"].f))
    assert 16.0 < where < 16.4 and np.isnan(located["down"].f).all()
    fig, _ = compose(with_jumps)
    ax = fig.axes[0]
    marks = [line_ for line_ in ax.get_lines() if line_.get_label() == "fold located (swept up)"]
    assert len(marks) == 1 and marks[0].get_marker() == fold.marker
    np.testing.assert_allclose(marks[0].get_xdata(), [where], rtol=0.0, atol=0.0)
    np.testing.assert_allclose(marks[0].get_ydata(), [1e3 * np.nanmax(located["up"].velocity)],
                               rtol=0.0, atol=0.0)
    assert f"{where:.5f} Hz" in [text.get_text() for text in ax.texts]
    # Without the observable's values the figure draws no located jump.
    fig, _ = compose(line)
    assert not [x for x in fig.axes[0].get_lines() if "located" in str(x.get_label())]
