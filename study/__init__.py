"""study: parameter studies of vibration-driven stick-slip locomotion.

A soft structure with a resonant plate, on a vertically shaken table, walks forward
or backward by stick-slip (Barois, Boucherie, Tadrist & Kellay). See README.md.
"""

from study.analysis import frontier, minimum_threshold
from study.api import run
from study.physics import (
    force_amplitudes,
    lift_off_acceleration,
    mode_response,
    normal_force,
    tangential_force,
    thresholds,
)
from study.solver import SolverSettings, SteadyState, steady_state, steady_velocity
from study.specfile import SpecError
from study.status import NonConvergence, Status
from study.structure import Structure
from study.validate import ResultError, open_result
from study.version import VERSION as __version__

__all__ = [
    "NonConvergence",
    "ResultError",
    "SolverSettings",
    "SpecError",
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
    "open_result",
    "run",
    "steady_state",
    "steady_velocity",
    "tangential_force",
    "thresholds",
]
