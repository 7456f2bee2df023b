"""The budgets the exact kernels take, as one named tuple.

:class:`study.solvers.settings.SolverSettings` validates them; the kernels read them by
name.
"""

from collections import namedtuple

#: ``max_events``: events followed before a stretch is abandoned (EVENT_BUDGET);
#: ``max_map_iterations``: iterations of the period map (two-way) or of the reversal
#: circle map (one-way) searched for a cycle (NO_PERIODIC_ORBIT), int64;
#: ``velocity_tolerance``: the confidence half-width [1] of an irregular motion's
#: time-averaged velocity, in units of ``a / (2 pi f)``, at which its average stops,
#: float64; ``max_average_periods``: the periods it is averaged over at most (then
#: NOT_CONVERGED, AVERAGE_BUDGET), int64.
Budget = namedtuple("Budget", ("max_events", "max_map_iterations", "velocity_tolerance",
                               "max_average_periods"))
