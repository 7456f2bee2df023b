"""Slow sweeps of the drive: an experiment's protocol, solved exactly.

An experimenter raises (or lowers) the drive frequency or acceleration in small steps,
each held until the motion has settled. :func:`slow_sweep` does that on a grid of
drive points: along the swept axis the points are visited in order, the drive switched
to the next value at phase 0 with the state carried over, and the motion followed from
that state until it settles again (docs/theory/starts.md). Where the motion followed
ends (a fold, a loss of stability, lift-off) it jumps to another attractor, and sweeps
up and down can disagree over a range of drives: hysteresis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from study.kernels.two_way import points as orbit_kernel
from study.kernels.two_way import protocol as protocol_kernel
from study.model import as_acceleration, as_frequency
from study.model.starts import Drop
from study.model.structure import Structure, check_structure
from study.solvers.exact import steady_state_from_rows
from study.solvers.settings import (
    SolverSettings,
    check_coupling,
    check_flight,
    check_settings,
    check_start,
    kernel_budget,
    kernel_start,
)
from study.solvers.steady import SteadyState
from study.solvers.structure_constants import past_lift_off, structure_vector

#: The drive axes a sweep can step along: frequency [Hz] or acceleration [m s-2].
SWEEP_AXES = ("f", "a")
#: The directions of a sweep: increasing or decreasing values of the swept axis.
SWEEP_DIRECTIONS = ("up", "down")
#: Where the branch followed goes on to a point but lost its stability on the way, the
#: motion the sweep settles on continues it (the doubled orbit of a period doubling, a
#: quasi-periodic motion about a torus) when its mean velocity is that of the orbit
#: followed to this fraction of a / (2 pi f); the same fraction decides after an
#: irregular motion, which has no orbit to follow.
JUMP_FRACTION = protocol_kernel.JUMP_FRACTION


@dataclass(frozen=True)
class SweptState:
    """The motions a slow sweep settles on, over the grid ``(f, a)``.

    Attributes
    ----------
    state : SteadyState
        The motion at each drive point as the sweep reaches it, each field of shape
        ``(len(f), len(a))``.
    jumped : numpy.ndarray of bool
        Where the motion the sweep settles on, started from the state carried from the
        previous point of its run, is not the continuation of the motion there: that
        motion's orbit, followed along its branch to this drive by pseudo-arclength
        continuation on the exact period map, folded back or ended on the way (a fold, a
        non-smooth end), or goes on but the carried state settled on another motion,
        whatever the velocity does. The doubled orbit of a period doubling on the way
        (and a period halving) is no jump; see :func:`study.kernels.two_way.protocol.is_jump`.
    along : str
        The swept axis, ``"f"`` or ``"a"``.
    direction : str
        ``"up"`` (increasing values) or ``"down"``.
    """

    state: SteadyState
    jumped: NDArray[np.bool_]
    along: str
    direction: str


def check_sweep(along: object, direction: object) -> tuple[str, str]:
    """``(along, direction)`` checked: one of :data:`SWEEP_AXES` and one of
    :data:`SWEEP_DIRECTIONS`; a ValueError names the key, the value and the allowed
    values otherwise."""
    if along not in SWEEP_AXES:
        raise ValueError(f"sweep protocol 'along' must be one of {list(SWEEP_AXES)}, got "
                         f"{along!r}")
    if direction not in SWEEP_DIRECTIONS:
        raise ValueError(f"sweep protocol 'direction' must be one of "
                         f"{list(SWEEP_DIRECTIONS)}, got {direction!r}")
    return str(along), str(direction)


def sweep_order(f: NDArray[np.float64], a: NDArray[np.float64], along: str,
                direction: str) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The runs of a sweep over the grid ``f`` x ``a`` (flat index ``i_f * len(a) +
    i_a``): the points in visiting order and the runs' bounds in it (run ``r`` is
    ``order[bounds[r]:bounds[r + 1]]``), one run for each value of the other axis."""
    swept, other = (f, a) if along == "f" else (a, f)
    ranks = np.argsort(swept, kind="stable")
    if direction == "down":
        ranks = ranks[::-1]
    runs = []
    for j in range(other.size):
        if along == "f":
            runs.append(ranks * a.size + j)
        else:
            runs.append(j * a.size + ranks)
    order = np.concatenate(runs).astype(np.int64) if runs else np.empty(0, np.int64)
    bounds = np.arange(0, order.size + 1, max(swept.size, 1), dtype=np.int64)
    return order, bounds


def previous_points(values: NDArray[np.float64], direction: str) -> NDArray[np.int64]:
    """For each index of a swept axis ``values`` (in any order), the index of the value
    a sweep in ``direction`` visits just before it (-1 for the run's first), as
    :func:`sweep_order` orders them."""
    ranks = np.argsort(np.asarray(values), kind="stable")
    if direction == "down":
        ranks = ranks[::-1]
    previous = np.full(ranks.size, -1, dtype=np.int64)
    previous[ranks[1:]] = ranks[:-1]
    return previous


def reversal_jumps(values: NDArray[np.float64], velocity: NDArray[np.float64],
                   jumped: NDArray[np.bool_], direction: str) -> NDArray[np.int64]:
    """The jumps of one run of a slow sweep that reverse the motion, in the order the
    sweep meets them: the indices along the swept axis ``values`` (in any order) of the
    jumped points where a sweep ``"up"`` goes from a forward motion (velocity > 0) at
    the point it visited before to a backward one (< 0), or a sweep ``"down"`` from a
    backward motion to a forward one.

    This is the rule of a reversal fold: the first such jump of a sweep up leaves the
    forward hop at its fold, the first of a sweep down the backward hop at its
    (:mod:`study.solvers.fold_curves`, :mod:`study.analyses.hop_folds`), where the jump
    is located at a fold (:mod:`study.solvers.jumps`). ``velocity`` and ``jumped`` are
    the run's, over ``values``; a NaN velocity reverses nothing."""
    previous = previous_points(values, direction)
    ranks = np.argsort(np.asarray(values), kind="stable")
    if direction == "down":
        ranks = ranks[::-1]
    found = []
    for i in ranks:  # in the order the sweep visits them
        before = int(previous[i])
        if before < 0 or not jumped[i]:
            continue
        if direction == "up":
            reverses = velocity[before] > 0.0 > velocity[i]
        else:
            reverses = velocity[before] < 0.0 < velocity[i]
        if reverses:
            found.append(int(i))
    return np.array(found, dtype=np.int64)


def slow_sweep(
    structure: Structure,
    f: ArrayLike,
    a: ArrayLike,
    *,
    along: str,
    direction: str = "up",
    flight: bool = False,
    settings: SolverSettings | None = None,
    start: str | Drop | None = None,
    parallel: bool | None = None,
) -> SweptState:
    """The motions of slow sweeps of the drive over the grid ``f`` x ``a``.

    Along ``along`` the drive values are visited in the ``direction``'s order, one run
    for each value of the other axis. A run's first point starts by ``start``; at each
    next value the drive switches at phase 0, the state (relative to the table)
    carried over, and the motion is followed until it settles: Newton's method from the
    carried state, verified reached (the iterates followed otherwise, to another cycle
    or an irregular motion). A point with no state to carry (lift-off without flight,
    the friction paradox, a budget spent) makes the next start by ``start`` again.
    Two-way coupling (the one-way model has no state of the mode to carry).

    Parameters
    ----------
    structure : Structure
        The structure.
    f : array_like
        Drive frequencies [Hz], 1-D, > 0.
    a : array_like
        Drive accelerations [m s-2], 1-D, >= 0.
    along : {"f", "a"}
        The swept axis.
    direction : {"up", "down"}, default "up"
        Increasing or decreasing values of the swept axis.
    flight : bool, default False
        Let the base fly and land (as :func:`study.solvers.exact.steady_state`).
    settings : SolverSettings, optional
        Budgets and the start; ``continuation`` must be False (a sweep carries the
        motion itself).
    start : {"release", "switch-on"} or Drop, optional
        The first point's start of each run (overrides ``settings.start``).
    parallel : bool, optional
        Runs in parallel over threads (each run is serial); by default when there are
        at least 8 runs.

    Returns
    -------
    SweptState
        The motions, of shape ``(len(f), len(a))``, and where they jumped.

    Raises
    ------
    ValueError
        An unknown ``along`` or ``direction`` (naming the allowed values), ``f`` or
        ``a`` not 1-D or out of range, one-way coupling, continuation, or a start the
        model cannot take.
    """
    structure = check_structure(structure)
    along, direction = check_sweep(along, direction)
    coupling = check_coupling("two-way")
    flight = check_flight(flight, coupling, structure)
    settings = check_start(check_settings(settings, coupling), start, coupling, flight)
    if settings.continuation:
        raise ValueError("a slow sweep carries the motion from point to point itself: "
                         "solver setting 'continuation' must be False with it")
    f_axis = np.asarray(as_frequency(f), dtype=np.float64)
    a_axis = np.asarray(as_acceleration(a), dtype=np.float64)
    for name, axis in (("f", f_axis), ("a", a_axis)):
        if axis.ndim != 1:
            raise ValueError(f"slow_sweep: {name!r} must be 1-D (the grid's axis), got "
                             f"shape {axis.shape}")
    grid_f, grid_a = (x.ravel() for x in np.meshgrid(f_axis, a_axis, indexing="ij"))
    grid_f = np.ascontiguousarray(grid_f)
    grid_a = np.ascontiguousarray(grid_a)
    order, bounds = sweep_order(f_axis, a_axis, along, direction)
    out = np.empty((grid_f.size, orbit_kernel.N_OUT))
    jumped = np.zeros(grid_f.size, dtype=np.int8)
    if parallel is None:
        parallel = bounds.size - 1 >= 8
    kernel = (protocol_kernel.sweep_points if parallel
              else protocol_kernel.sweep_points_serial)
    kernel(structure_vector(structure, coupling, flight), 2.0 * np.pi * grid_f, grid_a,
           past_lift_off(structure, grid_f, grid_a), kernel_budget(settings),
           kernel_start(settings.start), order, bounds, out, jumped)
    shape = (f_axis.size, a_axis.size)
    return SweptState(state=steady_state_from_rows(out, shape, flight),
                      jumped=jumped.reshape(shape).astype(bool), along=along,
                      direction=direction)
