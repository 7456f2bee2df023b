"""A trace that seeks one kind of bifurcation (``sought``), as a curve's next point is
sought: it locates that kind only, stops on the step past the first one, and finds it
exactly where the trace that locates every kind does; and a curve's points do not
depend on the longest step of the branches they are sought on.

Independent references: the bouncing block's fold and period doubling in closed form
(Gamma = pi (1 - e) / (1 + e), and Gamma^2 = that^2 + (2 (1 + e^2) / (1 + e)^2)^2), the
full trace of the same branch, and the same curve sought with five times shorter steps.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import study
from study.model.bifurcations import kind_named
from study.model.codes import BRANCH_STOPPED
from study.solvers.branch import trace, trace_from_section
from study.solvers.protocol import slow_sweep
from tests.support.bouncing_ball import G, ball, ball_doubling, ball_fold, ball_orbit

E = 0.5
FOLD = kind_named("fold").code
DOUBLING = kind_named("period_doubling").code
BALL = ball(E)
GAMMA_FOLD = ball_fold(E)
GAMMA_DOUBLING = ball_doubling(E)


def _seeded(to: float) -> tuple[object, dict]:
    """The ball's branch along a from between its fold and doubling, and the arguments
    that trace it again from its first step."""
    f = 10.0
    a = 0.5 * (GAMMA_FOLD + GAMMA_DOUBLING) * G
    full, _ = trace(BALL, f, a, along="a", to=to, start=ball_orbit(E, f, a), flight=True)
    again = dict(f=f, a=a, along="a", to=to, state=full.states()[0],
                 section=float(full.column("section")[0]), periods=full.periods,
                 flight=True)
    return full, again


@pytest.mark.parametrize(("kind", "to", "gamma"), [(FOLD, 0.8 * GAMMA_FOLD * G, GAMMA_FOLD),
                                                   (DOUBLING, 1.1 * GAMMA_DOUBLING * G,
                                                    GAMMA_DOUBLING)])
def test_a_sought_bifurcation_is_the_full_traces_and_ends_it(kind, to, gamma):
    _, again = _seeded(to)
    every = trace_from_section(BALL, **again)
    sought = trace_from_section(BALL, **again, sought=kind)
    assert every.end != BRANCH_STOPPED and sought.end == BRANCH_STOPPED
    kinds = sought.bifurcation_column("kind").astype(int)
    assert kinds.tolist() == [kind]
    first = int(np.flatnonzero(every.bifurcation_column("kind").astype(int) == kind)[0])
    step = int(every.bifurcation_column("step")[first])
    # The same steps up to the one past it, and the same location on that step.
    assert sought.steps.shape[0] == step + 2
    assert_allclose(sought.steps, every.steps[:step + 2], rtol=1e-13, atol=1e-15)
    assert_allclose(sought.bifurcations[0], every.bifurcations[first], rtol=1e-13,
                    atol=1e-15)
    _, a_found = sought.drive(sought.bifurcation_column("t")[0])
    assert_allclose(a_found / G, gamma, rtol=1e-9, atol=0)
    # What locating it took is recorded and is part of the trace's passes.
    newton = sought.bifurcation_column("newton_passes")[0]
    mapped = sought.bifurcation_column("map_passes")[0]
    assert newton >= 1 and mapped >= 0 and float(newton).is_integer()
    assert newton <= sought.newton_passes and mapped <= sought.map_passes


def test_sought_must_be_a_bifurcations_code():
    _, again = _seeded(0.8 * GAMMA_FOLD * G)
    with pytest.raises(ValueError, match="'sought' must be 0 or a bifurcation's code"):
        trace_from_section(BALL, **again, sought=99)


def test_a_curves_points_do_not_depend_on_its_branches_longest_step():
    # The fold of the forward hop at M = 0.99 with flight (hysteresis-flight's), from
    # the slow sweep's state at 15.9 Hz, followed from 10 to 10.5 m s-2.
    hop = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.99, cs=0.25)
    swept_f = np.round(np.arange(12.0, 15.91, 0.1), 6)
    swept = slow_sweep(hop, swept_f, [10.0], along="f", direction="up", flight=True)
    branch = study.branch(hop, 15.9, 10.0, along="f", to=16.2, flight=True,
                          start=swept.state.phase_state[-1, 0],
                          periods=int(swept.state.orbit_period[-1, 0]))
    fold = int(np.flatnonzero(branch.bifurcation_kind.values == FOLD)[0])
    default = study.bifurcation_curve(hop, branch, fold, to=10.5, num=6)
    short = study.bifurcation_curve(hop, branch, fold, to=10.5, num=6, max_step=0.02)
    assert default.attrs["curve_end"] == short.attrs["curve_end"] == "reached"
    assert default.sizes["point"] == short.sizes["point"]
    assert_allclose(default.f.values, short.f.values, rtol=1e-10, atol=0)
    assert_allclose(default.a.values, short.a.values, rtol=1e-12, atol=0)
    assert_allclose(default.multiplier_modulus.values, 1.0, rtol=0, atol=1e-8)
    # It moves: the fold falls by about 0.7 Hz over the half m s-2.
    assert default.f.values[-1] < default.f.values[0] - 0.3
