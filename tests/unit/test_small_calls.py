"""The shortcuts of a small call give what the long way gives.

* The kernel's lift-off decisions (:func:`study.kernels.one_way_velocity.lift_off_decisions`)
  against numpy's ``a > lift_off_acceleration(f)``, at and around the threshold:
  decided points agree, undecided ones lie within 1e-12 of it; the small-call driver
  :func:`study.kernels.one_way_velocity.lift_off_small` decides as it does and counts the rest.
* The drive checks' fast acceptance: the same refusals as before for every kind of bad
  value, scalar or array, short (checked as Python floats) or long (numpy's min and
  max), and a NaN that Python's min and max would miss.
* ``steady_velocity`` (velocity-only two-way path) against ``steady_state``, and a few
  points alone against the same points inside a large (parallel) call, bit for bit;
  ``steady_state``'s small one-way path (forces per point in the kernel) against the
  numpy forces of the parallel path, every output bit for bit, lift-off threshold
  points included.
* The constants kept per structure: the structure vector handed out is a fresh copy
  equal to one built from its definition, for structures taking turns (more than are
  kept), equal structures whose tilt differs in the sign of zero, and a changed one.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import study
from study.kernels import one_way_velocity
from study.kernels import structure_vector as sv
from study.model import as_acceleration, as_frequency, lift_off_acceleration
from study.model.contact import LAWS
from study.model.drive import SMALL_ARRAY, as_time
from study.model.inputs import SuspectInputWarning
from study.solvers.exact import steady_state, steady_velocity
from study.solvers.structure_constants import STRUCTURES_KEPT, structure_vector

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
    return one_way_velocity.ForceConstants(
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
        one_way_velocity.lift_off_decisions(ff, a, _constants(structure), decisions)
        numpy_says = a > lift_off_acceleration(structure, ff)
        decided = decisions != one_way_velocity.LIFT_UNDECIDED
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


def _threshold_points(structure, rng, count):
    """Random drive points and points at, just below and just above the lift-off
    threshold (where the kernel leaves the decision to numpy)."""
    f = rng.uniform(0.2, 3.0, count) * structure.f0
    threshold = lift_off_acceleration(structure, f)
    a = np.concatenate([rng.uniform(0.0, 1.5, count) * threshold, threshold,
                        np.nextafter(threshold, 0.0), np.nextafter(threshold, np.inf)])
    return np.tile(f, 4), a


def test_lift_off_small_decides_as_lift_off_decisions():
    structures, rng = _random_structures(20, 2234)
    undecided_seen = 0
    for structure in structures:
        f, a = _threshold_points(structure, rng, 8)
        decisions = np.empty(f.size, dtype=np.int8)
        one_way_velocity.lift_off_decisions(f, a, _constants(structure), decisions)
        lifted = np.empty(f.size, dtype=np.bool_)
        count = one_way_velocity.lift_off_small(f, a, tuple(_constants(structure)), lifted)
        assert_array_equal(lifted, decisions == 1)
        assert count == np.count_nonzero(decisions == one_way_velocity.LIFT_UNDECIDED)
        undecided_seen += count
    assert undecided_seen > 0


@pytest.mark.parametrize("check", [as_frequency, as_acceleration])
@pytest.mark.parametrize("size", [3, SMALL_ARRAY, SMALL_ARRAY + 1, 1000])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, -1.0, 2e6])
def test_drive_checks_refuse_short_and_long_arrays(check, size, bad):
    values = np.full(size, 5.0)
    where = size // 2
    values[where] = bad
    with pytest.raises(ValueError, match=rf"at index \({where},\)"):
        check(values)
    with pytest.raises(ValueError, match=rf"at index \(0, {where}\)"):
        check(values[None, :])
    assert_array_equal(check(np.full(size, 5.0)), np.full(size, 5.0))


def test_drive_checks_see_what_min_and_max_would_miss():
    # Python's min and max skip a NaN after the first value; inf - inf sums to NaN.
    for values in ([1.0, np.nan, 2.0], [np.inf, -np.inf], [2.0, 1.0, np.nan]):
        with pytest.raises(ValueError, match="must be finite"):
            as_frequency(np.array(values))
    # Finite times whose sum overflows are allowed (checked the long way), not an
    # infinity among them.
    huge = np.array([1.7e308, 1.7e308])
    assert_array_equal(as_time(huge), huge)
    with pytest.raises(ValueError, match=r"at index \(1,\)"):
        as_time(np.array([1.7e308, np.inf]))


def test_small_steady_state_is_the_numpy_path():
    structures, rng = _random_structures(24, 2235)
    structures += [PAPER.replace(alpha=0.0), PAPER.replace(alpha=-0.0)]
    for structure in structures:
        f, a = _threshold_points(structure, rng, 6)
        small = steady_state(structure, f, a, coupling="one-way")
        numpy_path = steady_state(structure, f, a, coupling="one-way", parallel=True)
        for name in ("velocity", "status", "reason", "slips_per_period",
                     "forward_fraction", "backward_fraction", "orbit_period"):
            got, want = getattr(small, name), getattr(numpy_path, name)
            assert got.dtype == want.dtype and got.tobytes() == want.tobytes(), name
        v, s = steady_velocity(structure, f, a)
        assert v.tobytes() == numpy_path.velocity.tobytes()
        assert_array_equal(s, numpy_path.status)
        one = steady_state(structure, float(f[0]), float(a[0]))
        assert isinstance(one.velocity, np.float64) and isinstance(one.status, np.int8)
        assert isinstance(one.orbit_period, np.int32)
        assert one.velocity.tobytes() == small.velocity[:1].tobytes()


def _reference_vector(structure, coupling, flight=False):
    """The structure vector by its definition, built afresh."""
    vector = np.zeros(sv.SIZE)
    w0 = structure.omega0
    vector[sv.DAMPING] = w0 / structure.Q
    vector[sv.STIFFNESS] = w0 * w0
    vector[sv.COS_ALPHA] = np.cos(structure.alpha_rad)
    vector[sv.SIN_ALPHA] = np.sin(structure.alpha_rad)
    vector[sv.MASS_RATIO] = structure.M
    vector[sv.STATIC_FRICTION] = structure.cs
    vector[sv.KINETIC_FRICTION] = structure.ck
    vector[sv.GRAVITY] = structure.g
    vector[sv.TWO_WAY] = 1.0 if coupling == "two-way" else 0.0
    vector[sv.RESTITUTION] = structure.restitution
    vector[sv.LIFT_OFF_LAW] = LAWS["lift_off"]["flight" if flight else "stop"].code
    return vector


def test_kept_vectors_are_fresh_and_never_stale():
    structures, rng = _random_structures(2 * STRUCTURES_KEPT + 3, 2236)
    # Equal structures whose tilt or restitution differs in the sign of zero: equal and
    # hashed alike, but sin(-0.0) is -0.0.
    plus = PAPER.replace(alpha=0.0, restitution=0.0)
    minus = PAPER.replace(alpha=-0.0, restitution=-0.0)
    assert plus == minus and hash(plus) == hash(minus)
    structures += [plus, minus, plus, study.Structure(**minus.as_dict()), PAPER,
                   PAPER.replace(Q=PAPER.Q * (1.0 + 2.0**-52))]
    order = [*range(len(structures)), *rng.permutation(len(structures)),
             *reversed(range(len(structures)))]
    for index in order:
        structure = structures[index]
        for coupling, flight in (("two-way", False), ("one-way", False), ("two-way", True)):
            vector = structure_vector(structure, coupling, flight)
            assert vector.flags.writeable
            assert vector.tobytes() == _reference_vector(structure, coupling, flight).tobytes()
            vector[:] = np.nan  # a caller's changes never reach what is kept
    assert math.copysign(1.0, structure_vector(minus, "two-way")[sv.SIN_ALPHA]) == -1.0
    assert math.copysign(1.0, structure_vector(plus, "two-way")[sv.SIN_ALPHA]) == 1.0


def test_structures_taking_turns_get_their_own_results():
    structures, rng = _random_structures(STRUCTURES_KEPT + 5, 2237)
    f = rng.uniform(8.0, 22.0, 3)
    a = rng.uniform(0.0, 10.0, 3)
    first = {}
    for _ in range(2):
        for index in rng.permutation(len(structures)):
            structure = structures[index]
            got = [x.tobytes() for coupling in ("one-way", "two-way")
                   for x in steady_velocity(structure, f, a, coupling=coupling)]
            assert first.setdefault(index, got) == got
    # Each against the numpy path of the one-way solver, on its own.
    for index, structure in enumerate(structures):
        assert first[index][0] == steady_state(structure, f, a, parallel=True).velocity.tobytes()
