"""The budgets the exact kernels take, as one named tuple.

:class:`study.solvers.exact.SolverSettings` validates them; the kernels read them by
name.
"""

from collections import namedtuple

#: ``max_events``: events followed before a stretch is abandoned (EVENT_BUDGET);
#: ``max_map_iterations``: iterations of the period map (two-way) or of the reversal
#: circle map (one-way) searched for a cycle (NO_PERIODIC_ORBIT). Both int64.
Budget = namedtuple("Budget", ("max_events", "max_map_iterations"))
