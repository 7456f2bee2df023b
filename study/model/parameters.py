"""The parameter table: every structure, mass-model and drive parameter, declared once.

Each :class:`Parameter` names a parameter, its symbol, its CF units, its allowed range
and the reason for it, its long name, its default and the paper's value with the
digits the paper states it with. Everything else derives from this table:

- :class:`study.Structure` (its checks, defaults, units and messages);
- the parameter definitions of the study, fit and design spec schemas
  (:func:`schema_definition`; ``make schemas`` writes the files, a test checks them);
- the parameter lists of the spec layer (:mod:`study.studies.spec`), of fits and
  of designs (:mod:`study.analyses.fit`, :mod:`study.analyses.design`);
- the paper's structure and the tolerance of :func:`study.model.paper.is_paper_structure`
  (half a unit of the last stated digit, :attr:`Parameter.paper_tolerance`);
- the drive limits of every public function (:mod:`study.model.drive`);
- the docs' parameter table (:func:`markdown_table`).

Adding a parameter is one :class:`Parameter` in its group, :data:`STRUCTURE`,
:data:`MASS` or :data:`DRIVE` (and its physics).
SI units inside, angles in degree.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from study.model.units import DEGREE, DIMENSIONLESS, HERTZ, KILOGRAM, METRE_PER_SECOND_SQUARED

__all__ = [
    "DRIVE",
    "MASS",
    "PARAMETERS",
    "STRUCTURE",
    "Parameter",
    "markdown_table",
    "number",
    "schema_definition",
    "schema_properties",
    "units_list",
]


def number(value: float) -> str:
    """A bound as messages and descriptions write it: ``1e6``, ``1e-6``, ``0.01``, ``90``."""
    text = f"{value:g}"
    mantissa, _, exponent = text.partition("e")
    return f"{mantissa}e{int(exponent)}" if exponent else text


@dataclass(frozen=True)
class Parameter:
    """One parameter: its name, units, allowed range and where it comes from.

    Attributes
    ----------
    name : str
        The key in specs, the argument of :class:`study.Structure`, the coordinate name.
    units : str
        CF units (:mod:`study.model.units`).
    long_name : str
        What it is, as a ``long_name`` attribute says it.
    lower, upper : float
        The allowed range [units].
    lower_open, upper_open : bool
        Whether ``lower`` (``upper``) itself is excluded.
    symbol : str
        Its symbol, in LaTeX (the docs write it ``$symbol$``).
    reason : str
        Why the range is what it is.
    default : float or None
        The value when none is given; None when it must be given (or, with
        ``default_text``, when it follows from another parameter).
    default_text : str
        The default in words when it is not a number (``"cs"`` for ``ck``).
    at_most : str
        Another parameter this one may not exceed (``"cs"`` for ``ck``), else ``""``.
    paper : str
        The paper's value as the paper writes it (``"14.44"``), else ``""``.
    """

    name: str
    units: str
    long_name: str
    lower: float
    upper: float
    lower_open: bool = True
    upper_open: bool = True
    symbol: str = field(default="", kw_only=True)
    reason: str = field(default="", kw_only=True)
    default: float | None = field(default=None, kw_only=True)
    default_text: str = field(default="", kw_only=True)
    at_most: str = field(default="", kw_only=True)
    paper: str = field(default="", kw_only=True)

    def allowed(self) -> str:
        """The range in words, as messages say it: ``"0 < M <= 1"`` (:meth:`range_text`)."""
        return self.range_text()

    def inside(self, value: float) -> bool:
        """Whether ``value`` is in the range (not checking :attr:`at_most`)."""
        low = value > self.lower if self.lower_open else value >= self.lower
        high = value < self.upper if self.upper_open else value <= self.upper
        return bool(low and high)

    def range_text(self, at_most: float | None = None) -> str:
        """The range as a chained inequality: ``"0.01 <= Q <= 1e6"``; with ``at_most``
        (the value of :attr:`at_most`): ``"1e-6 <= ck <= cs (cs = 0.25)"``."""
        low = f"{number(self.lower)} {'<' if self.lower_open else '<='} {self.name}"
        if self.at_most:
            high = f" <= {self.at_most}"
            if at_most is not None:
                high += f" ({self.at_most} = {at_most!r})"
        elif math.isinf(self.upper):
            high = ""
        else:
            high = f" {'<' if self.upper_open else '<='} {number(self.upper)}"
        return low + high

    @property
    def paper_value(self) -> float | None:
        """The paper's value [units], None when the paper gives none."""
        return float(self.paper) if self.paper else None

    @property
    def paper_tolerance(self) -> float | None:
        """Half a unit of the last digit the paper states (``"14.44"``: 0.005)."""
        if not self.paper:
            return None
        _, _, decimals = self.paper.partition(".")
        return 0.5 / 10 ** len(decimals)


#: The bounds shared by the drive and the mode's frequency [Hz], the drive
#: acceleration [m s-2] and the masses [kg].
_LARGEST = 1e6
_FREQUENCY_REASON = ("a frequency is positive; 1e6 Hz is far above any plate's mode and far "
                     "below where (2 pi f)^2 overflows, near 2e153 Hz")
_FRICTION_REASON = ("1e-6 is far below any measured dry or lubricated friction (near "
                    "cs = 1e-308, sin(alpha)/cs overflows); 100 is far above any")
_MASS_REASON = "a mass is positive; 1e6 kg bounds a table-top structure many times over"


def _by_name(*parameters: Parameter) -> dict[str, Parameter]:
    return {p.name: p for p in parameters}


#: The structure's parameters, in the order of :class:`study.Structure`'s arguments (the
#: ``[structure]`` table of specs).
STRUCTURE: dict[str, Parameter] = _by_name(
    Parameter("f0", HERTZ, "resonance frequency of the plate's first mode", 0.0, _LARGEST,
              upper_open=False, symbol="f_0", reason=_FREQUENCY_REASON, paper="14.44"),
    Parameter("Q", DIMENSIONLESS, "quality factor of the plate's first mode", 0.01, _LARGEST,
              lower_open=False, upper_open=False, symbol="Q",
              reason=("below 0.5 the mode is overdamped; below 0.01 the time integrator's "
                      "steps follow the mode's relaxation time Q / (pi f0): at Q = 1e-4 a "
                      "point took 0.6 s, at 1e-6 minutes; transients last about Q periods"),
              paper="17.5"),
    Parameter("alpha", DEGREE, "tilt of the plate from the horizontal", -90.0, 90.0,
              symbol="\\alpha",
              reason=("a plate tilted either way from the horizontal, short of vertical; "
                      "alpha -> -alpha mirrors the motion"),
              paper="64"),
    Parameter("M", DIMENSIONLESS, "mass ratio m1/m", 0.0, 1.0, upper_open=False, symbol="M",
              reason="the resonant mass m1 is a part of the total mass m", paper="0.08"),
    Parameter("cs", DIMENSIONLESS, "static friction coefficient", 1e-6, 100.0,
              lower_open=False, upper_open=False, symbol="c_s", reason=_FRICTION_REASON,
              paper="0.25"),
    Parameter("ck", DIMENSIONLESS, "kinetic friction coefficient", 1e-6, 100.0,
              lower_open=False, upper_open=False, symbol="c_k",
              reason="as cs; sliding friction is at most the static friction",
              default_text="cs", at_most="cs", paper="0.25"),
    Parameter("g", METRE_PER_SECOND_SQUARED, "gravitational acceleration", 0.0, 1000.0,
              upper_open=False, symbol="g",
              reason="gravity presses the base on the table; 1000 m s-2 is 100 Earths",
              default=9.8, paper="9.8"),
    Parameter("restitution", DIMENSIONLESS,
              "normal coefficient of restitution of the base's impacts on the table", 0.0, 1.0,
              lower_open=False, upper_open=False, symbol="e",
              reason=("Newton's law h'+ = -e h'-: 0 is a plastic landing, 1 an elastic "
                      "one; read only where the structure flies (flight = true)"),
              default=0.0),
)
#: The mass model's parameters (the ``[structure.mass]`` table of specs:
#: ``M = m1 / (m0 + m_add)``).
MASS: dict[str, Parameter] = _by_name(
    Parameter("m0", KILOGRAM, "mass of the bare structure", 0.0, _LARGEST, upper_open=False,
              symbol="m_0", reason=_MASS_REASON),
    Parameter("m1", KILOGRAM, "resonant (modal) mass", 0.0, _LARGEST, upper_open=False,
              symbol="m_1", reason=_MASS_REASON),
    Parameter("m1_fraction", DIMENSIONLESS,
              "resonant mass over the bare structure's mass, m1/m0", 0.0, 1.0,
              upper_open=False, symbol="m_1/m_0",
              reason="the resonant mass is a part of the bare structure"),
    Parameter("m_add", KILOGRAM, "added non-resonant mass", 0.0, _LARGEST, lower_open=False,
              upper_open=False, symbol="m_\\mathrm{add}",
              reason="a load is a mass added, none at 0", default=0.0),
)
#: The drive's parameters (the ``[sweep]`` f and a of specs, the f and a of every public
#: function).
DRIVE: dict[str, Parameter] = _by_name(
    Parameter("f", HERTZ, "drive frequency", 0.0, _LARGEST, upper_open=False, symbol="f",
              reason=_FREQUENCY_REASON),
    Parameter("a", METRE_PER_SECOND_SQUARED, "drive acceleration amplitude", 0.0, _LARGEST,
              lower_open=False, upper_open=False, symbol="a",
              reason=("an amplitude is not negative; 1e6 m s-2 is 1e5 g, far beyond any "
                      "shaker and far below overflow")),
)
#: Every parameter, declared once (above): the structure's, the mass model's, the drive's.
PARAMETERS: dict[str, Parameter] = {**STRUCTURE, **MASS, **DRIVE}


def _json_number(value: float) -> float | int:
    """An integral bound as a JSON integer (``1000000``, not ``1000000.0``)."""
    return int(value) if float(value).is_integer() else value


def schema_definition(name: str) -> dict[str, Any]:
    """A parameter's JSON schema: its range and a description with units and reason.

    Parameters
    ----------
    name : str
        A key of :data:`PARAMETERS`.

    Returns
    -------
    dict
        ``{"type": "number", <bounds>, "description": ...}``.
    """
    p = PARAMETERS[name]
    definition: dict[str, Any] = {"type": "number"}
    definition["exclusiveMinimum" if p.lower_open else "minimum"] = _json_number(p.lower)
    definition["exclusiveMaximum" if p.upper_open else "maximum"] = _json_number(p.upper)
    default = p.default_text or ("" if p.default is None else number(p.default))
    definition["description"] = (
        f"{p.long_name} [{p.units}], {p.range_text()}"
        + (f" and <= {number(p.upper)}" if p.at_most else "")
        + f" ({p.reason})" + (f"; default {default}" if default else "")
    )
    return definition


def schema_properties(names: Iterable[str]) -> dict[str, Any]:
    """JSON schema properties: a :func:`schema_definition` per parameter named."""
    return {name: schema_definition(name) for name in names}


def units_list(names: Iterable[str]) -> str:
    """Parameters with their units, as a schema's description lists them:
    ``"f0 [Hz], Q, alpha [degree]"``."""
    return ", ".join(name + ("" if PARAMETERS[name].units == DIMENSIONLESS
                             else f" [{PARAMETERS[name].units}]") for name in names)


def markdown_table(names: Iterable[str] | None = None) -> str:
    """The parameter table in Markdown (MyST), for the docs.

    Parameters
    ----------
    names : iterable of str, optional
        The parameters, in order (default: all of :data:`PARAMETERS`).

    Returns
    -------
    str
        A header, a rule and a row per parameter: name, symbol, units, allowed range
        and its reason, default, the paper's value.
    """
    rows = ["| name | symbol | units | allowed range (why) | default | paper |",
            "|---|---|---|---|---|---|"]
    for name in PARAMETERS if names is None else names:
        p = PARAMETERS[name]
        default = p.default_text or ("-" if p.default is None else number(p.default))
        cells = [f"`{p.name}`", f"${p.symbol}$", f"`{p.units}`",
                 f"`{p.range_text()}` ({p.reason})".replace("|", "\\|"),
                 default if not p.default_text else f"`{default}`", p.paper or "-"]
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows) + "\n"
