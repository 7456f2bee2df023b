"""Global continuation (study.analyses.basins.follow_attractors): each motion of a
basins map keeps one label across the drive.

Checked on a map built by hand (two branches across a fold, their births and deaths
where they were put), against the grid (a map refined 2x in f labels the shared points
one to one as the coarse map does), and on a monostable map (one label).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_array_equal

import study
from study.analyses.basins import (
    MATCH_THRESHOLD,
    attractor_distance,
    follow_attractors,
    fraction_by_label,
    status_class,
)
from study.model.status import Status
from tests.support.basins_dataset import computed

M_TO_1 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
PAPER = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)

# --- a map built by hand: two branches across a fold --------------------------------

F = np.arange(12.0, 16.01, 0.25)  # 17 frequencies [Hz]
A = np.array([10.0, 11.0, 12.0])  # m s-2
#: Index along f of the last point of the forward branch and the first of the backward
#: one, at each a: bistable between (the fold), the forward branch dies earlier and the
#: backward one is born earlier as a grows.
FORWARD_LAST = np.array([13, 10, 7])
BACKWARD_FIRST = np.array([4, 3, 2])


def _scale(f, a):
    return a / (2.0 * np.pi * f)


def _hand_map(*, period_two_at=None):
    """Forward hops (period 1, velocity 0.30 + 0.02 k of a / (2 pi f) at the k-th
    frequency, hop 0.4 + 0.01 k of a / (2 pi f)^2) for k <= FORWARD_LAST and backward
    hops (period 1, -1.10 - 0.01 k, hop 3.0 - 0.05 k) for k >= BACKWARD_FIRST, the two
    slots in an order that alternates with k; where both exist the forward basin shrinks
    from 1 to 0 across the fold. ``period_two_at``: a (k, j) where a third attractor,
    a period-2 orbit of exactly the forward one's velocity and hop, coexists."""
    shape = (F.size, A.size, 3)
    status = np.full(shape, -1, dtype=np.int8)
    period = np.zeros(shape, dtype=np.int32)
    velocity, hop = np.full(shape, np.nan), np.full(shape, np.nan)
    fraction = np.zeros(shape)
    truth = np.full(shape, -1)  # 0 forward, 1 backward, 2 the period-2 orbit
    for j, a in enumerate(A):
        for k, f in enumerate(F):
            omega = 2.0 * np.pi * f
            motions = []
            if k <= FORWARD_LAST[j]:
                motions.append((0, 0.30 + 0.02 * k, 0.4 + 0.01 * k, 1))
            if k >= BACKWARD_FIRST[j]:
                motions.append((1, -1.10 - 0.01 * k, 3.0 - 0.05 * k, 1))
            if period_two_at == (k, j):
                motions.append((2, 0.30 + 0.02 * k, 0.4 + 0.01 * k, 2))
            if k % 2:
                motions.reverse()
            share = np.clip((FORWARD_LAST[j] - k + 1) / (FORWARD_LAST[j] + 2
                                                         - BACKWARD_FIRST[j]), 0, 1)
            for slot, (which, v, h, p) in enumerate(motions):
                status[k, j, slot] = Status.BOUNCING
                period[k, j, slot] = p
                velocity[k, j, slot] = v * a / omega
                hop[k, j, slot] = h * a / omega**2
                truth[k, j, slot] = which
                fraction[k, j, slot] = share if which == 0 else 1.0 - share
            if len(motions) == 1:
                fraction[k, j, 0] = 1.0
    dims = ("f", "a", "attractor")
    dataset = xr.Dataset(
        {"basin_status": (dims, status), "basin_velocity": (dims, velocity),
         "basin_velocity_error": (dims, np.where(status >= 0, 0.0, np.nan)),
         "basin_largest_hop": (dims, hop), "basin_period": (dims, period),
         "basin_fraction": (dims, fraction)},
        coords={"f": F, "a": A, "attractor": np.arange(3)})
    return dataset, truth


def test_the_labels_follow_the_branches_built_by_hand():
    dataset, truth = _hand_map()
    labelled, summary = follow_attractors(dataset)
    label = labelled["attractor_label"].values
    assert summary.sizes["label"] == 2
    assert_array_equal(label == -1, truth == -1)
    # One label per branch, whatever slot it is in.
    for which in (0, 1):
        assert np.unique(label[truth == which]).size == 1
    forward = int(np.unique(label[truth == 0])[0])
    backward = int(np.unique(label[truth == 1])[0])
    assert forward != backward
    # Births and deaths where built: the forward branch dies after FORWARD_LAST, the
    # backward one is born at BACKWARD_FIRST; each spans the map's edge on the other side.
    assert_array_equal(summary["death_f"].sel(label=forward).values, F[FORWARD_LAST])
    assert_array_equal(summary["birth_f"].sel(label=backward).values, F[BACKWARD_FIRST])
    assert np.all(np.isnan(summary["birth_f"].sel(label=forward).values))
    assert np.all(np.isnan(summary["death_f"].sel(label=backward).values))
    assert_array_equal(summary["first_f"].sel(label=forward).values, F[0])
    assert_array_equal(summary["last_f"].sel(label=backward).values, F[-1])
    # Along a at 15.5 Hz (k = 14) the forward branch is absent, the backward one spans.
    assert np.isnan(summary["first_a"].sel(label=forward, f=F[14]))
    assert summary["first_a"].sel(label=backward, f=F[14]) == A[0]
    # The summary: points, classes, velocities, fractions.
    assert int(summary["points"].sel(label=forward)) == int(np.sum(truth == 0))
    assert int(summary["points"].sel(label=backward)) == int(np.sum(truth == 1))
    assert list(summary["status_class"].values) == ["period 1", "period 1"]
    assert float(summary["velocity_max"].sel(label=backward)) < 0.0
    assert float(summary["velocity_min"].sel(label=forward)) > 0.0
    assert float(summary["fraction_max"].sel(label=forward)) == 1.0
    shares = fraction_by_label(labelled)
    assert_array_equal(shares.sel(label=forward).notnull().values,
                       np.any(truth == 0, axis=-1))
    total = shares.fillna(0.0).sum("label").values
    np.testing.assert_allclose(total, 1.0, rtol=0, atol=1e-12)


def test_a_period_two_orbit_on_the_same_velocity_is_another_motion():
    dataset, truth = _hand_map(period_two_at=(5, 1))
    labelled, summary = follow_attractors(dataset)
    label = labelled["attractor_label"].values
    assert summary.sizes["label"] == 3
    two = int(np.unique(label[truth == 2])[0])
    assert summary["status_class"].sel(label=two) == "period 2"
    assert int(summary["points"].sel(label=two)) == 1
    assert np.unique(label[truth == 0]).size == 1  # the forward branch not cut by it


def test_a_jump_beyond_the_threshold_starts_a_new_label():
    """The backward branch made to jump by 2 MATCH_THRESHOLD in velocity between two
    frequencies: two labels for it, one dying where the other is born."""
    dataset, truth = _hand_map()
    scale = _scale(dataset["f"], dataset["a"])
    jump = xr.where(dataset["f"] >= F[12], 2.0 * MATCH_THRESHOLD * scale, 0.0)
    dataset["basin_velocity"] = dataset["basin_velocity"] - xr.where(
        xr.DataArray(truth == 1, dims=dataset["basin_status"].dims), jump, 0.0)
    labelled, summary = follow_attractors(dataset)
    label = labelled["attractor_label"].values
    assert summary.sizes["label"] == 3
    assert np.unique(label[(truth == 1) & (F[:, None, None] < F[12])]).size == 1
    assert np.unique(label[(truth == 1) & (F[:, None, None] >= F[12])]).size == 1
    late = int(np.unique(label[(truth == 1) & (F[:, None, None] >= F[12])])[0])
    assert_array_equal(summary["birth_f"].sel(label=late).values, F[12])


def test_no_label_holds_two_attractors_of_one_point():
    """Around a cusp a path over the grid joins two coexisting motions: the match that
    would put both under one label is refused, the farthest of the path. Built as a
    2 x 2 grid: the corner (0, 0) holds 0.15 and 0.30 (velocities in a / (2 pi f)), its
    neighbours 0.10 and 0.35 one each, the far corner 0.20: matches 0.05, 0.05, 0.10 and
    0.15 close the loop."""
    dims = ("f", "a", "attractor")
    status = np.array([[[6, 6], [6, -1]], [[6, -1], [6, -1]]], dtype=np.int8)
    v = np.array([[[0.15, 0.30], [0.10, np.nan]], [[0.35, np.nan], [0.20, np.nan]]])
    dataset = xr.Dataset(
        {"basin_status": (dims, status), "basin_velocity": (dims, v * _scale(13.0, 10.0)),
         "basin_largest_hop": (dims, np.zeros_like(v)),
         "basin_period": (dims, np.ones_like(status, dtype=np.int32)),
         "basin_fraction": (dims, np.where(status >= 0, 0.5, 0.0))},
        coords={"f": [13.0, 13.0], "a": [10.0, 10.0]})
    label = follow_attractors(dataset)[0]["attractor_label"].values
    assert label[0, 0, 0] != label[0, 0, 1]
    assert label[0, 0, 0] == label[0, 1, 0] == label[1, 1, 0]  # 0.05 and 0.10 kept
    assert label[0, 0, 1] == label[1, 0, 0] != label[1, 1, 0]  # 0.15 refused


def test_the_distance_separates_the_classes():
    classes = status_class([Status.STICK_SLIP, Status.BOUNCING, Status.BOUNCING,
                            Status.STATIC, Status.CHAOTIC, Status.QUASI_PERIODIC,
                            Status.LIFT_OFF, Status.NOT_CONVERGED, -1],
                           [1, 1, 2, 0, 0, 0, 0, 0, 0])
    assert classes[0] == classes[1] != classes[2]
    assert classes[4] == classes[5]
    assert len({*classes[[0, 2, 3, 4, 6, 7, 8]].tolist()}) == 7
    side = {"class": classes, "velocity": np.zeros(9), "velocity_error": np.zeros(9),
            "largest_hop": np.zeros(9), "f": 13.0, "a": 10.0}
    d = attractor_distance(side, side)
    assert d[0, 1] == 0.0 and np.isinf(d[0, 2]) and np.isinf(d[8, 8])
    assert d[6, 6] == 0.0 and np.isinf(d[6, 7])
    # Irregular velocities: the change less twice the combined error.
    scale = 10.0 / (2.0 * np.pi * 13.0)
    one = {"class": np.array([1]), "velocity": np.array([0.0]),
           "velocity_error": np.array([0.1 * scale]), "largest_hop": np.array([0.0]),
           "f": 13.0, "a": 10.0}
    two = dict(one, velocity=np.array([0.5 * scale]))
    np.testing.assert_allclose(attractor_distance(one, two)[0, 0],
                               0.5 - 2 * np.hypot(0.1, 0.1), rtol=1e-12)


def test_bad_input_is_refused():
    dataset, _ = _hand_map()
    with pytest.raises(ValueError, match="basin_period"):
        follow_attractors(dataset.drop_vars("basin_period"))
    with pytest.raises(ValueError, match="'along' names M"):
        follow_attractors(dataset, along=("M",))
    with pytest.raises(ValueError, match="threshold"):
        follow_attractors(dataset, threshold=0.0)


# --- computed maps ----------------------------------------------------------------------

def test_labels_are_stable_under_a_grid_refined_twice_in_f():
    """M = 0.99 with flight over 12-16 Hz at 10 and 12 m s-2 (the forward and backward
    hops coexist and fold): the coarse grid's labels map one to one onto the fine grid's
    at the points the two share."""
    a = np.array([10.0, 12.0])
    coarse = computed(M_TO_1, np.arange(12.0, 16.01, 0.5), a, flight=True)
    fine = computed(M_TO_1, np.arange(12.0, 16.01, 0.25), a, flight=True)
    coarse_labels, coarse_summary = follow_attractors(coarse)
    fine_labels, fine_summary = follow_attractors(fine)
    shared = fine_labels.sel(f=coarse["f"])
    assert_array_equal(shared["basin_status"], coarse["basin_status"])  # same attractors
    pairs = {(int(c), int(f)) for c, f in zip(
        coarse_labels["attractor_label"].values.ravel(),
        shared["attractor_label"].values.ravel(), strict=True) if c >= 0}
    forward = dict(pairs)
    backward = {f: c for c, f in pairs}
    assert len(forward) == len(backward) == len(pairs)  # one to one
    assert len(pairs) >= 2  # both hops are followed
    # A motion is born or dies in the same interval on both grids.
    for c, f in pairs:
        for kind in ("birth_f", "death_f"):
            on_coarse = coarse_summary[kind].sel(label=c).values
            on_fine = fine_summary[kind].sel(label=f).values
            assert np.all(np.isnan(on_coarse) == np.isnan(on_fine)), (kind, c, f)
            both = ~np.isnan(on_coarse)
            assert np.all(np.abs(on_coarse[both] - on_fine[both]) <= 0.25 + 1e-9)


def test_a_monostable_map_gets_one_label():
    """The paper's structure without flight, above the motion thresholds and below
    lift-off: one motion everywhere, one label."""
    labelled, summary = follow_attractors(
        computed(PAPER, [14.0, 14.25, 14.5, 14.75, 15.0], [5.5, 6.5, 7.5], starts=6))
    assert summary.sizes["label"] == 1
    assert_array_equal(labelled["attractor_label"].sel(attractor=0), 0)
    assert summary["status_class"].values.tolist() == ["period 1"]
    assert summary["points"].values.tolist() == [15]
    assert summary["fraction_min"].values.tolist() == [1.0]


def test_across_the_motion_threshold_rest_and_stick_slip_are_different_labels():
    """From rest into stick-slip at the threshold: rest is a class of its own, so each
    static region (here on both sides of the resonance) is a label and the moving
    region another; still one label at every point."""
    dataset = computed(PAPER, [13.0, 13.5, 14.0, 14.5, 15.0, 15.5], [5.0, 6.0, 7.0],
                       starts=6)
    labelled, summary = follow_attractors(dataset)
    assert_array_equal(dataset["attractor_count"], 1)
    assert sorted(summary["status_class"].values) == ["period 1", "static", "static"]
    static = summary["label"].values[summary["status_class"].values == "static"]
    first = labelled["attractor_label"].sel(attractor=0)
    assert_array_equal(first.isin(static),
                       dataset["basin_status"].sel(attractor=0) == Status.STATIC)
    # The two static regions are apart along f: one below, one above the moving band.
    low, high = sorted(static, key=lambda k: float(summary["first_f"].sel(label=k).min()))
    assert float(summary["last_f"].sel(label=low).max()) < float(
        summary["first_f"].sel(label=high).min())
