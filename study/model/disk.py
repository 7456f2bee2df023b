"""The planar model's structure: a rigid disk, its resonant plates and its contact.

The paper's Fig. 4 structure is a disk with two soft plates: a head plate that moves
it forward or backward and a tail plate, across the head-tail axis, that turns it.
Each plate is the single-plate model's mode (paper eqs. 2-4), mounted at a point of the
disk along a direction in its body frame. This module declares them (:class:`Plate`,
:class:`Disk`), checks them and gives the plates' steady response to a drive
(:func:`mode_amplitude`, :func:`steady_plate_response`); the time integration is
:mod:`study.solvers.planar`'s, the scene-level API :mod:`study.scenes.planar_model`'s.

SI units; every angle a caller passes or gets back is in degrees (the plates' tilt and
direction, as in :class:`study.model.structure.Structure`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.model.contact import COUPLINGS, DEFAULT_COUPLING, check_law
from study.model.forces import mode_response
from study.model.inputs import InputTypeError, instance_of
from study.model.structure import require_finite
from study.model.units import DEGREE, DIMENSIONLESS, HERTZ, spoken

__all__ = [
    "FRICTION_LENGTH_RATIO",
    "Disk",
    "Plate",
    "check_disk",
    "describe_disk",
    "mode_amplitude",
    "steady_plate_response",
]


@dataclass(frozen=True)
class Plate:
    """One resonant plate on the disk.

    Parameters
    ----------
    f0 : float
        Resonance frequency of the plate's first mode [Hz], > 0.
    Q : float
        Quality factor [1], > 0.
    alpha : float
        Tilt of the mode's direction from the horizontal [degree], in [0, 90].
    M : float
        Mass ratio of the plate's modal mass to the whole structure's mass [1], in (0, 1].
    direction : float
        Direction of the mode's horizontal component in the body frame, counterclockwise
        from the heading [degree].
    attachment : tuple of float
        Point where the plate acts, body frame ``(forward, left)`` from the disk's
        centre [m].
    name : str
        Label.
    """

    f0: float
    Q: float
    alpha: float
    M: float
    direction: float = 0.0
    attachment: tuple[float, float] = (0.0, 0.0)
    name: str = "plate"

    def __post_init__(self) -> None:
        checks = (
            ("f0", HERTZ, lambda v: v > 0.0, "> 0"),
            ("Q", DIMENSIONLESS, lambda v: v > 0.0, "> 0"),
            ("alpha", DEGREE, lambda v: 0.0 <= v <= 90.0, "in [0, 90]"),
            ("M", DIMENSIONLESS, lambda v: 0.0 < v <= 1.0, "in (0, 1]"),
            ("direction", DEGREE, lambda v: True, "finite"),
        )
        for name, units, ok, allowed in checks:
            value = require_finite(f"Plate.{name}", getattr(self, name))
            if not ok(value):
                raise ValueError(
                    f"Plate {self.name!r}: {name} = {value!r}{spoken(units)} is out of range; "
                    f"allowed: {allowed}"
                )
            object.__setattr__(self, name, value)
        point = (tuple(self.attachment) if isinstance(self.attachment, Iterable)
                 and not isinstance(self.attachment, str) else ())
        if len(point) != 2:
            raise ValueError(
                f"Plate {self.name!r}: attachment must be (forward, left) [m], got "
                f"{self.attachment!r}"
            )
        object.__setattr__(self, "attachment", tuple(
            require_finite(f"Plate.attachment[{i}]", v) for i, v in enumerate(point)
        ))

    @property
    def unit_direction(self) -> tuple[float, float]:
        """Body-frame unit vector of the mode's horizontal component (forward, left)."""
        angle = math.radians(self.direction)
        return math.cos(angle), math.sin(angle)

    @property
    def omega0(self) -> float:
        """Angular resonance frequency of the plate's mode [rad s-1]."""
        return 2.0 * math.pi * self.f0

    @property
    def lever(self) -> float:
        """Moment arm ``r x e`` of the plate's horizontal force about the centre [m]."""
        ex, ey = self.unit_direction
        return self.attachment[0] * ey - self.attachment[1] * ex


#: Friction length over the disk's radius [1]. At most 1: the friction torque's lever
#: cannot exceed the contact's radius (uniform pressure gives 2/3). At least 1e-3: the
#: kernel divides the friction torque by the length, and a shorter one makes the spin
#: a stiff, nearly frictionless mode (a 1 s two-plate schedule: 3.5e3 steps at 2/3,
#: 1e5 at 1e-3, 9.4e4 and 17 times the time at 1e-9, over 5 minutes at 1e-12, a
#: ZeroDivisionError at 1e-300). Declared here only; the scene and design specs refuse
#: a [disk] friction_length outside it through :class:`Disk`.
FRICTION_LENGTH_RATIO = (1e-3, 1.0)


@dataclass(frozen=True)
class Disk:
    """The rigid disk, its contact with the table and its plates.

    Parameters
    ----------
    radius : float
        Disk radius [m], > 0.
    plates : tuple of Plate
        The plates (at least one); their mass ratios sum to at most 1.
    cs : float
        Static friction coefficient [1], > 0.
    ck : float, optional
        Kinetic friction coefficient [1], in (0, cs]; default ``cs``.
    g : float
        Gravitational acceleration [m s-2].
    gyration_radius : float, optional
        Radius of gyration about the vertical axis [m]; default ``radius / sqrt(2)``
        (a uniform disk).
    friction_length : float, optional
        Length ``c`` of the ellipsoidal limit surface, the maximum friction torque
        over the maximum friction force [m]; default ``2 radius / 3`` (uniform
        pressure on the full disk); ``radius / 1000 <= c <= radius``
        (:data:`FRICTION_LENGTH_RATIO`).
    coupling : {"one-way", "two-way"}
        ``"one-way"`` (default, :data:`study.solvers.exact.DEFAULT_COUPLING`): each plate's mode
        is forced by the table only.
        ``"two-way"``: while the disk slides, the acceleration of each plate's
        attachment point projected on its direction, ``b_i``, forces it too,
        ``delta_i'' = F_i - sin(alpha_i) b_i`` (as :func:`study.solvers.integrator.simulate`'s
        two-way model); a slip whose coupled equations have no unique solution
        (Painleve's paradox) stops a run with outcome ``friction_paradox``.
    flight : bool
        The lift-off law: False (the only value allowed) ends a run with outcome
        ``lift_off`` where the normal force would turn negative; True (flight and
        impacts) is refused: the planar model does not implement it.
    """

    radius: float
    plates: tuple[Plate, ...]
    cs: float
    ck: float | None = None
    g: float = 9.8
    gyration_radius: float | None = None
    friction_length: float | None = None
    coupling: str = DEFAULT_COUPLING
    flight: bool = False
    _names: tuple[str, ...] = field(default=(), init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        radius = require_finite("Disk.radius", self.radius)
        if radius <= 0.0:
            raise ValueError(f"Disk: radius = {radius!r} [m] must be > 0")
        if isinstance(self.plates, Plate | str) or not isinstance(self.plates, Iterable):
            raise InputTypeError("Disk: plates must be a non-empty sequence of "
                                 f"study.model.disk.Plate, got {self.plates!r}")
        plates = tuple(self.plates)
        if not plates or not all(isinstance(p, Plate) for p in plates):
            raise ValueError("Disk: plates must be a non-empty sequence of "
                             "study.model.disk.Plate")
        total = sum(p.M for p in plates)
        if total > 1.0 + 1e-12:
            raise ValueError(
                f"Disk: the plates' mass ratios sum to {total:g} > 1; allowed: a sum <= 1 "
                "(each M is a share of the whole structure's mass)"
            )
        cs = require_finite("Disk.cs", self.cs)
        if cs <= 0.0:
            raise ValueError(f"Disk: cs = {cs!r} must be > 0")
        ck = cs if self.ck is None else require_finite("Disk.ck", self.ck)
        if not 0.0 < ck <= cs:
            raise ValueError(f"Disk: ck = {ck!r} must be in (0, cs = {cs!r}]")
        g = require_finite("Disk.g", self.g)
        if g <= 0.0:
            raise ValueError(f"Disk: g = {g!r} [m s-2] must be > 0")
        gyration = radius / math.sqrt(2.0) if self.gyration_radius is None else (
            require_finite("Disk.gyration_radius", self.gyration_radius))
        length = 2.0 * radius / 3.0 if self.friction_length is None else (
            require_finite("Disk.friction_length", self.friction_length))
        if self.coupling not in COUPLINGS:
            raise ValueError(f"Disk: coupling = {self.coupling!r} must be one of {COUPLINGS}")
        if not isinstance(self.flight, bool):
            raise ValueError(f"Disk: flight must be true or false, got {self.flight!r}")
        try:
            check_law("lift_off", "flight" if self.flight else "stop", "planar")
        except ValueError as err:
            raise ValueError(
                f"Disk: flight = {self.flight!r}: {err} (the planar model ends a run with "
                "outcome 'lift_off' where the normal force would turn negative; flight is "
                "modelled for the single plate by the exact solver and the time "
                "integrator)") from None
        for name, value in (("gyration_radius", gyration), ("friction_length", length)):
            if value <= 0.0:
                raise ValueError(f"Disk: {name} = {value!r} [m] must be > 0")
        low, high = FRICTION_LENGTH_RATIO
        if not low * radius <= length <= high * radius:
            raise ValueError(
                f"Disk: friction_length = {length!r} m is out of range; allowed: "
                f"radius/{1 / low:g} to radius ({low * radius:g} to {high * radius:g} m; "
                "uniform pressure gives 2 radius/3)")
        for name, value in (("radius", radius), ("plates", plates), ("cs", cs), ("ck", ck),
                            ("g", g), ("gyration_radius", gyration),
                            ("friction_length", length)):
            object.__setattr__(self, name, value)

    @property
    def diameter(self) -> float:
        """Disk diameter [m]."""
        return 2.0 * self.radius


def check_disk(disk: object) -> Disk:
    """``disk`` if it is a :class:`Disk`, else a TypeError
    (:class:`study.model.inputs.InputTypeError`) naming the argument."""
    return instance_of("disk", disk, Disk, "a study.model.disk.Disk")


def describe_disk(disk: Disk) -> dict[str, Any]:
    """The disk's parameters as plain numbers (for provenance)."""
    check_disk(disk)
    return {
        "radius": disk.radius, "cs": disk.cs, "ck": disk.ck, "g": disk.g,
        "gyration_radius": disk.gyration_radius, "friction_length": disk.friction_length,
        # Named only when two-way, so a one-way disk's description (and the hash of
        # every scene spec written before the option) stays as it was.
        **({"coupling": disk.coupling} if disk.coupling != "one-way" else {}),
        "plates": [
            {"name": p.name, "f0": p.f0, "Q": p.Q, "alpha": p.alpha, "M": p.M,
             "direction": p.direction, "attachment": list(p.attachment)}
            for p in disk.plates
        ],
    }


def mode_amplitude(plate: Plate, f: float, a: float) -> complex:
    """Complex amplitude of the plate's steady response ``delta`` to ``a cos(2 pi f t)``.

    Parameters
    ----------
    plate : Plate
        The plate (its mode's ``omega0`` [rad s-1], ``Q`` [1] and tilt ``alpha``
        [degree]).
    f : float
        Drive frequency [Hz], a checked one.
    a : float
        Drive acceleration amplitude [m s-2], a checked one.

    Returns
    -------
    complex
        ``a cos(alpha) G(f)`` [m], ``G`` the single-plate model's mode response
        (:func:`study.model.forces.mode_response`).
    """
    # mode_response needs only the mode's omega0 and Q, which a Plate has too.
    response = mode_response(plate, float(f))  # type: ignore[arg-type]
    return complex(float(a) * math.cos(math.radians(plate.alpha)) * response)


def steady_plate_response(disk: Disk, f: float, a: float, phase: float
                          ) -> NDArray[np.float64]:
    """Plate states on their steady response to ``a cos(2 pi f t + phase)`` at ``t = 0``.

    The arguments are not checked (:func:`study.scenes.planar_model.steady_plate_states`
    checks them against the scene spec's drive ranges, then calls this).

    Parameters
    ----------
    disk : Disk
    f : float
        Drive frequency [Hz].
    a : float
        Drive acceleration amplitude [m s-2].
    phase : float
        Drive phase at ``t = 0`` [rad].

    Returns
    -------
    numpy.ndarray
        ``(delta_1, delta_1', ...)`` [m, m s-1], two entries a plate: a run started
        there has no mode transient.
    """
    omega = 2.0 * math.pi * float(f)
    out = np.empty(2 * len(disk.plates))
    for i, plate in enumerate(disk.plates):
        rotating = mode_amplitude(plate, f, a) * complex(math.cos(phase), math.sin(phase))
        out[2 * i] = rotating.real
        out[2 * i + 1] = (1j * omega * rotating).real
    return out
