"""Starts as named pieces: the state each point's motion begins from.

A start is a physical protocol (docs/theory/starts.md): where the base and the mode are
when the drive takes hold. Each kind is declared once here (:data:`START_KINDS`): its
name, what it says, its parameters (units and allowed range), what the model needs to
take it (two-way coupling, flight), the observables it cannot stand beside, and its
kernel initial state, as the contact laws are declared in :mod:`study.model.contact`.
Everything else follows from the declarations: the values a start takes in the API and
in a spec (:func:`as_start`), the spec schema (:func:`spec_schema`), the result file's
attributes and their schema (:func:`start_attributes`, :func:`result_schema`), the one
refusal wording of a start the model cannot take (:func:`refusal`), the TOML a spec
writes (:func:`toml_value`), the kernels' initial state (:func:`kernel_fields`) and
the docs' table (:func:`markdown_table`).

A start without parameters is its name (``"release"``); one with parameters is a
frozen value (:class:`Drop`), written in a spec as a table keyed by the kind's name
(``{ drop = 0.002, phase = 0.25 }``).

Pure Python: no numba, no solver.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from typing import Any

from study.model.inputs import InputTypeError
from study.model.units import DIMENSIONLESS, METRE

__all__ = [
    "DEFAULT_START",
    "START_ALLOWED",
    "START_KINDS",
    "START_NAMES",
    "START_TYPES",
    "Drop",
    "StartKind",
    "StartParameter",
    "as_start",
    "canonical",
    "kernel_fields",
    "kind_of",
    "markdown_table",
    "refusal",
    "result_schema",
    "spec_schema",
    "start_attributes",
    "start_label",
    "toml_value",
]


@dataclass(frozen=True)
class StartParameter:
    """A parameter of a start kind.

    Attributes
    ----------
    key : str
        Its key in a spec's table (the kind's own name for its first parameter:
        ``{ drop = 0.002 }``).
    attribute : str
        Its attribute on the start's value, and the result attribute
        ``study_start_<attribute>``.
    units : str
        Its units, as the docs and result attributes spell them.
    words : str
        What it is, for descriptions (``"height of the base above the table"``).
    placeholder : str
        How the allowed values name it (``height_m``).
    lower, upper : float
        Its range; ``lower_open`` / ``upper_open`` exclude the bound.
    default : float or None
        Its value where a table leaves it out; None: required.
    fraction_of : str
        What a dimensionless parameter is a fraction of (``"period"``), for the words.
    """

    key: str
    attribute: str
    units: str
    words: str
    placeholder: str
    lower: float
    upper: float
    lower_open: bool = False
    upper_open: bool = False
    default: float | None = None
    fraction_of: str = ""

    @property
    def noun(self) -> str:
        """What it is in one or two words (``height``, ``drive phase``)."""
        return self.words.split(" of ")[0]

    def range_text(self) -> str:
        """``height > 0``, ``phase in [0, 1)``: the range as a message names it."""
        if math.isinf(self.upper):
            return f"{self.attribute} {'>' if self.lower_open else '>='} {self.lower:g}"
        return (f"{self.attribute} in {'(' if self.lower_open else '['}{self.lower:g}, "
                f"{self.upper:g}{')' if self.upper_open else ']'}")

    def schema(self) -> dict[str, Any]:
        """Its JSON-schema bounds (``type``, ``minimum`` or ``exclusiveMinimum``, ...)."""
        out: dict[str, Any] = {"type": "number"}
        out["exclusiveMinimum" if self.lower_open else "minimum"] = _number(self.lower)
        if not math.isinf(self.upper):
            out["exclusiveMaximum" if self.upper_open else "maximum"] = _number(self.upper)
        return out

    def within(self, value: float) -> bool:
        """Whether the finite ``value`` is in range."""
        above = value > self.lower if self.lower_open else value >= self.lower
        below = value < self.upper if self.upper_open else value <= self.upper
        return math.isfinite(value) and above and below


@dataclass(frozen=True)
class StartKind:
    """A kind of start, declared once.

    Attributes
    ----------
    name : str
        Its name (a spec's ``start = "name"``, or the key of its table).
    description : str
        What it says, one line (docs, schemas).
    parameters : tuple of StartParameter
        Empty for a start that is its name alone.
    value_type : type or None
        The frozen value of a start with parameters (:class:`Drop`), built from them.
    needs_two_way : bool
        Other than the release, a start needs two-way coupling: the one-way model's
        mode is driven by the table alone and has no state to start.
    needs_flight : bool
        The base starts off the table and must fly to it.
    excluded_observables : dict
        Observable name -> why the start cannot stand beside it.
    kernel : callable
        The start's value -> ``(phase [periods], factor [1], height [m])``, the kernels'
        initial state (:data:`study.kernels.start.Start`): the drive phase the motion
        starts at, the multiple of the mode's steady stick response it starts on (at
        rest at that multiple's state), the height of the base above the table.
    """

    name: str
    description: str
    kernel: Callable[[Any], tuple[float, float, float]]
    parameters: tuple[StartParameter, ...] = ()
    value_type: type | None = None
    needs_two_way: bool = True
    needs_flight: bool = False
    excluded_observables: Mapping[str, str] | None = None


@dataclass(frozen=True)
class Drop:
    """The drop start: the structure held at rest ``height`` above the vibrating table,
    the mode at rest at ``delta = delta' = 0`` (the static deflection of a held base),
    let go at drive phase ``phase``.

    Not the drops of :func:`study.solvers.attractors.attractors`, whose mode starts at rest
    at its flight equilibrium ``g cos(alpha) / k`` (a structure already falling
    freely): this one is held, then let go, so the mode starts its free oscillation
    about that equilibrium.

    Parameters
    ----------
    height : float
        Height of the base above the table [m], finite and > 0.
    phase : float, default 0
        Drive phase of the release [periods] (fraction of ``1/f``), in [0, 1): the
        table's acceleration is then ``-a cos(2 pi phase)``.

    Raises
    ------
    ValueError
        A height or phase that is not a finite number in range, naming the key
        ``start`` and the allowed values.
    """

    height: float
    phase: float = 0.0

    def __post_init__(self) -> None:
        _check_values(self, START_KINDS["drop"])

    def canonical(self) -> dict[str, float]:
        """As a spec writes it: ``{"drop": height, "phase": phase}``."""
        return canonical(self)  # type: ignore[return-value]

    def label(self) -> str:
        """``"drop 0.002 m at phase 0.25"``: what a result's ``start`` attribute says."""
        return start_label(self)


def _release(_: object) -> tuple[float, float, float]:
    return (0.0, 1.0, 0.0)


def _switch_on(_: object) -> tuple[float, float, float]:
    return (0.0, 0.0, 0.0)


def _drop(start: Drop) -> tuple[float, float, float]:
    return (start.phase, 0.0, start.height)


#: Every kind of start, the default first.
START_KINDS: dict[str, StartKind] = {kind.name: kind for kind in (
    StartKind(
        "release",
        "the base at rest on the table at drive phase 0, the mode on its steady stick "
        "response, as if held down until the plate oscillates steadily, then let go",
        _release, needs_two_way=False),
    StartKind(
        "switch-on",
        "base and mode at rest on the table, the drive switched on at phase 0",
        _switch_on),
    StartKind(
        "drop",
        "the base held at rest above the table, the mode at rest, let go at a drive "
        "phase",
        _drop,
        parameters=(
            StartParameter("drop", "height", METRE, "height of the base above the table",
                           "height_m", 0.0, math.inf, lower_open=True),
            StartParameter("phase", "phase", DIMENSIONLESS, "drive phase of the release",
                           "fraction_of_period", 0.0, 1.0, upper_open=True, default=0.0,
                           fraction_of="period"),
        ),
        value_type=Drop, needs_flight=True,
        excluded_observables={
            "without_flight": "that observable solves the same start with the run "
                              "stopped at lift-off, and a base above the table is no "
                              "state of that model"}),
)}

#: The start of every point unless one is named (every point's start before starts
#: were named; files without a start attribute started by it).
DEFAULT_START = "release"
#: The Python types a start is: a name, or a kind's value.
START_TYPES = (str, *(kind.value_type for kind in START_KINDS.values() if kind.value_type))
#: The starts that are their name alone, the default first.
START_NAMES = tuple(name for name, kind in START_KINDS.items() if not kind.parameters)


def _allowed() -> str:
    words = []
    for kind in START_KINDS.values():
        if not kind.parameters:
            words.append(f'"{kind.name}"' + (" (default)" if kind.name == DEFAULT_START
                                             else ""))
            continue
        keys = ", ".join(f"{p.key} = {p.placeholder}" for p in kind.parameters)
        ranges = ", ".join(p.range_text() for p in kind.parameters)
        words.append(f"a {kind.name} {{ {keys} }} ({ranges})")
    return ", ".join(words[:-1]) + ", or " + words[-1] if len(words) > 1 else words[0]


#: The allowed values of ``start``, as every error message names them.
START_ALLOWED = _allowed()


def _number(value: float) -> int | float:
    return int(value) if float(value).is_integer() else float(value)


def _check_values(value: object, kind: StartKind) -> None:
    """Each parameter of ``value`` a finite number in range, made a float (a frozen
    dataclass's fields set in place); else an error naming the key ``start``."""
    for parameter in kind.parameters:
        given = getattr(value, parameter.attribute)
        if isinstance(given, bool) or not _is_number(given):
            raise InputTypeError(
                f"solver setting 'start': {parameter.key} must be a number, got "
                f"{given!r}; allowed: {START_ALLOWED}")
    for parameter in kind.parameters:
        given = getattr(value, parameter.attribute)
        if not parameter.within(float(given)):
            units = "" if parameter.units in ("", DIMENSIONLESS) else f" {parameter.units}"
            raise ValueError(
                f"solver setting 'start': {parameter.key} = {given!r}{units}: the "
                f"{parameter.noun} must be {_range_words(parameter)}; "
                f"allowed: {START_ALLOWED}")
        object.__setattr__(value, parameter.attribute, float(given))


def _range_words(parameter: StartParameter) -> str:
    if math.isinf(parameter.upper):
        return f"finite and {'>' if parameter.lower_open else '>='} {parameter.lower:g}"
    text = parameter.range_text().removeprefix(f"{parameter.attribute} ")
    return text + (f" (a fraction of the {parameter.fraction_of})" if parameter.fraction_of
                   else "")


def _is_number(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def kind_of(start: object) -> StartKind:
    """The declared kind of a checked start (a name or a kind's value)."""
    if isinstance(start, str) and start in START_KINDS and not START_KINDS[start].parameters:
        return START_KINDS[start]
    for kind in START_KINDS.values():
        if kind.value_type is not None and isinstance(start, kind.value_type):
            return kind
    raise ValueError(f"solver setting 'start' must be {START_ALLOWED}; got {start!r}")


def as_start(value: object) -> Any:
    """``value`` as a start: a name of :data:`START_NAMES`, a kind's value (a
    :class:`Drop`), or a mapping keyed by a kind's name (a spec's table,
    ``{"drop": height, "phase": phase}``) made that value; else a ValueError (an
    InputTypeError for a wrong type) naming ``start`` and the allowed values."""
    for kind in START_KINDS.values():
        if kind.value_type is not None and isinstance(value, kind.value_type):
            return value
    if isinstance(value, str):
        if value not in START_NAMES:
            raise ValueError(f"solver setting 'start' must be {START_ALLOWED}; got "
                             f"{value!r}")
        return value
    if isinstance(value, dict):
        kind = next((kind for kind in START_KINDS.values()
                     if kind.parameters and kind.name in value), None)
        tables = [kind for kind in START_KINDS.values() if kind.parameters]
        allowed_keys = {p.key for k in ([kind] if kind else tables) for p in k.parameters}
        unknown = sorted(str(k) for k in value if k not in allowed_keys)
        if unknown or kind is None:
            problem = (f"unknown key {', '.join(map(repr, unknown))}" if unknown else
                       " or ".join(f"no key {k.name!r} (the {k.parameters[0].noun} "
                                   f"[{k.parameters[0].units}])" for k in tables))
            raise ValueError(f"solver setting 'start' = {value!r}: {problem}; allowed: "
                             f"{START_ALLOWED}")
        assert kind.value_type is not None
        return kind.value_type(**{p.attribute: value.get(p.key, p.default)
                                  for p in kind.parameters})
    raise InputTypeError(f"solver setting 'start' must be {START_ALLOWED}; got "
                         f"{type(value).__name__}: {value!r}")


def start_label(start: object) -> str:
    """A start as a result's ``start`` attribute names it: ``"release"``,
    ``"switch-on"``, ``"drop 0.002 m at phase 0.25"`` (the kind, its first parameter
    with its units, then ``at <key> <value>`` for the others)."""
    kind = kind_of(start)
    if not kind.parameters:
        return kind.name
    first, *rest = kind.parameters
    words = [f"{kind.name} {getattr(start, first.attribute)!r} {first.units}"]
    words += [f"at {p.key} {getattr(start, p.attribute)!r}" for p in rest]
    return " ".join(words)


def canonical(start: object) -> str | dict[str, float]:
    """As a spec writes it: the name, or the table ``{"drop": height, "phase": phase}``
    (every parameter, defaults included)."""
    kind = kind_of(start)
    if not kind.parameters:
        return kind.name
    return {p.key: getattr(start, p.attribute) for p in kind.parameters}


def toml_value(start: object, number: Callable[[float], str] = repr) -> str:
    """The TOML value of ``start`` (``"switch-on"``, ``{ drop = 0.002, phase = 0.25 }``),
    each number written by ``number``."""
    written = canonical(start)
    if isinstance(written, str):
        return f'"{written}"'
    return "{ " + ", ".join(f"{key} = {number(value)}" for key, value in written.items()) + " }"


def start_attributes(start: object) -> dict[str, str | float]:
    """The attributes a result records its start in: ``start`` (:func:`start_label`),
    ``start_kind`` (the kind's name), and each parameter as ``start_<attribute>``
    (a drop's ``start_height`` [m] and ``start_phase`` [periods]). A file without them
    started by the release."""
    kind = kind_of(start)
    out: dict[str, str | float] = {"start": start_label(start), "start_kind": kind.name}
    out.update({f"start_{p.attribute}": getattr(start, p.attribute) for p in kind.parameters})
    return out


def kernel_fields(start: object) -> tuple[float, float, float]:
    """``(phase [periods], factor [1], height [m])`` of a checked start: the kernels'
    :data:`~study.kernels.start.Start`."""
    return kind_of(start).kernel(start)


def refusal(start: object, *, coupling: str, flight: bool | None,
            observables: tuple[str, ...] = (), syntax: str = "python") -> str | None:
    """Why the model cannot take ``start`` (None if it can), in the one wording the API
    and specs share: a start other than the release needs ``coupling="two-way"``, a
    drop needs flight, and a start refuses the observables it cannot stand beside.

    Parameters
    ----------
    start : str or a kind's value
        A checked start.
    coupling : str
        ``"one-way"`` or ``"two-way"``.
    flight : bool or None
        Whether the base flies past lift-off (None: not said, taken as no).
    observables : tuple of str
        A spec's observables.
    syntax : {"python", "toml"}
        How the message spells the start and the keys: the API's ``start 'switch-on'
        ... coupling='two-way'``, or a spec's ``[solver] start = "switch-on"
        (switch-on) ... coupling = "two-way"``.
    """
    kind = kind_of(start)
    label = start_label(start)
    if syntax == "toml":
        subject = f"[solver] start = {toml_value(start)} ({label})"
        two_way, flying = 'coupling = "two-way"', "flight = true"
        got = f'coupling = "{coupling}"'
    else:
        subject = f"start {label!r}"
        two_way, flying = "coupling='two-way'", "flight=True"
        got = f"coupling={coupling!r}"
    needing = [k.name for k in START_KINDS.values() if k.needs_two_way]
    if kind.needs_two_way and coupling != "two-way":
        return (f"{subject} needs {two_way}: the one-way model's mode is driven by the "
                f"table alone and has no state to start (only the {DEFAULT_START} "
                f"applies); got {got}; allowed: {START_ALLOWED}, "
                f"{_and(needing)} with {two_way}")
    if kind.needs_flight and not flight:
        others = [f'"{k.name}"' for k in START_KINDS.values() if not k.needs_flight
                  and not k.parameters]
        return (f"{subject} needs {flying} (the lift-off law 'flight'): the base starts "
                f"above the table and must fly to it; allowed: {_or(others)}, or a "
                f"{kind.name} with {flying}")
    for name, why in (kind.excluded_observables or {}).items():
        if name in observables:
            others = [f'"{k.name}"' for k in START_KINDS.values()
                      if name not in (k.excluded_observables or {}) and not k.parameters]
            return (f"{subject} with the observable {name}: {why}; allowed: {_or(others)} "
                    f"with {name}, or remove it")
    return None


def _or(words: list[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def _and(words: list[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def spec_schema() -> dict[str, Any]:
    """``[solver] start`` in the spec schema: a name of :data:`START_NAMES`, or a
    kind's table with its parameters' bounds."""
    forms: list[dict[str, Any]] = [{"enum": list(START_NAMES)}]
    for kind in START_KINDS.values():
        if not kind.parameters:
            continue
        forms.append({
            "type": "object", "additionalProperties": False,
            "required": [p.key for p in kind.parameters if p.default is None],
            "properties": {p.key: {**p.schema(), "description": _described(p)}
                           for p in kind.parameters}})
    return {"anyOf": forms, "default": DEFAULT_START, "description": _description()}


def _words(parameter: StartParameter) -> str:
    """``height of the base above the table [m]``, ``drive phase of the release, a
    fraction of the period [1]``."""
    fraction = f", a fraction of the {parameter.fraction_of}" if parameter.fraction_of else ""
    return f"{parameter.words}{fraction} [{parameter.units}]"


def _described(parameter: StartParameter) -> str:
    default = "" if parameter.default is None else f" (default {parameter.default:g})"
    return f"{_words(parameter)}, {parameter.range_text()}{default}"


def _description() -> str:
    forms = []
    for kind in START_KINDS.values():
        if not kind.parameters:
            default = "default: " if kind.name == DEFAULT_START else ""
            forms.append(f'"{kind.name}" ({default}{kind.description})')
            continue
        keys = ", ".join(f"{p.key} = {p.placeholder}" for p in kind.parameters)
        ranges = ", ".join(p.range_text() for p in kind.parameters)
        needs = "; needs flight = true" if kind.needs_flight else ""
        forms.append(f"{{ {keys} }} ({kind.description}; {ranges}{needs})")
    return ("exact solver, two-way coupling: the state each point's motion starts from, a "
            f"physical protocol (docs/theory/starts.md): {_or(forms)}")


def result_schema() -> dict[str, Any]:
    """The result file's start attributes in its schema: ``properties`` (each
    ``study_start_<attribute>`` and the ``study_start_kind`` enum),
    ``dependentRequired`` (a kind's parameters together) and ``allOf`` (a kind with
    parameters records them all, another none of them)."""
    names = list(START_KINDS)
    properties: dict[str, Any] = {"study_start_kind": {
        "enum": names, "description": f"the kind of start: {_or(names)}"}}
    dependent: dict[str, list[str]] = {}
    conditions = []
    every = [f"study_start_{p.attribute}" for kind in START_KINDS.values()
             for p in kind.parameters]
    for kind in START_KINDS.values():
        if not kind.parameters:
            continue
        mine = [f"study_start_{p.attribute}" for p in kind.parameters]
        for p, key in zip(kind.parameters, mine, strict=True):
            properties[key] = {**p.schema(),
                               "description": f"a {kind.name}'s {_words(p)}"}
            dependent[key] = [other for other in mine if other != key]
        conditions.append({
            "if": {"properties": {"study_start_kind": {"const": kind.name}},
                   "required": ["study_start_kind"]},
            "then": {"required": mine},
            "else": {"not": {"anyOf": [{"required": [key]} for key in mine]}}})
    assert len(set(every)) == len(every), "start parameters share a result attribute"
    return {"properties": properties, "dependentRequired": dependent, "allOf": conditions}


def markdown_table() -> str:
    """The starts as a markdown table (docs/user-guide/specs.md): name, what it says,
    its spec form, its parameters and what it needs."""
    lines = ["| start | what it says | in a spec | parameters | needs |",
             "|---|---|---|---|---|"]
    for kind in START_KINDS.values():
        name = f"`{kind.name}`" + (" (default)" if kind.name == DEFAULT_START else "")
        if kind.parameters:
            keys = ", ".join(f"{p.key} = {p.placeholder}" for p in kind.parameters)
            form = f"`start = {{ {keys} }}`"
            parameters = "; ".join(
                f"`{p.key}`: {_described(p)}" for p in kind.parameters)
        else:
            form, parameters = f'`start = "{kind.name}"`', "none"
        needs = [n for n, wanted in (("two-way coupling", kind.needs_two_way),
                                     ("flight", kind.needs_flight)) if wanted]
        needs += [f"not with the observable `{name}`" for name in
                  (kind.excluded_observables or {})]
        lines.append(f"| {name} | {kind.description} | {form} | {parameters} | "
                     f"{', '.join(needs) or 'nothing'} |")
    return "\n".join(lines) + "\n"


def _fields_match() -> None:
    """Each kind's value carries exactly its parameters (checked at import)."""
    for kind in START_KINDS.values():
        if kind.value_type is not None:
            names = tuple(f.name for f in fields(kind.value_type))
            assert names == tuple(p.attribute for p in kind.parameters), kind.name


_fields_match()
