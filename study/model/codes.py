"""Integer codes shared by every kernel and by :mod:`study.model.status`, defined once.

The numba kernels return plain integers; :class:`study.model.status.Status` and
:class:`study.model.status.NonConvergence` are built from the same values, so a code means
one thing in a kernel's output, in memory and on disk.
"""

from __future__ import annotations

# Outcome of a point (study.model.status.Status).
STATIC = 0
STICK_SLIP = 1
CONTINUOUS_SLIDING = 2
LIFT_OFF = 3
NOT_CONVERGED = 4
FRICTION_PARADOX = 5
BOUNCING = 6
CHAOTIC = 7
QUASI_PERIODIC = 8

# Why a point did not converge (study.model.status.NonConvergence).
REASON_NONE = 0
REASON_NO_PERIODIC_ORBIT = 1
REASON_EVENT_BUDGET = 2
REASON_AVERAGE_BUDGET = 3

# Contact mode "stuck" of the time integrators (their slip modes are their own).
STICK = 0

# How a time integrator's run ended.
RUN_DONE = 0
RUN_LIFT_OFF = 1
RUN_BUDGET = 2
RUN_PARADOX = 3

# Event kinds recorded in trajectories. The planar disk's release has no sign: it is
# EVENT_RELEASE (the single plate's forward code).
EVENT_RELEASE_FORWARD = 1
EVENT_RELEASE = EVENT_RELEASE_FORWARD
EVENT_RELEASE_BACKWARD = 2
EVENT_SLIP_END = 3
EVENT_LIFT_OFF = 4
EVENT_PARADOX = 5
# With flight: EVENT_LIFT_OFF is the take-off, EVENT_IMPACT a landing on the table.
EVENT_IMPACT = 6

# Outcome of an impact of the base on the table (the impact law, study.kernels.impact).
IMPACT_STICK = 0  # the base ends the impact at rest tangentially (v = 0; e > 0 rebounds)
IMPACT_SLIP = 1  # the base ends the impact sliding, either way
IMPACT_PARADOX = 2  # the sliding effective normal mass is not positive: no solution

# Bifurcations of a periodic orbit's branch (study.model.bifurcations).
BIFURCATION_FOLD = 1
BIFURCATION_PERIOD_DOUBLING = 2
BIFURCATION_TORUS = 3
BIFURCATION_GRAZING = 4
BIFURCATION_LIFT_OFF = 5
BIFURCATION_SLIP_ONSET = 6
BIFURCATION_BRANCH_POINT = 7

# Why a traced branch ended (study.model.bifurcations).
BRANCH_REACHED = 1
BRANCH_ENDED = 2
BRANCH_BUDGET = 3
BRANCH_LEFT = 4
BRANCH_LOST = 5
BRANCH_STOPPED = 6

# Why a bifurcation's curve over the drive plane ended (study.model.bifurcations).
CURVE_REACHED = 1
CURVE_VANISHED = 2
CURVE_ENDED = 3
CURVE_LOST = 4
