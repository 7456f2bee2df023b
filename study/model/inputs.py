"""Numbers given to the public functions: refused when they are surely mistakes.

A string, a boolean, a complex number or a date where a physical quantity is expected
is refused with a :class:`InputTypeError` naming the argument (``Q='30'`` is not
read as 30). A value that is allowed but looks like a mistake gives a
:class:`SuspectInputWarning`: a plate tilt between :data:`RADIAN_LIKE_TILT` degrees
looks like an angle in radians; in a spec, a drop from above :data:`SUSPECT_DROP_HEIGHT`
looks like millimetres, and drive frequencies far above the resonance like angular
frequencies (:func:`drop_height_note`, :func:`frequency_axis_note`).
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.model.units import DIMENSIONLESS

__all__ = [
    "FAR_ABOVE_RESONANCE",
    "RADIAN_LIKE_FREQUENCY",
    "RADIAN_LIKE_TILT",
    "RESONANT_BAND",
    "SUSPECT_DROP_HEIGHT",
    "SUSPECT_DROP_HOPS",
    "InputTypeError",
    "StudyWarning",
    "SuspectInputWarning",
    "as_real_array",
    "bounded_integer",
    "bounded_number",
    "drop_height_note",
    "frequency_axis_note",
    "instance_of",
    "natural_hop",
    "radian_like_range",
    "radian_tilt_note",
    "real_number",
    "tilt_looks_like_radians",
]


class StudyWarning(UserWarning):
    """Base class of the warnings ``study`` gives (filter them all with this class)."""


class SuspectInputWarning(StudyWarning):
    """An allowed input that looks like a mistake (e.g. a tilt given in radians)."""


class InputTypeError(TypeError, ValueError):
    """A value of the wrong type for a number (a string, a boolean, a complex number,
    a date). A :class:`TypeError`; also a :class:`ValueError`, so that code catching
    the refusal of a bad parameter value catches it too."""


#: Tilts [degree] whose magnitude lies in ``[low, high)`` look like an angle in radians
#: (0.05 rad = 2.9 degree to 90 degree = pi/2 rad): a structure given one warns. Below
#: ``low`` a tilt is taken as the near-zero limit it looks like (the hard cases use
#: 1e-6 and 0.01 degree); 0 is exact in either unit.
RADIAN_LIKE_TILT = (0.05, math.pi / 2)


def tilt_looks_like_radians(alpha: float) -> bool:
    """Whether a tilt ``alpha`` [degree] lies in :data:`RADIAN_LIKE_TILT` (in magnitude)."""
    low, high = RADIAN_LIKE_TILT
    return low <= abs(alpha) < high


def radian_tilt_note(alpha: float) -> str:
    """Why a tilt ``alpha`` [degree] that :func:`tilt_looks_like_radians` is suspect, and
    the value in degree it would be if it were radians: the one text of the warning of
    :class:`study.Structure` and of a spec's tilt (:mod:`study.studies.spec`)."""
    return (f"{radian_like_range()} looks like an angle in radians; alpha is in degree "
            f"(for {alpha!r} rad give alpha = {math.degrees(alpha):.6g})")


def radian_like_range() -> str:
    """:data:`RADIAN_LIKE_TILT` in words, in degree throughout: ``"a tilt of 0.05 to
    1.571 degree (the numbers of 2.865 to 90 degree written in radians)"``."""
    low, high = RADIAN_LIKE_TILT
    return (f"a tilt of {low:g} to {high:.4g} degree (the numbers of {math.degrees(low):.4g} "
            f"to {math.degrees(high):.4g} degree written in radians)")


#: A drop height [m] above which a start looks like a height given in millimetres: a
#: fall from 0.1 m lands at 1.4 m s-1, some 20 times the table's speed at a = g, 14 Hz
#: (the drops the package draws itself are 0.1 to 5 mm).
SUSPECT_DROP_HEIGHT = 0.1
#: A drop height looks mistaken above this many natural hop scales ``g / (2 pi f)^2``
#: of the study's lowest drive frequency (the table's displacement at a = g; bouncing
#: hops are a few of them: 0.5 to 4 at M = 0.99, 12-17 Hz).
SUSPECT_DROP_HOPS = 100.0
#: Drive frequencies all above this many times the resonance f0 look like angular
#: frequencies [rad s-1] when ``f / (2 pi)`` comes within :data:`RESONANT_BAND` of f0.
RADIAN_LIKE_FREQUENCY = 2.0
#: Drive frequencies all above this many times f0 look mistaken whatever they are: the
#: mode's gain there is below 1 / (5^2 - 1) = 1/24 of the table's motion.
FAR_ABOVE_RESONANCE = 5.0
#: Within 20 % of the resonance: where ``f / (2 pi)`` of frequencies all above
#: :data:`RADIAN_LIKE_FREQUENCY` f0 lands when they are angular ones of a study around f0.
RESONANT_BAND = (0.8, 1.25)


def natural_hop(f: float, g: float) -> float:
    """The natural hop scale ``g / (2 pi f)^2`` [m] at drive frequency ``f`` [Hz] and
    gravity ``g`` [m s-2]: how far the table moves at an acceleration of g."""
    return g / (2.0 * math.pi * f) ** 2


def drop_height_note(height: float, f_min: float, g: float) -> str | None:
    """Why a drop from ``height`` [m] onto a table driven from ``f_min`` [Hz] up looks
    like a height in millimetres (above :data:`SUSPECT_DROP_HEIGHT` or
    :data:`SUSPECT_DROP_HOPS` natural hop scales at ``f_min``), or None: the text of a
    spec's warning (:mod:`study.studies.spec`)."""
    hop = natural_hop(f_min, g)
    if height <= SUSPECT_DROP_HEIGHT and height <= SUSPECT_DROP_HOPS * hop:
        return None
    return (f"{height / hop:.3g} times the natural hop scale g / (2 pi f)^2 = "
            f"{hop * 1e3:.3g} mm of the lowest drive frequency ({f_min:g} Hz)"
            + (f" and above {SUSPECT_DROP_HEIGHT:g} m" if height > SUSPECT_DROP_HEIGHT else "")
            + f": it looks like a height in millimetres; the height is in metres (for "
            f"{height:g} mm give drop = {height / 1e3:g})")


def frequency_axis_note(f_min: float, f_max: float, f0: float) -> str | None:
    """Why drive frequencies ``f_min`` .. ``f_max`` [Hz] look mistaken for a resonance
    ``f0`` [Hz], or None: every one above :data:`RADIAN_LIKE_FREQUENCY` f0 while ``f /
    (2 pi)`` reaches :data:`RESONANT_BAND` (angular frequencies given for f), or every
    one above :data:`FAR_ABOVE_RESONANCE` f0."""
    low, high = RESONANT_BAND
    hz_min, hz_max = f_min / (2.0 * math.pi), f_max / (2.0 * math.pi)
    if f_min > RADIAN_LIKE_FREQUENCY * f0 and hz_max >= low * f0 and hz_min <= high * f0:
        return (f"every drive frequency is above {RADIAN_LIKE_FREQUENCY:g} times the "
                f"resonance f0 = {f0:g} Hz, and f / (2 pi) = {hz_min:.4g} .. {hz_max:.4g} Hz "
                "would come within 20 % of it: they look like angular frequencies in rad "
                "s-1; f is in Hz (f = omega / (2 pi))")
    if f_min > FAR_ABOVE_RESONANCE * f0:
        return (f"every drive frequency is above {FAR_ABOVE_RESONANCE:g} times the "
                f"resonance f0 = {f0:g} Hz, where the mode's gain is below 1/"
                f"{FAR_ABOVE_RESONANCE ** 2 - 1:g} of the table's motion: f is in Hz, f0 "
                "too")
    return None


def _kind_name(value: Any) -> str:
    if isinstance(value, str | bytes):
        return "a string"
    if isinstance(value, bool | np.bool_):
        return "a boolean"
    if isinstance(value, complex | np.complexfloating):
        return "a complex number"
    if value is None:
        return "nothing (None)"
    if isinstance(value, np.datetime64):
        return "a date"
    if isinstance(value, np.timedelta64):
        return "a time span"
    return f"a {type(value).__name__}"


def real_number(name: str, value: Any, units: str = "") -> float:
    """``value`` as a float if it is a real number (an int or float, numpy's too).

    Parameters
    ----------
    name : str
        The parameter, for the message.
    value : object
        What was given.
    units : str
        CF units of the parameter, for the message.

    Raises
    ------
    InputTypeError
        For anything but a real number: strings (even ``'30'``), booleans, complex
        numbers, ``None``, arrays of more than one value.
    """
    # numpy registers its time spans as numbers: a time span is not a physical quantity.
    is_real = isinstance(value, numbers.Real) and not isinstance(
        value, bool | np.bool_ | np.timedelta64 | np.datetime64)
    if not is_real and isinstance(value, np.ndarray) and value.ndim == 0:
        is_real = value.dtype.kind in "iuf"
    if not is_real:
        where = f" [{units}]" if units not in ("", DIMENSIONLESS) else ""
        raise InputTypeError(
            f"{name} must be a real number{where}, got {_kind_name(value)}: {value!r}")
    return float(value)


def as_real_array(name: str, values: Any, units: str = "") -> NDArray[np.float64]:
    """``values`` as a float64 array if they are real numbers (no other check).

    Parameters
    ----------
    name : str
        The argument, for the message.
    values : array_like
        A number, a sequence of numbers or an array of integers or floats.
    units : str
        CF units of the argument, for the message.

    Raises
    ------
    InputTypeError
        For strings, booleans, complex numbers, dates or times, ``None`` or other
        objects, alone or inside a sequence.
    """
    if type(values) is float:  # the common scalar: nothing to inspect
        return np.array(values)
    where = f" [{units}]" if units not in ("", DIMENSIONLESS) else ""
    try:
        array = np.asarray(values)
    except (TypeError, ValueError) as err:  # ragged sequences
        raise InputTypeError(f"{name} must be real numbers{where}: {err}") from None
    kind = array.dtype.kind
    if kind == "O":
        for index, item in np.ndenumerate(array):
            try:
                real_number(name, item, units)
            except InputTypeError:
                raise InputTypeError(
                    f"{name} must be real numbers{where}, got {_kind_name(item)} at index "
                    f"{index}: {_short(item)}") from None
    elif kind not in "iuf":
        described = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "strings",
                     "M": "dates", "m": "time spans"}.get(kind, f"{array.dtype} values")
        raise InputTypeError(
            f"{name} must be real numbers{where}, got {described}: {_short(values)}")
    return np.asarray(array, dtype=np.float64)


def bounded_number(name: str, value: Any, units: str = "", *, lower: float = -math.inf,
                   upper: float = math.inf, lower_open: bool = False,
                   upper_open: bool = False) -> float:
    """``value`` as a finite float within ``[lower, upper]`` (ends open as asked).

    Raises
    ------
    InputTypeError
        For anything but a real number (see :func:`real_number`).
    ValueError
        For NaN, an infinity or a value outside the range; the message names the
        argument, its value and the allowed range.
    """
    number = real_number(name, value, units)
    below = number <= lower if lower_open else number < lower
    above = number >= upper if upper_open else number > upper
    if not math.isfinite(number) or below or above:
        where = f" {units}" if units not in ("", DIMENSIONLESS) else ""
        ends = []
        if lower > -math.inf:
            ends.append(f"{'>' if lower_open else '>='} {lower:g}{where}")
        if upper < math.inf:
            ends.append(f"{'<' if upper_open else '<='} {upper:g}{where}")
        allowed = " and ".join(["finite", *ends])
        raise ValueError(f"{name} = {value!r} is out of range; allowed: {allowed}")
    return number


def bounded_integer(name: str, value: Any, lower: int = 1,
                    upper: int = np.iinfo(np.int64).max) -> int:
    """``value`` as an int within ``[lower, upper]`` (an int or numpy integer, not a bool).

    The default ``upper`` is the largest count the numba kernels take (int64).

    Raises
    ------
    InputTypeError
        For anything but an integer (a float, even ``5.0``, a string, a boolean).
    ValueError
        For a value outside the range, naming the argument and the range.
    """
    if isinstance(value, bool | np.bool_ | np.timedelta64) or not isinstance(
            value, numbers.Integral):
        raise InputTypeError(f"{name} must be an integer, got {_kind_name(value)}: "
                             f"{_short(value)}")
    number = int(value)
    if not lower <= number <= upper:
        raise ValueError(f"{name} = {number!r} is out of range; allowed: >= {lower} and "
                         f"<= {upper}")
    return number


def instance_of(name: str, value: Any, kind: type, described: str) -> Any:
    """``value`` if it is a ``kind``, else an :class:`InputTypeError` naming the argument
    and what it must be (``described``, e.g. ``"a study.Structure"``)."""
    if not isinstance(value, kind):
        raise InputTypeError(f"{name} must be {described}, got {_kind_name(value)}: "
                             f"{_short(value)}")
    return value


def _short(values: Any) -> str:
    text = repr(values)
    return text if len(text) <= 80 else text[:77] + "..."
