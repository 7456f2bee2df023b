"""Declarative study specs: TOML files under ``workflows/``, validated before any work.

A spec names the study, the structure (any parameter fixed or swept), the drive
grid, the observables wanted and optional solver settings::

    [study]
    name = "regime-map"
    observables = ["thresholds", "velocity"]

    [structure]
    f0 = 14.44
    Q = 17.5
    alpha = 64.0
    M = 0.08
    cs = 0.25

    [sweep]
    f = { start = 10.0, stop = 20.0, num = 401 }
    a = { start = 0.0, stop = 12.0, num = 241 }

The machine-readable schema is ``study/schemas/study-spec-v1.schema.json``; the
checks that a JSON schema cannot express (a parameter both fixed and swept, every
swept structure being valid) are made here. Every refusal is a :class:`SpecError`
naming the file, the key and what is allowed; the checks that do not depend on each
other all run, and one :class:`SpecError` lists every problem they found, one a line.

A parameter that the chosen model does not read is refused (``restitution`` without
``[solver] flight = true``): which law reads which structure parameter is declared once,
with the law (:attr:`study.model.contact.ContactLaw.structure_parameters`). A tilt that
looks like radians is allowed but warned of (:func:`load_spec`, as :class:`study.Structure`
does).
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from study.engine.observables import (
    BASIN_KEYS,
    METHODS,
    UNSWEPT_VARIABLES,
    BasinSettings,
    unmet_needs,
    variables_of,
)
from study.engine.observables import OBSERVABLES as OBSERVABLE_REGISTRY
from study.engine.spec_files import (
    SCHEMA_DIR,
    SpecError,
    axis_length,
    axis_values,
    canonical_sha256,
    load_schema,
    parse_toml,
    read_spec_text,
    schema_error,
    schema_problems,
)
from study.engine.variables import DEFAULT_MAX_ATTRACTORS
from study.model import starts
from study.model.contact import (
    DEFAULT_COUPLING,
    DEFAULT_FRICTION,
    DEFAULT_LIFT_OFF,
    LAWS,
    ContactLaw,
    Friction,
    check_friction,
    check_law,
)
from study.model.inputs import (
    SuspectInputWarning,
    drop_height_note,
    frequency_axis_note,
    radian_tilt_note,
    tilt_looks_like_radians,
)
from study.model.parameters import (
    DRIVE,
    MASS,
    STRUCTURE,
    schema_definition,
    schema_properties,
)
from study.model.starts import Drop
from study.model.structure import Structure, tilt_warnings
from study.solvers.basins import DROP_HEIGHT_RANGE, FACTOR_RANGE
from study.solvers.frontier import finest_tolerance
from study.solvers.integrator import MAX_INTEGRATOR_BUDGET, IntegratorSettings
from study.solvers.protocol import SWEEP_AXES, SWEEP_DIRECTIONS
from study.solvers.settings import MAX_SOLVER_BUDGET, SolverSettings

__all__ = [
    "METHODS",
    "OBSERVABLES",
    "SOLVER_OBSERVABLES",
    "SPEC_SCHEMA_PATH",
    "Axis",
    "MassModel",
    "SpecError",
    "StudySpec",
    "default_chunk_points",
    "load_spec",
    "parse_spec",
]

SPEC_SCHEMA = "study-spec-v1"
#: The JSON schema of study specs (package data; ``results_schema/`` holds a copy).
SPEC_SCHEMA_PATH = SCHEMA_DIR / f"{SPEC_SCHEMA}.schema.json"

#: Observables a study can ask for, in the order they appear in a dataset (declared
#: in :mod:`study.engine.observables`).
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
        (:data:`study.engine.variables.GRID_SIZES`, the attractor slots set by
        ``[basins] max_attractors``): the ``sizes`` of
        :meth:`study.engine.variables.Variable.trailing`."""
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
        return _build_structure(params, self.mass)

    def structures(self) -> Iterator[tuple[tuple[int, ...], Structure]]:
        """Every structure of the study with its index along the structure axes."""
        ranges = [range(len(axis)) for axis in self.structure_axes]
        for index in itertools.product(*ranges):
            yield index, self.structure_at(index)


def _build_structure(params: dict[str, float], mass: MassModel | None) -> Structure:
    params = dict(params)
    m_add = params.pop("m_add", None)
    if mass is not None:
        params["M"] = mass.mass_ratio(0.0 if m_add is None else m_add)
    with tilt_warnings(False):  # a spec's tilts are in degree by its schema
        return Structure(**params)


def spec_schema() -> dict[str, Any]:
    """The JSON schema of study specs (``study/schemas/study-spec-v1.schema.json``).

    The parameters' ranges and descriptions come from :mod:`study.model.parameters`, the
    observables allowed and their descriptions from :mod:`study.engine.observables`,
    the solvers' budgets' maxima from :data:`study.solvers.settings.MAX_SOLVER_BUDGET` and
    :data:`study.solvers.integrator.MAX_INTEGRATOR_BUDGET` (the file on disk is their
    export, see :func:`export_spec_schema`).
    """
    schema = load_schema(SPEC_SCHEMA)
    schema["$defs"]["parameter"] = {name: schema_definition(name) for name in SWEEPABLE}
    structure = schema["properties"]["structure"]
    mass = structure["properties"]["mass"]
    mass["properties"] = {**schema_properties(name for name in MASS if name != "m_add"),
                          "m_add": {"$ref": "#/$defs/parameter/m_add"}}
    structure["properties"] = {
        **{name: {"$ref": f"#/$defs/parameter/{name}"} for name in STRUCTURE}, "mass": mass}
    schema["properties"]["sweep"]["properties"] = {
        **{name: {"$ref": "#/$defs/axis"} for name in (*DRIVE, *STRUCTURE, "m_add")},
        "protocol": {
            "type": "object",
            "additionalProperties": False,
            "required": ["along"],
            "properties": {
                "along": {"enum": list(SWEEP_AXES), "description": "the drive axis stepped"},
                "direction": {"enum": list(PROTOCOL_DIRECTIONS), "default": "up",
                              "description": "up: increasing values; down: decreasing"},
            },
            "description": (
                "exact solver, two-way coupling: a slow sweep (docs/theory/starts.md): "
                "along the axis the drive steps to the next value at phase 0 with the "
                "state carried, one run for each value of the other drive axis, the "
                "first point of a run started by [solver] start; absent: every point "
                "from its start"),
        },
    }
    listed = schema["properties"]["study"]["properties"]["observables"]
    listed["description"] = ("a non-empty list of distinct names from: "
                             + ", ".join(OBSERVABLES))
    items = listed["items"]
    items["enum"] = list(OBSERVABLES)
    items["description"] = "; ".join(
        f"{name}: {o.summary}" for name, o in OBSERVABLE_REGISTRY.items())
    solver = schema["properties"]["solver"]["properties"]
    for name, largest in {**MAX_SOLVER_BUDGET, **MAX_INTEGRATOR_BUDGET}.items():
        solver[name]["maximum"] = largest
    solver["friction"] = _friction_schema()
    solver["flight"] = _flight_schema()
    solver["continuation"] = {
        "type": "boolean",
        "default": False,
        "description": (
            "exact solver, two-way coupling: true: each orbit's Newton search starts from "
            "the fixed points of the points before it along its line of the sweep (2-4x "
            "faster on fine maps; where several motions are stable it follows its "
            "neighbours' branch, as a slowly swept drive, and a point's value depends on "
            "its grid); false (default): every point from rest"),
    }
    solver["start"] = _start_schema()
    schema["properties"]["basins"] = _basins_schema()
    return schema


def _basins_schema() -> dict[str, Any]:
    """``[basins]``: the basins observable's sampling (:class:`BasinSettings`)."""
    defaults = BasinSettings()
    lowest = {"starts": 1, "seed": 0, "max_attractors": 1, "sweep_steps": 0}
    words = {
        "starts": "starts followed at each drive point: the solver's start ([solver] "
                  "start), then seeded draws (the base at rest at a drive phase drawn "
                  "uniformly, the mode at rest on a multiple of its steady response drawn "
                  f"from [{FACTOR_RANGE[0]:g}, {FACTOR_RANGE[1]:g}); with flight every third "
                  "draw dropped from a height drawn log-uniformly from "
                  f"{1e3 * DROP_HEIGHT_RANGE[0]:g} to {1e3 * DROP_HEIGHT_RANGE[1]:g} mm)",
        "seed": "seed of the draws: the same starts at every point and on every machine",
        "max_attractors": "attractor slots per point (the attractor dimension): a point "
                          "with more attractors keeps the first ones its starts reach "
                          "(attractor_count stays exact)",
        "sweep_steps": "steps of the slow sweep down along f, from 1.5 times each point's "
                       "frequency (the release there) to the point, whose end state is "
                       "followed as one more start: it reaches the motions born at faster "
                       "drives that no drawn start reaches, counted among the attractors "
                       "but not in the fractions (shares of the drawn starts); 0: none",
    }
    return {
        "type": "object",
        "additionalProperties": False,
        "properties": {
            key: {"type": "integer", "minimum": lowest[key],
                  "maximum": MAX_BASIN_SETTINGS[key], "default": getattr(defaults, key),
                  "description": f"{words[key]} (default {getattr(defaults, key)})"}
            for key in BASIN_KEYS},
        "description": (
            "only with the observable basins (exact solver, two-way coupling): how each "
            "drive point is sampled; absent: the defaults"),
    }


def _start_schema() -> dict[str, Any]:
    """``[solver] start``: a named start or a start's table, from the declared kinds
    (:func:`study.model.starts.spec_schema`; :func:`study.model.starts.as_start` checks
    them, with the messages the API gives)."""
    return starts.spec_schema()


def _flight_schema() -> dict[str, Any]:
    """``[solver] flight`` from the lift-off laws' declarations
    (:data:`study.model.contact.LAWS`)."""
    law = LAWS["lift_off"]["flight"]
    stop = LAWS["lift_off"][DEFAULT_LIFT_OFF]
    return {
        "type": "boolean",
        "default": False,
        "description": (
            f"true: the lift-off law 'flight': {law.description} (methods: "
            f"{', '.join(law.solvers)}; needs coupling = \"two-way\" and M < 1); false "
            f"(default): '{stop.name}', {stop.description}"),
    }


def _friction_schema() -> dict[str, Any]:
    """``[solver] friction`` from the friction laws' declarations
    (:data:`study.model.contact.LAWS`): a law's name, or a table of the law and its
    parameters."""
    laws = LAWS["friction"]
    forms: list[dict[str, Any]] = [
        {"enum": [name for name, law in laws.items() if not law.parameters]}]
    for name, law in laws.items():
        if law.parameters:
            forms.append({
                "type": "object",
                "additionalProperties": False,
                "required": ["law", *(p.name for p in law.parameters)],
                "properties": {
                    "law": {"const": name},
                    **{p.name: {"type": "number", "exclusiveMinimum": p.lower,
                                "description": f"{p.long_name} [{p.units}]"}
                       for p in law.parameters},
                },
            })
    return {
        "default": DEFAULT_FRICTION,
        "oneOf": forms,
        "description": "friction law: " + "; ".join(
            f"{name}{' (default)' if name == DEFAULT_FRICTION else ''}: {law.description}"
            + (f" (solvers: {', '.join(law.solvers)}; give "
               f"{{ law = \"{name}\", {', '.join(p.name + ' = ...' for p in law.parameters)} }})"
               if law.parameters else "")
            for name, law in laws.items()),
    }


def export_spec_schema() -> str:
    """The spec schema as written to ``study/schemas`` (``make schemas``)."""
    import json

    return json.dumps(spec_schema(), indent=2) + "\n"


def load_spec(path: str | Path) -> StudySpec:
    """Read and validate a study spec file.

    Parameters
    ----------
    path : str or pathlib.Path
        A TOML file (UTF-8, at most :data:`study.engine.spec_files.MAX_SPEC_BYTES` bytes).

    Raises
    ------
    SpecError
        If the file cannot be read or parsed, or any key is unknown, mistyped or
        out of range, or the study would be absurdly large, or a parameter is given
        that the chosen laws do not read; every problem found, one a line. Nothing has
        been computed at that point.

    Warns
    -----
    study.SuspectInputWarning
        For each of :attr:`StudySpec.warnings` (a tilt that looks like radians, a drop
        height like millimetres, drive frequencies like angular ones).
    """
    spec = parse_spec(read_spec_text(path, "study spec"), str(path))
    for message in spec.warnings:
        warnings.warn(message, SuspectInputWarning, stacklevel=2)
    return spec


#: Grid points per chunk without ``[solver] chunk_points``: at least ...
CHUNK_POINTS_MIN = 20_000
#: ... and at most.
CHUNK_POINTS_MAX = 100_000


def default_chunk_points(points: int) -> int:
    """Points per chunk for a study of ``points`` grid points in all.

    A sixteenth of the study, within [:data:`CHUNK_POINTS_MIN`,
    :data:`CHUNK_POINTS_MAX`]: a small study keeps enough chunks to share among
    threads, and a large one pays the fixed cost of a chunk (a task, a cache block
    file, an HDF5 chunk: 2-3 ms) on fewer chunks (a 1e7-point velocity study: 8.1
    instead of 9.2 s of CPU with 100 000 instead of 20 000 points per chunk).
    """
    return int(min(CHUNK_POINTS_MAX, max(CHUNK_POINTS_MIN, points // 16)))


def parse_spec(text: str, path: str = "<string>") -> StudySpec:
    """Validate a study spec given as TOML text (see :func:`load_spec`).

    The schema's violations and the problems of the spec's other checks are reported
    together: a check runs on what no violation leaves unknown (an unknown observable
    and ``num = 0`` do not keep ``M = 1`` with flight for a second run), and one that
    reads a refused key is left for the run after its fix."""
    raw = parse_toml(text, path)
    # Before the schema, whose words for a parameter of another law are only "does not
    # match any allowed form": its own message, in place of the schema's.
    problems = _Problems(path)
    _check_unread_friction(raw, path, problems)
    tainted = [("solver", "friction")] if problems.messages else []
    violations = [(message, where) for message, where in schema_problems(raw, spec_schema())
                  if not any(_overlap(where, t) for t in tainted)]
    if not violations and not problems.messages:
        return _build(raw, text, path)
    tainted += [where for _, where in violations]
    before = list(problems.messages)
    others = _Problems(path, tuple(tainted))
    _check_parts(raw, path, others)
    if not others.messages and not before:  # the schema's alone, as they always read
        raise schema_error(violations, path, "study spec")
    problems.messages = [*before, *(f"{path}: {m}" for m, _ in violations), *others.messages]
    raise problems.error()


def _overlap(first: tuple[Any, ...], second: tuple[Any, ...]) -> bool:
    """Whether two locations in a spec (key paths) are one within the other."""
    n = min(len(first), len(second))
    return first[:n] == second[:n]


def _parameter_bounds(name: str) -> tuple[str, Any]:
    """The schema's range of a parameter: its text and a test of an array against it."""
    definition = spec_schema()["$defs"]["parameter"][name]
    operators = {
        "minimum": (np.greater_equal, ">="), "exclusiveMinimum": (np.greater, ">"),
        "maximum": (np.less_equal, "<="), "exclusiveMaximum": (np.less, "<"),
    }
    checks = [(*operators[k], definition[k]) for k in operators if k in definition]
    text = " and ".join(f"{symbol} {bound}" for _, symbol, bound in checks)

    def inside(values: NDArray[np.float64]) -> NDArray[np.bool_]:
        ok = np.ones(values.shape, dtype=bool)
        for compare, _, bound in checks:
            ok &= compare(values, bound)
        return ok

    return text, inside


# ---------------------------------------------------------------------------
# Size guard: refuse a study whose output or memory would be absurd, before any work

#: Grid points of a study at most: 20 times the 1e8-point benchmark study (at about
#: 1e6 points per second and core, 2e9 points already take hours on a workstation).
MAX_POINTS = 2_000_000_000
#: Result file size at most [bytes] (uncompressed values).
MAX_OUTPUT_BYTES = 64 * 2**30
#: Values one chunk (one parallel task) holds at most [bytes]: every worker thread
#: holds one or two chunks, so a 16-thread run stays within a few GiB.
MAX_CHUNK_BYTES = 256 * 2**20
#: Chunks (parallel tasks) of a study at most: the plan, the progress and the kept
#: chunks scale with it.
MAX_CHUNKS = 1_000_000

def _size(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} EiB"  # pragma: no cover


def check_size(lengths: dict[str, int], observables: tuple[str, ...], chunk_points: int,
               path: str, flight: bool = False,
               protocol: tuple[object, object] | None = None,
               max_attractors: int = DEFAULT_MAX_ATTRACTORS) -> None:
    """Refuse a study whose output or memory would be absurd, before any work.

    Parameters
    ----------
    lengths : dict
        Swept parameter -> number of values, in dataset dimension order (``f`` and
        ``a`` last).
    observables : tuple of str
        Requested observables.
    chunk_points : int
        ``[solver] chunk_points``.
    path : str
        The spec file, for messages.
    flight : bool
        ``[solver] flight``: the velocity observable writes its flight variables too.
    protocol : tuple, optional
        ``(along, direction)`` of ``[sweep] protocol`` as given (checked later): a slow
        sweep writes ``jumped`` too; ``direction = "both"`` computes and writes every
        per-point variable twice (but the unswept ones) in twice the chunks; along
        ``f`` one chunk holds every ``f`` and ``a`` of a structure.
    max_attractors : int
        ``[basins] max_attractors``: the attractor slots of each point of the basins
        observable's per-attractor variables.

    Raises
    ------
    SpecError
        Naming the sweep keys (or ``chunk_points``), the size and the limit, when the
        study has more than :data:`MAX_POINTS` points, more than :data:`MAX_OUTPUT_BYTES`
        of output, a chunk larger than :data:`MAX_CHUNK_BYTES` or more than
        :data:`MAX_CHUNKS` chunks.
    """
    needs_solver = any(o in observables for o in SOLVER_OBSERVABLES)
    structures = math.prod(n for name, n in lengths.items() if name not in DRIVE_PARAMETERS)
    n_f = lengths.get("f", 1)
    n_a = lengths.get("a", 1) if needs_solver else 1
    # What each variable holds per point, from its declaration (a phase section's
    # periods too).
    variables = variables_of(observables, flight, protocol is not None)
    per_f_bytes = sum(np.dtype(v.dtype).itemsize for v in variables if v.grid == "row")
    sizes = {"attractor": max_attractors}
    point_bytes = {v.name: np.dtype(v.dtype).itemsize * math.prod(v.trailing(sizes))
                   for v in variables if v.grid in ("point", "section", "attractor")}
    per_point_bytes = sum(point_bytes.values())
    # A slow sweep both ways: every point computed and written once each way, but the
    # values of each point from its start alone (no direction dimension).
    directions = 2 if protocol is not None and protocol[1] == "both" else 1
    written_point_bytes = per_point_bytes + (directions - 1) * sum(
        size for name, size in point_bytes.items() if name not in UNSWEPT_VARIABLES)
    swept = [name for name in lengths if needs_solver or name != "a"]
    keys = " x ".join(swept)
    sizes = " x ".join(str(lengths[name]) for name in swept)
    points = structures * n_f * n_a * directions
    output = structures * n_f * (per_f_bytes + n_a * written_point_bytes)
    if points > MAX_POINTS or output > MAX_OUTPUT_BYTES:
        both = (' x 2 directions ([sweep] protocol direction = "both")'
                if directions == 2 else "")
        raise SpecError(
            f"{path}: [sweep] {keys} = {sizes}{both} = {points:.3g} points "
            f"({_size(output)} of output); allowed at most {MAX_POINTS:.3g} points and "
            f"{_size(MAX_OUTPUT_BYTES)}: sweep fewer values"
        )
    # How study.engine.sweep cuts the grid: whole frequency rows (every a), about
    # chunk_points points per chunk; a slow sweep along f holds every f in one chunk
    # (its runs whole).
    along_f = needs_solver and protocol is not None and protocol[0] == "f"
    if along_f:
        chunk_bytes = n_f * (per_f_bytes + n_a * per_point_bytes)
        if chunk_bytes > MAX_CHUNK_BYTES:
            raise SpecError(
                f'{path}: [sweep] protocol along = "f": one task holds every f and a of a '
                f"structure ({n_f} x {n_a} points), {_size(chunk_bytes)}, more than one "
                f"task may hold ({_size(MAX_CHUNK_BYTES)}); allowed: at most "
                f"{MAX_CHUNK_BYTES // max(per_point_bytes, 1)} points (f x a), or "
                'along = "a"'
            )
    f_per_chunk = n_f if along_f else max(1, min(n_f, chunk_points // n_a))
    chunk_bytes = f_per_chunk * (per_f_bytes + n_a * per_point_bytes)
    if chunk_bytes > MAX_CHUNK_BYTES:
        if f_per_chunk == 1:
            raise SpecError(
                f"{path}: [sweep] a: one frequency row of {n_a} accelerations holds "
                f"{_size(chunk_bytes)}, more than one task may hold "
                f"({_size(MAX_CHUNK_BYTES)}); allowed: at most "
                f"{MAX_CHUNK_BYTES // max(per_point_bytes, 1)} values of a"
            )
        per_chunk_point = chunk_bytes / (f_per_chunk * n_a)
        raise SpecError(
            f"{path}: [solver] chunk_points = {chunk_points} makes tasks of "
            f"{_size(chunk_bytes)}; allowed: at most {int(MAX_CHUNK_BYTES // per_chunk_point)} "
            "points per chunk"
        )
    chunks = structures * math.ceil(n_f / f_per_chunk) * directions
    if chunks > MAX_CHUNKS:
        smallest = math.ceil(points / MAX_CHUNKS)
        raise SpecError(
            f"{path}: [solver] chunk_points = {chunk_points} cuts [sweep] {keys} into "
            f"{chunks:.3g} chunks; allowed at most {MAX_CHUNKS:.3g}: raise chunk_points to "
            f"at least {smallest} or sweep fewer structures"
        )


#: A location that stands for the key names of a table (whether a key is given), not
#: their values: ``("sweep", KEYS)`` is read by a check that asks which parameters are
#: swept, and is left unknown only by a violation of the whole table.
KEYS = "<keys>"


class _Problems:
    """The problems of one spec, gathered so that one :class:`SpecError` names them all.

    ``tainted``: the locations (key paths) the schema refused; a check that reads one of
    them (:meth:`reading`) is not run, since its answer would follow from the refusal.
    """

    def __init__(self, path: str, tainted: tuple[tuple[Any, ...], ...] = ()) -> None:
        self.path = path
        self.tainted = tainted
        self.messages: list[str] = []

    def add(self, message: str) -> None:
        self.messages.append(message)

    def reads(self, *locations: tuple[Any, ...]) -> bool:
        """Whether a check that reads ``locations`` may run: none is tainted."""
        return not any(_overlap(location, t) for location in locations for t in self.tainted)

    def collect(self, check: Any, *args: Any) -> Any:
        """``check(*args)``, its :class:`SpecError` kept as a problem (then None)."""
        try:
            return check(*args)
        except SpecError as err:
            self.add(str(err))
            return None

    def reading(self, locations: tuple[tuple[Any, ...], ...], check: Any, *args: Any) -> Any:
        """:meth:`collect` of a check that reads ``locations``; None, unrun, if one is
        tainted. Beside the schema's violations a check that trips on what they left
        (a value it did not expect) adds nothing: the spec is refused already."""
        if not self.reads(*locations):
            return None
        if not self.tainted:
            return self.collect(check, *args)
        try:
            return self.collect(check, *args)
        except (TypeError, ValueError, KeyError, AttributeError, IndexError):
            return None

    def error(self) -> SpecError:
        """One :class:`SpecError` of the problems found: a single problem's message as it
        is; several under a first line naming the file, one a line."""
        if len(self.messages) == 1:
            return SpecError(self.messages[0])
        return SpecError(f"{self.path}: {len(self.messages)} problems, each to fix:\n"
                         + "\n".join(f"  - {m}" for m in self.messages))

    def raise_any(self) -> None:
        """Raise :meth:`error` if any problem was found."""
        if self.messages:
            raise self.error()


class _Parts(NamedTuple):
    """A spec's tables, each checked (:func:`_check_parts`)."""

    study: dict[str, Any]
    observables: tuple[str, ...]
    fixed: dict[str, float]
    mass: MassModel | None
    sweep: dict[str, Any]
    axes: list[Axis]
    chunk_points: int
    settings: tuple[Any, ...]
    flight: bool
    protocol: tuple[str, str] | None
    basins: BasinSettings | None


def _table(raw: dict[str, Any], name: str) -> dict[str, Any]:
    """A table of the spec, or an empty one where it is absent or not a table (then the
    schema has refused it, and the checks reading it do not run)."""
    table = raw.get(name, {})
    return dict(table) if isinstance(table, dict) else {}


def _check_parts(raw: dict[str, Any], path: str, problems: _Problems) -> _Parts | None:
    """Check a spec's tables: the structure, the sweep, the solver settings, flight, the
    parameters the laws read and every structure of the study are checked
    independently, each problem added to ``problems``; the checked parts, or None.

    Each check names the locations it reads, so that beside the schema's violations
    (``problems.tainted``) the checks of the rest still run."""
    study = _table(raw, "study")
    structure = _table(raw, "structure")
    mass_table = structure.pop("mass", None)
    sweep = _table(raw, "sweep")
    solver_table = _table(raw, "solver")
    asked_flight = solver_table.get("flight", False) is True

    observed = ("study", "observables")
    asked = study.get("observables", ())
    observables = tuple(o for o in OBSERVABLES
                        if isinstance(asked, list | tuple) and o in asked)
    fixed_mass = problems.reading((("structure",), ("sweep", KEYS)), _fixed_structure,
                                  structure, mass_table, sweep, path)
    swept = problems.reading(
        (("sweep",), observed, ("solver", "chunk_points"), ("solver", "flight"),
         ("basins", "max_attractors")),
        _sweep_axes, sweep, observables, solver_table, path, _given_slots(raw.get("basins")))
    problems.reading((("solver", "method"), ("solver", "coupling"), ("solver", "flight"),
                      observed, ("sweep", KEYS)), _needs, solver_table, observables, path,
                     problems, "protocol" in sweep)
    settings = problems.reading((("solver",),), _solver, solver_table,
                                None if swept is None else swept[0], path, problems)
    method = solver_table.get("method", "exact")
    coupling = solver_table.get("coupling", DEFAULT_COUPLING)
    flight = problems.reading((("solver", "flight"), ("solver", "method"),
                               ("solver", "coupling")), _flight, solver_table, method,
                              coupling, path)
    if settings is not None:
        problems.reading((("solver",), observed), _check_start, settings[3], coupling, flight,
                         observables, path, problems)
    protocol = None if settings is None else problems.reading(
        (("sweep",), observed, ("solver",)), _protocol, sweep, observables, settings[0],
        coupling, settings[3], path)
    basins = None if settings is None else problems.reading(
        (("basins",), observed, ("sweep", KEYS), ("solver",)), _basins, raw.get("basins"),
        observables, "protocol" in sweep, settings[3], path)
    # The law asked for, even where refused above: its parameters are not unread.
    problems.reading((("structure", KEYS), ("sweep", KEYS), ("solver", "friction"),
                      ("solver", "coupling"), ("solver", "flight")), _check_unread,
                     structure, sweep, None if settings is None else settings[2], coupling,
                     asked_flight, path, problems)
    # Every structure of the study, with the flight asked for (even if refused above:
    # M = 1 is a problem of its own); its swept parameters only once the sweep passed.
    structure_axes = _structure_axes(sweep, None if swept is None else swept[0], path,
                                     problems)
    if fixed_mass is not None and structure_axes is not None:
        problems.reading(
            (("structure",), ("sweep", KEYS), ("solver", "flight"),
             *(("sweep", axis.name) for axis in structure_axes)),
            _check_structures, fixed_mass[0], fixed_mass[1], structure_axes, asked_flight,
            path)
    if problems.messages or None in (fixed_mass, swept, settings, flight):
        return None
    return _Parts(study, observables, *fixed_mass, sweep, *swept, settings, flight,
                  protocol, basins)


def _structure_axes(sweep: dict[str, Any], axes: list[Axis] | None, path: str,
                    problems: _Problems) -> list[Axis] | None:
    """The swept structure parameters: :func:`_sweep_axes`' axes but the drive's, or,
    where the sweep was refused (a drive axis, its size), each structure axis alone
    if none is refused and they hold at most :data:`MAX_CHUNKS` structures (each is a
    chunk at least: more are the size guard's to refuse); None if unknown."""
    if axes is not None:
        return [axis for axis in axes if axis.name not in DRIVE_PARAMETERS]
    names = [name for name in sweep if name not in DRIVE_PARAMETERS and name != "protocol"]
    if not problems.reads(("sweep", KEYS), *(("sweep", name) for name in names)):
        return None
    try:
        if math.prod(axis_length(sweep[name]) for name in names) > MAX_CHUNKS:
            return None
        return [Axis(name, axis_values(sweep[name], f"{path}: [sweep] {name}"),
                     *SWEEPABLE[name]) for name in names]
    except (SpecError, TypeError, ValueError, KeyError):  # the sweep's to refuse
        return None


def _build(raw: dict[str, Any], text: str, path: str) -> StudySpec:
    """A checked :class:`StudySpec` from a spec's tables (:func:`_check_parts`: every
    problem reported together)."""
    problems = _Problems(path)
    parts = _check_parts(raw, path, problems)
    problems.raise_any()
    assert parts is not None
    study, observables, fixed, mass = parts.study, parts.observables, parts.fixed, parts.mass
    sweep, axes, chunk_points, flight = parts.sweep, parts.axes, parts.chunk_points, parts.flight
    protocol, basins = parts.protocol, parts.basins
    method, coupling, friction, solver, integrator, frontier_tolerance = parts.settings
    canonical = _canonical(study, observables, fixed, mass, sweep, axes, method, coupling,
                           friction, solver, integrator, frontier_tolerance, flight)
    if protocol is not None:  # only when given: every fingerprint without it is kept
        canonical["protocol"] = {"along": protocol[0], "direction": protocol[1]}
    if basins is not None:  # likewise: only in a study that asks for basins
        canonical["basins"] = basins.canonical()
    spec = StudySpec(
        name=study["name"],
        title=study.get("title", study["name"]),
        description=study.get("description", ""),
        observables=observables,
        fixed=fixed,
        mass=mass,
        axes=tuple(axes),
        solver=solver,
        chunk_points=chunk_points,
        frontier_tolerance=frontier_tolerance,
        text=text,
        path=path,
        canonical=canonical,
        method=method,
        coupling=coupling,
        integrator=integrator,
        friction=friction,
        flight=flight,
        protocol=protocol,
        basins=basins,
        warnings=(*_suspect_tilts(fixed, axes, path),
                  *_suspect_units(fixed, axes, solver, path)),
    )
    return spec


def _given_slots(table: Any) -> int:
    """``[basins] max_attractors`` as given (the schema has checked it), for the size
    guard; the default without it."""
    slots = table.get("max_attractors") if isinstance(table, dict) else None
    return slots if isinstance(slots, int) and not isinstance(slots, bool) \
        else DEFAULT_MAX_ATTRACTORS


def _suspect_tilts(fixed: dict[str, float], axes: list[Axis], path: str) -> tuple[str, ...]:
    """A fixed tilt that looks like radians, or a swept one whose every nonzero value
    does (:func:`study.model.inputs.tilt_looks_like_radians`, the check of
    :class:`study.Structure`): a warning each, not a refusal."""
    if "alpha" in fixed and tilt_looks_like_radians(fixed["alpha"]):
        alpha = fixed["alpha"]
        return (f"{path}: [structure] alpha = {alpha!r} degree: {radian_tilt_note(alpha)}",)
    axis = next((axis for axis in axes if axis.name == "alpha"), None)
    if axis is not None:
        tilts = [float(v) for v in axis.values if v != 0]
        if tilts and all(tilt_looks_like_radians(v) for v in tilts):
            largest = max(tilts, key=abs)
            return (f"{path}: [sweep] alpha: every tilt swept, up to {largest!r} degree, "
                    f"looks like radians: {radian_tilt_note(largest)}",)
    return ()


def _suspect_units(fixed: dict[str, float], axes: list[Axis], solver: SolverSettings,
                   path: str) -> tuple[str, ...]:
    """A drop start that looks like a height in millimetres and drive frequencies that
    look like angular ones or are far above the resonance
    (:func:`study.model.inputs.drop_height_note`, :func:`~study.model.inputs.
    frequency_axis_note`): a warning each, naming the key and the value, not a refusal
    (each is a valid study)."""
    def largest(name: str) -> float:
        axis = next((axis for axis in axes if axis.name == name), None)
        return float(np.max(axis.values)) if axis is not None else float(
            fixed.get(name, STRUCTURE[name].default))

    f = next(axis for axis in axes if axis.name == "f").values
    f_min, f_max = float(np.min(f)), float(np.max(f))
    found = []
    start = solver.start
    if isinstance(start, Drop):
        note = drop_height_note(start.height, f_min, largest("g"))
        if note is not None:
            found.append(f"{path}: [solver] start drop = {start.height!r} m: a drop of "
                         f"{note}")
    note = frequency_axis_note(f_min, f_max, largest("f0"))
    if note is not None:
        found.append(f"{path}: [sweep] f = {f_min:g} .. {f_max:g} Hz: {note}")
    return tuple(found)


def _choosing(law: ContactLaw) -> str:
    """How a spec chooses ``law``: the ``[solver]`` setting, with what it needs."""
    if law.kind == "lift_off":
        return ('add [solver] flight = true (with coupling = "two-way")'
                if law.name == "flight" else "add [solver] flight = false")
    if law.kind == "coupling":
        return f'add [solver] coupling = "{law.name}"'
    given = ", ".join(f"{p.name} = ..." for p in law.parameters)
    methods = " or ".join(f'"{m}"' for m in law.solvers if m != "planar")
    return (f'give [solver] friction = {{ law = "{law.name}", {given} }} (method = '
            f'{methods})' if given else f'give [solver] friction = "{law.name}"')


def _check_unread(structure: dict[str, Any], sweep: dict[str, Any],
                  friction: Friction | None, coupling: str, flight: bool, path: str,
                  problems: _Problems) -> None:
    """Refuse a structure parameter that only laws the spec does not choose read
    (:attr:`study.model.contact.ContactLaw.structure_parameters`): it would have no
    effect, and giving it, let alone sweeping it, is surely a mistake."""
    chosen = {"friction": friction.law if friction is not None else None,
              "coupling": coupling, "lift_off": "flight" if flight else DEFAULT_LIFT_OFF}
    # What the chosen laws read (every law of a kind whose choice was refused above).
    read = {name for kind, laws in LAWS.items() for law in laws.values()
            if chosen[kind] in (None, law.name) for name in law.structure_parameters}
    refused: set[str] = set()
    for kind, laws in LAWS.items():
        for law in laws.values():
            for name in law.structure_parameters:
                if name in read or name in refused or (name not in structure
                                                       and name not in sweep):
                    continue
                refused.add(name)
                where = "[sweep]" if name in sweep else "[structure]"
                problems.add(_unread(f"{path}: {where}", name, law, str(chosen[kind])))


def _unread(where: str, name: str, law: ContactLaw, chosen: str) -> str:
    """The refusal of parameter ``name``, read only by ``law`` where ``chosen`` is used."""
    return (f"{where} {name} is read only by the {law.kind.replace('_', '-')} law "
            f"'{law.name}', which this study does not use (it uses '{chosen}'): {name} "
            f"would have no effect; allowed: {_choosing(law)}, or remove {name}")


def _check_unread_friction(raw: dict[str, Any], path: str, problems: _Problems) -> None:
    """Refuse a parameter of another friction law in ``[solver] friction``'s table
    (``stribeck_speed`` with ``law = "coulomb"``): the parameters a law reads are
    declared with it (:attr:`study.model.contact.ContactLaw.parameters`)."""
    solver = raw.get("solver")
    friction = solver.get("friction") if isinstance(solver, dict) else None
    if not isinstance(friction, dict) or friction.get("law") not in LAWS["friction"]:
        return  # the schema's to refuse
    chosen = LAWS["friction"][friction["law"]]
    own = {p.name for p in chosen.parameters}
    for law in LAWS["friction"].values():
        for parameter in law.parameters:
            if parameter.name in friction and parameter.name not in own:
                problems.add(_unread(f"{path}: [solver] friction", parameter.name, law,
                                     chosen.name))


def _fixed_structure(structure: dict[str, Any], mass_table: dict[str, Any] | None,
                     sweep: dict[str, Any], path: str
                     ) -> tuple[dict[str, float], MassModel | None]:
    """The fixed structure parameters and the mass model; every structure parameter
    given once, in [structure] or [sweep]."""
    both = sorted(set(structure) & set(sweep))
    if both:
        raise SpecError(
            f"{path}: {', '.join(both)} both fixed in [structure] and swept in [sweep]; "
            "give each parameter in one place"
        )
    mass = None
    fixed: dict[str, float] = {k: float(v) for k, v in structure.items()}
    if mass_table is not None:
        if "M" in structure or "M" in sweep:
            raise SpecError(
                f"{path}: [structure.mass] gives M = m1/(m0 + m_add); do not also give M"
            )
        m0 = float(mass_table["m0"])
        if "m1" in mass_table:
            m1 = float(mass_table["m1"])
        else:
            m1 = float(mass_table["m1_fraction"]) * m0
        mass = MassModel(m0=m0, m1=m1)
        if "m_add" in mass_table and "m_add" in sweep:
            raise SpecError(
                f"{path}: m_add both fixed in [structure.mass] and swept in [sweep]; "
                "give it in one place"
            )
        if "m_add" in mass_table:
            fixed["m_add"] = float(mass_table["m_add"])
    elif "m_add" in sweep:
        raise SpecError(
            f"{path}: [sweep] m_add needs [structure.mass] (m0 and one of m1, m1_fraction)"
        )

    required = {"f0", "Q", "alpha", "cs"} | (set() if mass else {"M"})
    missing = sorted(required - set(fixed) - set(sweep))
    if missing:
        raise SpecError(
            f"{path}: [structure] is missing {', '.join(missing)}; "
            "give each structure parameter in [structure] or sweep it in [sweep]"
        )
    return fixed, mass


def _sweep_axes(sweep: dict[str, Any], observables: tuple[str, ...],
                solver_table: dict[str, Any], path: str,
                max_attractors: int = DEFAULT_MAX_ATTRACTORS) -> tuple[list[Axis], int]:
    """The axes in result order (structure axes, then f, a) and the chunk size; the size
    guard runs on the axis lengths before any value is generated."""
    if "f" not in sweep:
        raise SpecError(f"{path}: [sweep] needs the drive frequency f")
    needs_solver = any(o in observables for o in SOLVER_OBSERVABLES)
    if needs_solver and "a" not in sweep:
        raise SpecError(
            f"{path}: [sweep] needs the drive acceleration a for observables "
            f"{', '.join(o for o in observables if o in SOLVER_OBSERVABLES)}"
        )

    order = [name for name in sweep if name not in DRIVE_PARAMETERS and name != "protocol"]
    order += [name for name in ("f", "a") if name in sweep]
    # The size guard needs only the axis lengths: refuse an absurd study before a
    # single value is generated.
    lengths = {name: axis_length(sweep[name]) for name in order}
    chunk_points = int(solver_table.get("chunk_points",
                                        default_chunk_points(math.prod(lengths.values()))))
    protocol = sweep.get("protocol")  # as given: checked with the solver's settings
    check_size(lengths, observables, chunk_points, path,
               bool(solver_table.get("flight", False)),
               (protocol.get("along"), protocol.get("direction", "up"))
               if isinstance(protocol, dict) else None, max_attractors)
    axes = []
    for name in order:
        units, long_name = SWEEPABLE[name]
        values = axis_values(sweep[name], f"{path}: [sweep] {name}")
        axes.append(Axis(name, values, units, long_name))

    for axis in axes:
        if axis.name == "f" and np.any(axis.values <= 0):
            raise SpecError(f"{path}: [sweep] f: drive frequencies must be > 0 Hz")
        if axis.name == "a" and np.any(axis.values < 0):
            raise SpecError(f"{path}: [sweep] a: drive accelerations must be >= 0 m s-2")
        if axis.name == "m_add" and np.any(axis.values < 0):
            raise SpecError(f"{path}: [sweep] m_add: added masses must be >= 0 kg")
        if axis.name not in STRUCTURE_PARAMETERS:
            _check_bounds(axis, path)
    return axes, chunk_points


def _needs(solver_table: dict[str, Any], observables: tuple[str, ...], path: str,
           problems: _Problems, protocol: bool = False) -> None:
    """What each observable needs of the method, coupling and flight, as it declares
    (and of a slow sweep: ``protocol``, whether ``[sweep]`` declares one), each unmet
    need added to ``problems``."""
    for line in unmet_needs(observables, solver_table.get("method", "exact"),
                            solver_table.get("coupling", DEFAULT_COUPLING),
                            bool(solver_table.get("flight", False)), protocol):
        problems.add(f"{path}: {line}")


def _solver(solver_table: dict[str, Any], axes: list[Axis] | None, path: str,
            problems: _Problems) -> tuple[str, str, Friction | None, SolverSettings | None,
                                          IntegratorSettings | None, float | None]:
    """Method, coupling, friction law, the settings of both solvers and the frontier
    tolerance; each problem is added to ``problems`` (a setting it makes unknown is
    None; the frontier tolerance is not checked without the sweep's f)."""
    coupling = solver_table.get("coupling", DEFAULT_COUPLING)
    raw_friction = solver_table.get("friction", DEFAULT_FRICTION)
    # The exact solver covers both couplings (closed form between events; with two-way
    # coupling the mode is a state of the orbit, found by Newton on the period map).
    method = solver_table.get("method", "exact")
    wrong = sorted(
        k for k in solver_table if k in (INTEGRATOR_KEYS if method == "exact" else EXACT_KEYS)
    )
    if wrong:
        problems.add(
            f"{path}: [solver] {', '.join(wrong)} do not apply to method = \"{method}\"; "
            f"its settings are: {', '.join(EXACT_KEYS if method == 'exact' else INTEGRATOR_KEYS)}"
        )
    friction = solver = integrator = None
    try:
        friction = check_friction(raw_friction, method)
    except ValueError as err:
        problems.add(f"{path}: [solver] friction: {err}")
    try:
        solver = SolverSettings(**{k: v for k, v in solver_table.items() if k in EXACT_KEYS})
        integrator = IntegratorSettings(
            **{k: v for k, v in solver_table.items() if k in INTEGRATOR_KEYS}
        )
    except ValueError as err:
        problems.add(f"{path}: [solver] {err}")
    if solver is not None and solver.continuation and coupling != "two-way":
        problems.add(
            f'{path}: [solver] continuation = true (each orbit continued from the points '
            f'before it along the sweep) needs coupling = "two-way" with method = "exact": '
            f'the one-way solver has no orbit to continue; got coupling = "{coupling}" '
            '(allowed: coupling = "two-way", or continuation = false)')
    frontier_tolerance = float(solver_table.get("frontier_tolerance", 1e-9))
    if axes is not None:
        # Bisection halves a bracket until it is narrower than the tolerance: below the
        # spacing of doubles near the largest f the midpoint stops moving and it never is.
        f_values = next(axis for axis in axes if axis.name == "f").values
        finest = finest_tolerance(np.max(f_values))
        if frontier_tolerance < finest:
            problems.add(
                f"{path}: [solver] frontier_tolerance = {frontier_tolerance!r} Hz is finer "
                f"than doubles resolve near the largest f; allowed: >= {finest:.3g} Hz"
            )
    return method, coupling, friction, solver, integrator, frontier_tolerance


def _protocol(sweep: dict[str, Any], observables: tuple[str, ...], method: str,
              coupling: str, solver: SolverSettings | None, path: str
              ) -> tuple[str, str] | None:
    """``[sweep] protocol`` checked: ``(along, direction)``, or None without it. A slow
    sweep steps a drive axis of at least 2 values and carries the exact two-way
    solver's state (no integrator, no one-way coupling, no continuation: the sweep
    carries the motion itself)."""
    where = f"{path}: [sweep] protocol"
    table = sweep.get("protocol")
    if table is None:
        return None
    if not isinstance(table, dict):
        raise SpecError(f'{where} = {table!r}: a table {{ along = "f" or "a", direction = '
                        '"up", "down" or "both" }')
    unknown = sorted(set(table) - set(PROTOCOL_KEYS))
    if unknown:
        raise SpecError(f"{where}: unknown key {', '.join(unknown)}; allowed: "
                        f"{', '.join(PROTOCOL_KEYS)}")
    along = table.get("along")
    if along not in SWEEP_AXES:
        raise SpecError(f"{where} along = {along!r}: not a drive axis; allowed: "
                        f"{', '.join(repr(x) for x in SWEEP_AXES)}")
    if along not in sweep:
        raise SpecError(f'{where} along = "{along}": {along} is not swept; allowed: a drive '
                        f"axis of [sweep] with at least 2 values")
    if axis_length(sweep[along]) < 2:
        raise SpecError(f'{where} along = "{along}": [sweep] {along} has '
                        f"{axis_length(sweep[along])} value, nothing to sweep; allowed: a "
                        "drive axis with at least 2 values")
    direction = table.get("direction", "up")
    if direction not in PROTOCOL_DIRECTIONS:
        raise SpecError(f"{where} direction = {direction!r}; allowed: "
                        f"{', '.join(repr(x) for x in PROTOCOL_DIRECTIONS)}")
    if "frontier" in observables:
        raise SpecError(f'{where} with the observable "frontier": its bisection solves '
                        "single points between the grid's, which no run of the sweep "
                        'visits (allowed: remove "frontier", or no protocol)')
    needs = ' needs method = "exact" with coupling = "two-way" (a slow sweep carries the '
    if method != "exact":
        raise SpecError(f'{where}{needs}exact solver\'s state from point to point); got '
                        f'method = "{method}" (allowed: method = "exact", or no protocol)')
    if coupling != "two-way":
        raise SpecError(f'{where}{needs}state of the mode, which the one-way model has '
                        f'not); got coupling = "{coupling}" (allowed: coupling = '
                        '"two-way", or no protocol)')
    if solver is not None and solver.continuation:
        raise SpecError(f"{where} with [solver] continuation = true: a slow sweep carries "
                        "the motion from point to point itself (allowed: continuation = "
                        "false, or no protocol)")
    return str(along), str(direction)


def _basins(table: Any, observables: tuple[str, ...], protocol: bool,
            solver: SolverSettings | None, path: str) -> BasinSettings | None:
    """``[basins]`` checked (the schema has checked its keys and their ranges): the
    settings of a study that asks for the observable ``basins`` (the defaults without
    the table), None for any other study; refused without that observable, beside the
    observable ``attractors`` (both write ``attractor_count``), with a slow sweep or
    with continuation (each start is followed from its own state)."""
    asked = "basins" in observables
    if not asked:
        if table is not None:
            raise SpecError(f'{path}: [basins] is read only by the observable "basins", '
                            'which this study does not ask for: it would have no effect '
                            '(allowed: add "basins" to [study] observables, or remove '
                            "[basins])")
        return None
    if "attractors" in observables:
        raise SpecError(f'{path}: [study] observables "attractors" and "basins" both '
                        'write attractor_count (basins counts the attractors of its own '
                        'starts, with each one\'s motion and basin fraction); allowed: one '
                        'of them')
    if protocol:
        raise SpecError(f'{path}: [study] observable "basins" with [sweep] protocol: basins '
                        "follows each of its starts from its own state at every point, "
                        "whatever the sweep carries (allowed: no protocol, or remove "
                        '"basins")')
    if solver is not None and solver.continuation:
        raise SpecError(f'{path}: [study] observable "basins" with [solver] continuation = '
                        "true: basins follows each of its starts from its own state "
                        '(allowed: continuation = false, or remove "basins")')
    table = dict(table or {})
    unknown = sorted(set(table) - set(BASIN_KEYS))
    if unknown:  # the schema refuses them first; kept for a caller without it
        raise SpecError(f"{path}: [basins] unknown key {', '.join(unknown)}; allowed: "
                        f"{', '.join(BASIN_KEYS)}")
    try:
        return BasinSettings(**table)
    except ValueError as err:
        raise SpecError(f"{path}: [basins] {err}; allowed: starts, max_attractors "
                        "integers >= 1, seed, sweep_steps integers >= 0") from None


def _check_start(solver: SolverSettings | None, coupling: str, flight: bool | None,
                 observables: tuple[str, ...], path: str, problems: _Problems) -> None:
    """``[solver] start`` where the model can take it, in the API's wording
    (:func:`study.model.starts.refusal`): other than the release needs coupling =
    "two-way", a drop needs flight = true and no ``without_flight`` observable."""
    if solver is None:
        return
    problem = starts.refusal(solver.start, coupling=coupling, flight=flight,
                             observables=observables, syntax="toml")
    if problem is not None:
        problems.add(f"{path}: {problem}")


#: Why flight needs two-way coupling (the decision of issue 21).
FLIGHT_NEEDS_TWO_WAY = (
    "the one-way model's mode is driven by the table alone, which does not hold once the "
    "base leaves the table")
#: Why flight needs M < 1.
FLIGHT_NEEDS_BASE_MASS = (
    "M = 1 is a massless base: the impact matrix W = I + M/(1 - M) e e^T is unbounded")


def _flight(solver_table: dict[str, Any], method: str, coupling: str, path: str) -> bool:
    """``[solver] flight``, refused where it cannot apply (a method that does not
    implement the lift-off law ``flight``, one-way coupling; the observables that need
    it or its absence are :func:`_solver`'s, from their declarations)."""
    flight = bool(solver_table.get("flight", False))
    if not flight:
        return False
    try:
        check_law("lift_off", "flight", method)
    except ValueError as err:
        raise SpecError(f'{path}: [solver] flight = true with method = "{method}": {err} '
                        "(allowed: flight = false)") from None
    if coupling != "two-way":
        raise SpecError(
            f'{path}: [solver] flight = true needs coupling = "two-way", got coupling = '
            f'"{coupling}": {FLIGHT_NEEDS_TWO_WAY} (allowed: coupling = "two-way", or '
            "flight = false)")
    return True


def _canonical(study: dict[str, Any], observables: tuple[str, ...], fixed: dict[str, float],
               mass: MassModel | None, sweep: dict[str, Any], axes: list[Axis], method: str,
               coupling: str, friction: Friction, solver: SolverSettings,
               integrator: IntegratorSettings, frontier_tolerance: float,
               flight: bool = False) -> dict[str, Any]:
    """What the numbers depend on, in a canonical form (hashed); defaults written out,
    so a spec that spells them out is the same study.

    Thirteen arguments: the parts of a spec, each computed and checked by its own step
    of :func:`_build`; gathering them into an object would only rename them.
    """
    structure_canonical = dict(fixed)
    if "g" not in fixed and "g" not in sweep:
        structure_canonical["g"] = Structure.__dataclass_fields__["g"].default
    if "ck" not in fixed and "ck" not in sweep and "cs" in fixed:
        structure_canonical["ck"] = fixed["cs"]
    canonical = {
        "name": study["name"],
        "observables": list(observables),
        "structure": {k: structure_canonical[k] for k in sorted(structure_canonical)},
        "mass": None if mass is None else {"m0": mass.m0, "m1": mass.m1},
        # A list, not a mapping: the order of the axes is the layout of the result.
        "sweep": [[axis.name, axis.values.tolist()] for axis in axes],
        "solver": {
            "method": method,
            "coupling": coupling,
            **(
                {
                    "max_events": solver.max_events,
                    "max_map_iterations": solver.max_map_iterations,
                }
                if method == "exact"
                else {
                    "tolerance": integrator.tolerance,
                    "steps_per_period": integrator.steps_per_period,
                    "max_periods": integrator.max_periods,
                    "max_orbit_period": integrator.max_orbit_period,
                    "period_tolerance": integrator.resolved_period_tolerance,
                }
            ),
            **({"frontier_tolerance": frontier_tolerance} if "frontier" in observables else {}),
            # Coulomb friction, the default, is left out: specs written before friction
            # laws were named keep their fingerprints.
            **({"friction": friction.canonical()}
               if friction.law != DEFAULT_FRICTION else {}),
            # Likewise flight only when on: specs without it keep their fingerprints.
            **({"flight": True} if flight else {}),
            # And continuation.
            **({"continuation": True} if method == "exact" and solver.continuation
               else {}),
            # And the averaging of irregular motions, where not the default.
            **(solver.averaging_changes() if method == "exact" else {}),
            # And the start, where not the release.
            **(solver.start_changes() if method == "exact" else {}),
        },
    }
    return canonical


def _check_bounds(axis: Axis, path: str) -> None:
    """Swept values obey the ranges of the schema's parameters, as fixed ones do."""
    allowed, inside = _parameter_bounds(axis.name)
    outside = axis.values[~inside(axis.values)]
    if outside.size:
        raise SpecError(
            f"{path}: [sweep] {axis.name}: value {float(outside[0])!r} is out of range; "
            f"allowed: {allowed}"
        )


def _check_structures(fixed: dict[str, float], mass: MassModel | None,
                      structure_axes: list[Axis], flight: bool, path: str) -> None:
    """Build every structure of the study now, so a bad one is refused before work
    (with flight, also one without a base mass); then the swept values' ranges (after
    the structure's own checks: they have the better words where they apply)."""
    ranges = [range(len(axis)) for axis in structure_axes]
    for index in itertools.product(*ranges):
        params = dict(fixed)
        for axis, i in zip(structure_axes, index, strict=True):
            params[axis.name] = float(axis.values[i])
        try:
            structure = _build_structure(params, mass)
        except ValueError as err:
            raise SpecError(f"{path}: invalid structure at {_where(structure_axes, index)}: "
                            f"{err}") from None
        if flight and structure.M >= 1:
            raise SpecError(
                f"{path}: M = {structure.M!r} at {_where(structure_axes, index)} with "
                f"[solver] flight = true: flight needs M < 1 ({FLIGHT_NEEDS_BASE_MASS}); "
                "allowed: M < 1, or flight = false")
    for axis in structure_axes:
        _check_bounds(axis, path)


def _where(structure_axes: list[Axis] | tuple[Axis, ...], index: tuple[int, ...]) -> str:
    """A structure of the study as the spec gives it: the swept values at ``index``."""
    at = ", ".join(
        f"{axis.name} = {float(axis.values[i])!r}"
        for axis, i in zip(structure_axes, index, strict=True)
    )
    return f"[sweep] point {at}" if at else "[structure]"
