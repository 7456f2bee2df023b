"""The single-plate structure: a validated value object (paper eqs. 2-4)."""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

from study.model.inputs import (
    SuspectInputWarning,
    instance_of,
    radian_tilt_note,
    real_number,
    tilt_looks_like_radians,
)
from study.model.parameters import STRUCTURE
from study.model.units import spoken

__all__ = ["Structure", "check_structure", "tilt_warnings"]


def require_finite(name: str, value: object) -> float:
    """A structure parameter as a finite float, else an error naming it."""
    number = real_number(f"Structure parameter {name!r}", value, UNITS.get(name, ""))
    if not math.isfinite(number):
        raise ValueError(f"Structure parameter {name!r} must be finite, got {value!r}")
    return number


#: Whether a Structure built in this context warns of a tilt that looks like radians.
_WARN_OF_RADIANS: ContextVar[bool] = ContextVar("study_warn_of_radians", default=True)


@contextmanager
def tilt_warnings(enabled: bool) -> Iterator[None]:
    """Turn the radians warning of :class:`Structure` on or off within a ``with`` block.

    The readers of spec, fit and design files build the structures a file declares with
    the warning off: a file's tilts are in degree by its schema, and an optimiser
    exploring small tilts is not a mistake. Per thread (a context variable).
    """
    token = _WARN_OF_RADIANS.set(bool(enabled))
    try:
        yield
    finally:
        _WARN_OF_RADIANS.reset(token)


#: CF units of the parameters, for messages (:data:`study.model.parameters.STRUCTURE`).
UNITS = {name: p.units for name, p in STRUCTURE.items()}


@dataclass(frozen=True)
class Structure:
    """A rigid base carrying one tilted resonant plate (docs/theory/model.md).

    All forces in the model are per unit total mass, so the structure is fully
    described by its mode and its friction with the table.

    Parameters
    ----------
    f0 : float
        Resonance frequency of the plate's first mode [Hz], ``0 < f0 <= 1e6``.
    Q : float
        Quality factor of the plate's first mode [1], ``0.01 <= Q <= 1e6``.
    alpha : float
        Tilt of the plate from the horizontal [degree], ``-90 < alpha < 90``.
        ``alpha -> -alpha`` mirrors the motion.
    M : float
        Mass ratio ``m1 / m`` of the resonant mass to the total mass [1],
        ``0 < M <= 1``.
    cs : float
        Static friction coefficient with the table [1], ``1e-6 <= cs <= 100``.
    ck : float, optional
        Kinetic friction coefficient [1], ``1e-6 <= ck <= cs``; defaults to ``cs``
        (the paper's single coefficient ``c_f``).
    g : float, optional
        Gravitational acceleration [m s-2], ``0 < g <= 1000``; default 9.8 as in the
        paper.
    restitution : float, optional
        Normal coefficient of restitution of the base's impacts on the table [1],
        ``0 <= restitution <= 1``; default 0 (plastic). Read only by solvers that follow
        the structure past lift-off (``flight=True``).

    The ranges, units and defaults are declared in :mod:`study.model.parameters`, with
    the reason for each range.

    Raises
    ------
    TypeError
        If a parameter is not a real number (a string such as ``'30'``, a boolean, a
        complex number, ``None``): :class:`study.model.inputs.InputTypeError`, which is
        also a ValueError.
    ValueError
        If a parameter is not finite or is outside its allowed range; the message
        names the parameter, its value and the range.

    Warns
    -----
    study.SuspectInputWarning
        If ``0.05 <= |alpha| < 1.571`` degree (:data:`study.model.inputs.RADIAN_LIKE_TILT`,
        the numbers of 2.9 to 90 degree written in radians): a tilt that looks like an
        angle in radians (``alpha=0.785`` for 45 degree). The structure is built as
        given, in degree.
    """

    f0: float
    Q: float
    alpha: float
    M: float
    cs: float
    ck: float | None = STRUCTURE["ck"].default
    g: float = STRUCTURE["g"].default  # type: ignore[assignment]
    restitution: float = STRUCTURE["restitution"].default  # type: ignore[assignment]

    def __post_init__(self) -> None:
        values = {}
        for name, parameter in STRUCTURE.items():
            given = getattr(self, name)
            if given is None and parameter.at_most:  # ck: defaults to cs
                values[name] = values[parameter.at_most]
            else:
                values[name] = require_finite(name, given)
        for name, parameter in STRUCTURE.items():
            value = values[name]
            limit = values[parameter.at_most] if parameter.at_most else None
            if not parameter.inside(value) or (limit is not None and value > limit):
                raise ValueError(
                    f"Structure parameter {name!r} = {value!r} is out of range; allowed: "
                    f"{parameter.range_text(limit)}{spoken(parameter.units)}"
                )
        for name, value in values.items():
            object.__setattr__(self, name, value)
        if tilt_looks_like_radians(values["alpha"]) and _WARN_OF_RADIANS.get():
            warnings.warn(
                f"Structure parameter 'alpha' = {values['alpha']!r} degree: "
                f"{radian_tilt_note(values['alpha'])}", SuspectInputWarning, stacklevel=3)

    @property
    def omega0(self) -> float:
        """Angular resonance frequency ``2 pi f0`` [rad s-1]."""
        return 2.0 * math.pi * self.f0

    @property
    def alpha_rad(self) -> float:
        """Plate tilt [rad]."""
        return math.radians(self.alpha)

    def replace(self, **changes: float) -> Structure:
        """Return a copy with some parameters changed, validated again.

        ``ck`` is stored explicitly once built: pass it too when lowering ``cs``
        below it.
        """
        params = self.as_dict()
        params.update(changes)
        return Structure(**params)

    def as_dict(self) -> dict[str, float]:
        """Parameters as a plain dict (``ck`` explicit)."""
        return {name: getattr(self, name) for name in STRUCTURE}


def check_structure(structure: object, name: str = "structure") -> Structure:
    """``structure`` if it is a :class:`Structure`, else a TypeError
    (:class:`study.model.inputs.InputTypeError`) naming the argument."""
    return instance_of(name, structure, Structure, "a study.Structure")
