"""Where a slow sweep jumps, located exactly: the bifurcation at which the branch it
rode ends between two of its points.

A slow sweep (:func:`study.solvers.protocol.slow_sweep`) marks a point ``jumped`` where
the motion it settles on is not the continuation of the previous point's. The grid says
only that the jump lies between the two drives. :func:`sweep_jumps` follows the
previous point's orbit along its branch towards the jumped point's drive
(:func:`study.solvers.branch.trace`, pseudo-arclength continuation on the exact period
map) and reports the first bifurcation after which the orbit the sweep rode is no longer
a stable orbit going on towards the new drive: a fold (the branch turns back), a
lift-off or a non-smooth end (it ends), or a period doubling, a torus, a branch point or
a grazing after which it is unstable. Each is located on the branch to 1e-10 of the
drive (:mod:`study.kernels.two_way.bifurcations`), not read off the grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from study.kernels.two_way import bifurcations as trace_kernel
from study.model import codes
from study.model.bifurcations import JUMP_NONE, JUMP_UNLOCATED
from study.model.status import Status
from study.model.structure import Structure
from study.solvers.branch import Trace, trace
from study.solvers.protocol import SweptState, previous_points
from study.solvers.settings import SolverSettings

__all__ = ["ORBIT_STATUSES", "SweepJumps", "jump_branch", "stability_loss", "sweep_jumps"]

#: The statuses whose motion has an orbit (or the static point) to follow.
ORBIT_STATUSES = (Status.STATIC, Status.STICK_SLIP, Status.CONTINUOUS_SLIDING,
                  Status.BOUNCING)
#: Kinds after which the orbit the sweep rode cannot go on as it was: the branch turns
#: back or ends there.
_ENDING = (codes.BIFURCATION_FOLD, codes.BIFURCATION_LIFT_OFF)


@dataclass(frozen=True)
class SweepJumps:
    """The located jumps of a slow sweep over the grid ``(f, a)``.

    Attributes
    ----------
    kind : numpy.ndarray of int8
        At a jumped point, the code of the bifurcation where the branch of the previous
        point's orbit ends (:data:`study.model.bifurcations.JUMP_FLAGS`); ``JUMP_NONE``
        (0) where the sweep did not jump, ``JUMP_UNLOCATED`` (-1) where it jumped but
        the branch followed shows no such bifurcation between the two drives (it goes
        on stable: the carried state left the orbit's basin; or the previous motion has
        no orbit to follow, an irregular one).
    f, a : numpy.ndarray
        The drive at that bifurcation [Hz, m s-2]; NaN where ``kind`` is 0 or -1.
    velocity : numpy.ndarray
        The mean velocity of the orbit there [m s-1]; NaN likewise.
    multiplier_modulus, multiplier_angle : numpy.ndarray
        The Floquet multiplier that crosses there, its modulus [1] and argument [rad]
        (+1 at a fold, -1 at a period doubling; the largest one where located by
        bisection); NaN likewise.
    """

    kind: NDArray[np.int8]
    f: NDArray[np.float64]
    a: NDArray[np.float64]
    velocity: NDArray[np.float64]
    multiplier_modulus: NDArray[np.float64]
    multiplier_angle: NDArray[np.float64]


def sweep_jumps(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
                swept: SweptState, *, flight: bool = False,
                settings: SolverSettings | None = None) -> SweepJumps:
    """Locate each jump of the slow sweep ``swept`` over the grid ``f x a``.

    Parameters
    ----------
    structure : Structure
        The structure the sweep ran on.
    f : numpy.ndarray
        The grid's drive frequencies [Hz], 1-D, as the sweep had them.
    a : numpy.ndarray
        The grid's drive accelerations [m s-2], 1-D.
    swept : SweptState
        The sweep (:func:`study.solvers.protocol.slow_sweep` over ``f x a``).
    flight : bool, default False
        Whether the sweep let the base fly (as it ran).
    settings : SolverSettings, optional
        The sweep's solver settings (its budgets).

    Returns
    -------
    SweepJumps
        Each field of shape ``(len(f), len(a))``.
    """
    f = np.asarray(f, dtype=np.float64)
    a = np.asarray(a, dtype=np.float64)
    shape = (f.size, a.size)
    kind = np.full(shape, JUMP_NONE, dtype=np.int8)
    found = {name: np.full(shape, np.nan) for name in ("f", "a", "velocity", "modulus",
                                                       "angle")}
    axis = 0 if swept.along == "f" else 1
    # The point visited just before each (an axis may be given in any order).
    previous = previous_points(f if axis == 0 else a, swept.direction)
    for i, j in np.argwhere(swept.jumped):
        before = (int(previous[i]), j) if axis == 0 else (i, int(previous[j]))
        if min(before) < 0:  # a run's first point follows nothing
            continue
        located = _locate(structure, f, a, swept, before, (i, j), flight, settings)
        if located is None:
            kind[i, j] = JUMP_UNLOCATED
            continue
        kind[i, j] = int(located[0])
        for name, value in zip(("f", "a", "velocity", "modulus", "angle"), located[1:],
                               strict=True):
            found[name][i, j] = value
    return SweepJumps(kind=kind, f=found["f"], a=found["a"], velocity=found["velocity"],
                      multiplier_modulus=found["modulus"], multiplier_angle=found["angle"])


def _locate(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
            swept: SweptState, before: tuple[int, int], here: tuple[int, int],
            flight: bool, settings: SolverSettings | None
            ) -> tuple[int, float, float, float, float, float] | None:
    """``(kind, f, a, velocity, modulus, angle)`` of the bifurcation where the branch of
    the orbit at ``before`` ends on its way to ``here`` (grid indices), or None."""
    found = jump_branch(structure, f, a, swept, before, here, flight=flight,
                        settings=settings)
    if found is None:
        return None
    traced, cause = found
    f0, a0 = float(f[before[0]]), float(a[before[1]])
    f1, a1 = float(f[here[0]]), float(a[here[1]])
    row = traced.bifurcations[cause]
    t = float(row[trace_kernel.B_T])
    multiplier = complex(row[trace_kernel.B_REAL],
                         row[trace_kernel.B_IMAG])
    return (int(row[trace_kernel.B_KIND]), f0 + t * (f1 - f0), a0 + t * (a1 - a0),
            float(row[trace_kernel.B_VELOCITY]), abs(multiplier),
            float(np.angle(multiplier)))


def jump_branch(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
                swept: SweptState, before: tuple[int, int], here: tuple[int, int], *,
                flight: bool = False, settings: SolverSettings | None = None
                ) -> tuple[Trace, int] | None:
    """The branch of the sweep's orbit at ``before`` traced towards ``here`` (grid
    indices of ``f x a``) and the index of the bifurcation on it where the sweep's
    motion ends (the jump :func:`sweep_jumps` locates); None where there is none (an
    irregular motion before, an orbit Newton's method does not close, a branch that
    goes on stable)."""
    state = swept.state
    status = Status(int(state.status[before]))
    if status not in ORBIT_STATUSES:
        return None  # an irregular motion (or none) has no orbit to follow
    f0, a0 = float(f[before[0]]), float(a[before[1]])
    f1, a1 = float(f[here[0]]), float(a[here[1]])
    along = swept.along
    if status == Status.STATIC:
        start: object = "release"  # the static point continues as the static motion
        periods = None
    else:
        start = np.asarray(state.phase_state[before], dtype=np.float64)
        periods = max(int(state.orbit_period[before]), 1)
    try:
        traced, _ = trace(structure, f0, a0, along=along, to=f1 if along == "f" else a1,
                          start=start, flight=flight, settings=settings, periods=periods)
    except ValueError:
        return None  # Newton's method from the carried orbit does not close it
    cause = stability_loss(traced)
    if cause is None:
        return None
    return traced, cause


def stability_loss(traced: Trace) -> int | None:
    """The index of the first located bifurcation of ``traced`` (in the order of the
    branch) after which the orbit does not go on stable: one that turns the branch back
    or ends it, one after which its largest multiplier is outside the unit circle, or
    the last one where the branch ended there; None if there is none."""
    rows = traced.bifurcations
    radius = traced.column("radius")
    for index, row in enumerate(rows):
        kind = int(row[trace_kernel.B_KIND])
        if kind in _ENDING:
            return index
        after = int(row[trace_kernel.B_STEP]) + 1
        if after < radius.size and radius[after] > 1.0:
            return index
        if index == rows.shape[0] - 1 and traced.end == codes.BRANCH_ENDED:
            return index
    return None
