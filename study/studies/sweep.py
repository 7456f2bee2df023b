"""Cut a study into independent chunks and compute what a chunk is missing.

A chunk is one structure (one point of the structure axes) and a contiguous block
of drive frequencies, with every drive acceleration. A :class:`Task` is the work
one chunk still needs after the kept values were looked up: its closed-form rows
and the rectangles of drive points whose solver observables are missing. A task
carries only its own slice of the grid (never the whole spec), so sending it to a
worker costs the size of the chunk, not of the study; :func:`compute_task` is a
pure function of it and runs on any worker.

A chunk's missing rectangles are computed in *work units*, each one small enough to
finish within about a second (the runner sizes them, :class:`UnitSizer`), so that its
values are kept as soon as they are computed and an interrupt is honoured within
seconds. A unit is cut (:func:`cut_unit`) only where no value depends on the cut
(:func:`unit_grain`): a point's value may depend on the points before it in its run
(a slow sweep's line, a continued two-way orbit), never on a point of another run, so
a unit holds whole runs, or any points where each is solved from its start alone.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from study.model.structure import Structure
from study.studies.observables import OBSERVABLES, Method, PointWork

__all__ = [
    "GRAINS",
    "UNIT_SECONDS",
    "Chunk",
    "Rectangle",
    "Task",
    "UnitSizer",
    "compute_task",
    "cut_unit",
    "missing_rectangles",
    "plan_chunks",
    "unit_grain",
]

#: How a rectangle of drive points may be cut into work units without changing a value
#: (:func:`unit_grain`): ``"points"`` anywhere (every point is solved from its start
#: alone), ``"rows"`` into whole rows (each row of ``f`` is a run: a slow sweep along
#: ``a``, continued orbits along a row), ``"columns"`` into whole columns (a slow sweep
#: along ``f``), ``"whole"`` not at all (continued orbits down one column).
GRAINS = ("points", "rows", "columns", "whole")

#: Computing time a work unit aims at [s]: an interrupt waits for at most about this
#: long per thread, and a unit's fixed cost (a task, a cache block per observable:
#: about 3 ms) stays under one percent of it.
UNIT_SECONDS = 1.0


@dataclass(frozen=True)
class Chunk:
    """A block of the study grid.

    Attributes
    ----------
    number : int
        Position in the plan.
    structure_index : tuple of int
        Index along the structure axes.
    f_start, f_stop : int
        Slice of the frequency axis.
    direction : int
        Index of the slow sweep's direction (``[sweep] protocol`` with direction
        ``"both"``: 0 up, 1 down); 0 otherwise.
    """

    number: int
    structure_index: tuple[int, ...]
    f_start: int
    f_stop: int
    direction: int = 0

    @property
    def size(self) -> int:
        """Number of frequencies in the chunk."""
        return self.f_stop - self.f_start


def plan_chunks(structure_shape: tuple[int, ...], n_f: int, n_a: int,
                chunk_points: int) -> list[Chunk]:
    """Cut a grid into chunks of about ``chunk_points`` points.

    Parameters
    ----------
    structure_shape : tuple of int
        Lengths of the structure axes.
    n_f, n_a : int
        Lengths of the frequency and acceleration axes (``n_a = 1`` without ``a``).
    chunk_points : int
        Target points per chunk.
    """
    f_per_chunk = max(1, min(n_f, chunk_points // max(n_a, 1)))
    n_blocks = math.ceil(n_f / f_per_chunk)
    chunks = []
    for structure_index in itertools.product(*(range(n) for n in structure_shape)):
        for block in range(n_blocks):
            start = block * f_per_chunk
            chunks.append(Chunk(len(chunks), structure_index, start,
                                min(n_f, start + f_per_chunk)))
    return chunks


@dataclass(frozen=True)
class Rectangle:
    """Drive points ``f[rows] x a[columns]`` of a chunk to compute (indices)."""

    rows: NDArray[np.intp]
    columns: NDArray[np.intp]

    @property
    def points(self) -> int:
        """Number of drive points."""
        return self.rows.size * self.columns.size


def missing_rectangles(missing: NDArray[np.bool_]) -> tuple[Rectangle, ...]:
    """Cover the ``True`` points of a ``(n_f, n_a)`` mask by rectangles, exactly.

    Rows with the same missing columns form one rectangle: a fresh chunk is one
    rectangle, an axis refined or extended is one or two.
    """
    groups: dict[bytes, list[int]] = {}
    for row in np.flatnonzero(missing.any(axis=1)):
        groups.setdefault(missing[row].tobytes(), []).append(int(row))
    return tuple(
        Rectangle(np.asarray(rows, dtype=np.intp), np.flatnonzero(missing[rows[0]]))
        for rows in groups.values()
    )


@dataclass(frozen=True)
class Task:
    """What one chunk still needs computing.

    Attributes
    ----------
    chunk : Chunk
    structure : Structure
    f : numpy.ndarray
        The chunk's drive frequencies [Hz].
    a : numpy.ndarray
        Drive accelerations [m s-2] (empty without an ``a`` axis).
    rows : tuple of str
        Closed-form (row) observables to compute on ``f``.
    points : tuple of str
        Solver observables to compute on each rectangle.
    rectangles : tuple of Rectangle
        Where the solver observables are missing.
    method : Method
    """

    chunk: Chunk
    structure: Structure
    f: NDArray[np.float64]
    a: NDArray[np.float64]
    rows: tuple[str, ...]
    points: tuple[str, ...]
    rectangles: tuple[Rectangle, ...]
    method: Method

    @property
    def point_count(self) -> int:
        """Drive points the solver computes in this task."""
        return sum(r.points for r in self.rectangles)


def compute_task(task: Task) -> tuple[dict[str, NDArray[Any]], list[dict[str, NDArray[Any]]]]:
    """Compute a task on one thread (parallelism comes from tasks side by side).

    Returns
    -------
    rows : dict
        Variable name -> ``(n_f,)`` array for the closed-form observables.
    rectangles : list of dict
        For each rectangle of the task, variable name -> ``(rows, columns)`` array
        of the solver observables.
    """
    rows: dict[str, NDArray[Any]] = {}
    for name in task.rows:
        rows.update(OBSERVABLES[name].compute(task.structure, task.f))
    blocks = []
    for rectangle in task.rectangles:
        work = PointWork(task.structure, task.f[rectangle.rows][:, None],
                         task.a[rectangle.columns][None, :], task.method)
        values: dict[str, NDArray[Any]] = {}
        for name in task.points:
            values.update(OBSERVABLES[name].compute(work))
        blocks.append(values)
    return rows, blocks


def unit_grain(method: Method, rectangle: Rectangle) -> str:
    """How ``rectangle`` can be cut into work units computed apart, every value the same
    bit for bit as when it is computed whole (one of :data:`GRAINS`).

    A slow sweep (``method.protocol``) solves each line of its swept axis in order, the
    motion carried from point to point: along ``a`` a run is a row of ``f``, along
    ``f`` a column of ``a`` (:func:`study.studies.kind.whole_runs` makes every
    missing rectangle hold whole runs). With ``[solver] continuation`` the two-way
    driver continues each orbit from the points before it on a line
    (:func:`study.kernels.two_way.points.sweep_runs`: a row of the rectangle if it has
    two columns or more, else its one column). Otherwise every point is solved from
    its start alone, and any cut keeps every value.
    """
    if method.protocol is not None:
        return "rows" if method.protocol[0] == "a" else "columns"
    if method.solver.continuation:
        return "rows" if rectangle.columns.size > 1 else "whole"
    return "points"


def cut_unit(rectangle: Rectangle, grain: str, points: int
             ) -> tuple[Rectangle, tuple[Rectangle, ...]]:
    """The first work unit of ``rectangle``, of about ``points`` drive points (at least
    the smallest piece ``grain`` allows, at most the rectangle), and what is left of it
    (in the order it is to be cut further).

    Parameters
    ----------
    rectangle : Rectangle
    grain : str
        One of :data:`GRAINS` (:func:`unit_grain`).
    points : int
        Drive points the unit should hold, >= 1.
    """
    if grain not in GRAINS:
        raise ValueError(f"grain {grain!r}: one of {GRAINS}")
    rows, columns = rectangle.rows, rectangle.columns
    points = max(1, int(points))
    if grain == "whole" or points >= rectangle.points:
        return rectangle, ()
    if grain == "columns":
        take = max(1, points // max(rows.size, 1))
        piece = Rectangle(rows, columns[:take])
        rest: tuple[Rectangle, ...] = (Rectangle(rows, columns[take:]),)
    elif grain == "rows" or points >= columns.size:
        take = max(1, points // max(columns.size, 1))
        piece = Rectangle(rows[:take], columns)
        rest = (Rectangle(rows[take:], columns),)
    else:
        # Part of the first row; then the rest of that row, then the other rows.
        piece = Rectangle(rows[:1], columns[:points])
        rest = (Rectangle(rows[:1], columns[points:]), Rectangle(rows[1:], columns))
    return piece, tuple(left for left in rest if left.points)


class UnitSizer:
    """How many drive points the next work unit holds: what one thread computes in
    about ``seconds`` at the cost per point measured so far.

    The first units hold one piece each (nothing is measured yet, and the first carries
    the solvers' compile time); the estimate of the cost per point follows a dearer
    unit at once and a cheaper one by at most a factor 4 per unit, so that a cheap
    stretch of the grid does not size the units of a dear one, and a unit grows by at
    most a factor 4 over the largest before it.

    Parameters
    ----------
    seconds : float
        Computing time a unit aims at [s].
    """

    def __init__(self, seconds: float = UNIT_SECONDS) -> None:
        self.seconds = float(seconds)
        #: Estimated computing time per point [s]; None before any unit was measured.
        self.seconds_per_point: float | None = None
        self._largest = 1

    def points(self) -> int:
        """Drive points of the next unit (>= 1)."""
        if self.seconds_per_point is None:
            return 1
        if self.seconds_per_point <= 0.0:
            wanted = 4 * self._largest
        else:
            wanted = int(self.seconds / self.seconds_per_point)
        size = max(1, min(wanted, 4 * self._largest))
        self._largest = max(self._largest, size)
        return size

    def measured(self, points: int, seconds: float) -> None:
        """A unit of ``points`` drive points took ``seconds`` of computing [s]."""
        if points <= 0:
            return
        cost = max(float(seconds), 0.0) / points
        if self.seconds_per_point is None:
            self.seconds_per_point = cost
        else:
            self.seconds_per_point = max(cost, self.seconds_per_point / 4.0)
