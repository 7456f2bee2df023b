"""Checks on drive arrays shared by every public entry point."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.model.inputs import as_real_array
from study.model.parameters import DRIVE
from study.model.units import SECOND


def drive_maximum(name: str) -> float:
    """The largest drive ``f`` [Hz] or ``a`` [m s-2] allowed: 1e6 Hz and 1e6 m s-2
    (:data:`study.model.parameters.DRIVE`, which a study spec's sweep is held to too).
    Far beyond them ``(2 pi f)^2`` overflows (f > 2e153 Hz: NaN forces and a
    ZeroDivisionError in the integrator)."""
    return DRIVE[name].upper


#: Arrays of up to this many values are checked as Python floats: numpy's two
#: reductions cost about 3 us whatever the size, the floats about 0.1 us a value.
SMALL_ARRAY = 16


def _all_allowed(
    array: NDArray[np.float64], lower: float, inclusive: bool, upper: float,
) -> bool:
    """Whether every value of ``array`` is finite and within the bounds: the common case,
    answered without the floating-point error state (its context costs about a
    microsecond, as much as a small call's solve) and without temporaries: from the
    smallest and the largest value, once they are known finite. A scalar is compared
    as a Python float."""
    if array.ndim == 0:
        value = float(array)
        return (math.isfinite(value) and (value >= lower if inclusive else value > lower)
                and value <= upper)
    if array.size <= SMALL_ARRAY:
        values = array.ravel().tolist()
        if not values:
            return True
        # A NaN or an infinity makes the sum NaN or infinite (so may finite values
        # that overflow: those are checked the long way, which finds nothing); Python's
        # min and max are exact on finite values.
        if not math.isfinite(sum(values)):
            return False
        low, high = min(values), max(values)
    else:
        # numpy's min and max propagate a NaN, and an infinity is one of them (the
        # ufuncs' reduce: the methods add a Python layer).
        low = float(np.minimum.reduce(array, axis=None))
        high = float(np.maximum.reduce(array, axis=None))
        if not (math.isfinite(low) and math.isfinite(high)):
            return False
    return (low >= lower if inclusive else low > lower) and high <= upper


def _checked(
    name: str, values: ArrayLike, units: str, lower: float, inclusive: bool,
    upper: float = np.inf,
) -> NDArray[np.float64]:
    """``values`` as float64, finite, above ``lower`` and at most ``upper``; else a
    ValueError naming the quantity, the first offending value, its index and the
    allowed range (a TypeError, :class:`study.model.inputs.InputTypeError`, for strings,
    booleans, complex numbers or dates)."""
    array = as_real_array(name, values, units)
    if _all_allowed(array, lower, inclusive, upper):
        return array
    with np.errstate(invalid="ignore"):
        bad = (~np.isfinite(array) | ((array < lower) if inclusive else (array <= lower))
               | (array > upper))
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        allowed = (f"finite [{units}]" if lower == -np.inf
                   else f"finite and {'>=' if inclusive else '>'} {lower:g} {units}")
        if upper < np.inf:
            allowed += f" and <= {upper:g} {units}"
        raise ValueError(
            f"{name} must be {allowed}; got {float(array[bad].ravel()[0])!r} at index {index}"
        )
    return array


def as_frequency(f: ArrayLike) -> NDArray[np.float64]:
    """Validate drive frequencies: finite, > 0 and <= 1e6 [Hz] (:func:`drive_maximum`).

    Raises
    ------
    ValueError
        Naming the first offending value, its index and the allowed range.
    TypeError
        For strings, booleans, complex numbers or dates
        (:class:`study.model.inputs.InputTypeError`).
    """
    limits = DRIVE["f"]
    return _checked("drive frequency f", f, limits.units, limits.lower,
                    inclusive=not limits.lower_open, upper=limits.upper)


def as_acceleration(a: ArrayLike) -> NDArray[np.float64]:
    """Validate drive acceleration amplitudes: finite, >= 0 and <= 1e6 [m s-2]
    (:func:`drive_maximum`).

    Raises
    ------
    ValueError
        Naming the first offending value, its index and the allowed range.
    TypeError
        For strings, booleans, complex numbers or dates
        (:class:`study.model.inputs.InputTypeError`).
    """
    limits = DRIVE["a"]
    return _checked("drive acceleration a", a, limits.units, limits.lower,
                    inclusive=not limits.lower_open, upper=limits.upper)


def as_time(t: ArrayLike) -> NDArray[np.float64]:
    """Validate times: finite [s] (any sign).

    Raises
    ------
    ValueError
        Naming the first value that is not finite and its index.
    TypeError
        For strings, booleans, complex numbers or dates
        (:class:`study.model.inputs.InputTypeError`).
    """
    return _checked("time t", t, SECOND, -np.inf, inclusive=True)
