"""The forward and backward hops' folds and the band where both exist
(:func:`study.analyses.hop_folds.hop_folds`, figure ``fold-curves``).

The bookkeeping on hand-built sweeps; the folds of real sweeps against a second method,
the fold followed over the drive plane by two-parameter continuation
(:func:`study.bifurcation_curve`), which never sweeps.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

import study
from study.analyses.hop_folds import EDGES, hop_folds
from study.figures import FigureError
from study.figures.fold_curves import compose, onset
from study.model.bifurcations import JUMP_NONE, JUMP_UNLOCATED, kind_named
from study.solvers.jumps import sweep_jumps
from study.solvers.protocol import slow_sweep
from tests.support.integrated import integrated_from

FOLD = kind_named("fold").code
DIMS = ("direction", "f", "a")


def _hand_built(v_up, v_down, jumps_up, jumps_down, f=None):
    """A sweep both ways of one acceleration: velocities [m s-1] and the jumps
    ``{index: (kind, f, velocity)}`` of each direction."""
    n = len(v_up)
    f = np.arange(10.0, 10.0 + n) if f is None else np.asarray(f)
    kind = np.full((2, n, 1), JUMP_NONE, dtype=np.int8)
    where = np.full((2, n, 1), np.nan)
    speed = np.full((2, n, 1), np.nan)
    for d, jumps in enumerate((jumps_up, jumps_down)):
        for i, (k, x, v) in jumps.items():
            kind[d, i, 0], where[d, i, 0], speed[d, i, 0] = k, x, v
    velocity = np.stack([np.asarray(v_up, float), np.asarray(v_down, float)])[..., None]
    return xr.Dataset(
        {"velocity": (DIMS, velocity), "jump_bifurcation": (DIMS, kind),
         "jump_f": (DIMS, where), "jump_velocity": (DIMS, speed)},
        coords={"direction": ["up", "down"], "f": f, "a": [10.0]},
        attrs={"study_protocol_along": "f"})


def test_the_band_between_the_two_reversal_folds():
    # Up: forward to index 3, jumps backward at 4 (fold at 13.4 Hz); down: backward to
    # index 2, jumps forward at 1 (fold at 11.7 Hz). A jump without reversal (up at 2,
    # forward to forward) is no hop's fold.
    data = _hand_built([0.02, 0.03, 0.04, 0.05, -0.1, -0.1],
                       [0.02, 0.03, -0.08, -0.09, -0.1, -0.1],
                       {2: (FOLD, 11.5, 0.035), 4: (FOLD, 13.4, 0.055)},
                       {1: (FOLD, 11.7, -0.07)})
    folds = hop_folds(data).isel(a=0)
    assert float(folds.forward_fold_f) == 13.4 and float(folds.forward_fold_velocity) == 0.055
    assert float(folds.backward_fold_f) == 11.7
    assert (float(folds.coexistence_low), float(folds.coexistence_high)) == (11.7, 13.4)
    assert int(folds.coexistence_low_edge) == EDGES.index("fold")
    assert int(folds.coexistence_high_edge) == EDGES.index("fold")
    assert_allclose(float(folds.coexistence_width), 1.7, rtol=0.0, atol=1e-12)
    assert folds.forward_fold_f.attrs["units"] == "Hz"


def test_a_band_narrower_than_a_grid_step_is_bounded_by_its_folds():
    # Both folds between grid points 1 and 2: no grid point has both hops.
    data = _hand_built([0.02, 0.03, -0.1, -0.1], [0.02, 0.03, -0.1, -0.1],
                       {2: (FOLD, 11.6, 0.03)}, {1: (FOLD, 11.4, -0.09)})
    folds = hop_folds(data).isel(a=0)
    assert (float(folds.coexistence_low), float(folds.coexistence_high)) == (11.4, 11.6)


def test_a_band_to_the_grids_end_and_an_unlocated_jump_say_so():
    # The backward hop exists down to the grid's first point; swept up the forward hop
    # jumps at index 3 without a located bifurcation.
    data = _hand_built([0.02, 0.03, 0.04, -0.1], [-0.05, -0.06, -0.08, -0.1],
                       {3: (JUMP_UNLOCATED, np.nan, np.nan)}, {})
    folds = hop_folds(data).isel(a=0)
    assert np.isnan(float(folds.forward_fold_f)) and np.isnan(float(folds.backward_fold_f))
    assert float(folds.coexistence_low) == 10.0
    assert int(folds.coexistence_low_edge) == EDGES.index("grid_end")
    assert float(folds.coexistence_high) == 12.0
    assert int(folds.coexistence_high_edge) == EDGES.index("unlocated_jump")


def test_one_motion_only_has_no_band():
    data = _hand_built([0.02, 0.03, 0.04], [0.02, 0.03, 0.04], {}, {})
    folds = hop_folds(data).isel(a=0)
    assert np.isnan(float(folds.coexistence_width))
    assert int(folds.coexistence_low_edge) == EDGES.index("none")
    assert np.isnan(float(onset(hop_folds(data))))


@pytest.mark.parametrize(("change", "fragment"), [
    (lambda d: d.drop_vars("jump_f"), "lacks jump_f"),
    (lambda d: d.sel(direction=["up"]), "both ways.*several values of direction"),
    (lambda d: d.assign_attrs(study_protocol_along="a"), "along f"),
])
def test_what_is_not_a_sweep_both_ways_with_jumps_is_refused(change, fragment):
    data = _hand_built([0.02, 0.03], [0.02, 0.03], {}, {})
    with pytest.raises(ValueError, match=fragment):
        hop_folds(change(data))
    with pytest.raises(FigureError, match=fragment):
        compose(change(data))


M099 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)


@pytest.fixture(scope="module")
def swept_m099():
    f = np.round(np.arange(12.0, 17.01, 0.1), 6)
    a = np.array([10.0, 11.0, 12.0])
    arrays = {name: [] for name in ("velocity", "jump_bifurcation", "jump_f",
                                    "jump_velocity")}
    sweeps = {}
    for direction in ("up", "down"):
        swept = slow_sweep(M099, f, a, along="f", direction=direction, flight=True)
        located = sweep_jumps(M099, f, a, swept, flight=True)
        sweeps[direction] = swept
        arrays["velocity"].append(swept.state.velocity)
        arrays["jump_bifurcation"].append(located.kind)
        arrays["jump_f"].append(located.f)
        arrays["jump_velocity"].append(located.velocity)
    data = xr.Dataset({name: (DIMS, np.stack(values)) for name, values in arrays.items()},
                      coords={"direction": ["up", "down"], "f": f, "a": a, "M": 0.99},
                      attrs={"study_protocol_along": "f", "study_coupling": "two-way",
                             "study_flight": 1})
    return data, sweeps


def test_the_forward_folds_lie_on_the_fold_curve_continued_in_a(swept_m099):
    # Each row's fold, located along f from the sweep's orbit, against the fold curve
    # followed in a from the first by two-parameter continuation.
    data, sweeps = swept_m099
    folds = hop_folds(data)
    up = sweeps["up"]
    k = int(np.flatnonzero(data.f.values == 15.9)[0])
    hop = study.branch(M099, 15.9, 10.0, along="f", to=16.2, flight=True,
                       start=up.state.phase_state[k, 0],
                       periods=int(up.state.orbit_period[k, 0]))
    fold = int(np.flatnonzero(hop.bifurcation_kind.values == kind_named("fold").code)[0])
    curve = study.bifurcation_curve(M099, hop, fold, to=12.0, num=3)
    for a_value in (10.0, 11.0, 12.0):
        on_curve = float(curve.f.values[np.flatnonzero(curve.a.values == a_value)[0]])
        assert_allclose(float(folds.forward_fold_f.sel(a=a_value)), on_curve, rtol=1e-9,
                        atol=0.0)
    # Swept down the backward hop stays to 12 Hz: the band reaches the grid's end.
    assert np.isnan(folds.backward_fold_f.values).all()
    assert (folds.coexistence_low.values == 12.0).all()
    assert (folds.coexistence_low_edge.values == EDGES.index("grid_end")).all()


def test_the_figure_draws_each_fold_where_it_was_located(swept_m099):
    data, _ = swept_m099
    folds = hop_folds(data)
    fig, title = compose(data)
    plane = fig.axes[0]
    forward = [x for x in plane.get_lines() if x.get_label().endswith("forward hop's fold")]
    assert len(forward) == 1
    assert_allclose(forward[0].get_xdata(), folds.forward_fold_f.values, rtol=0.0, atol=0.0)
    assert_allclose(forward[0].get_ydata(), data.a.values, rtol=0.0, atol=0.0)
    # No backward fold in range: no curve named for it.
    assert not [x for x in plane.get_lines() if "backward hop's fold" in x.get_label()]
    assert "Fold curves" in title


M095 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.95, cs=0.25)


def _integrated_from(structure, f, a, state):
    """The integrator's mean velocity [m s-1] at ``(f, a)`` from a phase-0 state
    ``(delta, delta', v, h, h')`` (the position x = 0)."""
    return integrated_from(structure, f, a,
                           np.array([state[0], state[1], 0.0, state[2], state[3], state[4]]))


def test_inside_the_band_the_integrator_keeps_both_hops_and_below_it_one():
    # M = 0.95 at 10 m s-2: the hops coexist over 12.1499-15.0575 Hz (workflow
    # mass-ratio-folds). From each sweep's state the integrator settles on that sweep's
    # motion inside the band (13.5 Hz), and on one motion below it (11.5 Hz).
    f = np.round(np.arange(8.0, 22.01, 0.1), 6)
    a = np.array([10.0])
    swept = {d: slow_sweep(M095, f, a, along="f", direction=d, flight=True)
             for d in ("up", "down")}
    located = {d: sweep_jumps(M095, f, a, swept[d], flight=True) for d in swept}
    dims = ("direction", "f", "a")
    data = xr.Dataset(
        {"velocity": (dims, np.stack([swept[d].state.velocity for d in ("up", "down")])),
         **{f"jump_{name}": (dims, np.stack([getattr(located[d], field)
                                             for d in ("up", "down")]))
            for name, field in (("bifurcation", "kind"), ("f", "f"),
                                ("velocity", "velocity"))}},
        coords={"direction": ["up", "down"], "f": f, "a": a},
        attrs={"study_protocol_along": "f"})
    band = hop_folds(data).isel(a=0)
    assert_allclose([float(band.coexistence_low), float(band.coexistence_high)],
                    [12.1499, 15.0575], rtol=0.0, atol=1e-4)
    scale = 10.0 / (2 * np.pi * 13.5)
    inside = int(np.flatnonzero(f == 13.5)[0])
    velocities = {d: _integrated_from(M095, 13.5, 10.0, swept[d].state.phase_state[inside, 0])
                  for d in ("up", "down")}
    for d in ("up", "down"):
        assert_allclose(velocities[d] / scale, swept[d].state.velocity[inside, 0] / scale,
                        rtol=0.0, atol=1e-6)
    assert velocities["up"] > 0.0 > velocities["down"]
    below = int(np.flatnonzero(f == 11.5)[0])
    assert_allclose(swept["up"].state.velocity[below, 0], swept["down"].state.velocity[below, 0],
                    rtol=0.0, atol=1e-12)
    from_down = _integrated_from(M095, 11.5, 10.0, swept["down"].state.phase_state[below, 0])
    assert_allclose(from_down / scale, swept["up"].state.velocity[below, 0] / scale,
                    rtol=0.0, atol=1e-6)
