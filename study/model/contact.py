"""Contact laws as named pieces: friction, coupling and what a vanishing normal force does.

Each law is declared once here (:data:`LAWS`): its name, what it says, the parameters it
needs (with units and allowed range) and the solvers that implement it. Solvers and
specs choose laws by name, as PySDM picks its formulae and PyBaMM its submodels; a
solver asked for a law it does not implement refuses it with one message naming the
law, the solver and the allowed values (:func:`check_law`).

The kernels read a chosen law through the structure vector
(:mod:`study.kernels.structure_vector`): a law's ``code`` and its parameters' values
(:meth:`Friction.vector_entries`). The numba form of each friction law is one branch of
:func:`study.kernels.friction.kinetic_coefficient`.

Laws
----
friction
    ``coulomb``: static coefficient ``cs`` holds a stick, kinetic ``ck`` opposes a slip.
    ``stribeck``: as Coulomb, but the kinetic coefficient falls with the slip speed
    ``|v|`` from ``cs`` to ``ck`` over the Stribeck speed ``v_s``:
    ``mu(v) = ck + (cs - ck) exp(-|v| / v_s)``. ``ck = cs`` is Coulomb exactly, and so
    is ``v_s -> 0`` away from rest.
coupling
    ``one-way``: the paper's model, the mode is driven by the table only. ``two-way``:
    the sliding base's acceleration also forces the mode.
lift_off
    ``stop``: a run ends with ``LIFT_OFF`` where the normal force would turn negative
    (the model of contact stops holding there). ``flight``: the base takes off there,
    flies and lands by an impact (restitution ``e``, friction during the impact);
    ``flight=True`` in the API and specs (docs/theory/flight.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "COUPLINGS",
    "DEFAULT_COUPLING",
    "DEFAULT_FRICTION",
    "DEFAULT_LIFT_OFF",
    "FRICTION_LAWS",
    "KINDS",
    "LAWS",
    "LIFT_OFF_LAWS",
    "SOLVERS",
    "ContactLaw",
    "Friction",
    "LawParameter",
    "check_friction",
    "check_law",
    "markdown_table",
    "supported",
]

#: The solvers that implement contact laws: the exact steady-state solver
#: (:mod:`study.solvers.exact`), the single-plate time integrator
#: (:mod:`study.solvers.integrator`) and the planar integrator
#: (:mod:`study.solvers.planar`).
SOLVERS = {
    "exact": "the exact steady-state solver",
    "integrator": "the time integrator",
    "planar": "the planar integrator",
}

#: The kinds of contact law, with what each decides.
KINDS = {
    "friction": "the friction coefficient a stick holds and a slip feels",
    "coupling": "whether the sliding base also forces the mode",
    "lift_off": "what happens where the normal force vanishes",
}


@dataclass(frozen=True)
class LawParameter:
    """A parameter a contact law needs.

    Attributes
    ----------
    name : str
        Its key in the API and in specs.
    units : str
        CF units.
    long_name : str
        What it is.
    lower : float
        Values must be greater than this (exclusive).
    upper : float
        Values must be less than this (exclusive).
    reason : str
        Why the range is what it is.
    """

    name: str
    units: str
    long_name: str
    lower: float = 0.0
    upper: float = math.inf
    reason: str = ""


@dataclass(frozen=True)
class ContactLaw:
    """One contact law, declared once.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    name : str
        The name a spec or an API call chooses it by.
    code : int
        Its number in the structure vector (the kernels branch on it).
    description : str
        What it says.
    parameters : tuple of LawParameter
        The parameters it needs besides the structure's, in structure-vector order.
    solvers : tuple of str
        The solvers (keys of :data:`SOLVERS`) that implement it.
    structure_parameters : tuple of str
        Parameters of the structure (:data:`study.model.parameters.STRUCTURE`) that only
        this law reads (the restitution of the lift-off law ``flight``): a result
        records them with the law (:func:`study.studies.layout.method_attributes`).
    """

    kind: str
    name: str
    code: int
    description: str
    parameters: tuple[LawParameter, ...] = ()
    solvers: tuple[str, ...] = tuple(SOLVERS)
    structure_parameters: tuple[str, ...] = ()


#: Every contact law, by kind and name.
LAWS: dict[str, dict[str, ContactLaw]] = {
    "friction": {
        "coulomb": ContactLaw(
            "friction", "coulomb", 0,
            "Coulomb friction: cs holds a stick, ck opposes a slip"),
        "stribeck": ContactLaw(
            "friction", "stribeck", 1,
            "velocity-weakening (Stribeck) friction: the kinetic coefficient falls "
            "from cs at rest to ck with the slip speed, mu(v) = ck + (cs - ck) "
            "exp(-|v| / stribeck_speed)",
            parameters=(LawParameter(
                "stribeck_speed", "m s-1", "Stribeck speed, over which mu falls from cs to ck",
                reason="a speed scale: > 0 (the limit 0 is Coulomb friction)"),),
            solvers=("integrator",)),
    },
    "coupling": {
        "one-way": ContactLaw(
            "coupling", "one-way", 0,
            "the paper's model: the mode is driven by the table only"),
        "two-way": ContactLaw(
            "coupling", "two-way", 1,
            "the sliding base's acceleration also forces the mode"),
    },
    "lift_off": {
        "stop": ContactLaw(
            "lift_off", "stop", 0,
            "the run ends with LIFT_OFF where the normal force would turn negative"),
        "flight": ContactLaw(
            "lift_off", "flight", 1,
            "the base takes off where the normal force vanishes, flies (free fall of "
            "base and plate, the mode a free oscillator of the two bodies) and lands "
            "by an impact with friction and the structure's restitution",
            solvers=("exact", "integrator"), structure_parameters=("restitution",)),
    },
}

#: Names of each kind's laws.
FRICTION_LAWS = tuple(LAWS["friction"])
COUPLINGS = tuple(LAWS["coupling"])
#: The coupling of every function, spec, fit and design that does not name one: the
#: paper's model, the one every workflow uses. Declared here only; everything else
#: (signatures, spec readers, schemas' descriptions) derives from it.
DEFAULT_COUPLING = "one-way"
LIFT_OFF_LAWS = tuple(LAWS["lift_off"])
#: What every solver does at lift-off unless told ``flight=True``: stop with LIFT_OFF.
DEFAULT_LIFT_OFF = "stop"
#: The friction law of every solver by default (the paper's).
DEFAULT_FRICTION = "coulomb"


def supported(kind: str, solver: str) -> tuple[str, ...]:
    """Names of the ``kind`` laws that ``solver`` implements."""
    return tuple(name for name, law in LAWS[kind].items() if solver in law.solvers)


def markdown_table() -> str:
    """The docs' table of contact laws (docs/user-guide/specs.md), from :data:`LAWS`:
    each law's name, kind, what it says, the parameters it reads and the solvers that
    implement it."""
    lines = ["| law | kind | what it says | parameters | solvers |", "|---|---|---|---|---|"]
    defaults = {"friction": DEFAULT_FRICTION, "coupling": DEFAULT_COUPLING,
                "lift_off": DEFAULT_LIFT_OFF}
    for kind, laws in LAWS.items():
        for name, law in laws.items():
            parameters = [f"`{p.name}` [{p.units}]: {p.long_name}"
                          + (f"; {p.reason}" if p.reason else "") for p in law.parameters]
            parameters += [f"reads the structure's `{p}`" for p in law.structure_parameters]
            default = " (default)" if defaults[kind] == name else ""
            description = law.description.replace("|", "\\|").replace("*", "\\*")
            lines.append(f"| `{name}`{default} | {kind} | {description} | "
                         f"{'<br>'.join(parameters) or 'none'} | {', '.join(law.solvers)} |")
    return "\n".join(lines) + "\n"


def check_law(kind: str, name: object, solver: str) -> ContactLaw:
    """The declared ``kind`` law ``name`` if ``solver`` implements it.

    Raises
    ------
    ValueError
        ``name`` is not a declared law of that kind, or ``solver`` does not implement
        it; the message names the law, the solver and the allowed values.
    """
    law = LAWS[kind].get(name) if isinstance(name, str) else None
    if law is not None and solver in law.solvers:
        return law
    # The messages' lists are made only for a refusal (every solver call checks a law).
    allowed = supported(kind, solver)
    listed = ", ".join(map(repr, allowed))
    if law is None:
        known = ", ".join(map(repr, LAWS[kind]))
        raise ValueError(f"{kind} law {name!r} is unknown; {kind} laws are {known} "
                         f"({SOLVERS[solver]} allows {listed})")
    raise ValueError(f"{kind} law {name!r} is not implemented by {SOLVERS[solver]} "
                     f"({solver!r}); allowed: {listed}")


@dataclass(frozen=True)
class Friction:
    """A chosen friction law and the values of its parameters.

    ``Friction("stribeck", stribeck_speed=1e-3)``; ``Friction()`` is Coulomb friction.
    Solvers take a law's name where it needs no parameters (``friction="coulomb"``).

    Attributes
    ----------
    law : str
        A name of :data:`FRICTION_LAWS`.
    values : dict
        The law's parameters (SI, units as declared in :data:`LAWS`).
    """

    law: str = DEFAULT_FRICTION
    values: Mapping[str, float] = field(default_factory=dict)

    def __init__(self, law: str = DEFAULT_FRICTION, **values: float) -> None:
        declared = LAWS["friction"].get(law) if isinstance(law, str) else None
        if declared is None:
            raise ValueError(f"friction law {law!r} is unknown; friction laws are "
                             f"{', '.join(map(repr, FRICTION_LAWS))}")
        checked: dict[str, float] = {}
        # Every solver call checks its law: one without parameters, given none (the
        # default), has nothing more to check.
        if declared.parameters or values:
            names = [p.name for p in declared.parameters]
            missing = [n for n in names if n not in values]
            extra = sorted(set(values) - set(names))
            if missing or extra:
                raise ValueError(
                    f"friction law {law!r} needs the parameters {names or 'none'}; "
                    + (f"missing {missing}" if missing else f"unknown {extra}"))
            for parameter in declared.parameters:
                value = values[parameter.name]
                if isinstance(value, bool) or not isinstance(value, int | float):
                    raise ValueError(f"friction law {law!r}: {parameter.name} must be a number "
                                     f"[{parameter.units}], got {value!r}")
                if not parameter.lower < float(value) < parameter.upper:
                    raise ValueError(
                        f"friction law {law!r}: {parameter.name} = {value!r} is out of range; "
                        f"allowed: {parameter.lower} < {parameter.name} < {parameter.upper} "
                        f"[{parameter.units}] ({parameter.reason})")
                checked[parameter.name] = float(value)
        object.__setattr__(self, "law", law)
        object.__setattr__(self, "values", checked)

    @property
    def declaration(self) -> ContactLaw:
        """The law's declaration in :data:`LAWS`."""
        return LAWS["friction"][self.law]

    def vector_entries(self) -> dict[str, float]:
        """The structure-vector entries of this choice: ``friction_law`` (the law's
        code) and each of its parameters by name."""
        return {"friction_law": float(self.declaration.code), **self.values}

    def canonical(self) -> dict[str, Any]:
        """The choice as plain JSON data: ``{"law": name, parameter: value, ...}``."""
        return {"law": self.law, **self.values}


def check_friction(friction: object, solver: str) -> Friction:
    """``friction`` (a law's name, a mapping ``{"law": name, parameter: value}`` as in
    a spec, or a :class:`Friction`) as a :class:`Friction` that ``solver`` implements.

    Raises
    ------
    ValueError
        An unknown law, its parameters missing, unknown or out of range, or a law
        ``solver`` does not implement (the message names the allowed values).
    TypeError
        ``friction`` is none of the three forms.
    """
    if isinstance(friction, str):
        check_law("friction", friction, solver)
        friction = Friction(friction)
    elif isinstance(friction, Mapping):
        values = dict(friction)
        law = values.pop("law", None)
        check_law("friction", law, solver)
        friction = Friction(law, **values)
    elif not isinstance(friction, Friction):
        raise TypeError("friction must be a law's name, a mapping {'law': name, "
                        "parameter: value} or a study.model.contact.Friction, got "
                        f"{type(friction).__name__}")
    check_law("friction", friction.law, solver)
    return friction
