"""Every result kind's contact laws as global attributes, and read back as one line of
text: what ``study info`` prints for a study, a scene, a fit or a design alike. The
laws' parameters are ``study_<law>_<parameter>`` attributes (:func:`law_attribute`)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from study.model.contact import DEFAULT_FRICTION, DEFAULT_LIFT_OFF, LAWS, Friction
from study.model.parameters import STRUCTURE

__all__ = ["contact_law_attributes", "law_attribute", "method_summary", "shortest_text"]


def shortest_text(value: float) -> str:
    """A float as its shortest exact text (``0.01``, not ``np.float64(0.01)``)."""
    return repr(float(value))


def law_attribute(kind: str, parameter: str) -> str:
    """The global attribute of a contact law's parameter: ``study_<kind>_<parameter>``
    (``study_friction_stribeck_speed``, ``study_lift_off_restitution``)."""
    return f"study_{kind}_{parameter}"


def contact_law_attributes(coupling: str, friction: Friction | str | None = None,
                           lift_off: str = DEFAULT_LIFT_OFF,
                           lift_off_values: Mapping[str, float] | None = None
                           ) -> dict[str, str | float]:
    """The global attributes that name a result's contact laws, made from their
    declarations (:data:`study.model.contact.LAWS`).

    The one place they are made for every kind of result: a study's
    (:func:`method_attributes`), a fit's, a design's and a scene's.

    Parameters
    ----------
    coupling : str
        A name of :data:`study.model.contact.COUPLINGS`.
    friction : Friction or str, optional
        The friction law with its parameters' values, or the name of a law that needs
        none; default :data:`study.model.contact.DEFAULT_FRICTION`.
    lift_off : str
        A name of :data:`study.model.contact.LIFT_OFF_LAWS`; default
        :data:`study.model.contact.DEFAULT_LIFT_OFF`.
    lift_off_values : mapping, optional
        Fixed values of the structure parameters the lift-off law reads
        (``restitution`` with ``flight``); one left out is not recorded (a study
        leaves out a swept one: its coordinate holds it).

    Returns
    -------
    dict
        ``study_coupling``, ``study_friction_law``, one float
        ``study_friction_<parameter>`` per parameter of the friction law,
        ``study_lift_off`` and one float ``study_lift_off_<parameter>`` per value of
        ``lift_off_values``, in that order.

    Raises
    ------
    ValueError
        A law that is not declared, or a value the lift-off law does not read.
    """
    if coupling not in LAWS["coupling"]:
        raise ValueError(f"coupling {coupling!r} is unknown; couplings are "
                         f"{', '.join(map(repr, LAWS['coupling']))}")
    friction = Friction() if friction is None else (
        Friction(friction) if isinstance(friction, str) else friction)
    law = LAWS["lift_off"].get(lift_off)
    if law is None:
        raise ValueError(f"lift-off law {lift_off!r} is unknown; lift-off laws are "
                         f"{', '.join(map(repr, LAWS['lift_off']))}")
    values = dict(lift_off_values or {})
    unread = sorted(set(values) - set(law.structure_parameters))
    if unread:
        raise ValueError(f"lift-off law {lift_off!r} reads "
                         f"{list(law.structure_parameters) or 'no parameter'}, not {unread}")
    return {
        "study_coupling": coupling,
        "study_friction_law": friction.law,
        **{law_attribute("friction", p.name): float(friction.values[p.name])
           for p in friction.declaration.parameters},
        "study_lift_off": lift_off,
        **{law_attribute("lift_off", name): float(values[name])
           for name in law.structure_parameters if name in values},
    }


_NOT_RECORDED = "not recorded; the default"


def method_summary(attrs: Mapping[str, Any], swept: Iterable[str] = (), *,
                   solver: bool = True) -> str:
    """A result's method in one line, from its global attributes (those of
    :func:`method_attributes`): ``exact solver, one-way coupling, friction stribeck
    (stribeck_speed=0.01 m s-1), lift-off flight, restitution e=0.5``, then the start
    where it is not the release (``start switch-on``).

    Files written before the method was recorded whole lack some attributes: the line
    says what the file has, and a default it assumes as such (``friction coulomb (not
    recorded; the default)``); a value of the wrong type is shown as it is.

    Parameters
    ----------
    attrs : mapping
        The result's global attributes.
    swept : iterable of str
        The result's dimensions: a law's structure parameter among them is said to be
        swept.
    solver : bool
        Whether the kind of result chooses a solver (``study_solver_method``): a study
        does; a fit, a design and a scene do not (their model is fixed), and their
        line starts with the coupling (those of :func:`contact_law_attributes`).
    """
    swept = set(swept)
    method = attrs.get("study_solver_method")
    coupling = attrs.get("study_coupling")
    parts = [f"{method} solver" if isinstance(method, str) else "solver not recorded"
             ] if solver else []
    parts += [f"{coupling} coupling" if isinstance(coupling, str) else "coupling not recorded",
              _friction_summary(attrs), _lift_off_summary(attrs, swept)]
    # The start only where it is not the release (absent: the release, as before starts
    # were named), so that the line of every other result stays as it was.
    start = attrs.get("study_start")
    if solver and start is not None and start != "release":
        parts.append(f"start {start}")
    return ", ".join(parts)


def _shown(value: Any) -> str:
    """An attribute's value: a number as its shortest exact text, anything else as it is."""
    if isinstance(value, int | float | np.integer | np.floating) and not isinstance(
            value, bool | np.bool_):
        return shortest_text(value)
    return repr(value)


def _friction_summary(attrs: Mapping[str, Any]) -> str:
    law = attrs.get("study_friction_law")
    if law is None:
        return f"friction {DEFAULT_FRICTION} ({_NOT_RECORDED})"
    if not isinstance(law, str):
        return f"friction {law!r}"
    declared = LAWS["friction"].get(law)
    units = {p.name: p.units for p in (declared.parameters if declared else ())}
    prefix = law_attribute("friction", "")
    # The declared parameters, then any other the file holds (an unknown law's).
    names = [*units, *(key[len(prefix):] for key in attrs
                       if key.startswith(prefix) and key != "study_friction_law"
                       and key[len(prefix):] not in units)]
    shown = [f"{name}={_shown(attrs[prefix + name])}"
             + (f" {units[name]}" if units.get(name, "1") != "1" else "")
             if prefix + name in attrs else f"{name} not recorded" for name in names]
    return f"friction {law}" + (f" ({', '.join(shown)})" if shown else "")


def _lift_off_summary(attrs: Mapping[str, Any], swept: set[str]) -> str:
    law = attrs.get("study_lift_off")
    if law is None:
        return f"lift-off {DEFAULT_LIFT_OFF} ({_NOT_RECORDED})"
    if not isinstance(law, str):
        return f"lift-off {law!r}"
    declared = LAWS["lift_off"].get(law)
    text = f"lift-off {law}"
    for name in (declared.structure_parameters if declared else ()):
        attribute = law_attribute("lift_off", name)
        symbol = STRUCTURE[name].symbol
        if attribute in attrs:
            text += f", {name} {symbol}={_shown(attrs[attribute])}"
        elif name in swept:
            text += f", {name} {symbol} swept"
        else:
            text += f", {name} not recorded"
    return text
