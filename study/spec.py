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
naming the file, the key and what is allowed.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import tomllib
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.solver import SolverSettings
from study.structure import Structure
from study.transient import IntegratorSettings

__all__ = [
    "METHODS",
    "OBSERVABLES",
    "SOLVER_OBSERVABLES",
    "SPEC_SCHEMA_PATH",
    "Axis",
    "MassModel",
    "SpecError",
    "StudySpec",
    "load_spec",
    "parse_spec",
]

#: JSON schemas ship inside the package (``study/schemas/``); the top-level
#: ``results_schema/`` folder holds an exact copy for readers of the repository.
SPEC_SCHEMA_PATH = Path(__file__).resolve().parent / "schemas" / "study-spec-v1.schema.json"

#: Observables a study can ask for, in the order they appear in a dataset.
OBSERVABLES = (
    "resonance", "thresholds", "lift_off", "velocity", "diagnostics", "paper_model", "frontier",
)
#: Observables that need the steady-state solver (and hence the drive acceleration a).
SOLVER_OBSERVABLES = ("velocity", "diagnostics", "paper_model", "frontier")

#: Velocity solvers a spec can choose with ``[solver] method``.
METHODS = ("exact", "integrator")
#: ``[solver]`` keys of the exact solver and of the time integrator.
EXACT_KEYS = ("max_events", "max_map_iterations")
INTEGRATOR_KEYS = (
    "tolerance", "steps_per_period", "max_periods", "max_orbit_period", "period_tolerance",
)

#: Structure parameters: units and long names (SI inside).
STRUCTURE_PARAMETERS = {
    "f0": ("Hz", "resonance frequency of the plate's first mode"),
    "Q": ("1", "quality factor of the plate's first mode"),
    "alpha": ("degree", "tilt of the plate from the horizontal"),
    "M": ("1", "mass ratio m1/m of the resonant mass to the total mass"),
    "cs": ("1", "static friction coefficient"),
    "ck": ("1", "kinetic friction coefficient"),
    "g": ("m s-2", "gravitational acceleration"),
}
DRIVE_PARAMETERS = {
    "f": ("Hz", "drive frequency"),
    "a": ("m s-2", "drive acceleration amplitude"),
}
MASS_PARAMETERS = {
    "m_add": ("kg", "added non-resonant mass"),
}
SWEEPABLE = {**STRUCTURE_PARAMETERS, **MASS_PARAMETERS, **DRIVE_PARAMETERS}


class SpecError(ValueError):
    """A study spec that cannot be run; the message names file, key and what is allowed."""


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
        Whether the sliding base also forces the mode (two-way, integrator only).
    integrator : IntegratorSettings
        Accuracy and budgets of the time integrator (used with ``method = "integrator"``).
    chunk_points : int
        Target number of grid points per parallel task.
    frontier_tolerance : float
        Bracket width at which frontier roots are accepted [Hz].
    text : str
        The spec file's text, kept verbatim for provenance.
    path : str
        Where it was read from.
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
    coupling: str = "one-way"
    integrator: IntegratorSettings = field(default_factory=IntegratorSettings)

    @property
    def sha256(self) -> str:
        """Hash of the canonical form: formatting, comments and key order do not count."""
        blob = json.dumps(self.canonical, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(blob.encode()).hexdigest()

    @property
    def structure_axes(self) -> tuple[Axis, ...]:
        """Swept parameters that change the structure (everything but f and a)."""
        return tuple(axis for axis in self.axes if axis.name not in DRIVE_PARAMETERS)

    def axis(self, name: str) -> Axis | None:
        """The swept axis called ``name``, if any."""
        return next((axis for axis in self.axes if axis.name == name), None)

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
    return Structure(**params)


@cache
def spec_schema() -> dict[str, Any]:
    """The JSON schema of study specs (``study/schemas/study-spec-v1.schema.json``)."""
    return json.loads(SPEC_SCHEMA_PATH.read_text())


def load_spec(path: str | Path) -> StudySpec:
    """Read and validate a study spec file.

    Parameters
    ----------
    path : str or pathlib.Path
        A TOML file.

    Raises
    ------
    SpecError
        If the file cannot be read or parsed, or any key is unknown, mistyped or
        out of range; nothing has been computed at that point.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as err:
        raise SpecError(f"{path}: cannot read the study spec ({err.strerror})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise SpecError(
            f"{path}: a study spec must be UTF-8 text (TOML); byte {err.start} is not"
        ) from None
    return parse_spec(text, str(path))


def parse_spec(text: str, path: str = "<string>") -> StudySpec:
    """Validate a study spec given as TOML text (see :func:`load_spec`)."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SpecError(f"{path}: not valid TOML: {err}") from None
    _check_schema(raw, path)
    return _build(raw, text, path)


def _where(location: list[Any]) -> str:
    if not location:
        return "top level"
    table, *rest = location
    key = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in rest).lstrip(".")
    return f"[{table}]" + (f" {key}" if key else "")


def _check_schema(raw: dict[str, Any], path: str) -> None:
    import jsonschema

    schema = spec_schema()
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(raw), key=lambda e: list(map(str, e.absolute_path)))
    if not errors:
        return
    messages = [_explain(error, schema) for error in errors]
    raise SpecError(f"{path}: invalid study spec:\n  " + "\n  ".join(dict.fromkeys(messages)))


def _explain(error: Any, schema: dict[str, Any]) -> str:
    """One schema violation as 'where: what is wrong; allowed: what'."""
    location = list(error.absolute_path)
    where = _where(location)
    if error.validator == "additionalProperties":
        allowed = sorted(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(allowed))
        what = "unknown key" + ("s " if len(extra) > 1 else " ") + ", ".join(map(repr, extra))
        return f"{where}: {what}; allowed keys: {', '.join(allowed)}"
    if error.validator == "required":
        return f"{where}: {error.message}"
    hint = error.schema.get("description", "")
    if error.validator in ("oneOf", "anyOf"):
        from jsonschema.exceptions import best_match

        detail = best_match(error.context) if error.context else None
        reason = f" ({detail.message})" if detail is not None else ""
        return f"{where}: {error.instance!r} does not match any allowed form{reason}; {hint}"
    if error.validator == "enum":
        allowed = ", ".join(map(repr, error.validator_value))
        return f"{where}: {error.instance!r} is not allowed; allowed: {allowed}"
    bounds = {
        "minimum": ">=", "exclusiveMinimum": ">", "maximum": "<=", "exclusiveMaximum": "<",
    }
    if error.validator in bounds:
        limits = " and ".join(
            f"{bounds[key]} {error.schema[key]}" for key in bounds if key in error.schema
        )
        return f"{where} = {error.instance!r} is out of range; allowed: {limits}"
    if error.validator == "type":
        return f"{where}: {error.instance!r} has the wrong type; expected {error.validator_value}"
    return f"{where}: {error.message}" + (f"; allowed: {hint}" if hint else "")


def _axis_values(name: str, table: dict[str, Any], path: str) -> NDArray[np.float64]:
    where = f"{path}: [sweep] {name}"
    if "values" in table:
        values = np.asarray(table["values"], dtype=np.float64)
    else:
        if not isinstance(table["num"], int):
            raise SpecError(f"{where}: num = {table['num']!r} must be an integer")
        start, stop, num = float(table["start"]), float(table["stop"]), table["num"]
        if not (np.isfinite(start) and np.isfinite(stop)):
            raise SpecError(f"{where}: start and stop must be finite numbers")
        if table.get("spacing", "linear") == "log":
            if start <= 0 or stop <= 0:
                raise SpecError(f"{where}: log spacing needs start > 0 and stop > 0")
            values = np.geomspace(start, stop, num)
        else:
            values = np.linspace(start, stop, num)
    if values.size == 0:
        raise SpecError(f"{where}: empty axis; give at least one value")
    if not np.all(np.isfinite(values)):
        raise SpecError(f"{where}: values must be finite")
    if np.unique(values).size != values.size:
        raise SpecError(f"{where}: values must be distinct")
    return values


def _build(raw: dict[str, Any], text: str, path: str) -> StudySpec:
    study = raw["study"]
    structure = dict(raw["structure"])
    mass_table = structure.pop("mass", None)
    sweep = raw.get("sweep", {})
    solver_table = dict(raw.get("solver", {}))

    observables = tuple(o for o in OBSERVABLES if o in study["observables"])

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
    if "f" not in sweep:
        raise SpecError(f"{path}: [sweep] needs the drive frequency f")
    needs_solver = any(o in observables for o in SOLVER_OBSERVABLES)
    if needs_solver and "a" not in sweep:
        raise SpecError(
            f"{path}: [sweep] needs the drive acceleration a for observables "
            f"{', '.join(o for o in observables if o in SOLVER_OBSERVABLES)}"
        )

    axes = []
    order = [name for name in sweep if name not in DRIVE_PARAMETERS]
    order += [name for name in ("f", "a") if name in sweep]
    for name in order:
        units, long_name = SWEEPABLE[name]
        axes.append(Axis(name, _axis_values(name, sweep[name], path), units, long_name))

    for axis in axes:
        if axis.name == "f" and np.any(axis.values <= 0):
            raise SpecError(f"{path}: [sweep] f: drive frequencies must be > 0 Hz")
        if axis.name == "a" and np.any(axis.values < 0):
            raise SpecError(f"{path}: [sweep] a: drive accelerations must be >= 0 m s-2")
        if axis.name == "m_add" and np.any(axis.values < 0):
            raise SpecError(f"{path}: [sweep] m_add: added masses must be >= 0 kg")

    coupling = solver_table.get("coupling", "one-way")
    # The exact solver covers the paper's (one-way) model; two-way coupling needs time
    # integration. A spec that says nothing gets the cheapest model that covers it.
    method = solver_table.get("method", "exact" if coupling == "one-way" else "integrator")
    if method == "exact" and coupling != "one-way":
        raise SpecError(
            f'{path}: [solver] coupling = "{coupling}" needs method = "integrator"; the exact '
            'solver models the paper\'s one-way coupling only (allowed with method = "exact": '
            'coupling = "one-way")'
        )
    if "paper_model" in observables and coupling == "one-way":
        raise SpecError(
            f'{path}: [study] observable "paper_model" (the one-way model beside a two-way '
            'study) needs [solver] coupling = "two-way"; a one-way study\'s velocity already '
            "is the paper's model"
        )
    wrong = sorted(
        k for k in solver_table if k in (INTEGRATOR_KEYS if method == "exact" else EXACT_KEYS)
    )
    if wrong:
        raise SpecError(
            f"{path}: [solver] {', '.join(wrong)} do not apply to method = \"{method}\"; "
            f"its settings are: {', '.join(EXACT_KEYS if method == 'exact' else INTEGRATOR_KEYS)}"
        )
    try:
        solver = SolverSettings(**{k: v for k, v in solver_table.items() if k in EXACT_KEYS})
        integrator = IntegratorSettings(
            **{k: v for k, v in solver_table.items() if k in INTEGRATOR_KEYS}
        )
    except ValueError as err:
        raise SpecError(f"{path}: [solver] {err}") from None
    chunk_points = int(solver_table.get("chunk_points", 20_000))
    frontier_tolerance = float(solver_table.get("frontier_tolerance", 1e-9))

    # Defaults written out: a spec that spells them out is the same study.
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
        },
    }
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
    )
    _check_structures(spec, path)
    return spec


def _check_structures(spec: StudySpec, path: str) -> None:
    """Build every structure of the study now, so a bad one is refused before work."""
    ranges = [range(len(axis)) for axis in spec.structure_axes]
    for index in itertools.product(*ranges):
        try:
            spec.structure_at(index)
        except ValueError as err:
            at = ", ".join(
                f"{axis.name} = {float(axis.values[i])!r}"
                for axis, i in zip(spec.structure_axes, index, strict=True)
            )
            where = f"[sweep] point {at}" if at else "[structure]"
            raise SpecError(f"{path}: invalid structure at {where}: {err}") from None
