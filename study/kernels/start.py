"""The state a point's motion starts from, as one named tuple the kernels take.

:class:`study.solvers.settings.SolverSettings` ``start`` names the protocol (release,
switch-on, a drop; docs/theory/starts.md); :func:`study.solvers.settings.kernel_start`
packs it into a :data:`Start`, which the two-way drivers
(:mod:`study.kernels.two_way.points`) read by name.
"""

from collections import namedtuple

from numba import njit

#: ``phase``: the drive phase the motion starts at [periods], in [0, 1) (the time
#: ``phase * 2 pi / omega``); ``factor``: the mode starts at rest on this multiple of
#: its steady stick response at that phase (1: on it, 0: at rest at ``delta = delta' =
#: 0``); ``height``: the base starts at rest this high above the table [m] (0: on it),
#: all float64.
Start = namedtuple("Start", ("phase", "factor", "height"))

#: The release: base at rest on the table at phase 0, the mode on its steady stick
#: response (every point's start before starts were named).
RELEASE = Start(0.0, 1.0, 0.0)
#: The switch-on: base at rest on the table at phase 0, the mode at rest at 0.
SWITCH_ON = Start(0.0, 0.0, 0.0)


@njit(cache=True, nogil=True, inline="always")
def is_release(start):
    """``start`` is the release (:data:`RELEASE`): the drivers then keep every bit of
    the solver before starts were named (the static points decided in closed form, the
    continuation)."""
    return start.phase == 0.0 and start.factor == 1.0 and start.height == 0.0
