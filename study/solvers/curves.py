"""The curve of a located bifurcation over the drive plane: a fold (or another
bifurcation) of a branch traced along one drive parameter, followed in the other.

:func:`follow_curve` is the algorithm of :func:`study.analyses.branches.
bifurcation_curve` (which labels its result) and of a study's ``fold_curves``
observable (:mod:`study.solvers.fold_curves`): at each sample of the other parameter the
orbit of the last point found (a point of the branch before its bifurcation) is moved
to the new drive along its own branch, then continued along the first parameter through
a window past the last location, and the same kind of bifurcation is located on it (to
1e-10 of the drive, :mod:`study.kernels.two_way.bifurcations`). Each of those traces
locates that kind only and stops on the step past it (``sought``): the other kinds met
on the way (a grazing near the curve costs about 100 passes of the period map to
locate) and the branch beyond would be work thrown away. Where it is no longer
met, the end is bracketed by halving the step in the other parameter.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from study.model.codes import (
    BRANCH_ENDED,
    BRANCH_REACHED,
    CURVE_ENDED,
    CURVE_LOST,
    CURVE_REACHED,
    CURVE_VANISHED,
)
from study.model.structure import Structure
from study.solvers.branch import DEFAULT_MAX_STEP, Trace, trace_from_section
from study.solvers.settings import SolverSettings

__all__ = ["DEFAULT_CURVE_MAX_STEP", "DEFAULT_CURVE_WINDOW", "MOVE_STEP", "CurveSeed",
           "FollowedCurve", "follow_curve", "seed_of_trace"]

#: The window a curve's bifurcation is sought in at the next point (a fraction of the
#: parameter's value along the branch).
DEFAULT_CURVE_WINDOW = 0.02

#: The longest step of the branch a curve's next point is sought on [1, in the scaled
#: space of state and drive, the window being 1]: the step control (the turn of the
#: tangent, the change of the multipliers) shortens it where the branch bends, so a
#: window needs no more than a few steps from its start to the bifurcation.
DEFAULT_CURVE_MAX_STEP = 0.25
#: ... and of the moves of an orbit to the next point's drive (a short way in the other
#: parameter, then back along the first): the whole way in one step where the step
#: control accepts it.
MOVE_STEP = 1.0

#: A point of a curve: ``(f, a, velocity, multiplier, test)`` [Hz, m s-2, m s-1, 1, 1].
CurveRow = tuple[float, float, float, complex, float]


@dataclass(frozen=True)
class CurveSeed:
    """A located bifurcation on a branch, where its curve starts.

    Attributes
    ----------
    kind : int
        Its code (``study.model.codes.BIFURCATION_*``).
    along : str
        The drive parameter the branch was traced along (``"f"`` or ``"a"``).
    x : float
        The bifurcation's value of ``along`` [Hz or m s-2].
    value : float
        Its value of the other parameter.
    way : float
        +1 or -1: the way the branch ran along ``along`` towards the bifurcation.
    periods : int
        The orbit's period in drive periods.
    flight : bool
        Whether the base may fly.
    x_steps, states, sections : numpy.ndarray
        The branch's steps: their value of ``along``, the orbit's state on the section
        and the section's place in the period.
    step : int
        The step before the bifurcation.
    row : tuple
        The bifurcation as a point of its curve (:data:`CurveRow`).
    """

    kind: int
    along: str
    x: float
    value: float
    way: float
    periods: int
    flight: bool
    x_steps: NDArray[np.float64]
    states: NDArray[np.float64]
    sections: NDArray[np.float64]
    step: int
    row: CurveRow


@dataclass(frozen=True)
class FollowedCurve:
    """A bifurcation's curve as :func:`follow_curve` found it.

    Attributes
    ----------
    rows : list of tuple
        Its points in the order found (:data:`CurveRow`), the seed's first, then the
        samples and those found while bracketing the end.
    sample : list of int
        For each row, the index of the sample it was located at (-1: the seed, or a
        point between samples).
    end : int
        Why it stopped (``study.model.codes.CURVE_*``).
    low, high : float
        Where a curve ended early, the values of the other parameter between which the
        bifurcation stops being met (NaN where it reached the last sample).
    """

    rows: list[CurveRow]
    sample: list[int]
    end: int
    low: float
    high: float


def seed_of_trace(traced: Trace, index: int, along: str) -> CurveSeed:
    """The bifurcation ``index`` of the branch ``traced`` (traced along ``along``) as
    the seed of its curve."""
    rows = traced  # its bifurcation columns
    t = float(rows.bifurcation_column("t")[index])
    b_f, b_a = traced.drive(t)
    x_steps = np.asarray(traced.drive(traced.column("t"))[0 if along == "f" else 1])
    step = int(rows.bifurcation_column("step")[index])
    x = float(b_f if along == "f" else b_a)
    way = np.sign(x - float(x_steps[step])) or float(
        np.sign(traced.column("tangent_t")[step]))
    mu = complex(rows.bifurcation_column("multiplier_real")[index],
                 rows.bifurcation_column("multiplier_imag")[index])
    return CurveSeed(
        kind=int(rows.bifurcation_column("kind")[index]), along=along, x=x,
        value=float(b_a if along == "f" else b_f), way=float(way),
        periods=int(traced.periods), flight=bool(traced.flight), x_steps=x_steps,
        states=np.asarray(traced.states()), sections=np.asarray(traced.column("section")),
        step=step,
        row=(float(b_f), float(b_a), float(rows.bifurcation_column("velocity")[index]), mu,
             float(rows.bifurcation_column("test")[index])))


def follow_curve(structure: Structure, seed: CurveSeed, samples: NDArray[np.float64],
                 spacing: float, *, settings: SolverSettings | None = None,
                 window: float = DEFAULT_CURVE_WINDOW, end_tolerance: float = 1e-6,
                 max_step: float = DEFAULT_CURVE_MAX_STEP,
                 progress: Callable[[int], None] | None = None) -> FollowedCurve:
    """The curve of ``seed``'s bifurcation at the ``samples`` of the other parameter.

    Parameters
    ----------
    structure : Structure
        The structure the seed's branch was traced on (checked).
    seed : CurveSeed
        Where the curve starts (:func:`seed_of_trace`).
    samples : numpy.ndarray
        The values of the other parameter to locate it at, in order away from the
        seed's (not the seed's own).
    spacing : float
        The step towards the samples that is tried first and grown back to after a
        halving [Hz or m s-2], signed the samples' way.
    settings : SolverSettings, optional
        The solver's budgets.
    window : float, default 0.02
        How far past the last location the bifurcation is sought at the next point, and
        how far before it the next point's branch starts [1, a fraction of the first
        parameter's value there].
    end_tolerance : float, default 1e-6
        The relative width [1] to which a curve's end is bracketed.
    max_step : float, default 0.25
        The longest step of the branch each point is sought on [1]
        (:data:`DEFAULT_CURVE_MAX_STEP`).
    progress : callable, optional
        ``progress(1)`` after each sample reached.

    Returns
    -------
    FollowedCurve
    """
    along = seed.along
    other = "a" if along == "f" else "f"
    kind, way, periods, flight = seed.kind, seed.way, seed.periods, seed.flight

    def anchor_before(x_steps, states, sections, before, x_here, value):
        """The point of a branch half a window before its bifurcation at ``x_here``
        (among its steps up to ``before``), where the next point's search starts."""
        far = np.flatnonzero(way * (x_here - x_steps[:before + 1])
                             >= 0.5 * window * abs(x_here))
        k = int(far[-1]) if far.size else 0
        return float(x_steps[k]), np.asarray(states[k]), float(sections[k]), value

    def locate(anchor, value, reach, careful=False):
        """The bifurcation on the branch through ``anchor`` at the other parameter's
        ``value``, sought up to ``reach`` windows past ``x_last``: ``(code, row,
        next_anchor)``. ``careful`` traces as :func:`study.branch` does (its steps, every
        kind located, the multipliers' bound on a step) where the quick search missed
        it: near a cusp a long step can pass both folds at once."""
        x_start, state, section, v_from = anchor
        careful_step = min(max_step, DEFAULT_MAX_STEP)
        longest, move, wanted = ((careful_step, careful_step, 0) if careful
                                 else (max_step, MOVE_STEP, kind))
        # The anchor's orbit first continued in the other parameter to ``value`` (its
        # own branch, so that the state arrives exact), then along the first.
        f, a = (x_start, v_from) if along == "f" else (v_from, x_start)
        moved_over = trace_from_section(
            structure, f, a, along=other, to=value, state=state, section=section,
            periods=periods, flight=flight, settings=settings, max_step=move,
            sought=wanted)
        if moved_over.end != BRANCH_REACHED or np.any(
                moved_over.bifurcation_column("kind").astype(int) == kind):
            # The anchor's orbit does not reach the new drive, or the curve passed the
            # anchor on the way: the curve moves faster than the sampling.
            return CURVE_LOST, None, None
        state = moved_over.states()[-1]
        section = float(moved_over.column("section")[-1])
        f, a = (x_start, value) if along == "f" else (value, x_start)
        behind = x_last - way * window * abs(x_last)
        if way * (behind - x_start) < 0.0:
            # Back to a whole window before the last location first, where the orbit
            # is farther from the bifurcation than the curve moves in a step.
            back = trace_from_section(
                structure, f, a, along=along, to=behind, state=state, section=section,
                periods=periods, flight=flight, settings=settings, max_step=move,
                sought=wanted)
            if back.end == BRANCH_REACHED and not np.any(
                    back.bifurcation_column("kind").astype(int) == kind):
                state = back.states()[-1]
                section = float(back.column("section")[-1])
                f, a = (behind, value) if along == "f" else (value, behind)
        traced = trace_from_section(
            structure, f, a, along=along, to=x_last + way * reach * window * abs(x_last),
            state=state, section=section, periods=periods, flight=flight,
            settings=settings, max_step=longest, sought=wanted)
        kinds = traced.bifurcation_column("kind").astype(int)
        hits = np.flatnonzero(kinds == kind)
        if hits.size == 0:
            return (CURVE_ENDED if traced.end == BRANCH_ENDED else CURVE_VANISHED,
                    None, None)
        hit = int(hits[0])
        b_f, b_a = traced.drive(traced.bifurcation_column("t")[hit])
        mu = (traced.bifurcation_column("multiplier_real")[hit]
              + 1j * traced.bifurcation_column("multiplier_imag")[hit])
        row = (float(b_f), float(b_a), float(traced.bifurcation_column("velocity")[hit]),
               mu, float(traced.bifurcation_column("test")[hit]))
        x_steps = np.asarray(traced.drive(traced.column("t"))[0 if along == "f" else 1])
        return CURVE_REACHED, row, anchor_before(
            x_steps, traced.states(), traced.column("section"),
            int(traced.bifurcation_column("step")[hit]), row[0] if along == "f" else row[1],
            value)

    rows = [seed.row]
    sample = [-1]
    x_last = seed.x
    anchor = anchor_before(seed.x_steps, seed.states, seed.sections, seed.step, seed.x,
                           seed.value)
    samples = np.asarray(samples, dtype=np.float64)
    current, h, i = seed.value, spacing, 0
    end, low, high = CURVE_REACHED, np.nan, np.nan
    while i < samples.size:
        # Towards the next sample, in steps halved where the curve is lost or ends and
        # grown back after each point found: an end is bracketed where they cannot be
        # halved further.
        target = samples[i]
        value = target if abs(target - current) <= abs(h) * (1 + 1e-12) else current + h
        if value == current:  # no step left in floating point: the curve cannot go on
            end, low, high = CURVE_LOST, float(current), float(target)
            break
        code, row, moved = locate(anchor, value, 1.0)
        if code == CURVE_VANISHED:
            code, row, moved = locate(anchor, value, 4.0)  # moved farther?
        if code == CURVE_VANISHED:
            code, row, moved = locate(anchor, value, 4.0, careful=True)
        if code == CURVE_REACHED:
            rows.append(row)
            sample.append(i if value == target else -1)
            anchor, x_last, current = moved, (row[0] if along == "f" else row[1]), value
            if value == target and progress is not None:
                progress(1)
            i += value == target
            h = spacing if abs(2.0 * h) >= abs(spacing) else 2.0 * h
            continue
        if abs(value - current) <= end_tolerance * max(abs(current), abs(value)):
            end, low, high = code, float(current), float(value)
            break
        h = 0.5 * (value - current)
    return FollowedCurve(rows, sample, end, low, high)
