"""The model stage: the parameter table, the structure, closed-form physics in plain numpy,
contact laws, status codes, units and the paper's values (docs/theory/model.md).

This face re-exports the closed-form physics of the single-plate model.
"""

from study.model.drive import as_acceleration, as_frequency
from study.model.forces import (
    force_amplitudes,
    lift_off_acceleration,
    mode_response,
    normal_force,
    release_amplitudes,
    slip_amplitudes,
    tangential_force,
    thresholds,
)

__all__ = [
    "as_acceleration",
    "as_frequency",
    "force_amplitudes",
    "lift_off_acceleration",
    "mode_response",
    "normal_force",
    "release_amplitudes",
    "slip_amplitudes",
    "tangential_force",
    "thresholds",
]
