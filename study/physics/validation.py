"""Checks on drive arrays shared by every public entry point."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def _as_real_array(name: str, values: ArrayLike, units: str) -> NDArray[np.float64]:
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be real numbers in {units}, got {values!r}") from None
    bad = ~np.isfinite(array)
    if bad.any():
        raise ValueError(
            f"{name} must be finite [{units}]; got {array[bad].ravel()[0]!r} "
            f"at index {tuple(int(i) for i in np.argwhere(bad)[0])}"
        )
    return array


def as_frequency(f: ArrayLike) -> NDArray[np.float64]:
    """Validate drive frequencies: finite and > 0 [Hz].

    Raises
    ------
    ValueError
        Naming the first offending value and its index.
    """
    array = _as_real_array("drive frequency f", f, "Hz")
    bad = array <= 0
    if bad.any():
        raise ValueError(
            f"drive frequency f must be > 0 Hz; got {array[bad].ravel()[0]!r} "
            f"at index {tuple(int(i) for i in np.argwhere(bad)[0])}"
        )
    return array


def as_acceleration(a: ArrayLike) -> NDArray[np.float64]:
    """Validate drive acceleration amplitudes: finite and >= 0 [m s^-2].

    Raises
    ------
    ValueError
        Naming the first offending value and its index.
    """
    array = _as_real_array("drive acceleration a", a, "m s^-2")
    bad = array < 0
    if bad.any():
        raise ValueError(
            f"drive acceleration a must be >= 0 m s^-2; got {array[bad].ravel()[0]!r} "
            f"at index {tuple(int(i) for i in np.argwhere(bad)[0])}"
        )
    return array
