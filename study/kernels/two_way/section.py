"""The phase-0 Poincare section of the motion a drive point reports.

A bifurcation diagram plots, against a swept drive parameter, the states the motion
takes at one phase of each drive period: one point for an orbit of period 1, ``p``
points for a cycle of ``p`` periods, a closed curve's worth of scattered points for a
quasi-periodic motion and a cloud for a chaotic one. From the state at phase 0 that
:mod:`~study.kernels.two_way.points` reports (the orbit's fixed point, or an irregular
motion's last iterate) the period map is followed ``count`` periods without its
Jacobian, and each state at phase 0 is kept. On an attractor the next ``count``
periods are as good as the last ``count``: the motion is already on it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from study.kernels.structure_vector import LIFT_OFF_LAW
from study.kernels.two_way.flight import (
    N_FLIGHT_ACC,
    N_ROWS,
    N_STATE,
    FlightRecord,
    flight_row,
    fly,
)
from study.kernels.two_way.modes import N_MODE, TWO_PI, DrivePoint, mode_row
from study.kernels.two_way.orbit import N_ACC, RUN_OK, PassRecord, run


@njit(cache=True, nogil=True, error_model="numpy")
def follow_section(structure, omega, a, state, max_events, out):
    """The states at phase 0 of ``out.shape[0]`` consecutive drive periods of the motion
    through ``state`` at phase 0 (``(delta [m], delta' [m s-1], v [m s-1], h [m],
    h' [m s-1])``, as a point's solve reports it) at ``omega`` [rad s-1], ``a`` [m s-2]
    (``structure`` the structure vector): ``out[k]`` holds the state after ``k``
    periods. NaN for a state that is not finite (no motion to follow), and from a
    period that does not end within ``max_events`` events (or ends in the paradox) on.
    Without the lift-off law ``flight`` the motion stays on the table (``h = h' = 0``)."""
    out[:, :] = np.nan
    for i in range(N_STATE):
        if not np.isfinite(state[i]):
            return
    table = np.zeros((N_ROWS, N_MODE))
    for mode in range(3):
        mode_row(structure, omega, a, table, mode)
    flying = structure[LIFT_OFF_LAW] != 0.0
    if flying:
        flight_row(structure, table)
    point = DrivePoint(structure, table, omega, a)
    z = state.copy()
    period = TWO_PI / omega
    flight_record = FlightRecord(np.zeros(N_FLIGHT_ACC), np.eye(N_STATE),
                                 np.empty((N_STATE, N_STATE)), np.empty((N_STATE, N_STATE)),
                                 np.zeros(2))
    contact = z[:3]
    contact_record = PassRecord(np.zeros(N_ACC), np.eye(3), np.zeros((3, 3)), np.zeros(2))
    for k in range(out.shape[0]):
        out[k, :] = z
        if k == out.shape[0] - 1:
            break
        if flying:
            flight_record.acc[:] = 0.0
            flag = fly(point, z, 0.0, period, flight_record, False, False, max_events)
        else:
            contact_record.acc[:] = 0.0
            flag = run(point, contact, 0.0, period, contact_record, False, -1.0, max_events)
        if flag != RUN_OK:
            return


@njit(cache=True, nogil=True, error_model="numpy")
def follow_sections(structure, omega, a, states, max_events, out):
    """:func:`follow_section` at each point: ``omega``, ``a`` and ``states`` (``(n,
    5)``) per point, ``out`` ``(n, periods, 5)``."""
    for p in range(omega.shape[0]):
        follow_section(structure, omega[p], a[p], states[p], max_events, out[p])
