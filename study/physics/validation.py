"""Checks on drive arrays shared by every public entry point."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.inputs import as_real_array
from study.units import HERTZ, METRE_PER_SECOND_SQUARED


def _checked(
    name: str, values: ArrayLike, units: str, lower: float, inclusive: bool
) -> NDArray[np.float64]:
    """``values`` as float64, finite and above ``lower``; else a ValueError naming the
    quantity, the first offending value, its index and the allowed range (a TypeError,
    :class:`study.inputs.InputTypeError`, for strings, booleans, complex numbers or
    dates)."""
    array = as_real_array(name, values, units)
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(array) | ((array < lower) if inclusive else (array <= lower))
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        allowed = f"finite and {'>=' if inclusive else '>'} {lower:g} {units}"
        raise ValueError(
            f"{name} must be {allowed}; got {float(array[bad].ravel()[0])!r} at index {index}"
        )
    return array


def as_frequency(f: ArrayLike) -> NDArray[np.float64]:
    """Validate drive frequencies: finite and > 0 [Hz].

    Raises
    ------
    ValueError
        Naming the first offending value, its index and the allowed range.
    TypeError
        For strings, booleans, complex numbers or dates
        (:class:`study.inputs.InputTypeError`).
    """
    return _checked("drive frequency f", f, HERTZ, 0.0, inclusive=False)


def as_acceleration(a: ArrayLike) -> NDArray[np.float64]:
    """Validate drive acceleration amplitudes: finite and >= 0 [m s-2].

    Raises
    ------
    ValueError
        Naming the first offending value, its index and the allowed range.
    TypeError
        For strings, booleans, complex numbers or dates
        (:class:`study.inputs.InputTypeError`).
    """
    return _checked("drive acceleration a", a, METRE_PER_SECOND_SQUARED, 0.0, inclusive=True)
