"""The layout of a study result, declared once: its coordinates and variables.

What a study's dataset holds follows from its spec alone: one coordinate per swept
axis, the fixed structure parameters as scalar coordinates, and the variables of the
requested observables over the structure axes and the drive grid, each with the
attributes :mod:`study.engine.variables` declares. The runner writes this layout into a file
chunk by chunk; :func:`study.compute_map` fills the same layout in memory.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.engine.observables import Method, Observable, resolve
from study.engine.study_spec import STRUCTURE_PARAMETERS, SWEEPABLE, StudySpec
from study.engine.variables import VARIABLES
from study.model.units import KILOGRAM

__all__ = [
    "Coordinate",
    "DataVariable",
    "coordinate_attrs",
    "coordinates",
    "data_variables",
    "method_description",
    "method_of",
    "observables_by_grid",
    "pad_branches",
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


def observables_by_grid(spec: StudySpec) -> tuple[tuple[Observable, ...],
                                                 tuple[Observable, ...], Observable | None]:
    """The study's observables (with those they require): closed-form rows, solver
    points, and the frontier if asked for."""
    observables = resolve(spec.observables, spec.flight)
    return (tuple(o for o in observables if o.grid == "row"),
            tuple(o for o in observables if o.grid == "point"),
            next((o for o in observables if o.grid == "frontier"), None))


def data_variables(spec: StudySpec, observables: tuple[Observable, ...]
                   ) -> tuple[DataVariable, ...]:
    """The variables of ``observables`` in the study's result, dims and attributes
    (without the ``coordinates`` attribute, which a file adds)."""
    structure_dims = tuple(axis.name for axis in spec.structure_axes)
    return tuple(
        DataVariable(name, VARIABLES[name].grid, VARIABLES[name].dims(structure_dims),
                     VARIABLES[name].dtype, VARIABLES[name].attrs(spec.flight))
        for observable in observables for name in observable.variables
    )


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
                  spec.flight)


def method_description(spec: StudySpec) -> str:
    """How the velocities were computed, for a result's own description."""
    if spec.method == "exact" and spec.coupling == "two-way":
        return (
            "the exact event-driven steady-state solver (closed form between events; "
            "two-way coupling: the sliding base also forces the mode, the orbit is the "
            "fixed point of the period map found by Newton's method"
            + ("; flight: past lift-off the base flies and lands by impacts)"
               if spec.flight else ")")
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
        + ("; flight: past lift-off the base flies and lands by impacts" if spec.flight
           else "") + ")"
    )
