"""Design specs: their schema, their parsing and their validation, before any model runs.

A design spec (TOML, ``study-design-spec-v1``) names target behaviours at drive
commands ``(f, a)``, a structure (the single-plate :class:`~study.model.structure.Structure`
in ``[structure]``, or the steering disk, ``[disk]`` and ``[[plate]]`` as in a scene
spec) with start and fixed values, and the free parameters with their bounds::

    [design]
    name = "forward-backward"
    coupling = "two-way"            # or "one-way", the default
    [structure]                     # start values / fixed values
    f0 = 14.44
    Q = 17.5
    alpha = 64.0
    M = 0.08
    cs = 0.25
    [free]                          # bounds of the searched parameters
    f0 = [12.0, 17.0]
    alpha = [30.0, 80.0]
    [[target]]
    f = 14.2
    a = 7.0
    behaviour = "forward"           # forward | backward | static | moving (| left | right)
    [[target]]
    f = 15.2
    a = 7.0
    behaviour = "backward"

For the disk, ``[free]`` holds ``cs``, ``ck`` and one table per plate name
(``[free.tail] f0 = [6.5, 9.5]``: ``tail.f0``); ``left`` and ``right`` are turns.

Reading one checks what can be checked without the model: the schema, one model
(``[structure]`` or the disk), the bounds against each parameter's range, the start
values inside the bounds, a valid structure at the start, distinct target labels and
plate names, and the plates' mass ratios summing to at most 1 at every point of the
bounds. The margins a design maximises are :mod:`study.analyses.design_margins`, the
search :mod:`study.analyses.design_search`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from study.engine.spec_files import (
    SpecError,
    canonical_sha256,
    check_schema,
    load_schema,
    parse_toml,
    read_spec_text,
)
from study.model.contact import DEFAULT_COUPLING
from study.model.disk import Disk
from study.model.parameters import STRUCTURE, Parameter, schema_properties, units_list
from study.model.structure import Structure, tilt_warnings
from study.model.units import DEGREE, DIMENSIONLESS, HERTZ, spoken
from study.scenes.scene_spec import disk_from_spec

__all__ = [
    "BEHAVIOURS",
    "DESIGN_SPEC_SCHEMA",
    "DesignSpec",
    "Target",
    "load_design_spec",
    "parse_design_spec",
]

DESIGN_SPEC_SCHEMA = "study-design-spec-v1"

#: Target behaviours, and which models know them.
BEHAVIOURS = {
    "forward": "moves forward (along the heading for the disk)",
    "backward": "moves backward",
    "static": "never slips: a below the motion threshold",
    "moving": "moves, either way",
    "left": "turns counterclockwise (disk only)",
    "right": "turns clockwise (disk only)",
}
TURNS = ("left", "right")

#: Parameters of one plate of the disk ("<plate>.<name>" in [free]).
PLATE_PARAMETERS: dict[str, Parameter] = {p.name: p for p in (
    Parameter("f0", HERTZ, "resonance frequency of the plate's first mode", 0.0, math.inf),
    Parameter("Q", DIMENSIONLESS, "quality factor of the plate's mode", 0.0, math.inf),
    Parameter("alpha", DEGREE, "tilt of the plate's mode from the horizontal", 0.0, 90.0,
              lower_open=False, upper_open=False),
    Parameter("M", DIMENSIONLESS, "mass ratio of the plate's mode", 0.0, 1.0, upper_open=False),
    Parameter("direction", DEGREE, "direction of the plate's mode in the body frame",
              -360.0, 360.0, lower_open=False, upper_open=False),
)}
#: Parameters of the single-plate structure a design can free (:mod:`study.model.parameters`).
STRUCTURE_PARAMETERS = {n: STRUCTURE[n] for n in ("f0", "Q", "alpha", "M", "cs", "ck")}


def design_spec_schema() -> dict[str, Any]:
    """The JSON schema of design specs (``study/schemas/study-design-spec-v1.schema.json``):
    the single-plate structure's ranges and free parameters from the parameter table
    (the file on disk is its export: ``make schemas``)."""
    schema = load_schema(DESIGN_SPEC_SCHEMA)
    schema["properties"]["structure"]["properties"] = schema_properties(STRUCTURE)
    free = schema["properties"]["free"]
    free["properties"] = {name: {"$ref": "#/$defs/bounds"} for name in STRUCTURE_PARAMETERS}
    free["description"] = (
        "free parameters with their bounds: single plate " + units_list(STRUCTURE_PARAMETERS)
        + "; disk cs, ck and a table per plate name (e.g. [free.tail] f0 = [6.5, 9.5])")
    return schema


def export_design_spec_schema() -> str:
    """The design spec schema as written to ``study/schemas`` (``make schemas``)."""
    return json.dumps(design_spec_schema(), indent=2) + "\n"


@dataclass(frozen=True)
class Target:
    """A behaviour asked for at a drive command.

    Attributes
    ----------
    f : float
        Drive frequency [Hz].
    a : float
        Drive acceleration amplitude [m s-2].
    behaviour : str
        One of :data:`BEHAVIOURS`.
    label : str
    """

    f: float
    a: float
    behaviour: str
    label: str


@dataclass(frozen=True)
class DesignSpec:
    """A validated design spec (module doc).

    Attributes
    ----------
    name, title, text, path : str
    model : str
        ``"plate"`` (``[structure]``) or ``"disk"`` (``[disk]`` and ``[[plate]]``).
    coupling : {"one-way", "two-way"}
        Model of the velocities (default :data:`study.solvers.exact.DEFAULT_COUPLING`).
    start : dict
        Every parameter's start (or fixed) value by name: ``f0``, ``Q``, ``alpha``,
        ``M``, ``cs``, ``ck`` (None: tied to ``cs``), ``g`` for the plate model;
        ``cs``, ``ck`` and ``<plate>.<parameter>`` for the disk.
    disk : Disk or None
        The disk at the start values.
    free : dict
        Free parameter -> (lower, upper) bounds as the spec gives them.
    targets : tuple of Target
    weights : dict
        ``speed``, ``threshold``, ``lift``: factors of each margin.
    seed, scan_points, max_iterations, population : int
        Search settings.
    """

    name: str
    title: str
    text: str
    path: str
    model: str
    coupling: str
    start: dict[str, float | None]
    disk: Disk | None
    free: dict[str, tuple[float, float]]
    targets: tuple[Target, ...]
    weights: dict[str, float] = field(default_factory=lambda: {
        "speed": 1.0, "threshold": 1.0, "lift": 1.0})
    seed: int = 1
    scan_points: int = 41
    max_iterations: int = 60
    population: int = 15

    @property
    def sha256(self) -> str:
        return canonical_sha256(parse_toml(self.text, self.path))

    def parameter(self, name: str) -> Parameter:
        """The declaration of a free parameter (units, range)."""
        if self.model == "plate" or "." not in name:
            return STRUCTURE_PARAMETERS[name]
        return PLATE_PARAMETERS[name.split(".", 1)[1]]


def load_design_spec(path: str | Path) -> DesignSpec:
    """Read and check a design spec.

    Raises
    ------
    SpecError
        Naming the file, the key and what is allowed.
    """
    path = Path(path)
    return parse_design_spec(read_spec_text(path, "design spec"), str(path))


def _label(target: dict[str, Any]) -> str:
    return target.get("label") or (
        f"{target['behaviour']} at {target['f']:g} Hz, {target['a']:g} m s-2")


def parse_design_spec(text: str, path: str = "<string>") -> DesignSpec:
    """A design spec from its text (see :func:`load_design_spec`)."""
    raw = parse_toml(text, path)
    check_schema(raw, design_spec_schema(), path, "design spec")
    table = raw["design"]
    has_structure = "structure" in raw
    has_disk = "disk" in raw or "plate" in raw
    if has_structure == has_disk:
        raise SpecError(f"{path}: give either [structure] (a single-plate structure) or "
                        "[disk] with [[plate]] tables (the steering disk), not "
                        f"{'both' if has_structure else 'neither'}")
    if has_disk and not ("disk" in raw and "plate" in raw):
        raise SpecError(f"{path}: the disk needs both [disk] and at least one [[plate]]")
    model = "plate" if has_structure else "disk"
    targets = tuple(Target(float(t["f"]), float(t["a"]), t["behaviour"], _label(t))
                    for t in raw["target"])
    if model == "plate":
        for i, t in enumerate(targets):
            if t.behaviour in TURNS:
                raise SpecError(f"{path}: [[target]] #{i + 1} behaviour = {t.behaviour!r}: "
                                "turns need the disk ([disk], [[plate]]); a single plate "
                                "moves forward, backward, or not")
        start, disk = _plate_start(raw, path), None
        free = _plate_free(raw["free"], start, path)
    else:
        disk = _disk(raw, path)
        start = _disk_start(disk, raw["disk"].get("ck"))
        free = _disk_free(raw["free"], disk, start, path)
    labels = [t.label for t in targets]
    if len(set(labels)) != len(labels):
        raise SpecError(f"{path}: two [[target]] tables have the same label; give each a "
                        "distinct label")
    weights = {"speed": 1.0, "threshold": 1.0, "lift": 1.0, **table.get("weights", {})}
    return DesignSpec(
        name=table["name"], title=table.get("title", table["name"]), text=text, path=path,
        model=model, coupling=table.get("coupling", DEFAULT_COUPLING), start=start, disk=disk,
        free=free, targets=targets, weights={k: float(v) for k, v in weights.items()},
        seed=int(table.get("seed", 1)), scan_points=int(table.get("scan_points", 41)),
        max_iterations=int(table.get("max_iterations", 60)),
        population=int(table.get("population", 15)),
    )


def _check_bounds(name: str, bounds: list[float], parameter: Parameter, start: float | None,
                  path: str) -> tuple[float, float]:
    lower, upper = float(bounds[0]), float(bounds[1])
    where = f"{path}: [free] {name} = [{lower:g}, {upper:g}]"
    if not lower < upper:
        raise SpecError(f"{where}: the lower bound must be below the upper one")
    for bound in (lower, upper):
        if not parameter.inside(bound):
            raise SpecError(f"{where}: bound {bound:g} is out of range; allowed: "
                            f"{parameter.allowed()}{spoken(parameter.units)}")
    if start is not None and not lower <= start <= upper:
        raise SpecError(f"{where}: the start value {start:g} is outside the bounds")
    return lower, upper


def _plate_start(raw: dict[str, Any], path: str) -> dict[str, float | None]:
    start: dict[str, float | None] = {k: float(v) for k, v in raw["structure"].items()}
    missing = [k for k in ("f0", "Q", "alpha", "M", "cs") if k not in start]
    if missing:
        raise SpecError(f"{path}: [structure] is missing {', '.join(missing)}; give every "
                        "structure parameter (the start value of a free one)")
    start.setdefault("ck", None)
    start.setdefault("g", 9.8)
    try:
        plate_structure(start)
    except ValueError as err:
        raise SpecError(f"{path}: [structure]: {err}") from None
    return start


def _plate_free(table: dict[str, Any], start: dict[str, float | None], path: str
                ) -> dict[str, tuple[float, float]]:
    free = {}
    for name, bounds in table.items():
        if name not in STRUCTURE_PARAMETERS:
            raise SpecError(f"{path}: [free] {name}: not a parameter of the single-plate "
                            f"structure; allowed: {', '.join(STRUCTURE_PARAMETERS)}")
        value = start[name] if start[name] is not None else start["cs"]
        free[name] = _check_bounds(name, bounds, STRUCTURE_PARAMETERS[name], value, path)
    if "ck" in free and start["ck"] is None:
        start["ck"] = start["cs"]
    return free


def _disk(raw: dict[str, Any], path: str) -> Disk:
    """The scene's disk, with plate names that can name free parameters."""
    disk = disk_from_spec(raw, path)
    names = [p.name for p in disk.plates]
    if len(set(names)) != len(names):
        raise SpecError(f"{path}: [[plate]] names must differ (they name free parameters: "
                        f"[free.NAME]); got {', '.join(names)}")
    return disk


def _disk_start(disk: Disk, ck: float | None) -> dict[str, float | None]:
    start: dict[str, float | None] = {"cs": disk.cs, "ck": None if ck is None else disk.ck}
    for plate in disk.plates:
        for name in PLATE_PARAMETERS:
            start[f"{plate.name}.{name}"] = float(getattr(plate, name))
    return start


def _disk_free(table: dict[str, Any], disk: Disk, start: dict[str, float | None], path: str
               ) -> dict[str, tuple[float, float]]:
    free = {}
    plates = {p.name: p for p in disk.plates}
    for key, value in table.items():
        if isinstance(value, dict):
            if key not in plates:
                raise SpecError(f"{path}: [free.{key}]: no plate is named {key!r}; plates: "
                                f"{', '.join(plates)}")
            for name, bounds in value.items():
                full = f"{key}.{name}"
                free[full] = _check_bounds(full, bounds, PLATE_PARAMETERS[name], start[full],
                                           path)
        elif key in ("cs", "ck"):
            value_at_start = start[key] if start[key] is not None else start["cs"]
            free[key] = _check_bounds(key, value, STRUCTURE_PARAMETERS[key], value_at_start,
                                      path)
        else:
            raise SpecError(f"{path}: [free] {key}: the disk's free parameters are cs, ck "
                            "and [free.PLATE] tables (f0, Q, alpha, M, direction)")
    if "ck" in free and start["ck"] is None:
        start["ck"] = start["cs"]
    heaviest = sum(free.get(f"{p.name}.M", (p.M, p.M))[1] for p in disk.plates)
    if heaviest > 1.0 + 1e-12:
        raise SpecError(f"{path}: [free]: the plates' mass ratios can sum to {heaviest:g} > 1 "
                        "within the bounds; lower the upper bounds of M")
    return free


def plate_structure(p: dict[str, float | None]) -> Structure:
    """The single-plate structure of a parameter set, as the spec and the search give it.

    Parameters
    ----------
    p : dict
        ``f0`` [Hz], ``Q`` [1], ``alpha`` [degree], ``M`` [1], ``cs`` and ``ck`` [1]
        (``ck`` None: tied to ``cs``) and ``g`` [m s-2], as :attr:`DesignSpec.start`.

    Returns
    -------
    Structure

    Raises
    ------
    ValueError
        If the parameters are no valid structure.
    """
    with tilt_warnings(False):  # the spec's tilts are in degree; the search may go near 0
        return Structure(f0=p["f0"], Q=p["Q"], alpha=p["alpha"], M=p["M"], cs=p["cs"],
                         ck=p["ck"], g=p["g"])
