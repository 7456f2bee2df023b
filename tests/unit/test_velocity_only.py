"""``steady_velocity`` takes its own path (velocity and status only, the force amplitudes
evaluated inside the kernel): its answers must be ``steady_state``'s, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import study
from study import SolverSettings, Status
from study.model.structure import tilt_warnings


def _assert_same_bits(structure, f, a, settings=None):
    velocity, status = study.steady_velocity(structure, f, a, settings)
    full = study.steady_state(structure, f, a, settings)
    assert velocity.shape == status.shape == full.velocity.shape
    assert status.dtype == np.int8
    np.testing.assert_array_equal(status, full.status)
    # Bits, not values: signed zeros and NaN payloads too.
    mismatch = velocity.view(np.int64) != full.velocity.view(np.int64)
    assert not mismatch.any(), (
        f"{int(mismatch.sum())} velocities differ, first at f = "
        f"{np.broadcast_to(f, mismatch.shape)[mismatch][0]!r}, "
        f"a = {np.broadcast_to(a, mismatch.shape)[mismatch][0]!r}"
    )
    return status


def test_paper_map_bit_identical(paper_structure):
    f = np.linspace(10.0, 20.0, 211)[:, None]
    a = np.linspace(0.0, 12.0, 307)[None, :]
    status = _assert_same_bits(paper_structure, f, a)  # 64777 points: parallel kernel
    for regime in (Status.STATIC, Status.STICK_SLIP, Status.LIFT_OFF):
        assert (status == regime).any()
    # A few points: the serial kernel.
    _assert_same_bits(paper_structure, f[::40], a[:, ::60])


def _random_structures(rng, count):
    for _ in range(count):
        cs = rng.uniform(0.05, 1.2)
        with tilt_warnings(False):  # small tilts are part of the space, in degree
            structure = study.Structure(
                f0=rng.uniform(2.0, 40.0), Q=rng.uniform(0.5, 200.0),
                alpha=rng.uniform(-89, 89),
                M=rng.choice([rng.uniform(0.01, 0.9), rng.uniform(0.9, 1.0), 1.0]), cs=cs,
                ck=cs * rng.choice([1.0, rng.uniform(0.05, 1.0)]), g=rng.uniform(1.0, 20.0),
            )
        yield structure


def test_random_structures_bit_identical():
    """Random structures, M near 1 and ck < cs among them: every regime, same bits."""
    rng = np.random.default_rng(20261122)
    seen = set()
    for structure in _random_structures(rng, 24):
        f = structure.f0 * rng.uniform(0.2, 3.0, 3000)
        # Mostly below lift-off, where the orbits are.
        a = rng.uniform(0.0, 1.1, f.size) * study.lift_off_acceleration(structure, f)
        seen.update(int(s) for s in np.unique(_assert_same_bits(structure, f, a)))
        seen.update(int(s) for s in np.unique(_assert_same_bits(structure, f[:50], a[:50])))
    assert {Status.STATIC, Status.STICK_SLIP, Status.CONTINUOUS_SLIDING,
            Status.LIFT_OFF} <= seen


@pytest.mark.parametrize(
    ("settings", "outcome"),
    [(SolverSettings(max_events=2), Status.NOT_CONVERGED),
     # A starved cycle search averages the motion instead (its slow cycles reported as
     # quasi-periodic, docs/theory/irregular.md).
     (SolverSettings(max_map_iterations=2), Status.QUASI_PERIODIC)]
)
def test_budgets_bit_identical(paper_structure, settings, outcome):
    """Starved budgets: the same points are flagged NOT_CONVERGED (NaN), or averaged,
    on both paths."""
    s = paper_structure.replace(M=1.0, ck=0.1)
    f = np.linspace(10.0, 20.0, 41)[:, None]
    a = np.linspace(0.0, 12.0, 53)[None, :]
    status = _assert_same_bits(s, f, a, settings)
    assert (status == outcome).any()


def test_thresholds_to_the_ulp_bit_identical():
    """The velocity path decides lift-off and static points on squares where that is
    sure: within ulps of either threshold it must still decide as ``steady_state``."""
    rng = np.random.default_rng(20261123)
    ulps = np.arange(-8, 9) * np.finfo(float).eps
    seen = set()
    for structure in _random_structures(rng, 12):
        f = structure.f0 * rng.uniform(0.2, 3.0, 40)
        lift = study.lift_off_acceleration(structure, f)
        a_plus, a_minus = study.thresholds(structure, f)
        for edge in (lift, a_plus, a_minus, np.minimum(a_plus, a_minus)):
            a = (edge[:, None] * (1.0 + ulps)).ravel()
            statuses = _assert_same_bits(structure, np.repeat(f, ulps.size), a)
            seen.update(int(s) for s in np.unique(statuses))
    assert {Status.STATIC, Status.LIFT_OFF} <= seen
