"""The event-driven integrator's mean velocity from a given state, for tests that check
a motion the exact solvers report against an independent integration."""

from __future__ import annotations

import numpy as np

from study.solvers.integrator import Schedule, simulate


def integrated_from(structure, f: float, a: float, state: np.ndarray, *, held: int = 240,
                    averaged: int = 120) -> float:
    """Mean velocity [m s-1] over the last ``averaged`` of ``held`` periods at ``(f, a)``
    [Hz, m s-2], by the integrator with flight from ``state`` ``(delta, delta', x, v, h,
    h')`` at phase 0."""
    times = np.array([(held - averaged) / f, held / f])
    trajectory = simulate(structure, Schedule(np.array([f]), np.array([a]),
                                              np.array([held / f])),
                          coupling="two-way", flight=True, initial_state=state,
                          output_times=times)
    assert trajectory.outcome == "completed"
    return float((trajectory.x[1] - trajectory.x[0]) * f / averaged)
