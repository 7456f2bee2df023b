"""The branch diagram: drawn artists of hand-built branches, sweeps over them, refusals,
and the fold of a real branch at M = 0.99."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr

import study
from study.figures.branch_diagram import compose, draw, kind_label, stability_pieces
from study.model.bifurcations import KINDS, kind_named
from study.solvers.protocol import slow_sweep

FOLD = kind_named("fold")
GRAZING = kind_named("grazing")


def _branch(f, velocity, stable, *, bifurcations=(), along="f", flight=0, hop=None):
    """A dataset shaped as a study.branch result; ``bifurcations`` are
    ``(kind, f, velocity, step)``."""
    f = np.asarray(f, dtype=float)
    kinds, b_f, b_v, b_step = (np.array(c) for c in zip(*bifurcations, strict=True)) \
        if bifurcations else (np.array([], int), np.array([]), np.array([]),
                              np.array([], int))
    x, fixed = (f, np.full(f.size, 10.0))
    drive = {"f": x, "a": fixed} if along == "f" else {"f": fixed, "a": x}
    b_drive = ({"f": b_f, "a": np.full(b_f.size, 10.0)} if along == "f"
               else {"f": np.full(b_f.size, 10.0), "a": b_f})
    return xr.Dataset(
        {"f": ("step", drive["f"], {"units": "Hz"}),
         "a": ("step", drive["a"], {"units": "m s-2"}),
         "velocity": ("step", np.asarray(velocity, float), {"units": "m s-1"}),
         "stable": ("step", np.asarray(stable, np.int8)),
         "largest_hop": ("step", np.asarray(hop if hop is not None else np.zeros(f.size)),
                         {"units": "m"}),
         "bifurcation_kind": ("bifurcation", np.asarray(kinds, np.int8)),
         "bifurcation_f": ("bifurcation", b_drive["f"]),
         "bifurcation_a": ("bifurcation", b_drive["a"]),
         "bifurcation_velocity": ("bifurcation", np.asarray(b_v, float)),
         "bifurcation_step": ("bifurcation", np.asarray(b_step, np.int32))},
        attrs={"along": along, "branch_end": "reached", "flight": flight,
               "structure_f0": 14.44, "structure_M": 0.99})


def _lines(ax, gid):
    return [line for line in ax.get_lines() if line.get_gid() == gid]


STABLE = [1, 1, 1, 0, 0, 1, 0, 0]


@pytest.fixture
def runs():
    dataset = _branch(np.linspace(15.0, 15.7, 8), np.linspace(0.01, 0.05, 8), STABLE)
    fig = compose(dataset)
    yield dataset, fig
    plt.close(fig)


def test_each_run_of_stability_is_one_piece_of_its_style(runs):
    dataset, fig = runs
    (ax,) = fig.axes  # no flight: one panel
    solid, dashed = _lines(ax, "branch 0 stable"), _lines(ax, "branch 0 unstable")
    # Runs of `stable`: 111, 00, 1, 00 -> two solid pieces, two dashed.
    assert (len(solid), len(dashed)) == (2, 2)
    assert {line.get_linestyle() for line in solid} == {"-"}
    assert {line.get_linestyle() for line in dashed} == {"--"}
    # Every step is on the piece of its own style; the cuts halfway between steps.
    x = dataset.f.values
    for line, steps in zip(sorted(solid + dashed, key=lambda c: c.get_xdata()[0]),
                           ([0, 1, 2], [3, 4], [5], [6, 7]), strict=True):
        assert set(x[steps]) <= set(line.get_xdata())
    assert sorted(solid + dashed, key=lambda c: c.get_xdata()[0])[1].get_xdata()[0] == (
        pytest.approx(0.5 * (x[2] + x[3]), rel=1e-15))
    assert ax.get_xlabel() == "drive frequency f [Hz]"
    assert ax.get_ylabel() == "mean velocity [mm s$^{-1}$]"


def test_a_single_stable_step_between_unstable_ones_is_still_a_piece():
    pieces = stability_pieces(np.arange(4.0), np.zeros(4), [0, 1, 0, 0])
    assert [stable for _, _, stable in pieces] == [False, True, False]
    np.testing.assert_array_equal(pieces[1][0], [0.5, 1.0, 1.5])


def test_the_style_changes_at_the_located_fold_and_its_marker_is_there_exactly():
    # Up to a fold between steps 2 and 3, back on the unstable part; a grazing further.
    f = [15.0, 15.5, 15.9, 15.8, 15.4]
    v = [0.040, 0.050, 0.055, 0.052, 0.046]
    fold = (FOLD.code, 15.9437, 0.0561, 2)
    grazing = (GRAZING.code, 15.6125, 0.0493, 3)
    dataset = _branch(f, v, [1, 1, 1, 0, 0], bifurcations=[fold, grazing])
    fig = compose(dataset)
    ax = fig.axes[0]
    (solid,), (dashed,) = _lines(ax, "branch 0 stable"), _lines(ax, "branch 0 unstable")
    assert (solid.get_xdata()[-1], solid.get_ydata()[-1]) == (15.9437, 1e3 * 0.0561)
    assert (dashed.get_xdata()[0], dashed.get_ydata()[0]) == (15.9437, 1e3 * 0.0561)
    assert 15.6125 in dashed.get_xdata()  # the line runs through the grazing
    for kind, where in ((FOLD, fold), (GRAZING, grazing)):
        (marker,) = _lines(ax, f"branch 0 {kind.name}")
        assert marker.get_marker() == kind.marker
        np.testing.assert_array_equal(marker.get_xdata(), [where[1]])
        np.testing.assert_array_equal(marker.get_ydata(), [1e3 * where[2]])
    legend = [text.get_text() for text in ax.get_legend().get_texts()]
    assert kind_label(FOLD.code) in legend and kind_label(GRAZING.code) in legend
    assert not {kind_label(k.code) for k in KINDS if k not in (FOLD, GRAZING)} & set(legend)
    assert kind_label(kind_named("period_doubling").code) == "period doubling"
    plt.close(fig)


def test_a_sweep_is_drawn_with_an_arrow_at_each_jump():
    dataset = _branch(np.linspace(15.0, 15.7, 8), np.linspace(0.01, 0.05, 8), [1] * 8)
    x = np.array([15.0, 15.2, 15.4, 15.6, 15.8])
    v = np.array([0.01, 0.02, 0.03, -0.10, -0.09])
    swept = SimpleNamespace(state=SimpleNamespace(velocity=v[:, None], largest_hop=None),
                            jumped=np.array([False, False, False, True, False])[:, None],
                            along="f", direction="up")
    fig = compose(dataset, sweeps=[(x, swept)])
    ax = fig.axes[0]
    pieces = _lines(ax, "sweep 0")
    assert [list(p.get_xdata()) for p in pieces] == [[15.0, 15.2, 15.4], [15.6, 15.8]]
    (jump,) = [t for t in ax.texts if t.get_gid() == "sweep 0 jump"]
    assert jump.xy == (15.6, 1e3 * -0.10)
    assert jump.xyann == (15.6, 1e3 * 0.03)
    assert "jump of a slow sweep" in [t.get_text() for t in ax.get_legend().get_texts()]
    plt.close(fig)


def test_with_flight_the_largest_hop_is_a_second_panel(tmp_path):
    dataset = _branch([15.0, 15.5], [0.04, 0.05], [1, 1], flight=1, hop=[6e-4, 8e-4])
    fig = compose(dataset)
    top, bottom = fig.axes
    assert bottom.get_ylabel() == "largest hop above the table [mm]"
    np.testing.assert_allclose(_lines(bottom, "branch 0 stable")[0].get_ydata(), [0.6, 0.8])
    assert top.get_xlabel() == "" and bottom.get_xlabel() == "drive frequency f [Hz]"
    plt.close(fig)
    paths = draw(dataset, tmp_path / "diagram")
    assert [p.suffix for p in paths] == [".png", ".pdf"]
    assert all(p.stat().st_size > 0 for p in paths)


def test_bad_input_is_refused_naming_the_argument():
    good = _branch([15.0, 15.5], [0.04, 0.05], [1, 1])
    with pytest.raises(ValueError, match=r"'branches'\[1\] is not a study.branch dataset: "
                                         r"it lacks .*stable"):
        compose([good, good.drop_vars("stable")])
    with pytest.raises(ValueError, match=r"'branches' is empty"):
        compose([])
    curve = xr.Dataset({"f": ("point", [15.0])}, attrs={"curve_kind": "fold"})
    with pytest.raises(ValueError, match=r"'branches'\[0\] is a study.bifurcation_curve"):
        compose([curve])
    with pytest.raises(ValueError, match=r"different parameters \(\[0\] along f, \[1\] "
                                         r"along a\)"):
        compose([good, _branch([8.0, 9.0], [0.04, 0.05], [1, 1], along="a")])
    with pytest.raises(ValueError, match=r"'quantity' must be a number along step .*"
                                         r"velocity"):
        compose(good, quantity="event_signature")
    swept = SimpleNamespace(state=SimpleNamespace(velocity=np.zeros((2, 1))),
                            jumped=np.zeros((2, 1), bool), along="a", direction="up")
    with pytest.raises(ValueError, match=r"'sweeps'\[0\] is swept along a"):
        compose(good, sweeps=[([8.0, 9.0], swept)])
    with pytest.raises(ValueError, match=r"'sweeps'\[0\] must be a pair"):
        compose(good, sweeps=[swept])
    with pytest.raises(ValueError, match=r"'labels' must name each of the 1"):
        compose(good, labels=["a", "b"])


M099 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)


def test_the_fold_marker_of_a_real_branch_sits_where_its_f_turns_back():
    # The release at 14.8 Hz hops forward (at 15.4 Hz it already hops backward); swept
    # up, the forward hop carries to 15.9 Hz.
    lead = slow_sweep(M099, [14.8, 15.9], [10.0], along="f", direction="up", flight=True)
    assert np.all(lead.state.velocity > 0.0)
    hop = study.branch(M099, 15.9, 10.0, along="f", to=16.2, flight=True,
                       start=lead.state.phase_state[-1, 0],
                       periods=int(lead.state.orbit_period[-1, 0]))
    fold = int(np.flatnonzero(hop.bifurcation_kind.values == FOLD.code)[0])
    step = int(hop.bifurcation_step.values[fold])
    # The branch runs up in f to the step before the fold and back after it.
    assert hop.branch_direction.values[step] == 1 and hop.branch_direction.values[step + 1] == -1
    fig = compose(hop, sweeps=[(np.array([14.8, 15.9]), lead)])
    top, _ = fig.axes  # with flight: the largest hop below
    (marker,) = _lines(top, "branch 0 fold")
    f_fold = float(hop.bifurcation_f.values[fold])
    assert marker.get_xdata()[0] == f_fold
    assert 16.054 < f_fold < 16.056
    drawn = np.concatenate([line.get_xdata() for line in top.get_lines()
                            if str(line.get_gid()).startswith("branch 0 ")
                            and line.get_linestyle() in ("-", "--")])
    # The fold is the drawn branch's largest f, past every step's.
    assert drawn.max() == f_fold and f_fold > hop.f.values.max()
    # Stable up to it, unstable past it.
    (solid,) = _lines(top, "branch 0 stable")
    assert solid.get_xdata()[-1] == f_fold
    assert _lines(top, "branch 0 unstable")[0].get_xdata()[0] == f_fold
    plt.close(fig)
