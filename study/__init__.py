"""study: parameter studies of vibration-driven stick-slip locomotion.

A soft structure with a resonant plate, on a vertically shaken table, walks forward
or backward by stick-slip (Barois, Boucherie, Tadrist & Kellay). See README.md.
"""

from study.analysis import frontier, minimum_threshold
from study.physics import (
    force_amplitudes,
    lift_off_acceleration,
    mode_response,
    normal_force,
    tangential_force,
    thresholds,
)
from study.solver import SolverSettings, SteadyState, steady_state, steady_velocity
from study.status import NonConvergence, Status
from study.structure import Structure
from study.version import VERSION as __version__

__all__ = [
    "NonConvergence",
    "SolverSettings",
    "Status",
    "SteadyState",
    "Structure",
    "__version__",
    "force_amplitudes",
    "frontier",
    "lift_off_acceleration",
    "minimum_threshold",
    "mode_response",
    "normal_force",
    "steady_state",
    "steady_velocity",
    "tangential_force",
    "thresholds",
]
