"""Closed-form physics of the single-plate model, pure numpy (docs/theory/model.md)."""

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
