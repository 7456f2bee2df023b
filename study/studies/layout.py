"""The layout of a study result, declared once: its coordinates and variables.

What a study's dataset holds follows from its spec alone: one coordinate per swept
axis, the fixed structure parameters as scalar coordinates, and the variables of the
requested observables over the structure axes and the drive grid, each with the
attributes :mod:`study.studies.variables` declares. The runner writes this layout into a file
chunk by chunk; :func:`study.compute_map` fills the same layout in memory. Both take
the global attributes that say how the values were computed (solver, coupling, contact
laws and their parameters) from :func:`method_attributes`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.engine.contact_attributes import (
    contact_law_attributes,
    shortest_text,
)
from study.model.contact import LAWS
from study.model.parameters import STRUCTURE
from study.model.starts import start_attributes
from study.model.units import DIMENSIONLESS, KILOGRAM
from study.solvers.basins import sampling_reach
from study.solvers.fold_curves import HOPS, SIDES
from study.studies.observables import UNSWEPT_VARIABLES, Method, Observable, resolve
from study.studies.spec import StudySpec
from study.studies.spec_types import STRUCTURE_PARAMETERS, SWEEPABLE
from study.studies.sweep import Chunk, plan_chunks
from study.studies.variables import GRID_SIZES, GRIDS, VARIABLES

__all__ = [
    "Coordinate",
    "DataVariable",
    "basins_attributes",
    "coordinate_attrs",
    "coordinates",
    "curve_observable",
    "data_variables",
    "direction_methods",
    "method_attributes",
    "method_description",
    "method_of",
    "observables_by_grid",
    "pad_branches",
    "plan_study",
    "protocol_attributes",
    "study_summary",
]


@dataclass(frozen=True)
class Coordinate:
    """A coordinate of a study result.

    Attributes
    ----------
    name : str
    dims : tuple of str
        ``(name,)`` for a swept axis, ``()`` for a fixed parameter, ``("m_add",)`` for
        the mass ratio of a swept added mass.
    values : numpy.ndarray
        In the parameter's SI units.
    attrs : dict
        ``units``, ``long_name``, ``coverage_content_type``.
    """

    name: str
    dims: tuple[str, ...]
    values: NDArray[np.float64] = field(repr=False)
    attrs: dict[str, Any] = field(repr=False)

    @property
    def auxiliary(self) -> bool:
        """Not a dimension of its own: listed in the variables' ``coordinates``."""
        return self.dims != (self.name,)


@dataclass(frozen=True)
class DataVariable:
    """A data variable of a study result: name, dims, dtype and attributes."""

    name: str
    grid: str
    dims: tuple[str, ...]
    dtype: str
    attrs: dict[str, Any] = field(repr=False)


def coordinate_attrs(units: str, long_name: str) -> dict[str, Any]:
    """The attributes of a coordinate with these CF ``units`` and ``long_name``."""
    return {"units": units, "long_name": long_name, "coverage_content_type": "coordinate"}


def coordinates(spec: StudySpec) -> tuple[Coordinate, ...]:
    """Every coordinate of the study's result, in file order."""
    found = [Coordinate(axis.name, (axis.name,), axis.values,
                        coordinate_attrs(axis.units, axis.long_name)) for axis in spec.axes]
    for name, value in spec.canonical["structure"].items():
        units, long_name = SWEEPABLE[name]
        found.append(Coordinate(name, (), np.float64(value), coordinate_attrs(units, long_name)))
    if spec.both_directions:
        found.append(Coordinate("direction", ("direction",), np.array(spec.directions),
                                coordinate_attrs(DIMENSIONLESS, "direction of the slow sweep "
                                                 "(increasing or decreasing values of the "
                                                 "swept axis)")))
    # The dimensions of a point's values (a phase section's periods), counted from 0.
    trailing = {d for o in resolve(spec.observables, spec.flight) for v in o.variables
                for d in GRIDS[VARIABLES[v].grid][2:]}
    sizes = {**GRID_SIZES, **spec.dimension_sizes}
    for name in sorted(trailing):
        found.append(Coordinate(name, (name,), np.arange(sizes[name], dtype=np.int32),
                                coordinate_attrs(DIMENSIONLESS, _TRAILING_NAMES[name])))
    if curve_observable(spec) is not None:
        found.append(Coordinate("hop", ("hop",), np.array(HOPS), coordinate_attrs(
            DIMENSIONLESS, "the hop whose fold is followed: forward (a slow sweep up along "
            "f rides it to its fold) or backward (a sweep down)")))
        found.append(Coordinate("curve_end", ("curve_end",), np.array(SIDES),
                                coordinate_attrs(DIMENSIONLESS, "the end of a fold curve: "
                                                 "towards smaller (below) or larger "
                                                 "(above) drive accelerations")))
    if spec.mass is not None:
        found.append(Coordinate("m0", (), np.float64(spec.mass.m0),
                                coordinate_attrs(KILOGRAM, "mass of the structure")))
        found.append(Coordinate("m1", (), np.float64(spec.mass.m1),
                                coordinate_attrs(KILOGRAM, "resonant (modal) mass")))
        m_add_axis = spec.axis("m_add")
        units, long_name = STRUCTURE_PARAMETERS["M"]
        if m_add_axis is not None:
            ratios = np.array([spec.mass.mass_ratio(m) for m in m_add_axis.values])
            found.append(Coordinate("M", ("m_add",), ratios, coordinate_attrs(units, long_name)))
        else:
            found.append(Coordinate("M", (), np.float64(spec.mass.mass_ratio(
                spec.fixed.get("m_add", 0.0))), coordinate_attrs(units, long_name)))
    return tuple(found)


#: long_name of each dimension of :data:`~study.studies.variables.GRID_SIZES`.
_TRAILING_NAMES = {"section_period": "drive periods of the phase section, counted from "
                   "the reported state",
                   "attractor": "attractors at the drive point, numbered from 0 in the order "
                   "the starts first reach them"}


def observables_by_grid(spec: StudySpec) -> tuple[tuple[Observable, ...],
                                                 tuple[Observable, ...], Observable | None]:
    """The study's observables (with those they require): closed-form rows, solver
    points, and the frontier if asked for."""
    observables = resolve(spec.observables, spec.flight, spec.protocol is not None)
    return (tuple(o for o in observables if o.grid == "row"),
            tuple(o for o in observables if o.grid == "point"),
            next((o for o in observables if o.grid == "frontier"), None))


def curve_observable(spec: StudySpec) -> Observable | None:
    """The study's observable continued over the drive plane after the map (the fold
    curves), if asked for."""
    return next((o for o in resolve(spec.observables, spec.flight, spec.protocol is not None)
                 if o.grid == "curves"), None)


def data_variables(spec: StudySpec, observables: tuple[Observable, ...]
                   ) -> tuple[DataVariable, ...]:
    """The variables of ``observables`` in the study's result, dims and attributes
    (without the ``coordinates`` attribute, which a file adds)."""
    structure_dims = tuple(axis.name for axis in spec.structure_axes)
    return tuple(
        DataVariable(name, VARIABLES[name].grid, variable_dims(spec, name, structure_dims),
                     VARIABLES[name].dtype,
                     VARIABLES[name].attrs(spec.flight, spec.observables))
        for observable in observables for name in observable.variables
    )


def variable_dims(spec: StudySpec, name: str, structure_dims: tuple[str, ...]
                  ) -> tuple[str, ...]:
    """A declared variable's dimensions in the study's result: with a slow sweep both
    ways, every per-point variable has a leading ``direction`` (up, down), but those of
    each point from its start alone (:data:`study.studies.observables.UNSWEPT_VARIABLES`)."""
    dims = VARIABLES[name].dims(structure_dims)
    if (spec.both_directions and VARIABLES[name].grid in ("point", "section", "attractor")
            and name not in UNSWEPT_VARIABLES):
        return ("direction", *dims)
    return dims


def pad_branches(values: NDArray[Any], branches: int, dtype: str) -> NDArray[Any]:
    """A frontier variable's ``(n_a, n)`` values padded to ``branches`` columns (NaN for
    floats, 0 for codes)."""
    dtype_ = np.dtype(dtype)
    padded = np.full((values.shape[0], branches), np.nan if dtype_.kind == "f" else 0,
                     dtype=dtype_)
    padded[:, :values.shape[1]] = values
    return padded


def method_of(spec: StudySpec) -> Method:
    """How the study computes velocities (solver, coupling and settings)."""
    return Method(spec.method, spec.coupling, spec.solver, spec.integrator, spec.friction,
                  spec.flight, spec.protocol, spec.basins)


def direction_methods(spec: StudySpec) -> tuple[Method, ...]:
    """The method of each direction of a slow sweep both ways (a chunk's ``direction``
    indexes it: up, then down), else the study's method alone."""
    method = method_of(spec)
    if not spec.both_directions:
        return (method,)
    return tuple(replace(method, protocol=(spec.protocol[0], direction))
                 for direction in spec.directions)


def plan_study(spec: StudySpec) -> list[Chunk]:
    """The chunks of a study (:func:`study.studies.sweep.plan_chunks`), as a result file
    and :func:`study.compute_map` cut it: a slow sweep's task holds whole runs (along a
    every chunk does, each holding every a; along f one chunk holds every f of its
    structure), and both ways every chunk comes once up, once down (the down chunks
    numbered after, ``direction`` 1)."""
    a_axis = spec.axis("a")
    n_a = len(a_axis) if (a_axis is not None and spec.needs_solver) else 1
    n_f = len(spec.axis("f"))
    along_f = spec.protocol is not None and spec.protocol[0] == "f"
    chunks = plan_chunks(tuple(len(axis) for axis in spec.structure_axes), n_f, n_a,
                         n_f * n_a if along_f else spec.chunk_points)
    if not spec.both_directions:
        return chunks
    return [*chunks, *(replace(chunk, number=len(chunks) + chunk.number, direction=1)
                       for chunk in chunks)]


def study_summary(spec: StudySpec) -> str:
    """The ``summary`` attribute of a study's result: the spec's description, else what
    it computes and how (:func:`method_description`)."""
    return spec.description or (
        f"Parameter study '{spec.name}' of vibration-driven stick-slip locomotion: "
        f"{', '.join(spec.observables)} of a soft structure with a resonant plate on a "
        f"vertically shaken table, computed by {method_description(spec)}.")


def method_description(spec: StudySpec) -> str:
    """How the velocities were computed, for a result's own description: the solver and
    its coupling, the friction law with its parameters and the lift-off law (with
    flight, the restitution of its impacts)."""
    return (f"{_solver_description(spec)}; {_friction_description(spec)}; "
            f"{_lift_off_description(spec)}")


def _solver_description(spec: StudySpec) -> str:
    if spec.method == "exact" and spec.coupling == "two-way":
        return (
            "the exact event-driven steady-state solver (closed form between events; "
            "two-way coupling: the sliding base also forces the mode, the orbit is the "
            "fixed point of the period map found by Newton's method)"
        )
    if spec.method == "exact":
        return (
            "the exact event-driven steady-state solver (closed form between events; "
            "one-way coupling, the paper's model)"
        )
    return (
        "Dormand-Prince 5(4) time integration with events located on the dense output, "
        f"until the orbit repeats ({spec.coupling} coupling"
        + ("; the sliding base also forces the mode" if spec.coupling == "two-way" else "")
        + ")"
    )


def _friction_description(spec: StudySpec) -> str:
    law = spec.friction.declaration
    values = "".join(f", {p.name} = {shortest_text(spec.friction.values[p.name])} {p.units}"
                     for p in law.parameters)
    return f"friction law '{law.name}'{values} ({law.description})"


def _lift_off_description(spec: StudySpec) -> str:
    law = LAWS["lift_off"][spec.lift_off]
    values = _lift_off_values(spec)
    shown = "".join(
        f", {name} {STRUCTURE[name].symbol} = {shortest_text(values[name])}" if name in values
        else f", {name} {STRUCTURE[name].symbol} swept (its coordinate)"
        for name in law.structure_parameters)
    return f"lift-off law '{law.name}'{shown} ({law.description})"


def _lift_off_values(spec: StudySpec) -> dict[str, float]:
    """The fixed values of the structure parameters the study's lift-off law reads
    (a swept one is left out: its coordinate holds its values)."""
    law = LAWS["lift_off"][spec.lift_off]
    return {name: float(spec.fixed.get(name, STRUCTURE[name].default))
            for name in law.structure_parameters if spec.axis(name) is None}


def protocol_attributes(spec: StudySpec) -> dict[str, str | float]:
    """How each point's motion is started (and, later, how the sweep visits the grid).

    What this returns joins :func:`method_attributes`, and so is written into every
    result and compared with the embedded spec by validation: the start
    (:func:`study.model.starts.start_attributes`): ``study_start``, its label
    (``"release"``, ``"switch-on"``, ``"drop 0.002 m at phase 0.25"``),
    ``study_start_kind`` (``release``, ``switch-on`` or ``drop``) and for a drop the
    floats ``study_start_height`` [m] and ``study_start_phase`` [periods]. A file
    written before starts were named has none of them: its points started by the
    release (validation reads it so). With a slow sweep (``[sweep] protocol``) also
    ``study_protocol`` (``"slow sweep"``), ``study_protocol_along`` (``f`` or ``a``)
    and ``study_protocol_direction`` (``up`` or ``down``); without one none of them.
    """
    found: dict[str, str | float] = {
        f"study_{key}": value for key, value in start_attributes(spec.solver.start).items()}
    if spec.protocol is not None:
        found.update({"study_protocol": "slow sweep", "study_protocol_along": spec.protocol[0],
                      "study_protocol_direction": spec.protocol[1]})
    return found


def basins_attributes(spec: StudySpec) -> dict[str, int | str]:
    """How the ``basins`` observable sampled each point, in a study that asks for it:
    ``study_basins_starts``, ``study_basins_seed``, ``study_basins_max_attractors`` and
    ``study_basins_sweep_steps`` (``[basins]``, its defaults where absent), and
    ``study_basins_reach``, what the starts reach in words
    (:func:`study.solvers.basins.sampling_reach`); nothing in any other study."""
    if spec.basins is None:
        return {}
    found: dict[str, int | str] = {
        f"study_basins_{key}": value for key, value in spec.basins.canonical().items()}
    found["study_basins_reach"] = sampling_reach(bool(spec.flight),
                                                 spec.basins.sweep_steps)
    return found


def method_attributes(spec: StudySpec) -> dict[str, str | float]:
    """The global attributes that say how a study's values were computed.

    The one place they are made: the runner's file (:mod:`study.studies.kind`) and
    :func:`study.compute_map`'s dataset both take them from here, and validation
    (:func:`study.studies.checks.method_problems`) compares a file's with its
    embedded spec's.

    Returns
    -------
    dict
        ``source`` (``"study: "`` and :func:`method_description`),
        ``study_solver_method`` (``"exact"`` or ``"integrator"``), then the contact
        laws' attributes (:func:`contact_law_attributes`): ``study_coupling``,
        ``study_friction_law`` (its name in :data:`study.model.contact.LAWS`), one
        float ``study_friction_<parameter>`` for each parameter the friction law
        declares (``study_friction_stribeck_speed`` in m s-1), ``study_lift_off``
        (``"stop"`` or ``"flight"``), and one float ``study_lift_off_<parameter>`` for
        each fixed structure parameter the lift-off law reads
        (``study_lift_off_restitution`` with flight; left out where it is swept, its
        coordinate holds it), then :func:`protocol_attributes` and, with the basins
        observable, :func:`basins_attributes`.
    """
    return {
        "source": f"study: {method_description(spec)}",
        "study_solver_method": spec.method,
        **contact_law_attributes(spec.coupling, spec.friction, spec.lift_off,
                                 _lift_off_values(spec)),
        **protocol_attributes(spec),
        **basins_attributes(spec),
    }


#: The words a method line uses for a contact law the attributes do not name.
