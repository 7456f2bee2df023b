"""Planar steering model: a rigid disk with resonant plates on a vertically shaken table.

The paper's Fig. 4 structure is a disk with two soft plates: a head plate that moves
it forward or backward and a tail plate, across the head-tail axis, that turns it.
Each plate is the single-plate model of paper eqs. 2-4 (a first mode driven by the
table; one-way coupled by default, or two-way: the disk's sliding acceleration at the
plate's attachment, projected on its direction, forces the plate too), mounted at a
point of the disk along a direction in its body frame. The disk's contact is planar
Coulomb friction with an ellipsoidal limit surface (the friction force and torque at
sliding lie on the ellipsoid ``|f|^2 / (mu n)^2 + tau^2 / (mu n c)^2 = 1``; the twist
is normal to it), with stick and slip for force and torque together. Where the normal
force would turn negative the model stops holding and a run ends with outcome
``lift_off`` (the lift-off law ``stop``, the only one the planar model implements): the
disk does not fly (``Disk(flight=True)`` is refused; the single plate's integrator and
the exact solver model flight). See
:mod:`study.kernels.planar_integrator` for the equations and docs/user-guide/steering.md
for the choices.

The model lives in three stages: the disk and its plates are declared in
:mod:`study.model.disk`, the time integration is :mod:`study.solvers.planar`'s
(:func:`~study.solvers.planar.simulate_planar`) and :mod:`study.solvers.planar_periodic`'s
(the periodic-orbit search), and this module holds the
model at the drives a scene spec allows: the drive checks against the scene spec
schema (:func:`check_drive`), the steady plate states and rest states at a drive, the
steady motion under a constant drive (:func:`periodic_motion`) and the contact margins.

Per unit total mass, SI units: lengths in m; every angle a caller passes or gets back
is in degrees (headings and turn rates in degree and degree s-1), including the
heading and spin of the state vectors (:func:`rest_state`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

from study.engine.spec_files import load_schema
from study.model.disk import Disk, check_disk, mode_amplitude, steady_plate_response
from study.model.inputs import (
    InputTypeError,
    as_real_array,
    bounded_integer,
    bounded_number,
)
from study.model.units import HERTZ, METRE_PER_SECOND_SQUARED
from study.solvers.integrator import IntegratorSettings, check_integrator_settings
from study.solvers.planar import MIN_DISK_FREQUENCY, POSE_STATE, SLAVING
from study.solvers.planar_periodic import PeriodicMotion, integrated_periodic_motion

__all__ = [
    "DRIVE_SCHEMA",
    "MAX_MARGIN_SAMPLES",
    "check_drive",
    "contact_margins",
    "max_steady_periods",
    "periodic_motion",
    "rest_state",
    "steady_plate_states",
]

#: Phases :func:`contact_margins` samples at most (one array of them per plate).
MAX_MARGIN_SAMPLES = 1_000_000


#: The spec schema whose ``$defs/parameter`` ranges of ``f`` and ``a`` bound a disk's
#: drive (study.scenes.scene_spec reads its specs against it): the API takes the same drives.
DRIVE_SCHEMA = "study-scene-spec-v1"


def max_steady_periods() -> int:
    """Drive periods :func:`periodic_motion` integrates at most: the scene schema's
    ``[calibration] max_periods`` maximum (1e5, about 100 s of one core)."""
    schema = load_schema(DRIVE_SCHEMA)
    return int(schema["properties"]["calibration"]["properties"]["max_periods"]["maximum"])


def check_drive(f: object, a: object) -> tuple[float, float]:
    """A disk's drive ``(f [Hz], a [m s-2])`` as floats, within the ranges the scene
    spec schema declares for ``f`` and ``a`` (finite, ``1e-100 <= f <= 1e4``,
    ``0 <= a <= 1e4``: beyond them the period or the forces overflow); else an error
    naming the argument and the range."""
    limits = load_schema(DRIVE_SCHEMA)["$defs"]["parameter"]
    f_value = bounded_number("f", f, HERTZ, lower=MIN_DISK_FREQUENCY,
                             upper=limits["f"]["maximum"])
    a_value = bounded_number("a", a, METRE_PER_SECOND_SQUARED, lower=limits["a"]["minimum"],
                             upper=limits["a"]["maximum"])
    return f_value, a_value


def steady_plate_states(disk: Disk, f: float, a: float, phase: float = 0.0
                        ) -> NDArray[np.float64]:
    """Plate states ``(delta_1, delta_1', ...)`` on their steady response to
    ``a cos(2 pi f t + phase)`` at ``t = 0`` [m, m s-1]: a run started there has no
    mode transient."""
    check_disk(disk)
    f, a = check_drive(f, a)
    phase = bounded_number("phase", phase)
    return steady_plate_response(disk, f, a, phase)


def rest_state(disk: Disk, pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
               drive: tuple[float, float] | None = None) -> NDArray[np.float64]:
    """A state vector (see :func:`study.solvers.planar.state_names`; heading [degree],
    spin [degree s-1]) with the disk at rest at ``pose`` ``(x [m], y [m], heading
    [degree])``: the plates at rest, or, with ``drive = (f [Hz], a [m s-2])``, on their
    steady response to it at drive phase 0."""
    check_disk(disk)
    state = np.zeros(len(POSE_STATE) + 2 * len(disk.plates))
    where = as_real_array("pose", pose)
    if where.shape != (3,):
        raise ValueError(f"pose must be (x [m], y [m], heading [degree]), got {pose!r}")
    state[:3] = where
    if drive is not None and (isinstance(drive, str) or not isinstance(drive, Iterable)
                              or len(tuple(drive)) != 2):
        raise InputTypeError(f"drive must be (f [Hz], a [m s-2]), got {drive!r}")
    if drive is not None:
        state[len(POSE_STATE):] = steady_plate_states(disk, *drive)
    return state


def periodic_motion(
    disk: Disk,
    f: float,
    a: float,
    *,
    settings: IntegratorSettings | None = None,
    max_periods: int = 400,
    max_orbit_period: int = 8,
    repeat_tolerance: float | None = None,
    slaving: float = SLAVING,
) -> PeriodicMotion:
    """Steady forward, lateral and turning speed under the drive ``a cos(2 pi f t)``.

    The plates start on their steady response (no mode transient to wait for) and the
    disk at rest; whole periods are integrated until the body-frame displacement per
    period and the body-frame twist at the period's end repeat within
    ``repeat_tolerance`` (in units of ``g / w^2`` and ``g / w``), possibly only after
    several periods (an orbit of period up to ``max_orbit_period``).

    Parameters
    ----------
    disk : Disk
    f : float
        Drive frequency [Hz].
    a : float
        Drive acceleration amplitude [m s-2].
    settings : IntegratorSettings, optional
        Integrator accuracy (default tolerance 1e-10).
    max_periods : int
        Budget; beyond it the status is ``NOT_CONVERGED``.
    max_orbit_period : int
        Longest orbit looked for [drive periods]; speeds are then means over the orbit.
    repeat_tolerance : float, optional
        Periodicity test [1]; default ``max(100 * tolerance, 1e-12)`` (integration
        noise must not hide the repetition).
    slaving : float
        See :func:`study.solvers.planar.simulate_planar`.

    Returns
    -------
    PeriodicMotion
    """
    check_disk(disk)
    settings = check_integrator_settings(settings)
    f, a = check_drive(f, a)
    max_periods = bounded_integer("max_periods", max_periods, 1, max_steady_periods())
    return integrated_periodic_motion(disk, f, a, settings=settings, max_periods=max_periods,
                                      max_orbit_period=max_orbit_period,
                                      repeat_tolerance=repeat_tolerance, slaving=slaving)


def contact_margins(disk: Disk, f: float, a: float, samples: int = 512
                    ) -> tuple[float, float]:
    """How close the steady drive comes to lifting the disk, whole or at its rim.

    The plates push on the disk vertically at their attachment points. With full
    contact and a pressure linear across the disk, the pressure stays positive at
    the rim while the tilting moment ``|sum_i M_i cos(alpha_i) delta_i'' r_i|`` stays
    below ``n R / 4`` (the kern of a disk). The model assumes full contact with
    uniform pressure (its limit surface); where the rim margin is negative, part of
    the disk would leave the table and the model is outside its validity there.
    Tilting moments of the horizontal forces (which act above the table, at heights
    the model does not know) are not counted.

    Parameters
    ----------
    disk : Disk
    f : float
        Drive frequency [Hz].
    a : float
        Drive acceleration amplitude [m s-2].
    samples : int
        Phases over the period at which the margins are evaluated.

    Returns
    -------
    (rim, normal) : tuple of float
        ``min_t (n R / 4 - |moment|) / (g R / 4)`` and ``min_t n / g`` over a period
        of the steady plate response [1]; negative means the rim (or the whole disk)
        leaves the table.
    """
    check_disk(disk)
    f, a = check_drive(f, a)
    samples = bounded_integer("samples", samples, 1, MAX_MARGIN_SAMPLES)
    omega = 2.0 * math.pi * float(f)
    phase = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
    normal = disk.g - float(a) * np.cos(phase)
    moment = np.zeros((2, samples))
    for plate in disk.plates:
        amplitude = mode_amplitude(plate, f, a)
        acceleration = (-(omega**2) * amplitude * np.exp(1j * phase)).real
        vertical = plate.M * math.cos(math.radians(plate.alpha)) * acceleration
        normal = normal + vertical
        moment += np.outer(plate.attachment, vertical)
    rim = normal * disk.radius / 4.0 - np.hypot(moment[0], moment[1])
    return float(np.min(rim) / (disk.g * disk.radius / 4.0)), float(np.min(normal) / disk.g)
