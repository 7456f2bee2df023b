"""The parsed study spec: its frozen types (:class:`StudySpec`, :class:`Axis`,
:class:`MassModel`) and the vocabulary of keys they are built from
(:mod:`study.studies.spec` parses a file into them)."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.engine.spec_files import (
    SCHEMA_DIR,
    canonical_sha256,
)
from study.model.contact import (
    DEFAULT_COUPLING,
    DEFAULT_LIFT_OFF,
    Friction,
)
from study.model.parameters import (
    DRIVE,
    MASS,
    STRUCTURE,
)
from study.model.structure import Structure, tilt_warnings
from study.solvers.integrator import IntegratorSettings
from study.solvers.protocol import SWEEP_DIRECTIONS
from study.solvers.settings import SolverSettings
from study.studies.observables import OBSERVABLES as OBSERVABLE_REGISTRY
from study.studies.observables import (
    BasinSettings,
)
from study.studies.variables import DEFAULT_MAX_ATTRACTORS

__all__ = [
    "DRIVE_PARAMETERS",
    "EXACT_KEYS",
    "INTEGRATOR_KEYS",
    "MASS_PARAMETERS",
    "MAX_BASIN_SETTINGS",
    "OBSERVABLES",
    "PROTOCOL_DIRECTIONS",
    "PROTOCOL_KEYS",
    "SOLVER_OBSERVABLES",
    "SPEC_SCHEMA",
    "SPEC_SCHEMA_PATH",
    "STRUCTURE_PARAMETERS",
    "SWEEPABLE",
    "Axis",
    "MassModel",
    "StudySpec",
    "build_structure",
]


SPEC_SCHEMA = "study-spec-v1"
#: The JSON schema of study specs (package data; ``results_schema/`` holds a copy).
SPEC_SCHEMA_PATH = SCHEMA_DIR / f"{SPEC_SCHEMA}.schema.json"

#: Observables a study can ask for, in the order they appear in a dataset (declared
#: in :mod:`study.studies.observables`).
OBSERVABLES = tuple(OBSERVABLE_REGISTRY)
#: Observables that need the steady-state solver (and hence the drive acceleration a).
SOLVER_OBSERVABLES = tuple(
    name for name, o in OBSERVABLE_REGISTRY.items() if o.needs_acceleration
)
#: ``[solver]`` keys of the exact solver and of the time integrator.
EXACT_KEYS = ("max_events", "max_map_iterations", "continuation", "velocity_tolerance",
              "max_average_periods", "start")
INTEGRATOR_KEYS = (
    "tolerance", "steps_per_period", "max_periods", "max_orbit_period", "period_tolerance",
)

#: ``[basins]``: the largest values a spec may give (starts: each costs a solve per
#: point; seed: the draws' generator takes any, 32 bits are plenty; max_attractors:
#: slots per point, each a value of every per-attractor variable).
MAX_BASIN_SETTINGS = {"starts": 100_000, "seed": 2**32 - 1, "max_attractors": 1_000,
                      "sweep_steps": 1_000}

#: ``[sweep] protocol`` keys and the directions it takes ("both": up, then down).
PROTOCOL_KEYS = ("along", "direction")
PROTOCOL_DIRECTIONS = (*SWEEP_DIRECTIONS, "both")

#: Structure parameters: units and long names (SI inside), from the parameter table
#: (:mod:`study.model.parameters`), as are the drive's and the swept mass's.
STRUCTURE_PARAMETERS = {name: (p.units, p.long_name) for name, p in STRUCTURE.items()}
DRIVE_PARAMETERS = {name: (p.units, p.long_name) for name, p in DRIVE.items()}
MASS_PARAMETERS = {name: (MASS[name].units, MASS[name].long_name) for name in ("m_add",)}
SWEEPABLE = {**STRUCTURE_PARAMETERS, **MASS_PARAMETERS, **DRIVE_PARAMETERS}


@dataclass(frozen=True)
class Axis:
    """One swept parameter: a dimension of the result dataset.

    Attributes
    ----------
    name : str
        Parameter name, also the dimension and coordinate name.
    values : numpy.ndarray
        The values, in the parameter's SI units.
    units, long_name : str
        CF ``units`` and ``long_name`` of the coordinate.
    """

    name: str
    values: NDArray[np.float64] = field(repr=False)
    units: str
    long_name: str

    def __len__(self) -> int:
        return self.values.size


@dataclass(frozen=True)
class MassModel:
    """The mass ratio in the paper's terms: ``M = m1 / (m0 + m_add)`` (masses in kg)."""

    m0: float
    m1: float

    def mass_ratio(self, m_add: float) -> float:
        """``M`` for an added non-resonant mass ``m_add`` [kg]."""
        return self.m1 / (self.m0 + m_add)


@dataclass(frozen=True)
class StudySpec:
    """A validated study spec.

    Attributes
    ----------
    name : str
        Study name (also the default result file stem).
    observables : tuple of str
        Requested observables, in :data:`OBSERVABLES` order.
    fixed : dict
        Fixed structure parameters (``m_add`` included when fixed).
    mass : MassModel or None
        Set when the mass ratio is declared through masses.
    axes : tuple of Axis
        Swept parameters in dataset dimension order: structure axes as declared,
        then ``f``, then ``a`` (the fastest-varying dimension).
    solver : SolverSettings
        Budgets of the exact solver.
    method : {"exact", "integrator"}
        Velocity solver: the exact steady-state solver, or time integration until
        the orbit repeats.
    coupling : {"one-way", "two-way"}
        Whether the sliding base also forces the mode (two-way; either method); default
        :data:`study.solvers.exact.DEFAULT_COUPLING`.
    integrator : IntegratorSettings
        Accuracy and budgets of the time integrator (used with ``method = "integrator"``).
    friction : Friction
        The friction law (``[solver] friction``).
    protocol : tuple of str or None
        ``[sweep] protocol``: ``(along, direction)`` of a slow sweep
        (:func:`study.solvers.protocol.slow_sweep`; direction ``"both"``: up and down,
        a leading ``direction`` dimension); None: every point from its start.
    basins : BasinSettings or None
        ``[basins]``: how the ``basins`` observable samples each point (its defaults
        where the table is absent); None: the study does not ask for ``basins``.
    flight : bool
        ``[solver] flight = true``: past lift-off the base flies and lands by impacts
        (the lift-off law ``flight`` of :mod:`study.model.contact`); default false, the
        run stops with ``LIFT_OFF`` there. Needs two-way coupling and ``M < 1``.
    chunk_points : int
        Target number of grid points per parallel task (default
        :func:`default_chunk_points`).
    frontier_tolerance : float
        Bracket width at which frontier roots are accepted [Hz].
    text : str
        The spec file's text, kept verbatim for provenance.
    path : str
        Where it was read from.
    warnings : tuple of str
        What looks like a mistake but is allowed (a tilt that looks like radians, a drop
        start that looks like millimetres, drive frequencies that look like angular
        ones), one message each naming the file, the key and the value;
        :func:`load_spec` warns of each.
    """

    name: str
    title: str
    description: str
    observables: tuple[str, ...]
    fixed: dict[str, float]
    mass: MassModel | None
    axes: tuple[Axis, ...]
    solver: SolverSettings
    chunk_points: int
    frontier_tolerance: float
    text: str = field(repr=False)
    path: str
    canonical: dict[str, Any] = field(repr=False)
    method: str = "exact"
    coupling: str = DEFAULT_COUPLING
    integrator: IntegratorSettings = field(default_factory=IntegratorSettings)
    friction: Friction = field(default_factory=Friction)
    flight: bool = False
    protocol: tuple[str, str] | None = None
    basins: BasinSettings | None = None
    warnings: tuple[str, ...] = field(default=(), repr=False, compare=False)

    @property
    def lift_off(self) -> str:
        """The lift-off law's name (:data:`study.model.contact.LIFT_OFF_LAWS`)."""
        return "flight" if self.flight else DEFAULT_LIFT_OFF

    @property
    def sha256(self) -> str:
        """Hash of the canonical form: formatting, comments and key order do not count."""
        return canonical_sha256(self.canonical)

    @property
    def structure_axes(self) -> tuple[Axis, ...]:
        """Swept parameters that change the structure (everything but f and a)."""
        return tuple(axis for axis in self.axes if axis.name not in DRIVE_PARAMETERS)

    def axis(self, name: str) -> Axis | None:
        """The swept axis called ``name``, if any."""
        return next((axis for axis in self.axes if axis.name == name), None)

    @property
    def directions(self) -> tuple[str, ...]:
        """The slow sweep's directions, ``("up", "down")`` for ``"both"``; ``()``
        without a protocol."""
        if self.protocol is None:
            return ()
        return SWEEP_DIRECTIONS if self.protocol[1] == "both" else (self.protocol[1],)

    @property
    def both_directions(self) -> bool:
        """Whether point variables have a leading ``direction`` dimension."""
        return len(self.directions) == 2

    @property
    def dimension_sizes(self) -> dict[str, int]:
        """Lengths of the dimensions after a drive point's
        (:data:`study.studies.variables.GRID_SIZES`, the attractor slots set by
        ``[basins] max_attractors``): the ``sizes`` of
        :meth:`study.studies.variables.Variable.trailing`."""
        slots = self.basins.max_attractors if self.basins is not None \
            else DEFAULT_MAX_ATTRACTORS
        return {"attractor": slots}

    @property
    def needs_solver(self) -> bool:
        """Whether any requested observable needs the velocity solver."""
        return any(o in self.observables for o in SOLVER_OBSERVABLES)

    def structure_at(self, index: tuple[int, ...]) -> Structure:
        """The structure at one point of the structure axes (``index`` in their order)."""
        params = dict(self.fixed)
        for axis, i in zip(self.structure_axes, index, strict=True):
            params[axis.name] = float(axis.values[i])
        return build_structure(params, self.mass)

    def structures(self) -> Iterator[tuple[tuple[int, ...], Structure]]:
        """Every structure of the study with its index along the structure axes."""
        ranges = [range(len(axis)) for axis in self.structure_axes]
        for index in itertools.product(*ranges):
            yield index, self.structure_at(index)


def build_structure(params: dict[str, float], mass: MassModel | None) -> Structure:
    params = dict(params)
    m_add = params.pop("m_add", None)
    if mass is not None:
        params["M"] = mass.mass_ratio(0.0 if m_add is None else m_add)
    with tilt_warnings(False):  # a spec's tilts are in degree by its schema
        return Structure(**params)
