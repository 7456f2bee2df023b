"""The folds that bound the coexistence of the forward and the backward hop, as curves
f_fold(a) over a study's drive plane.

A slow sweep up along ``f`` rides the forward hop until its branch folds back and jumps
to the backward hop; a sweep down rides the backward hop until its fold. Between the two
folds both motions are stable: the multistable region. :func:`fold_curves` finds each
fold where the sweeps of the study's ``f`` axis jump (:func:`study.solvers.protocol.
slow_sweep`, :func:`study.solvers.jumps.jump_branch`): the forward hop's, a jump of a
sweep up from a forward motion (velocity > 0) to a backward one (< 0), the backward
hop's, of a sweep down from a backward motion to a forward one. Where no sweep leaves
a hop at a fold, its branch is followed on past the sweeps (carried along ``a`` to where
the sweeps start on another motion, or past the ``f`` axis's end) to its fold. One such
fold of each hop seeds its curve, which is continued over the study's whole ``a`` axis
both ways (:func:`study.solvers.curves.follow_curve`) and located at each of its values
exactly (to 1e-10 of the drive), its ends bracketed.

The forward hop's other edge is no fold: followed down in ``f`` from where the sweep
up left it, its branch period-doubles (the orbit of period 1 turns into one of period
2, at M = 0.99 near 12.03 Hz at 10 m s-2). That period doubling is located on the same
branch and continued over ``a`` the same way (``doubling_*`` of :class:`FoldCurves`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from study.model import codes
from study.model.bifurcations import LOCATED
from study.model.status import Status
from study.model.structure import Structure
from study.solvers.branch import Trace, trace, trace_from_section
from study.solvers.curves import FollowedCurve, follow_curve, seed_of_trace
from study.solvers.jumps import ORBIT_STATUSES, jump_branch, stability_loss
from study.solvers.protocol import previous_points, reversal_jumps, slow_sweep
from study.solvers.settings import SolverSettings

__all__ = ["DOUBLING_STATUS_FLAGS", "FOLD_END_FLAGS", "FOLD_END_VALUES", "FOLD_STATUS_FLAGS",
           "HOPS", "SIDES", "FoldCurves", "fold_curve_work", "fold_curves"]

#: The hops whose folds are followed, and the way a slow sweep along f rides each to
#: its fold: the forward hop up, the backward hop down.
HOPS = ("forward", "backward")
_DIRECTIONS = {"forward": "up", "backward": "down"}
#: The ends of a curve: towards the study's smaller accelerations, and larger ones.
SIDES = ("below", "above")
#: Why the fold of a hop has (or has not) a frequency at an acceleration.
FOLD_STATUS_FLAGS = ("found", "no_fold", "beyond_end", "not_found")
FOUND, NO_FOLD, BEYOND_END, NOT_FOUND = range(len(FOLD_STATUS_FLAGS))
#: Why the forward hop's period doubling has (or has not) a frequency at an acceleration.
DOUBLING_STATUS_FLAGS = ("found", "no_doubling", "beyond_end", "not_found")
(DOUBLING_FOUND, DOUBLING_NONE, DOUBLING_BEYOND_END,
 DOUBLING_NOT_FOUND) = range(len(DOUBLING_STATUS_FLAGS))
#: How a curve ends on each side: the curve ends of
#: :data:`study.model.bifurcations.CURVE_ENDS` (their codes), or ``not_found`` (0): no
#: sweep located the hop's fold, nothing was followed.
FOLD_END_FLAGS = ("not_found", "reached", "vanished", "ended", "lost")
FOLD_END_VALUES = (0, codes.CURVE_REACHED, codes.CURVE_VANISHED, codes.CURVE_ENDED,
                   codes.CURVE_LOST)


@dataclass(frozen=True)
class FoldCurves:
    """The fold curves of a structure over ``f x a``.

    Attributes
    ----------
    f : numpy.ndarray
        ``(2, n_a)``: the fold's drive frequency of each hop (:data:`HOPS`) at each
        acceleration [Hz]; NaN where ``status`` is not ``found``.
    velocity : numpy.ndarray
        ``(2, n_a)``: the mean velocity of the hop's orbit at its fold [m s-1]; NaN
        likewise.
    status : numpy.ndarray of int8
        ``(2, n_a)``: :data:`FOLD_STATUS_FLAGS` (found; no_fold: past the curve's cusp,
        where the fold vanished; beyond_end: past where it ended at another bifurcation
        or was lost; not_found: neither a sweep nor the hop's branch followed past the
        sweeps located the hop's fold).
    end : numpy.ndarray of int8
        ``(2, 2)``: how each hop's curve ends on each side (:data:`SIDES`),
        :data:`FOLD_END_VALUES`.
    end_last, end_past : numpy.ndarray
        ``(2, 2)``: the accelerations between which it stops being met [m s-2]: the
        last one where it is, and the first where it is not (the bracket of its end);
        NaN where it reached the axis's end or was not followed.
    seed : numpy.ndarray of int
        ``(2,)``: the index along ``a`` of the fold that seeded each curve, a sweep's
        jump or off the sweeps (-1: none).
    doubling_f : numpy.ndarray
        ``(n_a,)``: the drive frequency of the forward hop's period doubling at each
        acceleration [Hz], below its fold in ``f``: where the forward hop, followed down
        in frequency, loses its stability to an orbit of twice its period (the other
        edge of where it exists stably); NaN where ``doubling_status`` is not
        ``found``.
    doubling_velocity : numpy.ndarray
        ``(n_a,)``: the mean velocity of the forward hop's orbit there [m s-1]; NaN
        likewise.
    doubling_status : numpy.ndarray of int8
        ``(n_a,)``: :data:`DOUBLING_STATUS_FLAGS` (found; no_doubling: past where the
        curve vanished, the hop's branch meeting no period doubling near the last one
        (at M = 0.99 where it meets a grazing); beyond_end: past where it ended at
        another bifurcation or was lost; not_found: the forward hop's fold was not
        found, or its branch followed down from there meets no period doubling).
    doubling_seed : int
        The index along ``a`` where the doubling was first located (-1: none), the
        forward fold's seed.
    """

    f: NDArray[np.float64]
    velocity: NDArray[np.float64]
    status: NDArray[np.int8]
    end: NDArray[np.int8]
    end_last: NDArray[np.float64]
    end_past: NDArray[np.float64]
    seed: NDArray[np.int64]
    doubling_f: NDArray[np.float64]
    doubling_velocity: NDArray[np.float64]
    doubling_status: NDArray[np.int8]
    doubling_seed: int = -1


def fold_curve_work(a: NDArray[np.float64]) -> int:
    """The steps :func:`fold_curves` reports to its ``progress`` for an ``a`` axis:
    each sweep, and each acceleration of each curve; the forward hop's branch followed
    down to its period doubling, and each acceleration of its curve."""
    return (len(HOPS) + 1) * (1 + np.size(a))


def fold_curves(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64], *,
                flight: bool = False, settings: SolverSettings | None = None,
                progress: Callable[[int], None] | None = None) -> FoldCurves:
    """The forward and the backward hop's folds over the grid ``f x a``.

    Parameters
    ----------
    structure : Structure
    f : numpy.ndarray
        Drive frequencies [Hz], 1-D, at least 2: the slow sweeps' steps.
    a : numpy.ndarray
        Drive accelerations [m s-2], 1-D: where each curve is located.
    flight : bool, default False
        Whether the base may fly (the sweeps and the branches).
    settings : SolverSettings, optional
        The solver's budgets and the sweeps' start (continuation is not used: a sweep
        carries its state itself).
    progress : callable, optional
        ``progress(steps)`` after each sweep and each acceleration a curve is located
        at or given up (:func:`fold_curve_work` in all).

    Returns
    -------
    FoldCurves
    """
    f = np.asarray(f, dtype=np.float64)
    a = np.asarray(a, dtype=np.float64)
    settings = SolverSettings() if settings is None else settings
    if settings.continuation:
        settings = replace(settings, continuation=False)
    report = progress if progress is not None else (lambda steps: None)
    shape = (len(HOPS), a.size)
    found = FoldCurves(f=np.full(shape, np.nan), velocity=np.full(shape, np.nan),
                       status=np.full(shape, NOT_FOUND, dtype=np.int8),
                       end=np.zeros((len(HOPS), len(SIDES)), dtype=np.int8),
                       end_last=np.full((len(HOPS), len(SIDES)), np.nan),
                       end_past=np.full((len(HOPS), len(SIDES)), np.nan),
                       seed=np.full(len(HOPS), -1, dtype=np.int64),
                       doubling_f=np.full(a.size, np.nan),
                       doubling_velocity=np.full(a.size, np.nan),
                       doubling_status=np.full(a.size, DOUBLING_NOT_FOUND, dtype=np.int8))
    order = np.argsort(a, kind="stable")
    ridden = None  # the forward hop's branch to its fold
    for h, hop in enumerate(HOPS):
        direction = _DIRECTIONS[hop]
        swept = slow_sweep(structure, f, a, along="f", direction=direction, flight=flight,
                           settings=settings)
        report(1)
        seeded = _seed(structure, f, a, swept, flight, settings)
        if seeded is None:
            seeded = _seed_off_sweeps(structure, f, a, swept, hop, flight, settings)
        if seeded is None:
            report(a.size)
            continue
        j, traced, cause = seeded
        if hop == "forward":
            ridden = (j, traced)
        seed = seed_of_trace(traced, cause, "f")
        found.seed[h] = j
        found.status[h, j] = FOUND
        found.f[h, j], found.velocity[h, j] = seed.row[0], seed.row[2]
        report(1)
        position = int(np.flatnonzero(order == j)[0])
        for side, indices in ((0, order[:position][::-1]), (1, order[position + 1:])):
            if indices.size == 0:
                found.end[h, side] = codes.CURVE_REACHED
                continue
            samples = a[indices]
            followed = follow_curve(structure, seed, samples, float(samples[0] - a[j]),
                                    settings=settings, progress=report)
            _fill(found, h, side, indices, followed)
            report(int(np.count_nonzero(found.status[h, indices] != FOUND)))
    if ridden is None:
        report(1 + a.size)
        return found
    return _doubling(structure, f, a, found, *ridden, flight, settings, report)


def _doubling(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
              found: FoldCurves, j: int, ridden: Trace, flight: bool,
              settings: SolverSettings, report: Callable[[int], None]) -> FoldCurves:
    """``found`` with the forward hop's period-doubling curve: the hop's orbit where
    the sweep up left it (the start of ``ridden``, its branch to its fold at ``a[j]``)
    followed down in ``f`` (to the axis's lowest value less its width, or half of it),
    the first period doubling on that branch located and continued over ``a`` both ways
    (:func:`study.solvers.curves.follow_curve`)."""
    f_start, a_start = (float(x) for x in ridden.drive(ridden.column("t")[0]))
    low = max(float(f.min()) - float(np.ptp(f)), 0.5 * float(f.min()))
    try:
        down = trace_from_section(structure, f_start, a_start, along="f", to=low,
                                  state=ridden.states()[0],
                                  section=float(ridden.column("section")[0]),
                                  periods=ridden.periods, flight=flight, settings=settings)
    except ValueError:
        down = None
    hits = (np.empty(0, dtype=np.int64) if down is None else np.flatnonzero(
        (down.bifurcation_column("kind").astype(int) == codes.BIFURCATION_PERIOD_DOUBLING)
        & (down.bifurcation_locations() == LOCATED)))
    report(1)
    if hits.size == 0:
        report(a.size)
        return found
    seed = seed_of_trace(down, int(hits[0]), "f")
    status = found.doubling_status
    status[j] = DOUBLING_FOUND
    found.doubling_f[j], found.doubling_velocity[j] = seed.row[0], seed.row[2]
    report(1)
    order = np.argsort(a, kind="stable")
    position = int(np.flatnonzero(order == j)[0])
    for indices in (order[:position][::-1], order[position + 1:]):
        if indices.size == 0:
            continue
        samples = a[indices]
        followed = follow_curve(structure, seed, samples, float(samples[0] - a[j]),
                                settings=settings, progress=report)
        for row, sample in zip(followed.rows, followed.sample, strict=True):
            if sample >= 0:
                k = indices[sample]
                status[k] = DOUBLING_FOUND
                found.doubling_f[k], found.doubling_velocity[k] = row[0], row[2]
        missing = status[indices] != DOUBLING_FOUND
        status[indices[missing]] = (DOUBLING_NONE if followed.end == codes.CURVE_VANISHED
                                    else DOUBLING_BEYOND_END)
        report(int(np.count_nonzero(missing)))
    return replace(found, doubling_seed=j)


def _seed(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
          swept, flight: bool, settings: SolverSettings
          ) -> tuple[int, object, int] | None:
    """``(j, trace, index)``: the jump of ``swept`` at the acceleration ``a[j]`` where
    the hop's branch folds, the branch it rode and the fold's index on it; the columns
    tried from the middle of the axis outwards, in each the sweep's reversals
    (:func:`study.solvers.protocol.reversal_jumps`: a sweep up's leave the forward hop,
    a sweep down's the backward hop) in the order it meets them, None where none is
    located at a fold."""
    velocity = swept.state.velocity
    previous = previous_points(f, swept.direction)
    middle = 0.5 * (a.size - 1)
    for j in sorted(range(a.size), key=lambda k: (abs(k - middle), k)):
        for i in reversal_jumps(f, velocity[:, j], swept.jumped[:, j], swept.direction):
            located = jump_branch(structure, f, a, swept, (int(previous[i]), j), (int(i), j),
                                  flight=flight, settings=settings)
            if located is None:
                continue
            traced, cause = located
            if _located_fold(traced, cause):
                return j, traced, cause
    return None


def _seed_off_sweeps(structure: Structure, f: NDArray[np.float64], a: NDArray[np.float64],
                     swept, hop: str, flight: bool, settings: SolverSettings
                     ) -> tuple[int, Trace, int] | None:
    """``(j, trace, index)`` as :func:`_seed` gives it, where no sweep of ``swept``
    leaves the hop at a fold: the hop's branch followed past the sweeps, in the sweep's
    direction to ``f``'s far end and beyond it (by the axis's width, at most to half
    its lowest value), its fold where it first stops being stable. Tried first at the
    accelerations where the sweeps start on another motion, the hop carried there along
    ``a`` at the sweeps' first frequency from the nearest acceleration where they start
    on it (its fold may lie inside the grid there: at M = 0.99 the backward hop's, at
    13.11 Hz at 9 m s-2, which sweeps down from 17 Hz on the forward hop never meet);
    then, from the middle of the axis outwards, where the sweeps ride the hop to the
    axis's far end without a jump. None where none is found."""
    sign = 1.0 if hop == "forward" else -1.0
    state = swept.state
    upward = swept.direction == "up"
    first, last = (int(np.argmin(f)), int(np.argmax(f))) if upward else (
        int(np.argmax(f)), int(np.argmin(f)))
    width = float(np.ptp(f))
    beyond = (float(f.max()) + width if upward
              else max(float(f.min()) - width, 0.5 * float(f.min())))
    orbit = np.isin(state.status.astype(int), [int(s) for s in ORBIT_STATUSES if
                                                s != Status.STATIC])
    rides = orbit[first] & (sign * state.velocity[first] > 0)
    ridden = np.flatnonzero(rides)
    if ridden.size == 0:
        return None
    others = sorted(np.flatnonzero(~rides).tolist(),
                    key=lambda j: (int(np.abs(ridden - j).min()), j))
    for j in others:
        k = int(ridden[np.argmin(np.abs(ridden - j))])
        try:
            carried, _ = trace(structure, float(f[first]), float(a[k]), along="a",
                               to=float(a[j]), start=state.phase_state[first, k],
                               flight=flight, settings=settings,
                               periods=max(int(state.orbit_period[first, k]), 1))
        except ValueError:
            continue  # Newton's method does not close the sweep's orbit
        if (carried.end != codes.BRANCH_REACHED or stability_loss(carried) is not None
                or carried.column("radius")[-1] > 1.0):
            continue  # the hop does not reach a[j] stable at this frequency
        branch = trace_from_section(structure, float(f[first]), float(a[j]), along="f",
                                    to=beyond, state=carried.states()[-1],
                                    section=float(carried.column("section")[-1]),
                                    periods=carried.periods, flight=flight,
                                    settings=settings)
        cause = _first_fold(branch)
        if cause is not None:
            return j, branch, cause
    jumped = swept.jumped.any(axis=0)
    through = rides & ~jumped & orbit[last] & (sign * state.velocity[last] > 0)
    middle = 0.5 * (a.size - 1)
    for j in sorted(np.flatnonzero(through).tolist(), key=lambda k: (abs(k - middle), k)):
        try:
            branch, _ = trace(structure, float(f[last]), float(a[j]), along="f", to=beyond,
                              start=state.phase_state[last, j], flight=flight,
                              settings=settings,
                              periods=max(int(state.orbit_period[last, j]), 1))
        except ValueError:
            continue
        cause = _first_fold(branch)
        if cause is not None:
            return j, branch, cause
    return None


def _first_fold(branch: Trace) -> int | None:
    """The index of the bifurcation where ``branch`` first stops being stable
    (:func:`study.solvers.jumps.stability_loss`) if it is a located fold; None where it
    stops otherwise (another bifurcation) or not at all."""
    cause = stability_loss(branch)
    return cause if cause is not None and _located_fold(branch, cause) else None


def _located_fold(traced: Trace, index: int) -> bool:
    """Whether the bifurcation ``index`` of ``traced`` is a fold located exactly (a
    curve's seed must be)."""
    return (int(traced.bifurcation_column("kind")[index]) == codes.BIFURCATION_FOLD
            and int(traced.bifurcation_locations()[index]) == LOCATED)


def _fill(found: FoldCurves, h: int, side: int, indices: NDArray[np.int64],
          followed: FollowedCurve) -> None:
    """One side of a hop's curve into ``found``: the points at its samples (``indices``
    along ``a``), the status past its end, the end and its bracket."""
    for row, sample in zip(followed.rows, followed.sample, strict=True):
        if sample >= 0:
            k = indices[sample]
            found.status[h, k] = FOUND
            found.f[h, k], found.velocity[h, k] = row[0], row[2]
    past = NO_FOLD if followed.end == codes.CURVE_VANISHED else BEYOND_END
    reached = found.status[h, indices] == FOUND
    found.status[h, indices[~reached]] = past
    found.end[h, side] = followed.end
    found.end_last[h, side], found.end_past[h, side] = followed.low, followed.high
