"""Closed-form physics of the single-plate model, pure numpy (docs/theory/model.md)."""

from study.physics.forces import (
    force_amplitudes,
    lift_off_acceleration,
    mode_response,
    normal_force,
    release_amplitudes,
    slip_amplitudes,
    tangential_force,
    thresholds,
)
from study.physics.validation import as_acceleration, as_frequency

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
