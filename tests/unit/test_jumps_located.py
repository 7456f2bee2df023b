"""A slow sweep's jumps located exactly (the ``jumps`` observable,
:func:`study.solvers.jumps.sweep_jumps`): at each jumped point the bifurcation where the
branch of the previous point's orbit ends.

Each located drive is checked against something the locator does not use: the same
sweep on a grid fine enough to bracket the jump (its velocities and flags alone), and
the multiplier that crosses at a fold, which must be +1 (a saddle-node).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.model.bifurcations import JUMP_NONE, JUMP_UNLOCATED, kind_named
from study.solvers.jumps import sweep_jumps
from study.solvers.protocol import slow_sweep

#: M = 0.99 with flight (hysteresis-flight's structure): swept up at 10 m s-2 the small
#: forward hop folds near 16.05 Hz and the sweep lands on the big backward hop.
M099 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
#: A user's structure near M = 1 (tests/unit/test_sweep_jumps.py's).
USER = study.Structure(f0=18.0, Q=25.0, alpha=55.0, M=0.9, cs=0.35)
M05 = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.5, cs=0.25)
FOLD = kind_named("fold").code


def _located(structure, f, a, along, direction):
    f, a = np.atleast_1d(np.asarray(f, float)), np.atleast_1d(np.asarray(a, float))
    swept = slow_sweep(structure, f, a, along=along, direction=direction, flight=True)
    return swept, sweep_jumps(structure, f, a, swept, flight=True)


def _fine_bracket(structure, coarse, fine, a, direction="up"):
    """The two drives of a sweep through ``coarse`` then ``fine`` [Hz] between which it
    jumps (the first jump in ``fine``)."""
    f = np.unique(np.concatenate([coarse, fine]))
    swept = slow_sweep(structure, f, [a], along="f", direction=direction, flight=True)
    jumped = np.flatnonzero(swept.jumped[:, 0] & (f >= fine.min()) & (f <= fine.max()))
    assert jumped.size >= 1
    i = int(jumped[0] if direction == "up" else jumped[-1])
    before = i - 1 if direction == "up" else i + 1
    return sorted((f[before], f[i]))


def test_the_hysteresis_fold_lies_where_a_fine_sweep_jumps():
    f = np.round(np.arange(12.0, 17.01, 0.1), 6)
    swept, jumps = _located(M099, f, 10.0, "f", "up")
    i = int(np.flatnonzero(swept.jumped[:, 0])[0])
    assert f[i] == 16.1
    assert jumps.kind[i, 0] == FOLD
    # Every other point: no jump, and nothing located.
    others = np.delete(np.arange(f.size), i)
    assert (jumps.kind[others, 0] == JUMP_NONE).all()
    assert np.isnan(jumps.f[others, 0]).all() and np.isnan(jumps.velocity[others, 0]).all()
    # A saddle-node: the multiplier that crosses is +1.
    assert_allclose(jumps.multiplier_modulus[i, 0], 1.0, rtol=0.0, atol=1e-8)
    assert_allclose(jumps.multiplier_angle[i, 0], 0.0, rtol=0.0, atol=1e-8)
    assert jumps.a[i, 0] == 10.0
    # The same sweep in steps of 0.0005 Hz past 16.0 Hz jumps in one step of it, which
    # holds the located fold; the velocity there is the forward hop's.
    low, high = _fine_bracket(M099, f[f <= 16.0], np.round(np.arange(16.0, 16.0601, 0.0005), 6),
                              10.0)
    assert low < jumps.f[i, 0] < high
    assert high - low == pytest.approx(0.0005, abs=1e-9)
    assert 0.05 < jumps.velocity[i, 0] < 0.06


def test_a_reversal_of_direction_is_located_at_the_forward_hops_fold():
    # The user's reversal at 12 m s-2 (forward hop +81 mm s-1 to backward -69 mm s-1).
    f = np.round(np.arange(11.3, 11.81, 0.1), 6)
    swept, jumps = _located(USER, f, 12.0, "f", "up")
    np.testing.assert_array_equal(jumps.kind[:, 0] != JUMP_NONE, swept.jumped[:, 0])
    assert jumps.kind[3, 0] == FOLD
    low, high = _fine_bracket(USER, f[f <= 11.5], np.round(np.arange(11.5, 11.6001, 0.002), 6),
                              12.0)
    assert low < jumps.f[3, 0] < high
    assert_allclose(jumps.multiplier_modulus[3, 0], 1.0, rtol=0.0, atol=1e-8)


@pytest.mark.parametrize(("direction", "frequencies", "where", "bracket"), [
    # Two forward hops 0.2 mm s-1 apart coexist over 9.4031-9.4040 Hz: each direction's
    # sweep leaves its hop at that hop's fold (a 0.0001 Hz sweep jumps between
    # 9.4039 and 9.4042 Hz up, test_sweep_jumps.py).
    ("up", [9.4030, 9.4035, 9.4045], 2, (9.4039, 9.4042)),
    ("down", [9.4025, 9.4035, 9.4045], 0, (9.4025, 9.4035)),
])
def test_both_directions_locate_their_own_fold(direction, frequencies, where, bracket):
    swept, jumps = _located(USER, frequencies, 10.0, "f", direction)
    np.testing.assert_array_equal(np.flatnonzero(swept.jumped[:, 0]), [where])
    assert jumps.kind[where, 0] == FOLD
    assert bracket[0] < jumps.f[where, 0] < bracket[1]
    assert_allclose(jumps.multiplier_modulus[where, 0], 1.0, rtol=0.0, atol=1e-8)


def test_the_two_directions_folds_bound_where_both_hops_coexist():
    # The down sweep's fold is below the up sweep's: between them both hops exist.
    _, up = _located(USER, [9.4030, 9.4035, 9.4045], 10.0, "f", "up")
    _, down = _located(USER, [9.4025, 9.4035, 9.4045], 10.0, "f", "down")
    assert np.nanmax(down.f) < np.nanmin(up.f)
    assert np.nanmin(up.velocity) != pytest.approx(np.nanmax(down.velocity), abs=1e-5)


def test_leaving_a_branch_that_goes_on_is_unlocated():
    # M = 0.5 at 17 Hz swept down along a: at 7.4 m s-2 the carried state settles on
    # another hop while the branch it rode goes on stable (test_sweep_jumps.py): no
    # bifurcation to locate, said by the flag, every value NaN.
    a = np.round(np.linspace(0.0, 12.0, 61), 6)
    swept, jumps = _located(M05, 17.0, a, "a", "down")
    i = int(np.flatnonzero(a == 7.4)[0])
    assert swept.jumped[0, i]
    assert jumps.kind[0, i] == JUMP_UNLOCATED
    assert (jumps.kind[0, np.arange(a.size) != i] == JUMP_NONE).all()
    for values in (jumps.f, jumps.a, jumps.velocity, jumps.multiplier_modulus,
                   jumps.multiplier_angle):
        assert np.isnan(values).all()


def test_a_period_doubling_the_sweep_follows_locates_nothing():
    a = np.round(np.linspace(0.0, 12.0, 61), 6)
    swept, jumps = _located(M05, 18.5, a, "a", "up")
    assert not swept.jumped.any()
    assert (jumps.kind == JUMP_NONE).all()


@pytest.mark.parametrize("direction", ["up", "down"])
def test_an_axis_given_in_descending_order_locates_the_same_jumps(direction):
    # A spec may give f from high to low; the sweep still visits it in its direction's
    # order, and each jump is located from the point visited before it (found by a
    # fuzzed spec: the point before was taken by index and ran off the axis).
    f = np.round(np.arange(12.0, 16.31, 0.1), 6)
    _, ascending = _located(M099, f, 10.0, "f", direction)
    _, descending = _located(M099, f[::-1], 10.0, "f", direction)
    if direction == "up":  # the forward hop's fold at 16.0545 Hz is among them
        assert (ascending.kind == FOLD).sum() == 1
    np.testing.assert_array_equal(descending.kind[::-1], ascending.kind)
    assert_allclose(descending.f[::-1], ascending.f, rtol=0.0, atol=0.0)
