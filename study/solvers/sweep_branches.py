"""The branches slow sweeps ride: each motion a sweep settles on, continued over the
swept range through its folds onto its unstable part.

A slow sweep (:func:`study.solvers.protocol.slow_sweep`) rides one motion from point to
point until it jumps (``jumped``) onto another. Each such piece of a run is one branch
(:func:`study.solvers.branch.trace`, pseudo-arclength continuation on the exact period
map): from the orbit of the piece's last point, continued back to the piece's first
drive (the part the sweep rode) and on in the sweep's direction to the end of the
swept axis (where the sweep jumped: the fold it left at, and past it the unstable part
back). The two are joined into one branch in the sweep's direction, every bifurcation
on it located (:mod:`study.kernels.two_way.bifurcations`). The trace on in the sweep's
direction starts from the orbit :func:`study.solvers.jumps.jump_branch` starts from, so
the fold where a sweep leaves the branch is the one the ``jumps`` observable locates
(each located to 1e-10 of its segment's drive).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from study.model import codes
from study.model.status import Status
from study.model.structure import Structure
from study.solvers.branch import DEFAULT_MAX_STEPS, Trace, trace
from study.solvers.protocol import SweptState, sweep_order
from study.solvers.settings import SolverSettings

__all__ = ["BRANCH_BIFURCATION_SLOTS", "BRANCH_STEP_SLOTS", "NO_STEP", "SweptBranches",
           "swept_branches", "swept_pieces"]

#: The statuses whose motion has an orbit (or the static point) to follow.
_ORBITS = (Status.STATIC, Status.STICK_SLIP, Status.CONTINUOUS_SLIDING, Status.BOUNCING)
#: Steps of a branch at most: each of its two parts traced with the default budget, the
#: orbit they share once.
BRANCH_STEP_SLOTS = 2 * DEFAULT_MAX_STEPS - 1
#: Bifurcations kept per branch (the first along it; ``count`` says how many were
#: located).
BRANCH_BIFURCATION_SLOTS = 64
#: ``stable`` of a step slot a branch does not fill.
NO_STEP = -1


@dataclass(frozen=True)
class SweptBranches:
    """The branches of slow sweeps, one per piece of a run between two jumps.

    Each per-step array is ``(branches, BRANCH_STEP_SLOTS)``, each per-bifurcation one
    ``(branches, BRANCH_BIFURCATION_SLOTS)``; slots past a branch's ``steps`` and
    ``count`` hold NaN (floats), ``NO_STEP`` (``stable``), 0 (``kind``) and -1
    (``step``).

    Attributes
    ----------
    sweep : numpy.ndarray of int8
        The sweep each branch is of: its index in the sweeps given (0 up, 1 down both
        ways).
    start_f, start_a : numpy.ndarray
        The drive of the piece's first point [Hz, m s-2]: where the sweep settled on
        the motion.
    end : numpy.ndarray of int8
        How the branch ends in the sweep's direction (``study.model.codes.BRANCH_*``):
        ``reached`` where the sweep rode it to the end of its axis, else the end of its
        trace on (a fold turns it back, ``turned_back`` past the last point ridden);
        ``not_followed`` where the piece's motion has no orbit to follow (an irregular
        one) or Newton's method does not close it.
    steps, periods, count : numpy.ndarray of int32
        Steps of each branch, its orbit's period [drive periods], its located
        bifurcations.
    f, a, velocity, largest_multiplier, largest_hop : numpy.ndarray
        Each step's drive [Hz, m s-2], mean velocity [m s-1], largest Floquet
        multiplier modulus [1] and largest hop [m], in the sweep's direction.
    stable : numpy.ndarray of int8
        1 where the step's orbit is stable, 0 where not.
    kind : numpy.ndarray of int8
        Each located bifurcation's kind (``study.model.codes.BIFURCATION_*``).
    bifurcation_f, bifurcation_a, bifurcation_velocity : numpy.ndarray
        Its drive [Hz, m s-2] and its orbit's mean velocity [m s-1].
    multiplier_modulus, multiplier_angle : numpy.ndarray
        The crossing multiplier there [1, rad].
    step : numpy.ndarray of int32
        The step before it along the branch (-1: before the first step, where the part
        traced back ended).
    location : numpy.ndarray of int8
        How it was placed (:data:`study.model.bifurcations.LOCATION_FLAGS`; 0 in a slot
        past the branch's bifurcations).
    """

    sweep: NDArray[np.int8]
    start_f: NDArray[np.float64]
    start_a: NDArray[np.float64]
    end: NDArray[np.int8]
    steps: NDArray[np.int32]
    periods: NDArray[np.int32]
    count: NDArray[np.int32]
    f: NDArray[np.float64]
    a: NDArray[np.float64]
    velocity: NDArray[np.float64]
    stable: NDArray[np.int8]
    largest_multiplier: NDArray[np.float64]
    largest_hop: NDArray[np.float64]
    kind: NDArray[np.int8]
    bifurcation_f: NDArray[np.float64]
    bifurcation_a: NDArray[np.float64]
    bifurcation_velocity: NDArray[np.float64]
    multiplier_modulus: NDArray[np.float64]
    multiplier_angle: NDArray[np.float64]
    step: NDArray[np.int32]
    location: NDArray[np.int8]


def swept_pieces(f: NDArray[np.float64], a: NDArray[np.float64], along: str,
                 direction: str, jumped: NDArray[np.bool_], status: NDArray[np.int8],
                 orbit_period: NDArray[np.int32]
                 ) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """The pieces of a sweep's runs, each on one motion: ``(first, last)`` grid indices
    ``(i_f, i_a)`` of each, run after run in the sweep's order. A piece starts where the
    sweep jumped (``jumped``, over ``f x a``) and where the motion's status or its
    orbit's period changes (a period doubling the sweep follows, which is no jump: the
    doubled orbit is another branch)."""
    order, bounds = sweep_order(np.asarray(f), np.asarray(a), along, direction)
    jumped = np.asarray(jumped, dtype=bool).reshape(-1)
    kind = np.stack([np.asarray(status).reshape(-1).astype(np.int64),
                     np.asarray(orbit_period).reshape(-1).astype(np.int64)], axis=1)
    pieces = []
    for r in range(bounds.size - 1):
        run = order[bounds[r]:bounds[r + 1]]
        starts = [0] + [k for k in range(1, run.size) if jumped[run[k]]
                        or (kind[run[k]] != kind[run[k - 1]]).any()]
        for k0, k1 in zip(starts, [*starts[1:], run.size], strict=True):
            first, last = divmod(int(run[k0]), a.size), divmod(int(run[k1 - 1]), a.size)
            pieces.append((first, last))
    return pieces


def swept_branches(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
                   sweeps: list[SweptState], *, flight: bool = False,
                   settings: SolverSettings | None = None,
                   progress: Callable[[int], None] | None = None) -> SweptBranches:
    """The branches the slow sweeps ``sweeps`` (each over the grid ``f x a``, along one
    axis) ride, one per piece of each run between its jumps, in the order of
    :func:`swept_pieces` sweep after sweep; ``progress(1)`` after each."""
    rows = []
    for number, swept in enumerate(sweeps):
        along = swept.along
        axis = f if along == "f" else a
        end_index = int(np.argmax(axis)) if swept.direction == "up" else int(np.argmin(axis))
        for first, last in swept_pieces(f, a, along, swept.direction, swept.jumped,
                                        swept.state.status, swept.state.orbit_period):
            end = (end_index, last[1]) if along == "f" else (last[0], end_index)
            rows.append((number, first, _piece(structure, f, a, swept, first, last, end,
                                               flight, settings)))
            if progress is not None:
                progress(1)
    return _gathered(f, a, rows)


@dataclass(frozen=True)
class _Joined:
    """One branch: its two traces joined in the sweep's direction."""

    end: int
    periods: int
    steps: NDArray[np.float64]   # (n, 6): f, a, velocity, radius, hop, stable
    bifurcations: NDArray[np.float64]  # (m, 8): kind, f, a, velocity, modulus, angle, step,
    # location


def _piece(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
           swept: SweptState, first: tuple[int, int], last: tuple[int, int],
           end: tuple[int, int], flight: bool, settings: SolverSettings | None
           ) -> _Joined | None:
    """The branch of a piece: the orbit of its ``last`` point traced back to its
    ``first`` drive and on to ``end`` (the end of the swept axis), joined; None where
    there is no orbit to follow."""
    state = swept.state
    status = Status(int(state.status[last]))
    if status not in _ORBITS:
        return None
    if status == Status.STATIC:
        start: object = "release"  # the static point continues as the static motion
        periods = None
    else:
        start = np.asarray(state.phase_state[last], dtype=np.float64)
        periods = max(int(state.orbit_period[last]), 1)
    along = swept.along
    here = (float(f[last[0]]), float(a[last[1]]))
    traces = []
    for target in (first, end):
        to = float(f[target[0]] if along == "f" else a[target[1]])
        if to == (here[0] if along == "f" else here[1]):
            traces.append(None)
            continue
        try:
            traced, _ = trace(structure, *here, along=along, to=to, start=start,
                              flight=flight, settings=settings, periods=periods)
        except ValueError:
            return None  # Newton's method from the carried orbit does not close it
        traces.append(traced)
    back, on = traces
    if back is None and on is None:
        return None
    return _joined(back, on)


def _columns(traced: Trace) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A trace's steps (f, a, velocity, radius, hop, stable) and bifurcations (kind, f,
    a, velocity, modulus, angle, step, location)."""
    f, a = traced.drive(traced.column("t"))
    radius = traced.column("radius")
    steps = np.column_stack([f, a, traced.column("velocity"), radius, traced.column("hop"),
                             (radius < 1.0).astype(np.float64)])
    b_f, b_a = traced.drive(traced.bifurcation_column("t"))
    mu = (traced.bifurcation_column("multiplier_real")
          + 1j * traced.bifurcation_column("multiplier_imag"))
    bifurcations = np.column_stack([
        traced.bifurcation_column("kind"), b_f, b_a, traced.bifurcation_column("velocity"),
        np.abs(mu), np.angle(mu), traced.bifurcation_column("step"),
        traced.bifurcation_locations()])
    return steps, bifurcations


def _joined(back: Trace | None, on: Trace | None) -> _Joined:
    """The part traced back, reversed, then the part traced on (their shared first
    orbit once); each bifurcation's step renumbered along the joined branch."""
    parts_steps, parts_bifurcations = [], []
    offset = 0
    if back is not None:
        steps, bifurcations = _columns(back)
        n = steps.shape[0]
        parts_steps.append(steps[::-1])
        reversed_ = bifurcations[::-1].copy()
        # Between back steps k and k + 1: between joined steps n - 2 - k and n - 1 - k.
        reversed_[:, 6] = n - 2 - reversed_[:, 6]
        parts_bifurcations.append(reversed_)
        offset = n - 1
    if on is not None:
        steps, bifurcations = _columns(on)
        parts_steps.append(steps[1:] if back is not None else steps)
        shifted = bifurcations.copy()
        shifted[:, 6] += offset
        parts_bifurcations.append(shifted)
    periods = (on if on is not None else back).periods  # type: ignore[union-attr]
    end = on.end if on is not None else codes.BRANCH_REACHED
    return _Joined(int(end), int(periods), np.concatenate(parts_steps),
                   np.concatenate(parts_bifurcations))


def _gathered(f: NDArray[np.float64], a: NDArray[np.float64],
              rows: list[tuple[int, tuple[int, int], _Joined | None]]) -> SweptBranches:
    """The branches in slots."""
    n = len(rows)
    steps, slots = BRANCH_STEP_SLOTS, BRANCH_BIFURCATION_SLOTS

    def full(shape: tuple[int, ...], value: float, dtype: type) -> NDArray:
        return np.full(shape, value, dtype=dtype)

    out = {
        "sweep": full((n,), 0, np.int8), "start_f": full((n,), np.nan, np.float64),
        "start_a": full((n,), np.nan, np.float64),
        "end": full((n,), codes.BRANCH_LOST, np.int8), "steps": full((n,), 0, np.int32),
        "periods": full((n,), 0, np.int32), "count": full((n,), 0, np.int32),
        **{name: full((n, steps), np.nan, np.float64)
           for name in ("f", "a", "velocity", "largest_multiplier", "largest_hop")},
        "stable": full((n, steps), NO_STEP, np.int8), "kind": full((n, slots), 0, np.int8),
        **{name: full((n, slots), np.nan, np.float64)
           for name in ("bifurcation_f", "bifurcation_a", "bifurcation_velocity",
                        "multiplier_modulus", "multiplier_angle")},
        "step": full((n, slots), -1, np.int32), "location": full((n, slots), 0, np.int8),
    }
    for b, (number, first, joined) in enumerate(rows):
        out["sweep"][b] = number
        out["start_f"][b], out["start_a"][b] = f[first[0]], a[first[1]]
        if joined is None:
            continue
        k = joined.steps.shape[0]
        out["end"][b], out["steps"][b], out["periods"][b] = joined.end, k, joined.periods
        for column, name in enumerate(("f", "a", "velocity", "largest_multiplier",
                                       "largest_hop")):
            out[name][b, :k] = joined.steps[:, column]
        out["stable"][b, :k] = joined.steps[:, 5].astype(np.int8)
        m = joined.bifurcations.shape[0]
        out["count"][b] = m
        kept = joined.bifurcations[:slots]
        m = kept.shape[0]
        out["kind"][b, :m] = kept[:, 0].astype(np.int8)
        for column, name in enumerate(("bifurcation_f", "bifurcation_a",
                                       "bifurcation_velocity", "multiplier_modulus",
                                       "multiplier_angle"), start=1):
            out[name][b, :m] = kept[:, column]
        out["step"][b, :m] = kept[:, 6].astype(np.int32)
        out["location"][b, :m] = kept[:, 7].astype(np.int8)
    return SweptBranches(**out)
