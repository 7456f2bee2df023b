"""The kernels' mode table of a drive point with flight, for tests that call the flight
kernels directly."""

from __future__ import annotations

import numpy as np

from study.kernels.two_way import flight
from study.kernels.two_way.modes import N_MODE, mode_row


def flight_table(vector: np.ndarray, omega: float, a: float) -> np.ndarray:
    """The mode table (``flight.N_ROWS`` x ``N_MODE``) at ``omega`` [rad s-1], ``a``
    [m s-2] for the structure vector ``vector`` (two-way, flight): the three contact rows
    and the flight row, as the solver fills them."""
    table = np.zeros((flight.N_ROWS, N_MODE))
    for row in range(3):
        mode_row(vector, omega, a, table, row)
    flight.flight_row(vector, table)
    return table
