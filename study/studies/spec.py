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
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from study.engine.spec_files import (
    SpecError,
    axis_length,
    axis_values,
    parse_toml,
    read_spec_text,
    schema_error,
    schema_problems,
)
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
    STRUCTURE,
)
from study.model.starts import Drop
from study.solvers.frontier import finest_tolerance
from study.solvers.integrator import IntegratorSettings
from study.solvers.protocol import SWEEP_AXES
from study.solvers.settings import SolverSettings
from study.studies.canonical import canonical_form
from study.studies.observables import (
    BASIN_KEYS,
    METHODS,
    BasinSettings,
    unmet_needs,
)
from study.studies.schema import spec_schema
from study.studies.size import MAX_CHUNKS, check_size, default_chunk_points
from study.studies.spec_types import (
    DRIVE_PARAMETERS,
    EXACT_KEYS,
    INTEGRATOR_KEYS,
    OBSERVABLES,
    PROTOCOL_DIRECTIONS,
    PROTOCOL_KEYS,
    SOLVER_OBSERVABLES,
    SPEC_SCHEMA_PATH,
    STRUCTURE_PARAMETERS,
    SWEEPABLE,
    Axis,
    MassModel,
    StudySpec,
    build_structure,
)
from study.studies.variables import DEFAULT_MAX_ATTRACTORS

#: The public names, as before the spec layer was split (types, schema and size guard
#: have their own modules; these are re-exported).
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
    canonical = canonical_form(study, observables, fixed, mass, sweep, axes, method, coupling,
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
        if axis.name == "f" and "fold_curves" in observables and len(axis.values) < 2:
            raise SpecError(f'{path}: [sweep] f has 1 value; the observable "fold_curves" '
                            "sweeps along f slowly (allowed: at least 2 values)")
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
            structure = build_structure(params, mass)
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
