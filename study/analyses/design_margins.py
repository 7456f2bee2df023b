"""Design margins: every target's motion and margins at one point of the design space.

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

Velocities are :func:`study.solvers.exact.steady_velocity` with the spec's coupling
(default :data:`study.solvers.exact.DEFAULT_COUPLING`, ``"one-way"``, the paper's model,
as everywhere), or :func:`study.scenes.planar_model.periodic_motion` for the disk.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from study.analyses.design_spec import PLATE_PARAMETERS, DesignSpec, plate_structure
from study.model import lift_off_acceleration, mode_response, thresholds
from study.model.disk import Disk, check_disk
from study.model.inputs import bounded_integer
from study.scenes.planar_model import (
    MAX_MARGIN_SAMPLES,
    check_drive,
    contact_margins,
    periodic_motion,
)
from study.solvers.exact import steady_velocity

__all__ = [
    "FAILED",
    "MIN_MARGIN",
    "Evaluation",
    "disk_limits",
    "evaluate",
]

#: Speed margin of a target where the model has no orbit (lift-off, no convergence).
FAILED = -1.0
#: Margins are clipped to [-CLIP, CLIP] (a threshold at infinity is a margin of CLIP).
CLIP = 10.0
#: A target is met when its margin exceeds this (a speed of 1e-6 a/w is no motion).
MIN_MARGIN = 1e-6
#: Phases per period at which the disk's stuck forces are sampled (disk_limits).
PHASES = 2048


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
        s = plate_structure(params)
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
