"""The exact solver against an independent time integrator of the full model.

``tests/reference/integrator.py`` integrates the mode ODE and the sliding ODE with
scipy's ``solve_ivp`` (DOP853, rtol 1e-12) and event location, from the same
canonical start (at rest, drive phase 0, mode on its steady response), until the
orbit is periodic. It uses no closed form of the sliding motion and imports nothing
from ``study``. Its tolerance (1e-12) is 100 times tighter than the assertion (1e-10; the issue asks
for 1e-8). Observed agreement: 2e-12 at worst, 2e-14 median.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study import Status
from tests.reference.integrator import reference_velocity
from tests.support.tiers import headline

PAPER = {"f0": 14.44, "Q": 17.5, "alpha": 64.0, "cs": 0.25}
STATUS_NAMES = {
    "static": Status.STATIC,
    "stick_slip": Status.STICK_SLIP,
    "continuous_sliding": Status.CONTINUOUS_SLIDING,
    "lift_off": Status.LIFT_OFF,
}


def _regime(structure, f, a, margin=0.02):
    """Regime of (f, a), or None within ``margin`` (relative) of a threshold.

    Within ``delta`` of a threshold the velocity's relative condition number is about
    ``1/delta``, so the integrator's 1e-12 tolerance only buys ~1e-12/delta (at
    a = a*(1 + 3.6e-5) it agrees to 8e-9 on v = -2.2e-11 m s-1). Those points are
    checked against the 40-digit mpmath reference instead (test_solver_cases.py).
    """
    a_plus, a_minus = study.thresholds(structure, f)
    if min(abs(a / a_plus - 1), abs(a / a_minus - 1)) < margin:
        return None
    return {(True, False): "P", (False, True): "N", (True, True): "PN"}.get(
        (bool(a > a_plus), bool(a > a_minus))
    )


def _points():
    """40 random drive points: 8 each in P, N and PN (M = 0.08), 8 with ck < cs and
    8 at large M near resonance, chosen by thresholds and lift-off only (closed forms)."""
    rng = np.random.default_rng(20261121)
    wanted = {"P": 8, "N": 8, "PN": 8, "ck<cs": 8, "large M": 8}
    points = []
    while any(wanted.values()):
        kind = next(k for k, n in wanted.items() if n)
        M = rng.uniform(0.8, 1.0) if kind == "large M" else 0.08
        ck = rng.uniform(0.05, 0.24) if kind == "ck<cs" else None
        s = study.Structure(M=M, ck=ck, **PAPER)
        # Near the resonance at large M, where the slips join into continuous sliding.
        f = rng.uniform(10.0, 20.0) if kind != "large M" else rng.uniform(13.0, 17.0)
        a = rng.uniform(0.0, float(study.lift_off_acceleration(s, f)))
        regime = _regime(s, f, a)
        if regime is None or (kind in ("P", "N", "PN") and regime != kind):
            continue
        wanted[kind] -= 1
        points.append(pytest.param(M, ck, f, a, id=f"{kind}-M{M:.2f}-f{f:.3f}-a{a:.3f}"))
    return points


@pytest.mark.parametrize(("M", "ck", "f", "a"), headline(_points(), keep=4))
def test_steady_velocity_agrees_with_solve_ivp(M, ck, f, a):
    s = study.Structure(M=M, ck=ck, **PAPER)
    v, status = study.steady_velocity(s, f, a)
    ref, ref_status, periods = reference_velocity(
        PAPER["f0"], PAPER["Q"], PAPER["alpha"], M, PAPER["cs"], f, a, ck=ck,
        rtol=1e-12, atol=1e-14, max_periods=2000,
    )
    assert ref_status in STATUS_NAMES, f"reference did not converge in {periods} periods"
    assert status == STATUS_NAMES[ref_status]
    assert_allclose(v, ref, rtol=1e-10, atol=1e-13)


def test_the_sample_covers_continuous_sliding():
    """At least a few of the large-M points slide without sticking."""
    statuses = []
    for param in _points():
        M, ck, f, a = param.values
        statuses.append(int(study.steady_velocity(study.Structure(M=M, ck=ck, **PAPER), f, a)[1]))
    assert statuses.count(Status.CONTINUOUS_SLIDING) >= 3
    assert statuses.count(Status.STICK_SLIP) >= 25
