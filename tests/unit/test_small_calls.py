"""The shortcuts of a small call give what the long way gives.

* The kernel's lift-off decisions (:func:`study.kernels.one_way.lift_off_decisions`)
  against numpy's ``a > lift_off_acceleration(f)``, at and around the threshold:
  decided points agree, undecided ones lie within 1e-12 of it.
* The drive checks' fast acceptance: the same refusals as before for every kind of bad
  value, scalar or array.
* ``steady_velocity`` (velocity-only two-way path) against ``steady_state``, and a few
  points alone against the same points inside a large (parallel) call, bit for bit.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import study
from study.kernels import one_way
from study.model import as_acceleration, as_frequency, lift_off_acceleration
from study.model.inputs import SuspectInputWarning
from study.solvers.exact import steady_state, steady_velocity

PAPER = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)


def _random_structures(count, seed):
    rng = np.random.default_rng(seed)
    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SuspectInputWarning)
        for _ in range(count):
            cs = rng.uniform(0.05, 1.0)
            out.append(study.Structure(
                f0=rng.uniform(5.0, 30.0), Q=rng.uniform(1.0, 60.0),
                alpha=rng.uniform(-89.0, 89.0), M=rng.uniform(0.0, 0.6), cs=cs,
                ck=cs * rng.uniform(0.3, 1.0)))
    return out, rng


def _constants(structure):
    return one_way.ForceConstants(
        float(structure.omega0), 1.0 / structure.Q, float(structure.M),
        float(np.cos(structure.alpha_rad)), float(np.sin(structure.alpha_rad)),
        float(structure.cs), float(structure.ck), float(structure.g))


def test_lift_off_decisions_are_numpys():
    structures, rng = _random_structures(40, 2231)
    undecided_seen = 0
    for structure in structures:
        f = rng.uniform(0.2, 3.0, 16) * structure.f0
        threshold = lift_off_acceleration(structure, f)
        steps = np.array([-1e-9, -1e-13, -4e-16, -2e-16, 0.0, 2e-16, 4e-16, 1e-13, 1e-9])
        a = (threshold[:, None] * (1.0 + steps[None, :])).ravel()
        a = np.concatenate([a, np.nextafter(threshold, 0.0), np.nextafter(threshold, np.inf),
                            rng.uniform(0.0, 3.0, 16) * threshold])
        ff = np.concatenate([np.repeat(f, steps.size), f, f, f])
        decisions = np.empty(ff.size, dtype=np.int8)
        one_way.lift_off_decisions(ff, a, _constants(structure), decisions)
        numpy_says = a > lift_off_acceleration(structure, ff)
        decided = decisions != one_way.LIFT_UNDECIDED
        assert_array_equal(decisions[decided] == 1, numpy_says[decided])
        near = np.abs(a / lift_off_acceleration(structure, ff) - 1.0) <= 1e-12
        assert np.all(near[~decided])
        undecided_seen += int(np.sum(~decided))
    assert undecided_seen > 0  # the numpy fallback is exercised


@pytest.mark.parametrize("check", [as_frequency, as_acceleration])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, -1.0, 2e6])
def test_drive_checks_refuse_as_before(check, bad):
    with pytest.raises(ValueError, match="must be finite"):
        check(bad)
    with pytest.raises(ValueError, match=r"at index \(2,\)"):
        check(np.array([1.0, 2.0, bad, 3.0]))


def test_drive_checks_bounds():
    with pytest.raises(ValueError, match="> 0"):
        as_frequency(0.0)
    assert as_acceleration(0.0) == 0.0
    assert as_frequency(1e6) == 1e6
    assert as_acceleration(np.zeros((2, 0))).shape == (2, 0)
    value = as_frequency(14)
    assert value.dtype == np.float64 and value.ndim == 0


@pytest.mark.parametrize("coupling", ["one-way", "two-way"])
def test_small_calls_are_the_large_call(coupling):
    rng = np.random.default_rng(2232)
    f = rng.uniform(8.0, 22.0, 3000)
    a = rng.uniform(0.0, 10.0, 3000)
    v_all, s_all = steady_velocity(PAPER, f, a, coupling=coupling)  # parallel kernel
    for start, size in ((0, 1), (10, 4), (100, 16)):
        v, s = steady_velocity(PAPER, f[start:start + size], a[start:start + size],
                               coupling=coupling)
        assert v.tobytes() == v_all[start:start + size].tobytes()
        assert_array_equal(s, s_all[start:start + size])
    v, s = steady_velocity(PAPER, float(f[7]), float(a[7]), coupling=coupling)
    assert isinstance(v, np.float64) and isinstance(s, np.int8)
    assert (math.isnan(v) and math.isnan(v_all[7])) or v == v_all[7]
    assert s == s_all[7]


def test_two_way_velocity_path_is_steady_state():
    rng = np.random.default_rng(2233)
    f = rng.uniform(8.0, 22.0, (5, 1))
    a = rng.uniform(0.0, 10.0, (1, 7))
    v, s = steady_velocity(PAPER, f, a, coupling="two-way")
    full = steady_state(PAPER, f, a, coupling="two-way")
    assert v.shape == s.shape == (5, 7) and s.dtype == np.int8
    assert v.tobytes() == full.velocity.tobytes()
    assert_array_equal(s, full.status)
