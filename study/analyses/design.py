"""Design: structure parameters that achieve target behaviours with the largest margins.

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

**Margins** of a target at ``(f, a)`` (all dimensionless; ``w = 2 pi f``):

* speed margin: the velocity in the target's direction over the table's velocity
  amplitude ``a / w``: ``v w / a`` (forward), ``-v w / a`` (backward), ``|v| w / a``
  (moving; the disk: ``|(v_forward, v_lateral, R spin)|``); a turn, the rim speed
  ``R spin w / a`` (left, counterclockwise) or ``-R spin w / a`` (right). Where the
  model has no orbit (lift-off in the sliding orbit, no convergence, Painleve) it is
  :data:`FAILED` (-1). A ``static`` target has none.
* threshold margin: ``(a - a*) / a`` above the motion threshold ``a*`` (the lowest
  drive at which the structure, stuck, starts to slip at ``f``: ``min(a*_+, a*_-)``,
  :func:`study.model.thresholds`; for the disk :func:`disk_limits`), or
  ``(a* - a) / a`` below it for ``static``.
* lift-off margin: ``(a_lift - a) / a`` below the lift-off acceleration
  (:func:`study.model.lift_off_acceleration`, :func:`disk_limits`).

The target's margin is the smallest of its margins, each times its weight
(``[design] weights``, default 1), and a target is met when its margin is above
:data:`MIN_MARGIN` (1e-6): it moves the asked way (or stays still), above (below) its
threshold and below lift-off.

**Objective**: maximise the smallest target margin over the free parameters within
their bounds (a max-min design: the worst target is as robust as it can be). Velocities
are :func:`study.solvers.exact.steady_velocity` with the spec's coupling (default
:data:`study.solvers.exact.DEFAULT_COUPLING`, ``"one-way"``, the paper's model, as everywhere),
or :func:`study.scenes.planar_model.periodic_motion` for the
disk. **Search**: one free parameter, a scan of ``scan_points`` values across the
bounds, then a bounded Brent refinement between the best value's neighbours; several,
:func:`scipy.optimize.differential_evolution` (fixed seed, the start values in the
first population, no gradient polish), then a bounded Nelder-Mead refinement. Every
trial point is a valid structure inside the bounds: bounds are checked against each
parameter's range when the spec is read, ``ck <= cs`` is kept (with both free, the
search runs on ``cs >= ck_lo`` and ``u`` in [0, 1], ``ck = ck_lo + u (min(ck_hi, cs) -
ck_lo)``) and the plates' mass ratios sum to at most 1 at every point of the bounds.

When the best point leaves a target unmet the design is **infeasible**; every target is
then searched alone, and the report names the targets that no point within the bounds
meets, or, if each can be met alone, the one that fails at the best compromise.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from study.engine.kinds import ResultFormat, ResultKind, register
from study.engine.layout import contact_law_attributes
from study.engine.spec_files import (
    SpecError,
    canonical_sha256,
    check_schema,
    load_schema,
    parse_toml,
    read_spec_text,
)
from study.model import lift_off_acceleration, mode_response, thresholds
from study.model.contact import DEFAULT_COUPLING
from study.model.disk import Disk, check_disk
from study.model.inputs import bounded_integer
from study.model.parameters import STRUCTURE, Parameter, schema_properties, units_list
from study.model.status import Status
from study.model.structure import Structure, tilt_warnings
from study.model.units import (
    DEGREE,
    DEGREE_PER_SECOND,
    DIMENSIONLESS,
    HERTZ,
    METRE_PER_SECOND,
    METRE_PER_SECOND_SQUARED,
    spoken,
)
from study.scenes.planar_model import (
    MAX_MARGIN_SAMPLES,
    check_drive,
    contact_margins,
    periodic_motion,
)
from study.scenes.scene_spec import disk_from_spec
from study.solvers.exact import steady_velocity

__all__ = [
    "BEHAVIOURS",
    "DESIGN_FORMAT",
    "DESIGN_KIND",
    "DESIGN_RESULT_SCHEMA",
    "DESIGN_SPEC_SCHEMA",
    "FAILED",
    "MIN_MARGIN",
    "DesignResult",
    "DesignSpec",
    "Evaluation",
    "Target",
    "design",
    "design_dataset",
    "disk_limits",
    "evaluate",
    "load_design_spec",
    "parse_design_spec",
]

DESIGN_SPEC_SCHEMA = "study-design-spec-v1"
DESIGN_RESULT_SCHEMA = "study-design-v1"
#: Layout of a design result (global attribute ``study_design_format``): 2 spells every
#: unit in CF/UDUNITS (``parameter_units`` of alpha and direction: ``degree``). Files
#: without it are format 1 (``deg``), refused as stale by validation.
DESIGN_FORMATS = (
    ResultFormat(1, "before 0.1.0", "units spelled deg", DESIGN_RESULT_SCHEMA),
    ResultFormat(2, "0.1.0", "every unit in CF/UDUNITS spelling (degree)", DESIGN_RESULT_SCHEMA),
)
#: The format this version writes.
DESIGN_FORMAT = DESIGN_FORMATS[-1].number

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

#: Speed margin of a target where the model has no orbit (lift-off, no convergence).
FAILED = -1.0
#: Margins are clipped to [-CLIP, CLIP] (a threshold at infinity is a margin of CLIP).
CLIP = 10.0
#: A target is met when its margin exceeds this (a speed of 1e-6 a/w is no motion).
MIN_MARGIN = 1e-6
#: Phases per period at which the disk's stuck forces are sampled (disk_limits).
PHASES = 2048

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
        _structure(start)
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


# ---------------------------------------------------------------------------
# The model: margins of every target at one point


def _structure(p: dict[str, float | None]) -> Structure:
    with tilt_warnings(False):  # the spec's tilts are in degree; the search may go near 0
        return Structure(f0=p["f0"], Q=p["Q"], alpha=p["alpha"], M=p["M"], cs=p["cs"],
                         ck=p["ck"], g=p["g"])


def _disk_of(spec: DesignSpec, p: dict[str, float | None]) -> Disk:
    assert spec.disk is not None
    plates = tuple(replace(plate, **{n: p[f"{plate.name}.{n}"] for n in PLATE_PARAMETERS})
                   for plate in spec.disk.plates)
    return replace(spec.disk, plates=plates, cs=p["cs"], ck=p["ck"], coupling=spec.coupling)


def disk_limits(disk: Disk, f: float, samples: int = PHASES) -> tuple[float, float]:
    """The disk's motion threshold and lift-off acceleration at ``f`` [m s-2].

    Stuck on the table, each plate's mode is on its steady response, proportional to
    ``a``: the friction load ``|(f, T / c)|`` (force and torque over the limit
    surface's length ``c``) is ``a W(phase)`` and the normal force
    ``g - a m(phase)``. The disk starts to slip where ``a |W| > cs (g - a m)`` first
    holds, so ``a* = cs g / max(|W| + cs m)``, and lifts off at ``a_lift = g / max(m)``
    (maxima over ``samples`` phases; ``inf`` where never). With one plate along the
    heading ``a*`` is ``min(a*_+, a*_-)`` of the single-plate model (paper eq. 5).
    """
    check_disk(disk)
    f, _ = check_drive(f, 0.0)
    samples = bounded_integer("samples", samples, 1, MAX_MARGIN_SAMPLES)
    omega = 2.0 * math.pi * float(f)
    phase = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
    rotor = np.exp(1j * phase)
    load = np.zeros((3, samples))
    m = np.cos(phase)
    for plate in disk.plates:
        alpha = math.radians(plate.alpha)
        # delta'' per unit a (mode_response needs only f0 and Q, which a Plate has).
        amplitude = math.cos(alpha) * complex(mode_response(plate, float(f)))  # type: ignore[arg-type]
        acceleration = (-(omega**2) * amplitude * rotor).real
        m = m - plate.M * math.cos(alpha) * acceleration
        horizontal = -plate.M * math.sin(alpha) * acceleration
        ex, ey = plate.unit_direction
        load[0] += horizontal * ex
        load[1] += horizontal * ey
        load[2] += horizontal * plate.lever / disk.friction_length
    slip = float(np.max(np.sqrt(np.sum(load**2, axis=0)) + disk.cs * m))
    lift = float(np.max(m))
    return (disk.cs * disk.g / slip if slip > 0.0 else math.inf,
            disk.g / lift if lift > 0.0 else math.inf)


@dataclass(frozen=True)
class Evaluation:
    """Every target's motion and margins at one point of the design space.

    Every attribute is an array over the targets.

    Attributes
    ----------
    forward_speed : numpy.ndarray
        Mean velocity [m s-1] (the single plate's ``v``; the disk's along its heading).
    lateral_speed, turn_rate : numpy.ndarray
        The disk's lateral speed [m s-1] and turn rate [rad s-1] (NaN for a plate).
    status : numpy.ndarray
        :class:`~study.model.status.Status` codes.
    threshold, lift : numpy.ndarray
        The motion threshold and lift-off acceleration at ``f`` [m s-2].
    rim : numpy.ndarray
        The disk's rim contact margin (:func:`study.scenes.planar_model.contact_margins`; NaN for a
        plate).
    speed_margin, threshold_margin, lift_margin, margin : numpy.ndarray
        The margins [1] (``speed_margin`` is NaN for a static target).
    limiting : numpy.ndarray
        Which margin is the target's (``speed``, ``threshold`` or ``lift``).
    """

    forward_speed: NDArray[np.float64]
    lateral_speed: NDArray[np.float64]
    turn_rate: NDArray[np.float64]
    status: NDArray[np.int8]
    threshold: NDArray[np.float64]
    lift: NDArray[np.float64]
    rim: NDArray[np.float64]
    speed_margin: NDArray[np.float64]
    threshold_margin: NDArray[np.float64]
    lift_margin: NDArray[np.float64]
    margin: NDArray[np.float64]
    limiting: tuple[str, ...]

    @property
    def score(self) -> float:
        """The smallest target margin (the objective)."""
        return float(np.min(self.margin))

    @property
    def met(self) -> NDArray[np.bool_]:
        return self.margin > MIN_MARGIN


def evaluate(spec: DesignSpec, params: dict[str, float | None],
             which: list[int] | None = None) -> Evaluation:
    """Margins of the targets (all, or those indexed by ``which``) at ``params`` (every
    parameter by name, as :attr:`DesignSpec.start`)."""
    targets = [spec.targets[i] for i in (range(len(spec.targets)) if which is None
                                         else which)]
    n = len(targets)
    f = np.array([t.f for t in targets])
    a = np.array([t.a for t in targets])
    lateral = np.full(n, np.nan)
    turn = np.full(n, np.nan)
    rim = np.full(n, np.nan)
    status = np.zeros(n, dtype=np.int8)
    if spec.model == "plate":
        s = _structure(params)
        forward, status = steady_velocity(s, f, a, coupling=spec.coupling)
        forward = np.asarray(forward, dtype=float)
        status = np.asarray(status, dtype=np.int8)
        plus, minus = thresholds(s, f)
        threshold = np.minimum(plus, minus)
        lift = np.asarray(lift_off_acceleration(s, f), dtype=float)
        radius = 0.0
    else:
        disk = _disk_of(spec, params)
        radius = disk.radius
        forward = np.full(n, np.nan)
        threshold = np.empty(n)
        lift = np.empty(n)
        for i, t in enumerate(targets):
            threshold[i], lift[i] = disk_limits(disk, t.f)
            motion = periodic_motion(disk, t.f, t.a)
            # The planar API gives turn rates in degree s-1; margins use rad s-1.
            forward[i], lateral[i], turn[i] = (motion.forward_speed, motion.lateral_speed,
                                               math.radians(motion.turn_rate))
            status[i] = motion.status
            rim[i] = contact_margins(disk, t.f, t.a)[0]
    unit = a / (2.0 * np.pi * f)
    speed = np.full(n, np.nan)
    for i, t in enumerate(targets):
        if t.behaviour == "forward":
            speed[i] = forward[i]
        elif t.behaviour == "backward":
            speed[i] = -forward[i]
        elif t.behaviour == "left":
            speed[i] = radius * turn[i]
        elif t.behaviour == "right":
            speed[i] = -radius * turn[i]
        elif t.behaviour == "moving":
            parts = [forward[i]] if spec.model == "plate" else [
                forward[i], lateral[i], radius * turn[i]]
            speed[i] = math.hypot(*parts)
        else:
            continue
        speed[i] = speed[i] / unit[i] if math.isfinite(speed[i]) else FAILED
    static = np.array([t.behaviour == "static" for t in targets])
    with np.errstate(invalid="ignore"):
        above = np.clip(np.where(static, threshold - a, a - threshold) / a, -CLIP, CLIP)
        below = np.clip((lift - a) / a, -CLIP, CLIP)
    speed = np.clip(speed, -CLIP, CLIP)
    w = spec.weights
    kinds = ("speed", "threshold", "lift")
    margin = np.empty(n)
    limiting = []
    for i in range(n):
        values = [w["speed"] * speed[i], w["threshold"] * above[i], w["lift"] * below[i]]
        values = [v if not math.isnan(v) else math.inf for v in values]
        k = int(np.argmin(values))
        margin[i] = values[k]
        limiting.append(kinds[k])
    return Evaluation(
        forward_speed=forward, lateral_speed=lateral, turn_rate=turn, status=status,
        threshold=threshold, lift=lift, rim=rim, speed_margin=speed,
        threshold_margin=above, lift_margin=below, margin=margin, limiting=tuple(limiting))


# ---------------------------------------------------------------------------
# The search: a vector of internal coordinates, always a valid structure


@dataclass
class _Space:
    """Internal coordinates: the free parameters, except that with ``cs`` and ``ck``
    both free ``ck = ck_lo + u (min(ck_hi, cs) - ck_lo)`` with ``u`` in [0, 1] (and
    ``cs >= ck_lo``): every point is inside both boxes with ``ck <= cs``."""

    spec: DesignSpec
    names: list[str] = field(init=False)
    ratio: bool = field(init=False)  # ck searched as u (class doc)
    lower: NDArray[np.float64] = field(init=False)
    upper: NDArray[np.float64] = field(init=False)
    evaluations: int = 0

    def __post_init__(self) -> None:
        spec = self.spec
        self.names = list(spec.free)
        self.ratio = "cs" in spec.free and "ck" in spec.free
        lower = np.array([spec.free[n][0] for n in self.names])
        upper = np.array([spec.free[n][1] for n in self.names])
        ck = spec.start.get("ck")
        if "cs" in spec.free and not self.ratio and ck is not None:
            j = self.names.index("cs")
            lower[j] = max(lower[j], ck)
        if "ck" in spec.free and not self.ratio:
            j = self.names.index("ck")
            upper[j] = min(upper[j], float(spec.start["cs"]))
        if self.ratio:
            j, k = self.names.index("ck"), self.names.index("cs")
            lower[k] = max(lower[k], spec.free["ck"][0])
            lower[j], upper[j] = 0.0, 1.0
        self.lower, self.upper = lower, upper

    def _ck_span(self, cs: float) -> tuple[float, float]:
        low, high = self.spec.free["ck"]
        return low, max(min(high, cs) - low, 0.0)

    def start(self) -> NDArray[np.float64]:
        p = self.spec.start
        x = np.array([float(p[n] if p[n] is not None else p["cs"]) for n in self.names])
        if self.ratio:
            low, span = self._ck_span(float(p["cs"]))
            x[self.names.index("ck")] = (float(p["ck"]) - low) / span if span > 0 else 0.0
        return np.clip(x, self.lower, self.upper)

    def params(self, x: NDArray[np.float64]) -> dict[str, float | None]:
        p = dict(self.spec.start)
        for n, value in zip(self.names, x, strict=True):
            p[n] = float(value)
        if self.ratio:
            low, span = self._ck_span(float(p["cs"]))
            p["ck"] = min(low + float(p["ck"]) * span, float(p["cs"]))
        return p

    def physical(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        p = self.params(x)
        return np.array([p[n] if p[n] is not None else p["cs"] for n in self.names],
                        dtype=float)

    def score(self, x: NDArray[np.float64], which: list[int] | None = None) -> float:
        self.evaluations += 1
        x = np.clip(np.asarray(x, dtype=float), self.lower, self.upper)
        return evaluate(self.spec, self.params(x), which).score


def _search(space: _Space, which: list[int] | None, iterations: int
            ) -> tuple[NDArray[np.float64], float, NDArray[np.float64], NDArray[np.float64]]:
    """The best internal point, its score, and the 1-D scan (empty for several)."""
    from scipy.optimize import differential_evolution, minimize, minimize_scalar

    spec = space.spec
    lo, hi = space.lower, space.upper
    if len(space.names) == 1:
        grid = np.linspace(lo[0], hi[0], spec.scan_points)
        scores = np.array([space.score(np.array([v]), which) for v in grid])
        i = int(np.argmax(scores))
        left, right = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        best_x, best = np.array([grid[i]]), float(scores[i])
        refined = minimize_scalar(lambda v: -space.score(np.array([v]), which),
                                  bounds=(left, right), method="bounded",
                                  options={"xatol": 1e-6 * (hi[0] - lo[0])})
        if -refined.fun > best:
            best_x, best = np.array([float(refined.x)]), float(-refined.fun)
        return best_x, best, grid, scores
    bounds = list(zip(lo, hi, strict=True))
    found = differential_evolution(
        lambda x: -space.score(x, which), bounds, rng=spec.seed, maxiter=iterations,
        popsize=spec.population, tol=1e-8, polish=False, x0=space.start())
    best_x, best = np.asarray(found.x, dtype=float), float(-found.fun)
    refined = minimize(lambda x: -space.score(x, which), best_x, method="Nelder-Mead",
                       bounds=bounds, options={"maxfev": 100 * len(bounds),
                                               "xatol": 1e-8, "fatol": 1e-10})
    if -refined.fun > best:
        best_x, best = np.clip(np.asarray(refined.x, dtype=float), lo, hi), float(-refined.fun)
    return best_x, best, np.empty(0), np.empty(0)


@dataclass(frozen=True)
class DesignResult:
    """The best design and its margins.

    Attributes
    ----------
    names : list of str
        Free parameters.
    best, lower, upper, start : numpy.ndarray
        Best values and the search's bounds, in each parameter's units (``lower`` and
        ``upper`` are the effective bounds: ``ck <= cs`` can narrow the spec's).
    params : dict
        Every parameter at the best point (``ck`` None: tied to ``cs``).
    evaluation : Evaluation
        Every target at the best point.
    score : float
        The smallest target margin there.
    feasible : bool
        Whether every target is met.
    alone : numpy.ndarray
        Infeasible designs: each target's best margin searched alone (NaN otherwise).
    failing : list of str
        Labels of the targets the report blames (empty when feasible).
    message : str
        The report.
    scan_values, scan_scores : numpy.ndarray
        One free parameter: the scan of the objective (empty otherwise).
    evaluations : int
    wall_seconds : float
    """

    names: list[str]
    best: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    start: NDArray[np.float64]
    params: dict[str, float | None]
    evaluation: Evaluation
    score: float
    feasible: bool
    alone: NDArray[np.float64]
    failing: list[str]
    message: str
    scan_values: NDArray[np.float64]
    scan_scores: NDArray[np.float64]
    evaluations: int
    wall_seconds: float


def design(spec: DesignSpec, progress: Callable[[str], None] | None = None) -> DesignResult:
    """Search the free parameters of ``spec`` for the largest smallest target margin
    (module doc); never raises on an infeasible design, which the result reports."""
    started = time.perf_counter()
    space = _Space(spec)
    x, score, scan_values, scan_scores = _search(space, None, spec.max_iterations)
    params = space.params(x)
    evaluation = evaluate(spec, params)
    score = evaluation.score
    feasible = bool(np.all(evaluation.met))
    alone = np.full(len(spec.targets), np.nan)
    failing: list[str] = []
    if feasible:
        k = int(np.argmin(evaluation.margin))
        message = (f"feasible: every target is met; the smallest margin is {score:.4g} "
                   f"({evaluation.limiting[k]} margin of '{spec.targets[k].label}')")
    else:
        for i, target in enumerate(spec.targets):
            if progress is not None:
                progress(f"searching target '{target.label}' alone")
            alone[i] = _search(space, [i], max(10, spec.max_iterations // 2))[1]
        hopeless = [i for i in range(alone.size) if not alone[i] > MIN_MARGIN]
        if hopeless:
            failing = [spec.targets[i].label for i in hopeless]
            parts = "; ".join(
                f"'{spec.targets[i].label}' (best margin alone "
                f"{alone[i] if abs(alone[i]) > MIN_MARGIN else 0.0:.3g}; at the best "
                f"compromise its {evaluation.limiting[i]} margin is "
                f"{evaluation.margin[i]:.3g})" for i in hopeless)
            message = ("infeasible: no point within the bounds meets every target; "
                       f"not met anywhere within the bounds: {parts}")
        else:
            k = int(np.argmin(evaluation.margin))
            failing = [spec.targets[k].label]
            message = ("infeasible: each target can be met alone but not all together; at "
                       f"the best compromise '{spec.targets[k].label}' fails (its "
                       f"{evaluation.limiting[k]} margin is {evaluation.margin[k]:.3g})")
    return DesignResult(
        names=space.names, best=space.physical(x), lower=_effective(space, "lower"),
        upper=_effective(space, "upper"), start=space.physical(space.start()),
        params=params, evaluation=evaluation, score=score, feasible=feasible, alone=alone,
        failing=failing, message=message,
        scan_values=np.array([space.physical(np.array([v]))[0] for v in scan_values]),
        scan_scores=scan_scores, evaluations=space.evaluations,
        wall_seconds=time.perf_counter() - started)


def _effective(space: _Space, which: str) -> NDArray[np.float64]:
    values = np.array(getattr(space, which), dtype=float)
    if space.ratio:  # report ck's bounds as the spec gave them, not u's
        j = space.names.index("ck")
        values[j] = space.spec.free["ck"][0 if which == "lower" else 1]
    return values


# ---------------------------------------------------------------------------
# The result file


def design_dataset(spec: DesignSpec, result: DesignResult, command: str = "") -> xr.Dataset:
    """The design as a self-describing dataset (the layout of ``study-design-v1``)."""
    from study.engine.fingerprint import code_fingerprint
    from study.engine.provenance import utc_now

    code = code_fingerprint(("study.analyses.design",)).sha256
    now = utc_now()
    variables = {**_parameter_variables(result), **_target_variables(spec, result),
                 **_summary_variables(spec, result)}
    designed = {k: v for k, v in result.params.items() if v is not None}
    attrs = {
        "Conventions": "CF-1.11",
        "title": spec.title,
        "study_result_schema": DESIGN_RESULT_SCHEMA,
        "study_design_format": DESIGN_FORMAT,
        "study_design_name": spec.name,
        "study_name": spec.name,
        "study_spec": spec.text,
        "study_spec_sha256": spec.sha256,
        "study_code_sha256": code,
        "study_model": spec.model,
        # The model's contact laws (issue 33): the spec's coupling, and the friction
        # and lift-off laws both models use unless told otherwise (Coulomb, stop at
        # lift-off: steady_velocity and the disk's planar model), which a design spec
        # cannot change.
        **contact_law_attributes(spec.coupling),
        "study_weights": json.dumps(spec.weights),
        "study_designed_structure": json.dumps(designed),
        "study_feasible": int(result.feasible),
        "study_failing_targets": json.dumps(result.failing),
        "study_report": result.message,
        "date_created": now,
        "history": f"{now}: {command or 'study.analyses.design'}",
        "provenance": json.dumps(_design_provenance(spec, result, code, now, command),
                                 default=str),
    }
    return xr.Dataset({k: xr.Variable(*v) for k, v in variables.items()},
                      coords={k: xr.Variable(*v) for k, v in _design_coords(spec, result).items()},
                      attrs=attrs)


def _design_provenance(spec: DesignSpec, result: DesignResult, code: str, now: str,
                       command: str) -> dict[str, Any]:
    """The run's provenance record: spec, code, environment and how the search went."""
    from study.engine.provenance import environment, git_state, package_version

    names = result.names
    return {
        "spec": spec.text, "spec_sha256": spec.sha256, "code_sha256": code,
        "package_version": package_version(), **git_state(),
        "environment": environment(), "end_time": now, "command": command,
        "optimizer": ("scan + scipy.optimize.minimize_scalar(method='bounded')"
                      if len(names) == 1 else
                      "scipy.optimize.differential_evolution + minimize(method='Nelder-Mead')"),
        "evaluations": result.evaluations, "wall_seconds": result.wall_seconds,
    }


def _design_coords(spec: DesignSpec, result: DesignResult) -> dict[str, tuple[Any, ...]]:
    """The free parameters' axis with their units, and the targets' axis."""
    names = result.names
    units = [spec.parameter(n).units for n in names]
    p, t = ("parameter",), ("target",)
    return {
        "parameter": (p, np.array(names, dtype=object), {"long_name": "free parameter"}),
        "parameter_units": (p, np.array(units, dtype=object),
                            {"long_name": "units of the parameter's values"}),
        "target": (t, np.array([x.label for x in spec.targets], dtype=object),
                   {"long_name": "target behaviour at a drive command"}),
    }


#: The per-parameter variables' note on units.
_PER_UNIT = {"units_variable": "parameter_units",
             "comment": "in each parameter's own units (parameter_units)"}


def _parameter_variables(result: DesignResult) -> dict[str, tuple[Any, ...]]:
    """The variables over the free parameters: the design, the bounds and the start."""
    p, per_unit = ("parameter",), _PER_UNIT
    return {
        "best": (p, result.best, {"long_name": "designed value", **per_unit}),
        "lower_bound": (p, result.lower, {"long_name": "lower bound of the search",
                                          **per_unit}),
        "upper_bound": (p, result.upper, {"long_name": "upper bound of the search",
                                          **per_unit}),
        "start": (p, result.start, {"long_name": "start value", **per_unit}),
    }


def _target_variables(spec: DesignSpec, result: DesignResult) -> dict[str, tuple[Any, ...]]:
    """The variables over the targets: the drive asked for, the motion and margins at
    the design, whether each is met and its best margin searched alone."""
    t, one, ev = ("target",), {"units": DIMENSIONLESS}, result.evaluation
    return {
        "f": (t, np.array([x.f for x in spec.targets]), {
            "long_name": "drive frequency", "units": HERTZ}),
        "a": (t, np.array([x.a for x in spec.targets]), {
            "long_name": "drive acceleration amplitude", "units": METRE_PER_SECOND_SQUARED}),
        "behaviour": (t, np.array([x.behaviour for x in spec.targets], dtype=object), {
            "long_name": "behaviour asked for (" + ", ".join(BEHAVIOURS) + ")"}),
        "forward_speed": (t, ev.forward_speed, {
            "long_name": "steady mean velocity (the disk's along its heading)",
            "units": METRE_PER_SECOND}),
        "lateral_speed": (t, ev.lateral_speed, {
            "long_name": "steady mean velocity to the left of the heading (disk)",
            "units": METRE_PER_SECOND}),
        "turn_rate": (t, np.degrees(ev.turn_rate), {
            "long_name": "steady mean angular velocity, counterclockwise positive (disk)",
            "units": DEGREE_PER_SECOND}),
        "solver_status": (t, np.array([Status(int(s)).name for s in ev.status],
                                      dtype=object), {"long_name": "solver status"}),
        "motion_threshold": (t, ev.threshold, {
            "long_name": "lowest drive at which the structure slips at f",
            "units": METRE_PER_SECOND_SQUARED}),
        "lift_off_acceleration": (t, ev.lift, {
            "long_name": "drive above which the normal force vanishes in the cycle",
            "units": METRE_PER_SECOND_SQUARED}),
        "edge_contact_margin": (t, ev.rim, {
            "long_name": "rim contact margin of the disk (NaN: single plate)", **one}),
        "speed_margin": (t, ev.speed_margin, {
            "long_name": "velocity in the target's direction over a/w", **one,
            "comment": f"turns: rim speed R spin; {FAILED:g}: no orbit; NaN: static target"}),
        "threshold_margin": (t, ev.threshold_margin, {
            "long_name": "(a - a*)/a above the motion threshold ((a* - a)/a for static)",
            **one}),
        "lift_margin": (t, ev.lift_margin, {
            "long_name": "(a_lift - a)/a below lift-off", **one}),
        "margin": (t, ev.margin, {
            "long_name": "the target's margin: the smallest weighted margin", **one}),
        "limiting_margin": (t, np.array(ev.limiting, dtype=object), {
            "long_name": "which margin is the target's (speed, threshold, lift)"}),
        "met": (t, ev.met.astype(np.int8), {
            "long_name": "whether the target is met at the design",
            "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "not_met met"}),
        "best_margin_alone": (t, result.alone, {
            "long_name": "the target's best margin searched alone (infeasible designs)",
            **one, "comment": "NaN: not searched (the design is feasible)"}),
    }


def _summary_variables(spec: DesignSpec, result: DesignResult) -> dict[str, tuple[Any, ...]]:
    """The design's score and feasibility, and the scan of a one-parameter search."""
    names, one = result.names, {"units": DIMENSIONLESS}
    variables: dict[str, tuple[Any, ...]] = {
        "score": ((), result.score, {
            "long_name": "smallest target margin at the design (the objective)", **one}),
        "feasible": ((), np.int8(result.feasible), {
            "long_name": "whether every target is met",
            "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "infeasible feasible"}),
    }
    if result.scan_values.size:
        variables["scan_value"] = (("scan",), result.scan_values, {
            "long_name": f"scanned value of {names[0]}",
            "units": spec.parameter(names[0]).units})
        variables["scan_score"] = (("scan",), result.scan_scores, {
            "long_name": "smallest target margin at the scanned value", **one})
    return variables


# ---------------------------------------------------------------------------
# The design kind (study.engine.kinds): what the runner, validation and the CLI need


def _design_for_runner(spec: DesignSpec, progress: Any) -> DesignResult:
    return design(spec, progress=progress.say)


#: The design kind: structure parameters searched for target behaviours.
DESIGN_KIND = register(ResultKind(
    name="design", spec_table="design", spec_schema=DESIGN_SPEC_SCHEMA,
    result_schema=DESIGN_RESULT_SCHEMA, entry_modules=("study.analyses.design",),
    summary="design: structure parameters that achieve target behaviours",
    label="design result", spec_type=DesignSpec, load=load_design_spec,
    parse=parse_design_spec, validator="study.analyses.fit_checks:design_problems",
    name_attribute="study_design_name", compute=_design_for_runner, build=design_dataset,
    own_provenance=True,
    formats=DESIGN_FORMATS, format_attribute="study_design_format",
))
